"""Joints (links) between a body and its parent: what moves, about which axis, and where.

Every joint is placed in its parent body's frame by ``at`` (m) and ``rotation`` (a 3×3 matrix or a rotation
vector in rad). At the neutral configuration the child body's frame is that placed frame; axes are given in
the child body's frame (equal to the parent's axes when ``rotation`` is None).

Tangent coordinates (the velocity vector v) per joint, named ``<body><suffix>``:

=============  ==  ==  =========================================================
joint          nq  nv  coordinates
=============  ==  ==  =========================================================
Pivot           1   1  angle about ``axis`` (rad)
Slider          1   1  travel along ``axis`` (m)
Helical         1   1  angle (rad); the body also advances ``pitch`` m per rad
Cylindrical     2   2  ``.s`` travel (m), ``.theta`` angle (rad), same axis
Universal       2   2  ``.theta1`` about ``axis1``, ``.theta2`` about ``axis2``
Planar          4   3  ``.x``, ``.y`` (m), ``.theta`` (rad) in the plane normal to ``normal``
Ball            4   3  ``.rx .ry .rz`` rotation (rad, body axes); q is a unit quaternion
Free            7   6  ``.x .y .z`` (m), ``.rx .ry .rz`` (rad), in body axes
Fixed           0   0  none (the body is welded to its parent)
=============  ==  ==  =========================================================
"""

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pinocchio as pin

from .._check import (
    kind_of,
    rotation_matrix,
    scalar,
    unit_axis,
    value_number,
    value_rotation,
    value_string,
    value_vec3,
    vector3,
)
from .._deprecation import Renamed, warn_once
from ..errors import ModelError


def _floats(a):
    return tuple(float(x) for x in a)


