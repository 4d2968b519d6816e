"""Analyses of mechanisms with closed loops (:mod:`vibdyn.description.loops`): equilibrium, linearisation, motion.

The loops' equations Φ(q) = 0 add the generalized forces Φ_qᵀ λ to the tree: M v̇ + b − Q = Φ_qᵀ λ, λ the
loop forces (per equation: N for a position equation, N·m for an orientation one; for a point coincidence
λ is the force that body_a exerts on body_b through the loop, world axes). Everything is reduced to the
mechanism's independent motions: a basis N (nv × dof) of Φ_q N = 0.
"""

import time
from dataclasses import dataclass, field, fields, replace

import numpy as np
import pinocchio as pin

from .._check import scalar, turns_hint
from .._deprecation import Renamed
from ..defaults import EPS, EQUILIBRIUM_TOL, FD_STEP, MAX_ITER
from ..errors import ConvergenceError, ModelError
from ..model import dynamics
from ..model.fd import differences, displaced_vectors, steps, tangent_derivative, vector_derivative
from ..solvers.newton import Steps, newton
from .equilibrium import OperatingPoint
from .linearize import LinearModel, fd_error, reference_state, tree_linearize
from .modal import modes as _modes


def _constraints(system):
    if system.constraints is None:
        raise ModelError(f"system '{system.name}' has no loops")
    return system.constraints


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
    c = _constraints(system)
    nv, zero = system.nv, np.zeros(system.nv)
    speeds = speeds or {}
    what = "steady motion" if speeds else "static equilibrium"
    q, origin = system.start_configuration() if q0 is None else (system.check_configuration(q0, "q0"), "q0")
    turns = turns_hint(system, q)  # (said if the search fails: a start in degrees is far from everything)
    try:
        q = c.assemble(q, start=origin)
    except ConvergenceError as e:
        if not turns:
            raise
        raise ConvergenceError(f"{e}; the start has {turns}", residual=e.residual, best=e.best) from None
    v = zero.copy()
    for i, s in speeds.items():
        v[i] = s
    if speeds:
        J = c.jacobian(q)
        if np.abs(c.scaled_phi(J @ v)).max(initial=0.0) > 1e-9 * np.abs(v / c.col_scale).max():
            raise ModelError(f"steady_motion: turning {', '.join(system.coordinates[i] for i in speeds)} opens the "
                             "loops (Φ_q v ≠ 0): the cyclic coordinates of a mechanism with loops must carry the "
                             "loops with them (a rotor under the mechanism)")

    def residual(qq, J=None):
        if not speeds:
            return dynamics.inverse_dynamics(system, system.workspace(), qq, zero, zero, t)
        J = c.jacobian(qq) if J is None else J
        a = c.dependent_solution(J, -c.bias(qq, v), np.setdiff1d(np.arange(nv), ind))  # (zero for a rotor)
        return dynamics.inverse_dynamics(system, system.workspace(), qq, v, a, t)

    def reduced(qq, ind, N, xi):
        """N₁ᵀ r(q₁) at q₁ = assemble(qq ⊕ N ξ), N₁ the basis there with the same independent coordinates."""
        if not np.any(xi):
            return (N.T @ residual(qq))[rows], qq
        q1 = c.assemble(pin.integrate(system.model, qq, N @ xi), start=f"an iterate of the {what} search")
        J1 = c.jacobian(q1)
        return (c.partition(J1, ind)[1].T @ residual(q1, J1))[rows], q1

    J = c.jacobian(q)
    ind, N = c.partition(J)
    fixed = [system.coordinates[i] for i in speeds if i not in ind]
    if fixed:
        raise ModelError(f"steady_motion: {', '.join(fixed)} cannot turn freely: the loops tie it to the other "
                         "coordinates (give a coordinate the loops leave free)")
    rows = np.array([k for k, i in enumerate(ind) if i not in speeds], dtype=int)  # equations at rest
    r = residual(q, J)
    unit = system.coordinate_scales[ind]
    Kr = vector_derivative(lambda x: reduced(q, ind, N, x)[0], np.zeros(ind.size), 1e-6 * unit)
    force_scale = max(np.abs(r).max(initial=0.0), (np.abs(np.diag(Kr[:, rows])) * unit[rows]).max(initial=0.0),
                      1e-300)
    target = tol * force_scale
    basis = {"q": q, "ind": ind, "N": N, "J": J, "r": r}

    def at(qq):
        """The basis, loop Jacobian and residual at qq (a steady motion keeps its cyclic coordinates)."""
        if basis["q"] is not qq:
            J1 = c.jacobian(qq)
            ind1, N1 = c.partition(J1, ind0 if speeds else None)
            basis.update(q=qq, ind=ind1, N=N1, J=J1, r=residual(qq, J1))
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
    ind, N, J, r = b["ind"], b["N"], b["J"], b["r"]
    rho = (N.T @ r)[rows]
    cyclic = [k for k, i in enumerate(ind) if i in speeds]
    drive = dict(zip((system.coordinates[ind[k]] for k in cyclic), (float(x) for x in (N.T @ r)[cyclic])))
    lam = c.multipliers(J, r - N[:, cyclic] @ ((N.T @ r)[cyclic]) if cyclic else r)
    res = float(np.abs(rho).max(initial=0.0))
    lin = linearize(system, q, v=v, t=t, multipliers=lam)
    m = lin.modes()
    stability = m.verdict(ignore_zeros=len(speeds))
    phi = float(np.abs(c.scaled_phi(c.phi(q))).max(initial=0.0))
    q_error = np.abs(N @ np.linalg.pinv(lin.K, rcond=1e-10) @ np.full(ind.size, float(np.abs(rho).max()))) \
        + 4 * EPS * (np.abs(system.difference(system.neutral(), q)) + 1.0)
    return LoopEquilibrium(system, q, v, float(t), "steady" if speeds else "static", res, float(target), it,
                           stability, {system.coordinates[i]: float(s) for i, s in speeds.items()}, drive,
                           time.perf_counter() - start, m, q_error, lam, c.split(lam), phi)


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


