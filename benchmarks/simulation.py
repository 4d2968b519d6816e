"""Time integration: error against run time, vibdyn's methods beside MuJoCo's RK4 and implicitfast.

Cases (error: largest tangent-space difference of the final configuration from the reference, rad or m):

- IFToMM A01 over 10 s: exact elliptic solution (reference case R7); the error is the mass position (m).
- double pendulum (models/double_pendulum.toml), 5 s from (1.0, 0.5) rad at rest;
- 10-link pendulum chain (benchmarks/bench_linearize.py's chain with links of 0.3 m and 1 kg, torsion
  springs 10 N·m/rad: gravity-dominated), 2 s from a random tilt (std 0.3 rad);
- 10-link chain of rods on ball joints (benchmarks/bench_simulate.py's chain), 1 s from a random tilt;
- the rotor with the sprung slider (models/rotor_slider.toml), 5 s of spin-up from rest. MuJoCo has no
  actuator for the motor law 10 − ω² (quadratic in the speed), so this case has no MuJoCo runs.
- IFToMM A03, Andrew's squeezer (models/andrews_squeezer.toml, closed loops), 0.03 s: the seven angles
  against the CWI test set's reference solution; Radau and BDF beside DOP853 (no MuJoCo runs).
- IFToMM A02, the N-four-bar (models/iftomm_a02.toml, N = 4, four loops), 10 s through ten singular positions
  where the mobility jumps from 1 to 5: the position of B0 (m) against the exact parallelogram motion (one
  angle, integrated by scipy's DOP853 at rtol 1e-13); DOP853 and RK4 (no MuJoCo runs).
- IFToMM A04, Bricard's mechanism (models/iftomm_a04.toml, Grübler count 0, mobility 1), 10 s from rest: P3
  (m) against vibdyn's DOP853 at rtol 1e-12, checked against the mechanism cut at C; MuJoCo's RK4 beside,
  the loop closed by two soft ``connect`` equality constraints.
- IFToMM A05, the stiff flyball governor (models/iftomm_a05.toml), 10 s: the sleeve height against MuJoCo's
  RK4 at dt 2.5e-5 (the spring-dampers as tendons), checked against vibdyn's Radau at rtol 1e-11; Radau, BDF
  and DOP853 beside MuJoCo's RK4 and implicitfast.

References: the exact solution (A01); scipy's DOP853 at rtol = atol = 1e-13 on vibdyn's accelerations for
the chains of pivots (an independent integrator; the model itself is checked against MuJoCo by the test
suite); MuJoCo's RK4 at dt = 1e-5 for the ball chain (quaternions: scipy cannot integrate it as a vector),
checked against vibdyn's DOP853 at rtol 1e-11 (``reference_check``).
"""

import math

import numpy as np
from scipy.integrate import solve_ivp

import vibdyn as vd

from . import common as C
from .bench_linearize import pendulum_chain
from .bench_simulate import MJCF as A01_MJCF
from .bench_simulate import a01_error, ball_chain_scene

TARGET = 1e-8  # the equal-error comparison point with MuJoCo


def scipy_reference(system, q0, v0, t_end, rtol=1e-13):
    """Final (q, v) by scipy's DOP853 at rtol = atol = ``rtol`` on vibdyn's accelerations (nq = nv only)."""
    n = system.nv

    def f(t, x):
        return np.concatenate([x[n:], system.accelerations(x[:n], x[n:], t)])

    sol = solve_ivp(f, (0.0, t_end), np.concatenate([q0, v0]), method="DOP853", rtol=rtol, atol=rtol,
                    t_eval=[t_end])
    assert sol.success, sol.message
    return sol.y[:n, -1], sol.y[n:, -1]


def vibdyn_runs(system, q0, v0, t_end, error_of, settings, S):
    """vibdyn's runs: (method, kwargs) in ``settings``; error_of(q_final) → actual error."""
    runs = []
    for method, kw in settings:
        label = f"vibdyn {method} " + " ".join(f"{k}={v}" if isinstance(v, str) else f"{k}={v:g}"
                                               for k, v in kw.items())
        fn = lambda: system.simulate(t_end, q0, v0, method=method, t_eval=[t_end], progress=False, **kw)  # noqa: E731
        try:
            slow = method in ("radau", "bdf", "symplectic")
            tr, wall, peak = C.measure(fn, 1 if slow else S.repeat)
        except vd.VibdynError as e:
            runs.append(C.refused(label, "vibdyn", e, math.nan, method=method, **kw))
            continue
        runs.append(C.run_record(label, "vibdyn", error_of(tr.q[-1]), tr.error, wall, tr.nfev + tr.error_nfev,
                                 peak, method=method, steps=tr.accepted, error_method=tr.error_method,
                                 solution_time_s=solution_time(tr, wall),
                                 **{k: v for k, v in kw.items() if k != "error"}))
    return runs


