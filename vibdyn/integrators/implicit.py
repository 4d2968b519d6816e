"""Implicit stiff solvers: scipy's Radau IIA (order 5) and BDF (orders 1–5) on the ODE of :mod:`.chart`.

The Newton iterations use the analytic Jacobian (``System.linearize(method="analytic")``, mapped to the
chart). The solvers run unchanged in a chart; when a rotation of a curved joint grows past ``RECENTRE`` rad
in it, the chart is re-centred at the current configuration and the solver restarted there with its last
step size (scipy's solvers keep step history in chart coordinates, so they are restarted rather than
patched). Scenes of vector joints never restart. The work component w is integrated but not
error-controlled (its absolute tolerance is infinite): it feeds nothing back.
"""

import numpy as np
from scipy.integrate import BDF, Radau

from .explicit import StepError

RECENTRE = 1.0  # rad
SOLVERS = {"radau": Radau, "bdf": BDF}


class Implicit:
    """One scipy solver (``method`` "radau" or "bdf"), restarted at each re-centring of the chart."""

    def __init__(self, method, ode, t0, y0, t_end, rtol, atol_q, atol_v, first_step=None, max_step=np.inf):
        self.cls = SOLVERS[method]
        self.ode, self.t_end, self.rtol, self.max_step = ode, float(t_end), rtol, max_step
        self.atol = np.concatenate([atol_q, atol_v, [np.inf] * (ode.n - 2 * ode.nv)])
        self.accepted = self.njev = self.nlu = 0
        self.rejected = None  # scipy's implicit solvers do not report rejected steps
        self.local_error = None
        self.restarts = 0
        self.dense = None
        self._start(float(t0), y0, first_step)

    def _start(self, t, y, first_step):
        if hasattr(self, "solver"):
            self.njev += self.solver.njev
            self.nlu += self.solver.nlu
        self.solver = self.cls(self.ode, t, y, self.t_end, rtol=self.rtol, atol=self.atol, jac=self.ode.jacobian,
                               first_step=first_step, max_step=self.max_step)

    @property
    def t(self):
        return self.solver.t

    @property
    def y(self):
        return self.solver.y

    @property
    def counters(self):
        return self.njev + self.solver.njev, self.nlu + self.solver.nlu

    @property
    def state(self):
        ode, y = self.ode, self.solver.y
        return ode.configuration(y), y[ode.nv:2 * ode.nv].copy(), (y[-1] if ode.work else 0.0)

    def step(self, next_output=None):
        s = self.solver
        try:
            message = s.step()
        except ValueError as e:  # scipy's LU of a non-finite Jacobian: a blow-up
            raise StepError(f"{self.cls.__name__}: the state or its Jacobian is not finite ({e})") from None
        if s.status == "failed":
            raise StepError(f"{self.cls.__name__}: {message}")
        if not np.all(np.isfinite(s.y)):
            raise StepError(f"{self.cls.__name__}: the state is not finite")
        self.accepted += 1
        self.dense = ((s.dense_output(), self.ode.frozen())
                      if next_output is not None and next_output < s.t else None)
        if s.status == "running" and self.ode.extent(s.y) > RECENTRE:
            y = s.y.copy()
            self.ode.recentre(y)
            self.restarts += 1
            self._start(s.t, y, min(s.step_size, self.t_end - s.t))
