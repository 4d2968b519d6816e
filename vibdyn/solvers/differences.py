"""Difference quotients of plain functions (of a scalar or a vector; numbers or arrays out): the one place they
are written. :mod:`vibdyn.model.fd` builds its tangent-space stencils on these and re-exports them, so the
model and the analyses take them from there; the solvers (below the model) take them from here.

Central: D(h) = (f(x + h) − f(x − h)) / 2h, truncation h²/6·f‴ + O(h⁴); with an estimate, D(2h) too and
T = D(h) − D(2h) = −h²/2·f‴ + O(h⁴), three times the truncation to leading order (Richardson). One-sided,
second order (at a bound): D(h) = (−3f(x) + 4f(x + h) − f(x + 2h)) / 2h, T = D(h) − D(2h) likewise. Second:
(f(x + h) + f(x − h) − 2f(x)) / h², truncation h²/12·f⁗ (and the mixed ones of a Hessian). Each pair of values
is subtracted before it is divided (exact for nearby values: no rounding of products).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

CENTRAL = (1.0, -1.0)  # the steps of a central difference, in units of h
ESTIMATED = (1.0, 2.0, -1.0, -2.0)  # and those of the central difference with step 2h (positive ones first)
ONE_SIDED = (0.0, 1.0, 2.0, 4.0)  # the steps of the one-sided difference with step h, then 2h (x shared)


def divisors(signs, h) -> np.ndarray:
    """The divisors of the differences f(+s·h) − f(−s·h), one row per step and coordinate: 2h (and 4h)."""
    return (2 * np.multiply.outer(signs[:len(signs) // 2], h)).reshape(-1, 1)


def pairs(Y, divs, n):
    """(D, T) from step-major rows of evaluations (positive steps, then negative ones; outputs along the last
    axis) and their :func:`divisors`: each pair subtracted, then divided; D (outputs × n) and, where the rows
    have a 2h step, T = D(h) − D(2h), else None."""
    half = len(divs)
    diff = Y[:half] - Y[half:]
    diff /= divs
    D = diff[:n].T
    return (D, D - diff[n:].T) if half > n else (D, None)


def differences(Y, h):
    """(D, T) from evaluations Y at the rows of :func:`displaced_vectors` (outputs along Y's last axis): the
    central differences (outputs × n) and, from ``estimate`` rows, their truncation estimates D(h) − D(2h)
    (else None)."""
    signs = ESTIMATED if len(Y) == len(ESTIMATED) * len(h) else CENTRAL
    return pairs(Y, divisors(signs, h), len(h))


def displaced_vectors(x0, h, estimate=False) -> np.ndarray:
    """x0 + s·h_k e_k as rows, step-major (row i·n + k moves component k by signs[i]·h_k), for a plain
    vector x (steps ±h, and ±2h if ``estimate``)."""
    signs = ESTIMATED if estimate else CENTRAL
    S, n = len(signs), len(x0)
    X = np.empty((S * n, n))
    X[:] = x0
    X.reshape(S, n * n)[:, ::n + 1] += np.multiply.outer(signs, h)  # (each n × n block's diagonal)
    return X


def vector_derivative(fun: Callable, x0, h) -> np.ndarray:
    """∂fun/∂x (outputs × n) at x0 for a plain vector x, by central differences with steps h (one per
    component)."""
    return differences(np.array([np.ravel(fun(x)) for x in displaced_vectors(x0, h)]), h)[0]


def derivative(fun: Callable, x: float, h: float, estimate: bool = False, order: int = 2):
    """d fun/dx at the scalar x by the central difference (fun(x + h) − fun(x − h)) / 2h (a number or an array,
    as fun gives); with ``estimate``, (D, T) with T = D(h) − D(2h) its truncation estimate (3× the truncation).
    ``order`` 4: the five-point difference (8(f(x + h) − f(x − h)) − (f(x + 2h) − f(x − 2h))) / 12h
    = D(h) + (D(h) − D(2h))/3, truncation h⁴/30·f⁽⁵⁾ (no estimate)."""
    if order == 4 and not estimate:
        fp, fm, fp2, fm2 = (fun(x + s * h) for s in (1.0, -1.0, 2.0, -2.0))
        return (8 * (fp - fm) - (fp2 - fm2)) / (12 * h)
    if order != 2:
        raise ValueError(f"derivative: order 2, or 4 without an estimate, not {order!r}")
    if not estimate:
        return (fun(x + h) - fun(x - h)) / (2 * h)
    Y = [fun(x + s * h) for s in ESTIMATED]
    D = (Y[0] - Y[2]) / (2 * h)
    return D, D - (Y[1] - Y[3]) / (4 * h)


def second_derivative(fun: Callable, x: float, h: float, f0=None):
    """(f′, f″) at the scalar x by the central differences (f(x + h) − f(x − h)) / 2h and
    (f(x + h) + f(x − h) − 2f(x)) / h² (numbers or arrays, as fun gives); ``f0`` = fun(x) if already known."""
    fm, fp = fun(x - h), fun(x + h)
    if f0 is None:
        f0 = fun(x)
    return (fp - fm) / (2 * h), (fp + fm - 2 * f0) / h**2


def secant(fun: Callable, a, b):
    """(fun(b) − fun(a)) / (b − a): the slope between two points (numbers or arrays), as a central difference
    cut off at a bound (a = max(x − h, lower), b = x + h)."""
    return (fun(b) - fun(a)) / (b - a)


def hessian(fun: Callable, x0, h, f0=None) -> np.ndarray:
    """∂²fun/∂x² (outputs × n × n) at x0 for a plain vector x by central second differences with steps h (one
    per component, or one for all): (f(x + h_i) + f(x − h_i) − 2f(x)) / h_i² on the diagonal and
    (f(x + h_i + h_j) − f(x + h_i − h_j) − f(x − h_i + h_j) + f(x − h_i − h_j)) / 4h_ih_j off it; ``f0`` =
    fun(x0) if already known."""
    x0 = np.asarray(x0, float)
    n = x0.size
    h = np.broadcast_to(np.asarray(h, float), (n,))
    f0 = np.ravel(fun(x0)) if f0 is None else np.ravel(f0)

    def at(i, si, j=None, sj=0.0):
        x = x0.copy()
        x[i] += si * h[i]
        if j is not None:
            x[j] += sj * h[j]
        return np.ravel(fun(x))

    H = np.empty((f0.size, n, n))
    for i in range(n):
        H[:, i, i] = at(i, 1.0) + at(i, -1.0) - 2 * f0
        for j in range(i):
            H[:, i, j] = H[:, j, i] = (at(i, 1.0, j, 1.0) - at(i, 1.0, j, -1.0) - at(i, -1.0, j, 1.0)
                                       + at(i, -1.0, j, -1.0)) / 4
    return H / np.multiply.outer(h, h)


def one_sided(values, h):
    """(D, T) from the values at x + s·h for the steps :data:`ONE_SIDED` (0, h, 2h, 4h; numbers or arrays):
    the one-sided second-order difference D(h) = (−3f(x) + 4f(x + h) − f(x + 2h)) / 2h and T = D(h) − D(2h),
    its truncation estimate (3× the truncation)."""
    a, b, c, d = values
    D = (-3 * a + 4 * b - c) / (2 * h)
    return D, D - (-3 * a + 4 * c - d) / (4 * h)


def sides(values, h):
    """(D_left, D_right) from the values at x − 2h, x − h, x, x + h, x + 2h (numbers or arrays): the one-sided
    second-order differences from each side, (3f(x) − 4f(x − h) + f(x − 2h)) / 2h and
    (−3f(x) + 4f(x + h) − f(x + 2h)) / 2h. Of a smooth function they agree to O(h³) (their h² terms are equal); a
    kink or a jump at x sets them apart by its change of slope, or by the jump / h."""
    m2, m1, c, p1, p2 = values
    return (3 * c - 4 * m1 + m2) / (2 * h), (-3 * c + 4 * p1 - p2) / (2 * h)


def bend(values, h):
    """|f(x + 2h) − 2f(x) + f(x − 2h)| / 2h from the values at x − 2h, x − h, x, x + h, x + 2h (numbers or arrays):
    the change of slope across the stencil, h·f″ of a smooth function (at a smooth extremum the one-sided slopes of
    :func:`sides` differ by O(h³) of it), a kink's change of slope or a jump / h at x."""
    m2, _, c, _, p2 = values
    return np.abs(p2 - 2 * c + m2) / (2 * h)


def round_off(h, one_sided: bool = False):
    """A difference's rounding per unit rounding of its values (ε|f| each): Σ|coefficients| / divisor, 2/2h for
    a central difference, (3 + 4 + 1)/2h for the one-sided one (h a number or an array)."""
    return (8 if one_sided else 2) / (2 * h)


def jacobian(fun: Callable, x, h: float = 1e-7) -> np.ndarray:
    """∂fun/∂x (outputs × n) by central differences with steps h × max(1, |x_k|)."""
    x = np.asarray(x, float)
    hk = h * np.maximum(1.0, np.abs(x))
    return differences(np.array([np.ravel(fun(y)) for y in displaced_vectors(x, hk)], dtype=float), hk)[0]
