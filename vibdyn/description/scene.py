"""Scene: the plain description of a set of solids, its links and its force elements.

A scene is checked as it is built (every mistake is a ModelError naming the element) and compiled once by
:meth:`Scene.build` into a :class:`vibdyn.System`. It knows nothing of Pinocchio.
"""

from __future__ import annotations

import copy
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._check import (
    MAX_LENGTH,
    MAX_MASS,
    bounded,
    finite_array,
    scalar,
    unknown_name,
    vector3,
)
from ..errors import ModelError

if TYPE_CHECKING:  # the compiled type, for the entry point's hint (built on call)
    from ..model.system import System
from . import inertia as _inertia
from . import joints as _joints
from .elements import (
    KINDS,
    WORLD,
    BodyForce,
    Damper,
    JointDamper,
    JointForce,
    JointSpring,
    Spring,
    Support,
    attachment,
)


@dataclass(frozen=True)
class Body:
    """A rigid solid: mass (kg), centre of mass (m, body frame), inertia about it (kg·m², body axes)."""

    name: str
    parent: str
    joint: _joints.Joint
    mass: float
    com: tuple
    inertia: tuple
    shape: tuple = ()  # visual shapes (vibdyn.description.shapes.Shape), for the viewer only

    @property
    def coordinates(self):
        """Names of this body's tangent coordinates."""
        label = self.joint.name or self.name
        return tuple(label + s for s in self.joint.suffixes)

    def to_dict(self):
        d = {"name": self.name, "parent": self.parent, "mass": self.mass, "com": list(self.com),
             "inertia": [list(r) for r in self.inertia], "joint": self.joint.to_dict()}
        if self.shape:
            d["shape"] = [s.to_dict() for s in self.shape]
        return d


