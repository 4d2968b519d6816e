"""Robots from URDF / MJCF files (vibdyn.io.robots): loading, conversion, and agreement with Pinocchio's own
model of the same file (and with MuJoCo for MJCF).

Tolerances: direct evaluations (CRBA, RNEA, ABA, kinematics, energies, parsed numbers) carry no error
estimate; their error is round-off, a few ε × the size of the terms (× κ(M) where M is solved). Fixed
1e-15..1e-12 relative (≈ 4.5–4500 ε) bound it on these small, well-conditioned models; 1e-10 where M is
solved or another engine's arithmetic is compared. Results that carry an estimate are checked against it.
"""

import subprocess
import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest

import vibdyn as vd
from vibdyn.description.elements import JointDamper
from vibdyn.io import robots

RTOL = 1e-10


def pin_model(scene):
    """Pinocchio's own model of the file the scene came from (parsed independently of the conversion)."""
    src = scene.robot_source
    if src.format == "urdf":
        if src.floating:
            return pin.buildModelFromUrdf(src.path, pin.JointModelFreeFlyer())
        return pin.buildModelFromUrdf(src.path)
    return pin.buildModelFromMJCF(src.path)


def twin_states(system, model, rng, scale=1.0):
    """The same random state in both models: one tangent offset dq from neutral (angles for revolute and
    continuous joints alike) applied by each model's own exp map, and one velocity v."""
    dq = scale * rng.standard_normal(system.nv)
    v = rng.standard_normal(system.nv)
    q = system.integrate(system.neutral(), dq)
    q_pin = pin.integrate(model, pin.neutral(model), dq)
    return q, q_pin, v


def full_M(model, data, q):
    M = pin.crba(model, data, q)
    return np.triu(M) + np.triu(M, 1).T


def rel(a, b):
    return np.abs(np.asarray(a) - np.asarray(b)).max() / max(np.abs(b).max(), 1.0)


# ------------------------------------------------------------------------------------------- loading


@pytest.mark.parametrize("name, floating", [("ur5", False), ("panda", False), ("talos", True)])
def test_load_and_build(name, floating):
    scene = vd.load_robot(name)
    assert isinstance(scene, vd.Scene)
    assert scene.robot_source.floating is floating
    assert scene.gravity == (0.0, 0.0, -9.81)
    assert "URDF" in scene.source and scene.robot_source.path.endswith(".urdf")
    system = scene.build()
    model = pin_model(scene)
    assert system.nv == model.nv
    assert system.nq == model.nq  # no continuous joints in these three
    # coordinates are named after the URDF joints, in Pinocchio's order
    expected = []
    for i in range(1, model.njoints):
        if model.joints[i].shortname() == "JointModelFreeFlyer":
            expected += [model.names[i] + s for s in vd.Free.suffixes]
        else:
            expected.append(model.names[i])
    assert system.coordinates == tuple(expected)
    if floating:
        assert system.nv == 6 + (model.njoints - 2)
        assert system.coordinates[0] == "root_joint.x"


def test_talos_mass_is_the_urdf_mass():
    scene = vd.load_robot("talos")
    model = pin_model(scene)
    total = sum(b.mass for b in scene.bodies.values())
    assert total == pytest.approx(sum(Y.mass for Y in model.inertias), rel=1e-12)


def test_continuous_joints_become_pivots():
    scene = vd.load_robot("double_pendulum_continuous")
    system = scene.build()
    model = pin_model(scene)
    assert model.nq == 4 and model.nv == 2
    assert system.nq == 2 and system.nv == 2
    assert all(isinstance(b.joint, vd.Pivot) for b in scene.bodies.values() if b.joint.nv)
    assert all(c.continuous for c in scene.robot_source.coordinates)


# ------------------------------------------------------------------------------------------- dynamics


@pytest.mark.parametrize("name", ["ur5", "panda", "talos", "double_pendulum_continuous", "kinova",
                                  "tiago_no_hand", "solo12"])
def test_dynamics_equal_pinocchio(name):
    scene = vd.load_robot(name, damping=False)
    assert not scene.elements
    system = scene.build()
    model = pin_model(scene)
    data = model.createData()
    rng = np.random.default_rng(7)
    for _ in range(4):
        q, q_pin, v = twin_states(system, model, rng)
        assert rel(system.mass_matrix(q), full_M(model, data, q_pin)) < RTOL
        zero = np.zeros(system.nv)
        # bias (gravity + Coriolis) and the full inverse dynamics with an acceleration
        assert rel(system.inverse_dynamics(q, v, zero), pin.rnea(model, data, q_pin, v, zero)) < RTOL
        a = rng.standard_normal(system.nv)
        assert rel(system.inverse_dynamics(q, v, a), pin.rnea(model, data, q_pin, v, a)) < RTOL
        assert rel(system.gravity_forces(q), -pin.computeGeneralizedGravity(model, data, q_pin)) < RTOL
        # the recorded coordinate map agrees with the independent construction
        qp, vp = robots.to_pin(system, q, v)
        assert rel(qp, q_pin) < 1e-12 and np.array_equal(vp, v)
        q2, v2 = robots.from_pin(system, q_pin, v)
        assert rel(system.difference(q, q2), np.zeros(system.nv)) < 1e-12


