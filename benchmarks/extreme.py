"""Stiff and extreme cases: each vibdyn run must end "right" (error within its estimate) or "refused
loudly" (a clear vibdyn error); "silently wrong" is the failure this module exists to catch.

- linearisation extremes: bench_linearize's section 4 (stiffness ratio 1e8, tiny masses, high spin, a
  stretched singular arm), FD and analytic, exact references where marked;
- the light cart-pole: cart 1e-6 kg on a slider, massless 1 m pole on a pivot, 1 kg tip, released at
  θ0 = 1 rad, 10 s. Horizontal momentum is conserved, which reduces the motion to one quadrature:
  θ̇² = 2g (cos θ − cos θ0)(1 + ε)/(sin² θ + ε), ε = m_cart/m_tip; as the tip passes the bottom the cart
  whips across at ~3000 rad/s of pole rate. Reference: that quadrature (scipy.integrate.quad, endpoint
  singularity by an algebraic weight) inverted by Brent's method. scipy's solvers at their default
  tolerances on the same equations are shown beside (they report success);
- a stiff flyball-governor-like case: a spinning rotor carrying a hanging arm, tied to a sleeve on the
  rotor's axis by a spring K = 8e5 N/m and damper C = 4e4 N·s/m, 0.2 s. Reference: scipy Radau at
  rtol = atol = 1e-12 on vibdyn's accelerations;
- a helical joint of tiny pitch (1e-9 m/rad) with a torsion spring: exact harmonic motion about
  θ_eq = −m g p / k, ω² = k / (I + m p²); simulation (10 s) and modes;
- a ball joint driven through large rotations: a torque-free axisymmetric body spinning at 20 rad/s and
  tumbling at 5 rad/s for 10 s (hundreds of rad: the integrators' charts re-centre all along). Exact:
  R(t) = exp(t [L/I₁]) R₀ exp(t λ [e₃]), λ = ω₃ (1 − I₃/I₁); error = |log(R_refᵀ R)| (rad). MuJoCo RK4 beside.
"""

import math
import time

import numpy as np
import pinocchio as pin
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

import vibdyn as vd

from . import common as C
from .bench_linearize import bench_extreme

SCIPY_DEFAULT = ("RK45", "DOP853", "Radau", "BDF", "LSODA")


def guarded(label, fn, error_of, estimate_of, evals_of, S, repeat=1, reference_error=0.0, **extra):
    """One vibdyn run: right / silently wrong from its error and estimate, or refused loudly."""
    t = time.perf_counter()
    try:
        out, wall, peak = C.measure(fn, repeat)
    except Exception as e:  # noqa: BLE001 — a raw exception is recorded as "crashed", never hidden
        return C.refused(label, "vibdyn", e, time.perf_counter() - t, **extra)
    return C.run_record(label, "vibdyn", error_of(out), estimate_of(out), wall, evals_of(out), peak,
                        reference_error=reference_error, **extra)


def sim_run(system, label, T, q0, v0, error_of, S, repeat=1, reference_error=0.0, **kw):
    return guarded(label, lambda: system.simulate(T, q0, v0, t_eval=[T], progress=False, **kw),
                   lambda tr: error_of(tr.q[-1]), lambda tr: tr.error, lambda tr: tr.nfev + tr.error_nfev, S,
                   repeat, reference_error, options=dict(kw), method=kw.get("method", "dop853"))


def scipy_runs(system, T, q0, v0, error_of, methods, **kw):
    """scipy.solve_ivp on vibdyn's accelerations (nq = nv): context runs, no estimate."""
    n = system.nv
    runs = []

    def f(t, x):
        return np.concatenate([x[n:], system.accelerations(x[:n], x[n:], t)])

    for m in methods:
        label = f"scipy {m} " + (" ".join(f"{k}={v:g}" for k, v in kw.items()) or "defaults")
        t = time.perf_counter()
        try:
            sol = solve_ivp(f, (0.0, T), np.concatenate([q0, v0]), method=m, t_eval=[T], **kw)
        except vd.VibdynError as e:  # scipy fed vibdyn a non-finite state
            runs.append(C.run_record(label, "scipy", None, None, time.perf_counter() - t, verdict_=C.UNCHECKED,
                                     note=f"stopped: {type(e).__name__}: {e}"))
            continue
        wall = time.perf_counter() - t
        ok = sol.success and sol.y.shape[1] == 1
        runs.append(C.run_record(label, "scipy", error_of(sol.y[:n, -1]) if ok else None, None, wall, sol.nfev,
                                 note=f"scipy status: {'success' if sol.success else sol.message}"))
    return runs


