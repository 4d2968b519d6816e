"""Mode tracking: the modal assurance criterion (MAC) and the assignment of one set of modes to the previous
one's, shared by every study that follows modes along a parameter (Campbell diagrams, sweeps, backbones: the
multipliers' angles) and by the spread of perturbed Floquet multipliers (:func:`assign`, the Hungarian method)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError


def mac(a: ArrayLike, b: ArrayLike | None = None) -> np.ndarray | float:
    """Modal assurance criterion MAC_ij = |a_iᴴ b_j|² / (a_iᴴ a_i · b_jᴴ b_j) between columns of a and b."""
    from .._check import finite_array

    a = finite_array(a, None, "mac: first shapes") if not np.iscomplexobj(a) else np.asarray(a)
    b = a if b is None else (finite_array(b, None, "mac: second shapes") if not np.iscomplexobj(b) else np.asarray(b))
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ModelError("mac: shapes contain NaN or inf")
    a = a.reshape(a.shape[0], -1)
    b = b.reshape(b.shape[0], -1)
    if a.shape[0] != b.shape[0]:
        raise ModelError(f"mac: shapes have {a.shape[0]} and {b.shape[0]} components")
    num = np.abs(a.conj().T @ b) ** 2
    den = np.outer(np.einsum("ij,ij->j", a.conj(), a).real, np.einsum("ij,ij->j", b.conj(), b).real)
    out = num / np.where(den > 0, den, 1.0)
    return out if out.size > 1 else float(out[0, 0])



def match(previous: ArrayLike, shapes: ArrayLike, previous_values: ArrayLike | None = None,
          values: ArrayLike | None = None) -> np.ndarray:
    """The columns of ``shapes`` in the order of the columns of ``previous``: the assignment of largest total
    MAC (Hungarian method); with ``previous_values`` and ``values`` (frequencies), their closeness breaks the
    ties between degenerate shapes (a 1e-3 weight relative to the largest value)."""
    previous, shapes = np.asarray(previous), np.asarray(shapes)
    score = np.reshape(mac(previous, shapes), (previous.shape[1], shapes.shape[1]))
    if previous_values is not None and values is not None:
        fa, fb = np.asarray(previous_values, float), np.asarray(values, float)
        scale = max(np.abs(fa).max(initial=0.0), np.abs(fb).max(initial=0.0), 1e-300)
        score = score - 1e-3 * np.abs(fa[:, None] - fb[None, :]) / scale
    return assign(-score)[1]


def assign(cost: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols): the one-to-one assignment of least total ``cost`` (row i to column cols[k] for i = rows[k],
    rows in order; every row where there are as many columns), by the Hungarian method: the one tracker every
    follower of modes, multipliers or angles uses."""
    from scipy.optimize import linear_sum_assignment

    rows, cols = linear_sum_assignment(cost)
    return rows, cols
