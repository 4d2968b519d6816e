"""Forced-response curves by harmonic balance (vd.forced_response_curve) against closed forms and against
shooting on vibdyn's own time simulation (periodic orbits found by Newton on the state transition of
``simulate(..., variational=True)``).

Tolerances: the curve's own truncation estimate (``.error``, ``fold.error``, ``peak.error``) plus the
simulation's error estimate; the H = 1 closed form is checked to the continuation's tolerance (its points
solve the H = 1 balance to ‖R‖ ≤ 1e-11 of the force), not to the truncation error.
"""

import math

import numpy as np
import pinocchio as pin
import pytest

import vibdyn as vd

P, C, K3 = 0.18, 0.05, 0.1  # NLvib's Duffing example: ẍ + 0.05 ẋ + x + 0.1 x³ = 0.18 cos Ωt
RTOL = 1e-12  # the shooting's simulations


def duffing_scene(c=C, k3=K3, k=1.0, m=1.0, forcing=None):
    """A mass m on a slider, a spring k, a damper c and a cubic spring k3 x³; with ``forcing`` = (P, Ω) the
    force P cos Ωt as a scene element (for the time simulations)."""
    s = vd.Scene("duffing")
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=m)
    s.add_joint_spring("cart", k)
    if c:
        s.add_joint_damper("cart", c)
    if k3:
        s.add_cubic_joint_spring("cart", k3)
    if forcing is not None:
        amplitude, w = forcing
        s.add_joint_force("cart", vd.laws.Harmonic(amplitude, w, phase=math.pi / 2))  # sin(Ωt + π/2) = cos Ωt
    return s


@pytest.fixture(scope="module")
def duffing():
    return duffing_scene().build()


@pytest.fixture(scope="module")
def curve_h1(duffing):
    return vd.forced_response_curve(duffing, ("cart", P), (0.5, 1.6), "cart", harmonics=1)


@pytest.fixture(scope="module")
def curve(duffing):
    return vd.forced_response_curve(duffing, ("cart", P), (0.5, 1.6), "cart")


def state_at_zero(curve, i):
    """(x(0), ẋ(0)) of point i from its Fourier coefficients (constant, cos kτ, sin kτ): the q_eq offsets and
    velocities of every coordinate, one after the other (2n numbers)."""
    X = curve.coefficients[i]
    k = np.arange(1, curve.harmonics + 1)
    return np.concatenate([X[0] + X[1::2].sum(axis=0), curve.omega[i] * (k @ X[2::2])])


def shoot(system, z, T, t0=0.0, final=True):
    """The periodic orbit through z ≈ (x0, v0) (offsets from q = 0, which is q_eq in these scenes: vector
    joints) of period T by Newton on φ_T(z) − z (Jacobian Φ − I from the variational equations); returns
    (z, the trajectory of one period from z with its state transition and their error estimates, the
    residual; ``final``: the last run again with the error estimates (rerun), else the local ones)."""
    z = np.array(z, float)
    n = len(z) // 2

    def run(z, **kw):
        tr = system.simulate(t0 + T, z[:n], z[n:], rtol=RTOL, t0=t0, variational=True, **kw)
        return tr, np.concatenate([tr.q[-1], tr.v[-1]]) - z

    for _ in range(12):
        tr, F = run(z, error_method="local")
        if np.max(np.abs(F)) < 1e-11:
            break
        z = z - np.linalg.solve(tr.state_transition - np.eye(2 * n), F)
    if final:  # once more with the error estimates of the state and its transition
        tr, F = run(z)
    return z, tr, float(np.max(np.abs(F)))


def orbit_maximum(system, z, T, t0=0.0):
    """max over one period of |x| for the orbit through z, from the maxima and minima of x (zeros of v,
    located on the integrator's interpolant)."""
    tr = system.simulate(t0 + T, [z[0]], [z[1]], rtol=RTOL, t0=t0, events=lambda t, q, v: v[0])
    extremes = np.abs(np.concatenate([np.ravel(tr.q_events[0]), [z[0]]]))
    return float(extremes.max()), tr


def nlvib_closed_form(a, w):
    """NLvib's H = 1 solution written as F(a, Ω) = 0: Ω² = 1 − ζ²/2 + ¾γa² ± √(P²/a² + ζ⁴/4 − ζ² − ¾ζ²γa²)
    for ẍ + ζẋ + x + γx³ = P cos Ωt, i.e. here ζ ≡ c = 0.05 (the damping coefficient itself, 2ζ_r ω₀ with the
    damping ratio ζ_r = 0.025 and ω₀ = 1 rad/s), γ = k3 = 0.1, P = 0.18. Squared out: x = a cos(Ωt − φ)
    balances (1 − Ω² + ¾γa²) a = P cos φ and cΩa = P sin φ, so (1 − Ω² + ¾γa²)² + c²Ω² = P²/a²; its roots
    in Ω² are the ± formula (the term under the root: c⁴/4 − c²(1 + ¾γa²) + P²/a²)."""
    return (1 - w**2 + 0.75 * K3 * a**2) ** 2 + C**2 * w**2 - P**2 / a**2


def omega_closed_form(a, sign):
    root = P**2 / a**2 + C**4 / 4 - C**2 - 0.75 * C**2 * K3 * a**2
    return np.sqrt(1 - C**2 / 2 + 0.75 * K3 * a**2 + sign * np.sqrt(root))


# 1. the Duffing oscillator ---------------------------------------------------------------------------------------

