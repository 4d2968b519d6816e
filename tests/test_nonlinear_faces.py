"""Faces of the nonlinear analyses: the ``frc``, ``floquet`` and ``backbone`` commands on the bundled nonlinear
models (tables, JSON, PNG), the forced-response and frequency–energy plots, and the viewer pages of an orbit
(the real motion over one period: its frames move the body by the orbit's amplitude).

Oracles: the single-harmonic closed form of the Duffing oscillator (models/duffing.toml's reference: folds and
peak), the conservation of phase-space volume (|μ| = 1 for the undamped shaken pendulum) and Kapitza's
threshold a²Ω² = 2 g l_eq for the inverted one.
"""

import json
import math
import re

import numpy as np
import pytest
from conftest import MODELS
from oracles import cli as run

import vibdyn as vd

matplotlib = pytest.importorskip("matplotlib")


def assert_png(path, min_bytes=5000):
    from matplotlib.image import imread

    assert path.exists() and path.stat().st_size > min_bytes
    img = imread(path)
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    assert float(img[..., :3].var()) > 1e-3  # not blank


def animations(path):
    text = path.read_text(encoding="utf-8")
    return json.loads(re.search(r'id="vd-animations">(.*?)</script>', text, re.S).group(1).replace("<\\/", "</"))


def track(anim, body, name):
    """(times, values) of one body's track in a page's animation."""
    clip = next(c for c in anim if c["path"].endswith(f"/bodies/{body}"))
    tr = next(t for t in clip["clip"]["tracks"] if t["name"] == name)
    width = 3 if tr["type"] == "vector3" else 4
    return np.array(tr["times"]), np.array(tr["values"]).reshape(-1, width)


@pytest.fixture(scope="module")
def duffing():
    return vd.load_scene("duffing").build()


@pytest.fixture(scope="module")
def duffing_reference():
    return vd.load_scene("duffing").references


# ---------------------------------------------------------------------------------------------- frc
def test_frc_at_one_harmonic_is_the_closed_form(tmp_path, duffing_reference):
    """H = 1: the folds and the peak are those of [(k − mΩ² + ¾k₃a²)² + (cΩ)²]a² = F² (the reference's numbers);
    the JSON says every number's unit and error, and the PNG is drawn."""
    ref = duffing_reference
    png = tmp_path / "frc.png"
    code, out, err = run(["frc", "duffing", "--force", f"mass:{ref['force']}", "--omega", "0.5:2", "--harmonics", 1,
                          "--json", "--png", png])
    assert code == 0, err
    data = json.loads(out)
    for key in ("scene", "coordinate", "unit", "excitation", "harmonics", "omega_rad_s", "frequency_hz",
                "amplitude", "amplitude_error", "max_multiplier_modulus", "multiplier_error", "stability", "peak",
                "folds", "status", "elapsed_s"):
        assert key in data, key
    assert data["unit"] == "m" and data["harmonics"] == 1 and data["status"] == "finished"
    folds = sorted(data["folds"], key=lambda f: f["omega_rad_s"])
    assert len(folds) == 2
    for f, w, a in zip(folds, ref["fold_omega"], ref["fold_amplitude"]):
        # the H = 1 balance IS the closed form: they agree to the continuation's tolerance (1e-11 of the force)
        assert abs(f["omega_rad_s"] - w) < 1e-7 and abs(f["amplitude"] - a) < 1e-7
    assert abs(data["peak"]["omega_rad_s"] - ref["peak_omega"]) < 1e-7
    assert abs(data["peak"]["amplitude"] - ref["peak_amplitude"]) < 1e-7
    # between the folds, the middle branch is the unstable one (Hill)
    w = np.array(data["omega_rad_s"])
    between = (w > folds[0]["omega_rad_s"]) & (w < folds[1]["omega_rad_s"])
    assert "unstable" in np.array(data["stability"])[between]
    assert_png(png)