def solution_time(tr, wall):
    """The part of a measured wall time that went to the motion itself (not to its error estimate's second
    run): what MuJoCo, which gives no estimate, is compared with."""
    return wall * (1.0 - tr.error_elapsed / tr.elapsed) if tr.elapsed > 0 else wall


def mujoco_runs(make, q0, v0, t_end, error_of, settings, S):
    """MuJoCo's runs: (integrator, dt) in ``settings``; make(integrator, dt) → MuJoCoSim."""
    runs = []
    for integrator, dt in settings:
        n = int(round(t_end / dt))
        sim = make(integrator, t_end / n)
        (q, v), wall, peak = C.measure(lambda: sim.run(q0, v0, n), S.repeat)
        err = error_of(q) if np.all(np.isfinite(q)) else None
        runs.append(C.run_record(f"mujoco {integrator} dt={t_end / n:.3g}", "mujoco", err, None, wall,
                                 4 * n if integrator == "RK4" else n, peak, method=integrator,
                                 dt=t_end / n, **({} if err is not None else {"note": "diverged"})))
    return runs


def equal_error_ratios(case):
    """vibdyn DOP853 time / MuJoCo RK4 time at equal error (interpolated along each one's curve): per vibdyn
    run, and at TARGET. The ratio compares the motions alone (MuJoCo gives no error estimate);
    ``ratio_with_estimate`` counts vibdyn's default global error estimate too."""
    mj = [r for r in case["runs"] if r["solver"] == "mujoco" and r.get("method") == "RK4" and r["error"]]
    dop = [r for r in case["runs"] if r.get("method") == "dop853" and r["error"]]
    for r in case["runs"]:
        if r["solver"] == "vibdyn" and r["error"]:
            t = C.time_at_error(mj, r["error"])
            r["mujoco_rk4_time_at_equal_error"] = t
            r["ratio_to_mujoco_rk4"] = None if t is None else r.get("solution_time_s", r["time_s"]) / t
            r["ratio_with_estimate"] = None if t is None else r["time_s"] / t
    t_sol, t_all = C.time_at_error(dop, TARGET, "solution_time_s"), C.time_at_error(dop, TARGET)
    t_mj = C.time_at_error(mj, TARGET)
    # what a MuJoCo user pays to know the error too: Richardson's two runs, at dt (error ≈ 2⁴·TARGET for RK4)
    # and at dt/2 (error TARGET), read off the same curve
    t_mj2 = C.time_at_error(mj, 16 * TARGET)
    t_rich = None if t_mj is None or t_mj2 is None else t_mj + t_mj2
    case["equal_error"] = {"error": TARGET, "vibdyn_dop853_s": t_sol, "vibdyn_dop853_with_estimate_s": t_all,
                           "mujoco_rk4_s": t_mj, "mujoco_rk4_with_richardson_s": t_rich,
                           "ratio": None if t_sol is None or t_mj is None else t_sol / t_mj,
                           "ratio_with_estimate": None if t_all is None or t_mj is None else t_all / t_mj,
                           "ratio_estimates": None if t_all is None or t_rich is None else t_all / t_rich,
                           "estimate_cost": None if t_all is None or t_sol is None else t_all / t_sol - 1.0,
                           "targets": "ratio ≤ 0.7 (motions alone); ratio_estimates ≤ 1 (vibdyn with its global "
                                      "estimate against MuJoCo RK4 with Richardson's)"}
    return case


def _settings(S, full, quick, smoke):
    return smoke if S.smoke else quick if S.quick else full