# ------------------------------------------------------------------------------------------- linearisation
def linearization_extremes(S):
    """bench_linearize's section 4, as case records (one run per path)."""
    rows = bench_extreme(1 if S.quick else 3, 4096)
    cases = []
    for r in rows:
        outcome = r["outcome"]
        runs = []
        if "fd" in r:
            for method in ("fd", "analytic"):
                o = r[method]
                v = C.RIGHT if outcome == "right" else C.WRONG
                runs.append(C.run_record(f"vibdyn {method}", "vibdyn", o["actual"], o["estimate"], o["time_s"],
                                         verdict_=v, method=method, note=f"reference: {r['reference']}"))
        else:
            v = C.REFUSED if outcome.startswith("clear error") else C.WRONG
            runs.append(C.run_record("vibdyn steady_motion", "vibdyn", None, None, r["total_s"], verdict_=v,
                                     message=outcome))
        cases.append(C.case_record(r["case"], "extreme", r["note"], runs, expected="right or refused loudly"))
    return cases


# ------------------------------------------------------------------------------------------- cart-pole
EPS, TH0, T_CP = 1e-6, 1.0, 10.0


def cartpole():
    s = vd.Scene("light cart-pole", gravity=(0, 0, -C.G))
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=EPS)
    s.add_body("pole", "cart", vd.Pivot((0, 1, 0)), mass=1.0, com=(0, 0, -1.0))
    return s


def cartpole_exact(t):
    """(x_cart, θ) at time t from the momentum-conserving quadrature (see the module docstring)."""
    def dt_dth(u):  # dt/dθ, times sqrt(θ0 − u) (the weight takes the endpoint singularity)
        num = (math.sin(u) ** 2 + EPS) / ((1 + EPS) * 2 * C.G)
        den = (math.cos(u) - math.cos(TH0)) / (TH0 - u) if u < TH0 else math.sin(TH0)
        return math.sqrt(num / den)

    def t_of(th):  # time from TH0 down to th ∈ [0, TH0]
        return quad(dt_dth, th, TH0, weight="alg", wvar=(0, -0.5), limit=200, epsabs=1e-15, epsrel=1e-14)[0]

    quarter = t_of(0.0)
    tau = t % (4 * quarter)
    leg, s = divmod(tau, quarter)
    back = [s, quarter - s, s, quarter - s][int(leg)]  # time from TH0 along this quarter
    sign = [1, -1, -1, 1][int(leg)]
    th = sign * (brentq(lambda x: t_of(x) - back, 0.0, TH0, xtol=1e-15, rtol=1e-15) if back > 0 else TH0)
    # horizontal momentum (1 + ε) ẋ_c − cos θ θ̇ = 0 (the tip is at x_c − sin θ for this pivot), from rest
    x = (math.sin(th) - math.sin(TH0)) / (1 + EPS)
    return np.array([x, th])


def case_cartpole(S):
    system = cartpole().build()
    q0, v0 = np.array([0.0, TH0]), np.zeros(2)
    ref = cartpole_exact(T_CP)

    def err(q):
        return float(np.abs(np.asarray(q) - ref).max())

    a0 = system.accelerations(q0, v0)
    assert a0[1] < 0, "the pole must fall towards θ = 0 (pivot sign)"
    runs = [sim_run(system, "vibdyn dop853 rtol=1e-8 (defaults)", T_CP, q0, v0, err, S),
            sim_run(system, "vibdyn rk4 dt=1e-4", T_CP, q0, v0, err, S, method="rk4", dt=1e-4)]
    if not S.smoke:
        runs += [sim_run(system, "vibdyn dop853 rtol=1e-10", T_CP, q0, v0, err, S, rtol=1e-10),
                 sim_run(system, "vibdyn dop853 rtol=1e-12", T_CP, q0, v0, err, S, rtol=1e-12),
                 sim_run(system, "vibdyn symplectic dt=1e-4", T_CP, q0, v0, err, S, method="symplectic", dt=1e-4)]
    if S.full:
        runs += [sim_run(system, "vibdyn radau rtol=1e-8", T_CP, q0, v0, err, S, method="radau"),
                 sim_run(system, "vibdyn bdf rtol=1e-8", T_CP, q0, v0, err, S, method="bdf")]
    runs += scipy_runs(system, T_CP, q0, v0, err, SCIPY_DEFAULT if S.full else ("RK45", "DOP853", "LSODA")
                       if S.quick else ("RK45",))
    return C.case_record("light cart-pole (cart 1e-6 kg, 10 s)", "extreme",
                         "momentum-conserving quadrature (exact to ~1e-13)", runs, unit="m or rad",
                         reference_state=ref.tolist())


