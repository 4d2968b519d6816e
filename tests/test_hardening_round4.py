"""Issue 40 acceptance, round four of adversarial probes: each test is a probe that returned a wrong number with a
confident estimate, a raw traceback or a hang, checked against an independent oracle."""

import math

import numpy as np
import pytest

import vibdyn as vd


def _chain(k1=120.0, k2=50.0):
    s = vd.Scene("chain")
    s.add_body("a", joint=vd.Slider(axis=(1, 0, 0)), mass=1.0)
    s.add_body("b", parent="a", joint=vd.Slider(axis=(1, 0, 0)), mass=1.0)
    s.add_joint_spring("a", k1, name="k1")
    s.add_joint_spring("b", k2, name="k2")
    return s


def _chain_omega(k1, k2):
    """The two-slider chain by hand: b slides on a, so M = [[2, 1], [1, 1]] kg, K = diag(k1, k2)."""
    return np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve([[2.0, 1.0], [1.0, 1.0]], np.diag([k1, k2]))).real))


@pytest.mark.parametrize("sigma", [1e-300, 1e-100, 1e100, 1e300])
def test_update_fits_whatever_the_scale_of_sigma(sigma):
    # σ = 1e-100 rad/s returned the start (130, 45) with std 8e-99 (scipy's squares overflowed); 1e-300 a raw
    # "array must not contain infs or NaNs". The fit's minimum does not depend on σ's scale, std scales with it.
    fit = vd.update(_chain, {"k1": 130.0, "k2": 45.0}, _chain_omega(120.0, 50.0), sigma=sigma)
    assert fit.values["k1"] == pytest.approx(120.0, rel=1e-9) and fit.values["k2"] == pytest.approx(50.0, rel=1e-9)
    reference = vd.update(_chain, {"k1": 130.0, "k2": 45.0}, _chain_omega(120.0, 50.0), sigma=1.0)
    for k in ("k1", "k2"):
        assert fit.std[k] == pytest.approx(reference.std[k] * sigma, rel=1e-6)


def _duffing_omega(a, k=1.0, k3=0.1):
    """ω of the undamped Duffing orbit x'' + k x + k3 x³ = 0 of amplitude a: 2π over 4∫ dx/v (x = a sin θ)."""
    from scipy.integrate import quad

    energy = 0.5 * k * a**2 + 0.25 * k3 * a**4

    def dt(theta):
        x = a * np.sin(theta)
        return a * np.cos(theta) / np.sqrt(2 * (energy - 0.5 * k * x**2 - 0.25 * k3 * x**4))

    return 2 * np.pi / (4 * quad(dt, 0, np.pi / 2, epsabs=1e-14, epsrel=1e-13)[0])


def test_a_backbone_at_large_amplitude_reports_the_least_period():
    # the Duffing backbone at 100 m gave ω = 13.405 ± 1.4e-11 rad/s, half the truth 26.811: the continuation had
    # landed on the orbit followed twice over (period 2T), which shooting closes as well as the orbit itself
    b = vd.backbone(vd.load_scene("duffing").build(), 0, amplitudes=[100.0])
    truth = np.array([_duffing_omega(a) for a in b.amplitude])
    assert np.all(np.abs(b.omega - truth) <= b.error)


@pytest.mark.parametrize("multiple", [2.0, 3.0, 7.0])
def test_a_periodic_orbit_guessed_at_a_multiple_of_its_period_is_the_least_one(multiple):
    # a period guess near kT converged to kT (ω reported k times too small, with an error of 1e-12 s)
    from scipy.special import ellipk

    rod = vd.load_scene("rod_pivot").build()  # uniform rod, 1 m: ω₀² = 3g/(2L); T = 4K(sin²(θ₀/2))/ω₀
    period = 4 * ellipk(np.sin(1.0) ** 2) / np.sqrt(1.5 * 9.81)
    orbit = vd.periodic_orbit(rod, [2.0], [0.0], period=multiple * period, phase="rod")
    amplitude = abs(float(orbit.q0[0]))
    truth = 4 * ellipk(np.sin(amplitude / 2) ** 2) / np.sqrt(1.5 * 9.81)
    assert abs(orbit.period - truth) <= orbit.period_error


