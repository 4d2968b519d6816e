"""A thin System (issue 33, item 2): compilation, the mass-matrix policy and the operating-point choice live in
their own modules; the System forwards to them. Its scratch (the per-thread workspace) is invisible to its
results: a query made in the middle of another computation (from a user's force law), or between two others,
changes nothing they return."""

import pickle

import numpy as np
import pytest

import vibdyn as vd
from vibdyn.analysis.equilibrium import operating_point
from vibdyn.errors import ModelError
from vibdyn.model import geometry, inertia_check
from vibdyn.model.compile import BodyInfo, Compiled


def build(meddle):
    """A 3-link chain with a spring between points, a joint damper and a force law of the state on the last
    body; with ``meddle``, the law also asks the System for poses, point velocities, momenta, reactions and
    energies at another state each time it is evaluated."""
    s = vd.Scene("meddled", gravity=(0.0, 0.0, -9.81))
    parent = vd.WORLD
    for i, joint in enumerate((vd.Pivot((0, 1, 0)), vd.Slider((1, 0, 0)), vd.Pivot((1, 0, 0)))):
        s.add_body(f"b{i}", parent, joint, mass=1.0 + i, com=(0, 0, -0.2), inertia=vd.inertia.box(1.0, (0.1, 0.1, 0.4)))
        parent = f"b{i}"
    s.add_spring("k", (vd.WORLD, (0.3, 0.0, 0.1)), ("b2", (0.0, 0.0, -0.4)), 50.0, free_length=0.2)
    s.add_joint_damper("b1", 0.7)
    box = {}
    q_other, v_other = np.array([0.4, -0.1, 0.9]), np.array([1.0, -2.0, 0.5])

    def law(t, q, v):
        system = box.get("system")
        if meddle and system is not None and not box.get("busy"):
            box["busy"] = True  # (reactions and energies evaluate this law too)
            system.body_pose("b2", q_other)
            system.point_position("b1", (0.1, 0.2, 0.3), q_other)
            system.point_velocity("b2", (0.0, 0.1, 0.0), q_other, v_other)
            system.momentum_matrix(q_other, (1.0, 0.0, 0.0))
            system.reactions(q_other, v_other, np.zeros(3))
            system.energy(q_other, v_other)
            box["busy"] = False
        return (3.0 * q[0] + 0.2 * v[2], 0.0, -1.0 + q[1] ** 2)

    s.add_force("f", "b2", law, at=(0.0, 0.05, -0.3))
    box["system"] = system = s.build()
    return system


def results(system):
    q, v, a = np.array([0.3, 0.05, -0.4]), np.array([0.2, -0.3, 0.6]), np.array([1.0, 0.5, -0.2])
    lin = system.linearize(q, v=v, method="analytic")
    fd = system.linearize(q, v=v)
    r = system.reactions(q, v, a)
    e = system.energy(q, v)
    return [system.accelerations(q, v), system.generalized_forces(q, v), system.inverse_dynamics(q, v, a),
            lin.K, lin.C, fd.K, fd.C, r.force, r.moment, np.array([e.kinetic, e.gravity, e.elastic]),
            *system.body_pose("b2", q), system.point_velocity("b2", (0.1, 0, 0), q, v), *system.momentum_matrix(q)]


def test_queries_made_inside_a_force_law_change_no_result():
    """The law asks for poses, velocities, momenta, reactions and energies at another state while the
    accelerations, forces, reactions, energies and both linearisations evaluate it: every result is the one
    the same law gives without asking."""
    quiet, meddled = results(build(False)), results(build(True))
    for x, y in zip(quiet, meddled):
        np.testing.assert_array_equal(x, y)


def flat(x):
    return np.concatenate([np.ravel(y) for y in x]) if isinstance(x, tuple) else np.ravel(x)


def test_two_queries_interleaved_give_what_each_gives_alone():
    system = build(False)
    q1, q2 = np.array([0.3, 0.05, -0.4]), np.array([-1.0, 0.2, 0.7])
    v1 = np.array([0.2, -0.3, 0.6])
    queries = [lambda s: s.body_pose("b2", q1), lambda s: s.point_velocity("b1", (0.1, 0, 0), q2, v1),
               lambda s: s.momentum_matrix(q1), lambda s: s.reactions(q2, v1, np.zeros(3)).force,
               lambda s: s.point_position("b0", (0, 0, -0.2), q2), lambda s: s.accelerations(q1, v1)]
    alone = [flat(f(build(False))) for f in queries]
    forwards = [flat(f(system)) for f in queries]
    backwards = [flat(f(system)) for f in queries[::-1]][::-1]
    for a, b, c in zip(alone, forwards, backwards):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, c)


def test_the_geometry_takes_a_workspace_explicitly():
    """As Pinocchio passes Data: the free functions compute in the workspace they are given."""
    system = build(False)
    ws = system.new_workspace()
    q, v = np.array([0.3, 0.05, -0.4]), np.array([0.2, -0.3, 0.6])
    M = geometry.body_pose(system, ws, system.body_info("b2"), q)
    R, p = system.body_pose("b2", q)
    np.testing.assert_array_equal(M.rotation, R)
    np.testing.assert_array_equal(M.translation, p)
    np.testing.assert_array_equal(
        geometry.point_velocity(system, ws, system.body_info("b1"), np.array([0.1, 0, 0]), q, v),
        system.point_velocity("b1", (0.1, 0, 0), q, v))
    for x, y in zip(geometry.momentum_matrix(system, ws, q, np.zeros(3)), system.momentum_matrix(q)):
        np.testing.assert_array_equal(x, y)


def test_the_system_forwards_to_the_layers_that_own_the_work():
    system = build(False)
    assert isinstance(system, Compiled) and isinstance(system.body_info("b0"), BodyInfo)
    assert system.lower_limits.shape == (3,) and not system.lower_limits.flags.writeable
    np.testing.assert_array_equal(system.operating_point().q, operating_point(system).q)
    inertia_check.check_mass_matrix(system, system.neutral(), "neutral")
    with pytest.raises(ModelError, match="singular mass matrix at here: body 'b1'"):
        M = system.mass_matrix(system.neutral())
        M[1, :] = M[:, 1] = 0.0
        system.check_mass_matrix(system.neutral(), "here", M)
    scene = vd.Scene("plain")
    scene.add_body("b", vd.WORLD, vd.Ball(), mass=1.0, com=(0, 0, -0.3), inertia=vd.inertia.box(1.0, (0.1, 0.1, 0.1)))
    plain = scene.build()
    copy = pickle.loads(pickle.dumps(plain))
    q = plain.random_configuration(rng=1)
    np.testing.assert_array_equal(copy.mass_matrix(q), plain.mass_matrix(q))
    assert copy.unit_blocks == plain.unit_blocks == (("b", 0, 4),)
