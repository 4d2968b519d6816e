"""Robots as vibdyn scenes: URDF and MJCF files (parsed by Pinocchio) and the example-robot-data models.

:func:`load_urdf`, :func:`load_mjcf` and :func:`load_robot` return a :class:`vibdyn.Scene` that you can
extend (``scene.add_joint_spring("shoulder_pan_joint", 10.0)``) and ``build()``. One converter,
:func:`scene_from_model`, turns the parsed ``pin.Model`` into the scene:

* every moving joint becomes a body, named after its child link, joined to its parent link by the vibdyn
  joint of the same kind and **named after the file's joint**, so coordinates carry the joint names;
* the mass of a moving body is the one Pinocchio computed: its link plus every link welded to it by fixed
  joints (merged). The welded links, and MJCF sites, are kept as massless ``Fixed`` bodies — markers that
  springs, dampers and forces can attach to (``("tool0", (0, 0, 0.1))``) — placed where the file puts them;
* continuous (unbounded) joints become a :class:`~vibdyn.Pivot`: the same dynamics, with one angle as
  coordinate where Pinocchio stores (cos θ, sin θ);
* a body of several MJCF joints (a Pinocchio composite joint) becomes a chain of bodies, one per joint,
  the first ones massless; every joint keeps its own name;
* viscous joint damping of the file (URDF ``<dynamics damping>``, MJCF ``damping``) becomes joint
  dampers (``damping=False`` to leave it out); friction is not modelled;
* massless moving bodies that carry no mass (a dummy end-effector joint) are kept, so the coordinates are
  those of the file, but ``build()`` refuses them (their motion is undefined): loading warns, and
  ``weld_massless=True`` welds them instead (their coordinates disappear);
* URDF mimic joints are read as independent joints (Pinocchio's default);
* position limits of revolute and prismatic joints are kept (``scene.limits``, ``system.limits``):
  equilibrium searches refuse to leave them; velocity and effort limits are not kept;
* the scene's operating point is the neutral configuration held by the drives (``System.held``): under
  gravity a robot has no free equilibrium (``scene.set_operating_point(...)`` changes it).

Geometry (meshes) is not needed for the dynamics and is not loaded; ``scene.robot_source``
(:class:`RobotSource`) records the file, its package folders and the correspondence of configurations,
for a viewer or for comparisons with Pinocchio (:func:`to_pin`, :func:`from_pin`);
:func:`reference_configuration` reads a posture of the robot's SRDF file ("half_sitting" for Talos).
"""

import importlib.metadata
import math
import os
import sys
import sysconfig
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from .._check import count, scalar, unknown_name
from ..errors import ModelError
from .robot_scene import DEFAULT_GRAVITY, CoordinateLink, replace_fields, scene_from_model, vslice, warn  # noqa: F401