@dataclass(frozen=True, eq=False)
class Joint:
    """Common placement of every joint: ``at`` (m) and ``rotation`` in the parent body frame."""

    at: tuple = (0.0, 0.0, 0.0)
    rotation: object = None
    name: str | None = None  # optional joint name (URDF joint name); body name is used otherwise

    type = "joint"  # the joint type: the name scene files give it (``type = "pivot"``)
    kind = Renamed("type")
    group = Renamed("lie_group")
    #: scene-file keys every joint takes, and each type's own (``file_keys``, ``file_required``)
    common_file_keys: ClassVar[dict] = {"type": value_string, "at": value_vec3, "rotation": value_rotation,
                                        "name": value_string}
    file_keys: ClassVar[dict] = {}
    file_required: ClassVar[tuple] = ()
    suffixes: ClassVar[tuple[str, ...]] = ()
    units: ClassVar[tuple[str, ...]] = ()  # "m" or "rad" per coordinate
    #: per coordinate: an angle whose q is the angle itself, so that q and q ± 2π are the same pose
    periodic: ClassVar[tuple[bool, ...]] = ()
    # What the rest of vibdyn asks of a joint type, declared here (a new type is this module's class alone):
    #: names of the components of q (default: the coordinates' suffixes, nq = nv)
    q_names: ClassVar[tuple[str, ...] | None] = None
    #: (offset, size) within the joint's q of a block kept at unit norm (a quaternion, a (cos, sin) pair)
    unit_block: ClassVar[tuple[int, int] | None] = None
    #: tangent components that are rotations of a curved (Lie-group) joint, whose chart holds only so far
    chart_rotations: ClassVar[tuple[int, ...]] = ()
    #: the Lie group of a curved joint ("SO3", "SE3", "SE2": the symplectic integrator's coadjoint), or None
    lie_group: ClassVar[str | None] = None
    #: a joint spring with one stiffness gives the torque −kφ exactly (no Jacobian of the difference)
    isotropic_spring: ClassVar[bool] = False
    #: the rows a loop closed by this joint makes (None: it cannot close a loop): "position" p_b − p_a (3),
    #: "normal" (R_a n)·(p_b − p_a) per :meth:`loop_normals`, "aligned" (R_a n)·(R_b u) per
    #: :meth:`loop_alignments`, "locked" log(R_aᵀ R_b) (3)
    loop_rows: ClassVar[tuple[str, ...] | None] = None
    #: Pinocchio joint models (``shortname()``) this type stands for when a robot file is read
    pinocchio_models: ClassVar[frozenset[str]] = frozenset()
    #: Pinocchio's analytic RNEA/ABA derivatives are right for this joint (tests/test_joint_derivatives.py
    #: checks every type against central differences); False: vibdyn differences its columns instead
    analytic_derivatives: ClassVar[bool] = True
    problem = None  # what is wrong with the parameters (str), reported when the joint joins a scene

    def __post_init__(self):
        try:
            self._check()
        except ModelError as e:  # raised by checked(), with the body's name, when the joint joins a scene
            object.__setattr__(self, "problem", str(e))

    @classmethod
    def from_file(cls, params: dict, error) -> "Joint":
        """The joint of a scene file's checked ``params`` (``error(subkey, message)`` makes the file's error)."""
        return cls(**params)

    def checked(self, what=None):
        """The joint, or the ModelError saying what is wrong with its parameters (after ``what``, e.g.
        "body 'rod'": a joint is made before the body it will carry, so only the scene can name it)."""
        if self.problem:
            raise ModelError(f"{what}: {self.problem}" if what else self.problem)
        return self

    def _check(self):
        """Check and normalise the parameters (ModelError naming the parameter)."""
        if self.name is not None and (not isinstance(self.name, str) or not self.name
                                      or self.name.strip() != self.name):
            raise ModelError(f"{self.type} joint name must be a non-empty string without surrounding spaces,"
                             f" got {self.name!r}")
        object.__setattr__(self, "at", _floats(vector3(self.at, f"{self._what} 'at'")))
        if self.rotation is not None:
            R = rotation_matrix(self.rotation, f"{self._what} 'rotation'")
            object.__setattr__(self, "rotation", tuple(_floats(r) for r in R))

    @property
    def _what(self):
        """How error messages name this joint: its kind, and its name if it has one."""
        return f"{self.type} joint '{self.name}'" if self.name else f"{self.type} joint"

    @property
    def placement(self):
        """Placement of the joint frame in the parent body frame (pin.SE3)."""
        R = np.eye(3) if self.rotation is None else np.array(self.rotation)
        return pin.SE3(R, np.array(self.at))

    @property
    def alignment(self):
        """Rotation from the body frame to Pinocchio's joint frame (identity unless the joint needs it)."""
        return np.eye(3)

    @property
    def nv(self):
        return len(self.suffixes)

    @property
    def nq(self):
        return self.nv if self.q_names is None else len(self.q_names)

    @property
    def scalar(self):
        """One coordinate, q the coordinate itself (pivot, slider, helical): what a servo, a cubic spring or a
        drive acts on."""
        return self.nv == 1 and self.nq == 1

    def markers(self):
        """How a viewer marks the joint: [(shape, axis)] with shape "cylinder" (a turning axis), "box" (a
        sliding one) or "sphere" (axis None); default a sphere."""
        return [("sphere", None)]

    def pin_model(self):
        raise NotImplementedError

    @classmethod
    def from_pinocchio(cls, jm, S, **placement) -> "Joint":
        """The joint for Pinocchio joint model ``jm`` (one of :attr:`pinocchio_models`) with motion subspace S
        (6 × nv, linear rows first, in its own frame); ``placement``: at, rotation, name."""
        return cls(**placement)

    def loop_normals(self) -> tuple:
        """Unit vectors n (body a's axes) of the loop's "normal" rows."""
        return ()

    def loop_alignments(self) -> list:
        """Pairs (n in body a's axes, u in body b's) of the loop's "aligned" rows."""
        return []

    @property
    def loop_equations(self) -> int:
        """How many equations a loop closed by this joint makes (0 if it cannot close one)."""
        rows = self.loop_rows or ()
        return 3 * ("position" in rows) + len(self.loop_normals()) + len(self.loop_alignments()) \
            + 3 * ("locked" in rows)

    def params(self):
        """The joint's own parameters as plain data (for scene files)."""
        return {}

    def to_dict(self):
        d = {"type": self.type, **self.params(), "at": list(self.at)}
        if self.rotation is not None:
            d["rotation"] = [list(r) for r in self.rotation]
        if self.name:
            d["name"] = self.name
        return d