def test_welded_links_are_markers_at_their_place():
    """Links fixed to others (tool0, panda_hand_tcp) are massless Fixed bodies placed like Pinocchio's frames."""
    for name, links in [("ur5", ["tool0", "ee_link", "base_link"]),
                        ("panda", ["panda_hand", "panda_hand_tcp", "panda_link8"])]:
        scene = vd.load_robot(name)
        system = scene.build()
        model = pin_model(scene)
        data = model.createData()
        rng = np.random.default_rng(3)
        q, q_pin, _ = twin_states(system, model, rng)
        pin.framesForwardKinematics(model, data, q_pin)
        for link in links:
            body = scene.body(link)
            assert isinstance(body.joint, vd.Fixed) and body.mass == 0.0
            R, p = system.body_pose(link, q)
            oMf = data.oMf[model.getFrameId(link)]
            assert np.allclose(p, oMf.translation, atol=1e-12)
            assert np.allclose(R, oMf.rotation, atol=1e-12)
    # the fingers hang from the hand, as in the URDF
    panda = vd.load_robot("panda")
    assert panda.body("panda_finger_joint1").parent == "panda_hand"
    assert panda.body("panda_finger_joint1").name == "panda_leftfinger"


def test_link_named_like_a_joint_is_renamed():
    scene = vd.load_robot("anymal_c")  # links LF_HAA ... share their names with joints
    system = scene.build()
    assert "LF_HAA" in system.coordinates
    assert "LF_HAA_link" in scene.bodies
    assert scene.body("LF_HAA").joint.name == "LF_HAA"


# ------------------------------------------------------------------------------------------- force elements


def test_joint_spring_and_damper_on_a_loaded_robot():
    scene = vd.load_robot("ur5")
    base = scene.build()
    scene.add_joint_spring("shoulder_pan_joint", 10.0, rest=0.2)
    scene.add_joint_damper("elbow_joint", 3.0)
    system = scene.build()
    rng = np.random.default_rng(11)
    q = system.random_configuration(rng=rng)
    v = rng.standard_normal(system.nv)
    i = system.coordinate_index("shoulder_pan_joint")
    j = system.coordinate_index("elbow_joint")
    Q = np.zeros(system.nv)
    Q[i] = -10.0 * (q[i] - 0.2)
    Q[j] = -3.0 * v[j]
    assert np.allclose(system.generalized_forces(q, v), Q, rtol=0, atol=1e-12)
    da = system.accelerations(q, v) - base.accelerations(q, v)
    assert np.allclose(da, np.linalg.solve(system.mass_matrix(q), Q), rtol=1e-9, atol=1e-10)


def test_file_damping_becomes_joint_dampers():
    scene = vd.load_robot("panda")
    model = pin_model(scene)
    system = scene.build()
    v = np.random.default_rng(2).standard_normal(system.nv)
    q = system.neutral()
    assert np.allclose(system.generalized_forces(q, v), -np.asarray(model.damping) * v, rtol=0, atol=1e-14)
    assert not vd.load_robot("panda", damping=False).elements


# ------------------------------------------------------------------------------------------- errors


def test_unknown_robot_lists_the_names():
    with pytest.raises(vd.ModelError) as e:
        vd.load_robot("ur42")
    msg = str(e.value)
    assert "ur42" in msg and "ur5" in msg and "talos" in msg and "panda" in msg


def test_bad_urdf_path_and_bad_urdf(tmp_path):
    with pytest.raises(vd.ModelError, match="not found"):
        vd.load_urdf(tmp_path / "missing.urdf")
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='bad'><link name='a'/><joint name='j' type='revolute'>"
                   "<parent link='a'/><child link='nowhere'/></joint></robot>")
    with pytest.raises(vd.ModelError, match="bad.urdf"):
        vd.load_urdf(bad)
    with pytest.raises(vd.ModelError, match="not found"):
        vd.load_mjcf(tmp_path / "missing.xml")


