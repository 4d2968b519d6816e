"""TOML scene files: read them into a :class:`vibdyn.Scene` and write scenes back.

A scene file is data, never code: it is parsed with :mod:`tomllib` and checked key by key. Every problem
raises :class:`vibdyn.SceneFileError` (a ``ModelError``, hence a ``ValueError``) whose message names the file
and the key path, e.g. ``file trailer.toml, key 'body[1].joint.axis': ...``. Array-of-table entries are
numbered from 0 in file order (``body[0]`` is the first ``[[body]]``). SI units throughout.

Format
------

.. code-block:: toml

    [scene]
    name = "trailer"                      # optional, default: the file's stem
    gravity = [0.0, 0.0, -9.81]           # m/s², optional (default zero)
    source = "where the case comes from"  # optional
    description = "..."                   # optional

    [[body]]                      # any order: parents are resolved after reading every body
    name = "cart"
    parent = "world"              # optional, default "world"; a body's name or its joint's name
    mass = 10.0                   # kg (required; 0 for a massless body)
    com = [0.0, 0.0, 0.0]         # m, body frame, optional
    inertia = [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]]   # kg·m² about the com, optional
    # or a helper table using the body's mass (tensor about the com):
    # inertia = { shape = "rod", length = 1.0, axis = [0, 0, 1] }
    #   shapes: point | rod {length, axis} | box {size} | cylinder {radius, length, axis}
    #           | disc {radius, axis} | sphere {radius, hollow}         (axis optional, default z)
    inertia_about = [0.0, 0.0, 0.0]   # optional, with a matrix only: the tensor is about this point
    joint = { type = "slider", axis = [1.0, 0.0, 0.0], at = [0.0, 0.0, 0.0] }   # omitted: fixed weld
    # joint types and their parameters:
    #   pivot, slider, cylindrical: axis          helical: axis, and pitch (m/rad) or lead (m/turn)
    #   universal: axis1, axis2                    planar: normal
    #   ball, free, fixed: none
    # every joint also takes at (m, parent frame), rotation (3×3 matrix or rotation vector, rad), name

    [[spring]]        # linear spring between two points: force k (L − free_length) along the line
    name = "k1"
    a = ["world", [-1.0, 0.0, 0.0]]   # [body, [x, y, z]] (point in the body frame, m), or "body" (its origin)
    b = "cart"
    stiffness = 100.0                 # N/m
    free_length = 1.0                 # m, optional (default: the length at the neutral configuration)

    [[support]]       # a moving support (base excitation): springs and dampers attach to [name, [x, y, z]]
    name = "ground"   # (point in world axes at zero displacement)
    motion = { law = "harmonic_motion", amplitude = [0.0, 0.0, 0.01], omega = 15.0, phase = 0.0 }   # m, rad/s

    [[damper]]        # name, a, b, damping (N·s/m)
    [[joint_spring]]  # body, stiffness (N/m or N·m/rad: number or one per coordinate),
                      # rest (optional, same form, tangent offset from neutral), name (optional)
    [[joint_damper]]  # body, damping (number or list), name (optional)
    [[joint_force]]   # body, name (optional), and either value = number | list (N or N·m),
                      # or law = "polynomial", coefficients = [c0, c1, ...]     (Σ c_k v^k)
                      # or law = "harmonic", amplitude, omega, phase = 0, offset = 0
    [[force]]         # name, body, force = [fx, fy, fz] (N, default 0), at = [x, y, z] (m, body frame),
                      # torque = [...] (N·m, optional), frame = "world" (default) | "body"
    [[cubic_joint_spring]]  # body, k3 (N/m³ or N·m/rad³), rest (optional), name (optional): Q = −k3 (q − rest)³
    [[drive]]         # the coordinate of a pivot, slider or helical joint prescribed in time: body, name (optional),
                      # motion = { law = "harmonic", amplitude = 0.01, omega = 20.0, phase = 0.0, offset = 0.0 }
                      # (the coordinate itself: offset + amplitude·sin(omega·t + phase), m or rad, omega in rad/s)
    [[bearing]]       # name, housing, journal (ends as a spring's), stiffness = [[kxx, kxy], [kyx, kyy]] (N/m),
                      # damping = [[...]] (N·s/m, optional), speeds = [...] (rad/s, optional: then stiffness and
                      # damping are n × 2 × 2 tables), axis = [0, 0, 1] (default), interpolation = "linear" | "pchip"
    [[unbalance]]     # name, body, amount (m·e, kg·m), at = [x, y, z] (m, body frame), angle (rad, default 0)
                      # (every element kind of vibdyn.description.elements has its table, named after it)
    [[loop]]          # a joint closing a cycle: name, a = [body, [x, y, z]], b = [body or "world", [...]],
                      # joint = { type = "ball" } (default) | pivot | slider | cylindrical {axis}
                      #         | universal {axis1, axis2} | fixed   (axes in body a's frame; no at/rotation)

    [robot]           # optional: start from a robot, then add the bodies and elements above to it
    name = "ur5"      # an example-robot-data robot (vibdyn.load_robot), or:
    # urdf = "relative/path.urdf"   (relative to the scene file; vibdyn.load_urdf)
    floating = false  # optional (default: the robot's usual base; fixed for a URDF)
    package_dirs = ["meshes"]       # optional, with urdf (relative to the scene file)
    # [scene] name, gravity, source and description, when given, replace the robot's; bodies may name
    # the robot's bodies (or joints) as parents

    [limits]          # optional: position limits of one-coordinate joints (m or rad), as a URDF gives them
    elbow = [-2.0, 2.0]           # coordinate = [lower, upper]; equilibrium searches refuse to leave them

    [operating_point] # optional: where analyses linearise by default (System.operating_point())
    cyclic = { rotor = "free" }   # a steady motion: coordinate = speed (rad/s or m/s) or "free" (found)
    start = { slider = 0.1 }      # optional: where the search starts, tangent offsets from neutral by
                                  # coordinate (others 0), or a list with one offset per coordinate
    held = true                   # optional: the start configuration held by drives (System.held; the
                                  # default of robots), instead of a search
    # omitted: the static equilibrium nearest the neutral configuration (robots: held at neutral)

    [reference]       # free-form: the values this scene must reproduce and their source;
                      # kept as ``scene.references`` (a dict) and written back as is

Writing: :func:`~vibdyn.io.scenewrite.save_scene` (:mod:`vibdyn.io.scenewrite`) writes every body explicitly (a scene
started from a ``[robot]`` is saved with the robot's bodies spelled out), the elements grouped by kind, and the
references. Floats are written with ``repr`` so that a saved scene reads back bit for bit. Python callables cannot be
written (their ``to_dict`` raises ``ModelError``); use a law of :mod:`vibdyn.description.laws`. Comments are not kept.
"""

