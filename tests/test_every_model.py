"""Every bundled model works with every CLI command (``info``, ``modes``, ``frf``, ``simulate``, ``sensitivity``).

Each command must exit 0, or give one of the explained refusals listed in ``REFUSALS`` (exit 2, a
``vibdyn: error:`` line containing the listed words, no traceback). ``frf`` uses the model's first
coordinate as input and output; ``simulate`` runs 1 s from the neutral configuration at rest (a fast
mechanism runs the span in ``SIM_T``, its benchmark's own scale).
"""


import pytest
from conftest import MODELS
from oracles import cli as run

import vibdyn as vd

FILES = sorted(MODELS.glob("*.toml"))
COMMANDS = ("info", "modes", "frf", "simulate", "sensitivity")
# Andrews' squeezer turns at hundreds of rad/s: its benchmark spans 0.03 s (1 s would take minutes)
SIM_T = {"andrews_squeezer": "0.003"}

# (model, command) -> words the refusal must contain. Each one is a physical impossibility, not a bug.
REFUSALS: dict[tuple[str, str], str] = {}


def argv_for(command, path):
    if command == "frf":
        first = vd.load_scene(path).build().coordinates[0]
        return ["frf", str(path), "--input", first, "--output", first, "--points", "60"]
    if command == "simulate":
        return ["simulate", str(path), "--t-end", SIM_T.get(path.stem, "1"), "--no-progress"]
    return [command, str(path)]


def test_every_model_is_listed():
    assert len(FILES) >= 17
    stale = {m for m, _ in REFUSALS} - {p.stem for p in FILES}
    assert not stale, f"refusals listed for models that do not exist: {stale}"


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_command_on_model(path, command):
    code, out, err = run(argv_for(command, path))
    expected = REFUSALS.get((path.stem, command))
    if expected is None:
        assert code == 0, f"vibdyn {command} {path.stem} failed: {err.strip()}"
        assert out.strip(), "the command printed nothing"
        assert "nan" not in out.lower().split(), out
    else:
        assert code == 2, f"expected the refusal '{expected}', got exit {code}: {out[-500:]}"
        assert err.startswith("vibdyn: error:") and expected in err, err


# the nonlinear commands, on the models they apply to: frc needs a forced coordinate (and no drive), floquet a start
# off equilibrium or a drive, backbone a conservative scene
NONLINEAR = {
    "duffing": [["frc", "--force", "mass:0.1", "--omega", "0.8:1.4", "--harmonics", "3"],
                ["backbone", "--mode", "1", "--amplitudes", "0.5"]],
    "two_mass_cubic": [["frc", "--force", "m1:0.02", "--omega", "0.8:1.2", "--coordinate", "m2", "--harmonics", "3"],
                       ["floquet", "--start", "m1=0.5", "m2=0.5"]],
    "shaken_pendulum": [["floquet"], ["floquet", "--start", "pend=3.141592653589793"]],
    "rod_pivot": [["floquet", "--start", "rod=1"], ["backbone", "--mode", "1", "--amplitudes", "1"]],
}


@pytest.mark.parametrize("model, argv", [(m, a) for m, runs in NONLINEAR.items() for a in runs],
                         ids=[f"{m}-{' '.join(a[:1] + a[1:3])}" for m, runs in NONLINEAR.items() for a in runs])
def test_nonlinear_command_on_model(model, argv):
    code, out, err = run([argv[0], str(MODELS / f"{model}.toml"), *argv[1:]])
    assert code == 0, f"vibdyn {argv[0]} {model} failed: {err.strip()}"
    assert out.strip() and "nan" not in out.lower().split(), out


# the commands merged with issues 42 and 43 (response spectra, Campbell in rpm) on every model: exit 0 with output,
# or exit 2 with one line naming the cause (a model with rigid modes has no response spectrum, a slider no spin)
RECORD = "\n".join(str(x) for x in [0.0, 1.0, -2.0, 3.0, -1.0, 0.5, 0.0] * 20)
# (model, command) -> why it is expected to fail today (strict: the mark goes when the fault is fixed)
KNOWN: dict = {}  # (both the probe's reports are fixed: the one equilibrium search, the analytic guard)


def argv_new(command, path, tmp):
    if command == "campbell":
        first = vd.load_scene(path).build().coordinates[0]
        return ["campbell", str(path), "--spin", first, "--speeds", "0:300:4", "--rpm"]
    if command == "spectrum-design":
        return ["spectrum", str(path), "--design", "ec8:0.3:B", "--direction", "1", "0", "0", "--json"]
    record = tmp / "record.txt"
    record.write_text(RECORD)
    return ["spectrum", str(path), "--record", str(record), "--dt", "0.01", "--direction", "1", "0", "0"]


@pytest.mark.parametrize("command", ["campbell", "spectrum-design", "spectrum-record"])
@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_new_command_on_model(path, command, tmp_path, request):
    if (path.stem, command) in KNOWN:
        request.applymarker(pytest.mark.xfail(reason=KNOWN[path.stem, command], strict=True))
    code, out, err = run(argv_new(command, path, tmp_path))
    assert "Traceback" not in err, err
    if code == 0:
        assert out.strip() and "nan" not in out.lower().replace('"', " ").replace(",", " ").split(), out
    else:
        assert code == 2, f"vibdyn {command} {path.stem}: exit {code}: {err[-500:]}"
        lines = [x for x in err.splitlines() if x.strip() and "Warning" not in x and not x.startswith("  ")]
        assert len(lines) == 1 and lines[0].startswith("vibdyn: error:"), err
