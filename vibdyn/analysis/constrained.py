"""Analyses of mechanisms with closed loops (:mod:`vibdyn.description.loops`): equilibrium, linearisation, motion.

The loops' equations Φ(q) = 0 add the generalized forces Φ_qᵀ λ to the tree: M v̇ + b − Q = Φ_qᵀ λ, λ the
loop forces (per equation: N for a position equation, N·m for an orientation one; for a point coincidence
λ is the force that body_a exerts on body_b through the loop, world axes). Everything is reduced to the
mechanism's independent motions: a basis N (nv × dof) of Φ_q N = 0.
"""

import time
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from .._check import scalar, turns_hint
from ..defaults import EPS, EQUILIBRIUM_TOL, MAX_ITER
from ..errors import ConvergenceError, ModelError
from ..model import dynamics
from ..model.fd import vector_derivative
from ..solvers.newton import Steps, newton
from .equilibrium import OperatingPoint
from .reduced import linearize


def _reduction(system):
    """The system's reduction (ModelError for a scene without loops)."""
    if not system.reduction.curved:
        raise ModelError(f"system '{system.name}' has no loops")
    return system.reduction


@dataclass(frozen=True, eq=False)
class LoopEquilibrium(OperatingPoint):
    """An equilibrium of a mechanism with loops: also its loop forces.

    ``multipliers``: λ per loop equation (N or N·m, see :mod:`vibdyn.analysis.constrained`); ``loop_forces``: the same
    split per loop {name: array}; ``constraint_residual``: largest |Φ| there (dimensionless: m / length
    scale, rad).
    """

    multipliers: np.ndarray | None = field(repr=False, default=None)
    loop_forces: dict | None = field(default=None)
    constraint_residual: float = 0.0

    def linearize(self, **kwargs):
        return self.system.linearize(self, **kwargs)

    def reactions(self):
        """Link wrenches of the tree at this equilibrium, loop forces included (:meth:`System.reactions`)."""
        nv = self.system.nv
        return self.system.reactions(self.q, self.v, np.zeros(nv), self.t, loop_forces=self.multipliers)