@dataclass(frozen=True, eq=False)
class _AxisJoint(Joint):
    axis: tuple = (0.0, 0.0, 1.0)

    def _check(self):
        super()._check()
        object.__setattr__(self, "axis", _floats(unit_axis(self.axis, f"{self._what} axis")))

    def params(self):
        return {"axis": list(self.axis)}

    def loop_normals(self):
        return perpendicular(np.array(self.axis)) if "normal" in (self.loop_rows or ()) else ()

    def loop_alignments(self):
        u = np.array(self.axis)
        return [(n, u) for n in perpendicular(u)] if "aligned" in (self.loop_rows or ()) else []

    def _specialised(self, models, *args):
        """Pinocchio's joint model for this axis: the one specialised to x, y or z when the axis is one of
        them (cheaper in every algorithm), else ``models[3]``, the one for any axis."""
        i = _CANONICAL.get(self.axis)
        return models[i](*args) if i is not None else models[3](np.array(self.axis), *args)


_CANONICAL = {(1.0, 0.0, 0.0): 0, (0.0, 1.0, 0.0): 1, (0.0, 0.0, 1.0): 2}


def perpendicular(u):
    """Two unit vectors orthogonal to the unit vector u and to each other."""
    t = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    n1 = np.cross(u, t)
    n1 /= np.linalg.norm(n1)
    return n1, np.cross(u, n1)


def _ordered(cls):
    """Let axis-type joints take ``axis`` as their first positional argument: Pivot((0, 1, 0))."""
    fields = cls.__dataclass_fields__
    order = [n for n in cls._positional if n in fields] + [n for n in ("at", "rotation", "name") if n in fields]
    init = cls.__init__

    def __init__(self, *args, **kwargs):
        if len(args) > len(order):
            raise ModelError(f"{cls.__name__}: too many positional arguments")
        for name, value in zip(order, args):
            if name in kwargs:
                raise ModelError(f"{cls.__name__}: '{name}' given twice")
            kwargs[name] = value
        unknown = set(kwargs) - set(fields)
        if unknown:
            raise ModelError(f"{cls.__name__}: unknown argument(s) {sorted(unknown)}")
        init(self, **kwargs)

    cls.__init__ = __init__
    return cls


@_ordered
@dataclass(frozen=True, eq=False)
class Pivot(_AxisJoint):
    """Revolute joint: rotation (rad) about ``axis`` through the joint origin."""

    type = "pivot"
    file_keys = {"axis": value_vec3}
    file_required = ("axis",)
    suffixes = ("",)
    units = ("rad",)
    periodic = (True,)
    loop_rows = ("position", "aligned")
    pinocchio_models = frozenset({"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned",
                                  "JointModelRUBX", "JointModelRUBY", "JointModelRUBZ",
                                  "JointModelRevoluteUnboundedUnaligned"})
    _positional = ("axis",)

    def markers(self):
        return [("cylinder", self.axis)]

    @classmethod
    def from_pinocchio(cls, jm, S, **placement):
        return cls(axis=S[3:, 0], **placement)

    def pin_model(self):
        return self._specialised((pin.JointModelRX, pin.JointModelRY, pin.JointModelRZ,
                                  pin.JointModelRevoluteUnaligned))


@_ordered
@dataclass(frozen=True, eq=False)
class Slider(_AxisJoint):
    """Prismatic joint: translation (m) along ``axis``."""

    type = "slider"
    file_keys = {"axis": value_vec3}
    file_required = ("axis",)
    suffixes = ("",)
    units = ("m",)
    loop_rows = ("normal", "locked")
    pinocchio_models = frozenset({"JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned"})
    _positional = ("axis",)

    def markers(self):
        return [("box", self.axis)]

    @classmethod
    def from_pinocchio(cls, jm, S, **placement):
        return cls(axis=S[:3, 0], **placement)

    def pin_model(self):
        return self._specialised((pin.JointModelPX, pin.JointModelPY, pin.JointModelPZ,
                                  pin.JointModelPrismaticUnaligned))


