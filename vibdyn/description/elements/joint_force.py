"""Force or torque along a joint's coordinates: a constant, a law, or a callable of (t, q, v)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._check import (
    call_user,
    count,
    finite_array,
    user_callable,
    value_number,
    value_number_or_list,
    value_numbers,
    value_string,
)
from ..._format import with_units
from ...errors import ModelError
from ...model.groups import ForceGroup
from .. import laws
from .base import ElementKind, numbers, scalar_or_list

_LAW_PARAMS = tuple(dict.fromkeys(k for name in laws.FORCE_LAWS for k in laws.law_keys(name)[0]))


class JointForces(ForceGroup):
    """Forces/torques along joint coordinates: constants summed once, laws and callables per call."""

    def __init__(self, system, elements):
        self.constant = np.zeros(system.nv)
        self.laws = []
        for e in elements:
            b = system.body_info(e.body)
            if callable(e.value):
                self.laws.append((e, b))
            else:
                self.constant[list(b.v_indices)] += e.value
        self.has_constant = bool(np.any(self.constant))
        self.velocity_dependent = any(e.velocity_dependent for e, _ in self.laws)
        self.time_dependent = any(e.time_dependent for e, _ in self.laws)

    def apply(self, t, q, v, kin, Q, F):
        if self.has_constant:
            Q += self.constant
        for e, b in self.laws:
            if b.nv == 1:
                # numpy scalars, not Python floats: an overflow gives inf (caught as a blow-up), not OverflowError
                args = (t, q[b.idx_q], v[b.idx_v])
            else:
                args = (t, q[b.idx_q:b.idx_q + b.nq].copy(), v[b.idx_v:b.idx_v + b.nv].copy())
            val = call_user(e.value, args, f"joint force '{e.name}'", t)
            arr = numbers(val, None)
            if arr is None or np.atleast_1d(arr).shape != (b.nv,):
                raise ModelError(f"joint force '{e.name}' returned {val!r} at t = {t}: expected "
                                 f"{count(b.nv, 'finite number')}")
            Q[b.idx_v:b.idx_v + b.nv] += np.atleast_1d(arr)

    def derivatives(self, d):
        if not self.laws:
            return None, None
        nv = d.system.nv
        dQ, dV = np.zeros((nv, nv)), np.zeros((nv, nv))
        for e, b in self.laws:
            law = e.value
            if isinstance(law, laws.Polynomial):
                c = np.asarray(law.coefficients)
                dV[b.idx_v, b.idx_v] += np.polynomial.polynomial.polyval(d.v[b.idx_v], np.arange(1, c.size) * c[1:])
            elif not isinstance(law, laws.Harmonic):  # a user callable: differenced on its own
                one = JointForces(d.system, [e])
                fd = d.element_fd(lambda qq, vv: d.group_force(one, qq, vv))
                dQ += fd[0]
                dV += fd[1]
        return dQ, dV


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


@dataclass(frozen=True)
class JointForce(ElementKind):
    """Force or torque along a joint's coordinates: a constant, a law of :mod:`vibdyn.description.laws`, or a
    callable ``f(t, q, v)`` of time and the joint's own coordinates (numpy scalars for one-coordinate
    joints)."""

    table = "joint_force"
    keys = {"body": value_string, "name": value_string, "value": value_number_or_list, "law": value_string,
            "coefficients": value_numbers, **{k: value_number for k in _LAW_PARAMS if k != "coefficients"}}
    required = ("body",)
    group = JointForces

    name: str
    body: str
    value: object
    velocity_dependent: bool
    time_dependent: bool

    @classmethod
    def add(cls, scene, body, value, name=None, velocity_dependent=None, time_dependent=None) -> JointForce:
        b = scene.joint_body(body, "joint force")
        name = name or f"{b.name}.force"
        scene.check_new_name(name, "element")
        v = joint_force_value(value, b.joint.nv, f"joint force '{name}'")
        vd = bool(getattr(v, "velocity_dependent", callable(v))) if velocity_dependent is None else bool(
            velocity_dependent)
        td = bool(getattr(v, "time_dependent", callable(v))) if time_dependent is None else bool(time_dependent)
        return scene.add_element(cls(name, b.name, v, vd, td))

    @classmethod
    def from_file(cls, scene, e, error):
        """``value`` (a constant) or ``law`` with the law's own keys beside it."""
        what = f"joint force '{e['name']}'" if "name" in e else f"joint force on '{e['body']}'"
        params = {k for k in e if k in _LAW_PARAMS}
        if ("value" in e) == ("law" in e):
            raise error("value", f"{what}: give either value (a constant) or law ({' or '.join(laws.FORCE_LAWS)})")
        if "value" in e:
            if params:
                k = sorted(params)[0]
                raise error(k, f"{what}: '{k}' goes with a law, not with value")
            value = e["value"]
        else:
            law = e["law"]
            if law not in laws.FORCE_LAWS:
                raise error("law", f"{what}: unknown law {law!r} (one of {', '.join(laws.FORCE_LAWS)})")
            allowed, required = laws.law_keys(law)
            for k in sorted(params - set(allowed)):
                raise error(k, f"{what}: unknown key '{k}' for law \"{law}\" (allowed: {', '.join(allowed)})")
            for k in required:
                if k not in e:
                    raise error(k, f"{what}: missing required key '{k}' for law \"{law}\"")
            value = laws.from_dict({"law": law, **{k: e[k] for k in params}}, what)
        return cls.add(scene, e["body"], value, name=e.get("name"))

    def to_dict(self):
        d = {"name": self.name, "body": self.body}
        if hasattr(self.value, "to_dict"):
            d.update(self.value.to_dict())
        elif callable(self.value):
            raise ModelError(f"joint force '{self.name}': a Python callable cannot be written to a scene file"
                             " (use a law of vibdyn.laws)")
        else:
            d["value"] = scalar_or_list(self.value)
        return d

    def describe(self, scene=None):
        units = self.joint_units(scene)
        force = {"m": "N", "rad": "N·m"}
        if hasattr(self.value, "describe"):  # a law: its formula, in the joint's units
            speed = {"m": "m/s", "rad": "rad/s"}.get(units[0], "") if len(units) == 1 else ""
            unit = force.get(units[0], "") if len(units) == 1 else ""
            return f"on {self.body}: {self.value.describe(unit, speed)}"
        return f"on {self.body}: {'callable' if callable(self.value) else with_units(self.value, units, force)}"
