"""Periodic orbits and their Floquet multipliers: :func:`periodic_orbit`, :func:`floquet` → :class:`PeriodicOrbit`.

The orbit is found by shooting on the configuration Lie group (:mod:`.shooting`: single, or multiple where a
single one is ill-conditioned); its monodromy Φ(T) comes from the variational equations integrated with the
state in the tangent space (the time layer's state transition), never from differences of whole flows. The
Floquet multipliers μ are the eigenvalues of Φ(T), each with an uncertainty from Φ's error estimate (first-
order eigenvalue perturbation with the condition numbers of the left and right eigenvectors; for clustered or
defective multipliers, as the double 1 of a conservative orbit, the spread of the eigenvalues of Φ + E over
perturbations E of the size of Φ's error). Liouville's identity det Φ(T) = exp ∫₀ᵀ tr A dt is reported as a check.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike

from ..._check import integer, scalar
from ..._format import duration, html_table, number, summary, table
from ...errors import ConvergenceError, ModelError
from ...model.derivatives import linear_terms
from ...model.forcing import forcing
from ...simulation.flow import Flow
from ...simulation.trajectory import SimulationError
from ...solvers.tracking import assign
from .shooting import (
    MAX_SEGMENTS,
    RCOND,
    SCALE_RTOL,
    Shooting,
    check_span,
    conservative,
    damping_only,
    energy_roundoff,
    fastest_frequency,
    first_return,
    flow_scales,
    free_indices,
    growth_segments,
    motion_scales,
    resolvable_start,
    start_sizes,
    wrapped,
)

__all__ = ["PeriodicOrbit", "Liouville", "periodic_orbit", "floquet"]
TOL = 1e-10  # default closing tolerance (scaled residual: rad, length scales, velocities per 2π/T)
RTOL = 1e-11  # default relative tolerance of the flows (DOP853)
PERIOD_RTOL = 1e-9  # a forced scene's period: how close (relative) to a multiple of the forcing's
POINTS = 128  # outputs per period of the orbit's trajectory (equally spaced: the Liouville quadrature)
STEP_RESOLUTION = 0.5  # steps of the flows at most this / ω (ω: the start's fastest linear frequency or 2π/T)
SAMPLES = 8  # perturbations of Φ that measure the spread of clustered multipliers
SPREAD_FACTOR = 3.0  # the spread's safety factor
ISOLATED = 0.05  # κ·error below this share of the gap to the nearest other multiplier: first order holds (a Jordan
# pair split by the error itself, a conservative orbit's double 1, sits at about 1/4 of its own gap)
MIN_ENERGY_RATIO = 10.0  # a conservative orbit's motion energy must exceed this × the energy's round-off
COVER_GAP = 1e-6  # a return to the start at T/k closer than this (scaled) makes T/k the orbit's period
UNDETERMINED = 1e-6  # the period's share of a singular direction of the shooting Jacobian that leaves it open


class Liouville(NamedTuple):
    """Liouville's identity det Φ(T) = exp ∫₀ᵀ tr A dt: ``det`` (of the monodromy), ``expected`` (1 for a
    conservative scene; else exp(−∫ tr(M⁻¹ C) dt) along the orbit by the trapezoidal rule, spectrally accurate
    for a periodic integrand), ``error`` (the sum of both sides' estimated errors)."""

    det: float
    expected: float
    error: float


@dataclass(frozen=True, eq=False)
class PeriodicOrbit:
    """A periodic orbit and its Floquet multipliers (see :func:`periodic_orbit`).

    ``period`` T (s) and ``period_error`` (s); ``q0``, ``v0`` the state at ``t0`` (s); ``trajectory`` one
    period (a :class:`~vibdyn.simulation.trajectory.Trajectory`, equally spaced outputs; its
    ``state_transition`` the whole monodromy in the tree's coordinates); ``coordinates`` the free coordinates
    (the driven ones are given); ``monodromy`` Φ(T) (2n × 2n, n free coordinates: tangent displacements then
    velocities, in the tangent space at q0) and ``monodromy_error`` (bound on the 2-norm of its error);
    ``multipliers`` μ (complex, by decreasing modulus) and ``multiplier_error`` (uncertainty of each μ, hence
    of each |μ|); ``exponents`` log μ / T (1/s, complex); ``stable``: no |μ| exceeds 1 by more than its
    uncertainty (bounded in the linear sense); ``stability`` the verdict: "unstable", "stable" (every
    multiplier but the ``trivial`` one — the flow's own 1 of an autonomous orbit — inside the unit circle
    beyond its uncertainty: an attracting orbit) or "neutral within the error" (the largest such |μ| equals 1 within its
    uncertainty: conservative orbits, a parametric oscillator inside its stable region); ``liouville`` (det Φ
    against exp ∫ tr A dt); ``error`` the largest of the closing residual and the flows' estimated error (m or
    rad, tangent space), ``velocity_error`` (m/s or rad/s) likewise; ``residual`` the closing residual
    (scaled: rad, length scales, velocities per 2π/T); ``segments`` (1: single shooting), ``iterations``,
    ``autonomous`` (the period was an unknown), ``energy_fixed`` (a conservative orbit: the start's energy was
    kept), ``elapsed`` (s).
    """

    system: Any = field(repr=False)
    period: float
    period_error: float
    t0: float
    q0: np.ndarray
    v0: np.ndarray
    trajectory: Any = field(repr=False)
    coordinates: tuple
    monodromy: np.ndarray = field(repr=False)
    monodromy_error: float
    multipliers: np.ndarray
    multiplier_error: np.ndarray
    trivial: int
    liouville: Liouville
    error: float
    velocity_error: float
    residual: float
    segments: int
    iterations: int
    autonomous: bool
    energy_fixed: bool
    elapsed: float

    @property
    def omega(self) -> float:
        """2π/T (rad/s): the orbit's fundamental angular frequency."""
        return 2 * math.pi / self.period

    @property
    def frequency_hz(self) -> float:
        """1/T (Hz)."""
        return 1.0 / self.period

    @property
    def exponents(self) -> np.ndarray:
        """Floquet exponents log μ / T (1/s, complex; the imaginary part is defined modulo 2π/T)."""
        return np.log(self.multipliers.astype(complex)) / self.period

    @property
    def stable(self) -> bool:
        """No multiplier's modulus exceeds 1 by more than its uncertainty (``multiplier_error``)."""
        return bool(np.all(np.abs(self.multipliers) - 1.0 <= self.multiplier_error))

    @property
    def stability(self) -> str:
        """"unstable", "stable" or "neutral within the error" (see the class docstring)."""
        if not self.stable:
            return "unstable"
        mod, err = np.abs(self.multipliers), self.multiplier_error
        others = np.argsort(np.abs(self.multipliers - 1.0), kind="stable")[self.trivial:]
        return "stable" if np.all(mod[others] < 1.0 - err[others]) else "neutral within the error"

    @property
    def growth(self) -> tuple[float, float]:
        """(largest |μ| − 1, its uncertainty): how far the orbit is from the stability boundary."""
        k = int(np.argmax(np.abs(self.multipliers)))
        return float(abs(self.multipliers[k]) - 1.0), float(self.multiplier_error[k])

    def to_dict(self) -> dict:
        """Plain data (JSON-ready), SI units, complex numbers as [re, im]."""
        return {"period_s": self.period, "period_error_s": self.period_error, "omega_rad_s": self.omega,
                "frequency_hz": self.frequency_hz, "t0_s": self.t0, "q0": self.q0.tolist(), "v0": self.v0.tolist(),
                "coordinates": list(self.coordinates), "monodromy": self.monodromy.tolist(),
                "monodromy_error": self.monodromy_error,
                "multipliers": [[z.real, z.imag] for z in self.multipliers],
                "multiplier_error": self.multiplier_error.tolist(),
                "exponents_1_s": [[z.real, z.imag] for z in self.exponents], "stable": self.stable,
                "stability": self.stability, "liouville": dict(zip(Liouville._fields, self.liouville)),
                "error_estimate": self.error,
                "velocity_error": self.velocity_error, "residual": self.residual, "segments": self.segments,
                "iterations": self.iterations, "autonomous": self.autonomous, "energy_fixed": self.energy_fixed,
                "elapsed_s": self.elapsed}

    def _head(self):
        shooting = "single shooting" if self.segments == 1 else f"multiple shooting ({self.segments} segments)"
        return (f"periodic orbit: T = {number(self.period, 's', digits=10)} ± {self.period_error:.1e} s "
                f"(ω = 2π/T = {number(self.omega, 'rad/s')}, {number(self.frequency_hz, 'Hz')}), {self.stability}; "
                f"closing error {self.error:.1e}, {shooting}, {self.iterations} iterations, "
                f"{duration(self.elapsed)}")

    def _rows(self):
        return [[str(k + 1), number(abs(mu), digits=10), number(np.angle(mu), "rad", digits=6), f"{e:.1e}",
                 number(x.real, "1/s", digits=6)]
                for k, (mu, e, x) in enumerate(zip(self.multipliers, self.multiplier_error, self.exponents))]

    def __str__(self):
        li = self.liouville
        lines = [self._head(), "  Floquet multipliers:"]
        lines += ["    " + line for line in table(["μ", "|μ|", "arg μ", "± (|μ| and μ)", "Re exponent"], self._rows())]
        lines.append(f"  Liouville: det Φ(T) = {li.det:.10g}, exp ∫ tr A dt = {li.expected:.10g} (± {li.error:.1e})")
        sysm = self.system
        dq = sysm.difference(sysm.neutral(), self.q0)
        rows = [[c, number(dq[i], u, digits=10), number(self.v0[i], f"{u}/s", digits=10)]
                for i, (c, u) in enumerate(zip(sysm.coordinates, sysm.units))]
        lines.append(f"  start at t0 = {number(self.t0, 's')}:")
        lines += ["    " + line for line in table(["coordinate", "offset", "velocity"], rows)]
        return "\n".join(lines)

    def __repr__(self):
        g, e = self.growth
        return summary("PeriodicOrbit", f"T = {number(self.period, 's', digits=10)}", self.stability,
                       f"max |μ| − 1 = {g:.2e} ± {e:.1e}", f"{self.segments} segment{'s' if self.segments > 1 else ''}",
                       duration(self.elapsed))

    def _repr_html_(self):
        return html_table(self._head(), ["μ", "|μ|", "arg μ", "±", "Re exponent"], self._rows())


def periodic_orbit(system: Any, q0: Any = None, v0: ArrayLike | None = None, period: float | None = None,
                   t0: float = 0.0, *,
                   segments: int | None = None, phase: str | None = None, tol: float = TOL, rtol: float = RTOL,
                   max_iter: int = 20, points: int = POINTS) -> PeriodicOrbit:
    """The periodic orbit through (or near) the state (q0, v0) at ``t0`` (s), and its Floquet multipliers.

    Autonomous scenes: the period T (s) is an unknown, ``period`` its starting guess (None: the time the motion
    takes to come back near its start); a phase condition fixes the orbit's start — its tangent displacement
    from (q0, v0) orthogonal to the flow there, or with ``phase`` = a coordinate's name that coordinate's
    velocity is zero at t0 (a turning point). A conservative scene's orbits form families in the energy: the
    start's energy is kept (the orbit through the start's energy level; a family left by symmetries is solved
    for the nearest member by least-squares steps). Scenes with time-dependent forces, moving supports or
    drives: ``period`` is required (the forcing's, or a whole multiple of it: see :func:`forcing_multiple`), and t0
    places the start in it; driven coordinates take their drives' values.

    Shooting (:mod:`vibdyn.analysis.nonlinear.shooting`) with ``segments`` nodes along the orbit (None:
    single shooting unless a first run over the period amplifies errors by more than 50, then enough segments
    for each to amplify them by about 50; an unstable orbit whose single run leaves it needs nodes near the
    orbit: give q0 (m × nq) and v0 (m × nv), one row per node at t0 + i·T/m). Newton stops at a closing
    residual ``tol`` (scaled: rad, length scales, velocities per 2π/T); flows by DOP853 at ``rtol``; the
    final flows are integrated again with an error estimate (rerun at rtol/100) at ``points`` equally
    spaced outputs per period.

    Raises ModelError for bad input (a period ≤ 0 or not finite, a scene with loops, ...), ConvergenceError
    (with the residual reached and what to try) when the orbit is not found.
    """
    return orbit_from(system, q0, v0, period, t0, segments=segments, phase=phase, tol=tol, rtol=rtol,
                      max_iter=max_iter, points=points)


def orbit_from(system: Any, q0: Any, v0: ArrayLike | None, period: float | None, t0: float = 0.0, *,
               segments: int | None = None, phase: str | None = None, tol: float = TOL, rtol: float = RTOL,
               max_iter: int = 20, points: int = POINTS, first: Any = None) -> PeriodicOrbit:
    """:func:`periodic_orbit`, with ``first`` a flow over one period from (q0, v0) with the variational equations at
    ``rtol`` that the caller made already (a backbone's request, solved there: a FlowResult of every step), taken
    as the first run instead of integrating it again (None: integrated here)."""
    start = time.perf_counter()
    what = "periodic_orbit"
    system.reduction.require("periodic orbits", what)
    if system.nv == 0:
        raise ModelError(f"{what}: the scene has no coordinates: nothing moves")
    t0 = scalar(t0, f"{what}: t0 (s)")
    if period is not None:
        period = scalar(period, f"{what}: period (s)", positive=True)
    tol = scalar(tol, f"{what}: tol", positive=True)
    rtol = scalar(rtol, f"{what}: rtol", positive=True)
    max_iter = integer(max_iter, f"{what}: max_iter", minimum=1)
    points = integer(points, f"{what}: points", minimum=4, maximum=100000)
    free = free_indices(system)
    if free.size == 0:
        raise ModelError(f"{what}: every coordinate is driven: nothing is free to be periodic")
    autonomous = not system.depends_on_time
    if not autonomous and period is None:
        raise ModelError(f"{what}: the scene depends on time (time-dependent forces, moving supports or drives): "
                         "give its period (s)")
    if not autonomous:
        period = forcing_multiple(system, period, what)
    if phase is not None and not autonomous:
        raise ModelError(f"{what}: phase applies to autonomous scenes only (here the forcing fixes the phase)")
    damping = damping_only(system) if autonomous and not conservative(system) else None
    if damping is not None and np.all(damping[free] > 0):
        raise ModelError(f"{what}: the scene is autonomous and every coordinate is damped (its only non-conservative "
                         f"forces are dampers): every motion loses energy, so it has no periodic orbit other than "
                         f"rest at an equilibrium; {_DAMPED_HINT}")
    nodes = _start_nodes(system, q0, v0, t0, segments, what)
    if segments is not None:
        segments = integer(segments, f"{what}: segments", minimum=1, maximum=MAX_SEGMENTS)
        if len(nodes) not in (1, segments):
            raise ModelError(f"{what}: {len(nodes)} starting nodes given for segments = {segments}")
    q_start, v_start = nodes[0]
    resolvable_start(system, q_start, start_sizes(system, q_start, v_start, t0, free), free, tol, what)
    if period is not None:
        check_span(system, q_start, v_start, t0, free, period, autonomous, what)
    omega = 2 * math.pi / period if period is not None else _omega_guess(system, q_start, v_start, t0, free)
    returned = None
    if autonomous and period is None:
        period, returned = first_return(system, q_start, v_start, t0, omega, rtol)
        omega = 2 * math.pi / period
    assert period is not None  # (given, or found from the first return)
    cons = autonomous and conservative(system)
    nodes = Shooting.impose(system, nodes, t0, period)
    if returned is not None and not (np.array_equal(nodes[0][0], q_start) and np.array_equal(nodes[0][1], v_start)):
        returned = None  # (a run from another start)
    q_start, v_start = nodes[0]
    # a first run over the first segment: the coordinates' scales, the energy scale and (one node) the growth
    k = len(nodes)
    omega_v = max(_omega_guess(system, q_start, v_start, t0, free), 2 * math.pi / period)
    max_step = STEP_RESOLUTION / omega_v
    span = period * (1 if k == 1 else 1.0 / k)
    try:
        if first is None or k != 1:
            # the flows' tolerances are rtol of the motion's size, measured first by a loose run (or the run that
            # found the period: it covers one from this start)
            if returned is None or k != 1:
                returned = Flow(system, q_start, v_start, rtol=max(rtol, SCALE_RTOL), max_step=max_step)(
                    q_start, v_start, t0, t0 + span)
            fs = flow_scales(system, returned, omega, autonomous)
            # (before flows at rtol of a motion the round-off cannot resolve: their steps would shrink to nothing)
            resolvable_start(system, q_start, motion_scales(system, returned, omega, relative=autonomous), free, tol,
                             what, motion=True)
            trial = Shooting(system, t0, span, False, 1, omega, rtol, max_step=max_step, flow_scales=fs)
            first = trial.flows(trial.pack([nodes[0]]), full=True)[0]
            kinetic = float(np.max(first.kinetic))
        else:
            fs = flow_scales(system, first, omega, autonomous)
            resolvable_start(system, q_start, motion_scales(system, first, omega, relative=autonomous), free, tol, what,
                             motion=True)
            kinetic = max(system.energy(q, v, t).kinetic for q, v, t in zip(first.q, first.v, first.t)) if cons else 0.0
    except SimulationError as e:
        raise ConvergenceError(f"{what}: the motion from the start cannot be integrated over a period ({e}): "
                               "start closer to the orbit, or give nodes along it (q0, v0 one row each)",
                               best=nodes) from e
    scales = motion_scales(system, first, omega, relative=autonomous)
    phase_spec = _phase(system, q_start, v_start, t0, omega, free, phase, scales, what) if autonomous else None
    energy = _energy_condition(system, q_start, v_start, t0, kinetic, scales, free, tol, what) if cons else None
    m = segments if segments is not None else k if k > 1 else growth_segments(first.state_transition)
    shoot = Shooting(system, t0, period, autonomous, m, omega, rtol, phase_spec, energy, scales, max_step,
                     flow_scales=fs)
    if m > 1 and k == 1:  # nodes along a first run from the start
        run = Flow(system, q_start, v_start, rtol=rtol)(q_start, v_start, t0, t0 + period,
                                                       t_eval=[shoot.time(i, period) for i in range(m)])
        nodes = Shooting.impose(system, list(zip(run.q, run.v)), t0, period)
    x0 = shoot.pack(nodes, period)
    if m == 1 and k == 1:
        shoot.seed(x0, [first])
    x, residual, iterations = shoot.solve(x0, tol, max_iter)
    if autonomous:
        k = _cover(system, shoot, x, rtol)
        if k > 1:  # the orbit found is its least one followed k times over: that one, with its frequency
            (q_k, v_k), T = shoot.unpack(x)[0][0], shoot.unpack(x)[1]
            return orbit_from(system, q_k, v_k, T / k, t0, phase=phase, tol=tol, rtol=rtol, max_iter=max_iter,
                              points=points)
    orbit = _result(system, shoot, x, residual, iterations, points, cons, start, tol)
    if autonomous:
        _moves(system, shoot, orbit, tol, damping is not None, what)
        if not math.isfinite(orbit.period_error):
            raise ConvergenceError(f"{what}: the shooting equations do not determine the period there (their "
                                   "Jacobian is singular along a direction that changes it): start elsewhere on "
                                   "the orbit, or give phase (a coordinate whose velocity is zero at the start)",
                                   residual=orbit.residual, best=[(orbit.q0, orbit.v0)])
    return orbit


def _cover(system, shoot, x, rtol, most: int = 32) -> int:
    """How many times over the autonomous orbit x follows its least one: the largest k ≤ ``most`` for which the flow
    from the start returns to it at T/k (within COVER_GAP of the motion's scales), else 1. Shooting closes a
    k-fold orbit as well as the least one (a continuation's step or a period guess near kT lands on it)."""
    nodes, T = shoot.unpack(x)
    q0, v0 = nodes[0]
    times = [shoot.t0 + T / k for k in range(most, 1, -1)]
    try:
        run = Flow(system, q0, v0, rtol=rtol, max_step=STEP_RESOLUTION / (2 * math.pi / T))(
            q0, v0, shoot.t0, times[-1], t_eval=times)
    except SimulationError:
        return 1
    gaps = [float(np.abs(np.concatenate([wrapped(system.difference(q0, q)[shoot.free], shoot.wrap),
                                         (v - v0)[shoot.free]]) / shoot.node_scale).max())
            for q, v in zip(run.q, run.v)]
    if max(gaps) <= 1e3 * COVER_GAP:  # (no motion to speak of: an orbit settled onto rest, said by the caller)
        return 1
    return next((k for k, gap in zip(range(most, 1, -1), gaps) if gap <= COVER_GAP), 1)


def floquet(system: Any, period: float, q0: Any = None, v0: ArrayLike | None = None, t0: float = 0.0,
            **kwargs: Any) -> PeriodicOrbit:
    """Floquet multipliers of the orbit of period ``period`` (s) through (q0, v0) at ``t0`` (s), converged
    first if it is not yet periodic (an autonomous orbit's period is then refined from ``period``): the same
    result as :func:`periodic_orbit` (keywords as there). A scene forced in time: ``period`` must be a whole
    multiple of the forcing's (:func:`vibdyn.model.forcing.forcing`; callables of time declare none)."""
    if period is not None:
        period = scalar(period, "floquet: period (s)", positive=True)
    if system.depends_on_time:
        period = forcing_multiple(system, period, "floquet")
    if period is None:
        raise ModelError("floquet: period (s) is required (periodic_orbit finds it for an autonomous scene)")
    return periodic_orbit(system, q0, v0, period, t0, **kwargs)


def forcing_multiple(system: Any, period: float | None, what: str) -> float | None:
    """``period`` (s) of a scene forced in time, checked against the forcing's common period T_f: the whole
    multiple k·T_f it equals within PERIOD_RTOL (returned exact); as given where the forcing declares no
    frequency (callables of time). ModelError, naming both periods, for any other period (None included, where
    T_f is known), and where the forcing's frequencies are not commensurate (quasi-periodic: no period)."""
    f = forcing(system)
    if not f.commensurate:
        raise ModelError(f"{what}: the scene's forcing frequencies are not commensurate ({f.describe()}): its "
                         "motion is quasi-periodic, with no period")
    if f.period is None:
        return period
    part = "" if f.complete else " harmonic"
    if period is None:
        raise ModelError(f"{what}: period (s) is required: the scene's{part} forcing period "
                         f"{number(f.period, 's', digits=10)} ({f.describe()}) or a multiple of it")
    k = round(period / f.period)
    if k >= 1 and abs(period - k * f.period) <= PERIOD_RTOL * period:
        return k * f.period
    raise ModelError(f"{what}: period {number(period, 's', digits=10)} is not a whole multiple of the scene's"
                     f"{part} forcing period {number(f.period, 's', digits=10)} ({f.describe()}): give "
                     f"{number(f.period, 's', digits=10)} or a multiple of it")


# ---------------------------------------------------------------------------------------------- set-up
def _start_nodes(system, q0, v0, t0, segments, what):
    """[(q, v)] at the nodes given (one row each; driven coordinates are imposed by :meth:`Shooting.impose`)."""
    if hasattr(q0, "q") and hasattr(q0, "v"):  # an equilibrium or operating point
        q0, v0 = q0.q, q0.v if v0 is None else v0
    if q0 is None:
        q0 = system.neutral()
    qa = np.asarray(q0, dtype=float) if not isinstance(q0, dict) else None
    if qa is not None and qa.ndim == 2:
        va = np.zeros((len(qa), system.nv)) if v0 is None else np.asarray(v0, dtype=float)
        if va.shape != (len(qa), system.nv):
            raise ModelError(f"{what}: {len(qa)} starting nodes in q0 need v0 of shape ({len(qa)}, {system.nv}), "
                             f"got {va.shape}")
        nodes = [(system.check_configuration(q, f"{what}: q0[{i}]"), system.check_velocity(v, f"{what}: v0[{i}]"))
                 for i, (q, v) in enumerate(zip(qa, va))]
    else:
        q = system.check_configuration(q0, f"{what}: q0")
        nodes = [(q, np.zeros(system.nv) if v0 is None else system.check_velocity(v0, f"{what}: v0"))]
    return nodes


def _omega_guess(system, q, v, t, free):
    """A frequency scale (rad/s) at a start: the largest of √|eig(M⁻¹K)| there and the angles' speeds (rad/s: a
    turning pivot's); 1 if neither is positive. A slider's speed is no frequency: over the scene's length scale
    (1 mm for a slider at the origin) it made the flows' steps hundreds of times too short."""
    w = fastest_frequency(system, q, v, t, free)
    return w if w > 0 else 1.0


def _phase(system, q, v, t, omega, free, phase, scales, what):
    if phase is not None:
        if not isinstance(phase, str):
            raise ModelError(f"{what}: phase must be a coordinate's name, got {phase!r}")
        i = system.coordinate_index(phase)
        where = np.flatnonzero(free == i)
        if not where.size:
            raise ModelError(f"{what}: phase: coordinate '{phase}' is driven, not free")
        return ("velocity", int(where[0]))
    s = np.asarray(scales, dtype=float)[free]
    a = system.accelerations(q, v, t)
    u = np.concatenate([v[free] / s, a[free] / (s * omega)])
    norm = float(np.linalg.norm(u))
    if not norm > 1e-12:
        raise ModelError(f"{what}: the start (q0, v0) is an equilibrium (no flow there): start away from it, e.g. "
                         "displaced along a mode")
    return ("flow", np.array(q), np.array(v), u / norm)


def _energy_condition(system, q, v, t, moving, scales, free, tol, what):
    """(E_start J, the energy row's scale J) of a conservative orbit: ``moving``, the largest kinetic energy (J) of the
    first run (the total's own variation across the orbit: gravity and a spring holding it against each other trade
    far more), or the energy's round-off / tol where that is larger (the row then holds E to its round-off).
    ModelError where the motion's energy is within MIN_ENERGY_RATIO × the round-off: the start is too close to
    rest for its orbit to be told from its neighbours (the amplitude below which this happens is named)."""
    noise = energy_roundoff(system, q, v, t)
    if not moving > MIN_ENERGY_RATIO * noise:
        cs = np.asarray(system.coordinate_scales, dtype=float)[free]
        k = int(np.argmax(np.asarray(scales, dtype=float)[free] / cs))
        i = int(free[k])
        need = float(scales[i]) * math.sqrt(MIN_ENERGY_RATIO * noise / max(moving, 1e-300))
        raise ModelError(
            f"{what}: the start is too close to rest: the energy of its motion ({moving:.2g} J) is within "
            f"{MIN_ENERGY_RATIO:g} times the round-off of the scene's energy ({noise:.2g} J), so its orbit cannot be "
            f"told from its neighbours; start from a larger amplitude (above about {need:.1g} "
            f"{system.units[i]} of '{system.coordinates[i]}'), or take the linear modes' periods 2π/ω "
            "(System.linearize(...).modes()), which are the small orbits' limit")
    return system.energy(q, v, t).total, max(moving, noise / tol)


# ---------------------------------------------------------------------------------------------- result
_DAMPED_HINT = ("force it (a time-dependent force or support; then periodic_orbit or floquet with the forcing's "
                "period), or use backbone for the orbits of its undamped part")


def _moves(system, shoot, orbit, tol, damped, what):
    """Refuse an autonomous orbit that converged onto rest: its motion (scaled: |Δq| from q0, |v|/ω) within
    100·tol plus 10× its own error. ModelError where the scene's only non-conservative forces are dampers (no
    other periodic orbit through the start exists), ConvergenceError otherwise."""
    s = shoot.s
    traj = orbit.trajectory
    dq = max(float(np.abs(system.difference(orbit.q0, q)[shoot.free] / s).max()) for q in traj.q)
    dv = float(np.abs(traj.v[:, shoot.free] / (s * shoot.omega)).max())
    noise = 100 * tol + 10 * max(float(np.max(orbit.error / s)),
                                 float(np.max(orbit.velocity_error / (s * shoot.omega))))
    if max(dq, dv) > noise:
        return
    if damped:
        raise ModelError(f"{what}: the motion from the start settles to rest, not to a periodic orbit: the scene is "
                         "autonomous and its only non-conservative forces are dampers, which take energy from every "
                         "motion that moves them, so no periodic orbit other than rest at an equilibrium exists "
                         "there; " + _DAMPED_HINT)
    raise ConvergenceError(f"{what}: the shooting converged onto rest (an equilibrium), not a periodic orbit: start "
                           "further from the equilibrium, or closer to the orbit", residual=orbit.residual,
                           best=[(orbit.q0, orbit.v0)])


def _result(system, shoot, x, residual, iterations, points, cons, start, tol):
    m, n = shoot.m, shoot.n
    per = max(2, 2 * math.ceil(points / (2 * m)))  # outputs per segment (even: the half-grid quadrature)
    x, residual, iterations, deviation, runs, coarse, (mono_before, mono_after) = _polish(shoot, x, residual,
                                                                                         iterations, per, tol)
    nodes, T = shoot.unpack(x)
    taken = runs is not None
    if not taken:  # (the polish step not taken: the error estimate's runs from x)
        runs = shoot.flows(x, error="rerun", points=per, refine=2)
    # Φ's own integration error, per segment (an entry's size × √(2n): a typical perturbation's 2-norm, not the worst)
    own = [float(r.state_transition_error) * math.sqrt(2 * n) for r in runs]
    # the variational equations' own error: halving the largest step (DOP853, order 8: counted as if order 4);
    # against the flows before the polish step where it was taken (their difference also holds the step's own
    # change of Φ, the deviation: a larger estimate, never a smaller one)
    runs = [replace(r, state_transition_error=max(float(r.state_transition_error), float(
        np.abs(np.asarray(r.state_transition) - np.asarray(c.state_transition)).max()) / 15.0))
        for r, c in zip(runs, coarse)]
    closing = shoot.closing(nodes, runs)
    res_q = max(float(np.abs(dq).max(initial=0.0)) for dq, _ in closing)
    res_v = max(float(np.abs(dv).max(initial=0.0)) for _, dv in closing)
    int_q = max(float(r.q_error.max()) for r in runs)
    int_v = max(float(r.v_error.max()) for r in runs)
    shoot.check_transitions(nodes, T, runs, np.concatenate([np.full(n, int_q), np.full(n, int_v)]))
    maps = shoot.segment_maps(nodes, runs)
    mono, mono_err = _product([P for P, _, _ in maps], [r.state_transition_error * P.shape[0] for r, (P, _, _) in
                                                         zip(runs, maps)])
    mono_err += deviation
    J = shoot.jacobian_of(nodes, T, runs)
    r = shoot.residual_of(nodes, runs)
    extra = np.zeros(shoot.extra)  # the phase row is exact; the energy row rounds off (both E and its target)
    if shoot.energy is not None:
        extra[-1] = 2 * energy_roundoff(system, nodes[0][0], nodes[0][1], shoot.t0) / shoot.energy[1]
    e = np.concatenate([np.concatenate([np.full(n, int_q), np.full(n, int_v)]) / shoot.node_scale
                        for _ in range(m)] + [extra])
    period_error = 0.0
    if shoot.free_period:  # (a direction the pseudo-inverse cuts that moves T leaves T undetermined: inf)
        U, sv, Vt = np.linalg.svd(J, full_matrices=False)
        keep = sv > RCOND * sv[0]
        Jp = (Vt[keep].T / sv[keep]) @ U[:, keep].T
        period_error = float(np.abs(Jp[-1]) @ (np.abs(r) + e)) * shoot.unknown_scale[-1]
        if float(np.abs(Vt[~keep, -1]).max(initial=0.0)) > UNDETERMINED:
            period_error = math.inf
    # the multipliers' moves between Φ and the monodromies computed otherwise: the Newton's coarser flows from x
    # (the steps' halving over 15, or with the polish step taken, that step's change too) and the polish step's
    others = [] if mono_before is None else [(mono_before, 1.0 if taken else 15.0)]
    if not taken and mono_after is not None:
        others.append((mono_after, 1.0))
    mu, mu_err = multipliers(mono, mono_err, _product([P for P, _, _ in maps], own)[1], others)
    trivial = 1 if shoot.free_period else 0  # the flow's own multiplier (a conservative one's second is neutral)
    traj = runs[0] if m == 1 else _join(runs)
    full = _product([np.asarray(rr.state_transition) for rr in runs], [0.0] * m)[0]
    traj = replace(traj, state_transition=full, state_transition_error=mono_err)
    li = _liouville(system, shoot, traj, mono, mono_err, cons, T)
    q0, v0 = nodes[0]
    coords = tuple(system.coordinates[i] for i in shoot.free)
    return PeriodicOrbit(system, float(T), period_error, shoot.t0, np.array(q0), np.array(v0), traj, coords, mono,
                         mono_err, mu, mu_err, trivial, li, max(res_q, int_q), max(res_v, int_v), float(residual), m,
                         iterations, shoot.free_period, cons, time.perf_counter() - start)


def _polish(shoot, x, residual, iterations, per, tol):
    """One more Newton step from the converged x, taken if it lowers the residual or keeps it within ``tol``:
    (x, residual, iterations, deviation, runs, coarse, monodromies) with ``deviation`` the 2-norm of the change of
    the monodromy across that step — the monodromy's error from the orbit's own closing error (Φ at a point a
    residual away from the orbit), which decides the split of a defective multiplier such as the double 1 of a
    conservative orbit. The flows from the step's end are the error estimate's (``per`` outputs a segment, steps
    halved, a rerun at tolerances / 100): ``runs`` those where the step is taken (else None: the caller makes them
    from x), ``coarse`` the Newton's flows from x (the halved steps' comparison); ``monodromies`` (Φ from x by
    those, Φ from the step's end or None)."""
    nodes, T = shoot.unpack(x)
    before = shoot.flows(x)
    r = shoot.residual_of(nodes, before)
    J = shoot.jacobian_of(nodes, T, before)
    x2 = shoot.retract(x, np.linalg.lstsq(J, -r, rcond=RCOND)[0])
    nodes2, T2 = shoot.unpack(x2)
    after = None
    if T2 > 0:
        try:
            after = shoot.flows(x2, error="rerun", points=per, refine=2)
        except SimulationError:
            pass
    r2 = None if after is None else shoot.residual_of(nodes2, after)
    if r2 is None or not np.all(np.isfinite(r2)):
        shoot.seed(x, before)  # (x's flows are the ones wanted next, not integrated again)
        return x, residual, iterations, 0.0, None, before, (None, None)
    mono = [_product([P for P, _, _ in shoot.segment_maps(*nr)], [0.0] * shoot.m)[0]
            for nr in ((nodes, before), (nodes2, after))]
    deviation = float(np.linalg.norm(mono[1] - mono[0], 2))
    res2 = float(np.abs(r2).max())
    if res2 < float(np.abs(r).max()) or res2 <= tol:
        return x2, res2, iterations + 1, deviation, after, before, tuple(mono)
    shoot.seed(x, before)
    return x, residual, iterations, deviation, None, before, tuple(mono)


def _product(mats, errs):
    """(P_{m−1} ⋯ P_0, bound on the 2-norm of its error) from each factor's error bound (2-norm)."""
    m = len(mats)
    prod = mats[0]
    for P in mats[1:]:
        prod = P @ prod
    err = 0.0
    for i in range(m):
        left = np.eye(len(prod))
        for P in mats[i + 1:]:
            left = P @ left
        right = np.eye(len(prod))
        for P in mats[:i]:
            right = P @ right
        err += np.linalg.norm(left, 2) * errs[i] * np.linalg.norm(right, 2)
    return prod, float(err)


def multipliers(mono, error, own=None, others=()):
    """(μ by decreasing modulus, the uncertainty of each) for a monodromy whose error has 2-norm ≤ ``error``:
    κ_k · error (κ_k = ‖x‖‖y‖/|yᴴx| from the right and left eigenvectors) where that is below ISOLATED of the
    distance to the nearest other multiplier; for clustered or defective ones (first order fails there: κ · error
    is then no bound), the largest move of μ_k over perturbations of Φ of 2-norm ``error``, times SPREAD_FACTOR,
    plus half the gap to the nearest other (a split Jordan pair's truth lies between its members). With ``own``
    (the 2-norm of the part of Φ's error known only by its size: the integration's own estimate) and ``others``
    (pairs (Φ', d): monodromies computed otherwise, whose difference from Φ over d estimates the rest of its
    error), an isolated μ_k's is κ_k · own plus its moves |μ_k(Φ') − μ_k| / d: the multipliers' own differences
    keep the cancellations a bound on ‖Φ' − Φ‖ loses (κ ‖E‖ overstated a forced orbit's by 100 ×)."""
    lam, vl, vr = sla.eig(mono, left=True, right=True)
    order = np.argsort(-np.abs(lam), kind="stable")
    lam, vl, vr = lam[order], vl[:, order], vr[:, order]
    dot = np.abs(np.einsum("ij,ij->j", vl.conj(), vr))
    kappa = np.linalg.norm(vl, axis=0) * np.linalg.norm(vr, axis=0) / np.maximum(dot, 1e-300)
    first = kappa * error
    gap = np.array([np.abs(np.delete(lam, k) - lam[k]).min(initial=np.inf) for k in range(lam.size)])
    bad = ~(first < ISOLATED * gap)
    err = first.copy()
    if own is not None:
        err = kappa * own
        for other, divisor in others:
            moved = np.linalg.eigvals(other)
            rows, cols = assign(np.abs(lam[:, None] - moved[None, :]))
            err[rows] += np.abs(moved[cols] - lam[rows]) / divisor
        err = np.minimum(err, first)  # (never above the bound)
    if bad.any() and error > 0:
        rng = np.random.default_rng(0)
        spread = np.zeros(lam.size)
        for _ in range(SAMPLES):
            E = rng.standard_normal(mono.shape)
            E *= error / np.linalg.norm(E, 2)
            moved = np.linalg.eigvals(mono + E)
            rows, cols = assign(np.abs(lam[:, None] - moved[None, :]))
            spread[rows] = np.maximum(spread[rows], np.abs(moved[cols] - lam[rows]))
        # (κ·error is no bound where first order fails: a Jordan pair's moves go as √error, and the pair computed is
        # already split by Φ's error, its truth anywhere between its members: half the gap more)
        err[bad] = SPREAD_FACTOR * spread[bad] + 0.5 * gap[bad]
        # a cluster shares one uncertainty: its members move together
        for k in np.flatnonzero(bad):
            near = bad & (np.abs(lam - lam[k]) <= err[k] + err)
            err[near] = err[near].max()
    err = np.where(np.isfinite(err), err, np.inf)
    return lam, err


def _join(runs):
    """One Trajectory of the segments' runs end to end (their common node times once; work summed on)."""
    first = runs[0]
    cat = {}
    for name in ("t", "q", "v", "kinetic", "gravity", "elastic", "q_error", "v_error"):
        cat[name] = np.concatenate([getattr(first, name)] + [getattr(r, name)[1:] for r in runs[1:]])
    work, offset = [first.work], first.work[-1]
    for r in runs[1:]:
        work.append(r.work[1:] + offset)
        offset += r.work[-1]
    rejected = None if any(r.rejected is None for r in runs) else sum(r.rejected for r in runs)
    return replace(first, **cat, work=np.concatenate(work), nfev=sum(r.nfev for r in runs),
                   njev=sum(r.njev for r in runs), nlu=sum(r.nlu for r in runs),
                   accepted=sum(r.accepted for r in runs), rejected=rejected,
                   error_nfev=sum(r.error_nfev for r in runs), elapsed=sum(r.elapsed for r in runs),
                   error_elapsed=sum(r.error_elapsed for r in runs),
                   message=f"one period in {len(runs)} segments (multiple shooting)")


def _liouville(system, shoot, traj, mono, mono_err, cons, T):
    det = float(np.linalg.det(mono))
    try:
        inv = np.linalg.norm(np.linalg.inv(mono), 2)
    except np.linalg.LinAlgError:
        inv = np.inf
    det_err = abs(det) * inv * mono_err * len(mono)
    if cons:
        return Liouville(det, 1.0, det_err)
    f = np.ix_(shoot.free, shoot.free)
    tr = []
    for q, v, t in zip(traj.q[:-1], traj.v[:-1], traj.t[:-1]):
        M, _, C = linear_terms(system, q, v, t)
        tr.append(-np.trace(np.linalg.solve(M[f], C[f])))
    tr = np.array(tr)
    whole, half = T * tr.mean(), T * tr[::2].mean()
    return Liouville(det, math.exp(whole), det_err + math.exp(whole) * abs(whole - half))
