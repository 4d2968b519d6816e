"""The benchmark suite: one entry point, results, report, plots and the regression check.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks [--quick | --smoke] [--check] [--only NAME ...]

Each module of REGISTRY has ``run(settings) -> list of case records`` (see benchmarks/common.py). The suite
writes ``results/<name>.json`` per module (machine, versions, cases), ``results/report.md`` and the
work-precision plots ``results/<name>.png`` (matplotlib, imported only by benchmarks/plot.py). ``--check``
compares the cases with ``baseline.json`` (:func:`compare`) and exits 1 on a regression.
"""

import argparse
import importlib
import json
import math
import os
import time
from pathlib import Path

from . import common as C

REGISTRY = {
    "simulation": "benchmarks.simulation",  # time integration, vibdyn beside MuJoCo RK4 / implicitfast
    "linearization": "benchmarks.linearization",  # linearise + all modes against chain length, FD V-curve
    "extreme": "benchmarks.extreme",  # stiff and extreme cases: right or refused loudly
    "speed": "benchmarks.speed",  # the next speed targets, as ratios to MuJoCo
    "nonlinear": "benchmarks.nonlinear",  # forced-response curves (HB beside pyHarm, sweeps), periodic orbits
}
RESULTS = C.HERE / "results"
BASELINE = C.HERE / "baseline.json"
ERROR_GROWTH = 10.0  # --check fails when a run's error grows more than this factor over the baseline
ERROR_FLOOR = 1e-12  # ... measured from at least this (round-off differs between machines)


