#!/usr/bin/env python
"""Regression benchmark: linearisation + modal analysis, error against run time.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_linearize.py [--quick] [--plot out.png]

Sections (see benchmarks/README.md):

1. targets  — a 100-body pivot chain with torsion springs hanging under gravity (its equilibrium is the
   neutral configuration): linearise + all modes by finite differences (target ≤ 20 ms) and analytically
   (target ≤ 3 ms); best and median wall time of repeated runs (time.perf_counter).
2. large    — the same chain with 100 … 1000 bodies, each in a fresh subprocess (memory capped with
   RLIMIT_AS): build, FD and analytic linearise + all modes, peak resident memory read from the child's
   own /proc/self/status VmHWM. Targets for 1000 bodies: ≤ 3 s and ≤ 300 MB.
3. sweep    — error against run time on the 100-body chain: FD steps 1e-3 … 1e-8 → (time, actual error of
   K against the analytic K, vibdyn's estimate ``lin.relative_error``, frequency error against the analytic modes,
   vibdyn's frequency estimate ``modes.relative_error``).
4. extreme  — stiff / ill-conditioned cases (right, or a clear vibdyn error, never NaN): stiffness ratio
   1e8, masses 1e-6 kg next to 1e3 kg, a 300-link chain, a rotor at 1e4 rad/s with a sprung slider, a
   stretched (singular) 2-link arm with a point-to-point spring. Each against an exact reference (closed
   form) where one exists, else against the analytic linearisation.

Writes benchmarks/results/linearize.json; ``--plot out.png`` draws error against time (needs matplotlib,
which is not a vibdyn dependency: the plot is skipped with a message if it is missing).
"""

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: threaded OpenBLAS is far slower here

import numpy as np
import scipy.linalg as sla

import vibdyn as vd

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "linearize.json"
G = 9.81

TARGETS = {"chain100_fd_s": 20e-3, "chain100_analytic_s": 3e-3, "chain1000_s": 3.0, "chain1000_mb": 300.0}


# ------------------------------------------------------------------------------------------- scenes
def pendulum_chain(n, k=10.0, L=0.1, m=0.1):
    """n pivots about y, links of length L (m) and mass m (kg) hanging along −z, a torsion spring k
    (N·m/rad, rest 0; one number or one per pivot) on every pivot: the neutral configuration is the
    (stable) equilibrium."""
    ks = np.broadcast_to(np.asarray(k, dtype=float), (n,))
    s = vd.Scene(f"chain{n}", gravity=(0.0, 0.0, -G))
    parent = vd.WORLD
    for i in range(n):
        name = f"l{i}"
        s.add_body(name, parent, vd.Pivot((0, 1, 0), at=(0, 0, -L if i else 0.0)), mass=m, com=(0, 0, -L / 2),
                   inertia=vd.inertia.box(m, (0.02, 0.02, L)))
        s.add_joint_spring(name, ks[i])
        parent = name
    return s


def slider_chain(masses, stiffnesses, tilt=0.3):
    """Sliders in series along x (relative coordinates), a spring on each; gravity tilted towards −x so
    that the equilibrium is off neutral. Exact: M_ij = Σ_{l ≥ max(i, j)} m_l, K = diag(k)."""
    s = vd.Scene("sliders", gravity=(-G * np.sin(tilt), 0.0, -G * np.cos(tilt)))
    parent = vd.WORLD
    for i, (m, k) in enumerate(zip(masses, stiffnesses)):
        name = f"s{i}"
        s.add_body(name, parent, vd.Slider((1, 0, 0), at=(0.1 if i else 0.0, 0, 0)), mass=m,
                   inertia=vd.inertia.box(m, (0.05, 0.05, 0.05)))
        s.add_joint_spring(name, k)
        parent = name
    m = np.asarray(masses, dtype=float)
    below = np.cumsum(m[::-1])[::-1]
    idx = np.arange(len(m))
    M = below[np.maximum.outer(idx, idx)]
    return s, M, np.diag(np.asarray(stiffnesses, dtype=float))