# ------------------------------------------------------------------------------------------- cases
def case_a01(S):
    system = vd.load_scene(C.ROOT / "models" / "iftomm_a01.toml").build()
    q0, v0, T = system.neutral(), np.zeros(1), 10.0

    def err(q):
        return a01_error(float(q[0]), T)

    vd_set = _settings(S, [("dop853", {"rtol": r}) for r in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-12)]
                       + [("rk4", {"dt": d}) for d in (1e-2, 3e-3, 1e-3)] + [("radau", {"rtol": 1e-9}),
                                                                            ("symplectic", {"dt": 1e-3})],
                       [("dop853", {"rtol": r}) for r in (1e-6, 1e-8, 1e-10, 1e-12)] + [("rk4", {"dt": 3e-3})],
                       [("dop853", {"rtol": 1e-8}), ("rk4", {"dt": 3e-3})])
    runs = vibdyn_runs(system, q0, v0, T, err, vd_set, S)
    mj = C.mujoco()
    if mj is not None:
        def make(integrator, dt):
            sim = _A01Sim(mj, integrator, dt)
            return sim

        # (RK4 from dt 2e-2: its error there passes 16 × 1e-8, where a Richardson estimate's coarse run sits)
        mj_set = _settings(S, [("RK4", d) for d in (2e-2, 1e-2, 5e-3, 3e-3, 2e-3, 1e-3, 5e-4)]
                           + [("implicitfast", d) for d in (1e-3, 1e-4, 1e-5)],
                           [("RK4", d) for d in (2e-2, 1e-2, 3e-3, 1e-3, 5e-4)]
                           + [("implicitfast", d) for d in (1e-3, 1e-4)],
                           [("RK4", d) for d in (3e-3, 1e-3)])
        runs += mujoco_runs(make, q0, v0, T, err, mj_set, S)
    return equal_error_ratios(C.case_record("A01 pendulum (10 s)", "simulation", "exact (elliptic functions, R7)",
                                            runs, unit="m"))


class _A01Sim:
    """A01 in MuJoCo: bench_simulate's model (1 kg at 1 m, inertia 1e-12), hinge angle = vibdyn's θ."""

    def __init__(self, mj, integrator, dt):
        self.mj = mj
        self.model = mj.MjModel.from_xml_string(A01_MJCF.format(dt=dt).replace('integrator="RK4"',
                                                                               f'integrator="{integrator}"'))
        self.data = mj.MjData(self.model)

    def run(self, q0, v0, n):
        self.mj.mj_resetData(self.model, self.data)
        self.mj.mj_step(self.model, self.data, nstep=n)
        return self.data.qpos.copy(), self.data.qvel.copy()


def chain_case(name, scene, q0, T, reference, vd_set, mj_set, S, ref_kind):
    system = scene.build()
    v0 = np.zeros(system.nv)
    q_ref = reference(system, q0, v0, T)

    def err(q):
        return float(np.abs(system.difference(q_ref, q)).max())

    runs = vibdyn_runs(system, q0, v0, T, err, vd_set, S)
    if C.mujoco() is not None and mj_set:
        runs += mujoco_runs(lambda i, dt: C.MuJoCoSim(scene, system, i, dt), q0, v0, T, err, mj_set, S)
    return equal_error_ratios(C.case_record(name, "simulation", ref_kind, runs, unit="rad"))


def _chain_settings(S, slow=False):
    vd_set = _settings(S, [("dop853", {"rtol": r}) for r in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-12)]
                       + [("rk4", {"dt": d}) for d in (3e-3, 1e-3, 3e-4)] + [("radau", {"rtol": 1e-8})],
                       [("dop853", {"rtol": r}) for r in (1e-6, 1e-8, 1e-10)] + [("rk4", {"dt": 1e-3})],
                       [("dop853", {"rtol": 1e-8})])
    mj_set = _settings(S, [("RK4", d) for d in (1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5)]
                       + [("implicitfast", d) for d in (1e-3, 1e-4, 1e-5)],
                       [("RK4", d) for d in (1e-2, 3e-3, 1e-3, 3e-4, 1e-4)]
                       + [("implicitfast", d) for d in (1e-3, 1e-4)],
                       [("RK4", 1e-3)])
    return vd_set, mj_set


def case_double_pendulum(S):
    scene = C.with_min_inertia(vd.load_scene(C.ROOT / "models" / "double_pendulum.toml"))
    vd_set, mj_set = _chain_settings(S)
    return chain_case("double pendulum (5 s)", scene, np.array([1.0, 0.5]), 5.0, lambda s, q, v, T:
                      scipy_reference(s, q, v, T)[0], vd_set, mj_set, S, "scipy DOP853 rtol 1e-13")


def case_pivot_chain(S):
    scene = pendulum_chain(10, k=10.0, L=0.3, m=1.0)  # gravity-dominated: its motion is not chaotic over 2 s
    system = scene.build()
    q0 = system.random_configuration(0.3, 1)
    vd_set, mj_set = _chain_settings(S)
    return chain_case("10-link pendulum chain (2 s)", scene, q0, 2.0, lambda s, q, v, T: scipy_reference(s, q, v, T)[0],
                      vd_set, mj_set, S, "scipy DOP853 rtol 1e-13")


