"""The time layer's lean entry for analyses: :class:`Flow`, the motion of one system from any state, its
settings checked once.

Shooting, Floquet multipliers and backbones integrate the same equations hundreds of times (one run per node,
per Newton iteration, per continuation step). :func:`vibdyn.simulation.simulate.simulate` checks its input
and computes the energies at every output on each call; a :class:`Flow` is made (and its method, tolerances
and options checked) once per analysis, then called with a state and a time span: the same stepper, the same
error estimate (the steps' summed local errors, or a rerun at tolerances / 100) and, with ``variational``, the
same state transition and its error, and the same events, without the per-call checks and energies.
:func:`vibdyn.simulation.simulate.simulate` is a thin driver over a Flow (:meth:`Flow.of` its checked settings);
both drive the engine of :mod:`vibdyn.simulation.runs`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .._check import scalar
from ..errors import ModelError
from .runs import Settings, checked_error_method, checked_events, finish, settings, solve, stopped

__all__ = ["Flow", "FlowResult"]


@dataclass(frozen=True, eq=False)
class FlowResult:
    """One flow: output times ``t`` (s), configurations ``q`` (n × nq) and velocities ``v`` (n × nv) there, their
    estimated errors ``q_error`` and ``v_error`` per output (tangent space: m or rad, m/s or rad/s), with
    ``variational`` the ``state_transition`` ∂(q, v)(t_end)/∂(q0, v0) (2nv × 2nv, tangent spaces) and its
    ``state_transition_error``; ``error_method`` (how the errors were estimated: "local", "rerun", "richardson",
    or "none"); ``nfev``, ``accepted``, ``rejected`` (the main run's) and ``elapsed`` (s); with events,
    ``t_events`` (s), ``q_events``, ``v_events``: per event function, the crossings' times and states (scipy's
    names, as :class:`~vibdyn.simulation.trajectory.Trajectory` has them; empty without events)."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    q_error: np.ndarray
    v_error: np.ndarray
    state_transition: np.ndarray | None
    state_transition_error: float | None
    error_method: str
    nfev: int
    accepted: int
    rejected: int | None
    elapsed: float
    t_events: tuple = ()
    q_events: tuple = ()
    v_events: tuple = ()

    @property
    def error(self) -> float:
        """Largest estimated configuration error over the outputs (m or rad)."""
        return float(self.q_error.max()) if len(self.t) else 0.0

    @property
    def velocity_error(self) -> float:
        """Largest estimated velocity error over the outputs (m/s or rad/s)."""
        return float(self.v_error.max()) if len(self.t) else 0.0


class Flow:
    """The motion of ``system`` by ``method`` at ``rtol``/``atol`` (as :func:`~vibdyn.simulation.simulate.simulate`
    takes them, checked here once: ModelError for bad ones), ``error_method`` ("local" by default: the summed
    local errors; "rerun" a second run at tolerances / 100), ``max_step`` (s), ``dt`` (s: the step of fixed-step
    methods, the first step of adaptive ones), ``variational`` (the state transition) and ``transition_rtol``
    (the state transition's own error control, at least rtol; None: rtol's — looser where the transition only
    feeds a Newton step's Jacobian). Call it with a state the caller made —
    (q0, v0) at ``t0`` (s; driven entries at their laws' values, on the loops of a mechanism: not checked again;
    ``q0``, ``v0`` of the constructor: a state of the same kind, checked as simulate checks its start, default
    neutral) — and the end time ``t1`` (s): a :class:`FlowResult` (``trajectory=True``: a full
    :class:`~vibdyn.simulation.trajectory.Trajectory`, energies included).
    ``t_eval``, ``error_method``, ``max_step`` and ``events`` (as simulate takes them: located on the steps'
    interpolants, a terminal one ends the run) may be given per call. A run that cannot go on raises
    SimulationError; Ctrl-C is raised again (an analysis has no use for a part of a flow)."""

    def __init__(self, system, q0=None, v0=None, *, method="dop853", rtol: float = 1e-8, atol=None,
                 error_method: str = "local", max_step: float | None = None, variational: bool = False,
                 transition_rtol: float | None = None, dt: float | None = None):
        self.system = system
        self.settings = settings(system, 1.0, q0, v0, method, rtol, atol, dt, None, error_method, max_step, False,
                                 variational=variational, checked_span=False)
        if transition_rtol is not None:
            transition_rtol = scalar(transition_rtol, "flow: transition_rtol", positive=True)
            if not self.settings.rtol <= transition_rtol < 1.0:
                raise ModelError(f"flow: transition_rtol must be in [rtol, 1) (the variational equations' own "
                                 f"tolerance, never tighter than the state's rtol = {self.settings.rtol:g}), got "
                                 f"{transition_rtol:g}")
            self.settings = replace(self.settings, transition_rtol=transition_rtol)

    @classmethod
    def of(cls, system, checked: Settings) -> "Flow":
        """The Flow of settings :func:`~vibdyn.simulation.runs.settings` has checked (simulate's)."""
        flow = cls.__new__(cls)
        flow.system, flow.settings = system, checked
        return flow

    def __call__(self, q0, v0, t0: float, t1: float, *, t_eval=None, error_method: str | None = None,
                 max_step: float | None = None, events=None, trajectory: bool = False, started: float | None = None):
        start = time.perf_counter() if started is None else started
        cfg = self.settings
        changes: dict[str, Any] = {}
        if error_method is not None and error_method != cfg.error:
            changes["error"] = checked_error_method(cfg.stepper, error_method, "flow")
        if max_step is not None:  # (a bound more: a sampled law's still holds)
            changes["max_step"] = min(float(max_step), cfg.max_step)
            if cfg.relaxed is not None:
                changes["relaxed"] = (cfg.relaxed[0], min(float(max_step), cfg.relaxed[1]))
        if events is not None:
            changes["events"] = checked_events(cfg.stepper, events, "flow")
        cfg = replace(cfg, q0=np.array(q0, dtype=float), v0=np.array(v0, dtype=float), t0=float(t0),
                      t_end=float(t1), t_eval=None if t_eval is None else np.asarray(t_eval, dtype=float), **changes)
        solved = solve(self.system, cfg)
        main = solved.main
        if main.status == "interrupted" and not trajectory:
            raise KeyboardInterrupt
        if trajectory:
            return finish(self.system, cfg, solved, start)
        if main.status == "failed":
            raise stopped(self.system, cfg, main) from main.failure
        n = len(main.t)
        nfev, _, _, accepted, rejected = main.stepper.counters
        found = main.events.result(self.system.nq, self.system.nv) if main.events is not None else ((), (), ())
        return FlowResult(np.array(main.t, dtype=float), np.array(main.q).reshape(n, self.system.nq),
                          np.array(main.v).reshape(n, self.system.nv), np.asarray(solved.q_err, dtype=float),
                          np.asarray(solved.v_err, dtype=float), solved.transition, solved.transition_error,
                          solved.error_method, nfev, accepted, rejected, time.perf_counter() - start, *found)
