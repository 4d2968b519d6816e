"""Equilibria and steady motions: Newton in the tangent space, several equilibria, stability, failures.

Tolerances: a result's own error estimate (modes.relative_error/residual, lin.K_error, traj.error, ...) wherever the
comparison is one the estimate covers; fixed 1e-15..1e-12 ones are identities that hold to round-off (a
few ε × the size of the terms: ΦᵀMΦ = 1 from eigh, a unit quaternion, a closed form in a few flops).
"""

import numpy as np
import pytest
from scipy.optimize import brentq

import vibdyn as vd

G = 9.81


def inverted_bar(kt, m=2.0, L=1.0):
    s = vd.Scene("inverted", gravity=(0, 0, -G))
    s.add_body("bar", joint=vd.Pivot((0, 1, 0)), mass=m, com=(0, 0, L / 2), inertia=vd.inertia.rod(m, L))
    s.add_joint_spring("bar", kt)
    return s.build()


def test_inverted_bar_stable_with_stiff_spring():
    eq = inverted_bar(50.0).equilibrium()
    assert eq.regime == "static" and eq.stability == "stable"
    assert eq.modes.omega[0] == pytest.approx(7.764342, rel=1e-6)


def test_weak_spring_has_three_equilibria():
    """k θ = m g (L/2) sin θ: the upright is unstable, the two tilted ones are stable."""
    kt, m, L = 5.0, 2.0, 1.0
    system = inverted_bar(kt, m, L)
    theta = brentq(lambda x: kt * x - m * G * L / 2 * np.sin(x), 0.5, 3.0)
    starts = [system.integrate(system.neutral(), [x]) for x in (-2.0, 0.0, 2.0)]
    found = system.equilibria(starts)
    angles = sorted(round(e.coordinate("bar"), 9) for e in found)
    np.testing.assert_allclose(angles, [-theta, 0.0, theta], atol=1e-9)
    by_angle = {round(e.coordinate("bar"), 3): e.stability for e in found}
    assert by_angle[0.0] == "unstable"
    assert by_angle[round(theta, 3)] == by_angle[round(-theta, 3)] == "stable"
    # lowest potential first: the tilted ones
    assert abs(found[0].coordinate("bar")) == pytest.approx(theta, rel=1e-9)


def test_newton_moves_to_the_equilibrium_in_the_tangent_space():
    """A ball-joint pendulum with an offset centre of mass and a torsion spring: the residual vanishes and
    the configuration stays a unit quaternion."""
    s = vd.Scene("ball", gravity=(0, 0, -G))
    s.add_body("p", joint=vd.Ball(), mass=1.0, com=(0.2, 0.1, -0.5), inertia=vd.inertia.box(1.0, (0.1, 0.1, 0.4)))
    s.add_joint_spring("p", 3.0)
    system = s.build()
    eq = system.equilibrium()
    assert eq.iterations > 0 and eq.residual <= eq.tol
    assert np.abs(system.inverse_dynamics(eq.q, np.zeros(3), np.zeros(3))).max() <= 1e-9
    assert np.linalg.norm(eq.q) == pytest.approx(1.0, abs=1e-12)
    assert eq.stability == "stable"


def test_free_coordinate_gives_singular_K_and_neutral_stability():
    """Trailer with no spring: the cart position is free (K singular); the least-squares step copes."""
    s = vd.Scene("trailer", gravity=(0, 0, -G))
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=10.0)
    s.add_body("rod", "cart", vd.Pivot((0, 1, 0)), mass=2.0, com=(0, 0, -0.5), inertia=vd.inertia.rod(2.0, 1.0))
    system = s.build()
    eq = system.equilibrium(system.integrate(system.neutral(), [0.3, 0.4]))
    assert eq.coordinate("rod") == pytest.approx(0.0, abs=1e-9)
    assert eq.coordinate("cart") == pytest.approx(0.3, abs=1e-6)  # stays where it was
    assert eq.stability == "neutral" and eq.modes.rigid.sum() == 1


def test_no_equilibrium_raises_convergence_error_with_best_point():
    s = vd.Scene("driven")
    s.add_body("wheel", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=vd.inertia.disc(1.0, 0.1))
    s.add_joint_force("wheel", 2.0)
    with pytest.raises(vd.ConvergenceError) as err:
        s.build().equilibrium(max_iter=5)
    assert err.value.residual == pytest.approx(2.0) and err.value.best is not None
    # a constant torque has no stationary point at all: refused as such, naming the coordinate
    assert "no static equilibrium" in str(err.value) and "'wheel' is constant" in str(err.value)


def rotor(c=2.0, k=100.0, m=1.0, l0=0.5):
    """Reference case R6: rotor driven by τ = 10 − ω² carrying a sprung radial slider."""
    s = vd.Scene("rotor", gravity=(0, 0, -G))
    s.add_body("rotor", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=np.diag([0.05, 0.05, 0.1]))
    s.add_body("slider", "rotor", vd.Slider((1, 0, 0), at=(l0, 0, 0)), mass=m,
               inertia=np.diag([0.0005, 0.0005, 0.001]))
    s.add_spring("k", ("rotor", (0, 0, 0)), ("slider", (0, 0, 0)), stiffness=k, free_length=l0)
    if c:
        s.add_joint_damper("slider", c)
    s.add_joint_force("rotor", vd.laws.Polynomial((10, 0, -1)))
    return s.build()