def test_h1_curve_is_nlvib_closed_form_at_every_point(curve_h1):
    a, w = curve_h1.amplitude, curve_h1.omega
    assert curve_h1.harmonics == 1 and curve_h1.status == "finished"
    assert w[0] == 0.5 and w[-1] == 1.6
    # each point solves the squared-out balance; its ∂/∂Ω at fixed a is of order 1, so ‖R‖ ~ 1e-11 P moves it
    # by ~1e-11 (1e-9 allows the conditioning near the folds)
    assert np.max(np.abs(nlvib_closed_form(a, w))) < 1e-9
    # and equals the ± formula of NLvib, on its + (upper) or − (lower) branch
    with np.errstate(invalid="ignore"):  # the − branch has no real Ω at small amplitudes
        gap = np.fmin(np.abs(omega_closed_form(a, 1) - w), np.abs(omega_closed_form(a, -1) - w))
    assert np.max(gap) < 1e-8
    # H = 1 truncates the 3rd harmonic: its estimate says so (about γa³/32 ÷ 8Ω² ≈ 1e-2 m at the peak)
    assert 1e-3 < curve_h1.peak.error < 1e-1


def test_h1_folds_and_peak_against_the_closed_form(curve_h1):
    assert len(curve_h1.folds) == 2
    upper, lower = sorted(curve_h1.folds, key=lambda f: -f.omega)
    # both folds lie on the + branch (the − one rises to the peak): the jump-down fold where its Ω(a) is
    # largest, the jump-up fold where it is smallest, found on the closed form by bounded scalar searches
    from scipy.optimize import minimize_scalar

    up = minimize_scalar(lambda a: -omega_closed_form(a, 1), bounds=(2.0, 2.85), method="bounded",
                         options={"xatol": 1e-12})
    down = minimize_scalar(lambda a: omega_closed_form(a, 1), bounds=(0.6, 2.0), method="bounded",
                           options={"xatol": 1e-12})
    assert upper.omega == pytest.approx(-up.fun, abs=1e-9)
    assert lower.omega == pytest.approx(down.fun, abs=1e-9)
    # amplitudes at a fold are flat in Ω: compared on the closed form's own Ω(a) instead
    assert omega_closed_form(upper.amplitude, 1) == pytest.approx(upper.omega, abs=1e-9)
    assert omega_closed_form(lower.amplitude, 1) == pytest.approx(lower.omega, abs=1e-9)
    # the peak: where the two branches meet (the root vanishes), Ω² = 1 − c²/2 + ¾γa²
    peak = curve_h1.peak
    assert nlvib_closed_form(peak.amplitude, peak.omega) == pytest.approx(0, abs=1e-9)
    assert peak.omega == pytest.approx(math.sqrt(1 - C**2 / 2 + 0.75 * K3 * peak.amplitude**2), abs=1e-6)
    assert lower.omega < peak.omega < upper.omega and peak.amplitude > upper.amplitude > lower.amplitude


def test_h1_stability_changes_at_the_folds(curve_h1):
    """The middle branch (between the folds along the curve) is unstable, the others stable; the multipliers'
    product is exp(−cT) (Liouville: tr A = −c/m)."""
    f1, f2 = sorted(curve_h1.folds, key=lambda f: f.index)
    idx = np.arange(len(curve_h1.omega))
    middle = (idx > f1.index) & (idx <= f2.index)
    assert np.all(~curve_h1.stable[middle]) and np.all(curve_h1.stable[~middle])
    T = 2 * np.pi / curve_h1.omega
    det = np.prod(curve_h1.multipliers, axis=1)
    np.testing.assert_allclose(det.real, np.exp(-C * T), rtol=1e-8)


def test_adaptive_harmonics_reach_the_tolerance(curve):
    assert curve.status == "finished"
    assert np.max(curve.error) <= 1e-8 * curve.peak.amplitude
    H, worst = zip(*curve.history)
    assert H[-1] == curve.harmonics and worst[-1] <= 1e-8 and all(w > 1e-8 for w in worst[:-1])
    text = str(curve)
    assert "fold" in text and "peak" in text and "rad/s" in text and "Hz" in text


def turning_point_orbit(A, y0, J=None):
    """(Ω, t0) of the forced orbit with a turning point x = A, ẋ = 0 at t0 (the forcing's phase and Ω the
    unknowns, regular at a fold), from y0 = (Ω, t0): by Newton (central differences), or with a Jacobian J
    given by the chord method; returns ((Ω, t0), the last Jacobian, the residual)."""
    def G(y):
        system = duffing_scene(forcing=(P, y[0])).build()
        tr = system.simulate(y[1] + 2 * np.pi / y[0], [A], [0.0], rtol=RTOL, t0=y[1], error_method="local")
        return np.array([tr.q[-1][0] - A, tr.v[-1][0]])

    y, newton = np.array(y0, float), J is None
    for _ in range(40):
        g = G(y)
        if np.max(np.abs(g)) < 1e-12:
            break
        if newton:
            J = np.column_stack([(G(y + e) - G(y - e)) / 2e-6 for e in np.diag([1e-6, 1e-6])])
        y = y - np.linalg.solve(J, g)
    return y, J, float(np.max(np.abs(g)))


def vertex(f, x0, d):
    """The extremum of f near x0 from parabolas through x0 and x0 ± d, x0 ± d/2, their d² errors removed
    (Richardson)."""
    f0 = f(x0)

    def one(h):
        c = np.polyfit([-h, 0.0, h], [f(x0 - h), f0, f(x0 + h)], 2)
        return x0 - c[1] / (2 * c[0])

    return (4 * one(d / 2) - one(d)) / 3


