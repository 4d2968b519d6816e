"""Linearisation: finite differences against analytic derivatives, error estimates, closed forms.

Tolerances: a result's own error estimate (modes.relative_error/residual, lin.K_error, traj.error, ...) wherever the
comparison is one the estimate covers; fixed 1e-15..1e-12 ones are identities that hold to round-off (a
few ε × the size of the terms: ΦᵀMΦ = 1 from eigh, a unit quaternion, a closed form in a few flops).
"""

import numpy as np
import pytest

import vibdyn as vd

G = 9.81


def mixed_chain(n=10, seed=0, conservative=False):
    """A 10-link chain mixing pivots, sliders, helical and ball joints, with every kind of force element."""
    rng = np.random.default_rng(seed)
    s = vd.Scene("mixed", gravity=(0.3, -1.0, -G))
    kinds = [vd.Pivot((0, 1, 0.2), at=(0.1, 0, -0.3)), vd.Slider((1, 0.2, 0), at=(0, 0.1, -0.2)),
             vd.Helical((0, 0.3, 1), 0.05, at=(0.1, 0, -0.2)), vd.Ball(at=(0, 0.1, -0.3))]
    parent = "world"
    for i in range(n):
        name = f"b{i}"
        s.add_body(name, parent, kinds[i % 4], mass=1 + rng.random(),
                   com=tuple(rng.normal(size=3) * 0.1 + [0, 0, -0.15]), inertia=vd.inertia.box(1, (0.1, 0.2, 0.3)))
        s.add_joint_spring(name, 40.0 + 5 * i)
        if not conservative:
            s.add_joint_damper(name, 0.3)
        parent = name
    s.add_spring("k1", ("world", (0.5, 0.2, 0)), ("b3", (0.05, 0, 0)), stiffness=200, free_length=0.3)
    s.add_spring("k2", ("b2", (0, 0, 0)), ("b7", (0.05, 0.02, 0)), stiffness=150)
    s.add_force("f1", "b6", force=(1, 2, 3), at=(0.1, 0, 0))  # constant in world axes: conservative
    if not conservative:
        s.add_damper("c1", ("world", (0.5, -0.3, 0.1)), ("b5", (0.0, 0.05, 0)), damping=3)
        s.add_damper("c2", ("b1", (0.02, 0, 0)), ("b8", (0.0, 0.05, 0)), damping=2)
        s.add_force("f2", "b9", force=(0.5, -1, 2), at=(0.1, 0, 0), torque=(0.1, 0.2, 0.3), frame="body")
        s.add_joint_force("b0", vd.laws.Polynomial((1, 0.5, -0.2)))
        s.add_joint_force("b1", lambda t, q, v: np.sin(q) + 0.1 * v)
    return s.build()


def rel(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)


@pytest.fixture(scope="module")
def chain():
    return mixed_chain()


@pytest.mark.parametrize("where", ["equilibrium", "moving"])
def test_fd_equals_analytic_on_mixed_chain(chain, where):
    if where == "equilibrium":
        eq = chain.equilibrium()
        assert eq.residual <= eq.tol
        at, v = eq, None
    else:
        rng = np.random.default_rng(3)
        at, v = chain.random_configuration(0.4, rng=rng), rng.normal(size=chain.nv)
    fd = chain.linearize(at, v=v)
    an = chain.linearize(at, v=v, method="analytic")
    assert rel(fd.K, an.K) <= 1e-7
    assert rel(fd.C, an.C) <= 1e-7
    np.testing.assert_array_equal(fd.M, an.M)
    # the error estimate bounds the actual difference (in the max norm)
    assert np.abs(fd.K - an.K).max() <= fd.K_error.max()
    assert np.abs(fd.C - an.C).max() <= fd.C_error.max()
    assert fd.relative_error < 1e-6 and fd.elapsed > 0 and an.elapsed > 0


def test_K_symmetric_at_true_equilibrium_only():
    system = mixed_chain(conservative=True)
    eq = system.equilibrium()
    lin = eq.linearize()
    assert np.abs(lin.N).max() <= 10 * lin.K_error.max()
    assert np.abs(lin.N).max() <= 1e-7 * np.abs(lin.K).max()
    # away from equilibrium (with an acceleration a0 ≠ 0) K is not symmetric in general
    off = system.linearize(system.random_configuration(0.5, rng=1), method="analytic")
    assert np.abs(off.N).max() > 1e-4 * np.abs(off.K).max()


