"""Unbalance: a mass × radius (kg·m) at a point of a spinning body, at an angle about its spin axis.

It describes the load case of :func:`vibdyn.unbalance_response` — the force U Ω² rotating with the spin — and
exerts no force of its own in the other analyses (a scene's real unbalance, a centre of mass off the spin axis,
is in the nonlinear dynamics already). The angle (rad) is measured about the body's spin axis from the body's
first axis normal to it (for a spin about the body's z: from its x towards its y).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..._check import MAX_LENGTH, bounded, scalar, value_nonnegative, value_number, value_string, value_vec3, vector3
from ..._format import number, vector
from .base import ElementKind


@dataclass(frozen=True)
class Unbalance(ElementKind):
    """``amount`` m·e (kg·m) on ``body`` at its point ``at`` (m, body frame), at ``angle`` (rad) about the spin
    axis."""

    table = "unbalance"
    keys = {"name": value_string, "body": value_string, "amount": value_nonnegative, "at": value_vec3,
            "angle": value_number}
    required = ("name", "body", "amount")
    group = None

    name: str
    body: str
    amount: float
    at: tuple = (0.0, 0.0, 0.0)
    angle: float = 0.0

    @classmethod
    def add(cls, scene, name, body, amount, at=(0.0, 0.0, 0.0), angle=0.0) -> Unbalance:
        what = f"unbalance '{name}'"
        scene.check_new_name(name, "element")
        b = scene.find_body(body)
        if b is None:
            raise scene.unknown_body(body, what)
        point = tuple(float(x) for x in bounded(vector3(at, what + " at"), MAX_LENGTH, what + " at", "m"))
        return scene.add_element(cls(name, b.name, scalar(amount, what + " amount", nonnegative=True), point,
                                     scalar(angle, what + " angle")))

    def to_dict(self):
        return {"name": self.name, "body": self.body, "amount": self.amount, "at": list(self.at),
                "angle": self.angle}

    def describe(self, scene=None):
        return (f"{number(self.amount, 'kg·m')} on {self.body} at {vector(self.at)} m, angle "
                f"{number(self.angle, 'rad')}")

    def reference_points(self):
        return (self.at,)