class IndependentView:
    """A system seen in the independent coordinates of its mechanism (what the responses of a
    :class:`ConstrainedLinearModel` name): ``coordinates``, ``units`` and ``coordinate_index`` are the
    independent ones'; everything else is the system's."""

    def __init__(self, system, independent):
        self.system = system
        self.independent = tuple(int(i) for i in independent)
        self.coordinates = tuple(system.coordinates[i] for i in self.independent)
        self.units = tuple(system.units[i] for i in self.independent)
        self.nv = len(self.independent)

    def coordinate_index(self, name):
        if name in self.coordinates:
            return self.coordinates.index(name)
        if name in self.system.coordinates:
            raise ModelError(f"coordinate '{name}' is not an independent motion of the mechanism (its loops fix "
                             f"it; independent: {', '.join(self.coordinates)}): give a body point "
                             "(body, (x, y, z), (dx, dy, dz)) instead")
        raise ModelError(f"unknown coordinate '{name}' (independent coordinates: {', '.join(self.coordinates)})")

    def __getattr__(self, name):
        return getattr(self.system, name)


@dataclass(frozen=True, eq=False)
class ReducedLinearModel(LinearModel):
    """Linear model of a mechanism with loops in its independent motions: M, C, K (dof × dof) are
    NᵀM N, NᵀC N and Nᵀ(K − ∂(Φ_qᵀλ)/∂q)N, N (``null_space``, nv × dof) the motions that keep the loops closed,
    whose rows at the ``independent`` tree coordinates are the identity: the model's coordinates are those
    tree coordinates (``system`` is the system seen in them, :class:`IndependentView`). ``tree`` is the
    nv × nv model (K with the constraint-force curvature). ``rank``: rank of Φ_q at q0. Inputs and outputs of
    responses are any tree coordinate (its row of N) and body points (any point: J N)."""

    null_space: np.ndarray | None = field(repr=False, default=None)
    tree: LinearModel | None = field(repr=False, default=None)
    multipliers: np.ndarray | None = field(repr=False, default=None)
    rank: int = 0
    basis = Renamed("null_space")

    @property
    def independent(self):
        return self.system.independent

    def point_jacobian(self, points):
        """Displacements (m, world axes) of body points per independent coordinate (3·npoints × dof)."""
        return self.tree.point_jacobian(points) @ self.null_space

    def coordinate_row(self, name):
        """(row of N, unit): the tree coordinate ``name`` (independent or not) per independent coordinate."""
        system = self.tree.system
        i = system.coordinate_index(name)
        return self.null_space[i].copy(), system.units[i]

    def joint_input(self, coordinates=None):
        """Reduced input Nᵀ B of generalized forces on the named tree coordinates (dof × m; None: the
        independent ones)."""
        names = self.coordinates if coordinates is None else coordinates
        return self.null_space.T @ self.tree.joint_input(names)

    def support_input(self, name, step=FD_STEP):
        """(Nᵀ B_y, Nᵀ B_v): the tree's base-excitation inputs reduced (see :meth:`LinearModel.support_input`)."""
        By, Bv = self.tree.support_input(name, step)
        return self.null_space.T @ By, self.null_space.T @ Bv

    def relinearize(self, method):
        """The same operating point linearised again with ``method`` (the tree's part: "fd" or "analytic")."""
        return type(self)(**{f.name: getattr(linearize(self.tree.system, self.q, v=self.v, t=self.t, method=method,
                                                        multipliers=self.multipliers), f.name)
                             for f in fields(type(self))})

    def summary(self):
        return (f"{type(self).__name__}({self.method}, nv={self.tree.nv}, dof={self.nv}, rank {self.rank}, "
                f"relative error ≈ {self.relative_error:.1e}, {self.elapsed * 1e3:.2f} ms)")


