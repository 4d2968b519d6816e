"""The one reduction of coordinates (vibdyn.model.reduction): the identity for a tree, a free subset for held
coordinates (drives, held speeds), the loops' null space N(q), their composition; and the linear models made
through it against the tree's own (rows and columns of the free coordinates, Φ_q N = 0)."""

import math

import numpy as np
import pytest
from conftest import MODELS

import vibdyn as vd


def rotor_with_slider():
    """A hub spinning about z carrying a sprung radial slider (a tree: the spin is held only when asked)."""
    s = vd.Scene("hub_slider")
    s.add_body("hub", joint=vd.Pivot(axis=(0, 0, 1)), mass=1.0, inertia=np.diag([0.3, 0.3, 0.5]))
    s.add_body("slider", parent="hub", joint=vd.Slider(axis=(1, 0, 0), at=(0.4, 0, 0)), mass=2.0,
               inertia=vd.inertia.point())
    s.add_joint_spring("slider", 200.0)
    return s.build()


def test_a_tree_reduces_by_the_identity():
    system = rotor_with_slider()
    R = system.reduction
    assert R.kind == "tree" and R.is_identity and not R.looped and not R.time_laws
    q, v = system.neutral(), np.array([1.0, 0.2])
    ind, N = R.independent(q)
    assert ind.tolist() == [0, 1] and np.array_equal(N, np.eye(2))
    q1, v1 = R.impose(q, v, 0.0)
    assert np.array_equal(q1, q) and np.array_equal(v1, v)
    assert R.closure(q) == 0.0 and R.multipliers(q, np.ones(2)).size == 0


def test_holding_a_speed_is_a_free_subset_and_its_linear_model_the_free_block():
    """N constant (columns of the identity): the held model is the tree model's free rows and columns, exactly
    (same operating point, same differences), and the held coordinate is no coordinate of it."""
    system = rotor_with_slider()
    op = system.steady_motion({"hub": 3.0})
    R = system.reduction.holding({0: 3.0})
    assert R.kind == "held" and R.held.tolist() == [0] and R.free.tolist() == [1] and R.held_names == ("hub",)
    assert R.impose(op.q, np.zeros(2), 0.0)[1].tolist() == [3.0, 0.0]
    free = op.linearize(method="analytic")
    held = op.linearize(method="analytic", hold="hub")
    assert held.coordinates == ("slider",) and held.units == ("m",) and held.nv == 1
    for name in ("M", "C", "K"):
        assert np.array_equal(getattr(held, name), getattr(free, name)[1:, 1:])
    # in the rotating frame m(ẍ − Ω² x) = −k x: ω² = k/m − Ω² (the held hub absorbs the Coriolis torque)
    omega = held.modes().omega[0]
    assert omega == pytest.approx(np.sqrt(200.0 / 2.0 - 9.0), abs=10 * held.modes().omega_error[0] + 1e-12)
    assert set(held.drive) == {"hub"}  # the torque that holds the speed (N·m)
    with pytest.raises(vd.ModelError, match="held at its speed"):
        held.coordinate_index("hub")
    with pytest.raises(vd.ModelError, match="unknown coordinate"):
        held.coordinate_index("nope")


def test_a_driven_scene_reduces_to_its_free_coordinates():
    system = vd.load_scene(MODELS / "shaken_pendulum.toml").build()
    R = system.reduction
    assert R.kind == "held" and R.time_laws and R.driven.size == len(R.driven_names) >= 1
    assert R.free.size + R.held.size == system.nv
    q, v = R.impose(system.neutral(), np.zeros(system.nv), 0.3)
    qd, vd_, _ = R.law_values(0.3)
    assert np.array_equal(q[R.driven_q], qd) and np.array_equal(v[R.driven], vd_)
    with pytest.raises(vd.ModelError, match="driven"):
        R.holding({int(R.driven[0]): 1.0})


def test_loops_reduce_by_their_null_space_and_compose_with_a_held_spin():
    from test_mechanisms import L, hand_reduction, spun_trammel  # (the trammel on a turntable)

    k = hand_reduction(0.7, 3.0)[0]
    system = spun_trammel(k).build()
    q0 = system.configuration({"A": 2 * L * math.sin(0.7), "disk": 0.7, "B": 2 * L * math.cos(0.7)})
    R = system.reduction
    assert R.kind == "loops" and R.looped
    q = R.close(q0)
    assert R.closure(q) < 1e-12
    ind, N = R.independent(q)
    J = system.constraint_jacobian(q)
    assert np.abs(J @ N).max() < 1e-12 * np.abs(J).max() * np.abs(N).max()
    assert np.array_equal(N[ind], np.eye(ind.size))
    rotor = system.coordinate_index("rotor")
    assert rotor in ind
    both = R.holding({rotor: 3.0})
    assert both.kind == "loops, held"
    ind2, N2 = both.independent(q)
    assert rotor not in ind2 and ind2.size == ind.size - 1
    assert np.all(N2[rotor] == 0.0) and np.abs(J @ N2).max() < 1e-12 * np.abs(J).max() * np.abs(N2).max()


