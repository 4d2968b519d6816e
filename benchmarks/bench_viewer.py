#!/usr/bin/env python
"""Benchmark of the viewer: time to write the offline page of an n-body chain (target: 30 bodies < 2 s).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_viewer.py [--bodies 30] [--repeat 3]

The chain: n pivots about y, links of 0.1 m and 0.1 kg (rod inertia) hanging along −z, a torsion spring
of 10 N·m/rad on every pivot and a spring + damper from each mass to a wall. The time covers everything
``vd.export_html(scene, path)`` does: build, equilibrium, linearisation, all modes, the drawing, one
animation per mode and the page (best of the repeats, time.perf_counter).
"""

import argparse
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import vibdyn as vd


def chain(n):
    s = vd.Scene(f"chain{n}", gravity=(0, 0, -9.81))
    parent = "world"
    for i in range(n):
        name = f"link{i}"
        s.add_body(name, parent=parent, joint=vd.Pivot((0, 1, 0), at=(0, 0, -0.1 if i else 0.0)), mass=0.1,
                   com=(0, 0, -0.05), inertia=vd.inertia.rod(0.1, 0.1, axis=(0, 0, 1)))
        s.add_joint_spring(name, 10.0)
        s.add_spring(f"k{i}", ("world", (-0.5, 0, -0.1 * (i + 1))), (name, (0, 0, -0.1)), stiffness=5.0)
        s.add_damper(f"c{i}", ("world", (-0.5, 0, -0.1 * (i + 1) + 0.03)), (name, (0, 0, -0.07)), damping=0.1)
        parent = name
    return s


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bodies", type=int, default=30)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    scene = chain(args.bodies)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "chain.html"
        times = []
        for _ in range(args.repeat):
            t = time.perf_counter()
            vd.export_html(scene, path)
            times.append(time.perf_counter() - t)
        size = path.stat().st_size
    print(f"export_html of a {args.bodies}-body chain ({args.bodies} modes, {2 * args.bodies} springs/dampers): "
          f"best {min(times):.3f} s of {args.repeat} (target < 2 s), page {size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