def _on_reduced(name):
    """A response method of ConstrainedLinearModel that runs on its reduced model."""
    def method(self, *args, **kwargs):
        return getattr(self.reduced, name)(*args, **kwargs)

    method.__name__ = name
    method.__doc__ = getattr(LinearModel, name).__doc__
    return method


@dataclass(frozen=True, eq=False)
class ConstrainedLinearModel(ReducedLinearModel):
    """:class:`ReducedLinearModel` whose :meth:`modes` give their shapes in the tree's coordinates (nv each,
    φ = N ψ, Φ_q φ = 0, φᵀ M φ = 1 with the tree's M; ``modes.linear`` is the tree model). Responses run on
    :attr:`reduced` (modes in the independent coordinates): receptances between tree coordinates are
    N (K_r − ω²M_r + iωC_r)⁻¹ Nᵀ."""

    @property
    def reduced(self):
        return ReducedLinearModel(**{f.name: getattr(self, f.name) for f in fields(ReducedLinearModel)})

    def modes(self, **kwargs):
        """Exactly dof modes, shapes in the tree's coordinates (see the class)."""
        m = _modes(self, **kwargs)
        N = self.null_space
        cs = m.complex_shapes
        return replace(m, linear=self.tree, shapes=N @ m.shapes, complex_shapes=N @ cs if cs.size else cs)

    def with_modal_damping(self, zeta):
        return self.with_damping(self.reduced.with_modal_damping(zeta).C)

    # the responses run on the reduced model
    free_response = _on_reduced("free_response")
    receptance = _on_reduced("receptance")
    harmonic_response = _on_reduced("harmonic_response")
    base_response = _on_reduced("base_response")
    forced_response = _on_reduced("forced_response")
    appropriation = _on_reduced("appropriation")


