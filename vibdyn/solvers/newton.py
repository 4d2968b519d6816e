"""Newton's method on a manifold: x ← retract(x, Δ) with Δ the (least-squares, minimum-norm where the
Jacobian is singular or the system over- or under-determined) solution of J Δ = −F, a step cap, and a
backtracking line search on ‖F‖. Equilibria, steady motions, assembly and the continuation corrector are
all this iteration with their own residual, Jacobian and retraction (``pin.integrate`` for configurations).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError


@dataclass(frozen=True)
class NewtonResult:
    """``x`` the point reached, ``residual`` ‖F(x)‖_∞ there, ``iterations``, ``converged`` (residual ≤ tol),
    ``message`` (why it stopped), ``elapsed`` (s)."""

    x: np.ndarray
    residual: float
    iterations: int
    converged: bool
    message: str
    elapsed: float


def fd_jacobian(fun: Callable, x: np.ndarray, f0: np.ndarray | None = None, h: float = 1e-7) -> np.ndarray:
    """∂fun/∂x by central differences (steps h × max(1, |x_k|)), as a fallback where no Jacobian is given."""
    x = np.asarray(x, float)
    cols = []
    for k in range(x.size):
        e = np.zeros_like(x)
        e[k] = h * max(1.0, abs(x[k]))
        cols.append((np.asarray(fun(x + e), float) - np.asarray(fun(x - e), float)) / (2 * e[k]))
    return np.array(cols).T.reshape(-1, x.size)


def newton(fun: Callable, x0: np.ndarray, jacobian: Callable | None = None, retract: Callable | None = None, *,
           tol: float = 1e-10, max_iter: int = 50, max_step: float | None = None, rcond: float = 1e-12,
           raise_on_failure: bool = False) -> NewtonResult:
    """Solve F(x) = 0 from x0 (F: ℝⁿ or a manifold → ℝᵐ, tangent steps of n components).

    ``jacobian(x)``: m × n (central differences if None); ``retract(x, dx)``: the point reached from x by
    the tangent step dx (x + dx if None); ``max_step``: the largest |dx| component of one step (a trust
    region); the line search halves a step until ‖F‖ decreases (Armijo, down to 1e-4 of it). Stops when
    ‖F‖_∞ ≤ tol, or when a step no longer decreases it (``converged`` False, ``message`` says why; with
    ``raise_on_failure`` a ConvergenceError carrying the residual and the best point)."""
    start = time.perf_counter()
    retract = retract or (lambda x, dx: x + dx)
    x = np.array(x0, dtype=float)
    f = np.asarray(fun(x), float)
    res = float(np.abs(f).max(initial=0.0))
    it, message = 0, "converged"
    while res > tol:
        if it >= max_iter:
            message = f"no convergence in {max_iter} iterations (residual {res:.3e}, tolerance {tol:.1e})"
            break
        it += 1
        J = jacobian(x) if jacobian is not None else fd_jacobian(fun, x, f)
        dx = np.linalg.lstsq(J, -f, rcond=rcond)[0]
        if max_step is not None:
            over = np.abs(dx).max(initial=0.0) / max_step
            if over > 1:
                dx /= over
        norm0, alpha = float(np.linalg.norm(f)), 1.0
        while True:
            x_new = retract(x, alpha * dx)
            f_new = np.asarray(fun(x_new), float)
            if np.all(np.isfinite(f_new)) and np.linalg.norm(f_new) <= (1 - 1e-4 * alpha) * norm0:
                break
            alpha *= 0.5
            if alpha < 1e-4:
                break
        if alpha < 1e-4:
            message = f"no step decreases the residual further (residual {res:.3e}, tolerance {tol:.1e})"
            break
        x, f = x_new, f_new
        res = float(np.abs(f).max(initial=0.0))
    out = NewtonResult(x, res, it, res <= tol, message, time.perf_counter() - start)
    if raise_on_failure and not out.converged:
        raise ConvergenceError(f"Newton: {message}", residual=res, best=x)
    return out
