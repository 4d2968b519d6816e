"""Explicit Runge–Kutta methods on the ODE of :mod:`.chart`, re-centred at every step.

Each step starts a chart at q_n (ξ = 0) and every stage configuration is integrate(q_n, ξ_stage): the
Runge–Kutta–Munthe-Kaas construction, exact in order on Lie groups. Classical RK4 takes fixed steps;
Dormand–Prince 8(5,3) (DOP853) controls its step with the embedded 5th- and 3rd-order estimates, with the
step-size control of Hairer's DOP853 and its 7th-order dense output (tableau in :mod:`.dop853_tableau`,
starting step by Hairer's algorithm, :func:`.base.initial_step`). The stage loop is written here to keep the
per-stage cost low (for a one-degree-of-freedom pendulum the Python overhead, not the dynamics, is what a
step costs).

Error control: positions are measured in the step's chart, so their scale is atol_q + rtol·|Δq| (an angle
of 1000 rad after many turns does not loosen the tolerance); velocities use atol_v + rtol·max(|v_n|, |v_n+1|).
The work component w is integrated with the state but not controlled (it feeds nothing back). The variational
equations' Φ is controlled too (normwise relative, see :class:`DOP853`): a state at rest would otherwise allow
steps that leave Φ unresolved.
"""

import math

import numpy as np

from . import dop853_tableau as _dop
from .base import DIFFERENCED_RTOL, Interpolant, ODEStepper, StepError, initial_step
from .chart import VectorODE

__all__ = ["DOP853", "RK4", "RungeKutta", "StepError"]

# step-size control of Hairer's DOP853: new step within [h/3, 6h], safety factor 0.9, with Lund stabilisation
# (PI control) β = 0.04 (Hairer, Nørsett & Wanner, Solving ODEs I, §II.4 and §IV.2): on the pendulum of
# IFToMM A01 it rejects 2 % of the steps instead of 20 % with scipy's pure I control, 15 % fewer evaluations
SAFETY, MIN_FACTOR, MAX_FACTOR, BETA = 0.9, 1.0 / 3.0, 6.0, 0.04