def case_ball_chain(S):
    scene = ball_chain_scene(10)
    system = scene.build()
    q0 = system.random_configuration(0.3, 1)
    T, v0 = 1.0, np.zeros(system.nv)
    # reference: MuJoCo's RK4 at dt = 1e-5 (another engine and integrator; its error ≈ 3e-13 by the RK4 runs'
    # convergence), checked against vibdyn's DOP853 at rtol 1e-11. Not vibdyn at rtol 1e-13: measured here,
    # that run is 7e-10 off both, with an estimate of 1e-12 (it is one of the runs below).
    own = system.simulate(T, q0, v0, rtol=1e-11, t_eval=[T], progress=False).q[-1]
    if C.mujoco() is not None:
        q_ref = C.MuJoCoSim(scene, system, "RK4", 1e-5).run(q0, v0, 100_000)[0]
        kind = "MuJoCo RK4 dt 1e-5 (checked against vibdyn DOP853 rtol 1e-11)"
    else:
        q_ref, kind = own, "vibdyn DOP853 rtol 1e-11 (MuJoCo not installed)"
    check = float(np.abs(system.difference(q_ref, own)).max())
    vd_set, mj_set = _chain_settings(S)
    if S.full:
        vd_set = vd_set + [("dop853", {"rtol": 1e-13})]
    case = chain_case("10-link ball-joint chain (1 s)", scene, q0, T, lambda s, q, v, T_: q_ref, vd_set, mj_set, S,
                      kind)
    case["reference_check"] = check
    case["note"] = f"Reference and its check differ by {check:.1e} rad."
    return case


def case_rotor(S):
    scene = vd.load_scene(C.ROOT / "models" / "rotor_slider.toml")
    vd_set, _ = _chain_settings(S)
    return chain_case("rotor with sprung slider (5 s spin-up)", scene, scene.build().neutral(), 5.0,
                      lambda s, q, v, T: scipy_reference(s, q, v, T)[0], vd_set, [], S,
                      "scipy DOP853 rtol 1e-13 (no MuJoCo: motor law 10 − ω² has no MuJoCo actuator)")


def case_a03(S):
    """IFToMM A03, Andrew's squeezer (models/andrews_squeezer.toml: three loops at E, 1 dof): 0.03 s from
    rest; error: largest difference of the seven angles from the CWI test set's reference (rad). Stiff
    methods (Radau, BDF) beside DOP853; the loops are closed by projection after each DOP853 step. DOP853's
    error is estimated by a rerun: its sum of local errors ("local") underestimates this fast motion (2.5
    turns of the crank in 0.03 s) by 2 to 6 times. The reference itself is about 1e-9 rad off on beta
    (independent runs at rtol 1e-12 agree with each other to 1e-11 and with it to 1.1e-9, ~1e-10 relative):
    runs tighter than rtol 1e-6 cannot be judged against it."""
    scene = vd.load_scene(C.ROOT / "models" / "andrews_squeezer.toml")
    system, ref = scene.build(), scene.references

    def err(q):
        dq = system.difference(system.neutral(), q)
        return max(abs(ref["initial"][a] + dq[system.coordinate_index(b)] - ref[a]) for a, b in ref["bodies"].items())

    settings = _settings(S, [("radau", {"rtol": r}) for r in (1e-5, 1e-7)] + [("bdf", {"rtol": 1e-6})]
                         + [("dop853", {"rtol": r, "error": "rerun"}) for r in (1e-5, 1e-6)],
                         [("radau", {"rtol": 1e-6})]
                         + [("dop853", {"rtol": r, "error": "rerun"}) for r in (1e-5, 1e-6)],
                         [("dop853", {"rtol": 1e-6, "error": "rerun"})])
    runs = vibdyn_runs(system, system.neutral(), np.zeros(system.nv), ref["t"], err, settings, S)
    return C.case_record("IFToMM A03 Andrew's squeezer (0.03 s)", "simulation", "CWI test set reference solution", runs,
                         "rad")


