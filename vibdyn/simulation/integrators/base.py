"""The stepper protocol every time integrator follows (in the manner of scipy's ``OdeSolver``).

A stepper advances the motion of a system from (q0, v0) at t0 towards t_end. It declares what it is —
``order``, ``adaptive`` (it chooses its steps: :meth:`Stepper.step`) or fixed (the caller gives each step's end:
:meth:`Stepper.step_to`), ``error_methods`` (how a run's error can be estimated, the default first),
``dense_output`` (it interpolates inside its last step, on demand: :meth:`Stepper.interpolant`) — and counts its
work: ``nfev`` dynamics evaluations,
``njev`` Jacobians, ``nlu`` LU factorisations (or inverses), ``accepted`` steps and ``rejected`` ones (None
when the underlying solver does not report them). ``state`` is (q, v, w) now (w: work integral, J), and
``local_error`` the accumulated local error per (q, v) component (tangent space) or None.

As in scipy's ``OdeSolver``, the base class owns the bookkeeping — ``t``, ``t_old`` (the last step's start),
``direction`` (+1: forward in time) and ``status`` ("running", "finished" at t_end, "failed" after a
:class:`StepError`) — and its :meth:`~Stepper.step` / :meth:`~Stepper.step_to` call the subclass's
``_step_impl``.

:data:`vibdyn.simulation.integrators.METHODS` maps each method name to its class.
"""

import math

import numpy as np

from .chart import make_ode

# per-step relative accuracy to which a state transition is resolved where the Jacobian differences a user callable
# (central differences of step 1e-6 of the scale: round-off ~1e-10 of the derivative, which an embedded error
# estimate sees as noise: held to 1e-10, van der Pol's Φ over a period takes 5600 steps instead of 70)
DIFFERENCED_RTOL = 1e-9


class StepError(Exception):
    """A step that cannot be taken; the message says why (the driver adds the time and the trajectory)."""


class Stepper:
    """Base class of the integrators; subclasses set the class attributes and implement ``_step_impl(target)``:
    one step, ``target`` the next output time or None (adaptive methods) or the step's end (fixed-step ones); and,
    with dense output, ``_interpolant()`` (the last step's :class:`Interpolant`).

    Constructor, shared by all: ``(system, q0, v0, t_end, *, rtol, atol_q, atol_v, first_step, max_step,
    work, t0, variational, transition_rtol)`` — rtol and atol_q/atol_v (arrays, tangent units) bound the local
    error per step of adaptive methods, first_step and max_step (s) bound their steps; ``work`` integrates the
    power of the force elements alongside (the energy balance); ``t0`` (s) the start time (t_end is absolute);
    ``variational`` integrates the tangent-space variational equations with the state (methods that declare
    ``supports_variational``: :attr:`state_transition`), whose own error an adaptive method holds to
    ``transition_rtol`` (None: rtol; a looser one where only a Newton step's Jacobian needs it)."""

    name: str = ""
    order: int = 0
    adaptive: bool = False
    dense_output: bool = False
    error_methods: tuple = ()
    supports_loops: bool = False  # integrates a mechanism with closed loops on its loops (projected ODE)
    supports_variational: bool = False  # integrates the variational equations with the state
    supports_events: bool = False  # its steps can be interpolated (dense output, or the ends' Hermite)
    supports_drives: bool = False  # integrates the free coordinates of a scene with drives (driven ODE)
    nfev: int = 0  # counters (instance values; see the module docstring)

    def __init__(self, system, q0, v0, t_end, *, rtol=None, atol_q=None, atol_v=None, first_step=None,
                 max_step=math.inf, work=False, t0=0.0, variational=False, transition_rtol=None):
        self.system, self.t_end, self.t = system, float(t_end), float(t0)
        self.variational = variational
        self.transition_rtol = transition_rtol  # the variational equations' own rtol (None: rtol's)
        self.rtol, self.atol_q, self.atol_v = rtol, atol_q, atol_v
        self.first_step, self.max_step, self.work = first_step, max_step, work
        self.accepted, self.rejected = 0, 0
        self.njev = self.nlu = 0
        self.local_error = None
        self.dense = None  # an Interpolant of the last step when asked for (adaptive methods)
        self.t_old = None  # the last step's start (s); None before the first step
        self.direction = 1.0 if self.t_end >= self.t else -1.0
        self.status = "running" if self.t_end != self.t else "finished"
        self._dense_cache = None  # the last step's Interpolant, once asked for

    def bound(self, max_step: float) -> None:
        """Bound the steps from now on by ``max_step`` (s) instead (a sampled support motion's bound lifted after
        its last sample)."""
        self.max_step = max_step

    @property
    def counters(self):
        """(nfev, njev, nlu, accepted, rejected) so far."""
        return self.nfev, self.njev, self.nlu, self.accepted, self.rejected

    @property
    def state(self):
        """(q, v, w) at the current time ``t``."""
        raise NotImplementedError

    def step(self, next_output=None):
        """One accepted step (adaptive methods), not beyond t_end; if ``next_output`` (s) falls inside it,
        ``dense`` is set to its interpolant, else None (the interpolant is also there on demand:
        :meth:`interpolant`)."""
        if not self.adaptive:
            raise NotImplementedError(f"{self.name} takes fixed steps: use step_to")
        self._advance(next_output)

    def step_to(self, t_new):
        """One step to ``t_new`` (s) (fixed-step methods)."""
        if self.adaptive:
            raise NotImplementedError(f"{self.name} chooses its own steps: use step")
        self._advance(t_new)

    def _advance(self, target):
        if self.status != "running":
            raise StepError(f"{self.name}: no step to take ({self.status} at t = {self.t:.6g} s)")
        t = self.t
        try:
            self._step_impl(target)
        except StepError:
            self.status = "failed"
            raise
        self.t_old, self._dense_cache = t, None
        if self.direction * (self.t - self.t_end) >= 0:
            self.status = "finished"

    def _step_impl(self, target):
        raise NotImplementedError

    def interpolant(self):
        """The last step's dense output, an :class:`Interpolant` over [t_old, t] (made on first request, kept
        until the next step); methods without dense output raise NotImplementedError."""
        if self.t_old is None:
            raise StepError(f"{self.name}: no step taken yet: nothing to interpolate")
        if self._dense_cache is None:
            self._dense_cache = self._interpolant()
        return self._dense_cache

    def _interpolant(self):
        raise NotImplementedError(f"{self.name} keeps no dense output")

    @property
    def state_transition(self):
        """∂(q, v)(t)/∂(q0, v0) (2nv × 2nv, tangent space at q(t) and q0) when integrated (``variational``)."""
        raise NotImplementedError(f"{self.name} does not integrate the variational equations")


