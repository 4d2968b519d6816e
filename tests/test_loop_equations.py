"""The loops' equations have three writings: the hot path (Φ and Φ_q row by row), the one with the wrench
coefficients (Φ_q = C_a J_a + C_b J_b, for the loop forces) and the batched one of the assembly's restarts (many
configurations at once, the ends' Jacobians from the joints' local ones). They agree to round-off for every kind
of loop joint, between two bodies and with the world, at random configurations."""

import numpy as np
import pytest

import vibdyn as vd
from vibdyn.description.elements import WORLD
from vibdyn.model.loop_batch import LoopBatch

EPS = np.finfo(float).eps
I3 = np.diag([1e-3, 2e-3, 3e-3])
JOINTS = {"pivot": lambda: vd.Pivot((0, 0, 1)), "slider": lambda: vd.Slider((1, 0, 0)),
          "cylindrical": lambda: vd.Cylindrical((0, 1, 0)), "universal": lambda: vd.Universal((1, 0, 0), (0, 1, 0)),
          "ball": lambda: vd.Ball(), "fixed": lambda: vd.Fixed()}


@pytest.mark.parametrize("world", [False, True])
@pytest.mark.parametrize("kind", list(JOINTS))
def test_the_loop_equations_hot_path_equals_the_wrench_form(kind, world):
    s = vd.Scene("loops", gravity=(0, -9.81, 0))
    s.add_body("a", joint=vd.Free(), mass=1.0, inertia=I3)
    s.add_body("b", joint=vd.Free(), mass=1.0, inertia=I3)
    s.add_body("c", parent="b", joint=vd.Pivot((0, 1, 0), at=(0.1, 0, 0)), mass=1.0, inertia=I3)
    other = (WORLD, (0.1, 0.2, 0.3)) if world else ("a", (0.1, 0.2, 0.3))
    s.add_loop("L", ("c", (0.2, 0, 0.1)), other, joint=JOINTS[kind]())
    if not world:
        s.add_loop("M", ("a", (0.0, 0.1, 0.0)), ("b", (0.1, 0, 0.1)), joint=vd.Pivot((1, 0, 0)))
    s.set_operating_point(start={})
    system = s.build()
    c = system.constraints
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = system.integrate(system.neutral(), rng.standard_normal(system.nv))
        phi, J = c.evaluate(q)
        phi_w, J_w, _ = c.evaluate(q, wrenches=True)
        assert np.abs(phi - phi_w).max() <= 1e-15 * max(1.0, np.abs(phi_w).max())
        assert np.abs(c.evaluate(q, jacobian=False)[0] - phi_w).max() <= 1e-15 * max(1.0, np.abs(phi_w).max())
        assert np.abs(J - J_w).max() <= 1e-15 * max(1.0, np.abs(J_w).max())
        # some loops only: their rows of the whole, in the order asked
        ends = np.cumsum((0,) + c.sizes)
        for loops in ([1, 0], [0]) if not world else ([0],):
            rows = np.concatenate([np.arange(ends[i], ends[i + 1]) for i in loops])
            phi_l, J_l = c.evaluate(q, loops=loops)
            assert np.array_equal(phi_l, phi[rows]) and np.array_equal(J_l, J[rows])
        # batched, this configuration among others: each one's rows (round-off of some 50 operations)
        Q = np.array([system.integrate(q, rng.standard_normal(system.nv)), q])
        for loops in ([1, 0], [0], [1]) if not world else ([0],):
            phi_b, J_b = LoopBatch(c, loops).evaluate(Q)
            for k in range(len(Q)):
                phi_k, J_k = c.evaluate(Q[k], loops=loops)
                assert np.abs(phi_b[k] - phi_k).max() <= 50 * EPS * max(1.0, np.abs(phi_k).max())
                assert np.abs(J_b[k] - J_k).max() <= 50 * EPS * max(1.0, np.abs(J_k).max())
