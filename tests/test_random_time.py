"""Random loading, the rest of issue 42 items 1-3: sample paths, Monte Carlo in time, ISO 8608 roads, and the
faces (``vibdyn random``, the PSD plots).

Oracles: the sample's variance against the PSD's integral (exact by construction, and its spread across seeds
against the chi-square law of a Gaussian sum), the linear Monte Carlo against ``random_response`` (a different
method: time integration of sample paths) within 3 sampling errors, ISO 8608's own numbers, the JSON against the
Python result.
"""

import json
import math

import numpy as np
import pytest
from oracles import cli as run

import vibdyn as vd


def test_sample_is_gaussian_with_the_psd_variance_and_exact_derivatives():
    p = vd.PSD([1.0, 10.0], [2.0, 0.02], unit="(m/s^2)^2/Hz")
    var = np.array([p.sample(40.0, seed=s).variance for s in range(400)])
    exact = p.rms() ** 2
    # E[Σ a_k²/2] = ∫G df exactly (cells integrated); its spread: the standard error of 400 draws
    assert abs(var.mean() - exact) <= 4 * var.std(ddof=1) / math.sqrt(var.size)
    s = p.sample(40.0, seed=3)
    t = np.linspace(0.0, 40.0, 40001)
    a, v = s.acceleration(t), s.velocity(t)
    np.testing.assert_array_equal(a, s(t))
    h = 1e-5
    np.testing.assert_allclose((s.velocity(t[:50] + h) - s.velocity(t[:50] - h)) / (2 * h), a[:50],
                               atol=1e-6 * np.abs(a).max())
    np.testing.assert_allclose((s.displacement(t[:50] + h) - s.displacement(t[:50] - h)) / (2 * h), v[:50],
                               atol=1e-6 * np.abs(v).max())
    assert abs(np.mean(a[:-1] ** 2) - s.variance) <= 1e-9 * s.variance  # periodic: the mean square, exactly
    assert np.array_equal(p.sample(40.0, seed=3).phase, s.phase)  # seeded
    with pytest.raises(vd.ModelError, match="give f_max"):
        vd.PSD.white(1.0, unit="N^2/Hz").sample(10.0)
    with pytest.raises(vd.ModelError, match="has no displacement"):
        vd.PSD.white(1.0, unit="N^2/Hz").sample(10.0, f_max=5.0).displacement(0.0)


def test_iso8608_road_class_and_speed():
    road = vd.PSD.iso8608("B", speed=20.0)
    # spatial: G_d(n0) = 64e-6 m³ at n0 = 0.1 cycle/m; temporal at f = n0·V: G_d(n0)/V
    assert road(np.array([2.0]))[0] == pytest.approx(64e-6 / 20.0, rel=1e-12)
    assert road.band == pytest.approx((0.011 * 20, 2.83 * 20))
    # the road's RMS does not depend on the speed (the same profile), and doubles per class
    assert vd.PSD.iso8608("B", speed=5.0).rms() == pytest.approx(road.rms(), rel=1e-12)
    assert vd.PSD.iso8608("C", speed=20.0).rms() == pytest.approx(2 * road.rms(), rel=1e-12)
    with pytest.raises(vd.ModelError, match="class: one of A, B"):
        vd.PSD.iso8608("Z", speed=20.0)


def sdof(m=1.0, k=40.0, c=1.26):
    s = vd.Scene("sdof")
    s.add_support("base", vd.laws.HarmonicMotion((0, 0, 0.0), 1.0))
    s.add_body("mass", joint=vd.Slider((1, 0, 0), at=(1.0, 0, 0)), mass=m)
    s.add_spring("k", ("base", (0, 0, 0)), "mass", stiffness=k)
    s.add_damper("c", ("base", (0, 0, 0)), "mass", damping=c)
    return s.build().linearize()


def test_linear_monte_carlo_agrees_with_random_response_within_its_sampling_error():
    lin = sdof()
    psd = vd.PSD.band_limited(0.02, 0.3, 3.0, unit="m^2/Hz")
    r = lin.random_response(psd, support="base", direction=(1, 0, 0))
    mc = vd.monte_carlo(lin, psd, "base", (1, 0, 0), duration=20.0, samples=6, seed=11, dt=0.05, models=("linear",))
    for q in ("displacement", "velocity", "acceleration"):
        assert abs(mc.rms(q, "linear")[0] - r.rms(q)[0]) <= 3 * mc.rms_error(q, "linear")[0], q
        assert mc.rms_error(q, "linear")[0] < 0.2 * r.rms(q)[0]  # the check has teeth
    d = mc.to_dict()
    assert d["samples"] == 6 and len(d["linear_displacement_rms"]) == 1
    with pytest.raises(vd.ModelError, match="no 'nonlinear' runs"):
        mc.rms("displacement", "nonlinear")