def test_frc_table_says_what_each_number_is(duffing_reference):
    code, out, err = run(["frc", "duffing", "--force", "mass:0.1", "--omega", "0.8:1.4"])
    assert code == 0, err
    for words in ("peak: amplitude", "fold: Ω =", "rad/s", "Hz", "amplitude m", "max |μ|", "± |μ|", "unstable"):
        assert words in out, words
    assert "nan" not in out.lower().split()


@pytest.mark.parametrize("args, words", [
    (["--force", "mass:x", "--omega", "0.5:2"], "--force 'mass:x': expected NAME:AMPLITUDE"),
    (["--force", "nope:0.1", "--omega", "0.5:2"], "no coordinate 'nope'"),
    (["--force", "mass:0.1", "--omega", "2:1"], "increasing pair"),
    (["--force", "mass:0.1", "--omega", "1"], "--omega '1': expected LO:HI"),
    (["--force", "mass:0", "--omega", "0.5:2"], "force"),
    (["--force", "mass:0.1", "--omega", "0.5:2", "--coordinate", "q"], "--coordinate 'q'"),
    (["--force", "mass:0.1", "--omega", "0.5:2", "--harmonics", "0"], "harmonics"),
])
def test_frc_bad_input_is_named(args, words):
    code, out, err = run(["frc", "duffing", *args])
    assert code == 2 and err.startswith("vibdyn: error:") and words in err, err


def test_frc_refuses_a_driven_scene():
    code, _, err = run(["frc", "shaken_pendulum", "--force", "pend:0.1", "--omega", "1:2"])
    assert code == 2 and "drives" in err


# ---------------------------------------------------------------------------------------------- floquet
def shaken_file(tmp_path, omega):
    """The bundled shaken pendulum with the drive at ``omega`` (rad/s)."""
    text = (MODELS / "shaken_pendulum.toml").read_text(encoding="utf-8")
    assert "omega = 70.0 }" in text
    path = tmp_path / f"shaken_{omega:g}.toml"
    path.write_text(text.replace("omega = 70.0 }", f"omega = {omega!r} }}"), encoding="utf-8")
    return path


def test_floquet_inverted_pendulum_above_and_below_kapitza(tmp_path):
    """Inverted (θ = π): held up above Kapitza's threshold Ω_K = √(2 g l_eq)/a — both |μ| = 1 within their error
    (an undamped Hamiltonian orbit: μ₁μ₂ = 1) — and falling below it (|μ| > 1 beyond the error); the period is
    the drive's 2π/Ω."""
    ref = vd.load_scene("shaken_pendulum").references
    omega_k = ref["omega_kapitza"]
    above = ["floquet", "shaken_pendulum", "--start", f"pend={math.pi!r}", "--json"]
    code, out, err = run(above)
    assert code == 0, err
    data = json.loads(out)
    for key in ("scene", "start", "period_source", "period_s", "omega_rad_s", "multipliers", "multiplier_error",
                "stability", "liouville", "error_estimate", "elapsed_s"):
        assert key in data, key
    assert data["omega_rad_s"] > omega_k
    assert abs(data["period_s"] - 2 * math.pi / ref["drive_omega"]) <= data["period_error_s"] + 1e-15
    mods = np.hypot(*np.array(data["multipliers"]).T)
    assert np.all(np.abs(mods - 1) <= np.array(data["multiplier_error"]))
    assert data["stability"] == "neutral within the error"
    below = shaken_file(tmp_path, 0.6 * omega_k)
    code, out, err = run(["floquet", below, "--start", f"pend={math.pi!r}"])
    assert code == 0, err
    assert "unstable" in out and "|μ|" in out and "Liouville" in out
    g, e = (float(x) for x in re.search(r"largest \|μ\| − 1 = (\S+) ± ([^\s:]+)", out).groups())
    assert g > e


