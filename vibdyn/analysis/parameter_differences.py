"""The linear model's derivatives along a parameter of a scene, by differences of the whole pipeline (the scene
rebuilt at p ± h and p ± 2h, its operating point found again, linearised), with their error estimates; what
:mod:`vibdyn.analysis.sensitivity` projects on the modes. A parameter the model is not differentiable in at p
(a kink, a jump: the left and right slopes disagree far beyond their errors) is refused, naming it; at the edge
of a builder's domain (it refuses p − h) the difference is one-sided."""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..defaults import EPS
from ..errors import ModelError
from ..model.fd import bend, differences, one_sided, round_off, sides
from .linearize import linearize

#: relative step of the pipeline's differences (h = STEP·|p|, or STEP × the parameter's scale at p = 0)
STEP = 1e-4

#: how each regime's point is found again in a rebuilt system (q0, v0: the base point's; speeds: the held ones)
FOUND_AGAIN: dict[str, Callable] = {
    "declared": lambda system, q0, v0, speeds: system.operating_point(),
    "steady": lambda system, q0, v0, speeds: system.steady_motion(speeds, q0=q0),
    "static": lambda system, q0, v0, speeds: system.equilibrium(q0=q0),
    "held": lambda system, q0, v0, speeds: system.held(q0, v0),
    "pose": lambda system, q0, v0, speeds: q0,
}


class NotSmooth(ModelError):
    """The model has a kink or a jump along a parameter at its value."""


class CoordinatesChanged(ModelError):
    """The scene at a displaced parameter value has other coordinates than at the base value."""


def _at(names, values):
    return ", ".join(f"{n} = {float(x):.10g}" for n, x in zip(names, values))


class Pipeline:
    """p -> (M, C, K with their errors) of the scene at p: rebuilt, its operating point found again as the
    base one was (static equilibrium from the base pose, the same held speeds, or the base pose held),
    linearised analytically (finite differences where the analytic path refuses). ``names``: the parameters'
    (for messages); ``coordinates``: the base scene's, which every rebuilt one must have."""

    def __init__(self, make_scene: Callable, q0, v0, regime, hold=(), independent=None, names=(), coordinates=None):
        self.make_scene, self.q0, self.v0, self.regime, self.hold = make_scene, q0, v0, regime, tuple(hold)
        # a reduced model's independent coordinates, kept at every p (a choice flipping between p ± h, at a
        # symmetric pose, would difference models in different coordinates)
        self.independent = None if independent is None else np.asarray(independent, dtype=int)
        self.names = tuple(names)
        self.coordinates = None if coordinates is None else tuple(coordinates)
        self.base_values, self.base = None, None  # (the base values, and the model there once made)
        self.a0: np.ndarray | None = None  # (about a pose: the acceleration given with the base model, kept)

    def __call__(self, values):
        scene, speeds = self.make_scene(values)
        system = scene.build()
        if self.coordinates is not None and tuple(system.coordinates) != self.coordinates:
            base = "" if self.base_values is None else f" at {_at(self.names, self.base_values)}"
            raise CoordinatesChanged(
                f"sensitivity: the scene at {_at(self.names, values)} has the coordinates "
                f"{list(system.coordinates)}, and{base} {list(self.coordinates)}: it gains or loses a body or joint "
                "as the parameter moves, and a derivative needs the same coordinates on both sides of p")
        op = FOUND_AGAIN[self.regime](system, self.q0, self.v0, speeds)
        at = {"v": self.v0} if self.regime == "pose" else {}  # (an operating point carries its own velocity)
        if self.a0 is not None:
            at["a"] = self.a0
        # reduced as the base model is: the same coordinates held at their (new) speeds, the same independent ones
        at.update(hold=self.hold, independent=self.independent)
        try:
            lin = linearize(system, op, method="analytic", **at)
        except ModelError:
            lin = linearize(system, op, method="fd", **at)
        return getattr(lin, "reduced", lin)  # a mechanism's: in its independent motions


def step(value, unit, length_scale):
    """The difference step of a parameter of ``value`` in ``unit``: STEP of it, or of its unit's scale at 0."""
    if value != 0:
        return STEP * abs(value)
    return STEP * (length_scale if unit == "m" else 1.0)


#: the share of one rounding per evaluation (ε|X| over the step) kept beside |D(h) − D(2h)|, which shows the
#: evaluations' rounding itself (their combination f(2h) − 2f(h) + 2f(−h) − f(−2h)); the share covers a draw where
#: it cancels (1/16 left a tiny stiffness's derivative 2× beyond its error)
UNSEEN_ROUNDING = 1 / 4