@pytest.mark.parametrize("speeds", [[0.0, 1e9], [-1e9, 1e9], [0.0, 1e12], np.linspace(0.0, 1e9, 5)])
def test_campbell_finds_the_critical_speed_on_a_wide_speed_list(speeds):
    # [0, 1e9] rad/s: at 1e9 the backward whirl (300/(0.12·1e9) rad/s) is lost in the round-off beside the forward
    # one (1.5e9) and given as 0 ± 0.0015, and the crossing between was skipped (no critical speed); found, Brent's
    # tolerance over the bracket (1e-3 rad/s) gave 38.729845 ± 3.9e-11, and [-1e9, 1e9] -38.729764 ± 3.9e-11
    c = vd.campbell(vd.load_scene("gimbal_rotor").build(), "rotor", speeds)
    truth = np.sqrt(300.0 / (0.08 + 0.12))  # √(k/(It + Ip)): the disk's backward critical speed
    found = [cs for cs in c.critical_speeds(1) if cs.speed > 0]
    assert len(found) == 1 and abs(found[0].speed - truth) <= found[0].error
    for cs in c.critical_speeds(1):
        assert abs(abs(cs.speed) - truth) <= cs.error


@pytest.mark.parametrize("angle", [1e7, 1e9, 1e300])
def test_a_periodic_orbit_from_an_angle_beyond_round_off_is_refused_at_once(angle):
    # rod_pivot from 1e7 rad (or 1e9) hung in the shooting's polish (> 60 s; 1e6 took 26 s): a double's round-off
    # there (2.2e-9 rad) exceeds the closing tolerance of the motion (1e-10 of about 1 rad)
    import time

    start = time.perf_counter()
    with pytest.raises(vd.ModelError, match="round-off"):
        vd.periodic_orbit(vd.load_scene("rod_pivot").build(), [angle], [0.0], phase="rod")
    assert time.perf_counter() - start < 10.0


def test_a_periodic_orbit_a_few_thousand_turns_out_is_still_right():
    from scipy.special import ellipk

    with pytest.warns(UserWarning, match="degrees by mistake"):
        orbit = vd.periodic_orbit(vd.load_scene("rod_pivot").build(), [1000.0], [0.0], phase="rod")
    amplitude = abs(math.remainder(float(orbit.q0[0]), 2 * math.pi))
    assert abs(orbit.period - 4 * ellipk(np.sin(amplitude / 2) ** 2) / np.sqrt(1.5 * 9.81)) <= orbit.period_error


def test_a_forced_response_curve_with_more_harmonics_than_can_be_computed_is_refused_at_once():
    # `vibdyn frc duffing --force mass:0.1 --omega 0.5:2 --harmonics 1000` ran for hours (H = 128 took 27 s, the
    # cost grows as H³: Hill's matrices (2H + 1)·2n square at each point); the accepted maximum was 1000
    import time

    duffing = vd.load_scene("duffing").build()
    start = time.perf_counter()
    with pytest.raises(vd.ModelError, match="harmonics = 1000.*at most 99"):
        vd.forced_response_curve(duffing, ("mass", 0.1), (0.5, 2.0), "mass", harmonics=1000)
    assert time.perf_counter() - start < 5.0


_AT2 = """PEER NGA STRONG MOTION DATABASE RECORD
Synthetic test, 1 January 2000, Nowhere, 090
ACCELERATION TIME SERIES IN UNITS OF G
NPTS=   12, DT=   .0050 SEC
  .1000000E-02  .2000000E-02 -.3000000E-02  .4000000E-02  .5000000E-02
 -.6000000E-02  .7000000E-02  .8000000E-02 -.9000000E-02  .1000000E-01
  .1100000E-01 -.1200000E-01
"""


def test_a_peer_at2_record_is_read_in_g_with_its_header_step(tmp_path):
    path = tmp_path / "RSN1_TEST_090.AT2"
    path.write_text(_AT2)
    record = vd.laws.Record.from_file(path)
    samples = np.array([1, 2, -3, 4, 5, -6, 7, 8, -9, 10, 11, -12]) * 1e-3
    assert record.dt == 0.005 and np.allclose(record.acceleration, samples * 9.80665, rtol=1e-15)
    assert np.allclose(vd.laws.Record.from_file(path, unit="m/s^2").acceleration, samples, rtol=1e-15)
    # the older NGA header ("12  0.0050  NPTS, DT") too
    older = tmp_path / "older.AT2"
    older.write_text(_AT2.replace("NPTS=   12, DT=   .0050 SEC", "   12    0.0050    NPTS, DT"))
    assert vd.laws.Record.from_file(older).dt == 0.005
    with pytest.raises(vd.ModelError, match="contradicts the header"):
        vd.laws.Record.from_file(path, dt=0.01)
    short = tmp_path / "short.AT2"
    short.write_text(_AT2.replace("NPTS=   12", "NPTS=   13"))
    with pytest.raises(vd.ModelError, match="NPTS = 13 samples, the file has 12"):
        vd.laws.Record.from_file(short)
    # the other formats are as before: one column with dt, two columns in m/s^2 by default
    plain = tmp_path / "two.txt"
    plain.write_text("0 0.1\n0.01 0.2\n0.02 -0.1\n")
    two = vd.laws.Record.from_file(plain)
    assert two.dt == pytest.approx(0.01) and np.allclose(two.acceleration, [0.1, 0.2, -0.1])