@_ordered
@dataclass(frozen=True, eq=False)
class Helical(_AxisJoint):
    """Screw joint: rotation θ (rad) about ``axis`` with translation ``pitch``·θ along it (pitch in m/rad).

    A lead given per turn (m/turn) converts with :meth:`per_turn`: pitch = lead / 2π.
    """

    pitch: float = 0.0
    type = "helical"
    file_keys = {"axis": value_vec3, "pitch": value_number, "lead": value_number}
    file_required = ("axis",)
    suffixes = ("",)
    units = ("rad",)
    pinocchio_models = frozenset({"JointModelHX", "JointModelHY", "JointModelHZ", "JointModelHelicalUnaligned"})
    _positional = ("axis", "pitch")

    @classmethod
    def from_pinocchio(cls, jm, S, **placement):
        """A helical joint of zero pitch is a pivot."""
        axis = S[3:, 0]
        pitch = float(S[:3, 0] @ axis)
        return cls(axis=axis, pitch=pitch, **placement) if pitch != 0.0 else Pivot(axis=axis, **placement)

    def markers(self):
        return [("cylinder", self.axis)]

    def _check(self):
        super()._check()
        p = scalar(self.pitch, f"{self._what} pitch (m/rad)")
        if p == 0.0:
            raise ModelError(f"{self._what} pitch is zero: use a Pivot for a pure rotation")
        object.__setattr__(self, "pitch", p)

    @classmethod
    def per_turn(cls, axis, lead, **kwargs):
        """Helical joint from its lead in metres per turn (pitch = lead / 2π m/rad)."""
        return cls(axis, scalar(lead, "helical joint lead (m/turn)") / (2 * math.pi), **kwargs)

    def params(self):
        return {"axis": list(self.axis), "pitch": self.pitch}

    def pin_model(self):
        return self._specialised((pin.JointModelHX, pin.JointModelHY, pin.JointModelHZ,
                                  pin.JointModelHelicalUnaligned), self.pitch)

    @classmethod
    def from_file(cls, params, error):
        """``pitch`` (m/rad) or ``lead`` (m/turn), exactly one."""
        if ("pitch" in params) == ("lead" in params):
            raise error("pitch", "a helical joint needs either pitch (m/rad) or lead (m/turn)")
        if "lead" in params:
            params = dict(params)
            params["pitch"] = params.pop("lead") / (2.0 * math.pi)
        return cls(**params)


@_ordered
@dataclass(frozen=True, eq=False)
class Cylindrical(_AxisJoint):
    """Translation ``s`` (m) along and rotation ``theta`` (rad) about the same ``axis``."""

    type = "cylindrical"
    file_keys = {"axis": value_vec3}
    file_required = ("axis",)
    suffixes = (".s", ".theta")
    units = ("m", "rad")
    periodic = (False, True)
    loop_rows = ("normal", "aligned")

    def markers(self):
        return [("cylinder", self.axis)]
    _positional = ("axis",)

    def pin_model(self):
        a = np.array(self.axis)
        j = pin.JointModelComposite(pin.JointModelPrismaticUnaligned(a))
        j.addJoint(pin.JointModelRevoluteUnaligned(a))
        return j


@_ordered
@dataclass(frozen=True, eq=False)
class Universal(Joint):
    """Cardan joint: rotation about ``axis1``, then about ``axis2`` (orthogonal, in the body frame)."""

    axis1: tuple = (1.0, 0.0, 0.0)
    axis2: tuple = (0.0, 1.0, 0.0)
    type = "universal"
    file_keys = {"axis1": value_vec3, "axis2": value_vec3}
    file_required = ("axis1", "axis2")
    suffixes = (".theta1", ".theta2")
    units = ("rad", "rad")
    periodic = (True, True)
    loop_rows = ("position", "aligned")
    pinocchio_models = frozenset({"JointModelUniversal"})
    # Pinocchio 4.1.0's computeRNEADerivatives/computeABADerivatives ignore that S depends on θ2: the θ2
    # column of ∂τ/∂q and both columns of ∂τ/∂v are wrong by O(1) (JointModelSphericalZYX likewise)
    analytic_derivatives = False
    _positional = ("axis1", "axis2")

    def markers(self):
        return [("cylinder", self.axis1), ("cylinder", self.axis2)]

    @classmethod
    def from_pinocchio(cls, jm, S, **placement):
        u = jm.extract()
        return cls(axis1=u.axis1, axis2=u.axis2, **placement)

    def loop_alignments(self):
        return [(np.array(self.axis1), np.array(self.axis2))]

    def _check(self):
        super()._check()
        a1 = unit_axis(self.axis1, f"{self._what} axis1")
        a2 = unit_axis(self.axis2, f"{self._what} axis2")
        if abs(a1 @ a2) > 1e-9:
            raise ModelError(f"{self._what}: axes must be orthogonal (axis1·axis2 = {a1 @ a2:.3g})")
        object.__setattr__(self, "axis1", _floats(a1))
        object.__setattr__(self, "axis2", _floats(a2))

    def params(self):
        return {"axis1": list(self.axis1), "axis2": list(self.axis2)}

    def pin_model(self):
        return pin.JointModelUniversal(np.array(self.axis1), np.array(self.axis2))


