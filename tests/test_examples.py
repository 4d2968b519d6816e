"""The gallery (examples/plot_*.py) runs: each example in a fresh temporary working directory, matplotlib's
Agg backend, as the docs build runs it. Each example asserts its own numbers against the book's within
vibdyn's error estimate, so a wrong result fails here even without the docs build; an example with mode
shapes must leave its offline viewer page ``viewer_<topic>.html`` in the working directory and nothing
elsewhere. The Dask example is skipped when dask.distributed is absent."""

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCRIPTS = sorted(EXAMPLES.glob("plot_*.py"))
NEEDS = {"plot_sweep_dask.py": "distributed"}  # optional packages an example needs
NO_VIEWER = {"plot_base_excitation.py", "plot_sweep_dask.py"}  # no mode shapes to show


def test_the_gallery_is_there():
    assert (EXAMPLES / "README.rst").is_file()
    assert len(SCRIPTS) >= 11


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_example_runs(script, tmp_path):
    need = NEEDS.get(script.name)
    if need and importlib.util.find_spec(need) is None:
        pytest.skip(f"{script.name} needs {need}")
    env = dict(os.environ, MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1")
    run = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, f"{script.name} failed:\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}"
    made = {p.name for p in tmp_path.iterdir()}
    topic = script.stem.removeprefix("plot_")
    if script.name not in NO_VIEWER:
        assert f"viewer_{topic}.html" in made, f"{script.name} wrote no viewer page"
    assert made <= {f"viewer_{topic}.html"} | {p for p in made if p.endswith(".png")}, made
