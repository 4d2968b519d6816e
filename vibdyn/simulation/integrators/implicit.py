"""Implicit stiff solvers: scipy's Radau IIA (order 5) and BDF (orders 1–5) on the ODE of :mod:`.chart`.

The Newton iterations use the analytic Jacobian (:func:`vibdyn.model.derivatives.linear_terms`, mapped to the
chart). The solvers run unchanged in a chart; when a rotation of a curved joint grows past ``RECENTRE`` rad
in it, the chart is re-centred at the current configuration and the solver restarted there with its last
step size (scipy's solvers keep step history in chart coordinates, so they are restarted rather than
patched). Scenes of vector joints never restart. The work component w is integrated but not
error-controlled (its absolute tolerance is infinite): it feeds nothing back. scipy.integrate (its public
``Radau`` and ``BDF`` classes) is imported on first use.
"""

import numpy as np

from ...errors import VibdynError
from .base import Interpolant, ODEStepper, StepError

RECENTRE = 1.0  # rad


class Implicit(ODEStepper):
    """One scipy solver (``solver_name``: a public class of scipy.integrate), restarted at each re-centring
    of the chart. scipy's implicit solvers do not report rejected steps (``rejected`` is None)."""

    adaptive = True
    dense_output = True
    error_methods = ("rerun",)
    solver_name = ""

    def __init__(self, system, q0, v0, t_end, **kwargs):
        super().__init__(system, q0, v0, t_end, **kwargs)
        import scipy.integrate

        self.initial_derivative()
        self.cls = getattr(scipy.integrate, self.solver_name)
        self.rejected = None
        self.restarts = 0
        self._done_njev = self._done_nlu = 0  # counters of the solvers before the last restart
        self._start(self.t, self.y, self.first_step)

    def _start(self, t, y, first_step):
        if hasattr(self, "solver"):
            self._done_njev += self.solver.njev
            self._done_nlu += self.solver.nlu
        self.solver = self.cls(self.ode, t, y, self.t_end, rtol=self.rtol, atol=self.atol_vector(),
                               jac=self.ode.jacobian, first_step=first_step, max_step=self.max_step)
        self.t, self.y = self.solver.t, self.solver.y

    def bound(self, max_step: float) -> None:
        super().bound(max_step)
        self.solver.max_step = max_step

    @property
    def njev(self):
        return self._done_njev + self.solver.njev

    @njev.setter
    def njev(self, value):  # the base class's initial 0; the solvers count their own
        pass

    @property
    def nlu(self):
        return self._done_nlu + self.solver.nlu

    @nlu.setter
    def nlu(self, value):
        pass

    def _step_impl(self, next_output=None):
        s = self.solver
        try:
            message = s.step()
        except VibdynError:  # an element of the scene that failed (a ModelError is a ValueError too)
            raise
        except ValueError as e:  # scipy's LU of a non-finite Jacobian: a blow-up
            raise StepError(f"{self.cls.__name__}: the state or its Jacobian is not finite ({e})") from None
        if s.status == "failed":
            raise StepError(f"{self.cls.__name__}: {message}")
        if not np.all(np.isfinite(s.y)):
            raise StepError(f"{self.cls.__name__}: the state is not finite")
        self.accepted += 1
        self.t, self.y = s.t, s.y
        self._last = (s, self.ode)  # (the step's dense output made on demand: scipy's until its next step)
        self.dense = self._interpolant() if next_output is not None and next_output < s.t else None
        # re-centre a chart whose rotations grew, and put a mechanism with loops back on its loops once its
        # drift reaches the local tolerance (the solver restarts from the projected state)
        if s.status == "running" and (self.ode.extent(s.y) > RECENTRE or self.ode.drift(s.y) > self.rtol):
            self._last = (s, self.ode.frozen())  # (the step's chart, before it moves)
            y = s.y.copy()
            self.ode.recentre(y)
            self.restarts += 1
            self._start(s.t, y, min(s.step_size, self.t_end - s.t))

    def _interpolant(self):
        solver, chart = self._last
        return Interpolant(solver.dense_output(), chart.frozen() if chart is self.ode else chart)


class Radau(Implicit):
    """Radau IIA of order 5 (scipy.integrate.Radau), stiffly accurate: stiff scenes, strong damping."""

    name = "radau"
    order = 5
    solver_name = "Radau"


class BDF(Implicit):
    """Backward differentiation formulas of variable order 1–5 (scipy.integrate.BDF): large stiff scenes."""

    name = "bdf"
    order = 5
    solver_name = "BDF"
