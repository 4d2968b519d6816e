"""The result of a simulation: :class:`Trajectory` (times, states, energies, errors, events, the state
transition) and :class:`SimulationError` (a run that could not go on, with the motion so far)."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from .._deprecation import Renamed
from .._format import number
from ..errors import ConvergenceError, ModelError
from ..results import TimeResult, check_quantity


class SimulationError(ConvergenceError):
    """A simulation that could not go on. ``t``: the time reached; ``trajectory``: the motion up to it
    (status "failed"); the message says why."""

    def __init__(self, message, trajectory, t):
        super().__init__(message, best=trajectory)
        self.trajectory = trajectory
        self.t = float(t)


@dataclass(frozen=True, eq=False)
class Trajectory(TimeResult):
    """A simulated motion (a :class:`~vibdyn.results.TimeResult`). Arrays have one row per
    output time ``t`` (s).

    ``q`` (n × nq) and ``v`` (n × nv) in the system's coordinates, ``a`` (n × nv, m/s² or rad/s²) the
    accelerations there (computed on first use); ``coordinates`` and ``units`` the system's; ``kinetic``,
    ``gravity``, ``elastic`` (J) from :meth:`System.energy`; ``work`` (J) the work of the non-conservative
    forces since t0 (and of the drives: ``drive_work``, J, None without drives); ``q_error``/``v_error``
    (arrays) the estimated global error at each output (tangent space, largest over the coordinates: m or rad,
    m/s or rad/s) by ``error_method``, and ``error`` / ``velocity_error`` (numbers) their largest values over the
    outputs; ``nfev`` dynamics evaluations, ``njev`` Jacobians (implicit and symplectic methods), ``nlu`` LU
    factorisations (or inverses), ``accepted``/``rejected`` steps (rejected is None for scipy's implicit solvers, which
    do not report it), all of the run itself; ``error_nfev`` the evaluations spent on the error estimate (its second
    run, if any); ``elapsed`` (s) the whole call, of which ``error_elapsed`` (s) went to the error estimate's second
    run; ``status`` "finished", "interrupted" (Ctrl-C) or "failed", with ``message``.
    """

    system: Any = field(repr=False)
    method: str
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    kinetic: np.ndarray
    gravity: np.ndarray
    elastic: np.ndarray
    work: np.ndarray
    q_error: np.ndarray
    v_error: np.ndarray
    error_method: str
    nfev: int
    njev: int
    nlu: int
    accepted: int
    rejected: object
    error_nfev: int
    elapsed: float
    status: str
    message: str
    rtol: float
    atol: np.ndarray = field(repr=False)
    dt: object
    energy0: Any = None  # Energy at t0 (the outputs need not include t0)
    error_elapsed: float = 0.0
    t0: float = 0.0  # s, where the run started
    t_events: tuple = ()  # per event function, the times (s) of its crossings
    q_events: tuple = ()  # per event function, the configurations there (n × nq)
    v_events: tuple = ()  # per event function, the velocities there (n × nv)
    state_transition: np.ndarray | None = field(default=None, repr=False)  # ∂(q, v)(t_end)/∂(q0, v0), tangent
    state_transition_error: float | None = None  # its estimated error (largest entry)
    drive_work: np.ndarray | None = field(default=None, repr=False)  # J per output: the drives' work (in work)
    events = Renamed("t_events")  # (the event functions are given as simulate's events=; these are found)
    event_q = Renamed("q_events")
    event_v = Renamed("v_events")
    error_kind = Renamed("error_scope")

    @property
    def coordinates(self) -> tuple:
        return tuple(self.system.coordinates)

    @property
    def units(self) -> tuple:
        return tuple(self.system.units)

    @cached_property
    def a(self) -> np.ndarray:
        """Accelerations (m/s², rad/s²) at each output (n × nv), from the equations of motion; NaN rows
        where they are not finite (a failed run's last state)."""
        out = np.full((len(self), self.system.nv), np.nan)
        for i, (q, v, t) in enumerate(zip(self.q, self.v, self.t)):
            try:
                out[i] = self.system.accelerations(q, v, t)
            except ModelError:
                pass
        return out

    def series(self, quantity: str = "displacement", outputs: Any = None,
               direction: Any = None) -> tuple[list, list, np.ndarray]:
        """(labels, units, values n_t × k) of coordinates (a name, a list of names, or None: all):
        displacement = offset from the neutral configuration (tangent space, m or rad), velocity or
        acceleration. Body points: see :meth:`point_positions`."""
        rate = check_quantity(quantity, "trajectory")
        names = list(self.coordinates) if outputs is None else [outputs] if isinstance(outputs, str) else outputs
        try:
            names = list(names)
        except TypeError:
            names = [None]
        if not names or direction is not None or not all(isinstance(n, str) for n in names):
            raise ModelError(f"trajectory outputs: give coordinate names ({', '.join(self.coordinates)}) or None, "
                             f"got {outputs!r}; for body points use point_positions(body, point)")
        idx = [self.system.coordinate_index(n) for n in names]
        if quantity == "displacement":
            neutral = self.system.neutral()
            full = np.array([self.system.difference(neutral, q) for q in self.q]).reshape(len(self), -1)
        else:
            full = self.v if quantity == "velocity" else self.a
        return list(names), [self.units[i] + rate for i in idx], full[:, idx]

    @property
    def error(self) -> float:
        """Estimated global error of the configuration (m or rad), largest over the outputs."""
        return float(self.q_error.max()) if len(self) else 0.0

    @property
    def error_scope(self) -> str:
        """What :attr:`error` is: "local (not a global bound)" for DOP853's accumulated local error estimates
        (measured up to ~30× too low on long chaotic or light-bodied runs: use error_method="rerun" for a global
        estimate), else "global estimate (rerun)" or "global estimate (richardson)"; "none" without one."""
        if self.error_method == "local":
            return "local (not a global bound)"
        return "none" if self.error_method == "none" else f"global estimate ({self.error_method})"

    @property
    def velocity_error(self) -> float:
        """Estimated global error of the velocities (m/s or rad/s), largest over the outputs (the largest of
        :attr:`v_error`, as :attr:`error` is of :attr:`q_error`)."""
        return float(self.v_error.max()) if len(self) else 0.0

    @property
    def constraint_residual(self) -> np.ndarray:
        """Largest |Φ| of the loops at each output (m for positions, rad for orientations; zeros for a
        tree): how well the motion keeps the loops closed (see :mod:`vibdyn.model.reduction`)."""
        return self.system.reduction.closures(self.q)

    @property
    def energy(self) -> np.ndarray:
        """Total mechanical energy T + V_gravity + V_elastic (J) at each output."""
        return self.kinetic + self.gravity + self.elastic

    @property
    def energy_balance(self) -> np.ndarray:
        """E − E(0) − W_nc (J): zero for the exact motion."""
        return self.energy - self.energy0.total - self.work

    @property
    def drift(self) -> float:
        """Largest |energy_balance| (J)."""
        return float(np.abs(self.energy_balance).max()) if len(self) else 0.0

    @property
    def energy_scale(self) -> float:
        """The energy that moves (J): largest kinetic energy, change of a potential, or work."""
        if not len(self):
            return 0.0
        e0 = self.energy0
        return float(max(e0.kinetic, self.kinetic.max(), np.abs(self.gravity - e0.gravity).max(),
                         np.abs(self.elastic - e0.elastic).max(), np.abs(self.work).max()))

    @property
    def drift_relative(self) -> float:
        """drift / energy_scale (0 when nothing moves)."""
        scale = self.energy_scale
        return self.drift / scale if scale > 0 else 0.0

    def point_positions(self, body: str, point: Any = (0.0, 0.0, 0.0)) -> np.ndarray:
        """World positions (m) of a point given in a body's frame at every output (n × 3)."""
        return np.array([self.system.point_position(body, point, q) for q in self.q]).reshape(-1, 3)

    def summary(self) -> str:
        steps = f"{self.accepted} steps" + ("" if self.rejected is None else f" ({self.rejected} rejected)")
        return (f"{self.method}: t = {self.t[-1] if len(self) else 0.0:.6g} s ({self.status}), {steps}, "
                f"{self.nfev} evaluations, error ≈ {self.error:.1e} ({self.error_scope}), energy drift "
                f"{self.drift:.2e} J ({self.drift_relative:.1e} relative), {self.elapsed:.3g} s")

    def __repr__(self):
        return f"Trajectory({self.summary()})"

    def _repr_html_(self):
        from .._format import html_table

        sysm = self.system
        rows = []
        if len(self):
            dq = sysm.difference(sysm.neutral(), self.q[-1])
            rows = [[n, u, number(x), number(v)] for n, u, x, v in zip(sysm.coordinates, sysm.units, dq, self.v[-1])]
        return html_table(self.summary(), ["coordinate", "unit", "final offset", "final speed"], rows)

    # ------------------------------------------------------------------ export
    def columns(self) -> tuple[list[str], np.ndarray]:
        """(names, table): one column per time, q and v component, energy, work, balance and error."""
        qn, vn = q_names(self.system), self.system.coordinates
        names = (["t"] + [f"q:{n}" for n in qn] + [f"v:{n}" for n in vn]
                 + ["kinetic", "gravity", "elastic", "work", "energy_balance", "q_error", "v_error"])
        table = np.column_stack([self.t, self.q, self.v, self.kinetic, self.gravity, self.elastic, self.work,
                                 self.energy_balance, self.q_error, self.v_error])
        return names, table

    def _meta(self):
        return {"scene": self.system.name, "method": self.method, "status": self.status, "message": self.message,
                "error_method": self.error_method, "error_scope": self.error_scope, "error": self.error,
                "velocity_error": self.velocity_error,
                "drift_J": self.drift, "drift_relative": self.drift_relative, "nfev": self.nfev,
                "njev": self.njev, "nlu": self.nlu, "accepted": self.accepted,
                "rejected": -1 if self.rejected is None else self.rejected, "error_nfev": self.error_nfev,
                "elapsed_s": self.elapsed, "error_elapsed_s": self.error_elapsed,
                "rtol": self.rtol, "dt": float("nan") if self.dt is None else self.dt}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the time-result protocol's fields (q in the system's nq components, named by
        ``q_names``), the energies, work and errors per output, and the run's figures."""
        return {**self.time_dict(), "q_names": q_names(self.system), "kinetic": self.kinetic.tolist(),
                "gravity": self.gravity.tolist(), "elastic": self.elastic.tolist(), "work": self.work.tolist(),
                "q_error": self.q_error.tolist(), "v_error": self.v_error.tolist(),
                **{k: v for k, v in self._meta().items() if k not in ("method", "error", "elapsed_s")},
                "rejected": self.rejected, "dt": self.dt}  # None where not applicable (the files write -1, nan)

    def to_csv(self, path: str | Path) -> Path:
        """Write a CSV file: '#' header lines with the run's figures, then one row per output time."""
        names, table = self.columns()
        header = "\n".join([f"{k} = {v}" for k, v in self._meta().items()] + [",".join(names)])
        np.savetxt(Path(path), table, delimiter=",", header=header, comments="# ", fmt="%.17g")
        return Path(path)

    def to_npz(self, path: str | Path) -> Path:
        """Write a NumPy .npz archive: the arrays (t, q, v, energies, work, errors, atol), the coordinate
        names and the run's figures."""
        arrays: dict[str, Any] = dict(
            t=self.t, q=self.q, v=self.v, kinetic=self.kinetic, gravity=self.gravity, elastic=self.elastic,
            work=self.work, energy_balance=self.energy_balance, q_error=self.q_error, v_error=self.v_error,
            atol=self.atol, q_names=np.array(q_names(self.system)), coordinates=np.array(self.system.coordinates),
            **{k: np.array(v) for k, v in self._meta().items()})
        np.savez(Path(path), **arrays)
        return Path(path)


def q_names(system):
    """A name for each configuration component: the coordinate for vector joints; the joint type's own
    ``q_names`` otherwise (x, y, z, qx, qy, qz, qw for a free joint; qx … qw a ball; x, y, cos, sin planar)."""
    names = []
    for b in system.body_infos.values():
        names += list(b.coordinates) if b.joint.q_names is None else [f"{b.name}.{p}" for p in b.joint.q_names]
    return names


# ---------------------------------------------------------------------------------------------- entry point
