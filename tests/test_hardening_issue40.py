"""Issue 40 (items 6, 7, 9, 12): former names warn at the user's line, raw errors become vibdyn errors naming the
argument, messages name the cause, and a first session's frictions."""

import os
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import vibdyn as vd

# ------------------------------------------------------------------ item 6: former names warn at the caller's line
_SCRIPT = '''
import warnings
from dataclasses import dataclass

import vibdyn as vd
from vibdyn import _deprecation
from vibdyn.description.joints import Pivot, joint_type

s = vd.Scene("p", gravity=(0, 0, -9.81))
s.add_body("rod", joint=vd.Pivot(axis=(1, 0, 0)), mass=1.0, com=(0, 0, -1))
S = s.build()
op = S.equilibrium()
lin = S.linearize(op)
m = lin.modes(tolerance=1e-9)  # W modes(tolerance=
t = S.simulate(0.05, error="local")  # W simulate(error=
_deprecation._warned.clear()  # (each former name warns once per process: vd.simulate shares System.simulate's)
t = vd.simulate(S, 0.05, error="local")  # W simulate(error=
x = vd.equilibrium.steady_motion  # W vibdyn.equilibrium.steady_motion
x = vd.simulate.SimulationError  # W vibdyn.simulate.SimulationError
x = op.tolerance  # W OperatingPoint.tolerance
x = vd.Slider.kind  # W Joint.kind


@joint_type  # W Joint.group
@dataclass(frozen=True, eq=False)
class OldStyle(Pivot):
    type = "old_style"
    group = None
'''


def test_former_names_warn_at_the_callers_line_under_default_filters(tmp_path):
    """Python's default filters show a DeprecationWarning only when attributed to __main__: each former name's
    warning is shown, at the line of the script that used it (they were attributed to vibdyn's own lines and
    hidden for the keywords)."""
    script = tmp_path / "user_script.py"
    script.write_text(_SCRIPT)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
    env["OPENBLAS_NUM_THREADS"] = "1"
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0, run.stderr
    shown = {(int(n), msg) for n, msg in re.findall(r"user_script\.py:(\d+): DeprecationWarning: (.*)", run.stderr)}
    expected = [(i, line.split("# W ")[1]) for i, line in enumerate(_SCRIPT.splitlines(), 1) if "# W " in line]
    assert len(expected) == 8
    for lineno, what in expected:
        assert any(n == lineno and what in msg for n, msg in shown), (lineno, what, run.stderr)
    assert "vibdyn/" not in "".join(re.findall(r"(\S+):\d+: DeprecationWarning", run.stderr))
