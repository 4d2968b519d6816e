"""External force (N) at a body point and torque (N·m), constant or callables of (t, q, v)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..._check import MAX_LENGTH, bounded, call_user, user_callable, value_string, value_vec3, vector3
from ..._format import vector
from ...errors import ModelError
from ...model.groups import ForceGroup
from ...model.points import point_set
from .base import ElementKind, numbers


class BodyForces(ForceGroup):
    """External forces and torques on body points, constant or callables of (t, q, v)."""

    uses_points = True

    def __init__(self, system, elements):
        self.elements = elements
        self.jp, self.pp = system.attachments([(e.body, e.at) for e in elements])
        self.Rb = np.array([system.body_in_joint(e.body).rotation for e in elements])
        self.body_axes = np.array([e.frame == "body" for e in elements])
        self.joints = tuple(sorted(set(self.jp)))
        self.points = point_set(self.jp, self.pp, system.model.njoints)
        self.velocity_dependent = any(e.velocity_dependent for e in elements)
        self.time_dependent = any(e.time_dependent for e in elements)
        # the given vectors once (constants checked here, zeros for none), the callables' rows to fill per call
        self.given, self.calls = {}, {}
        for attr in ("force", "torque"):
            given = np.zeros((len(elements), 3))
            self.calls[attr] = []
            for i, e in enumerate(elements):
                x = getattr(e, attr)
                if callable(x):
                    self.calls[attr].append((i, x, f"force '{e.name}' ({attr})", e.name))
                elif x is not None:
                    given[i] = self._checked(x, e.name, attr, 0.0)
            given.flags.writeable = False
            self.given[attr] = given
        self.has_torque = any(e.torque is not None for e in elements)
        self.any_body_axes = bool(self.body_axes.any())

    @staticmethod
    def _checked(val, name, attr, t):
        arr = numbers(val, (3,))
        if arr is None:
            raise ModelError(f"force '{name}': {attr} must be 3 finite numbers, got {val!r} at t = {t}")
        return arr

    def vectors(self, attr, t, q, v):
        """Each element's ``attr`` ("force", N, or "torque", N·m) at (t, q, v) in its own axes (n × 3)."""
        calls = self.calls[attr]
        if not calls:
            return self.given[attr]
        out = self.given[attr].copy()
        for i, x, what, name in calls:
            out[i] = self._checked(call_user(x, (t, q, v), what, t), name, attr, t)
        return out

    def apply(self, t, q, v, kin, Q, F):
        f = self.vectors("force", t, q, v)
        tq = self.vectors("torque", t, q, v) if self.has_torque else None
        if self.any_body_axes:
            Rw = np.einsum("nij,njk->nik", kin.R[self.jp], self.Rb)  # body axes -> world
            f = np.where(self.body_axes[:, None], np.einsum("nij,nj->ni", Rw, f), f)
            if tq is not None:
                tq = np.where(self.body_axes[:, None], np.einsum("nij,nj->ni", Rw, tq), tq)
        self.points.add_forces(F, kin, f)
        if tq is not None:
            Rt = np.transpose(kin.R[self.jp], (0, 2, 1))
            np.add.at(F[:, 3:], self.jp, np.einsum("nij,nj->ni", Rt, tq))

    def derivatives(self, d):
        """Given vectors: constant (no own derivative) or callables (differenced); body-axes vectors turn
        with the body, world-axes ones turn relative to the joint frame (both handled by the chain rule)."""
        q, v, t = d.q, d.v, d.t
        values = lambda qq, vv: np.hstack([self.vectors("force", t, qq, vv), self.vectors("torque", t, qq, vv)])  # noqa
        y = values(q, v).ravel()
        if self.velocity_dependent or any(callable(e.force) or callable(e.torque) for e in self.elements):
            Dq, Dv = d.element_fd(values)
        else:
            Dq = Dv = np.zeros((y.size, d.system.nv))
        for i in range(len(self.elements)):
            j, r = int(self.jp[i]), self.pp[i]
            if j == 0:
                continue
            (f, df_q, df_v), (tq, dt_q, dt_v) = (
                _to_world(d, j, self.Rb[i], self.body_axes[i], y[6 * i + o:6 * i + o + 3],
                          Dq[6 * i + o:6 * i + o + 3], Dv[6 * i + o:6 * i + o + 3]) for o in (0, 3))
            d.add_force(j, r, f, df_q, df_v)
            R = d.R[j]
            d.dFq[j][3:] += R.T @ dt_q + pin.skew(R.T @ tq) @ d.J[j][3:]
            d.dFv[j][3:] += R.T @ dt_v


def _to_world(d, j, Rb, body_axes, x, dx_q, dx_v):
    """A vector given in world or body axes, in world axes, with its derivatives (3 × nv)."""
    if not body_axes:
        return x, dx_q, dx_v
    Rw = d.R[j] @ Rb
    return Rw @ x, Rw @ dx_q - d.R[j] @ pin.skew(Rb @ x) @ d.J[j][3:], Rw @ dx_v


def vector_or_callable(value, what):
    if value is None:
        return value
    if callable(value):
        return user_callable(value, 3, what + " (a callable of t, q, v)")
    return tuple(float(x) for x in vector3(value, what))


def _frame(x):
    from ..._check import BadValue

    if x not in ("world", "body"):
        raise BadValue(f'frame must be "world" or "body", got {x!r}')
    return x


@dataclass(frozen=True)
class BodyForce(ElementKind):
    """Force (N) at a body point and torque (N·m), constant or a callable ``f(t, q, v)`` → 3-vector;
    ``frame`` says whether the vectors are in world axes ("world") or in the body axes ("body")."""

    table = "force"
    keys = {"name": value_string, "body": value_string, "force": value_vec3, "at": value_vec3,
            "torque": value_vec3, "frame": _frame}
    required = ("name", "body")
    group = BodyForces

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

    @classmethod
    def add(cls, scene, name, body, force=(0.0, 0.0, 0.0), at=(0.0, 0.0, 0.0), torque=None,
            frame="world") -> BodyForce:
        what = f"force '{name}'"
        scene.check_new_name(name, "element")
        b = scene.find_body(body)
        if b is None:
            raise scene.unknown_body(body, what)
        if frame not in ("world", "body"):
            raise ModelError(f"{what}: frame must be 'world' or 'body', got {frame!r}")
        f = vector_or_callable(force, f"{what} force")
        tq = vector_or_callable(torque, f"{what} torque")
        p = tuple(map(float, bounded(vector3(at, f"{what} at"), MAX_LENGTH, f"{what} at", "m")))
        return scene.add_element(cls(name, b.name, p, f, tq, frame))

    def to_dict(self):
        if callable(self.force) or callable(self.torque):
            raise ModelError(f"force '{self.name}': a Python callable cannot be written to a scene file")
        d = {"name": self.name, "body": self.body, "at": list(self.at), "force": list(self.force)}
        if self.frame != "world":
            d["frame"] = self.frame
        if self.torque is not None:
            d["torque"] = list(self.torque)
        return d

    def describe(self, scene=None):
        force = "callable" if callable(self.force) else vector(self.force)
        return f"on {self.body} at {vector(self.at)}, force {force} ({self.frame})"