# name -> (URDF path under example-robot-data's ``robots`` folder, floating base by default,
#          SRDF path (reference postures) or None, default posture or None)
ROBOTS = {
    "a1": ("a1_description/urdf/a1.urdf", True, "a1_description/srdf/a1.srdf", "standing"),
    "alex_nub_hands": ("alex_description/urdf/alex_nub_hands.urdf", False,
                       "alex_description/srdf/alex_nub_hands.srdf", "default"),
    "alex_psyonic_hands": ("alex_description/urdf/alex_psyonic_hands.urdf", False,
                           "alex_description/srdf/alex_psyonic_hands.srdf", "default"),
    "alex_sake_hands": ("alex_description/urdf/alex_sake_hands.urdf", False,
                        "alex_description/srdf/alex_sake_hands.srdf", "default"),
    "alexander": ("alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf", True,
                  "alexander_description/srdf/alexander.srdf", "default"),
    "allegro_left_hand": ("allegro_hand_description/urdf/allegro_left_hand.urdf", False, None, None),
    "allegro_right_hand": ("allegro_hand_description/urdf/allegro_right_hand.urdf", False, None, None),
    "anymal": ("anymal_b_simple_description/robots/anymal.urdf", True,
               "anymal_b_simple_description/srdf/anymal.srdf", "standing"),
    "anymal_c": ("anymal_c_simple_description/urdf/anymal.urdf", True,
                 "anymal_c_simple_description/srdf/anymal.srdf", "standing"),
    "anymal_kinova": ("anymal_b_simple_description/robots/anymal-kinova.urdf", True,
                      "anymal_b_simple_description/srdf/anymal-kinova.srdf", "standing_with_arm_up"),
    "asr_twodof": ("asr_twodof_description/urdf/TwoDofs.urdf", False, None, None),
    "b1": ("b1_description/urdf/b1.urdf", True, "b1_description/srdf/b1.srdf", "standing"),
    "b1_z1": ("b1_description/urdf/b1-z1.urdf", True, "b1_description/srdf/b1-z1.srdf",
              "standing_with_arm_home"),
    "baxter": ("baxter_description/urdf/baxter.urdf", False, "baxter_description/srdf/baxter_manipulation.srdf",
               "neutral"),
    "bolt": ("bolt_description/robots/bolt.urdf", True, "bolt_description/srdf/bolt.srdf", "standing"),
    "borinot": ("borinot_description/urdf/borinot_flying_arm_2.urdf", True,
                "borinot_description/srdf/borinot_flying_arm_2.srdf", "home"),
    "centauro": ("centauro_description/urdf/centauro.urdf", True, "centauro_description/srdf/centauro.srdf",
                 "homing_balanced"),
    "double_pendulum": ("double_pendulum_description/urdf/double_pendulum.urdf", False, None, None),
    "double_pendulum_continuous": ("double_pendulum_description/urdf/double_pendulum_continuous.urdf", False,
                                   None, None),
    "double_pendulum_simple": ("double_pendulum_description/urdf/double_pendulum_simple.urdf", False, None,
                               None),
    "finger_edu": ("finger_edu_description/robots/finger_edu.urdf", False,
                   "finger_edu_description/srdf/finger_edu.srdf", "hanging"),
    "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", True, None, None),
    "g1_with_hands": ("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", True, None, None),
    "go1": ("go1_description/urdf/go1.urdf", True, "go1_description/srdf/go1.srdf", "standing"),
    "go2": ("go2_description/urdf/go2.urdf", True, "go2_description/srdf/go2.srdf", "standing"),
    "hector": ("hector_description/robots/quadrotor_base.urdf", True, None, None),
    "hextilt": ("hextilt_description/urdf/hextilt_flying_arm_5.urdf", True,
                "hextilt_description/srdf/hextilt_flying_arm_5.srdf", "home"),
    "human": ("human_description/robots/human.urdf", True, None, None),
    "hyq": ("hyq_description/robots/hyq_no_sensors.urdf", True, "hyq_description/srdf/hyq.srdf", "standing"),
    "icub": ("icub_description/robots/icub.urdf", True, "icub_description/srdf/icub.srdf", "half_sitting"),
    "icub_reduced": ("icub_description/robots/icub_reduced.urdf", True, "icub_description/srdf/icub.srdf",
                     "half_sitting"),
    "iris": ("iris_description/robots/iris_simple.urdf", True, None, None),
    "kinova": ("kinova_description/robots/kinova.urdf", False, "kinova_description/srdf/kinova.srdf", "arm_up"),
    "laikago": ("laikago_description/urdf/laikago.urdf", True, None, None),
    "panda": ("panda_description/urdf/panda.urdf", False, "panda_description/srdf/panda.srdf", "default"),
    "panda_collision": ("panda_description/urdf/panda_collision.urdf", False,
                        "panda_description/srdf/panda.srdf", "default"),
    "pr2": ("pr2_description/urdf/pr2.urdf", True, "pr2_description/srdf/pr2.srdf", "tuck_left_arm"),
    "quadruped": ("quadruped_description/urdf/quadruped.urdf", True, None, None),
    "romeo": ("romeo_description/urdf/romeo.urdf", True, "romeo_description/srdf/romeo.srdf", "half_sitting"),
    "simple_humanoid": ("simple_humanoid_description/urdf/simple_humanoid.urdf", True,
                        "simple_humanoid_description/srdf/simple_humanoid.srdf", "half_sitting"),
    "simple_humanoid_classical": ("simple_humanoid_description/urdf/simple_humanoid_classical.urdf", True,
                                  "simple_humanoid_description/srdf/simple_humanoid_classical.srdf",
                                  "half_sitting"),
    "so100": ("so_arm_description/urdf/so100.urdf", False, None, None),
    "so101": ("so_arm_description/urdf/so101.urdf", False, None, None),
    "solo8": ("solo_description/robots/solo.urdf", True, "solo_description/srdf/solo.srdf", "standing"),
    "solo12": ("solo_description/robots/solo12.urdf", True, "solo_description/srdf/solo.srdf", "standing"),
    "talos": ("talos_data/robots/talos_reduced.urdf", True, "talos_data/srdf/talos.srdf", "half_sitting"),
    "talos_arm": ("talos_data/robots/talos_left_arm.urdf", False, "talos_data/srdf/talos.srdf", None),
    "talos_box": ("talos_data/robots/talos_reduced_box.urdf", True, "talos_data/srdf/talos.srdf", "half_sitting"),
    "talos_full": ("talos_data/robots/talos_full_v2.urdf", True, "talos_data/srdf/talos.srdf", "half_sitting"),
    "talos_full_box": ("talos_data/robots/talos_full_v2_box.urdf", True, "talos_data/srdf/talos.srdf",
                       "half_sitting"),
    "tiago": ("tiago_description/robots/tiago.urdf", False, None, None),
    "tiago_dual": ("tiago_description/robots/tiago_dual.urdf", False, None, None),
    "tiago_no_hand": ("tiago_description/robots/tiago_no_hand.urdf", False, None, None),
    "tiago_pro": ("tiago_pro_description/robots/tiago_pro.urdf", False, None, None),
    "ur3": ("ur_description/urdf/ur3_robot.urdf", False, None, None),
    "ur3_gripper": ("ur_description/urdf/ur3_gripper.urdf", False, "ur_description/srdf/ur3_gripper.srdf", None),
    "ur3_limited": ("ur_description/urdf/ur3_joint_limited_robot.urdf", False, None, None),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", False, "ur_description/srdf/ur5.srdf", None),
    "ur5_gripper": ("ur_description/urdf/ur5_gripper.urdf", False, "ur_description/srdf/ur5_gripper.srdf", None),
    "ur5_limited": ("ur_description/urdf/ur5_joint_limited_robot.urdf", False,
                    "ur_description/srdf/ur5_joint_limited_robot.srdf", None),
    "ur10": ("ur_description/urdf/ur10_robot.urdf", False, None, None),
    "ur10_limited": ("ur_description/urdf/ur10_joint_limited_robot.urdf", False, None, None),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", False, "xarm_description/srdf/xarm7.srdf", "home"),
    "z1": ("z1_description/urdf/z1.urdf", False, "z1_description/srdf/z1.srdf", "arm_up"),
}


