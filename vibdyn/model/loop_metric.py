"""Distances between configurations of a looped system in the loops' dimensionless metric: tangent offsets divided
by the coordinate scales (1 for angles, the length scale for translations), periodic angles taken the shorter way
round (q and q ± 2π are one pose)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

SAME = 1e-6  # closures nearer each other than this (dimensionless) are one


def offsets(c, qd, q) -> np.ndarray:
    """Dimensionless tangent offsets from qd to q (c: the :class:`Constraints`)."""
    return pin.difference(c.model, qd, q) / c.col_scale


def gap(c, a, b) -> float:
    """Dimensionless tangent distance from a to b, b's periodic angles taken within π of a's."""
    return float(np.linalg.norm(offsets(c, a, c.within_pi(b.copy(), a))))


def gaps(c, q, samples) -> np.ndarray:
    """:func:`gap` from q to each of ``samples`` (an array of configurations, one a row)."""
    model, iq = c.model, c.periodic_coordinates
    if model.nq != model.nv:  # (a Lie group other than ℝⁿ: one by one)
        return np.array([gap(c, q, s) for s in samples])
    d = samples - q
    d[:, iq] -= 2 * np.pi * np.rint(d[:, iq] / (2 * np.pi))
    return np.linalg.norm(d / c.col_scale, axis=1)