def rotor(k=100.0, c=2.0, m=1.0, l0=0.5):
    """Reference case R6 (the scene of tests/test_equilibrium.py): rotor driven by τ = 10 − ω² carrying a
    radial slider on a point-to-point spring (stiffness k, free length l0) and a joint damper c."""
    s = vd.Scene("rotor", gravity=(0, 0, -G))
    s.add_body("rotor", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=np.diag([0.05, 0.05, 0.1]))
    s.add_body("slider", "rotor", vd.Slider((1, 0, 0), at=(l0, 0, 0)), mass=m, inertia=np.diag([0.0005, 0.0005, 0.001]))
    s.add_spring("k", ("rotor", (0, 0, 0)), ("slider", (0, 0, 0)), stiffness=k, free_length=l0)
    if c:
        s.add_joint_damper("slider", c)
    s.add_joint_force("rotor", vd.laws.Polynomial((10, 0, -1)))
    return s


def rotor_exact(omega, k, c=2.0, m=1.0, l0=0.5, J=0.1 + 0.001):
    """M, C, K of the R6 rotor at the steady motion of given speed Ω (closed form): radius r = k l0/(k − mΩ²),
    M = diag(J + m r², m), C = [[2Ω, 2mrΩ], [−2mrΩ, c]] (drive law and Coriolis), K = diag(0, k − mΩ²)."""
    r = k * l0 / (k - m * omega**2)
    M = np.diag([J + m * r * r, m])
    C = np.array([[2 * omega, 2 * m * r * omega], [-2 * m * r * omega, c]])
    K = np.diag([0.0, k - m * omega**2])
    return M, C, K, r


def stretched_arm(k=100.0, l0=0.5, m=1.0, L=1.0):
    """Planar 2-link arm (pivots about z, rods of length L along x) fully stretched by a point-to-point spring
    from its tip to the world point (2L + 1, 0, 0): a singular configuration (the tip cannot move along the
    arm), held only by the tension T = k (1 − l0). Exact K = T [[2L, L], [L, L]] + T/1 · J_yᵀ J_y with
    J_y = (2L, L); M of two uniform rods."""
    s = vd.Scene("arm", gravity=(0, 0, -G))
    I = np.diag([1e-4, m * L * L / 12, m * L * L / 12])
    s.add_body("a1", joint=vd.Pivot((0, 0, 1)), mass=m, com=(L / 2, 0, 0), inertia=I)
    s.add_body("a2", "a1", vd.Pivot((0, 0, 1), at=(L, 0, 0)), mass=m, com=(L / 2, 0, 0), inertia=I)
    s.add_spring("k", ("a2", (L, 0, 0)), ("world", (2 * L + 1.0, 0, 0)), stiffness=k, free_length=l0)
    T = k * (1.0 - l0)
    Jy = np.array([2 * L, L])
    K = T * np.array([[2 * L, L], [L, L]]) + T / 1.0 * np.outer(Jy, Jy)
    Iz, lc = m * L * L / 12, L / 2
    M = np.array([[2 * Iz + m * lc**2 + m * (L * L + lc**2 + 2 * L * lc), Iz + m * (lc**2 + L * lc)],
                  [Iz + m * (lc**2 + L * lc), Iz + m * lc**2]])
    return s, M, K


# ------------------------------------------------------------------------------------------- helpers
def timed(fn, repeat):
    """(last result, list of wall times in s); one untimed warm-up call first."""
    fn()
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return out, times


def lin_modes(system, at, method, step=1e-5):
    lin = system.linearize(at, method=method) if method == "analytic" else system.linearize(at, method="fd", step=step)
    return lin, lin.modes()


def rel(a, b):
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def omega_error(omega, ref):
    """Largest per-mode relative error of natural frequencies (ref > 0; zeros compared absolutely)."""
    ref = np.asarray(ref, dtype=float)
    return float(np.max(np.abs(np.asarray(omega) - ref) / np.maximum(ref, 1e-12 * ref.max())))


def eig_error(lam, ref):
    """Largest relative error of matched complex eigenvalues (zeros relative to max |λ|)."""
    from scipy.optimize import linear_sum_assignment

    i, j = linear_sum_assignment(np.abs(ref[:, None] - lam[None, :]))
    scale = np.maximum(np.abs(ref[i]), 1e-12 * np.abs(ref).max())
    return float(np.max(np.abs(ref[i] - lam[j]) / scale))


def state_eigenvalues(M, C, K):
    n = M.shape[0]
    X = np.linalg.solve(M, np.hstack([K, C]))
    return np.linalg.eigvals(np.block([[np.zeros((n, n)), np.eye(n)], [-X[:, :n], -X[:, n:]]]))