def test_velocity_differences_skipped_when_nothing_depends_on_velocity():
    s = vd.Scene("pendulum", gravity=(0, 0, -G))
    s.add_body("bob", joint=vd.Pivot((0, 1, 0)), mass=2.0, com=(0, 0, -0.7))
    system = s.build()
    lin = system.linearize()
    assert not system.depends_on_velocity
    assert lin.evaluations == 4 * system.nv + 1  # the operating point, then ±h and ±2h per coordinate
    assert not lin.C.any() and not lin.C_error.any()
    assert lin.K[0, 0] == pytest.approx(2.0 * G * 0.7, rel=1e-9)  # closed form m g l
    # a callable counts as velocity-dependent unless declared otherwise
    s.add_joint_force("bob", lambda t, q, v: 0.0)
    assert s.build().linearize().evaluations == 8 * system.nv + 1
    s2 = vd.Scene("pendulum", gravity=(0, 0, -G))
    s2.add_body("bob", joint=vd.Pivot((0, 1, 0)), mass=2.0, com=(0, 0, -0.7))
    s2.add_joint_force("bob", lambda t, q, v: -3.0 * q, velocity_dependent=False)
    lin2 = s2.build().linearize()
    assert lin2.evaluations == 5 and lin2.K[0, 0] == pytest.approx(2.0 * G * 0.7 + 3.0, rel=1e-9)


def test_prestressed_string_geometric_stiffness():
    """A mass held between two stretched springs: transverse stiffness 2T/L, axial 2k."""
    k, l0, L, m = 300.0, 0.4, 0.5, 0.2
    s = vd.Scene("string")
    s.add_body("m", joint=vd.Planar(normal=(0, 0, 1)), mass=m, inertia=vd.inertia.sphere(m, 0.01))
    s.add_spring("left", ("world", (-L, 0, 0)), "m", stiffness=k, free_length=l0)
    s.add_spring("right", ("world", (L, 0, 0)), "m", stiffness=k, free_length=l0)
    lin = s.build().linearize(method="analytic")
    T = k * (L - l0)
    assert np.all(np.abs(np.diag(lin.K)[:2] - [2 * k, 2 * T / L]) <= np.diag(lin.K_error)[:2])
    fd = s.build().linearize()
    np.testing.assert_allclose(fd.K, lin.K, rtol=0, atol=1e-7 * 2 * k)


def test_gyroscopic_split_of_spinning_rotor():
    """Rotor carrying a radial slider, spinning at Ω: C has the skew part 2 m s Ω (Coriolis)."""
    m, s0, omega = 1.5, 0.4, 3.0
    s = vd.Scene("rotor")
    s.add_body("rotor", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=np.diag([0.05, 0.05, 0.1]))
    s.add_body("slider", "rotor", vd.Slider((1, 0, 0), at=(s0, 0, 0)), mass=m)
    system = s.build()
    v = np.array([omega, 0.0])
    lin = system.linearize(v=v)
    an = system.linearize(v=v, method="analytic")
    assert lin.G[0, 1] == pytest.approx(2 * m * s0 * omega, rel=1e-9)
    assert rel(lin.C, an.C) < 1e-9
    assert np.abs(lin.D).max() < 1e-9  # no damping: C is purely gyroscopic