def run_suite(mode="quick", only=None, out=RESULTS, plots=True, log=print):
    """Run the registered modules; returns {name: results dict} and writes the JSON files, report and plots."""
    S = C.Settings(mode)
    names = only or list(REGISTRY)
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise SystemExit(f"benchmarks: unknown benchmark(s) {', '.join(unknown)}; choose from {', '.join(REGISTRY)}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    all_results = {}
    info = C.machine()
    for name in names:
        start = time.perf_counter()
        log(f"== {name} ({mode})")
        try:
            cases = importlib.import_module(REGISTRY[name]).run(S)
        except Exception as e:  # noqa: BLE001 — one broken module must not hide the others' results
            import traceback

            cases = [C.case_record(f"{name}: the module crashed", name, "—", [C.refused(
                "module", "vibdyn", e, time.perf_counter() - start,
                traceback="".join(traceback.format_exception(e))[-2000:])])]
        res = {"name": name, "mode": mode, "machine": info, "estimate_slack": C.ESTIMATE_SLACK,
               "total_s": time.perf_counter() - start, "cases": cases}
        (out / f"{name}.json").write_text(json.dumps(res, indent=1, default=_json_default))
        all_results[name] = res
        for c in cases:
            log(summary_line(c))
        log(f"   ({res['total_s']:.1f} s)")
    if plots:
        from . import plot

        for name, res in all_results.items():
            path = plot.work_precision(res, out / f"{name}.png")
            if path:
                log(f"plot written to {path}")
    (out / "report.md").write_text(report(all_results))
    return all_results


def _json_default(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return str(x)


def summary_line(case):
    vd = [r for r in case["runs"] if r["solver"] == "vibdyn"]
    best = min((r for r in vd if r["error"] is not None), key=lambda r: r["error"], default=None)
    eq = case.get("equal_error", {}).get("ratio")
    return (f"   {case['name']:<46} {case['verdict']:<15} " + (f"best error {best['error']:.1e} " if best else "")
            + (f"vibdyn/MuJoCo at equal error {eq:.2f}" if eq else ""))


# ------------------------------------------------------------------------------------------- regression check
def _runs(results):
    """{(module, case, run label): run} of a results dict ({name: module results})."""
    return {(m, c["name"], r["label"]): r for m, res in results.items() for c in res["cases"] for r in c["runs"]}


def _ratios(results):
    """{(module, case): vibdyn/MuJoCo time ratio measured in that run}."""
    out = {}
    for m, res in results.items():
        for c in res["cases"]:
            ratio = c.get("equal_error", {}).get("ratio") or c.get("ratio_to_mujoco")
            if ratio:
                out[(m, c["name"])] = ratio
    return out


def compare(current, baseline):
    """Regressions of ``current`` against ``baseline`` (both {module: results}): (failures, notes).

    A failure: a run that was "right" and is not any more, a run that was "refused loudly" and is now
    silently wrong or crashed, or an error grown more than ERROR_GROWTH × (from at least ERROR_FLOOR).
    Notes (never failures): run-time ratios to MuJoCo measured in the same run, and runs present on one
    side only (a quick or smoke run has fewer)."""
    failures, notes = [], []
    cur, base = _runs(current), _runs(baseline)
    for key, r in cur.items():
        b = base.get(key)
        where = " / ".join(key)
        if b is None:
            notes.append(f"new (not in the baseline): {where}")
            continue
        if b["verdict"] == C.RIGHT and r["verdict"] != C.RIGHT:
            failures.append(f"{where}: was right, now {r['verdict']} (error {_fmt(r['error'])}, estimate "
                            f"{_fmt(r['estimate'])}{'; ' + r['message'] if r.get('message') else ''})")
        elif b["verdict"] == C.REFUSED and r["verdict"] in (C.WRONG, C.CRASHED):
            failures.append(f"{where}: was refused loudly, now {r['verdict']}")
        elif b["error"] is not None and r["error"] is not None and r["error"] > ERROR_GROWTH * max(b["error"],
                                                                                                  ERROR_FLOOR):
            failures.append(f"{where}: error grew {r['error'] / max(b['error'], ERROR_FLOOR):.0f}× "
                            f"({_fmt(b['error'])} → {_fmt(r['error'])})")
        elif b["error"] is not None and r["error"] is None and r["verdict"] != C.REFUSED and b["solver"] == "vibdyn":
            failures.append(f"{where}: no error any more ({r['verdict']})")
    missing = [k for k in base if k[0] in current and k not in cur]
    if missing:
        notes.append(f"{len(missing)} baseline run(s) not run this time (quick/smoke/--only)")
    rc, rb = _ratios(current), _ratios(baseline)
    for key, ratio in rc.items():
        if key in rb:
            notes.append(f"time ratio to MuJoCo {' / '.join(key)}: {rb[key]:.2f} → {ratio:.2f} "
                         f"({ratio / rb[key]:.2f}× the baseline's; not failed: machines are noisy)")
    return failures, notes


def _fmt(x):
    return "—" if x is None else f"{x:.2e}"


def load_baseline(path=BASELINE):
    return json.loads(Path(path).read_text())["results"]


def write_baseline(results, path=BASELINE):
    Path(path).write_text(json.dumps({"note": "python -m benchmarks --save-baseline (full run)",
                                      "results": results}, indent=1, default=_json_default))


# ------------------------------------------------------------------------------------------- report
def report(results):
    """Markdown: per module, machine and a table of every case's runs."""
    lines = ["# Benchmark report", ""]
    first = next(iter(results.values()), None)
    if first:
        m = first["machine"]
        lines += [f"Mode `{first['mode']}`; {m['platform']}, {m['cpus']} CPUs, load {m.get('loadavg')}, Python "
                  f"{m['python']}, numpy {m['numpy']}, scipy {m['scipy']}, Pinocchio {m['pinocchio']}, MuJoCo "
                  f"{m.get('mujoco')}, vibdyn {m['vibdyn']}, OPENBLAS_NUM_THREADS={m['OPENBLAS_NUM_THREADS']}.",
                  "", f"Verdicts: *right* = actual error ≤ {C.ESTIMATE_SLACK:g} × vibdyn's estimate (+{C.FLOOR:g}); "
                  "*refused loudly* = a clear vibdyn error; *silently wrong* = an answer whose error exceeds its "
                  "estimate; *unchecked* = no estimate (MuJoCo, scipy). Times: best of the repeats, one core; "
                  "the machine may be loaded, compare ratios measured in the same run. vibdyn's times include its "
                  "error estimate (DOP853's default: a second run at tolerances/100); ratios to MuJoCo compare "
                  "the motions alone, with the estimate's cost beside.", ""]
    lines += ["## Verdicts per case", "", "| module | case | verdict | vibdyn/MuJoCo time at equal error |",
              "|---|---|---|---|"]
    for name, res in results.items():
        for c in res["cases"]:
            eq = c.get("equal_error", {})
            ratio = (f"{eq['ratio']:.2f} (at error {eq['error']:g}; with the error estimate "
                     f"{eq['ratio_with_estimate']:.2f}"
                     + (f"; against MuJoCo RK4 with its Richardson estimate {eq['ratio_estimates']:.2f}"
                        if eq.get("ratio_estimates") else "") + ")"
                     if eq.get("ratio") and eq.get("ratio_with_estimate") else
                     f"{eq['ratio']:.2f} (at error {eq['error']:g})" if eq.get("ratio") else
                     f"{c['ratio_to_mujoco']:.2f} ({c.get('ratio_note', '')})" if c.get("ratio_to_mujoco") else "")
            lines.append(f"| {name} | {c['name']} | {c['verdict']} | {ratio} |")
    for name, res in results.items():
        lines += ["", f"## {name} ({res['total_s']:.0f} s)", ""]
        for c in res["cases"]:
            lines += [f"### {c['name']}: {c['verdict']}", "", f"Reference: {c['reference']}. Error unit: "
                      f"{c['unit'] or 'relative'}." + (f" {c['note']}" if c.get("note") else ""), "",
                      "| run | error | estimate | time | evaluations | peak MB | verdict | note |",
                      "|---|---|---|---|---|---|---|---|"]
            for r in c["runs"]:
                note = r.get("message") or r.get("note") or ""
                if r.get("ratio_to_mujoco_rk4"):
                    note = (note + "; " if note else "") + f"{r['ratio_to_mujoco_rk4']:.2f}× MuJoCo RK4 at equal error"
                    if r.get("ratio_with_estimate") and r.get("solution_time_s", r["time_s"]) != r["time_s"]:
                        note += f" ({r['ratio_with_estimate']:.2f}× with the error estimate)"
                lines.append(f"| {r['label']} | {_fmt(r['error'])} | {_fmt(r['estimate'])} | {_time(r['time_s'])} | "
                             f"{r['evaluations'] if r['evaluations'] is not None else ''} | "
                             f"{_mb(r['peak_mb'])} | "
                             f"{r['verdict']} | {note.replace('|', '/')} |")
            lines.append("")
    return "\n".join(lines) + "\n"


def _mb(x):
    return "" if x is None else f"{x:.1f}"


def _time(t):
    if t is None or (isinstance(t, float) and math.isnan(t)):
        return "—"
    return f"{t * 1e6:.0f} µs" if t < 1e-3 else f"{t * 1e3:.2f} ms" if t < 1 else f"{t:.2f} s"


# ------------------------------------------------------------------------------------------- command line
def main(argv=None, prog="python -m benchmarks"):
    p = argparse.ArgumentParser(prog=prog, description="vibdyn's regression benchmarks: error against run time "
                                "beside MuJoCo, stiff and extreme cases, speed targets.")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="fewer settings and repeats (< 5 min on 2 cores)")
    g.add_argument("--smoke", action="store_true", help="a tiny subset (seconds): for the test suite")
    p.add_argument("--check", action="store_true", help=f"compare with {BASELINE.name}; exit 1 on a regression")
    p.add_argument("--only", nargs="+", metavar="NAME", help=f"run only these ({', '.join(REGISTRY)})")
    p.add_argument("--out", default=str(RESULTS), help=f"results folder (default {RESULTS})")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots (no matplotlib needed)")
    p.add_argument("--save-baseline", action="store_true", help=f"write this run as {BASELINE.name} (with --check: "
                   "after comparing with the one it replaces)")
    args = p.parse_args(argv)
    if os.environ.get("OPENBLAS_NUM_THREADS") != "1":
        print(f"warning: OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}; times are meant for one "
              "thread (set OPENBLAS_NUM_THREADS=1 before starting Python)")
    mode = "smoke" if args.smoke else "quick" if args.quick else "full"
    previous = load_baseline() if args.check else None  # (--check --save-baseline: against the one replaced)
    start = time.perf_counter()
    results = run_suite(mode, args.only, args.out, plots=not args.no_plots)
    print(f"results, report.md and plots in {args.out} ({time.perf_counter() - start:.0f} s)")
    if args.save_baseline:
        write_baseline(results)
        print(f"baseline written to {BASELINE}")
    status = 0
    if args.check:
        failures, notes = compare(results, previous)
        for n in notes:
            print(f"note: {n}")
        for f in failures:
            print(f"REGRESSION: {f}")
        print(f"check against {BASELINE.name}: " + ("FAILED" if failures else "passed"))
        status = 1 if failures else 0
    return status
