"""The next speed targets, measured as ratios to MuJoCo (or with a stated target) in the same run.

- linearise + all modes of the 10-body chain (linearization.py's scene and exact reference), FD and
  analytic, interleaved with MuJoCo's ``mjd_transitionFD`` (centred) + eig and ``mjd_inverseFD`` + eigh:
  best of many calls each. Target: vibdyn ≤ 1× transitionFD for both paths;
- point-element evaluation: ``system.generalized_forces(q, v)`` of a scene with 6 point-to-point springs on
  3 bodies (one slider, two pivots) at a random state. Target ≤ 20 µs. Reference: Jᵀf summed spring by
  spring from Pinocchio's joint Jacobians (tests/oracles.py); "estimate": 1e3 ε × the force scale (the
  evaluation is exact to round-off).

Sensitivities of all modes of the 30-link chain to its 30 stiffnesses: ≤ 10× one linearise + modes.

The third target (10-link chain simulated to 1e-8 against MuJoCo RK4 at equal error) is the
``equal_error`` figure of simulation.py's chain cases.

The nonlinear analyses' targets (backbones against a hand-written scipy shooting, one ball-pendulum request) and
where their time goes: :mod:`benchmarks.nonlinear_speed` (quick and full runs).
"""

import time

import numpy as np

import vibdyn as vd
from vibdyn.analysis.modal import QR_LIMIT

from . import common as C
from .bench_linearize import pendulum_chain
from .linearization import MuJoCoLinear, exact_omega, lin_modes, omega_error

POINT_TARGET_S = 20e-6
LIN_TARGET_RATIO = 1.0


def interleaved(fns, repeat):
    """Best wall time of each function, calls interleaved round-robin (the machine's load hits all alike),
    the order rotated every round: a call runs faster after one that shares its code and data (caches),
    so each function follows each of the others equally often (in a fixed order the same linearisation
    measured 177 µs after vibdyn's analytic path and 202 µs after MuJoCo's transitionFD)."""
    for f in fns.values():
        f()
    best = {k: np.inf for k in fns}
    items = list(fns.items())
    for r in range(repeat):
        for k, f in items[r % len(items):] + items[:r % len(items)]:
            t = time.perf_counter()
            f()
            best[k] = min(best[k], time.perf_counter() - t)
    return best


def case_lin10(S):
    n = 10
    scene = pendulum_chain(n)
    system = scene.build()
    q0 = system.neutral()
    ref = exact_omega(n)
    fns = {"fd": lambda: lin_modes(system, q0, "fd"), "analytic": lambda: lin_modes(system, q0, "analytic")}
    fns["raw pinocchio"] = raw_pinocchio(system, q0)
    mjl = MuJoCoLinear(scene, system) if C.mujoco() is not None else None
    if mjl:
        fns.update(transitionFD=mjl.transition, inverseFD=mjl.inverse)
    best = interleaved(fns, {"smoke": 5, "quick": 100, "full": 400}[S.mode])
    runs = []
    for method in ("fd", "analytic"):
        lin, m = fns[method]()
        r = C.run_record(f"vibdyn {method}", "vibdyn", omega_error(m.omega, ref), m.relative_error, best[method],
                         lin.evaluations, method=method)
        r["ratio_to_raw_pinocchio"] = best[method] / best["raw pinocchio"]
        if mjl:
            r["ratio_to_transitionFD"] = best[method] / best["transitionFD"]
            r["ratio_to_inverseFD"] = best[method] / best["inverseFD"]
        runs.append(r)
    runs.append(C.run_record("raw pinocchio (RNEA derivatives + CRBA + eigh)", "pinocchio",
                             omega_error(np.sqrt(np.abs(fns["raw pinocchio"]())), ref), None, best["raw pinocchio"],
                             1, verdict_=C.UNCHECKED, note="the floor: no checks, no error estimate"))
    if mjl:
        for k in ("transitionFD", "inverseFD"):
            runs.append(C.run_record(f"mujoco {k}", "mujoco", omega_error(fns[k](), ref), None, best[k], method=k))
    case = C.case_record("target: linearise + all modes, chain n=10", "speed", "exact M, K + eigh", runs,
                         target=f"vibdyn ≤ {LIN_TARGET_RATIO:g}× mjd_transitionFD, both paths")
    if mjl:
        case["ratio_to_mujoco"] = max(r["ratio_to_transitionFD"] for r in runs[:2])
        case["ratio_note"] = (f"worst of FD {runs[0]['ratio_to_transitionFD']:.2f}, analytic "
                              f"{runs[1]['ratio_to_transitionFD']:.2f} / transitionFD (target ≤ {LIN_TARGET_RATIO:g}); "
                              f"/ inverseFD FD {runs[0]['ratio_to_inverseFD']:.2f}, analytic "
                              f"{runs[1]['ratio_to_inverseFD']:.2f} (target ≤ 1.5); / raw Pinocchio FD "
                              f"{runs[0]['ratio_to_raw_pinocchio']:.2f}, analytic "
                              f"{runs[1]['ratio_to_raw_pinocchio']:.2f} (target ≤ 2 for analytic)")
        case["target_met"] = case["ratio_to_mujoco"] <= LIN_TARGET_RATIO
    return case


