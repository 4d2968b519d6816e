"""MuJoCo as an independent oracle for the rigid-body dynamics of vibdyn scenes.

The same scene is written as MJCF (tests/oracles.py) and compared at random states: the mass matrix
(CRBA vs ``mj_fullM``), the bias b(q, v) = C v + g (vibdyn's ``inverse_dynamics(q, v, 0)`` on a scene with
no force elements vs ``qfrc_bias``) and the body placements. MuJoCo's free joint uses world linear
velocity, Pinocchio's a body one: the oracle maps M and b through v_mj = T v_pin.

Tolerances: direct evaluations (CRBA, RNEA, ABA, kinematics, energies, parsed numbers) carry no error
estimate; their error is round-off, a few ε × the size of the terms (× κ(M) where M is solved). Fixed
1e-15..1e-12 relative (≈ 4.5–4500 ε) bound it on these small, well-conditioned models; 1e-10 where M is
solved or another engine's arithmetic is compared. Results that carry an estimate are checked against it.
"""

import numpy as np
import pytest
from oracles import MuJoCoOracle, assert_close, random_chain, random_inertia, rel_error, scene_to_mjcf, with_min_inertia

import vibdyn as vd

pytest.importorskip("mujoco")

TOL = 1e-10


def _compare(scene, rng, n_states=4, scale=1.0, what=""):
    system = scene.build()
    oracle = MuJoCoOracle(scene, system)
    worst = (0.0, 0.0)
    for _ in range(n_states):
        q = system.random_configuration(scale, rng)
        v = 2.0 * rng.standard_normal(system.nv)
        M = system.mass_matrix(q)
        b = system.inverse_dynamics(q, v, np.zeros(system.nv))
        M_mj, b_mj = oracle.dynamics(q, v)
        e1 = assert_close(M, M_mj, TOL, what=f"{what} M")
        # scale for b: gravity and velocity terms may cancel; compare with the size of their parts
        g = system.inverse_dynamics(q, np.zeros(system.nv), np.zeros(system.nv))
        e2 = assert_close(b, b_mj, TOL, scale=max(np.abs(g).max(), np.abs(b - g).max()), what=f"{what} bias")
        # placements of every body frame (MuJoCo xpos) against vibdyn's body_pose
        pos = oracle.positions()
        for name in system.bodies:
            assert_close(system.body_pose(name, q)[1], pos[name], TOL, scale=1.0, what=f"{what} {name} origin")
        worst = (max(worst[0], e1), max(worst[1], e2))
    return worst


@pytest.mark.parametrize("n", [3, 10])
def test_pivot_slider_chain(n):
    rng = np.random.default_rng(100 + n)
    for trial in range(3):
        _compare(random_chain(rng, n, ("pivot", "slider")), rng, what=f"pivot/slider n={n}")


@pytest.mark.parametrize("n", [3, 10])
def test_pivot_chain(n):
    rng = np.random.default_rng(200 + n)
    _compare(random_chain(rng, n, ("pivot",), gravity=(1.0, -9.0, 2.5)), rng, what=f"pivot n={n}")


@pytest.mark.parametrize("n", [3, 8])
def test_ball_chain(n):
    rng = np.random.default_rng(300 + n)
    _compare(random_chain(rng, n, ("ball",)), rng, what=f"ball n={n}")
    _compare(random_chain(rng, n, ("ball", "pivot", "slider", "fixed")), rng, what=f"mixed n={n}")


def test_free_body_chain():
    """A free root body (its velocity convention converted) carrying a chain of mixed joints."""
    rng = np.random.default_rng(400)
    for _ in range(2):
        scene = random_chain(rng, 6, ("ball", "pivot", "slider"), first="free", gravity=(0.5, 0.3, -9.81))
        _compare(scene, rng, what="free chain")


def test_branched_tree():
    """A tree whose bodies are added in a non-depth-first order (b2 hangs from b0 after b1 from b0, b3 from
    b1...). Pinocchio's CRBA needs each subtree's coordinates contiguous; vibdyn must order the joints
    depth-first whatever the order of ``add_body``."""
    rng = np.random.default_rng(410)
    for first in (None, "free"):
        scene = random_chain(rng, 7, ("ball", "pivot", "slider"), first=first, parents=[-1, 0, 0, 1, 2, 1, 3],
                             gravity=(0.5, 0.3, -9.81))
        _compare(scene, rng, what=f"tree root={first}")


