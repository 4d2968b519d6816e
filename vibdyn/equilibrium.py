"""Equilibria: static (Q − g = 0 at v = 0) and steady motions (some coordinates turning at constant speed,
the others at rest relative to them), found by Newton in the tangent space, and their stability.
"""

import time
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ._check import integer, scalar
from .errors import ConvergenceError, ModelError
from .linearize import jacobian_q, jacobian_v, linearize, steps
from .modal import classify


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """An equilibrium (``kind`` "static") or steady motion (``kind`` "steady") of a system.

    ``residual``: largest remaining generalized force (N or N·m); ``speeds``: the cyclic coordinates'
    speeds (rad/s or m/s); ``drive``: generalized force needed to hold each given speed (N or N·m);
    ``stability``: "stable", "unstable" or "neutral" (rigid-body/cyclic directions, undamped).
    """

    system: object = field(repr=False)
    q: np.ndarray
    v: np.ndarray
    t: float
    kind: str
    residual: float
    tolerance: float
    iterations: int
    stability: str
    speeds: dict
    drive: dict
    elapsed: float  # s
    modes: object = field(repr=False, default=None)

    def linearize(self, **kwargs):
        """The linear model about this point (see :meth:`vibdyn.System.linearize`)."""
        return linearize(self.system, self, **kwargs)

    def coordinate(self, name):
        """Value of a tangent coordinate, as the offset from the neutral configuration (m or rad)."""
        return float(self.system.difference(self.system.neutral(), self.q)[self.system.coordinate_index(name)])

    def __str__(self):
        dq = self.system.difference(self.system.neutral(), self.q)
        lines = [f"{self.kind} equilibrium: {self.stability}, residual {self.residual:.2e} "
                 f"after {self.iterations} iterations, {self.elapsed * 1e3:.1f} ms"]
        for name, x, u in zip(self.system.coordinates, dq, self.system.units):
            speed = f"   speed {self.speeds[name]:.10g} {u}/s" if name in self.speeds else ""
            lines.append(f"  {name:<24} {x:>+16.10g} {u}{speed}")
        return "\n".join(lines)


def static_equilibrium(system, q0=None, t=0.0, tol=1e-10, max_iter=100):
    """Static equilibrium near ``q0`` (neutral if None): Newton with line search; least-squares steps where
    K is singular (free or cyclic coordinates). Raises ConvergenceError with the best point."""
    return _solve(system, q0, t, {}, tol, max_iter)


def steady_motion(system, v_cyclic, q0=None, t=0.0, tol=1e-10, max_iter=100, guess=1.0):
    """Steady motion: the coordinates named in ``v_cyclic`` turn at constant speed — a number (given) or
    None (found from the forces, starting from ``guess`` rad/s or m/s) — while the others rest.

    Example (a rotor driven by τ = 10 − ω² carrying a sprung slider): ``steady_motion({"rotor": None})``.
    """
    if not isinstance(v_cyclic, dict) or not v_cyclic:
        raise ModelError("steady_motion: v_cyclic must be a dict {coordinate: speed or None}")
    cyclic = {}
    for name, speed in v_cyclic.items():
        i = system.coordinate_index(name)
        cyclic[i] = None if speed is None else scalar(speed, f"steady_motion: speed of '{name}'")
    return _solve(system, q0, t, cyclic, tol, max_iter, guess)


def equilibria(system, starts, t=0.0, tol=1e-10, max_iter=100):
    """Distinct static equilibria reached from several starting configurations, lowest potential first."""
    found = []
    for q0 in starts:
        try:
            eq = static_equilibrium(system, q0, t, tol, max_iter)
        except ConvergenceError:
            continue
        if all(np.abs(system.difference(e.q, eq.q)).max() > 1e-6 * max(1.0, system.length_scale) for e in found):
            found.append(eq)
    if not found:
        raise ConvergenceError("equilibria: no start converged", residual=None, best=None)
    return sorted(found, key=lambda e: system.energy(e.q, e.v).potential)


