"""Forced-response curves of nonlinear scenes by harmonic balance (HB) with alternating frequency–time (AFT).

The steady response to a harmonic excitation at Ω (rad/s) is sought as x(τ) = c₀ + Σ_{k=1..H} (c_k cos kτ +
s_k sin kτ), τ = Ωt, x the tangent displacement of the free coordinates from the static equilibrium q_eq:
q = q_eq ⊕ x. For pivots, sliders, helical, cylindrical and universal joints x is q − q_eq itself; for ball,
free and planar joints the unknowns are tangent coordinates (a ball's rotation vector from q_eq), with
v = J(x) ẋ and a = J(x) ẍ + (∂J/∂x · ẋ) ẋ, J = ∂(q_eq ⊕ x)/∂x (``pin.dIntegrate``). The residual is evaluated
in time at N = 4H + 4 samples (oversampled against aliasing: exact for cubic forces) through vibdyn's own
inverse dynamics M(q) a + b(q, v) − Q(q, v) (gravity, springs, dampers, cubic springs, large rotations) minus
the excitation, and projected back on the harmonics (Galerkin). Its Jacobian: the samples' ∂/∂q, ∂/∂v, ∂/∂a,
analytic (:func:`vibdyn.model.derivatives.analytic_derivatives`, M by CRBA; on curved groups each sample's
∂/∂x, ∂/∂ẋ, ∂/∂ẍ by central differences), carried by the DFT matrices; ∂/∂Ω analytic too (for a moving
support, whose velocity Ω·Y·sin τ also depends on Ω, a central difference). The branch is followed in Ω by the
solver kit's pseudo-arclength continuation (:mod:`vibdyn.solvers.continuation`), which locates folds exactly.

Truncation: each point's error is estimated by one Newton step of the 2H + 1 balance from the H solution (its
largest displacement of the reported coordinate over a period); with ``harmonics=None`` H grows (doubled, then
where the estimates' geometric decay says) until that estimate is below ``tol`` × the peak amplitude.

Stability: Hill's method, the quadratic eigenproblem (Δ₀ + λΔ₁ + λ²Δ₂) Y = 0 of the HB Jacobian, keeping the
2n exponents whose eigenvectors, written in complex exponentials, are centred on the harmonic 0 and whose
|Im λ| is least (the others are the same exponents shifted by ikΩ, or truncation's); Floquet multipliers
μ = exp(λ 2π/Ω), each |μ|'s error from the same exponent on the 2H + 1 problem (nonlinear inverse iteration
from the H one).

Damping is whatever the scene has. Not handled (refused with a ModelError): closed loops, drives,
time-dependent forces of the scene itself (give the excitation as ``force``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..._check import finite_array, integer, scalar
from ..._format import number
from ...defaults import FD_STEP
from ...errors import ConvergenceError, ModelError
from ...model import dynamics
from ...model.derivatives import analytic_derivatives
from ...model.fd import point_jacobian, steps, tangent_derivative, vector_derivative
from ...solvers.continuation import continuation
from ...solvers.newton import newton

if TYPE_CHECKING:
    from ...model.system import System

START_HARMONICS = 3  # adaptive runs start here
MAX_HARMONICS = 48  # and stop growing here (said so in the result's message)
CONTINUATION_TOL = 1e-11  # ‖R‖_∞ of the corrector, relative to the excitation's generalized force


@dataclass(frozen=True)
class PointForce:
    """A harmonic point force amplitude·direction·cos Ωt (N; ``direction`` in world axes, normalised) applied
    at ``point`` (m, in the frame of ``body``)."""

    body: str
    point: tuple
    direction: tuple
    amplitude: float


@dataclass(frozen=True)
class SupportMotion:
    """The support ``support`` (a :meth:`Scene.add_support`) moved by amplitude·cos Ωt (m, 3 numbers, world
    axes) in place of its own motion law: base excitation through its springs and dampers. The static
    equilibrium is the scene's at t = 0, its law's position there (zero for a HarmonicMotion's sine)."""

    support: str
    amplitude: tuple


@dataclass(frozen=True)
class ResponseFold:
    """A fold of a forced-response curve: ``omega`` (rad/s), ``amplitude`` (m or rad), ``error`` and
    ``omega_error`` (their truncation estimates), ``index`` (the curve point after which it lies)."""

    omega: float
    amplitude: float
    error: float
    index: int
    omega_error: float = 0.0

    @property
    def frequency_hz(self) -> float:
        """Ω in Hz."""
        return self.omega / (2 * math.pi)


@dataclass(frozen=True)
class ResponsePeak:
    """The largest amplitude along the curve: ``omega`` (rad/s), ``amplitude`` (m or rad), ``error`` and
    ``omega_error`` (their truncation estimates)."""

    omega: float
    amplitude: float
    error: float
    omega_error: float = 0.0

    @property
    def frequency_hz(self) -> float:
        """Ω in Hz."""
        return self.omega / (2 * math.pi)


@dataclass(frozen=True, eq=False)
class ForcedResponseCurve:
    """A forced-response curve (:func:`forced_response_curve`).

    Per point: ``omega`` (Ω, rad/s), ``amplitude`` (max over a period of |q_c − q_c,eq|, m or rad),
    ``error`` (its harmonic-truncation estimate, same unit), ``coefficients`` (points × (2H + 1) × nv: the
    constant, then cos kΩt and sin kΩt for k = 1..H, of each tangent coordinate's displacement from
    ``q_eq``), ``multipliers`` (points × 2nv complex Floquet multipliers by Hill's method, by decreasing
    modulus), ``multiplier_error`` (the largest error of their moduli, from Hill's method with 2H + 1
    harmonics), ``stable`` (all |μ| < 1) and ``stability`` ("stable", "unstable", or "within the error" where
    the largest |μ| is within its error of 1, as at a fold). ``folds`` and ``peak``; ``harmonics`` H;
    ``status`` ("finished", "stopped", "failed") and ``message``; ``elapsed`` (s)."""

    coordinate: str
    unit: str
    excitation: str
    omega: np.ndarray
    amplitude: np.ndarray
    error: np.ndarray
    coefficients: np.ndarray
    multipliers: np.ndarray
    multiplier_error: np.ndarray
    stable: np.ndarray
    stability: tuple
    folds: list
    peak: ResponsePeak
    harmonics: int
    q_eq: np.ndarray
    status: str
    message: str
    elapsed: float
    history: list = field(default_factory=list, repr=False)  # (H, largest truncation estimate) of each run
    system: Any = field(default=None, repr=False)

    @property
    def frequency_hz(self) -> np.ndarray:
        """Ω in Hz per point."""
        return self.omega / (2 * math.pi)

    def orbit(self, i: int, points: int = 64) -> Any:
        """The steady motion at point ``i`` over one period, q(t) = q_eq ⊕ x(Ωt) (a ResponseOrbit, animated by
        ``vd.export_html(curve.orbit(i), path)``)."""
        from .response_orbit import response_orbit

        return response_orbit(self, i, points)

    def plot(self, path: str | None = None, dpi: int = 100) -> Any:
        """Amplitude against Ω (matplotlib): stable solid, unstable dashed, folds and peak marked (see
        :func:`vibdyn.faces.plots.forced_response`). Saves to ``path`` if given."""
        from ...faces import plots

        return plots.forced_response(self, path=path, dpi=dpi)

    def __str__(self):
        u = self.unit
        lines = [f"forced-response curve of '{self.coordinate}' under {self.excitation}: harmonic balance, "
                 f"H = {self.harmonics}, {len(self.omega)} points, Ω {number(self.omega[0])} … "
                 f"{number(self.omega[-1])} rad/s, {self.status} ({self.message}), {self.elapsed:.2f} s",
                 f"  peak: amplitude {number(self.peak.amplitude, u, digits=10)} ± {self.peak.error:.1e} at "
                 f"Ω = {number(self.peak.omega, digits=10)} rad/s ({number(self.peak.frequency_hz, digits=8)} Hz)",
                 f"  truncation error ≤ {float(np.max(self.error)):.1e} {u}; "
                 f"{int(np.count_nonzero(~self.stable))} unstable points (Hill's method, |μ| to "
                 f"{float(np.max(self.multiplier_error)):.0e})"]
        for f in self.folds:
            lines.append(f"  fold: Ω = {number(f.omega, digits=10)} ± {f.omega_error:.1e} rad/s "
                         f"({number(f.frequency_hz, digits=8)} Hz), amplitude {number(f.amplitude, u, digits=10)} ± "
                         f"{f.error:.1e}")
        if not self.folds:
            lines.append("  no folds")
        return "\n".join(lines)

    def __repr__(self):
        return (f"ForcedResponseCurve('{self.coordinate}', H={self.harmonics}, {len(self.omega)} points, "
                f"{len(self.folds)} folds, peak {self.peak.amplitude:.6g} {self.unit} at {self.peak.omega:.6g} "
                f"rad/s, {self.status})")


def forced_response_curve(system: System, force: Any, omega: Any, coordinate: str, harmonics: int | None = None,
                          *, tol: float = 1e-8, equilibrium: Any = None, step: float = 0.02,
                          max_steps: int = 2000) -> ForcedResponseCurve:
    """The steady response of ``coordinate`` to a harmonic excitation, Ω swept over ``omega = (lo, hi)``
    rad/s by harmonic balance and arclength continuation (through folds).

    ``force``: ``(coordinate, amplitude)`` — a force (N) or torque (N·m) amplitude·cos Ωt on that joint
    coordinate; a :class:`PointForce`; or a :class:`SupportMotion`. ``harmonics``: H fixed, or None to
    add harmonics until each point's truncation estimate is ≤ ``tol`` × the peak amplitude.
    ``equilibrium``: the static equilibrium (an OperatingPoint) or a configuration to search it from
    (default: searched from the neutral configuration). ``step``: the first arclength step (in amplitudes
    scaled by the linear response's peak and Ω by hi − lo)."""
    start = time.perf_counter()
    lo, hi = _omega_range(omega)
    c = system.coordinate_index(coordinate) if isinstance(coordinate, str) else _bad_coordinate(coordinate)
    if harmonics is not None:
        harmonics = integer(harmonics, "forced_response_curve: harmonics", minimum=1, maximum=1000)
    tol = scalar(tol, "forced_response_curve: tol", positive=True)
    step = scalar(step, "forced_response_curve: step", positive=True)
    max_steps = integer(max_steps, "forced_response_curve: max_steps", minimum=1)
    _check_system(system)
    excitation = _Excitation(system, force)
    q_eq = _equilibrium(system, equilibrium)
    H = harmonics or START_HARMONICS
    history: list = []
    X0 = None
    while True:
        bal = _Balance(system, excitation, q_eq, H)
        run = _follow(bal, lo, hi, X0, step, max_steps)
        trunc = [bal.truncation(x, w, c) for x, w in zip(run.x, run.lam)]
        err = np.array([e[0] for e in trunc])
        amp = np.array([bal.amplitude(x, c) for x in run.x])
        worst = float(np.max(err / max(float(np.max(amp)), 1e-300)))
        history.append((H, worst))
        if harmonics is not None or worst <= tol or H >= MAX_HARMONICS:
            break
        H_next = _next_harmonics(history, tol)
        X0 = _embed(run.x[0], H, H_next, system.nv)
        H = H_next
    status, message = run.status, run.message
    if harmonics is None and worst > tol:
        message += f"; truncation {worst:.1e} of the peak with H = {H} (the most tried) is above tol = {tol:g}"
    if status != "finished":
        message += f"; largest amplitude reached {float(np.max(amp)):.6g} {system.units[c]}"
    folds = []
    for f in run.folds:
        e = bal.truncation(f.x, f.lam, c)
        folds.append(ResponseFold(f.lam, bal.amplitude(f.x, c), e[0], f.index, e[1]))
    peak = _peak(bal, run, amp, c)
    # each |μ|'s error: its exponent again on Hill's problem of the 2H + 1 balance (at the truncation step's
    # coefficients), followed from the H one by inverse iteration
    mult, mult_error = np.empty((len(run.lam), 2 * system.nv), complex), np.empty(len(run.lam))
    for k, (x, w, (_, _, x2, w2)) in enumerate(zip(run.x, run.lam, trunc)):
        mult[k], lam, Y = bal.hill(x, w, vectors=True)
        fine = bal.refined().refined_multipliers(x2, w2, lam, Y)
        mult_error[k] = np.max(np.abs(np.abs(mult[k]) - np.abs(fine)))
    largest = np.abs(mult[:, 0])
    stable = largest < 1.0
    verdict = tuple("within the error" if abs(m - 1.0) <= e else "stable" if m < 1.0 else "unstable"
                    for m, e in zip(largest, mult_error))
    return ForcedResponseCurve(coordinate, system.units[c], excitation.label, run.lam.copy(), amp, err,
                               run.x.reshape(len(run.lam), 2 * H + 1, system.nv).copy(), mult, mult_error, stable,
                               verdict, folds, peak, H, q_eq.copy(), status, message, time.perf_counter() - start,
                               history, system)


def _next_harmonics(history, tol):
    """The next H to try: twice the last, or, after two runs, where the estimates' geometric decay
    ρ = (e₂/e₁)^(1/(H₂ − H₁)) says tol is reached, plus one (at least two more, at most twice)."""
    H2, e2 = history[-1]
    guess = 2 * H2
    if len(history) > 1:
        H1, e1 = history[-2]
        rho = (e2 / e1) ** (1.0 / (H2 - H1)) if e1 > 0 and e2 > 0 else 1.0
        if rho < 1.0:
            guess = H2 + math.ceil(math.log(tol / e2) / math.log(rho)) + 1
    return int(min(max(guess, H2 + 2), 2 * H2, MAX_HARMONICS))


def _omega_range(omega):
    try:
        lo, hi = (float(w) for w in omega)
    except (TypeError, ValueError):
        raise ModelError(f"forced_response_curve: omega must be a pair (lo, hi) of frequencies in rad/s, got "
                         f"{omega!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ModelError(f"forced_response_curve: omega must be an increasing pair of positive finite "
                         f"frequencies (rad/s), got ({lo}, {hi})")
    return lo, hi


def _bad_coordinate(coordinate):
    raise ModelError(f"forced_response_curve: coordinate must be a coordinate's name, got {coordinate!r}")


def _check_system(system):
    what = "forced_response_curve"
    if system.has_loops:
        raise ModelError(f"{what}: scenes with closed loops are not handled by harmonic balance yet")
    if getattr(system, "drives", None) is not None:
        raise ModelError(f"{what}: scenes with drives are not handled by harmonic balance yet")
    timed = [type(g).__name__ for g in system.force_groups if getattr(g, "time_dependent", False)]
    if timed:
        raise ModelError(f"{what}: the scene's own forces depend on time ({', '.join(timed)}): they are not "
                         "periodic at Ω; remove them and give the excitation as `force`")


def _equilibrium(system, equilibrium):
    if equilibrium is not None and hasattr(equilibrium, "kind"):
        if equilibrium.kind != "static":
            raise ModelError(f"forced_response_curve: equilibrium must be a static one, got a {equilibrium.kind} "
                             "operating point")
        return np.array(equilibrium.q, dtype=float)
    eq = system.equilibrium(equilibrium)
    return np.array(eq.q, dtype=float)


class _Excitation:
    """The excitation as generalized forces or support shifts at given τ = Ωt."""

    def __init__(self, system, force):
        self.system = system
        self.kind = None
        what = "forced_response_curve: force"
        if isinstance(force, PointForce):
            b = system.body_info(force.body) if force.body in system.body_infos else None
            if b is None:
                raise ModelError(f"{what}: unknown body '{force.body}' (bodies: {', '.join(system.body_infos)})")
            self.point = (force.body, tuple(finite_array(force.point, (3,), f"{what}: point")))
            d = finite_array(force.direction, (3,), f"{what}: direction")
            if not np.any(d):
                raise ModelError(f"{what}: direction is the zero vector")
            self.F = _nonzero(force.amplitude, what) * d / np.linalg.norm(d)
            self.kind, self.label = "point", (f"a point force {number(np.linalg.norm(self.F))} N·cos Ωt on "
                                              f"'{force.body}'")
        elif isinstance(force, SupportMotion):
            if force.support not in system.support_index:
                raise ModelError(f"{what}: unknown support '{force.support}' (supports: "
                                 f"{', '.join(system.support_index) or 'none'})")
            self.isup = system.support_index[force.support]
            self.Y = finite_array(force.amplitude, (3,), f"{what}: support amplitude")
            if not np.any(self.Y):
                raise ModelError(f"{what}: support amplitude is zero: there is no response to follow")
            self.kind, self.label = "support", f"support '{force.support}' moving {self.Y.tolist()} m·cos Ωt"
        elif isinstance(force, (tuple, list)) and len(force) == 2 and isinstance(force[0], str):
            self.i = system.coordinate_index(force[0])
            self.P = _nonzero(force[1], what)
            u = "N" if system.units[self.i] == "m" else "N·m"
            self.kind, self.label = "joint", f"{number(self.P)} {u}·cos Ωt on '{force[0]}'"
        else:
            raise ModelError(f"{what}: expected (coordinate, amplitude), a PointForce or a SupportMotion, got "
                             f"{force!r}")
        for k, s in enumerate(system.supports):  # other supports must stand still: their motion is not at Ω
            if self.kind == "support" and k == self.isup:
                continue
            for t in (0.0, 0.37, 1.9, 7.3):
                if np.any(np.asarray(s.motion.velocity(t), float)):
                    raise ModelError(f"forced_response_curve: support '{s.name}' moves by its own law, which is "
                                     "not periodic at Ω; excite it with SupportMotion or make it still")

    def shift(self, tau, omega, t):
        """Supports' offsets (n_supports × 6) making the excited one move as Y cos τ (None: no support)."""
        sys_ = self.system
        if not sys_.supports:
            return None
        out = np.zeros((len(sys_.supports), 6))
        for k, s in enumerate(sys_.supports):
            p, v = np.asarray(s.motion.position(t), float), np.asarray(s.motion.velocity(t), float)
            out[k, :3], out[k, 3:] = -p, -v
            if self.kind == "support" and k == self.isup:
                out[k, :3] += self.Y * math.cos(tau)
                out[k, 3:] += -omega * self.Y * math.sin(tau)
        return out

    def force(self, q, tau):
        """Generalized force of a joint or point excitation at τ (N or N·m per coordinate)."""
        if self.kind == "joint":
            f = np.zeros(self.system.nv)
            f[self.i] = self.P * math.cos(tau)
            return f
        if self.kind == "point":
            return point_jacobian(self.system, q, [self.point]).T @ self.F * math.cos(tau)
        return np.zeros(self.system.nv)


def _nonzero(amplitude, what):
    a = scalar(amplitude, f"{what}: amplitude")
    if a == 0.0:
        raise ModelError(f"{what}: amplitude is zero: there is no response to follow")
    return a


class _Balance:
    """The H-harmonic balance of one system and excitation: residual, Jacobian, Hill's matrices."""

    def __init__(self, system, excitation, q_eq, H):
        self.system, self.exc, self.q_eq, self.H, self.n = system, excitation, q_eq, H, system.nv
        self.N = N = 4 * H + 4
        self.tau = 2 * np.pi * np.arange(N) / N
        self.E, self.E1, self.E2 = _basis(self.tau, H)
        w = np.full(2 * H + 1, 2.0 / N)
        w[0] = 1.0 / N
        self.P = w[:, None] * self.E.T  # Galerkin projection: exact coefficients of a trig polynomial ≤ H
        self.k, self.iq = system.additive_coordinates
        self.h = steps(system, FD_STEP)
        self.support = excitation.kind == "support"
        self.curved = bool(system.curved_coordinates)
        self._memo = self._kept = None
        X0 = np.zeros((2 * H + 1) * self.n)
        r0 = self._samples(X0, 1.0)[3]
        self.scale = max(float(np.max(np.abs(r0))), 1e-300)  # the excitation's generalized force

    def _samples(self, X, omega):
        Xm = X.reshape(2 * self.H + 1, self.n)
        x, xd, xdd = self.E @ Xm, omega * (self.E1 @ Xm), omega**2 * (self.E2 @ Xm)
        if self.curved:
            r = np.array([self._sample(j, x[j], xd[j], xdd[j], omega) for j in range(self.N)])
            return x, xd, xdd, r
        Q = np.repeat(self.q_eq[None, :], self.N, axis=0)
        Q[:, self.iq] += x[:, self.k]  # q_eq ⊕ x: a sum on these joints
        ws = self.system.workspace()
        r = np.empty((self.N, self.n))
        for j, tau in enumerate(self.tau):
            t = tau / omega
            r[j] = dynamics.inverse_dynamics(self.system, ws, Q[j], xd[j], xdd[j], t,
                                             self.exc.shift(tau, omega, t)) - self.exc.force(Q[j], tau)
        return Q, xd, xdd, r

    def _state(self, x, xd, xdd):
        """(q, v, a) of the tangent coordinates x and their rates on a curved group: q = q_eq ⊕ x,
        v = J(x) ẋ and a = J(x) ẍ + (∂J/∂x · ẋ) ẋ with J = ∂(q_eq ⊕ x)/∂x (``pin.dIntegrate``), its derivative
        along ẋ by a fourth-order central difference."""
        model = self.system.model
        J = pin.dIntegrate(model, self.q_eq, x, pin.ARG1)
        e = 1e-3 / max(float(np.linalg.norm(xd)), 1e-300)
        Jm, Jp, Jm2, Jp2 = (pin.dIntegrate(model, self.q_eq, x + s * e * xd, pin.ARG1) for s in (-1, 1, -2, 2))
        dJ = (8 * (Jp - Jm) - (Jp2 - Jm2)) / (12 * e)
        return pin.integrate(model, self.q_eq, x), J @ xd, J @ xdd + dJ @ xd

    def _sample(self, j, x, xd, xdd, omega):
        """The time residual at sample j as a function of the tangent coordinates and their rates."""
        tau = self.tau[j]
        t = tau / omega
        q, v, a = self._state(x, xd, xdd)
        return (dynamics.inverse_dynamics(self.system, self.system.workspace(), q, v, a, t,
                                          self.exc.shift(tau, omega, t)) - self.exc.force(q, tau))

    def residual(self, X, omega):
        """R (the harmonics of the time residual, flattened) / the excitation's force scale."""
        return (self.P @ self._samples(X, omega)[3]).ravel() / self.scale

    def _derivatives(self, X, omega):
        """Per sample: r, K = ∂r/∂q, C = ∂r/∂v, M = ∂r/∂a (the last point's kept: Jacobian, Hill's matrices
        and the truncation step ask at the same point)."""
        key = (X.tobytes(), omega)
        if self._kept is not None and self._kept[0] == key:
            return self._kept[1]
        Q, xd, xdd, r = self._samples(X, omega)
        N, n, sys_, ws = self.N, self.n, self.system, self.system.workspace()
        K, C, M = np.empty((N, n, n)), np.empty((N, n, n)), np.empty((N, n, n))
        if self.curved:  # ∂/∂x, ∂/∂ẋ, ∂/∂ẍ of each sample's residual by central differences
            for j in range(N):
                K[j] = vector_derivative(lambda y: self._sample(j, y, xd[j], xdd[j], omega), Q[j], self.h)
                C[j] = vector_derivative(lambda y: self._sample(j, Q[j], y, xdd[j], omega), xd[j], self.h)
                M[j] = vector_derivative(lambda y: self._sample(j, Q[j], xd[j], y, omega), xdd[j], self.h)
            self._kept = (key, (xd, xdd, r, K, C, M))
            return xd, xdd, r, K, C, M
        for j, tau in enumerate(self.tau):
            t = tau / omega
            M[j] = dynamics.mass_matrix(sys_.model, ws.data, Q[j])
            K[j], C[j] = analytic_derivatives(sys_, Q[j], xd[j], xdd[j], t, shift=self.exc.shift(tau, omega, t))[:2]
            if self.exc.kind == "point":  # J(q)ᵀF turns with the body: its own ∂/∂q, by differences
                K[j] -= tangent_derivative(sys_, lambda q: self.exc.force(q, tau), Q[j], self.h)
        self._kept = (key, (xd, xdd, r, K, C, M))
        return xd, xdd, r, K, C, M

    def jacobian(self, X, omega):
        """[∂R/∂X, ∂R/∂Ω] / the force scale."""
        key = (X.tobytes(), omega)
        if self._memo is not None and self._memo[0] == key:
            return self._memo[1]
        xd, xdd, r, K, C, M = self._derivatives(X, omega)
        JX = self._galerkin((K, self.E), (C, omega * self.E1), (M, omega**2 * self.E2))
        if self.support:  # the support's velocity Ω·Y·sin τ depends on Ω too: a central difference
            d = 1e-6 * omega
            JW = (self.residual(X, omega + d) - self.residual(X, omega - d)) * self.scale / (2 * d)
        else:  # ẋ ∝ Ω, ẍ ∝ Ω²
            JW = (self.P @ (np.einsum("jpi,ji->jp", C, xd) + 2 * np.einsum("jpi,ji->jp", M, xdd))).ravel() / omega
        out = np.column_stack([JX, JW]) / self.scale
        self._memo = (key, out)
        return out

    def _galerkin(self, *terms):
        """The Galerkin matrix Σ P · diag_j(A_j) · B of the per-sample n × n matrices A_j and sample bases B:
        rows (harmonic, equation), columns (harmonic, coordinate), as X is ordered."""
        W = sum(A[:, :, :, None] * B[:, None, None, :] for A, B in terms)  # (N, n, n, 2H + 1)
        G = np.tensordot(self.P, W, axes=(1, 0))  # (2H + 1, n, n, 2H + 1): (a, p, i, b)
        m = (2 * self.H + 1) * self.n
        return G.transpose(0, 1, 3, 2).reshape(m, m)

    def hill_matrices(self, X, omega):
        """(Δ₀, Δ₁, Δ₂) of Hill's quadratic eigenproblem (Δ₀ + λΔ₁ + λ²Δ₂) Y = 0 at this solution."""
        xd, xdd, r, K, C, M = self._derivatives(X, omega)
        D0 = self.jacobian(X, omega)[:, :X.size] * self.scale
        D1 = self._galerkin((C, self.E), (M, 2 * omega * self.E1))
        D2 = self._galerkin((M, self.E))
        return D0, D1, D2

    def hill(self, X, omega, vectors=False):
        """The 2n Floquet multipliers by Hill's method, by decreasing modulus (and, with ``vectors``, their
        exponents λ and the eigenvectors Y, in that order)."""
        m, n = X.size, self.n
        D0, D1, D2 = self.hill_matrices(X, omega)
        A = np.block([[np.zeros((m, m)), np.eye(m)],
                      [-np.linalg.solve(D2, D0), -np.linalg.solve(D2, D1)]])
        lam, V = np.linalg.eig(A)
        # each exponent appears shifted by ikΩ; keep the 2n whose eigenvectors, in complex exponentials
        # e^{ikτ}, are centred nearest to k = 0 (a real exponent of the resonant harmonic weighs on k = ±1
        # alike), ties (the same nearest k) to the least |Im λ| (a symmetric scene's truncated constant mode is
        # centred on 0 too, far from |Im λ| ≤ Ω/2), skipping copies of one already kept (λ' − λ ≈ ikΩ)
        Y = V[:m].reshape(2 * self.H + 1, n, 2 * m)
        w0 = (np.abs(Y[0]) ** 2).sum(axis=0)
        wp = (np.abs(Y[1::2] - 1j * Y[2::2]) ** 2).sum(axis=1) / 4  # k = +1..H
        wm = (np.abs(Y[1::2] + 1j * Y[2::2]) ** 2).sum(axis=1) / 4  # k = −1..−H
        k = np.arange(1, self.H + 1)[:, None]
        centroid = (k * (wp - wm)).sum(axis=0) / np.maximum(w0 + (wp + wm).sum(axis=0), 1e-300)
        keep = []
        for j in np.lexsort((np.abs(lam.imag), np.floor(np.abs(centroid) + 0.5))):
            shift = (lam[j] - lam[keep]) / (1j * omega)
            if not np.any((np.abs(shift.imag) <= 1e-6) & (np.abs(shift.real - np.round(shift.real)) <= 1e-6)):
                keep.append(j)
            if len(keep) == 2 * n:
                break
        mu = np.exp(lam[keep] * 2 * np.pi / omega)
        order = np.argsort(-np.abs(mu), kind="stable")
        if vectors:
            return mu[order], lam[keep][order], V[:m, keep][:, order]
        return mu[order]

    def refined_multipliers(self, X2, omega, lam, Y):
        """The multipliers of the 2H + 1 balance (``self`` is it) at X2, from the H ones' exponents ``lam`` and
        eigenvectors ``Y`` (H harmonics) by nonlinear inverse iteration on its Hill problem (one complex solve
        per step, no eigenproblem of the larger size)."""
        D0, D1, D2 = self.hill_matrices(X2, omega)
        out = np.empty(len(lam), complex)
        H = (Y.shape[0] // self.n - 1) // 2
        for k, (l, y) in enumerate(zip(lam, Y.T)):
            w = _embed(y, H, self.H, self.n)
            w = w / np.linalg.norm(w)
            y = w.copy()
            for _ in range(8):
                L, dL = D0 + l * D1 + l * l * D2, D1 + 2 * l * D2
                try:
                    u = np.linalg.solve(L, dL @ y)
                except np.linalg.LinAlgError:  # λ is an exact eigenvalue
                    break
                step = (np.conj(w) @ y) / (np.conj(w) @ u)
                l, y = l - step, u / (np.conj(w) @ u)
                if abs(step) <= 1e-14 * max(abs(l), omega):
                    break
            out[k] = np.exp(l * 2 * np.pi / omega)
        return out

    def amplitude(self, X, c):
        """max over a period of |x_c(τ)| (m or rad), the maximum refined by Newton on dx/dτ = 0."""
        a = X.reshape(2 * self.H + 1, self.n)[:, c]
        k = np.arange(1, self.H + 1)
        ac, as_ = a[1::2], a[2::2]
        grid = np.linspace(0, 2 * np.pi, max(64, 16 * (2 * self.H + 1)), endpoint=False)
        vals = _basis(grid, self.H)[0] @ a
        j = int(np.argmax(np.abs(vals)))
        tau, best = grid[j], abs(vals[j])
        for _ in range(8):
            d1 = np.sum(k * (-ac * np.sin(k * tau) + as_ * np.cos(k * tau)))
            d2 = np.sum(k**2 * (-ac * np.cos(k * tau) - as_ * np.sin(k * tau)))
            if d2 == 0.0:
                break
            tau -= d1 / d2
        val = abs(a[0] + np.sum(ac * np.cos(k * tau) + as_ * np.sin(k * tau)))
        return float(max(val, best))

    def refined(self):
        """The balance with 2H + 1 harmonics (the next odd one too, which odd forces excite), made once."""
        big = self.__dict__.get("_refined")
        if big is None:
            big = self._refined = _Balance.__new__(_Balance)
            big.__dict__.update(self.__dict__)
            H2 = 2 * self.H + 1
            big.H, big.N = H2, 4 * H2 + 4
            big.tau = 2 * np.pi * np.arange(big.N) / big.N
            big.E, big.E1, big.E2 = _basis(big.tau, H2)
            w = np.full(2 * H2 + 1, 2.0 / big.N)
            w[0] = 1.0 / big.N
            big.P, big._memo, big._kept, big._refined = w[:, None] * big.E.T, None, None, None
        return big

    def truncation(self, X, omega, c):
        """(error, omega_error, X2, omega2): the estimated truncation errors of this point of the branch — one
        Newton step of the 2H + 1 balance from it, normal to the branch (the continuation's corrector: regular
        at folds too), its largest displacement of coordinate c over a period and its change of Ω — and the
        coefficients and Ω that step reaches."""
        t = np.linalg.svd(self.jacobian(X, omega))[2][-1]  # the branch's tangent (X, Ω)
        big = self.refined()
        X2 = _embed(X, self.H, big.H, self.n)
        t2 = np.append(_embed(t[:-1], self.H, big.H, self.n), t[-1])
        A = np.vstack([big.jacobian(X2, omega), t2])
        dY = np.linalg.lstsq(A, np.append(-big.residual(X2, omega), 0.0), rcond=None)[0]
        dX = dY[:-1]
        grid = np.linspace(0, 2 * np.pi, max(64, 8 * (2 * big.H + 1)), endpoint=False)
        d = _basis(grid, big.H)[0] @ dX.reshape(2 * big.H + 1, self.n)[:, c]
        return float(np.max(np.abs(d))), float(abs(dY[-1])), X2 + dX, omega + float(dY[-1])


def _basis(tau, H):
    """E, dE/dτ, d²E/dτ² at the samples τ: columns 1, cos τ, sin τ, …, cos Hτ, sin Hτ."""
    k = np.arange(1, H + 1)
    kt = np.multiply.outer(tau, k)
    c, s = np.cos(kt), np.sin(kt)
    N = len(tau)
    E, E1, E2 = np.zeros((N, 2 * H + 1)), np.zeros((N, 2 * H + 1)), np.zeros((N, 2 * H + 1))
    E[:, 0] = 1.0
    E[:, 1::2], E[:, 2::2] = c, s
    E1[:, 1::2], E1[:, 2::2] = -k * s, k * c
    E2[:, 1::2], E2[:, 2::2] = -k**2 * c, -k**2 * s
    return E, E1, E2


def _embed(X, H, H2, n):
    """The coefficients of H harmonics as those of H2 ≥ H (zeros above)."""
    out = np.zeros((2 * H2 + 1, n), dtype=X.dtype)
    out[:2 * H + 1] = X.reshape(2 * H + 1, n)
    return out.ravel()


def _follow(bal, lo, hi, X0, step, max_steps):
    """The branch from Ω = lo to hi (a linear guess at lo unless X0 is given)."""
    n, H, sys_ = bal.n, bal.H, bal.system
    D = bal._derivatives(np.zeros((2 * H + 1) * n), lo)
    K0, C0, M0 = D[3][0], D[4][0], D[5][0]
    f1 = bal.P[1:3] @ (-D[2])  # the excitation's first harmonic at rest (cos, sin)
    grid = np.linspace(lo, hi, 201)
    peak = np.zeros(n)
    for w in grid:
        Z = K0 - w**2 * M0 + 1j * w * C0
        try:
            u = np.linalg.solve(Z, f1[0] - 1j * f1[1])
        except np.linalg.LinAlgError:
            continue
        peak = np.maximum(peak, np.where(np.isfinite(u), np.abs(u), 0.0))
    ref = float(np.max(peak)) if np.max(peak) > 0 else sys_.length_scale
    if X0 is None:
        Z = K0 - lo**2 * M0 + 1j * lo * C0
        u = np.linalg.lstsq(Z, f1[0] - 1j * f1[1], rcond=None)[0]
        Xm = np.zeros((2 * H + 1, n))
        Xm[1], Xm[2] = u.real, -u.imag
        X0 = Xm.ravel()
    scale = np.append(np.full(X0.size, ref), hi - lo)
    big = 10 * ref

    def stop(x, w):  # the branch has gone back below lo, or far beyond the linear peak
        return w < lo - 0.5 * (hi - lo) or np.max(np.abs(x)) > 1e3 * big

    branch = continuation(bal.residual, X0, lo, hi, step=step, jacobian=bal.jacobian, tol=CONTINUATION_TOL,
                          max_steps=max_steps, max_step=5 * step, scale=scale, stop=stop)
    if len(branch.lam) == 0:
        raise ConvergenceError(f"forced_response_curve: no periodic response found at Ω = {lo:g} rad/s "
                               f"({branch.message}); try a lower start, a smaller excitation or an explicit "
                               "equilibrium", residual=branch.residual)
    return branch


def _peak(bal, run, amp, c):
    """The largest amplitude along the branch, refined between the neighbours of the best point: amplitude
    maximised over the arclength s, each point solved on the hyperplane normal to the tangent there."""
    i = int(np.argmax(amp))
    y_i = np.append(run.x[i], run.lam[i])
    if 0 < i < len(amp) - 1:
        from scipy.optimize import minimize_scalar

        J = bal.jacobian(run.x[i], run.lam[i])
        t = np.linalg.svd(J)[2][-1]
        lo_s = float(t @ (np.append(run.x[i - 1], run.lam[i - 1]) - y_i))
        hi_s = float(t @ (np.append(run.x[i + 1], run.lam[i + 1]) - y_i))
        lo_s, hi_s = min(lo_s, hi_s), max(lo_s, hi_s)
        cache = {}

        def solve(s):
            res = newton(lambda y: np.append(bal.residual(y[:-1], y[-1]), t @ (y - y_i) - s), y_i + s * t,
                         lambda y: np.vstack([bal.jacobian(y[:-1], y[-1]), t]), tol=CONTINUATION_TOL, max_iter=20)
            cache[s] = res
            return -bal.amplitude(res.x[:-1], c) if res.converged else -amp[i]

        opt = minimize_scalar(solve, bounds=(lo_s, hi_s), method="bounded",
                              options={"xatol": 1e-10 * max(hi_s - lo_s, 1e-300)})
        res = cache.get(opt.x)
        if res is not None and res.converged and -opt.fun >= amp[i]:
            y = res.x
            e = bal.truncation(y[:-1], y[-1], c)
            return ResponsePeak(float(y[-1]), float(-opt.fun), e[0], e[1])
    e = bal.truncation(run.x[i], run.lam[i], c)
    return ResponsePeak(float(run.lam[i]), float(amp[i]), e[0], e[1])