import copy
import math
import os
import stat
from difflib import get_close_matches
from importlib import resources
from pathlib import Path

from .._check import (
    BadValue,
    as_list,
    is_number,
    shown,
    value_attachment,
    value_boolean,
    value_matrix_or_table,
    value_nonnegative,
    value_number,
    value_numbers,
    value_string,
    value_strings,
    value_table,
    value_vec3,
)
from ..description import inertia as _inertia
from ..description import joints as _joints
from ..description.elements import KINDS, WORLD
from ..description.elements.base import file_attachment
from ..description.scene import Scene
from ..errors import ModelError, SceneFileError
from .bundled import bundled_model, bundled_models, is_model_name

try:  # Python ≥ 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib  # type: ignore[no-redef]

__all__ = ["load_scene", "scene_from_dict", "check_values"]

# ------------------------------------------------------------------ reading


def load_scene(path):
    """Read a TOML scene file into a :class:`vibdyn.Scene` (see the module docstring for the format). A bare
    name that is no file here ("four_bar" or "four_bar.toml") is a bundled model (:func:`bundled_models`)."""
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise SceneFileError(f"expected a file path (str or Path), got {path!r}")
    p = Path(path)
    if is_model_name(path) and not p.exists():
        found = bundled_model(path)
        if found is None:
            names = bundled_models()
            near = get_close_matches(path.removesuffix(".toml"), names, n=1)
            raise SceneFileError(("no such scene file, nor a bundled model of that name"
                                  + (f" (did you mean {near[0]}?)" if near else "")
                                  + "; the bundled models are " + ", ".join(names)), path=str(p))
        with resources.as_file(found) as real:
            return load_scene(real)
    try:
        st = p.stat()
        if stat.S_ISDIR(st.st_mode):
            raise IsADirectoryError
        if not stat.S_ISREG(st.st_mode):  # a FIFO, a device (/dev/zero): could block or never end
            raise SceneFileError("not a regular file", path=str(p))
        if st.st_size > MAX_FILE_BYTES:
            raise SceneFileError(f"too large ({st.st_size} bytes; a scene file is at most {MAX_FILE_BYTES})",
                                 path=str(p))
        with open(p, "rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
        if len(raw) > MAX_FILE_BYTES:
            raise SceneFileError(f"too large (more than {MAX_FILE_BYTES} bytes)", path=str(p))
        text = raw.decode("utf-8")
    except FileNotFoundError:
        # a checkout's path to a bundled model (models/rod_pivot.toml), used where vibdyn is installed
        stem = p.name.removesuffix(".toml")
        hint = (f"; the bundled model '{stem}' loads by its bare name: vd.load_scene('{stem}') (vibdyn modes {stem} "
                "on the command line)") if bundled_model(stem) is not None else ""
        raise SceneFileError("no such scene file" + hint, path=str(p)) from None
    except IsADirectoryError:
        raise SceneFileError("is a directory, not a scene file", path=str(p)) from None
    except UnicodeDecodeError as e:
        raise SceneFileError(f"not UTF-8 text ({e.reason} at byte {e.start})", path=str(p)) from None
    except OSError as e:
        raise SceneFileError(f"cannot read: {e.strerror or e}", path=str(p)) from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SceneFileError(f"TOML syntax error: {e}", path=str(p)) from None
    except RecursionError:  # (the parser recursed too deep to say where: a scan of the text does)
        key, line = _too_deep(text)
        raise SceneFileError(f"nested more than {MAX_DEPTH} levels deep" + (f" (line {line})" if line else ""),
                             path=str(p), key=key) from None
    check_values(doc, str(p))
    return scene_from_dict(doc, path=p)


def scene_from_dict(d, path=None):
    """A :class:`vibdyn.Scene` from the plain data of a scene file (as read by ``tomllib`` or written by
    :func:`scene_to_dict`). ``path`` names the file in errors and anchors relative robot paths."""
    check_values(d, path)
    return _Reader(path).scene(d)


MAX_FILE_BYTES = 256 * 2**20  # a scene file larger than this is not a scene file
MAX_DEPTH = 64  # tables and arrays nested deeper than this are not a scene


def check_values(doc, path):
    """Walk the plain data once, without recursion: nesting deeper than MAX_DEPTH and integers beyond the
    float range are SceneFileErrors naming the key (later checks convert numbers to float)."""
    stack = [(doc, "", 0)]
    while stack:
        x, key, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise SceneFileError(f"nested more than {MAX_DEPTH} levels deep", path=path and str(path), key=key)
        if isinstance(x, dict):
            stack.extend((v, f"{key}.{k}" if key else str(k), depth + 1) for k, v in x.items())
        elif isinstance(x, (list, tuple)):
            stack.extend((v, f"{key}[{i}]", depth + 1) for i, v in enumerate(x))
        elif isinstance(x, int) and not isinstance(x, bool) and not _fits_float(x):
            raise SceneFileError("integer too large for a number (beyond ±1.8e308)", path=path and str(path),
                                 key=key)


def _too_deep(text):
    """(key, line number) where arrays or inline tables first nest deeper than MAX_DEPTH in a TOML text
    (strings and comments skipped), the key as _check_values names it; (None, None) if nowhere."""
    table, counts, key, depth = "", {}, None, 0
    for number, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if depth == 0:
            if s.startswith("[["):
                name = s[2:s.find("]]")].strip()
                counts[name] = counts.get(name, -1) + 1
                table = f"{name}[{counts[name]}]"
                continue
            if s.startswith("["):
                table = s[1:s.find("]")].strip()
                continue
            if "=" in s:
                key = s.split("=", 1)[0].strip().strip('"')
        quote = None
        for ch in line:
            if quote:
                quote = None if ch == quote else quote
            elif ch in "\"'":
                quote = ch
            elif ch == "#":
                break
            elif ch in "[{":
                depth += 1
                if depth > MAX_DEPTH:
                    return ".".join(x for x in (table, key) if x) or None, number
            elif ch in "]}":
                depth = max(depth - 1, 0)
    return None, None


def _fits_float(n):
    try:
        float(n)
        return True
    except OverflowError:
        return False


# value kinds: each checker returns the value (lists for arrays) or raises BadValue with what was expected


SCENE_KEYS = {"name": value_string, "gravity": value_vec3, "source": value_string, "description": value_string}
ROBOT_KEYS = {"name": value_string, "urdf": value_string, "floating": value_boolean, "package_dirs": value_strings}
BODY_KEYS = {"name": value_string, "parent": value_string, "mass": value_nonnegative, "com": value_vec3,
             "inertia": value_matrix_or_table, "inertia_about": value_vec3, "joint": value_table,
             "shape": lambda x: x}  # shape: checked by vibdyn.description.shapes
INERTIA_SHAPES = {  # shape: (keys, required, helper(mass, **params))
    "point": ({}, (), lambda m: _inertia.point(m)),
    "rod": ({"length": value_nonnegative, "axis": value_vec3}, ("length",), _inertia.rod),
    "box": ({"size": value_vec3}, ("size",), _inertia.box),
    "cylinder": ({"radius": value_nonnegative, "length": value_nonnegative, "axis": value_vec3}, ("radius", "length"),
                 _inertia.cylinder),
    "disc": ({"radius": value_nonnegative, "axis": value_vec3}, ("radius",), _inertia.disc),
    "sphere": ({"radius": value_nonnegative, "hollow": value_boolean}, ("radius",), _inertia.sphere),
}
# [[table]] -> (keys, required) of each element kind, from its declaration (vibdyn.description.elements);
# supports first, so that springs and dampers can attach to them
ELEMENT_KEYS = {table: (kind.keys, kind.required) for table, kind in KINDS.items()}
def _start(x):
    if isinstance(x, dict):
        out = {}
        for k, v in x.items():
            try:
                out[k] = value_number(v)
            except BadValue as e:
                raise BadValue(f"start of '{k}': {e}") from None
        return out
    try:
        return value_numbers(x)
    except BadValue:
        raise BadValue(f"expected {{ coordinate = offset, ... }} or a list of offsets (one per coordinate), "
                   f"got {shown(x)}") from None


def _limits(x):
    a = as_list(x)
    if a is None or len(a) != 2 or not all(is_number(v) for v in a) or any(math.isnan(v) for v in a):
        raise BadValue(f"expected [lower, upper] (m or rad), got {shown(x)}")
    return [float(v) for v in a]


OPERATING_POINT_KEYS = {"cyclic": value_table, "start": _start, "held": value_boolean}
TOP_LEVEL = ("scene", "robot", "body", *KINDS, "loop", "limits", "operating_point", "reference")
LOOP_KEYS = {"name": value_string, "a": value_attachment, "b": value_attachment, "joint": value_table}


class _Reader:
    def __init__(self, path):
        self.path = None if path is None else Path(path)
        self.file = None if path is None else str(path)

    def error(self, key, message):
        return SceneFileError(message, path=self.file, key=key)

    def fields(self, d, key, spec, required=(), what=None):
        """Check a table: known keys only, required ones present, each of the right kind."""
        if not isinstance(d, dict):
            raise self.error(key, f"expected a table, got {shown(d)}")
        prefix = f"{what}: " if what else ""
        for k in d:
            if k not in spec:
                raise self.error(f"{key}.{k}", f"{prefix}unknown key '{k}' (allowed: {', '.join(spec)})")
        for k in required:
            if k not in d:
                raise self.error(f"{key}.{k}", f"{prefix}missing required key '{k}'")
        out = {}
        for k, v in d.items():
            try:
                out[k] = spec[k](v)
            except BadValue as e:
                raise self.error(f"{key}.{k}", f"{prefix}{e}") from None
        return out

    def entries(self, d, table):
        """The entries of an array of tables ``[[table]]`` (a list of dicts), checked for shape."""
        value = d.get(table, [])
        if not isinstance(value, (list, tuple)) or not all(isinstance(x, dict) for x in value):
            raise self.error(table, f"expected an array of tables [[{table}]], got {shown(value)}")
        return list(value)

    # ---------------------------------------------------------------- whole scene
    def scene(self, d):
        if not isinstance(d, dict):
            raise self.error(None, f"a scene file holds a table, got {shown(d)}")
        for k, v in d.items():
            if k not in TOP_LEVEL:
                if isinstance(v, (dict, list)):
                    raise self.error(k, f"unknown table '{k}' (allowed: {', '.join(TOP_LEVEL)})")
                raise self.error(k, f"unknown top-level key '{k}': keys go in a table such as [scene] "
                                    f"(tables: {', '.join(TOP_LEVEL)})")
        for k in ("scene", "robot", "limits", "operating_point", "reference"):
            if k in d and not isinstance(d[k], dict):
                raise self.error(k, f"expected a table [{k}], got {shown(d[k])}")
        head = self.fields(d.get("scene", {}), "scene", SCENE_KEYS)
        bodies = self.entries(d, "body")
        elements = {t: self.entries(d, t) for t in ELEMENT_KEYS}

        if "name" in head:
            try:
                Scene(head["name"])  # the same check as the Scene's own
            except ModelError as e:
                raise self.error("scene.name", str(e)) from None
        if "robot" in d:
            scene = self.robot(d["robot"])
            for k in ("name", "source", "description"):
                if k in head:
                    setattr(scene, k, head[k])
            if "gravity" in head:
                scene.gravity = tuple(head["gravity"])
        else:
            default = self.path.stem if self.path is not None and self.path.stem else "scene"
            try:
                scene = Scene(head.get("name", default), head.get("gravity", (0.0, 0.0, 0.0)),
                              source=head.get("source"), description=head.get("description"))
            except ModelError as e:
                raise self.error("scene", str(e)) from None

        if self.path is not None:
            scene.shape_folder = str(self.path.resolve().parent)
        for i, b in self.ordered_bodies(bodies, scene):
            self.body(scene, i, b)
        for table, entries in elements.items():
            for i, e in enumerate(entries):
                self.element(scene, table, i, e)
        for i, e in enumerate(self.entries(d, "loop")):
            self.loop(scene, i, e)
        for name, value in d.get("limits", {}).items():
            try:
                scene.set_limits(name, *_limits(value))
            except (BadValue, ModelError) as e:
                raise self.error(f"limits.{name}", str(e)) from None
        if "operating_point" in d:
            self.operating_point(scene, d["operating_point"])
        if "reference" in d:
            scene.references = copy.deepcopy(dict(d["reference"]))
        return scene

    def operating_point(self, scene, d):
        op = self.fields(d, "operating_point", OPERATING_POINT_KEYS)
        cyclic = None
        if "cyclic" in op:
            cyclic = {}
            for name, speed in op["cyclic"].items():
                if speed == "free":
                    cyclic[name] = None
                elif is_number(speed):
                    cyclic[name] = speed
                else:
                    raise self.error(f"operating_point.cyclic.{name}",
                                     f"speed must be a number (rad/s or m/s) or \"free\", got {shown(speed)}")
        try:
            scene.set_operating_point(cyclic, op.get("start"), op.get("held", False))
        except ModelError as e:
            raise self.error("operating_point", str(e)) from None

    def robot(self, d):
        r = self.fields(d, "robot", ROBOT_KEYS)
        if ("name" in r) == ("urdf" in r):
            raise self.error("robot", "give either name (an example-robot-data robot) or urdf (a file path)")
        options = {"floating": r["floating"]} if "floating" in r else {}  # else the loader's default
        base = self.path.parent if self.path is not None else Path.cwd()
        try:
            from . import robots
        except ImportError as e:
            raise self.error("robot", f"robot loading is not available ({e})") from None
        try:
            if "name" in r:
                if "package_dirs" in r:
                    raise self.error("robot.package_dirs", "package_dirs goes with urdf, not with name")
                return robots.load_robot(r["name"], **options)
            dirs = [str(base / p) for p in r["package_dirs"]] if "package_dirs" in r else None
            urdf = base / r["urdf"]
            if not urdf.is_file():
                raise self.error("robot.urdf", f"no such URDF file: {urdf}")
            return robots.load_urdf(str(urdf), package_dirs=dirs, **options)
        except SceneFileError:
            raise
        except (ModelError, ValueError, OSError, RuntimeError) as e:
            raise self.error("robot", f"cannot load the robot: {e}") from None

    # ---------------------------------------------------------------- bodies
    def ordered_bodies(self, bodies, scene):
        """Body entries parents first; unknown parents and parent cycles are errors naming the body."""
        names = {}  # body name or joint name -> entry index
        for i, b in enumerate(bodies):
            key = f"body[{i}]"
            if "name" not in b:
                raise self.error(f"{key}.name", "missing required key 'name'")
            name = b["name"]
            if not isinstance(name, str):
                raise self.error(f"{key}.name", f"expected a string, got {shown(name)}")
            if name in names:
                raise self.error(f"{key}.name", f"duplicate body name '{name}' (also body[{names[name]}])")
            names[name] = i
        for i, b in enumerate(bodies):
            j = b.get("joint")
            jname = j.get("name") if isinstance(j, dict) else None
            if isinstance(jname, str) and jname not in names:
                names[jname] = i
        parent = {}
        for i, b in enumerate(bodies):
            p = b.get("parent", WORLD)
            if not isinstance(p, str):
                raise self.error(f"body[{i}].parent", f"body '{b['name']}': expected a string, got {shown(p)}")
            if p == WORLD or (p not in names and _has_body(scene, p)):
                parent[i] = None
            elif p in names:
                parent[i] = names[p]
            else:
                raise self.error(f"body[{i}].parent", f"body '{b['name']}': unknown parent '{p}'")
        order, state = [], {}
        for start in range(len(bodies)):
            path, i = [], start
            while i is not None and state.get(i) != "done":
                if i in path:
                    cycle = path[path.index(i):] + [i]
                    names_ = " -> ".join(bodies[k]["name"] for k in cycle)
                    raise self.error(f"body[{i}].parent", f"body '{bodies[i]['name']}': cycle in the parent "
                                                           f"links ({names_})")
                path.append(i)
                i = parent[i]
            for k in reversed(path):
                state[k] = "done"
                order.append(k)
        return [(i, bodies[i]) for i in order]

    def body(self, scene, i, d):
        key = f"body[{i}]"
        what = f"body '{d['name']}'"
        b = self.fields(d, key, BODY_KEYS, ("name", "mass"), what)
        joint = self.joint(b["joint"], f"{key}.joint", what) if "joint" in b else None
        inertia = b.get("inertia")
        if isinstance(inertia, dict):
            if "inertia_about" in b:
                raise self.error(f"{key}.inertia_about", f"{what}: inertia_about goes with an inertia matrix; "
                                                         "a helper table gives the tensor about the com")
            inertia = self.inertia_table(inertia, b["mass"], f"{key}.inertia", what)
        try:
            scene.add_body(b["name"], parent=b.get("parent", WORLD), joint=joint, mass=b["mass"],
                           com=b.get("com", (0.0, 0.0, 0.0)), inertia=inertia,
                           inertia_about=b.get("inertia_about"), shape=b.get("shape"))
        except ModelError as e:
            raise self.error(key, str(e)) from None

    def kind(self, d, field, registry, key, what, noun):
        """The value of the table's ``field`` (e.g. a joint's type), which must name an entry of registry."""
        kind = d.get(field)
        if kind is None:
            raise self.error(f"{key}.{field}", f"{what}: missing required key '{field}' (one of "
                                               f"{', '.join(registry)})")
        if not isinstance(kind, str) or kind not in registry:
            raise self.error(f"{key}.{field}", f"{what}: unknown {noun} {shown(kind)} (one of "
                                               f"{', '.join(registry)})")
        return kind

    def joint(self, d, key, what):
        kind = self.kind(d, "type", _joints.JOINT_TYPES, key, what, "joint type")
        cls = _joints.JOINT_TYPES[kind]
        j = self.fields(d, key, {**cls.common_file_keys, **cls.file_keys}, cls.file_required, f"{what} {kind} joint")
        j.pop("type")
        try:
            return cls.from_file(j, lambda k, message: self.error(f"{key}.{k}", f"{what}: {message}")).checked()
        except SceneFileError:
            raise
        except ModelError as e:
            raise self.error(key, f"{what}: {e}") from None

    def inertia_table(self, d, mass, key, what):
        shape = self.kind(d, "shape", INERTIA_SHAPES, key, what, "inertia shape")
        params, required, helper = INERTIA_SHAPES[shape]
        p = self.fields(d, key, {"shape": value_string, **params}, required, f"{what} {shape} inertia")
        p.pop("shape")
        try:
            return helper(mass, **p)
        except ModelError as e:
            raise self.error(key, f"{what}: {e}") from None

    # ---------------------------------------------------------------- elements
    def element(self, scene, table, i, d):
        key = f"{table}[{i}]"
        spec, required = ELEMENT_KEYS[table]
        name, body = d.get("name"), d.get("body")
        what = table.replace("_", " ")
        if isinstance(name, str):
            what += f" '{name}'"
        elif isinstance(body, str):
            what += f" on '{body}'"

        e = self.fields(d, key, spec, required, what)
        try:
            KINDS[table].from_file(scene, e, lambda k, message: self.error(f"{key}.{k}", message))
        except ModelError as err:
            if isinstance(err, SceneFileError):
                raise
            raise self.error(key, str(err)) from None

    def loop(self, scene, i, d):
        key = f"loop[{i}]"
        what = f"loop '{d['name']}'" if isinstance(d.get("name"), str) else "loop"
        e = self.fields(d, key, LOOP_KEYS, ("name", "a", "b"), what)
        joint = self.joint(e["joint"], f"{key}.joint", what) if "joint" in e else None
        try:
            scene.add_loop(e["name"], file_attachment(e["a"]), file_attachment(e["b"]), joint=joint)
        except ModelError as err:
            if isinstance(err, SceneFileError):
                raise
            raise self.error(key, str(err)) from None


def _has_body(scene, name):
    try:
        scene.body(name)
        return True
    except ModelError:
        return False