def test_monte_carlo_refusals():
    lin = sdof()
    psd = vd.PSD.band_limited(0.02, 0.3, 3.0, unit="m^2/Hz")
    for kwargs, words in [({"psd": vd.PSD.white(1.0, unit="N^2/Hz")}, "expected a motion PSD"),
                          ({"support": "floor"}, "'floor' is not a support"),
                          ({"models": ("exact",)}, "models must be among"),
                          ({"duration": -1.0}, "must be positive"),
                          ({"psd": vd.PSD.white(1.0, unit="m^2/Hz")}, "give f_max")]:
        args = {"psd": psd, "support": "base", "direction": (1, 0, 0), "duration": 5.0, **kwargs}
        with pytest.raises(vd.ModelError) as e:
            vd.monte_carlo(lin, args.pop("psd"), args.pop("support"), args.pop("direction"), **args)
        assert words in str(e.value), (words, str(e.value))


def test_cli_random_text_json_png_and_refusals(tmp_path):
    spec = tmp_path / "road.txt"
    spec.write_text("# a road\n# unit: m^2/Hz\n0.5 2e-4\n30, 5.6e-8\n")
    png = tmp_path / "psd.png"
    code, out, err = run(["random", "quarter_car", "--psd", spec, "--support", "road", "--png", png])
    assert code == 0, err
    assert "body" in out and "acceleration" in out and "m/s^2" in out and png.stat().st_size > 5000
    code, out, err = run(["random", "quarter_car", "--psd", spec, "--support", "road", "--json"])
    data = json.loads(out)
    car = vd.load_scene("quarter_car").build().operating_point().linearize()
    r = car.random_response(vd.PSD([0.5, 30], [2e-4, 5.6e-8], unit="m^2/Hz"), support="road", direction=(0, 0, 1))
    np.testing.assert_allclose(data["acceleration_rms"], r.rms("acceleration"), rtol=1e-12)
    assert data["convention"].startswith("one-sided PSD in Hz")
    bad = tmp_path / "bad.txt"
    for text, words in [("1 2\n3\n", "line 2: expected two numbers"), ("1 2\n3 4\n", "no unit"),
                        ("# unit: m^2/Hz\n10 1\n5 1\n", "strictly increasing")]:
        bad.write_text(text)
        code, out, err = run(["random", "quarter_car", "--psd", bad, "--support", "road"])
        assert code == 2 and words in err, (words, err)
    code, out, err = run(["random", "quarter_car", "--psd", spec, "--support", "road", "--unit", "N^2/Hz"])
    assert code == 2 and "support 'road' moves" in err


def test_psd_plots(tmp_path):
    pytest.importorskip("matplotlib")
    spec = vd.PSD([20, 150, 600, 2000], [0.0053, 0.04, 0.04, 0.0036], unit="g^2/Hz")
    fig = spec.plot(tmp_path / "in.png")
    assert (tmp_path / "in.png").stat().st_size > 5000 and fig.axes[0].get_xscale() == "log"
    with pytest.raises(vd.ModelError, match="give band"):
        vd.PSD.white(1.0, unit="N^2/Hz").plot(tmp_path / "w.png")
    with pytest.raises(vd.ModelError, match="no such directory"):
        spec.plot(tmp_path / "missing" / "x.png")


MODELS = sorted((__import__("pathlib").Path(__file__).resolve().parents[1] / "models").glob("*.toml"))
# the refusals vibdyn random may give on a bundled model: physical impossibilities, each said in words
RANDOM_REFUSALS = ("lies where the input has power", "is an angle (rad)", "unstable", "leaves no free coordinate")


@pytest.mark.parametrize("path", MODELS, ids=[p.stem for p in MODELS])
def test_cli_random_on_every_bundled_model(path, tmp_path):
    """``vibdyn random`` on each bundled model: its first support under a band-limited acceleration PSD, else a
    force on its linear model's first coordinate: a table of finite RMS values, or a refusal that says why."""
    spec = tmp_path / "spec.txt"
    system = vd.load_scene(path).build()
    if system.supports:
        spec.write_text("# unit: (m/s^2)^2/Hz\n0.5 1e-3\n50 1e-3\n")
        where = ["--support", system.supports[0].name]
    else:
        lin = system.operating_point().linearize()
        unit = "N^2/Hz" if lin.units[0] == "m" else "(N*m)^2/Hz"
        spec.write_text(f"# unit: {unit}\n0.5 1e-3\n50 1e-3\n")
        where = ["--force", lin.coordinates[0]]
    code, out, err = run(["random", path, "--psd", spec, *where])
    if code == 2 and "undamped mode" in err:  # modal damping makes it bounded
        code, out, err = run(["random", path, "--psd", spec, *where, "--zeta", "0.02"])
    if code == 0:
        assert "acceleration" in out and "nan" not in out.lower().split(), out
    else:
        assert code == 2 and err.startswith("vibdyn: error:") and any(w in err for w in RANDOM_REFUSALS), err
