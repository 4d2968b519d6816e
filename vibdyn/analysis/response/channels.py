"""Channels: inputs and outputs of a response (coordinates, body points with a direction)."""

from dataclasses import dataclass

import numpy as np

from ..._check import unit_axis, vector3
from ...errors import ModelError


# ====================================================================== inputs and outputs
@dataclass(frozen=True, eq=False)
class Channels:
    """Inputs or outputs of a response. Row j of ``matrix`` (k × nv) is the displacement along channel j
    per tangent coordinate; a unit force on channel j is the generalized force ``matrix[j]`` (Jᵀd)."""

    matrix: np.ndarray
    labels: tuple
    units: tuple  # displacement unit per channel: "m" or "rad"

    @property
    def force_units(self):
        return tuple("N" if u == "m" else "N·m" for u in self.units)


def channels(lin, spec=None, direction=None, what="outputs"):
    """:class:`Channels` of a linear model from a spec: None (all coordinates), a coordinate name, a body
    point ``(body, (x, y, z), (dx, dy, dz))`` (or ``(body, (x, y, z))`` with ``direction``), or a list of
    them."""
    if spec is None:
        return Channels(np.eye(lin.nv), tuple(lin.coordinates), tuple(lin.units))
    items = [spec] if isinstance(spec, str) or _is_point(spec) else _as_list(spec, what)
    if not items:
        raise ModelError(f"{what}: empty list (give coordinate names, body points or None)")
    rows, labels, units = [], [], []
    for item in items:
        if isinstance(item, str):
            row, unit = lin.coordinate_row(item)
            rows.append(row)
            labels.append(item)
            units.append(unit)
        elif _is_point(item):
            body = item[0]
            point = vector3(item[1], f"{what}: point of body '{body}'")
            d = item[2] if len(item) == 3 else direction
            if d is None:
                raise ModelError(f"{what}: point {body}{vector_label(point)} needs a direction: "
                                 "(body, (x, y, z), (dx, dy, dz)) or direction=(dx, dy, dz)")
            d = unit_axis(d, f"{what}: direction at {body}{vector_label(point)}")
            rows.append(d @ lin.point_jacobian([(body, point)]))
            labels.append(f"{body}{vector_label(point)}·{vector_label(d)}")
            units.append("m")
        else:
            raise ModelError(f"{what}: expected a coordinate name, a point (body, (x, y, z), (dx, dy, dz)) "
                             f"or None, got {item!r}")
    return Channels(np.array(rows), tuple(labels), tuple(units))


def _is_point(x):
    if not isinstance(x, (tuple, list)) or len(x) not in (2, 3) or not isinstance(x[0], str):
        return False
    try:
        return not isinstance(x[1], str) and np.shape(x[1]) == (3,)
    except ValueError:
        return False


def _as_list(spec, what):
    try:
        return list(spec)
    except TypeError:
        raise ModelError(f"{what}: expected a coordinate name, a body point, a list of them or None, "
                         f"got {spec!r}") from None


def vector_label(x):
    return "(" + ",".join(f"{float(v):g}" for v in np.ravel(x)) + ")"


