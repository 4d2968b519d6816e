"""Results read well in a terminal and in Jupyter: a short repr with the key numbers, HTML tables for the
main results, and a progress bar whose clock starts with the run."""

import time

import numpy as np
import pytest
from conftest import MODELS

import vibdyn as vd

SHORT = 400


@pytest.fixture(scope="module")
def damped():
    system = vd.load_scene(MODELS / "receptance_damped.toml").build()
    eq = system.operating_point()
    lin = eq.linearize()
    return system, eq, lin, lin.modes()


def short(obj, *words):
    text = repr(obj)
    assert len(text) < SHORT, f"{type(obj).__name__} repr is {len(text)} characters: {text[:200]}…"
    assert "\n" not in text
    for w in words:
        assert w in text, f"{w!r} not in {text}"
    return text


def test_reprs_are_short_and_carry_the_key_numbers(damped):
    system, eq, lin, m = damped
    short(m, "Modes", "2 modes", "rad/s", f"{m.omega[0]:.4g}", m.stability)
    short(lin, "LinearModel", "nv = 2", "fd", "damped")
    short(eq, "OperatingPoint", eq.regime, eq.stability)  # (an equilibrium is one kind of operating point)
    frf = lin.receptance(np.geomspace(0.1, 7, 400), inputs=["m1"], outputs=["m1", "m2"])
    short(frf, "FRF", "400 frequencies", "receptance")
    short(frf.peaks("m1", "m1"), "Peaks", "0.945274", "3.35271", "1.47667")
    short(frf.half_power("m1", "m1"), "HalfPower", "2 resonances", "0.186")
    short(lin.harmonic_response(2.0, [1.0], ["m1"]), "HarmonicResponse")
    short(lin.free_response(np.linspace(0, 1, 11), [0.0, 0.01]), "TimeResponse", "11 times")
    short(lin.appropriation(0, inputs=["m1", "m2"]), "Appropriation", "mode 0")
    short(lin.state_space(["m1"], ["m2"]), "StateSpace", "4 states")
    q, v = system.neutral(), np.zeros(system.nv)
    short(system.reactions(q, v, system.accelerations(q, v)), "Reactions", "2 links")
    short(system.energy(q, v), "Energy")
    traj = system.simulate(0.2)
    short(traj, "Trajectory", "finished")
    t = np.linspace(0, 10, 2001)
    short(vd.log_decrement(t, np.exp(-0.1 * t) * np.cos(3 * t)), "LogDecrement", "ζ")
    short(vd.fit_rayleigh([1.0, 3.0], [0.05, 0.04]), "RayleighFit", "α")


def test_html_tables(damped):
    system, eq, lin, m = damped
    frf = lin.receptance(np.geomspace(0.1, 7, 100), inputs=["m1"], outputs=["m1"])
    for obj in (m, frf, eq, system.simulate(0.1)):
        html = obj._repr_html_()
        assert html.startswith("<table") and "</table>" in html and "http" not in html
    assert "0.94527" in frf._repr_html_() and f"{m.omega[1]:.6g}"[:5] in m._repr_html_()


def test_progress_bar_clock_starts_with_the_run(monkeypatch, capsys):
    from vibdyn.simulation import runs

    monkeypatch.setattr(runs, "PROGRESS_DELAY", 0.2)
    p = runs.Progress(1.0, True, "run")
    time.sleep(0.3)
    p.update(0.5)
    try:
        assert p.bar is not None
        assert p.bar.format_dict["elapsed"] >= 0.3  # not the ~0 s since the bar appeared
    finally:
        p.close()
