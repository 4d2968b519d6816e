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
largest displacement of the reported coordinate over a period), plus the balance's own residual and round-off
carried to the amplitude at that Ω (:meth:`Balance.precision`), both first order and a point's reported twice; with
``harmonics=None`` H grows (doubled, then where the estimates' geometric decay says) until the step is below ``tol``
× the peak amplitude.

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
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..._check import integer, scalar
from ..._format import number
from ...defaults import EPS
from ...errors import ConvergenceError, ModelError
from ...solvers.continuation import Arclength, continuation
from ...solvers.differences import second_derivative
from ...solvers.newton import newton
from ..equilibrium import static_configuration
from .balance import Balance, Excitation, PointForce, SupportMotion, embed, sampled_basis

__all__ = ["forced_response_curve", "ForcedResponseCurve", "ResponseFold", "ResponsePeak", "PointForce",
           "SupportMotion"]

if TYPE_CHECKING:
    from ...model.system import System

START_HARMONICS = 3  # adaptive runs start here
MAX_HARMONICS = 48  # and stop growing here (said so in the result's message)
MAX_HILL = 400  # a fixed H is refused where Hill's matrices pass this size (H = 99 for one coordinate: 10 s)
CHORD = 0.1  # the corrector keeps a Jacobian while each step cuts the residual 10 times
CONTINUATION_TOL = 1e-11  # ‖R‖_∞ of the corrector, relative to the excitation's generalized force
PEAK_COND = 1e10  # a natural frequency sizes the linear peak where Z(ω) is no worse conditioned (undamped: ∞)
ROUNDOFF_MARGIN = 8.0  # and at least this many ulps of the largest stiffness force of the linear peak
TRUNCATION_SAFETY = 2.0  # first-order error estimates (truncation step, residual's) taken this many times


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
    ``omega_error`` (their truncation estimates; infinite where the curve stopped while the amplitude still grew)."""

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
    ``error`` (twice its truncation estimate plus the balance's residual and round-off carried to it, same unit),
    ``coefficients`` (points × (2H + 1) × nv: each tangent
    coordinate's displacement from ``q_eq``, x(τ) = c₀ + Σ_k a_k cos kτ + b_k sin kτ with τ = Ωt, its rows
    interleaved c₀, a₁, b₁, a₂, b₂, …, a_H, b_H; :meth:`harmonic` picks one harmonic), ``multipliers``
    (points × 2nv complex Floquet multipliers by Hill's method, by decreasing modulus), ``multiplier_error`` (the
    largest error of their moduli, from Hill's method with 2H + 1 harmonics), ``stable`` (all |μ| < 1) and ``stability``
    ("stable", "unstable", or "within the error" where the largest |μ| is within its error of 1, as at a fold).
    ``folds`` and ``peak``; ``harmonics`` H; ``status`` ("finished", "stopped", "failed") and ``message``; ``elapsed``
    (s)."""

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

    def harmonic(self, k: int, coordinate: str | None = None) -> Any:
        """The k-th harmonic per point: for k = 0 the constant c₀ (points × nv), for k = 1..H the pair (a_k, b_k)
        of cos kΩt and sin kΩt coefficients (each points × nv; m or rad); ``coordinate`` (a name) keeps its
        column alone (arrays of one value per point)."""
        k = integer(k, "ForcedResponseCurve.harmonic: k", minimum=0, maximum=self.harmonics)
        X = self.coefficients
        if coordinate is not None:
            X = X[:, :, self.system.coordinate_index(coordinate)]
        return X[:, 0].copy() if k == 0 else (X[:, 2 * k - 1].copy(), X[:, 2 * k].copy())

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
                 f"  points' error ≤ {float(np.max(self.error)):.1e} {u}; "
                 f"{self.stability.count('unstable')} unstable points, {self.stability.count('within the error')} "
                 f"neutral within the error of |μ| (Hill's method, |μ|'s error up to "
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
        top = max(MAX_HARMONICS, (MAX_HILL // (2 * max(system.nv, 1)) - 1) // 2)
        if harmonics > top:  # (Hill's eigenproblem, (2H + 1)·2n square at every point, costs H³: hours at H = 1000)
            raise ModelError(f"forced_response_curve: harmonics = {harmonics} makes Hill's matrices "
                             f"{(2 * harmonics + 1) * 2 * system.nv} square at every point of the curve (their cost "
                             f"grows as H³); at most {top} for this scene of {system.nv} coordinate"
                             f"{'s' if system.nv > 1 else ''} (harmonics=None chooses H for tol, up to "
                             f"{MAX_HARMONICS})")
    tol = scalar(tol, "forced_response_curve: tol", positive=True)
    step = scalar(step, "forced_response_curve: step", positive=True)
    max_steps = integer(max_steps, "forced_response_curve: max_steps", minimum=1)
    _check_system(system)
    excitation = Excitation(system, force)
    q_eq = static_configuration(system, equilibrium, "forced_response_curve")
    _check_held(system, q_eq)
    H = harmonics or START_HARMONICS
    history: list = []
    X0 = None
    while True:
        bal = Balance(system, excitation, q_eq, H)
        run, run_tol = _follow(bal, lo, hi, X0, step, max_steps)
        trunc = [bal.truncation(x, w, c, at_omega=True) for x, w in zip(run.x, run.lam)]
        err = np.array([e[0] for e in trunc])
        amp = np.array([bal.amplitude(x, c) for x in run.x])
        worst = float(np.max(err / max(float(np.max(amp)), 1e-300)))
        history.append((H, worst))
        if harmonics is not None or worst <= tol or H >= MAX_HARMONICS:
            break
        H_next = _next_harmonics(history, tol)
        X0 = embed(run.x[0], H, H_next, system.nv)
        H = H_next
    # (both are first-order estimates, the step of the 2H + 1 balance and the residual carried through ∂R/∂X: either
    # fell up to 9 % short of the actual error; H is chosen on the step itself, each reported twice)
    err = TRUNCATION_SAFETY * (err + np.array([bal.precision(x, w, c) for x, w in zip(run.x, run.lam)]))
    status, message = run.status, run.message
    if harmonics is None and worst > tol:
        message += f"; truncation {worst:.1e} of the peak with H = {H} (the most tried) is above tol = {tol:g}"
    if status != "finished":
        message += f"; largest amplitude reached {float(np.max(amp)):.6g} {system.units[c]}"
    folds = []
    for f in run.folds:
        e = bal.truncation(f.x, f.lam, c)
        folds.append(ResponseFold(f.lam, bal.amplitude(f.x, c), e[0], f.index, e[1]))
    peak = _peak(bal, run, amp, c, run_tol)
    if status != "finished" and int(np.argmax(amp)) == len(amp) - 1:
        # (the curve stopped while its amplitude still grew: the largest reached is no peak, and how far the true
        # one lies above it, or at what Ω, is not known)
        peak = ResponsePeak(peak.omega, peak.amplitude, math.inf, math.inf)
        message += " (still growing where the curve stopped: the peak is beyond it, its error infinite)"
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
    system.reduction.require("harmonic balance", what)
    timed = [type(g).__name__ for g in system.force_groups if getattr(g, "time_dependent", False)]
    if timed:
        raise ModelError(f"{what}: the scene's own forces depend on time ({', '.join(timed)}): they are not "
                         "periodic at Ω; remove them and give the excitation as `force`")


def _check_held(system, q_eq):
    """Refuse a scene with a rigid mode at its equilibrium: nothing holds that motion, so the mean of its
    coordinate over a period is undetermined (the balance has no unique solution, Hill's method no 2n exponents)."""
    m = system.linearize(q_eq).modes()
    if m.rigid.any():
        j = int(np.flatnonzero(m.rigid)[0])
        name = system.coordinates[int(np.argmax(np.abs(m.shapes[:, j]) / np.asarray(system.coordinate_scales)))]
        raise ModelError(f"forced_response_curve: the scene has a rigid mode at its equilibrium (ω = 0, mainly "
                         f"'{name}'): nothing holds that motion, so its mean position over a period is undetermined; "
                         "hold it (a spring, or a Fixed joint)")


def _follow(bal, lo, hi, X0, step, max_steps):
    """The branch from Ω = lo to hi (a linear guess at lo unless X0 is given)."""
    n, H, sys_ = bal.n, bal.H, bal.system
    D = bal.derivatives(np.zeros((2 * H + 1) * n), lo)
    K0, C0, M0 = D[3][0], D[4][0], D[5][0]
    f1 = bal.P[1:3] @ (-D[2])  # the excitation's first harmonic at rest (cos, sin)
    natural = _natural_frequencies(K0, M0, lo, hi)
    grid = np.concatenate([np.linspace(lo, hi, 201), natural])
    peak = np.zeros(n)
    for j, w in enumerate(grid):
        Z = K0 - w**2 * M0 + 1j * w * C0
        if j >= 201 and np.linalg.cond(Z) > PEAK_COND:  # (an undamped resonance: no finite linear peak)
            continue
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

    # legs ending at each undamped natural frequency in the range: the branch is solved there, on its lightly
    # damped peak (at c = 1e-6 a step of 0.1 rad/s across Ω = 1 otherwise landed on the far side of the 1e-6 rad/s
    # wide peak: 199.7 m claimed as the peak, ± 9e-13, for 1e6)
    branch, x, w, h = None, X0, lo, step
    # the corrector's tolerance, relative to the force, above the round-off of the balance's largest terms there
    # (k·X at a peak of Q times the static response: 2e-10 of the force at c = 1e-6, below which it stalls)
    tol = max(CONTINUATION_TOL, ROUNDOFF_MARGIN * EPS * ref * float(np.max(np.abs(K0))) / bal.scale)
    for end in [*natural, hi]:
        left = max_steps - (branch.steps if branch is not None else 0)
        leg = continuation(bal.residual, x, w, end, jacobian=bal.jacobian, stop=stop, parameter="Ω (rad/s)",
                           path=Arclength(step=h, tol=tol, max_steps=max(left, 1), max_step=5 * step,
                                          scale=scale, chord=CHORD, strict=True))
        branch = leg if branch is None else branch.then(leg)
        if leg.status != "finished" or not leg.lam.size or end == hi:
            break
        x, w, h = leg.x[-1], float(leg.lam[-1]), leg.step or h
    if branch.reason == "max_steps":  # (the last leg's message counts its own steps)
        branch = replace(branch, message=f"{max_steps} steps taken before Ω (rad/s) = {hi:g}")
    if len(branch.lam) == 0:
        raise ConvergenceError(f"forced_response_curve: no periodic response found at Ω = {lo:g} rad/s "
                               f"({branch.message}); try a lower start, a smaller excitation or an explicit "
                               "equilibrium", residual=branch.residual)
    return branch, tol


def _natural_frequencies(K, M, lo, hi):
    """The undamped natural frequencies (rad/s) of K, M strictly within (lo, hi), increasing."""
    try:
        lam = np.linalg.eigvals(np.linalg.solve(M, K))
    except np.linalg.LinAlgError:
        return []
    real = lam[(np.abs(lam.imag) <= 1e-9 * np.abs(lam)) & (lam.real > 0)].real
    return sorted(float(v) for v in np.sqrt(real) if lo < v < hi)


def _peak(bal, run, amp, c, tol):
    """The largest amplitude along the branch, refined between the neighbours of the best point: amplitude
    maximised over the arclength s, each point solved on the hyperplane normal to the tangent there.

    Errors: the truncation estimate, plus (near a flat maximum A(s) ≈ A* − ½|A''| (s − s*)² every s within
    √(2 δA / |A''|) of s* looks alike) the optimiser's resolution from the amplitude's own precision δA — the
    points' residuals carried to A, and its rounding — and the bracket the optimiser stops in; the peak's Ω
    error is that s range times |dΩ/ds|."""
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
            res = cache.get(s)
            if res is None:
                res = cache[s] = newton(lambda y: np.append(bal.residual(y[:-1], y[-1]), t @ (y - y_i) - s),
                                        y_i + s * t, lambda y: np.vstack([bal.jacobian(y[:-1], y[-1]), t]),
                                        tol=tol, max_iter=20)
            return -bal.amplitude(res.x[:-1], c) if res.converged else -amp[i]

        xatol = 1e-10 * max(hi_s - lo_s, 1e-300)
        opt = minimize_scalar(solve, bounds=(lo_s, hi_s), method="bounded", options={"xatol": xatol})
        res = cache.get(opt.x)
        if res is not None and res.converged and -opt.fun >= amp[i]:
            y, A = res.x, -opt.fun
            e = bal.truncation(y[:-1], y[-1], c)
            residual = max(r.residual for r in cache.values() if r.converged)
            dA = _amplitude_precision(bal, y, t, c, A, residual)
            # the optimiser's s: within 2 (√ε |s| + xatol/3) of the maximum of what it saw (scipy's bounded
            # Brent), and every s within √(2 δA / |A''|) of it looks alike; A'', dΩ/ds, d²Ω/ds² by differences
            h = (hi_s - lo_s) / 8
            (_, w1), (A2, w2) = second_derivative(lambda s: np.array([-solve(s), cache[s].x[-1]]), opt.x, h,
                                                  np.array([A, y[-1]]))
            curved = A2 < 0 and cache[opt.x - h].converged and cache[opt.x + h].converged
            ds = 2 * (math.sqrt(EPS) * abs(opt.x) + xatol / 3)
            ds += math.sqrt(2 * dA / -A2) if curved else hi_s - lo_s  # (else: the bracket)
            dw = abs(w1) * ds + 0.5 * abs(w2) * ds**2
            dw = max(dw, _flat(A, e[0] + dA, float(y[-1]), run.lam, amp, i))
            return ResponsePeak(float(y[-1]), float(A), float(e[0] + dA), float(e[1] + dw))
    e = bal.truncation(run.x[i], run.lam[i], c)
    dA = e[0] + bal.precision(run.x[i], run.lam[i], c)
    dw = _flat(amp[i], dA, run.lam[i], run.lam, amp, i) if 0 < i < len(amp) - 1 else 0.0
    return ResponsePeak(float(run.lam[i]), float(amp[i]), dA, e[1] + dw)


def _flat(A, dA, w, lam, amp, i):
    """The Ω (rad/s) within which the amplitude stays within its error dA of the peak A at w: √(2 dA / A''), A''
    from the chords to the neighbours i ± 1 (≤ the top's own on a resonance peak: the safe side, where the
    arclength differences fail, as on a peak 1e-6 rad/s wide whose tangent is almost all X)."""
    chords = [2 * (A - amp[j]) / (w - lam[j]) ** 2 for j in (i - 1, i + 1) if lam[j] != w]
    return math.sqrt(2 * dA / max(chords)) if chords and max(chords) > 0 else 0.0


def _amplitude_precision(bal, y, t, c, A, residual):
    """The amplitude's precision (m or rad) at the solved point y = (X, Ω) of the hyperplane t·y = s: the
    residual ‖R‖_∞ carried to A = |x_c(τ*)| through the bordered Jacobian (|gᵀ [J; t]⁻¹|₁ ‖R‖), plus A's
    rounding."""
    H, n = bal.H, bal.n
    E = sampled_basis(H)[1]
    x_c = E @ y[:-1].reshape(2 * H + 1, n)[:, c]
    j = int(np.argmax(np.abs(x_c)))
    g = np.zeros(y.size)
    g[:-1].reshape(2 * H + 1, n)[:, c] = np.sign(x_c[j]) * E[j]
    z = np.linalg.lstsq(np.vstack([bal.jacobian(y[:-1], y[-1]), t]).T, g, rcond=None)[0]
    return float(np.sum(np.abs(z))) * residual + EPS * (2 * H + 1) * A