def test_adaptive_folds_and_peak_agree_with_shooting(curve):
    """Shooting on the simulation, each number where it is regular. A fold's Ω: the orbit with a turning
    point at the fold's amplitude (Ω and the forcing's phase the unknowns), Ω being extremal there; its
    amplitude: where that Ω(A) is extremal (a parabola's vertex, Richardson over two widths). The peak's
    amplitude: the orbit at Ω_peak, A(Ω) being extremal there; its Ω: where A(Ω) is extremal."""
    assert len(curve.folds) == 2
    for fold in curve.folds:
        X = curve.coefficients[fold.index][:, 0]  # the phase of the neighbouring point's largest x
        grid = np.linspace(0, 2 * np.pi, 4001)
        k = np.arange(1, curve.harmonics + 1)
        x = X[0] + np.cos(np.outer(grid, k)) @ X[1::2] + np.sin(np.outer(grid, k)) @ X[2::2]
        y0 = np.array([fold.omega, grid[np.argmax(x)] / curve.omega[fold.index]])
        y, J, res = turning_point_orbit(fold.amplitude, y0)
        assert res < 1e-10  # (the stopping test asks 1e-12; adaptive steps leave ~1e-13 of noise)
        assert abs(y[0] - fold.omega) <= 1e-6 + fold.omega_error
        A = vertex(lambda a: turning_point_orbit(a, y, J)[0][0], fold.amplitude, 4e-4)
        assert abs(A - fold.amplitude) <= 1e-6 + fold.error
    peak = curve.peak
    i = int(np.argmin(np.abs(curve.amplitude - peak.amplitude)))
    z0 = state_at_zero(curve, i)

    def amplitude(w):
        system = duffing_scene(forcing=(P, w)).build()
        z, _, res = shoot(system, z0, 2 * np.pi / w, final=False)
        assert res < 1e-11
        return orbit_maximum(system, z, 2 * np.pi / w)[0]

    assert abs(amplitude(peak.omega) - peak.amplitude) <= 1e-6 + peak.error
    # (the upper fold lies 9e-4 rad/s above the peak: the parabolas stay below it)
    assert abs(vertex(amplitude, peak.omega, 2e-4) - peak.omega) <= 1e-6 + peak.omega_error