# ------------------------------------------------------------------------------------------- flyball
K_FLY, C_FLY, T_FLY = 8e5, 4e4, 0.2


def flyball():
    s = vd.Scene("flyball-like", gravity=(0, 0, -C.G))
    s.add_body("rotor", joint=vd.Pivot((0, 0, 1)), mass=2.0, inertia=np.diag([0.02, 0.02, 0.01]))
    s.add_body("arm", "rotor", vd.Pivot((0, 1, 0), at=(0.05, 0, 0)), mass=1.0, com=(0, 0, -0.3),
               inertia=vd.inertia.rod(1.0, 0.3, axis=(0, 0, 1)) + 1e-4 * np.eye(3))
    s.add_body("sleeve", "rotor", vd.Slider((0, 0, 1), at=(0, 0, -0.3)), mass=0.5,
               inertia=np.diag([1e-3, 1e-3, 1e-3]))
    s.add_spring("link", ("arm", (0, 0, -0.2)), ("sleeve", (0, 0, 0)), stiffness=K_FLY)
    s.add_damper("link_damper", ("arm", (0, 0, -0.2)), ("sleeve", (0, 0, 0)), damping=C_FLY)
    return s


def case_flyball(S):
    system = flyball().build()
    q0 = system.integrate(system.neutral(), np.array([0.0, 0.3, 0.0]))
    v0 = np.array([10.0, 0.0, 0.0])
    n = system.nv

    def f(t, x):
        return np.concatenate([x[n:], system.accelerations(x[:n], x[n:], t)])

    def reference(tol):
        return solve_ivp(f, (0, T_FLY), np.concatenate([q0, v0]), method="Radau", rtol=tol, atol=tol,
                         t_eval=[T_FLY]).y[:n, -1]

    ref = reference(1e-12)
    # the reference's own uncertainty: its distance to the same at tolerance 1e-11 (a bound, the 1e-12 run
    # being the more accurate), so that errors at its level are not blamed on vibdyn's estimate
    ref_err = float(np.abs(system.difference(ref, reference(1e-11))).max())

    def err(q):
        return float(np.abs(system.difference(ref, q)).max())

    runs = [sim_run(system, "vibdyn radau rtol=1e-6", T_FLY, q0, v0, err, S, reference_error=ref_err,
                    method="radau", rtol=1e-6),
            sim_run(system, "vibdyn bdf rtol=1e-6", T_FLY, q0, v0, err, S, reference_error=ref_err, method="bdf",
                    rtol=1e-6)]
    if S.full:
        runs += [sim_run(system, "vibdyn radau rtol=1e-9", T_FLY, q0, v0, err, S, reference_error=ref_err,
                         method="radau", rtol=1e-9),
                 sim_run(system, "vibdyn dop853 rtol=1e-8 (defaults)", T_FLY, q0, v0, err, S,
                         reference_error=ref_err)]
    return C.case_record("stiff flyball-like (K = 8e5 N/m, C = 4e4 N·s/m, 0.2 s)", "extreme",
                         f"scipy Radau rtol 1e-12 (its own uncertainty {ref_err:.1e}, from a run at 1e-11, is counted "
                         "in the verdicts)", runs, unit="rad or m", reference_error=ref_err)


# ------------------------------------------------------------------------------------------- helical
P_HEL, K_HEL, I_HEL, M_HEL, T_HEL = 1e-9, 3.0, 0.3, 2.0, 10.0


