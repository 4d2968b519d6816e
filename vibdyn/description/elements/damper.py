"""Point-to-point linear viscous damper: force c·(rate of change of the distance) along the line."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._check import scalar, value_attachment, value_nonnegative, value_string
from ..._format import number
from ...model.groups import TwoPoint
from .base import ElementKind, att_list, end_label, file_attachment


class Dampers(TwoPoint):
    """Point-to-point viscous dampers: force on end b = −c (u·(v_b − v_a)) u."""

    noun = "damper"
    rows = True
    uses_point_velocities = True
    needs_velocity_derivatives = True
    velocity_dependent = True

    def __init__(self, system, elements):
        super().__init__(system, elements)
        self.c = np.array([e.damping for e in elements])
        self.tiny = np.full(len(elements), 1e-12)

    def apply(self, t, q, v, kin, Q, F):
        d, L = self.geometry(kin)
        u = d / L[..., None]
        va, vb = self.end_velocities(kin)
        rate = np.einsum("...ni,...ni->...n", u, vb - va)
        fb = (-self.c * rate)[..., None] * u
        self.ends.add_forces(F, kin, fb)  # fb on every end b, −fb on every end a

    def derivatives(self, d):
        dx, L = self.geometry(d.fkin)
        va, vb = self.end_velocities(d.fkin)
        vrel = vb - va
        for i in range(len(self.c)):
            ja, jb = int(self.ja[i]), int(self.jb[i])
            u = dx[i] / L[i]
            Jrel = d.point(jb, self.pb[i]) - d.point(ja, self.pa[i])
            dvrel_dq = d.point_velocity_dq(jb, self.pb[i]) - d.point_velocity_dq(ja, self.pa[i])
            rate = u @ vrel[i]
            du_dq = (np.eye(3) - np.outer(u, u)) / L[i] @ Jrel
            drate_dq = vrel[i] @ du_dq + u @ dvrel_dq
            Fb = -self.c[i] * rate * u
            dF_dq = -self.c[i] * (np.outer(u, drate_dq) + rate * du_dq)
            dF_dv = -self.c[i] * np.outer(u, u @ Jrel)
            d.add_force(jb, self.pb[i], Fb, dF_dq, dF_dv)
            d.add_force(ja, self.pa[i], -Fb, -dF_dq, -dF_dv)


@dataclass(frozen=True)
class Damper(ElementKind):
    """Linear viscous damper between two points: force c·(rate of change of the distance) (N·s/m)."""

    table = "damper"
    keys = {"name": value_string, "a": value_attachment, "b": value_attachment, "damping": value_nonnegative}
    required = ("name", "a", "b", "damping")
    group = Dampers
    linear_in = ("damping",)

    name: str
    a: tuple
    b: tuple
    damping: float

    @classmethod
    def add(cls, scene, name, a, b, damping) -> Damper:
        what = f"damper '{name}'"
        scene.check_new_name(name, "element")
        a, b = scene.resolve_attachment(a, what + " end a"), scene.resolve_attachment(b, what + " end b")
        return scene.add_element(cls(name, a, b, scalar(damping, f"{what} damping", nonnegative=True)))

    @classmethod
    def from_file(cls, scene, e, error):
        return cls.add(scene, e["name"], file_attachment(e["a"]), file_attachment(e["b"]), e["damping"])

    def to_dict(self):
        return {"name": self.name, "a": att_list(self.a), "b": att_list(self.b), "damping": self.damping}

    def describe(self, scene=None):
        return f"{end_label(self.a)} – {end_label(self.b)}, c = {number(self.damping, 'N·s/m')}"
