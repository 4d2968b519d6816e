"""Explicit Runge–Kutta methods on the ODE of :mod:`.chart`, re-centred at every step.

Each step starts a chart at q_n (ξ = 0) and every stage configuration is integrate(q_n, ξ_stage): the
Runge–Kutta–Munthe-Kaas construction, exact in order on Lie groups. Classical RK4 takes fixed steps;
Dormand–Prince 8(5,3) (DOP853) controls its step with the embedded 5th- and 3rd-order estimates. The DOP853
coefficients, its error estimate, its dense output and the initial step are scipy's (``scipy.integrate._ivp``);
the stage loop is written here to keep the per-stage cost low (for a one-degree-of-freedom pendulum the
Python overhead, not the dynamics, is what a step costs), with the step-size control of Hairer's DOP853.

Error control: positions are measured in the step's chart, so their scale is atol_q + rtol·|Δq| (an angle
of 1000 rad after many turns does not loosen the tolerance); velocities use atol_v + rtol·max(|v_n|, |v_n+1|).
The work component w is integrated with the state but not controlled (it feeds nothing back).
"""

import math

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop
from scipy.integrate._ivp.common import select_initial_step
from scipy.integrate._ivp.rk import Dop853DenseOutput

# step-size control of Hairer's DOP853: new step within [h/3, 6h], safety factor 0.9, with Lund stabilisation
# (PI control) β = 0.04 (Hairer, Nørsett & Wanner, Solving ODEs I, §II.4 and §IV.2): on the pendulum of
# IFToMM A01 it rejects 2 % of the steps instead of 20 % with scipy's pure I control, 15 % fewer evaluations
SAFETY, MIN_FACTOR, MAX_FACTOR, BETA = 0.9, 1.0 / 3.0, 6.0, 0.04


class StepError(Exception):
    """A step that cannot be taken; the message says why (the driver adds the time and the trajectory)."""


class RungeKutta:
    """Explicit Runge–Kutta stepping shared by the fixed-step and adaptive methods.

    ``A``, ``B``, ``C``: Butcher tableau of the ``stages`` main stages; rows of ``YK`` hold y_n then the
    stages K_0 … (the last one f(t + h, y_n+1)), so that each stage state is one dot product
    [1, h a_s] · YK.
    """

    A = B = C = None
    order = None
    extra_rows = 0  # stages beyond the main ones (dense output)

    def __init__(self, ode, t0, y0):
        self.ode, self.t, self.y = ode, float(t0), y0
        self.f = ode(self.t, y0)
        self.accepted = self.rejected = 0
        s = self.stages = len(self.B)
        self.YK = YK = np.empty((s + 2 + self.extra_rows, ode.n))
        self._CA = np.ones((s, s + 1))  # row i: [1, h a_i] (its first i + 1 entries are used)
        self._CB = np.ones(s + 1)  # [1, h b]
        self._plan = [(self.C[i], self._CA[i, :i + 1], YK[:i + 1], YK[i + 1]) for i in range(1, s)]
        self.local_error = None  # accumulated |local error| per (q, v) component, if the method has one
        self.dense = None

    @property
    def state(self):
        """(q, v, w) at the current time (after re-centring, ξ = 0)."""
        ode, y = self.ode, self.y
        return ode.configuration(y), y[ode.nv:2 * ode.nv].copy(), (y[-1] if ode.work else 0.0)

    def _stages(self, h):
        """One step of size h from (t, y, f): (y_new, f_new); YK then holds y and every stage."""
        t, YK, s, into, dot = self.t, self.YK, self.stages, self.ode.into, np.dot
        YK[0], YK[1] = self.y, self.f
        np.multiply(self.A, h, out=self._CA[:, 1:])
        for c, a, Y, out in self._plan:
            into(t + c * h, dot(a, Y), out)
        np.multiply(self.B, h, out=self._CB[1:])
        y_new = dot(self._CB, YK[:s + 1])
        f_new = YK[s + 1]
        into(t + h, y_new, f_new)
        return y_new, f_new.copy()

    def _accept(self, h, y_new, f_new):
        self.t += h
        self.ode.recentre(y_new, f_new)
        self.y, self.f = y_new, f_new
        self.accepted += 1


