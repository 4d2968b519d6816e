"""A bracketed root with its error: Brent's method (``scipy.optimize.brentq``) on a function that returns its
value and the value's own error, the root's error being Brent's tolerance plus that error over the slope."""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..errors import ConvergenceError, ModelError


def bracketed_root(f: Callable[[float], tuple[tuple[float, float], Any]], a: float, b: float,
                   fa: tuple[float, float], fb: tuple[float, float], what: str) -> tuple[float, float, Any]:
    """(x, its error, the extra at x): the root in [a, b] of ``f(x) -> ((value, value error), extra)`` with
    ``fa``, ``fb`` its (value, error) at the ends (of opposite signs), by Brent's method to 1e-12 of the bracket's
    scale. The error: Brent's tolerance plus the value's error at the root over the slope to the evaluation
    nearest it whose value differs from the root's beyond both their errors (at most the bracket's width)."""
    from scipy.optimize import brentq

    seen = {a: (fa, None), b: (fb, None)}

    def g(x):
        x = float(x)
        if x not in seen:
            seen[x] = f(x)
        return seen[x][0][0]

    xtol = 1e-12 * max(abs(a), abs(b), abs(b - a))
    try:
        x = float(brentq(g, a, b, xtol=xtol, rtol=4 * np.finfo(float).eps, maxiter=100))
    except (RuntimeError, ValueError) as e:
        raise ModelError(f"{what}: Brent's method failed in [{a:g}, {b:g}]: {e}") from None
    g(x)
    (value, error), extra = seen[x]
    # a root where f jumps (the followed quantity changed identity inside the bracket) is no root: Brent's last
    # point of a continuous f is within its tolerance times the slope of f
    secant = abs(fb[0] - fa[0]) / abs(b - a)
    if abs(value) > 10 * error + 1e3 * xtol * secant + 64 * np.finfo(float).eps * max(abs(fa[0]), abs(fb[0])):
        raise ConvergenceError(f"{what}: no continuous crossing in [{a:g}, {b:g}]: the value jumps there "
                               f"({value:.3g} at {x:.10g}, error {error:.1e}); give more points in that interval",
                               residual=abs(value), best=x)
    # the slope from the nearest evaluation whose difference from the root's value is well outside both their
    # errors: Brent's last points lie within xtol of the root, where the difference is the values' noise
    # (a slope 1e3 × too steep there made the root's error 1e3 × too small)
    others = sorted((p for p in seen if p != x), key=lambda p: abs(p - x))
    clear = [p for p in others if abs(seen[p][0][0] - value) > 10 * (error + seen[p][0][1])] or others[-1:]
    slope = abs((seen[clear[0]][0][0] - value) / (clear[0] - x))
    bound = error / slope if slope > 0 else abs(b - a)
    return x, float(min(bound, abs(b - a)) + 2 * xtol + 8 * np.finfo(float).eps * abs(x)), extra


def signs(x: np.ndarray, error: np.ndarray) -> np.ndarray:
    """+1 or −1 where ``x`` is positive or negative beyond its ``error``, 0 where |x| is within it: a sign change
    between two neighbours (+1 next to −1) brackets a root that is no round-off."""
    x, error = np.asarray(x, float), np.asarray(error, float)
    return np.where(x > error, 1, np.where(x < -error, -1, 0))


def sign_changes(sign: np.ndarray) -> list[tuple[int, int]]:
    """(i, k) for each change of a sign sequence (from :func:`signs`) from +1 to −1 or back, between neighbours
    or across samples that are 0 (within their error) between them: the brackets of the roots."""
    nonzero = np.flatnonzero(sign)
    return [(int(i), int(k)) for i, k in zip(nonzero[:-1], nonzero[1:]) if sign[i] * sign[k] < 0]
