"""Moving support: a frame of the world translated by a motion law (base excitation)."""

from __future__ import annotations

from dataclasses import dataclass

from ..._check import value_string, value_table
from ...errors import ModelError
from .base import ElementKind


@dataclass(frozen=True)
class Support(ElementKind):
    """A moving support: a frame of the world translated by ``motion`` (a law with ``position(t)`` in m and
    ``velocity(t)`` in m/s, e.g. :class:`vibdyn.description.laws.HarmonicMotion`). Springs and dampers attach
    to it as ``(support_name, point)``, the point given in world axes at zero displacement. It has no force
    of its own: the model moves the elements' ends with it."""

    table = "support"
    keys = {"name": value_string, "motion": value_table}
    required = ("name", "motion")

    name: str
    motion: object

    @classmethod
    def add(cls, scene, name, motion) -> Support:
        scene.check_new_name(name, "support")
        from .. import laws

        if isinstance(motion, dict):
            motion = laws.from_dict(motion, f"support '{name}' motion")
        if isinstance(motion, laws.Harmonic):  # (it has position(t) too, but of one coordinate: a drive's)
            raise ModelError(f"support '{name}': vibdyn.laws.Harmonic moves one coordinate (a drive's); a support "
                             "moves along the world axes: use vibdyn.laws.HarmonicMotion(amplitude (3 numbers, m), "
                             "omega)")
        if not (callable(getattr(motion, "position", None)) and callable(getattr(motion, "velocity", None))):
            raise ModelError(f"support '{name}': motion must have position(t) and velocity(t) (m, m/s), e.g. "
                             "vibdyn.laws.HarmonicMotion")
        return scene.add_element(cls(name, motion))

    def to_dict(self):
        return {"name": self.name, "motion": self.motion.to_dict()}

    def describe(self, scene=None):
        if callable(getattr(self.motion, "describe", None)):  # a law that says itself (a record: not its samples)
            return f"moving support: {self.motion.describe()}"
        try:
            return f"moving support: {self.motion.to_dict()}"
        except (ModelError, AttributeError):  # callables: no plain-data form
            return f"moving support: {type(self.motion).__name__}"