def differences_along(pipeline, base_values, j, h, at_bound, base=None, finer=True):
    """(derivatives, their errors, a note) of (M, C, K) along parameter j: central differences (or one-sided,
    second order, at a bound, or where the scene at p − h or p − 2h is refused: the note says so), each error
    |D(h) − D(2h)| plus the models' own errors carried over the step. ``base``: the pipeline's model at p (the
    central differences' left and right slopes there are compared: a kink or jump is refused).

    |D(h) − D(2h)| is three times the h step's truncation, and about the size of the evaluations' random part
    (the rounding of a model's finite differences, of its operating point found again, whatever its source: the
    four evaluations show it, where a bound of it over the step was 1e2–1e4 times what the differences carry).
    The models' error estimates (finite-difference truncation, the bounds of their rounding) are systematic:
    smooth in p, they cancel in a difference but for their own variation, their relative size times the
    derivative. An entry that moves with p carries at least one rounding of its value each side (ε |X| over the
    step); one equal at every point moves with nothing (its difference is exact)."""
    def at(x):
        vals = np.array(base_values, float)
        vals[j] = x
        lin = pipeline(vals)
        return (lin.M, lin.C, lin.K), (None, lin.C_error, lin.K_error)

    p, note = base_values[j], ""
    name = pipeline.names[j] if j < len(pipeline.names) else f"parameter {j + 1}"
    X = []
    side = 1.0  # (−1: one-sided from the left, where the builder refuses p + h)
    if not at_bound:
        try:
            X = [at(x) for x in (p - 2 * h, p - h)]
            X += [at(x) for x in (p + h, p + 2 * h)]
        except CoordinatesChanged:
            raise
        except ModelError as e:  # the edge of the builder's domain: differences from the other side only
            side = -1.0 if len(X) == 2 else 1.0
            at_bound = True
            note = f"'{name}': one-sided differences at {p:g} (from the {'left' if side < 0 else 'right'}), as {e}"
    if at_bound:
        X = [at(p + s * side * h) for s in (0, 1, 2, 4)]
        DT = [one_sided(values, side * h) for values in zip(*(x[0] for x in X))]  # (M, C, K)
        Dh, T = [d for d, _ in DT], [t for _, t in DT]
    else:
        Dh, T = richardson([X[2][0], X[3][0], X[1][0], X[0][0]], h)
    weight = round_off(h, at_bound)
    err, rels = [], []
    for k, (d, t) in enumerate(zip(Dh, T)):
        values = np.array([x[0][k] for x in X])
        size = np.abs(values).max(axis=0)
        moved = np.any(values != values[0], axis=0)
        e = np.abs(t) + np.where(moved, UNSEEN_ROUNDING * EPS * size * weight, 0.0)
        errors = [x[1][k] for x in X if x[1][k] is not None]
        rel = 0.0
        if errors:  # a model's own estimate, relative to its matrix, times the derivative
            rel = max(float(np.abs(x).max(initial=0.0)) for x in errors) / max(float(size.max(initial=0.0)), 1e-300)
            e += rel * np.abs(d)
            # an entry within its own error of zero at every point (a cyclic coordinate's: zero but for a rounding
            # that need not be random in p, so the differences do not show it) is zero within that error over the step
            within = np.all([np.abs(x[0][k]) <= x[1][k] for x in X if x[1][k] is not None], axis=0)
            e += np.where(within & moved, np.max(errors, axis=0) * weight, 0.0)
        err.append(e)
        rels.append(rel)
    if base is not None and not at_bound:
        try:
            _smooth(name, p, h, [x[0] for x in X], (base.M, base.C, base.K), rels)
        except NotSmooth:
            if not finer:
                raise
            # (a feature finer than the step, a pendulum of 1e-7 m at a step of 1e-7 m, looks like a kink at it: a kink
            # or a jump is one at a step a hundred times finer too)
            return differences_along(pipeline, base_values, j, h / 100, at_bound, base, finer=False)
    return Dh, err, note


def _smooth(name, p, h, X, base, rels):
    """Refuses a parameter the model has a kink or a jump in at p: the one-sided second-order slopes from the
    left and from the right (equal to O(h³) for a smooth model) differ by over 1 % (of the slopes, and of their change
    across the stencil) and over ten times what the evaluations' rounding and the models' own errors can move them
    by (a kink smaller than that is not seen)."""
    for k, label in enumerate("MCK"):
        f = [X[0][k], X[1][k], base[k], X[2][k], X[3][k]]
        left, right = sides(f, h)
        gap = np.abs(right - left)
        size = np.abs(np.array(f)).max(axis=0)
        # each value's rounding through the pipeline (its build, point found again, linearisation: ~1e2 ε of
        # the entry, 10 ε of the matrix's largest), and the models' own errors; Σ|coefficients| 16/2h
        top = size.max(initial=0.0)
        noise = (100 * EPS * size + (10 * EPS + rels[k]) * top) * 2 * round_off(h, True)
        # (beside the slopes, their change across the stencil: at a smooth extremum both one-sided slopes are O(h³)
        # and differ by that much, a kink's or a jump's by as much as it changes)
        bad = (gap > 10 * noise) & (gap > 0.01 * np.maximum(np.maximum(np.abs(left), np.abs(right)), bend(f, h)))
        if bad.any():
            i, c = np.unravel_index(int(np.argmax(np.where(bad, gap / np.maximum(noise, 1e-300), 0.0))), gap.shape)
            raise NotSmooth(
                f"sensitivity: '{name}': not differentiable at {name} = {p:.10g}: the left and right slopes differ "
                f"(∂{label}[{i}, {c}]/∂p is {left[i, c]:.6g} from the left, {right[i, c]:.6g} from the right, steps "
                f"of {h:.3g}); the model has a kink or a jump there: differentiate on either side of it")


def richardson(values, h):
    """Central differences of (M, C, K) along a parameter or direction from their values at +h, +2h, −h and −2h
    (:func:`vibdyn.model.fd.differences`): the derivatives and their truncation estimates D(h) − D(2h)."""
    n = values[0][0].shape
    D, T = differences(np.array([np.concatenate([m.ravel() for m in mats]) for mats in values]), np.array([h]))
    size = n[0] * n[1]
    return ([A[i * size:(i + 1) * size, 0].reshape(n) for i in range(3)] for A in (D, T))
