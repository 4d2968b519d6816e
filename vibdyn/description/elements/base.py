"""What every force-element kind shares: attachments, the kind protocol and its registry, and the numpy
building blocks of the compiled groups (joint poses, point forces).

A kind is one module of this package declaring, in one place: its data (a frozen dataclass subclassing
:class:`ElementKind`), its checks (``add``: the ``Scene.add_<table>`` method), its scene-file schema
(``table``, ``keys``, ``required``, ``from_file``, ``to_dict``), how ``vibdyn info`` describes it
(``describe``), its compiled evaluation (``group``: a :class:`Group` of all its members) and the group's
analytic derivatives (``Group.derivatives``). The model layer compiles the groups of the kinds a scene has
(:func:`vibdyn.model.forces.compile_groups`); scene files, the CLI and the analytic linearisation read the
same declarations. Attachment points are ``(body, (x, y, z))`` with the point in the body frame (m), or
``("world", point)``, or ``(support_name, point)`` (world axes).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import pinocchio as pin

from ..._check import finite_array, vector3
from ...errors import ModelError

WORLD = "world"

#: table name -> kind class, in the order groups are compiled and scene files are read and written
KINDS: dict[str, type[ElementKind]] = {}


class ElementKind:
    """Base of the force-element data classes (see the module docstring for the protocol)."""

    table: ClassVar[str] = ""  # scene-file table [[table]] and Scene.add_<table>
    keys: ClassVar[dict[str, Any]] = {}  # scene-file key -> value check (vibdyn._check's value_* functions)
    required: ClassVar[tuple[str, ...]] = ()
    group: ClassVar[type | None] = None  # compiled evaluation of all members (None: no force of its own)

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("table"):
            if cls.table in KINDS:
                raise TypeError(f"element kind table '{cls.table}' declared twice")
            KINDS[cls.table] = cls

    @classmethod
    def add(cls, scene, *args, **kwargs) -> ElementKind:
        """Check the arguments and add one element to ``scene`` (what ``Scene.add_<table>`` does)."""
        raise NotImplementedError

    @classmethod
    def from_file(cls, scene, entry: dict, error) -> ElementKind:
        """Add the element of a checked scene-file entry (``error(subkey, message)`` makes the file's error)."""
        return cls.add(scene, **entry)

    def to_dict(self) -> dict:
        """The scene-file entry (plain data)."""
        raise NotImplementedError

    def describe(self) -> str:
        """One line for ``vibdyn info``."""
        return ""

    def reference_points(self) -> tuple:
        """Points (m) that size the scene (:attr:`vibdyn.System.length_scale`)."""
        return ()

    @property
    def label(self) -> str:
        return self.table.replace("_", " ")


def attachment(value, what):
    """``"body"`` or ``(body, point)`` → ``(body, (x, y, z))``."""
    if isinstance(value, str):
        return value, (0.0, 0.0, 0.0)
    try:
        body, point = value
    except (TypeError, ValueError):
        raise ModelError(f"{what}: expected (body, (x, y, z)), got {value!r}") from None
    if not isinstance(body, str):
        raise ModelError(f"{what}: body name must be a string, got {body!r}")
    return body, tuple(float(x) for x in vector3(point, what))


def file_attachment(a):
    """A scene file's attachment ("body" or [body, [x, y, z]]) as the Scene API takes it."""
    return a if isinstance(a, str) else (a[0], tuple(a[1]))


def att_list(a):
    return [a[0], list(a[1])]


def scalar_or_list(x):
    if isinstance(x, (tuple, list)):
        return x[0] if len(x) == 1 else list(x)
    return x


def numbers(value, shape):
    """``value`` as finite floats of ``shape`` (None: any), or None if it is not (the caller says why)."""
    try:
        return finite_array(value, shape, "")
    except ModelError:
        return None


def end_label(a):
    from ..._format import vector

    return f"{a[0]}{vector(a[1])}"


# ---------------------------------------------------------------------------------------------- groups
def cross(a, b):
    """Row-wise cross product of (n, 3) arrays (numpy's own is slow on small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


_NO_SUPPORT = np.zeros((1, 3))


class Kinematics:
    """Poses (and local velocities if asked) of the joints that point elements attach to."""

    __slots__ = ("R", "p", "v", "w", "sp", "sv")

    def __init__(self, model, data, joints, q, v=None, supports=None):
        # support displacements and velocities (m, m/s), one row per support and a last zero row, so that
        # index −1 (an end on no support) adds nothing
        self.sp, self.sv = supports if supports is not None else (_NO_SUPPORT, _NO_SUPPORT)
        if v is None:
            pin.forwardKinematics(model, data, q)
        else:
            pin.forwardKinematics(model, data, q, v)
        nj = model.njoints
        self.R = np.empty((nj, 3, 3))
        self.p = np.empty((nj, 3))
        self.R[0], self.p[0] = np.eye(3), 0.0
        for j in joints:
            M = data.oMi[j]
            self.R[j], self.p[j] = M.rotation, M.translation
        if v is not None:
            self.v = np.zeros((nj, 3))
            self.w = np.zeros((nj, 3))
            for j in joints:
                vj = data.v[j]
                self.v[j], self.w[j] = vj.linear, vj.angular

    def points(self, joints, local):
        """World positions (m) of points given in their joint frames."""
        return np.einsum("nij,nj->ni", self.R[joints], local) + self.p[joints]

    def velocities(self, joints, local):
        """World velocities (m/s) of points given in their joint frames."""
        lin = self.v[joints] + cross(self.w[joints], local)
        return np.einsum("nij,nj->ni", self.R[joints], lin)


def add_point_forces(F, kin, joints, world_points, world_forces):
    """Accumulate forces (world axes) applied at world points into the local spatial forces ``F``."""
    # Rᵀ applied to the force and to the lever arm at once: (n, 3, 3)ᵀ @ (n, 3, 2)
    fr = np.matmul(np.transpose(kin.R[joints], (0, 2, 1)),
                   np.stack([world_forces, world_points - kin.p[joints]], axis=2))
    f, r = fr[:, :, 0], fr[:, :, 1]
    np.add.at(F, joints, np.concatenate([f, cross(r, f)], axis=1))


class Group:
    """One kind of force element, all members at once: adds its generalized force to ``Q`` (joint space,
    length nv) and, for point elements, spatial forces to ``F`` (one row (force, moment) per Pinocchio
    joint, in that joint's frame) that the system hands to ABA/RNEA as external forces."""

    uses_points = False  # needs joint poses (point elements)
    uses_point_velocities = False
    needs_velocity_derivatives = False  # its derivatives need ∂(point velocities)/∂q
    velocity_dependent = False
    time_dependent = False
    joints: tuple = ()  # Pinocchio joints it applies forces to

    def apply(self, t, q, v, kin, Q, F):
        raise NotImplementedError

    def potential(self, q, kin):
        return 0.0

    def derivatives(self, d):
        """Analytic derivatives (see :mod:`vibdyn.model.derivatives`, whose ``d`` gives the point Jacobians,
        force accumulators and finite differences of user callables): a point group adds its forces'
        derivatives through ``d.add_force``; a joint group returns (∂Q/∂q, ∂Q/∂v), each None for zero."""
        raise NotImplementedError


class TwoPoint(Group):
    """Elements between two points: ends a and b of each member."""

    uses_points = True
    tiny: np.ndarray

    def __init__(self, system, elements):
        self.names = [e.name for e in elements]
        self.ja, self.pa = system.attachments([e.a for e in elements])
        self.jb, self.pb = system.attachments([e.b for e in elements])
        self.sa = system.support_indices([e.a for e in elements])
        self.sb = system.support_indices([e.b for e in elements])
        self.joints = tuple(sorted(set(self.ja) | set(self.jb)))
        self.j_ends = np.concatenate([self.ja, self.jb])

    def add_end_forces(self, F, kin, xa, xb, fb):
        """Force fb (world axes) on every end b and −fb on every end a, in one accumulation."""
        add_point_forces(F, kin, self.j_ends, np.concatenate([xa, xb]), np.concatenate([-fb, fb]))

    def end_velocities(self, kin):
        """World velocities (m/s) of the two ends, supports' motion included."""
        return (kin.velocities(self.ja, self.pa) + kin.sv[self.sa],
                kin.velocities(self.jb, self.pb) + kin.sv[self.sb])

    def geometry(self, kin, zero_ok=None):
        """(xa, xb, d, L): world ends (m), d = xb − xa and lengths L (m); a zero length is a ModelError
        naming the element (``zero_ok`` marks elements allowed to reach it)."""
        xa = kin.points(self.ja, self.pa) + kin.sp[self.sa]
        xb = kin.points(self.jb, self.pb) + kin.sp[self.sb]
        d = xb - xa
        L = np.linalg.norm(d, axis=1)
        tiny = L <= self.tiny
        if zero_ok is not None:
            tiny &= ~zero_ok
        if tiny.any():
            i = int(np.flatnonzero(tiny)[0])
            raise ModelError(f"{self.kind} '{self.names[i]}' reached zero length (its two ends coincide at "
                             f"{np.round(xa[i], 12).tolist()}): its direction is undefined")
        return xa, xb, d, L

    kind = "element"


def tangent(model, body, rest):
    """A tangent vector of the model with ``rest`` on ``body``'s coordinates and zeros elsewhere."""
    dv = np.zeros(model.nv)
    dv[body.idx_v:body.idx_v + body.nv] = rest
    return dv
