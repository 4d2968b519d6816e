"""Issue 34, a light first hour: what a newcomer meets on the base install. load_robot without the robots extra
names the extra; a checkout's path to a bundled model says the bare name loads it."""

import pathlib

import pytest

import vibdyn as vd
from vibdyn.io import robots


def test_load_robot_without_the_robots_extra_names_the_extra(monkeypatch):
    monkeypatch.setattr(robots, "_ROBOTS_DIR", [])  # forget the folder found, and find none (as where it is missing)
    monkeypatch.delenv("EXAMPLE_ROBOT_DATA_MODEL_DIR", raising=False)
    monkeypatch.setattr(pathlib.Path, "is_dir", lambda self: False)
    with pytest.raises(vd.ModelError) as e:
        vd.load_robot("ur5")
    message = str(e.value)
    assert message.startswith("robot 'ur5': the robots of example-robot-data are not installed")
    assert "pip install 'vibdyn[robots]'" in message


def test_a_checkout_path_to_a_bundled_model_names_the_bare_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(vd.SceneFileError) as e:
        vd.load_scene("models/rod_pivot.toml")
    assert "the bundled model 'rod_pivot' loads by its bare name: vd.load_scene('rod_pivot')" in str(e.value)
    assert vd.load_scene("rod_pivot").name == "rod_pivot"


def _docs_module(name):
    import importlib
    import sys

    from conftest import ROOT

    folder = str(ROOT / "docs" / ("_ext" if name == "vibdyn_gallery" else ""))
    sys.path.insert(0, folder)
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(folder)


def test_the_gallery_scraper_leaves_pyplot_figures_to_matplotlibs_scraper(tmp_path):
    """A pyplot figure, closed by matplotlib's scraper, was taken again by vibdyn's (shown twice on the
    four-bar's page); a Figure vibdyn returns (modes.plot()) is vibdyn's scraper's, once."""
    pytest.importorskip("sphinx_gallery", reason="the docs extra")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    gallery = _docs_module("vibdyn_gallery")
    src = tmp_path / "examples" / "plot_x.py"
    src.parent.mkdir()
    src.write_text("", encoding="utf-8")
    (tmp_path / "images").mkdir()
    images = iter(tmp_path / "images" / f"sphx_glr_plot_x_{i:03d}.png" for i in range(1, 10))
    mine = Figure()
    mine.subplots().plot([0, 1], [1, 0])
    drawn, _ = plt.subplots()
    plt.close("all")  # what matplotlib's scraper does after saving it
    scraper = gallery.VibdynScraper()
    for _block in range(2):
        scraper({}, {"src_file": str(src), "example_globals": {"fig": drawn, "fig_mode": mine},
                     "image_path_iterator": images}, {"src_dir": str(tmp_path)})
    assert sorted(p.name for p in (tmp_path / "images").iterdir()) == ["sphx_glr_plot_x_001.png"]


def test_the_site_check_finds_a_figure_shown_twice_and_an_object_repr(tmp_path):
    check_site = _docs_module("check_site")
    page = tmp_path / "auto_examples" / "plot_x.html"
    (tmp_path / "_images").mkdir(parents=True)
    page.parent.mkdir()
    for name, data in (("a", b"one"), ("b", b"one"), ("c", b"two")):
        (tmp_path / "_images" / f"sphx_glr_plot_x_{name}.png").write_bytes(data)
    img = '<img src="../_images/sphx_glr_plot_x_{}.png" alt="" class="sphx-glr-single-img">'
    page.write_text(img.format("a") + img.format("c") + "<pre>&lt;matplotlib.legend.Legend object at 0x7f3a9c&gt;"
                    "</pre>", encoding="utf-8")
    assert check_site.gallery_problems(tmp_path, ["auto_examples/plot_x.html"]) == [
        "auto_examples/plot_x.html: an object's repr in its output: <matplotlib.legend.Legend object at 0x7f3a9c>"]
    page.write_text(img.format("a") + img.format("b") + "<pre>ω = 17.466 rad/s</pre>", encoding="utf-8")
    assert check_site.gallery_problems(tmp_path, ["auto_examples/plot_x.html"]) == [
        "auto_examples/plot_x.html: the same figure shown twice (../_images/sphx_glr_plot_x_a.png and "
        "../_images/sphx_glr_plot_x_b.png)"]


