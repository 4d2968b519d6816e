"""The benchmark suite (benchmarks/, at the repository root): its smoke run records what a maintainer needs
for every run, and its regression check passes against the committed baseline and fails on a degraded run.

Timings are never asserted here (machines differ); errors and verdicts are.
"""

import copy
import json
import math
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import common as C  # noqa: E402
from benchmarks import suite  # noqa: E402

VERDICTS = {C.RIGHT, C.REFUSED, C.WRONG, C.UNCHECKED, C.CRASHED}


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    return suite.run_suite("smoke", out=out, log=lambda *a: None), out


def test_smoke_records_every_run(smoke):
    results, out = smoke
    assert set(results) == set(suite.REGISTRY)
    n = 0
    for name, res in results.items():
        saved = json.loads((out / f"{name}.json").read_text())
        assert saved["machine"]["numpy"] and saved["cases"], name
        for case in res["cases"]:
            assert case["runs"] and case["verdict"] in VERDICTS and case["reference"], case["name"]
            for r in case["runs"]:
                n += 1
                what = f"{name} / {case['name']} / {r['label']}"
                assert r["verdict"] in VERDICTS, what
                assert r["time_s"] is not None and r["time_s"] > 0, what
                if r["solver"] == "vibdyn":
                    assert r["verdict"] != C.CRASHED, f"{what}: a raw exception ({r.get('message')})"
                if r["verdict"] == C.REFUSED:
                    assert r["message"], what  # refused loudly: with the vibdyn error's message
                    continue
                if r["verdict"] == C.UNCHECKED and r["solver"] == "vibdyn":
                    continue  # context figures (e.g. the time of ABA beside a target)
                assert r["error"] is not None and math.isfinite(r["error"]), what
                if r["solver"] == "vibdyn":
                    assert r["estimate"] is not None and r["estimate"] >= 0, what
                    # the verdict follows from the error and the estimate
                    assert r["verdict"] == C.verdict(r["error"], r["estimate"]), what
    assert n >= 20
    assert (out / "report.md").read_text().count("|") > 50
    assert all((out / f"{name}.png").stat().st_size > 10_000 for name in results)


def test_check_passes_against_the_committed_baseline(smoke):
    results, _ = smoke
    failures, notes = suite.compare(results, suite.load_baseline())
    assert not failures, failures
    assert not [n for n in notes if n.startswith("new")], "smoke runs missing from the baseline"


def test_check_fails_on_a_degraded_run(smoke):
    results, _ = smoke
    assert suite.compare(results, results)[0] == []
    # a 100× larger error in one vibdyn run
    bad = copy.deepcopy(results)
    case = bad["simulation"]["cases"][0]
    run = next(r for r in case["runs"] if r["solver"] == "vibdyn" and r["verdict"] == C.RIGHT)
    run["error"] *= 100
    failures, _ = suite.compare(bad, results)
    assert len(failures) == 1 and run["label"] in failures[0] and "grew 100×" in failures[0]
    # a run that stops being right (error beyond its estimate) fails even when the error grew less than 10×
    bad = copy.deepcopy(results)
    run = next(r for c in bad["linearization"]["cases"] for r in c["runs"] if r["verdict"] == C.RIGHT)
    run["verdict"] = C.WRONG
    failures, _ = suite.compare(bad, results)
    assert len(failures) == 1 and "now silently wrong" in failures[0]


def test_vibdyn_bench_without_the_suite_is_a_clear_error(monkeypatch, tmp_path, capsys):
    from vibdyn.faces.cli import main

    monkeypatch.setenv("VIBDYN_BENCHMARKS", str(tmp_path / "nowhere"))
    assert main(["bench", "--smoke"]) == 2
    err = capsys.readouterr().err
    assert "no benchmark suite" in err and "VIBDYN_BENCHMARKS" in err


def test_the_stored_chain_reference_is_this_chains_and_finer_than_double_precision():
    """benchmarks/data/chain_omega.json (40-digit ω of the linearisation benchmarks' chains) belongs to the chain
    that linearization.exact_chain describes: double-precision eigh of its exact M and K agrees with it to that
    solve's own round-off at n = 10 and 30 (a changed link, mass or spring without a new reference fails here),
    and the stored digits go far beyond double precision."""
    import numpy as np
    import scipy.linalg as sla

    from benchmarks.linearization import REFERENCE, exact_chain, exact_omega

    stored = json.loads(REFERENCE.read_text())
    assert stored["digits"] >= 30 and sorted(map(int, stored["omega"])) == [10, 30, 100, 300]
    for n, tol in ((10, 1e-12), (30, 1e-10)):
        M, K = exact_chain(n)
        w = np.sqrt(sla.eigh(K, M, eigvals_only=True))
        ref = exact_omega(n)
        assert ref.shape == (n,) and np.all(np.diff(ref) > 0)
        assert np.abs(w - ref).max() <= tol * ref.max()
        assert all(len(x.replace(".", "").lstrip("0")) >= 20 for x in stored["omega"][str(n)])
