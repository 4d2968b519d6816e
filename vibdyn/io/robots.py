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
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from .._check import count, scalar, unknown_name
from ..description import joints as _joints
from ..description.elements import WORLD
from ..description.scene import Scene
from ..errors import ModelError
from ..model.system import massless_leaves

DEFAULT_GRAVITY = (0.0, 0.0, -9.81)

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
class CoordinateLink:
    """Where one Pinocchio joint's configuration goes in the vibdyn configuration.

    ``joint`` is the vibdyn joint name (None if the joint was welded); ``pin_idx_q``/``pin_nq`` and
    ``pin_idx_v``/``pin_nv`` its slices in Pinocchio's q and v; ``continuous`` says that Pinocchio stores
    (cos θ, sin θ) where vibdyn stores θ.
    """

    joint: str
    pin_idx_q: int
    pin_nq: int
    pin_idx_v: int
    pin_nv: int
    continuous: bool


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
        idx = [i for i in range(1, model.njoints) if np.any(model.armature[_vslice(model, i)] != 0.0)]
        _warn(f"MJCF {path}: joint armature (rotor inertia) of {', '.join(model.names[i] for i in idx)} is not "
              "represented in the vibdyn scene; the mass matrix leaves it out")
    if info["stiff"]:
        _warn(f"MJCF {path}: joint stiffness of {', '.join(info['stiff'])} is not read by Pinocchio; add it with "
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
    root = robots_dir()
    path = root / rel
    if not path.is_file():
        raise ModelError(f"robot {name!r}: file {path} is missing from this example-robot-data installation")
    kwargs.setdefault("package_dirs", [str(root.parent.parent)])
    kwargs.setdefault("name", name)
    scene = load_urdf(path, floating=free if floating is None else floating, **kwargs)
    srdf_path = root / srdf if srdf and (root / srdf).is_file() else None
    scene.robot_source = _replace(scene.robot_source, robot=name, srdf=srdf_path and str(srdf_path),
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
        if body.joint.nv != 1 or body.joint.kind not in ("pivot", "slider", "helical"):
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
    raise ModelError("example-robot-data is not installed (no share/example-robot-data/robots folder found); "
                     "install it with `pip install example-robot-data`")


# ====================================================================== conversion


def scene_from_model(model, name=None, gravity=DEFAULT_GRAVITY, source=None, damping=True, weld_massless=False,
                     composite_names=None):
    """Convert a Pinocchio model (from a URDF or MJCF parser) into a :class:`vibdyn.Scene`.

    ``source`` (:class:`RobotSource`) is recorded on the scene (its coordinate map is filled in here).
    ``composite_names`` maps a link name to the names of its joints, for composite (multi-joint) bodies.
    """
    name = name or model.name or "robot"
    composite_names = composite_names or {}
    scene = Scene(name, gravity=gravity)
    frames = list(model.frames)

    # -- the moving (sub-)joints of each Pinocchio joint, checked first: a bad joint fails before anything
    plans = {i: _joint_plan(model, i, composite_names) for i in range(1, model.njoints)}
    carried = np.array([model.inertias[i].mass for i in range(model.njoints)], dtype=float)
    for i in range(model.njoints - 1, 0, -1):
        carried[model.parents[i]] += carried[i]
    welded = {i: bool(weld_massless and carried[i] == 0.0) for i in plans}

    # -- frames: the JOINT frame of each joint and the link (BODY frame) it moves
    joint_frame, link_frame = {}, {}
    for k, f in enumerate(frames):
        if f.type == pin.FrameType.JOINT and f.parentJoint > 0 and f.name == model.names[f.parentJoint]:
            joint_frame.setdefault(f.parentJoint, k)
    for k, f in enumerate(frames):
        jf = joint_frame.get(f.parentJoint)
        if f.type == pin.FrameType.BODY and jf is not None and f.parentFrame == jf and \
                f.parentJoint not in link_frame:
            link_frame[f.parentJoint] = k

    # -- names: joints keep theirs; bodies take their link's, renamed if they collide
    joint_names = {sub[0] for p in plans.values() for sub in p}
    taken = set(joint_names) | {WORLD}

    def body_name(wanted, own_joint=None):
        if wanted == own_joint:  # a body may carry its own joint's name
            n = wanted
        else:
            n, k = wanted, 1
            while n in taken:
                n = f"{wanted}_link" if k == 1 else f"{wanted}_link{k}"
                k += 1
        taken.add(n)
        return n

    # per scene body: where its frame sits in its Pinocchio joint's frame
    placed = {}  # frame index -> (scene body holding it, that body's frame in the Pinocchio joint's frame)
    last_body = {0: (WORLD, pin.SE3.Identity())}  # Pinocchio joint -> (its scene body, body frame in joint)
    links = []
    order = _frame_order(frames, joint_frame, model)
    for item in order:
        kind, k = item
        if kind == "joint":
            i = k
            parent_name, parent_B = _parent_of_joint(model, frames, i, joint_frame, placed, last_body)
            placement = parent_B.inverse() * model.jointPlacements[i]
            lf = link_frame.get(i)
            link = frames[lf].name if lf is not None else model.names[i]
            link_at_joint = lf is not None and _is_identity(frames[lf].placement)
            subs = plans[i]
            for s, (jname, jm, sub_placement, continuous) in enumerate(subs):
                at = placement * sub_placement if s == 0 else sub_placement
                last = s == len(subs) - 1
                joint = _vibdyn_joint(jm, at, jname, welded[i], scene.name)
                if last:
                    bname = body_name(link if link_at_joint else jname, jname)
                    Y = model.inertias[i]
                    mass, com, inertia = float(Y.mass), Y.lever.copy(), Y.inertia.copy()
                else:
                    bname = body_name(jname, jname)
                    mass, com, inertia = 0.0, np.zeros(3), np.zeros((3, 3))
                try:
                    scene.add_body(bname, parent=parent_name, joint=joint, mass=mass, com=com,
                                   inertia=_clean_inertia(inertia, mass))
                except ModelError as e:
                    raise ModelError(f"{_where(scene.name)}joint '{jname}' (link '{link}'): {e}") from None
                links.append((jname, i, s, continuous, welded[i]))
                parent_name = bname
            last_body[i] = (parent_name, pin.SE3.Identity())
            placed[joint_frame.get(i, -1 - i)] = (parent_name, pin.SE3.Identity())
            if lf is not None:
                if link_at_joint:
                    placed[lf] = (parent_name, pin.SE3.Identity())
                else:
                    _add_marker(scene, frames, lf, placed, body_name)
        else:
            _add_marker(scene, frames, k, placed, body_name)

    # -- damping of the file as joint dampers
    if damping:
        for jname, i, s, continuous, w in links:
            if w:
                continue
            sl = _sub_vslice(model, i, s)
            c = np.asarray(model.damping[sl], dtype=float)
            if np.any(c > 0.0):
                scene.add_joint_damper(jname, c)

    # -- position limits of the file (revolute and prismatic joints; equal bounds are a URDF's "no limit")
    for jname, i, s, continuous, w in links:
        jq = _sub_qslice(model, i, s)
        if w or continuous or jq.stop - jq.start != 1:
            continue
        lo, up = float(model.lowerPositionLimit[jq.start]), float(model.upperPositionLimit[jq.start])
        if lo < up and abs(lo) < 1e300 and abs(up) < 1e300:
            scene.set_limits(jname, lo, up)
    # under gravity a robot has no free equilibrium: its drives hold it, at neutral brought within the limits
    inside = {k: min(max(0.0, lo), up) for k, (lo, up) in scene.limits.items() if not lo <= 0.0 <= up}
    scene.set_operating_point(start=inside or None, held=True)

    # -- record where it came from
    if source is not None:
        coords = []
        for jname, i, s, continuous, w in links:
            jq, jv = _sub_qslice(model, i, s), _sub_vslice(model, i, s)
            coords.append(CoordinateLink(None if w else jname, jq.start, jq.stop - jq.start, jv.start,
                                         jv.stop - jv.start, continuous))
        source = _replace(source, pin_neutral=tuple(map(float, pin.neutral(model))), coordinates=tuple(coords))
        scene.robot_source = source
        scene.source = f"{source.format.upper()} {source.path}"
    else:
        scene.robot_source = None
    leaves = massless_leaves(scene)
    if leaves:
        _warn(f"robot '{name}': moving bodies {', '.join(leaves)} carry no mass, so build() will refuse them "
              "(their motion is undefined): load with weld_massless=True to weld them, or give them a mass")
    scene.description = (f"{name}: {len(links)} joints from a Pinocchio model"
                         + (f" ({'floating' if source.floating else 'fixed'} base)" if source else ""))
    return scene


def _add_marker(scene, frames, k, placed, body_name):
    """A welded massless body for a link fixed to another (or an MJCF site), at its place."""
    f = frames[k]
    if f.type not in (pin.FrameType.BODY, pin.FrameType.OP_FRAME) or k in placed:
        return
    parent, B = _placed_parent(frames, k, placed)
    rel = B.inverse() * f.placement
    if parent == WORLD and f.name == WORLD and _is_identity(rel):
        placed[k] = (WORLD, pin.SE3.Identity())
        return
    bname = body_name(f.name)
    R = rel.rotation
    at = rel.translation.copy()
    at[np.abs(at) < 1e-15] = 0.0
    scene.add_body(bname, parent=parent, joint=_joints.Fixed(at=at,
                                                             rotation=None if _is_identity_R(R) else R))
    placed[k] = (bname, f.placement)


def _placed_parent(frames, k, placed):
    """The nearest ancestor frame already in the scene: (scene body, its frame in the Pinocchio joint)."""
    p = frames[k].parentFrame
    seen = set()
    while p not in seen:
        seen.add(p)
        if placed.get(p) is not None:
            return placed[p]
        if p == 0:
            return WORLD, pin.SE3.Identity()
        p = frames[p].parentFrame
    return WORLD, pin.SE3.Identity()


def _parent_of_joint(model, frames, i, joint_frame, placed, last_body):
    """Scene body a joint hangs from and that body's frame in the parent Pinocchio joint's frame."""
    parent_joint = model.parents[i]
    jf = joint_frame.get(i)
    if jf is not None:
        p = frames[jf].parentFrame
        seen = set()
        while p not in seen and p != 0:
            seen.add(p)
            entry = placed.get(p)
            if entry is not None and frames[p].parentJoint == parent_joint:
                return entry
            p = frames[p].parentFrame
    return last_body[parent_joint]


def _frame_order(frames, joint_frame, model):
    """Joints and marker frames, parents first (frames are created parents first by the parsers)."""
    order, done = [], set()
    frame_of_joint = {k: i for i, k in joint_frame.items()}
    for k, f in enumerate(frames):
        if k in frame_of_joint:
            i = frame_of_joint[k]
            # a joint whose parent joint has no frame: make sure the parent comes first
            for a in _ancestors(model, i):
                if a not in done:
                    order.append(("joint", a))
                    done.add(a)
            if i not in done:
                order.append(("joint", i))
                done.add(i)
        elif k > 0 and f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME):
            order.append(("frame", k))
    for i in range(1, model.njoints):  # joints without frames (models built by hand)
        if i not in done:
            order.append(("joint", i))
            done.add(i)
    return order


def _ancestors(model, i):
    out = []
    p = model.parents[i]
    while p > 0:
        out.append(p)
        p = model.parents[p]
    return out[::-1]


def _joint_plan(model, i, composite_names):
    """[(vibdyn joint name, pin joint model, placement after the previous sub-joint, continuous)]."""
    jm = model.joints[i]
    jname = model.names[i]
    if jm.shortname() != "JointModelComposite":
        _joint_kind(jm.shortname(), jname)
        return [(jname, jm, pin.SE3.Identity(), jm.shortname().startswith("JointModelRUB") or
                 jm.shortname() == "JointModelRevoluteUnboundedUnaligned")]
    comp = jm.extract()
    subs = list(comp.joints)
    places = list(comp.jointPlacements)
    names = None
    for ns in composite_names.values():
        if ns and ns[0] == jname.removeprefix("Composite_") and len(ns) == len(subs):
            names = ns
            break
    if names is None:
        names = [f"{jname}.{k}" for k in range(len(subs))]
    plan = []
    for k, (sj, P) in enumerate(zip(subs, places)):
        sn = sj.shortname()
        if sn == "JointModelComposite":
            raise ModelError(f"joint '{jname}': nested composite joints are not supported")
        _joint_kind(sn, f"{names[k]}' (in composite joint '{jname}")
        plan.append((names[k], sj, P, sn.startswith("JointModelRUB") or sn == "JointModelRevoluteUnboundedUnaligned"))
    return plan


_REVOLUTE = {"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned", "JointModelRUBX",
             "JointModelRUBY", "JointModelRUBZ", "JointModelRevoluteUnboundedUnaligned"}
_PRISMATIC = {"JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned"}
_HELICAL = {"JointModelHX", "JointModelHY", "JointModelHZ", "JointModelHelicalUnaligned"}
_OTHER = {"JointModelSpherical": "ball", "JointModelFreeFlyer": "free", "JointModelPlanar": "planar",
          "JointModelUniversal": "universal"}


def _joint_kind(shortname, jname):
    if shortname in _REVOLUTE:
        return "pivot"
    if shortname in _PRISMATIC:
        return "slider"
    if shortname in _HELICAL:
        return "helical"
    if shortname in _OTHER:
        return _OTHER[shortname]
    what = {"JointModelMimic": "a mimic joint (load without mimic joints)",
            "JointModelSphericalZYX": "a spherical ZYX joint",
            "JointModelTranslation": "a 3-D translation joint",
            "JointModelEllipsoid": "an ellipsoid joint"}.get(shortname, f"a {shortname} joint")
    raise ModelError(f"joint '{jname}' is {what}, which vibdyn does not support (supported: revolute, "
                     "continuous, prismatic, helical, spherical, planar, universal, free)")


def _vibdyn_joint(jm, placement, jname, weld, scene_name):
    """The vibdyn joint for a Pinocchio joint model placed by ``placement`` in its parent body."""
    at = placement.translation.copy()
    at[np.abs(at) < 1e-15] = 0.0  # round-off of frame compositions
    R = placement.rotation
    rotation = None if _is_identity_R(R) else R.copy()
    if weld:
        return _joints.Fixed(at=at, rotation=rotation, name=None)
    kind = _joint_kind(jm.shortname(), jname)
    try:
        if kind in ("pivot", "slider", "helical"):
            S = _motion_subspace(jm)[:, 0]
            if kind == "slider":
                return _joints.Slider(axis=S[:3], at=at, rotation=rotation, name=jname)
            axis = S[3:]
            pitch = float(S[:3] @ axis)
            if kind == "pivot" or pitch == 0.0:
                return _joints.Pivot(axis=axis, at=at, rotation=rotation, name=jname)
            return _joints.Helical(axis=axis, pitch=pitch, at=at, rotation=rotation, name=jname)
        if kind == "ball":
            return _joints.Ball(at=at, rotation=rotation, name=jname)
        if kind == "free":
            return _joints.Free(at=at, rotation=rotation, name=jname)
        if kind == "planar":
            return _joints.Planar(at=at, rotation=rotation, name=jname)
        u = jm.extract()
        return _joints.Universal(axis1=u.axis1, axis2=u.axis2, at=at, rotation=rotation, name=jname)
    except ModelError as e:
        raise ModelError(f"{_where(scene_name)}joint '{jname}': {e}") from None


def _motion_subspace(jm):
    """Motion subspace S (6 × nv, linear first) of a joint model, in its own frame, at neutral."""
    m = pin.Model()
    j = jm.extract() if hasattr(jm, "extract") else jm
    m.addJoint(0, j, pin.SE3.Identity(), "j")
    d = m.createData()
    pin.forwardKinematics(m, d, pin.neutral(m))
    return np.asarray(d.joints[1].S).reshape(6, -1).copy()


def _clean_inertia(I, mass):
    """Symmetrise a parsed inertia and remove the round-off of Pinocchio's merging of links: principal
    moments within 1e-15 kg·m² (or 1e-9 relative) of zero become zero, and a triangle inequality broken by
    less than that becomes an equality. A massless body gets zero. Real defects are left for the scene's
    check to report."""
    if mass == 0.0:
        return np.zeros((3, 3))
    I = 0.5 * (I + I.T)
    w, V = np.linalg.eigh(I)
    tol = 1e-9 * np.abs(w).max() + 1e-15
    c = np.where(np.abs(w) <= tol, 0.0, w)
    if c[2] > c[0] + c[1] and c[2] - (c[0] + c[1]) <= tol:
        c[2] = c[0] + c[1]
    if np.array_equal(c, w):
        return I
    I = (V * c) @ V.T
    return 0.5 * (I + I.T)


def _is_identity(M, tol=1e-12):
    return np.abs(M.translation).max() <= tol and _is_identity_R(M.rotation, tol)


def _is_identity_R(R, tol=1e-12):
    return np.abs(np.asarray(R) - np.eye(3)).max() <= tol


def _vslice(model, i):
    return slice(model.idx_vs[i], model.idx_vs[i] + model.nvs[i])


def _sub_vslice(model, i, s):
    jm = model.joints[i]
    if jm.shortname() != "JointModelComposite":
        return _vslice(model, i)
    start = model.idx_vs[i] + sum(j.nv for j in list(jm.extract().joints)[:s])
    return slice(start, start + list(jm.extract().joints)[s].nv)


def _sub_qslice(model, i, s):
    jm = model.joints[i]
    if jm.shortname() != "JointModelComposite":
        return slice(model.idx_qs[i], model.idx_qs[i] + model.nqs[i])
    subs = list(jm.extract().joints)
    start = model.idx_qs[i] + sum(j.nq for j in subs[:s])
    return slice(start, start + subs[s].nq)


def _where(scene_name):
    return f"robot '{scene_name}': " if scene_name else ""


def _warn(message):
    """A UserWarning pointing at the first caller outside vibdyn."""
    package = str(Path(__file__).resolve().parents[1])
    frame, level = sys._getframe(1), 2
    while frame is not None and frame.f_code.co_filename.startswith(package):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, stacklevel=level)


def _replace(obj, **changes):
    import dataclasses

    return dataclasses.replace(obj, **changes)


# ====================================================================== parsing


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
