"""Backbones of nonlinear normal modes: :func:`backbone` → :class:`Backbone`.

A nonlinear normal mode (NNM) of a conservative scene is the family of periodic orbits that grows out of one
linear mode of the static equilibrium; its backbone is the fundamental frequency ω (rad/s) against the energy
(or an amplitude). The family is followed from the linear mode at small amplitude (q = q_eq ⊕ ε φ, v = 0,
T = 2π/ω_lin) by the solver kit's pseudo-arclength continuation (:mod:`vibdyn.solvers.continuation`) in the
energy above the equilibrium's (J), or in the amplitude of the reported coordinate, on the shooting equations of
:mod:`.shooting`: unknowns the start's tangent displacement ξ from q_eq (q0 = q_eq ⊕ ξ: ball joints stay on
their group), its velocities v0 and the period T; equations the closing of the orbit, the phase condition
v_c(0) = 0 (the start is a turning point of the coordinate c) and the parameter's own row (E(q0, v0) − E_eq = λ,
or ξ_c = λ). The closing equations hold one redundant row (energy is conserved): the system is square plus one
consistent row, solved in least squares, its one-dimensional null space the branch's tangent. Each request is an
end point of the continuation, solved exactly there, then converged again by :func:`.periodic.periodic_orbit`
(energy kept, same phase condition) for its Floquet multipliers and error estimates. The start's ε is where the
potential along φ is still quadratic (to 1 %); the unknowns and residuals of each stretch between requests are
measured in units of its motion (the amplitude there along the mode), never of the scene's size or of where its
bodies sit, so that a slider placed at the origin or at 1 m gives the same backbone.

Internal resonances: at every point of the branch the nontrivial Floquet multipliers (the monodromy on the
energy level, the flow's direction removed) are followed as rotation angles θ_j, starting from 2π ω_j/ω_i of the
other linear modes; θ_j crossing a multiple 2πk (a multiplier μ = e^{iθ_j} reaching +1: the other NNM's period
commensurate, k:1) is reported in :attr:`Backbone.resonances` with the energy and ω where met, as are the folds
of the branch; the continuation goes on past it (the orbits after it are flagged in the summary).

Damping is left out: a scene's backbone is that of its conservative part (dampers and velocity-dependent forces
dropped, said in :attr:`Backbone.note`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pinocchio as pin
import scipy.linalg as sla
from numpy.typing import ArrayLike

from ..._check import degrees_hint, has_coordinates, hint, integer, scalar
from ..._deprecation import Renamed
from ..._format import duration, number, summary, table
from ...errors import ConvergenceError, ModelError
from ...model.dynamics import energy_gradient
from ...model.groups import ForceGroup
from ...simulation.flow import Flow
from ...simulation.trajectory import SimulationError
from ...solvers.continuation import Arclength, continuation
from ...solvers.newton import Steps, newton
from ...solvers.tracking import assign
from ..equilibrium import static_configuration
from .backbone_requests import bad_coordinate, checked_requests, mode_index, within_a_turn
from .periodic import MIN_ENERGY_RATIO, RTOL, STEP_RESOLUTION, TOL, orbit_from
from .shooting import RCOND, Shooting, conservative, energy_roundoff

__all__ = ["Backbone", "Resonance", "backbone"]
START_SHIFT = 1e-2  # the linear start: its potential departs from the linear mode's quadratic by at most this share
MAX_PERIOD_GROWTH = 50.0  # the branch stops where T exceeds this × the linear period (a separatrix near)
FIRST_STEP = 0.4  # the continuation's first arclength step (variables scaled by each leg's: see _Follower.run)
CONTINUATION_RTOL = 1e-9  # the flows along the branch (each request is solved again at the caller's rtol)
CONTINUATION_TOL = 1e-8  # and the branch's closing tolerance (scaled)
# the state transitions' own tolerance along the branch: they make the corrector's Newton steps and the predictor's
# tangent only (the branch points are solved again at each request with every tolerance the caller's); held to the
# state's 1e-9 they took 33-50 % more steps than the state needs (Kerschen's two masses: 540 -> 361 steps)
CONTINUATION_TRANSITION_RTOL = 1e-7
REQUEST_WEIGHT = 100.0  # a request's row weighs this much more than the closing rows when it is solved exactly
MIN_STEP = 1e-4  # steps halved below this (scaled) end the branch: it cannot be followed further
MAX_STEP = 1.0  # and its largest (each leg starts with the last one's step, in its own units)
ARG1 = pin.ArgumentPosition.ARG1


@dataclass(frozen=True)
class Resonance:
    """Where the backbone meets an internal resonance or a fold: ``category`` ("internal resonance": the nontrivial
    Floquet multiplier of linear mode ``other_mode`` reaches +1, its frequency ``ratio`` = k times ω, k:1; or
    "fold": the energy turns back along the branch), ``energy`` (J above the equilibrium's) and ``omega`` (rad/s)
    there, ``energy_range`` (J, the branch points that bracket it: its uncertainty), ``message``."""

    category: str
    energy: float
    omega: float
    energy_range: tuple
    other_mode: int | None = None
    ratio: int | None = None
    message: str = ""
    kind = Renamed("category")

    @property
    def frequency_hz(self) -> float:
        """ω / 2π (Hz)."""
        return self.omega / (2 * math.pi)

    def to_dict(self) -> dict:
        return {"category": self.category, "energy_J": self.energy, "omega_rad_s": self.omega,
                "frequency_hz": self.frequency_hz, "energy_range_J": list(self.energy_range),
                "other_mode": self.other_mode, "ratio": self.ratio, "message": self.message}


@dataclass(frozen=True, eq=False)
class Backbone:
    """The backbone of one nonlinear normal mode (see :func:`backbone`), one entry per request, in the order given.

    ``omega`` fundamental angular frequency 2π/T (rad/s; ``frequency_hz`` alongside) and ``error`` its estimated
    error (rad/s: the shooting's closing residual and the flows' integration error, through the period's
    sensitivity); ``amplitude`` max over the orbit of |q_c − q_c,eq| of ``coordinate`` (m or rad, ``unit``) and
    ``amplitude_error``; ``energy`` total mechanical energy above the equilibrium's (J) and ``energy_error``;
    ``orbits`` the :class:`~vibdyn.analysis.nonlinear.periodic.PeriodicOrbit` of each request (``.trajectory``
    one period); ``stable`` (no Floquet multiplier beyond the unit circle by more than its uncertainty) and
    ``stability`` (the orbits' verdicts: "unstable", "stable", "neutral within the error"); ``resonances``
    (:class:`Resonance`: internal resonances and folds met on the followed branch up to the last request);
    ``mode`` (index into the undamped linear modes, ascending ω) and ``linear_omega`` (its ω, rad/s);
    ``q_eq`` the static equilibrium; ``requested`` ("amplitude" or "energy"); ``points`` branch points
    followed; ``note`` (what was left out: damping); ``elapsed`` (s); ``system`` the conservative scene used.
    """

    system: Any = field(repr=False)
    mode: int
    coordinate: str
    unit: str
    requested: str
    linear_omega: float
    omega: np.ndarray
    error: np.ndarray
    amplitude: np.ndarray
    amplitude_error: np.ndarray
    energy: np.ndarray
    energy_error: np.ndarray
    orbits: tuple = field(repr=False)
    resonances: tuple
    q_eq: np.ndarray = field(repr=False)
    points: int
    note: str
    elapsed: float

    @property
    def frequency_hz(self) -> np.ndarray:
        """ω / 2π (Hz) per request."""
        return self.omega / (2 * math.pi)

    @property
    def period(self) -> np.ndarray:
        """T = 2π/ω (s) per request."""
        return 2 * math.pi / self.omega

    @property
    def stable(self) -> np.ndarray:
        """Per request: no Floquet multiplier's modulus exceeds 1 by more than its uncertainty."""
        return np.array([o.stable for o in self.orbits], dtype=bool)

    @property
    def stability(self) -> tuple:
        """Per request: the orbit's verdict ("unstable", "stable" or "neutral within the error")."""
        return tuple(o.stability for o in self.orbits)

    def to_dict(self) -> dict:
        """Plain data (JSON-ready), SI units named in the keys; each orbit as :meth:`PeriodicOrbit.to_dict`."""
        return {"mode": self.mode, "coordinate": self.coordinate, "unit": self.unit, "requested": self.requested,
                "linear_omega_rad_s": self.linear_omega, "omega_rad_s": self.omega.tolist(),
                "omega_error_rad_s": self.error.tolist(), "frequency_hz": self.frequency_hz.tolist(),
                "period_s": self.period.tolist(), f"amplitude_{self.unit}": self.amplitude.tolist(),
                f"amplitude_error_{self.unit}": self.amplitude_error.tolist(), "energy_J": self.energy.tolist(),
                "energy_error_J": self.energy_error.tolist(), "stable": self.stable.tolist(),
                "stability": list(self.stability), "resonances": [r.to_dict() for r in self.resonances],
                "points": self.points, "note": self.note, "elapsed_s": self.elapsed,
                "orbits": [o.to_dict() for o in self.orbits]}

    def plot(self, path: Any = None, dpi: Any = 100, *, ax: Any = None) -> Any:
        """The frequency–energy plot (:func:`vibdyn.faces.plots.frequency_energy`), saved to ``path`` (first, as every
        result's ``plot``), on ``ax`` (an Axes; given first, the former order, taken as ``ax``). Returns the Figure."""
        from ...faces import plots

        return plots.frequency_energy(self, **plots.axes_first(path, dpi, ax))

    def __str__(self):
        u = self.unit
        # (mode = index, counted from 0 as the API takes it; "mode n" elsewhere counts from 1, as `vibdyn modes`)
        lines = [f"backbone of mode index {self.mode} (mode {self.mode + 1}; linear ω = "
                 f"{number(self.linear_omega, 'rad/s', digits=10)}, "
                 f"{number(self.linear_omega / (2 * math.pi), 'Hz')}), amplitude of '{self.coordinate}', "
                 f"{len(self.omega)} {self.requested} requests, {self.points} branch points, {duration(self.elapsed)}"]
        rows = [[number(a, u, digits=10), number(e, "J", digits=10), number(w, "rad/s", digits=12), f"{de:.1e}",
                 number(w / (2 * math.pi), "Hz", digits=10), s]
                for a, e, w, de, s in zip(self.amplitude, self.energy, self.omega, self.error, self.stability)]
        lines += ["  " + line for line in table(["amplitude", "energy", "ω", "± ω (rad/s)", "f", "stability"], rows)]
        for r in self.resonances:
            lines.append(f"  {r.category}: {r.message}")
        if not self.resonances:
            lines.append("  no internal resonance or fold met on the branch")
        lines.append(f"  note: {self.note}")
        return "\n".join(lines)

    def __repr__(self):
        return summary("Backbone", f"mode index {self.mode}", f"'{self.coordinate}'", f"{len(self.omega)} points",
                       f"ω {number(float(self.omega.min()), 'rad/s')} … {number(float(self.omega.max()), 'rad/s')}",
                       f"{len(self.resonances)} resonances", duration(self.elapsed))


def backbone(system: Any, mode: int, amplitudes: ArrayLike | None = None, energies: ArrayLike | None = None,
             coordinate: str | None = None, *, equilibrium: Any = None, tol: float = TOL, rtol: float = RTOL,
             max_steps: int = 400) -> Backbone:
    """The backbone of the nonlinear normal mode grown from linear mode ``mode`` (index into the undamped modes
    of the linearisation at the static equilibrium, ascending ω), at each of ``amplitudes`` (m or rad: max over
    the orbit of |q_c − q_c,eq| of ``coordinate``, default the coordinate with the largest share of the linear
    mode) or ``energies`` (J, total mechanical energy above the equilibrium's): exactly one of the two.

    Continued by pseudo-arclength from the linear mode (see the module docstring); each request is solved
    exactly (never interpolated), by shooting at closing tolerance ``tol`` (scaled) with flows at ``rtol``.
    ``equilibrium``: the static equilibrium (an OperatingPoint) or a configuration to search it from (default:
    from the neutral configuration). Damping is left out: a damped scene's backbone is that of its conservative
    part (dampers and velocity-dependent forces dropped; said in ``.note``).

    Raises ModelError for bad input (both or neither of amplitudes/energies, a request ≤ 0 or not finite, a mode
    index out of range, a rigid or unstable mode, scenes with loops, drives, supports or time-dependent forces)
    and ConvergenceError for a request beyond the followed branch (naming the largest amplitude and energy
    reached and why the branch stopped).
    """
    start = time.perf_counter()
    what = "backbone"
    requested, requests = checked_requests(amplitudes, energies, what)
    tol = scalar(tol, f"{what}: tol", positive=True)
    rtol = scalar(rtol, f"{what}: rtol", positive=True)
    max_steps = integer(max_steps, f"{what}: max_steps", minimum=1)
    cons, note = _conservative_part(system, what)
    q_eq = static_configuration(cons, equilibrium, what)
    modes = cons.linearize(q_eq).modes()
    k = mode_index(mode, modes, what)
    phi = np.asarray(modes.shapes[:, k], dtype=float)
    s = np.asarray(cons.coordinate_scales, dtype=float)
    c = (cons.coordinate_index(coordinate) if isinstance(coordinate, str)
         else bad_coordinate(coordinate, what) if coordinate is not None else int(np.argmax(np.abs(phi) / s)))
    if abs(phi[c]) < 1e-8 * float(np.max(np.abs(phi) / s)) * s[c]:
        raise ModelError(f"{what}: coordinate '{cons.coordinates[c]}' does not move in mode {k} (its share of the "
                         "linear mode is zero): choose a coordinate that moves")
    if requested == "amplitude" and cons.units[c] == "rad":
        hint(degrees_hint([(cons.coordinates[c], a) for a in requests]), f"{what}: amplitudes")
    if requested == "amplitude":
        within_a_turn(cons, c, requests, what)
    phi = phi / phi[c]  # the coordinate c moves by 1 (m or rad)
    _resolvable(cons, q_eq, phi, c, float(modes.omega[k]), requested, requests, what)
    follower = _Follower(cons, q_eq, phi, c, float(modes.omega[k]), modes, k, requested, requests, rtol, tol)
    order = np.argsort(requests, kind="stable")
    solved = follower.run(requests[order], max_steps)
    out: list[Any] = [None] * len(requests)
    for i, (z, slope, runs) in zip(order, solved):
        out[i] = follower.request(z, slope, float(requests[i]), runs)
    cols = [np.array([o[j] for o in out]) for j in range(6)]
    orbits = tuple(o[6] for o in out)
    if follower.jumps:
        note += (f"; the multipliers' angles moved by more than π/2 over {follower.jumps} branch step(s): an internal "
                 "resonance there may be missed")
    return Backbone(cons, k, cons.coordinates[c], cons.units[c], requested, float(modes.omega[k]), cols[0], cols[1],
                    cols[2], cols[3], cols[4], cols[5], orbits, tuple(follower.resonances), q_eq,
                    follower.points, note, time.perf_counter() - start)


# ---------------------------------------------------------------------------------------------- checks
def _resolvable(system, q_eq, phi, c, omega, requested, requests, what):
    """ModelError for a request whose energy above rest (½ ω² a² φᵀMφ for an amplitude a) is within
    4 · MIN_ENERGY_RATIO times the round-off of the scene's energy (periodic_orbit's floor, amplitude × 2):
    its orbit cannot be told from its neighbours; the message names the smallest request resolved."""
    stiffness = omega**2 * float(phi @ system.mass_matrix(q_eq) @ phi)  # J per (m or rad)² of c, times 2
    floor = 4 * MIN_ENERGY_RATIO * energy_roundoff(system, q_eq, np.zeros(system.nv), 0.0)
    energies = requests if requested == "energy" else 0.5 * stiffness * requests**2
    small = np.flatnonzero(energies <= floor)
    if small.size:
        i, unit = int(small[0]), "J" if requested == "energy" else system.units[c]
        least = floor if requested == "energy" else math.sqrt(2 * floor / stiffness)
        raise ModelError(f"{what}: the {requested} {float(requests[i]):.3g} {unit} (entry {i}) is too close to "
                         "rest: the orbit's energy is within the round-off of the scene's energy, so it cannot be told "
                         f"from its neighbours; ask for at least about {least:.1g} {unit} (the small orbits' frequency "
                         f"tends to the linear one, ω = {number(omega, 'rad/s', digits=10)})")


def _conservative_part(system, what):
    """(the System with its dampers and velocity-dependent forces off — a view of the compiled System, nothing
    rebuilt — and the note)."""
    system.reduction.require("backbones", what)  # (loops, drives)
    has_coordinates(system, what, "oscillates")
    if system.supports:
        raise ModelError(f"{what}: the scene has drives or moving supports: a backbone needs an autonomous scene")
    timed = [type(g).__name__ for g in system.force_groups if g.time_dependent]
    if timed:
        raise ModelError(f"{what}: the scene's forces depend on time ({', '.join(timed)}): a backbone needs an "
                         "autonomous scene")
    note = "conservative scene: the backbone of its own free motion"
    if not conservative(system):
        # a view of the compiled System with its velocity-dependent groups (dampers, velocity-dependent laws) off;
        # a group that holds other elements too would take them with it: those are refused below, as remaining
        dropped = [g for g in system.force_groups if g.velocity_dependent]
        kinds = {type(g) for g in dropped}
        names = [name for name, e in system.scene.elements.items() if type(e).group in kinds]
        mixed = [name for name in names if not _velocity_dependent(system.scene.elements[name])]
        view = system.without_groups(dropped)
        if mixed or not conservative(view):
            kinds = sorted({type(g).__name__ for g in view.force_groups if type(g).potential is ForceGroup.potential}
                           | {type(g).__name__ for g in dropped if mixed})
            raise ModelError(f"{what}: forces without a potential remain once dampers are dropped "
                             f"({', '.join(kinds) or 'applied forces'}): a backbone needs a conservative scene")
        system = view
        note = (f"damping left out: the backbone of the conservative part ({', '.join(names)} dropped: dampers "
                "and velocity-dependent forces)")
    return system, note


def _velocity_dependent(element):
    if getattr(element, "velocity_dependent", False):
        return True
    group = type(element).group
    return group is not None and bool(getattr(group, "velocity_dependent", False) is True)


# ---------------------------------------------------------------------------------------------- the branch
class _Follower:
    """The continuation of one NNM: unknowns z = (ξ, v0, T) (q0 = q_eq ⊕ ξ), parameter λ (the energy above the
    equilibrium's, J, or ξ_c, m or rad); the points' monitoring (periods, multipliers' angles, resonances)."""

    def __init__(self, system, q_eq, phi, c, omega, modes, k, requested, requests, rtol, tol):
        self.system, self.model, self.q_eq, self.c = system, system.model, q_eq, c
        self.n, self.rtol, self.tol, self.requested = system.nv, rtol, tol, requested
        self.omega_lin, self.T_lin = omega, 2 * math.pi / omega
        self.E_eq = system.energy(q_eq, np.zeros(system.nv)).total
        self.omega_max = float(np.max(modes.omega))
        M = system.mass_matrix(q_eq)
        self.m_phi = m_phi = float(phi @ M @ phi)  # E = ½ ω² a² φᵀMφ for the linear mode of amplitude a
        # per coordinate, its motion per unit amplitude of c: the mode's share, at least a tenth of c's by kinetic
        # energy (m or rad per m or rad): the scales of the unknowns come from the motion, never from the scene's
        # size or where its bodies sit
        self.shape = np.maximum(np.abs(phi), 0.1 * np.sqrt(M[c, c] / np.diag(M)))
        self.a0 = self.linear_start(0.5 * self.amplitude_of(float(np.min(requests))), phi, omega**2 * m_phi)
        self.z0 = np.concatenate([self.a0 * phi, np.zeros(self.n), [self.T_lin]])
        # the other oscillating modes' rotation angles θ_j = 2π ω_j/ω (their multipliers e^{±iθ_j})
        others = [j for j in range(len(modes.omega)) if j != k and not modes.unstable[j] and not modes.rigid[j]]
        self.others = others
        self.theta = np.array([2 * math.pi * modes.omega[j] / omega for j in others])
        self.resonances: list = []
        self.jumps = 0  # branch steps over which a multiplier's angle moved by more than π/2 (tracking unsure)
        self.points = 0
        self.last = None  # (λ, energy, ω) of the last branch point
        self.reached = (0.0, 0.0)  # (largest amplitude, largest energy) on the branch
        self.why = ""
        self.failure = ""  # why the last flow of the current leg that could not be integrated failed

    # ------------------------------------------------------------------ unknowns
    def state(self, z):
        n = self.n
        return pin.integrate(self.model, self.q_eq, z[:n]), np.array(z[n:2 * n]), float(z[2 * n])

    def energy(self, q, v):
        return self.system.energy(q, v).total - self.E_eq

    def amplitude_of(self, request):
        """The amplitude (m or rad) of c a request means: itself, or the linear mode's at that energy (J)."""
        return request if self.requested == "amplitude" else math.sqrt(2 * request / (self.omega_lin**2 * self.m_phi))

    def linear_start(self, a, phi, stiffness):
        """The largest of a, a/2, a/4, … (m or rad) at which the potential along the mode, V(q_eq ⊕ a φ), departs
        from its quadratic ½ a² ``stiffness`` (J) by at most START_SHIFT of it, or by its own round-off."""
        for _ in range(60):
            quad = 0.5 * a * a * stiffness
            V = self.energy(pin.integrate(self.model, self.q_eq, a * phi), np.zeros(self.n))
            if abs(V - quad) <= max(START_SHIFT * quad, 1e3 * np.finfo(float).eps * abs(self.E_eq)):
                break
            a *= 0.5
        return a

    def scales(self, a):
        """Per coordinate, what one unit of the shooting's unknowns is (m or rad) on an orbit where c moves by a."""
        return max(a, self.a0) * self.shape

    def energy_gradient(self, q, v):
        """∂E/∂(δq, δv) at (q, v), δq in the tangent space at q (central differences of 1e-6 of the motion's
        scales: q is a turning point of c; M v)."""
        s = self.scales(abs(float(pin.difference(self.model, self.q_eq, q)[self.c])))
        return energy_gradient(self.system, q, v, 1e-6 * s, reference=self.E_eq)

    def shooting(self, T, tight, a, loose=False):
        """The shooting equations at period guess T for orbits where c moves by about a (m or rad: the residual's
        scales): flows at the caller's rtol for a request (``tight``), at CONTINUATION_RTOL along the branch
        (steps resolve the orbit's own ω; DOP853 controls the rest); ``loose``: their state transitions at
        CONTINUATION_TRANSITION_RTOL."""
        omega = 2 * math.pi / T
        rtol = self.rtol if tight else max(self.rtol, CONTINUATION_RTOL)
        fastest = max(self.omega_max, omega) if tight else omega
        return Shooting(self.system, 0.0, T, True, 1, omega, rtol, ("velocity", self.c), None, self.scales(a),
                        STEP_RESOLUTION / fastest, max(rtol, CONTINUATION_TRANSITION_RTOL) if loose else None)

    # ------------------------------------------------------------------ equations
    def equations(self, shoot, row_scale):
        n, c = self.n, self.c

        def fun(z, lam):
            q0, v0, T = self.state(z)
            x = shoot.pack([(q0, v0)], T)
            if T > 0:
                try:
                    shoot.flows(x)  # (kept: the residual uses these flows)
                except SimulationError as e:  # the residual is then not finite: the step is shortened
                    self.failure = str(e.__cause__ or e)  # (the cause: not the run's internal times)
            r = shoot.residual(x)
            p = self.energy(q0, v0) if self.requested == "energy" else z[c]
            return np.append(r, (p - lam) / row_scale)

        def jac(z, lam):
            q0, v0, T = self.state(z)
            J = shoot.jacobian(shoot.pack([(q0, v0)], T)) / shoot.unknown_scale[None, :]
            Jr = pin.dIntegrate(self.model, self.q_eq, z[:n], ARG1)
            J[:, :n] = J[:, :n] @ Jr
            row = np.zeros(2 * n + 2)
            if self.requested == "energy":
                g = self.energy_gradient(q0, v0)
                row[:n], row[n:2 * n] = g[:n] @ Jr, g[n:]
            else:
                row[c] = 1.0
            row[-1] = -1.0
            return np.vstack([np.hstack([J, np.zeros((J.shape[0], 1))]), row / row_scale])

        return fun, jac

    # ------------------------------------------------------------------ the run
    def run(self, targets, max_steps):
        """[(z at each target (ascending), dω/dλ there, the flows from z or None)]; ConvergenceError past the
        branch's end."""
        z = self.z0
        q0, v0, T = self.state(z)
        lam = self.energy(q0, v0) if self.requested == "energy" else float(z[self.c])
        self.monitor(z, lam, None)
        out, steps, h, a_last, runs = [], 0, FIRST_STEP, None, None
        for target in targets:
            if target == lam and out:
                out.append(out[-1])
                continue
            # each leg's scales: its end's amplitude (or energy) and its start's period, not the scene's size
            a = max(abs(float(z[self.c])), self.amplitude_of(target))
            if a_last is not None:  # the last leg's step, in this leg's units
                h = min(max(h * max(a_last, self.a0) / max(a, self.a0), FIRST_STEP), MAX_STEP)
            branch, shoot = self.leg(z, lam, target, h, a, runs, max(1, max_steps - steps), loose=True)
            if branch.reason in ("floor", "step") and not self.why:
                # the looser transitions may be what stalls the corrector where the Jacobian is nearly singular (a
                # separatrix near): the leg goes on from where it stopped with transitions at the flows' rtol
                start = (branch.x[-1], float(branch.lam[-1])) if branch.lam.size else (z, lam)
                more, shoot = self.leg(*start, target, branch.step or h, a, None,
                                       max(1, max_steps - steps - branch.steps), loose=False)
                branch = branch.then(more)
            steps += branch.steps
            h, a_last = branch.step, a
            for f in branch.folds:
                q, v, Tf = self.state(f.x)
                e = self.energy(q, v)
                self.resonances.append(Resonance("fold", e, 2 * math.pi / Tf, (e, e), message=(
                    f"the branch folds back in {self.requested} at energy {number(e, 'J', digits=8)}, "
                    f"ω = {number(2 * math.pi / Tf, 'rad/s', digits=8)}: a turning point of the family (an internal "
                    "resonance's tongue, or the branch turning)")))
            if branch.status != "finished" or branch.lam.size == 0 or branch.lam[-1] != target:
                self.beyond(target, branch)
            if branch.lam.size > 1 and self.last is not None:
                self.monitor(branch.x[-1], float(branch.lam[-1]), shoot)
            (z, runs, slope), lam = self.exact(branch.x[-1], float(target)), float(target)
            # |dω/dλ|: the larger of the tangent's and the last step's secant (which lags a bending backbone)
            if branch.lam.size > 1 and branch.lam[-1] != branch.lam[-2]:
                slope = max(slope, abs(float((2 * math.pi / branch.x[-1, -1] - 2 * math.pi / branch.x[-2, -1])
                                             / (branch.lam[-1] - branch.lam[-2]))))
            out.append((z, slope, runs))
        return out

    def leg(self, z, lam, target, h, a, runs, max_steps, loose):
        """(Branch, its Shooting) from (z, λ) to λ = target, first step h, scaled for orbits where c moves by a (m or
        rad); ``runs``: z's flows if made; ``loose``: Φ at CONTINUATION_TRANSITION_RTOL. ConvergenceError where a flow
        cannot be integrated."""
        T = self.state(z)[2]
        shoot = self.shooting(T, False, a, loose)
        if runs is not None:  # the last request's flows from z (at its tighter rtol): the leg's start as they are
            q0, v0, _ = self.state(z)
            shoot.seed(shoot.pack([(q0, v0)], T), runs)
        fun, jac = self.equations(shoot, max(target, lam))
        xi = self.scales(a)
        self.failure = ""
        try:
            scale = np.concatenate([xi, xi * 2 * math.pi / T, [T], [max(target, lam)]])
            path = Arclength(h, max(self.tol, CONTINUATION_TOL), max_steps, MIN_STEP, MAX_STEP, scale, curvature=True)
            return continuation(fun, z, lam, float(target), jacobian=jac, path=path,
                                stop=lambda x, lm: self.monitor(x, lm, shoot),
                                parameter=f"the {self.requested} ({self.request_unit()})"), shoot
        except (SimulationError, np.linalg.LinAlgError) as e:
            self.why = self.why or f"the motion could not be integrated further: {e.__cause__ or e}"
            self.beyond(target, None)

    def exact(self, z, target):
        """The branch point at λ = target solved again with the request's tolerances (tol, rtol), the request's
        row weighted REQUEST_WEIGHT times the closing rows (down to the energy's round-off): the orbit meets the
        request well within its own closing error. Returns (z, the flows from z where they are the last ones made,
        else None, |dω/dλ| there: the branch's tangent from the Jacobian at z, in rad/s per J or per m or rad)."""
        shoot = self.shooting(self.state(z)[2], True, abs(float(z[self.c])))
        noise = 100 * np.finfo(float).eps * (abs(self.E_eq) + target) / self.tol if self.requested == "energy" else 0
        fun, jac = self.equations(shoot, max(target / REQUEST_WEIGHT, noise))
        res = newton(lambda y: fun(y, target), z, lambda y: jac(y, target)[:, :-1], tol=self.tol, max_iter=10,
                     rcond=RCOND, steps=Steps(stall=100.0))
        if not (res.converged or res.residual <= 100 * self.tol):
            why = {"max_iter": "in 10 Newton iterations", "diverged": "the motion could not be integrated"}.get(
                res.status, "no Newton step closes it further")
            raise ConvergenceError(f"backbone: the {self.requested} {self.request_text(target)} was reached along "
                                   f"the branch, but its orbit could not be closed to tol = {self.tol:.1e} ({why}): "
                                   "try a looser tol, or a tighter rtol", residual=res.residual, best=res.x)
        if res.iterations == 0 and res.residual > 0:
            # (a loose tol, met at the branch point: one step all the same, the request met to its closing error)
            y = res.x + np.linalg.lstsq(jac(res.x, target)[:, :-1], -fun(res.x, target), rcond=RCOND)[0]
            r = float(np.abs(fun(y, target)).max())
            if r < res.residual:
                res = replace(res, x=y, residual=r, iterations=1)
        q0, v0, T = self.state(res.x)
        runs = shoot.cached(shoot.pack([(q0, v0)], T))
        # the tangent (J dz = −∂F/∂λ: the closing rows hold, the request's moves with λ) from z's flows, if at hand
        slope = 0.0
        if runs is not None:
            J = jac(res.x, target)
            dz = np.linalg.lstsq(J[:, :-1], -J[:, -1], rcond=RCOND)[0]
            slope = abs(2 * math.pi / T**2 * float(dz[-1]))
        return res.x, runs, slope

    def request_unit(self):
        return "J" if self.requested == "energy" else self.unit()

    def request_text(self, target):
        return number(target, self.request_unit(), digits=6)

    def beyond(self, target, branch):
        a, e = self.reached
        why = self.why or self.reason(branch)
        if not self.why and self.last is not None and self.last[2] < self.omega_lin / 3:
            why += (f"; the period has grown to {2 * math.pi / self.last[2]:.4g} s, "
                    f"{self.omega_lin / self.last[2]:.3g} times the linear one: a separatrix (infinite period) is near")
        best = branch.x[-1] if branch is not None and branch.x.size else None
        raise ConvergenceError(
            f"backbone: the {self.requested} {self.request_text(target)} is beyond the followed branch: largest "
            f"amplitude reached {a:.6g} {self.unit()}, largest energy {e:.6g} J ({why})",
            residual=None if branch is None else branch.residual, best=best)

    def reason(self, branch):
        """Why the branch ended, in words (no internal quantity)."""
        failed = f"; beyond it the motion could not be integrated: {self.failure}" if self.failure else ""
        return {"start": "no orbit was found where this stretch of the branch starts",
                "max_steps": "the limit of max_steps continuation steps was reached: give a larger max_steps",
                "floor": "the orbits' closing error cannot be brought below the continuation's tolerance there: "
                         "the flows are not computed more accurately than that",
                "step": "the branch could not be followed further: a bifurcation, or a turning point it could not "
                        f"pass{failed}"}.get(branch.reason, branch.message)

    def unit(self):
        return self.system.units[self.c]

    def monitor(self, z, lam, shoot):
        """Called at every branch point (the continuation's ``stop``): records how far the branch went, follows
        the nontrivial multipliers' angles (a crossing of 2πk: a k:1 internal resonance), stops where the period
        grows without bound (a separatrix)."""
        q0, v0, T = self.state(z)
        e, w = self.energy(q0, v0), 2 * math.pi / T
        self.points += 1
        x = float(z[self.c])  # (an angle's swing taken the shorter way round: q and q ± 2π are one pose)
        x = abs(math.remainder(x, 2 * math.pi) if self.c in self.system.periodic_tangents else x)
        self.reached = (max(self.reached[0], x), max(self.reached[1], e))
        if shoot is not None and self.theta.size:
            theta = self.angles(shoot, q0, v0, T)
            if theta is not None and self.last is not None:
                for j, (a, b) in enumerate(zip(self.theta, theta)):
                    ka, kb = math.floor(a / (2 * math.pi)), math.floor(b / (2 * math.pi))
                    if ka != kb:
                        k = max(ka, kb)
                        f = (2 * math.pi * k - a) / (b - a) if b != a else 0.5
                        e0, w0 = self.last[1], self.last[2]
                        ei, wi = e0 + f * (e - e0), w0 + f * (w - w0)
                        j_mode = self.others[j]
                        self.resonances.append(Resonance(
                            "internal resonance", ei, wi, (min(e0, e), max(e0, e)), j_mode, k,
                            f"a {k}:1 internal resonance with mode {j_mode} (its Floquet multiplier reaches +1) at "
                            f"energy ≈ {number(ei, 'J', digits=6)} (between {e0:.6g} and {e:.6g} J), ω ≈ "
                            f"{number(wi, 'rad/s', digits=6)}: continued past it; the orbits beyond are flagged"))
            if theta is not None:
                if np.any(np.abs(theta - self.theta) > 0.5 * math.pi):
                    self.jumps += 1
                self.theta = theta
        self.last = (lam, e, w)
        if T > MAX_PERIOD_GROWTH * self.T_lin:
            self.why = (f"the period grew to {T:.4g} s, {MAX_PERIOD_GROWTH:g} times the linear one: a separatrix "
                        "(an orbit of infinite period) is near")
            return True
        return False

    def angles(self, shoot, q0, v0, T):
        """The nontrivial multipliers' angles, unwrapped from the previous point's (None if unavailable)."""
        x = shoot.pack([(q0, v0)], T)
        try:
            runs = shoot.flows(x)
        except Exception:  # noqa: BLE001 - a point whose flow fails is simply not monitored
            return None
        P = shoot.segment_maps([(q0, v0)], runs)[0][0]
        d = shoot.node_scale
        P = P * (1.0 / d)[:, None] * d[None, :]
        a = self.system.accelerations(q0, v0)
        f = np.concatenate([v0, a]) / d
        g = self.energy_gradient(q0, v0) * d
        W = sla.null_space(np.vstack([g, f]))
        if W.shape[1] != 2 * self.n - 2:
            return None
        mu = np.linalg.eigvals(W.T @ P @ W)
        # each angle moves to the nearest multiplier's (modulo 2π), one multiplier each: the least total move
        moves = ((np.angle(mu)[None, :] - self.theta[:, None] + math.pi) % (2 * math.pi)) - math.pi
        out = self.theta.copy()
        rows, cols = assign(np.abs(moves))
        out[rows] += moves[rows, cols]
        return out

    # ------------------------------------------------------------------ a request
    def request(self, z, slope, target, runs=None):
        """(ω, its error, amplitude, its error, energy, its error, PeriodicOrbit) at the branch point z solved for
        the request ``target`` (J or m/rad): ω's error is that of ω at the request — the orbit's own, plus dω/dλ
        times how far the orbit's energy or amplitude is from the request (the closing tolerance's share).
        ``runs``: the flows from z at the request's rtol (the exact solve's), the orbit's first run."""
        q0, v0, T = self.state(z)
        name = self.system.coordinates[self.c]
        orbit = orbit_from(self.system, q0, v0, T, phase=name, tol=self.tol, rtol=self.rtol,
                           first=None if runs is None else runs[0])
        omega = orbit.omega
        err_w = 2 * math.pi * orbit.period_error / orbit.period**2 + 16 * np.finfo(float).eps * omega  # (+ round-off)
        amp, amp_extra = self.amplitude(orbit)
        amp_err = orbit.error + amp_extra
        g = self.energy_gradient(orbit.q0, orbit.v0)
        e = self.energy(orbit.q0, orbit.v0)
        err_e = float(np.abs(g[:self.n]).sum() * orbit.error + np.abs(g[self.n:]).sum() * orbit.velocity_error)
        if self.requested == "energy":
            err_w += abs(slope) * (err_e + abs(e - target))
        else:
            err_w += abs(slope) * (amp_err + abs(amp - target))
        return omega, err_w, amp, amp_err, e, err_e, orbit

    def amplitude(self, orbit):
        """(max over the orbit of |q_c − q_c,eq|, the error it adds to the orbit's own): at the start (a turning
        point of c by the phase condition: nothing to add) or at the other turning points (zeros of v_c), each
        between two samples of the orbit's trajectory where v_c changes sign, located by a simulation's events over
        that interval (and half the next) from the first sample: that sample's estimated error carried over the
        interval plus that run's global error estimate (the location's own error costs nothing at a turning point,
        where q_c is stationary)."""
        c, T, traj = self.c, orbit.period, orbit.trajectory
        best = abs(float(self.system.difference(self.q_eq, orbit.q0)[c]))

        def turning(t, q, v):
            return float(v[c])

        scale = self.scales(best)  # (the flow's absolute tolerance from the motion, not from the scene's size)
        atol = self.rtol * np.concatenate([scale, scale * orbit.omega])
        t0, extra = float(traj.t[0]), 0.0
        flow = Flow(self.system, traj.q[0], traj.v[0], rtol=self.rtol, atol=atol, error_method="rerun")
        vc = np.asarray(traj.v)[:, c]
        end = float(traj.t[-1])
        for k in np.flatnonzero(vc[:-1] * vc[1:] <= 0.0):
            # (on to half the next interval: a turning point at a sample, as T/2 of a reversible orbit is, may fall
            # just past the interval in the run from k)
            a, b = float(traj.t[k]), float(traj.t[k + 1])
            run = flow(traj.q[k], traj.v[k], a, min(b + 0.5 * (b - a), end), events=turning)
            carried = float(traj.q_error[k]) + float(traj.v_error[k]) * (b - a)
            for t, q in zip(run.t_events[0], run.q_events[0]):
                if 1e-6 * T < t - t0 < (1 - 1e-6) * T:
                    amp = abs(float(self.system.difference(self.q_eq, q)[c]))
                    if amp > best:
                        best, extra = amp, carried + run.error  # (largest over the outputs and coordinates)
        return best, extra
