"""The time layer's engine: one run of a scene's equations of motion with its error estimate (a second run at
tighter tolerances or coarser steps, or the summed local errors), its state transition with ``variational``,
its events, and the :class:`~vibdyn.simulation.trajectory.Trajectory` made of it. :class:`vibdyn.simulation.flow.Flow`
drives it (checked once, called many times); :func:`vibdyn.simulation.simulate.simulate` is a thin driver over a
Flow. Settings are checked by :func:`settings` (bad input: ModelError naming it).
"""

import math
import sys
import time
from dataclasses import dataclass, field, replace

import numpy as np

from .._check import finite_array, has_coordinates, scalar, start_hint
from ..defaults import EPS
from ..errors import ModelError, VibdynError
from ..model.groups import ForceGroup
from ..model.system import Energy
from .integrators import METHODS, StepError, method_class
from .integrators.base import DIFFERENCED_RTOL
from .integrators.driven import free_block
from .trajectory import SimulationError, Trajectory

RERUN_FACTOR = 100.0  # the "rerun" error estimate tightens rtol and atol by this factor
RERUN_OWN = 0.1  # the rerun's own error, counted as this share of the main run's (at most: about 1/60 for dop853)
MIN_RTOL = 100 * np.finfo(float).eps
MAX_FIXED_STEPS = 1e9  # a fixed-step run longer than this is a mistake (days of computing), refused
PROGRESS_DELAY = 2.0  # s of wall time before a progress bar appears
SINGULAR_NOTE = 1e-4  # a failed run of a mechanism whose loops are this near a singular position says so



def finish(system, cfg, solved, start):
    """The Trajectory of a solved run (energies at every output), or its SimulationError; ``start``: when the
    call began (perf_counter s)."""
    main = solved.main
    traj = _trajectory(system, cfg, main, solved.runs, solved.q_err, solved.v_err, time.perf_counter() - start,
                       solved.error_elapsed, solved.error_method)
    if solved.transition is not None:
        traj = replace(traj, state_transition=solved.transition, state_transition_error=solved.transition_error)
    if main.status == "finished" and not np.all(np.isfinite(traj.energy)):
        raise SimulationError("the energies of the motion overflow (state too large for double precision)",
                              traj, cfg.t_end)
    if main.status == "failed":
        raise stopped(system, cfg, main, traj) from main.failure
    return traj


def stopped(system, cfg, main, traj=None):
    """The SimulationError of a failed run: where it stopped and why (with ``traj``, the run so far, and a note
    where a mechanism's loops are near a singular position)."""
    t = _t_reached(main)
    note = "" if traj is None else singular_note(system, traj)
    return SimulationError(f"simulation stopped at t = {t:.6g} s (of {cfg.t_end:g}): {main.message}{note}", traj, t)


@dataclass
class Solved:
    """A run with its error estimate (what :func:`simulate` and :class:`vibdyn.simulation.flow.Flow` report)."""
    main: "_Run"
    runs: list
    q_err: np.ndarray
    v_err: np.ndarray
    error_elapsed: float
    error_method: str
    transition: np.ndarray | None = None
    transition_error: float | None = None