def _distance(points, line, scale):
    """Largest distance (scaled) from each of ``points`` (n × 2) to the polyline ``line`` (m × 2)."""
    import numpy as np

    P, L = np.asarray(points) / scale, np.asarray(line) / scale
    A, AB = L[:-1], np.diff(L, axis=0)
    worst = 0.0
    for p in P:
        t = np.clip(((p - A) * AB).sum(1) / np.maximum((AB * AB).sum(1), 1e-300), 0.0, 1.0)
        worst = max(worst, float(np.min(np.linalg.norm(A + t[:, None] * AB - p, axis=1))))
    return worst


def test_a_forced_response_curve_is_drawn_as_a_curve_through_its_points():
    """Duffing's curve with a coarse step (24 points): the drawn curve (splines of the harmonic coefficients along
    the arc) stays within 1 % of the plot's scale of the curve computed with a fine step (143 points), 4 times
    nearer than the polyline through the coarse points; the coarse points lie on it."""
    import numpy as np

    duffing = vd.load_scene("duffing").build()
    coarse = vd.forced_response_curve(duffing, ("mass", 0.1), (0.5, 2.0), "mass", harmonics=5, step=0.1)
    fine = vd.forced_response_curve(duffing, ("mass", 0.1), (0.5, 2.0), "mass", harmonics=5, step=0.005)
    assert len(coarse.omega) < 30 < 100 < len(fine.omega)
    fig = coarse.plot()
    drawn = [line.get_xydata() for line in fig.axes[0].lines if line.get_linestyle() in ("-", "--")
             and len(line.get_xydata()) > 2]
    curve = np.vstack(drawn)
    assert len(curve) >= 10 * len(coarse.omega)
    scale = np.array([np.ptp(coarse.omega), coarse.amplitude.max()])
    truth = np.c_[fine.omega, fine.amplitude]
    dense, polyline = _distance(truth, curve, scale), _distance(truth, np.c_[coarse.omega, coarse.amplitude], scale)
    assert dense < 0.01 and dense < polyline / 4, (dense, polyline)
    assert _distance(np.c_[coarse.omega, coarse.amplitude], curve, scale) < 1e-12


def test_a_backbone_is_drawn_as_a_curve_through_its_requests():
    """The frequency–energy plot draws ω as a shape-preserving cubic of log energy through the requested orbits:
    through each of them, densely, and without overshoot between two of them."""
    import types

    import numpy as np

    e, w = np.array([0.01, 0.1, 1.0, 10.0]), np.array([1.0009, 1.0090, 1.0659, 1.2069])
    bb = types.SimpleNamespace(energy=e, omega=w, stability=("neutral within the error",) * 4, linear_omega=1.0,
                               mode=0, coordinate="m1", resonances=(), error=np.full(4, 1e-12),
                               system=types.SimpleNamespace(name="two_mass_cubic"))
    fig = vd.plots.frequency_energy(bb)
    (line,) = [ln for ln in fig.axes[0].lines if ln.get_linestyle() == "-" and len(ln.get_xydata()) > 4]
    x, y = line.get_xydata().T
    assert len(x) >= 24 * 3 and np.all(np.diff(x) > 0)
    assert np.interp(e, x, y) == pytest.approx(w, rel=1e-12)  # through the requests
    assert np.all(np.diff(y) >= 0)  # monotone requests: a monotone curve (no overshoot)