def case_a02(S):
    """IFToMM A02, the N-four-bar (models/iftomm_a02.toml): from the neutral configuration with ẋ(B0) = 1 m/s,
    10 s; error: distance of B0 from the exact parallelogram motion at the end (m), its one angle φ from
    ((N+1)/3 + N) φ̈ = −g ((N+1)/2 + N) cos φ (the model's reference note)."""
    scene = vd.load_scene(C.ROOT / "models" / "iftomm_a02.toml")
    system, ref = scene.build(), scene.references
    n, T = ref["N"], ref["t_end"]
    mass, weight = (n + 1) / 3 + n, C.G * ((n + 1) / 2 + n)
    exact = solve_ivp(lambda _, y: [y[1], -weight * math.cos(y[0]) / mass], (0.0, T), [math.pi / 2, ref["v0_crank"]],
                      method="DOP853", rtol=1e-13, atol=1e-14).y[0, -1]
    v0 = np.array([ref["v0_crank"] if c.startswith("crank") else ref["v0_coupler"] for c in system.coordinates])

    def err(q):
        b0 = system.point_position("crank0", (1.0, 0.0, 0.0), q)
        return float(math.hypot(b0[0] - math.cos(exact), b0[1] - math.sin(exact)))

    settings = _settings(S, [("dop853", {"rtol": r}) for r in (1e-6, 1e-7, 1e-8)] + [("rk4", {"dt": 4e-3})],
                         [("dop853", {"rtol": 1e-8})], [])
    runs = vibdyn_runs(system, system.neutral(), v0, T, err, settings, S)
    return C.case_record("IFToMM A02 N-four-bar, N = 4 (10 s, 10 singular positions)", "simulation",
                         "exact parallelogram motion (scipy DOP853 rtol 1e-13 on its one angle)", runs, "m")


class _A04Sim(C.MuJoCoSim):
    """A04 in MuJoCo: the same tree, its loop F closed by two ``connect`` equality constraints on the x axis
    through F (a revolute closure), made as stiff as the step allows (solref time constant 2 dt, critically
    damped): MuJoCo's constraints are soft, so its error is bounded below by their compliance."""

    def __init__(self, scene, system, integrator, dt):
        super().__init__(scene, system, integrator, dt)
        eq = (f'  <equality>\n    <connect body1="rod5" anchor="0 1 0" solref="{2 * dt!r} 1"/>\n'
              f'    <connect body1="rod5" anchor="0.5 1 0" solref="{2 * dt!r} 1"/>\n  </equality>\n</mujoco>')
        xml = self.oracle.xml.replace('integrator="RK4"', f'integrator="{integrator}" timestep="{dt!r}"')
        self.model = self.mj.MjModel.from_xml_string(xml.replace("</mujoco>", eq))
        self.oracle.model, self.oracle.data = self.model, self.mj.MjData(self.model)
        self.data = self.oracle.data


def case_a04(S):
    """IFToMM A04, Bricard's mechanism (models/iftomm_a04.toml: Grübler count 0, mobility 1), 10 s from rest:
    error: distance of P3 (the C joint) at the end from the reference (m). Reference: vibdyn DOP853 at rtol
    1e-12, checked against the same mechanism cut at C (another tree and loop) at the same tolerance
    (``reference_check``). MuJoCo's RK4 beside, the loop closed by two soft ``connect`` constraints."""
    scene = vd.load_scene(C.ROOT / "models" / "iftomm_a04.toml")
    system, ref = scene.build(), scene.references
    T = ref["t_end"]
    q0, v0 = system.neutral(), np.zeros(system.nv)
    q_ref = system.simulate(T, q0, v0, rtol=1e-12, t_eval=[T], progress=False).q[-1]
    p_ref = system.point_position("rod3", (0, 0, 0), q_ref)
    other = C._oracles().bricard_cut_at_c(scene).build()
    q_other = other.simulate(T, other.assemble(other.neutral()), rtol=1e-12, t_eval=[T], progress=False).q[-1]
    check = float(np.linalg.norm(other.point_position("rod2", (0, -1, 0), q_other) - p_ref))

    def err(q):
        return float(np.linalg.norm(system.point_position("rod3", (0, 0, 0), q) - p_ref))

    settings = _settings(S, [("dop853", {"rtol": r}) for r in (1e-6, 1e-8, 1e-10)] + [("rk4", {"dt": d}) for d in
                                                                                      (4e-3, 1e-3)]
                         + [("radau", {"rtol": 1e-8})],
                         [("dop853", {"rtol": r}) for r in (1e-6, 1e-8)], [])
    runs = vibdyn_runs(system, q0, v0, T, err, settings, S)
    if C.mujoco() is not None:
        mj_set = _settings(S, [("RK4", d) for d in (1e-3, 3e-4, 1e-4)], [("RK4", d) for d in (1e-3, 1e-4)], [])
        runs += mujoco_runs(lambda i, dt: _A04Sim(scene, system, i, dt), q0, v0, T, err, mj_set, S)
    case = C.case_record("IFToMM A04 Bricard's mechanism (10 s, Grübler 0, mobility 1)", "simulation",
                         "vibdyn DOP853 rtol 1e-12, checked against the mechanism cut at C", runs, "m")
    case["reference_check"] = check
    case["note"] = f"Reference and its check (the mechanism cut at C) differ by {check:.1e} m."
    return case


