"""`import vibdyn` loads only the description and the compiled model; analyses, scipy's heavy parts, plots,
the viewer and MuJoCo load on first use, and every public name stays importable from `vibdyn`."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

import vibdyn as vd

HEAVY = ("scipy.linalg", "scipy.integrate", "scipy.signal", "matplotlib", "meshcat", "tqdm", "mujoco", "dask",
         "distributed", "pandas")
LAZY_MODULES = ("vibdyn.simulation.simulate", "vibdyn.simulation.integrators", "vibdyn.analysis.response",
                "vibdyn.analysis.identify", "vibdyn.faces.plots", "vibdyn.studies.sweeps",
                "vibdyn.analysis.campbell_diagram")


def loaded_after(code):
    """Top-level module names in sys.modules after running ``code`` in a fresh interpreter."""
    out = subprocess.run([sys.executable, "-c", code + "\nimport sys, json; print(json.dumps(sorted(sys.modules)))"],
                         capture_output=True, text=True, check=True).stdout
    return set(json.loads(out.splitlines()[-1]))


def test_import_vibdyn_loads_no_heavy_module():
    mods = loaded_after("import vibdyn")
    assert not [m for m in mods if m.split(".")[0] in HEAVY or m.startswith(HEAVY)]
    assert not [m for m in mods if m.startswith(LAZY_MODULES)]


def test_first_use_loads_the_module():
    mods = loaded_after("import vibdyn\nvibdyn.Trajectory")
    assert "vibdyn.simulation.simulate" in mods and "vibdyn.simulation.integrators" in mods
    # scipy.integrate (its public Radau and BDF) only once an implicit method runs
    assert "scipy.integrate" not in mods
    code = ("import vibdyn\ns = vibdyn.load_scene({!r}).build()\ns.simulate(0.01, method={!r})")
    scene = str(Path(__file__).resolve().parents[1] / "models" / "iftomm_a01.toml")
    assert "scipy.integrate" not in loaded_after(code.format(scene, "dop853"))
    assert "scipy.integrate" in loaded_after(code.format(scene, "radau"))


@pytest.mark.parametrize("name", vd.__all__)
def test_every_public_name_is_importable(name):
    assert getattr(vd, name) is not None
    namespace = {}
    exec(f"from vibdyn import {name}", namespace)
    assert namespace[name] is getattr(vd, name)


def test_lazy_names_are_the_defining_modules_objects():
    from vibdyn.analysis.linearize import LinearModel
    from vibdyn.analysis.response import FRF
    from vibdyn.simulation.simulate import SimulationError

    assert vd.FRF is FRF and vd.LinearModel is LinearModel and vd.SimulationError is SimulationError
    assert issubclass(vd.SimulationError, vd.ConvergenceError)
    assert set(vd.__all__) <= set(dir(vd))
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        vd.nonsense  # noqa: B018
