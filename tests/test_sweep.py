"""Parameter sweeps: the same numbers on every executor (serial, process pool, thread pool, Dask), failed
points recorded, resumable stores (also after Ctrl-C), modes tracked through crossings and veerings, and
Monte Carlo statistics checked against a perturbation estimate within their own standard errors."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import scipy.stats as st

import vibdyn as vd
from vibdyn import examples

GRID = {"k1": [800.0, 1000.0, 1200.0], "k2": [900.0, 1100.0]}


def outputs(sw):
    return [(r["status"], r["outputs"]) for r in sw.results]


def test_grid_sweep_rows_and_table(tmp_path):
    sw = vd.sweep(examples.chain, GRID, progress=False)
    assert sw.n == 6 and sw.ok.all() and sw.executor == "serial"
    rows = sw.rows()
    assert [(r["k1"], r["k2"]) for r in rows] == [(a, b) for a in GRID["k1"] for b in GRID["k2"]]
    # each point's frequencies are those of its own chain
    m = examples.chain(3, k1=1200.0, k2=1100.0).build().operating_point().linearize().modes()
    assert np.array_equal(sw.values("omega")[5], m.omega)
    assert {"omega_0", "omega_2", "relative_error", "elapsed_s", "status"} <= set(rows[0])
    sw.to_csv(tmp_path / "s.csv")
    assert len((tmp_path / "s.csv").read_text().splitlines()) == 7
    assert len(sw.to_pandas()) == 6


def test_failed_points_are_recorded_and_the_rest_complete():
    sw = vd.sweep(examples.chain, {"m": [1.0, -1.0, 2.0]}, progress=False)
    assert sw.ok.tolist() == [True, False, True]
    assert "mass" in sw.results[1]["status"] and sw.results[1]["status"].startswith("failed")
    assert sw.values("omega").shape == (2, 3)


def test_executors_agree_bit_for_bit():
    ref = vd.sweep(examples.chain, GRID, progress=False)
    with ThreadPoolExecutor(2) as ex:
        threads = vd.sweep(examples.chain, GRID, executor=ex, progress=False)
    procs = vd.sweep(examples.chain, GRID, executor="processes", progress=False)
    assert outputs(threads) == outputs(ref) and outputs(procs) == outputs(ref)
    assert procs.executor == "processes"


def test_dask_local_cluster_agrees_bit_for_bit():
    distributed = pytest.importorskip("distributed")
    ref = vd.sweep(examples.chain, GRID, progress=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  host="127.0.0.1") as cluster, distributed.Client(cluster) as client:
        sw = vd.sweep(examples.chain, GRID, executor=client, progress=False)
    assert sw.executor == "dask" and outputs(sw) == outputs(ref)


def test_store_resumes_without_recomputing(tmp_path):
    store = tmp_path / "sweep.jsonl"
    first = vd.sweep(examples.chain, {"k1": [800.0, 1000.0]}, store=store, progress=False)
    full = vd.sweep(examples.chain, {"k1": [800.0, 1000.0, 1200.0]}, store=store, progress=False)
    assert full.results[:2] == first.results  # elapsed too: read back, not recomputed
    assert len(store.read_text().splitlines()) == 1 + 3  # the header (which sweep made it), then the points
    again = vd.sweep(examples.chain, {"k1": [800.0, 1000.0, 1200.0]}, store=store, progress=False)
    assert again.results == full.results


def _children(pid):
    out = set()
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{task}/children") as f:
                out |= {int(x) for x in f.read().split()}
        except OSError:
            pass
    return out


def test_ctrl_c_of_a_process_sweep_leaves_no_worker_and_resumes(tmp_path):
    store = tmp_path / "sweep.jsonl"
    script = textwrap.dedent(f"""
        import numpy as np, vibdyn as vd
        from vibdyn import examples
        vd.sweep(examples.chain, {{"k1": list(np.linspace(500, 1500, 400)), "n": [12.0]}},
                 executor="processes", store={str(store)!r}, progress=False, chunksize=2)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL) and None)
    workers = set()
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and (not store.exists() or len(store.read_text().splitlines()) < 6):
        workers |= _children(proc.pid) if proc.poll() is None else set()
        time.sleep(0.05)
    workers |= _children(proc.pid)
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=30)
    assert workers, "the pool never started"
    time.sleep(0.5)
    alive = [w for w in workers if os.path.exists(f"/proc/{w}") and open(f"/proc/{w}/stat").read().split()[2] != "Z"]
    assert not alive, f"workers left behind: {alive}"
    done = {json.loads(line)["key"]: json.loads(line)["result"] for line in store.read_text().splitlines()
            if line.strip().endswith("}") and '"key"' in line}
    assert 6 <= len(done) < 400
    sw = vd.sweep(examples.chain, {"k1": list(np.linspace(500, 1500, 400)), "n": [12.0]}, store=store,
                  progress=False)
    from vibdyn.studies.sweeps import _key

    assert all(r == done[_key(p)] for p, r in zip(sw.parameters, sw.results) if _key(p) in done)
    assert sw.ok.all() and sw.n == 400


