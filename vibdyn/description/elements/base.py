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

    def describe(self, scene: Any = None) -> str:
        """One line for ``vibdyn info`` (``scene``: where the element is, for the units of its joint)."""
        return ""

    def joint_units(self, scene) -> tuple:
        """The units ("m" or "rad") of the coordinates of the joint the element acts on (``body``), () if
        unknown."""
        found = scene.find_body(getattr(self, "body", None)) if scene is not None else None
        return found.joint.units if found is not None else ()

    def reference_points(self) -> tuple:
        """Points (m) that size the scene (:attr:`vibdyn.System.length_scale`)."""
        return ()

    def reference_lengths(self) -> tuple:
        """Lengths (m) that size the scene, wherever its bodies are (a spring's free length)."""
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
_LEVI_CIVITA = np.zeros((3, 3, 3))
_LEVI_CIVITA[0, 1, 2] = _LEVI_CIVITA[1, 2, 0] = _LEVI_CIVITA[2, 0, 1] = 1.0
_LEVI_CIVITA[0, 2, 1] = _LEVI_CIVITA[2, 1, 0] = _LEVI_CIVITA[1, 0, 2] = -1.0


def cross(a, b):
    """Row-wise cross product of (n, 3) arrays, (a × b)_i = ε_ijk a_j b_k in one einsum (numpy's own cross
    is slow on small arrays)."""
    return np.einsum("ijk,nj,nk->ni", _LEVI_CIVITA, a, b)


_NO_SUPPORT = np.zeros((1, 3))
_ONES3 = np.ones(3)


class Kinematics:
    """Poses (and local velocities if asked) of the joints that point elements attach to: ``R``, ``p`` (and
    ``v``, ``w``) indexed by Pinocchio joint id, rows of other joints zero; joint 0 (the world) is the
    identity at rest. Computed in the workspace ``ws`` (its Data, and its live views of the Data's joint
    poses and velocities, one per joint: ``rotations``, ``translations``, ``linear``, ``angular``), read
    after forward kinematics in one copy per array. ``R`` and ``p`` are views of one vector ``pose`` =
    (R, p), of which point positions are linear functions (:class:`PointSet`)."""

    __slots__ = ("R", "p", "pose", "v", "w", "sp", "sv", "q")

    def __init__(self, model, ws, joints, q, v=None, supports=None):
        self.q = q  # (where an element that cannot be evaluated says it met its singular point)
        # support displacements and velocities (m, m/s), one row per support and a last zero row, so that
        # index −1 (an end on no support) adds nothing
        self.sp, self.sv = supports if supports is not None else (_NO_SUPPORT, _NO_SUPPORT)
        if v is None:
            pin.forwardKinematics(model, ws.data, q)
        else:
            pin.forwardKinematics(model, ws.data, q, v)
        nj = len(ws.rotations)
        self.pose = np.empty(12 * nj) if len(joints) == nj - 1 else np.zeros(12 * nj)
        self.R = gather(ws.rotations, joints, self.pose[:9 * nj].reshape(nj, 3, 3))
        self.p = gather(ws.translations, joints, self.pose[9 * nj:].reshape(nj, 3))
        if v is not None:
            self.v, self.w = gather(ws.linear, joints, np.zeros((nj, 3))), gather(ws.angular, joints, np.zeros((nj, 3)))

    def points(self, joints, local):
        """World positions (m) of points given in their joint frames."""
        return np.einsum("nij,nj->ni", self.R[joints], local) + self.p[joints]

    def velocities(self, joints, local):
        """World velocities (m/s) of points given in their joint frames."""
        lin = self.v[joints] + cross(self.w[joints], local)
        return np.einsum("nij,nj->ni", self.R[joints], lin)


def gather(views, joints, out):
    """``out`` with the arrays ``views[j]`` of joint 0 (the world's identity pose, zero velocity) and of the
    sorted ``joints`` as its rows, indexed by joint id (rows of other joints left as they are: zeros, as
    PointSet's constant maps take every row)."""
    if len(joints) == len(views) - 1:  # every joint: one copy
        out[:] = views
    else:
        out[0] = views[0]
        for j in joints:
            out[j] = views[j]
    return out