class _A05Sim:
    """A05 in MuJoCo (tests/oracles.py: the spring-dampers as spatial tendons), qpos = vibdyn's q."""

    def __init__(self, integrator, dt):
        mj = C.mujoco()
        xml = C._oracles().a05_mjcf(dt).replace('integrator="RK4"', f'integrator="{integrator}"')
        self.mj, self.model = mj, mj.MjModel.from_xml_string(xml)
        self.data = mj.MjData(self.model)

    def run(self, q0, v0, n):
        self.mj.mj_resetData(self.model, self.data)
        self.data.qpos[:], self.data.qvel[:] = q0, v0
        self.mj.mj_step(self.model, self.data, nstep=n)
        return self.data.qpos.copy(), self.data.qvel.copy()


def case_a05(S):
    """IFToMM A05, the stiff flyball governor (models/iftomm_a05.toml; spring-dampers 8e5 N/m, 4e4 N·s/m),
    10 s from s = 0.5 m, β = 30°, co-rotating at 2π rad/s: error of the sleeve height s at the end (m).
    Reference: MuJoCo's RK4 at dt = 2.5e-5 s (its error, from the run at 5e-5, ~1e-14 m), checked against
    vibdyn's Radau at rtol 1e-11 (``reference_check``); without MuJoCo, that Radau run itself."""
    scene = vd.load_scene(C.ROOT / "models" / "iftomm_a05.toml")
    system, ref = scene.build(), scene.references
    T = ref["t_end"]
    q0 = system.configuration({"sleeve": ref["s0"], "rod1": ref["beta0"], "rod2": ref["beta0"]})
    v0 = np.array([ref["spin0"], 0.0, 0.0, 0.0])
    own = system.simulate(T, q0, v0, method="radau", rtol=1e-11, t_eval=[T], progress=False).q[-1][1]
    if C.mujoco() is not None:
        s_ref = float(_A05Sim("RK4", 2.5e-5).run(q0, v0, int(round(T / 2.5e-5)))[0][1])
        kind = "MuJoCo RK4 dt 2.5e-5 (checked against vibdyn Radau rtol 1e-11)"
    else:
        s_ref, kind = float(own), "vibdyn Radau rtol 1e-11 (MuJoCo not installed)"

    def err(q):
        return abs(float(q[1]) - s_ref)

    settings = _settings(S, [("radau", {"rtol": r}) for r in (1e-6, 1e-8, 1e-10)]
                         + [("bdf", {"rtol": r}) for r in (1e-6, 1e-8)] + [("dop853", {"rtol": 1e-6})],
                         [("radau", {"rtol": r}) for r in (1e-6, 1e-8)] + [("bdf", {"rtol": 1e-6})], [])
    runs = vibdyn_runs(system, q0, v0, T, err, settings, S)
    if C.mujoco() is not None:
        mj_set = _settings(S, [("RK4", d) for d in (2e-4, 1e-4, 5e-5)] + [("implicitfast", d) for d in (1e-3, 1e-4)],
                           [("RK4", 1e-4), ("implicitfast", 1e-4)], [])
        runs += mujoco_runs(lambda i, dt: _A05Sim(i, dt), q0, v0, T, err, mj_set, S)
    case = C.case_record("IFToMM A05 stiff flyball governor (10 s, K = 8e5 N/m, C = 4e4 N·s/m)", "simulation",
                         kind, runs, "m")
    case["reference_check"] = abs(float(own) - s_ref)
    return case


def run(S):
    """Every time-integration case (the smoke mode: A01 only)."""
    cases = [case_a01]
    if not S.smoke:
        cases += [case_double_pendulum, case_pivot_chain, case_ball_chain, case_rotor, case_a03, case_a02, case_a04,
                  case_a05]
    return [c(S) for c in cases]
