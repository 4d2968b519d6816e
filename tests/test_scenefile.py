"""TOML scene files: round trips, helper tables, body order, the writer, and errors naming file and key.

Tolerances: direct evaluations (CRBA, RNEA, ABA, kinematics, energies, parsed numbers) carry no error
estimate; their error is round-off, a few ε × the size of the terms (× κ(M) where M is solved). Fixed
1e-15..1e-12 relative (≈ 4.5–4500 ε) bound it on these small, well-conditioned models; 1e-10 where M is
solved or another engine's arithmetic is compared. Results that carry an estimate are checked against it.
"""

import math
import sys
import textwrap
import types
import warnings

import numpy as np
import pytest
import tomllib
from hypothesis import given, settings
from hypothesis import strategies as st

import vibdyn as vd
import vibdyn.io
from vibdyn.io.scenefile import load_scene, scene_from_dict
from vibdyn.io.scenewrite import dumps, save_scene, scene_to_dict


def write(tmp_path, text, name="scene.toml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text), encoding="utf-8")
    return p


def every_kind_scene():
    """A scene with every joint type and every element kind that a file can hold."""
    s = vd.Scene("everything", gravity=(0.3, -0.2, -9.81), source="tests", description='all "kinds", ünïcode')
    s.add_body("base", joint=vd.Slider((1, 0, 0), at=(0, 0, 0.1)), mass=3.0,
               inertia=vd.inertia.box(3.0, (0.4, 0.3, 0.2)))
    s.add_body("arm", "base", vd.Pivot((0, 1, 0), at=(0.1, 0, 0), rotation=(0.1, 0.2, 0.3), name="shoulder"),
               mass=1.5, com=(0.2, 0.0, -0.3), inertia_about=(0, 0, 0),
               inertia=vd.inertia.to_point(np.diag([0.03, 0.025, 0.02]) + 0.001, 1.5, (0.2, 0.0, -0.3)))
    s.add_body("screw", "shoulder", vd.Helical((0, 0, 1), 0.05, at=(0, 0, -0.6)), mass=0.8,
               inertia=vd.inertia.cylinder(0.8, 0.05, 0.2))
    s.add_body("sleeve", "screw", vd.Cylindrical((0.6, 0.8, 0), at=(0, 0, -0.1)), mass=0.6, com=(0.05, 0, 0),
               inertia=vd.inertia.disc(0.6, 0.1, (1, 0, 0)))
    s.add_body("cardan", "sleeve", vd.Universal((1, 0, 0), (0, 1, 0), at=(0, 0, -0.1)), mass=0.5,
               com=(0, 0, -0.2), inertia=vd.inertia.rod(0.5, 0.4))
    s.add_body("ball", "cardan", vd.Ball(at=(0, 0, -0.4)), mass=0.4, com=(0.1, 0, -0.1),
               inertia=vd.inertia.sphere(0.4, 0.05, hollow=True))
    s.add_body("weld", "ball", vd.Fixed(at=(0.1, 0.2, 0.0), rotation=np.eye(3)[[1, 2, 0]]), mass=0.5,
               com=(0, 0.1, 0), inertia=vd.inertia.box(0.5, (0.1, 0.2, 0.3)))
    s.add_body("puck", joint=vd.Planar((0, 0, 1), at=(2, 0, 0)), mass=1.0, inertia=vd.inertia.disc(1.0, 0.2))
    s.add_body("drone", joint=vd.Free(at=(0, 3, 1)), mass=2.0, inertia=np.diag([0.1, 0.2, 0.25]))
    s.add_body("point", "drone", mass=0.1, com=(0.1, 0, 0))  # welded point mass
    s.add_spring("s1", ("world", (-1, 0, 0.1)), "base", 50.0, free_length=0.8)
    s.add_spring("s2", ("arm", (0.2, 0, -0.3)), ("ball", (0, 0, -0.1)), 30.0)
    s.add_spring("s3", ("world", (2, 0, 1)), ("drone", (0.1, 0, 0)), 20.0, free_length=1.5)
    s.add_damper("d1", ("world", (-1, 0, 0.1)), "base", 2.0)
    s.add_damper("d2", "puck", ("drone", (0, 0, 0.1)), 0.5)
    s.add_joint_spring("shoulder", 12.0, rest=0.1)
    s.add_joint_spring("sleeve", [10.0, 2.0], name="sleeve_k")
    s.add_joint_spring("ball", [1.0, 2.0, 3.0], rest=[0.1, 0.0, -0.1])
    s.add_joint_damper("cardan", [0.1, 0.2])
    s.add_joint_damper("puck", 0.3)
    s.add_joint_force("base", 1.5)
    s.add_joint_force("screw", vd.laws.Polynomial((0.5, 0.0, -0.1)), name="motor")
    s.add_joint_force("shoulder", vd.laws.Harmonic(2.0, 3.0, phase=0.5, offset=0.1), name="shaker")
    s.add_joint_force("cardan", [0.2, -0.1], name="cardan_push")
    s.add_force("push", "drone", force=(1.0, 0.0, 2.0), at=(0.1, 0.1, 0), torque=(0, 0, 0.3), frame="body")
    s.add_force("wind", "puck", force=(0.0, 0.5, 0.0))
    s.references = {"note": 'a "quoted" note\nwith a newline, tab\t and ünïcode ω', "omega": [1.0, 2.5e-300, 1e300],
                    "count": 3, "flag": True, "matrix": [[1.0, 0.1], [0.1, 2.0]],
                    "nested": {"deeper": {"x": -0.0, "label": "a.b [c]"}, "list": [1, 2]},
                    "modes": [{"omega": 1.0, "shape": [1.0, -1.0]}, {"omega": 2.0, "shape": [1.0, 1.0]}],
                    "mixed": [1, "two", [3.0], {"four": 4}], "key with spaces": 0.1, "": "empty key"}
    return s


def same_dynamics(sa, sb, seed=0):
    a, b = sa.build(), sb.build()
    assert a.coordinates == b.coordinates
    rng = np.random.default_rng(seed)
    q = a.random_configuration(0.3, rng)
    v = rng.standard_normal(a.nv)
    np.testing.assert_array_equal(a.mass_matrix(q), b.mass_matrix(q))
    np.testing.assert_allclose(a.accelerations(q, v, 0.7), b.accelerations(q, v, 0.7), rtol=1e-13, atol=1e-13)


def test_round_trip_every_kind(tmp_path):
    s = every_kind_scene()
    path = tmp_path / "everything.toml"
    save_scene(s, path)
    t = load_scene(path)
    assert scene_to_dict(t) == scene_to_dict(s)  # bit for bit: floats are written with repr
    assert t.references == s.references
    assert (t.name, t.gravity, t.source, t.description) == (s.name, s.gravity, s.source, s.description)
    assert list(t.bodies) == list(s.bodies)
    assert sorted(t.elements) == sorted(s.elements)
    for name, e in s.elements.items():
        assert t.elements[name].to_dict() == e.to_dict()
    same_dynamics(s, t)
    # the Scene methods go through the same functions
    s.save(tmp_path / "again.toml")
    assert (tmp_path / "again.toml").read_text(encoding="utf-8") == path.read_text(encoding="utf-8")
    assert s.to_dict() == scene_to_dict(s)
    assert scene_to_dict(vd.load_scene(str(path))) == scene_to_dict(s)


def test_round_trip_of_an_axis_is_bit_exact(tmp_path):
    s = vd.Scene("axis")
    s.add_body("b", joint=vd.Slider((1, 1, 0)), mass=1.0)
    save_scene(s, tmp_path / "axis.toml")
    assert load_scene(tmp_path / "axis.toml").bodies["b"].joint.axis == s.bodies["b"].joint.axis


def test_round_trip_through_dict():
    s = every_kind_scene()
    t = scene_from_dict(scene_to_dict(s))
    assert scene_to_dict(t) == scene_to_dict(s)
    same_dynamics(s, t, seed=1)


def test_saved_file_is_readable_toml(tmp_path):
    s = every_kind_scene()
    save_scene(s, tmp_path / "x.toml")
    doc = tomllib.loads((tmp_path / "x.toml").read_text(encoding="utf-8"))
    assert set(doc) == {"scene", "body", "spring", "damper", "joint_spring", "joint_damper", "joint_force", "force",
                        "reference"}
    assert doc["body"][0] == {"name": "base", "mass": 3.0, "inertia": [list(r) for r in s.bodies["base"].inertia],
                              "joint": {"type": "slider", "axis": [1.0, 0.0, 0.0], "at": [0.0, 0.0, 0.1]}}
    assert doc["joint_force"][1] == {"name": "motor", "body": "screw", "law": "polynomial",
                                     "coefficients": [0.5, 0.0, -0.1]}
    assert "parent" not in doc["body"][0] and doc["body"][1]["parent"] == "base"


def test_callables_cannot_be_saved(tmp_path):
    s = vd.Scene("c")
    s.add_body("b", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_joint_force("b", lambda t, q, v: -q)
    with pytest.raises(vd.ModelError, match="callable"):
        save_scene(s, tmp_path / "c.toml")
    s2 = vd.Scene("c2")
    s2.add_body("b", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s2.add_force("f", "b", force=lambda t, q, v: (0, 0, 1))
    with pytest.raises(vd.ModelError, match="callable"):
        s2.save(tmp_path / "c2.toml")


def test_inertia_helper_tables(tmp_path):
    p = write(tmp_path, """
        [[body]]
        name = "rod"
        mass = 2.0
        inertia = { shape = "rod", length = 1.5, axis = [1, 0, 0] }
        joint = { type = "pivot", axis = [0, 1, 0] }
        [[body]]
        name = "box"
        mass = 3.0
        inertia = { shape = "box", size = [0.1, 0.2, 0.3] }
        joint = { type = "slider", axis = [1, 0, 0] }
        [[body]]
        name = "cyl"
        mass = 4.0
        inertia = { shape = "cylinder", radius = 0.1, length = 0.5, axis = [0, 1, 0] }
        joint = { type = "pivot", axis = [0, 0, 1] }
        [[body]]
        name = "cyl_z"
        mass = 4.0
        inertia = { shape = "cylinder", radius = 0.1, length = 0.5 }
        joint = { type = "pivot", axis = [0, 0, 1] }
        [[body]]
        name = "disc"
        mass = 1.0
        inertia = { shape = "disc", radius = 0.3, axis = [0, 0, 1] }
        joint = { type = "pivot", axis = [0, 0, 1] }
        [[body]]
        name = "sphere"
        mass = 5.0
        inertia = { shape = "sphere", radius = 0.2 }
        joint = { type = "ball" }
        [[body]]
        name = "shell"
        mass = 5.0
        inertia = { shape = "sphere", radius = 0.2, hollow = true }
        joint = { type = "ball" }
        [[body]]
        name = "pt"
        mass = 1.0
        com = [0.0, 0.0, -1.0]
        inertia = { shape = "point" }
        joint = { type = "pivot", axis = [0, 1, 0] }
        [[body]]
        name = "about"
        mass = 2.0
        com = [0.0, 0.0, -0.5]
        inertia = [[0.6666666666666666, 0, 0], [0, 0.6666666666666666, 0], [0, 0, 0.01]]
        inertia_about = [0.0, 0.0, 0.0]
        joint = { type = "pivot", axis = [0, 1, 0] }
    """)
    s = load_scene(p)
    expect = {"rod": vd.inertia.rod(2.0, 1.5, (1, 0, 0)), "box": vd.inertia.box(3.0, (0.1, 0.2, 0.3)),
              "cyl": vd.inertia.cylinder(4.0, 0.1, 0.5, (0, 1, 0)), "cyl_z": vd.inertia.cylinder(4.0, 0.1, 0.5),
              "disc": vd.inertia.disc(1.0, 0.3), "sphere": vd.inertia.sphere(5.0, 0.2),
              "shell": vd.inertia.sphere(5.0, 0.2, hollow=True), "pt": np.zeros((3, 3)),
              "about": vd.inertia.to_com(np.diag([2 / 3, 2 / 3, 0.01]), 2.0, (0, 0, -0.5))}
    for name, I in expect.items():
        np.testing.assert_allclose(np.array(s.bodies[name].inertia), I, rtol=0, atol=1e-15, err_msg=name)
    np.testing.assert_allclose(np.array(s.bodies["about"].inertia), np.diag([1 / 6, 1 / 6, 0.01]), atol=1e-15)
    assert s.name == "scene"  # default: the file's stem


def test_joint_parameters(tmp_path):
    p = write(tmp_path, """
        [scene]
        name = "joints"
        [[body]]
        name = "nut"
        mass = 1.0
        inertia = [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]
        joint = { type = "helical", axis = [0, 0, 2], lead = 0.01, at = [1, 2, 3], name = "screw", \
                  rotation = [0, 0, 1.5707963267948966] }
        [[body]]
        name = "tip"
        parent = "screw"
        mass = 1.0
        joint = { type = "slider", axis = [0, 1, 0], rotation = [[1, 0, 0], [0, 0, -1], [0, 1, 0]] }
    """)
    s = load_scene(p)
    j = s.bodies["nut"].joint
    assert isinstance(j, vd.Helical) and j.name == "screw"
    assert j.pitch == pytest.approx(0.01 / (2 * math.pi), rel=1e-15)
    assert j.axis == (0.0, 0.0, 1.0) and j.at == (1.0, 2.0, 3.0)
    np.testing.assert_allclose(np.array(j.rotation), [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    assert s.bodies["tip"].parent == "nut"  # a parent named by its joint's name
    np.testing.assert_array_equal(np.array(s.bodies["tip"].joint.rotation), [[1, 0, 0], [0, 0, -1], [0, 1, 0]])


def test_bodies_in_any_order(tmp_path):
    body = """
        [[body]]
        name = "{name}"
        parent = "{parent}"
        mass = 1.0
        com = [0.0, 0.0, -1.0]
        joint = {{ type = "pivot", axis = [0, 1, 0], at = [0.0, 0.0, {at}] }}
    """
    chain = [("a", "world", 0.0), ("b", "a", -1.0), ("c", "b", -1.0), ("d", "b", -0.5)]
    ordered = "[scene]\ngravity = [0, 0, -9.81]\n" + "".join(
        textwrap.dedent(body.format(name=n, parent=p, at=a)) for n, p, a in chain)
    shuffled = "[scene]\ngravity = [0, 0, -9.81]\n" + "".join(
        textwrap.dedent(body.format(name=n, parent=p, at=a)) for n, p, a in [chain[3], chain[2], chain[0], chain[1]])
    sa, sb = load_scene(write(tmp_path, ordered, "a.toml")), load_scene(write(tmp_path, shuffled, "b.toml"))
    assert {n: b.parent for n, b in sb.bodies.items()} == {"a": "world", "b": "a", "c": "b", "d": "b"}
    order = list(sb.bodies)
    assert order.index("a") < order.index("b") < min(order.index("c"), order.index("d"))
    sb.name = sa.name
    sys_a, sys_b = sa.build(), sb.build()
    q = sys_a.random_configuration(0.5, 3)
    qb = np.array([q[sys_a.coordinate_index(c)] for c in sys_b.coordinates])
    Ma, Mb = sys_a.mass_matrix(q), sys_b.mass_matrix(qb)
    perm = [sys_a.coordinate_index(c) for c in sys_b.coordinates]
    np.testing.assert_allclose(Mb, Ma[np.ix_(perm, perm)], atol=1e-14)


def test_relative_coordinates_and_elements_on_joint_names(tmp_path):
    p = write(tmp_path, """
        [[body]]
        name = "cart"
        mass = 2.0
        joint = { type = "slider", axis = [1, 0, 0], name = "rail" }
        [[joint_spring]]
        body = "rail"
        stiffness = 8.0
        rest = 0.25
        [[joint_force]]
        body = "cart"
        law = "harmonic"
        amplitude = 1.0
        omega = 2.0
    """)
    s = load_scene(p)
    sys_ = s.build()
    np.testing.assert_allclose(sys_.accelerations([0.25], [0.0], 0.0), [0.0], atol=1e-15)
    np.testing.assert_allclose(sys_.accelerations([0.0], [0.0], 0.0), [1.0], atol=1e-15)  # 8 * 0.25 / 2
    f = s.elements["cart.force"].value
    assert isinstance(f, vd.laws.Harmonic) and (f.phase, f.offset) == (0.0, 0.0)


def test_robot_table(tmp_path, monkeypatch):
    calls = []

    def fake_scene(name):
        sc = vd.Scene(name, gravity=(0, 0, -9.81))
        sc.add_body("link1", joint=vd.Pivot((0, 0, 1), name="j1"), mass=1.0, com=(0.5, 0, 0),
                    inertia=vd.inertia.rod(1.0, 1.0, (1, 0, 0)))
        return sc

    def load_robot(name, floating=None):
        calls.append(("robot", name, floating))
        return fake_scene(name)

    def load_urdf(path, floating=False, package_dirs=None):
        calls.append(("urdf", path, floating, package_dirs))
        return fake_scene("from_urdf")

    fake = types.SimpleNamespace(load_robot=load_robot, load_urdf=load_urdf)
    monkeypatch.setitem(sys.modules, "vibdyn.io.robots", fake)
    monkeypatch.setattr(vibdyn.io, "robots", fake, raising=False)
    (tmp_path / "urdf").mkdir()
    (tmp_path / "urdf" / "arm.urdf").write_text("<robot name='arm'/>")
    p = write(tmp_path, """
        [scene]
        name = "arm_with_tool"
        gravity = [0.0, -9.81, 0.0]
        [robot]
        urdf = "urdf/arm.urdf"
        floating = true
        package_dirs = ["meshes"]
        [[body]]
        name = "tool"
        parent = "j1"
        mass = 0.5
        joint = { type = "slider", axis = [1, 0, 0], at = [1.0, 0, 0] }
        [[spring]]
        name = "tool_spring"
        a = "link1"
        b = ["tool", [0.1, 0, 0]]
        stiffness = 10.0
    """)
    s = load_scene(p)
    assert calls == [("urdf", str(tmp_path / "urdf" / "arm.urdf"), True, [str(tmp_path / "meshes")])]
    assert s.name == "arm_with_tool" and s.gravity == (0.0, -9.81, 0.0)
    assert list(s.bodies) == ["link1", "tool"] and s.bodies["tool"].parent == "link1"
    assert s.build().nv == 2
    p2 = write(tmp_path, '[robot]\nname = "ur5"\n', "r.toml")
    s2 = load_scene(p2)
    assert calls[-1] == ("robot", "ur5", None) and s2.name == "ur5" and s2.gravity == (0.0, 0.0, -9.81)
    # saved with the robot's bodies spelled out
    save_scene(s, tmp_path / "saved.toml")
    assert scene_to_dict(load_scene(tmp_path / "saved.toml")) == scene_to_dict(s)
    with pytest.raises(vd.SceneFileError, match="either name") as e:
        load_scene(write(tmp_path, '[robot]\nname = "ur5"\nurdf = "x.urdf"\n', "both.toml"))
    assert e.value.key == "robot"
    with pytest.raises(vd.SceneFileError, match="no such URDF") as e:
        load_scene(write(tmp_path, '[robot]\nurdf = "missing.urdf"\n', "missing.toml"))
    assert e.value.key == "robot.urdf" and "missing.toml" in str(e.value)


# ------------------------------------------------------------------ errors

BODY = """
[[body]]
name = "b"
mass = 1.0
joint = { type = "slider", axis = [1, 0, 0] }
"""

ERRORS = [
    # (case id, file text, key, a piece of the message)
    ("syntax", "[scene]\nname = \n", None, "line 2"),
    ("syntax_bracket", BODY + "[[spring]\n", None, "TOML syntax error"),
    ("unknown_table", "[bodies]\nx = 1\n", "bodies", "unknown table 'bodies'"),
    ("table_not_array", '[body]\nname = "b"\nmass = 1.0\n', "body", "array of tables"),
    ("unknown_scene_key", '[scene]\nnmae = "x"\n', "scene.nmae", "unknown key 'nmae'"),
    ("unknown_body_key", BODY.replace("mass = 1.0", "mass = 1.0\nmasss = 2.0"), "body[0].masss", "unknown key"),
    ("missing_mass", BODY.replace("mass = 1.0\n", ""), "body[0].mass", "missing required key 'mass'"),
    ("missing_name", BODY.replace('name = "b"\n', ""), "body[0].name", "missing required key 'name'"),
    ("mass_bool", BODY.replace("mass = 1.0", "mass = true"), "body[0].mass", "expected a number"),
    ("negative_mass", BODY.replace("mass = 1.0", "mass = -1.0"), "body[0].mass", "must not be negative"),
    ("nan_mass", BODY.replace("mass = 1.0", "mass = nan"), "body[0].mass", "finite"),
    ("bad_joint_type", BODY.replace('"slider"', '"hinge"'), "body[0].joint.type", "unknown joint type 'hinge'"),
    ("missing_joint_type", BODY.replace('type = "slider", ', ""), "body[0].joint.type", "missing required key"),
    ("missing_axis", BODY.replace(', axis = [1, 0, 0]', ""), "body[0].joint.axis", "missing required key 'axis'"),
    ("axis_wrong_type", BODY.replace("[1, 0, 0]", '"x"'), "body[0].joint.axis", "expected 3 numbers"),
    ("axis_wrong_length", BODY.replace("[1, 0, 0]", "[1, 0]"), "body[0].joint.axis", "expected 3 numbers"),
    ("axis_zero", BODY.replace("[1, 0, 0]", "[0, 0, 0]"), "body[0].joint", "zero length"),
    ("joint_param_of_other_type", BODY.replace("axis = [1, 0, 0]", "axis = [1, 0, 0], normal = [0, 0, 1]"),
     "body[0].joint.normal", "unknown key 'normal'"),
    ("helical_pitch_and_lead", BODY.replace('"slider", axis = [1, 0, 0]',
                                            '"helical", axis = [0, 0, 1], pitch = 0.1, lead = 0.5'),
     "body[0].joint.pitch", "either pitch"),
    ("bad_rotation", BODY.replace("axis = [1, 0, 0]", "axis = [1, 0, 0], rotation = [[1, 0, 0], [0, 1, 0], [0, 0, 2]]"),
     "body[0].joint", "not a rotation matrix"),
    ("unknown_parent", BODY + BODY.replace('"b"', '"c"').replace("mass = 1.0", 'parent = "nobody"\nmass = 1.0'),
     "body[1].parent", "body 'c': unknown parent 'nobody'"),
    ("cycle", BODY.replace("mass = 1.0", 'parent = "c"\nmass = 1.0')
     + BODY.replace('"b"', '"c"').replace("mass = 1.0", 'parent = "b"\nmass = 1.0'), "body[0].parent", "cycle"),
    ("self_parent", BODY.replace("mass = 1.0", 'parent = "b"\nmass = 1.0'), "body[0].parent", "cycle"),
    ("duplicate_body", BODY + BODY, "body[1].name", "duplicate body name 'b'"),
    ("bad_inertia", BODY.replace("mass = 1.0", "mass = 1.0\ninertia = [[1, 0, 0], [0, 1, 0], [0, 0, 3]]"),
     "body[0]", "triangle inequality"),
    ("inertia_not_matrix", BODY.replace("mass = 1.0", "mass = 1.0\ninertia = [1, 2, 3]"), "body[0].inertia",
     "3×3 matrix"),
    ("unknown_shape", BODY.replace("mass = 1.0", 'mass = 1.0\ninertia = { shape = "cone", radius = 1 }'),
     "body[0].inertia.shape", "unknown inertia shape 'cone'"),
    ("shape_missing_param", BODY.replace("mass = 1.0", 'mass = 1.0\ninertia = { shape = "rod" }'),
     "body[0].inertia.length", "missing required key 'length'"),
    ("helper_with_about", BODY.replace("mass = 1.0", 'mass = 1.0\ninertia = { shape = "point" }\n'
                                                     'inertia_about = [0, 0, 0]'), "body[0].inertia_about",
     "inertia_about"),
    ("gravity_wrong", '[scene]\ngravity = [0, -9.81]\n', "scene.gravity", "expected 3 numbers"),
    ("scene_name_empty", '[scene]\nname = ""\n', "scene.name", "non-empty"),
    ("negative_stiffness", BODY + '[[spring]]\nname = "k"\na = "world"\nb = ["b", [1, 0, 0]]\nstiffness = -5.0\n',
     "spring[0].stiffness", "must not be negative"),
    ("spring_missing_b", BODY + '[[spring]]\nname = "k"\na = "world"\nstiffness = 5.0\n', "spring[0].b",
     "missing required key 'b'"),
    ("spring_bad_attachment", BODY + '[[spring]]\nname = "k"\na = ["world", [0, 0]]\nb = "b"\nstiffness = 5.0\n',
     "spring[0].a", "expected \"body\" or"),
    ("spring_unknown_body", BODY + '[[spring]]\nname = "k"\na = "world"\nb = ["nobody", [1, 0, 0]]\nstiffness = 5.0\n',
     "spring[0]", "unknown body 'nobody'"),
    ("duplicate_element", BODY + '[[damper]]\nname = "b"\na = ["world", [-1, 0, 0]]\nb = "b"\ndamping = 1.0\n',
     "damper[0]", "duplicate name 'b'"),
    ("joint_spring_wrong_count", BODY + '[[joint_spring]]\nbody = "b"\nstiffness = [1.0, 2.0]\n', "joint_spring[0]",
     "expected a number, got shape (2,)"),
    ("joint_damper_negative", BODY + '[[joint_damper]]\nbody = "b"\ndamping = [-1.0]\n', "joint_damper[0].damping",
     "joint damper on 'b': must not be negative"),
    ("joint_force_both", BODY + '[[joint_force]]\nbody = "b"\nvalue = 1.0\nlaw = "harmonic"\n',
     "joint_force[0].value", "either value"),
    ("unknown_law", BODY + '[[joint_force]]\nbody = "b"\nlaw = "cubic"\n', "joint_force[0].law", "unknown law 'cubic'"),
    ("law_missing_param", BODY + '[[joint_force]]\nbody = "b"\nlaw = "harmonic"\namplitude = 1.0\n',
     "joint_force[0].omega", "missing required key 'omega'"),
    ("law_wrong_param", BODY + '[[joint_force]]\nbody = "b"\nlaw = "polynomial"\ncoefficients = [1.0]\nomega = 2.0\n',
     "joint_force[0].omega", "unknown key 'omega' for law"),
    ("joint_force_welded", '[[body]]\nname = "w"\nmass = 1.0\n[[joint_force]]\nbody = "w"\nvalue = 1.0\n',
     "joint_force[0]", "welded"),
    ("force_bad_frame", BODY + '[[force]]\nname = "f"\nbody = "b"\nforce = [1, 0, 0]\nframe = "local"\n',
     "force[0].frame", "frame must be"),
    ("robot_unknown_key", '[robot]\nname = "ur5"\nfloat = true\n', "robot.float", "unknown key 'float'"),
    ("top_level_value", 'name = "x"\n', "name", "unknown top-level key 'name'"),
]


@pytest.mark.parametrize("text, key, message", [e[1:] for e in ERRORS], ids=[e[0] for e in ERRORS])
def test_errors_name_file_and_key(tmp_path, text, key, message):
    p = write(tmp_path, text, "broken_case.toml")
    with pytest.raises(vd.SceneFileError) as e:
        load_scene(p)
    msg = str(e.value)
    assert "broken_case.toml" in msg and e.value.path == str(p)
    assert message in msg
    if key is not None:
        assert f"key '{key}'" in msg and e.value.key == key
    assert isinstance(e.value, vd.ModelError) and isinstance(e.value, ValueError)


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(vd.SceneFileError, match="no such scene file") as e:
        vd.load_scene(tmp_path / "nope.toml")
    assert "nope.toml" in str(e.value)
    with pytest.raises(vd.SceneFileError, match="directory"):
        load_scene(tmp_path)
    (tmp_path / "latin1.toml").write_bytes('[scene]\nname = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(vd.SceneFileError, match="UTF-8"):
        load_scene(tmp_path / "latin1.toml")


def test_build_errors_stay_model_errors(tmp_path):
    # a file that reads fine but describes a scene that cannot be built: the System's ModelError
    p = write(tmp_path, '[[body]]\nname = "ghost"\nmass = 0.0\njoint = { type = "slider", axis = [1, 0, 0] }\n')
    s = load_scene(p)
    with pytest.raises(vd.ModelError, match="ghost"):
        s.build()


# ------------------------------------------------------------------ the writer

keys = st.text(max_size=8)
scalars = (st.floats(allow_nan=False) | st.integers(-2**63, 2**63 - 1) | st.booleans() | st.text(max_size=12))
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(keys, inner, max_size=3),
                      max_leaves=12)
documents = st.dictionaries(keys, values | st.lists(st.dictionaries(keys, values, max_size=3), min_size=1, max_size=3),
                            max_size=5)


@settings(max_examples=300, deadline=None)
@given(documents)
def test_dumps_round_trips_through_tomllib(doc):
    assert tomllib.loads(dumps(doc)) == doc


def test_dumps_quotes_keys_that_are_not_bare():
    doc = {"0\n": {"a b": 1, "x.y": [], "": {"\n": 2}}, "ok_key-1": {"ω": 3}}
    text = dumps(doc)
    assert '["0\\n"]' in text and '"a b" = 1' in text and '"x.y" = []' in text and "ok_key-1" in text
    assert tomllib.loads(text) == doc


def test_dumps_special_values():
    doc = {"a": {"inf": math.inf, "minf": -math.inf, "tiny": 5e-324, "big": 1.7976931348623157e308, "neg0": -0.0,
                 "esc": "\x00\x1f\x7f\\\"'\u2028"}, "nan": math.nan, "np": np.arange(3.0), "npi": np.int64(7),
           "tup": (1.5, (2, 3)), "skip": None}
    back = tomllib.loads(dumps(doc))
    assert math.isnan(back.pop("nan"))
    assert back == {"a": doc["a"], "np": [0.0, 1.0, 2.0], "npi": 7, "tup": [1.5, [2, 3]]}
    assert math.copysign(1.0, back["a"]["neg0"]) == -1.0
    with pytest.raises(vd.SceneFileError, match="cannot write") as e:
        dumps({"reference": {"x": [1.0, object()]}})
    assert e.value.key == "reference.x[1]"
    with pytest.raises(vd.SceneFileError, match="cannot write"):
        dumps({"z": 1 + 2j})


def test_robot_table_with_example_robot_data(tmp_path):
    pytest.importorskip("vibdyn.io.robots")
    p = write(tmp_path, """
        [scene]
        name = "ur5_tool"
        source = "example-robot-data ur5 with a tool"
        [robot]
        name = "ur5"
        [[body]]
        name = "tool"
        parent = "wrist_3_link"
        mass = 0.5
        com = [0.0, 0.0, 0.1]
        inertia = { shape = "cylinder", radius = 0.03, length = 0.2 }
        [[joint_damper]]
        body = "shoulder_pan_joint"
        damping = 0.1
    """)
    s = load_scene(p)
    assert s.name == "ur5_tool" and s.source == "example-robot-data ur5 with a tool"
    assert s.bodies["tool"].parent == "wrist_3_link"
    system = s.build()
    assert system.nv == 6
    save_scene(s, tmp_path / "saved.toml")
    t = load_scene(tmp_path / "saved.toml")
    assert scene_to_dict(t) == scene_to_dict(s)
    same_dynamics(s, t, seed=2)


junk = st.one_of(st.none(), st.booleans(), st.integers(-3, 3), st.floats(), st.text(max_size=6),
                 st.lists(st.integers(-2, 2) | st.floats(-2, 2) | st.text(max_size=3), max_size=4),
                 st.lists(st.lists(st.floats(-2, 2), max_size=4), max_size=4),
                 st.dictionaries(st.sampled_from(["type", "shape", "axis", "name", "law", "x"]),
                                 st.text(max_size=8) | st.floats(-2, 2), max_size=3))


def _leaves(d, path=()):
    if isinstance(d, dict):
        for k, v in d.items():
            yield path + (k,)
            yield from _leaves(v, path + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield path + (i,)
            yield from _leaves(v, path + (i,))


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_mutated_files_fail_only_with_scene_file_errors(data):
    """Any one-value change to a valid scene file: it loads, or it raises SceneFileError (no other error)."""
    base = scene_to_dict(every_kind_scene())
    base.pop("reference")
    leaves = list(_leaves(base))
    path = data.draw(st.sampled_from(leaves))
    doc = base
    for k in path[:-1]:
        doc = doc[k]
    if data.draw(st.booleans()) and isinstance(doc, dict):
        del doc[path[-1]]
    else:
        doc[path[-1]] = data.draw(junk)
    with warnings.catch_warnings(record=True) as caught:  # numpy's, on the way to a refusal only
        warnings.simplefilter("always")
        try:
            scene_from_dict(base, path="fuzz.toml")
        except vd.SceneFileError as e:
            assert "fuzz.toml" in str(e)
            return
    # (vibdyn's own hint that an angle beyond a full turn may be degrees: the value is legal, the hint meant)
    caught = [w for w in caught if "degrees by mistake?" not in str(w.message)]
    assert not caught, f"a scene loaded through warnings: {[str(w.message) for w in caught]}"


def test_documented_format_is_valid_toml():
    import vibdyn.io.scenefile as m

    block = m.__doc__.split(".. code-block:: toml")[1].split("Writing:")[0]
    doc = tomllib.loads(textwrap.dedent(block))
    from vibdyn.description.elements.base import KINDS

    # every element kind's table is documented, and nothing else but the scene-level tables
    assert set(doc) == set(KINDS) | {"scene", "body", "loop", "robot", "limits", "operating_point", "reference"}
    assert doc["operating_point"]["cyclic"] == {"rotor": "free"}
    body = dict(doc["body"][0], parent="world")
    s = scene_from_dict({"scene": doc["scene"], "body": [body], "spring": doc["spring"]}, path="doc.toml")
    assert s.build().nv == 1


def test_operating_point_table(tmp_path):
    path = tmp_path / "op.toml"
    path.write_text('[[body]]\nname = "r"\nmass = 1.0\ninertia = { shape = "disc", radius = 0.1 }\n'
                    'joint = { type = "pivot", axis = [0, 0, 1] }\n'
                    '[[joint_force]]\nbody = "r"\nlaw = "polynomial"\ncoefficients = [4.0, 0.0, -1.0]\n'
                    '[operating_point]\ncyclic = { r = "free" }\n')
    scene = vd.load_scene(path)
    assert scene.operating_point == {"cyclic": {"r": None}, "start": None}
    op = scene.build().operating_point()
    # 4 − ω² = 0; the search stops at |4 − ω²| ≤ tolerance (N·m), so ω is within tolerance / 2ω
    assert op.regime == "steady" and op.speeds["r"] == pytest.approx(2.0, abs=op.tol / 4)
    scene.save(tmp_path / "again.toml")
    assert vd.load_scene(tmp_path / "again.toml").operating_point == scene.operating_point
    path.write_text(path.read_text().replace('"free"', '"fast"'))
    with pytest.raises(vd.SceneFileError, match=r"op.toml.*operating_point.cyclic.r"):
        vd.load_scene(path)