# Above this many numbers in PointSet's dense maps (points × joints), the per-point gather and scatter of
# ScatteredPoints is faster (measured: 30 springs on 30 pivots 75 µs dense vs 280 µs per point; 300 on 300,
# 7.8 ms dense vs 1.2 ms per point)
DENSE_MAX = 200_000


def point_set(joints, local, nj, D=None):
    """The faster of :class:`PointSet` (dense constant maps, small scenes) and :class:`ScatteredPoints`
    (per-point gather and scatter, large ones) for these points: same protocol, same results."""
    joints = np.asarray(joints, dtype=int)
    moving = joints[joints > 0]
    span = int(moving.max() - moving.min() + 1) if moving.size else 0
    n = len(joints) if D is None else len(D)
    size = 3 * n * 12 * nj + 54 * span * 3 * n
    return (PointSet if size <= DENSE_MAX else ScatteredPoints)(joints, local, nj, D)


class ScatteredPoints:
    """:class:`PointSet`'s protocol by per-point gathers of the joint poses and one scatter of the forces:
    O(points) work and memory, for scenes too large for dense maps."""

    def __init__(self, joints, local, nj, D=None):
        self.joints = np.asarray(joints, dtype=int)
        self.local = np.asarray(local, dtype=float).reshape(-1, 3)
        self.D = None if D is None else np.asarray(D, dtype=float)

    def positions(self, kin):
        """The combined world positions D x (m), n × 3."""
        x = kin.points(self.joints, self.local)
        return x if self.D is None else self.D @ x

    def add_forces(self, F, kin, f):
        """Accumulate the forces Dᵀ f (world axes; ``f`` n × 3) on the points into ``F``."""
        f = f if self.D is None else self.D.T @ f
        fl = np.einsum("nji,nj->ni", kin.R[self.joints], f)  # Rᵀ f, in each point's joint frame
        np.add.at(F, self.joints, np.concatenate([fl, cross(self.local, fl)], axis=1))


class PointSet:
    """Fixed points of joint frames (``joints``, ``local`` points in those frames, of a model of ``nj``
    joints) seen through n combinations ``D`` (n × points; None: the points themselves): the combined
    positions D x and the forces Dᵀ f on the points for n given forces f, as constant linear maps of the
    joint poses.

    A position R r + p is linear in joint j's (R, p): D x is one constant matrix times the joints' poses
    (:attr:`Kinematics.pose`). In j's frame a force f (world axes) at r is (Rᵀ f, r × Rᵀ f), bilinear in
    (R, f): one constant matrix times f gives its coefficients on the rotations of the contiguous span of
    joints the points are on (the world, joint 0, takes no force). The matrices are dense, of size
    (points × joints): a few matrix products for the tens of elements of a scene, in place of per-point
    indexing and scatter."""

    def __init__(self, joints, local, nj, D=None):
        joints = np.asarray(joints, dtype=int)
        local = np.asarray(local, dtype=float).reshape(-1, 3)
        D = np.eye(len(joints)) if D is None else np.asarray(D, dtype=float)
        moving = np.flatnonzero(joints)
        lo, hi = (int(joints[moving].min()), int(joints[moving].max()) + 1) if len(moving) else (0, 0)
        self.span, k, n = slice(lo, hi), hi - lo, len(D)
        G = np.zeros((len(joints), 3, 12 * nj))  # x[e, i] = G[e, i] · (R, p)
        B = np.zeros((k, 6, len(joints), 3))  # (force, moment) on each joint per local force at each point
        for e, (j, r) in enumerate(zip(joints, local)):
            for i in range(3):
                G[e, i, 9 * j + 3 * i:9 * j + 3 * i + 3], G[e, i, 9 * nj + 3 * j + i] = r, 1.0
            if j != 0:
                B[j - lo, :3, e], B[j - lo, 3:, e] = np.eye(3), pin.skew(r)
        self.G = np.einsum("me,eX->mX", D, G.reshape(len(joints), -1)).reshape(3 * n, 12 * nj)
        # F_j,a = Σ_ik C[j, a, i, k] R_j[i, k] with C = K f: K[j, a, i, k, l, i] = Σ_e B[j, a, e, k] D[l, e]
        BD = np.einsum("jaek,le->jakl", B, D)
        K = np.zeros((k, 6, 3, 3, n, 3))
        for i in range(3):
            K[:, :, i, :, :, i] = BD
        self.K = K.reshape(54 * k, 3 * n)

    def positions(self, kin):
        """The combined world positions D x (m), n × 3."""
        return (self.G @ kin.pose).reshape(-1, 3)

    def add_forces(self, F, kin, f):
        """Accumulate the forces Dᵀ f (world axes; ``f`` n × 3) on the points into ``F``."""
        s = self.span
        R = kin.R[s]
        F[s] += ((self.K @ f.ravel()).reshape(len(R), 6, 9) @ R.reshape(len(R), 9, 1)).reshape(len(R), 6)


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

    def apply_rows(self, t, q, v, Q):
        """A joint-space group's generalized forces at many states at once: rows of q (B × nq) and v (B × nv,
        or one nv-vector for every row) add into the rows of Q (B × nv). A group whose force is plain numpy
        over coordinates overrides this with one evaluation of all rows; this default calls :meth:`apply`
        row by row."""
        for c in range(len(q)):
            self.apply(t, q[c], v[c] if v.ndim == 2 else v, None, Q[c], None)

    def potential(self, q, kin):
        return 0.0

    def derivatives(self, d):
        """Analytic derivatives (see :mod:`vibdyn.model.derivatives`, whose ``d`` gives the point Jacobians,
        force accumulators and finite differences of user callables): a point group adds its forces'
        derivatives through ``d.add_force``; a joint group returns (∂Q/∂q, ∂Q/∂v), each None for zero."""
        raise NotImplementedError