def test_steady_motion_of_rotor_R6():
    system = rotor()
    st = system.steady_motion({"rotor": None})
    s_star = 100 * 0.5 / (100 - 10)
    assert st.regime == "steady" and st.speeds["rotor"] == pytest.approx(np.sqrt(10), rel=1e-9)
    assert 0.5 + st.coordinate("slider") == pytest.approx(s_star, rel=1e-9)
    lin = st.linearize()
    np.testing.assert_allclose(np.diag(lin.M), [0.4096420, 1.0], rtol=1e-6)
    np.testing.assert_allclose(lin.C, [[6.324555, 3.513642], [-3.513642, 2.0]], rtol=1e-6)
    np.testing.assert_allclose(lin.K, np.diag([0.0, 90.0]), atol=1e-6)
    lam = np.sort_complex(lin.modes().eigenvalues)
    expected = np.sort_complex(np.array([0, -13.7940275, -1.8225996 + 9.8697688j, -1.8225996 - 9.8697688j]))
    np.testing.assert_allclose(lam, expected, rtol=1e-6, atol=1e-7)
    assert st.stability == "stable"  # the zero eigenvalue is the cyclic rotor angle


def test_steady_motion_without_damper_R6():
    st = rotor(c=0.0).steady_motion({"rotor": None})
    lam = st.linearize().modes().eigenvalues
    osc = lam[np.abs(lam.imag) > 1]
    np.testing.assert_allclose(np.sort(osc.imag), [-9.9485487, 9.9485487], rtol=1e-6)
    np.testing.assert_allclose(osc.real, -0.7383683, rtol=1e-6)


def test_steady_motion_at_given_speed_reports_drive():
    """At a given Ω = 3 rad/s: s* = k l0/(k − mΩ²); the drive holding Ω is −(10 − Ω²)."""
    st = rotor().steady_motion({"rotor": 3.0})
    assert 0.5 + st.coordinate("slider") == pytest.approx(100 * 0.5 / (100 - 9), rel=1e-9)
    assert st.drive["rotor"] == pytest.approx(-(10 - 9), rel=1e-9)


def test_bad_names_are_model_errors():
    with pytest.raises(vd.ModelError, match="unknown coordinate 'nope'"):
        rotor().steady_motion({"nope": None})
    with pytest.raises(vd.ModelError):
        rotor().steady_motion({})


def test_held_speed_is_linearised_about_the_held_motion():
    """At a given speed the drive holds Ω: no spurious ∂M/∂q·a term. K = diag(0, k − mΩ²), and C has the
    motor's 2Ω, the damper and the Coriolis pair ±2 m s Ω."""
    omega, k, m, c, l0 = 3.0, 100.0, 1.0, 2.0, 0.5
    st = rotor(c=c, k=k, m=m, l0=l0).steady_motion({"rotor": omega})
    lin = st.linearize()
    np.testing.assert_allclose(lin.a, 0.0)
    s = k * l0 / (k - m * omega**2)
    np.testing.assert_allclose(lin.K, np.diag([0.0, k - m * omega**2]), atol=1e-6)
    np.testing.assert_allclose(lin.C, [[2 * omega, 2 * m * s * omega], [-2 * m * s * omega, c]], rtol=1e-7)
    an = st.linearize(method="analytic")
    assert np.abs(an.K - lin.K).max() <= lin.K_error.max()


@pytest.mark.parametrize("method", ["fd", "analytic"])
def test_high_spin_state_eigenvalues_within_their_error_estimate(method):
    """R6 rotor held at 1e4 rad/s with a 1e9 N/m slider spring (extreme gyroscopic coupling): the state
    eigenvalues match those of the exact linear model to within vibdyn's own per-mode error estimate."""
    omega, k, m, c, l0, J = 1e4, 1e9, 1.0, 2.0, 0.5, 0.1 + 0.001
    st = rotor(c=c, k=k, m=m, l0=l0).steady_motion({"rotor": omega})
    s = k * l0 / (k - m * omega**2)
    assert 0.5 + st.coordinate("slider") == pytest.approx(s, rel=1e-9)
    M = np.diag([J + m * s * s, m])
    C = np.array([[2 * omega, 2 * m * s * omega], [-2 * m * s * omega, c]])
    K = np.diag([0.0, k - m * omega**2])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    exact = np.linalg.eigvals(A)
    modes = st.linearize(method=method).modes()
    for lam, err in zip(modes.damped_eigenvalues, modes.eigenvalue_error):
        ref = exact[np.argmin(np.abs(exact - lam))]
        assert abs(lam - ref) <= max(err, 1e-9 * np.abs(exact).max())  # (err: 1/s)
    # (FD: the 1e9 N/m spring's force, from world positions, rounds off by ε·k·|x| per evaluation: ~1e-6)
    assert modes.relative_error < (1e-6 if method == "analytic" else 1e-5) and st.stability == "stable"


def test_equilibrium_far_away_in_a_scene_with_a_tiny_length_scale():
    """A 2 kg point mass on a slider (no geometry: length scale 1 mm), spring 50 N/m, force 5 N: x* = F/k =
    0.1 m, a hundred of the search's first steps away; the expanding trust region reaches it."""
    s = vd.Scene("point")
    s.add_body("m", joint=vd.Slider((1, 0, 0)), mass=2.0)
    s.add_joint_spring("m", 50.0)
    s.add_joint_force("m", lambda t, q, v: 5.0)
    system = s.build()
    assert system.length_scale <= 1e-3
    eq = system.equilibrium()
    assert eq.q[0] == pytest.approx(0.1, abs=10 * eq.q_error[0] + 1e-15) and eq.iterations < 30
