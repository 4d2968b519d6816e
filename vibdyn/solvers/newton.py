"""Newton's method on a manifold: x ← retract(x, Δ) with Δ the (least-squares, minimum-norm where the
Jacobian is singular or the system over- or under-determined) solution of J Δ = −F, a step cap, and a
backtracking line search on ‖F‖. Equilibria, steady motions, assembly and the continuation corrector are
all this iteration with their own residual, Jacobian and retraction (``pin.integrate`` for configurations).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError
from .differences import jacobian


@dataclass(frozen=True)
class NewtonResult:
    """``x`` the best point reached (least ‖F‖_∞), ``residual`` ‖F(x)‖_∞ there, ``iterations``, ``converged``
    (residual ≤ tol), ``jacobians`` (how many were evaluated), ``status`` ("converged"; "stagnated": steps at
    round-off with the residual within the
    caller's ``stall`` factor of tol; "max_iter"; "no_decrease": no step reduces ‖F‖; "diverged": F became
    non-finite, or was at x0: no step is taken from there), ``message`` (why it stopped), ``elapsed`` (s)."""

    x: np.ndarray
    residual: float
    iterations: int
    converged: bool
    message: str
    elapsed: float
    status: str = "converged"
    jacobians: int = 0  # Jacobians evaluated (fewer than iterations with ``chord``)

    def check(self) -> NewtonResult:
        """This result if it converged; else a ConvergenceError with its message, residual and best point."""
        if not self.converged:
            raise ConvergenceError(f"Newton: {self.message}", residual=self.residual, best=self.x)
        return self


def fd_jacobian(fun: Callable, x: np.ndarray, f0: np.ndarray | None = None, h: float = 1e-7) -> np.ndarray:
    """∂fun/∂x by central differences (steps h × max(1, |x_k|): :func:`vibdyn.solvers.differences.jacobian`), as a
    fallback where no Jacobian is given (``f0`` unused)."""
    return jacobian(fun, x, h)


@dataclass(frozen=True)
class Steps:
    """How a Newton step is taken (a trust region and a line search). ``max_step``: the largest |dx| component
    of one step, a number or one per component; ``expand``: that cap is a trust region that doubles after a
    capped step is taken whole (a far solution is reached in log₂ of the distance steps) and falls back towards
    ``max_step`` after a step the line search had to cut; ``shape(x, f, J, dx)`` → dx: the caller's own say on
    each least-squares step before the cap (a fallback where the linear model fails, joint limits; it may
    raise); the line search halves a step until ‖F‖ decreases (Armijo), down to ``min_alpha``; there
    ``on_no_decrease`` "stop" ends the search, "accept" takes the shortest step tried and goes on (the best
    point is kept either way); ``stall``: a factor s, steps that no longer move x (round-off) end the search
    as "stagnated" once ‖F‖_∞ ≤ s·tol; ``polish``: after convergence, one more step with the last Jacobian,
    kept if it lowers the residual; ``refine``: a residual to go on to after convergence (round-off, below tol),
    by at most :data:`REFINE_ITER` fresh Newton steps (capped by ``max_step``), kept where they lower it."""

    max_step: float | np.ndarray | None = None
    expand: bool = False
    shape: Callable | None = None
    min_alpha: float = 1e-4
    on_no_decrease: str = "stop"
    stall: float | None = None
    polish: bool = False
    refine: float | None = None


REFINE_ITER = 3  # the fresh Newton steps ``Steps.refine`` may take past convergence
PLAIN = Steps()  # full least-squares steps, no cap, the line search down to 1e-4, stopped where nothing decreases


def newton(fun: Callable, x0: np.ndarray, jacobian: Callable | None = None, retract: Callable | None = None, *,
           tol: float = 1e-10, max_iter: int = 50, rcond: float = 1e-12, steps: Steps = PLAIN,
           start: tuple[np.ndarray | None, np.ndarray | None] = (None, None),
           chord: float | None = None) -> NewtonResult:
    """Solve F(x) = 0 from x0 (F: ℝⁿ or a manifold → ℝᵐ, tangent steps of n components).

    ``jacobian(x)``: m × n (central differences if None); ``retract(x, dx)``: the point reached from x by
    the tangent step dx (x + dx if None); ``rcond``: the least-squares cut-off of small singular values;
    ``steps``: the trust region and line search (:class:`Steps`). Stops when ‖F‖_∞ ≤ tol (``converged``);
    otherwise ``message`` says why (:meth:`NewtonResult.check` raises it). ``start``: (F, J) at x0 where the
    caller has them already (either may be None). ``chord``: a factor κ < 1; a Jacobian is kept for the next
    step while each full step cuts ‖F‖ at least κ times (a chord iteration: residuals only), evaluated afresh
    where one does not (or the line search fails on it); there the start's J may be a neighbouring point's."""
    began = time.perf_counter()
    f0, jacobian0 = start
    max_step, expand, shape_step, min_alpha = steps.max_step, steps.expand, steps.shape, steps.min_alpha
    on_no_decrease, stall = steps.on_no_decrease, steps.stall
    retract = retract or (lambda x, dx: x + dx)
    x = np.array(x0, dtype=float)
    f = np.asarray(fun(x) if f0 is None else f0, float)
    res = float(np.abs(f).max(initial=0.0))
    it, status, message = 0, "converged", "converged"
    if not np.all(np.isfinite(f)):  # x0 outside F's domain (e.g. a period ≤ 0): no Jacobian there, no step
        res, status, message = math.inf, "diverged", "the residual is not finite at the start (diverged)"
    best = (res, x)
    J, J_last, radius, evaluated = jacobian0, None, 1.0, 0
    fresh = jacobian0 is not None and chord is None  # (with chord, jacobian0 may be a neighbour's)
    while res > tol and status != "diverged":
        if it >= max_iter:
            status, message = "max_iter", f"no convergence in {max_iter} iterations (residual {best[0]:.3e}, " \
                f"tolerance {tol:.1e})"
            break
        it += 1
        if J is None:
            J = jacobian(x) if jacobian is not None else fd_jacobian(fun, x, f)
            fresh, evaluated = True, evaluated + 1
        dx = np.linalg.lstsq(J, -f, rcond=rcond)[0]
        if shape_step is not None:
            dx = np.asarray(shape_step(x, f, J, dx), float)
        capped = False
        if max_step is not None:
            over = (np.abs(dx) / (radius * max_step)).max(initial=0.0)
            if over > 1:
                dx, capped = dx / over, True
        norm0, alpha = math.sqrt(f @ f), 1.0
        while True:
            x_new = retract(x, alpha * dx)
            f_new = np.asarray(fun(x_new), float)
            norm_new = math.sqrt(f_new @ f_new)  # (nan or inf if f_new is not finite)
            decreased = norm_new <= (1 - 1e-4 * alpha) * norm0
            if decreased or alpha * 0.5 < min_alpha:
                break
            alpha *= 0.5
        finite = decreased or bool(np.all(np.isfinite(f_new)))
        if not decreased and chord is not None and not fresh:  # a kept Jacobian gone stale: a fresh one
            J = None
            continue
        if not decreased and (on_no_decrease == "stop" or not finite):
            status = "no_decrease" if finite or on_no_decrease == "stop" else "diverged"
            message = (f"no step decreases the residual further (residual {best[0]:.3e}, tolerance {tol:.1e})"
                       if status == "no_decrease" else "the residual became non-finite (diverged)")
            break
        if expand:
            radius = min(2.0 * radius, 1024.0) if capped and alpha == 1.0 else max(1.0, radius * alpha)
        res_old = res
        x, f, J_last = x_new, f_new, J
        res = float(np.abs(f).max(initial=0.0))
        kept = chord is not None and alpha == 1.0 and res <= chord * res_old
        J, fresh = (J, False) if kept else (None, False)
        if res < best[0]:
            best = (res, x)
        if res <= tol:
            break
        if stall is not None and res <= stall * tol and \
                np.abs(alpha * dx).max(initial=0.0) <= 1e-15 * max(1.0, float(np.max(max_step, initial=1.0))
                                                                    if max_step is not None else 1.0):
            status, message = "stagnated", f"stagnated at round-off (residual {res:.3e}, tolerance {tol:.1e})"
            break
    x_last = x
    res, x = best
    if steps.polish and 0 < res <= tol and J_last is not None:
        f_best = f if x is x_last else np.asarray(fun(x), float)
        x_p = retract(x, np.linalg.lstsq(J_last, -f_best, rcond=rcond)[0])
        f_p = np.asarray(fun(x_p), float)
        res_p = float(np.abs(f_p).max(initial=0.0))
        if res_p < res:
            res, x = res_p, x_p
    if steps.refine is not None and 0 < steps.refine < res <= tol:
        more = newton(fun, x, jacobian, retract, tol=steps.refine, max_iter=REFINE_ITER, rcond=rcond,
                      steps=Steps(max_step=max_step, on_no_decrease="stop"))
        if more.residual < res:
            res, x, it, evaluated = more.residual, more.x, it + more.iterations, evaluated + more.jacobians
    out = NewtonResult(x, res, it, res <= tol, "converged" if res <= tol else message, time.perf_counter() - began,
                       "converged" if res <= tol else status, evaluated)
    return out
