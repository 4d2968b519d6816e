"""Viscous damper on a joint's tangent coordinates: Q = −c·v."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._check import stiffness_like, value_nonnegative_number_or_list, value_string
from ..._format import with_units
from ...model.groups import ForceGroup
from .base import ElementKind, scalar_or_list


class JointDampers(ForceGroup):
    """Viscous dampers on joint coordinates: Q = −c v."""

    velocity_dependent = True

    def __init__(self, system, elements):
        iv = [i for e in elements for i in system.body_info(e.body).v_indices]
        # dampers sharing a coordinate add up: one coefficient per coordinate
        self.iv, where = np.unique(iv, return_inverse=True)
        self.c = np.zeros(len(self.iv))
        np.add.at(self.c, where, [c for e in elements for c in e.damping])

    def apply(self, t, q, v, kin, Q, F):
        Q[self.iv] -= self.c * v[self.iv]

    def apply_rows(self, t, q, v, Q):
        Q[:, self.iv] -= self.c * v[..., self.iv]

    def derivatives(self, d):
        dV = np.zeros((d.system.nv, d.system.nv))
        dV[self.iv, self.iv] = -self.c
        return None, dV


@dataclass(frozen=True)
class JointDamper(ElementKind):
    """Viscous damper on a joint's tangent coordinates: Q = −c·v (N·s/m or N·m·s/rad)."""

    table = "joint_damper"
    keys = {"body": value_string, "damping": value_nonnegative_number_or_list, "name": value_string}
    required = ("body", "damping")
    group = JointDampers
    linear_in = ("damping",)

    name: str
    body: str
    damping: tuple

    @classmethod
    def add(cls, scene, body, damping, name=None) -> JointDamper:
        b = scene.joint_body(body, "joint damper")
        name = name or f"{b.name}.damper"
        scene.check_new_name(name, "element")
        c = stiffness_like(damping, b.joint.nv, f"joint damper '{name}' damping")
        return scene.add_element(cls(name, b.name, tuple(map(float, c))))

    def to_dict(self):
        return {"name": self.name, "body": self.body, "damping": scalar_or_list(self.damping)}

    def describe(self, scene=None):
        c = with_units(self.damping, self.joint_units(scene), {"m": "N·s/m", "rad": "N·m·s/rad"})
        return f"on {self.body}, c = {c}"
