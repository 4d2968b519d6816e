"""Cubic (hardening) spring on a joint coordinate: Q = −k₃ x³, x = q ⊖ q_rest (Duffing-type stiffness).

This module is the whole kind: data and checks (``Scene.add_cubic_joint_spring``), scene-file table
``[[cubic_joint_spring]]``, ``vibdyn info`` line, evaluation, potential and analytic derivatives.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._check import stiffness_like, value_nonnegative_number_or_list, value_number_or_list, value_string
from ..._format import with_units
from ...errors import ModelError
from ...model.groups import ForceGroup, as_slice
from .base import ElementKind, scalar_or_list
from .joint_spring import rest_offsets


class CubicJointSprings(ForceGroup):
    """Q_i = −k₃ᵢ xᵢ³ on one-coordinate joints (pivots, sliders, helical), x = q − q_rest (m or rad);
    potential k₃ x⁴/4; ∂Q/∂q = −3 k₃ x²."""

    def __init__(self, system, elements):
        self.iq = np.array([system.body_info(e.body).idx_q for e in elements])
        self.iv = np.array([system.body_info(e.body).idx_v for e in elements])
        self.k3 = np.array([e.k3[0] for e in elements])
        self.rest = np.array([e.rest[0] for e in elements])
        self.nv = system.nv
        # one spring per coordinate: plain indexing (np.subtract.at, for coordinates with several, costs more)
        self.distinct = len(set(self.iv.tolist())) == len(self.iv)
        self.iq_at, self.iv_at = as_slice(self.iq), as_slice(self.iv)

    def apply(self, t, q, v, kin, Q, F):
        x = q[self.iq_at] - self.rest
        if self.distinct:
            Q[self.iv_at] -= self.k3 * (x * x * x)
        else:
            np.subtract.at(Q, self.iv, self.k3 * x**3)

    def apply_rows(self, t, q, v, Q):
        x = q[:, self.iq] - self.rest
        np.subtract.at(Q.T, self.iv, (self.k3 * x**3).T)

    def potential(self, q, kin):
        x = q[self.iq] - self.rest
        return 0.25 * float(self.k3 @ x**4)

    def derivatives(self, d):
        return self.joint_rows(d.q[None, :], None, d.t)[0][0], None

    def joint_rows(self, q, v, t):
        x = q[:, self.iq] - self.rest
        dQ = np.zeros((len(q), self.nv, self.nv))
        np.add.at(dQ, (slice(None), self.iv, self.iv), -3.0 * self.k3 * x**2)
        return dQ, None


@dataclass(frozen=True)
class CubicJointSpring(ElementKind):
    """Cubic spring on a one-coordinate joint: Q = −k3·(q − rest)³ (k3 in N/m³ or N·m/rad³; rest in m or
    rad from the neutral configuration)."""

    table = "cubic_joint_spring"
    keys = {"body": value_string, "k3": value_nonnegative_number_or_list, "rest": value_number_or_list,
            "name": value_string}
    required = ("body", "k3")
    group = CubicJointSprings
    linear_in = ("k3",)

    name: str
    body: str
    k3: tuple
    rest: tuple

    @classmethod
    def add(cls, scene, body, k3, rest=0.0, name=None) -> CubicJointSpring:
        b = scene.joint_body(body, "cubic joint spring")
        name = name or f"{b.name}.cubic_spring"
        what = f"cubic joint spring '{name}'"
        if not b.joint.scalar:
            raise ModelError(f"{what}: acts on one-coordinate joints (pivot, slider, helical); '{b.name}' has a "
                             f"{b.joint.type} joint")
        scene.check_new_name(name, "element")
        k = stiffness_like(k3, 1, f"{what} k3")
        return scene.add_element(cls(name, b.name, (float(k[0]),), rest_offsets(rest, b, what)))

    def to_dict(self):
        d = {"name": self.name, "body": self.body, "k3": scalar_or_list(self.k3)}
        if np.any(self.rest):
            d["rest"] = scalar_or_list(self.rest)
        return d

    def describe(self, scene=None):
        units = self.joint_units(scene)
        k3 = with_units(self.k3, units, {"m": "N/m³", "rad": "N·m/rad³"})
        return f"on {self.body}, k3 = {k3}, rest {with_units(self.rest, units, {'m': 'm', 'rad': 'rad'})}"