def raw_pinocchio(system, q0, k=10.0, shapes=False):
    """The floor: Pinocchio's RNEA derivatives and CRBA at rest, the chain's torsion springs k (N·m/rad) on the
    diagonal, and scipy's eigh, no Python around them; returns ω² (rad²/s²). ``shapes``: eigh computes the
    mode shapes too, as ``modes()`` does (the eigenvalues alone are the cheaper floor the target names)."""
    import pinocchio as pin
    from scipy.linalg import eigh

    model, data, z = system.model, system.model.createData(), np.zeros(system.nv)
    springs = np.diag(np.full(system.nv, k))

    def run():
        pin.computeRNEADerivatives(model, data, q0, z, z)
        M = pin.crba(model, data, q0)
        out = eigh(data.dtau_dq + springs, M, lower=False, eigvals_only=not shapes)
        return out[0] if shapes else out

    return run


def compiled_path(system, q0):
    """The compiled calls vibdyn's analytic linearise + modes makes at q0 (a point where the free acceleration
    is zero), in its order and with nothing around them: CRBA, ABA (the reference acceleration), RNEA derivatives,
    the mass matrix's Cholesky factor and its inverse (trtri: the regularity check), the generalized eigenproblem
    (LAPACK sygv, or sygvd beyond modal.QR_LIMIT) and the residual's triangular solve. Its time is vibdyn's own
    floor; what the path takes beyond it is Python around those calls (the checks and the error estimates)."""
    import pinocchio as pin
    from scipy.linalg import lapack

    model, data, z = system.model, system.model.createData(), np.zeros(system.nv)
    springs = np.diag(np.full(system.nv, 10.0))
    sygv = lapack.dsygv if system.nv <= QR_LIMIT else lapack.dsygvd  # (as modes() chooses)

    def run():
        M = pin.crba(model, data, q0)
        a = pin.aba(model, data, q0, z, z)
        K = pin.computeRNEADerivatives(model, data, q0, z, a)[0] + springs
        L = lapack.dpotrf(M, lower=1)[0]
        lapack.dtrtri(L, lower=1)
        w2, Phi, _ = sygv(K, M.copy(order="F"), overwrite_b=1)
        lapack.dtrtrs(L, Phi, lower=1)
        return w2

    return run


def unchecked_path(system, q0):
    """vibdyn's analytic linearise + modes with its checks and error estimates left out, for the decision they
    cost (stop 28's option 3): the same building blocks (CRBA, the elements' forces, ABA, the RNEA derivatives
    with the groups' own, sygv and the shapes' sign convention) and the LinearModel they fill, nothing else.
    Not a vibdyn path: a measurement of what the checks and estimates take."""
    from scipy.linalg import lapack

    from vibdyn.analysis.linearize import LinearModel
    from vibdyn.model import dynamics
    from vibdyn.model.derivatives import analytic_derivatives

    n = system.nv
    zero, v0 = np.zeros((n, n)), np.zeros(n)
    sygv = lapack.dsygv if n <= QR_LIMIT else lapack.dsygvd

    def run():
        ws = system.workspace()
        M = dynamics.mass_matrix(system.model, ws.data, q0)
        applied = dynamics.forces(system, ws, q0, v0, 0.0)
        a0 = dynamics.accelerations(system, ws, q0, v0, 0.0, applied).copy()
        K, C, _, _ = analytic_derivatives(system, q0, v0, a0, 0.0, applied=applied)
        lin = LinearModel(system, q0, v0, a0, 0.0, M, C, K, zero, zero, "analytic", 0.0, 1)
        w2, Phi, _ = sygv(0.5 * (K + K.T), M.copy(order="F"), overwrite_b=1)
        Phi *= np.copysign(1.0, np.minimum.reduce(Phi) + np.maximum.reduce(Phi))
        return lin, w2, Phi

    return run


