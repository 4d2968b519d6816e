"""Periodic orbits and Floquet multipliers (issue 25): shooting on the Lie group against closed forms (the
pendulum's elliptic period, a forced damped oscillator, a conical pendulum), Hill's determinant for the Mathieu
equation, multiple against single shooting, and bad input. Tolerances come from each result's own estimates."""

import cmath
import json
import math

import numpy as np
import pinocchio as pin
import pytest
from conftest import MODELS
from scipy.integrate import quad
from scipy.special import ellipk

import vibdyn as vd

G = 9.81


# ---------------------------------------------------------------------------------------------- 1. pendulum
@pytest.fixture(scope="module")
def rod():
    return vd.load_scene(MODELS / "rod_pivot.toml").build()


W0_ROD = math.sqrt(3 * G / 2)  # uniform rod on a pivot at its end, L = 1 m: ω₀² = m g (L/2) / (m L²/3)


@pytest.mark.parametrize("amplitude", [0.3, 1.5, 3.0])
def test_pendulum_period_is_the_complete_elliptic_integral(rod, amplitude):
    """Released from rest at A (phase: the turning point, energy kept): T = 4 K(sin²(A/2)) / ω₀ (K with the
    parameter m = k²) to 1e-8, within the orbit's own period error; both multipliers 1 within their error,
    det Φ = 1 (conservative)."""
    orbit = vd.periodic_orbit(rod, [amplitude], [0.0], phase="rod")
    a = float(orbit.q0[0])  # the converged turning point
    assert abs(a - amplitude) <= 1e-9 and orbit.v0[0] == pytest.approx(0.0, abs=1e-12)
    exact = 4 * ellipk(math.sin(a / 2) ** 2) / W0_ROD
    assert abs(orbit.period - exact) <= orbit.period_error
    assert orbit.period_error < 1e-8
    assert orbit.autonomous and orbit.energy_fixed and orbit.monodromy.shape == (2, 2)
    assert np.all(np.abs(orbit.multipliers - 1.0) <= orbit.multiplier_error)
    assert orbit.stable and orbit.stability == "neutral within the error"
    li = orbit.liouville
    assert li.expected == 1.0 and abs(li.det - 1.0) <= li.error
    assert orbit.trajectory.t[0] == 0.0 and orbit.trajectory.t[-1] == pytest.approx(orbit.period, abs=1e-12)


def test_pendulum_period_found_from_its_first_return(rod):
    """No period given: the first return to the section through the start gives the guess; the start is
    converged by the flow-orthogonal phase condition, the energy kept: T(E) against the elliptic integral with
    the amplitude of that energy (E = −m g L/2 cos A)."""
    orbit = vd.periodic_orbit(rod, [1.0], [0.5])
    energy = rod.energy(orbit.q0, orbit.v0).total
    assert energy == pytest.approx(rod.energy([1.0], [0.5]).total, abs=1e-12)
    a = math.acos(-energy / (G * 0.5))
    assert abs(orbit.period - 4 * ellipk(math.sin(a / 2) ** 2) / W0_ROD) <= orbit.period_error < 1e-8


def test_rotating_pendulum_closes_modulo_a_turn(rod):
    """Over the top from θ = 0 at θ̇ = v0 > 2ω₀: the pivot turns by 2π per period, T = 4 K(4ω₀²/v0²) / v0."""
    v0 = 9.0
    orbit = vd.periodic_orbit(rod, [0.0], [v0])
    traj = orbit.trajectory
    assert traj.q[-1, 0] - traj.q[0, 0] == pytest.approx(2 * math.pi, abs=1e-6)
    # the energy is kept, so v0 at θ = 0 is the start's; the converged start may sit elsewhere on the orbit
    e = rod.energy(orbit.q0, orbit.v0).total + G * 0.5  # kinetic energy at θ = 0 (m L²/3 = 1/3 kg·m²)
    speed = math.sqrt(2 * e * 3)
    assert speed == pytest.approx(v0, rel=1e-10)
    assert abs(orbit.period - 4 * ellipk(4 * W0_ROD**2 / speed**2) / speed) <= orbit.period_error < 1e-8


@pytest.mark.parametrize("amplitude", [1e-6, 1e-5, 1e-4, 1e-3])
def test_small_pendulum_orbits_are_right_within_their_error(rod, amplitude):
    """Issue 32: near rest the shooting degenerates (the period's column of its Jacobian shrinks like the
    amplitude, the energy row grows like its inverse). Released from A, the period against the elliptic integral
    4 K(sin²(A/2)) / ω₀ (→ 2π/ω₀) within the stated error, and that error small (it was 4e-6 s off at 1e-6 rad
    with an error of 1e-37 s); the multipliers a double 1 within theirs (they were 1 ± 1.6e-5 i ± 6e-11)."""
    orbit = vd.periodic_orbit(rod, [amplitude], [0.0], phase="rod")
    exact = 4 * ellipk(math.sin(orbit.q0[0] / 2) ** 2) / W0_ROD
    assert abs(orbit.q0[0] - amplitude) <= 1e-4 * amplitude  # (its energy is held to the energy's round-off)
    assert abs(orbit.period - exact) <= orbit.period_error < 1e-9
    assert np.all(np.abs(orbit.multipliers - 1.0) <= orbit.multiplier_error)