def linearize(system, at=None, *, v=None, t=0.0, a=None, method="fd", step=FD_STEP, multipliers=None):
    """Linear model of a mechanism with loops about ``at`` (a LoopEquilibrium, a steady motion, or a
    configuration, assembled first) with velocity ``v`` (zero if None; it must keep the loops closed,
    Φ_q v = 0), in the mechanism's independent coordinates.

    At rest: the tree's M, C, K (:func:`vibdyn.analysis.linearize.linearize`) with the constraint-force
    curvature ∂(Φ_qᵀλ)/∂q by central differences in the tangent space (two steps for its error), projected
    on the null space of Φ_q. λ: ``multipliers``, the equilibrium's, or the minimum-norm λ with Φ_qᵀλ = r.

    About a steady motion (v ≠ 0; the independent coordinates do not accelerate, ``a`` must be None or
    zero): the reduced equations F(z, ż, z̈) = N(q)ᵀ r(q, N(q) ż, N(q) z̈ + a_γ) = 0 (q on the loops with
    independent coordinates z, a_γ the acceleration of the dependent ones that keeps Φ_q v̇ + γ = 0) are
    differenced in z and ż (:func:`moving`): their K holds the constraint curvature, the centrifugal and
    the gyroscopic terms together, C the gyroscopic coupling and the dampers."""
    start = time.perf_counter()
    c = _constraints(system)
    q0, v0, t0 = reference_state(system, at, v, t)
    phi = np.abs(c.scaled_phi(c.phi(q0))).max(initial=0.0)
    if phi > 1e-9:
        q0 = c.assemble(q0)
    moving = bool(np.any(v0))
    if a is not None and np.any(a):
        raise ModelError("linearize: a mechanism with loops is linearised about an equilibrium or a steady motion "
                         "(its independent coordinates do not accelerate): give a = None")
    J = c.jacobian(q0)
    ind, N = c.partition(J)
    a0 = np.zeros(system.nv)
    if moving:
        speed = np.abs(v0 / c.col_scale).max()
        if np.abs(c.scaled_phi(J @ v0)).max(initial=0.0) > 1e-9 * speed:
            raise ModelError("linearize: the velocity v of the operating point opens the loops (Φ_q v ≠ 0: "
                             f"{np.abs(c.scaled_phi(J @ v0)).max():.3e} dimensionless): give a motion the loops "
                             "allow (a steady motion's v, or v = N ż)")
        a0 = c.dependent_solution(J, -c.bias(q0, v0), np.setdiff1d(np.arange(system.nv), ind))
    tree = tree_linearize(system, q0, v=v0, t=t0, a=a0, method=method, step=step)
    r = dynamics.inverse_dynamics(system, system.workspace(), q0, v0, a0, t0)
    if multipliers is None:
        multipliers = getattr(at, "multipliers", None)
    lam = c.multipliers(J, r) if multipliers is None else np.asarray(multipliers, dtype=float)
    h = steps(system, step)
    terms = dynamics.cancelling_terms(system, system.workspace(), q0, v0, a0, t0)
    G, T = tangent_derivative(system, lambda q: c.jacobian(q).T @ lam, q0, h, estimate=True)
    G_err = fd_error(G, T, terms, h)
    K_tree = tree.K - G
    tree = replace(tree, K=K_tree, K_error=tree.K_error + G_err)
    aN = np.abs(N)
    M_r = N.T @ tree.M @ N
    M_r = 0.5 * (M_r + M_r.T)
    evaluations = tree.evaluations + 4 * system.nv + 1
    if moving:
        K_r, C_r, K_err, C_err = moving_terms(system, c, q0, v0, t0, ind, h, aN.T @ terms)
        evaluations += 8 * ind.size
    else:
        C_r, K_r = N.T @ tree.C @ N, N.T @ K_tree @ N
        K_err, C_err = aN.T @ tree.K_error @ aN, aN.T @ tree.C_error @ aN
    rank = system.nv - ind.size
    return ConstrainedLinearModel(IndependentView(system, ind), q0, v0, a0, t0, M_r, C_r, K_r, K_err, C_err,
                                  tree.method, time.perf_counter() - start, evaluations, null_space=N, tree=tree,
                                  multipliers=lam, rank=rank)


def moving_terms(system, c, q0, v0, t0, ind, h, terms):
    """(K_r, C_r, K_error, C_error) of the reduced equations about the steady motion (q0, v0) (see
    :func:`linearize`): central differences in the independent coordinates z (q moved by N₀ δz, then closed
    by the dependent ones: :meth:`Constraints.close`) and in their speeds ż, steps h and 2h (Richardson);
    ``terms`` the reduced round-off scale (N or N·m)."""
    nv = system.nv
    dep = np.setdiff1d(np.arange(nv), ind)
    ws = system.workspace()
    zd0 = v0[ind]
    _, N0 = c.partition(c.jacobian(q0), ind)

    def residual(q, zd):
        J = c.jacobian(q)
        N = c.partition(J, ind)[1]
        v = N @ zd
        a = c.dependent_solution(J, -c.bias(q, v), dep)
        return N.T @ dynamics.inverse_dynamics(system, ws, q, v, a, t0)

    hz = h[ind]
    hv = hz * np.maximum(1.0, np.abs(zd0))
    Z = displaced_vectors(np.zeros(ind.size), hz, estimate=True)
    K, T = differences(np.array([residual(c.close(pin.integrate(system.model, q0, N0 @ z), dep), zd0) for z in Z]),
                       hz)
    K_err = fd_error(K, T, terms, hz)
    V = displaced_vectors(zd0, hv, estimate=True)
    C, T = differences(np.array([residual(q0, zd) for zd in V]), hv)
    C_err = fd_error(C, T, terms, hv)
    return K, C, K_err, C_err
