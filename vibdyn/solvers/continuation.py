"""Pseudo-arclength continuation of a branch of solutions of F(x, λ) = 0 (x ∈ ℝⁿ, λ a parameter), through its
folds: predictor along the tangent, Newton corrector on the bordered system [F; tᵀ(y − y_pred)] = 0
(:mod:`.newton`), step control by the corrector's iterations, and each fold (λ extremal along the branch:
the tangent's λ component changes sign) located by Newton on its defining system F = 0, F_x v = 0, v·v₀ = 1.
What follows branches — Campbell's critical speeds, backbones, forced-response curves — uses this one.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import ModelError
from .differences import derivative
from .newton import fd_jacobian, newton


@dataclass(frozen=True)
class Fold:
    """A fold (turning point) of a branch: ``x``, ``lam`` there, ``index`` the branch point after which it
    lies, ``residual`` of its defining system."""

    x: np.ndarray
    lam: float
    index: int
    residual: float


@dataclass(frozen=True)
class Branch:
    """A continued branch: points ``x`` (k × n) and ``lam`` (k), the arclength ``s`` at each (in the scaled
    variables), ``folds``, ``status`` ("finished": λ reached ``lam_end``; "stopped": a ``stop`` condition
    or the step limit; "failed": the corrector could not go on), ``reason`` (why it ended: "finished", "stop",
    "max_steps", "start": no solution at λ0, "floor": the corrector stalls at F's own error, "step": the step
    fell below ``min_step``), ``message``, ``steps``, ``rejected``, ``elapsed`` (s), and ``residual`` the
    largest ‖F‖_∞ over its points."""

    x: np.ndarray
    lam: np.ndarray
    s: np.ndarray
    folds: list = field(default_factory=list)
    status: str = "finished"
    message: str = ""
    steps: int = 0
    rejected: int = 0
    elapsed: float = 0.0
    residual: float = 0.0
    reason: str = "finished"
    step: float = 0.0  # the arclength step (scaled) the branch would have taken next: where a following one starts

    def then(self, more: "Branch") -> "Branch":
        """This branch and ``more``, a continuation that goes on from its last point, as one (``more``'s status)."""
        joined = replace(more, steps=self.steps + more.steps, rejected=self.rejected + more.rejected,
                         elapsed=self.elapsed + more.elapsed)
        if not self.lam.size:
            return joined
        k = 1 if more.lam.size else 0  # (more's first point is this one's last)
        shift = self.lam.size - k  # (more's folds' indices, counted in the joined points)
        return replace(joined, x=np.vstack([self.x, more.x[k:]]), lam=np.concatenate([self.lam, more.lam[k:]]),
                       s=np.concatenate([self.s, self.s[-1] + more.s[k:] - (more.s[0] if more.s.size else 0.0)]),
                       folds=list(self.folds) + [replace(f, index=f.index + shift) for f in more.folds],
                       residual=max(self.residual, more.residual))


CLOSE = 0.01  # (``curvature``) a correction within this × the step from the predictor doubles the next step
HARD = 5  # and one of this many iterations or more halves it (else ×1.5 after an easy correction)
FLOOR_FACTOR = 10.0  # a corrector failing with ‖F‖ within this factor of tol has met F's own error floor


@dataclass(frozen=True)
class Arclength:
    """How a branch is stepped (the one place these settings live). ``step``: the first arclength step, in the
    variables scaled by ``scale`` (n + 1 positive numbers, default 1: what "one unit" of each means), grown ×1.5
    after an easy correction, halved after a failed one, at most ``max_step`` (default 20 × ``step``), at least
    ``min_step`` (below it the branch ends "failed"); ``tol``: the corrector's tolerance on ‖F‖_∞;
    ``max_steps``: the branch ends "stopped" after that many; ``chord``: the corrector starts from the last
    point's Jacobian and keeps it while each step cuts the residual ``chord`` times (:func:`.newton`): one
    Jacobian per point where the branch is smooth (for Jacobians dearer than residuals); ``curvature``: the
    predictor follows the branch's curvature too (from the change of the tangent over the last step:
    y + h t + h²κ/2; along the tangent alone after a failed correction), the step doubles after a correction of
    at most 2 iterations that moved less than ``CLOSE`` × h from the predictor and halves after one of ``HARD``
    iterations or more: fewer, longer steps where the branch is smooth."""

    step: float = 0.05
    tol: float = 1e-10
    max_steps: int = 2000
    min_step: float = 1e-9
    max_step: float | None = None
    scale: np.ndarray | None = None
    chord: float | None = None
    curvature: bool = False
    strict: bool = False  # a correction moving λ back against both tangents (two folds skipped) fails


def continuation(fun: Callable, x0: np.ndarray, lam0: float, lam_end: float, *, jacobian: Callable | None = None,
                 stop: Callable | None = None, path: Arclength = Arclength(), parameter: str = "λ") -> Branch:
    """Follow the branch of F(x, λ) = 0 from (x0, lam0) (x0 corrected first at λ = lam0) towards λ = lam_end.

    ``fun(x, lam)`` → ℝᵐ, m ≥ n (m > n: a consistent system with redundant rows, solved in least squares, as
    shooting with energy conservation); ``jacobian(x, lam)`` → m × (n + 1) = [F_x, F_λ] (central differences
    if None); ``path``: how it is stepped (:class:`Arclength`). A branch whose corrector stops three times in
    four just above the tolerance (within ``FLOOR_FACTOR``, no step decreasing ‖F‖) has met F's own error and
    ends "failed" at once, since smaller steps cannot lower that floor; ``stop(x, lam)`` → True ends the branch
    there (a request reached). The point where λ crosses lam_end is solved exactly (its last point has
    λ = lam_end); where lam_end lies within the next step on a branch steep in λ (|t_λ| > 0.5), it is solved
    there directly from the predictor, kept only if λ did not turn back on the way (no fold stepped over). A
    predictor where F is not finite (outside its domain) is a failed correction: the step is halved.
    ``parameter``: λ's name in the messages, with its unit (e.g. "Ω (rad/s)")."""
    start = time.perf_counter()
    step, tol, max_steps, min_step = path.step, path.tol, path.max_steps, path.min_step
    scale, chord, bends = path.scale, path.chord, path.curvature
    x0 = np.asarray(x0, dtype=float)
    n = x0.size
    w = np.ones(n + 1) if scale is None else np.asarray(scale, dtype=float)
    if w.shape != (n + 1,) or not np.all(w > 0):
        raise ModelError(f"continuation: scale must be {n + 1} positive numbers (x then λ)")
    lam0, lam_end = float(lam0), float(lam_end)
    if lam_end == lam0:
        raise ModelError("continuation: lam_end must differ from lam0")
    max_step = path.max_step or 20 * step

    def F(y):  # in scaled variables
        return np.asarray(fun(y[:n] * w[:n], y[n] * w[n]), float)

    def J(y):
        if jacobian is not None:
            return np.asarray(jacobian(y[:n] * w[:n], y[n] * w[n]), float).reshape(-1, n + 1) * w[None, :]
        return fd_jacobian(F, y)

    first = newton(lambda x: F(np.append(x, lam0 / w[n])), x0 / w[:n],
                   lambda x: J(np.append(x, lam0 / w[n]))[:, :n], tol=tol)
    if not first.converged:
        return Branch(np.zeros((0, n)), np.zeros(0), np.zeros(0), [], "failed",
                      f"no solution at {parameter} = {lam0:g} near the start", 0, 0, time.perf_counter() - start,
                      first.residual, "start")
    y = np.append(first.x, lam0 / w[n])
    Jy = J(y)
    t = _tangent(Jy, None, np.sign(lam_end - lam0))
    ys, ss, folds = [y.copy()], [0.0], []
    h, steps, rejected, status, message = step, 0, 0, "finished", f"reached {parameter} = {lam_end:g}"
    reason = "finished"
    residual = first.residual
    recent: list[bool] = []  # the last corrections: True for a failure at the residual's floor
    bend = np.zeros(n + 1)  # the branch's curvature d²y/ds² from the last step (``curvature``)
    while True:
        if steps >= max_steps:
            status, message, reason = "stopped", f"{max_steps} steps taken before {parameter} = {lam_end:g}", \
                "max_steps"
            break
        reach = (lam_end / w[n] - y[n]) / t[n] if t[n] != 0 else np.inf
        if 0 < reach <= h and abs(t[n]) > 0.5:
            # lam_end within this step, the branch steep in λ (no fold near): solve there from the predictor
            guess = y[:n] + reach * t[:n] + (0.5 * reach * reach) * bend[:n]
            end = newton(lambda x: F(np.append(x, lam_end / w[n])), guess,
                         lambda x: J(np.append(x, lam_end / w[n]))[:, :n], tol=tol, max_iter=8)
            if end.converged:
                y_end = np.append(end.x, lam_end / w[n])
                t_end = _tangent(J(y_end), t, None)
                if t[n] * t_end[n] > 0:  # λ did not turn back on the way: no fold stepped over
                    ys.append(y_end.copy())
                    ss.append(ss[-1] + float(np.linalg.norm(y_end - y)))
                    residual = max(residual, end.residual)
                    steps += 1
                    y, t = y_end, t_end
                    break
        yp = y + h * t + (0.5 * h * h) * bend
        corr = newton(lambda z: np.append(F(z), t @ (z - yp)), yp, lambda z: np.vstack([J(z), t]), tol=tol,
                      max_iter=8 if chord is None else 12, chord=chord,
                      start=(None, None if chord is None else np.vstack([Jy, t])))
        # a corrector that stops just above tol because no step decreases ‖F‖ has met the floor of F's own
        # error (shooting near a separatrix: the flows' error times the orbit's sensitivity); smaller steps do
        # not lower that floor, so a branch that meets it three times in four corrections ends there
        recent = recent[-3:] + [not corr.converged and corr.status in ("no_decrease", "stagnated")
                                and corr.residual <= FLOOR_FACTOR * tol]
        if sum(recent) >= 3:
            status, message, reason = "failed", (
                f"the corrector's residual stalls just above the tolerance at {parameter} = {y[n] * w[n]:.10g}, "
                "and no step decreases it (F is not evaluated more accurately than that here)"), "floor"
            break
        if not corr.converged:
            h *= 0.5
            rejected += 1
            bend[:] = 0.0  # (retried along the tangent alone: the curvature is an estimate from the last step)
            if h < min_step:
                status, reason = "failed", "step"
                message = (f"the corrector could not go on at {parameter} = {y[n] * w[n]:.10g}: a branch point, or "
                           "a singular Jacobian")
                break
            continue
        y_new = corr.x
        Jy_new = J(y_new)
        t_new = _tangent(Jy_new, t, None)
        if path.strict and t[n] * t_new[n] > 0 and (y_new[n] - y[n]) * t[n] < 0 and \
                abs(y_new[n] - y[n]) > abs(t[n]) * h:
            # (λ went back further than the predictor took it forward while both tangents point ahead: the
            # corrector crossed to another part of the branch, as across a narrow resonance loop)
            h *= 0.5
            rejected += 1
            bend[:] = 0.0
            if h < min_step:
                status, reason = "failed", "step"
                message = f"the corrector could not go on at {parameter} = {y[n] * w[n]:.10g}: the branch doubles back"
                break
            continue
        steps += 1
        lam_old, lam_new = y[n] * w[n], y_new[n] * w[n]
        if t[n] * t_new[n] < 0:  # λ turned back: a fold between the two points
            folds.append(_fold(F, J, y, y_new, t, w, n, len(ys) - 1, tol))
        crossed = (lam_new - lam_end) * (lam_old - lam_end) <= 0 and lam_new != lam_old
        if crossed:  # solve the end point exactly: λ = lam_end, x on the branch between
            end = newton(lambda x: F(np.append(x, lam_end / w[n])), y_new[:n],
                         lambda x: J(np.append(x, lam_end / w[n]))[:, :n], tol=tol)
            y_new = np.append(end.x, lam_end / w[n])
        ys.append(y_new.copy())
        ss.append(ss[-1] + float(np.linalg.norm(y_new - y)))
        residual = max(residual, corr.residual)
        if bends:
            bend = (t_new - t) / max(ss[-1] - ss[-2], 1e-300)
        y, t, Jy = y_new, t_new, Jy_new
        if crossed:
            break
        if stop is not None and stop(y[:n] * w[:n], y[n] * w[n]):
            status, message, reason = "stopped", f"stopped on request at {parameter} = {y[n] * w[n]:.10g}", "stop"
            break
        if bends and chord is None and corr.iterations <= 2 and float(np.linalg.norm(y_new - yp)) <= CLOSE * h:
            # (a predictor that lands this close: its error falls as h³, not h²)
            h = min(2.0 * h, max_step)
        elif corr.iterations <= 3 if chord is None else corr.jacobians <= 1 and corr.iterations <= 6:
            h = min(1.5 * h, max_step)
        elif bends and chord is None and corr.iterations >= HARD:  # (its long steps: shortened where it turns)
            h *= 0.5
    Y = np.array(ys)
    return Branch(Y[:, :n] * w[:n], Y[:, n] * w[n], np.array(ss), folds, status, message, steps, rejected,
                  time.perf_counter() - start, residual, reason, h)


def _tangent(Jy, previous, lam_sign):
    """The unit null vector of the n × (n + 1) Jacobian, oriented along the previous tangent (or with the
    sign of λ's direction at the start)."""
    t = np.linalg.svd(Jy)[2][-1]
    if previous is not None:
        return t if t @ previous >= 0 else -t
    return t if t[-1] * lam_sign >= 0 else -t


def _fold(F, J, ya, yb, t, w, n, index, tol):
    """The fold between branch points ya and yb: Newton on F(x, λ) = 0, F_x v = 0, v·v₀ = 1 (v₀ the tangent's x
    part, a good approximation of the null vector near the fold), from their midpoint."""
    v0 = t[:n] / max(np.linalg.norm(t[:n]), 1e-300)
    z0 = np.concatenate([0.5 * (ya + yb), v0])

    def G(z):
        y, v = z[:n + 1], z[n + 1:]
        return np.concatenate([F(y), J(y)[:, :n] @ v, [v @ v0 - 1.0]])

    def DG(z):  # ∂(F_x v)/∂y = the derivative of J along (v, 0) (second derivatives commute): 3 Jacobians
        y, v = z[:n + 1], z[n + 1:]
        Jy, e = J(y), np.append(v, 0.0)
        h = 1e-5 * max(1.0, float(np.linalg.norm(y))) / max(float(np.linalg.norm(v)), 1e-300)
        Jv = derivative(lambda s: J(y + s * e), 0.0, h)
        m = Jy.shape[0]  # (m ≥ n rows: a redundant consistent system)
        return np.block([[Jy, np.zeros((m, n))], [Jv, Jy[:, :n]], [np.zeros((1, n + 1)), v0[None, :]]])

    res = newton(G, z0, DG, tol=tol, max_iter=30)
    y = res.x[:n + 1]
    return Fold(y[:n] * w[:n], float(y[n] * w[n]), index, res.residual)