def test_cylindrical_universal():
    """Composite joints: cylindrical = slide + hinge on one axis, universal = hinge about axis1 then axis2."""
    rng = np.random.default_rng(500)
    _compare(random_chain(rng, 6, ("cylindrical", "universal", "pivot")), rng, what="cyl/univ")


def test_planar_joints():
    """Planar joints (SE(2): body-axis in-plane velocity) on oblique normals, carrying other joints."""
    rng = np.random.default_rng(550)
    s = vd.Scene("planar", gravity=(1.0, 2.0, -9.81))
    s.add_body("p", joint=vd.Planar((0.3, -0.5, 1.0), at=(0.1, 0.2, 0.3), rotation=(0.3, 0.2, -0.4)), mass=1.3,
               com=(0.1, -0.2, 0.05), inertia=random_inertia(rng, 1.3))
    s.add_body("h", "p", vd.Pivot((0.2, 1.0, 0.1), at=(0.3, 0.0, -0.2)), mass=0.8, com=(0.0, 0.1, -0.3),
               inertia=random_inertia(rng, 0.8))
    s.add_body("q", "h", vd.Planar((1.0, 0.0, 0.0), at=(0.0, 0.2, -0.5)), mass=0.5, com=(0.05, 0.0, 0.1),
               inertia=random_inertia(rng, 0.5))
    _compare(s, rng, what="planar")


def test_point_masses_double_pendulum():
    """Point masses (zero inertia) need the tiny MuJoCo inertia: give vibdyn the very same one."""
    s = vd.Scene("double", gravity=(0, 0, -9.81))
    s.add_body("m1", joint=vd.Pivot((0, 1, 0)), mass=1.3, com=(0, 0, -0.7))
    s.add_body("m2", "m1", vd.Pivot((0, 1, 0), at=(0, 0, -0.7)), mass=0.6, com=(0, 0, -1.1))
    s = with_min_inertia(s)
    assert np.array(s.bodies["m1"].inertia)[0, 0] == 1e-12
    _compare(s, np.random.default_rng(600), what="double pendulum")


def test_oracle_detects_a_different_model():
    """The comparison can fail: a 1e-6 change in one inertia or one axis is seen far above the tolerance."""
    rng = np.random.default_rng(700)
    scene = random_chain(rng, 4, ("pivot", "ball"))
    system = scene.build()
    q = system.random_configuration(1.0, rng)
    v = rng.standard_normal(system.nv)
    wrong = scene.copy()
    import dataclasses

    b = wrong.bodies["b2"]
    wrong.bodies["b2"] = dataclasses.replace(b, mass=b.mass * (1 + 1e-6))
    M_mj, b_mj = MuJoCoOracle(wrong, wrong.build()).dynamics(q, v)
    assert rel_error(system.mass_matrix(q), M_mj) > 100 * TOL
    assert rel_error(system.inverse_dynamics(q, v, 0 * v), b_mj) > 100 * TOL
    # a swapped velocity convention on a free joint is caught as well
    free = random_chain(rng, 2, ("pivot",), first="free")
    fs = free.build()
    oracle = MuJoCoOracle(free, fs)
    q = fs.random_configuration(1.0, rng)
    v = rng.standard_normal(fs.nv)
    T, _ = oracle.set_state(q, v)
    import mujoco

    mujoco.mj_forward(oracle.model, oracle.data)
    M = np.zeros((fs.nv, fs.nv))
    mujoco.mj_fullM(oracle.model, oracle.data, M)
    assert rel_error(fs.mass_matrix(q), M) > 1e-3  # without T the free-joint blocks differ


def test_mjcf_writer_refuses_what_it_cannot_model():
    s = vd.Scene("h", gravity=(0, 0, -9.81))
    s.add_body("screw", joint=vd.Helical((0, 0, 1), 0.01), mass=1.0, inertia=np.eye(3) * 0.1)
    with pytest.raises(ValueError, match="helical"):
        scene_to_mjcf(s)
    t = vd.Scene("s")
    t.add_body("a", joint=vd.Slider((1, 0, 0)), mass=1.0)
    t.add_spring("k", "a", ("world", (-1, 0, 0)), 10.0)
    with pytest.raises(ValueError, match="force elements"):
        scene_to_mjcf(t)
