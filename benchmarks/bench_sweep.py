"""Sweep scale: 1000 points of a 10-body chain (build + operating point + linearise + all modes), serial,
on a local pool of 2 processes, and on Dask with 2 workers. Reports wall times, the speedup and the
per-point overhead (wall × workers / points − a point's own time, measured where it ran; also against the
serial point time), and extrapolates to a cluster.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_sweep.py [--points N]
"""

import argparse
import json
import os
from pathlib import Path

import numpy as np

import vibdyn as vd
from vibdyn import examples


def main(points=1000):
    grid = {"k": list(np.linspace(500.0, 1500.0, points)), "n": [10.0]}
    out = {"points": points, "cores": os.cpu_count()}
    serial = vd.sweep(examples.chain, grid, progress=False)
    own = float(np.mean([r["elapsed"] for r in serial.results]))
    out["serial_s"], out["point_s"] = serial.elapsed, own
    procs = vd.sweep(examples.chain, grid, executor="processes", progress=False)
    out["processes_s"] = procs.elapsed
    own_in = {"processes": float(np.mean([r["elapsed"] for r in procs.results]))}
    try:
        import distributed

        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                      host="127.0.0.1") as cluster, distributed.Client(cluster) as client:
            # workers up and warm (vibdyn, Pinocchio, scipy imported) before the clock starts, as on a
            # cluster that serves many sweeps
            vd.sweep(examples.chain, {"k": [1000.0, 1100.0, 1200.0, 1300.0]}, executor=client, progress=False,
                     chunksize=1)
            dask = vd.sweep(examples.chain, grid, executor=client, progress=False)
        out["dask_s"] = dask.elapsed
        own_in["dask"] = float(np.mean([r["elapsed"] for r in dask.results]))
        same = [r["outputs"] for r in dask.results] == [r["outputs"] for r in serial.results]
        out["dask_equals_serial"] = same
    except ImportError:
        out["dask_s"] = None
    for k in ("processes", "dask"):
        if out.get(f"{k}_s"):
            out[f"{k}_speedup"] = out["serial_s"] / out[f"{k}_s"]
            # overhead: what the sweep machinery adds to a point's own time as measured where it ran (a
            # worker's point is slower than a serial one when the scheduler and client share the cores:
            # that slowdown is shown apart, as the slowdown and against the serial point time)
            out[f"{k}_point_s"] = own_in[k]
            out[f"{k}_point_slowdown"] = own_in[k] / own
            out[f"{k}_overhead_per_point"] = out[f"{k}_s"] * 2 / points - own_in[k]
            out[f"{k}_overhead_fraction"] = out[f"{k}_overhead_per_point"] / own_in[k]
            out[f"{k}_overhead_fraction_vs_serial_point"] = (out[f"{k}_s"] * 2 / points - own) / own
    # a 100-node cluster of 2-core machines, by the same per-point cost (own time + the Dask overhead)
    per = own + max(out.get("dask_overhead_per_point") or 0.0, 0.0)
    out["extrapolated_1e6_points_on_200_workers_s"] = 1e6 * per / 200
    print(json.dumps(out, indent=1))
    Path(__file__).with_name("results").mkdir(exist_ok=True)
    Path(__file__).with_name("results").joinpath("sweep.json").write_text(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=1000)
    main(ap.parse_args().points)