def peak_rss_mb():
    """Peak resident memory of this process (MB): VmHWM of its own address space (Linux), which — unlike
    ru_maxrss — does not inherit the parent's high-water mark across fork/exec."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def ms(x):
    return f"{1e3 * x:9.3f} ms"


# ------------------------------------------------------------------------------------------- 1. targets
def bench_targets(repeat):
    system = pendulum_chain(100).build()
    eq = system.equilibrium()
    assert eq.residual <= eq.tol and np.abs(system.difference(system.neutral(), eq.q)).max() == 0.0
    out = {"n": 100, "equilibrium_residual": eq.residual, "repeat": repeat}
    res = {}
    for method in ("fd", "analytic"):
        (lin, m), times = timed(lambda: lin_modes(system, eq, method), repeat)
        res[method] = (lin, m)
        out[method] = {"min_s": min(times), "median_s": statistics.median(times), "linearize_s": lin.elapsed,
                       "modes_s": m.elapsed, "evaluations": lin.evaluations, "error_estimate_K": lin.relative_error,
                       "error_estimate_omega": m.relative_error, "stability": m.stability,
                       "omega_min": float(m.omega.min()), "omega_max": float(m.omega.max())}
    (fd, mf), (an, ma) = res["fd"], res["analytic"]
    out["fd"]["actual_error_K"] = rel(fd.K, an.K)
    out["fd"]["actual_error_omega"] = omega_error(mf.omega, ma.omega)
    out["pass_fd"] = out["fd"]["min_s"] <= TARGETS["chain100_fd_s"]
    out["pass_analytic"] = out["analytic"]["min_s"] <= TARGETS["chain100_analytic_s"]
    print("\n== 1. targets: 100-body pivot chain with torsion springs, hanging (linearise + all modes)")
    print(f"{'method':>9} {'min':>12} {'median':>12} {'lin':>12} {'modes':>12} {'est. K':>9} {'est. ω':>9} "
          f"{'actual ω':>9}  target")
    for method, key in (("fd", "chain100_fd_s"), ("analytic", "chain100_analytic_s")):
        r = out[method]
        act = f"{r['actual_error_omega']:9.1e}" if "actual_error_omega" in r else f"{'(ref)':>9}"
        print(f"{method:>9} {ms(r['min_s'])} {ms(r['median_s'])} {ms(r['linearize_s'])} {ms(r['modes_s'])} "
              f"{r['error_estimate_K']:9.1e} {r['error_estimate_omega']:9.1e} {act}  ≤ {ms(TARGETS[key]).strip()}: "
              f"{'PASS' if out['pass_' + method] else 'FAIL'}")
    return out


# ------------------------------------------------------------------------------------------- 2. large chains
def child_chain(n, repeat):
    """Runs in the subprocess: JSON with times (s) and peak memory (MB) of the n-body chain."""
    out = {"n": n, "baseline_mb": peak_rss_mb(), "pinocchio_data_tensors_mb": 4 * 8 * n**3 / 2**20}
    try:
        t = time.perf_counter()
        scene = pendulum_chain(n)
        out["scene_s"] = time.perf_counter() - t
        try:  # one phase of build() timed on its own (private: informative only)
            from vibdyn.model.system import _topological

            t = time.perf_counter()
            _topological(scene)
            out["topological_s"] = time.perf_counter() - t
        except ImportError:
            pass
        t = time.perf_counter()
        system = scene.build()
        out["build_s"] = time.perf_counter() - t
        out["after_build_mb"] = peak_rss_mb()
        q0 = system.neutral()
        out["equilibrium_residual"] = float(np.abs(system.inverse_dynamics(q0, 0 * q0, 0 * q0)).max())
        res = {}
        for method in ("fd", "analytic"):
            (lin, m), times = timed(lambda: lin_modes(system, q0, method), repeat)
            res[method] = (lin, m)
            finite = bool(np.all(np.isfinite(m.omega)))
            out[method] = {"min_s": min(times), "median_s": statistics.median(times), "linearize_s": lin.elapsed,
                           "modes_s": m.elapsed, "error_estimate_omega": m.relative_error, "finite": finite,
                           "rigid": int(m.rigid.sum()), "stability": m.stability}
        out["fd"]["actual_error_omega"] = omega_error(res["fd"][1].omega, res["analytic"][1].omega)
    except (MemoryError, vd.VibdynError) as e:
        import traceback

        where = traceback.extract_tb(e.__traceback__)[-1]
        out["error"] = (f"{type(e).__name__}{': ' + str(e) if str(e) else ''} at "
                        f"{Path(where.filename).name}:{where.lineno} ({where.line})")
    out["peak_mb"] = peak_rss_mb()
    return out


def run_child(n, repeat, cap_mb, timeout=900):
    """The n-body chain in a fresh interpreter (address space capped at cap_mb)."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", str(n), "--repeat", str(repeat),
           "--mem-cap-mb", str(cap_mb)]
    env = dict(os.environ, OPENBLAS_NUM_THREADS=os.environ.get("OPENBLAS_NUM_THREADS", "1"))
    t = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return {"n": n, "error": f"timed out after {timeout} s"}
    wall = time.perf_counter() - t
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
    if p.returncode != 0 or not lines:
        tail = (p.stderr.strip().splitlines() or ["?"])[-1]
        return {"n": n, "error": f"child exited {p.returncode}: {tail}", "wall_s": wall}
    out = json.loads(lines[-1])
    out["wall_s"] = wall
    return out