def test_stable_point_stays_unstable_point_leaves(curve):
    """Started 1e-5 off the curve at t = 0 (the HB state moved by 1e-5 m and 1e-5 m/s), a simulation of 40
    periods comes back to the orbit at a stable point (|μ| ≈ 0.87: 0.87⁴⁰ ≈ 4e-3) and leaves it at an
    unstable one (μ ≈ 1.3: 1.3⁴⁰ ≈ 4e4); the monodromy of the shot orbit has Hill's multipliers."""
    unstable = np.flatnonzero(~curve.stable)
    assert unstable.size
    i_u = unstable[unstable.size // 2]
    i_s = int(np.argmin(np.abs(curve.omega - curve.omega[i_u]) + 10 * ~curve.stable))
    assert curve.stable[i_s]
    for i, leaves in ((i_u, True), (i_s, False)):
        w = curve.omega[i]
        system = duffing_scene(forcing=(P, w)).build()
        T = 2 * np.pi / w
        z0 = state_at_zero(curve, i)
        tr = system.simulate(40 * T, [z0[0] + 1e-5], [z0[1] + 1e-5], rtol=1e-10)
        drift = max(abs(tr.q[-1][0] - z0[0]), abs(tr.v[-1][0] - z0[1]))
        expected = 1e-5 * np.abs(curve.multipliers[i][0]) ** 40  # the start's offset, grown or shrunk
        if leaves:
            assert expected > 1e-2 and drift > 1e-2
        else:  # (10: the transient growth of a non-normal monodromy and the offset's two components)
            assert drift < 10 * expected + 10 * max(np.max(tr.q_error), np.max(tr.v_error))
        z, tr1, res = shoot(system, z0, T)
        assert res < 1e-11 and abs(z[0] - z0[0]) < 1e-7  # HB and shooting: the same orbit
        mu = np.sort(np.abs(np.linalg.eigvals(tr1.state_transition)))[::-1]
        hill = np.abs(curve.multipliers[i])
        assert np.all(np.abs(mu - hill) <= 10 * (curve.multiplier_error[i] + tr1.state_transition_error))
        assert curve.stability[i] == ("unstable" if leaves else "stable")
        assert (mu[0] > 1) == leaves


# 2. the linear oscillator ------------------------------------------------------------------------------------------

def test_linear_oscillator_is_the_receptance_without_folds():
    """m ẍ + c ẋ + k x = F0 + F cos Ωt: |X| = F / √((k − mΩ²)² + (cΩ)²) about the static offset F0/k; the peak
    at ω_n √(1 − 2ζ²), of F / (c ω_n √(1 − ζ²)); multipliers exp(−cT/2m)."""
    m, k, c, F, F0 = 2.0, 50.0, 1.5, 3.0, 5.0
    s = duffing_scene(c=c, k3=0.0, k=k, m=m)
    s.add_joint_force("cart", F0)  # a constant force: the equilibrium moves, the curve does not
    # (searched from 0.09 m: from the neutral configuration the search's step cap stops it halfway)
    crv = vd.forced_response_curve(s.build(), ("cart", F), (1.0, 10.0), "cart", equilibrium=[0.09])
    w = crv.omega
    exact = F / np.sqrt((k - m * w**2) ** 2 + (c * w) ** 2)
    assert np.all(np.abs(crv.amplitude - exact) <= crv.error + 1e-9 * exact.max())
    assert crv.q_eq[0] == pytest.approx(F0 / k, rel=1e-9)
    assert np.max(np.abs(crv.coefficients[:, 0])) < 1e-9 * exact.max()  # no mean offset about q_eq
    assert not crv.folds and np.all(crv.stable)
    np.testing.assert_allclose(np.abs(crv.multipliers), np.exp(-c / (2 * m) * 2 * np.pi / w)[:, None] * [1, 1],
                               rtol=1e-9)
    wn, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
    # the peak is flat in Ω: located to √(the amplitude's precision) ≈ 1e-6 of ω_n
    assert crv.peak.omega == pytest.approx(wn * math.sqrt(1 - 2 * zeta**2), rel=1e-5)
    assert crv.peak.amplitude == pytest.approx(F / (c * wn * math.sqrt(1 - zeta**2)), rel=1e-9)
    # linear: the adaptive loop stops at the first H (the higher harmonics are zero)
    assert crv.harmonics == 3 and np.max(np.abs(crv.coefficients[:, 3:])) < 1e-12
    text = repr(crv)
    assert "\n" not in text and len(text) < 400 and "peak" in text
    # the equilibrium given as the static OperatingPoint itself: the same curve about the same offset
    system = s.build()
    again = vd.forced_response_curve(system, ("cart", F), (1.0, 10.0), "cart",
                                     equilibrium=system.equilibrium([0.09]))
    assert again.q_eq[0] == crv.q_eq[0] and np.array_equal(again.amplitude, crv.amplitude)


def test_an_operating_point_that_is_not_static_is_refused_as_the_equilibrium():
    """A steady motion (a rotor at its speed) is no static equilibrium to vibrate about, for a forced response
    or a backbone: a ModelError names the regime (the forced response took it for a start and crashed)."""
    system = vd.load_scene("rotor_slider").build()
    steady = system.steady_motion({"rotor": 5.0})
    with pytest.raises(vd.ModelError, match="forced_response_curve: equilibrium must be a static one, got a "
                                            "steady operating point"):
        vd.forced_response_curve(system, ("slider", 0.1), (0.5, 1.6), "slider", equilibrium=steady)
    with pytest.raises(vd.ModelError, match="backbone: equilibrium must be a static one, got a steady"):
        vd.backbone(system, 0, amplitudes=[0.01], equilibrium=steady)


def test_point_force_and_support_motion_are_the_same_excitations():
    """A point force F along the slider at the cart is the joint force F; a support moving Y cos Ωt through a
    spring k and damper c excites x with |X| = Y √(k² + c²Ω²) / √((k − mΩ²)² + c²Ω²)."""
    m, k, c, F, Y = 2.0, 50.0, 1.5, 3.0, 0.01
    joint = vd.forced_response_curve(duffing_scene(c=c, k3=0.0, k=k, m=m).build(), ("cart", F), (1.0, 10.0),
                                     "cart", harmonics=3)
    point = vd.forced_response_curve(duffing_scene(c=c, k3=0.0, k=k, m=m).build(),
                                     vd.PointForce("cart", (0, 0, 0), (2, 0, 0), F), (1.0, 10.0), "cart",
                                     harmonics=3)
    assert point.peak.amplitude == pytest.approx(joint.peak.amplitude, rel=1e-9)
    assert point.peak.omega == pytest.approx(joint.peak.omega, abs=1e-6)
    s = vd.Scene("base")
    s.add_support("ground", vd.laws.HarmonicMotion((0, 0, 0), 0.0))
    s.add_body("mass", joint=vd.Slider((0, 0, 1), at=(0, 0, 1.0)), mass=m)
    s.add_spring("k", ("ground", (0, 0, 0)), "mass", stiffness=k)
    s.add_damper("c", ("ground", (0, 0, 0)), "mass", damping=c)
    base = vd.forced_response_curve(s.build(), vd.SupportMotion("ground", (0, 0, Y)), (1.0, 10.0), "mass",
                                    harmonics=3)
    w = base.omega
    exact = Y * np.sqrt(k**2 + (c * w) ** 2) / np.sqrt((k - m * w**2) ** 2 + (c * w) ** 2)
    assert np.all(np.abs(base.amplitude - exact) <= base.error + 1e-8 * exact.max())


# 3. a pendulum: gravity and large rotations --------------------------------------------------------------------

def pendulum_scene(forcing=None, m=1.0, length=1.0, c=0.5, g=9.81):
    """A point mass m on a massless arm of ``length`` about a pivot, gravity g, a joint damper c; with
    ``forcing`` = (M, Ω) the torque M cos Ωt as a scene element (for the time simulations)."""
    s = vd.Scene("pendulum", gravity=(0, 0, -g))
    s.add_body("arm", joint=vd.Pivot((0, 1, 0)), mass=m, com=(0, 0, -length), inertia=np.zeros((3, 3)))
    s.add_joint_damper("arm", c)
    if forcing is not None:
        s.add_joint_force("arm", vd.laws.Harmonic(forcing[0], forcing[1], phase=math.pi / 2))
    return s


def test_forced_pendulum_leans_left_and_matches_shooting():
    """m l² θ̈ + c θ̇ + m g l sin θ = M cos Ωt (m = l = 1, c = 0.5, M = 1): softening, the peak lies below the
    linear one ω₀ √(1 − 2ζ²) (ω₀ = √(g/l), ζ = c / (2 m l² ω₀)) by the backbone's first-order shift
    ω ≈ ω₀ (1 − θ²/16); a point checked against shooting on the simulation."""
    M, c = 1.0, 0.5
    system = pendulum_scene().build()
    w0 = math.sqrt(9.81)
    zeta = c / (2 * w0)
    crv = vd.forced_response_curve(system, ("arm", M), (0.7 * w0, 1.2 * w0), "arm")
    assert crv.status == "finished" and not crv.folds and np.all(crv.stable)
    linear_peak = w0 * math.sqrt(1 - 2 * zeta**2)
    assert crv.peak.omega < linear_peak * (1 - 0.02)  # leans left: ~0.66 rad softens it by 2.7 %
    # first-order backbone and damping: 3e-4 apart here; the next orders (θ⁴ terms) are ~1e-4
    assert crv.peak.omega == pytest.approx(linear_peak * (1 - crv.peak.amplitude**2 / 16), rel=2e-3)
    # bent left: above the linear receptance M / √((mgl − ml²Ω²)² + c²Ω²) below ω₀, beneath it above ω₀
    linear = M / np.sqrt((9.81 - crv.omega**2) ** 2 + (c * crv.omega) ** 2)
    assert np.all((crv.amplitude > linear)[crv.omega < 0.95 * w0])
    assert np.all((crv.amplitude < linear)[crv.omega > linear_peak])
    i = int(np.argmax(crv.amplitude))
    for j in (max(i - 3, 0), i + 3):  # a point on each side of the peak
        w = crv.omega[j]
        forced = pendulum_scene(forcing=(M, w)).build()
        T = 2 * np.pi / w
        z, tr, res = shoot(forced, state_at_zero(crv, j), T)
        assert res < 1e-11
        A, _ = orbit_maximum(forced, z, T)
        assert abs(A - crv.amplitude[j]) <= 1e-8 + crv.error[j]


def double_pendulum_scene(forcing=None):
    """Two rods on pivots under gravity, dampers on both joints; with ``forcing`` = (M, Ω) the torque M cos Ωt
    on the upper joint as a scene element."""
    s = vd.Scene("double pendulum", gravity=(0, 0, -9.81))
    s.add_body("upper", joint=vd.Pivot((0, 1, 0)), mass=1.0, com=(0, 0, -0.5), inertia=vd.inertia.rod(1.0, 1.0))
    s.add_body("lower", "upper", vd.Pivot((0, 1, 0), at=(0, 0, -1.0)), mass=0.5, com=(0, 0, -0.4),
               inertia=vd.inertia.rod(0.5, 0.8))
    s.add_joint_damper("upper", 0.3)
    s.add_joint_damper("lower", 0.1)
    if forcing is not None:
        s.add_joint_force("upper", vd.laws.Harmonic(forcing[0], forcing[1], phase=math.pi / 2))
    return s


def test_double_pendulum_orbit_and_multipliers_against_shooting():
    """Two coordinates coupled through M(q) and gravity: at the peak near the first resonance, shooting from
    the HB state converges (the same orbit), whose offset of the reported coordinate at t = 0 and amplitude
    are HB's within its truncation estimate, and whose monodromy has Hill's multipliers within their errors."""
    M = 0.5
    system = double_pendulum_scene().build()
    w1 = system.linearize().modes().omega[0]
    crv = vd.forced_response_curve(system, ("upper", M), (0.9 * w1, 1.1 * w1), "lower", harmonics=12)
    i = int(np.argmax(crv.amplitude))
    w = crv.omega[i]
    forced = double_pendulum_scene(forcing=(M, w)).build()
    T = 2 * np.pi / w
    z0 = state_at_zero(crv, i)
    z, tr, res = shoot(forced, z0, T)
    assert res < 1e-10
    assert abs(z[1] - z0[1]) <= 10 * crv.error[i] + 1e-9  # the reported coordinate's offset at t = 0
    mu = np.abs(np.linalg.eigvals(tr.state_transition))
    assert np.all(np.abs(np.sort(mu) - np.sort(np.abs(crv.multipliers[i])))
                  <= 10 * (crv.multiplier_error[i] + tr.state_transition_error))
    ext = forced.simulate(T, z[:2], z[2:], rtol=RTOL, events=lambda t, q, v: v[1])
    A = max(np.abs(np.asarray(ext.q_events[0])[:, 1]).max(), abs(z[1]))
    assert abs(A - crv.amplitude[i]) <= 10 * crv.error[i] + 1e-9


def test_point_force_on_a_pendulum_against_shooting():
    """A horizontal force F cos Ωt at the pendulum's tip (a generalized torque F l cos θ cos Ωt that turns with
    the arm): a point near the peak and its multipliers against shooting on the scene with that force as an
    element (``add_force`` with a callable of t)."""
    F, w0 = 1.0, math.sqrt(9.81)
    crv = vd.forced_response_curve(pendulum_scene().build(), vd.PointForce("arm", (0, 0, -1.0), (1, 0, 0), F),
                                   (0.8 * w0, 1.1 * w0), "arm", harmonics=10)
    i = int(np.argmax(crv.amplitude))
    w = crv.omega[i]
    s = pendulum_scene()
    s.add_force("push", "arm", lambda t, q, v: np.array([F * math.cos(w * t), 0.0, 0.0]), at=(0, 0, -1.0))
    forced = s.build()
    T = 2 * np.pi / w
    z, tr, res = shoot(forced, state_at_zero(crv, i), T)
    assert res < 1e-11
    A, _ = orbit_maximum(forced, z, T)
    assert abs(A - crv.amplitude[i]) <= 10 * crv.error[i] + 1e-9
    mu = np.sort(np.abs(np.linalg.eigvals(tr.state_transition)))
    assert np.all(np.abs(mu - np.sort(np.abs(crv.multipliers[i])))
                  <= 10 * (crv.multiplier_error[i] + tr.state_transition_error))


def spherical_pendulum_scene(forcing=None):
    """The pendulum of :func:`pendulum_scene` on a ball joint (point mass 1 kg at 1 m, a small inertia 0.01
    kg·m² about every axis, a damper 0.5 N·m·s/rad per axis, a torsion spring 2 N·m/rad about the arm's own
    axis); with ``forcing`` = (M, Ω) the torque M cos Ωt about the joint's y axis as a scene element."""
    s = vd.Scene("spherical pendulum", gravity=(0, 0, -9.81))
    s.add_body("arm", joint=vd.Ball(), mass=1.0, com=(0, 0, -1.0), inertia=1e-2 * np.eye(3))
    s.add_joint_damper("arm", 0.5)
    s.add_joint_spring("arm", (0, 0, 2.0))
    if forcing is not None:
        M, w = forcing
        s.add_joint_force("arm", lambda t, q, v: np.array([0.0, M * math.cos(w * t), 0.0]))
    return s


def test_ball_joint_pendulum_is_the_pivot_one_and_its_orbit_closes_on_the_group():
    """On a ball joint the Fourier unknowns are tangent coordinates (the rotation vector from q_eq): forced
    about y, the motion stays planar (rx, rz zero) and its curve is the pivot pendulum's to the truncation
    error; the HB state, mapped onto the group (q = q_eq ⊕ x, v = J(x) ẋ), closes after one period in the
    simulation and the monodromy's multipliers (6: in-plane, out-of-plane, twist) are Hill's."""
    w0 = math.sqrt(9.81)
    pivot = vd.Scene("pendulum", gravity=(0, 0, -9.81))
    pivot.add_body("arm", joint=vd.Pivot((0, 1, 0)), mass=1.0, com=(0, 0, -1.0), inertia=1e-2 * np.eye(3))
    pivot.add_joint_damper("arm", 0.5)
    flat = vd.forced_response_curve(pivot.build(), ("arm", 1.0), (0.85 * w0, 1.05 * w0), "arm", harmonics=6)
    system = spherical_pendulum_scene().build()
    ball = vd.forced_response_curve(system, ("arm.ry", 1.0), (0.85 * w0, 1.05 * w0), "arm.ry", harmonics=6)
    assert np.max(np.abs(ball.coefficients[:, :, [0, 2]])) < 1e-12  # planar
    assert ball.peak.amplitude == pytest.approx(flat.peak.amplitude, abs=10 * (ball.peak.error + flat.peak.error))
    assert ball.peak.omega == pytest.approx(flat.peak.omega, abs=1e-6)  # (a flat maximum: located to ~1e-8)
    i = int(np.argmax(ball.amplitude))
    w = ball.omega[i]
    forced = spherical_pendulum_scene(forcing=(1.0, w)).build()
    X, k = ball.coefficients[i], np.arange(1, ball.harmonics + 1)
    x0, xd0 = X[0] + X[1::2].sum(axis=0), w * (k @ X[2::2])
    q0 = forced.integrate(ball.q_eq, x0)
    v0 = pin.dIntegrate(forced.model, ball.q_eq, x0, pin.ARG1) @ xd0
    tr = forced.simulate(2 * np.pi / w, q0, v0, rtol=RTOL, variational=True)
    closing = max(np.max(np.abs(forced.difference(q0, tr.q[-1]))), np.max(np.abs(tr.v[-1] - v0)) / w)
    assert closing <= 10 * (ball.error[i] + tr.error)
    mu = np.sort(np.abs(np.linalg.eigvals(tr.state_transition)))
    assert len(mu) == 6
    assert np.all(np.abs(mu - np.sort(np.abs(ball.multipliers[i])))
                  <= 10 * (ball.multiplier_error[i] + tr.state_transition_error + closing))


def test_spherical_pendulum_planar_motion_is_unstable_out_of_its_plane():
    """Miles's spherical pendulum (Miles 1962): weakly damped (0.05 N·m·s/rad) and forced in a plane near
    resonance, its planar motion — on the branch above the jump-down fold, in-plane stable — is unstable out
    of the plane: Hill's largest |μ| ≈ 1.10 is the monodromy's, a simulation started on the orbit stays
    planar, and one started 1e-6 rad out of the plane leaves it by that factor per period."""
    def scene(forcing=None):
        s = vd.Scene("spherical pendulum", gravity=(0, 0, -9.81))
        s.add_body("arm", joint=vd.Ball(), mass=1.0, com=(0, 0, -1.0), inertia=1e-2 * np.eye(3))
        s.add_joint_damper("arm", 0.05)
        s.add_joint_spring("arm", (0, 0, 2.0))
        if forcing is not None:
            s.add_joint_force("arm", lambda t, q, v: np.array([0.0, 0.1 * math.cos(forcing * t), 0.0]))
        return s

    system = scene().build()
    crv = vd.forced_response_curve(system, ("arm.ry", 0.1), (3.08, 3.10), "arm.ry", harmonics=5)
    i = len(crv.omega) // 2
    w, mu = crv.omega[i], np.abs(crv.multipliers[i])
    assert crv.stability[i] == "unstable" and mu[0] > 1.05 and mu[1] < 1
    forced = scene(w).build()
    X, k = crv.coefficients[i], np.arange(1, crv.harmonics + 1)
    x0, xd0 = X[0] + X[1::2].sum(axis=0), w * (k @ X[2::2])
    T = 2 * np.pi / w
    tr = forced.simulate(T, system.integrate(crv.q_eq, x0), pin.dIntegrate(system.model, crv.q_eq, x0, pin.ARG1)
                         @ xd0, rtol=RTOL, variational=True)
    mono = np.sort(np.abs(np.linalg.eigvals(tr.state_transition)))[::-1]
    assert np.all(np.abs(mono - mu) <= 10 * (crv.multiplier_error[i] + tr.state_transition_error + crv.error[i]))
    for offset in (0.0, 1e-6):
        x1 = x0 + [offset, 0.0, 0.0]  # out of the plane: about x
        q1 = system.integrate(crv.q_eq, x1)
        v1 = pin.dIntegrate(system.model, crv.q_eq, x1, pin.ARG1) @ xd0
        run = forced.simulate(30 * T, q1, v1, rtol=1e-10, t_eval=np.arange(31) * T)
        rx = np.abs([forced.difference(crv.q_eq, q)[0] for q in run.q])
        if offset == 0.0:
            assert rx.max() < 1e-12  # the symmetry keeps it planar
        else:  # grows as μ per period once its own transient has passed
            assert (rx[30] / rx[15]) ** (1 / 15) == pytest.approx(mu[0], rel=1e-2)


def test_a_branch_that_leaves_the_range_stops_and_says_how_far_it_got():
    """Weakly damped (c = 0.1) and pushed hard (M = 0.6 N·m), the pendulum's branch bends so far left past its
    fold that it turns back below the range's start: the curve stops there, says so and gives the largest
    amplitude reached (approaching π: over the top)."""
    w0 = math.sqrt(9.81)
    crv = vd.forced_response_curve(pendulum_scene(c=0.1).build(), ("arm", 0.6), (0.7 * w0, 1.2 * w0), "arm",
                                   harmonics=8)
    assert crv.status == "stopped" and "largest amplitude reached" in crv.message
    assert crv.omega[-1] < 0.7 * w0 and crv.amplitude.max() > 2.0
    assert len(crv.folds) == 1 and not crv.stable[-1]
    assert "stopped" in str(crv)


# 4. bad input ------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("omega, match", [
    ((1.6, 0.5), "increasing pair"), ((0.0, 1.0), "positive"), ((-1.0, 1.0), "positive"),
    ((0.5, float("inf")), "finite"), ((0.5, float("nan")), "finite"), (1.0, "pair"), ((1, 2, 3), "pair"),
    (("a", 2.0), "pair")])
