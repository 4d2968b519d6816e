"""Nonlinear vibrations: forced-response curves by harmonic balance, periodic orbits and backbones (nonlinear normal
modes), error against run time.

Cases (references independent of the method measured):

- **Duffing forced response, peak amplitude** (models/duffing.toml, F = 0.1 N): the reference is the largest
  amplitude of the true periodic response, found by shooting on vibdyn's time simulation (``vd.floquet`` of the
  scene with the force as a time law, each orbit started from the last) maximised over Ω by Brent's method;
  its uncertainty is the orbits' closing error plus the maximiser's. Runs: vibdyn's harmonic balance at H = 1,
  3, 5, 7 and adaptive (estimate: the peak's truncation estimate); pyHarm (``pyharm-os`` 1.2.2, the HB code of
  Safran, installed with pip) at nh = 1, 3, 5, 7 (no error estimate); and a brute-force sweep — vibdyn's
  simulation run to steady state at each Ω of a grid, up in frequency (each start the last end), the
  amplitude read off the last periods. Each run also records its folds' Ω against the single-harmonic closed
  form at H = 1 (``fold_error_h1``: the closed form solves the H = 1 balance exactly) and the jump frequencies
  of the sweep (only as fine as its grid).
- **Two-mass cubic forced response, peak of x₁** (models/two_mass_cubic.toml, Kerschen et al.'s system, with a
  damper of 0.02 N·s/m on each mass and 0.02 N·cos Ωt on m1, Ω from 0.7 to 2 rad/s: both modes): the same
  reference by shooting, vibdyn's balance at H = 1, 3, 5 and adaptive, brute-force sweeps up through the first
  resonance (41 Ω × 120 periods: 6.3e-3 m in 46 s, the peak between its grid points), pyHarm at nh = 1…7 on the
  same matrices (and, in both cases, pyHarm with its default steps ds0 = ds_max = 1,
  which jump over the resonance: its peak is off by 93 % (Duffing) and 38 % (two-mass), without a warning).
  vibdyn evaluates its multibody forces (three point springs) at all time samples of the alternating
  frequency–time loop in one pass, as pyHarm's cubic spring is one vectorised formula: at equal harmonics it is
  the faster (H = 1: 0.25 s against 0.64 s, the same error), and the only one whose peak goes below pyHarm's
  continuation resolution (~1e-5 m: vibdyn's H = 3 reaches 6.5e-6 in 0.37 s, pyHarm's best 1.2e-5 in 0.78 s).
- **Pendulum orbits against the elliptic integral** (models/rod_pivot.toml, released from 2.5 rad): the
  period T = 4 K(sin²(A/2))/ω₀ of the nonlinear normal mode at that amplitude, ``vd.periodic_orbit`` at
  several flow tolerances (estimate: ``period_error``).
- **Backbones** (nonlinear normal modes, ``vd.backbone``), ω at requested amplitudes: the pendulum (rod_pivot,
  A = 1 and 2.5 rad) against the elliptic integral π ω₀ / (2 K(sin²(A/2))); the two-mass cubic oscillator
  (both NNMs, x₁ amplitude 0.1, 0.3, 0.5 m) against an independent shooting with scipy's DOP853 at rtol 1e-13
  on the hand-written ODE (checked on the pendulum against the elliptic integral to 4e-15). vd.backbone at
  (tol, rtol) = (1e-6, 1e-7), (1e-8, 1e-9), (1e-10, 1e-11) (estimate: the largest ω error estimate; each run
  also records how far the reported amplitudes are from the requests, ``amplitude_miss``, against its
  ``amplitude_estimate``); the brute-force competitor is that scipy shooting itself at rtol 1e-6, 1e-8, 1e-10
  (no estimate), continued from the linear mode in steps of 0.05. pyHarm has no backbone (no nonlinear normal
  mode continuation of a conservative system: its analyses are forced-response curves), so it is not run here.

What each gets wrong is recorded in the runs (``note``): a single harmonic misses the Duffing peak by about
1 % (its truncation estimate says so); pyHarm's peak is the best of its continuation points (no refinement),
so its error floors at the step's resolution whatever nh; the sweep's peak and jumps are only as fine as its
grid and each Ω costs ~10 damping times of simulation.
"""

