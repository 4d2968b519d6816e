"""The configuration space of a compiled system: configurations from offsets, the declared start, position
limits, and the one check of state vectors. Units: m and rad per tangent coordinate.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from .._check import all_finite, count, finite_array, start_hint
from ..errors import ModelError

if TYPE_CHECKING:
    from .system import System

_FLOAT = np.dtype(float)


def start_configuration(system: System) -> tuple[np.ndarray, str]:
    """(q, what): the configuration analyses start from when given none (the scene's declared start, else
    neutral: with loops, their closure nearest it) and its name."""
    start = (system.scene.operating_point or {}).get("start")
    if start is None:  # (with loops: vibdyn.model.assembly)
        if system.compiled_loops is None:
            return system.neutral(), "the neutral configuration"
        return system.compiled_loops.start(system)
    try:
        q = configuration(system, start)
    except ModelError as e:
        raise ModelError(f"operating point start: {e}") from None
    start_hint(system, q, "operating point start")
    if isinstance(start, Mapping):
        text = ", ".join(f"{k} = {float(x):.6g}" for k, x in start.items())
    else:
        text = ", ".join(f"{k} = {float(x):.6g}" for k, x in zip(system.coordinates, np.ravel(start)))
    if not text:  # (an empty start declares neutral: the closures of loops are searched only without one)
        text = "neutral" if not system.scene.loops else \
            "neutral: empty; declare none to have the closures searched"
    return q, f"the declared start ({text})"


def configuration(system: System, offsets: Any) -> np.ndarray:
    """Configuration at tangent offsets from neutral (m or rad): one per coordinate, or a dict
    {coordinate: offset} (the others at 0)."""
    dv = np.zeros(system.nv)
    if isinstance(offsets, dict):
        for name, x in offsets.items():
            dv[system.coordinate_index(name)] = x
    else:
        dv = np.asarray(offsets, dtype=float)
        if dv.shape != (system.nv,):
            raise ModelError(f"offsets: expected {count(system.nv, 'number')} (one per coordinate: "
                             f"{', '.join(system.coordinates)}), got {dv.size}")
    return system.integrate(system.neutral(), dv)


def beyond_limits(system: System, x: np.ndarray) -> np.ndarray:
    """Which offsets x from neutral (m or rad; a vector, or one a row) lie beyond their position limits."""
    return (x < system.lower_limits) | (x > system.upper_limits)


def check_limits(system: System, q: Any, what: str) -> None:
    """ModelError naming the first coordinate of ``q`` outside its position limits (m or rad from neutral)."""
    if not system.limits:
        return
    lower, upper = system.lower_limits, system.upper_limits
    x = system.difference(system.neutral(), q)
    for i in np.flatnonzero(beyond_limits(system, x)):
        side, bound = ("lower", lower[i]) if x[i] < lower[i] else ("upper", upper[i])
        u = system.units[i]
        raise ModelError(f"{what}: coordinate '{system.coordinates[i]}' = {x[i]:.6g} {u} is beyond its {side} "
                         f"limit {bound:.6g} {u}")


def state(x: Any, n: int, what: str, expected: Callable[[], str]) -> np.ndarray:
    """A finite float vector of n numbers (the one input layer: finite_array), a new array; ``expected()``
    says what it should be in the error."""
    if type(x) is np.ndarray and x.dtype is _FLOAT and x.shape == (n,) and all_finite(x):
        return x.copy()  # the common case, without finite_array's conversions
    try:
        return finite_array(x, (n,), what)
    except ModelError as e:
        detail = str(e)[len(what) + 2:]
        if detail.startswith("contains"):
            raise
        got = f"shape {detail.split('got ', 1)[1]}" if detail.startswith("expected shape") else repr(x)
        raise ModelError(f"{what}: expected {expected()}, got {got}") from None