@dataclass(frozen=True)
class RobotSource:
    """Where a robot scene came from: its file, how it was parsed, and the map of its coordinates."""

    format: str  # "urdf" or "mjcf"
    path: str
    floating: bool
    package_dirs: tuple
    robot: str | None = None  # name in the example-robot-data table
    srdf: str | None = None  # SRDF file with reference postures
    posture: str | None = None  # default posture of the SRDF
    pin_neutral: tuple = ()
    coordinates: tuple = ()  # CoordinateLink per Pinocchio (sub-)joint, in Pinocchio's order

    @property
    def pin_nq(self):
        return len(self.pin_neutral)

    @property
    def pin_nv(self):
        return sum(c.pin_nv for c in self.coordinates)

    def pin_model(self):
        """Pinocchio's own model of the file (no geometry), parsed the same way as the scene."""
        if self.format == "urdf":
            return _parse_urdf(self.path, self.floating)
        return _parse_mjcf(self.path)


# ====================================================================== loading


def load_urdf(path, floating=False, package_dirs=None, name=None, gravity=DEFAULT_GRAVITY, damping=True,
              weld_massless=False):
    """A :class:`vibdyn.Scene` from a URDF file (see the module documentation for the conversion).

    ``floating``: put the robot on a free joint (6 coordinates ``root_joint.x`` ... ``root_joint.rz``)
    instead of welding its root link to the world. ``package_dirs``: folders that ``package://`` mesh
    paths refer to, recorded for a viewer (meshes are not loaded). ``name``: scene name (default: the
    robot name of the file). ``gravity``: m/s², world axes. ``damping``: turn the joints' viscous damping
    into joint dampers. ``weld_massless``: weld moving bodies that carry no mass instead of keeping them.
    """
    path = _existing(path, "URDF")
    floating = bool(floating)
    model = _parse_urdf(path, floating)
    dirs = tuple(str(Path(d)) for d in ([package_dirs] if isinstance(package_dirs, (str, os.PathLike))
                                         else (package_dirs or ())))
    source = RobotSource("urdf", path, floating, dirs)
    return scene_from_model(model, name=name or model.name or Path(path).stem, gravity=gravity, source=source,
                            damping=damping, weld_massless=weld_massless)


