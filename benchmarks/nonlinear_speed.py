"""Speed targets of the nonlinear analyses (issue 33, item 3), where users wait: ratios to a hand-written scipy
shooting of the same equations at the same accuracy, and where the time goes.

- Kerschen's two masses (models/two_mass_cubic.toml), in-phase NNM at x₁ amplitudes 0.1, 0.3, 0.5 m:
  ``vd.backbone`` at its defaults (tol 1e-10, rtol 1e-11) against :func:`benchmarks.nonlinear.scipy_backbone`
  (DOP853 on the hand-written ODE, natural continuation) at the loosest rtol of 1e-9 … 1e-13 whose ω error (against
  scipy at rtol 1e-13, step 0.025) is at most vibdyn's. Target ≤ 10×.
- The rod pendulum (models/rod_pivot.toml) at A = 1 and 2.5 rad, the same comparison against the elliptic
  integral. Target ≤ 1.5×.
- One request on a ball pendulum with a point spring (:func:`ball_point_spring`): target ≤ 2 s.

Times are the best of interleaved calls (the machine's load hits all alike). Where the time goes: the flows
(variational or plain) per stage of the analysis — continuation legs, each request's exact solve, the periodic
orbit's own Newton, its polish step, the error-estimate reruns, the check of the state transitions against
differences of the flows, the amplitude's event run — with their steps, dynamics evaluations and time; "other"
is the rest (equilibrium, linearisation, checks, Newton algebra, energies); and the cost of one stage of the
flows with and without the variational equations.
"""

import collections
import inspect
import math
import time

import numpy as np

import vibdyn as vd

from . import common as C
from .nonlinear import pendulum_ode, scipy_backbone, two_mass_ode

G = 9.81
KERSCHEN_TARGET, ROD_TARGET, BALL_TARGET_S = 10.0, 1.5, 2.0
SCIPY_RTOLS = (1e-9, 1e-10, 1e-11, 1e-12, 1e-13)
PHASES = ("amplitude", "differenced", "_polish", "_result", "first_return", "exact", "angles", "periodic_orbit",
          "run")  # callers of the flows, innermost first ("run": the continuation legs)
PHASE_NAMES = {"run": "continuation legs", "exact": "requests solved exactly", "periodic_orbit":
               "periodic orbit's Newton", "_polish": "polish step", "_result": "error-estimate reruns",
               "differenced": "transition check (plain flows)", "amplitude": "amplitude (event run)",
               "angles": "multipliers' angles", "first_return": "first return"}


def ball_point_spring():
    """A 2 kg box (0.3 × 0.1 × 1 m, centre 0.5 m below a ball joint; a torsion spring of 5 N·m/rad on the ball's z
    holds its spin) with a point spring of 10 N/m from its bottom (0, 0, −1) m to the world point (0, 1, −1) m:
    the stiffer swing about x; the NNM of its lowest mode (about y) at 1 rad."""
    m, a, b, h, d = 2.0, 0.3, 0.1, 1.0, 0.5
    sc = vd.Scene("ball pendulum, point spring", gravity=(0, 0, -G))
    sc.add_body("b", joint=vd.Ball(), mass=m, com=(0, 0, -d), inertia=vd.inertia.box(m, (a, b, h)))
    sc.add_joint_spring("b", [0.0, 0.0, 5.0])
    sc.add_spring("s", ("b", (0, 0, -1.0)), ("world", (0, 1.0, -1.0)), 10.0)
    return sc.build()


def interleaved(fns, rounds):
    """Best wall time (s) of each function over ``rounds`` interleaved calls, and each one's last result."""
    best, out = {k: math.inf for k in fns}, {}
    for _ in range(rounds):
        for k, f in fns.items():
            t = time.perf_counter()
            out[k] = f()
            best[k] = min(best[k], time.perf_counter() - t)
    return best, out


def breakdown(fn):
    """(result, {phase: [flows, steps, evaluations, s]}, total s): ``fn()`` with the time layer's flows counted by
    the analysis stage that asked for them."""
    from vibdyn.analysis.nonlinear import backbone as B
    from vibdyn.analysis.nonlinear import periodic as P
    from vibdyn.analysis.nonlinear import shooting as SH

    try:
        from vibdyn.simulation import flow as F
    except ImportError:  # (the code before the Flow: every flow was a simulate call)
        F = None

    stats = collections.defaultdict(lambda: [0, 0, 0, 0.0])

    def phase(variational):
        names = [f.function for f in inspect.stack()[2:14]]
        where = next((p for p in PHASES if p in names), names[0])
        return f"{PHASE_NAMES.get(where, where)}{' (variational)' if variational else ''}"

    def count(key, t, steps, nfev):
        s = stats[key]
        s[0] += 1
        s[1] += steps
        s[2] += nfev
        s[3] += time.perf_counter() - t

    call, simulate = (F.Flow.__call__ if F else None), vd.simulate

    def flow(self, *a, **k):
        key, t = phase(self.settings.variational), time.perf_counter()
        r = call(self, *a, **k)
        count(key, t, r.accepted + (r.rejected or 0), r.nfev + getattr(r, "error_nfev", 0))
        return r

    def sim(*a, **k):
        key, t = phase(k.get("variational", False)), time.perf_counter()
        r = simulate(*a, **k)
        count(key, t, r.accepted + (r.rejected or 0), r.nfev + r.error_nfev)
        return r

    mods = [m for m in (SH, P, B) if hasattr(m, "simulate")]
    if F:
        F.Flow.__call__ = flow
    for m in mods:
        m.simulate = sim
    try:
        t = time.perf_counter()
        out = fn()
        total = time.perf_counter() - t
    finally:
        if F:
            F.Flow.__call__ = call
        for m in mods:
            m.simulate = simulate
    stats["other (equilibrium, linearisation, checks, Newton algebra)"] = [
        0, 0, 0, total - sum(s[3] for s in stats.values())]
    return out, dict(stats), total