@pytest.mark.parametrize("call", [lambda b: vd.update(b, {"k": 1.0}, [1.0]), lambda b: vd.sensitivity(b, {"k": 1.0})])
def test_a_builder_returning_the_scene_class_itself_is_named(call):
    # `return vd.Scene` (the class, a forgotten call) ended in a raw TypeError "Scene.build() missing 'self'"
    with pytest.raises(vd.ModelError, match="returned the class Scene itself"):
        call(lambda k: vd.Scene)


def test_update_names_a_zero_measuring_direction():
    # direction=(0, 0, 0) ended in "mac: second shapes: contains NaN or inf"
    with pytest.raises(vd.ModelError, match="direction .*zero length"):
        vd.update(_chain, {"k1": 130.0, "k2": 45.0}, _chain_omega(120.0, 50.0), shapes=np.eye(2), points=["a", "b"],
                  direction=(0, 0, 0))


def test_a_forced_response_curve_stopped_on_its_way_up_claims_no_peak():
    # a linear oscillator with c = 1e-6 (true peak F/c = 1e5 m at Ω ≈ 1): the curve stops after its steps at 387 m
    # while still rising, and called that the peak, 386.56 ± 5e-10 m
    # (the branch now ends a leg at the natural frequency: 200 steps reach the peak, 5 still stop below it)
    system = vd.with_values(vd.load_scene("duffing"), {"k3.k3": 0.0, "c.damping": 1e-6}).build()
    truth = 0.1 / 1e-6 / np.sqrt(1 - 0.25e-12)
    for steps, growing in ((5, True), (200, False)):
        curve = vd.forced_response_curve(system, ("mass", 0.1), (0.5, 2.0), "mass", max_steps=steps)
        assert curve.status == "stopped" and f"{steps} steps taken" in curve.message
        assert abs(curve.peak.amplitude - truth) <= curve.peak.error
        assert ("still growing" in curve.message) == growing and math.isfinite(curve.peak.error) != growing


@pytest.mark.parametrize("k, omega", [(1.0, 1e-3), (1e6, 1.3)])
def test_a_periodic_orbit_over_hundreds_of_natural_periods_is_refused_at_once(k, omega):
    # a linear oscillator forced at Ω = 1e-3 rad/s (1000 natural periods per forcing period) took 91 s, k = 1e6
    # at Ω = 1.3 (769) over 120 s: the flows step at most 0.5/ω, about 0.1 s per natural period
    import time

    s = vd.Scene("forced")
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_joint_spring("cart", k)
    s.add_joint_damper("cart", 0.01)
    s.add_joint_force("cart", vd.laws.Harmonic(1.0, omega, phase=math.pi / 2))
    start = time.perf_counter()
    with pytest.raises(vd.ModelError, match=r"spans .* of the scene's fastest natural period .*more than 200"):
        vd.floquet(s.build(), 2 * math.pi / omega)
    assert time.perf_counter() - start < 5.0


def test_a_period_guess_far_below_the_natural_period_is_named_too_short():
    # rod_pivot from 1 rad with a guess of 1e-9 s said "the start is too close to rest"
    with pytest.raises(vd.ModelError, match=r"the period 1e-09 s is too short: .* natural period at the start"):
        vd.floquet(vd.load_scene("rod_pivot").build(), 1e-9, [1.0], [0.0])


@pytest.mark.parametrize("call, words", [
    (lambda S: S.equilibrium(q0="abc"), "q0: expected a configuration of 2 numbers, got 'abc'"),
    (lambda S: S.equilibrium(q0={"crank": 0.3}), "q0: expected a configuration of 2 numbers"),
    (lambda S: S.steady_motion({"mass1": 1.0}, q0="x"), "q0: expected a configuration"),
    (lambda S: S.held("abc"), "held q: expected a configuration"),
    (lambda S: S.held(None, v="x"), "held v: expected 2 numbers"),
])
def test_a_start_that_is_no_configuration_is_named(call, words):
    """They ended in numpy's raw ValueError/TypeError (the start was made an array before it was checked)."""
    with pytest.raises(vd.ModelError) as e:
        call(vd.load_scene("double_pendulum").build())
    assert words in str(e.value)


def test_an_empty_declared_start_of_a_mechanism_says_how_to_have_its_closures_searched():
    """set_operating_point(start={}) declares neutral, where the four-bar cannot close: the message said only
    "neutral", while the same scene with no start assembles (its closures searched)."""
    scene = vd.load_scene("four_bar")
    scene.set_operating_point(start={})
    with pytest.raises(vd.ConvergenceError, match="declare none to have the closures searched"):
        scene.build().operating_point()
    scene.set_operating_point()
    assert scene.build().operating_point().constraint_residual < 1e-12