def bench_large(sizes, cap_mb, quick):
    print(f"\n== 2. large chains: one fresh subprocess each, address space capped at {cap_mb} MB; "
          "peak memory = the child's VmHWM")
    print(f"{'n':>5} {'build':>10} {'FD lin+modes':>14} {'an. lin+modes':>14} {'peak MB':>8} {'base MB':>8} "
          f"{'Data nv³ MB':>11} {'est. ω FD':>10} {'actual ω FD':>11}  note")
    rows = []
    for n in sizes:
        r = run_child(n, 1 if n > 300 else (2 if quick else 5), cap_mb)
        rows.append(r)
        if "fd" in r:
            print(f"{n:>5} {r['build_s']:>9.3f}s {r['fd']['min_s']:>13.3f}s {r['analytic']['min_s']:>13.3f}s "
                  f"{r['peak_mb']:>8.0f} {r['baseline_mb']:>8.0f} {r['pinocchio_data_tensors_mb']:>11.0f} "
                  f"{r['fd']['error_estimate_omega']:>10.1e} {r['fd']['actual_error_omega']:>11.1e}")
        else:
            print(f"{n:>5} {'—':>10} {'—':>14} {'—':>14} {r.get('peak_mb', float('nan')):>8.0f} "
                  f"{r.get('baseline_mb', float('nan')):>8.0f} {4 * 8 * n**3 / 2**20:>11.0f} {'':>10} {'':>11}  "
                  f"{r['error']}")
        if "topological_s" in r:
            print(f"{'':>5} (scene {r['scene_s']:.3f} s; build's body ordering _topological alone "
                  f"{r['topological_s']:.3f} s)")
    big = next((r for r in rows if r["n"] == 1000), None)
    out = {"cap_mb": cap_mb, "rows": rows}
    if big is not None:
        ok_time = "fd" in big and max(big["fd"]["min_s"], big["analytic"]["min_s"]) <= TARGETS["chain1000_s"]
        ok_mem = "fd" in big and big["peak_mb"] <= TARGETS["chain1000_mb"]
        out["pass_1000_time"], out["pass_1000_memory"] = bool(ok_time), bool(ok_mem)
        print(f"1000 bodies: time ≤ {TARGETS['chain1000_s']} s: {'PASS' if ok_time else 'FAIL'}; "
              f"memory ≤ {TARGETS['chain1000_mb']:.0f} MB: {'PASS' if ok_mem else 'FAIL'}")
        if "MemoryError" in big.get("error", ""):
            print("   cause: Pinocchio 4.1's Data constructor allocates four nv×nv×nv tensors (d2tau_dqdq, "
                  "d2tau_dvdv, d2tau_dqdv, d2tau_dadq: 4·8·nv³ B = "
                  f"{4 * 8 * 1000**3 / 2**30:.0f} GiB at nv = 1000) whatever the algorithm used "
                  "(stack-of-tasks/pinocchio#2949).")
    # what the modal part alone costs at nv = 1000 (a lower bound for the target once Data fits)
    rng = np.random.default_rng(0)
    A = rng.standard_normal((1000, 1000))
    K = A @ A.T + 1000 * np.eye(1000)
    B = rng.standard_normal((1000, 1000))
    M = B @ B.T + 1000 * np.eye(1000)
    _, times = timed(lambda: sla.eigh(K, M), 1 if quick else 3)
    out["eigh_1000_s"] = min(times)
    print(f"for scale: scipy.linalg.eigh(K, M) alone at nv = 1000 takes {min(times):.3f} s on one core")
    return out