def test_unsupported_joint_is_named():
    model = pin.Model()
    jid = model.addJoint(0, pin.JointModelSphericalZYX(), pin.SE3.Identity(), "neck")
    model.appendBodyToJoint(jid, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    with pytest.raises(vd.ModelError, match="'neck'.*spherical ZYX"):
        robots.scene_from_model(model, "head")


# ------------------------------------------------------------------------------------------- massless bodies

URDF_DUMMY = """<robot name="arm_with_dummy">
  <link name="base"/>
  <link name="arm">
    <inertial><origin xyz="0.25 0 0"/><mass value="2"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.04" iyz="0" izz="0.04"/></inertial>
  </link>
  <link name="tip"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="arm"/><origin xyz="0 0 1"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
  </joint>
  <joint name="tip_joint" type="revolute">
    <parent link="arm"/><child link="tip"/><origin xyz="0.5 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
  </joint>
</robot>
"""


def test_massless_leaf_is_kept_then_welded_on_request(tmp_path):
    path = tmp_path / "dummy.urdf"
    path.write_text(URDF_DUMMY)
    with pytest.warns(UserWarning, match="tip.*weld_massless"):
        scene = vd.load_urdf(path)
    assert scene.body("tip_joint").joint.nv == 1  # kept, as in the file
    with pytest.raises(vd.ModelError, match="tip"):
        scene.build()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        welded = vd.load_urdf(path, weld_massless=True)
    system = welded.build()
    assert system.coordinates == ("shoulder",)
    assert isinstance(welded.body("tip").joint, vd.Fixed)
    # the welded joint sits at its neutral in Pinocchio's configuration
    q_pin = robots.to_pin(system, np.array([0.3]))
    assert np.allclose(q_pin, [0.3, 0.0])
    # a pendulum: I_O = I_G + m d² about the shoulder
    assert system.mass_matrix(system.neutral())[0, 0] == pytest.approx(0.04 + 2 * 0.25**2, rel=1e-12)


# ------------------------------------------------------------------------------------------- all joint kinds


def test_every_supported_joint_kind_matches_pinocchio():
    rng = np.random.default_rng(5)

    def inertia():
        box = pin.Inertia.FromBox(rng.uniform(0.5, 2.0), *rng.uniform(0.1, 0.5, 3))
        R = pin.SE3.Random().rotation
        return pin.Inertia(box.mass, rng.uniform(-0.2, 0.2, 3), R @ box.inertia @ R.T)

    model = pin.Model()
    parent = 0
    for jname, jm in [("u", pin.JointModelUniversal(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))),
                      ("pl", pin.JointModelPlanar()),
                      ("he", pin.JointModelHelicalUnaligned(np.array([0, 0.6, 0.8]), 0.05)),
                      ("hy", pin.JointModelHY(0.1)),
                      ("sp", pin.JointModelSpherical()),
                      ("rub", pin.JointModelRUBY()),
                      ("pu", pin.JointModelPrismaticUnaligned(np.array([0.6, 0, 0.8]))),
                      ("rx", pin.JointModelRX()),
                      ("ff", pin.JointModelFreeFlyer())]:
        parent = model.addJoint(parent, jm, pin.SE3.Random(), jname)
        model.appendBodyToJoint(parent, inertia(), pin.SE3.Identity())
    scene = robots.scene_from_model(model, "all_kinds")
    kinds = [b.joint.type for b in scene.bodies.values()]
    assert kinds == ["universal", "planar", "helical", "helical", "ball", "pivot", "slider", "pivot", "free"]
    system = scene.build()
    assert system.nv == model.nv and system.nq == model.nq - 1  # the continuous joint stores one angle
    data = model.createData()
    for _ in range(3):
        q, q_pin, v = twin_states(system, model, rng)
        assert rel(system.mass_matrix(q), full_M(model, data, q_pin)) < RTOL
        zero = np.zeros(system.nv)
        assert rel(system.inverse_dynamics(q, v, zero), pin.rnea(model, data, q_pin, v, zero)) < RTOL


# ------------------------------------------------------------------------------------------- postures


def test_reference_configuration_from_srdf():
    system = vd.load_robot("talos").build()
    q = robots.reference_configuration(system)  # half_sitting
    model = pin_model(system.scene)
    pin.loadReferenceConfigurations(model, system.scene.robot_source.srdf, False)
    q_ref = model.referenceConfigurations["half_sitting"]
    assert np.allclose(robots.to_pin(system, q), pin.normalize(model, q_ref), atol=1e-12)
    assert q[2] == pytest.approx(q_ref[2])
    with pytest.raises(vd.ModelError, match="unknown posture 'moonwalk'"):
        robots.reference_configuration(system, "moonwalk")


# ------------------------------------------------------------------------------------------- MJCF

