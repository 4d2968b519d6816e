"""Linearisation about an operating point: M δv̇ + C δv + K δq = B δu, in the tangent space.

M comes from CRBA; K = ∂r/∂q and C = ∂r/∂v with r(q, v) = inverse_dynamics(q, v, a0, t0) = M a0 + b − Q,
by central finite differences (configurations perturbed with ``integrate``) or analytically
(``pin.computeRNEADerivatives`` plus the force elements' own derivatives). Units: K in N/m, N or N·m/rad
per coordinate pair, C in N·s/m or N·m·s/rad, M in kg, kg·m or kg·m².
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from .._check import all_finite, has_coordinates, scalar, unknown_name
from .._deprecation import Renamed
from ..defaults import EPS, FD_STEP
from ..errors import ModelError

if TYPE_CHECKING:  # result types of the entry points below (imported on call, not at import)
    from ..model.system import System
    from .modal import Modes
    from .response import FRF, Appropriation, HarmonicResponse, RandomResponse, TimeResponse
    from .statespace import StateSpace
from ..model import dynamics
from ..model.derivatives import analytic_derivatives, row_derivatives, solve_mass
from ..model.fd import differences, displaced_vectors, point_jacobian, stencil, step_stencil, vector_derivative
from . import modal


@dataclass(frozen=True, eq=False)
class LinearModel:
    """Linear model about the state (``q``, ``v``) at time ``t`` (s), with the reference motion's accelerations
    ``a`` (zero at an equilibrium), its error estimate and the time it took.

    ``K_error`` and ``C_error`` are elementwise estimates of the absolute error of K and C (zero for an
    exact part); ``relative_error`` is the largest of them relative to the norm of K (or C). ``K_error_terms``: None,
    or (U, V) the part of ``K_error`` made of rank-one errors Σ_s u_s e_sᵀ with |e_s| ≤ v_s (rows of U, V;
    the rounding of point springs' forces in finite differences): ``K_error`` holds Σ_s |u_s| v_sᵀ, and a
    quadratic form φᵀ δK φ is bounded by Σ_s |u_s·φ| (v_s·|φ|) (zero for a mode that does not stretch s).
    """

    system: System = field(repr=False)
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    t: float
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    K_error: np.ndarray
    C_error: np.ndarray
    method: str
    elapsed: float  # s
    evaluations: int  # residual evaluations (finite differences) or derivative calls
    K_error_terms: tuple | None = field(default=None, repr=False)
    q0 = Renamed("q")
    v0 = Renamed("v")
    a0 = Renamed("a")
    t0 = Renamed("t")
    error = Renamed("relative_error")

    def __repr__(self):
        from .._format import duration, number, summary

        kind = "damped" if self.has_damping else "undamped"
        return summary("LinearModel", f"nv = {self.nv}", f"method {self.method}", kind,
                       f"relative error {number(self.relative_error, digits=2)}", f"{self.evaluations} evaluations",
                       duration(self.elapsed))

    @property
    def coordinates(self) -> tuple[str, ...]:
        """Names of this model's coordinates (nv)."""
        return self.system.coordinates

    @property
    def units(self) -> tuple[str, ...]:
        """Unit of each coordinate ("m" or "rad")."""
        return self.system.units

    def coordinate_index(self, name: str) -> int:
        """Index of the coordinate ``name`` in this model."""
        return self.system.coordinate_index(name)

    @property
    def nv(self):
        return self.M.shape[0]

    @property
    def hold(self) -> tuple[str, ...]:
        """Names of the coordinates held at their speed (``linearize(hold=...)``): none for a tree's model."""
        return ()

    @property
    def D(self):
        """Damping: symmetric part of C."""
        return 0.5 * (self.C + self.C.T)

    @property
    def G(self):
        """Gyroscopic: skew part of C."""
        return 0.5 * (self.C - self.C.T)

    @property
    def K_s(self):
        """Symmetric part of K (elastic + geometric stiffness)."""
        return 0.5 * (self.K + self.K.T)

    @property
    def N(self):
        """Circulatory: skew part of K (zero at a conservative equilibrium)."""
        return 0.5 * (self.K - self.K.T)

    @property
    def relative_error(self) -> float:
        """Largest estimated error of K and C, relative to their norms."""
        k = float(self.K_error.max(initial=0.0) / max(np.abs(self.K).max(initial=0.0), 1e-300))
        c = float(self.C_error.max(initial=0.0) / max(np.abs(self.C).max(initial=0.0), 1e-300))
        return max(k if np.any(self.K) else 0.0, c if np.any(self.C) else 0.0)

    @property
    def has_damping(self):
        return np.count_nonzero(self.C) > 0

    @property
    def A(self):
        """State matrix of x = (δq, δv): ẋ = A x + B_state u (2nv × 2nv)."""
        n = self.nv
        A = np.zeros((2 * n, 2 * n))  # (in place, not np.block: the damped modes ask at every Campbell speed)
        A[:n, n:] = np.eye(n)
        A[n:, :n], A[n:, n:] = -self.solve_mass(self.K), -self.solve_mass(self.C)
        return A

    def state_input(self, B: ArrayLike) -> np.ndarray:
        """State input matrix [[0], [M⁻¹ B]] for a generalized input matrix B (nv × m)."""
        B = np.asarray(B, dtype=float).reshape(self.nv, -1)
        return np.vstack([np.zeros_like(B), self.solve_mass(B)])

    def coordinate_row(self, name: str) -> tuple[np.ndarray, str]:
        """(row, unit): the displacement of the coordinate ``name`` per coordinate of this model (nv), and its
        unit ("m" or "rad"); the same row is the generalized force of a unit force on it."""
        i = self.coordinate_index(name)
        row = np.zeros(self.nv)
        row[i] = 1.0
        return row, self.units[i]

    def joint_input(self, coordinates: str | list[str] | None = None) -> np.ndarray:
        """Input matrix of generalized forces on the named coordinates (nv × m; all if None)."""
        names = self.coordinates if coordinates is None else coordinates
        B = np.zeros((self.nv, len(names)))
        for j, name in enumerate(names):
            B[self.coordinate_index(name), j] = 1.0
        return B

    def point_jacobian(self, points: list) -> np.ndarray:
        """Displacements (m, world axes) of body points per tangent coordinate: (3·npoints × nv).

        ``points``: body names (their origin) or ``(body, (x, y, z))`` with the point in the body frame.
        """
        return point_jacobian(self.system, self.q, points)

    def point_input(self, points: list) -> np.ndarray:
        """Input matrix of forces (N, world axes) at body points: Jᵀ (nv × 3·npoints)."""
        return self.point_jacobian(points).T

    def support_input(self, name: str, step: float = FD_STEP) -> tuple[np.ndarray, np.ndarray]:
        """(B_y, B_v): generalized force (N or N·m) per unit displacement (m) and per unit velocity (m/s)
        of the support ``name`` along the world axes (nv × 3 each), by central differences: the linear
        model's base-excitation input, M δv̇ + C δv + K δq = B_y y + B_v ẏ."""
        system = self.system
        if name not in system.support_index:
            raise unknown_name(name, [s.name for s in system.supports], "support", what="support input")
        i = system.support_index[name]

        def residual(x):
            shift = np.zeros((len(system.supports), 6))
            shift[i] = x
            return dynamics.inverse_dynamics(system, system.workspace(), self.q, self.v, self.a, self.t, shift)

        # (a power of two: the support moves by exactly it, see :func:`vibdyn.model.fd.steps`)
        h = float(np.exp2(np.round(np.log2(step * system.length_scale))))
        out = -vector_derivative(residual, np.zeros(6), np.full(6, h))  # Q = −r
        return out[:, :3], out[:, 3:]

    # responses (vibdyn.analysis.response): thin entry points
    def free_response(self, t: ArrayLike, x0: ArrayLike, v0: ArrayLike | None = None, **kwargs: Any) -> TimeResponse:
        """Free response from δq(0) = x0, δv(0) = v0 at times t (s) (:func:`vibdyn.analysis.response.free_response`)."""
        from .response import free_response

        return free_response(self, t, x0, v0, **kwargs)

    def receptance(self, omega: ArrayLike | None, inputs: Any = None, outputs: Any = None, **kwargs: Any) -> FRF:
        """Receptance α(ω) (m/N, ...) between inputs and outputs (:func:`vibdyn.analysis.response.receptance`)."""
        from .response import receptance

        return receptance(self, omega, inputs, outputs, **kwargs)

    def harmonic_response(self, omega: float, force: ArrayLike, inputs: Any = None, outputs: Any = None,
                          **kwargs: Any) -> HarmonicResponse:
        """Steady response to harmonic forces (:func:`vibdyn.analysis.response.harmonic_response`)."""
        from .response import harmonic_response

        return harmonic_response(self, omega, force, inputs, outputs, **kwargs)

    def base_response(self, omega: ArrayLike | None, support: str, direction: ArrayLike | None = None,
                      outputs: Any = None, **kwargs: Any) -> FRF:
        """Steady response to a harmonic motion of a support or prescribed joint: transmissibility
        (:func:`vibdyn.analysis.response.base_response`)."""
        from .response import base_response

        return base_response(self, omega, support, direction, outputs, **kwargs)

    def forced_response(self, t: ArrayLike, force: Any = None, inputs: Any = None, **kwargs: Any) -> TimeResponse:
        """Transient response to force histories and/or base motion
        (:func:`vibdyn.analysis.response.forced_response`)."""
        from .response import forced_response

        return forced_response(self, t, force, inputs, **kwargs)

    def random_response(self, psd: Any, support: str | None = None, direction: ArrayLike | None = None,
                        outputs: Any = None, **kwargs: Any) -> RandomResponse:
        """Stationary response to random inputs given by one-sided PSDs in Hz: RMS, spectra, covariances
        (:func:`vibdyn.analysis.response.random_response`)."""
        from .response import random_response

        return random_response(self, psd, support, direction, outputs, **kwargs)

    def appropriation(self, mode: int, inputs: Any = None, **kwargs: Any) -> Appropriation:
        """Force pattern exciting one undamped mode alone (:func:`vibdyn.analysis.response.appropriation`)."""
        from .response import appropriation

        return appropriation(self, mode, inputs, **kwargs)

    def state_space(self, inputs: Any = None, outputs: Any = None, **kwargs: Any) -> StateSpace:
        """State-space form ẋ = A x + B u, y = C x + D u, x = (δq, δv), for control tools
        (:func:`vibdyn.analysis.statespace.state_space`)."""
        from .statespace import state_space

        return state_space(self, inputs, outputs, **kwargs)

    def modes(self, **kwargs: Any) -> Modes:
        """Modal analysis of this linear model (see :func:`vibdyn.analysis.modal.modes`)."""
        return modal.modes(self, **kwargs)

    def with_damping(self, C: ArrayLike) -> LinearModel:
        """The same model with the damping matrix C (nv × nv) instead of its own."""
        C = np.asarray(C, dtype=float)
        if C.shape != self.M.shape or not np.all(np.isfinite(C)):
            raise ModelError(f"damping matrix: expected a finite {self.M.shape} array")
        return replace(self, C=C, C_error=np.zeros_like(C))

    def with_rayleigh(self, zeta: ArrayLike, omega: ArrayLike) -> LinearModel:
        """Rayleigh damping C = αM + βK_s giving ratios ``zeta`` = (ζ1, ζ2) at ``omega`` = (ω1, ω2) rad/s."""
        alpha, beta = modal.rayleigh(zeta, omega)
        return self.with_damping(alpha * self.M + beta * self.K_s)

    def with_modal_damping(self, zeta: float | ArrayLike) -> LinearModel:
        """Damping giving the ratio ``zeta`` (one number or one per mode) to each undamped mode:
        C = M Φ diag(2 ζ_r ω_r) Φᵀ M."""
        m = replace(self, C=np.zeros_like(self.C), C_error=np.zeros_like(self.C)).modes()
        z = np.broadcast_to(np.asarray(zeta, dtype=float), m.omega.shape)
        if np.any(z < 0) or not np.all(np.isfinite(z)):
            raise ModelError(f"modal damping ratios must be finite and ≥ 0, got {zeta!r}")
        MPhi = self.M @ m.shapes
        return self.with_damping(MPhi @ np.diag(2 * z * m.omega) @ MPhi.T)

    def relinearize(self, method: str) -> LinearModel:
        """The same operating point linearised again with ``method`` ("fd" or "analytic")."""
        return tree_linearize(self.system, self.q, v=self.v, t=self.t, a=self.a, method=method)

    def summary(self) -> str:
        return (f"LinearModel({self.method}, nv={self.nv}, relative error ≈ {self.relative_error:.1e}, "
                f"{self.elapsed * 1e3:.2f} ms, {self.evaluations} evaluations)")

    def solve_mass(self, B: ArrayLike) -> np.ndarray:
        """M⁻¹ B by Cholesky (B: nv × k); a singular M is a ModelError naming the body."""
        try:
            return solve_mass(self.M, np.asarray(B, dtype=float))
        except np.linalg.LinAlgError:
            self.system.check_mass_matrix(self.q, "the operating point")
            raise ModelError("the mass matrix of this linear model is singular or not finite") from None


def reference_state(system, at=None, v=None, t=0.0):
    """(q0, v0, t0) from an equilibrium/steady-motion result, a configuration, or None (neutral)."""
    if at is None:
        q0 = system.neutral()
    elif hasattr(at, "q") and hasattr(at, "v"):
        q0, v = at.q, at.v if v is None else v
        t = getattr(at, "t", t)
    else:
        q0 = at
    q0 = system.check_configuration(q0, "operating point q")
    v0 = np.zeros(system.nv) if v is None else system.check_velocity(v, "operating point v")
    return q0, v0, system.check_time(t)


def linearize(system: System, at: Any = None, *, v: ArrayLike | None = None, t: float = 0.0,
              a: ArrayLike | None = None, method: str = "fd", step: float = FD_STEP,
              hold: str | list[str] | tuple[str, ...] = (), independent: Any = None) -> LinearModel:
    """Linear model of ``system`` about ``at`` (an Equilibrium/SteadyMotion, a configuration q, or None
    for the neutral configuration) with velocity ``v`` (zero if None) at time ``t``.

    ``a``: the acceleration of the reference motion; default zero about an equilibrium or steady motion
    (a given speed is held by its drive), else the free acceleration at (q, v, t).
    ``method``: "fd" (central differences with steps ``step`` × scale, scale 1 rad or the scene's length
    scale; error estimated from a second step 2h) or "analytic" (Pinocchio's RNEA derivatives plus the
    force elements' derivatives; the columns of joints whose type Pinocchio gets wrong, a universal joint's,
    by central differences, their error added to the estimate). The analytic K and C are checked against
    central differences of the residual along a fixed pseudo-random direction of (q, v) (:func:`guard`, once per
    system and kind of state, at rest or moving): a disagreement beyond the differences' own error estimate warns
    (UserWarning naming the scene's joint types) and falls back to "fd" (the result's ``method`` says so). A mechanism
    with loops, a scene with drives, and ``hold`` (coordinate names held at their speed in v by their drive: a Campbell
    diagram's spin) are linearised in the independent coordinates of the system's reduction
    (:mod:`vibdyn.model.reduction`, :func:`vibdyn.analysis.reduced.linearize`); ``independent`` (indices in v) keeps
    those as the independent coordinates instead of choosing them (another model's, to compare or difference).
    """
    reduction = system.reduction
    if hold is not None and not isinstance(hold, str) and (
            not isinstance(hold, (list, tuple)) or not all(isinstance(name, str) for name in hold)):
        raise ModelError(f"linearize: hold must be a coordinate's name or a list of names, got {hold!r}")
    if hold:
        held = [system.coordinate_index(name) for name in ([hold] if isinstance(hold, str) else hold)]
        speeds = reference_state(system, at, v, t)[1]
        reduction = reduction.holding({i: float(speeds[i]) for i in held})

    def reduced(R):  # in the independent coordinates of the loops, drives and held speeds
        from .reduced import linearize as reduced_linearize

        return reduced_linearize(system, R, at, v=v, t=t, a=a, method=method, step=step, independent=independent)

    return reduction.linear_model(lambda: tree_linearize(system, at, v=v, t=t, a=a, method=method, step=step),
                                  reduced)


def tree_linearize(system: System, at: Any = None, *, v: ArrayLike | None = None, t: float = 0.0,
                   a: ArrayLike | None = None, method: str = "fd", step: float = FD_STEP) -> LinearModel:
    """:func:`linearize` of the tree itself (a mechanism's loops left open: its constrained linearisation
    builds on this one)."""
    start = time.perf_counter()
    has_coordinates(system, "linearize", "to linearise")
    if step is not FD_STEP:
        step = scalar(step, "linearize step", positive=True)
        if step < EPS:  # (a displacement below q's own round-off: the differences would be round-off over ~0)
            raise ModelError(f"linearize: step {step:g} is below the machine epsilon {EPS:.1e} (a relative step)")
    if method not in ("fd", "analytic"):
        raise ModelError(f"linearize: unknown method {method!r} (use 'fd' or 'analytic')")
    q0, v0, t0 = reference_state(system, at, v, t)
    ws = system.workspace()
    M = dynamics.mass_matrix(system.model, ws.data, q0)
    # the elements' forces at the operating point, evaluated once for the accelerations and the derivatives
    applied = dynamics.forces(system, ws, q0, v0, t0) if method == "analytic" else None
    if a is not None:
        a0 = system.check_velocity(a, "a")
    elif hasattr(at, "drive"):  # an equilibrium or steady motion: the reference motion does not accelerate
        a0 = np.zeros(system.nv)
    else:
        a0 = dynamics.accelerations(system, ws, q0, v0, t0, applied).copy()
        if not all_finite(a0):
            system.check_mass_matrix(q0, "the operating point", M)
            raise ModelError(f"linearize: the accelerations are not finite at the operating point (t = {t0})")
    rounding, damping = None, None  # (damping: whether C has a nonzero, where already counted)
    if method == "fd":
        K, C, K_err, C_err, n, rounding = _finite_differences(system, ws, q0, v0, a0, t0, step)
    else:
        K, C, terms, K_size, C_size, differenced = analytic_derivatives(system, q0, v0, a0, t0, with_terms=True,
                                                                        applied=applied)
        # round-off of the terms that cancel in r, per unit coordinate (1 m: length scale, 1 rad), and of
        # those summed into K (gravity's, the centrifugal, inertial and elements' stiffnesses: K_size ≥ |K|),
        # with a floor: the largest of the cancelling terms (N·m: per unit rad, or m × the length scale) reaches
        # each entry through the tree's transforms (a joint that gravity does not load still has derivatives
        # made of its neighbours' torques; a held robot's wrist read −4e-10 rad²/s² for 0); K_size has them all
        K_err = K_size
        K_err *= 16 * EPS
        damping = bool(np.count_nonzero(C))
        if damping:
            C_err = terms[:, None] / system.coordinate_scales
            C_err += np.abs(C) if C_size is None else C_size
            C_err *= 16 * EPS
        else:
            C_err = np.zeros(C.shape)
        n = 1
        if differenced is not None:  # columns differenced (joints Pinocchio gets wrong): their FD error
            k, h, T_q, hv, T_v = differenced
            K_err[:, k] += fd_error(K[:, k], T_q, terms, h)
            rounding = force_rounding(system, ws, q0, t0, h)
            if rounding is not None:
                K_err[:, k] += np.abs(rounding[0]).T @ rounding[1]
                rounding = None
            n += 4 * len(k)
            if T_v is not None:
                C_err[:, k] += fd_error(C[:, k], T_v, terms, hv)
                n += 4 * len(k)
        checks, disagreement = guard(system, ws, q0, v0, a0, t0, M, K, C, K_err, C_err, terms)
        n += checks
        if disagreement:
            kinds = sorted({b.joint.type for b in system.body_infos.values() if b.nv})
            warnings.warn(f"linearize: the analytic {disagreement} (joint types here: {', '.join(kinds)}): "
                          "using finite differences instead", stacklevel=3)
            K, C, K_err, C_err, n_fd, rounding = _finite_differences(system, ws, q0, v0, a0, t0, step)
            n, method, damping = n + n_fd, "fd", None
    system.check_mass_matrix(q0, "the operating point", M)  # (finite, and regular against the scene's scales)
    if not all_finite(K):
        raise ModelError("linearize: K is not finite at the operating point")
    if (np.count_nonzero(C) if damping is None else damping) and not all_finite(C):  # (a C of zeros needs no test)
        raise ModelError("linearize: C is not finite at the operating point")
    return LinearModel(system, q0, v0, a0, t0, M, C, K, K_err, C_err, method, time.perf_counter() - start, n,
                       rounding)


GUARD_SAFETY = 10.0  # factor on the differences' error estimate beyond which the analytic K or C is refused


def _guard_plan(system, ws):
    """The guard's fixed pseudo-random directions, kept with the workspace's stencils: (δq, |δq|, the rows
    ±δq, ±2δq, δv, the rows ±δv, ±2δv), δ = d∘h with h the FD steps and d of random sign and size in [1/2, 1]
    per coordinate (no structure of a scene, equal masses or a symmetric chain, cancels a wrong entry; one
    direction suffices: a wrong entry cancels in a random one with probability zero)."""
    plan = ws.stencils.get("guard")
    if plan is None:
        rng = np.random.default_rng(system.nv)
        d = rng.choice((-1.0, 1.0), size=(2, system.nv)) * rng.uniform(0.5, 1.0, (2, system.nv))
        d *= step_stencil(system, ws, FD_STEP, estimate=True).h
        signs = np.array([[1.0], [2.0], [-1.0], [-2.0]])
        plan = ws.stencils["guard"] = (d[0], np.abs(d[0]), signs * d[0], d[1], signs * d[1])
    return plan


def guard(system, ws, q0, v0, a0, t0, M, K, C, K_err, C_err, terms):
    """(evaluations, disagreement): K·δq + C·δv against the central difference of the residual r(q, v) along a
    fixed direction (:func:`_guard_plan`; q moved by ``integrate``, δv scaled by max(1, |v0|), and zero where C is
    zero by construction: no velocity dependence and v0 = 0), the states ±δ, ±2δ in one pass. Its error
    estimate: :func:`fd_error`'s from the 2δ difference, with the round-off of the forces that cancel in r
    (``terms``; the forces the steps make, |K||δq| + |C|(|v0| + 2|δv|) + |M||a0|: stiffness, inertia and Coriolis
    forces that RNEA sums away; the largest of all these, or of the point forces, through the tree's transforms as
    the analytic estimate's floor; the point springs' rounding), plus K's and C's own. ``disagreement``: None, or
    how far beyond GUARD_SAFETY × that estimate they disagree. It checks formulas, not numbers: once per compiled
    system (its workspace) and kind of state — at rest, or moving (where C's velocity terms join) — as a derivative
    wrong for a joint type or an element is wrong at almost every state (a Campbell diagram or a continuation
    pays for it once)."""
    moving = bool(system.depends_on_velocity or np.count_nonzero(v0))
    passed = ws.stencils.setdefault("guard passed", set())
    if moving in passed:  # this system's formulas already agreed with differences in this kind of state
        return 0, None
    dq, dq_abs, X, dv, Y = _guard_plan(system, ws)
    Q = np.array([pin.integrate(system.model, q0, x) for x in X]) if system.curved_coordinates else X + q0
    if moving:
        w = np.maximum(1.0, np.abs(v0))
        dv, V = dv * w, Y * w
        V += v0
    s = system.coordinate_scales
    made = np.abs(K) @ dq_abs  # the forces the steps themselves make (N or N·m): their round-off too
    if moving:
        made += np.abs(C) @ (np.abs(v0) + 2 * np.abs(dv))
    if np.count_nonzero(a0):
        made += np.abs(M) @ np.abs(a0)
    # the largest force in the tree reaches every row through its transforms, where it cancels: the operating
    # point's terms, its point forces (still in the workspace's buffers: N·m through the length scale) and the
    # steps' own (a spun rotor's spin row sums tilt × spin products that cancel, while its own forces are all 0)
    largest = max([float((terms * s).max()) if len(s) else 0.0, float((made * s).max(initial=0.0))] + [
        np.linalg.norm(ws.forces[j][:3]) * system.length_scale + np.linalg.norm(ws.forces[j][3:])
        for j in system.point_joints])
    forces = terms + made
    forces += largest / s
    rounding = force_rounding(system, ws, q0, t0, np.ones(1))  # (springs' forces from rounded positions)
    r, F = dynamics.inverse_dynamics_rows(system, ws, Q, V if moving else v0, a0, t0)
    r -= F  # rows: +δ, +2δ, −δ, −2δ
    D = r[0] - r[2]
    D /= 2  # ≈ K δq + C δv (N or N·m)
    T = r[3] - r[1]
    T /= 4
    T += D  # D(δ) − D(2δ)
    off = K @ dq
    bound = K_err @ dq_abs
    if moving:
        off += C @ dv
        bound += C_err @ np.abs(dv)
    off -= D
    bound += fd_error(D[:, None], T[:, None], forces, 1.0)[:, 0]
    if rounding is not None:
        bound += np.abs(rounding[0]).T @ rounding[1][:, 0]
    if (np.abs(off) <= GUARD_SAFETY * bound).all():
        passed.add(moving)
        return len(Q), None
    return len(Q), (f"K and C disagree with central differences of the residual along a random direction "
                    f"(by {float(np.max(np.abs(off) / bound)):.3g} × their error estimate)")


def jacobian_q(system, q0, v0, a0, t0, h):
    """∂r/∂q by central differences in the tangent space (steps h per coordinate), all columns in one pass."""
    ws = system.workspace()
    st = stencil(system, ws, h)
    tau, F = dynamics.inverse_dynamics_rows(system, ws, st.configurations(system, q0), v0, a0, t0)
    tau -= F
    return st.derivatives(tau)[0]


def jacobian_v(system, q0, v0, a0, t0, h):
    """∂r/∂v by central differences (steps h per coordinate), all columns in one pass."""
    tau, F = dynamics.inverse_dynamics_rows(system, system.workspace(), q0[None, :], displaced_vectors(v0, h), a0, t0)
    tau -= F
    return differences(tau, h)[0]


def fd_error(D, T, terms, h, round_off=None):
    """Error estimate of central differences D with steps h: the truncation estimate T = D(h) − D(2h)
    (:mod:`vibdyn.model.fd`) plus the round-off of the terms that cancel in r (|RNEA| + |Q| + |g| per row,
    N or N·m: 16ε·terms/h, ``round_off`` = 16ε/h if given) and of D itself."""
    err = np.abs(D)
    err *= 4 * EPS
    err += np.abs(T)
    err += terms[:, None] * (16 * EPS / h if round_off is None else round_off)
    return err


def measured_share(R, bound, nv):
    """Per row, the share of ``bound`` (the row's bound of each evaluation's round-off, N or N·m) that the
    evaluations show: R the residuals at a stencil's rows (:class:`vibdyn.model.fd.Stencil` with estimate: q0, then
    ±h, ±2h per coordinate). Each row's round-off is sampled by the fourth difference r(2h) − 4r(h) + 6r(0) − 4r(−h)
    + r(−2h) of every column (h⁴ r⁗ beside it is nothing at these steps; random round-off of size e gives it √70 e):
    three times their root mean square over √70, over the bound, kept between 1/16 and 1 (the bound where the
    round-off cancels exactly, at every step alike)."""
    fourth = _FOURTH.dot(R[1:].reshape(4, -1)).reshape(nv, -1)  # (stencil rows: steps +h, +2h, −h, −2h)
    fourth += 6 * R[0]
    noise = np.hypot.reduce(fourth, axis=0)  # (no overflow of the squares)
    noise *= 3 / math.sqrt(70 * nv)
    share = np.minimum(noise, bound, out=noise)
    share /= bound + 1e-300
    return np.maximum(share, 1 / 16, out=share)


_FOURTH = np.array([-4.0, 1.0, -4.0, 1.0])  # the fourth difference's weights of r(h), r(2h), r(−h), r(−2h)


def _finite_differences(system, ws, q0, v0, a0, t0, step):
    """K, C and their error estimates (:func:`fd_error`): every displaced configuration evaluated in one
    pass (:func:`vibdyn.model.dynamics.inverse_dynamics_rows`), the operating point's own evaluation first
    (its terms size the round-off), then the velocities if anything depends on them."""
    st = step_stencil(system, ws, step, estimate=True)
    h = st.h
    tau, F = dynamics.inverse_dynamics_rows(system, ws, st.configurations(system, q0), v0, a0, t0)
    tau0 = np.abs(tau[0])
    terms = tau0 + np.abs(F[0])
    terms += tau0 if dynamics.is_gravity(system, v0, a0) else np.abs(dynamics.gravity_term(system, ws, q0))
    tau -= F
    K, T = st.derivatives(tau)
    # the round-off bound of each row's evaluations (the terms that cancel, the point springs' forces), and the
    # share of it the evaluations show
    rounding = force_rounding(system, ws, q0, t0, h)
    bound = 16 * EPS * terms
    if rounding is not None:
        bound += np.abs(rounding[0]).T @ (rounding[1][:, 0] * h[0])
    share = measured_share(tau, bound, system.nv) if rounding is not None or terms.any() else None
    K_err = fd_error(K, T, terms if share is None else share * terms, h, st.round_off)
    if rounding is not None:  # (one share for every spring: a spring's rounding reaches every row it moves)
        U = rounding[0]
        rounding = (U * float(share[np.abs(U).max(axis=0, initial=0.0) > 0].max(initial=1 / 16)), rounding[1])
        K_err += np.abs(rounding[0]).T @ rounding[1]
    evaluations = 4 * system.nv + 1
    if system.depends_on_velocity or np.count_nonzero(v0):
        hv = h * np.maximum(1.0, np.abs(v0))
        tau_v, F = dynamics.inverse_dynamics_rows(system, ws, q0[None, :], displaced_vectors(v0, hv, estimate=True),
                                                  a0, t0)
        tau_v -= F
        C, T = differences(tau_v, hv)
        C_err = fd_error(C, T, terms, hv)
        # a velocity-dependent force that vanishes at v0 as a difference of large terms (a motor law 10 − ω² at
        # its steady ω) rounds off by ε × their size, which |C|·|v0| measures where the force itself does not
        C_err += np.multiply.outer(np.abs(C) @ np.abs(v0), EPS / hv)
        evaluations += 4 * system.nv
    else:  # nothing depends on velocity and v0 = 0: C is exactly zero
        C, C_err = np.zeros(K.shape), np.zeros(K.shape)
    return K, C, K_err, C_err, evaluations, rounding


def force_rounding(system, ws, q0, t0, h):
    """(U, V) of the point forces computed from rounded world positions (``force_rounding`` of their groups):
    the columns of central differences with steps h carry each force's rounding s / h_j along u (N/m or
    N·m/rad per coordinate): V = s ⊗ 1/h. None where no group has such forces."""
    groups = [g for g in system.point_groups if g.force_rounding is not None]
    if not groups:
        return None
    d = row_derivatives(system, ws, q0[None, :], None, t0)
    parts = [g.force_rounding(d) for g in groups]
    U = np.vstack([p[0] for p in parts])
    return U, np.multiply.outer(np.concatenate([p[1] for p in parts]), 1.0 / h)