def load_mjcf(path, name=None, gravity=None, damping=True, weld_massless=False):
    """A :class:`vibdyn.Scene` from a MuJoCo MJCF file parsed by Pinocchio.

    ``gravity`` defaults to the file's ``<option gravity>`` (Pinocchio does not read it), else
    (0, 0, −9.81). A free joint stays a :class:`~vibdyn.Free` joint. Pinocchio 4.1 reads only the first
    body tree of ``<worldbody>``: a file with several is refused. Joint ``armature`` (rotor inertia) and
    ``stiffness`` are not represented: a warning says so (add the stiffness with ``add_joint_spring``).
    """
    path = _existing(path, "MJCF")
    info = _mjcf_info(path)
    model = _parse_mjcf(path)
    if gravity is None:
        gravity = info["gravity"] if info["gravity"] is not None else DEFAULT_GRAVITY
    if np.any(np.asarray(model.armature) != 0.0):
        idx = [i for i in range(1, model.njoints) if np.any(model.armature[vslice(model, i)] != 0.0)]
        warn(f"MJCF {path}: joint armature (rotor inertia) of {', '.join(model.names[i] for i in idx)} is not "
              "represented in the vibdyn scene; the mass matrix leaves it out")
    if info["stiff"]:
        warn(f"MJCF {path}: joint stiffness of {', '.join(info['stiff'])} is not read by Pinocchio; add it with "
              "scene.add_joint_spring")
    floating = model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer"
    source = RobotSource("mjcf", path, floating, (str(Path(path).parent),))
    scene = scene_from_model(model, name=name or model.name or Path(path).stem, gravity=gravity, source=source,
                             damping=damping, weld_massless=weld_massless, composite_names=info["joints"])
    return scene


def load_robot(name, floating=None, servo=None, **kwargs):
    """A :class:`vibdyn.Scene` of a robot of example-robot-data by its name (see :data:`ROBOTS`).

    ``floating`` None uses the robot's usual base (free for legged robots, humanoids and drones, fixed for
    arms); other keywords go to :func:`load_urdf`. The scene's ``robot_source`` records the SRDF file whose
    postures :func:`reference_configuration` reads. ``servo`` = (stiffness, damping): the joints held by
    position servos (:func:`add_servo`): a robot held by its drives alone has only gravity's stiffness, so
    most of its modes come out rigid.
    """
    if name not in ROBOTS:
        raise unknown_name(name, known_robots(), "robot", "known robots")
    rel, free, srdf, posture = ROBOTS[name]
    try:
        root = robots_dir()
    except ModelError as e:
        raise ModelError(f"robot {name!r}: {e}") from None
    path = root / rel
    if not path.is_file():
        raise ModelError(f"robot {name!r}: file {path} is missing from this example-robot-data installation")
    kwargs.setdefault("package_dirs", [str(root.parent.parent)])
    kwargs.setdefault("name", name)
    scene = load_urdf(path, floating=free if floating is None else floating, **kwargs)
    srdf_path = root / srdf if srdf and (root / srdf).is_file() else None
    scene.robot_source = replace_fields(scene.robot_source, robot=name, srdf=srdf_path and str(srdf_path),
                                  posture=posture if srdf_path else None)
    scene.source = f"example-robot-data '{name}': URDF {path}"
    if scene.robot_source.posture:  # held at the SRDF's posture rather than at neutral
        scene.set_operating_point(start=_posture_offsets(scene), held=True)
    if servo is not None:
        add_servo(scene, *_servo_pair(servo))
    return scene


def _servo_pair(servo):
    try:
        stiffness, damping = servo
    except (TypeError, ValueError):
        raise ModelError(f"servo: expected (stiffness, damping) (N·m/rad or N/m, N·m·s/rad or N·s/m), got "
                         f"{servo!r}") from None
    return stiffness, damping


def add_servo(scene, stiffness, damping=0.0):
    """Hold every one-coordinate joint (pivots, sliders, helical: the actuated ones) by a position servo: a
    joint spring ``stiffness`` (N·m/rad or N/m) about the held posture (the operating point's start, else
    neutral) and a joint damper ``damping`` (N·m·s/rad or N·s/m), named ``<joint>.servo``. The modes of the
    held robot are then its vibration modes on its servos (without them only gravity stiffens it)."""
    k = scalar(stiffness, "servo stiffness", positive=True)
    c = scalar(damping, "servo damping", nonnegative=True)
    start = (scene.operating_point or {}).get("start") or {}
    if not isinstance(start, dict):
        start = dict(zip((n for b in scene.bodies.values() for n in b.coordinates), start))
    for body in list(scene.bodies.values()):
        if not body.joint.scalar:
            continue
        (coordinate,) = body.coordinates
        scene.add_joint_spring(body.name, k, rest=start.get(coordinate, 0.0), name=f"{coordinate}.servo_spring")
        if c > 0:
            scene.add_joint_damper(body.name, c, name=f"{coordinate}.servo_damper")