def case_floor(S):
    """The analytic and FD paths (linearise + all modes) against raw Pinocchio at n = 10, 30, 100: the
    ratio, interleaved, and where the analytic path's time goes: linearise and modes apart, and the compiled
    calls it makes (:func:`compiled_path`) against the Python around them (its checks and error estimates)."""
    runs, where, inverse = [], [], []
    for n in ((10, 30) if S.quick else (10, 30, 100)):
        scene = pendulum_chain(n)
        system = scene.build()
        q0, ref = system.neutral(), exact_omega(n)
        lin0 = system.linearize(q0, method="analytic")
        fns = {"fd": lambda: lin_modes(system, q0, "fd"), "analytic": lambda: lin_modes(system, q0, "analytic"),
               "raw": raw_pinocchio(system, q0), "raw shapes": raw_pinocchio(system, q0, shapes=True),
               "linearize": lambda: system.linearize(q0, method="analytic"), "modes": lin0.modes,
               "compiled": compiled_path(system, q0), "unchecked": unchecked_path(system, q0)}
        if C.mujoco() is not None:
            fns["inverseFD"] = MuJoCoLinear(scene, system).inverse
        best = interleaved(fns, {"smoke": 3, "quick": 50 if n < 100 else 10, "full": 200 if n < 100 else 30}[S.mode])
        for method in ("analytic", "fd"):
            lin, m = fns[method]()
            r = C.run_record(f"vibdyn {method}, n={n}", "vibdyn", omega_error(m.omega, ref), m.relative_error,
                             best[method], lin.evaluations, method=method)
            r["ratio_to_raw_pinocchio"] = best[method] / best["raw"]
            r["ratio_to_raw_with_shapes"] = best[method] / best["raw shapes"]
            if "inverseFD" in best:
                r["ratio_to_inverseFD"] = best[method] / best["inverseFD"]
                inverse.append(f"{method} {r['ratio_to_inverseFD']:.2f} at n={n}")
            if method == "analytic":
                r.update(linearize_s=best["linearize"], modes_s=best["modes"], compiled_s=best["compiled"],
                         python_s=best[method] - best["compiled"], unchecked_s=best["unchecked"],
                         unchecked_ratio_to_raw_pinocchio=best["unchecked"] / best["raw"])
                where.append(f"n={n}: linearise {best['linearize'] * 1e6:.0f} + modes {best['modes'] * 1e6:.0f} µs, "
                             f"of which compiled calls {best['compiled'] * 1e6:.0f} µs "
                             f"({best['compiled'] / best['raw shapes']:.2f}× the raw floor with shapes); the same "
                             f"path without its checks and error estimates {best['unchecked'] * 1e6:.0f} µs "
                             f"({best['unchecked'] / best['raw']:.2f}× the raw floor)")
            runs.append(r)
        runs.append(C.run_record(f"raw pinocchio, n={n}", "pinocchio", omega_error(np.sqrt(np.abs(fns["raw"]())), ref),
                                 None, best["raw"], 1, verdict_=C.UNCHECKED, note="floor"))
        runs.append(C.run_record(f"raw pinocchio with shapes, n={n}", "pinocchio",
                                 omega_error(np.sqrt(np.abs(fns["raw shapes"]())), ref), None, best["raw shapes"], 1,
                                 verdict_=C.UNCHECKED, note="floor computing what modes() returns: ω² and shapes"))
        if "inverseFD" in best:
            runs.append(C.run_record(f"mujoco inverseFD + eigh, n={n}", "mujoco", omega_error(fns["inverseFD"](), ref),
                                     None, best["inverseFD"], method="inverseFD",
                                     note="forward differences, n + 1 evaluations; eigenvalues only"))
    case = C.case_record("floor: linearise + all modes against raw Pinocchio", "speed", "exact M, K + eigh", runs,
                         target="analytic ≤ 2× raw Pinocchio at every size")
    ratios = [r["ratio_to_raw_pinocchio"] for r in runs if r.get("method") == "analytic"]
    like = [r["ratio_to_raw_with_shapes"] for r in runs if r.get("method") == "analytic"]
    case["ratio_note"] = ("analytic / raw: " + ", ".join(f"{x:.2f}" for x in ratios) + "; against a raw floor that "
                          "also computes the shapes (as modes() does): " + ", ".join(f"{x:.2f}" for x in like))
    case["time_goes_to"] = ("; ".join(where) + ". The rest is Python around the compiled calls: the checks (a regular "
                            "mass matrix, finite results, the circulatory test) and the error estimates (the round-off "
                            "of the terms that cancel, eigen residuals, quadratic forms of K's error): at n = 10 about "
                            "100 small numpy operations and Python calls of about 1 µs each, at n = 100 the residual's "
                            "and the quadratic forms' matrix products")
    if inverse:  # the other target on these sizes: ≤ 1.5× inverseFD at n = 10, ≤ 1× from n = 30 on
        case["inverse_fd_note"] = ("/ mujoco inverseFD + eigh: " + ", ".join(inverse) + " (target ≤ 1.5 at n = 10, "
                                   "≤ 1 from n = 30 on). The FD path evaluates 4n + 1 configurations (its truncation "
                                   "estimate needs steps h and 2h) where inverseFD evaluates n + 1, and computes the "
                                   "mode shapes where the MuJoCo run asks eigh for the eigenvalues alone")
        case["inverse_fd_target_met"] = all(
            r["ratio_to_inverseFD"] <= (1.5 if r["label"].endswith("n=10") else 1.0)
            for r in runs if "ratio_to_inverseFD" in r)
    case["target_met"] = max(ratios) <= 2.0
    return case