def test_tracking_through_a_crossing_and_a_veering():
    k1 = np.linspace(80.0, 120.0, 41)
    cross = vd.sweep(examples.two_modes, {"k1": k1}, progress=False).tracked("omega")
    assert len(cross.crossings) == 1 and not cross.veerings
    col = int(np.argmin(np.abs(cross.values[0] - np.sqrt(80.0))))  # the k1 mode: ω = √k1 all along
    assert np.allclose(cross.values[:, col], np.sqrt(k1), rtol=1e-9)
    assert np.allclose(cross.values[:, 1 - col], 10.0, rtol=1e-9)
    veer = vd.sweep(examples.two_modes, {"k1": k1, "kc": [2.0]}, progress=False).tracked("omega")
    assert not veer.crossings and len(veer.veerings) == 1
    assert np.all(veer.values[:, 0] < veer.values[:, 1])  # the curves repel: each stays on its branch


def test_sample_methods():
    u = st.uniform(0.0, 1.0)
    lhs = vd.sample({"a": u, "b": u}, 50, method="lhs", seed=3)
    for v in lhs.values.values():  # one sample per stratum in every dimension
        assert sorted(np.floor(v * 50).astype(int)) == list(range(50))
    sob = vd.sample({"a": u}, 64, method="sobol", seed=3)
    assert sob.n == 64 and np.all((sob.values["a"] >= 0) & (sob.values["a"] < 1))
    assert np.array_equal(vd.sample({"a": u}, 5, "random", seed=1).values["a"],
                          vd.sample({"a": u}, 5, "random", seed=1).values["a"])
    with pytest.raises(vd.ModelError, match="method"):
        vd.sample({"a": u}, 5, method="halton")
    with pytest.raises(vd.ModelError, match="distribution"):
        vd.sample({"a": 3.0}, 5)


def test_monte_carlo_frequencies_against_perturbation_theory():
    """±20 % uniform stiffness on a 3-mass chain, 2000 samples. The 90 % band's width matches first-order
    sensitivity (∂ω_r/∂k_i = φ_ir²/(2ω_r), mass-normalised modes) within its Monte Carlo error; the median
    is shifted from ω_r by the second-order term ½ Σ ∂²ω_r/∂k_i² Var(k_i) — which at ±20 % is several
    standard errors, so the check includes it."""
    k0, half = 1000.0, 200.0
    smp = vd.sample({f"k{i}": st.uniform(k0 - half, 2 * half) for i in (1, 2, 3)}, 2000, method="random", seed=7)
    sw = vd.sweep(examples.chain, smp, executor="processes", progress=False)
    assert sw.ok.all()
    q = sw.quantiles("omega", [0.05, 0.5, 0.95])
    m0 = examples.chain(3, k=k0).build().operating_point().linearize().modes()
    Phi, w = m0.shapes, m0.omega
    lam, var = w ** 2, (2 * half) ** 2 / 12
    dk = np.stack([smp.values[f"k{i}"] - k0 for i in (1, 2, 3)], axis=1)
    first = np.quantile(w + dk @ (Phi ** 2 / (2 * w)), [0.05, 0.95], axis=0)
    bias = np.zeros(3)
    for r in range(3):
        for i in range(3):
            d1 = Phi[i, r] ** 2
            d2 = 2 * sum((Phi[i, s] * Phi[i, r]) ** 2 / (lam[r] - lam[s]) for s in range(3) if s != r)
            bias[r] += 0.5 * var * (d2 / (2 * w[r]) - d1 ** 2 / (4 * w[r] ** 3))
    assert np.all(np.abs(q.value[1] - (w + bias)) <= 3 * q.standard_error[1])
    band, band_se = q.value[2] - q.value[0], np.hypot(q.standard_error[2], q.standard_error[0])
    assert np.all(np.abs(band - (first[1] - first[0])) <= 3 * band_se)
    p = sw.probability(lambda row: row["omega_0"] < q.value[1][0])
    assert abs(p.value - 0.5) <= 3 * p.standard_error