class RK4(RungeKutta):
    """Classical fourth-order Runge–Kutta with the step the caller gives (see :meth:`step_to`)."""

    order = 4
    A = np.array([[0.0, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0], [0.0, 0.5, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    B = np.array([1.0, 2.0, 2.0, 1.0]) / 6.0
    C = np.array([0.0, 0.5, 0.5, 1.0])

    def step_to(self, t_new):
        """One step to t_new (fixed-step methods land on their output times: no dense output)."""
        h = t_new - self.t
        y_new, f_new = self._stages(h)
        if not np.all(np.isfinite(y_new)):
            raise StepError(f"the state is not finite after a step of {h:.3g} s (step too large for this motion?)")
        self._accept(h, y_new, f_new)
        self.t = t_new


class DOP853(RungeKutta):
    """Dormand–Prince 8(5,3) with step-size control and 7th-order dense output (scipy's coefficients)."""

    order = 8
    A = _dop.A[:_dop.N_STAGES, :_dop.N_STAGES]
    B = _dop.B
    C = _dop.C[:_dop.N_STAGES]
    extra_rows = _dop.N_STAGES_EXTENDED - _dop.N_STAGES - 1
    alpha = 1.0 / 8.0 - 0.2 * BETA  # error estimator of order 7, PI-stabilised

    def __init__(self, ode, t0, y0, t_end, rtol, atol_q, atol_v, first_step=None, max_step=np.inf):
        super().__init__(ode, t0, y0)
        nv = ode.nv
        self.t_end, self.rtol, self.max_step = float(t_end), rtol, max_step
        self.atol_q, self.atol_v = atol_q, atol_v
        self.local_error = np.zeros(2 * nv)
        self._previous = 1e-4  # error norm of the last accepted step
        self._E = np.vstack([_dop.E5, _dop.E3])
        self._atol = np.concatenate([atol_q, atol_v])
        if first_step is None:
            atol = np.concatenate([atol_q, atol_v, [np.inf] * (ode.n - 2 * nv)])
            try:
                first_step = select_initial_step(ode, self.t, y0, self.t_end, max_step, self.f, 1.0, 7, rtol, atol)
            except TypeError:  # scipy < 1.13: no t_bound, max_step
                first_step = min(select_initial_step(ode, self.t, y0, self.f, 1.0, 7, rtol, atol), self.t_end - t0)
        self.h_abs = min(float(first_step), max_step)

    def step(self, next_output=None):
        """One accepted step (not beyond t_end); its dense output in ``dense`` if ``next_output`` (a time)
        falls inside it (before its end)."""
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
        self.dense = (self._dense_output(h, y_new, f_new)
                      if next_output is not None and next_output < t_new else None)
        self._accept(h, y_new, f_new)
        self.t = t_new

    def _dense_output(self, h, y_new, f_new):
        """(interpolant of y over the step, chart it is expressed in): scipy's DOP853 dense output."""
        ode, YK, t, s = self.ode, self.YK, self.t, self.stages + 1
        y_old = YK[0]
        for i, (a, c) in enumerate(zip(_dop.A[s:], _dop.C[s:]), start=s):
            ode.into(t + c * h, y_old + h * (a[:i] @ YK[1:i + 1]), YK[i + 1])
        K = YK[1:]
        dy = y_new - y_old
        F = np.empty((_dop.INTERPOLATOR_POWER, ode.n))
        F[0] = dy
        F[1] = h * K[0] - dy
        F[2] = 2 * dy - h * (f_new + K[0])
        F[3:] = h * (_dop.D @ K)
        return Dop853DenseOutput(t, t + h, y_old.copy(), F), ode.frozen()