# ------------------------------------------------------------------------------------------- 3. sweep
def bench_sweep(steps, repeat):
    system = pendulum_chain(100).build()
    q0 = system.neutral()
    an, ma = lin_modes(system, q0, "analytic")
    _, t_an = timed(lambda: lin_modes(system, q0, "analytic"), repeat)
    rows = []
    print("\n== 3. error against run time: 100-body chain, FD step sweep (reference: analytic K and modes)")
    print(f"{'step':>8} {'time':>12} {'K actual':>10} {'K estimate':>10} {'est/act':>8} {'ω actual':>10} "
          f"{'ω estimate':>10} {'rigid':>5}")
    for h in steps:
        (lin, m), times = timed(lambda: lin_modes(system, q0, "fd", h), repeat)
        r = {"step": h, "time_s": min(times), "K_actual": rel(lin.K, an.K), "K_estimate": lin.relative_error,
             "omega_actual": omega_error(m.omega, ma.omega), "omega_estimate": m.relative_error,
             "rigid": int(m.rigid.sum())}
        rows.append(r)
        print(f"{h:>8.0e} {ms(r['time_s'])} {r['K_actual']:>10.1e} {r['K_estimate']:>10.1e} "
              f"{r['K_estimate'] / max(r['K_actual'], 1e-300):>8.1f} {r['omega_actual']:>10.1e} "
              f"{r['omega_estimate']:>10.1e} {r['rigid']:>5}")
    analytic = {"time_s": min(t_an), "K_estimate": an.relative_error, "omega_estimate": ma.relative_error}
    print(f"{'analytic':>8} {ms(analytic['time_s'])} {'(ref)':>10} {an.relative_error:>10.1e} {'':>8} {'(ref)':>10} "
          f"{ma.relative_error:>10.1e}")
    tracks = all(r["K_estimate"] >= r["K_actual"] or r["K_actual"] <= 1e-14 for r in rows)
    ratios = [r["K_estimate"] / r["K_actual"] for r in rows if r["K_actual"] > 1e-14]
    print(f"K estimate ≥ actual error at every step (down to round-off, 1e-14): {tracks}; estimate/actual "
          f"{min(ratios):.1f} … {max(ratios):.1f}; best actual K error {min(r['K_actual'] for r in rows):.1e} at "
          f"step {min(rows, key=lambda r: r['K_actual'])['step']:.0e}")
    return {"rows": rows, "analytic": analytic, "estimate_bounds_actual": tracks}


# ------------------------------------------------------------------------------------------- 4. extreme
def _case(name, note, fn):
    """Run one extreme case; a clear vibdyn error is a valid outcome (recorded), NaN is not."""
    t = time.perf_counter()
    try:
        r = fn()
    except vd.VibdynError as e:
        r = {"outcome": f"clear error: {type(e).__name__}: {str(e).splitlines()[0]}"}
    r["case"], r["note"], r["total_s"] = name, note, time.perf_counter() - t
    return r


def _verdict(r):
    """"right" (finite, stability right, actual error within the estimate), or what is wrong."""
    problems = []
    for method in ("fd", "analytic"):
        o = r[method]
        if not o["finite"]:
            problems.append(f"{method}: NOT FINITE")
        if o["rigid"] != r["expected_zero_modes"]:
            problems.append(f"{method}: {o['rigid']} mode(s) zeroed as rigid (expected {r['expected_zero_modes']}), "
                            f"stability '{o['stability']}'")
        # Modes.error covers ω and the damped eigenvalues; against the analytic model, that model's own error
        # is part of the difference (a reference known to 1e-6 cannot show an error of 1e-7)
        allowed = o["estimate"] + (r["analytic"]["estimate"] if r.get("reference") == "analytic" and
                                   method == "fd" else 0.0)
        if o["actual"] > max(allowed, 1e-13):
            problems.append(f"{method}: error {o['actual']:.1e} > estimate {allowed:.1e}")
    return "right" if not problems else "WRONG: " + "; ".join(problems)


