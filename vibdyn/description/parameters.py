"""Scene parameters by name: ``"<body or element>.<attribute>[.<component>]"`` and ``"gravity[.<axis>]"``.

A parameter is a number of the description a user can name as in a scene: ``"cart.mass"`` (kg), ``"rod.com.z"``
(m), ``"rod.inertia.yy"`` (kg·m²), ``"rod.joint.at.x"`` (m), ``"k.stiffness"`` (N/m, or N·m/rad on a pivot),
``"damper.damping"``, ``"k.free_length"`` (m), an end of a spring or damper ``"k.a.x"`` (m: on the world, a
support's position), ``"gravity"`` (the magnitude along the scene's gravity direction, m/s²) or
``"gravity.z"``. A vector attribute named without a component (``"rod.com"``) stands for its components; a
per-coordinate tuple whose entries are equal (a joint spring's stiffness) is one parameter, its common value.
:func:`parameters` resolves names; :func:`with_values` returns a copy of a scene with new values.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._check import scalar, unknown_name
from ..errors import ModelError

_AXES = {"x": 0, "y": 1, "z": 2}
_INERTIA = {"xx": (0, 0), "yy": (1, 1), "zz": (2, 2), "xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
#: attribute -> unit, per the coordinate unit of the joint it acts on where it has one
_UNITS = {"mass": "kg", "com": "m", "inertia": "kg·m²", "joint.at": "m", "free_length": "m", "a": "m", "b": "m",
          "gravity": "m/s²", "length": "m"}
_JOINT_UNITS = {"stiffness": {"m": "N/m", "rad": "N·m/rad"}, "damping": {"m": "N·s/m", "rad": "N·m·s/rad"},
                "rest": {"m": "m", "rad": "rad"}, "force": {"m": "N", "rad": "N·m"}}
_POINT_UNITS = {"stiffness": "N/m", "damping": "N·s/m"}
#: attributes that cannot be negative (a difference about zero is taken on one side)
NONNEGATIVE = frozenset({"mass", "stiffness", "damping", "free_length", "inertia"})


@dataclass(frozen=True)
class Parameter:
    """One named number of a scene: ``owner`` (a body, an element, or "gravity"), ``attribute`` ("mass",
    "joint.at", ...), ``index`` (a component: an int, a (row, column) of an inertia, or None for a scalar or
    for every equal entry of a tuple), its ``unit`` and its ``value`` in the scene."""

    name: str
    owner: str
    attribute: str
    index: object
    unit: str
    value: float

    @property
    def nonnegative(self) -> bool:
        if self.attribute == "inertia":  # (a moment of inertia, not a product of inertia)
            ij: tuple = self.index  # type: ignore[assignment]
            return ij[0] == ij[1]
        return self.attribute in NONNEGATIVE


def parameters(scene: Any, names: Any) -> list[Parameter]:
    """The parameters of ``scene`` named by ``names`` (a name or a list; a vector named whole stands for its
    components); an unknown name is a ModelError with the names there are and the closest match."""
    if isinstance(names, str):
        names = [names]
    try:
        names = list(names)
    except TypeError:
        raise ModelError(f"parameters: expected a list of names such as ['k.stiffness', 'cart.mass'], "
                         f"got {names!r}") from None
    if not names:
        raise ModelError("parameters: no parameter named (e.g. ['k.stiffness', 'cart.mass'])")
    out: list[Parameter] = []
    for name in names:
        if not isinstance(name, str):
            raise ModelError(f"parameters: a parameter name must be a string such as 'k.stiffness', got {name!r}")
        out += _resolve(scene, name)
    seen = set()
    for p in out:
        if p.name in seen:
            raise ModelError(f"parameters: '{p.name}' named twice")
        seen.add(p.name)
    return out


def with_values(scene: Any, params: Any, values: Any = None) -> Any:
    """A copy of ``scene`` with new values (SI, each in its parameter's unit): ``params`` a dict {name: value}
    (``with_values(scene, {"k.stiffness": 120.0, "cart.mass": 2.0})``), or a list of names or of
    :class:`Parameter` (as :func:`parameters` gives them) with ``values`` one number each."""
    if isinstance(params, dict):
        if values is not None:
            raise ModelError("with_values: give a dict {name: value}, or names and values, not both")
        params, values = list(params), list(dict(params).values())
    elif isinstance(params, (str, Parameter)):
        params = [params]
    if values is None:
        raise ModelError("with_values: no values: give a dict {name: value}, or names and one value each")
    values = [values] if np.ndim(values) == 0 else list(values)
    params = list(params)
    if len(params) != len(values):
        raise ModelError(f"with_values: {len(params)} parameters but {len(values)} values")
    resolved = []
    for p, x in zip(params, values):
        found = parameters(scene, [p]) if isinstance(p, str) else [p]
        if len(found) != 1:
            raise ModelError(f"with_values: '{p}' stands for {len(found)} parameters "
                             f"({', '.join(q.name for q in found)}): name each")
        resolved.append((found[0], scalar(x, f"with_values: value of '{found[0].name}'")))
    new = scene.copy()
    for p, x in resolved:
        _set(new, p, x)
    return new


def _names(scene):
    """Every name a parameter can have in ``scene`` (for "did you mean")."""
    out = ["gravity", "gravity.x", "gravity.y", "gravity.z"]
    for b in scene.bodies.values():
        out += [f"{b.name}.mass", f"{b.name}.com", f"{b.name}.inertia", f"{b.name}.joint.at"]
    for e in scene.elements.values():
        out += [f"{e.name}.{a}" for a, v in _numbers(e).items()]
    return out


def _numbers(element):
    """The numeric attributes of an element: name -> value (a float or a tuple of them)."""
    out = {}
    for f in dataclasses.fields(element):
        v = _number(element, f.name)
        if v is not None:
            out[f.name] = v
    return out


def _number(element, attr):
    """The element's attribute ``attr`` as a float or a tuple of floats (an end: its point), None if it is no
    number (or no field)."""
    if attr not in element.__dataclass_fields__:
        return None
    v = getattr(element, attr)
    if attr in ("a", "b") and isinstance(v, tuple) and len(v) == 2:
        return tuple(v[1])
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return float(v)
    if isinstance(v, tuple) and v and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
        return tuple(map(float, v))
    return None


def _component(name, value, key, what):
    """(index, value) of the component ``key`` (None: the whole) of a scalar or tuple ``value``."""
    if not isinstance(value, tuple):
        if key is not None:
            raise ModelError(f"parameter '{name}': {what} is one number, it has no component '{key}'")
        return None, value
    if key is None:
        if len(set(value)) == 1:
            return None, value[0]
        return "each", None
    if len(value) == 3 and key in _AXES:
        return _AXES[key], value[_AXES[key]]
    if key.isdigit() and int(key) < len(value):
        return int(key), value[int(key)]
    comps = "x, y, z" if len(value) == 3 else ", ".join(str(i) for i in range(len(value)))
    raise ModelError(f"parameter '{name}': {what} has no component '{key}' (its components: {comps})")


def _expand(name, owner, attribute, value, unit):
    """The parameters of every component of a tuple attribute named whole."""
    keys = "xyz" if len(value) == 3 else [str(i) for i in range(len(value))]
    return [Parameter(f"{name}.{k}", owner, attribute, i, unit, float(x)) for i, (k, x) in enumerate(zip(keys, value))]


def _resolve(scene, name):
    parts = name.split(".")
    if parts[0] == "gravity" and len(parts) <= 2 and "gravity" not in scene.elements:
        g = scene.gravity
        if len(parts) == 1:
            return [Parameter(name, "gravity", "gravity", None, "m/s²", float(np.linalg.norm(g)))]
        index, value = _component(name, tuple(g), parts[1], "gravity")
        return [Parameter(name, "gravity", "gravity", index, "m/s²", float(value))]
    # an element's name may hold dots ("rod.spring"): the longest leading name that is an element's
    element = next((scene.elements[".".join(parts[:i])] for i in range(len(parts) - 1, 0, -1)
                    if ".".join(parts[:i]) in scene.elements), None)
    body = scene.find_body(parts[0]) if element is None else None
    if (body is None and element is None) or len(parts) < 2:
        raise unknown_name(name, _names(scene), "parameter", f"parameters of scene '{scene.name}'")
    if element is not None:
        parts = [element.name, *parts[len(element.name.split(".")):]]
    owner = body.name if body is not None else element.name
    if body is not None:
        attr = "joint.at" if parts[1:3] == ["joint", "at"] else parts[1]
        rest = parts[3:] if attr == "joint.at" else parts[2:]
        if attr == "mass" and not rest:
            return [Parameter(name, owner, "mass", None, "kg", float(body.mass))]
        if attr in ("com", "joint.at") and len(rest) <= 1:
            value = tuple(body.com) if attr == "com" else tuple(body.joint.at)
            if not rest:
                return _expand(name, owner, attr, value, "m")
            index, x = _component(name, value, rest[0], attr)
            return [Parameter(name, owner, attr, index, "m", float(x))]
        if attr == "inertia" and len(rest) <= 1:
            I = np.array(body.inertia)
            if not rest:
                return [Parameter(f"{name}.{k}", owner, "inertia", ij, "kg·m²", float(I[ij]))
                        for k, ij in _INERTIA.items()]
            if rest[0] not in _INERTIA:
                raise ModelError(f"parameter '{name}': an inertia's components are {', '.join(_INERTIA)}")
            return [Parameter(name, owner, "inertia", _INERTIA[rest[0]], "kg·m²", float(I[_INERTIA[rest[0]]]))]
        raise unknown_name(name, _names(scene), "parameter", f"parameters of scene '{scene.name}'")
    attr = parts[1]
    value = _number(element, attr)
    if value is None or len(parts) > 3:
        raise unknown_name(name, _names(scene), "parameter", f"parameters of scene '{scene.name}'")
    unit = _unit(scene, element, attr)
    whole = value
    index, value = _component(name, whole, parts[2] if len(parts) == 3 else None, f"{element.name}.{attr}")
    if index == "each":
        return _expand(name, owner, attr, whole, unit)
    return [Parameter(name, owner, attr, index, unit, float(value))]


def _unit(scene, element, attr):
    if attr in _JOINT_UNITS and getattr(element, "body", None) is not None:
        units = set(element.joint_units(scene))
        if len(units) == 1:
            return _JOINT_UNITS[attr][units.pop()]
        return " or ".join(_JOINT_UNITS[attr][u] for u in ("m", "rad"))
    return _POINT_UNITS.get(attr) or _UNITS.get(attr, "SI (as the scene gives it)")


def _replaced(value, index, x):
    if index is None:
        return tuple(x for _ in value) if isinstance(value, tuple) else x
    out = list(value)
    out[index] = x
    return tuple(out)


def _set(scene, p, x):
    if p.owner == "gravity":
        g = np.array(scene.gravity, float)
        if p.index is None:
            norm = np.linalg.norm(g)
            g = g / norm * x if norm > 0 else np.array([0.0, 0.0, -x])
        else:
            g[p.index] = x
        scene.gravity = tuple(map(float, g))
        return
    if p.owner in scene.bodies:
        b = scene.bodies[p.owner]
        if p.attribute == "mass":
            b = dataclasses.replace(b, mass=x)
        elif p.attribute == "com":
            b = dataclasses.replace(b, com=_replaced(tuple(b.com), p.index, x))
        elif p.attribute == "joint.at":
            b = dataclasses.replace(b, joint=dataclasses.replace(b.joint, at=_replaced(tuple(b.joint.at), p.index, x)))
        else:  # inertia (symmetric)
            I = np.array(b.inertia, float)
            i, j = p.index
            I[i, j] = I[j, i] = x
            b = dataclasses.replace(b, inertia=tuple(tuple(map(float, r)) for r in I))
        scene.bodies[p.owner] = b
        return
    e = scene.elements[p.owner]
    old = getattr(e, p.attribute)
    if p.attribute in ("a", "b"):
        new = (old[0], _replaced(tuple(old[1]), p.index, x))
    else:
        new = _replaced(old, p.index, x)
    scene.elements[p.owner] = dataclasses.replace(e, **{p.attribute: new})