MJCF_ARM = """<mujoco model="arm">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body name="upper" pos="0 0 1" euler="10 0 20">
      <joint name="shoulder" type="hinge" axis="0 1 0" pos="0.05 0 0" damping="0.5"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.05" mass="1"/>
      <site name="elbow_site" pos="0.5 0 0"/>
      <body name="fore" pos="0.5 0 0" euler="0 0 30">
        <joint name="elbow" type="hinge" axis="0 0.6 0.8"/>
        <inertial pos="0.2 0.01 0" mass="0.7" diaginertia="0.01 0.02 0.025"/>
        <body name="wrist" pos="0.4 0 0">
          <joint name="wx" type="hinge" axis="1 0 0"/>
          <joint name="wy" type="slide" axis="0 1 0"/>
          <inertial pos="0.05 0 0" mass="0.2" diaginertia="0.001 0.002 0.002"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

MJCF_TWO_LINKS = """<mujoco model="two_links">
  <worldbody>
    <body name="l1" pos="0 0 0">
      <joint name="j1" type="hinge" axis="0 0 1"/>
      <geom type="capsule" fromto="0 0 0 1 0 0" size="0.05" mass="1"/>
      <body name="l2" pos="1 0 0">
        <joint name="j2" type="hinge" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 1 0 0" size="0.05" mass="1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("text", [MJCF_TWO_LINKS, MJCF_ARM], ids=["two_links", "arm"])
def test_mjcf_matches_mujoco(tmp_path, text):
    mujoco = pytest.importorskip("mujoco")
    path = tmp_path / "arm.xml"
    path.write_text(text)
    scene = vd.load_mjcf(path)
    assert scene.robot_source.format == "mjcf" and "MJCF" in scene.source
    system = scene.build()
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    assert system.nv == mj.nv
    rng = np.random.default_rng(4)
    for _ in range(3):
        q = system.random_configuration(rng=rng)
        data.qpos[:] = q  # hinges and slides only: same numbers in both
        data.qvel[:] = 0.0
        mujoco.mj_forward(mj, data)
        M = np.zeros((mj.nv, mj.nv))
        mujoco.mj_fullM(mj, data, M)
        assert rel(system.mass_matrix(q), M) < RTOL
        assert rel(-system.gravity_forces(q), data.qfrc_bias) < RTOL


def test_mjcf_conversion_details(tmp_path):
    path = tmp_path / "arm.xml"
    path.write_text(MJCF_ARM)
    scene = vd.load_mjcf(path)
    system = scene.build()
    # a body with two joints becomes a chain; each joint keeps its name
    assert system.coordinates == ("shoulder", "elbow", "wx", "wy")
    assert scene.body("wy").name == "wrist" and scene.body("wx").mass == 0.0
    # a joint off the body origin: the moving body is named after the joint, the link is a marker on it
    assert scene.body("upper").parent == "shoulder"
    assert np.allclose(scene.body("upper").joint.at, [-0.05, 0, 0])
    # sites are markers too, and the file's damping is a joint damper
    assert scene.body("elbow_site").parent == "upper"
    dampers = scene.elements_of(JointDamper)
    assert [(d.body, d.damping) for d in dampers] == [("shoulder", (0.5,))]


def test_mjcf_gravity_armature_stiffness_and_several_trees(tmp_path):
    path = tmp_path / "g.xml"
    path.write_text("""<mujoco model="g"><option gravity="0 -9.81 0"/>
      <default><joint armature="0.02"/></default>
      <worldbody><body name="a"><joint name="h" type="hinge" axis="0 0 1" stiffness="3"/>
        <inertial pos="0.1 0 0" mass="0.2" diaginertia="0.001 0.001 0.001"/></body></worldbody></mujoco>""")
    with pytest.warns(UserWarning) as record:
        scene = vd.load_mjcf(path)
    messages = " ".join(str(r.message) for r in record)
    assert "armature" in messages and "stiffness" in messages
    assert scene.gravity == (0.0, -9.81, 0.0)
    with pytest.warns(UserWarning):
        assert vd.load_mjcf(path, gravity=(0, 0, -1)).gravity == (0.0, 0.0, -1.0)

    two = tmp_path / "two.xml"
    two.write_text("""<mujoco model="two"><worldbody>
      <body name="a"><joint name="ha" type="hinge"/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>
      <body name="b"><joint name="hb" type="slide"/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>
      </worldbody></mujoco>""")
    with pytest.raises(vd.ModelError, match="2 body trees"):
        vd.load_mjcf(two)


# ------------------------------------------------------------------------------------------- imports


def test_robots_import_stays_light():
    code = ("import sys, vibdyn, vibdyn.io.robots; "
            "bad = [m for m in ('mujoco', 'meshcat', 'matplotlib') if m in sys.modules]; "
            "assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True)
