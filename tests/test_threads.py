"""One System, several threads: each thread computes in its own workspace, so concurrent calls give exactly
the serial results (the System is immutable; Pinocchio Data and force buffers are per thread)."""

import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import vibdyn as vd


def sprung_chain(n=6):
    """Pivot chain under gravity with point springs to the world and a damper: every force path (joint
    kinematics for point elements, gravity, velocity terms) writes into Pinocchio's Data."""
    s = vd.Scene("threads", gravity=(0, 0, -9.81))
    parent = "world"
    for i in range(n):
        s.add_body(f"b{i}", parent, vd.Pivot((0, 1, 0), at=(0, 0, -0.3 if i else 0.0)), mass=1.0 + 0.1 * i,
                   com=(0, 0, -0.15), inertia=vd.inertia.rod(1.0, 0.3, axis=(0, 0, 1)))
        s.add_spring(f"k{i}", ("world", (0.5, 0.0, -0.3 * i)), (f"b{i}", (0, 0, -0.3)), stiffness=50.0 + 5 * i,
                     free_length=0.2)
        parent = f"b{i}"
    s.add_damper("c", ("world", (0.0, 0.5, 0.0)), (f"b{n - 1}", (0, 0, -0.3)), damping=0.7)
    return s


@pytest.fixture()
def fast_switching():
    """Make the interpreter switch threads every microsecond, so that calls interleave between Pinocchio
    calls (with the default 5 ms they would mostly run one after the other)."""
    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(old)


def _work(system, q, v):
    lin = system.linearize(q, v=v, method="analytic")
    return (lin.M, lin.C, lin.K, system.accelerations(q, v), system.generalized_forces(q, v),
            system.energy(q, v).total, system.point_position("b5", (0, 0, -0.3), q))


def test_threads_linearising_one_system_give_the_serial_results(fast_switching):
    system = sprung_chain().build()
    rng = np.random.default_rng(7)
    states = [(system.random_configuration(0.5, rng), rng.standard_normal(system.nv)) for _ in range(24)]
    serial = [_work(system, q, v) for q, v in states]
    with ThreadPoolExecutor(4) as pool:
        threaded = list(pool.map(lambda s: _work(system, *s), states))
    for i, (a, b) in enumerate(zip(serial, threaded)):
        for x, y in zip(a, b):
            assert np.array_equal(x, y), f"state {i}: a thread's result differs from the serial one"


def test_threads_simulating_one_system_give_the_serial_trajectory(fast_switching):
    system = sprung_chain(4).build()
    q0 = system.configuration(np.full(system.nv, 0.2))
    runs = [(q0, np.full(system.nv, s)) for s in (0.0, 0.5, -0.5, 1.0)]
    serial = [system.simulate(1.0, q, v, t_eval=[1.0]).q[-1] for q, v in runs]
    with ThreadPoolExecutor(4) as pool:
        threaded = list(pool.map(lambda r: system.simulate(1.0, *r, t_eval=[1.0]).q[-1], runs))
    for a, b in zip(serial, threaded):
        assert np.array_equal(a, b)


def test_each_thread_has_its_own_workspace_and_the_system_is_frozen():
    system = sprung_chain(3).build()
    here = system.workspace()
    with ThreadPoolExecutor(1) as pool:
        there = pool.submit(system.workspace).result()
    assert here is system.workspace() and there is not here and there.data is not here.data
    with pytest.raises(AttributeError, match="immutable"):
        system.nv = 3
    with pytest.raises(TypeError):
        system.body_infos["b0"] = None
    with pytest.raises(ValueError):
        system.inertia_scales[0] = 0.0


def test_workspace_views_follow_the_data_and_stale_copies_are_refused():
    """Point forces read joint poses through live views of Pinocchio's Data: they must follow every forward
    kinematics (else every point force would be silently stale), and a binding handing out copies is refused."""
    import pinocchio as pin

    from vibdyn.model.workspace import Workspace, check_views

    s = vd.Scene("arm")
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_body("arm", "cart", vd.Pivot((0, 1, 0)), mass=1.0, com=(0, 0, -0.5))
    system = s.build()
    ws = Workspace(system.model)
    q = system.integrate(system.neutral(), [0.4, 0.9])
    pin.forwardKinematics(system.model, ws.data, q)
    np.testing.assert_array_equal(ws.translations[1], [0.4, 0.0, 0.0])
    np.testing.assert_allclose(ws.rotations[2], pin.exp3(np.array([0.0, 0.9, 0.0])), atol=1e-15)
    ws.translations[2] = ws.translations[2].copy()  # what a copying binding would give
    with pytest.raises(vd.ModelError, match="copies"):
        check_views(system.model, ws)
