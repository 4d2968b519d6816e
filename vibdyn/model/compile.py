"""Compilation of a scene into what a :class:`vibdyn.System` holds: the Pinocchio model of its tree (joints,
inertias, a frame per moving body), where each body lives in it (:class:`BodyInfo`), the names, units and
limits of the tangent coordinates, the scene's length and inertia scales, then the force-element groups,
which are built on the System's own lookups: :class:`Compiled`, the base of the System, holds them.
Run once by ``Scene.build()``; nothing here runs after it. SI units: m, rad, kg, kg·m².
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..description.elements import WORLD, Support
from ..errors import ModelError
from .forces import compile_groups
from .workspace import Workspace

if TYPE_CHECKING:
    from collections.abc import Mapping


@dataclass(frozen=True)
class BodyInfo:
    """Where a scene body lives in the Pinocchio model."""

    name: str
    joint: Any  # the vibdyn joint
    joint_id: int  # Pinocchio joint that moves it (its parent's for a Fixed body)
    body_in_joint: pin.SE3  # body frame expressed in that joint's frame
    idx_q: int
    idx_v: int
    nq: int
    nv: int
    coordinates: tuple

    @property
    def v_indices(self) -> range:
        return range(self.idx_v, self.idx_v + self.nv)


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


class Compiled:
    """The tables ``Scene.build()`` compiles from a scene, which a :class:`vibdyn.System` holds (read only)
    and analyses use, with the two compilation steps (:meth:`_compile_tree`, :meth:`_compile_elements`)."""

    scene: Any  # the System's own copy of the scene
    name: str
    model: pin.Model
    model_without_gravity: pin.Model  # gravity zero: RNEA at rest on it is −Σ Jᵀ f of the external forces
    body_infos: Mapping[str, BodyInfo]
    nq: int
    nv: int
    unit_blocks: tuple  # (body, index in q, size): the unit quaternions and (cos, sin) pairs q must hold
    coordinates: tuple  # names of the tangent coordinates
    units: tuple  # "m" or "rad" per tangent coordinate
    bodies: tuple
    limits: Mapping[str, tuple]  # coordinate -> (lower, upper), m or rad from neutral
    lower_limits: np.ndarray  # per tangent coordinate (−inf where none), read only
    upper_limits: np.ndarray
    has_gravity: bool
    supports: tuple
    support_index: Mapping[str, int]  # support name -> index in supports
    length_scale: float  # m (:func:`length_scale`)
    coordinate_scales: np.ndarray  # finite-difference scale: 1 for rad, the length scale for m
    inverse_scale_products: np.ndarray  # 1/(s_i s_j), nv × nv
    unit_scales: bool  # every coordinate scale is 1 (rotations only)
    additive_coordinates: tuple  # (indices in v, indices in q) of the vector-space joints' coordinates
    curved_coordinates: tuple  # indices in v of those that move by integrate (ball, planar, free)
    periodic_coordinates: np.ndarray  # indices in q of angles whose q is the angle itself (q ± 2π: one pose)
    periodic_tangents: frozenset  # their indices in v
    inertia_scales: np.ndarray  # kg (m) or kg·m² (rad) per coordinate: the scale of M's diagonal
    inertia_weights: np.ndarray  # 1/√(s_i s_j) of the inertia scales (vibdyn.model.inertia_check)
    force_groups: tuple  # the force-element groups, one per kind the scene has
    point_groups: tuple  # those that need joint poses
    joint_groups: tuple  # the others
    point_joints: tuple  # Pinocchio joints the point groups apply forces to
    uses_point_velocities: bool
    depends_on_velocity: bool
    compiled_drives: Any  # the drives' table (vibdyn.model.drives.Drives, None without drives): refers to no System
    compiled_loops: Any  # the loops' table (vibdyn.model.constraints.Constraints, None without loops): the same

    @property
    def drives(self) -> Any:
        """The scene's drives (:class:`vibdyn.model.drives.Drives`; None without drives): the compiled table bound
        to this system on each access (``system.drives.forces(q, v, t)``), so that nothing compiled refers back to
        the System."""
        table = self.compiled_drives
        return None if table is None else table.bound(self)

    @property
    def constraints(self) -> Any:
        """The scene's closed loops (:class:`vibdyn.model.constraints.Constraints`; None without loops): the compiled
        table bound to this system on each access (``system.constraints.assembly()``), as :attr:`drives`."""
        table = self.compiled_loops
        return None if table is None else table.bound(self)

    def _compile_tree(self, scene: Any) -> Workspace:
        """Compile a scene's tree into this object's tables; return the first workspace (made at build: a
        scene too large for memory is refused there). ModelError for a massless leaf."""
        self.scene = scene = scene.copy()
        self.name = scene.name
        order = scene.tree_order()
        leaves = scene.massless_leaves(order)
        if leaves:
            raise ModelError(f"body '{leaves[0]}' has zero mass and carries no mass: its motion is undefined "
                             "(give it a mass or weld it with Fixed; for a loaded robot: weld_massless=True)")
        model, infos = compile_model(scene, order)
        model.gravity.linear = np.array(scene.gravity)
        self.model, self.body_infos = model, MappingProxyType(infos)
        self.model_without_gravity = pin.Model(model)
        self.model_without_gravity.gravity = pin.Motion.Zero()
        ws = Workspace(model)
        self.nq, self.nv = model.nq, model.nv
        nv = model.nv
        self.unit_blocks = tuple((b.name, b.idx_q + b.joint.unit_block[0], b.joint.unit_block[1])
                                 for b in infos.values() if b.joint.unit_block is not None)
        self.coordinates = tuple(c for b in infos.values() for c in b.coordinates)
        self.units = tuple(u for b in infos.values() for u in b.joint.units)
        self.bodies = tuple(infos)
        self.limits = MappingProxyType(dict(scene.limits))
        lower, upper = np.full(nv, -np.inf), np.full(nv, np.inf)
        for name, (lo, up) in self.limits.items():
            lower[self.coordinates.index(name)], upper[self.coordinates.index(name)] = lo, up
        self.lower_limits, self.upper_limits = _readonly(lower), _readonly(upper)
        self.has_gravity = bool(np.any(scene.gravity))
        self.supports = tuple(scene.elements_of(Support))
        self.support_index = MappingProxyType({s.name: i for i, s in enumerate(self.supports)})
        self.length_scale, extent = length_scale(scene, model, ws.data, infos)
        scales = np.array([self.length_scale if u == "m" else 1.0 for u in self.units])
        self.coordinate_scales = _readonly(scales)
        self.inverse_scale_products = _readonly(1.0 / np.outer(scales, scales))
        self.unit_scales = bool(np.all(scales == 1.0))
        additive = [(b.idx_v + i, b.idx_q + i) for b in infos.values() if b.nq == b.nv for i in range(b.nv)]
        self.additive_coordinates = tuple(np.array(c, dtype=int) for c in zip(*additive)) if additive else (
            np.zeros(0, int), np.zeros(0, int))
        self.curved_coordinates = tuple(k for b in infos.values() if b.nq != b.nv for k in b.v_indices)
        self.periodic_coordinates = _readonly(np.array([b.idx_q + i for b in infos.values()
                                                        for i, p in enumerate(b.joint.periodic) if p], dtype=int))
        self.periodic_tangents = frozenset(b.idx_v + i for b in infos.values()
                                           for i, p in enumerate(b.joint.periodic) if p)
        self.inertia_scales = s = inertia_scales(scene, self.units, extent)
        self.inertia_weights = _readonly(1.0 / np.outer(np.sqrt(s), np.sqrt(s)))
        return ws

    def _compile_elements(self) -> None:
        """The force-element groups, once the tree is compiled (they use the System's lookups:
        ``attachments``, ``body_info``, ...), and what they need."""
        for key, value in _group_tables(compile_groups(self, self.scene)).items():
            setattr(self, key, value)

    def without_groups(self, dropped: Any) -> Any:
        """A view of this compiled system with the force groups ``dropped`` left out (the same model, bodies and
        tables, their force-group tables made again; workspaces of its own): e.g. its conservative part, dampers
        off. Its ``scene`` is a copy of this one's without the dropped groups' elements: what it shows is what it
        computes (a scene file written from it, its table of elements)."""
        from .workspace import PerThread

        view = object.__new__(type(self))
        view.__dict__.update(self.__dict__)
        groups = tuple(g for g in self.force_groups if not any(g is d for d in dropped))
        gone = {name for g in dropped for name in g.members}
        scene = self.scene.copy()
        scene.elements = {name: e for name, e in scene.elements.items() if name not in gone}
        view.__dict__.update(_group_tables(groups), _per_thread=PerThread(), scene=scene)
        view.__dict__["depends_on_time"] = any(g.time_dependent for g in groups) or bool(
            self.supports or self.compiled_drives)
        return view


def _group_tables(groups: Any) -> dict:
    """The force-group tables of a compiled system: the groups, those with and without points, the joints point
    elements attach to, and what they depend on."""
    groups = tuple(groups)
    point = tuple(g for g in groups if g.uses_points)
    return {"force_groups": groups, "point_groups": point,
            "joint_groups": tuple(g for g in groups if not g.uses_points),
            "point_joints": tuple(sorted({int(j) for g in point for j in g.joints} - {0})),
            "uses_point_velocities": any(g.uses_point_velocities for g in groups),
            "depends_on_velocity": any(g.velocity_dependent for g in groups)}


def attachments(system: Any, atts: Any) -> tuple[np.ndarray, np.ndarray]:
    """(joint ids, points in joint frames, m) of ``[(body, point), ...]``; world and support points on joint 0."""
    joints, local = [], []
    for body, point in atts:
        if body == WORLD or body in system.support_index:
            joints.append(0)
            local.append(np.asarray(point, dtype=float))
        else:
            b = system.body_info(body)
            joints.append(b.joint_id)
            local.append(b.body_in_joint.act(np.asarray(point, dtype=float)))
    return np.array(joints, dtype=int), np.array(local, dtype=float).reshape(-1, 3)

def compile_model(scene: Any, order: list) -> tuple[pin.Model, dict[str, BodyInfo]]:
    """The Pinocchio model of a scene (bodies in ``order``) and, per body, where it lives in it."""
    model = pin.Model()
    model.name = scene.name
    infos: dict[str, BodyInfo] = {}
    for body in order:
        if body.parent == WORLD:
            parent_jid, parent_B = 0, pin.SE3.Identity()
        else:
            p = infos[body.parent]
            parent_jid, parent_B = p.joint_id, p.body_in_joint
        J = body.joint
        placement = parent_B * J.placement
        if J.nv == 0:
            jid, B = parent_jid, placement
            idx_q = idx_v = model.nq if parent_jid == 0 else model.idx_qs[parent_jid]
        else:
            A = J.alignment
            jid = model.addJoint(parent_jid, J.pin_model(), placement * pin.SE3(A, np.zeros(3)),
                                 J.name or body.name)
            B = pin.SE3(A.T, np.zeros(3))
            idx_q, idx_v = model.idx_qs[jid], model.idx_vs[jid]
        I_body = np.array(body.inertia)
        inertia = pin.Inertia(body.mass, B.act(np.array(body.com)), B.rotation @ I_body @ B.rotation.T)
        append_body(model, jid, inertia)
        if J.nv:  # (Pinocchio's addFrame searches every frame by name: one per welded body would be quadratic)
            model.addFrame(pin.Frame(body.name, jid, B, pin.FrameType.BODY), False)  # inertia added above
        infos[body.name] = BodyInfo(body.name, J, jid, B, idx_q, idx_v, J.nv and model.nqs[jid], J.nv,
                                    body.coordinates)
    return model, infos


def append_body(model: pin.Model, jid: int, inertia: pin.Inertia) -> None:
    """Add a body's inertia to joint ``jid``'s. Summed as dynamic parameters (m, m·c, I about the joint:
    linear, no division): Pinocchio's Inertia addition divides by max(m, ε) and so moves the centre of mass
    of a body lighter than ε ≈ 2e-16 kg to the joint."""
    p = model.inertias[jid].toDynamicParameters() + inertia.toDynamicParameters()
    model.appendBodyToJoint(jid, pin.Inertia.Zero(), pin.SE3.Identity())
    if p[0] > 0:
        model.inertias[jid] = pin.Inertia.FromDynamicParameters(p)
    else:  # massless: the rotational inertia about the joint only
        I = np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]])
        model.inertias[jid] = pin.Inertia(0.0, np.zeros(3), I)


def length_scale(scene: Any, model: pin.Model, data: pin.Data, infos: Mapping[str, BodyInfo]) -> tuple[float, float]:
    """(length scale, extent) (m): the largest distance of a body origin, centre of mass or spring end from the
    world origin at the neutral configuration, or a spring's free length (at least 1 mm); and the bodies' own
    extent (without the elements: what sizes their inertia). Forward kinematics in ``data``."""
    pin.forwardKinematics(model, data, pin.neutral(model))
    pts = [np.zeros(3)]
    for b in infos.values():
        M = data.oMi[b.joint_id] * b.body_in_joint
        pts += [M.translation, M.act(np.array(scene.bodies[b.name].com))]
    extent = max(1e-3, float(np.max(np.linalg.norm(pts, axis=1))))
    ends = [np.array(p, dtype=float) for e in scene.elements.values() for p in e.reference_points()]
    lengths = [float(x) for e in scene.elements.values() for x in e.reference_lengths()]
    return max([extent, *(float(np.linalg.norm(p)) for p in ends), *lengths]), extent


def inertia_scales(scene: Any, units: tuple, extent: float) -> np.ndarray:
    """Per coordinate, the scene's scale of M's diagonal: its total mass (kg, for m) or total mass × the
    bodies' extent² (m) plus their rotational inertias (kg·m², for rad; a spring's far end or free length
    does not size a body's inertia)."""
    bodies = scene.bodies.values()
    mass = sum(b.mass for b in bodies)
    rot = mass * extent**2 + sum(float(np.trace(np.array(b.inertia))) for b in bodies)
    return _readonly(np.array([mass if u == "m" else rot for u in units]))