SPRINGS = [(("world", (-1, 0, 0)), ("cart", (0, 0, 0))), (("world", (1, 0.2, 0)), ("cart", (0.1, 0, 0))),
           (("cart", (0, 0.1, 0)), ("arm", (0, 0, -0.5))), (("world", (0, 1, -0.5)), ("arm", (0, 0, -1))),
           (("arm", (0, 0, -1)), ("tip", (0, 0, -0.4))), (("world", (0.5, -1, -1.5)), ("tip", (0.1, 0, -0.8)))]


def springs_scene():
    s = vd.Scene("six springs", gravity=(0, 0, -C.G))
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=10.0, inertia=vd.inertia.box(10.0, (0.4, 0.3, 0.2)))
    s.add_body("arm", "cart", vd.Pivot((0, 1, 0)), mass=2.0, com=(0, 0, -0.5),
               inertia=vd.inertia.rod(2.0, 1.0, axis=(0, 0, 1)))
    s.add_body("tip", "arm", vd.Pivot((1, 0, 0), at=(0, 0, -1)), mass=1.0, com=(0, 0, -0.4),
               inertia=vd.inertia.rod(1.0, 0.8, axis=(0, 0, 1)))
    for i, (a, b) in enumerate(SPRINGS):
        s.add_spring(f"k{i}", a, b, stiffness=100.0 * (i + 1), free_length=0.3)
    return s


def case_point_elements(S):
    system = springs_scene().build()
    rng = np.random.default_rng(3)
    q = system.random_configuration(0.3, rng)
    v = rng.standard_normal(system.nv)
    spring_force_q = C._oracles().spring_force_q
    Q_ref = sum(spring_force_q(system, a, b, 100.0 * (i + 1), 0.3, q) for i, (a, b) in enumerate(SPRINGS))
    fns = {"generalized_forces": lambda: system.generalized_forces(q, v),
           "accelerations": lambda: system.accelerations(q, v)}
    best = interleaved(fns, {"smoke": 20, "quick": 2000, "full": 10000}[S.mode])
    Q = fns["generalized_forces"]()
    scale = float(np.abs(Q_ref).max())
    err = float(np.abs(Q - Q_ref).max()) / scale
    runs = [C.run_record("vibdyn generalized_forces (6 springs)", "vibdyn", err, 1e3 * np.finfo(float).eps, best[
        "generalized_forces"], 1, note=f"target ≤ {POINT_TARGET_S * 1e6:.0f} µs"),
            C.run_record("vibdyn accelerations (ABA + 6 springs)", "vibdyn", None, None, best["accelerations"], 1,
                         verdict_=C.UNCHECKED, note="context")]
    case = C.case_record("target: point-element evaluation, 6 springs", "speed",
                         "Jᵀf per spring from Pinocchio joint Jacobians (tests/oracles.py)", runs, unit="relative",
                         target=f"≤ {POINT_TARGET_S * 1e6:.0f} µs")
    case["target_met"] = best["generalized_forces"] <= POINT_TARGET_S
    return case


