"""Undamped resonances are results, not errors: a peak at exactly ω_r with unbounded amplitude, no
half-power band, a finite plot and valid JSON. Anti-resonances of a driving-point FRF are checked against
an independent oracle: the natural frequencies of the model with that coordinate clamped."""

import json
import math

import numpy as np
import pytest
import scipy.linalg as sl
from conftest import MODELS
from oracles import cli as run

import vibdyn as vd


def strict_json(text):
    def refuse(c):
        raise AssertionError(f"not JSON: {c}")
    return json.loads(text, parse_constant=refuse)


def chain():
    lin = vd.load_scene(MODELS / "chain5_fixed_free.toml").build().operating_point().linearize()
    return lin, lin.modes()


def test_undamped_peaks_are_the_natural_frequencies_exactly():
    lin, m = chain()
    exact = [2 * math.sqrt(1000.0) * math.sin((2 * j - 1) * math.pi / 22) for j in range(1, 6)]  # R1 fixed–free
    frf = lin.receptance(np.geomspace(1, 100, 300), inputs=["m1"], outputs=["m5"])
    p = frf.peaks("m5", "m1")
    assert p.unbounded.all() and np.all(np.isinf(p.amplitudes))
    tol = m.omega_error + 4 * np.finfo(float).eps * m.omega  # the modes' own error estimate (rad/s)
    np.testing.assert_array_equal(p.resonances, m.omega)  # exactly the modes' frequencies
    assert np.all(np.abs(p.resonances - exact) <= tol + 1e-12 * np.array(exact))
    hp = frf.half_power("m5", "m1")
    assert hp.omega_peak.size == 0 and np.array_equal(hp.undamped, m.omega)


def test_driving_point_antiresonances_are_the_clamped_frequencies():
    lin, m = chain()
    frf = lin.receptance(np.geomspace(1, 100, 400), inputs=["m3"], outputs=["m3"])
    p = frf.peaks("m3", "m3")
    keep = [i for i in range(5) if i != 2]  # clamp m3: the remaining model's frequencies
    clamped = np.sqrt(sl.eigvalsh(lin.K[np.ix_(keep, keep)], lin.M[np.ix_(keep, keep)]))
    assert p.antiresonances.size == 4
    assert np.all(np.abs(p.antiresonances - clamped) <= p.omega_error)  # Brent's own tolerance (√ε scale)
    # the modes where m3 does not move (none in a chain) would not be peaks: every pole is seen here
    assert p.resonances.size == 5


def test_a_mode_the_channel_does_not_see_is_no_peak():
    # two identical uncoupled oscillators: the FRF of the first never sees the second's mode
    s = vd.Scene("pair")
    s.add_body("a", joint=vd.Slider(axis=(1, 0, 0)), mass=1.0)
    s.add_body("b", joint=vd.Slider(axis=(1, 0, 0), at=(0, 1, 0)), mass=4.0)
    s.add_joint_spring("a", 100.0)
    s.add_joint_spring("b", 100.0)
    lin = s.build().operating_point().linearize()
    p = lin.receptance(np.geomspace(1, 40, 200), inputs=["a"], outputs=["a"]).peaks("a", "a")
    assert p.resonances.tolist() == [10.0] and p.antiresonances.size == 0


def test_lightly_damped_peaks_still_refine():
    lin = vd.load_scene(MODELS / "receptance_damped.toml").build().operating_point().linearize()
    frf = lin.receptance(np.geomspace(0.1, 7, 300), inputs=["m1"], outputs=["m1"])
    p = frf.peaks("m1", "m1")
    assert not p.unbounded.any()
    np.testing.assert_allclose(p.resonances, [0.94527, 3.35271], atol=1e-5)  # reference-cases R5
    assert frf.half_power("m1", "m1").undamped.size == 0


@pytest.mark.parametrize("model, channel", [("chain5_fixed_free", "m1"), ("double_pendulum", "mass1"),
                                            ("triple_pendulum", None)])
def test_cli_frf_on_undamped_models(model, channel, tmp_path):
    path = MODELS / f"{model}.toml"
    channel = channel or vd.load_scene(path).build().coordinates[0]
    code, out, err = run(["frf", str(path), "--input", channel, "--output", channel, "--png",
                          str(tmp_path / "b.png")])
    assert code == 0, err
    assert out.count("unbounded") >= 2 and "0 (undamped)" in out and "anti-resonance" in out
    assert (tmp_path / "b.png").stat().st_size > 10_000
    code, out, err = run(["frf", str(path), "--input", channel, "--output", channel, "--json"])
    assert code == 0, err
    data = strict_json(out)
    assert all(data["peaks"]["unbounded"]) and data["peaks"]["amplitudes"][0] is None


def test_cli_frf_rigid_only_and_unstable_models_explain_themselves():
    code, out, _ = run(["frf", str(MODELS / "helical.toml"), "--input", "screw", "--output", "screw"])
    assert code == 0 and "every mode is rigid" in out
    code, out, _ = run(["frf", str(MODELS / "inverted_bar_unstable.toml"), "--input", "bar", "--output", "bar"])
    assert code == 0 and "unstable" in out and "no steady harmonic response" in out


def test_end_to_end_transfer_of_a_chain_has_no_antiresonance():
    # H_15 of a spring chain is (Π k_i) / det(K − ω²M): no zeros, so the minima of |H| between poles (where
    # H keeps its sign) are not anti-resonances
    lin, m = chain()
    p = lin.receptance(np.geomspace(1, 100, 300), inputs=["m1"], outputs=["m5"]).peaks("m5", "m1")
    assert p.antiresonances.size == 0 and p.resonances.size == 5


def test_half_power_of_an_undamped_channel_reads_well():
    lin, m = chain()
    hp = lin.receptance(np.geomspace(1, 100, 300), inputs=["m1"], outputs=["m5"]).half_power("m5", "m1")
    text = repr(hp)
    assert "undamped" in text and f"{m.omega[0]:.6g}" in text and "0 resonances" not in text and len(text) < 400
