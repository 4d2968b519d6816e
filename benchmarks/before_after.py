"""Before/after timings of a change: the same user-facing calls timed on two checkouts of vibdyn, alternately.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.before_after BEFORE_DIR AFTER_DIR [--rounds 3] [--only NAME ...]

Each case runs in a fresh interpreter per checkout (``PYTHONPATH=<dir>``), its set-up untimed, its statement
timed best of ``repeat`` calls; the checkouts alternate round by round (the machine's load hits both alike)
and the best of the rounds is kept. Prints a Markdown table (ms, after/before) and writes JSON beside it
with ``--json PATH``. A case that fails on one side says so instead of a time (a renamed name, for instance).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import textwrap

# name -> (set-up, statement, repeats): the calls users wait for, across the layers a change may touch
CASES = {
    "chain10 linearize+modes fd": (
        "from benchmarks.bench_linearize import pendulum_chain\ns = pendulum_chain(10).build(); q = s.neutral()",
        "s.linearize(q).modes()", 40),
    "chain10 linearize+modes analytic": (
        "from benchmarks.bench_linearize import pendulum_chain\ns = pendulum_chain(10).build(); q = s.neutral()",
        "s.linearize(q, method='analytic').modes()", 40),
    "chain100 linearize analytic": (
        "from benchmarks.bench_linearize import pendulum_chain\ns = pendulum_chain(100).build(); q = s.neutral()",
        "s.linearize(q, method='analytic')", 5),
    "build chain100": (
        "from benchmarks.bench_linearize import pendulum_chain\nsc = pendulum_chain(100)", "sc.build()", 5),
    "four_bar operating point+modes (loops)": (
        "s = vd.load_scene('four_bar').build()", "s.operating_point().linearize().modes()", 5),
    "trammel operating point+modes (loops)": (
        "s = vd.load_scene('trammel').build()", "s.operating_point().linearize().modes()", 5),
    "shaken_pendulum linearize (drives)": (
        "s = vd.load_scene('shaken_pendulum').build(); q = s.neutral()", "s.linearize(q, t=0.1).modes()", 20),
    "gimbal campbell 31 speeds": (
        "import numpy as np\ns = vd.load_scene('gimbal_rotor').build(); w = np.linspace(0, 150, 31)",
        "vd.campbell(s, 'rotor', w)", 3),
    "rotor_slider operating point+modes": (
        "s = vd.load_scene('rotor_slider').build()", "s.operating_point().linearize().modes()", 10),
    "three_storey receptance 400 freqs": (
        "import numpy as np\nlin = vd.load_scene('three_storey_building').build().linearize()\n"
        "w = np.linspace(1, 60, 400)", "lin.receptance(w)", 10),
    "double_pendulum simulate 2 s": (
        "s = vd.load_scene('double_pendulum').build(); q = s.configuration([0.5, 0.3])",
        "s.simulate(2.0, q)", 3),
    "andrews_squeezer simulate 1e-3 s (loops)": (
        "s = vd.load_scene('andrews_squeezer').build()", "s.simulate(1e-3)", 2),
    "rod_pivot periodic orbit 0.5 rad": (
        "s = vd.load_scene('rod_pivot').build(); q = s.configuration([0.5])",
        "vd.periodic_orbit(s, q0=q)", 2),
    "rod_pivot backbone 1 request": (
        "s = vd.load_scene('rod_pivot').build()", "vd.backbone(s, 0, energies=[0.01])", 1),
    "duffing forced response curve": (
        "s = vd.load_scene('duffing').build()",
        "vd.forced_response_curve(s, ('mass', 0.1), (0.5, 2.0), 'mass')", 1),
    "rotor_slider sensitivity (stiffness)": (
        "s = vd.load_scene('rotor_slider').build()", "vd.sensitivity(s, ['radial_spring.stiffness'])", 3),
    "two_mass_cubic simulate 50 s": (
        "s = vd.load_scene('two_mass_cubic').build(); q = s.configuration([1.3, 2.2])",
        "s.simulate(50.0, q)", 2),
    "ball pendulum simulate 5 s with Φ": (
        "from benchmarks.nonlinear_speed import ball_point_spring\nimport numpy as np\n"
        "s = ball_point_spring(); q = s.integrate(s.neutral(), np.array([0.3, 0.5, 0.2]))",
        "s.simulate(5.0, q, variational=True)", 2),
    "ball chain simulate 1 s": (
        "from benchmarks.bench_simulate import ball_chain\nimport numpy as np\n"
        "s = ball_chain(5); q = s.integrate(s.neutral(), 0.2 * np.ones(s.nv))", "s.simulate(1.0, q)", 2),
}

# described looped scenes with no start: their assembly (issue 40 item 4's branch enumeration) runs at build
_RZ = "def rz(t):\n    return np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1.0]])\n"
_WATT = ("import numpy as np\n" + _RZ +
         "def watt(rotation):\n"
         "    s, I = vd.Scene('watt', gravity=(0, -9.81, 0)), np.diag([1e-5, 1e-3, 1e-3])\n"
         "    s.add_body('crank', joint=vd.Pivot((0, 0, 1), rotation=rz(rotation)), mass=1.0, com=(0.05, 0, 0),"
         " inertia=I)\n"
         "    s.add_body('coupler', parent='crank', joint=vd.Pivot((0, 0, 1), at=(0.1, 0, 0)), mass=0.5,"
         " com=(0.15, 0, 0), inertia=I)\n"
         "    s.add_body('link5', parent='coupler', joint=vd.Pivot((0, 0, 1), at=(0.15, 0.05, 0)), mass=0.3,"
         " com=(0.1, 0, 0), inertia=I)\n"
         "    s.add_body('rocker', joint=vd.Pivot((0, 0, 1), at=(0.3, 0, 0)), mass=0.8, com=(0.125, 0, 0), inertia=I)\n"
         "    s.add_body('link6', parent='rocker', joint=vd.Pivot((0, 0, 1), at=(0.125, -0.05, 0)), mass=0.3,"
         " com=(0.1, 0, 0), inertia=I)\n"
         "    s.add_loop('C', ('coupler', (0.3, 0, 0)), ('rocker', (0.25, 0, 0)), joint=vd.Pivot((0, 0, 1)))\n"
         "    s.add_loop('G', ('link5', (0.2, 0, 0)), ('link6', (0.2, 0, 0)), joint=vd.Pivot((0, 0, 1)))\n"
         "    return s\n")
_SLIDER_CRANK = ("import numpy as np\n" + _RZ +
                 "s = vd.Scene('slider_crank_drawn', gravity=(0, -9.81, 0))\n"
                 "s.add_body('crank', joint=vd.Pivot((0, 0, 1), rotation=rz(1.8)), mass=1.0, com=(0.05, 0, 0),"
                 " inertia=np.diag([1e-5, 1e-3, 1e-3]))\n"
                 "s.add_body('rod', parent='crank', joint=vd.Pivot((0, 0, 1), at=(0.1, 0, 0)), mass=0.5,"
                 " com=(0.15, 0, 0), inertia=np.diag([1e-5, 4e-3, 4e-3]))\n"
                 "s.add_body('piston', joint=vd.Slider((1, 0, 0), at=(0.3, 0, 0)), mass=2.0)\n"
                 "s.add_loop('pin', ('rod', (0.3, 0, 0)), ('piston', (0, 0, 0)), joint=vd.Pivot((0, 0, 1)))\n")
CASES.update({
    "four_bar assembly, no start (loops)": (
        "sc = vd.load_scene('four_bar'); sc.operating_point = None", "sc.build()", 3),
    "trammel assembly, no start (loops)": (
        "sc = vd.load_scene('trammel'); sc.operating_point = None", "sc.build()", 3),
    "slider-crank drawn at 1.8 rad assembly (loops)": (_SLIDER_CRANK, "s.build()", 3),
    "Watt six-bar assembly (loops)": (_WATT + "sc = watt(0.0)", "sc.build()", 3),
})

RUNNER = """
import json, sys, time, warnings
warnings.simplefilter("ignore")
import vibdyn as vd
{setup}
best = float("inf")
for _ in range({repeat}):
    t = time.perf_counter()
    {statement}
    best = min(best, time.perf_counter() - t)
