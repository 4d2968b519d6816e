"""What every force-element kind shares: attachments, the kind protocol and its registry,.

A kind is one module of this package declaring, in one place: its data (a frozen dataclass subclassing
:class:`ElementKind`), its checks (``add``: the ``Scene.add_<table>`` method), its scene-file schema
(``table``, ``keys``, ``required``, ``from_file``, ``to_dict``), how ``vibdyn info`` describes it
(``describe``), its compiled evaluation (``group``: a :class:`~vibdyn.model.groups.ForceGroup` of all its members) and
the group's analytic derivatives (``ForceGroup.derivatives``). The model layer compiles the groups of the kinds a scene
has (:func:`vibdyn.model.forces.compile_groups`); scene files, the CLI and the analytic linearisation read the same
declarations. Attachment points are ``(body, (x, y, z))`` with the point in the body frame (m), or ``("world", point)``,
or ``(support_name, point)`` (world axes).
"""

from __future__ import annotations

from typing import Any, ClassVar

from ..._check import MAX_LENGTH, bounded, finite_array, vector3
from ...errors import ModelError

WORLD = "world"

#: table name -> kind class, in the order groups are compiled and scene files are read and written
KINDS: dict[str, type[ElementKind]] = {}


class ElementKind:
    """Base of the force-element data classes (see the module docstring for the protocol)."""

    table: ClassVar[str] = ""  # scene-file table [[table]] and Scene.add_<table>
    keys: ClassVar[dict[str, Any]] = {}  # scene-file key -> value check (vibdyn._check's value_* functions)
    required: ClassVar[tuple[str, ...]] = ()
    group: ClassVar[type | None] = None  # compiled evaluation of all members (None: no force of its own)
    #: attributes the element's force is proportional to (a stiffness, a damping): a design sensitivity to
    #: one of them is the force of the element with that attribute 1, no rebuild
    linear_in: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("table"):
            if cls.table in KINDS:
                raise TypeError(f"element kind table '{cls.table}' declared twice")
            KINDS[cls.table] = cls

    @classmethod
    def add(cls, scene, *args, **kwargs) -> ElementKind:
        """Check the arguments and add one element to ``scene`` (what ``Scene.add_<table>`` does)."""
        raise NotImplementedError

    @classmethod
    def from_file(cls, scene, entry: dict, error) -> ElementKind:
        """Add the element of a checked scene-file entry (``error(subkey, message)`` makes the file's error)."""
        return cls.add(scene, **entry)

    def to_dict(self) -> dict:
        """The scene-file entry (plain data)."""
        raise NotImplementedError

    def describe(self, scene: Any = None) -> str:
        """One line for ``vibdyn info`` (``scene``: where the element is, for the units of its joint)."""
        return ""

    def joint_units(self, scene) -> tuple:
        """The units ("m" or "rad") of the coordinates of the joint the element acts on (``body``), () if
        unknown."""
        found = scene.find_body(getattr(self, "body", None)) if scene is not None else None
        return found.joint.units if found is not None else ()

    def reference_points(self) -> tuple:
        """Points (m) that size the scene (:attr:`vibdyn.System.length_scale`)."""
        return ()

    def reference_lengths(self) -> tuple:
        """Lengths (m) that size the scene, wherever its bodies are (a spring's free length)."""
        return ()

    @property
    def label(self) -> str:
        return self.table.replace("_", " ")


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
    return body, tuple(float(x) for x in bounded(vector3(point, what), MAX_LENGTH, f"{what} point", "m"))


def file_attachment(a):
    """A scene file's attachment ("body" or [body, [x, y, z]]) as the Scene API takes it."""
    return a if isinstance(a, str) else (a[0], tuple(a[1]))


def att_list(a):
    return [a[0], list(a[1])]


def scalar_or_list(x):
    if isinstance(x, (tuple, list)):
        return x[0] if len(x) == 1 else list(x)
    return x


def numbers(value, shape):
    """``value`` as finite floats of ``shape`` (None: any), or None if it is not (the caller says why)."""
    try:
        return finite_array(value, shape, "")
    except ModelError:
        return None


def end_label(a):
    from ..._format import vector

    return f"{a[0]}{vector(a[1])}"