def test_bad_omega(duffing, omega, match):
    with pytest.raises(vd.ModelError, match=match):
        vd.forced_response_curve(duffing, ("cart", P), omega, "cart")


def test_bad_coordinate_force_and_harmonics(duffing):
    with pytest.raises(vd.ModelError, match="nope"):
        vd.forced_response_curve(duffing, ("cart", P), (0.5, 1.6), "nope")
    with pytest.raises(vd.ModelError, match="nope"):
        vd.forced_response_curve(duffing, ("nope", P), (0.5, 1.6), "cart")
    with pytest.raises(vd.ModelError, match="amplitude is zero"):
        vd.forced_response_curve(duffing, ("cart", 0.0), (0.5, 1.6), "cart")
    with pytest.raises(vd.ModelError, match="amplitude"):
        vd.forced_response_curve(duffing, ("cart", float("nan")), (0.5, 1.6), "cart")
    with pytest.raises(vd.ModelError, match="force"):
        vd.forced_response_curve(duffing, 0.18, (0.5, 1.6), "cart")
    with pytest.raises(vd.ModelError, match="unknown body 'nope'"):
        vd.forced_response_curve(duffing, vd.PointForce("nope", (0, 0, 0), (1, 0, 0), 1.0), (0.5, 1.6), "cart")
    with pytest.raises(vd.ModelError, match="direction is the zero vector"):
        vd.forced_response_curve(duffing, vd.PointForce("cart", (0, 0, 0), (0, 0, 0), 1.0), (0.5, 1.6), "cart")
    with pytest.raises(vd.ModelError, match="unknown support 'ground'"):
        vd.forced_response_curve(duffing, vd.SupportMotion("ground", (0, 0, 1e-3)), (0.5, 1.6), "cart")
    for H in (0, -1, 1.5, True):
        with pytest.raises(vd.ModelError, match="harmonics"):
            vd.forced_response_curve(duffing, ("cart", P), (0.5, 1.6), "cart", harmonics=H)
    for key, value in (("tol", 0.0), ("tol", float("nan")), ("step", -0.1), ("max_steps", 0)):
        with pytest.raises(vd.ModelError, match=key):
            vd.forced_response_curve(duffing, ("cart", P), (0.5, 1.6), "cart", **{key: value})
    with pytest.raises(vd.ModelError, match="coordinate"):
        vd.forced_response_curve(duffing, ("cart", P), (0.5, 1.6), 0)


