"""Visual shapes of bodies (what the viewer draws; no effect on the dynamics).

A shape is given as a table, in Python as in a TOML scene file (``shape = {type = "box", size = [...]}``):

=========  ==========================================  ====================================
type       parameters (m)                              drawn
=========  ==========================================  ====================================
box        ``size = [x, y, z]``                         box, centred
cylinder   ``radius``, ``length``, ``axis`` (def. z)    cylinder, centred
sphere     ``radius``                                   sphere
capsule    ``radius``, ``length``, ``axis`` (def. z)    cylinder of that length with two caps
mesh       ``path`` (.stl, .obj, .dae), ``scale``       the mesh file (scale: one or three)
=========  ==========================================  ====================================

Every shape also takes ``at`` (m, body frame; default the centre of mass), ``rotation`` (3×3 matrix or
rotation vector, rad) and ``color`` (``[r, g, b]`` in 0..1 or ``"#rrggbb"``). A body takes one shape or
a list of them. Relative mesh paths are relative to the scene file's folder (or the working directory).
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._check import finite_array, rotation_matrix, scalar, unit_axis, vector3
from .._deprecation import Renamed
from ..errors import ModelError

SHAPE_TYPES = {  # a scene file's type: (required, optional)
    "box": (("size",), ()),
    "cylinder": (("radius", "length"), ("axis",)),
    "sphere": (("radius",), ()),
    "capsule": (("radius", "length"), ("axis",)),
    "mesh": (("path",), ("scale",)),
}
COMMON = ("type", "at", "rotation", "color")
MESH_FORMATS = (".stl", ".obj", ".dae")


@dataclass(frozen=True)
class Shape:
    """One visual shape of a body (see the module documentation); lengths in m, in the body frame."""

    type: str  # "box", "sphere", "cylinder", "capsule" or "mesh" (the scene file's ``type``)
    size: tuple = ()  # box (x, y, z); cylinder / capsule (radius, length); sphere (radius,); mesh scale (3)
    axis: tuple = (0.0, 0.0, 1.0)
    at: tuple | None = None  # None: the body's centre of mass
    rotation: tuple | None = None  # 3×3, None: identity
    color: tuple | None = None  # (r, g, b) in 0..1
    path: str | None = None  # mesh file
    kind = Renamed("type")

    def to_dict(self):
        d = {"type": self.type}
        if self.type == "box":
            d["size"] = list(self.size)
        elif self.type == "sphere":
            d["radius"] = self.size[0]
        elif self.type in ("cylinder", "capsule"):
            d["radius"], d["length"] = self.size
            if self.axis != (0.0, 0.0, 1.0):
                d["axis"] = list(self.axis)
        else:
            d["path"] = self.path
            if self.size != (1.0, 1.0, 1.0):
                d["scale"] = list(self.size)
        if self.at is not None:
            d["at"] = list(self.at)
        if self.rotation is not None:
            d["rotation"] = [list(r) for r in self.rotation]
        if self.color is not None:
            d["color"] = list(self.color)
        return d


def shapes(value, what, base=None):
    """A tuple of :class:`Shape` from a shape, a table or a list of them (None: no shape); ``base`` is the
    folder relative mesh paths start from. Bad input is a ModelError naming ``what``."""
    if value is None:
        return ()
    items = list(value) if isinstance(value, (list, tuple)) else [value]
    return tuple(_one(v, f"{what} shape" + (f"[{i}]" if len(items) > 1 else ""), base)
                 for i, v in enumerate(items))


def _one(v, what, base):
    if isinstance(v, Shape):
        v = v.to_dict()
    if not isinstance(v, dict):
        raise ModelError(f"{what}: expected a table such as {{type = \"box\", size = [0.1, 0.1, 0.1]}}, got {v!r}")
    kind = v.get("type")
    if kind not in SHAPE_TYPES:
        raise ModelError(f"{what}: unknown shape type {kind!r} (one of {', '.join(SHAPE_TYPES)})")
    required, optional = SHAPE_TYPES[kind]
    for k in v:
        if k not in required + optional + COMMON:
            raise ModelError(f"{what}: unknown key '{k}' for a {kind} "
                             f"(allowed: {', '.join(required + optional + COMMON)})")
    for k in required:
        if k not in v:
            raise ModelError(f"{what}: a {kind} needs '{k}'")
    out = {"type": kind}
    if kind == "box":
        size = vector3(v["size"], f"{what} size")
        if np.any(size <= 0):
            raise ModelError(f"{what}: box sizes must be positive, got {list(size)}")
        out["size"] = tuple(map(float, size))
    elif kind == "sphere":
        out["size"] = (scalar(v["radius"], f"{what} radius", positive=True),)
    elif kind in ("cylinder", "capsule"):
        out["size"] = (scalar(v["radius"], f"{what} radius", positive=True),
                       scalar(v["length"], f"{what} length", nonnegative=kind == "capsule",
                              positive=kind == "cylinder"))
        if "axis" in v:
            out["axis"] = tuple(map(float, unit_axis(v["axis"], f"{what} axis")))
    else:
        path = v["path"]
        if not isinstance(path, str) or not path:
            raise ModelError(f"{what}: path must be a file name, got {path!r}")
        p = Path(path)
        if not p.is_absolute() and base is not None:
            p = Path(base) / p
        if p.suffix.lower() not in MESH_FORMATS:
            raise ModelError(f"{what}: mesh file {path!r} must be one of {', '.join(MESH_FORMATS)}")
        if not p.is_file():
            raise ModelError(f"{what}: mesh file {str(p)!r} not found")
        out["path"] = str(p.resolve())
        s = np.atleast_1d(finite_array(v.get("scale", 1.0), None, f"{what} scale")).astype(float)
        if s.size == 1:
            s = np.repeat(s, 3)
        if s.shape != (3,) or np.any(s <= 0):
            raise ModelError(f"{what}: scale must be one positive number or three, got {v.get('scale')!r}")
        out["size"] = tuple(map(float, s))
    if "at" in v:
        out["at"] = tuple(map(float, vector3(v["at"], f"{what} at")))
    if "rotation" in v:
        out["rotation"] = tuple(tuple(map(float, r)) for r in rotation_matrix(v["rotation"], f"{what} rotation"))
    if "color" in v:
        out["color"] = color(v["color"], f"{what} color")
    return Shape(**out)


def color(value, what):
    """(r, g, b) in 0..1 from ``[r, g, b]`` (0..1) or ``"#rrggbb"``."""
    if isinstance(value, str):
        s = value.lstrip("#")
        try:
            if len(s) != 6:
                raise ValueError
            return tuple(int(s[i:i + 2], 16) / 255 for i in (0, 2, 4))
        except ValueError:
            raise ModelError(f"{what}: expected \"#rrggbb\", got {value!r}") from None
    c = vector3(value, what)
    if np.any(c < 0) or np.any(c > 1):
        raise ModelError(f"{what}: components must be in 0..1, got {list(c)}")
    return tuple(map(float, c))
