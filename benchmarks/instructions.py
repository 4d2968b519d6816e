"""Instructions per call of before/after cases (valgrind's callgrind): deterministic where times move by ±10 %.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.instructions BEFORE_DIR AFTER_DIR --calls 3 --only NAME ...

Each case of :data:`benchmarks.before_after.CASES` runs under callgrind in a fresh interpreter per checkout
(``PYTHONPATH=<dir>``): its set-up and 3 warm-up calls, then ``--calls`` more; the instructions per call are the
total less that of the same run with no more calls, over ``--calls``. Needs ``valgrind``; slow (about 50× a plain
run), so give the cases with ``--only``.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile

from .before_after import CASES


def instructions(source: str, name: str, calls: int) -> float:
    """Instructions per call of the case ``name`` on the checkout at ``source``."""
    setup, statement, _ = CASES[name]
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([source, here]), OPENBLAS_NUM_THREADS="1")
    totals = []
    for n in (0, calls):
        code = ("import warnings\nwarnings.simplefilter('ignore')\nimport vibdyn as vd\n" + setup +
                f"\nfor _ in range(3 + {n}):\n    " + statement + "\n")
        with tempfile.TemporaryDirectory() as d:
            out = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={d}/out", sys.executable,
                                  "-c", code], capture_output=True, text=True, env=env, cwd=source)
        found = re.search(r"Collected : (\d+)", out.stderr)
        if out.returncode or not found:
            raise RuntimeError(f"{name} on {source}: {(out.stderr.strip().splitlines() or ['failed'])[-1]}")
        totals.append(int(found.group(1)))
    return (totals[1] - totals[0]) / calls


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("before")
    p.add_argument("after")
    p.add_argument("--calls", type=int, default=3)
    p.add_argument("--only", nargs="+", required=True)
    args = p.parse_args(argv)
    print("| case | before (M instructions) | after | after/before |\n|---|---|---|---|")
    for name in args.only:
        a, b = (instructions(s, name, args.calls) for s in (args.before, args.after))
        print(f"| {name} | {a / 1e6:.3f} | {b / 1e6:.3f} | {b / a:.3f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