def solve(system, cfg):
    """The main run of ``cfg`` and its error estimate (second run(s) at tighter tolerances or coarser steps, or
    the summed local errors), and with ``variational`` its state transition and that one's error."""
    main = _integrate(system, cfg, "simulate")
    runs = [main]
    q_err = v_err = None
    error_elapsed = 0.0
    error_method = cfg.error
    if main.status == "finished":
        if cfg.error == "local":
            q_err, v_err = main.local
        else:
            t_check = time.perf_counter()
            check_cfg = replace(cfg, t_end=main.t[-1], events=None) if main.t else cfg
            with np.errstate(over="ignore", invalid="ignore"):  # (2·dt or 4·dt may diverge: that is its answer)
                check = _integrate(system, check_cfg, "error estimate", reference=main)
                runs.append(check)
                coarse = None
                if cfg.error == "richardson" and check.status == "finished":  # the observed order, from 4·dt
                    coarse = _integrate(system, replace(check_cfg, variational=False), "error estimate",
                                        reference=main, stride=4)
                    runs.append(coarse)
            error_elapsed = time.perf_counter() - t_check
            q_err, v_err = _round_off_floor(main, *_compare(system, main, check, cfg, coarse))
            if check.status != "finished":
                main.message = f"reached t_end = {cfg.t_end:g} s; error estimate incomplete: {check.message}"
    elif main.local is not None:  # a run that stopped early: its summed local errors are all there is
        q_err, v_err = main.local
        error_method = "local"
    if q_err is None:  # the run stopped before its error could be estimated
        q_err = v_err = np.full(len(main.t), np.inf)
    solved = Solved(main, runs, q_err, v_err, error_elapsed, error_method)
    if cfg.variational and main.transition is not None:
        other = runs[1].transition if len(runs) > 1 else None
        err = np.inf if other is None else float(np.abs(main.transition - other).max()) / (
            1.0 - RERUN_OWN if cfg.error == "rerun" else 2.0 ** cfg.stepper.order - 1.0)
        floored = getattr(main.stepper, "floored_steps", 0)
        if floored:  # both runs held these steps' Φ to the same floor: their errors, summed
            err = max(err, DIFFERENCED_RTOL * floored * float(np.abs(main.transition).max()))
        solved.transition, solved.transition_error = main.transition, err
    return solved


def singular_note(system, traj):
    """Why a mechanism's run can stop at a singular position of its loops ('' if it is not at one)."""
    if not len(traj.t):
        return ""
    cond = system.reduction.conditioning(traj.q[-1])
    if cond > SINGULAR_NOTE:
        return ""
    return (f"; the loops are at a singular position there (σ_min/σ_max of their Jacobian {cond:.1e}): the "
            "index-1 accelerations lose about 1/σ² of round-off near it, which bounds the tolerance a step can "
            "meet: loosen rtol (the error estimate reruns at rtol/100) or use a fixed-step method (rk4)")


def checked_error_method(stepper, error, what):
    """``error`` (None: the stepper's default), checked against the error estimates the stepper offers."""
    error = stepper.error_methods[0] if error is None else error
    if error not in stepper.error_methods:
        raise ModelError(f"{what}: error estimate {error!r} is not available for method '{stepper.name}' (use "
                         f"{' or '.join(map(repr, stepper.error_methods))})")
    return error


# ---------------------------------------------------------------------------------------------- settings
@dataclass(frozen=True)
class Settings:
    t_end: float
    q0: np.ndarray
    v0: np.ndarray
    method: str
    rtol: float
    atol_q: np.ndarray
    atol_v: np.ndarray
    dt: object
    t_eval: object
    error: str
    max_step: float
    progress: object
    work: bool
    t0: float = 0.0
    events: tuple | None = None  # the event functions
    variational: bool = False
    stepper: type | None = None  # the method's stepper class
    transition_rtol: float | None = None  # the variational equations' own rtol (None: rtol)
    relaxed: tuple | None = None  # (t, max_step): past t (s) the sampled laws bound no step, max_step bounds them