def _posture_offsets(scene):
    """{coordinate: offset from neutral} of the robot's default SRDF posture (None if it breaks a limit)."""
    system = scene.build()
    q = reference_configuration(system)
    try:
        system.check_limits(q)
    except ModelError:
        return scene.operating_point["start"]
    dv = system.difference(system.neutral(), q)
    return {c: float(x) for c, x in zip(system.coordinates, dv) if x != 0.0} or None


def known_robots():
    """Names accepted by :func:`load_robot` (sorted)."""
    return sorted(ROBOTS)


def robot_path(name):
    """Path of the URDF file of a robot of the table."""
    if name not in ROBOTS:
        raise unknown_name(name, known_robots(), "robot", "known robots")
    return robots_dir() / ROBOTS[name][0]


_ROBOTS_DIR: list[Path] = []


def robots_dir():
    """The ``robots`` folder of example-robot-data (``<prefix>/share/example-robot-data/robots``)."""
    if _ROBOTS_DIR:
        return _ROBOTS_DIR[0]
    tail = Path("share", "example-robot-data", "robots")
    candidates = []
    env = os.environ.get("EXAMPLE_ROBOT_DATA_MODEL_DIR")
    if env:
        candidates.append(Path(env))
    try:
        candidates.append(Path(importlib.metadata.distribution("example-robot-data").locate_file(
            Path("cmeel.prefix") / tail)))
    except importlib.metadata.PackageNotFoundError:
        pass
    for p in [sysconfig.get_paths().get("purelib"), sysconfig.get_paths().get("platlib"), *sys.path]:
        if p:
            candidates.append(Path(p) / "cmeel.prefix" / tail)
            candidates.append(Path(p).parents[2] / tail if len(Path(p).parents) > 2 else Path(p) / tail)
    candidates.append(Path(sys.prefix) / tail)
    candidates.append(Path("/opt/openrobots") / tail)
    for c in candidates:
        if c.is_dir():
            _ROBOTS_DIR.append(c.resolve())
            return _ROBOTS_DIR[0]
    raise ModelError("the robots of example-robot-data are not installed (no share/example-robot-data/robots folder "
                     "found): they come with the robots extra, pip install 'vibdyn[robots]' (URDF and MJCF files of "
                     "your own load without it: vd.load_urdf, vd.load_mjcf)")


# ====================================================================== conversion


def _existing(path, kind):
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"{kind} file not found: {path}")
    return str(p.resolve())


def _parse_urdf(path, floating):
    try:
        if floating:
            return pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
        return pin.buildModelFromUrdf(str(path))
    except (RuntimeError, ValueError, OSError) as e:
        raise ModelError(f"URDF {path}: cannot be parsed by Pinocchio: {e}") from None


def _parse_mjcf(path):
    info = _mjcf_info(path)
    if len(info["roots"]) > 1:
        raise ModelError(f"MJCF {path}: <worldbody> holds {len(info['roots'])} body trees "
                         f"({', '.join(info['roots'])}); Pinocchio 4.1 reads only the first one: keep one "
                         "tree per file")
    try:
        return pin.buildModelFromMJCF(str(path))
    except (RuntimeError, ValueError, OSError) as e:
        raise ModelError(f"MJCF {path}: cannot be parsed by Pinocchio: {e}") from None