def welded_chain_text(n):
    """A scene file of one pivot carrying a chain of n − 1 welded bodies (the case that grew faster than
    linearly: a copy of every body at build, a name search per Pinocchio frame)."""
    lines = ['[scene]', 'name = "welded"', 'gravity = [0.0, 0.0, -9.81]', '',
             '[[body]]', 'name = "b0"', 'mass = 1.0', 'joint = { type = "pivot", axis = [0.0, 0.0, 1.0] }', '']
    for i in range(1, n):
        lines += ['[[body]]', f'name = "b{i}"', f'parent = "b{i - 1}"', 'mass = 1.0', 'com = [0.1, 0.0, 0.0]',
                  'joint = { type = "fixed", at = [0.1, 0.0, 0.0] }', '']
    return "\n".join(lines)


SCALE_TARGET = 1.5  # time per body at the largest size over that at the smallest: linear within this


def case_scale(S):
    """Load and build of a welded chain against its size: the time per body must stay flat (linear)."""
    import tempfile
    from pathlib import Path

    sizes = (2000, 4000, 8000) if S.quick else (5000, 10000, 20000, 40000)
    runs, per_body = [], []
    with tempfile.TemporaryDirectory() as folder:
        for n in sizes:
            path = Path(folder) / f"welded{n}.toml"
            path.write_text(welded_chain_text(n))
            t0 = time.perf_counter()
            scene = vd.load_scene(path)
            t1 = time.perf_counter()
            scene.build()
            t2 = time.perf_counter()
            per_body.append((t2 - t0) / n)
            runs.append(C.run_record(f"vibdyn load + build, {n} bodies", "vibdyn", None, None, t2 - t0, n,
                                     verdict_=C.UNCHECKED, load_s=t1 - t0, build_s=t2 - t1,
                                     us_per_body=1e6 * (t2 - t0) / n))
    growth = per_body[-1] / per_body[0]
    case = C.case_record("target: load + build linear in the number of bodies (welded chain)", "speed",
                         "time per body at the largest size / at the smallest", runs, unit="s",
                         target=f"≤ {SCALE_TARGET}", growth=growth)
    case["target_met"] = growth <= SCALE_TARGET
    return case


SENSITIVITY_TARGET_RATIO = 10.0  # issue 35: all modes × 30 stiffnesses ≤ 10× one linearise + modes


def case_sensitivity(S):
    """Sensitivities of all modes of the 30-link chain to its 30 torsion-spring stiffnesses against one
    linearise + modes (both analytic, interleaved). Reference: the exact chain's M, K (linearization.py),
    eigh, and ∂ω_m/∂k_i = φ_im²/(2ω_m) (∂K/∂k_i = e_i e_iᵀ at the hanging pose, which no spring loads)."""
    import scipy.linalg as sla

    from .linearization import exact_chain

    n = 30
    system = pendulum_chain(n).build()
    q0 = system.neutral()
    names = [f"l{i}.spring.stiffness" for i in range(n)]
    base = system.linearize(q0, method="analytic").modes()
    fns = {"linearise + modes": lambda: system.linearize(q0, method="analytic").modes(),
           "sensitivity": lambda: base.sensitivity(names)}
    best = interleaved(fns, {"smoke": 3, "quick": 30, "full": 100}[S.mode])
    s = fns["sensitivity"]()
    M, K = exact_chain(n)
    w2, Phi = sla.eigh(K, M)
    ref = (Phi**2 / (2 * np.sqrt(w2))[None, :]).T  # modes × stiffnesses
    scale = np.abs(ref).max()
    err = float(np.abs(s.d_omega - ref).max() / scale)
    est = float(s.d_omega_error.max() / scale)
    ratio = best["sensitivity"] / best["linearise + modes"]
    runs = [C.run_record("vibdyn sensitivity, 30 modes × 30 stiffnesses", "vibdyn", err, est, best["sensitivity"],
                         1, method=s.method, ratio_to_linearise_modes=ratio),
            C.run_record("vibdyn linearise + modes (analytic)", "vibdyn", None, None, best["linearise + modes"], 1,
                         verdict_=C.UNCHECKED, note="the unit of the target")]
    case = C.case_record("target: sensitivities of all modes to 30 stiffnesses, chain n=30", "speed",
                         "exact M, K + eigh: ∂ω/∂k_i = φ_i²/(2ω)", runs, unit="relative",
                         target=f"≤ {SENSITIVITY_TARGET_RATIO:g}× one linearise + modes", ratio=ratio)
    case["target_met"] = ratio <= SENSITIVITY_TARGET_RATIO
    return case


def run(S):
    from . import nonlinear_speed

    cases = [case_lin10(S), case_floor(S), case_point_elements(S), case_sensitivity(S)]
    return cases if S.smoke else cases + [case_scale(S)] + nonlinear_speed.cases(S)