def _compare(system, at, ref_M=None, ref_K=None, ref_C=None, repeat=3):
    """FD and analytic linearise + modes at ``at``; errors against the exact (M, K[, C]) if given, else
    against the analytic model. ``actual``: with vibdyn's default modes; ``actual_no_rigid``: with the
    rigid-mode cleaning off (``modes(tol=0)``), i.e. the numbers themselves."""
    out, res = {}, {}
    for method in ("fd", "analytic"):
        (lin, m), times = timed(lambda: lin_modes(system, at, method), repeat)
        res[method] = (lin, m)
        out[method] = {"time_s": min(times), "estimate": m.relative_error, "stability": m.stability,
                       "rigid": int(m.rigid.sum())}
    if ref_K is None:
        ref_M, ref_K, ref_C = res["analytic"][0].M, res["analytic"][0].K, res["analytic"][0].C
        out["reference"] = "analytic"
    else:
        out["reference"] = "exact"
    damped = ref_C is not None and np.any(ref_C)
    ref_w2 = sla.eigh(0.5 * (ref_K + ref_K.T), ref_M, eigvals_only=True)
    ref_w = np.sqrt(np.abs(ref_w2))
    out["expected_zero_modes"] = int(np.sum(np.abs(ref_w2) <= 1e-12 * np.abs(ref_w2).max()))
    ref_lam = state_eigenvalues(ref_M, ref_C, ref_K) if damped else None
    for method, (lin, m) in res.items():
        o = out[method]
        raw = lin.modes(tol=0.0)
        o["finite"] = bool(np.all(np.isfinite(m.omega)) and np.all(np.isfinite(m.eigenvalues)))
        o["K_actual"] = rel(lin.K, ref_K)
        o["M_actual"] = rel(lin.M, ref_M)
        if damped:  # state eigenvalues
            o["actual"] = o["actual_no_rigid"] = eig_error(m.eigenvalues, ref_lam)
        else:
            o["actual"] = omega_error(m.omega, ref_w)
            o["actual_no_rigid"] = omega_error(raw.omega, ref_w)
        o["estimate_no_rigid"] = raw.relative_error
    out["omega_range"] = [float(ref_w.min()), float(ref_w.max())]
    out["damped"] = bool(damped)
    out["outcome"] = _verdict(out)
    return out


def bench_extreme(repeat, cap_mb, chain300=None):
    cases = []

    def stiff_sliders():
        s, M, K = slider_chain([1.0] * 10, [1e2, 1e10] * 5)
        system = s.build()
        return _compare(system, system.equilibrium(), M, K, repeat=repeat)

    def stiff_pivots():
        system = pendulum_chain(10, k=[10.0, 1e9] * 5, L=0.3, m=1.0).build()
        return _compare(system, system.equilibrium(), repeat=repeat)

    def tiny_sliders():
        s, M, K = slider_chain([1e-6, 1e3] * 5, [1e5] * 10)
        system = s.build()
        return _compare(system, system.equilibrium(), M, K, repeat=repeat)

    def tiny_pivots():
        s = vd.Scene("tiny", gravity=(1.0, 0.0, -G))
        parent = vd.WORLD
        for i in range(10):
            m = 1e-6 if i % 2 == 0 else 1e3
            name = f"p{i}"
            s.add_body(name, parent, vd.Pivot((0, 1, 0), at=(0, 0, -0.3 if i else 0.0)), mass=m, com=(0, 0, -0.15),
                       inertia=vd.inertia.box(m, (0.02, 0.02, 0.3)))
            s.add_joint_spring(name, 5e4 * (10 - i), rest=0.05)
            parent = name
        system = s.build()
        return _compare(system, system.equilibrium(), repeat=repeat)

    def high_spin():
        omega, k = 1e4, 1e9
        system = rotor(k=k).build()
        st = system.steady_motion({"rotor": omega})
        M, C, K, r = rotor_exact(omega, k)
        out = _compare(system, st, M, K, C, repeat=repeat)
        out["radius_error"] = abs(0.5 + st.coordinate("slider") - r) / r
        out["C_actual"] = rel(st.linearize().C, C)
        return out

    def high_spin_soft():
        """The R6 rotor itself (k = 100 N/m) at 1e4 rad/s: mΩ² = 1e8 ≫ k, no steady motion exists off the
        axis (and on the axis the spring's direction is undefined): a clear error is the right answer."""
        system = rotor().build()
        st = system.steady_motion({"rotor": 1e4})
        return {"finite": True, "outcome": f"UNEXPECTED steady motion at slider {st.coordinate('slider'):.3g}"}

    def arm():
        s, M, K = stretched_arm()
        system = s.build()
        return _compare(system, system.equilibrium(), M, K, repeat=repeat)

    specs = [("stiffness ratio 1e8 (10 sliders, exact)", "k alternately 1e2 and 1e10 N/m", stiff_sliders),
             ("stiffness ratio 1e8 (10 pivots)", "torsion k alternately 10 and 1e9 N·m/rad, hanging", stiff_pivots),
             ("tiny masses (10 sliders, exact)", "1e-6 kg next to 1e3 kg, k = 1e5 N/m", tiny_sliders),
             ("tiny masses (10 pivots)", "1e-6 kg next to 1e3 kg, tilted gravity, rests", tiny_pivots),
             ("high spin 1e4 rad/s (exact)", "R6 rotor, slider spring k = 1e9 N/m, state eigenvalues", high_spin),
             ("high spin 1e4 rad/s, k = 100", "R6 as is: no steady motion exists", high_spin_soft),
             ("stretched 2-link arm (exact)", "singular configuration held by a spring's tension", arm)]
    print("\n== 4. extreme cases (right, or a clear vibdyn error; never NaN)")
    print(f"{'case':<38} {'FD time':>11} {'FD est.':>8} {'FD act.':>8} {'an. time':>11} {'an. est.':>8} "
          f"{'an. act.':>8} {'act. tol=0':>10}  outcome")
    for name, note, fn in specs:
        cases.append(_case(name, note, fn))
    if chain300 is not None:
        r = {"case": "300-link chain", "note": "hanging pivot chain, in a subprocess (see section 2)"}
        if "fd" in chain300:
            f3, a3 = chain300["fd"], chain300["analytic"]
            r.update({"fd": {"time_s": f3["min_s"], "estimate": f3["error_estimate_omega"],
                             "actual": f3["actual_error_omega"], "finite": f3["finite"], "rigid": f3["rigid"],
                             "stability": f3["stability"]},
                      "analytic": {"time_s": a3["min_s"], "estimate": a3["error_estimate_omega"], "actual": 0.0,
                                   "finite": a3["finite"], "rigid": a3["rigid"], "stability": a3["stability"]},
                      "reference": "analytic", "expected_zero_modes": 0, "build_s": chain300["build_s"],
                      "peak_mb": chain300["peak_mb"]})
            r["outcome"] = _verdict(r)
        else:
            r["outcome"] = chain300["error"]
        cases.append(r)
    for r in cases:
        if "fd" in r:
            f, a = r["fd"], r["analytic"]
            raw = max(f.get("actual_no_rigid", f["actual"]), a.get("actual_no_rigid", a["actual"]))
            print(f"{r['case']:<38} {ms(f['time_s'])} {f['estimate']:>8.1e} {f['actual']:>8.1e} {ms(a['time_s'])} "
                  f"{a['estimate']:>8.1e} {a['actual']:>8.1e} {raw:>10.1e}  {r['outcome']} (vs {r['reference']})")
        else:
            print(f"{r['case']:<38} {'':>11} {'':>8} {'':>8} {'':>11} {'':>8} {'':>8} {'':>10}  {r['outcome']}")
    bad = [r["case"] for r in cases if r["outcome"].startswith(("WRONG", "UNEXPECTED"))]
    print("right or a clear error in every case: " + ("yes" if not bad else "NO — " + "; ".join(bad)))
    return cases


