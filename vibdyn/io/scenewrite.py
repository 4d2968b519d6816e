"""Writing scene files: a Scene as plain data (:func:`scene_to_dict`) and as TOML text (:func:`dumps`,
:func:`save_scene`), the inverse of :mod:`vibdyn.io.scenefile`'s reading."""

import copy
import datetime as _dt
import math
import numbers
import re
from pathlib import Path

import numpy as np

from .._check import shown
from ..description.elements import KINDS, WORLD
from ..errors import SceneFileError
from .scenefile import check_values


def scene_to_dict(scene):
    """The plain data of a scene file (the structure :func:`scene_from_dict` reads).

    Raises ``ModelError`` for elements that hold Python callables (they cannot be written).
    """
    head = {"name": scene.name, "gravity": [float(g) for g in scene.gravity]}
    if scene.source is not None:
        head["source"] = scene.source
    if scene.description is not None:
        head["description"] = scene.description
    out = {"scene": head}
    bodies = []
    for body in scene.bodies.values():  # insertion order is parents first
        d = body.to_dict()
        b = {"name": d["name"]}
        if d["parent"] != WORLD:
            b["parent"] = d["parent"]
        b["mass"] = d["mass"]
        if any(d["com"]):
            b["com"] = d["com"]
        if any(any(r) for r in d["inertia"]):
            b["inertia"] = d["inertia"]
        j = d["joint"]
        if j["type"] != "fixed" or any(j["at"]) or "rotation" in j or "name" in j:
            b["joint"] = j
        if "shape" in d:
            b["shape"] = d["shape"]
        bodies.append(b)
    if bodies:
        out["body"] = bodies
    for table, kind in KINDS.items():
        entries = [e.to_dict() for e in scene.elements_of(kind)]
        if entries:
            out[table] = entries
    if getattr(scene, "loops", None):
        out["loop"] = [lp.to_dict() for lp in scene.loops.values()]
    if scene.limits:
        out["limits"] = {k: list(v) for k, v in scene.limits.items()}
    op = scene.operating_point
    if op:
        out["operating_point"] = {}
        if op.get("cyclic"):
            out["operating_point"]["cyclic"] = {k: "free" if x is None else x for k, x in op["cyclic"].items()}
        if op.get("start") is not None:
            st = op["start"]
            out["operating_point"]["start"] = dict(st) if isinstance(st, dict) else list(st)
        if op.get("held"):
            out["operating_point"]["held"] = True
    if scene.references:
        check_values(scene.references, None)  # nesting limit: no RecursionError in the copy below
        out["reference"] = copy.deepcopy(dict(scene.references))
    return out


def save_scene(scene, path):
    """Write ``scene`` as a TOML scene file that :func:`load_scene` reads back identically."""
    text = "# vibdyn scene file\n\n" + dumps(scene_to_dict(scene), path=str(path))
    Path(path).write_text(text, encoding="utf-8")


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def dumps(doc, path=None):
    """TOML text of a dict (strings, numbers, booleans, dates, arrays, tables, arrays of tables).

    Tables nested in the top-level tables are written as ``[a.b]`` sections; tables inside arrays of
    tables (and inside arrays) are written inline. ``None`` values in tables are left out (TOML has no
    null); anything else that TOML cannot hold raises ``SceneFileError`` naming the key.
    """
    if not isinstance(doc, dict):
        raise SceneFileError(f"expected a dict at the top level, got {shown(doc)}", path=path)
    lines = []
    _emit_table(lines, [], "", doc, inline=False, path=path)
    return "\n".join(lines).strip("\n") + "\n"


def _emit_table(lines, header, where, table, inline, path):
    """Write one table: its plain keys first, then (unless ``inline``) its sub-tables and arrays of tables in
    their order."""
    simple, nested = [], []
    for k, v in table.items():
        if not isinstance(k, str):
            raise SceneFileError(f"table keys must be strings, got {shown(k)}", path=path, key=where or None)
        if v is None:
            continue
        if not inline and (isinstance(v, dict) or (isinstance(v, (list, tuple)) and v
                                                   and all(isinstance(x, dict) for x in v))):
            nested.append((k, v))
        else:
            simple.append((k, v))
    for k, v in simple:
        lines.append(f"{_key(k)} = {_value(v, _join(where, k), path)}")
    for k, v in nested:
        name = ".".join(_key(h) for h in header + [k])
        if isinstance(v, dict):
            lines.extend(["", f"[{name}]"])
            _emit_table(lines, header + [k], _join(where, k), v, inline=False, path=path)
        else:
            for i, item in enumerate(v):
                lines.extend(["", f"[[{name}]]"])
                _emit_table(lines, header + [k], f"{_join(where, k)}[{i}]", item, inline=True, path=path)


def _join(where, k):
    return f"{where}.{k}" if where else k


def _key(k):
    return k if _BARE_KEY.fullmatch(k) else _string_literal(k)


def _string_literal(s):
    out = ['"']
    for ch in s:
        c = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif ch == "\r":
            out.append("\\r")
        elif c < 0x20 or c == 0x7F:
            out.append(f"\\u{c:04X}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _value(v, where, path):
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (numbers.Integral, np.integer)):
        return str(int(v))
    if isinstance(v, (numbers.Real, np.floating)):
        x = float(v)
        if math.isnan(x):
            return "nan"
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return repr(x)
    if isinstance(v, str):
        return _string_literal(v)
    if isinstance(v, (_dt.datetime, _dt.date, _dt.time)):
        return v.isoformat()
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x, f"{where}[{i}]", path) for i, x in enumerate(v)) + "]"
    if isinstance(v, dict):
        items = []
        for k, x in v.items():
            if not isinstance(k, str):
                raise SceneFileError(f"table keys must be strings, got {shown(k)}", path=path, key=where or None)
            if x is not None:
                items.append(f"{_key(k)} = {_value(x, _join(where, k), path)}")
        return "{ " + ", ".join(items) + " }" if items else "{}"
    raise SceneFileError(f"cannot write {shown(v)} ({type(v).__name__}) to TOML", path=path, key=where or None)
