"""A Pinocchio model (from a URDF or MJCF file) as a vibdyn :class:`~vibdyn.description.scene.Scene`: its
links as bodies (inertias cleaned, massless links welded or kept), its joints as vibdyn joints, its frames as
markers (see :mod:`vibdyn.io.robots` for the conversion's rules)."""

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .._deprecation import warn_caller
from ..description import joints as _joints
from ..description.elements import WORLD
from ..description.scene import Scene
from ..errors import ModelError

DEFAULT_GRAVITY = (0.0, 0.0, -9.81)


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


def replace_fields(obj, **changes):
    import dataclasses

    return dataclasses.replace(obj, **changes)


# ====================================================================== parsing


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
            sl = _subvslice(model, i, s)
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
            jq, jv = _sub_qslice(model, i, s), _subvslice(model, i, s)
            coords.append(CoordinateLink(None if w else jname, jq.start, jq.stop - jq.start, jv.start,
                                         jv.stop - jv.start, continuous))
        source = replace_fields(source, pin_neutral=tuple(map(float, pin.neutral(model))), coordinates=tuple(coords))
        scene.robot_source = source
        scene.source = f"{source.format.upper()} {source.path}"
    else:
        scene.robot_source = None
    leaves = scene.massless_leaves()
    if leaves:
        warn(f"robot '{name}': moving bodies {', '.join(leaves)} carry no mass, so build() will refuse them "
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


def _joint_kind(shortname, jname):
    """The vibdyn joint type standing for Pinocchio joint model ``shortname`` (each type declares its
    ``pinocchio_models``), or a ModelError naming the joint."""
    for cls in _joints.JOINT_TYPES.values():
        if shortname in cls.pinocchio_models:
            return cls
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
    cls = _joint_kind(jm.shortname(), jname)
    try:
        return cls.from_pinocchio(jm, _motion_subspace(jm), at=at, rotation=rotation, name=jname)
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


def vslice(model, i):
    return slice(model.idx_vs[i], model.idx_vs[i] + model.nvs[i])


def _subvslice(model, i, s):
    jm = model.joints[i]
    if jm.shortname() != "JointModelComposite":
        return vslice(model, i)
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


def warn(message):
    """A UserWarning pointing at the first caller outside vibdyn."""
    warn_caller(message)