class TwoPoint(Group):
    """Elements between two points: ends a and b of each member (the ends' arrays: a's then b's)."""

    uses_points = True
    tiny: np.ndarray  # lengths at or below these are zero (negative: the member may reach zero length)

    def __init__(self, system, elements):
        self.names = [e.name for e in elements]
        self.ja, self.pa = system.attachments([e.a for e in elements])
        self.jb, self.pb = system.attachments([e.b for e in elements])
        self.sa = system.support_indices([e.a for e in elements])
        self.sb = system.support_indices([e.b for e in elements])
        self.joints = tuple(sorted(set(self.ja) | set(self.jb)))
        self.j_ends = np.concatenate([self.ja, self.jb])
        self.on_supports = bool(np.any(self.sa >= 0) or np.any(self.sb >= 0))
        n = len(elements)
        self.ends = point_set(self.j_ends, np.concatenate([self.pa, self.pb]), system.model.njoints,
                             np.hstack([-np.eye(n), np.eye(n)]))  # combined: xb − xa

    def end_velocities(self, kin):
        """World velocities (m/s) of the two ends, supports' motion included."""
        return (kin.velocities(self.ja, self.pa) + kin.sv[self.sa],
                kin.velocities(self.jb, self.pb) + kin.sv[self.sb])

    def geometry(self, kin):
        """(d, L): d = xb − xa between the world ends (m) and the lengths L (m); a length at or below ``tiny``
        is a ModelError naming the element."""
        d = self.ends.positions(kin)
        if self.on_supports:
            d += kin.sp[self.sb] - kin.sp[self.sa]
        L = np.sqrt((d * d) @ _ONES3)
        zero = (L <= self.tiny).tolist()  # a list: faster than a numpy reduction on a few elements
        if True in zero:
            i = zero.index(True)
            xa = kin.points(self.ja[i:i + 1], self.pa[i:i + 1])[0] + kin.sp[self.sa[i]]
            raise ModelError(f"{self.kind} '{self.names[i]}' reached zero length at the configuration q = "
                             f"{np.round(kin.q, 9).tolist()} (its two ends coincide at {np.round(xa, 12).tolist()} m):"
                             " its direction, and so its force, is undefined there; start the analysis or the "
                             "motion away from it (q0=, or Scene.set_operating_point(start=...))")
        return d, L

    kind = "element"


def as_slice(index):
    """An index array as the equal slice when its entries are consecutive and increasing (a view, not a
    gather), else the array itself."""
    index = np.asarray(index, dtype=int)
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + index.size)
    return index


def tangent(model, body, rest):
    """A tangent vector of the model with ``rest`` on ``body``'s coordinates and zeros elsewhere."""
    dv = np.zeros(model.nv)
    dv[body.idx_v:body.idx_v + body.nv] = rest
    return dv