def test_floquet_table_of_the_hanging_pendulum_says_within_the_error():
    code, out, err = run(["floquet", "shaken_pendulum"])
    assert code == 0, err
    assert "period the forcing's 2π/ω" in out and "(within the error)" in out and "rad/s" in out


@pytest.mark.parametrize("argv, words", [
    (["floquet", "duffing"], "equilibrium"),
    (["floquet", "shaken_pendulum", "--period", "-1"], "period"),
    (["floquet", "rod_pivot", "--start", "rod=1", "--velocity", "zz=1"], "--velocity zz"),
    (["floquet", "rod_pivot", "--start", "rod=1", "--velocity", "rod"], "expected NAME=VALUE"),
    (["floquet", "four_bar"], "closed loops"),
])
def test_floquet_bad_input_is_named(argv, words):
    code, out, err = run(argv)
    assert code == 2 and err.startswith("vibdyn: error:") and words in err, err


# ---------------------------------------------------------------------------------------------- plots, viewer
def test_forced_response_plot_and_bad_path(tmp_path, duffing):
    curve = vd.forced_response_curve(duffing, ("mass", 0.1), (0.8, 1.4), "mass", harmonics=3)
    fig = curve.plot(tmp_path / "c.png")
    assert_png(tmp_path / "c.png")
    ax = fig.axes[0]
    assert "amplitude" in ax.get_ylabel() and "(m)" in ax.get_ylabel() and "rad/s" in ax.get_xlabel()
    assert any(line.get_linestyle() == "--" for line in ax.lines)  # the unstable branch
    with pytest.raises(vd.ModelError, match="no such directory"):
        vd.plots.forced_response(curve, path=tmp_path / "missing" / "c.png")


def test_viewer_animates_the_forced_response_motion(tmp_path, duffing):
    """The page of ``curve.orbit(i)`` at the peak: one period of the harmonic-balance motion; the mass's frames
    reach its amplitude (less the sampling's cos(Ω Δt/2) and the 64 samples' interpolation, both second order)."""
    curve = vd.forced_response_curve(duffing, ("mass", 0.1), (0.8, 1.4), "mass")
    i = int(np.argmax(curve.amplitude))
    orbit = curve.orbit(i)
    assert orbit.q.shape == (65, 1) and abs(orbit.t[-1] - 2 * math.pi / curve.omega[i]) < 1e-12
    assert np.allclose(orbit.q[0], orbit.q[-1])
    page = vd.export_html(orbit, tmp_path / "frc.html")
    text = page.read_text(encoding="utf-8")
    assert "forced response at Ω" in text and "set_animation" in text
    t, pos = track(animations(page)[0], "mass", ".position")
    dt = (t[1] - t[0]) * curve.omega[i]  # the frames' spacing in phase (rad)
    sampling = curve.amplitude[i] * ((math.pi / 64) ** 2 + dt**2 / 8) + 1e-6
    rest = duffing.scene.bodies["mass"].joint.at[0] + curve.q_eq[0]  # the slider's placement (m) plus x_eq
    assert abs(np.abs(pos[:, 0] - rest).max() - curve.amplitude[i]) <= sampling + curve.error[i]
    assert t[-1] >= 2.0 - 1e-6  # a period shorter than 2 s is shown over 2 s
    with pytest.raises(vd.ModelError, match="index"):
        curve.orbit(len(curve.omega))