def _solve(system, q0, t, cyclic, tol, max_iter, guess=1.0):
    start = time.perf_counter()
    t, tol = system._t(t), scalar(tol, "equilibrium tol", positive=True)
    max_iter, guess = integer(max_iter, "equilibrium max_iter", minimum=0), scalar(guess, "steady_motion guess")
    nv, model = system.nv, system.model
    q = system.neutral() if q0 is None else system._q(np.array(q0, dtype=float), "q0").copy()
    v = np.zeros(nv)
    given = {i: s for i, s in cyclic.items() if s is not None}
    unknown = [i for i, s in cyclic.items() if s is None]
    for i, s in given.items():
        v[i] = s
    for i in unknown:
        v[i] = guess
    rest = [i for i in range(nv) if i not in cyclic]  # coordinates at (relative) rest: unknown positions
    rows = rest + unknown  # equations: no acceleration of these
    a0 = np.zeros(nv)
    h = steps(system, 1e-6)
    unit = np.where(np.array(system.units) == "m", system.length_scale, 1.0)

    def residual(q, v):
        return system._residual(q, v, a0, t)

    def jacobian(q, v):
        Jq = jacobian_q(system, q, v, a0, t, h)
        cols = [Jq[np.ix_(rows, rest)]]
        if unknown:
            Jv = jacobian_v(system, q, v, a0, t, h * np.maximum(1.0, np.abs(v)))
            cols.append(Jv[np.ix_(rows, unknown)])
        return np.hstack(cols)

    r = residual(q, v)
    J = jacobian(q, v)
    force_scale = max(np.abs(r).max(initial=0.0), (np.abs(np.diag(J)[: len(rest)]) * unit[rest]).max(initial=0.0),
                      1e-300)
    target = tol * force_scale
    best = (np.abs(r[rows]).max(initial=0.0), q.copy(), v.copy())
    it = 0
    max_step = np.concatenate([0.5 * unit[rest], [max(1.0, abs(v[i])) for i in unknown]])
    while best[0] > target:
        if it >= max_iter:
            raise ConvergenceError(f"{'steady motion' if cyclic else 'equilibrium'} search did not converge in "
                                   f"{max_iter} iterations: residual {best[0]:.3e} (target {target:.3e})",
                                   residual=best[0], best=best[1])
        it += 1
        rr = r[rows]
        step = np.linalg.lstsq(J, -rr, rcond=1e-12)[0]
        over = np.abs(step) / max_step
        if over.max() > 1:
            step /= over.max()
        alpha, norm0 = 1.0, np.linalg.norm(rr)
        while True:
            dq = np.zeros(nv)
            dq[rest] = alpha * step[: len(rest)]
            q_new = pin.integrate(model, q, dq)
            v_new = v.copy()
            v_new[unknown] += alpha * step[len(rest):]
            r_new = residual(q_new, v_new)
            if np.linalg.norm(r_new[rows]) <= (1 - 1e-4 * alpha) * norm0 or alpha < 1e-3:
                break
            alpha *= 0.5
        q, v, r = q_new, v_new, r_new
        res = np.abs(r[rows]).max(initial=0.0)
        if res < best[0]:
            best = (res, q.copy(), v.copy())
        if not np.all(np.isfinite(r)):
            raise ConvergenceError("equilibrium search diverged (non-finite forces)", residual=best[0], best=best[1])
        if res <= target:
            break
        if np.abs(step * alpha).max() <= 1e-15 * max(1.0, np.abs(max_step).max()) and res <= 1e3 * target:
            break  # stagnated at round-off
        J = jacobian(q, v)
    q, v = best[1], best[2]
    lin = linearize(system, q, v=v, t=t, a=np.zeros(nv))
    m = lin.modes()
    stability = classify(m.rigid, m.unstable, m.eigenvalues, m.zero_threshold, ignore_zeros=len(cyclic))
    names = system.coordinates
    drive = {names[i]: float(r[i]) for i in given}
    return Equilibrium(system, q, v, float(t), "steady" if cyclic else "static", float(best[0]), float(target), it,
                       stability, {names[i]: float(v[i]) for i in cyclic}, drive, time.perf_counter() - start, m)
