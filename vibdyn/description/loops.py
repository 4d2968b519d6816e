"""Closed loops, as described: joints that close cycles of bodies (compiled by :mod:`vibdyn.model.constraints`).

A loop joins the frame at ``point_a`` of ``body_a`` and the frame at ``point_b`` of ``body_b`` (both with
their body's axes; ``body_b`` may be "world") by a joint type whose free motions stay free:

=============  ==  =====================================================================
joint          eq  equations
=============  ==  =====================================================================
Ball            3  p_b − p_a = 0 (m, world axes)
Pivot(u)        5  p_b − p_a = 0; (R_a n_i)·(R_b u) = 0, n_1, n_2 ⊥ u (the axis stays aligned)
Cylindrical(u)  4  (R_a n_i)·(p_b − p_a) = 0; (R_a n_i)·(R_b u) = 0
Slider(u)       5  (R_a n_i)·(p_b − p_a) = 0; log(R_aᵀ R_b) = 0 (rad)
Universal(a,b)  4  p_b − p_a = 0; (R_a a)·(R_b b) = 0
Fixed           6  p_b − p_a = 0; log(R_aᵀ R_b) = 0
=============  ==  =====================================================================

Axes are in body_a's frame (the second axis of a Universal in body_b's). The tree stays what the user
built: q is *consistent* when Φ(q) = 0. Redundant equations are normal (a planar four-bar closed with a
pivot has 5 equations of which 2 are independent): ranks come from an SVD of the Jacobian made
dimensionless (position rows / L, translation columns × L, L the scene's length scale) with the relative
tolerance :data:`RANK_RTOL`.
"""

from dataclasses import dataclass

from ..defaults import ASSEMBLY_TOL, RANK_RTOL  # noqa: F401  (vd.loops.RANK_RTOL)
from ..errors import ModelError
from . import joints as _joints
from .elements import WORLD, attachment


@dataclass(frozen=True)
class Loop:
    """A loop closure: ``a`` and ``b`` are (body, point) with the point in the body frame (m)."""

    name: str
    a: tuple
    b: tuple
    joint: _joints.Joint

    @property
    def equations(self):
        return self.joint.loop_equations

    def to_dict(self):
        j = self.joint.to_dict()
        j.pop("at", None)
        return {"name": self.name, "a": [self.a[0], list(self.a[1])], "b": [self.b[0], list(self.b[1])],
                "joint": j}


def make_loop(scene, name, a, b, joint):
    """A checked :class:`Loop` for ``scene`` (ModelError naming the loop otherwise)."""
    what = f"loop '{name}'"
    joint = _joints.Ball() if joint is None else joint
    if not isinstance(joint, _joints.Joint):
        raise ModelError(f"{what}: joint must be a vibdyn joint (Ball, Pivot, Slider, Cylindrical, Universal, "
                         f"Fixed), got {joint!r}")
    if joint.loop_rows is None:
        able = ", ".join(cls.__name__ for cls in _joints.JOINT_TYPES.values() if cls.loop_rows is not None)
        raise ModelError(f"{what}: a {joint.type} joint cannot close a loop (use one of {able})")
    if any(joint.at) or joint.rotation is not None:
        raise ModelError(f"{what}: the joint's 'at'/'rotation' are not used by a loop: the loop frames are at "
                         "point_a and point_b, with their bodies' axes")
    ends = []
    for end, value in (("a", a), ("b", b)):
        body, point = attachment(value, f"{what} end {end}")
        if body != WORLD:
            found = scene.find_body(body)
            if found is None:
                raise ModelError(f"{what} end {end}: unknown body '{body}' (bodies: "
                                 f"{', '.join(scene.bodies) or 'none'}, or 'world')")
            body = found.name
        ends.append((body, tuple(float(x) for x in point)))
    (ba, pa), (bb, pb) = ends
    if ba == WORLD:
        raise ModelError(f"{what}: body_a must be a body (axes are given in its frame); 'world' may be body_b")
    if ba == bb:
        raise ModelError(f"{what}: joins body '{ba}' to itself: a loop closes a cycle between two bodies")
    return Loop(name, ends[0], ends[1], joint)