def work_of(ode, y):
    """The work integral w of a state y of ``ode`` (J, 0 if not integrated); with drives, (w, W_d): the
    drives' work W_d is the component before w (:mod:`.driven`)."""
    w = y[-1] if ode.work else 0.0
    if ode.system.compiled_drives is None:
        return w
    return np.array([w, y[-2] if ode.work else y[-1]])


class Interpolant:
    """A step's dense output ``sol`` (a callable y(t) in the chart of that step) as (q, v, w) at a time."""

    def __init__(self, sol, chart):
        self.sol, self.chart = sol, chart

    def __call__(self, t):
        y, chart = self.sol(t), self.chart
        nv = chart.nv
        q, v = chart.configuration(y), y[nv:2 * nv].copy()
        if chart.system.compiled_drives is not None:  # the driven entries: the laws' at t, exactly
            q, v = chart.system.compiled_drives.impose(q, v, t)
        return q, v, work_of(chart, y)


class ODEStepper(Stepper):
    """A stepper of the first-order ODE y' = f(t, y) of :mod:`.chart` (y = chart coordinates, v[, w]);
    ``ode``, ``y``; ``nfev`` is the ODE's count. Closed loops: the ODE is projected (see
    :func:`vibdyn.simulation.integrators.projected.projected_ode`)."""

    supports_loops = True
    supports_events = True
    supports_drives = True

    def __init__(self, system, q0, v0, t_end, **kwargs):
        super().__init__(system, q0, v0, t_end, **kwargs)
        self.ode, self.y = make_ode(system, q0, v0, self.work, self.variational)

    @property
    def state_transition(self):
        return self.ode.transition(self.y)

    @property
    def nfev(self):
        return self.ode.nfev

    @property
    def state(self):
        ode, y = self.ode, self.y
        q, v = ode.configuration(y), y[ode.nv:2 * ode.nv].copy()
        if self.system.compiled_drives is not None:  # the driven entries: the laws' at t, exactly
            q, v = self.system.compiled_drives.impose(q, v, self.t)
        return q, v, work_of(ode, y)

    def atol_vector(self):
        """Absolute tolerances of every ODE component (the work component is not controlled: inf)."""
        return np.concatenate([self.atol_q, self.atol_v, [np.inf] * (self.ode.n - 2 * self.ode.nv)])

    def initial_derivative(self):
        """f(0, y0), checked finite (no step size can be chosen from a non-finite one)."""
        f = self.ode(self.t, self.y)
        if not np.all(np.isfinite(f)):
            raise StepError("the initial accelerations are not finite (initial state too large?)")
        return f


def initial_step(fun, t0, y0, f0, t_end, max_step, order, rtol, atol):
    """Hairer's starting step size (Hairer, Nørsett & Wanner, Solving ODEs I, §II.4, and their code's
    HINIT): h0 from ‖y0‖/‖f0‖, one explicit Euler step to estimate ‖f′‖, then h1 with the local error of
    a method of ``order`` at the tolerance; norms are RMS norms scaled by atol + rtol·|y0|."""
    interval = t_end - t0
    if y0.size == 0 or interval <= 0:
        return max(interval, 0.0) if y0.size else math.inf
    scale = atol + rtol * np.abs(y0)

    def norm(x):  # RMS, scaled by the largest component first so that huge states do not overflow
        z = np.abs(x / scale)
        m = float(z.max())
        return m * float(np.sqrt(np.mean(np.square(z / m)))) if 0.0 < m < math.inf else m

    d0, d1 = norm(y0), norm(f0)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, interval)
    if not h0 > 0.0:  # the state is too large for the arithmetic (d1 overflowed, or d0/d1 underflowed)
        raise StepError(f"no positive first step from the initial state (‖y0‖ = {d0:.3g}, ‖f0‖ = {d1:.3g} in "
                        "tolerance units): the initial state is too large")
    f1 = fun(t0 + h0, y0 + h0 * f0)
    d2 = norm(f1 - f0) / h0
    if max(d1, d2) <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100 * h0, h1, interval, max_step)
