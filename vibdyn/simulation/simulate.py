"""Nonlinear time simulation: the full equations of motion of any scene, on its configuration Lie group.

``simulate(system, t_end, ...)`` (or :meth:`vibdyn.System.simulate`) integrates M(q) v̇ + b(q, v) = Q(q, v, t)
from (q0, v0) at t = 0 and returns a :class:`Trajectory`: times, configurations, velocities, energies, the
work of the non-conservative forces, counters, an error estimate and the elapsed time.

Analyses that integrate the same equations many times (shooting, Floquet, backbones) use
:class:`vibdyn.simulation.flow.Flow`: the same runs and error estimates, settings checked once, no energies.

Methods: the registry :data:`METHODS` (name → stepper class, :mod:`vibdyn.simulation.integrators`; ``method=``
also takes such a class), all
exact in order on Lie groups (ball, free and planar joints are stepped in a local chart q = integrate(q_c,
ξ), see :mod:`vibdyn.simulation.integrators.chart`):

- ``"dop853"`` (default): Dormand–Prince 8(5,3), adaptive, re-centred at every step (Runge–Kutta–Munthe-
  Kaas). Error estimate ``"rerun"`` (default): a second run at tolerances / 100, error ≈ |y − y_tight| / 0.9 (the
  second run's own error counted as at most a tenth of the first's), a global estimate (about 1.8× the first run's
  cost); or ``"local"``: the sum of the steps' local error estimates, free but not a bound (it ignores how the
  motion amplifies earlier errors: 3–30× below the actual error on the benchmarks' light cart-pole, tumbling top
  and ball-joint chain).
- ``"rk4"``: classical Runge–Kutta, fixed step ``dt``, re-centred at every step. Error ``"richardson"``:
  runs with steps 2·dt and 4·dt, error ≈ |y_dt − y_2dt| / (ρ − 1) with ρ = |y_2dt − y_4dt| / |y_dt − y_2dt|
  the observed convergence (16 for a fourth order, the most it counts); where ρ is not within 2× of 16 the
  steps are not in the method's asymptotic range (a mechanism through its singular positions: there /15 was
  2.3× short) and the estimate is |y_dt − y_2dt| itself; at each output the largest estimate so far (the
  two runs' difference passes through zero where their phases cross).
- ``"radau"`` (Radau IIA, order 5) and ``"bdf"`` (orders 1–5): scipy's implicit solvers for stiff scenes,
  Newton with the analytic Jacobian; the chart is re-centred (solver restarted) when a rotation in it passes
  1 rad. Error ``"rerun"``: a second run at tolerances / 100, error ≈ |y − y_tight| / 0.9.
- ``"symplectic"`` (alias ``"variational"``): midpoint variational integrator on the group, fixed step
  ``dt``, second order, symplectic: no energy drift over long conservative runs, momentum maps of symmetric
  scenes conserved to round-off. Error ``"richardson"`` (as rk4's, ρ at most 4).

Errors are in the tangent space (m or rad for q, per second for v), largest over the coordinates.

Energy monitoring: E = T + V_gravity + V_elastic (:meth:`System.energy`) and W_nc, the work of the
non-conservative forces (dampers, applied forces, motor laws: every force element without a potential).
W_nc = ∫ v·τ dt + V_elastic(t) − V_elastic(0), with τ = RNEA(q, v, v̇) the total generalized force of the
force elements, integrated with the motion; ``energy_balance`` = E − E(0) − W_nc is zero for the exact
motion and its largest magnitude is the ``drift`` figure. A scene whose elements all have a potential
integrates nothing extra (W_nc = 0).
"""

import time
from typing import Any

from .._deprecation import RenamedKeyword
from .flow import Flow
from .integrators import ALIASES, METHODS
from .runs import settings
from .trajectory import SimulationError, Trajectory, q_names  # noqa: F401  (the module's public names)

__all__ = ["ALIASES", "METHODS", "SimulationError", "Trajectory", "simulate"]

_ERROR_METHOD = RenamedKeyword("simulate", "error", "error_method")


