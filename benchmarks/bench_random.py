#!/usr/bin/env python
"""Speed target of issue 42: RMS of every output of a 100-degree-of-freedom chain under a tabulated PSD.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_random.py [--quick] [--n 100]

A chain of n masses on sliders in series (fixed–free), each spring with a damper beside it (then modal damping
ζ = 2 % on every mode: the chain's own dampers are replaced), base-excited by a support under the first spring
through a tabulated acceleration PSD (5 / 150 / 600 / 2000 Hz at 0.0053 / 0.04 / 0.04 / 0.0036 g²/Hz, log-log).
Outputs: the absolute acceleration of every mass.

- vibdyn: ``lin.random_response(psd, support=..., outputs=None)`` at its default tolerance (RMS to 1e-8, with
  an estimate);
- the reference a user would otherwise run: one direct transmissibility ``lin.base_response(omega, ...)`` on a
  log-spaced grid over the band, then the trapezoid rule. The grid is the coarsest (of a sequence growing by 25 %) whose
  RMS values are all within 1 % of vibdyn's; its error is measured against vibdyn's result;
- pyyeti's ``ode.solvepsd`` (modal, on its own frequency grid) at that grid too, if pyyeti is installed (it is
  not a vibdyn dependency).

Target: vibdyn's time ≤ 5 × the receptance's. The calls are interleaved (rotating order, best of several), and
the ratio is what to read on a loaded machine. Writes benchmarks/results/random.json.
"""

import argparse
import json
import os
import platform
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

import vibdyn as vd

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "random.json"
G = 9.80665
PSD = vd.PSD([5, 150, 600, 2000], [0.0053, 0.04, 0.04, 0.0036], unit="g^2/Hz")
TARGET = 5.0


def chain(n, m=0.1, k=None, zeta=0.02):
    """n masses m (kg) on sliders along z in series from a support; highest natural frequency ≈ 1 kHz."""
    k = m * (np.pi * 1000.0) ** 2 if k is None else k
    s = vd.Scene(f"chain{n}")
    s.add_support("base", vd.laws.HarmonicMotion((0, 0, 0.0), 1.0))
    prev = ("base", (0, 0, 0))
    for i in range(n):
        s.add_body(f"m{i}", joint=vd.Slider((0, 0, 1), at=(0, 0, 1.0 + i)), mass=m)
        s.add_spring(f"k{i}", prev, f"m{i}", stiffness=k)
        prev = f"m{i}"
    return s.build().linearize().with_modal_damping(zeta)


def trapezoid_rms(lin, f):
    """RMS absolute acceleration of every mass by one direct transmissibility on the grid f (Hz) + trapezoid."""
    T = lin.base_response(2 * np.pi * f, "base", direction=(0, 0, 1), outputs=None, method="direct")
    S = np.abs(T.alpha[:, :, 0]) ** 2 * PSD(f)[:, None]  # |T|² G_a: absolute acceleration per base acceleration
    return np.sqrt(np.trapezoid(S, f, axis=0))


def bare_solve(lin, f):
    """The same transmissibility by plain numpy solves (no error checks): a floor for any direct method."""
    By, Bv = lin.support_input("base")
    b = By[:, 2] + 0j
    out = []
    for x in 2 * np.pi * f:
        out.append(np.linalg.solve(lin.K - x * x * lin.M + 1j * x * lin.C, b + 1j * x * Bv[:, 2]))
    return np.array(out)


def vibdyn_rms(lin):
    r = lin.random_response(PSD, support="base", direction=(0, 0, 1), outputs=None)
    return r.rms("acceleration"), r.rms_error("acceleration"), r