def test_an_orbit_too_close_to_rest_is_refused(rod):
    """At 1e-8 rad the orbit's energy above rest (2.5e-16 J) is below the round-off of the pendulum's energy
    (4.9 J): refused, naming the smallest amplitude it resolves and the linear limit."""
    with pytest.raises(vd.ModelError, match=r"too close to rest.*round-off.*larger amplitude \(above about "
                                            r"[\d.e-]+ rad of 'rod'\).*linear"):
        vd.periodic_orbit(rod, [1e-8], [0.0], phase="rod")


def duffing(damping=0.0, k=1.0, k3=0.1):
    s = vd.Scene("duffing")
    s.add_body("mass", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_joint_spring("mass", k)
    s.add_cubic_joint_spring("mass", k3)
    if damping:
        s.add_joint_damper("mass", damping)
    return s.build()


def duffing_period(a, k=1.0, k3=0.1):
    """x'' + k x + k3 x³ = 0 from rest at a: T = 4 ∫₀^{π/2} du / √(k + ½ k3 a² (1 + sin²u)) (x = a sin u),
    by adaptive quadrature (its error estimate returned)."""
    return quad(lambda u: 4 / math.sqrt(k + 0.5 * k3 * a * a * (1 + math.sin(u) ** 2)), 0, math.pi / 2,
                epsabs=0, epsrel=1e-13)


@pytest.mark.parametrize("amplitude", [1e-8, 1e-5, 1e-3, 0.5])
def test_small_duffing_orbits_against_the_quadrature_of_the_period(amplitude):
    """An undamped Duffing oscillator (no gravity: its energy rounds off relative to the motion's, so even
    1e-8 m is resolved): the period against the quadrature within the stated error (it was 2.5e-5 s off at 1e-5 m
    with an error of 5e-34 s)."""
    orbit = vd.periodic_orbit(duffing(), [amplitude], [0.0], phase="mass")
    exact, quad_error = duffing_period(float(orbit.q0[0]))
    assert abs(orbit.period - exact) <= orbit.period_error + quad_error
    assert orbit.period_error < 1e-9


def test_a_damped_autonomous_scene_has_no_periodic_orbit():
    """Issue 32: the bundled Duffing (c = 0.05, unforced) from 0.5 m used to converge onto rest and call it a
    "stable" orbit of 6.337 s. Every coordinate damped: refused before any shooting. A damper on one of two
    uncoupled oscillators: the undamped one's orbit is found (T = 2π/ω₁ within its error), a start on the damped
    one is refused once the shooting settles onto rest."""
    with pytest.raises(vd.ModelError, match="every coordinate is damped.*no periodic orbit other than rest"):
        vd.periodic_orbit(vd.load_scene("duffing").build(), [0.5], [0.0])
    with pytest.raises(vd.ModelError, match="no periodic orbit other than rest"):
        vd.periodic_orbit(duffing(0.05), [0.5], [0.0], phase="mass")
    s = vd.Scene("two")
    s.add_body("a", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_body("b", joint=vd.Slider((0, 1, 0)), mass=1.0)
    s.add_joint_spring("a", 1.0)
    s.add_joint_spring("b", 4.0)
    s.add_joint_damper("b", 0.1)
    system = s.build()
    orbit = vd.periodic_orbit(system, [0.3, 0.0], [0.0, 0.0], phase="a")
    assert abs(orbit.period - 2 * math.pi) <= orbit.period_error < 1e-9
    with pytest.raises(vd.ModelError, match="settles to rest.*only non-conservative forces are dampers"):
        vd.periodic_orbit(system, [0.0, 0.3], [0.0, 0.0], phase="b")


@pytest.mark.parametrize("factor", [1.5, 1.0001])
def test_a_wrong_derivative_in_the_variational_equations_is_caught(rod, monkeypatch, factor):
    """The monodromy from the variational equations is checked against central differences of plain flows in
    a random direction: a stiffness 1e-4 too large in the time layer's linearisation (as Pinocchio's universal-
    joint derivatives are wrong) is a ConvergenceError, where reciprocal multipliers and Liouville's
    determinant would not see it."""
    from vibdyn.simulation.integrators import chart

    right = chart.linear_terms

    def wrong(*args, **kwargs):
        M, K, C = right(*args, **kwargs)
        return M, K * factor, C

    monkeypatch.setattr(chart, "linear_terms", wrong)
    with pytest.raises(vd.ConvergenceError, match="variational equations disagree with the flows"):
        vd.periodic_orbit(rod, [1.0], [0.0], phase="rod")


# ---------------------------------------------------------------------------------------------- 2. forced oscillator
def test_forced_damped_oscillator_against_its_closed_form():
    """m x'' + c x' + k x = F cos Ωt (a harmonic joint force): x = X cos(Ωt − φ), X = F/√((k − mΩ²)² + (cΩ)²),
    tan φ = cΩ/(k − mΩ²); multipliers exp((−ζω₀ ± iω_d) T); det Φ = exp(−c T/m) = exp ∫ tr A dt."""
    m, k, c, force, omega = 2.0, 8.0, 0.4, 1.5, 1.7
    s = vd.Scene("forced")
    s.add_body("m", joint=vd.Slider((1, 0, 0)), mass=m)
    s.add_joint_spring("m", k)
    s.add_joint_damper("m", c)
    s.add_joint_force("m", vd.laws.Harmonic(force, omega, phase=math.pi / 2))  # F sin(Ωt + π/2) = F cos Ωt
    system = s.build()
    period = 2 * math.pi / omega
    orbit = vd.floquet(system, period, [0.0], [0.0])
    x_amp = force / math.hypot(k - m * omega**2, c * omega)
    phi = math.atan2(c * omega, k - m * omega**2)
    assert abs(orbit.q0[0] - x_amp * math.cos(phi)) <= orbit.error
    assert abs(orbit.v0[0] - x_amp * omega * math.sin(phi)) <= orbit.velocity_error
    assert not orbit.autonomous and orbit.period == period and orbit.period_error == 0.0
    w0, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
    mu = np.exp((-zeta * w0 + 1j * w0 * math.sqrt(1 - zeta**2)) * period)
    assert np.abs(np.sort_complex(orbit.multipliers) - np.sort_complex(np.array([mu, mu.conjugate()]))).max() <= \
        orbit.multiplier_error.max()
    assert orbit.multiplier_error.max() < 1e-8
    assert orbit.stability == "stable" and orbit.stable
    assert orbit.exponents.real == pytest.approx(-zeta * w0, abs=orbit.multiplier_error.max() / abs(mu) / period)
    li = orbit.liouville
    assert abs(li.expected - math.exp(-c / m * period)) <= li.error
    assert abs(li.det - math.exp(-c / m * period)) <= li.error


def test_van_der_pol_limit_cycle_is_attracting_with_liouville_multiplier():
    """x'' − μ(1 − x²) x' + x = 0 (a velocity-dependent joint force law), μ = 0.5: an autonomous, non-conservative
    orbit (period free, energy not kept). Its multipliers are the flow's 1 and, by Liouville, det Φ = exp ∫ tr A
    dt = exp ∫ μ(1 − x²) dt (the trapezoidal rule over the orbit, checked here against the trajectory itself):
    the second multiplier within the errors; the cycle attracts ("stable"). The period against the two-term
    expansion 2π(1 + μ²/16 − 5μ⁴/3072) to its next term's order (μ⁶ ≈ 0.016 of 2π: 0.1 s is loose, 1e-3 s is
    what the series gives)."""
    mu = 0.5
    s = vd.Scene("van der Pol")
    s.add_body("x", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_joint_spring("x", 1.0)
    s.add_joint_force("x", lambda t, q, v: mu * (1 - q * q) * v, velocity_dependent=True, time_dependent=False)
    orbit = vd.periodic_orbit(s.build(), [2.0], [0.0])
    assert orbit.autonomous and not orbit.energy_fixed and orbit.stability == "stable"
    flow, other = orbit.multipliers[np.argsort(np.abs(orbit.multipliers - 1.0))]
    assert abs(flow - 1.0) <= orbit.multiplier_error.max()
    li = orbit.liouville
    assert abs(other - li.expected) <= orbit.multiplier_error.max() + li.error
    traj = orbit.trajectory
    integral = orbit.period * np.mean(mu * (1 - traj.q[:-1, 0] ** 2))  # (equally spaced outputs, periodic)
    assert abs(li.expected - math.exp(integral)) <= li.error
    assert abs(orbit.period - 2 * math.pi * (1 + mu**2 / 16 - 5 * mu**4 / 3072)) < 1e-3


# ---------------------------------------------------------------------------------------------- 3. Mathieu
def hill_multipliers(delta, eps, n=4000):
    """Floquet multipliers over 2π of x'' + (δ + ε cos t) x = 0 from Hill's determinant (Whittaker & Watson
    §19.42, with t = 2z: θ₀ = 4δ, θ₁ = 2ε): tr Φ = 2 − 4 Δ(0) sin²(π√δ), Δ(0) the infinite determinant with
    unit diagonal and off-diagonal θ₁/((2r)² − θ₀) = ε/(2(r² − δ)) in row r; det Φ = 1. Returns (μ, the
    truncation error: the change from n to 2n rows)."""

    def trace(n):
        r = np.arange(-n, n + 1)
        off = eps / (2 * (r**2 - delta))
        d_prev, d = 1.0, 1.0  # the tridiagonal determinant by its three-term recurrence (a continuant)
        for k in range(1, r.size):
            d_prev, d = d, d - off[k] * off[k - 1] * d_prev
        return 2 - 4 * d * (cmath.sin(math.pi * cmath.sqrt(delta)) ** 2).real  # (δ < 0: −sinh²)

    tr, tr2 = trace(n), trace(2 * n)
    mu = np.roots([1.0, -tr2, 1.0]).astype(complex)
    return mu[np.argsort(-np.abs(mu))], abs(tr2 - tr)


def mathieu(delta, eps):
    s = vd.Scene("mathieu")
    s.add_body("x", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_joint_force("x", lambda t, q, v: -(delta + eps * math.cos(t)) * q, velocity_dependent=False,
                      time_dependent=True)
    return s.build()


@pytest.mark.parametrize("delta, eps, verdict", [(0.5, 0.1, "neutral within the error"), (0.25, 0.1, "unstable"),
                                                 (0.9, 0.3, "neutral within the error")])
def test_mathieu_multipliers_against_hill_determinant(delta, eps, verdict):
    """The orbit x = 0 of the Mathieu equation (a slider with the parametric force −(δ + ε cos t) x): its
    multipliers against Hill's determinant to 1e-6, within their own error; stable (on the unit circle)
    between the tongues, unstable inside the first one (δ = 1/4)."""
    orbit = vd.floquet(mathieu(delta, eps), 2 * math.pi, [0.0], [0.0])
    mu, trunc = hill_multipliers(delta, eps)
    got = orbit.multipliers
    if mu.imag.any():  # a conjugate pair: match by the sign of the imaginary part
        got, mu = np.sort_complex(got), np.sort_complex(mu)
    assert np.all(np.abs(got - mu) <= orbit.multiplier_error + trunc)
    assert orbit.multiplier_error.max() < 1e-6
    assert orbit.stability == verdict and orbit.stable == (verdict != "unstable")
    assert abs(orbit.liouville.det - 1.0) <= orbit.liouville.error


# ---------------------------------------------------------------------------------------------- 4. conical pendulum
def test_conical_pendulum_on_a_ball_joint():
    """A sphere (m, radius r) at L below a ball joint (nq = 4, nv = 3) turning at the tilt α: Ω² = g/(L cos α)
    for any isotropic inertia; the monodromy is 6 × 6 in the tangent space; multipliers on the unit circle: four
    equal to 1 (the flow, energy, the two symmetries), and the nutation pair exp(±iω_n T) with ω_n from the
    Routh-reduced equation of the tilt θ (a Lagrange top: A θ̈ = A φ̇² sinθ cosθ − p_ψ φ̇ sinθ + m g L sinθ at
    fixed p_φ, p_ψ), differentiated here by central differences."""
    m, L, r, alpha = 1.0, 1.0, 0.1, 0.6
    s = vd.Scene("conical", gravity=(0, 0, -G))
    s.add_body("bob", joint=vd.Ball(), mass=m, com=(0, 0, -L), inertia=vd.inertia.sphere(m, r))
    system = s.build()
    omega = math.sqrt(G / (L * math.cos(alpha)))
    q0 = system.integrate(system.neutral(), [alpha, 0.0, 0.0])
    v0 = pin.utils.rotate("x", alpha).T @ np.array([0.0, 0.0, omega])  # body-frame angular velocity
    period = 2 * math.pi / omega
    orbit = vd.periodic_orbit(system, q0, v0, period=1.01 * period)
    assert abs(orbit.period - period) <= orbit.period_error + 1e-12 * period
    assert orbit.monodromy.shape == (6, 6) and system.nq == 4
    assert np.all(np.abs(np.abs(orbit.multipliers) - 1.0) <= orbit.multiplier_error)
    ones = np.abs(orbit.multipliers - 1.0) <= orbit.multiplier_error
    assert ones.sum() == 4
    # the nutation: Routh reduction of the symmetric top (A about the pivot, C about its axis)
    j = 0.4 * m * r * r
    A, C = j + m * L * L, j
    th0 = math.pi - alpha  # from the upward vertical
    p_psi = C * omega * math.cos(th0)
    p_phi = A * omega * math.sin(th0) ** 2 + p_psi * math.cos(th0)

    def force(th):
        phidot = (p_phi - p_psi * math.cos(th)) / (A * math.sin(th) ** 2)
        return A * phidot**2 * math.sin(th) * math.cos(th) - p_psi * phidot * math.sin(th) + m * G * L * math.sin(th)

    assert abs(force(th0)) < 1e-12  # the steady precession

    def nutation(h):
        return math.sqrt(-(force(th0 + h) - force(th0 - h)) / (2 * h) / A)

    wn, wn_error = nutation(1e-4), abs(nutation(1e-4) - nutation(2e-4))  # (difference error ~h², h and 2h)
    pair = orbit.multipliers[~ones]
    expected = np.exp(1j * wn * orbit.period * np.array([1, -1]))
    assert np.abs(np.sort_complex(pair) - np.sort_complex(expected)).max() <= \
        orbit.multiplier_error[~ones].max() + wn_error * orbit.period + orbit.period_error * wn
    assert orbit.multiplier_error[~ones].max() < 1e-6 and orbit.stability == "neutral within the error"
    assert abs(orbit.liouville.det - 1.0) <= orbit.liouville.error


# ---------------------------------------------------------------------------------------------- 5. multiple shooting
def inverted(force, omega, m=1.0, L=1.0, r=0.05):
    """A sphere above a pivot (inverted pendulum, unstable) driven by the torque F cos Ωt; its λ² = m g L / I."""
    s = vd.Scene("inverted", gravity=(0, 0, -G))
    s.add_body("rod", joint=vd.Pivot((0, 1, 0)), mass=m, com=(0, 0, L), inertia=vd.inertia.sphere(m, r))
    s.add_joint_force("rod", vd.laws.Harmonic(force, omega, phase=math.pi / 2))
    inertia = m * L * L + 0.4 * m * r * r
    return s.build(), inertia, math.sqrt(m * G * L / inertia)


def linear_nodes(force, omega, inertia, lam, period, m):
    """The linear periodic response θ = −F/(I(λ² + Ω²)) cos Ωt at the m node times (rows)."""
    t = np.arange(m) * period / m
    a = -force / (inertia * (lam**2 + omega**2))
    return (a * np.cos(omega * t))[:, None], (-a * omega * np.sin(omega * t))[:, None]


def test_multiple_shooting_gives_the_multipliers_of_single_shooting():
    """A mildly unstable orbit (the forced inverted pendulum, T = 1 s, μ ≈ e^{λT} ≈ 23): single and multiple
    (4 segments) shooting agree within their errors, and with the linear theory's e^{±λT} (the orbit's
    amplitude is 5e-6 rad: the nonlinearity shifts λ by ~1e-11)."""
    force, period = 1e-4, 1.0
    omega = 2 * math.pi / period
    system, inertia, lam = inverted(force, omega)
    q, v = linear_nodes(force, omega, inertia, lam, period, 1)
    single = vd.floquet(system, period, q[0], v[0])
    multiple = vd.floquet(system, period, q[0], v[0], segments=4)
    assert single.segments == 1 and multiple.segments == 4
    err = single.multiplier_error + multiple.multiplier_error
    assert np.all(np.abs(single.multipliers - multiple.multipliers) <= err)
    exact = np.exp(np.array([lam, -lam]) * period)
    for orbit in (single, multiple):
        assert np.all(np.abs(orbit.multipliers - exact) <= orbit.multiplier_error + 1e-9 * exact[0])
        assert orbit.stability == "unstable" and not orbit.stable
        assert abs(orbit.q0[0] - q[0, 0]) <= orbit.error + 1e-12


def test_multiple_shooting_converges_where_single_shooting_fails():
    """Strongly unstable (T = 8 s, μ ≈ e^{λT} ≈ 7e10): single shooting cannot close the orbit of amplitude 1e-3
    rad (its residual is amplified integration error) and says what to try, where 16 segments from nodes along
    the linear response converge; at the amplitude 1e-5 rad (where the nonlinearity shifts λT by ~1e-10) the
    large multiplier is e^{λT} within its error."""
    period = 8.0
    omega = 2 * math.pi / period
    system, inertia, lam = inverted(1e-2, omega)
    q, v = linear_nodes(1e-2, omega, inertia, lam, period, 16)
    with pytest.raises(vd.ConvergenceError, match=r"did not converge.*misses its start by .*more segments") as info:
        vd.floquet(system, period, q[0], v[0], segments=1, max_iter=6)
    assert info.value.residual > 1e-10
    orbit = vd.floquet(system, period, q, v)
    assert orbit.segments == 16 and orbit.stability == "unstable" and orbit.error < 1e-10
    force = 1e-4
    system, inertia, lam = inverted(force, omega)
    q, v = linear_nodes(force, omega, inertia, lam, period, 16)
    orbit = vd.floquet(system, period, q, v)
    assert orbit.segments == 16 and orbit.stability == "unstable"
    big = math.exp(lam * period)
    assert abs(orbit.multipliers[0] - big) <= orbit.multiplier_error[0] + 1e-8 * big
    assert orbit.multiplier_error[0] < 1e-6 * big
    assert np.abs(orbit.trajectory.q[:, 0] - force / (inertia * (lam**2 + omega**2)) * -np.cos(
        omega * orbit.trajectory.t)).max() < 1e-9


# ---------------------------------------------------------------------------------------------- drives
def shaken(a, omega, up=False, m=1.0, l=0.3, r=0.02):
    """A sphere (m, radius r) at l from a pivot on a carriage driven vertically, z = a sin Ωt (a drive); hanging
    or (``up``) inverted. Returns the system and the equivalent length l_eq = I_O/(m l) (m)."""
    s = vd.Scene("shaken pendulum", gravity=(0, 0, -G))
    s.add_body("cart", joint=vd.Slider((0, 0, 1)), mass=1.0)
    s.add_body("pend", parent="cart", joint=vd.Pivot((0, 1, 0)), mass=m, com=(0, 0, l if up else -l),
               inertia=vd.inertia.sphere(m, r))
    s.add_drive("cart", vd.laws.Harmonic(a, omega))
    return s.build(), (m * l * l + 0.4 * m * r * r) / (m * l)


@pytest.mark.parametrize("up, factor, verdict", [(False, None, "neutral within the error"),
                                                 (False, 0.0, "unstable"),
                                                 (True, 4.0, "neutral within the error"),
                                                 (True, 1.0, "unstable")],
                         ids=["hanging", "hanging, first tongue", "inverted above Kapitza", "inverted below"])
def test_pendulum_on_a_shaken_carriage_is_mathieu(up, factor, verdict):
    """The carriage's drive z = a sin Ωt makes the pendulum's linearisation about θ = 0 Mathieu's equation in
    τ = Ωt: θ'' + (±g/(l_eq Ω²) − (a/l_eq) sin τ) θ = 0; the monodromy over 2π/Ω is over the free coordinate
    only (the carriage is given); its multipliers against Hill's determinant to 1e-6 within their error. Hanging:
    stable off the tongues, unstable at Ω = 2ω₀ (δ = 1/4); inverted: held up above Kapitza's threshold
    (a²Ω² = 4 g l_eq > 2 g l_eq), falling below it (a²Ω² = g l_eq)."""
    a = 0.05
    _, leq = shaken(a, 1.0, up)
    w0 = math.sqrt(G / leq)
    omega = (2.6 * w0 if factor is None else 2 * w0) if not up else math.sqrt(factor * G * leq) / a
    system, leq = shaken(a, omega, up)
    orbit = vd.floquet(system, 2 * math.pi / omega, [0.0, 0.0], [0.0, 0.0])
    assert orbit.coordinates == ("pend",) and orbit.monodromy.shape == (2, 2)
    delta = (-1 if up else 1) * G / (leq * omega**2)
    mu, trunc = hill_multipliers(delta, a / leq)
    got = orbit.multipliers
    if mu.imag.any():
        got, mu = np.sort_complex(got), np.sort_complex(mu)
    assert np.all(np.abs(got - mu) <= orbit.multiplier_error + trunc)
    assert orbit.multiplier_error.max() < 1e-6
    assert orbit.stability == verdict
    assert abs(orbit.liouville.det - 1.0) <= orbit.liouville.error


# ---------------------------------------------------------------------------------------------- 6. bad input
@pytest.mark.parametrize("period", [0.0, -1.0, math.nan, math.inf])
def test_a_period_that_is_not_positive_and_finite_is_refused(rod, period):
    with pytest.raises(vd.ModelError, match="period"):
        vd.periodic_orbit(rod, [1.0], [0.0], period=period)
    with pytest.raises(vd.ModelError, match="period"):
        vd.floquet(rod, period, [1.0], [0.0])


def test_bad_input_is_named():
    forced = mathieu(0.5, 0.1)
    with pytest.raises(vd.ModelError, match="depends on time.*give its period"):
        vd.periodic_orbit(forced, [0.1], [0.0])
    with pytest.raises(vd.ModelError, match="phase applies to autonomous scenes only"):
        vd.floquet(forced, 2 * math.pi, [0.1], [0.0], phase="x")
    with pytest.raises(vd.ModelError, match="floquet: period"):
        vd.floquet(forced, None, [0.1], [0.0])
    rod = vd.load_scene(MODELS / "rod_pivot.toml").build()
    with pytest.raises(vd.ModelError, match="equilibrium"):
        vd.periodic_orbit(rod, [0.0], [0.0])
    with pytest.raises(vd.ModelError, match="segments"):
        vd.periodic_orbit(rod, [1.0], [0.0], segments=0)
    with pytest.raises(vd.ModelError, match="coordinate"):
        vd.periodic_orbit(rod, [1.0], [0.0], phase="nope")
    with pytest.raises(vd.ModelError, match="starting nodes"):
        vd.periodic_orbit(rod, [[1.0], [0.5]], [[0.0]])
    system, _ = shaken(0.05, 30.0)
    with pytest.raises(vd.ModelError, match="depends on time"):
        vd.periodic_orbit(system, [0.0, 0.1], [0.0, 0.0])
    s = vd.Scene("all driven")
    s.add_body("cart", joint=vd.Slider((0, 0, 1)), mass=1.0)
    s.add_drive("cart", vd.laws.Harmonic(0.1, 3.0))
    with pytest.raises(vd.ModelError, match="every coordinate is driven"):
        vd.floquet(s.build(), 2 * math.pi / 3.0)
    looped = vd.load_scene(MODELS / "four_bar.toml").build()
    with pytest.raises(vd.ModelError, match="closed loops"):
        vd.periodic_orbit(looped, period=1.0)


def test_a_motion_that_never_comes_back_asks_for_the_period():
    s = vd.Scene("drift")
    s.add_body("m", joint=vd.Slider((1, 0, 0)), mass=1.0)
    system = s.build()
    with pytest.raises(vd.ConvergenceError, match="does not come back near it.*give the period"):
        vd.periodic_orbit(system, [0.0], [1.0])


def test_the_result_reads_and_serialises(rod):
    orbit = vd.periodic_orbit(rod, [1.0], [0.0], phase="rod")
    text = str(orbit)
    assert "T = " in text and "Floquet multipliers" in text and "Liouville" in text and "rad/s" in text
    assert repr(orbit).startswith("PeriodicOrbit(T = ")
    assert "<table>" in orbit._repr_html_()
    d = json.loads(json.dumps(orbit.to_dict()))
    assert d["period_s"] == orbit.period and len(d["multipliers"]) == 2
    assert orbit.omega == pytest.approx(2 * math.pi / orbit.period) and orbit.exponents.shape == (2,)


# ---------------------------------------------------------------------------------------------- 7. forcing period
def forced_oscillator(*forces, m=2.0, k=8.0, c=0.4):
    """m x'' + c x' + k x = Σ F cos(Ω t) (harmonic joint forces (F, Ω), phase π/2 turning sin into cos)."""
    s = vd.Scene("forced")
    s.add_body("m", joint=vd.Slider((1, 0, 0)), mass=m)
    s.add_joint_spring("m", k)
    s.add_joint_damper("m", c)
    for i, (force, omega) in enumerate(forces):
        s.add_joint_force("m", vd.laws.Harmonic(force, omega, phase=math.pi / 2), name=f"f{i}")
    return s


def damped_multipliers(period, m=2.0, k=8.0, c=0.4):
    """exp((−ζω₀ ± iω_d) T): the multipliers of a linear damped oscillator over T, whatever forces it."""
    w0, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
    mu = np.exp((-zeta * w0 + 1j * w0 * math.sqrt(1 - zeta**2)) * period)
    return np.sort_complex(np.array([mu, mu.conjugate()]))


def check_linear_orbit(orbit, forces, m=2.0, k=8.0, c=0.4):
    """The orbit's start against Σ X cos(φ) (X = F/√((k − mΩ²)² + (cΩ)²), tan φ = cΩ/(k − mΩ²)) and its
    multipliers against :func:`damped_multipliers`, within the orbit's own errors."""
    x = sum(f / math.hypot(k - m * w**2, c * w) * math.cos(math.atan2(c * w, k - m * w**2)) for f, w in forces)
    v = sum(f / math.hypot(k - m * w**2, c * w) * w * math.sin(math.atan2(c * w, k - m * w**2)) for f, w in forces)
    assert abs(orbit.q0[-1] - x) <= orbit.error and abs(orbit.v0[-1] - v) <= orbit.velocity_error
    got = np.sort_complex(orbit.multipliers)
    assert np.abs(got - damped_multipliers(orbit.period, m, k, c)).max() <= orbit.multiplier_error.max()


def test_a_forced_scene_takes_only_multiples_of_its_forcing_period():
    """Issue 32 (4): a harmonic force at Ω = 3 rad/s makes the scene 2π/3-periodic. period = 1 s (or 2.0944 s,
    a rounded 2π/3) is refused naming both periods; two forcing periods are taken (the orbit is the same, its
    multipliers those over 4π/3); without a period the forcing's is named."""
    system = forced_oscillator((1.5, 3.0)).build()
    for wrong in (1.0, 2.0944):
        with pytest.raises(vd.ModelError, match=rf"floquet: period {wrong:g} s is not a whole multiple of the "
                                                r"scene's forcing period 2\.094395102 s \(ω = 3 rad/s \('f0'\)\)"):
            vd.floquet(system, wrong, [0.0], [0.0])
    with pytest.raises(vd.ModelError, match=r"periodic_orbit: period 1 s is not a whole multiple .* 2\.094395102 s"):
        vd.periodic_orbit(system, [0.0], [0.0], period=1.0)
    with pytest.raises(vd.ModelError, match=r"period \(s\) is required: the scene's forcing period 2\.094395102 s"):
        vd.floquet(system, None, [0.0], [0.0])
    orbit = vd.floquet(system, 2 * (2 * math.pi / 3), [0.0], [0.0])
    assert orbit.period == 4 * math.pi / 3
    check_linear_orbit(orbit, [(1.5, 3.0)])
    near = vd.floquet(system, 2.094395102, [0.0], [0.0])  # its printed 10 digits: the exact period is used
    assert near.period == 2 * math.pi / 3.0
    check_linear_orbit(near, [(1.5, 3.0)])


def test_commensurate_forcings_share_their_common_period(tmp_path):
    """Forces at 3 and 4.5 rad/s repeat together every 4π/3 s (3·(2π/4.5) = 2·(2π/3)): the orbit is the sum of
    both linear responses; 2π/3 (the first force's alone) is refused; `vibdyn floquet` takes the common period."""
    import contextlib
    import io

    from vibdyn.faces.cli import main

    forces = [(1.5, 3.0), (0.7, 4.5)]
    scene = forced_oscillator(*forces)
    system = scene.build()
    with pytest.raises(vd.ModelError, match=r"period 2\.094395102 s is not a whole multiple of the scene's "
                                            r"forcing period 4\.188790205 s \(ω = 3 rad/s \('f0'\), "
                                            r"ω = 4\.5 rad/s \('f1'\)\)"):
        vd.floquet(system, 2 * math.pi / 3, [0.0], [0.0])
    orbit = vd.floquet(system, 4 * math.pi / 3, [0.0], [0.0])
    check_linear_orbit(orbit, forces)
    path = tmp_path / "two_forces.toml"
    scene.save(path)
    with contextlib.redirect_stdout(io.StringIO()) as out:
        assert main(["floquet", str(path), "--json"]) == 0
    data = json.loads(out.getvalue())
    assert data["period_source"] == "the forcing's common period"
    assert abs(data["period_s"] - 4 * math.pi / 3) <= 1e-15 * data["period_s"]


def test_incommensurate_forcings_are_refused():
    """Forces at 3 and π rad/s never repeat together: the motion is quasi-periodic, with no period to give."""
    system = forced_oscillator((1.5, 3.0), (0.7, math.pi)).build()
    with pytest.raises(vd.ModelError, match=r"not commensurate \(ω = 3 rad/s \('f0'\), ω = 3\.141592654 rad/s "
                                            r"\('f1'\)\).*quasi-periodic"):
        vd.floquet(system, 2 * math.pi / 3, [0.0], [0.0])


def test_supports_and_drives_set_the_forcing_period_too():
    """A slider held by a spring to a support moving at 2 rad/s, beside a carriage driven at 3 rad/s: the scene
    repeats every 2π s. π s (the support's period) is refused; over 2π s the slider's multipliers are those of
    its own damped oscillation (the carriage is given)."""
    m, k, c = 2.0, 8.0, 0.4
    s = vd.Scene("support and drive")
    s.add_body("cart", joint=vd.Slider((0, 0, 1), at=(0, 5, 0)), mass=1.0)
    s.add_drive("cart", vd.laws.Harmonic(0.1, 3.0))
    s.add_support("base", vd.laws.HarmonicMotion((0.05, 0.0, 0.0), 2.0))
    s.add_body("m", joint=vd.Slider((1, 0, 0)), mass=m)
    s.add_spring("k", ("base", (-1.0, 0.0, 0.0)), "m", k, 1.0)
    s.add_joint_damper("m", c)
    system = s.build()
    with pytest.raises(vd.ModelError, match=r"period 3\.141592654 s is not a whole multiple of the scene's forcing "
                                            r"period 6\.283185307 s .*'cart\.drive'.*'base'"):
        vd.floquet(system, math.pi, [0.0, 0.0], [0.0, 0.0])
    orbit = vd.floquet(system, 2 * math.pi, [0.0, 0.0], [0.0, 0.0])
    assert orbit.coordinates == ("m",)
    got = np.sort_complex(orbit.multipliers)
    assert np.abs(got - damped_multipliers(2 * math.pi, m, k, c)).max() <= orbit.multiplier_error.max()