class Scene:
    """A set of rigid solids joined to a tree of links, with springs, dampers, forces and gravity.

    ``gravity`` is the gravity vector (m/s², world axes): a free vector, e.g. ``(0, 0, -9.81)``.
    ``source`` and ``references`` record where the scene comes from and values it must reproduce.
    """

    def __init__(self, name="scene", gravity=(0.0, 0.0, 0.0), *, source=None, description=None):
        if not isinstance(name, str) or not name:
            raise ModelError(f"scene name must be a non-empty string, got {name!r}")
        self.name = name
        self.gravity = tuple(float(x) for x in vector3(gravity, f"scene '{name}' gravity"))
        self.source = source
        self.description = description
        self.references = {}
        self.bodies = {}
        self.elements = {}  # name -> element, in insertion order
        self.operating_point = None  # None: static equilibrium from neutral; see set_operating_point
        self.limits = {}  # coordinate -> (lower, upper) (m or rad); see set_limits
        self.robot_source = None  # where a loaded robot came from (vibdyn.io.robots)
        self.shape_folder = None  # where relative mesh paths of shapes start (a scene file's folder)
        self.loops = {}  # name -> vibdyn.description.loops.Loop: joints closing cycles (see add_loop)

    # ---------------------------------------------------------------- bodies
    def add_body(self, name: str, parent: str = WORLD, joint: _joints.Joint | None = None, mass: float = 0.0,
                 com: Any = (0.0, 0.0, 0.0), inertia: Any = None, inertia_about: Any = None,
                 shape: Any = None) -> Body:
        """Add a body joined to ``parent`` by ``joint`` (a Fixed weld if None).

        ``mass`` in kg; ``com`` in m (body frame); ``inertia`` a 3×3 tensor (kg·m², body axes) about the
        centre of mass, or about the point ``inertia_about`` (converted by Huygens); None is a point mass.
        ``shape``: what the viewer draws (a table or a list, see :mod:`vibdyn.description.shapes`); None draws the box
        of equal inertia.
        """
        what = f"body '{name}'"
        self.check_new_name(name, "body")
        if parent == name:
            raise ModelError(f"{what}: cannot be its own parent (cycle)")
        if parent != WORLD:
            found = self.find_body(parent)
            if found is None:
                raise self.unknown_body(parent, what, noun="parent", extra=(WORLD,))
            parent = found.name
        joint = _joints.Fixed() if joint is None else joint
        if not isinstance(joint, _joints.Joint):
            raise ModelError(f"{what}: joint must be a vibdyn joint (Pivot, Slider, ...), got {joint!r}")
        joint.checked(what)
        if joint.name == WORLD:
            raise ModelError(f"{what}: joint name 'world' is reserved for the fixed frame")
        if joint.name and (joint.name in self.elements or self.find_body(joint.name) is not None):
            raise ModelError(f"{what}: duplicate name '{joint.name}' for its joint")
        bounded(joint.at, MAX_LENGTH, f"{what} joint 'at'", "m")
        m = bounded(scalar(mass, f"{what} mass"), MAX_MASS, f"{what} mass", "kg")
        if m < 0:
            raise ModelError(f"{what}: negative mass {m} kg")
        c = bounded(vector3(com, f"{what} com"), MAX_LENGTH, f"{what} com", "m")
        I = np.zeros((3, 3)) if inertia is None else finite_array(inertia, (3, 3), f"{what} inertia")
        if inertia_about is not None:
            I = _inertia.to_com(I, m, c, vector3(inertia_about, f"{what} inertia_about"))
        I = _inertia.check(I, m, f"{what} inertia")
        from .shapes import shapes

        body = Body(name, parent, joint, m, tuple(map(float, c)), tuple(tuple(map(float, r)) for r in I),
                    shapes(shape, what, self.shape_folder))
        self.bodies[name] = body
        index = self.__dict__.get("_joint_index")
        if index is not None and index[0] == len(self.bodies) - 1:  # kept current: loading stays linear
            if joint.name:
                index[1][joint.name] = body
            self._joint_index = (len(self.bodies), index[1])
        return body

    # ---------------------------------------------------------------- elements
    # force elements: each kind checks its own arguments (vibdyn.description.elements.<kind>.add)
    def add_spring(self, name: str, a: Any, b: Any, stiffness: float, free_length: float | None = None) -> Spring:
        """Linear spring (N/m) between points ``a`` and ``b``: ``"body"``, ``(body, (x, y, z))`` in the body
        frame (m), ``("world", point)`` or ``(support, point)``; ``free_length`` (m) None: the distance at the
        neutral configuration."""
        return Spring.add(self, name, a, b, stiffness, free_length)

    def add_damper(self, name: str, a: Any, b: Any, damping: float) -> Damper:
        """Linear viscous damper (N·s/m) between points ``a`` and ``b``."""
        return Damper.add(self, name, a, b, damping)

    def add_joint_spring(self, body: str, stiffness: Any, rest: Any = 0.0, name: str | None = None) -> JointSpring:
        """Spring on the joint of ``body`` (torsion spring on a pivot; on the rotation vector for a ball).

        ``stiffness`` N/m or N·m/rad, one number or one per coordinate; ``rest`` the rest offset from the
        neutral configuration in tangent coordinates (m or rad).
        """
        return JointSpring.add(self, body, stiffness, rest, name)

    def add_joint_damper(self, body: str, damping: Any, name: str | None = None) -> JointDamper:
        """Viscous damper on the joint of ``body`` (N·s/m or N·m·s/rad, one number or one per coordinate)."""
        return JointDamper.add(self, body, damping, name)

    def add_joint_force(self, body: str, value: Any, name: str | None = None, velocity_dependent: bool | None = None,
                        time_dependent: bool | None = None) -> JointForce:
        """Force/torque on the joint of ``body`` in its coordinates (N or N·m).

        ``value``: a number (one per coordinate), a law from :mod:`vibdyn.laws`, or a callable
        ``f(t, q, v)`` of time and the joint's own coordinates. A callable counts as depending on v and t
        unless declared otherwise with ``velocity_dependent=False`` / ``time_dependent=False``.
        """
        return JointForce.add(self, body, value, name, velocity_dependent, time_dependent)

    def add_support(self, name: str, motion: Any) -> Support:
        """A moving support (base excitation): springs and dampers attach to ``(name, point)``, the point in
        world axes, moved by ``motion`` — a :class:`vibdyn.laws.HarmonicMotion`, ``vibdyn.laws.road(...)``,
        a :class:`vibdyn.laws.Motion` of two callables of t, or a dict of a law."""
        return Support.add(self, name, motion)

    def add_force(self, name: str, body: str, force: Any = (0.0, 0.0, 0.0), at: Any = (0.0, 0.0, 0.0),
                  torque: Any = None, frame: str = "world") -> BodyForce:
        """External force (N) at the point ``at`` of ``body`` (m, body frame) and optional torque (N·m).

        ``force``/``torque``: 3-vectors or callables ``f(t, q, v)`` → 3-vector; ``frame`` "world" or "body"
        says in which axes they are given.
        """
        return BodyForce.add(self, name, body, force, at, torque, frame)

    def add_drive(self, body: str, motion: Any, name: str | None = None) -> Any:
        """Prescribe the coordinate of ``body``'s joint (pivot, slider or helical) in time: ``motion`` is
        :class:`vibdyn.laws.Harmonic` or :class:`vibdyn.laws.Motion` (position, velocity, acceleration: m or
        rad, per s, per s²). Analyses and simulations take it as given (see
        :mod:`vibdyn.description.elements.drive`)."""
        return KINDS["drive"].add(self, body, motion, name)

    def add_bearing(self, name: str, housing: Any, journal: Any, stiffness: Any, damping: Any = None,
                    speeds: Any = None, *, axis: Any = (0.0, 0.0, 1.0), interpolation: str = "linear") -> Any:
        """Bearing between ``housing`` and ``journal`` (ends as springs take them): ``stiffness`` (N/m) and
        ``damping`` (N·s/m) [[xx, xy], [yx, yy]] in the world axes normal to ``axis``, or tables (n × 2 × 2) at
        the journal's spin speeds ``speeds`` (rad/s, increasing) (see :mod:`vibdyn.description.elements.bearing`)."""
        return KINDS["bearing"].add(self, name, housing, journal, stiffness, damping, speeds, axis=axis,
                                    interpolation=interpolation)

    def add_unbalance(self, name: str, body: str, amount: float, at: Any = (0.0, 0.0, 0.0), angle: float = 0.0) -> Any:
        """Unbalance ``amount`` m·e (kg·m) at the point ``at`` of ``body`` (m, body frame), at ``angle`` (rad)
        about its spin axis: the load of :func:`vibdyn.unbalance_response`."""
        return KINDS["unbalance"].add(self, name, body, amount, at, angle)

    def __getattr__(self, name):
        # every other element kind: Scene.add_<table>(...) is its ``add`` (one declaration per kind)
        if name.startswith("add_") and name[4:] in KINDS:
            kind = KINDS[name[4:]]
            return lambda *args, **kwargs: kind.add(self, *args, **kwargs)
        raise AttributeError(f"'Scene' object has no attribute {name!r}")

    def add_loop(self, name: str, a: Any, b: Any, joint: _joints.Joint | None = None) -> Any:
        """Close a loop: the frame at point a = ``(body_a, point_a)`` and the frame at b = ``(body_b,
        point_b)`` (points in m, body frames; frames with the bodies' axes; ``body_b`` may be "world") are
        joined by ``joint`` (``Ball()`` if None; ``Pivot(axis)``, ``Slider(axis)``, ``Cylindrical(axis)``,
        ``Universal(axis1, axis2)``, ``Fixed()``; axes in body_a's frame). See :mod:`vibdyn.description.loops`."""
        from .loops import make_loop

        self.check_new_name(name, "loop")
        if name in getattr(self, "loops", {}):
            raise ModelError(f"duplicate name '{name}' (loop): names must be unique in a scene")
        loop = make_loop(self, name, a, b, joint)
        self.loops[name] = loop
        return loop

    def set_operating_point(self, cyclic: dict | None = None, start: Any = None, held: bool = False) -> None:
        """Declare the operating point analyses use by default (``System.operating_point()``).

        ``cyclic``: {coordinate: speed (rad/s or m/s) or None (found from the forces)} for a steady motion;
        None for a static equilibrium. ``start``: where the search begins (or, with ``held``, the held
        configuration): tangent offsets from neutral, one per coordinate, or {coordinate: offset} (m or
        rad; the others at 0). ``held``: the configuration is held by drives (``System.held``) instead of
        searched for (robots under gravity have no free equilibrium). Names are checked at build time.
        """
        if cyclic is not None:
            if not isinstance(cyclic, dict) or not cyclic:
                raise ModelError("operating point: cyclic must be a non-empty dict {coordinate: speed or None}")
            cyclic = {str(k): (None if x is None else scalar(x, f"operating point speed of '{k}'"))
                      for k, x in cyclic.items()}
        if isinstance(start, dict):
            start = {str(k): scalar(x, f"operating point start of '{k}'") for k, x in start.items()}
        elif start is not None:
            start = tuple(float(x) for x in finite_array(start, (None,), "operating point start"))
        if held and cyclic is not None:
            raise ModelError("operating point: held and cyclic exclude each other (a held point does not move)")
        if cyclic is None and start is None and not held:
            self.operating_point = None
        else:
            self.operating_point = {"cyclic": cyclic, "start": start}
            if held:
                self.operating_point["held"] = True

    def set_limits(self, coordinate: str, lower: float = -np.inf, upper: float = np.inf) -> None:
        """Position limits of a one-coordinate joint (pivot, slider, helical; m or rad, from its neutral),
        as a URDF gives them. Equilibrium searches refuse to leave them (``System.limits``)."""
        b = self.joint_body(coordinate, "limits")
        if b.joint.nv != 1:
            raise ModelError(f"limits on '{coordinate}': only one-coordinate joints (pivot, slider, helical) take "
                             f"limits, its joint is a {b.joint.type}")
        bounds = []
        for x in (lower, upper):
            if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)) or np.isnan(x):
                raise ModelError(f"limits on '{coordinate}': expected two numbers (lower, upper), got {x!r}")
            bounds.append(float(x))
        lo, up = bounds
        if not lo <= up:
            raise ModelError(f"limits on '{coordinate}': need lower ≤ upper, got [{lo:g}, {up:g}]")
        self.limits[b.coordinates[0]] = (float(lo), float(up))

    # ---------------------------------------------------------------- queries
    def elements_of(self, kind: Any) -> list:
        """The elements of one kind (its class, e.g. ``Spring``), in insertion order."""
        return [e for e in self.elements.values() if isinstance(e, kind)]

    def children(self, name: str) -> list[Body]:
        return [b for b in self.bodies.values() if b.parent == name]

    def body(self, name: str) -> Body:
        """A body by its name or its joint's name."""
        b = self.find_body(name)
        if b is None:
            raise self.unknown_body(name, f"scene '{self.name}'")
        return b

    def unknown_body(self, name: str, what: str, *, noun: str = "body", extra: tuple = (),
                     moving: bool = False) -> ModelError:
        """The ModelError for an unknown body name: the valid names (bodies and their joints' names, after
        ``extra``; only bodies with a coordinate if ``moving``) and the closest match."""
        bodies = [b for b in self.bodies.values() if not moving or b.joint.nv]
        names = [*extra, *(n for b in bodies for n in (b.name, b.joint.name) if n)]
        plural = "valid parents" if noun == "parent" else "bodies with a coordinate" if moving else "bodies"
        return unknown_name(name, names, noun, plural, what)

    #: tables of immutable entries (frozen bodies, elements, loops): a copy shares their entries
    _IMMUTABLE_ENTRIES = ("bodies", "elements", "loops")

    def tree_order(self) -> list[Body]:
        """The bodies depth-first from the world (Pinocchio's CRBA needs each subtree's coordinates
        contiguous); a cycle or an unknown parent is a ModelError naming the body."""
        rooted = {WORLD}  # bodies known to reach the world
        for b in self.bodies.values():
            path, on_path, p = [b.name], {b.name}, b.parent
            while p not in rooted:
                if p not in self.bodies:
                    raise self.unknown_body(p, f"body '{path[-1]}'", noun="parent", extra=(WORLD,))
                if p in on_path:
                    raise ModelError(f"body '{b.name}': cycle in the parent links ({' -> '.join(path + [p])})")
                path.append(p)
                on_path.add(p)
                p = self.bodies[p].parent
            rooted.update(path)
        children: dict[str, list[Body]] = {}
        for b in self.bodies.values():
            children.setdefault(b.parent, []).append(b)
        order, stack = [], list(reversed(children.get(WORLD, [])))
        while stack:
            b = stack.pop()
            order.append(b)
            stack.extend(reversed(children.get(b.name, [])))
        return order

    def massless_leaves(self, order: list[Body] | None = None) -> list[str]:
        """Names of the bodies with coordinates and zero mass that carry no mass below them (their motion is
        undefined); ``order``: :meth:`tree_order`, if already made."""
        order = self.tree_order() if order is None else order
        carried = {b.name: b.mass for b in order}
        for b in reversed(order):
            if b.parent in carried:
                carried[b.parent] += carried[b.name]
        return [b.name for b in order if b.joint.nv > 0 and carried[b.name] == 0.0]

    def copy(self) -> Scene:
        """An independent copy: new tables sharing their immutable entries, the rest copied deeply (linear in
        the number of bodies, where a deep copy of every body was not)."""
        new = copy.copy(self)
        new.__dict__.pop("_joint_index", None)  # (a cache of this scene's own bodies: rebuilt on demand)
        try:
            for key, value in list(vars(new).items()):
                setattr(new, key, dict(value) if key in self._IMMUTABLE_ENTRIES else copy.deepcopy(value))
        except RecursionError:  # e.g. references nested a thousand deep
            raise ModelError(f"scene '{self.name}': data nested too deeply to copy (references?)") from None
        return new

    def build(self) -> System:
        """Compile the scene into a :class:`vibdyn.System` (checks it as a whole first)."""
        from ..model.system import System

        return System(self)

    def to_dict(self) -> dict:
        from ..io.scenewrite import scene_to_dict

        return scene_to_dict(self)

    def save(self, path: str | os.PathLike) -> None:
        """Write the scene as a TOML scene file."""
        from ..io.scenewrite import save_scene

        save_scene(self, path)

    def __repr__(self):
        g = "" if not any(self.gravity) else f", gravity={self.gravity}"
        return f"Scene({self.name!r}, {len(self.bodies)} bodies, {len(self.elements)} elements{g})"

    # ---------------------------------------------------------------- helpers
    def find_body(self, name: str) -> Body | None:
        """The body named ``name`` or carried by the joint named ``name``; None if there is none."""
        if not isinstance(name, str):
            return None
        if name in self.bodies:
            return self.bodies[name]
        index = self.__dict__.get("_joint_index")
        if index is None or index[0] != len(self.bodies):  # bodies by joint name, rebuilt if stale
            index = (len(self.bodies), {b.joint.name: b for b in self.bodies.values() if b.joint.name})
            self._joint_index = index
        b = index[1].get(name)
        return b if b is not None and self.bodies.get(b.name) is b else None

    def joint_body(self, name: str, noun: str) -> Body:
        """The body with coordinates named ``name`` (or its joint's name), for an element called ``noun``."""
        b = self.find_body(name)
        if b is None:
            raise self.unknown_body(name, noun, moving=True)
        if b.joint.nv == 0:
            raise ModelError(f"{noun} on '{name}': body is welded (Fixed joint), it has no coordinate")
        return b

    def resolve_attachment(self, value: Any, what: str) -> tuple:
        """An attachment checked against this scene: (body name, point) with the body's own name, "world",
        or a support."""
        body, point = attachment(value, what)
        if body != WORLD and not isinstance(self.elements.get(body), Support):
            b = self.find_body(body)
            if b is None:
                supports = [e.name for e in self.elements.values() if isinstance(e, Support)]
                raise self.unknown_body(body, what, extra=(WORLD, *supports))
            body = b.name
        return body, point

    def check_new_name(self, name: str, noun: str) -> None:
        """A ModelError if ``name`` is not a fresh name for an element called ``noun``."""
        if not isinstance(name, str) or not name or name.strip() != name:
            raise ModelError(f"{noun} name must be a non-empty string without surrounding spaces, got {name!r}")
        if name == WORLD:
            raise ModelError(f"{noun} name 'world' is reserved for the fixed frame")
        if name in self.bodies or name in self.elements or self.find_body(name) is not None:
            raise ModelError(f"duplicate name '{name}' ({noun}): names must be unique in a scene")

    def add_element(self, element: Any) -> Any:
        """Add a checked element (what each kind's ``add`` ends with)."""
        self.elements[element.name] = element
        return element