def test_scenes_harmonic_balance_does_not_handle_are_refused():
    timed = duffing_scene(forcing=(P, 1.0)).build()
    with pytest.raises(vd.ModelError, match="depend on time"):
        vd.forced_response_curve(timed, ("cart", P), (0.5, 1.6), "cart")
    driven = double_pendulum_scene()
    driven.add_drive("upper", vd.laws.Harmonic(0.1, 2.0))
    with pytest.raises(vd.ModelError, match="drives"):
        vd.forced_response_curve(driven.build(), ("lower", 1.0), (0.5, 1.6), "lower")


def test_doubled_samples_are_exact_for_trig_polynomials_below_half_the_samples():
    """The truncation step's 2H + 1 Jacobian takes the H balance's per-sample derivatives at twice the
    samples: exact for a trig polynomial of degree < N/2 (a cubic force's 3x² at an H-harmonic x)."""
    from vibdyn.analysis.nonlinear.balance import doubled

    N = 12
    rng = np.random.default_rng(4)
    a, b = rng.standard_normal(6), rng.standard_normal(6)  # degree 5 < N/2 = 6

    def f(tau):
        k = np.arange(6)
        return np.cos(np.multiply.outer(tau, k)) @ a + np.sin(np.multiply.outer(tau, k)) @ b

    tau, fine = 2 * np.pi * np.arange(N) / N, np.pi * np.arange(2 * N) / N
    samples = np.stack([f(tau), 2 * f(tau)], axis=-1)  # with a trailing axis, as K per sample
    assert np.max(np.abs(doubled(samples)[:, 0] - f(fine))) <= 1e-13 * np.max(np.abs(f(fine)))
    assert np.max(np.abs(doubled(samples)[:, 1] - 2 * f(fine))) <= 2e-13 * np.max(np.abs(f(fine)))