def test_input_matrices_are_virtual_work():
    s = vd.Scene("trailer", gravity=(0, 0, -G))
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=10.0)
    s.add_body("rod", "cart", vd.Pivot((0, 1, 0)), mass=2.0, com=(0, 0, -0.5), inertia=vd.inertia.rod(2.0, 1.0))
    lin = s.build().linearize()
    B = lin.point_input([("rod", (0, 0, -1.0))])  # force at the rod tip, world axes
    # a force F along +x at the tip: (F, −F·1 m), since a rotation +θ about y moves the tip by −θ along x
    np.testing.assert_allclose(B @ [1.0, 0, 0], [1.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(lin.joint_input(["rod"]).ravel(), [0, 1])
    A = lin.A
    assert A.shape == (4, 4)
    np.testing.assert_allclose(A[2:, 2:], -np.linalg.solve(lin.M, lin.C))


def test_ball_chain_analytic_is_accurate_on_long_chain():
    """Regression guard for the brief's trap: the analytic path (RNEA derivatives, CRBA) stays accurate on
    a 20-link chain of ball joints, where computeMinverse/ABA derivatives do not."""
    s = vd.Scene("balls", gravity=(0, 0, -G))
    parent = "world"
    for i in range(20):
        s.add_body(f"b{i}", parent, vd.Ball(at=(0, 0, -0.2 if i else 0)), mass=1.0, com=(0.01, 0, -0.1),
                   inertia=vd.inertia.box(1.0, (0.05, 0.06, 0.2)))
        s.add_joint_spring(f"b{i}", 30.0)
        parent = f"b{i}"
    system = s.build()
    q = system.random_configuration(0.3, rng=2)
    fd, an = system.linearize(q), system.linearize(q, method="analytic")
    assert rel(fd.K, an.K) < 1e-7


def test_singular_mass_matrix_at_the_operating_point_names_the_body():
    """A massless carriage on a pivot carries a point mass on a radial slider: when the mass reaches the
    axis, nothing has inertia about it."""
    s = vd.Scene("carriage")
    s.add_body("carriage", joint=vd.Pivot((0, 0, 1)), mass=0.0)
    s.add_body("bead", "carriage", vd.Slider((1, 0, 0), at=(0.5, 0, 0)), mass=1.0)
    system = s.build()  # fine at neutral: the bead is 0.5 m from the axis
    q = system.integrate(system.neutral(), [0.0, -0.5])
    with pytest.raises(vd.ModelError, match="singular mass matrix.*'carriage'"):
        system.linearize(q)
    with pytest.raises(vd.ModelError, match="singular mass matrix.*'carriage'"):
        system.accelerations(q, np.zeros(2))


def _column_by_column(system, q0, v0, a0, h, hv):
    """The definition, one column at a time: q moved by pin.integrate, the checked inverse dynamics."""
    import pinocchio as pin

    K, C = np.zeros((system.nv, system.nv)), np.zeros((system.nv, system.nv))
    for k in range(system.nv):
        e = np.zeros(system.nv)
        e[k] = h[k]
        qp, qm = pin.integrate(system.model, q0, e), pin.integrate(system.model, q0, -e)
        K[:, k] = (system.inverse_dynamics(qp, v0, a0) - system.inverse_dynamics(qm, v0, a0)) / (2 * h[k])
        e[k] = hv[k]
        C[:, k] = (system.inverse_dynamics(q0, v0 + e, a0) - system.inverse_dynamics(q0, v0 - e, a0)) / (2 * hv[k])
    return K, C


@pytest.mark.parametrize("where", ["rest", "moving"])
def test_one_pass_sweep_is_the_column_by_column_difference(chain, where):
    """The FD sweep makes every displaced configuration at once (vector-space coordinates by a sum, ball
    joints by integrate) and evaluates them in one pass (joint-space groups on all rows at once, gravity
    alone at rest): the same central differences as one column at a time with pin.integrate and the full
    inverse dynamics, to within the round-off part of the model's own estimate."""
    from vibdyn.model.fd import steps

    rng = np.random.default_rng(11)
    q0 = chain.random_configuration(0.3, rng)
    v0 = np.zeros(chain.nv) if where == "rest" else rng.normal(size=chain.nv)
    a0 = np.zeros(chain.nv)
    lin = chain.linearize(q0, v=v0, a=a0, method="fd")
    h = steps(chain, 1e-5)
    K, C = _column_by_column(chain, q0, v0, a0, h, h * np.maximum(1.0, np.abs(v0)))
    assert np.all(np.abs(lin.K - K) <= lin.K_error)
    assert np.all(np.abs(lin.C - C) <= lin.C_error)
    assert rel(lin.K, K) < 1e-6  # (and the estimate is not vacuous)


def test_stencil_configurations_are_integrate_of_each_step(chain):
    """Every row of a stencil is integrate(q0, s·h_k e_k), bit for bit, on every joint kind (pivot, slider,
    helical and ball joints here: the ball's rows come from integrate, the others from a sum)."""
    import pinocchio as pin

    from vibdyn.model.fd import ESTIMATED, stencil, steps

    system = chain
    rng = np.random.default_rng(2)
    q0 = system.random_configuration(0.5, rng)
    h = steps(system, 1e-3)
    st = stencil(system, system.workspace(), h, estimate=True)
    Q = st.configurations(system, q0)
    assert np.array_equal(Q[0], q0) and len(Q) == 1 + 4 * system.nv
    for i, s in enumerate(ESTIMATED):
        for k in range(system.nv):
            e = np.zeros(system.nv)
            e[k] = s * h[k]
            assert np.array_equal(Q[1 + i * system.nv + k], pin.integrate(system.model, q0, e)), (i, k)
    assert stencil(system, system.workspace(), h, estimate=True) is st  # made once per steps


def test_fd_damping_error_counts_a_motor_law_vanishing_as_a_difference():
    """The rotor driven by τ = 10 − ω² at its steady speed Ω = √10: the law is a difference of two terms of 10
    N·m that rounds off by ε × 10 where its value is 0. The FD C must carry that round-off in its error
    estimate (it differs from the analytic C by ~1e-11; the estimate once said 6e-15); the steady speed itself
    is polished to round-off, not left anywhere below the search's tolerance."""
    system = vd.load_scene("rotor_slider").build()
    st = system.operating_point()
    assert abs(st.v[0] - np.sqrt(10.0)) <= 1e-13
    fd, an = st.linearize(method="fd"), st.linearize(method="analytic")
    assert np.all(np.abs(fd.C - an.C) <= fd.C_error + an.C_error)
    assert np.all(np.abs(fd.K - an.K) <= fd.K_error + an.K_error)


def storeys(angle, offset):
    """Rao's three-storey shear building on sliders along a horizontal axis at ``angle`` (rad) from x, its
    storey springs 10 m long along that axis, the whole scene moved by ``offset`` (m): K is the same
    [[1e6, −4e5, 0], [−4e5, 6e5, −2e5], [0, −2e5, 2e5]] N/m for any angle and offset."""
    import math

    u, o = np.array([math.cos(angle), math.sin(angle), 0.0]), np.asarray(offset, float)
    s = vd.Scene("storeys")
    for i, m in enumerate([2000.0, 1500.0, 1000.0]):
        s.add_body(f"floor{i + 1}", mass=m, joint=vd.Slider(axis=tuple(u), at=tuple(o + (0.0, 0.0, 3.0 * (i + 1)))))
    for i, k in enumerate([6e5, 4e5, 2e5]):
        a = ("world", tuple(o - 10 * u + (0, 0, 3.0))) if i == 0 else (f"floor{i}", tuple(-10 * u + (0, 0, 3.0)))
        s.add_spring(f"storey{i + 1}", a, f"floor{i + 1}", stiffness=k, free_length=10.0)
    return s.build()


def test_fd_steps_are_powers_of_two_so_that_positions_move_by_exactly_them():
    """Along x, a step that is a power of two adds exactly to the springs' 10 m offsets: the FD K is exact
    (a step of 1.04e-4 m rounded in 10 + h biased every entry by 8e-13, which no estimate saw)."""
    from vibdyn.model.fd import steps

    system = storeys(0.0, (0.0, 0.0, 0.0))
    h = steps(system, 1e-5)
    assert np.all(np.exp2(np.round(np.log2(h))) == h)
    assert np.all(np.abs(h / (1e-5 * system.coordinate_scales) - 1) < 0.42)
    lin = system.linearize(method="fd")
    K = np.array([[1e6, -4e5, 0], [-4e5, 6e5, -2e5], [0, -2e5, 2e5]])
    assert np.array_equal(lin.K, K)


@pytest.mark.parametrize("angle", [0.3, 1.1])
@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (100.0, 50.0, 0.0), (1000.0, 700.0, 0.0)])
def test_fd_modes_estimate_covers_springs_rounding_far_from_the_origin(angle, offset):
    """Oblique springs 10 m long, up to 1.2 km from the origin: each force is computed from world positions
    that round off by ε|x|, whatever the force; the FD modes' estimate carries it (each spring's part as a
    rank-one term: a mode that does not stretch it takes none) and covers the error (it was up to 3× under)."""
    from scipy.linalg import eigh

    M = np.diag([2000.0, 1500.0, 1000.0])
    K = np.array([[1e6, -4e5, 0], [-4e5, 6e5, -2e5], [0, -2e5, 2e5]])
    exact = np.sqrt(eigh(K, M, eigvals_only=True))
    lin = storeys(angle, offset).linearize(method="fd")
    assert lin.K_error_terms is not None and np.all(np.abs(lin.K - K) <= lin.K_error)
    modes = lin.modes()
    assert np.all(np.abs(modes.omega - exact) <= modes.omega_error * exact)