def test_every_held_coordinate_leaves_nothing_to_vibrate():
    system = rotor_with_slider()
    with pytest.raises(vd.ModelError, match="nothing is free to vibrate"):
        system.linearize(system.neutral(), hold=["hub", "slider"])


def test_a_held_configuration_is_a_reduction_holding_every_coordinate():
    """Servo-held robots are a reduction (issue 41): every coordinate held at (q, v), nothing independent, the
    holders' forces the inverse dynamics there; the one search finds the held point in zero iterations."""
    from vibdyn.analysis.equilibrium import search

    system = rotor_with_slider()
    q, v = system.configuration([0.3, 0.05]), np.array([2.0, 0.0])
    R = system.reduction.holding_all(q, v)
    assert R.regime(False) == "held" and R.has() == ("held configuration",) and R.free.size == 0
    ind, N = R.independent(q)
    assert ind.size == 0 and N.shape == (2, 0)
    q1, v1 = R.impose(system.neutral(), np.zeros(2), 0.0)
    assert np.array_equal(q1, q) and np.array_equal(v1, v)
    tau = system.inverse_dynamics(q, v, np.zeros(2))
    op = system.held(q, v)
    assert op.regime == "held" and op.iterations == 0 and op.residual == 0.0 and op.speeds == {"hub": 2.0}
    assert op.drive == R.held_forces(tau) == {"hub": tau[0], "slider": tau[1]}
    found = search(system, q, 0.0, {}, 1e-10, 50, caller="held", reduction=R)
    assert found.drive == op.drive and found.tol == op.tol and found.stability == op.stability
    lin = op.linearize(method="analytic")  # the free tree's model about it, a = 0
    assert lin.nv == 2 and not np.any(lin.a)


def test_a_built_tree_is_freed_without_the_garbage_collector():
    """The System holds its reduction, which holds no reference back: a System nobody refers to is freed at once
    (with a cycle, every System built, Pinocchio Data included, waited for the collector: a 100-body build took
    twice as long, and a sweep's memory grew)."""
    import gc
    import weakref

    enabled = gc.isenabled()
    gc.disable()
    try:
        system = rotor_with_slider()
        system.linearize(system.neutral(), hold="hub")  # (a held reduction made and dropped on the way)
        ref = weakref.ref(system)
        del system
        assert ref() is None
        driven = vd.load_scene("shaken_pendulum").build()  # (its compiled Drives: no reference back either)
        driven.simulate(0.01, driven.neutral())
        assert len(driven.drives.forces(driven.neutral(), np.zeros(driven.nv), 0.0)) == 1
        ref = weakref.ref(driven)
        del driven
        assert ref() is None
    finally:
        if enabled:
            gc.enable()


def test_nothing_compiled_refers_back_to_the_system():
    """No back-references from the compiled drives or the reduction to the System (issue 41): neither holds it,
    strongly or weakly; ``system.drives`` is the table bound on access, and a driven System pickles."""
    import gc
    import pickle
    import weakref

    system = vd.load_scene("shaken_pendulum").build()
    table, R = system.compiled_drives, system.reduction
    for obj in (table, R, *vars(table).values(), *vars(R).values()):
        assert not any(x is system or isinstance(x, weakref.ref) for x in (obj, *gc.get_referents(obj))), obj
    bound = system.drives
    assert bound is not table and bound.names == table.names and np.array_equal(bound.index, table.index)
    tau = bound.forces(system.neutral(), np.zeros(system.nv), 0.0)
    with pytest.raises(vd.ModelError, match="bound to no System"):
        table.forces(system.neutral(), np.zeros(system.nv), 0.0)
    copy = pickle.loads(pickle.dumps(system))
    assert copy.drives.forces(copy.neutral(), np.zeros(copy.nv), 0.0) == tau
    enabled = gc.isenabled()
    gc.disable()
    try:  # freed by its last reference alone, its bound drives dropped first
        ref = weakref.ref(system)
        del system, bound, copy
        assert ref() is None
    finally:
        if enabled:
            gc.enable()