def test_flat_peak_frequency_error_includes_the_optimisers_resolution():
    """m ẍ + c ẋ + k x = F cos Ωt (m = 2, k = 50, c = 0.4): the peak at ω_n √(1 − 2ζ²), of
    F / (c ω_n √(1 − ζ²)). The maximum is flat: the amplitude's last digits locate Ω only to about √ε, and
    the stated Ω error says so (the truncation alone is ~1e-16 here, the Ω found 2.6e-10 from the truth)."""
    m, k, c, F = 2.0, 50.0, 0.4, 1.0
    crv = vd.forced_response_curve(duffing_scene(c=c, k3=0.0, k=k, m=m).build(), ("cart", F), (1.0, 10.0), "cart")
    wn, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
    peak = crv.peak
    exact = wn * math.sqrt(1 - 2 * zeta**2)
    assert abs(peak.omega - exact) <= peak.omega_error
    assert peak.omega_error < 1e-6 * exact  # still a located peak: ~√ε, not the continuation's step
    amplitude = F / (c * wn * math.sqrt(1 - zeta**2))
    rounding = 4 * np.finfo(float).eps * amplitude  # the closed form's own
    assert abs(peak.amplitude - amplitude) <= peak.error + rounding


def test_summary_counts_verdicts_not_a_bare_comparison_with_one():
    """An undamped forced two-mass oscillator below its first resonance: every |μ| is 1 within its error, and
    the summary says so (it counted them "unstable", by |μ| ≥ 1 alone, while each row said within the error)."""
    system = vd.load_scene("two_mass_cubic").build()
    curve = vd.forced_response_curve(system, ("m1", 0.02), (0.8, 1.1), "m2", harmonics=3)
    n_within = curve.stability.count("within the error")
    assert n_within == len(curve.omega) and curve.stability.count("unstable") == 0
    assert f"0 unstable points, {n_within} neutral within the error" in str(curve)


