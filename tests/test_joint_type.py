"""A joint type is one class (issue 23): everything vibdyn asks of a joint — its coordinates and q, chart,
spring law, markers, scene-file name — is declared on it, so a new type defined here, in this test file
alone, works in every analysis, simulation, picture and scene file."""

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import pytest

import vibdyn as vd
from vibdyn.description.joints import Joint, joint_type

G = 9.81


@joint_type
@dataclass(frozen=True, eq=False)
class TurnZ(Joint):
    """A rotation about the joint frame's z axis only (rad): a planar mechanism's hinge, as a new type."""

    type = "turn_z"
    suffixes = ("",)
    units = ("rad",)
    periodic = (True,)
    _positional = ()

    def pin_model(self):
        return pin.JointModelRZ()

    def markers(self):
        return [("cylinder", (0.0, 0.0, 1.0))]


def pendulum():
    """A 1 kg point 0.5 m from a TurnZ hinge, gravity −y, held by a torsion spring 2 N·m/rad."""
    s = vd.Scene("turn", gravity=(0, -G, 0))
    s.add_body("arm", joint=TurnZ(), mass=1.0, com=(0.0, -0.5, 0.0))
    s.add_joint_spring("arm", 2.0)
    return s


def test_a_joint_type_defined_in_this_file_works_everywhere(tmp_path):
    scene = pendulum()
    system = scene.build()
    assert system.coordinates == ("arm",) and system.nq == system.nv == 1
    # modes: ω² = (k + m g l) / (m l²), the textbook's hanging pendulum with a torsion spring
    m = system.operating_point().linearize().modes()
    assert m.omega[0] == pytest.approx(math.sqrt((2.0 + G * 0.5) / 0.25), rel=10 * m.relative_error + 1e-9)
    # simulation with an event, and its names
    traj = system.simulate(2.0, [0.3], [0.0], events=lambda t, q, v: q[0], t_eval=np.linspace(0, 2, 5))
    assert len(traj.t_events[0]) >= 2 and traj.error < 1e-6
    from vibdyn.simulation.simulate import q_names

    assert q_names(system) == ["arm"]
    # the scene file knows its name, and reads it back
    scene.save(tmp_path / "turn.toml")
    assert 'type = "turn_z"' in (tmp_path / "turn.toml").read_text()
    back = vd.load_scene(tmp_path / "turn.toml").build()
    assert back.operating_point().linearize().modes().omega == pytest.approx(m.omega, rel=1e-12)
    # the viewer marks it with its own marker
    from vibdyn.faces.viewer.drawing import drawing

    d = drawing(system, system.neutral())
    assert any(i.name == "joint" and i.node == "bodies/arm" for i in d.items)
    vd.export_html(m, tmp_path / "turn.html")
    assert (tmp_path / "turn.html").stat().st_size > 1000


def test_the_declarations_the_library_reads_are_on_the_joint_classes():
    """The curved joints carry their q's unit block, chart rotations and group; scalar joints say so."""
    assert vd.Ball().unit_block == (0, 4) and vd.Free().unit_block == (3, 4) and vd.Planar().unit_block == (2, 2)
    assert vd.Ball().chart_rotations == (0, 1, 2) and vd.Free().lie_group == "SE3" and vd.Planar().lie_group == "SE2"
    assert vd.Ball().nq == 4 and vd.Free().nq == 7 and vd.Planar().nq == 4 and vd.Universal().nq == 2
    assert [j.scalar for j in (vd.Pivot(), vd.Slider(), vd.Helical(), vd.Cylindrical(), vd.Ball())] == \
        [True, True, True, False, False]
    assert TurnZ().scalar and TurnZ().nq == 1


@joint_type
@dataclass(frozen=True, eq=False)
class HingeZ(TurnZ):
    """TurnZ that can also close a loop: its rows, declared here alone, are the points' coincidence and the
    two alignments of z axes."""

    type = "hinge_z"
    loop_rows = ("position", "aligned")

    def loop_alignments(self):
        z = np.array([0.0, 0.0, 1.0])
        return [(np.array([1.0, 0.0, 0.0]), z), (np.array([0.0, 1.0, 0.0]), z)]


def test_a_joint_type_defined_here_closes_a_loop():
    """A parallelogram (two arms of length l hinged 1 m apart, point masses m at their tips, a coupler of mass
    M joining the tips, closed by the new type): the coupler translates on a circle of radius l, so the kinetic
    energy is ½(2m + M) l² θ̇² and the potential −(2m + M) g l cos θ: ω = √(g/l) whatever m and M."""
    l, m, M = 0.8, 0.5, 3.0
    s = vd.Scene("parallelogram", gravity=(0, -G, 0))
    s.add_body("arm1", joint=TurnZ(), mass=m, com=(0.0, -l, 0.0))
    s.add_body("arm2", joint=TurnZ(at=(1.0, 0.0, 0.0)), mass=m, com=(0.0, -l, 0.0))
    s.add_body("coupler", parent="arm1", joint=TurnZ(at=(0.0, -l, 0.0)), mass=M, com=(0.5, 0.0, 0.0),
               inertia=vd.inertia.rod(M, 1.0, axis=(1, 0, 0)))
    s.add_loop("tip", ("coupler", (1.0, 0.0, 0.0)), ("arm2", (0.0, -l, 0.0)), joint=HingeZ())
    assert HingeZ().loop_equations == 5 and TurnZ().loop_rows is None
    system = s.build()
    assert system.dof == 1
    eq = system.operating_point()
    modes = eq.linearize().modes()
    assert modes.omega[0] == pytest.approx(math.sqrt(G / l), rel=10 * modes.relative_error + 1e-8)
    with pytest.raises(vd.ModelError, match="turn_z joint cannot close a loop"):
        s.add_loop("again", ("coupler", (1.0, 0.0, 0.0)), ("arm2", (0.0, -l, 0.0)), joint=TurnZ())