def case_helical(S):
    s = vd.Scene("tiny-pitch screw", gravity=(0, 0, -C.G))
    s.add_body("screw", joint=vd.Helical((0, 0, 1), P_HEL), mass=M_HEL, inertia=np.diag([0.2, 0.2, I_HEL]))
    s.add_joint_spring("screw", K_HEL)
    system = s.build()
    J = I_HEL + M_HEL * P_HEL**2
    w = math.sqrt(K_HEL / J)
    th_eq = -M_HEL * C.G * P_HEL / K_HEL
    q0 = np.array([0.5])

    def err(q):
        return abs(float(q[0]) - (th_eq + (0.5 - th_eq) * math.cos(w * T_HEL)))

    runs = [sim_run(system, "vibdyn dop853 rtol=1e-8", T_HEL, q0, np.zeros(1), err, S, repeat=S.repeat),
            sim_run(system, "vibdyn dop853 rtol=1e-11", T_HEL, q0, np.zeros(1), err, S, rtol=1e-11)]
    for method in ("fd", "analytic"):
        runs.append(guarded(f"vibdyn linearize {method} + modes", lambda: _modes_at_eq(system, method),
                            lambda m: abs(m.omega[0] - w) / w, lambda m: m.relative_error, lambda m: None, S, S.repeat,
                            method=method))
    return C.case_record("helical joint, pitch 1e-9 m/rad", "extreme",
                         "exact: harmonic about θ_eq = −m g p/k, ω² = k/(I + m p²)", runs, unit="rad (ω: relative)")


def _modes_at_eq(system, method):
    return system.equilibrium().linearize(method=method).modes()


# ------------------------------------------------------------------------------------------- ball, large rotations
I1, I3, W0, T_TOP = 0.2, 0.05, np.array([5.0, 0.0, 20.0]), 10.0


def top():
    s = vd.Scene("free top", gravity=(0, 0, 0))
    s.add_body("top", joint=vd.Ball(), mass=1.0, inertia=np.diag([I1, I1, I3]))
    return s


def top_exact(R0, w0, t):
    L = R0 @ (np.array([I1, I1, I3]) * w0)
    lam = w0[2] * (1 - I3 / I1)
    return pin.exp3(L / I1 * t) @ R0 @ pin.exp3(np.array([0, 0, lam * t]))


def case_ball(S):
    scene = top()
    system = scene.build()
    q0 = system.integrate(system.neutral(), np.array([0.3, -0.2, 0.1]))
    R0 = pin.Quaternion(q0[3], *q0[:3]).matrix()
    R_ref = top_exact(R0, W0, T_TOP)

    def err(q):
        R = pin.Quaternion(q[3], *q[:3]).matrix()
        return float(np.linalg.norm(pin.log3(R_ref.T @ R)))

    runs = [sim_run(system, f"vibdyn dop853 rtol={r:g}", T_TOP, q0, W0, err, S, repeat=S.repeat, rtol=r)
            for r in ((1e-8,) if S.smoke else (1e-6, 1e-8, 1e-10))]
    if not S.smoke:
        runs += [sim_run(system, "vibdyn rk4 dt=1e-3", T_TOP, q0, W0, err, S, method="rk4", dt=1e-3)]
    if S.full:
        runs += [sim_run(system, "vibdyn symplectic dt=1e-3", T_TOP, q0, W0, err, S, method="symplectic", dt=1e-3)]
    if C.mujoco() is not None:
        from .simulation import mujoco_runs

        scene_mj = C.with_min_inertia(scene)
        runs += mujoco_runs(lambda i, dt: C.MuJoCoSim(scene_mj, system, i, dt), q0, W0, T_TOP, err,
                            [("RK4", 1e-3)] if S.smoke else [("RK4", d) for d in (1e-2, 1e-3, 1e-4)], S)
    return C.case_record("ball joint, large rotations (torque-free top, 10 s)", "extreme",
                         "exact (axisymmetric torque-free motion)", runs, unit="rad")


def run(S):
    cases = [case_cartpole(S), case_helical(S), case_ball(S)]
    if not S.smoke:
        cases = linearization_extremes(S) + cases + [case_flyball(S)]
    return cases