# ------------------------------------------------------------------------------------------- plot
def plot(results, path):
    """Two panels: error against wall time (chains of 100 … 300 bodies, FD and analytic, actual and
    estimated frequency errors, with the 100-body targets), and error against FD step (estimate vs actual)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print(f"--plot: matplotlib is not installed, figure {path} skipped (pip install matplotlib; it is not a "
              "vibdyn dependency)")
        return False
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 5.2))
    rows = [r for r in results["large"]["rows"] if "fd" in r]
    for method, color in (("fd", "tab:blue"), ("analytic", "tab:orange")):
        t = [r[method]["min_s"] * 1e3 for r in rows]
        est = [r[method]["error_estimate_omega"] for r in rows]
        ax.loglog(t, est, "o--", color=color, label=f"{method}: estimated ω error")
        if method == "fd":
            ax.loglog(t, [max(r["fd"]["actual_error_omega"], 1e-17) for r in rows], "o-", color=color,
                      label="fd: actual ω error (vs analytic)")
        for r, ti, e in zip(rows, t, est):
            ax.annotate(f"n={r['n']}", (ti, e), fontsize=7, xytext=(3, 4), textcoords="offset points")
    for r in results["extreme"]:
        if "fd" in r and r["case"] != "300-link chain":
            for method, marker in (("fd", "^"), ("analytic", "v")):
                ax.loglog(r[method]["time_s"] * 1e3, max(r[method]["actual"], 1e-17), marker, color="gray", ms=5)
    ax.plot([], [], "^", color="gray", label="extreme cases: actual error (fd ▲, analytic ▼)")
    for key, ls in (("chain100_fd_s", ":"), ("chain100_analytic_s", "-.")):
        ax.axvline(TARGETS[key] * 1e3, color="k", ls=ls, lw=0.8, label=f"target {key[9:-2]} (100 bodies)")
    ax.set_xlabel("linearise + all modes, wall time (ms, one core)")
    ax.set_ylabel("relative error of the natural frequencies")
    ax.set_title("error against run time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)

    sw = results["sweep"]
    h = [r["step"] for r in sw["rows"]]
    for key, style, label in (("K_actual", "o-", "K: actual error (vs analytic)"),
                              ("K_estimate", "o--", "K: vibdyn estimate (lin.relative_error)"),
                              ("omega_actual", "s-", "ω: actual error (vs analytic)"),
                              ("omega_estimate", "s--", "ω: vibdyn estimate (modes.relative_error)")):
        bx.loglog(h, [max(r[key], 1e-17) for r in sw["rows"]], style, label=label)
    for i, r in enumerate(r for r in sw["rows"] if r["rigid"]):
        bx.annotate(f"h={r['step']:.0e}: {r['rigid']} mode(s) zeroed as rigid", (r["step"], r["omega_actual"]),
                    fontsize=7, xytext=(8, -12 - 10 * i), textcoords="offset points")
    bx.axhline(sw["analytic"]["K_estimate"], color="k", ls=":", lw=0.8, label="analytic: K estimate")
    bx.set_xlabel("FD step (rad)")
    bx.set_ylabel("relative error")
    bx.set_title(f"100-body chain, FD step sweep ({1e3 * min(r['time_s'] for r in sw['rows']):.1f} ms each)")
    bx.invert_xaxis()
    bx.grid(True, which="both", alpha=0.3)
    bx.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"figure written to {path}")
    return True


# ------------------------------------------------------------------------------------------- main
def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="fewer repetitions and sizes (≈ 1 min)")
    p.add_argument("--plot", metavar="PNG", help="write a log-log error-against-time figure (needs matplotlib)")
    p.add_argument("--json", metavar="PATH", default=str(RESULTS), help=f"results file (default {RESULTS})")
    p.add_argument("--mem-cap-mb", type=int, default=4096,
                   help="address-space cap of each large-chain subprocess (protects the machine; default 4096)")
    p.add_argument("--child", type=int, help=argparse.SUPPRESS)
    p.add_argument("--repeat", type=int, default=3, help=argparse.SUPPRESS)
    args = p.parse_args(argv)

    if args.child:
        cap = args.mem_cap_mb * 2**20
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
        print(json.dumps(child_chain(args.child, args.repeat)))
        return 0

    threads = os.environ.get("OPENBLAS_NUM_THREADS")
    if threads != "1":
        print(f"warning: OPENBLAS_NUM_THREADS={threads}; the targets are for one thread")
    quick = args.quick
    start = time.perf_counter()
    results = {"machine": {"platform": platform.platform(), "processor": platform.processor(), "cpus": os.cpu_count(),
                           "python": platform.python_version(), "numpy": np.__version__,
                           "scipy": __import__("scipy").__version__, "pinocchio": __import__("pinocchio").__version__,
                           "vibdyn": vd.__version__, "OPENBLAS_NUM_THREADS": threads},
               "quick": quick, "targets": TARGETS}
    results["targets_100"] = bench_targets(10 if quick else 100)
    sizes = [100, 300, 1000] if quick else [100, 150, 200, 300, 1000]
    results["large"] = bench_large(sizes, args.mem_cap_mb, quick)
    steps = ([1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8] if quick
             else [1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8])
    results["sweep"] = bench_sweep(steps, 3 if quick else 10)
    chain300 = next((r for r in results["large"]["rows"] if r["n"] == 300), None)
    results["extreme"] = bench_extreme(2 if quick else 5, args.mem_cap_mb, chain300)
    results["total_s"] = time.perf_counter() - start

    t1, lg = results["targets_100"], results["large"]
    summary = {"chain100_fd": t1["pass_fd"], "chain100_analytic": t1["pass_analytic"],
               "chain1000_time": lg.get("pass_1000_time"), "chain1000_memory": lg.get("pass_1000_memory")}
    results["summary"] = summary
    print("\n== summary: " + ", ".join(f"{k} {'PASS' if v else 'FAIL'}" for k, v in summary.items())
          + f"  ({results['total_s']:.0f} s)")
    path = Path(args.json)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(results, indent=1, default=float))
    print(f"results written to {path}")
    if args.plot:
        plot(results, args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