def stage_cost(system, rounds=5):
    """(µs per stage with the variational equations, µs per plain stage): a DOP853 flow over 1 s at rtol 1e-9 from
    a state 0.3 rad/m from neutral, its time over its dynamics evaluations (best of ``rounds``)."""
    rng = np.random.default_rng(0)
    q = system.integrate(system.neutral(), 0.3 * rng.standard_normal(system.nv))
    v = 0.1 * rng.standard_normal(system.nv)
    out = {}
    for variational in (True, False):
        try:
            from vibdyn.simulation.flow import Flow

            flow = Flow(system, q, v, rtol=1e-9, variational=variational)

            def run():
                return flow(q, v, 0.0, 1.0)
        except ImportError:  # (the code before the Flow)
            def run():
                return vd.simulate(system, 1.0, q, v, rtol=1e-9, error_method="local", variational=variational)
        best = math.inf
        for _ in range(rounds):
            t = time.perf_counter()
            r = run()
            best = min(best, (time.perf_counter() - t) / r.nfev)
        out[variational] = best * 1e6
    return out[True], out[False]


def table(stats, total):
    return [{"phase": k, "flows": n, "steps": st, "evaluations": nf, "time_s": round(s, 4),
             "share": round(s / total, 3)} for k, (n, st, nf, s) in sorted(stats.items(), key=lambda kv: -kv[1][3])]


def backbone_target(S, name, system, amplitudes, coordinate, ode, reference, target):
    """vd.backbone against the scipy shooting at the same accuracy: the ratio of their best times."""
    rounds = 3 if S.full else 2

    def vib():
        return vd.backbone(system, 0, amplitudes=amplitudes, coordinate=coordinate)

    bb, stats, _ = breakdown(vib)
    err = float(np.abs(bb.omega - reference).max())
    scipy_errors = {r: float(np.abs(scipy_backbone(*ode, amplitudes, r) - reference).max()) for r in SCIPY_RTOLS}
    rtol = next((r for r in SCIPY_RTOLS if scipy_errors[r] <= max(err, 1e-15)), SCIPY_RTOLS[-1])
    best, _ = interleaved({"vibdyn": vib, "scipy": lambda: scipy_backbone(*ode, amplitudes, rtol)}, rounds)
    ratio = best["vibdyn"] / best["scipy"]
    v_stage, p_stage = stage_cost(system)
    runs = [C.run_record("vibdyn backbone (defaults)", "vibdyn", err, float(bb.error.max()), best["vibdyn"],
                         method="continuation + shooting", points=bb.points, ratio_to_scipy=ratio,
                         where_the_time_goes=table(stats, sum(s[3] for s in stats.values())),
                         stage_us={"variational": round(v_stage, 1), "plain": round(p_stage, 1)}),
            C.run_record(f"scipy shooting rtol={rtol:g}", "scipy", scipy_errors[rtol], None, best["scipy"],
                         method="hand-written ODE, DOP853, natural continuation", rtol=rtol,
                         note="the loosest rtol whose ω error is at most vibdyn's", errors_by_rtol=scipy_errors)]
    case = C.case_record(f"target: {name}", "speed", "see benchmarks/nonlinear.py", runs, unit="rad/s",
                         target=f"vibdyn ≤ {target:g}× the scipy shooting at the same accuracy")
    case["ratio_to_scipy"] = ratio
    return case


def case_kerschen(S):
    A = [0.1, 0.3, 0.5]
    reference = scipy_backbone(*two_mass_ode(0), A, 1e-13, step=0.025)
    return backbone_target(S, "backbone of Kerschen's two masses (in-phase NNM, x₁ = 0.1, 0.3, 0.5 m)",
                           vd.load_scene("two_mass_cubic").build(), A, "m1", two_mass_ode(0), reference,
                           KERSCHEN_TARGET)


def case_rod(S):
    from scipy.special import ellipk

    A = [1.0, 2.5]
    w0 = vd.load_scene("rod_pivot").references["omega"][0]
    exact = np.array([math.pi * w0 / (2 * float(ellipk(math.sin(a / 2) ** 2))) for a in A])
    return backbone_target(S, "backbone of the rod pendulum (A = 1, 2.5 rad)", vd.load_scene("rod_pivot").build(),
                           A, "rod", pendulum_ode(), exact, ROD_TARGET)


def case_ball(S):
    system = ball_point_spring()

    def vib():
        return vd.backbone(system, 0, amplitudes=[1.0])

    bb, stats, _ = breakdown(vib)
    best, _ = interleaved({"vibdyn": vib}, 2 if S.full else 1)
    v_stage, p_stage = stage_cost(system)
    run = C.run_record("vibdyn backbone, one request (1 rad)", "vibdyn", None, float(bb.error.max()),
                       best["vibdyn"], verdict_=C.UNCHECKED, method="continuation + shooting", points=bb.points,
                       omega=float(bb.omega[0]), where_the_time_goes=table(stats, sum(s[3] for s in stats.values())),
                       stage_us={"variational": round(v_stage, 1), "plain": round(p_stage, 1)},
                       note="no independent reference: the time is the target")
    return C.case_record("target: one backbone request on a ball pendulum with a point spring", "speed",
                         "none (time target)", [run], unit="rad/s", target=f"≤ {BALL_TARGET_S:g} s")


def cases(S):
    """The three targets (not in the smoke run: ~30 s together)."""
    return [] if S.smoke else [case_kerschen(S), case_rod(S), case_ball(S)]