@pytest.mark.parametrize("kwargs, words", [
    ({"parameters": {}}, "parameters"),
    ({"parameters": {"k1": [1.0]}, "analysis": "campbel"}, "analysis"),
    ({"parameters": {"k1": [1.0]}, "executor": "gpu"}, "executor"),
])
def test_sweep_bad_input(kwargs, words):
    with pytest.raises(vd.ModelError, match=words):
        vd.sweep(examples.chain, progress=False, **kwargs)


def test_campbell_sweep_over_the_polar_inertia():
    sw = vd.sweep(examples.gimbal_rotor, {"Ip": [0.12, 0.16]}, analysis="campbell",
                  options={"spin": "rotor", "speeds": list(np.linspace(0, 100, 11))}, progress=False)
    crit = [r["outputs"]["critical_speeds"] for r in sw.results]
    for Ip, c in zip([0.12, 0.16], crit):
        assert c == pytest.approx([np.sqrt(300.0 / (0.08 + Ip))], rel=1e-8)



def _fails_with_a_type_error(k1):
    """A user's build that raises what vibdyn does not (here for one value)."""
    if k1 > 900.0:
        raise TypeError("unknown parameter")
    return examples.chain(k1=k1)


def _raises_runtime_error(k1):
    raise RuntimeError("the user's own failure")


def test_a_sweep_records_every_failure_of_a_point_and_goes_on(tmp_path):
    """A build raising anything (a TypeError, a user's RuntimeError) is that point's failure, recorded with
    its type and message; the other points run (on a million-point Dask sweep nothing is lost)."""
    sw = vd.sweep(_fails_with_a_type_error, {"k1": [800.0, 1000.0]}, progress=False)
    assert sw.ok.tolist() == [True, False]
    assert sw.results[1]["status"] == "failed: TypeError: unknown parameter"
    sw = vd.sweep(_raises_runtime_error, {"k1": [800.0]}, progress=False)
    assert sw.results[0]["status"] == "failed: RuntimeError: the user's own failure"


def test_sweep_stores_are_checked_before_any_work_and_never_mixed(tmp_path):
    with pytest.raises(vd.ModelError, match="no such directory"):
        vd.sweep(examples.chain, {"k1": [800.0]}, store=tmp_path / "missing" / "s.jsonl", progress=False)
    store = tmp_path / "s.jsonl"
    vd.sweep(examples.chain, {"k1": [800.0, 1000.0]}, store=store, progress=False)
    # another analysis on the same store is refused, not answered with the old outputs
    with pytest.raises(vd.ModelError, match="made by another sweep"):
        vd.sweep(examples.chain, {"k1": [800.0, 1000.0]}, analysis="equilibrium", store=store, progress=False)
    # a run cut mid-line: the next resume drops the cut line and appends cleanly after it
    text = store.read_text()
    store.write_text(text + '{"key": "{\\"k1\\": 1200.0}", "resu')
    sw = vd.sweep(examples.chain, {"k1": [800.0, 1000.0, 1200.0]}, store=store, progress=False)
    assert sw.ok.all()
    again = vd.sweep(examples.chain, {"k1": [800.0, 1000.0, 1200.0]}, store=store, progress=False)
    assert again.results == sw.results
    # a record whose result is not one is named by its line
    bad = tmp_path / "bad.jsonl"
    bad.write_text(store.read_text().splitlines()[0] + '\n{"key": "{}", "result": null}\n{"key": "x", "result": {}}\n')
    with pytest.raises(vd.ModelError, match="line 2 is not a sweep record"):
        vd.sweep(examples.chain, {"k1": [800.0]}, store=bad, progress=False)


def test_a_lambda_build_for_processes_is_refused_with_the_reason():
    with pytest.raises(vd.ModelError, match="cannot be sent to worker processes.*module level"):
        vd.sweep(lambda k1: examples.chain(k1=k1), {"k1": [800.0]}, executor="processes", progress=False)


def test_systems_and_modes_pickle_for_workers():
    """A built System (and its results) goes to a process pool or a Dask worker: pickled and back, it computes
    the same modes (its workspaces are made anew)."""
    import pickle

    system = examples.chain(k1=900.0).build()
    m = system.linearize(system.neutral()).modes()
    copy = pickle.loads(pickle.dumps(system))
    assert np.array_equal(copy.linearize(copy.neutral()).modes().omega, m.omega)
    assert np.array_equal(pickle.loads(pickle.dumps(m)).omega, m.omega)
    with pytest.raises(AttributeError, match="immutable"):
        copy.nv = 3
