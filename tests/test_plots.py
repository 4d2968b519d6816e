"""Plots and the ``vibdyn frf`` command: PNG files that exist and are not blank; matplotlib stays out of
``import vibdyn``."""

import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import MODELS

import vibdyn as vd
from vibdyn.faces.cli import main
from vibdyn.results import TimeResult

matplotlib = pytest.importorskip("matplotlib")


def assert_png(path, min_bytes=5000):
    from matplotlib.image import imread

    assert path.exists() and path.stat().st_size > min_bytes
    img = imread(path)
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    assert float(img[..., :3].var()) > 1e-3  # not blank


def test_import_vibdyn_does_not_import_matplotlib():
    code = ("import sys, vibdyn, vibdyn.faces.plots, vibdyn.analysis.response, vibdyn.analysis.identify; "
            "print('matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_cli_frf_writes_bode_and_nyquist_pngs(tmp_path, capsys):
    bode, nyq = tmp_path / "bode.png", tmp_path / "nyquist.png"
    model = str(MODELS / "receptance_damped.toml")
    assert main(["frf", model, "--input", "m1", "--output", "m1", "--png", str(bode), "--nyquist", str(nyq)]) == 0
    out = capsys.readouterr().out
    assert "resonance" in out and "0.9452737" in out and "3.352711" in out and "anti-resonance" in out
    assert_png(bode)
    assert_png(nyq)


def test_cli_frf_json_with_point_channels(capsys):
    model = str(MODELS / "receptance_damped.toml")
    ref = vd.load_scene(MODELS / "receptance_damped.toml").references
    assert main(["frf", model, "--input", "m1:0,0,0:1,0,0", "--output", "m1", "--from", "0.2", "--to", "5",
                 "--points", "80", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(d["peaks"]["resonances_rad_s"], ref["peaks_alpha11"], rtol=1e-7)
    np.testing.assert_allclose(d["peaks"]["antiresonances_rad_s"], [ref["antiresonance_alpha11"]], rtol=1e-7)
    assert d["units"] == "m/N" and len(d["omega_rad_s"]) == 80 and d["relative_error"] < 1e-8
    assert d["inputs"] == ["m1(0,0,0)·(1,0,0)"] and d["elapsed_s"] > 0


def test_cli_frf_transmissibility_and_errors(tmp_path, capsys):
    scene = tmp_path / "base.toml"
    scene.write_text('[[support]]\nname = "ground"\n'
                     'motion = { law = "harmonic_motion", amplitude = [0.0, 0.0, 0.01], omega = 15.0 }\n'
                     '[[body]]\nname = "mass"\nmass = 2.0\n'
                     'joint = { type = "slider", axis = [0, 0, 1], at = [0, 0, 1] }\n'
                     '[[spring]]\nname = "k"\na = ["ground", [0, 0, 0]]\nb = "mass"\nstiffness = 800.0\n'
                     '[[damper]]\nname = "c"\na = ["ground", [0, 0, 0]]\nb = "mass"\ndamping = 8.0\n')
    assert main(["frf", str(scene), "--input", "support:ground:0,0,1", "--output", "mass", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    w = np.array(d["omega_rad_s"])
    H = np.array(d["alpha"])[:, 0, 0, :]
    np.testing.assert_allclose(np.hypot(H[:, 0], H[:, 1]), vd.transmissibility(w / 20.0, 0.1), rtol=1e-8)
    assert main(["frf", str(scene), "--input", "mass:0,0:1,0,0", "--output", "mass"]) == 2
    assert "not three comma-separated numbers" in capsys.readouterr().err


def test_mode_shape_and_time_history_plots(tmp_path):
    lin = vd.load_scene(MODELS / "two_mass_modal.toml").build().linearize()
    modes = lin.modes()
    fig = vd.plots.mode_shapes(modes, points=["m1", "m2"], direction=(1, 0, 0), path=tmp_path / "modes.png")
    assert len(fig.axes) == 2
    assert_png(tmp_path / "modes.png")
    r = lin.free_response(np.linspace(0, 20, 400), [0.0, 1.0])
    vd.plots.time_history(r, path=tmp_path / "t.png")
    assert_png(tmp_path / "t.png")
    frf = lin.with_modal_damping(0.05).receptance(np.geomspace(0.5, 5, 200), "m2", ["m1", "m2"])
    fig = vd.plots.bode(frf, "m1", "m2", quantity="accelerance", hz=True, db=True, path=tmp_path / "b.png")
    assert_png(tmp_path / "b.png")
    with pytest.raises(vd.ModelError, match="need a direction"):
        vd.plots.mode_shapes(modes, points=["m1"])


def test_time_history_takes_a_time_response_and_a_trajectory(tmp_path):
    """One time-result protocol: the linear free response and the nonlinear simulation of the same linear
    scene (sliders and springs along x) draw the same curves, each within its own error estimate."""
    system = vd.load_scene(MODELS / "two_mass_modal.toml").build()
    t = np.linspace(0.0, 5.0, 101)
    x0 = np.array([0.0, 0.1])
    r = system.linearize().free_response(t, x0)
    traj = system.simulate(5.0, q0=system.integrate(system.neutral(), x0), t_eval=t, rtol=1e-10, error_method="rerun")
    curves = {}
    for name, result in (("response", r), ("trajectory", traj)):
        assert isinstance(result, TimeResult) and result.coordinates == ("m1", "m2") and result.units == ("m", "m")
        for quantity, unit in (("displacement", "m"), ("velocity", "m/s"), ("acceleration", "m/s²")):
            fig = vd.plots.time_history(result, ["m2", "m1"], quantity=quantity, path=tmp_path / f"{name}.png")
            lines = fig.axes[0].lines
            assert [line.get_label() for line in lines] == [f"m2 ({unit})", f"m1 ({unit})"]
            np.testing.assert_array_equal(lines[0].get_xdata(), t)
            curves[name, quantity] = np.column_stack([line.get_ydata() for line in lines])
        assert_png(tmp_path / f"{name}.png")
        assert set(result.to_dict()) >= {"t_s", "coordinates", "units", result.position_name, "v", "a", "method",
                                         "error_estimate", "elapsed_s"}
        assert result.position_name == ("x" if name == "response" else "q")
    np.testing.assert_array_equal(curves["response", "velocity"], r.v[:, ::-1])
    np.testing.assert_array_equal(curves["trajectory", "velocity"], traj.v[:, ::-1])
    # the same motion: the linear model's error is relative to max|δq|, the simulation's absolute
    tol_q = r.error + traj.error
    assert np.abs(curves["trajectory", "displacement"] - curves["response", "displacement"]).max() <= tol_q
    assert np.abs(curves["trajectory", "velocity"] - curves["response", "velocity"]).max() <= (
        r.relative_error * np.abs(r.v).max() + traj.velocity_error)
    # accelerations from the equations of motion: a = −M⁻¹K δq for this linear scene, at the simulated states
    lin = system.linearize()
    np.testing.assert_allclose(traj.a, -np.linalg.solve(lin.M, lin.K @ (traj.q - system.neutral()).T).T,
                               atol=10 * np.finfo(float).eps * np.abs(traj.a).max() * np.linalg.cond(lin.M)
                               + np.abs(lin.K_error).max() * np.abs(traj.q - system.neutral()).max())
    with pytest.raises(vd.ModelError, match="coordinate names"):
        vd.plots.time_history(traj, [("m1", (0, 0, 0), (1, 0, 0))])
    with pytest.raises(vd.ModelError, match="quantity must be"):
        traj.plot(quantity="jerk")
