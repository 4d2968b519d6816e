"""Equilibria: static (Q − g = 0 at v = 0) and steady motions (some coordinates turning at constant speed,
the others at rest relative to them), found by one Newton search in the independent coordinates of the system's
reduction whatever the scene (tree, drives, loops: :func:`search`), and their stability; and configurations
held by drives (robots under gravity, which have no free equilibrium): the same search in a reduction that holds
every coordinate (:meth:`~vibdyn.model.reduction.Reduction.holding_all`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from .._check import has_coordinates, integer, scalar, start_hint, turns_hint
from .._deprecation import Renamed
from .._format import number, table
from ..defaults import EPS, EQUILIBRIUM_TOL, MAX_ITER
from ..errors import ConvergenceError, ModelError
from ..model import dynamics
from ..model.fd import steps
from ..solvers.newton import NewtonResult, Steps, newton
from .linearize import LinearModel, jacobian_q, jacobian_v, linearize

if TYPE_CHECKING:
    from ..model.system import System
    from .modal import Modes


@dataclass(frozen=True, eq=False)
class OperatingPoint:
    """An equilibrium (``regime`` "static"), steady motion ("steady") or configuration held by drives
    ("held", :func:`held`) of a system.

    ``residual``: largest remaining generalized force (N or N·m); ``speeds``: the cyclic coordinates'
    speeds (rad/s or m/s); ``drive``: generalized force needed to hold each given speed, or for a held
    point each coordinate (N or N·m); ``stability``: "stable", "unstable" or "neutral" (rigid-body/cyclic
    directions, undamped); ``tol``: the residual it was solved to (N or N·m); ``q_error``: estimated error of
    each coordinate's offset (m or rad).
    """

    system: System = field(repr=False)
    q: np.ndarray
    v: np.ndarray
    t: float
    regime: str
    residual: float
    tol: float
    iterations: int
    stability: str
    speeds: dict
    drive: dict
    elapsed: float  # s
    modes: Modes | None = field(repr=False, default=None)
    q_error: np.ndarray | None = field(repr=False, default=None)
    tolerance = Renamed("tol")

    def linearize(self, **kwargs: Any) -> LinearModel:
        """The linear model about this point (see :meth:`vibdyn.System.linearize`)."""
        return linearize(self.system, self, **kwargs)

    def coordinate(self, name: str) -> float:
        """Value of a tangent coordinate, as the offset from the neutral configuration (m or rad)."""
        return float(self.system.difference(self.system.neutral(), self.q)[self.system.coordinate_index(name)])

    def __repr__(self):
        from .._format import duration, number, summary

        return summary("OperatingPoint", self.regime, self.stability, f"residual {number(self.residual, digits=2)}",
                       f"{self.iterations} iterations" if self.regime != "held" else "",
                       f"speeds {self.speeds}" if self.speeds else "", duration(self.elapsed))

    def _repr_html_(self):
        from .._format import html_table, number

        sysm = self.system
        dq = sysm.difference(sysm.neutral(), self.q)
        rows = [[n, u, number(x), number(self.v[i]), number(self.drive[n]) if n in self.drive else ""]
                for i, (n, u, x) in enumerate(zip(sysm.coordinates, sysm.units, dq))]
        return html_table(f"{self.regime} ({self.stability}), residual {number(self.residual, digits=2)}",
                          ["coordinate", "unit", "offset", "speed", "drive"], rows)

    def __str__(self):
        sysm = self.system
        dq = sysm.difference(sysm.neutral(), self.q)
        err = np.zeros(sysm.nv) if self.q_error is None else self.q_error
        ms = f"{self.elapsed * 1e3:.1f} ms"
        if self.regime == "held":
            head = (f"held configuration ({self.stability} without its drives' stiffness): the drives hold every "
                    f"coordinate, {ms}")
        else:
            head = (f"{self.regime} equilibrium: {self.stability}, residual {self.residual:.1e} after "
                    f"{self.iterations} iterations, {ms}")
        cols = ["coordinate", "offset"]
        if self.speeds:
            cols.append("speed")
        if self.drive:
            cols.append("drive")
        rows = []
        for i, (name, u) in enumerate(zip(sysm.coordinates, sysm.units)):
            row = [name, number(dq[i], u, err[i], 10)]
            if self.speeds:
                row.append(number(self.speeds[name], f"{u}/s", digits=10) if name in self.speeds else "")
            if self.drive:
                row.append(number(self.drive[name], "N" if u == "m" else "N·m", self.tol)
                           if name in self.drive else "")
            rows.append(row)
        return "\n".join([head] + ["  " + line for line in table(cols, rows)])


Equilibrium = OperatingPoint  # (the former name: a static equilibrium is one kind of operating point)


def static_equilibrium(system, q0=None, t=0.0, tol=EQUILIBRIUM_TOL, max_iter=MAX_ITER):
    """Static equilibrium near ``q0`` (neutral if None; with loops the system's start, and q0 need not close
    them): Newton in the independent coordinates of the system's reduction (:func:`search`), with line search
    and least-squares steps where K is singular (free or cyclic coordinates). Raises ConvergenceError with the
    best point. With drives, the driven coordinates are held at their laws' position and speed at t (a moving
    drive makes it a steady motion); with loops, the result also carries the loop forces."""
    _given_start(system, q0, "equilibrium: q0")
    return search(system, q0, t, {}, tol, max_iter, caller="equilibrium")


def static_configuration(system, equilibrium: Any, what: str) -> np.ndarray:
    """q of a static equilibrium (m and rad): ``equilibrium`` an OperatingPoint of regime "static" (any other
    regime is a ModelError naming ``what``), or a configuration to search it from (None: the neutral one)."""
    if isinstance(equilibrium, OperatingPoint):
        if equilibrium.regime != "static":
            raise ModelError(f"{what}: equilibrium must be a static one, got a {equilibrium.regime} operating point")
        return np.array(equilibrium.q, dtype=float)
    return np.array(system.equilibrium(equilibrium).q, dtype=float)


def steady_motion(system, v_cyclic, q0=None, t=0.0, tol=EQUILIBRIUM_TOL, max_iter=MAX_ITER, guess=1.0):
    """Steady motion: the coordinates named in ``v_cyclic`` turn at constant speed — a number (given) or
    None (found from the forces, starting from ``guess`` rad/s or m/s) — while the others rest.

    Given speeds: a search from ``q0`` that fails is followed from the resting state near it as the speeds grow
    (continuation); without ``q0``, an unstable steady motion found from neutral gives way to the one spun up from
    rest where that one is not unstable.

    Example (a rotor driven by τ = 10 − ω² carrying a sprung slider): ``steady_motion({"rotor": None})``.
    With drives, the driven coordinates move at their laws' speeds at t; with loops, the turning coordinates
    carry the loops with them (Φ_q v = 0: a rotor under the mechanism) at given speeds (:func:`search`).
    """
    _given_start(system, q0, "steady_motion: q0")
    return _steady(system, v_cyclic, q0, t, tol, max_iter, guess)


def _steady(system, v_cyclic, q0, t=0.0, tol=EQUILIBRIUM_TOL, max_iter=MAX_ITER, guess=1.0):
    if not isinstance(v_cyclic, dict) or not v_cyclic:
        raise ModelError("steady_motion: v_cyclic must be a dict {coordinate: speed or None}")
    cyclic = {}
    for name, speed in v_cyclic.items():
        if speed is None:
            system.reduction.require("steady motions of unknown speed", "steady_motion", loops=(
                f"the speed of '{name}' must be given for a mechanism with loops (a speed found from the forces "
                "is not supported there)"))
        i = system.coordinate_index(name)
        cyclic[i] = None if speed is None else scalar(speed, f"steady_motion: speed of '{name}'")
    given = all(s is not None for s in cyclic.values()) and max_iter > 0
    # (followed from rest in the tree's own coordinates: where the reduction allows it)
    given = given and system.reduction.allows("steady motions followed from rest")
    try:
        found = search(system, q0, t, cyclic, tol, max_iter, guess, caller="steady_motion", suggest=not given)
    except ConvergenceError as failed:
        if not given:
            raise
        # (from rest, a spun body's steady pose may lie far from the start: follow it as the speeds grow)
        q_rest = system.start_configuration()[0] if q0 is Declared else q0
        return search(system, _along_speed(system, q_rest, t, cyclic, failed), t, cyclic, tol, max_iter, guess,
                      caller="steady_motion")
    if given and q0 is None and found.stability == "unstable":
        # sought from rest, found on another branch (a pendulum flung inwards): the one spun up from rest instead,
        # where that one is not unstable
        try:
            spun = search(system, _along_speed(system, None, t, cyclic, None), t, cyclic, tol, max_iter, guess,
                          caller="steady_motion")
        except ConvergenceError:
            return found
        return spun if spun.stability != "unstable" else found
    return found


def _along_speed(system, q0, t, cyclic, failed):
    """q of the steady motion at the given speeds ``cyclic`` {index: speed}, followed from the resting state
    near ``q0`` (the static equilibrium of the other coordinates, the speeds 0) as the speeds grow together
    (pseudo-arclength continuation in their common factor s, 0 → 1). A branch that does not reach them is a
    ConvergenceError saying how far it went (the search's own start hint was not checked: left out); ``failed``:
    the search's own ConvergenceError (None: a plain ConvergenceError)."""
    from ..solvers.continuation import Arclength, continuation

    nv, model = system.nv, system.model
    base = system.neutral() if q0 is None else system.check_configuration(q0, "q0").copy()
    rest = [i for i in range(nv) if i not in cyclic]
    speeds = np.zeros(nv)
    speeds[list(cyclic)] = list(cyclic.values())
    unit, a0 = system.coordinate_scales, np.zeros(nv)

    def at(x):
        dq = np.zeros(nv)
        dq[rest] = x
        return pin.integrate(model, base, dq)

    r = dynamics.inverse_dynamics(system, system.workspace(), base, speeds, a0, t)
    Jq = jacobian_q(system, base, speeds, a0, t, steps(system, 1e-6))
    force_scale = max(np.abs(r).max(initial=0.0), (np.abs(np.diag(Jq))[rest] * unit[rest]).max(initial=0.0), 1e-300)
    furthest = [0.0]

    def fun(x, s):
        return dynamics.inverse_dynamics(system, system.workspace(), at(x), s * speeds, a0, t)[rest] / force_scale

    def turned_back(x, s):  # (past a fold, the branch goes back to lower speeds: it will not reach them)
        furthest[0] = max(furthest[0], s)
        return s < furthest[0] - 0.05

    branch = continuation(fun, np.zeros(len(rest)), 0.0, 1.0, stop=turned_back, parameter="the speeds' factor s",
                          path=Arclength(scale=np.append(unit[rest], 1.0), tol=1e-10, max_steps=400))
    if branch.status == "finished":
        return at(branch.x[-1])
    if failed is None:  # (asked only for a better branch: no message)
        raise ConvergenceError(branch.message)
    names = system.coordinates
    head = str(failed).split(". Start nearer")[0].rstrip(".")
    if not branch.lam.size:
        raise ConvergenceError(f"{head}; no resting state (static equilibrium with the speeds 0) was found near the "
                               "start either: give q0= near the steady pose", residual=failed.residual,
                               best=failed.best) from None
    k = int(np.argmax(branch.lam))
    s, q = float(branch.lam[k]), at(branch.x[k])
    reached = ", ".join(f"'{names[i]}' = {number(s * speeds[i], system.units[i] + '/s')}" for i in cyclic)
    pose = ", ".join(f"{names[i]} = {number(x, system.units[i])}" for i, x in
                     zip(rest, system.difference(system.neutral(), q)[rest]))
    why = "the branch turns back there (a fold)" if branch.reason == "stop" else branch.message
    raise ConvergenceError(f"{head}. Followed from rest as the speeds grow, the steady motion goes no further than "
                           f"{reached} ({pose}): {why}; beyond, no steady motion joins the resting state",
                           residual=failed.residual, best=q) from None


def equilibria(system, starts, t=0.0, tol=EQUILIBRIUM_TOL, max_iter=MAX_ITER):
    """Distinct static equilibria reached from several starting configurations, lowest potential first."""
    starts = list(starts)
    if not starts:
        raise ModelError("equilibria: starts is empty: give the configurations to search from (one or more)")
    found = []
    for q0 in starts:
        try:
            _given_start(system, q0, "equilibrium: q0")
            eq = search(system, q0, t, {}, tol, max_iter, caller="equilibrium", suggest=False)  # (others tried)
        except ConvergenceError:
            continue
        if all(np.abs(system.difference(e.q, eq.q)).max() > 1e-6 * max(1.0, system.length_scale) for e in found):
            found.append(eq)
    if not found:
        raise ConvergenceError("equilibria: no start converged", residual=None, best=None)
    return sorted(found, key=lambda e: system.energy(e.q, e.v).potential)


def held(system, q=None, v=None, t=0.0):
    """The configuration ``q`` (neutral if None) moving at the constant velocity ``v`` (0 if None), held by
    drives on every coordinate: ``drive`` is the generalized force (N or N·m) they add to balance gravity,
    the elastic and the other forces, M·0 + b(q, v) − Q(q, v, t) (not for a mechanism with loops, whose
    drives could not all act): :func:`search` in the reduction holding every coordinate, nothing left to solve.
    Linearised with a = 0, its K is ∂(g − Q)/∂q at q: the drives are taken as constant forces (no stiffness of
    their own)."""
    _given_start(system, q, "held: q")
    return _held(system, q, v, t)


def _held(system, q, v, t):
    system.reduction.require("held configurations", "held", drives=(
        f"scene '{system.name}' has drives ({{drives}}) whose coordinates move with time: not supported yet; "
        "linearise it about a state of its motion (system.linearize(q, v=v, t=t), free coordinates) or simulate "
        "it"))
    has_coordinates(system, "held", "to hold")
    q = system.neutral() if q is None else system.check_configuration(q, "held q").copy()
    v = np.zeros(system.nv) if v is None else system.check_velocity(v, "held v").copy()
    system.check_limits(q, "held configuration")
    R = system.reduction.holding_all(q, v)  # (nothing left to solve: the holders' forces, the inverse dynamics')
    return search(system, q, t, {}, EQUILIBRIUM_TOL, MAX_ITER, caller="held", reduction=R)


def operating_point(system: System, tol: float = EQUILIBRIUM_TOL, max_iter: int = MAX_ITER) -> OperatingPoint:
    """The scene's declared operating point (``Scene.set_operating_point``): the configuration held by drives
    (:func:`held`) if it says so (robots' default), a steady motion (:func:`steady_motion`) if it names cyclic
    coordinates, else the static equilibrium nearest its start (neutral by default)."""
    op = system.scene.operating_point or {}
    declared = Declared if op.get("start") is not None else None
    # (the declared start is hinted where it is read: not again as a start given here)
    if op.get("held"):
        return _held(system, system.start_configuration()[0] if declared else None, None, 0.0)
    if op.get("cyclic"):
        return _steady(system, op["cyclic"], declared, tol=tol, max_iter=max_iter)
    return search(system, declared, 0.0, {}, tol, max_iter, caller="equilibrium")


def _given_start(system, q0, what):
    """The degrees hint for a start ``q0`` the user gave (None: none given), as simulate's (a ``q0`` that is not a
    configuration is refused by the search itself, in its words)."""
    if q0 is None or q0 is Declared or not system.nv:
        return
    try:
        q = system.check_configuration(q0, what)
    except ModelError:
        return
    start_hint(system, q, what)


class Declared:
    """q0 of a search that starts from the scene's declared start (:meth:`System.start_configuration`: a
    mechanism's names it if its loops cannot close there)."""


def search(system, q0, t, cyclic, tol, max_iter, guess=1.0, caller="equilibrium", reduction=None, suggest=True):
    """The one equilibrium search, for every scene: Newton in the independent coordinates z of the system's
    reduction R (:mod:`vibdyn.model.reduction`; ``reduction``: another, e.g. every coordinate held,
    :meth:`~Reduction.holding_all`), q moved by :meth:`~Reduction.step` (the loops closed again),
    on the reduced forces ρ = N(q)ᵀ r(q, v, a_ref) of the coordinates at (relative) rest and of those whose
    speed is unknown, r the inverse dynamics and a_ref :meth:`~Reduction.reference_acceleration`.
    ``cyclic``: {index in v: speed (rad/s or m/s), or None to find it from ``guess``}; the held coordinates
    (drives) move at their laws' position and speed at t (:meth:`~Reduction.impose`). With nothing independent
    (every coordinate held) there is nothing to solve: the forces are the holders', to the inverse dynamics'
    round-off (``tol``). ``suggest``: a failed search checks the start it suggests (False: none suggested)."""
    start = time.perf_counter()
    has_coordinates(system, "steady motion" if cyclic else "equilibrium", "to balance")
    R, names, nv, nq = reduction or system.reduction, system.coordinates, system.nv, system.nq
    t, tol = system.check_time(t), scalar(tol, "equilibrium tol", positive=True)
    max_iter, guess = integer(max_iter, "equilibrium max_iter", minimum=0), scalar(guess, "steady_motion guess")
    R.require_uniform(caller, t, system.coordinate_scales)
    for i in cyclic:
        if i in R.held:
            raise ModelError(f"{caller}: coordinate '{names[i]}' is driven: its speed is its drive's")
    if q0 is None or q0 is Declared:
        q, origin = system.start_configuration() if q0 is Declared else R.default_start(system)
    else:
        q, origin = system.check_configuration(q0, "q0").copy(), "q0"
    q_given = q  # (a start in degrees is far from everything: said if the search fails)
    v = np.zeros(nv)
    for i, s in cyclic.items():
        v[i] = guess if s is None else s
    q, v = R.impose(q, v, t)
    try:
        q = R.close(q, start=origin)
    except ConvergenceError as e:
        turns = turns_hint(system, q_given)
        if not turns:
            raise
        raise ConvergenceError(f"{e}; the start has {turns}", residual=e.residual, best=e.best) from None
    system.check_limits(q, "equilibrium search start")
    if R.opening(q, v) > 1e-9:
        raise ModelError(f"steady_motion: turning {', '.join(names[i] for i in cyclic)} opens the loops (Φ_q v ≠ "
                         "0): the cyclic coordinates of a mechanism with loops must carry the loops with them (a "
                         "rotor under the mechanism)")
    ind, _ = R.independent(q)
    fixed = [names[i] for i in cyclic if i not in ind]
    if fixed:
        raise ModelError(f"steady_motion: {', '.join(fixed)} cannot turn freely: the loops tie it to the other "
                         "coordinates (give a coordinate the loops leave free)")
    keep = ind if cyclic else None  # (a steady motion keeps its cyclic coordinates independent)
    position = {int(i): k for k, i in enumerate(ind)}
    rest = [k for k, i in enumerate(ind) if int(i) not in cyclic]  # positions in ind: unknown positions
    unknown = [i for i, s in cyclic.items() if s is None]  # indices in v: unknown speeds
    rows = rest + [position[i] for i in unknown]  # equations: no acceleration of these
    unit = system.coordinate_scales
    regime = R.regime(bool(cyclic))
    what = {"static": "static equilibrium", "steady": "steady motion", "held": "held configuration"}[regime]
    moved = f"an iterate of the {what} search"

    def acceleration(q, v, ind):
        return R.reference_acceleration(system.workspace(), q, v, t, ind)

    def residual(q, v, ind):
        return dynamics.inverse_dynamics(system, system.workspace(), q, v, acceleration(q, v, ind), t)

    def split(x):  # the unknowns: the configuration, then the unknown speeds
        vv = v.copy()
        vv[unknown] = x[nq:]
        return x[:nq], vv

    memo = {"x": None}

    def at(x):
        """The basis, the residual r (nv) and the reduced forces ρ (n) at the unknowns x."""
        if memo["x"] is not x and (memo["x"] is None or not np.array_equal(memo["x"], x)):
            qq, vv = split(x)
            ind1, N1 = R.independent(qq, keep)
            r = residual(qq, vv, ind1)
            memo.update(x=x, q=qq, v=vv, ind=ind1, N=N1, r=r, f=R.reduce(ind1, N1, r))
        return memo

    def rho(x):
        return at(x)["f"][rows]

    def jacobian(x):
        b = at(x)
        qq, vv, ind1 = b["q"], b["v"], b["ind"]
        a = acceleration(qq, vv, ind1)
        J = R.derivative(qq, ind1, b["N"], lambda q1: R.reduce(ind1, R.independent(q1, ind1)[1],
                                                                residual(q1, vv, ind1)),
                         lambda q1: jacobian_q(system, q1, vv, a, t, h), 1e-6 * unit, moved)
        cols = [J[block]]
        if unknown:
            Jv = jacobian_v(system, qq, vv, a, t, h * np.maximum(1.0, np.abs(vv)))
            cols.append(R.reduce(ind1, b["N"], Jv)[np.ix_(rows, unknown)])
        return np.hstack(cols)

    fine = {"on": False}  # (the loops closed on to round-off at each step: see LOCK_CLOSURE)

    def retract(x, step):
        b = at(x)
        dz = np.zeros(b["ind"].size)
        dz[rest] = step[: len(rest)]
        return np.concatenate([R.step(b["q"], b["N"], dz, moved, refine=fine["on"]), x[nq:] + step[len(rest):]])

    def found(out, target):
        """The operating point the search ``out`` reached, with the holders' forces and the loops'."""
        b = at(out.x)
        q, v, N, r, f = b["q"], b["v"], b["N"], b["r"], b["f"]
        given = [i for i, s in cyclic.items() if s is not None]
        turning = [position[i] for i in cyclic]
        drive = {names[i]: float(f[position[i]]) for i in given}
        drive.update({names[i]: float(r[i]) for i in R.held})
        held = regime == "held"  # (a held configuration lists the coordinates that move)
        speeds = {names[i]: float(v[i]) for i in [*cyclic, *R.held] if v[i] or not held}
        lam = R.multipliers(q, r - N[:, turning] @ f[turning] if turning else r)
        loops = {"multipliers": lam, "loop_forces": R.split(lam), "constraint_residual": R.closure(q)} if lam.size \
            else {}
        if loops:  # a mechanism's equilibrium also carries its loop forces
            from .constrained import LoopEquilibrium as kind
        else:
            kind = OperatingPoint
        point = kind(system, q, v, float(t), regime, float(np.abs(f[rows]).max(initial=0.0)), float(target),
                     out.iterations, "", speeds, drive, 0.0, **loops)
        if held:  # its linear model is the free tree's (the holders constant forces), its offsets the given ones
            return _finish(point, None, 0, start)
        return _finish(point, N, len(speeds), start, float(np.abs(system.difference(x0[:nq], q)).max(initial=0.0)))

    x0 = np.concatenate([q, v[unknown]])
    b = at(x0)
    if not rows:  # nothing to solve for: RNEA's round-off, eps × nv × the forces' scale (largest, or weight × length)
        weight = sum(I.mass for I in system.model.inertias) * np.linalg.norm(system.scene.gravity) * system.length_scale
        target = 100 * nv * EPS * max(np.abs(b["r"]).max(initial=0.0), weight, 1e-300)
        return found(NewtonResult(x0, 0.0, 0, True, "nothing to solve for", 0.0), target)
    block, h = np.ix_(rows, rest), steps(system, 1e-6)
    J = jacobian(x0)
    r_rest = np.diag(J)[: len(rest)] * unit[ind[rest]]
    force_scale = max(np.abs(b["r"]).max(initial=0.0), np.abs(r_rest).max(initial=0.0), 1e-300)
    target = tol * force_scale
    max_step = np.concatenate([0.5 * unit[ind[rest]], [max(1.0, abs(v[i])) for i in unknown]])

    def tree_forces(x):
        """The reduced forces at x on the tree's coordinates (nv; zero at the held and dependent ones)."""
        b = at(x)
        out = np.zeros(nv)
        out[b["ind"]] = b["f"]
        return out

    def shape_step(x, f, J, step):
        b = at(x)
        left = f + J @ step  # what the linear model cannot remove (K = 0 along it here)
        if np.linalg.norm(left) > 0.5 * np.linalg.norm(f):
            _refuse_constant(system, what, b, R, rest, np.abs(left[: len(rest)]) > 0.5 * target, force_scale,
                             lambda q1: residual(q1, b["v"], b["ind"]))
            # a gradient step: move along the unbalanced force, as far as a step may go
            step = step - left / (np.abs(left) / max_step).max()
        return _within_limits(system, what, b["q"], step.copy(), b["ind"][rest], tree_forces(x), unit, target)

    # past tol on to round-off (refine): a linear model taken at a residual of tol carries K's change over the
    # pose's error (K′ δq), which no estimate of its own sees (iftomm_a05's ω 7.7e-10 off, stated 4.8e-12)
    out = newton(rho, x0, jacobian, retract, tol=target, max_iter=max_iter, start=(b["f"][rows], J),
                 steps=Steps(max_step=max_step, expand=True, shape=shape_step, min_alpha=1e-3,
                             on_no_decrease="accept", stall=1e3, polish=True,
                             refine=ROUND_OFF * nv * EPS * force_scale))
    if out.status == "diverged":
        raise ConvergenceError(f"{what} search diverged (non-finite forces)", residual=out.residual,
                               best=split(out.x)[0])
    if out.status not in ("converged", "stagnated"):
        b = at(out.x)

        # (one unknown speed: the check starts it where this search left it, the guess it suggests with the start)
        spun = {i: float(b["v"][i]) for i in unknown}
        try:  # the linear model's whole step from there, uncapped (an equilibrium far off: a weak spring)
            leap = retract(out.x, np.linalg.lstsq(jacobian(out.x), -rho(out.x), rcond=None)[0])[:nq] if suggest \
                else None
        except (ConvergenceError, ModelError, np.linalg.LinAlgError):
            leap = None
        again = float(f"{spun[unknown[0]]:.6g}") if len(unknown) == 1 else guess  # (as printed: as checked)

        def check(q1):
            try:
                return search(system, q1, t, cyclic, tol, max_iter, again, caller, reduction, suggest=False)
            except (ConvergenceError, ModelError):
                return None
        raise ConvergenceError(_not_converged(system, what, max_iter, out.residual, b["q"], tree_forces(out.x),
                                              target, b["ind"][rest], turns_hint(system, q_given),
                                              check if suggest else None, spun, again if unknown else None, leap),
                               residual=out.residual, best=b["q"])
    q_end = split(out.x)[0]  # (the configuration alone: at() would evaluate the forces again)
    closure = R.closure(q_end)
    if out.converged and closure > 16 * EPS and closure > LOCK_CLOSURE * R.conditioning(q_end):
        # near a lock the loops' Jacobian is ill-conditioned: their closure left at ASSEMBLY_TOL moves the pose by
        # closure / conditioning along the mechanism, and its modes with it (a four-bar 0.1 µm short of locking:
        # pose 1.7e-9 rad, ω 5.6e-7 off): the search ends with the loops closed on to round-off
        fine["on"] = True
        x1 = np.concatenate([R.close(q_end, moved, refine=True), out.x[nq:]])
        more = newton(rho, x1, jacobian, retract, tol=target, max_iter=max_iter,
                      steps=Steps(max_step=max_step, on_no_decrease="stop", polish=True,
                                  refine=ROUND_OFF * nv * EPS * force_scale))
        if more.converged:
            out = more
    return found(out, target)


ROUND_OFF = 8  # × nv ε × the forces' scale: the residual a search refines to past its tol (round-off)
LOCK_CLOSURE = 1e-11  # a closure over the loops' conditioning (σ_min/σ_max) above this is closed on to round-off


def _finish(point, N, ignore_zeros, start, travel=0.0):
    """``point`` with its stability from the modes of its linear model (the reference motion not accelerating),
    and the error of its offsets: |N| |K⁺| × the remaining forces (N the basis of the independent coordinates,
    None: the identity) plus what the loops' closure leaves, and along rigid (neutral) directions, where any
    offset is an equilibrium, the drift of a search that travelled ``travel`` (m or rad) with a Jacobian
    differenced to a relative √eps."""
    system, q = point.system, point.q
    lin = linearize(system, point)
    m = lin.modes()
    stability = m.verdict(ignore_zeros=ignore_zeros)
    M, n = m.linear.M, lin.K.shape[0]
    if point.residual and n:  # (none left: no offset to carry, K not inverted)
        Kinv = np.abs(np.linalg.pinv(lin.K, rcond=1e-10))
        q_error = Kinv @ np.full(n, point.residual)
    else:
        q_error = np.zeros(n)
    if N is not None and N.shape[1] < N.shape[0]:  # on the tree's coordinates through N (held offsets: exact)
        q_error = np.abs(N) @ q_error
        # and the loops closed to their assembly's tolerance move the pose along the mechanism (0 without loops)
        q_error = q_error + system.reduction.closure_shift(q) * system.coordinate_scales
    if point.iterations:  # the offsets carry the round-off of the steps that reached them
        q_error = q_error + 4 * np.finfo(float).eps * (np.abs(system.difference(system.neutral(), q)) + 1.0)
        if m.rigid.any():
            P = np.abs(m.shapes[:, m.rigid] @ (m.shapes[:, m.rigid].T @ M))  # M-projector on rigid modes
            q_error = q_error + np.sqrt(np.finfo(float).eps) * travel * P.sum(axis=1)
    return replace(point, stability=stability, elapsed=time.perf_counter() - start, modes=m, q_error=q_error)


def _refuse_constant(system, what, b, R, rest, candidates, force_scale, residual):
    """Raise ConvergenceError if the unbalanced force along some independent coordinate (positions ``rest`` in
    b["ind"]) is the same at every configuration tried (it does not depend on q): then there is no stationary
    point at all."""
    ks = [rest[k] for k in np.flatnonzero(candidates)]
    if not ks:
        return
    ind, N, f, q = b["ind"], b["N"], b["f"], b["q"]
    unit = system.coordinate_scales
    rng = np.random.default_rng(0)
    same, change = np.ones(len(ks), bool), np.zeros(len(ks))
    for _ in range(3):
        dz = np.zeros(ind.size)
        dz[rest] = rng.uniform(-1.0, 1.0, len(rest)) * unit[ind[rest]]
        try:
            q2 = R.step(q, N, dz)
        except ConvergenceError:  # (loops that cannot close there: no verdict)
            return
        moved = system.difference(q, q2)[ind[rest]]
        if np.any(np.abs(moved - dz[rest]) > 0.5 * np.abs(dz[rest])):  # (the step lost to round-off, at an angle
            return  # of 1e300 rad: the force cannot change, no verdict)
        f2 = R.reduce(ind, R.independent(q2, ind)[1], residual(q2))
        change = np.maximum(change, np.abs(f2[ks] - f[ks]))
        same &= change <= 1e-9 * force_scale
    if not same.any():
        return
    coords = [(system.coordinates[ind[k]], system.units[ind[k]], f[k]) for k, s in zip(ks, same) if s]
    forces = ", ".join(f"'{n}': {number(-x, 'N' if u == 'm' else 'N·m')}" for n, u, x in coords)
    moved = change[same].max()
    # (a change above the forces' round-off is a weak dependence, a spring of 1e-8 N/m under a weight: a balance
    # far away, not none)
    exact = moved <= 100 * EPS * force_scale
    how = ("the same at every configuration tried: it does not depend on q), so there is no stationary point"
           if exact else f"nearly: it changed by at most {moved:.2g} over the configurations tried, a coordinate "
           "scale around here, below 1e-9 of the forces), so there is no stationary point within reach: a balance, "
           "if any, lies far beyond")
    raise ConvergenceError(
        f"no {what}{'' if exact else ' within reach'}: the generalized force along "
        f"{', '.join(repr(n) for n, _, _ in coords)} is constant "
        f"({forces}, {how}. Hold it instead (system.held(q), or `held = true` under [operating_point] in a "
        "scene file), or add a spring or a force that balances it", residual=float(np.abs(f[ks]).max()),
        best=q.copy())


def _within_limits(system, what, q, step, rest, r, unit, target):
    """The step scaled down to stay within the coordinates' position limits; a coordinate already on its
    limit and pushed beyond it by a force above ``target`` is a ConvergenceError naming it and the limit."""
    lower, upper = system.limit_bounds()
    if not (np.isfinite(lower[rest]).any() or np.isfinite(upper[rest]).any()):
        return step
    x = system.difference(system.neutral(), q)
    scale = 1.0
    for k, i in enumerate(rest):
        d = step[k]
        bound = upper[i] if d > 0 else lower[i]
        if d == 0 or not np.isfinite(bound):
            continue
        room = bound - x[i]
        if room * np.sign(d) <= 1e-9 * unit[i] and (-r[i] * d <= 0 or abs(r[i]) <= target):
            step[k] = 0.0  # on its limit, and no force worth the name pushes it beyond: it stays there
        elif room * np.sign(d) <= 1e-9 * unit[i]:
            u = system.units[i]
            raise ConvergenceError(
                f"{what} search left the joint limits: coordinate '{system.coordinates[i]}' is at its "
                f"{'upper' if d > 0 else 'lower'} limit {bound:.6g} {u} and the forces push it beyond "
                f"({number(-r[i], 'N' if u == 'm' else 'N·m')}): no {what} within the limits from this start; "
                "hold the configuration instead (system.held(q)) or start elsewhere",
                residual=float(np.abs(r).max()), best=q.copy())
        elif abs(d) > abs(room):
            scale = min(scale, room / d)
    return step * scale


def _not_converged(system, what, max_iter, res, q, r, target, rest, turns, check, spun, guess, leap):
    """The message of a search that did not converge at q (residual ``res``, forces r on the tree's coordinates;
    ``spun`` {index: speed} where it left the unknown speeds): what did not settle, and a start only if ``check``
    (a start's q -> the point the same search reaches from it, from speed ``guess``, or None) found that one
    converges: where it stopped, then half a unit on along the forces, then ``leap`` (the linear model's whole
    step from q, or None) (None: no start suggested)."""
    x = system.difference(system.neutral(), q)
    bad = [i for i in rest if abs(r[i]) > target]
    units = system.units
    parts = [f"'{system.coordinates[i]}' (unbalanced {number(-r[i], 'N' if units[i] == 'm' else 'N·m')} at "
             f"{number(x[i], units[i])})" for i in bad]
    parts += [f"the speed of '{system.coordinates[i]}' (unbalanced {number(-r[i], 'N' if units[i] == 'm' else 'N·m')}"
              f" at {number(w, units[i] + '/s')})" for i, w in spun.items() if abs(r[i]) > target]
    head = (f"{what} search did not converge in {max_iter} iterations: residual {res:.3e} (target "
            f"{target:.3e}); not settled: {', '.join(parts) or 'none'}.")
    if turns:  # (a start in degrees: the hint below would be as far off)
        return f"{head} start nearer an equilibrium (q0=); the start has {turns}"
    if check is None:
        return head
    unit = system.coordinate_scales
    stepped = x.copy()
    stepped[bad] -= 0.5 * unit[bad] * np.sign(r[bad])
    tried = (x, stepped) if leap is None else (x, stepped, system.difference(system.neutral(), leap))
    for offsets in tried:  # (as printed: the start a user would type is the one checked)
        given = {i: float(number(offsets[i], digits=4)) for i in rest}
        given = {i: v for i, v in given.items() if v}
        dq = np.zeros(system.nv)
        dq[list(given)] = list(given.values())
        point = check(pin.integrate(system.model, system.neutral(), dq))
        if point is None:
            continue
        hint = " ".join(f"{system.coordinates[i]}={v:g}" for i, v in given.items())
        at = system.difference(system.neutral(), point.q)
        reached = ", ".join([f"{system.coordinates[i]} = {number(at[i], units[i])}" for i in rest] + [
            f"'{system.coordinates[i]}' turning at {number(point.v[i], units[i] + '/s')}" for i in spun])
        from_speed = f" and guess={guess:.6g} (steady_motion's start speed)" if guess is not None else ""
        where = (f"`--start {hint}` (vibdyn modes/frf), `start = {{ {hint.replace(' ', ', ').replace('=', ' = ')} }}` "
                 "under [operating_point] in the scene file, or q0= in Python" if hint else "the neutral configuration")
        return (f"{head} Start nearer an equilibrium: {where}{from_speed}: from there the same search converges to the "
                f"{what} at {reached} (checked)")
    return (f"{head} No start was suggested: from where it stopped, half a unit on along the forces, and a whole "
            f"step of its linear model on, the same "
            f"search (max_iter={max_iter}) does not converge either: raise max_iter or start elsewhere (q0=); there "
            f"may be no {what} near")