def simulate(system, t_end: float, q0=None, v0=None, method: Any = "dop853", rtol: float = 1e-8, atol=None,
             dt: float | None = None, t_eval=None, *, error_method: str | None = None, max_step: float | None = None,
             progress: bool | None = None, t0: float = 0.0, events=None, variational: bool = False,
             error: str | None = None) -> Trajectory:
    """Integrate the nonlinear motion of ``system`` from (q0, v0) at ``t0`` (s, default 0) to the absolute
    time ``t_end`` (s): a time-dependent force sees the true t.

    q0: configuration (default neutral; for a mechanism with loops, whose neutral configuration need not close
    them, the scene's declared start if it has one: :meth:`System.start_configuration`), or an
    equilibrium/steady-motion result (then v0 defaults to its v); v0: velocities (default zero). A mechanism
    with loops starts from (q0, v0) put on its loops (q0 assembled, v0 projected in the kinetic-energy
    metric): its energies, work and errors are those of that state. ``method``: a name of :data:`METHODS` —
    "dop853", "rk4", "radau", "bdf"
    or "symplectic" (alias "variational") — see the module docstring — or a stepper class
    (a subclass of :class:`vibdyn.simulation.integrators.Stepper` with a ``name``).
    ``rtol`` and ``atol`` (adaptive methods): local error per step below atol + rtol·|x|,
    positions measured from the step's start; ``atol`` a number, one per coordinate (positions and
    velocities alike) or 2·nv numbers (positions then velocities); default rtol × (1 rad, or the scene's
    length scale for m coordinates). ``dt``: the step of fixed-step methods (required; each interval between
    output times gets an even number of equal steps ≤ dt), the first step of adaptive ones. ``t_eval``:
    output times in [t0, t_end] (default: every step, and t0). ``error_method``: how the error is
    estimated (default "rerun" for dop853, radau and bdf, "richardson" for fixed-step methods; "local" for
    dop853 is cheaper but not a global bound; ``error``: its former name).
    ``max_step``: largest step of adaptive methods. A support moving by a sampled law (a ground record,
    :class:`vibdyn.laws.Record`) bounds ``max_step`` and ``dt`` by its sampling step. ``progress``: a tqdm bar for
    runs longer than a few seconds (None: only on a terminal).

    ``events``: a callable ``f(t, q, v) → float`` or a list of them (attributes ``direction`` ∈ {−1, 0, 1}
    and ``terminal`` allowed, as in scipy): each zero crossing is located on the step's interpolant, to the
    step's accuracy (:mod:`vibdyn.simulation.events`): ``traj.t_events`` (an array of times per function),
    ``traj.q_events``, ``traj.v_events`` (the states there), scipy's names; a terminal one ends the run there.
    ``variational``: integrate the tangent-space variational equations with the state (dop853, rk4; not
    with loops): ``traj.state_transition`` (2nv × 2nv) is ∂(q, v)(t_end)/∂(q0, v0) in the tangent spaces,
    ``traj.state_transition_error`` its estimated error (from the error estimate's second run).

    Drives (:meth:`vibdyn.Scene.add_drive`; every method but "symplectic"): the free coordinates alone are
    integrated; the driven entries of q0 and v0 are replaced by the laws' values at t0 and those of every
    output are the laws' (to round-off); ``traj.drive_work`` is the drives' work W_d (J) and ``traj.work``
    includes it (the energy balance closes with it); ``state_transition`` is 2nf × 2nf over the free coordinates,
    ordered (δq_f, δv_f) as
    ``system.reduction.free``.

    Returns a :class:`Trajectory`; Ctrl-C returns the motion so far with status "interrupted". Bad input is
    a :class:`ModelError`; a run that cannot go on (step-size underflow, non-finite state, an element that
    fails) raises :class:`SimulationError` carrying the time reached and the trajectory so far.
    """
    start = time.perf_counter()
    error = _ERROR_METHOD(error_method, error)
    cfg = settings(system, t_end, q0, v0, method, rtol, atol, dt, t_eval, error, max_step, progress, t0, events,
                   variational)
    return Flow.of(system, cfg)(cfg.q0, cfg.v0, cfg.t0, cfg.t_end, t_eval=cfg.t_eval, trajectory=True,
                                started=start)


