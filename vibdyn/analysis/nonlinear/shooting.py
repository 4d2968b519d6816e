"""Shooting on the configuration Lie group: the equations of a periodic orbit, their Jacobian from the time
layer's variational equations, solved by the solver kit's Newton (:func:`vibdyn.solvers.newton.newton`).

Unknowns: m nodes x_i = (q_i, v_i) at t_i = t0 + i·T/m (m = 1: single shooting; m > 1: multiple shooting),
moved in the tangent space (q_i ← integrate(q_i, δq_i), free coordinates only), and the period T of an
autonomous orbit. Equations, per segment i (node m is node 0):

    difference(q_{i+1}, q(t_i + T/m; x_i)) = 0,        v(t_i + T/m; x_i) − v_{i+1} = 0

(angles of pivots compared modulo 2π, so that a rotating orbit closes), with the Jacobian [D₁ Φ_i, D₀; Φ_vi, −1]
from each segment's state transition Φ_i (the time layer's :class:`vibdyn.simulation.flow.Flow` with
``variational=True``, tangent spaces: its settings checked once per problem) and Pinocchio's dDifference D₀,
D₁, and ∂/∂T = (D₁ v, a)/m at each segment's end. An autonomous orbit adds a phase condition on x_0 (its
tangent displacement from the start is orthogonal to the start's flow (v, a), or a chosen velocity is zero); a
conservative one also keeps the start's energy E(x_0) = E_start (its orbits form a family in the energy: fixing it picks
one member). The residuals and unknowns are scaled: positions by the coordinate scales (1 rad, the scene's length),
velocities by those × 2π/T, the period by T/2π, where a coordinate's scale is the larger of its own (1 rad, the scene's
length) and how far it moves in a first run from the start.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from ..._format import number
from ...description.elements.damper import Dampers
from ...description.elements.joint_damper import JointDampers
from ...errors import ConvergenceError, ModelError
from ...model.derivatives import linear_terms
from ...model.dynamics import energy_gradient
from ...model.groups import ForceGroup
from ...simulation.flow import Flow
from ...simulation.trajectory import SimulationError
from ...solvers.differences import derivative
from ...solvers.newton import Steps, newton

ARG0, ARG1 = pin.ArgumentPosition.ARG0, pin.ArgumentPosition.ARG1
GROWTH_PER_SEGMENT = 50.0  # automatic multiple shooting: each segment amplifies errors by at most about this
MAX_SEGMENTS = 64
RCOND = 1e-10  # singular values of the scaled Jacobian below this (relative) are its error: a family direction
MIN_ALPHA = 1.0 / 32  # the line search's shortest step: below it the flows' noise decides, not the model
STEP_CAP = 1.0  # largest Newton step per scaled unknown (1 rad, one length scale, T/2π)
ROUNDOFF = 16.0  # ulps of the energy's terms: its round-off
STILL = 1e-6  # a unit's coordinates moving less than this × their scales (motion_scales) are at rest
RESOLVED = 1e-3  # the flows resolve a coordinate to rtol of at least this × the largest motion of its unit
SCALE_RTOL = 1e-6  # the loose run that sizes the motion before the first flow (its steps cost little)
MAX_CYCLES = 200  # a period spanning more of the start's fastest natural periods is refused (each costs ~0.1 s)
MIN_GUESS = 1e-3  # an autonomous period guess below this share of the fastest natural period is refused
CHECK_STEP = 3e-5  # the transitions' check: flows from the nodes moved by this (and twice this) of the scales
# (1e-4 before: with Φ exact to its tolerance, the differences' truncation then exceeded the flows' error/h and the
# second pair ran on the ball pendulum's backbone; a stiffness 1e-4 too large is still caught)


def conservative(system) -> bool:
    """Whether the scene keeps its mechanical energy: autonomous, no velocity-dependent force, and every
    force element has a potential."""
    return not system.depends_on_time and not any(
        g.velocity_dependent or g.time_dependent or type(g).potential is ForceGroup.potential
        for g in system.force_groups)


def damping_only(system) -> np.ndarray | None:
    """Where the autonomous scene's only non-conservative forces are viscous dampers (on joints or between
    points: each takes energy from every motion that moves it): the joint dampers' coefficient per coordinate
    (N·s/m or N·m·s/rad, length nv; zeros where none); else None."""
    if system.depends_on_time:
        return None
    c = np.zeros(system.nv)
    for g in system.force_groups:
        if isinstance(g, JointDampers):
            c[g.iv] += g.c
        elif not isinstance(g, Dampers) and (g.velocity_dependent or g.time_dependent
                                             or type(g).potential is ForceGroup.potential):
            return None
    return c


def free_indices(system) -> np.ndarray:
    """Indices in v of the free coordinates (all but the driven ones)."""
    return np.asarray(system.reduction.free, dtype=int)


def turning_indices(system, free) -> np.ndarray:
    """Positions in ``free`` of the angles whose q is the angle itself (pivots): q and q ± 2π are one pose."""
    v_idx, q_idx = system.additive_coordinates
    turning = set(np.asarray(v_idx)[np.isin(q_idx, system.periodic_coordinates)].tolist())
    return np.array([k for k, i in enumerate(free) if int(i) in turning], dtype=int)


def wrapped(dq, wrap):
    """dq with the entries ``wrap`` brought into [−π, π) (a pivot that turned by whole turns has closed)."""
    if wrap.size:
        dq = np.array(dq, dtype=float)
        dq[wrap] = (dq[wrap] + math.pi) % (2 * math.pi) - math.pi
    return dq


class Shooting:
    """The shooting equations of one problem (see the module docstring). ``phase``: None (the period is
    given), ("flow", q_ref, v_ref, u) with u the unit scaled flow at the start, or ("velocity", k) (the free
    velocity number k is zero at t0); ``energy``: None or (E_target J, E_scale J); ``scales``: per tangent
    coordinate (m or rad; default the system's coordinate scales); ``transition_rtol``: the state transitions'
    own tolerance (None: rtol; looser where they only make the Newton steps, as along a continuation);
    ``flow_scales``: per tangent coordinate, the motion's size (m or rad) the flows' absolute tolerance is rtol of
    (None: ``scales``, or without them the flows' default, rtol of the coordinate scales)."""

    def __init__(self, system, t0, period, free_period, segments, omega, rtol, phase=None, energy=None, scales=None,
                 max_step=math.inf, transition_rtol=None, flow_scales=None):
        self.system, self.model, self.t0, self.m = system, system.model, float(t0), int(segments)
        self.period, self.free_period, self.rtol = float(period), bool(free_period), float(rtol)
        self.max_step = float(max_step)
        self.transition_rtol = transition_rtol
        self.reduction = system.reduction
        self.free = free_indices(system)
        self.free2 = np.concatenate([self.free, self.free + system.nv])
        n = self.n = self.free.size
        self.nq, self.nv = system.nq, system.nv
        cs = np.asarray(system.coordinate_scales, dtype=float)
        full = cs if scales is None else np.asarray(scales, dtype=float)
        self.s = full[self.free]
        # the energy row's difference steps (m or rad; those of coordinates that are not free are not used)
        self.h_energy = 1e-6 * cs
        self.h_energy[self.free] = 1e-6 * np.maximum(self.s, cs[self.free])
        # the flows' absolute tolerance: rtol of each coordinate's motion (``flow_scales``, default ``scales``), never
        # of the scene's length (a slider at the origin has a length scale of 1 mm: an orbit of metres then ran
        # ~70 times more steps, at tolerances below its round-off where it crosses 0)
        fs = full if flow_scales is None else np.asarray(flow_scales, dtype=float)
        self.atol = None if scales is None and flow_scales is None else float(rtol) * np.tile(fs, 2)
        self.omega = float(omega)
        self.node_scale = np.concatenate([self.s, self.s * self.omega])
        self.unknown_scale = np.concatenate([np.tile(self.node_scale, self.m)]
                                            + ([np.array([1.0 / self.omega])] if self.free_period else []))
        self.phase, self.energy = phase, energy
        self.extra = (phase is not None) + (energy is not None)
        self.rows = 2 * n * self.m + self.extra
        self.row_scale = np.concatenate([np.tile(self.node_scale, self.m), np.ones(self.extra)])
        self.wrap = turning_indices(system, self.free)
        self._cache = (None, None)
        self.evaluations = 0  # sets of flows integrated
        # the flows (with the variational equations) and the plain ones of the transitions' check, checked once
        # (at the first node flowed from)
        self._flow: Flow | None = None
        self._plain: Flow | None = None

    # ------------------------------------------------------------------ unknowns
    @staticmethod
    def impose(system, nodes, t0, T):
        """Nodes [(q, v)] with their driven coordinates set to the drives' values at t0 + i·T/m."""
        return [system.reduction.impose(q, v, t0 + i * T / len(nodes)) for i, (q, v) in enumerate(nodes)]

    def time(self, i, T):
        """Time (s) of node i."""
        return self.t0 + i * T / self.m

    def pack(self, nodes, T=None):
        parts = [np.concatenate([q, v]) for q, v in nodes]
        return np.concatenate(parts + ([np.array([T])] if self.free_period else []))

    def unpack(self, x):
        """([(q_i, v_i)], T)."""
        w = self.nq + self.nv
        nodes = [(x[i * w:i * w + self.nq], x[i * w + self.nq:(i + 1) * w]) for i in range(self.m)]
        return nodes, (float(x[-1]) if self.free_period else self.period)

    def retract(self, x, dx):
        """The unknowns moved by the scaled tangent step dx (configurations by ``integrate``)."""
        dx = np.asarray(dx, dtype=float) * self.unknown_scale
        nodes, T = self.unpack(x)
        if self.free_period:
            T = T + dx[-1]
        n, out = self.n, []
        for i, (q, v) in enumerate(nodes):
            d = dx[2 * n * i:2 * n * (i + 1)]
            dq = np.zeros(self.nv)
            dq[self.free] = d[:n]
            q1, v1 = pin.integrate(self.model, q, dq), np.array(v, dtype=float)
            v1[self.free] += d[n:]
            out.append(self.reduction.impose(q1, v1, self.time(i, T)))
        return self.pack(out, T)

    # ------------------------------------------------------------------ flows
    def flows(self, x, error="local", points=None, refine=1, full=False):
        """One run per segment from its node (variational equations included): a list of
        :class:`~vibdyn.simulation.flow.FlowResult`, or of Trajectory (energies at every output) with ``points``
        or ``full``. ``points``: equally spaced outputs per segment (None: every step); steps at most max_step /
        ``refine`` (the error estimate's run halves the steps: the variational equations' own convergence)."""
        key = x.tobytes()
        cached = error == "local" and points is None and refine == 1 and not full
        if cached and self._cache[0] == key:
            return self._cache[1]
        nodes, T = self.unpack(x)
        h, runs = T / self.m, []
        for i, (q, v) in enumerate(nodes):
            a = self.time(i, T)
            t_eval = None if points is None else np.linspace(a, a + h, points + 1)
            runs.append(self.flow(q, v)(q, v, a, a + h, t_eval=t_eval, error_method=error,
                                        max_step=self.max_step / refine, trajectory=full or points is not None))
        self.evaluations += 1
        if cached:
            self._cache = (key, runs)
        return runs

    def flow(self, q, v, variational=True):
        """The problem's Flow (with the variational equations, or ``variational=False`` the plain one), made on
        first use with the state (q, v) as its checked start (ModelError for one that cannot start a flow)."""
        if (self._flow if variational else self._plain) is None:
            made = Flow(self.system, q, v, rtol=self.rtol, atol=self.atol, variational=variational,
                        transition_rtol=self.transition_rtol if variational else None)
            if variational:
                self._flow = made
            else:
                self._plain = made
        return self._flow if variational else self._plain

    def cached(self, x):
        """The flows from x (FlowResults, as :meth:`flows` gives them) if they are the last ones integrated, else
        None."""
        return self._cache[1] if self._cache[0] == np.asarray(x, dtype=float).tobytes() else None

    def seed(self, x, runs):
        """Take ``runs`` as the flows from x (a run the caller made already, with this problem's settings)."""
        self._cache = (np.asarray(x, dtype=float).tobytes(), runs)

    def residual(self, x):
        """The scaled residual (non-finite where a flow cannot be integrated: the line search backs off)."""
        nodes, T = self.unpack(x)
        if not T > 0:
            return np.full(self.rows, np.inf)
        try:
            runs = self.flows(x)
        except SimulationError:
            return np.full(self.rows, np.inf)
        return self.residual_of(nodes, runs)

    def closing(self, nodes, runs):
        """Per segment, the unscaled mismatch (Δq tangent m or rad, Δv m/s or rad/s) at its end (free coordinates)."""
        out = []
        for i, run in enumerate(runs):
            qj, vj = nodes[(i + 1) % self.m]
            dq = wrapped(pin.difference(self.model, qj, run.q[-1])[self.free], self.wrap)
            out.append((dq, (run.v[-1] - vj)[self.free]))
        return out

    def residual_of(self, nodes, runs):
        r = [np.concatenate([dq, dv]) / self.node_scale for dq, dv in self.closing(nodes, runs)]
        q0, v0 = nodes[0]
        if self.phase is not None:
            r.append([self.phase_value(q0, v0)])
        if self.energy is not None:
            target, scale = self.energy
            r.append([(self.system.energy(q0, v0, self.t0).total - target) / scale])
        return np.concatenate(r)

    # ------------------------------------------------------------------ phase and energy rows
    def phase_value(self, q0, v0):
        if self.phase[0] == "velocity":
            k = self.phase[1]
            return float(v0[self.free[k]]) / (self.s[k] * self.omega)
        _, q_ref, v_ref, u = self.phase
        d = pin.difference(self.model, q_ref, q0)[self.free] / self.s
        return float(u @ np.concatenate([d, (v0 - v_ref)[self.free] / (self.s * self.omega)]))

    def phase_row(self, q0, v0):
        """∂(phase)/∂(δq_0, δv_0), unscaled unknowns."""
        n = self.n
        row = np.zeros(2 * n)
        if self.phase[0] == "velocity":
            k = self.phase[1]
            row[n + k] = 1.0 / (self.s[k] * self.omega)
            return row
        _, q_ref, _, u = self.phase
        D = pin.dDifference(self.model, q_ref, q0, ARG1)[np.ix_(self.free, self.free)]
        row[:n] = (u[:n] / self.s) @ D
        row[n:] = u[n:] / (self.s * self.omega)
        return row

    def energy_row(self, q0, v0):
        """∂E/∂(δq_0, δv_0) / E_scale: central differences in the tangent space for q (steps 1e-6 of each
        coordinate's scale, or of its motion where larger), M v for v."""
        return energy_gradient(self.system, q0, v0, self.h_energy, self.t0)[self.free2] / self.energy[1]

    # ------------------------------------------------------------------ Jacobian
    def jacobian(self, x):
        nodes, T = self.unpack(x)
        return self.jacobian_of(nodes, T, self.flows(x))

    def segment_maps(self, nodes, runs):
        """Per segment, its transition carried to the next node's tangent space: blockdiag(D₁, 1) Φ_i (free
        coordinates), and D₀ (∂ of the mismatch with respect to the next node's δq)."""
        f, n = self.free, self.n
        out = []
        for i, run in enumerate(runs):
            qj = nodes[(i + 1) % self.m][0]
            D0 = pin.dDifference(self.model, qj, run.q[-1], ARG0)[np.ix_(f, f)]
            D1 = pin.dDifference(self.model, qj, run.q[-1], ARG1)[np.ix_(f, f)]
            P = np.array(run.state_transition, dtype=float)
            if P.shape[0] != 2 * n:  # (with drives the time layer gives it over the free coordinates already)
                P = P[np.ix_(self.free2, self.free2)]
            P[:n] = D1 @ P[:n]
            out.append((P, D0, D1))
        return out

    def jacobian_of(self, nodes, T, runs):
        n, m = self.n, self.m
        J = np.zeros((self.rows, 2 * n * m + (1 if self.free_period else 0)))
        for i, ((P, D0, D1), run) in enumerate(zip(self.segment_maps(nodes, runs), runs)):
            j = (i + 1) % m
            ri, ci, cj = slice(2 * n * i, 2 * n * (i + 1)), slice(2 * n * i, 2 * n * (i + 1)), 2 * n * j
            J[ri, ci] += P
            J[2 * n * i:2 * n * i + n, cj:cj + n] += D0
            J[2 * n * i + n:2 * n * (i + 1), cj + n:cj + 2 * n] -= np.eye(n)
            if self.free_period:
                qe, ve, te = run.q[-1], run.v[-1], run.t[-1]
                a = self.system.accelerations(qe, ve, te)
                J[ri, -1] = np.concatenate([D1 @ ve[self.free], a[self.free]]) / m
        q0, v0 = nodes[0]
        k = 2 * n * m
        if self.phase is not None:
            J[k, :2 * n] = self.phase_row(q0, v0)
            k += 1
        if self.energy is not None:
            J[k, :2 * n] = self.energy_row(q0, v0)
        return J / self.row_scale[:, None] * self.unknown_scale[None, :]

    # ------------------------------------------------------------------ consistency of the transitions
    def check_transitions(self, nodes, T, runs, flow_error, directions=1):
        """Each segment's state transition Φ_i (variational equations) against central differences of its plain
        flows from the node moved by ±h δ along ``directions`` random unit scaled directions δ (h = CHECK_STEP
        of the scales; ``pin.integrate``, end states compared by ``pin.difference``). The differences' error: the
        flows' own (``flow_error``: per free coordinate, m or rad, then m/s or rad/s) over h, plus, only where
        Φ·δ is farther than that, their change from ±2h δ; Φ's: its estimated entry error times ‖δ‖₁. Returns the
        largest disagreement over those errors (≤ 1: consistent); ConvergenceError where it exceeds 1 (a wrong
        derivative in the variational equations: the Newton steps and the multipliers cannot be trusted)."""
        n, rng, worst = self.n, np.random.default_rng(0), 0.0
        for i, run in enumerate(runs):
            a, (q, v) = self.time(i, T), nodes[i]
            P = np.array(run.state_transition, dtype=float)
            if P.shape[0] != 2 * n:
                P = P[np.ix_(self.free2, self.free2)]
            for _ in range(directions):
                d = rng.standard_normal(2 * n)
                d *= self.node_scale / np.linalg.norm(d)
                def moved(s):  # (used within this iteration only)
                    return self.moved_end(q, v, a, a + T / self.m, run.q[-1], run.v[-1], s * d)

                fd = derivative(moved, 0.0, CHECK_STEP)
                gap = np.abs(P @ d - fd)
                err = float(run.state_transition_error) * np.abs(d).sum() + np.asarray(flow_error) / CHECK_STEP
                if np.any(gap > err):  # the differences' truncation error, from ±2h, only where it could matter
                    err = err + np.abs(fd - derivative(moved, 0.0, 2 * CHECK_STEP))
                ratios = gap / (err + 1e-300 * self.node_scale)
                k = int(np.argmax(ratios))
                worst = max(worst, float(ratios[k]))
                if ratios[k] > 1.0:
                    raise ConvergenceError(
                        f"periodic orbit: the variational equations disagree with the flows they linearise: over "
                        f"segment {i + 1} of {self.m}, Φ·δ and differences of the motion from the start moved by "
                        f"±δ (a random direction) differ by {gap[k] / self.node_scale[k]:.2e} (scaled), beyond both "
                        f"estimated errors ({err[k] / self.node_scale[k]:.1e}): the scene's "
                        f"derivatives (∂q̈/∂q, ∂q̈/∂v) are wrong for one of its joint types or force elements; the "
                        "Newton steps and the Floquet multipliers cannot be trusted (please report the scene)",
                        residual=gap[k] / self.node_scale[k])
        return worst

    def moved_end(self, q, v, t0, t1, q_end, v_end, delta):
        """x(t1; x0 ⊕ δ) − x_end over the free coordinates (tangent at q_end, unscaled): a plain flow at the
        shooting's tolerances from (q, v) moved by δ (free coordinates, then their speeds)."""
        n = self.n
        dq = np.zeros(self.nv)
        dq[self.free] = delta[:n]
        v1 = np.array(v, dtype=float)
        v1[self.free] += delta[n:]
        q1 = pin.integrate(self.model, q, dq)
        run = self.flow(q1, v1, False)(q1, v1, t0, t1, max_step=self.max_step / 2, t_eval=[t1])
        return np.concatenate([pin.difference(self.model, q_end, run.q[-1])[self.free], (run.v[-1] - v_end)[self.free]])

    # ------------------------------------------------------------------ solution
    def solve(self, x0, tol, max_iter):
        """Newton from x0: (x, residual, iterations); a point where Newton stalls at the flows' noise (no step
        decreases the residual, or steps at round-off) is accepted within 100·tol. A ConvergenceError says what
        was reached and what to try."""
        try:
            f0 = self.residual(x0)
        except SimulationError as e:
            raise ConvergenceError(f"periodic orbit: the motion from the start cannot be integrated over a period "
                                   f"({e}): start closer to the orbit or use more segments", best=x0) from e
        if not np.all(np.isfinite(f0)):
            raise ConvergenceError("periodic orbit: the motion from the start cannot be integrated over a period: "
                                   "start closer to the orbit, or use more segments", best=x0)
        res = newton(self.residual, x0, self.jacobian, self.retract, tol=tol, max_iter=max_iter, rcond=RCOND,
                     steps=Steps(max_step=STEP_CAP, min_alpha=MIN_ALPHA, stall=100.0), start=(f0, None))
        accepted = res.converged or (res.status in ("stagnated", "no_decrease") and res.residual <= 100 * tol)
        if not accepted:
            hint = ("more segments (segments=...), " if self.m < MAX_SEGMENTS else "") + \
                "a better start (closer to the orbit), a smaller amplitude, or a looser tol"
            why = {"max_iter": f"in {max_iter} iterations", "diverged": "the motion diverged"}.get(
                res.status, "no step brought it closer")
            raise ConvergenceError(
                f"periodic orbit: shooting with {self.m} segment{'s' if self.m > 1 else ''} did not converge "
                f"({why}): the orbit still misses its start by {res.residual:.1e} of its size (each coordinate over "
                f"its scale, 1 rad or the scene's length, velocities over 2π/T), against tol = {tol:.1e}; try "
                f"{hint}", residual=res.residual, best=self.unpack(res.x))
        return res.x, res.residual, res.iterations


def growth_segments(transition) -> int:
    """Segments for multiple shooting so that each amplifies errors by about GROWTH_PER_SEGMENT at most,
    from a single run's state transition over the period."""
    g = float(np.linalg.norm(transition, 2)) if np.all(np.isfinite(transition)) else np.inf
    if not g > GROWTH_PER_SEGMENT:
        return 1
    return int(min(MAX_SEGMENTS, math.ceil(math.log(g) / math.log(GROWTH_PER_SEGMENT)))) if math.isfinite(g) \
        else MAX_SEGMENTS


def first_return(system, q0, v0, t0, omega, rtol):
    """(T, run): the time T (s) the motion from (q0, v0) takes to come back near its start — the first upward
    crossing of the section through the start orthogonal to its flow (scaled by ``omega`` rad/s) that comes back
    to within a tenth of how far the motion went — and the run that found it (at least T long). Looks over 3
    periods of ``omega``, then 4 times longer, 5 times."""
    free = free_indices(system)
    wrap = turning_indices(system, free)
    s = np.asarray(system.coordinate_scales, dtype=float)[free]
    a0 = system.accelerations(q0, v0, t0)
    u = np.concatenate([v0[free] / s, a0[free] / (s * omega)])
    if not np.linalg.norm(u) > 1e-12:
        raise ModelError("periodic orbit: the start (q0, v0) is an equilibrium (no flow there): start away from "
                         "it, e.g. displaced along a mode")
    u /= np.linalg.norm(u)

    def scaled(q, v):
        return np.concatenate([wrapped(system.difference(q0, q)[free], wrap) / s, (v - v0)[free] / (s * omega)])

    def section(t, q, v):
        return float(u @ scaled(q, v))

    setattr(section, "direction", 1)  # upward crossings only (the event protocol's attribute)
    span = 3 * 2 * math.pi / omega
    flow = Flow(system, q0, v0, rtol=max(rtol, 1e-9))
    for _ in range(5):
        traj = flow(q0, v0, t0, t0 + span, events=section)
        dist = np.array([np.linalg.norm(scaled(q, v)) for q, v in zip(traj.q, traj.v)])
        for tc, qc, vc in zip(traj.t_events[0], traj.q_events[0], traj.v_events[0]):
            dc = float(np.linalg.norm(scaled(qc, vc)))
            went = dist[traj.t < tc].max(initial=0.0)
            if went > 0 and dc < 0.1 * went:
                return float(tc - t0), traj
        span *= 4
    raise ConvergenceError(f"periodic orbit: the motion from the start does not come back near it within "
                           f"{span / 4:.4g} s: give the period (s), or start on (or near) a periodic orbit")


def motion_scales(system, run, omega, relative=False):
    """Per tangent coordinate, the larger of its own scale (1 rad, the scene's length) and how far it moves
    in ``run`` (|Δq| from the start, |v|/ω): what one unit of the shooting unknowns means. ``relative`` (an
    autonomous orbit, which shrinks onto an equilibrium): below one scale of motion the floor is the motion's
    fraction ρ of the scales (ρ = the largest |Δq|/scale, |v|/(ω·scale)), so that the equations stay in units
    of the orbit however small it is."""
    q0 = run.q[0]
    dq = np.abs([system.difference(q0, q) for q in run.q]).max(axis=0)
    moves = np.maximum(dq, np.abs(run.v).max(axis=0) / omega)
    cs = np.asarray(system.coordinate_scales, dtype=float)
    rho = min(1.0, float((moves / cs).max(initial=0.0))) if relative else 1.0
    return np.maximum(cs * (rho if rho > 0 else 1.0), moves)


def flow_scales(system, run, omega, relative=True) -> np.ndarray:
    """Per tangent coordinate, the size of its motion in ``run`` (m or rad: |Δq| from the start, |v|/ω), at least
    RESOLVED × the largest motion of the coordinates of its unit: what the flows' absolute tolerance is rtol of. The
    scene's own scales enter only where nothing of that unit moves beyond STILL × them (ρ times them with
    ``relative``, an autonomous orbit: ρ the motion's fraction of them, as :func:`motion_scales` takes it)."""
    q0 = run.q[0]
    dq = np.abs([system.difference(q0, q) for q in run.q]).max(axis=0)
    moves = np.maximum(dq, np.abs(run.v).max(axis=0) / omega)
    out = motion_scales(system, run, omega, relative=relative)
    units = np.asarray(system.units)
    for unit in set(units.tolist()):
        kind = units == unit
        largest = float(moves[kind].max(initial=0.0))
        # (a unit at rest on the orbit, the shaken pendulum upright, "moves" by round-off: a tolerance of rtol ×
        # round-off would never let a step pass)
        if largest > STILL * float(out[kind].max()):
            out[kind] = np.maximum(moves[kind], RESOLVED * largest)
    return out


def energy_roundoff(system, q, v, t) -> float:
    """The round-off (J) of the scene's energy at (q, v, t): ROUNDOFF ulps of its terms' sizes (an energy
    difference below it, e.g. an orbit's energy above a nearby rest, is not resolved)."""
    e = system.energy(q, v, t)
    return ROUNDOFF * float(np.finfo(float).eps) * (abs(e.kinetic) + abs(e.gravity) + abs(e.elastic))


def resolvable_start(system, q, scales, free, tol, what, motion=False) -> None:
    """Refuse a start so far from neutral (an angle of 1e7 rad) that a double's round-off there exceeds half the
    closing tolerance of the motion: the shooting can then neither close nor stop (each flow's steps shrink to the
    round-off). ``scales`` (per tangent coordinate) the motion's size: guessed before any flow, measured by a first
    run with ``motion`` True."""
    size = np.abs(system.difference(system.neutral(), q))
    roundoff = size * np.finfo(float).eps
    bad = [i for i in free if roundoff[i] > 0.5 * tol * scales[i]]
    if bad:
        i = bad[0]
        unit = system.units[i]
        hint = ("start within a few turns of neutral (an angle less 2π·k, the same pose where nothing depends on the "
                "turns)") if unit == "rad" else "place the scene (or its rest positions) nearer the motion"
        raise ModelError(f"{what}: {system.coordinates[i]} = {size[i]:.3g} {unit} from neutral: at that size a "
                         f"number's round-off ({roundoff[i]:.1e} {unit}) exceeds the closing tolerance "
                         f"(tol = {tol:.0e} of {scales[i]:.3g} {unit}{', its motion' if motion else ''}); {hint}, "
                         "or give a looser tol")


def start_sizes(system, q, v, t, free) -> np.ndarray:
    """Before any flow, per tangent coordinate, how far the motion from (q, v) may go: 2 of the coordinate's scale (a
    pendulum's orbit moves by about that), and for a translation also |v|/ω and |a|/ω² at the start (ω its fastest
    frequency: a Duffing slider released 1000 m out in a scene of no length moves by about that)."""
    sizes = 2 * np.asarray(system.coordinate_scales, dtype=float)
    moving = np.asarray(system.units) != "rad"
    w = fastest_frequency(system, q, v, t, free) if moving[free].any() else 0.0
    if w > 0.0:
        a = np.asarray(system.accelerations(q, v, t), dtype=float)
        guess = np.maximum(np.abs(v) / w, np.abs(a) / w**2)
        sizes = np.where(moving & np.isfinite(guess), np.maximum(sizes, guess), sizes)
    return sizes


def fastest_frequency(system, q, v, t, free):
    """The start's largest frequency (rad/s): of √|eig(M⁻¹K)| there and the angles' speeds (a turning pivot's); 0
    where there is none (or it is not finite)."""
    M, K, _ = linear_terms(system, q, v, t)
    f = np.ix_(free, free)
    lam = np.abs(np.linalg.eigvals(np.linalg.solve(M[f], K[f])))
    angles = np.asarray(system.units)[free] == "rad"
    w = max(math.sqrt(float(lam.max(initial=0.0))), float(np.abs(v[free][angles]).max(initial=0.0)))
    return w if w > 0 and math.isfinite(w) else 0.0


def check_span(system, q, v, t, free, period, autonomous, what) -> None:
    """Refuse, before any flow, a period that the flows cannot resolve in reasonable time or that cannot be an
    orbit's: one spanning more than MAX_CYCLES of the start's fastest natural period 2π/ω (the flows step at most
    STEP_RESOLUTION/ω, so their cost grows with that count: about 0.08 s a cycle for one coordinate, each flow
    run several times by the shooting), or an autonomous guess shorter than MIN_GUESS of it (no orbit is that
    fast, and the shooting from it only finds rest)."""
    w = fastest_frequency(system, q, v, t, free)
    if w == 0.0:
        return
    natural = 2 * math.pi / w
    cycles = period / natural
    if cycles > MAX_CYCLES:
        raise ModelError(
            f"{what}: the period {number(period, 's', digits=6)} spans {cycles:.3g} of the scene's fastest natural "
            f"period at the start ({number(natural, 's', digits=6)}, ω = {number(w, digits=6)} rad/s): the flows "
            f"must resolve each of them, about 0.1 s each, and more than {MAX_CYCLES} are refused (over 20 s); for "
            "a linear response far below (or above) resonance use the receptance (System.linearize(...).receptance) or "
            "forced_response_curve (harmonic balance, no flows)")
    if autonomous and cycles < MIN_GUESS:
        raise ModelError(
            f"{what}: the period {number(period, 's', digits=6)} is too short: {cycles:.2g} of the scene's fastest "
            f"natural period at the start ({number(natural, 's', digits=6)}, ω = {number(w, digits=6)} rad/s "
            "from its stiffness and speeds there), and no orbit from this start is that fast; give a guess near "
            "the orbit's period, or none (found from the motion's first return)")