import math
import time

import numpy as np

import vibdyn as vd

from . import common as C

F = 0.1  # N: the forcing of the Duffing cases (models/duffing.toml's reference)
RANGE = (0.5, 2.0)  # rad/s: the swept Ω


def duffing():
    scene = vd.load_scene("duffing")
    return scene, scene.build(), scene.references


def forced(scene, omega):
    s = scene.copy()
    s.add_joint_force("mass", vd.laws.Harmonic(F, omega, phase=math.pi / 2))  # F cos Ωt
    return s.build()


def orbit_amplitude(orbit, c=0):
    """max |x_c| over a periodic orbit's samples, refined by a parabola through the largest and its neighbours."""
    x = np.abs(orbit.trajectory.q[:-1, c])
    k = int(np.argmax(x))
    a, b, c = x[k - 1], x[k], x[(k + 1) % len(x)]
    d = a - 2 * b + c
    return float(b - (a - c) ** 2 / (8 * d)) if d < 0 else float(b)


def shooting_peak(scene, curve, xatol=1e-7, width=None, forced_at=None, c=0, at_peak=False):
    """(Ω*, largest amplitude of coordinate ``c``, its uncertainty, elapsed) of the true response by shooting,
    maximised over Ω between the curve's neighbours of its largest point (or ± ``width`` rad/s about its peak);
    ``forced_at(Ω)``: the forced System (default: the Duffing scene's, :func:`forced`). ``at_peak`` (the smoke
    run's): shooting at the curve's peak Ω alone, no maximisation — the amplitude is flat there, so Ω off by the
    curve's ``omega_error`` δ costs at most ½|A''|δ², which the uncertainty adds (3 orbits instead of ~14)."""
    from scipy.optimize import minimize_scalar

    start = time.perf_counter()
    i = int(np.argmax(curve.amplitude))
    lo, hi = float(curve.omega[max(i - 1, 0)]), float(curve.omega[min(i + 1, len(curve.omega) - 1)])
    if width is not None:
        lo, hi = curve.peak.omega - width, curve.peak.omega + width
    forced_at = forced_at or (lambda w: forced(scene, w))
    coef = curve.coefficients[i]  # (2H + 1) × nv: constant, then cos and sin of each harmonic
    k = np.arange(1, curve.harmonics + 1)[:, None]
    state = {"x": (coef[0] + coef[1::2].sum(axis=0), curve.omega[i] * (k * coef[2::2]).sum(axis=0))}
    errs = []

    def neg(w):
        x0, v0 = state["x"]
        orbit = vd.floquet(forced_at(w), 2 * math.pi / w, x0, v0, points=1024)
        state["x"] = (orbit.q0, orbit.v0)
        errs.append(orbit.error)
        return -orbit_amplitude(orbit, c)

    if at_peak:
        w = float(curve.peak.omega)
        peak, off = -neg(w), float(curve.peak.omega_error)
    else:
        res = minimize_scalar(neg, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
        w, peak, off = float(res.x), float(-res.fun), 3 * xatol
    # flat at the peak: Ω off by δ (≲ 3·xatol, or the curve's own Ω error) costs ½|A''|δ² (A'' by a central
    # difference there)
    h = 1e-4 * w
    curvature = abs(-neg(w + h) - 2 * peak - neg(w - h)) / h**2
    return w, peak, max(errs) + 0.5 * curvature * off**2 + 1e-12, time.perf_counter() - start


DUFFING_MATRICES = (np.array([[1.0]]), np.array([[0.05]]), np.array([[1.0]]), 0.1)  # M, C, K, k3 (SI)


def pyharm_curve(nh, ds=5e-3, matrices=DUFFING_MATRICES, force=F, omega_range=RANGE):
    """(Ω, amplitude of the first coordinate) of pyHarm's FRC with nh harmonics of ``matrices`` = (M, C, K, k3):
    a cubic spring k3 x₁³ to ground and the force ``force``·cos Ωt on the first coordinate; and its folds."""
    from pyHarm.DynamicOperator import compute_DFT
    from pyHarm.Maestro import Maestro

    Mm, Cm, Km, k3 = matrices
    linsys = {"M": Mm, "C": Cm, "K": Km, "G": np.zeros_like(Mm)}
    data = {"analysis": {"frf": {"study": "frf", "puls_inf": omega_range[0], "puls_sup": omega_range[1], "ds0": ds,
                                 "ds_min": 1e-8, "ds_max": ds, "sign_ds": 1, "verbose": False,
                                 "stepsizer": "acceptance", "predictor": "tangent", "corrector": "arc_length",
                                 "stopper": "bounds"}},
            "system": {"type": "Base", "nh": nh, "nti": 256, "adim": {"status": False, "lc": 1.0, "wc": 1.0}},
            "substructures": {"duffing": {"matrix": linsys, "ndofs": 1}},  # (one coordinate per node)
            "connectors": {"loading": {"type": "CosinusForcing", "connect": {"duffing": [0]}, "dirs": [0],
                                       "amp": force},
                           "cubic": {"type": "CubicSpring", "connect": {"duffing": [0]}, "dirs": [0], "k": k3}}}
    import logging
    import warnings

    logging.disable(logging.WARNING)  # its log of folds and steps
    try:
        with warnings.catch_warnings():  # pyHarm's own deprecations (getIndex) are not ours to report
            warnings.simplefilter("ignore")
            M = Maestro(data)
            ix = M.getIndex("duffing", 0, 0)
            M.operate()
    finally:
        logging.disable(logging.NOTSET)
    sols = [s for s in M.nls["frf"].SolList if s.flag_accepted]
    D = compute_DFT(M.system.nti, M.system.nh)
    w = np.array([s.x[-1] for s in sols])
    a = np.array([np.max(np.abs(s.x[ix] @ D["ft"])) for s in sols])
    turns = np.flatnonzero(np.diff(np.sign(np.diff(w))) != 0) + 1  # where Ω turns back: the folds (a point each)
    return w, a, sorted(w[turns].tolist())


def sweep(system_at, omegas, periods):
    """Brute force: at each Ω (upwards) the simulation from the last end (the first from rest at q = 0, the
    equilibrium) runs ``periods`` forcing periods; the amplitude is max |q₀| over the last two. Returns the
    amplitudes."""
    x = v = None
    amps = []
    for w in omegas:
        T = 2 * math.pi / w
        system = system_at(w)
        if x is None:
            x, v = np.zeros(system.nq), np.zeros(system.nv)
        tr = system.simulate(periods * T, x, v, t_eval=np.linspace((periods - 2) * T, periods * T, 257),
                             rtol=1e-9)
        x, v = tr.q[-1], tr.v[-1]
        amps.append(float(np.abs(tr.q[:, 0]).max()))
    return np.array(amps)


def fold_error(folds, reference):
    if len(folds) != len(reference):
        return None
    return float(max(abs(a - b) for a, b in zip(sorted(folds), sorted(reference))))


def pyharm_runs(S, runs, a_ref, folds_h1=None, **kw):
    """Append pyHarm's runs at nh = 1, 3, 5, 7 (``kw``: :func:`pyharm_curve`'s) to ``runs``; returns what was done."""
    try:
        import os
        import tempfile

        # pyHarm keeps a "kernel state" file, by default ./.pyHarm/context.json: out of the working tree, one
        # per process (two test workers running the smoke suite at once would read each other's half-written file)
        if "PYHARM_CONTEXT_FILE" not in os.environ:
            import atexit

            path = os.path.join(tempfile.gettempdir(), "vibdyn-pyharm", f"context-{os.getpid()}.json")
            os.environ["PYHARM_CONTEXT_FILE"] = path
            atexit.register(lambda: os.path.exists(path) and os.remove(path))
        import pyHarm  # noqa: F401
    except ImportError as e:  # said in the case (a run of its own would be "new" against the baseline)
        return f"pyHarm not run: pyharm-os is not installed here ({e}); pip install pyharm-os"
    for nh in [1] if S.smoke else [1, 3, 5, 7]:
        (w, a, folds), t, peak_mb = C.measure(lambda: pyharm_curve(nh, **kw), 1, memory=False)
        runs.append(C.run_record(f"pyHarm nh={nh}", "pyharm", abs(float(a.max()) - a_ref), None, t, None, None,
                                 method="pyHarm", harmonics=nh, points=len(w), peak_omega=float(w[a.argmax()]),
                                 folds=folds, fold_error_h1=fold_error(folds, folds_h1) if folds_h1 and nh == 1
                                 else None, note="peak = best continuation point (not refined); folds = turning "
                                 "points"))
    # pyHarm as it comes (its FRF's own ds0 = ds_max = 1): the steps jump over the resonance, silently
    (w, a, folds), t, _ = C.measure(lambda: pyharm_curve(5, ds=1.0, **kw), 1, memory=False)
    runs.append(C.run_record("pyHarm nh=5, its default steps", "pyharm", abs(float(a.max()) - a_ref), None, t, None,
                             None, method="pyHarm", harmonics=5, points=len(w), peak_omega=float(w[a.argmax()]),
                             folds=folds, note="pyHarm's defaults ds0 = ds_max = 1 (the runs above: 5e-3, tuned): "
                             f"{len(w)} points over the range, the resonance peak missed, no warning"))
    return "pyharm-os installed and run (tuned steps ds = 5e-3, and its default steps)"


def duffing_case(S):
    scene, system, ref = duffing()
    best = vd.forced_response_curve(system, ("mass", F), RANGE, "mass")
    w_ref, a_ref, a_err, t_ref = shooting_peak(scene, best, 1e-7, at_peak=S.smoke)
    folds_h1 = ref["fold_omega"]
    runs = []
    for H in ([1] if S.smoke else [1, 3, 5, 7]) + [None]:
        curve, t, peak_mb = C.measure(
            lambda: vd.forced_response_curve(system, ("mass", F), RANGE, "mass", harmonics=H), S.repeat)
        folds = [f.omega for f in curve.folds]
        runs.append(C.run_record(f"vibdyn HB H={H or 'adaptive'}", "vibdyn", abs(curve.peak.amplitude - a_ref),
                                 curve.peak.error, t, None, peak_mb, reference_error=a_err, method="harmonic balance",
                                 harmonics=curve.harmonics, points=len(curve.omega), peak_omega=curve.peak.omega,
                                 folds=folds, fold_error_h1=fold_error(folds, folds_h1) if H == 1 else None,
                                 fold_estimate=max((f.omega_error for f in curve.folds), default=None)))
    pyharm_note = pyharm_runs(S, runs, a_ref, folds_h1)
    # every mode runs the coarse sweep (the smoke run's, so that its baseline exists); the others a finer one
    for n, periods in [(5, 10)] + ([] if S.smoke else [(13, 40)] if S.quick else [(61, 80)]):
        grid = np.linspace(0.9, 1.2, n)  # damping time 1/(ζω) ≈ 40 s ≈ 6 periods
        amps, t, _ = C.measure(lambda: sweep(lambda w: forced(scene, w), grid, periods), 1, memory=False)
        k = int(np.argmax(amps))
        jump = float(grid[k + 1]) if k + 1 < len(grid) else None
        runs.append(C.run_record(f"brute-force simulation sweep, {n} Ω × {periods} periods", "simulation",
                                 abs(float(amps.max()) - a_ref), None, t, None, None, method="simulation sweep",
                                 peak_omega=float(grid[k]), jump_up_sweep=jump,
                                 note=f"grid step {grid[1] - grid[0]:.3g} rad/s: the jump (true upper fold "
                                      f"{best.folds[0].omega if best.folds else float('nan'):.6f}) and the peak "
                                      "only to that resolution; unsettled transients remain after few periods"))
    return C.case_record("Duffing FRC peak amplitude (F = 0.1 N)", "nonlinear",
                         f"shooting on the simulation, maximised over Ω: {a_ref:.10f} m at Ω = {w_ref:.8f} rad/s "
                         f"(± {a_err:.1e} m, {t_ref:.1f} s)", runs, unit="m", reference_value=a_ref,
                         reference_omega=w_ref, reference_error=a_err, pyharm=pyharm_note)


F2, C2, RANGE2 = 0.02, 0.02, (0.7, 2.0)  # N on m1, N·s/m on each mass, rad/s: the two-mass forced case


def two_mass(omega=None):
    """models/two_mass_cubic.toml with a damper C2 on each mass and, at ``omega``, F2·cos Ωt on m1 (a System)."""
    scene = vd.load_scene("two_mass_cubic")
    for body in ("m1", "m2"):
        scene.add_joint_damper(body, C2)
    if omega is not None:
        scene.add_joint_force("m1", vd.laws.Harmonic(F2, omega, phase=math.pi / 2))  # F2 cos Ωt
    return scene.build()


def two_mass_case(S):
    """The Kerschen two-mass oscillator, damped and forced on m1: peak of x₁ against shooting, vibdyn's HB and
    pyHarm on the same equations (M = I, K = [[2, −1], [−1, 2]], C = C2·I, 0.5 x₁³)."""
    system = two_mass()
    best = vd.forced_response_curve(system, ("m1", F2), RANGE2, "m1", harmonics=5 if S.smoke else None)
    w_ref, a_ref, a_err, t_ref = shooting_peak(None, best, 1e-7, forced_at=two_mass, at_peak=S.smoke)
    runs = []
    for H in [1] if S.smoke else [1, 3, 5, None]:  # (the adaptive run takes ~8 s: not in the smoke run)
        curve, t, peak_mb = C.measure(
            lambda: vd.forced_response_curve(system, ("m1", F2), RANGE2, "m1", harmonics=H), S.repeat)
        runs.append(C.run_record(f"vibdyn HB H={H or 'adaptive'}", "vibdyn", abs(curve.peak.amplitude - a_ref),
                                 curve.peak.error, t, None, peak_mb, reference_error=a_err, method="harmonic balance",
                                 harmonics=curve.harmonics, points=len(curve.omega), peak_omega=curve.peak.omega,
                                 folds=[f.omega for f in curve.folds]))
    matrices = (np.eye(2), C2 * np.eye(2), np.array([[2.0, -1.0], [-1.0, 2.0]]), 0.5)
    pyharm_note = pyharm_runs(S, runs, a_ref, matrices=matrices, force=F2, omega_range=RANGE2)
    # brute force: sweeps up through the first resonance (damping time 1/(ζω) ≈ 100 s ≈ 16 periods)
    for n, periods in [(5, 10)] + ([] if S.smoke else [(13, 40)] if S.quick else [(41, 120)]):
        grid = np.linspace(0.95, 1.1, n)
        amps, t, _ = C.measure(lambda: sweep(two_mass, grid, periods), 1, memory=False)
        k = int(np.argmax(amps))
        runs.append(C.run_record(f"brute-force simulation sweep, {n} Ω × {periods} periods", "simulation",
                                 abs(float(amps.max()) - a_ref), None, t, None, None, method="simulation sweep",
                                 peak_omega=float(grid[k]), note=f"grid step {grid[1] - grid[0]:.3g} rad/s: the "
                                 "peak only to that resolution; unsettled transients remain after few periods"))
    return C.case_record(f"two-mass cubic FRC peak amplitude of x₁ (F = {F2} N, c = {C2} N·s/m)", "nonlinear",
                         f"shooting on the simulation, maximised over Ω: {a_ref:.10f} m at Ω = {w_ref:.8f} rad/s "
                         f"(± {a_err:.1e} m, {t_ref:.1f} s)", runs, unit="m", reference_value=a_ref,
                         reference_omega=w_ref, reference_error=a_err, pyharm=pyharm_note)


def pendulum_case(S):
    from scipy.special import ellipk

    system = vd.load_scene("rod_pivot").build()
    A = 2.5
    w0 = vd.load_scene("rod_pivot").references["omega"][0]
    exact = 4 * float(ellipk(math.sin(A / 2) ** 2)) / w0
    runs = []
    for rtol in [1e-9] if S.smoke else [1e-5, 1e-7, 1e-9, 1e-11]:
        orbit, t, peak_mb = C.measure(lambda: vd.periodic_orbit(system, [A], [0.0], phase="rod", rtol=rtol,
                                                                tol=max(rtol * 10, 1e-10)), S.repeat)
        runs.append(C.run_record(f"vibdyn periodic_orbit rtol={rtol:g}", "vibdyn", abs(orbit.period - exact),
                                 orbit.period_error, t, None, peak_mb, method="shooting", rtol=rtol,
                                 multiplier_error=float(orbit.multiplier_error.max())))
    return C.case_record(f"pendulum orbit from {A} rad: period", "nonlinear",
                         f"4 K(sin²(A/2)) / ω₀ = {exact:.12f} s (scipy ellipk)", runs, unit="s")


# ---------------------------------------------------------------------------------------------- backbones
def scipy_backbone(accel, stiffness, phi, c, omega_lin, amplitudes, rtol, step=0.05):
    """The independent reference (and the brute-force competitor): ω (rad/s) of the NNM grown from the linear
    mode ``phi`` at each amplitude of coordinate ``c`` (ascending), by shooting with scipy's DOP853 on the
    hand-written ODE ẍ = accel(x) (∂accel/∂x = −stiffness(x)): a time-reversible orbit released at rest from a
    turning point, x_c(0) = A, v(0) = 0, the other x_j(0) and T/2 the unknowns, v(T/2) = 0 the equations
    (Newton on the variational equations), continued from A = ``step`` in steps of ``step``."""
    from scipy.integrate import solve_ivp

    n = len(phi)
    others = [j for j in range(n) if j != c]

    def rhs(t, y):
        x, v = y[:n], y[n:2 * n]
        S = y[2 * n:].reshape(2 * n, n)  # ∂(x, v)/∂x0
        return np.concatenate([v, accel(x), S[n:].ravel(), (-stiffness(x) @ S[:n]).ravel()])

    x0, half, out = np.asarray(phi, float) / phi[c] * step, math.pi / omega_lin, []
    grid = sorted(set(np.round(np.arange(step, max(amplitudes) + step / 2, step), 12)) | set(amplitudes))
    A_prev = step
    for A in grid:
        x0 = x0 * (A / A_prev)
        x0[c], A_prev = A, A
        for _ in range(40):
            y0 = np.concatenate([x0, np.zeros(n), np.eye(n).ravel(), np.zeros(n * n)])
            y = solve_ivp(rhs, (0.0, half), y0, method="DOP853", rtol=rtol, atol=rtol * 1e-3).y[:, -1]
            S = y[2 * n:].reshape(2 * n, n)
            J = np.column_stack([S[n:, others], accel(y[:n])])
            d = np.linalg.lstsq(J, -y[n:2 * n], rcond=None)[0]
            x0[others] += d[:-1]
            half += d[-1]
            if np.max(np.abs(d)) < 1e-14 * max(1.0, half):
                break
        if A in amplitudes:
            out.append(math.pi / half)
    return np.array(out)


def pendulum_ode():
    """rod_pivot as a hand-written ODE: θ̈ = −ω₀² sin θ."""
    w0 = vd.load_scene("rod_pivot").references["omega"][0]
    return (lambda x: -w0**2 * np.sin(x)), (lambda x: np.array([[w0**2 * math.cos(x[0])]])), np.array([1.0]), 0, w0


def two_mass_ode(mode):
    """Kerschen's system as a hand-written ODE: ẍ₁ = −(2x₁ − x₂ + 0.5x₁³), ẍ₂ = −(2x₂ − x₁); the linear mode."""
    def accel(x):
        return np.array([-(2 * x[0] - x[1] + 0.5 * x[0] ** 3), -(2 * x[1] - x[0])])

    def stiffness(x):
        return np.array([[2 + 1.5 * x[0] ** 2, -1.0], [-1.0, 2.0]])

    return accel, stiffness, np.array([1.0, 1.0 if mode == 0 else -1.0]), 0, (1.0 if mode == 0 else math.sqrt(3))


BACKBONE_SETTINGS = [(1e-6, 1e-7), (1e-8, 1e-9), (1e-10, 1e-11)]  # vd.backbone's (tol, rtol)


def backbone_case(S, name, system, mode, coordinate, amplitudes, ode, reference, reference_text):
    """vd.backbone at BACKBONE_SETTINGS (the default last; the smoke run: only it) against ``reference`` (ω per
    amplitude); the scipy shooting of :func:`scipy_backbone` at looser tolerances beside (no estimate)."""
    runs = []
    for tol, rtol in BACKBONE_SETTINGS[-1:] if S.smoke else BACKBONE_SETTINGS:
        try:
            bb, t, peak_mb = C.measure(lambda: vd.backbone(system, mode, amplitudes=amplitudes, coordinate=coordinate,
                                                           tol=tol, rtol=rtol), S.repeat)
        except vd.VibdynError as e:
            runs.append(C.refused(f"vibdyn backbone tol={tol:g} rtol={rtol:g}", "vibdyn", e, 0.0))
            continue
        err = np.abs(bb.omega - reference)
        runs.append(C.run_record(f"vibdyn backbone tol={tol:g} rtol={rtol:g}", "vibdyn", float(err.max()),
                                 float(bb.error.max()), t, None, peak_mb, method="continuation + shooting",
                                 tol=tol, rtol=rtol, points=bb.points, errors=err.tolist(), estimates=bb.error.tolist(),
                                 amplitude_miss=float(np.abs(bb.amplitude - amplitudes).max()),
                                 amplitude_estimate=float(bb.amplitude_error.max())))
    for rtol in [] if S.smoke else [1e-6, 1e-8, 1e-10]:
        w, t, _ = C.measure(lambda: scipy_backbone(*ode, amplitudes, rtol), 1, memory=False)
        runs.append(C.run_record(f"scipy shooting rtol={rtol:g}", "scipy", float(np.abs(w - reference).max()), None,
                                 t, None, None, method="hand-written ODE, DOP853, natural continuation", rtol=rtol,
                                 note="brute force: the equations written by hand, no error estimate"))
    return C.case_record(name, "nonlinear", reference_text, runs, unit="rad/s")


def pendulum_backbone_case(S):
    from scipy.special import ellipk

    A = [1.0, 2.5]
    w0 = vd.load_scene("rod_pivot").references["omega"][0]
    exact = np.array([math.pi * w0 / (2 * float(ellipk(math.sin(a / 2) ** 2))) for a in A])
    return backbone_case(S, "pendulum backbone ω at A = 1, 2.5 rad", vd.load_scene("rod_pivot").build(), 0, "rod",
                         A, pendulum_ode(), exact, "π ω₀ / (2 K(sin²(A/2))) (scipy ellipk): "
                         + ", ".join(f"{w:.12f}" for w in exact) + " rad/s")


def two_mass_backbone_case(S, mode):
    A = [0.1, 0.3, 0.5]
    start = time.perf_counter()
    ref = scipy_backbone(*two_mass_ode(mode), A, 1e-13, step=0.025)
    t_ref = time.perf_counter() - start
    return backbone_case(S, f"two-mass cubic backbone, {'in-phase' if mode == 0 else 'out-of-phase'} NNM: ω at x₁ "
                         "amplitude 0.1, 0.3, 0.5 m", vd.load_scene("two_mass_cubic").build(), mode, "m1", A,
                         two_mass_ode(mode), ref, "scipy DOP853 shooting at rtol 1e-13 on the hand-written ODE: "
                         + ", ".join(f"{w:.12f}" for w in ref) + f" rad/s ({t_ref:.1f} s)")


def run(S):
    backbones = [pendulum_backbone_case(S)]
    if not S.smoke:  # (~10 s each: the smoke run keeps the pendulum's)
        backbones += [two_mass_backbone_case(S, 0), two_mass_backbone_case(S, 1)]
    return [duffing_case(S), two_mass_case(S), pendulum_case(S), *backbones]