def test_viewer_animates_a_periodic_orbit(tmp_path):
    """A pendulum's orbit from 1 rad: the rod's frames turn it by 1 rad (its quaternion's angle), and the page
    names the orbit's period; the Kapitza page moves the carriage by the drive's ± a."""
    rod = vd.load_scene("rod_pivot").build()
    orbit = vd.periodic_orbit(rod, [1.0], [0.0], phase="rod")
    page = vd.export_html(orbit, tmp_path / "orbit.html")
    assert f"T = {orbit.period:.6g} s" in page.read_text(encoding="utf-8")
    t, quat = track(animations(page)[0], "rod", ".quaternion")
    angle = 2 * np.arctan2(np.linalg.norm(quat[:, :3], axis=1), np.abs(quat[:, 3]))
    dt = (t[1] - t[0]) * orbit.omega
    assert abs(angle.max() - 1.0) <= (math.pi / 128) ** 2 + dt**2 / 8 + 1e-5
    ref = vd.load_scene("shaken_pendulum").references
    kap = vd.floquet(vd.load_scene("shaken_pendulum").build(), 2 * math.pi / ref["drive_omega"], [0.0, math.pi])
    page = vd.export_html(kap, tmp_path / "kapitza.html")
    t, pos = track(animations(page)[0], "cart", ".position")
    a = ref["drive_amplitude"]
    dt = (t[1] - t[0]) * kap.omega
    assert abs(pos[:, 2].max() - a) <= a * ((math.pi / 128) ** 2 + dt**2 / 8) + 1e-6
    assert abs(pos[:, 2].min() + a) <= a * ((math.pi / 128) ** 2 + dt**2 / 8) + 1e-6


# ---------------------------------------------------------------------------------------------- backbone
def elliptic_omega(amplitude):
    """ω (rad/s) of the compound pendulum (rod_pivot) swinging with ``amplitude`` (rad): π ω₀ / (2 K(sin²(A/2)))."""
    from scipy.special import ellipk

    w0 = vd.load_scene("rod_pivot").references["omega"][0]
    return math.pi * w0 / (2 * ellipk(math.sin(amplitude / 2) ** 2))


@pytest.fixture(scope="module")
def pendulum_backbone():
    return vd.backbone(vd.load_scene("rod_pivot").build(), 0, amplitudes=[0.3, 1.0])


def test_backbone_table_is_the_elliptic_integral():
    """Each row's ω is the pendulum's exact ω(A) within the row's own error column; every column says its unit."""
    code, out, err = run(["backbone", "rod_pivot", "--mode", 1, "--amplitudes", "0.3,1"])
    assert code == 0, err
    for words in ("mode 1", "ω_lin = 3.836013556 rad/s", "request: amplitude rad", "energy J", "ω rad/s", "f Hz",
                  "ω/ω_lin", "± ω rad/s", "stability", "neutral within the error", "note:"):
        assert words in out, words
    assert "nan" not in out.lower().split()
    rows = [line.split() for line in out.splitlines() if re.match(r"\s+(0\.3|1)\s", line)]
    assert len(rows) == 2
    for row in rows:
        A, w, f, ratio, e = float(row[1]), float(row[3]), float(row[4]), float(row[5]), float(row[6])
        assert abs(w - elliptic_omega(A)) <= e + 1e-11 * w  # + the table's 12 printed digits
        assert abs(f - w / (2 * math.pi)) <= 1e-9 * f and abs(ratio - w / 3.8360135557633264) <= 1e-9


def test_backbone_json_png_and_html(tmp_path):
    """--json is the Backbone's to_dict (units in the keys), --png the frequency–energy plot, --html the orbit of
    the largest request: the rod's frames turn it by that amplitude (its quaternion's angle)."""
    png, html = tmp_path / "fe.png", tmp_path / "bb.html"
    code, out, err = run(["backbone", "rod_pivot", "--mode", 1, "--energies", "0.5,2", "--json", "--png", png,
                          "--html", html])
    assert code == 0, err
    data = json.loads(out)
    for key in ("scene", "mode", "mode_number", "coordinate", "unit", "requested", "linear_omega_rad_s",
                "omega_rad_s", "omega_error_rad_s", "frequency_hz", "amplitude_rad", "energy_J", "energy_error_J",
                "stability", "resonances", "note", "elapsed_s", "orbits"):
        assert key in data, key
    assert data["requested"] == "energy" and data["mode"] == 0 and data["mode_number"] == 1
    assert np.allclose(data["energy_J"], [0.5, 2.0], rtol=0, atol=1e-9 + max(data["energy_error_J"]))
    for A, w, e in zip(data["amplitude_rad"], data["omega_rad_s"], data["omega_error_rad_s"]):
        assert abs(w - elliptic_omega(A)) <= 1e-6 * w  # the amplitude's own error moves ω(A) by dω/dA·δA
    assert_png(png)
    text = html.read_text(encoding="utf-8")
    assert "backbone of mode 1" in text and "set_animation" in text
    t, quat = track(animations(html)[0], "rod", ".quaternion")
    angle = 2 * np.arctan2(np.linalg.norm(quat[:, :3], axis=1), np.abs(quat[:, 3]))
    A = max(data["amplitude_rad"])
    dt = (t[1] - t[0]) * max(data["omega_rad_s"])
    assert abs(angle.max() - A) <= A * ((math.pi / 128) ** 2 + dt**2 / 8) + 1e-5