@pytest.mark.parametrize("c", [1e-2, 1e-6])
def test_linear_points_cover_the_closed_form_through_resonance(c):
    """m ẍ + c ẋ + k x = F cos Ωt: each point's error covers |X − F/√((k − mΩ²)² + (cΩ)²)|. It was the truncation
    estimate alone (zero here): the corrector's residual (‖R‖ ≤ 1e-11 of F) moves the amplitude by |R|/|∂R/∂X|,
    large near a lightly damped resonance — actual errors up to 308× the stated at c = 1e-2, 1.3e4× at 1e-6."""
    for k, m, F, lo, hi in [(1.0, 1.0, 1.0, 0.5, 1.5), (50.0, 2.0, 3.0, 2.5, 7.5), (50.0, 2.0, 3.0, 4.95, 5.05)]:
        crv = vd.forced_response_curve(duffing_scene(c=c, k3=0.0, k=k, m=m).build(), ("cart", F), (lo, hi), "cart")
        w = crv.omega
        exact = F / np.sqrt((k - m * w**2) ** 2 + (c * w) ** 2)
        actual = np.abs(crv.amplitude - exact)
        assert np.all(actual <= crv.error)
        # and within about a decade where the residual carries the error, not the round-off of k·X and mΩ²·X
        # (ε·(k + mΩ²)·X/|Z|: a bound there, 12–25× the actual at the top of the c = 1e-6 peak)
        Z = np.hypot(k - m * w**2, c * w)
        big = actual > 100 * np.finfo(float).eps * (k + m * w**2) * exact / Z
        assert np.all(crv.error[big] <= 10 * actual[big])
        # the peak too: at c = 1e-6 the branch stepped over the 1e-6 rad/s wide resonance (199.7 ± 9e-13 m claimed
        # for 1e6 m); with k = 50 at c = 1e-2 it looped around it for 2000 steps
        wn, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
        assert crv.status == "finished" and len(w) < 2500
        assert abs(crv.peak.amplitude - F / (c * wn * math.sqrt(1 - zeta**2))) <= crv.peak.error
        assert abs(crv.peak.omega - wn * math.sqrt(1 - 2 * zeta**2)) <= crv.peak.omega_error


def test_adaptive_duffing_points_cover_a_high_harmonic_reference(duffing, curve):
    """Each point of the adaptive Duffing curve against the 25-harmonic balance solved at its Ω (Newton to 1e-14 of
    the force, from the point): the difference of amplitudes is within the point's error."""
    from vibdyn.analysis.nonlinear.balance import Balance, Excitation, embed
    from vibdyn.solvers.newton import newton

    big = Balance(duffing, Excitation(duffing, ("cart", P)), curve.q_eq, 25)
    for i, w in enumerate(curve.omega):
        x0 = embed(curve.coefficients[i].ravel(), curve.harmonics, 25, 1)
        res = newton(lambda x: big.residual(x, w), x0, lambda x: big.jacobian(x, w)[:, :-1], tol=1e-14, max_iter=30)
        assert res.converged
        assert abs(curve.amplitude[i] - big.amplitude(res.x, 0)) <= curve.error[i]