def _mjcf_info(path):
    """What Pinocchio does not give back from an MJCF file: gravity, top-level bodies, the names of the
    joints of multi-joint bodies, and the joints with a stiffness."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        raise ModelError(f"MJCF {path}: not a valid XML file: {e}") from None
    if root.tag != "mujoco":
        raise ModelError(f"MJCF {path}: root element is <{root.tag}>, expected <mujoco>")
    for inc in root.iter("include"):  # Pinocchio's parser skips it: its bodies would be missing
        raise ModelError(f"MJCF {path}: <include file=\"{inc.attrib.get('file', '?')}\"> is not supported "
                         "(Pinocchio drops the included elements): paste the included file in place")
    gravity = None
    for opt in root.iter("option"):
        if "gravity" in opt.attrib:
            gravity = tuple(float(x) for x in opt.attrib["gravity"].split())
    roots, joints, stiff = [], {}, []
    for wb in root.iter("worldbody"):
        roots += [b.attrib.get("name", "?") for b in wb.findall("body")]
        for b in wb.iter("body"):
            js = [j for j in b if j.tag in ("joint", "freejoint")]
            names = [j.attrib.get("name") for j in js]
            if len(js) > 1 and all(names):
                joints[b.attrib.get("name")] = names
    for j in root.iter("joint"):
        try:
            if float(j.attrib.get("stiffness", "0")) != 0.0:
                stiff.append(j.attrib.get("name") or j.attrib.get("class") or "(default)")
        except ValueError:
            pass
    return {"gravity": gravity, "roots": roots, "joints": joints, "stiff": stiff}


# ====================================================================== configurations


def to_pin(system, q, v=None):
    """Pinocchio's configuration (and velocity) of the file's model for a vibdyn one of a loaded robot.

    Continuous joints become (cos θ, sin θ); welded joints sit at their neutral. Returns q_pin, or
    (q_pin, v_pin) if ``v`` is given. The model is ``system.scene.robot_source.pin_model()``.
    """
    src = _source(system)
    q = np.asarray(q, dtype=float)
    qp = np.array(src.pin_neutral)
    vp = np.zeros(src.pin_nv) if v is not None else None
    for c in src.coordinates:
        if c.joint is None:
            continue
        b = system.body_info(c.joint)
        if c.continuous:
            th = q[b.idx_q]
            qp[c.pin_idx_q:c.pin_idx_q + 2] = math.cos(th), math.sin(th)
        else:
            qp[c.pin_idx_q:c.pin_idx_q + c.pin_nq] = q[b.idx_q:b.idx_q + b.nq]
        if v is not None:
            vp[c.pin_idx_v:c.pin_idx_v + c.pin_nv] = np.asarray(v, dtype=float)[b.idx_v:b.idx_v + b.nv]
    return qp if v is None else (qp, vp)


def from_pin(system, q_pin, v_pin=None):
    """The vibdyn configuration (and velocity) of a loaded robot from Pinocchio's ones (inverse of
    :func:`to_pin`; the coordinates of welded joints are dropped)."""
    src = _source(system)
    q_pin = np.asarray(q_pin, dtype=float)
    if q_pin.shape != (src.pin_nq,):
        raise ModelError(f"q_pin: expected {count(src.pin_nq, 'number')}, got shape {q_pin.shape}")
    q = system.neutral()
    v = np.zeros(system.nv) if v_pin is not None else None
    for c in src.coordinates:
        if c.joint is None:
            continue
        b = system.body_info(c.joint)
        s = q_pin[c.pin_idx_q:c.pin_idx_q + c.pin_nq]
        if c.continuous:
            q[b.idx_q] = math.atan2(s[1], s[0])
        else:
            q[b.idx_q:b.idx_q + b.nq] = s
        if v_pin is not None:
            v[b.idx_v:b.idx_v + b.nv] = np.asarray(v_pin, dtype=float)[c.pin_idx_v:c.pin_idx_v + c.pin_nv]
    return q if v_pin is None else (q, v)


def reference_configuration(system, posture=None):
    """A posture of the robot's SRDF file (e.g. "half_sitting" for Talos) as a vibdyn configuration.

    ``posture`` None is the robot's default posture (see :data:`ROBOTS`).
    """
    src = _source(system)
    if not src.srdf:
        raise ModelError(f"scene '{system.scene.name}': no SRDF file with reference postures is known for it")
    posture = posture or src.posture
    model = src.pin_model()
    try:
        pin.loadReferenceConfigurations(model, src.srdf, False)
    except (RuntimeError, ValueError) as e:
        raise ModelError(f"SRDF {src.srdf}: {e}") from None
    names = [e.key() for e in model.referenceConfigurations]
    if not names:
        raise ModelError(f"SRDF {src.srdf}: holds no reference posture")
    if posture is None:
        if len(names) > 1:
            raise ModelError(f"SRDF {src.srdf}: name the posture, one of {', '.join(names)}")
        posture = names[0]
    if posture not in names:
        raise unknown_name(posture, names, "posture", what=f"SRDF {src.srdf}")
    return from_pin(system, pin.normalize(model, model.referenceConfigurations[posture]))


def _source(system):
    scene = getattr(system, "scene", system)
    src = getattr(scene, "robot_source", None)
    if src is None:
        raise ModelError(f"scene '{scene.name}' was not loaded from a robot file (no robot_source)")
    return src