@pytest.mark.parametrize("argv", [
    ["frc", "duffing", "--force", "mass:0.1", "--omega", "0.5:2", "--harmonics", "3", "--png", "{bad}"],
    ["frf", "receptance_damped", "--input", "m1", "--output", "m1", "--points", "50", "--png", "{bad}"],
    ["modes", "trailer", "--png", "{bad}"],
], ids=["frc", "frf", "modes"])
def test_a_picture_that_cannot_be_written_keeps_the_printed_results(argv, tmp_path, monkeypatch):
    """`vibdyn frc duffing ... --png frc.png` printed only the error when the picture failed and threw the curve
    away: the table is printed first, then the error names the picture (exit status 2)."""
    import contextlib
    import io

    from vibdyn.faces.cli import main

    monkeypatch.chdir(tmp_path)
    bad = str(tmp_path / "no_such_folder" / "picture.png")
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([bad if a == "{bad}" else a for a in argv])
    assert code == 2
    assert err.getvalue().startswith(f"vibdyn: error: picture {bad}: no such directory")
    assert "the results above were computed and printed" in err.getvalue()
    header = {"frc": "Ω rad/s", "frf": "rad/s", "modes": "rad/s"}[argv[0]]
    assert header in out.getvalue() and len(out.getvalue().splitlines()) > 5 and "saved" not in out.getvalue()


def test_a_forced_response_curves_harmonics_by_number():
    """The coefficients are interleaved c₀, a₁, b₁, a₂, b₂, …: curve.harmonic(k) picks the k-th; the sampled
    motion c₀ + Σ a_k cos kτ + b_k sin kτ reaches the curve's amplitude."""
    import numpy as np

    curve = vd.forced_response_curve(vd.load_scene("duffing").build(), ("mass", 0.1), (0.5, 2.0), "mass",
                                     harmonics=3, step=0.1)
    c0 = curve.harmonic(0, "mass")
    pairs = [curve.harmonic(k, "mass") for k in (1, 2, 3)]
    tau = np.linspace(0, 2 * np.pi, 4001)
    x = c0[:, None] + sum(a[:, None] * np.cos(k * tau) + b[:, None] * np.sin(k * tau)
                          for k, (a, b) in enumerate(pairs, 1))
    assert np.abs(x).max(axis=1) == pytest.approx(curve.amplitude, rel=1e-6)
    a1, b1 = curve.harmonic(1)
    assert a1.shape == (len(curve.omega), 1) and np.all(np.abs(a1[:, 0]) + np.abs(b1[:, 0]) > 0)
    assert np.abs(pairs[1][0]).max() < 1e-12 < np.abs(pairs[2][0]).max()  # a cubic force: odd harmonics only
    with pytest.raises(vd.ModelError, match=r"ForcedResponseCurve.harmonic: k: must be in \[0, 3\], got 4"):
        curve.harmonic(4)


def test_a_start_in_degrees_is_named():
    """A start more than a full turn from neutral in a rotation coordinate is more often degrees than turns:
    simulate warns (and runs), so does an equilibrium search, and one that fails says so again; a start within a
    turn is silent (warnings are errors in this suite)."""
    rod = vd.load_scene("rod_pivot").build()
    rod.simulate(0.05, [1.0])
    with pytest.warns(UserWarning, match=r"^simulate: q0: rod = 90 rad, more than a full turn \(2π\) from neutral: "
                                         r"degrees by mistake\? 90° is 1.5708 rad$"):
        traj = rod.simulate(0.05, [90.0])
    assert traj.q[0, 0] == 90.0  # (the motion itself is still computed: a pendulum may be wound 14 turns)
    four_bar = vd.load_scene("four_bar").build()
    with pytest.raises(vd.ConvergenceError) as e, pytest.warns(UserWarning, match=r"^equilibrium: q0: crank = 57 rad"):
        four_bar.equilibrium(q0=[57.0, 30.0, 80.0], max_iter=20)  # (hinted at once, and again in the failure)
    assert "start nearer an equilibrium (q0=); the start has crank = 57 rad, coupler = 30 rad, rocker = 80 rad, " \
           "more than a full turn (2π) from neutral: degrees by mistake? 57° is 0.994838 rad" in str(e.value)