@_ordered
@dataclass(frozen=True, eq=False)
class Planar(Joint):
    """Motion in the plane normal to ``normal``: two translations (m) and the rotation about ``normal`` (rad).

    The in-plane x axis is the body x axis projected on the plane (or y when x is along ``normal``).
    """

    normal: tuple = (0.0, 0.0, 1.0)
    type = "planar"
    file_keys = {"normal": value_vec3}
    file_required = ("normal",)
    suffixes = (".x", ".y", ".theta")
    units = ("m", "m", "rad")
    q_names = ("x", "y", "cos", "sin")
    unit_block = (2, 2)
    chart_rotations = (2,)
    lie_group = "SE2"
    pinocchio_models = frozenset({"JointModelPlanar"})
    _positional = ("normal",)

    def _check(self):
        super()._check()
        object.__setattr__(self, "normal", _floats(unit_axis(self.normal, f"{self._what} normal")))

    @property
    def alignment(self):
        n = np.array(self.normal)
        x = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
        x = x - (x @ n) * n
        x /= np.linalg.norm(x)
        return np.column_stack([x, np.cross(n, x), n])

    def params(self):
        return {"normal": list(self.normal)}

    def pin_model(self):
        return pin.JointModelPlanar()


@_ordered
@dataclass(frozen=True, eq=False)
class Ball(Joint):
    """Spherical joint: free rotation about the joint origin (unit quaternion, 3 tangent coordinates)."""

    type = "ball"
    suffixes = (".rx", ".ry", ".rz")
    units = ("rad", "rad", "rad")
    q_names = ("qx", "qy", "qz", "qw")
    unit_block = (0, 4)
    chart_rotations = (0, 1, 2)
    lie_group = "SO3"
    isotropic_spring = True
    loop_rows = ("position",)
    pinocchio_models = frozenset({"JointModelSpherical"})
    _positional = ()

    def pin_model(self):
        return pin.JointModelSpherical()


@_ordered
@dataclass(frozen=True, eq=False)
class Free(Joint):
    """Six degrees of freedom (a floating body); q = (position, unit quaternion)."""

    type = "free"
    suffixes = (".x", ".y", ".z", ".rx", ".ry", ".rz")
    units = ("m", "m", "m", "rad", "rad", "rad")
    q_names = ("x", "y", "z", "qx", "qy", "qz", "qw")
    unit_block = (3, 4)
    chart_rotations = (3, 4, 5)
    lie_group = "SE3"
    pinocchio_models = frozenset({"JointModelFreeFlyer"})
    _positional = ()

    def pin_model(self):
        return pin.JointModelFreeFlyer()


@_ordered
@dataclass(frozen=True, eq=False)
class Fixed(Joint):
    """Weld: the body moves with its parent (no coordinate)."""

    type = "fixed"
    suffixes = ()
    loop_rows = ("position", "locked")
    _positional = ()

    def pin_model(self):
        return None


#: joint type name (a scene file's ``type``) -> class
JOINT_TYPES = {cls.type: cls for cls in (Pivot, Slider, Helical, Cylindrical, Universal, Planar, Ball, Free, Fixed)}


def joint_type(cls):
    """Declare a joint type (a subclass of :class:`Joint`, frozen dataclass): positional arguments as
    ``_positional`` says, and its ``type`` (the name scene files give it) known to scene files. A new type is its
    class, here or anywhere."""
    for former, new in (("kind", "type"), ("group", "lie_group")):  # declared by their former names
        if former in cls.__dict__ and not isinstance(cls.__dict__[former], Renamed):
            warn_once(f"Joint.{former}", f"Joint.{former} is Joint.{new} now: declare {new} = ... (the former "
                      "name works until the next release)")
            setattr(cls, new, cls.__dict__[former])
    cls = _ordered(cls)
    JOINT_TYPES[cls.type] = cls
    return cls


def from_dict(d, what="joint"):
    """A joint from its plain-data form (``{"type": "pivot", "axis": [...], ...}``)."""
    cls, params = kind_of(d, "type", JOINT_TYPES, what, "{'type': 'pivot', ...}", "joint type")
    return cls(**params).checked()
