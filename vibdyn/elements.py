"""Force elements as plain data: springs, dampers, joint springs/dampers, joint forces and body forces.

These only describe; :mod:`vibdyn.forces` compiles each kind into a group that evaluates all its members.
Attachment points are ``(body, (x, y, z))`` with the point in the body frame (m), or ``("world", point)``.
"""

from dataclasses import dataclass

import numpy as np

from . import laws
from ._check import count, finite_array, scalar, user_callable, vector3
from .errors import ModelError

WORLD = "world"


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


@dataclass(frozen=True)
class Spring:
    """Linear spring between two points: force k (L − free_length) along the line (N, m).

    ``free_length`` None means the distance at the neutral configuration (unstressed there).
    """

    name: str
    a: tuple
    b: tuple
    stiffness: float
    free_length: float | None = None

    def to_dict(self):
        d = {"name": self.name, "a": _att(self.a), "b": _att(self.b), "stiffness": self.stiffness}
        if self.free_length is not None:
            d["free_length"] = self.free_length
        return d


@dataclass(frozen=True)
class Damper:
    """Linear viscous damper between two points: force c·(rate of change of the distance) (N·s/m)."""

    name: str
    a: tuple
    b: tuple
    damping: float

    def to_dict(self):
        return {"name": self.name, "a": _att(self.a), "b": _att(self.b), "damping": self.damping}


@dataclass(frozen=True)
class JointSpring:
    """Spring on a joint's tangent coordinates: Q = −k·(q ⊖ q_rest) (N/m or N·m/rad).

    ``stiffness`` is one number or one per coordinate; ``rest`` is the rest offset from the neutral
    configuration in tangent coordinates (for a ball joint: the rotation vector, rad).
    """

    name: str
    body: str
    stiffness: tuple
    rest: tuple

    def to_dict(self):
        return {"name": self.name, "body": self.body, "stiffness": _scalar_or_list(self.stiffness),
                "rest": _scalar_or_list(self.rest)}


@dataclass(frozen=True)
class JointDamper:
    """Viscous damper on a joint's tangent coordinates: Q = −c·v (N·s/m or N·m·s/rad)."""

    name: str
    body: str
    damping: tuple

    def to_dict(self):
        return {"name": self.name, "body": self.body, "damping": _scalar_or_list(self.damping)}


@dataclass(frozen=True)
class JointForce:
    """Force or torque along a joint's coordinates: a constant, a law of :mod:`vibdyn.laws`, or a callable
    ``f(t, q, v)`` of time and the joint's own coordinates (floats for one-coordinate joints)."""

    name: str
    body: str
    value: object
    velocity_dependent: bool
    time_dependent: bool

    def to_dict(self):
        d = {"name": self.name, "body": self.body}
        if hasattr(self.value, "to_dict"):
            d.update(self.value.to_dict())
        elif callable(self.value):
            raise ModelError(f"joint force '{self.name}': a Python callable cannot be written to a scene file"
                             " (use a law of vibdyn.laws)")
        else:
            d["value"] = _scalar_or_list(self.value)
        return d


@dataclass(frozen=True)
class BodyForce:
    """Force (N) at a body point and torque (N·m), constant or a callable ``f(t, q, v)`` → 3-vector;
    ``frame`` says whether the vectors are in world axes ("world") or in the body axes ("body")."""

    name: str
    body: str
    at: tuple
    force: object
    torque: object
    frame: str

    @property
    def velocity_dependent(self):
        return any(callable(x) and getattr(x, "velocity_dependent", True) for x in (self.force, self.torque))

    @property
    def time_dependent(self):
        return any(callable(x) and getattr(x, "time_dependent", True) for x in (self.force, self.torque))

    def to_dict(self):
        if callable(self.force) or callable(self.torque):
            raise ModelError(f"force '{self.name}': a Python callable cannot be written to a scene file")
        d = {"name": self.name, "body": self.body, "at": list(self.at), "force": list(self.force),
             "frame": self.frame}
        if self.torque is not None:
            d["torque"] = list(self.torque)
        return d


@dataclass(frozen=True)
class Support:
    """A moving support: a frame of the world translated by ``motion`` (a law with ``position(t)`` in m and
    ``velocity(t)`` in m/s, e.g. :class:`vibdyn.laws.HarmonicMotion`). Springs and dampers attach to it as
    ``(support_name, point)``, the point given in world axes at zero displacement (base excitation)."""

    name: str
    motion: object

    def to_dict(self):
        return {"name": self.name, "motion": self.motion.to_dict()}


def joint_force_value(value, nv, what):
    """Check a joint force value: a number (or nv numbers), a law, or a callable."""
    if isinstance(value, dict):
        return laws.from_dict(value, what)
    if callable(value):
        return user_callable(value, 3, what + " (a callable of t, q, v)")
    arr = np.atleast_1d(finite_array(value, None, what))
    if arr.shape != (nv,):
        raise ModelError(f"{what}: expected {count(nv, 'number')} (one per coordinate), got shape {arr.shape}")
    return float(arr[0]) if nv == 1 else tuple(float(x) for x in arr)


def vector_or_callable(value, what):
    if value is None:
        return value
    if callable(value):
        return user_callable(value, 3, what + " (a callable of t, q, v)")
    return tuple(float(x) for x in vector3(value, what))


def _att(a):
    return [a[0], list(a[1])]


def _scalar_or_list(x):
    if isinstance(x, (tuple, list)):
        return x[0] if len(x) == 1 else list(x)
    return x


def positive_or_zero(value, what):
    return scalar(value, what, nonnegative=True)