def settings(system, t_end, q0, v0, method, rtol, atol, dt, t_eval, error, max_step, progress, t0=0.0,
             events=None, variational=False, checked_span=True):
    """The checked :class:`Settings` of a run (simulate's arguments; ``checked_span``: whether ``t_end`` is the
    run's, which ``dt`` must fit in: a Flow's is given per call)."""
    what = "simulate"
    has_coordinates(system, what)
    t0 = scalar(t0, f"{what}: t0 (s)")
    t_end = scalar(t_end, f"{what}: t_end (s)")
    if not t_end > t0:
        raise ModelError(f"{what}: t_end = {t_end:g} s must be after t0 = {t0:g} s (t_end is an absolute time)")
    stepper = method_class(method)
    if stepper is None:
        raise ModelError(f"{what}: unknown method {method!r} (use one of {', '.join(METHODS)}, or a Stepper "
                         "subclass)")
    method = stepper.name
    variational = bool(variational)
    R = system.reduction
    if variational:
        R.require("variational equations", what)
    if variational and not stepper.supports_variational:
        raise ModelError(f"{what}: method '{method}' does not integrate the variational equations (use "
                         f"{', '.join(m for m, c in METHODS.items() if c.supports_variational)})")
    if events is not None:
        events = checked_events(stepper, events, what)
    if hasattr(q0, "q") and hasattr(q0, "v"):  # an equilibrium or a steady motion
        q0, v0 = q0.q, q0.v if v0 is None else v0
    lacks = {"loops": f"method '{method}' does not handle closed loops; use "
                      f"{', '.join(m for m, c in METHODS.items() if c.supports_loops)} (projected onto the loops)",
             "drives": f"method '{method}' does not integrate a scene with drives (use "
                       f"{', '.join(m for m, c in METHODS.items() if c.supports_drives)})"}
    R.require(f"method '{method}'", what, **{k: m for k, m in lacks.items() if not getattr(stepper, f"supports_{k}")})
    given = q0 is not None
    q0, start = R.default_start(system) if q0 is None else (system.check_configuration(q0, f"{what}: q0"), "q0")
    if given:  # a start may wind a pendulum many turns, but it is more often degrees given for radians
        start_hint(system, q0, f"{what}: q0")
    v0 = np.zeros(system.nv) if v0 is None else system.check_velocity(v0, f"{what}: v0")
    q0, v0 = R.impose(q0, v0, t0)  # the driven entries of q0 and v0 are the laws' at t0
    # the run starts on the loops: its energies and errors are of that state
    q0, v0 = R.project(R.close(q0, start=start), v0, system.mass_matrix)
    system.check_mass_matrix(q0, "the initial configuration q0")
    rtol = scalar(rtol, f"{what}: rtol")
    if not MIN_RTOL <= rtol < 1.0:
        raise ModelError(f"{what}: rtol must be in [{MIN_RTOL:.2g}, 1) (relative error per step), got {rtol:g}")
    scale = system.coordinate_scales
    if atol is None:
        atol_q = atol_v = rtol * scale
    else:
        a = np.atleast_1d(finite_array(atol, None, f"{what}: atol"))
        if a.ndim != 1 or a.size not in (1, system.nv, 2 * system.nv):
            raise ModelError(f"{what}: atol must be one number, one per coordinate ({system.nv}) or one per "
                             f"position and velocity ({2 * system.nv}), got shape {np.shape(atol)}")
        if np.any(a <= 0):
            raise ModelError(f"{what}: atol must be positive, got {a.tolist()}")
        a = np.broadcast_to(a, (system.nv,)) if a.size < 2 * system.nv else a
        atol_q, atol_v = (a[:system.nv], a[system.nv:]) if a.size == 2 * system.nv else (a, a)
        atol_q, atol_v = np.array(atol_q, dtype=float), np.array(atol_v, dtype=float)
    if dt is not None:
        dt = scalar(dt, f"{what}: dt (s)", positive=True)
        if checked_span and dt > t_end - t0:
            raise ModelError(f"{what}: dt = {dt:g} s is longer than the run (t_end − t0 = {t_end - t0:g} s)")
        if not stepper.adaptive and (t_end - t0) / dt > MAX_FIXED_STEPS:
            raise ModelError(f"{what}: (t_end − t0) / dt = {(t_end - t0) / dt:.3g} steps is more than "
                             f"{MAX_FIXED_STEPS:.0e}: take a larger dt or a shorter run")
    elif not stepper.adaptive:
        raise ModelError(f"{what}: method '{method}' takes fixed steps: give dt (s)")
    if t_eval is not None:
        t_eval = np.atleast_1d(finite_array(t_eval, None, f"{what}: t_eval"))
        if t_eval.ndim != 1 or t_eval.size == 0:
            raise ModelError(f"{what}: t_eval must be a non-empty list of times (s)")
        if np.any(np.diff(t_eval) <= 0):
            raise ModelError(f"{what}: t_eval must be strictly increasing")
        if t_eval[0] < t0 or t_eval[-1] > t_end:
            raise ModelError(f"{what}: t_eval must lie in [t0 = {t0:g}, t_end = {t_end:g}] s, got [{t_eval[0]:g}, "
                             f"{t_eval[-1]:g}]")
    error = checked_error_method(stepper, error, what)
    max_step = np.inf if max_step is None else scalar(max_step, f"{what}: max_step (s)", positive=True)
    # a sampled support motion (a ground record, vibdyn.laws.Record) bounds the steps by its own: none crosses
    # two of its kinks, none aliases it
    sampled = [s.motion for s in system.supports if hasattr(s.motion, "max_step")]
    law_step = min((m.max_step for m in sampled), default=np.inf)
    # past their last samples the laws are smooth (uniform motion): the steps are bound by max_step alone again
    relaxed = (max(getattr(m, "bounded_until", np.inf) for m in sampled), max_step) if law_step < max_step else None
    max_step = min(max_step, law_step)
    if dt is not None and not stepper.adaptive:
        dt = min(dt, law_step)
    if progress not in (None, True, False):
        raise ModelError(f"{what}: progress must be None, True or False, got {progress!r}")
    work = bool(system.supports) or bool(R.driven.size) or any(
        type(g).potential is ForceGroup.potential or g.time_dependent for g in system.force_groups)
    return Settings(t_end, q0, v0, method, rtol, atol_q, atol_v, dt, t_eval, error, max_step, progress, work, t0,
                    events, variational, stepper, relaxed=relaxed)