def test_frequency_energy_plot(tmp_path, pendulum_backbone):
    """Log energy axis, ω in rad/s with Hz on the right, the linear ω dotted; a request's orbit exports too."""
    bb = pendulum_backbone
    fig = bb.plot(path=tmp_path / "bb.png")
    assert_png(tmp_path / "bb.png")
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and "(J)" in ax.get_xlabel() and "rad/s" in ax.get_ylabel()
    assert any("Hz" in a.get_ylabel() for a in fig.axes[1:] + [c for c in ax.child_axes])
    dotted = [line for line in ax.lines if line.get_linestyle() == ":"]
    assert any(np.allclose(line.get_ydata(), bb.linear_omega) for line in dotted)
    # ω falls with the swing: the marked points are the backbone's own numbers, the solid curve passes through them
    (marked,) = [line for line in ax.lines if line.get_marker() == "o"]
    assert np.allclose(marked.get_xdata(), bb.energy) and np.allclose(marked.get_ydata(), bb.omega)
    (drawn,) = [line for line in ax.lines if line.get_linestyle() == "-" and len(line.get_xdata()) > 2]
    assert np.allclose(np.interp(bb.energy, drawn.get_xdata(), drawn.get_ydata()), bb.omega, rtol=1e-12)
    assert bb.stability == ("neutral within the error",) * 2
    fig2 = vd.plots.frequency_energy([bb, bb], path=tmp_path / "two.png")
    assert_png(tmp_path / "two.png")
    assert len(fig2.axes[0].get_legend().get_texts()) == 3  # two backbones and the one verdict
    page = vd.export_html(bb.orbits[0], tmp_path / "orbit.html")
    assert f"T = {bb.orbits[0].period:.6g} s" in page.read_text(encoding="utf-8")
    with pytest.raises(vd.ModelError, match="no backbone"):
        vd.plots.frequency_energy([])


@pytest.mark.parametrize("argv, words", [
    (["rod_pivot", "--mode", "1", "--amplitudes", "x"], "--amplitudes 'x': expected amplitudes"),
    (["rod_pivot", "--mode", "1", "--amplitudes", "0.5,-1"], "positive and finite"),
    (["rod_pivot", "--mode", "1", "--energies", "nan"], "positive and finite"),
    (["rod_pivot", "--mode", "1", "--amplitudes", "0.5", "--energies", "1"], "not both"),
    (["rod_pivot", "--mode", "0"], "numbered from 1"),
    (["rod_pivot", "--mode", "3", "--amplitudes", "0.5"], "out of range"),
    (["rod_pivot", "--mode", "1", "--coordinate", "zz"], "--coordinate 'zz'"),
    (["shaken_pendulum", "--mode", "1", "--amplitudes", "0.5"], "drives"),
    (["four_bar", "--mode", "1", "--amplitudes", "0.1"], "closed loops"),
])
def test_backbone_bad_input_is_named(argv, words):
    code, out, err = run(["backbone", *argv])
    assert code == 2 and err.startswith("vibdyn: error:") and words in err, err