def equilibrium(system, q0=None, t=0.0, tol=EQUILIBRIUM_TOL, max_iter=MAX_ITER, speeds=None):
    """Static equilibrium of a mechanism with loops near q0 (need not be consistent; default: the system's
    start): Newton on the reduced force Nᵀ r(q) = 0 (r = inverse dynamics at rest, N the null-space basis at
    the current point), each iterate re-assembled onto Φ = 0; the reduced Jacobian by central differences
    (steps 1e-6 rad or 1e-6 × length scale along N's columns). The loop forces are the minimum-norm λ with
    Φ_qᵀλ = r. ``speeds`` ({coordinate index: speed}, rad/s or m/s): a steady motion instead, those
    independent coordinates turning at the given speeds (held by their drives: ``drive``), r the inverse
    dynamics at that velocity (see :func:`steady_motion`)."""
    start = time.perf_counter()
    R = _reduction(system)
    zero = np.zeros(system.nv)
    speeds = speeds or {}
    what = "steady motion" if speeds else "static equilibrium"
    q, origin = system.start_configuration() if q0 is None else (system.check_configuration(q0, "q0"), "q0")
    turns = turns_hint(system, q)  # (said if the search fails: a start in degrees is far from everything)
    try:
        q = R.close(q, start=origin)
    except ConvergenceError as e:
        if not turns:
            raise
        raise ConvergenceError(f"{e}; the start has {turns}", residual=e.residual, best=e.best) from None
    v = zero.copy()
    for i, s in speeds.items():
        v[i] = s
    if speeds:
        if R.opening(q, v) > 1e-9:
            raise ModelError(f"steady_motion: turning {', '.join(system.coordinates[i] for i in speeds)} opens the "
                             "loops (Φ_q v ≠ 0): the cyclic coordinates of a mechanism with loops must carry the "
                             "loops with them (a rotor under the mechanism)")

    def residual(qq):
        if not speeds:
            return dynamics.inverse_dynamics(system, system.workspace(), qq, zero, zero, t)
        a = R.reference_acceleration(system.workspace(), qq, v, t, ind)  # (zero for a rotor)
        return dynamics.inverse_dynamics(system, system.workspace(), qq, v, a, t)

    def reduced(qq, ind, N, xi):
        """N₁ᵀ r(q₁) at q₁ = assemble(qq ⊕ N ξ), N₁ the basis there with the same independent coordinates."""
        if not np.any(xi):
            return (N.T @ residual(qq))[rows], qq
        q1 = R.close(pin.integrate(system.model, qq, N @ xi), start=f"an iterate of the {what} search")
        return (R.independent(q1, ind)[1].T @ residual(q1))[rows], q1

    ind, N = R.independent(q)
    fixed = [system.coordinates[i] for i in speeds if i not in ind]
    if fixed:
        raise ModelError(f"steady_motion: {', '.join(fixed)} cannot turn freely: the loops tie it to the other "
                         "coordinates (give a coordinate the loops leave free)")
    rows = np.array([k for k, i in enumerate(ind) if i not in speeds], dtype=int)  # equations at rest
    r = residual(q)
    unit = system.coordinate_scales[ind]
    Kr = vector_derivative(lambda x: reduced(q, ind, N, x)[0], np.zeros(ind.size), 1e-6 * unit)
    force_scale = max(np.abs(r).max(initial=0.0), (np.abs(np.diag(Kr[:, rows])) * unit[rows]).max(initial=0.0),
                      1e-300)
    target = tol * force_scale
    basis = {"q": q, "ind": ind, "N": N, "r": r}

    def at(qq):
        """The basis, loop Jacobian and residual at qq (a steady motion keeps its cyclic coordinates)."""
        if basis["q"] is not qq:
            ind1, N1 = R.independent(qq, ind0 if speeds else None)
            basis.update(q=qq, ind=ind1, N=N1, r=residual(qq))
        return basis

    def rho_of(qq):
        b = at(qq)
        return (b["N"].T @ b["r"])[rows]

    def retract(qq, xi):
        b = at(qq)
        return reduced(qq, b["ind"], b["N"], xi)[1]

    def jacobian(qq):
        b = at(qq)
        unit = system.coordinate_scales[b["ind"]]
        return vector_derivative(lambda x: reduced(qq, b["ind"], b["N"], x)[0], np.zeros(b["ind"].size),
                                 1e-6 * unit)

    def cap(qq, f, J, xi):  # a trust region: half a unit of each independent coordinate
        over = (np.abs(xi) / (0.5 * system.coordinate_scales[at(qq)["ind"]])).max(initial=0.0)
        return xi / over if over > 1 else xi

    ind0 = ind
    out = newton(rho_of, q, jacobian, retract, tol=target, max_iter=max_iter, start=((N.T @ r)[rows], Kr),
                 steps=Steps(shape=cap, on_no_decrease="accept", min_alpha=1e-3, stall=1e3))
    if out.status == "diverged":
        raise ConvergenceError(f"{what} search diverged (non-finite forces)", residual=None, best=out.x)
    if out.status not in ("converged", "stagnated"):
        raise ConvergenceError(f"{what} of the mechanism with loops did not converge in {max_iter} "
                               f"iterations: reduced residual {out.residual:.3e} (target {target:.3e}); "
                               "start nearer an equilibrium (q0=)" + (f"; the start has {turns}" if turns else ""),
                               residual=out.residual, best=out.x)
    q, it = out.x, out.iterations
    b = at(q)
    ind, N, r = b["ind"], b["N"], b["r"]
    rho = (N.T @ r)[rows]
    cyclic = [k for k, i in enumerate(ind) if i in speeds]
    drive = dict(zip((system.coordinates[ind[k]] for k in cyclic), (float(x) for x in (N.T @ r)[cyclic])))
    lam = R.multipliers(q, r - N[:, cyclic] @ ((N.T @ r)[cyclic]) if cyclic else r)
    res = float(np.abs(rho).max(initial=0.0))
    lin = linearize(system, R, q, v=v, t=t, multipliers=lam)
    m = lin.modes()
    stability = m.verdict(ignore_zeros=len(speeds))
    phi = R.closure(q)
    q_error = np.abs(N @ np.linalg.pinv(lin.K, rcond=1e-10) @ np.full(ind.size, float(np.abs(rho).max()))) \
        + 4 * EPS * (np.abs(system.difference(system.neutral(), q)) + 1.0)
    return LoopEquilibrium(system, q, v, float(t), "steady" if speeds else "static", res, float(target), it,
                           stability, {system.coordinates[i]: float(s) for i, s in speeds.items()}, drive,
                           time.perf_counter() - start, m, q_error, lam, R.split(lam), phi)


def steady_motion(system, v_cyclic, q0=None, t=0.0, tol=EQUILIBRIUM_TOL, max_iter=MAX_ITER):
    """Steady motion of a mechanism with loops: the coordinates of ``v_cyclic`` ({name: speed}, rad/s or
    m/s, given) turn at constant speed, held by their drives, carrying the loops with them (Φ_q v = 0: a
    rotor under the mechanism); the others rest relative to them (:func:`equilibrium` with ``speeds``)."""
    if not isinstance(v_cyclic, dict) or not v_cyclic:
        raise ModelError("steady_motion: v_cyclic must be a dict {coordinate: speed}")
    speeds = {}
    for name, speed in v_cyclic.items():
        if speed is None:
            raise ModelError(f"steady_motion: the speed of '{name}' must be given for a mechanism with loops (a "
                             "speed found from the forces is not supported there)")
        speeds[system.coordinate_index(name)] = scalar(speed, f"steady_motion: speed of '{name}'")
    return equilibrium(system, q0, t, tol, max_iter, speeds)