def checked_events(stepper, events, what):
    """``events`` (a callable or a list of them) as a tuple, checked now: a bad one is refused before the run."""
    from .events import Events

    Events(events)
    if not stepper.supports_events:
        raise ModelError(f"{what}: method '{stepper.name}' does not locate events (use "
                         f"{', '.join(m for m, c in METHODS.items() if c.supports_events)})")
    return tuple([events] if callable(events) else events)


# ---------------------------------------------------------------------------------------------- one run
@dataclass
class _Run:
    t: list
    q: list
    v: list
    w: list
    err: list  # accumulated local error (q part, v part) at each output, or None
    stepper: object = None
    status: str = "finished"
    message: str = ""
    failure: BaseException | None = None
    events: object = None  # vibdyn.simulation.events.Events
    transition: np.ndarray | None = None  # the state transition at the end (variational runs)
    system: object = None
    steps: list = field(default_factory=list)  # accepted steps at each output

    @property
    def local(self):
        if not self.err or self.err[0] is None:
            return None
        e = np.array(self.err)
        return e[:, 0], e[:, 1]


def _integrate(system, cfg, label, reference=None, stride=2):
    """One integration (the main run, or with ``reference`` an error-estimate run at its output times: for a
    fixed-step method, with every ``stride``-th step of the main run's grid)."""
    t_end, adaptive = cfg.t_end, cfg.stepper.adaptive
    rtol, atol_q, atol_v = cfg.rtol, cfg.atol_q, cfg.atol_v
    transition_rtol = cfg.transition_rtol
    if reference is not None and adaptive:  # "rerun": tighter tolerances
        rtol = max(rtol / RERUN_FACTOR, MIN_RTOL)
        atol_q, atol_v = atol_q / RERUN_FACTOR, atol_v / RERUN_FACTOR
        if transition_rtol is not None:
            transition_rtol = max(transition_rtol / RERUN_FACTOR, MIN_RTOL)
    outputs = reference.t if reference is not None else cfg.t_eval
    run = _Run([], [], [], [], [])
    run.system = system
    progress = Progress(t_end, cfg.progress, label)
    try:
        run.stepper = cfg.stepper(system, cfg.q0, cfg.v0, t_end, rtol=rtol, atol_q=atol_q, atol_v=atol_v,
                                          first_step=cfg.dt if adaptive else None, max_step=cfg.max_step,
                                          work=cfg.work, t0=cfg.t0, variational=cfg.variational,
                                          transition_rtol=transition_rtol)
        if cfg.events:
            from .events import Events

            run.events = Events(cfg.events)
            run.events.start(cfg.t0, cfg.q0, cfg.v0)
        if adaptive:
            _adaptive(cfg, run, outputs, progress)
        else:
            _fixed(cfg, run, outputs, stride=stride if reference is not None else 1, progress=progress)
        if cfg.variational:  # (a run a terminal event stopped inside its last step has none at its end)
            stopped = run.events is not None and run.events.stop is not None
            run.transition = None if stopped else free_block(system, run.stepper.state_transition)
    except KeyboardInterrupt:
        run.status, run.message = "interrupted", f"interrupted (Ctrl-C) at t = {_t_reached(run):.6g} s"
    except (StepError, VibdynError, FloatingPointError, np.linalg.LinAlgError) as e:
        run.status, run.message, run.failure = "failed", str(e), e
    finally:
        progress.close()
    if run.status != "finished" and reference is None and run.stepper is not None:
        t = _t_reached(run)
        if t > (run.t[-1] if run.t else 0.0):  # keep the last state reached, between output times
            _record(run, t, *run.stepper.state, run.stepper.local_error)
    return run