print(json.dumps(best))
"""


def time_case(source: str, name: str) -> float | str:
    """Best time (s) of the case on the checkout at ``source``, or the last line of its error."""
    setup, statement, repeat = CASES[name]
    code = RUNNER.format(setup=setup, statement=textwrap.indent(statement, "    ").strip(), repeat=repeat)
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([source, here]), OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=source)
    if out.returncode:
        return (out.stderr.strip().splitlines() or ["failed"])[-1][:120]
    return float(json.loads(out.stdout.strip().splitlines()[-1]))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("before")
    p.add_argument("after")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--only", nargs="*")
    p.add_argument("--json")
    a = p.parse_args(argv)
    names = [n for n in CASES if not a.only or any(o in n for o in a.only)]
    best: dict = {n: {"before": float("inf"), "after": float("inf")} for n in names}
    for r in range(a.rounds):
        for n in names:
            for side in (("before", "after") if r % 2 == 0 else ("after", "before")):
                t = time_case(getattr(a, side), n)
                if isinstance(t, str):
                    best[n][side] = t
                elif not isinstance(best[n][side], str):
                    best[n][side] = min(best[n][side], t)
    print("| case | before (ms) | after (ms) | after/before |\n|---|---|---|---|")
    for n in names:
        b, f = best[n]["before"], best[n]["after"]
        if isinstance(b, str) or isinstance(f, str):
            print(f"| {n} | {b if isinstance(b, str) else f'{b * 1e3:.2f}'} | "
                  f"{f if isinstance(f, str) else f'{f * 1e3:.2f}'} | — |")
        else:
            print(f"| {n} | {b * 1e3:.2f} | {f * 1e3:.2f} | {f / b:.2f} |")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(best, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
