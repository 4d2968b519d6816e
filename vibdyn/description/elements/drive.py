"""Drive: a one-coordinate joint (pivot, slider, helical) whose coordinate is prescribed in time (a rheonomic
joint).

A drive is declared here as an element kind, though it has no force law of its own (``group`` None, like a
moving support): it is a per-joint declaration (one body, checked against the scene as it is added) and the
kind protocol gives it, from this one module, ``Scene.add_drive``, its ``[[drive]]`` scene-file table (read and
written), its ``vibdyn info`` line and a place in scene copies, with nothing added to the Scene, the reader or
the writer. The model compiles the drives of a scene into :class:`vibdyn.model.drives.Drives` (which
coordinates are driven, their values at t, the force each drive exerts).

``motion`` is a law of time with ``position(t)``, ``velocity(t)`` and ``acceleration(t)`` (the coordinate
itself: m, m/s, m/s² for a slider; rad, rad/s, rad/s² for a pivot or a helical joint):
:class:`vibdyn.laws.Harmonic` (offset + amplitude·sin(ωt + phase), derivatives analytic) or
:class:`vibdyn.laws.Motion` (three callables of t, checked finite where first evaluated).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..._check import value_string, value_table
from ...errors import ModelError
from .base import ElementKind

#: the parts of a law a drive needs
PARTS = ("position", "velocity", "acceleration")


@dataclass(frozen=True)
class Drive(ElementKind):
    """The coordinate of ``body``'s joint (pivot, slider or helical) prescribed by ``motion`` (see the module
    docstring); one drive per joint."""

    table = "drive"
    keys = {"body": value_string, "name": value_string, "motion": value_table}
    required = ("body", "motion")

    name: str
    body: str
    motion: object

    @classmethod
    def add(cls, scene, body, motion, name=None) -> Drive:
        b = scene.joint_body(body, "drive")
        if b.joint.nv != 1 or b.joint.unit_block is not None:
            raise ModelError(f"drive on '{body}': only a one-coordinate joint (pivot, slider, helical) can be "
                             f"driven; body '{b.name}' has a {b.joint.type} joint ({b.joint.nv} coordinates)")
        for other in scene.elements_of(Drive):
            if other.body == b.name:
                raise ModelError(f"drive on '{body}': the joint of body '{b.name}' is already driven by drive "
                                 f"'{other.name}' (one drive per joint)")
        name = name or f"{b.name}.drive"
        scene.check_new_name(name, "drive")
        what = f"drive '{name}'"
        if isinstance(motion, dict):
            from .. import laws

            motion = laws.from_dict(motion, f"{what} motion")
        missing = [p for p in PARTS if not callable(getattr(motion, p, None))]
        if missing:
            raise ModelError(f"{what}: motion must be a law of time with position(t), velocity(t) and "
                             f"acceleration(t) (vibdyn.laws.Harmonic(amplitude, omega) or vibdyn.laws.Motion("
                             f"position, velocity, acceleration)); {motion!r} has no {', '.join(missing)}")
        return scene.add_element(cls(name, b.name, motion))

    def to_dict(self):
        try:
            return {"name": self.name, "body": self.body, "motion": self.motion.to_dict()}
        except (ModelError, AttributeError) as e:
            raise ModelError(f"drive '{self.name}': {e}") from None

    def describe(self, scene=None):
        units = self.joint_units(scene)
        unit = units[0] if len(units) == 1 else ""
        speed = {"m": "m/s", "rad": "rad/s"}.get(unit, "")
        if hasattr(self.motion, "describe"):
            return f"{self.body} prescribed: {self.motion.describe(unit, speed)}"
        return f"{self.body} prescribed: {type(self.motion).__name__} (callables of t)"