def pyyeti_rms(lin, f):
    try:
        from pyyeti import ode
    except ImportError:
        return None
    m = lin.modes()
    Phi, w = m.shapes, m.omega
    n = w.size
    By, _ = lin.support_input("base")
    r = np.linalg.solve(lin.K, By[:, 2])  # influence vector: the static motion per unit base displacement
    zeta = np.full(n, 0.02)
    sol = ode.SolveUnc(np.ones(n), 2 * zeta * w, w ** 2, 1.0)  # modal, mass-normalised
    t_frc = -(Phi.T @ lin.M @ r)[:, None]  # relative motion under base acceleration: modal force −Φᵀ M r ÿ_b
    # absolute acceleration = relative (Φ q̈) + the base's, carried rigidly (r ÿ_b: the force feedthrough)
    rms, psd_out = ode.solvepsd(sol, PSD(f)[None, :], t_frc, f, [[Phi, None, None, r[:, None]]])
    return rms, psd_out


def best(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--n", type=int, default=100)
    args = ap.parse_args(argv)
    lin = chain(args.n)
    ref, err, res = vibdyn_rms(lin)
    print(f"chain of {args.n}: vibdyn RMS absolute acceleration {ref.min() / G:.4f} … {ref.max() / G:.4f} G, "
          f"largest estimated relative error {np.max(err / ref):.1e}, {res.evaluations} transfer evaluations, "
          f"method {res.method}")
    grid, n_pts = None, 40
    while n_pts <= 256000:
        f = np.geomspace(PSD.band[0], PSD.band[1], n_pts)
        gap = np.max(np.abs(trapezoid_rms(lin, f) / ref - 1))
        print(f"  receptance grid {n_pts:6d} log-spaced points: largest RMS error {gap:.2%}")
        if gap <= 0.01:
            grid = f
            break
        n_pts = round(n_pts * 1.25)
    repeats = 2 if args.quick else 5
    t_v, t_r = [], []
    calls = (lambda: vibdyn_rms(lin), lambda: trapezoid_rms(lin, grid))
    for i in range(repeats):  # interleaved, rotating order
        for j in ([0, 1] if i % 2 == 0 else [1, 0]):
            (t_v if j == 0 else t_r).append(best(calls[j], 1))
    tv, tr = min(t_v), min(t_r)
    out = {"n": args.n, "grid_points_for_1_percent": int(grid.size), "vibdyn_s": tv, "receptance_s": tr,
           "ratio": tv / tr, "target_ratio": TARGET, "vibdyn_max_relative_error_estimate": float(np.max(err / ref)),
           "vibdyn_evaluations": res.evaluations, "machine": platform.node(),
           "load_average": os.getloadavg()[0], "note": "best of interleaved runs; read the ratio on a loaded machine"}
    print(f"vibdyn {tv:.3f} s, one direct receptance at the 1 % grid ({grid.size} points) {tr:.3f} s: "
          f"ratio {tv / tr:.2f} (target ≤ {TARGET})")
    t_b = min(best(lambda: bare_solve(lin, grid), 1) for _ in range(repeats))
    out["bare_numpy_solve_s"] = t_b
    out["ratio_to_bare_solve"] = tv / t_b
    print(f"plain numpy solves on that grid (no error checks) {t_b:.3f} s: vibdyn / bare {tv / t_b:.2f}")
    py = None
    try:
        py = pyyeti_rms(lin, grid)
    except Exception as e:  # pyyeti's API differs between versions: report, don't fail the benchmark
        out["pyyeti"] = f"failed: {type(e).__name__}: {e}"
        print("pyyeti:", out["pyyeti"])
    if py is not None:
        t_p = min(best(lambda: pyyeti_rms(lin, grid), 1) for _ in range(repeats))
        out["pyyeti_s"] = t_p
        out["pyyeti_ratio_to_receptance"] = t_p / tr
        gap = float(np.max(np.abs(py[0][0] / ref - 1)))
        out["pyyeti_largest_rms_error"] = gap
        print(f"pyyeti ode.solvepsd at the same grid: {t_p:.3f} s (ratio to the receptance {t_p / tr:.2f}), largest "
              f"RMS error {gap:.2%} (no estimate)")
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
