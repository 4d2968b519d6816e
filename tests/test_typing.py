"""Types: the public API carries type hints, and mypy passes on the package (CI installs mypy with the test
extra: under CI=true a missing mypy fails instead of skipping)."""

import inspect
import os
import subprocess
import sys
from pathlib import Path

import pytest

import vibdyn as vd

ROOT = Path(__file__).resolve().parents[1]

# the classes users call methods on (README), beside vibdyn.__all__'s functions
CLASSES = ["Scene", "System", "LinearModel", "Modes", "Equilibrium", "Trajectory", "FRF", "StateSpace", "Campbell",
           "Sweep"]


def _public_callables():
    for name in vd.__all__:
        obj = getattr(vd, name)
        if inspect.isfunction(obj):
            yield name, obj
    for cls_name in CLASSES:
        cls = getattr(vd, cls_name)
        for name, member in vars(cls).items():
            if name.startswith("_") or not inspect.isfunction(member):
                continue
            yield f"{cls_name}.{name}", member


def test_public_api_has_type_hints():
    missing = []
    for name, f in _public_callables():
        sig = inspect.signature(f)
        bare = [p.name for p in sig.parameters.values()
                if p.name not in ("self", "cls") and p.annotation is inspect.Parameter.empty]
        if bare or sig.return_annotation is inspect.Signature.empty:
            arrow = "" if sig.return_annotation is not inspect.Signature.empty else " -> ?"
            missing.append(f"{name}({', '.join(bare)}){arrow}")
    assert not missing, f"{len(missing)} public callables without full hints:\n  " + "\n  ".join(missing)


def test_mypy_passes_on_the_package():
    try:
        import mypy  # noqa: F401
    except ImportError:
        if os.environ.get("CI"):
            raise
        pytest.skip("mypy is not installed (pip install -e '.[test]')")
    r = subprocess.run([sys.executable, "-m", "mypy", "vibdyn"], cwd=ROOT, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    assert "Success" in r.stdout
