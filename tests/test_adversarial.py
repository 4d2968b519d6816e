"""The adversarial run (benchmarks/adversarial.py, issue 11) as tests: every bad input, hostile file, numerical
extreme and simulation fault it tries ends clear — a vibdyn error, or a result its own check accepts — never
silently wrong, with a raw exception, or hung. Each case runs in its own process (a crash or a hang is caught
there), so the script cannot go stale unnoticed (it once asked for a removed attribute)."""

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import adversarial  # noqa: E402


@pytest.mark.parametrize("name", list(adversarial.CASES))
def test_the_case_ends_clear(name):
    kind, detail = adversarial.run_case(name, adversarial.CASES[name], timeout=300)
    assert kind == "clear", f"{name}: {kind}: {detail}"