class RungeKutta(ODEStepper):
    """Explicit Runge–Kutta stepping shared by the fixed-step and adaptive methods.

    ``A``, ``B``, ``C``: Butcher tableau of the ``stages`` main stages; rows of ``YK`` hold y_n then the
    stages K_0 … (the last one f(t + h, y_n+1)), so that each stage state is one dot product
    [1, h a_s] · YK.
    """

    supports_variational = True  # (the stage loop integrates whatever the ODE's state holds)
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    extra_rows = 0  # stages beyond the main ones (dense output)

    def __init__(self, system, q0, v0, t_end, **kwargs):
        super().__init__(system, q0, v0, t_end, **kwargs)
        ode = self.ode
        self.f = self.initial_derivative() if self.adaptive else ode(self.t, self.y)
        s = self.stages = len(self.B)
        self.YK = YK = np.empty((s + 2 + self.extra_rows, ode.n))
        self._CA = np.ones((s, s + 1))  # row i: [1, h a_i] (its first i + 1 entries are used)
        self._CB = np.ones(s + 1)  # [1, h b]
        self._plan = [(self.C[i], self._CA[i, :i + 1], YK[:i + 1], YK[i + 1]) for i in range(1, s)]
        self._stage = np.empty(ode.n)  # each stage's state (the ODE's ``into`` keeps no reference to it)
        # the variational equations by stages of the state first, then every stage's Jacobian in one batch (the
        # state's stages do not depend on Φ): where the ODE is the plain chart's with Φ alone appended, its
        # Jacobian exact (a differenced one floors Φ's control: the coupled stages keep that bookkeeping) and its
        # point elements' derivatives vectorised over states (the batch's gain: Kerschen's two masses, 38.7 -> 20.9
        # ms a period; a pendulum without point elements, 11.3 -> 24.2 ms: not batched)
        base = getattr(ode, "base", None)
        groups = system.point_groups
        self._batched = bool(self.variational and base is not None and base.n == ode.m and getattr(
            base, "_blocks", False) and not ode.differenced and groups and all(
            g.derivatives_rows is not None for g in groups))

    def _stages(self, h):
        """One step of size h from (t, y, f): (y_new, f_new); YK then holds y and every stage."""
        if self._batched:
            return self._batched_stages(h)
        t, YK, s, into, dot, y = self.t, self.YK, self.stages, self.ode.into, np.dot, self._stage
        YK[0], YK[1] = self.y, self.f
        np.multiply(self.A, h, out=self._CA[:, 1:])
        for c, a, Y, out in self._plan:
            into(t + c * h, dot(a, Y, out=y), out)
        np.multiply(self.B, h, out=self._CB[1:])
        y_new = dot(self._CB, YK[:s + 1])
        f_new = YK[s + 1]
        into(t + h, y_new, f_new)
        return y_new, f_new.copy()

    def _batched_stages(self, h):
        """:meth:`_stages` with the variational equations: the state's stages (the base ODE's), then J at every
        stage and at the step's end in one batch (:meth:`~.chart.VectorODE.jacobians`), then Φ's stages
        K_i = J_i (Φ_n + h Σ a_ij K_j): the same Runge–Kutta step of the coupled system, one batched Jacobian
        instead of one per stage."""
        t, YK, s, dot, ode = self.t, self.YK, self.stages, np.dot, self.ode
        base, m = ode.base, ode.m
        X, P = slice(0, m), slice(m, m + m * m)  # the state's and Φ's columns
        YK[0], YK[1] = self.y, self.f
        np.multiply(self.A, h, out=self._CA[:, 1:])
        np.multiply(self.B, h, out=self._CB[1:])
        times = np.empty(s + 1)
        states = np.empty((s + 1, m))
        accelerations = np.empty((s + 1, m // 2))
        for i, (c, a, Y, out) in enumerate(self._plan, start=1):
            states[i] = dot(a, Y[:, X])
            times[i] = t + c * h
            base.into(times[i], states[i], out[X])
            accelerations[i] = out[m // 2:m]
        y_new = np.empty(ode.n)
        y_new[X] = states[s] = dot(self._CB, YK[:s + 1, X])
        f_new = YK[s + 1]
        times[s] = t + h
        base.into(times[s], states[s], f_new[X])
        accelerations[s] = f_new[m // 2:m]
        J = base.jacobians(times[1:], states[1:], accelerations[1:])  # (s × m × m): stages 1 … s−1, then the end
        for i, (c, a, Y, out) in enumerate(self._plan, start=1):
            out[P] = (J[i - 1] @ dot(a, Y[:, P]).reshape(m, m)).ravel()
        y_new[P] = dot(self._CB, YK[:s + 1, P])
        f_new[P] = (J[-1] @ y_new[P].reshape(m, m)).ravel()
        return y_new, f_new.copy()

    def _accept(self, h, y_new, f_new):
        self.t += h
        self.ode.recentre(y_new, f_new, self.t)
        self.y, self.f = y_new, f_new
        self.accepted += 1


class RK4(RungeKutta):
    """Classical fourth-order Runge–Kutta with the step the caller gives (see :meth:`step_to`)."""

    name = "rk4"
    order = 4
    error_methods = ("richardson",)
    A = np.array([[0.0, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0], [0.0, 0.5, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    B = np.array([1.0, 2.0, 2.0, 1.0]) / 6.0
    C = np.array([0.0, 0.5, 0.5, 1.0])

    def _step_impl(self, t_new):
        """One step to t_new (fixed-step methods land on their output times: no dense output)."""
        h = t_new - self.t
        y_new, f_new = self._stages(h)
        if not np.all(np.isfinite(y_new)):
            raise StepError(f"the state is not finite after a step of {h:.3g} s (step too large for this motion?)")
        self._accept(h, y_new, f_new)
        self.t = t_new


class DOP853(RungeKutta):
    """Dormand–Prince 8(5,3) with step-size control and 7th-order dense output."""

    name = "dop853"
    order = 8
    adaptive = True
    dense_output = True
    error_methods = ("rerun", "local")
    A = _dop.A[:_dop.N_STAGES, :_dop.N_STAGES]
    B = _dop.B
    C = _dop.C[:_dop.N_STAGES]
    extra_rows = _dop.N_STAGES_EXTENDED - _dop.N_STAGES - 1
    alpha = 1.0 / 8.0 - 0.2 * BETA  # error estimator of order 7, PI-stabilised

    def __init__(self, system, q0, v0, t_end, **kwargs):
        super().__init__(system, q0, v0, t_end, **kwargs)
        nv = self.ode.nv
        self.local_error = np.zeros(2 * nv)
        self._previous = 1e-4  # error norm of the last accepted step
        self._E = np.vstack([_dop.E5, _dop.E3])
        self._atol = np.concatenate([self.atol_q, self.atol_v])
        # the variational equations are controlled too (a state at rest would otherwise take steps that leave Φ
        # unresolved): Φ made dimensionless by the tolerances, Φ̂_ij = Φ_ij atol_j / atol_i, held to
        # rtol·max(1, max|Φ̂|) (normwise relative: an entry's scale is that of the largest, as in a matrix norm);
        # not below DIFFERENCED_RTOL where the Jacobian differences a user callable (its noise would stall the steps);
        # held to transition_rtol instead where the caller asks for a looser one (never tighter than the state's)
        self._Y = None
        self.rtol_Y = self.rtol if self.transition_rtol is None else max(self.transition_rtol, self.rtol)
        self.floored_steps = 0  # accepted steps whose Φ was held to DIFFERENCED_RTOL rather than rtol
        if self.variational:
            self._Y = slice(2 * nv, 2 * nv + 4 * nv * nv)
            self._Yscale = (self._atol[None, :] / self._atol[:, None]).ravel()
        first_step = self.first_step
        if first_step is None:
            first_step = initial_step(self.ode, self.t, self.y, self.f, self.t_end, self.max_step, 7, self.rtol,
                                      self.atol_vector())
        self.h_abs = min(float(first_step), self.max_step)
        self._last = None  # (h, y_new, f_new, its chart) of the last step, for its dense output on demand

    def _step_impl(self, next_output=None):
        """One accepted step (not beyond t_end); its dense output in ``dense`` if ``next_output`` (a time)
        falls inside it (before its end), else kept for :meth:`interpolant` (the step's end state and chart)."""
        t, y, nv = self.t, self.y, self.ode.nv
        m = 2 * nv
        min_step = 10 * (math.nextafter(t, math.inf) - t)
        h_abs = min(max(self.h_abs, min_step), self.max_step)
        rejected = False
        E, rtol, atol = self._E, self.rtol, self._atol
        # error scale atol + rtol·max(|x_n|, |x_n+1|) with positions measured from q_n: x = y − (q_n, 0)
        origin = y[:m].copy()
        origin[nv:] = 0.0
        size_n = np.abs(y[:m])
        size_n[:nv] = 0.0
        while True:
            if not h_abs >= min_step:  # also a NaN step
                raise StepError(f"step size underflow ({h_abs:.3g} s): the solver cannot meet its tolerance "
                                "(a singularity, a blow-up, or a stiff scene: try method='radau')")
            t_new = min(t + h_abs, self.t_end)
            h = t_new - t
            y_new, f_new = self._stages(h)
            err = np.dot(E, self.YK[1:self.stages + 2, :m])  # rows: 5th- and 3rd-order error estimates / h
            scale = np.abs(y_new[:m] - origin)
            np.maximum(scale, size_n, out=scale)
            scale *= rtol
            scale += atol
            n5, n3 = np.square(err / scale).sum(axis=1).tolist()
            error_norm = 0.0 if n5 == 0 and n3 == 0 else h * n5 / math.sqrt((n5 + 0.01 * n3) * m)
            if self._Y is not None:
                Yhat = np.abs(y_new[self._Y] * self._Yscale).max()
                rtol_Y = max(self.rtol_Y, DIFFERENCED_RTOL) if self.ode.differenced else self.rtol_Y
                errY = np.dot(E, self.YK[1:self.stages + 2, self._Y]) * (self._Yscale / (rtol_Y * max(1.0, Yhat)))
                y5, y3 = np.square(errY).sum(axis=1).tolist()
                y_norm = h * y5 / math.sqrt((y5 + 0.01 * y3) * m * m) if y5 > 0 else 0.0
                floored = y_norm > error_norm and rtol_Y > self.rtol_Y  # this step's Φ is held to the floor only
                error_norm = max(error_norm, y_norm)
            if error_norm <= 1:  # accepted: PI control (Lund stabilisation) with the previous error norm
                factor = SAFETY * (error_norm ** -self.alpha if error_norm > 0 else math.inf) * self._previous ** BETA
                factor = min(MAX_FACTOR, max(MIN_FACTOR, factor))
                if rejected:
                    factor = min(1.0, factor)
                self._previous = max(error_norm, 1e-4)
                self.h_abs = h * factor
                break
            # rejected (a non-finite state gives a NaN or inf error norm: also rejected)
            factor = SAFETY * error_norm ** -self.alpha if math.isfinite(error_norm) else 0.0
            h_abs = h * max(MIN_FACTOR, factor)
            rejected = True
            self.rejected += 1
        # componentwise local error h·|err5|·√(n5 / (n5 + n3/100)), the error DOP853 controls (its scaled RMS
        # norm is error_norm), accumulated
        c = math.sqrt(n5 / (n5 + 0.01 * n3)) if n5 > 0 else 0.0
        self.local_error += (h * c) * np.abs(err[0])
        if self._Y is not None and floored:
            self.floored_steps += 1
        if next_output is not None and next_output < t_new:
            self.dense = self._dense_output(h, y_new, f_new)
            self._last = None
        else:  # (on demand: the re-centring of a chart or of Φ below changes y_new, f_new and the chart in place)
            self.dense = None
            ode = self.ode
            self._last = ((h, y_new, f_new, ode) if type(ode).recentre is VectorODE.recentre
                          else (h, y_new.copy(), f_new.copy(), ode.frozen()))
        self._accept(h, y_new, f_new)
        self.t = t_new

    def _interpolant(self):
        if self._last is None:  # (made during the step already)
            return self.dense
        h, y_new, f_new, chart = self._last
        return self._dense_output(h, y_new, f_new, chart, self.t_old)

    def _dense_output(self, h, y_new, f_new, ode=None, t=None):
        """The step's interpolant: DOP853's 7th-order dense output in the step's chart (``ode``: that chart, default
        the current one; ``t``: the step's start, default the current time); with batched variational equations, of
        the state only (an :class:`~.base.Interpolant` reads q, v and w)."""
        ode = self.ode if ode is None else ode
        YK, t, s = self.YK, self.t if t is None else t, self.stages + 1
        y_old = YK[0]
        if self._batched:  # (the interpolant gives (q, v): the extra stages of the state alone, Φ's left at zero)
            m = ode.m
            for i, (a, c) in enumerate(zip(_dop.A[s:], _dop.C[s:]), start=s):
                ode.base.into(t + c * h, y_old[:m] + h * (a[:i] @ YK[1:i + 1, :m]), YK[i + 1, :m])
                YK[i + 1, m:] = 0.0
        else:
            for i, (a, c) in enumerate(zip(_dop.A[s:], _dop.C[s:]), start=s):
                ode.into(t + c * h, y_old + h * (a[:i] @ YK[1:i + 1]), YK[i + 1])
        K = YK[1:]
        dy = y_new - y_old
        F = np.empty((_dop.INTERPOLATOR_POWER, ode.n))
        F[0] = dy
        F[1] = h * K[0] - dy
        F[2] = 2 * dy - h * (f_new + K[0])
        F[3:] = h * (_dop.D @ K)
        return Interpolant(Dop853Dense(t, h, y_old.copy(), F), ode.frozen() if ode is self.ode else ode)


class Dop853Dense:
    """DOP853's continuous extension over one step [t0, t0 + h]: with x = (t − t0)/h and the rows F_k,
    y(t) = y0 + x(F_0 + (1 − x)(F_1 + x(F_2 + (1 − x)(F_3 + …)))) (Hairer's CONTD8), nested from the last row."""

    def __init__(self, t0, h, y0, F):
        self.t0, self.h, self.y0, self.F = t0, h, y0, F

    def __call__(self, t):
        x = (t - self.t0) / self.h
        y = np.zeros_like(self.y0)
        for i, f in enumerate(self.F[::-1]):
            y += f
            y *= x if i % 2 == 0 else 1 - x
        return y + self.y0