def test_a_system_with_loops_and_every_bundled_model_is_freed_without_the_garbage_collector():
    """The compiled loops keep what they need of the System, not the System (issue 41 item 2): a System with loops,
    after an analysis on it, and every bundled model are freed by their last reference alone (with the loops'
    reference back, each waited for the collector)."""
    import gc
    import pickle
    import weakref

    enabled = gc.isenabled()
    gc.disable()
    try:
        for name in ("four_bar", "trammel", "slider_crank"):
            system = vd.load_scene(name).build()
            table = system.compiled_loops
            for obj in (table, *vars(table).values()):
                assert not any(x is system or isinstance(x, weakref.ref) for x in (obj, *gc.get_referents(obj))), obj
            bound = system.constraints
            assert bound is not table and bound.closed is table.closed and system.dof == 1
            if name == "four_bar":  # (its start is declared: the described pose's assembly not searched yet)
                with pytest.raises(vd.ModelError, match="bound to no System"):
                    table.assembly()
            assert bound.assembly() is table.assembly(system) is system.constraints.assembly()
            copy = pickle.loads(pickle.dumps(system))
            assert copy.dof == 1 and copy.constraints.closed[1] == system.constraints.closed[1]
            system.operating_point().linearize().modes()
            ref = weakref.ref(system)
            del system, bound, table, copy
            assert ref() is None, name
        for path in sorted(MODELS.glob("*.toml")):
            ref = weakref.ref(vd.load_scene(path.stem).build())
            assert ref() is None, path.stem
    finally:
        if enabled:
            gc.enable()


def test_held_speed_accelerations_are_the_rotating_frame_closed_form():
    """Hub held at Ω, slider at rest at r = 0.4 m with its spring at rest: the hub does not accelerate and the
    slider's acceleration is the centripetal term Ω² r (m/s²); the held path shares the drives' solve."""
    system = rotor_with_slider()
    R = system.reduction.holding({0: 3.0})
    q, v = R.impose(system.neutral(), np.zeros(2), 0.0)
    a = R.accelerations(system, system.workspace(), q, v, 0.0)
    assert a[0] == 0.0 and a[1] == pytest.approx(9.0 * 0.4, rel=1e-12)


def test_the_reduction_answers_refusals_by_name():
    """An analysis names itself; the reduction says what the scene has that the analysis lacks (issue 41)."""
    tree, loops = rotor_with_slider(), vd.load_scene("four_bar").build()
    driven = vd.load_scene("shaken_pendulum").build()
    for name in ("backbones", "harmonic balance", "periodic orbits", "variational equations"):
        assert tree.reduction.require(name, "x") is None
    with pytest.raises(vd.ModelError, match=r"^backbone: not available for a mechanism with closed loops$"):
        loops.reduction.require("backbones", "backbone")
    with pytest.raises(vd.ModelError, match=r"^x: scenes with drives are not handled by harmonic balance yet$"):
        driven.reduction.require("harmonic balance", "x")
    assert loops.reduction.has() == ("loops",) and driven.reduction.has() == ("drives",) and tree.reduction.has() == ()
    # the paths an analysis takes where it can, asked by name (allows: require without the error)
    assert tree.reduction.allows("derivatives on the tree's elements")
    assert not driven.reduction.allows("derivatives on the tree's elements")
    assert not tree.reduction.holding({0: 1.0}).allows("derivatives on the tree's elements")
    assert loops.reduction.allows("operating points found from a state")
    assert not driven.reduction.allows("operating points found from a state")
    assert tree.reduction.allows("steady motions followed from rest")
    assert not loops.reduction.allows("steady motions followed from rest")
    # an analysis's own refusal, only for what the scene has
    assert driven.reduction.require("a stepper", "y", loops="no loops here") is None
    with pytest.raises(vd.ModelError, match=r"^y: held \(drives .*\)$"):
        driven.reduction.require("a stepper", "y", drives="held ({describe})")


def test_the_reduced_stiffness_through_the_chart_is_the_linear_models():
    """At a mechanism's equilibrium, ∂(Nᵀr)/∂z through the chart (Reduction.derivative: N re-evaluated, loops closed
    again) is the reduced K of its linear model, Nᵀ(K − ∂(Φ_qᵀλ)/∂q)N: two paths, within their error estimates."""
    system = vd.load_scene("four_bar").build()
    R, eq = system.reduction, system.equilibrium()
    zero = np.zeros(system.nv)
    ind, N = R.independent(eq.q)

    def reduced(q1):
        return R.reduce(ind, R.independent(q1, ind)[1], system.inverse_dynamics(q1, zero, zero))

    h = 1e-4 * system.coordinate_scales
    J1 = R.derivative(eq.q, ind, N, reduced, None, h)
    J2 = R.derivative(eq.q, ind, N, reduced, None, 2 * h)
    lin = system.linearize(eq)
    tol = 2 * np.abs(J1 - J2) + lin.K_error + 1e-9 * np.abs(lin.K).max()
    assert np.all(np.abs(J1 - lin.K) <= tol)
    # the check can fail: holding N at its value at the equilibrium drops the loop forces' curvature
    frozen = R.derivative(eq.q, ind, N, lambda q1: N.T @ system.inverse_dynamics(q1, zero, zero), None, h)
    assert np.any(np.abs(frozen - lin.K) > 100 * tol)
