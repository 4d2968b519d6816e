"""Adaptive Gauss–Kronrod quadrature of vector integrands over frequency, vectorised across intervals.

The integrand is evaluated at every node of every interval still open in one call (a response PSD at a
batch of frequencies costs one batched transfer evaluation), the intervals start split at the points where
the integrand bends or peaks (breakpoints of the input, damped natural frequencies ± multiples of their
half-power widths), and an infinite upper limit is mapped to (0, 1] by f = F/u. Each interval's error is
|K15 − G7| (the error of the embedded 7-point Gauss rule: a pessimistic bound of the 15-point Kronrod
result's), summed per component.
"""

import math
from dataclasses import dataclass

import numpy as np

# the 15-point Kronrod nodes on [-1, 1] (positive half, QUADPACK qk15) and weights; the 7-point Gauss rule
# uses the odd ones
_XK = np.array([0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
                0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
                0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
                0.207784955007898467600689403773245, 0.0])
_WK = np.array([0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
                0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
                0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
                0.204432940075298892414161999234649, 0.209482141084727828012999174891714])
_WG = np.array([0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
                0.381830050505118944950369775488975, 0.417959183673469387755102040816327])
NODES = np.concatenate([-_XK[:-1], _XK[::-1]])  # 15 nodes, ascending
W_KRONROD = np.concatenate([_WK[:-1], _WK[::-1]])
W_GAUSS = np.zeros(15)
W_GAUSS[[1, 3, 5, 7, 9, 11, 13]] = np.concatenate([_WG[:-1], _WG[::-1]])


@dataclass(frozen=True)
class Quadrature:
    """∫ g(f) df per component (``value``), its error estimate (``error``, ≥ 0), the intervals used and the
    integrand evaluations (nodes); ``converged``: every component met its tolerance."""

    value: np.ndarray
    error: np.ndarray
    intervals: int
    evaluations: int
    converged: bool


def integrate(g, points, upper, *, rtol=1e-9, floor=1e-12, groups=None, max_intervals=200000):
    """∫ g over [points[0], upper] (Hz; ``upper`` may be inf) of a vector integrand g(f) (array of n_f
    frequencies ↦ n_f × n_c, real), starting from the intervals between the sorted ``points``.

    Component c is converged when its summed error ≤ rtol·max(|I_c|, floor·max|I| of its group) (``groups``:
    an integer label per component, so that a component far smaller than its peers, e.g. an output the input
    does not reach, is measured against them)."""
    pts = np.unique(np.asarray(points, dtype=float))
    tail = None
    if math.isinf(upper):
        tail = pts[-1] if pts[-1] > 0 else 1.0
        pts = pts[pts <= tail]
    else:
        pts = pts[pts <= upper]
        if pts[-1] < upper:
            pts = np.append(pts, upper)
    a, b = pts[:-1], pts[1:]
    is_tail = np.zeros(a.size, bool)
    if tail is not None:  # f = tail/u, u in (0, 1]
        a, b, is_tail = np.append(a, 0.0), np.append(b, 1.0), np.append(is_tail, True)
    keep = b > a
    a, b, is_tail = a[keep], b[keep], is_tail[keep]
    done_v = done_e = 0.0
    evaluations = 0
    converged = False
    while True:
        v, e = _rule(g, a, b, is_tail, tail)
        evaluations += 15 * a.size
        total_v = done_v + v.sum(0)
        total_e = done_e + e.sum(0)
        scale = np.abs(total_v)
        if groups is not None:
            for label in np.unique(groups):
                sel = groups == label
                scale[sel] = np.maximum(scale[sel], floor * scale[sel].max(initial=0.0))
        target = rtol * scale
        bad = total_e > target
        if not bad.any():
            converged = True
            break
        if a.size > max_intervals:
            break
        # split the intervals carrying more than an equal share of a failing component's allowance; the others
        # are final
        share = target[bad] / max(a.size, 1)
        split = np.any(e[:, bad] > share, axis=1)
        if not split.any():
            split = np.any(e[:, bad] >= e[:, bad].max(axis=0), axis=1)
        done_v = done_v + v[~split].sum(0)
        done_e = done_e + e[~split].sum(0)
        mid = 0.5 * (a[split] + b[split])
        a, b, is_tail = (np.concatenate([a[split], mid]), np.concatenate([mid, b[split]]),
                         np.concatenate([is_tail[split], is_tail[split]]))
    return Quadrature(total_v, total_e, int(a.size), evaluations, converged)


def _rule(g, a, b, is_tail, tail):
    """(K15 value, |K15 − G7|) per interval (n_int × n_c)."""
    half, mid = 0.5 * (b - a), 0.5 * (a + b)
    x = mid[:, None] + half[:, None] * NODES[None, :]  # n_int × 15
    jac = np.broadcast_to(half[:, None], x.shape).copy()
    if is_tail.any():
        u = x[is_tail]
        x[is_tail] = tail / u
        jac[is_tail] = jac[is_tail] * tail / (u * u)
    y = np.asarray(g(x.ravel()), dtype=float).reshape(a.size, 15, -1) * jac[:, :, None]
    k = np.einsum("n,inc->ic", W_KRONROD, y)
    gauss = np.einsum("n,inc->ic", W_GAUSS, y)
    return k, np.abs(k - gauss)