def _t_reached(run):
    return run.stepper.t if run.stepper is not None else 0.0


def _record(run, t, q, v, w, local=None):
    run.steps.append(run.stepper.accepted)
    run.t.append(t)
    run.q.append(q)
    run.v.append(v)
    run.w.append(w)
    run.err.append(None if local is None else (local[:len(local) // 2].max(), local[len(local) // 2:].max()))


def _adaptive(cfg, run, outputs, progress):
    stepper, events, relaxed = run.stepper, run.events, cfg.relaxed
    k = 0
    if outputs is None or outputs[0] == cfg.t0:
        _record(run, cfg.t0, *stepper.state, _zero_local(stepper))
        k = 1 if outputs is not None else 0
    while stepper.t < cfg.t_end:
        # (the step's interpolant is made only where an output or an event's crossing falls inside it)
        stepper.step(outputs[k] if outputs is not None and k < len(outputs) else None)
        t = stepper.t
        stop = None
        if events is not None:
            ends = stepper.state[:2]
            stop = events.step(t, *ends, lambda s: stepper.interpolant()(s)[:2] if s < t else ends)
        end = t if stop is None else stop
        if outputs is None:
            if stop is None:
                _record(run, t, *stepper.state, stepper.local_error)
        else:
            while k < len(outputs) and outputs[k] <= end:
                state = stepper.state if outputs[k] == t else stepper.interpolant()(float(outputs[k]))
                _record(run, float(outputs[k]), *state, stepper.local_error)
                k += 1
        if stop is not None:  # a terminal event: the run ends there
            if not run.t or run.t[-1] < stop:
                _record(run, stop, *stepper.interpolant()(stop), stepper.local_error)
            run.message = f"stopped by a terminal event at t = {stop:.10g} s"
            return
        if relaxed is not None and t >= relaxed[0]:
            stepper.bound(relaxed[1])
            relaxed = None
        progress.update(t)


def _zero_local(stepper):
    return None if stepper.local_error is None else np.zeros_like(stepper.local_error)


def _grid(cfg, stride=1):
    """Step end times of a fixed-step run: each interval between output times (and t_end) gets a multiple of
    four equal steps ≤ dt; the runs of Richardson's estimate take every ``stride``-th one (2, 4)."""
    stops = [] if cfg.t_eval is None else [float(t) for t in cfg.t_eval if t > cfg.t0]
    if not stops or stops[-1] < cfg.t_end:
        stops.append(cfg.t_end)
    a = cfg.t0
    for b in stops:  # lazily: a long run must not allocate its whole grid
        n = max(4, 4 * math.ceil((b - a) / (4 * cfg.dt) * (1 - 1e-12)))
        for i in range(stride, n + 1, stride):
            yield b if i == n else a + (b - a) * i / n
        a = b


def _fixed(cfg, run, outputs, stride, progress):
    stepper, events = run.stepper, run.events
    record = None if outputs is None else set(np.asarray(outputs, dtype=float).tolist())
    if record is None or cfg.t0 in record:
        _record(run, cfg.t0, *stepper.state)
    ends = None
    for t_new in _grid(cfg, stride):
        if events is not None:
            ends = (stepper.t, _with_acceleration(run.system, stepper))
        stepper.step_to(float(t_new))
        if events is not None:  # (a fixed-step method keeps no interpolant: a cubic Hermite of the ends)
            from .events import hermite

            at = hermite(run.system, ends[0], ends[1], stepper.t, _with_acceleration(run.system, stepper))
            stop = events.step(stepper.t, *stepper.state[:2], at)
            if stop is not None:
                q, v = at(stop)
                _record(run, stop, q, v, stepper.state[2])
                run.message = f"stopped by a terminal event at t = {stop:.10g} s"
                return
        if record is None or t_new in record:
            _record(run, float(t_new), *stepper.state)
        progress.update(t_new)


def _with_acceleration(system, stepper):
    """(q, v, a) of a stepper's state now."""
    q, v, _ = stepper.state
    return q, v, system.accelerations(q, v, stepper.t)


# ---------------------------------------------------------------------------------------------- error estimate
def _compare(system, main, check, cfg, coarse=None):
    """Per-output error of the main run from the check run: |Δq| (tangent), |Δv| for a rerun (over 1 − RERUN_OWN);
    for Richardson
    divided by ρ − 1, ρ = |y_2dt − y_4dt| / |y_dt − y_2dt| the observed convergence from the ``coarse`` run
    (at most 2^p; 2^p without it), or by 1 where ρ is not within 2× of 2^p (not the asymptotic range); the
    largest so far at each output. Outputs the check runs do not have (steps between theirs) take the
    larger estimate of their neighbours; outputs past their end, inf."""
    p2 = 2.0 ** cfg.stepper.order
    tm = np.array(main.t)
    dq, dv = _differences(system, tm, main, check)
    if cfg.error == "rerun":
        # (|y − y_tight| is the main run's error less the tight run's, which mostly shares its sign: the difference
        # alone fell 1–2 % short of the error)
        factor = np.full(len(tm), 1.0 - RERUN_OWN)
    elif coarse is None:
        factor = np.full(len(tm), p2 - 1.0)
    else:
        cq, cv = _differences(system, tm, check, coarse, at=np.array(check.t))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            rho = np.fmax(cq / dq, cv / dv)
        both = ~np.isnan(dq) & ~np.isnan(cq)
        rho = np.where(both & (dq == 0) & (dv == 0), p2, rho)  # (no difference at all: the full order)
        # in the asymptotic range (ρ within 2× of 2^p): /(ρ − 1); outside it the halved step's difference is
        # no guide to the error's rate, and the difference itself is the estimate
        factor = np.where((rho >= p2 / 2) & (rho <= 2 * p2), np.minimum(rho, p2) - 1.0, 1.0)
        # outputs between the 4·dt run's (every step recorded): the smaller factor of their neighbours; past
        # its end (it diverged) the difference itself
        known = np.flatnonzero(both)
        if known.size and known.size < len(tm):
            lo, hi = _neighbours(known, len(tm))
            factor = np.where(both, factor, np.minimum(factor[lo], factor[hi]))
        if coarse.status != "finished":
            reached = coarse.t[-1] if coarse.t else cfg.t0
            factor = np.where(tm > reached, 1.0, factor)
    eq, ev = dq / factor, dv / factor
    known = np.flatnonzero(~np.isnan(eq))
    if not known.size:
        return np.full(len(tm), np.inf), np.full(len(tm), np.inf)
    lo, hi = _neighbours(known, len(tm))
    for e in (eq, ev):
        fill = np.maximum(e[lo], e[hi])
        fill[np.arange(len(tm)) > known[-1]] = np.inf  # past the end of the check run
        e[np.isnan(e)] = fill[np.isnan(e)]
    if cfg.error == "richardson":
        # the largest estimate so far: two runs' difference passes through zero wherever their phases cross
        # (an oscillation stepped coarsely: an error of 5e-3 m read as 1e-4 at the crossing), while the error
        # of an undamped motion does not shrink (a rerun's tight reference has no such crossings)
        np.maximum.accumulate(eq, out=eq)
        np.maximum.accumulate(ev, out=ev)
    return eq, ev


def _round_off_floor(run, q_err, v_err):
    """The estimates held at or above the round-off the steps commit, ε per step in each part's size (the largest
    |q| and |v| so far; a quaternion's components count for a rotation's): two runs that agree to the last bit
    (both bound by a max_step) still carry it, and their difference, zero, says nothing of it."""
    n = np.asarray(run.steps, dtype=float) * EPS
    q_size = np.maximum.accumulate(np.abs(np.asarray(run.q)).max(axis=1, initial=0.0))
    v_size = np.maximum.accumulate(np.abs(np.asarray(run.v)).max(axis=1, initial=0.0))
    return np.maximum(q_err, n * q_size), np.maximum(v_err, n * v_size)


def _neighbours(known, n):
    """For each of n outputs, the known outputs before and after it (``known`` sorted, not empty; the first or
    last known one beyond the ends)."""
    pos = np.searchsorted(known, np.arange(n))
    return known[np.clip(pos - 1, 0, known.size - 1)], known[np.clip(pos, 0, known.size - 1)]


def _differences(system, tm, a, b, at=None):
    """|Δq| (tangent) and |Δv| between runs a and b at the times ``tm`` both have (nan elsewhere); ``at``: a's
    own times if a is not the main run (then indexed into a by them)."""
    ta, tb = (tm if at is None else at), np.array(b.t)
    dq, dv = np.full(len(tm), np.nan), np.full(len(tm), np.nan)
    ia, im = {t: i for i, t in enumerate(ta.tolist())}, {t: i for i, t in enumerate(tm.tolist())}
    for j, t in enumerate(tb.tolist()):
        i, k = ia.get(t), im.get(t)
        if i is not None and k is not None:
            dq[k] = np.abs(system.difference(b.q[j], a.q[i])).max()
            dv[k] = np.abs(b.v[j] - a.v[i]).max()
    return dq, dv


# ---------------------------------------------------------------------------------------------- result
def _trajectory(system, cfg, main, runs, q_err, v_err, elapsed, error_elapsed, error_method):
    n = len(main.t)
    q = np.array(main.q).reshape(n, system.nq)
    v = np.array(main.v).reshape(n, system.nv)
    t = np.array(main.t, dtype=float)
    energies = np.array([_energy(system, qi, vi, ti) for qi, vi, ti in zip(q, v, t)]).reshape(n, 3)
    e0 = Energy(*_energy(system, cfg.q0, cfg.v0, cfg.t0))
    w = np.array(main.w, dtype=float)
    w, drive_work = (w[:, 0], w[:, 1].copy()) if w.ndim == 2 else (w, None)  # with drives: (w, W_d)
    work = (w + energies[:, 2] - e0.elastic) if cfg.work and n else np.zeros(n)
    nfev, njev, nlu, accepted, rejected = main.stepper.counters if main.stepper is not None else (0, 0, 0, 0, 0)
    error_nfev = sum(r.stepper.nfev for r in runs[1:] if r.stepper is not None)
    error_method = error_method if np.all(np.isfinite(q_err)) or error_method == "local" else "none"
    return replace(Trajectory(
        system, cfg.method, t, q, v, energies[:, 0].copy(), energies[:, 1].copy(),
        energies[:, 2].copy(), work, np.asarray(q_err, dtype=float), np.asarray(v_err, dtype=float), error_method,
        nfev, njev, nlu, accepted, rejected, error_nfev, elapsed,
        main.status, main.message or f"reached t_end = {cfg.t_end:g} s", cfg.rtol,
        np.concatenate([cfg.atol_q, cfg.atol_v]), cfg.dt, e0, error_elapsed, cfg.t0,
        *(main.events.result(system.nq, system.nv) if main.events is not None else ((), (), ()))),
        drive_work=drive_work)


def _energy(system, q, v, t):
    """(kinetic, gravity, elastic) J, NaN where they overflow (the caller reports it)."""
    try:
        e = system.energy(q, v, t)
    except ModelError:
        return (np.nan, np.nan, np.nan)
    return (e.kinetic, e.gravity, e.elastic)


# ---------------------------------------------------------------------------------------------- progress bar
class Progress:
    """A tqdm bar of simulated time, shown only once a run has lasted PROGRESS_DELAY seconds, and (unless
    asked) only when stderr is a terminal. tqdm is imported only then."""

    def __init__(self, t_end, enabled, label):
        self.t_end, self.label = t_end, label
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.start = time.perf_counter()
        self.start_wall = time.time()  # tqdm's clock: the bar appears late but counts from the run's start
        self.bar = None
        self.shown = 0.0

    def update(self, t):
        if not self.enabled:
            return
        if self.bar is None:
            if time.perf_counter() - self.start < PROGRESS_DELAY:
                return
            from tqdm import tqdm

            self.bar = tqdm(total=self.t_end, desc=self.label, leave=False, dynamic_ncols=True,
                            bar_format="{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g} of {total:.4g} s "
                                       "[{elapsed}<{remaining}]")
            self.bar.start_t = self.start_wall
        self.bar.update(float(t) - self.shown)
        self.shown = float(t)

    def close(self):
        if self.bar is not None:
            self.bar.close()
