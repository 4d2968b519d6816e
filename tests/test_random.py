"""Random response (issue 42, items 1-3): PSD inputs and lin.random_response against independent references.

Oracles: Irvine's vibration-response-spectrum case (published values), closed forms of a single degree of
freedom under white force (σ_x² = G₀/(4kc), σ_v² = G₀/(4mc)), scipy's quad of a hand-built receptance for a
2-DOF chain, the exact white-noise transmissibility integral behind Miles' equation, the direct receptance.
Tolerances come from the results' own error estimates (plus the linear model's relative error where the
reference is built from the scene's numbers rather than from lin's matrices).
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad

import vibdyn as vd
from vibdyn.analysis.response.quadrature import integrate

G = 9.80665


def sdof(fn, Q=10.0, m=1.0):
    """A mass on a vertical slider tied to a support by a spring and a damper: natural frequency fn Hz, Q."""
    w = 2 * np.pi * fn
    s = vd.Scene("sdof")
    s.add_support("base", vd.laws.HarmonicMotion((0, 0, 0.0), 1.0))
    s.add_body("mass", joint=vd.Slider((0, 0, 1), at=(0, 0, 1.0)), mass=m)
    s.add_spring("k", ("base", (0, 0, 0)), "mass", stiffness=m * w * w)
    s.add_damper("c", ("base", (0, 0, 0)), "mass", damping=m * w / Q)
    return s.build().linearize()


def chain2(m=(1.0, 2.0), k=(1000.0, 500.0), c=(3.0, 1.5)):
    """Two masses on sliders along x, in series: ground–k1–m1–k2–m2 (coordinates absolute displacements
    after the change x2 = x1 + y2), dampers c1, c2 beside the springs."""
    s = vd.Scene("chain2")
    s.add_body("m1", joint=vd.Slider((1, 0, 0), at=(1.0, 0, 0)), mass=m[0])
    s.add_body("m2", joint=vd.Slider((1, 0, 0), at=(2.0, 0, 0)), mass=m[1])
    s.add_spring("k1", (vd.WORLD, (0, 0, 0)), "m1", stiffness=k[0])
    s.add_spring("k2", "m1", "m2", stiffness=k[1])
    s.add_damper("c1", (vd.WORLD, (0, 0, 0)), "m1", damping=c[0])
    s.add_damper("c2", "m1", "m2", damping=c[1])
    lin = s.build().linearize()
    M = np.diag(m)
    K = np.array([[k[0] + k[1], -k[1]], [-k[1], k[1]]])
    C = np.array([[c[0] + c[1], -c[1]], [-c[1], c[1]]])
    return lin, M, K, C


IRVINE = vd.PSD([20, 150, 600, 2000], [0.0053, 0.04, 0.04, 0.0036], unit="g^2/Hz")


# ---------------------------------------------------------------------- PSD inputs
def test_table_is_log_log_zero_outside_and_si():
    p = IRVINE
    f = math.sqrt(20 * 150)  # the geometric middle of a segment: the geometric mean of its levels
    assert p(np.array([f]))[0] == pytest.approx(math.sqrt(0.0053 * 0.04) * G * G, rel=1e-13)
    assert p(np.array([19.9, 2000.1])).tolist() == [0.0, 0.0]
    assert p(np.array([600.0]))[0] == pytest.approx(0.04 * G * G, rel=1e-15)
    # the dB/octave slopes of the specification (Irvine: +3 dB/oct up, flat, about -6 dB/oct down)
    np.testing.assert_allclose(p.slopes_db_per_octave(), [10 * math.log10(0.04 / 0.0053) / math.log2(7.5), 0.0,
                                                          10 * math.log10(0.0036 / 0.04) / math.log2(2000 / 600)])


def test_table_rms_exact_against_quad():
    p = IRVINE
    ref = sum(quad(lambda x: p(np.array([x]))[0], a, b, epsrel=1e-13)[0]
              for a, b in [(20, 150), (150, 600), (600, 2000)])
    assert p.rms() == pytest.approx(math.sqrt(ref), rel=1e-10)
    assert p.rms() / G == pytest.approx(6.14, abs=0.005)  # Irvine's overall level, 6.1 G rms


def test_units_white_band_and_callable():
    assert vd.PSD.white(1.0, unit="g^2/Hz")(np.array([1e6]))[0] == pytest.approx(G * G)
    b = vd.PSD.band_limited(0.5, 10.0, 20.0, unit="m^2/Hz")
    assert b.rms() == pytest.approx(math.sqrt(5.0))
    assert b(np.array([9.0, 15.0, 21.0])).tolist() == [0.0, 0.5, 0.0]
    c = vd.PSD.function(lambda f: 1.0 / (1 + f * f), unit="N^2/Hz", band=(0, 1000.0))
    assert c.rms() == pytest.approx(math.sqrt(math.atan(1000.0)), rel=1e-8)
    for unit, quantity in [("(m/s^2)^2/Hz", "acceleration"), ("(m/s)^2/Hz", "velocity"), ("m^2/Hz", "displacement"),
                           ("N^2/Hz", "force"), ("(N*m)^2/Hz", "torque"), ("g^2/Hz", "acceleration")]:
        assert vd.PSD.white(1.0, unit=unit).quantity == quantity


@pytest.mark.parametrize("args, kwargs, words", [
    (([10, 20], [1.0, -1.0]), {"unit": "g^2/Hz"}, "must not be negative: -1 g^2/Hz at 20 Hz"),
    (([10, 30, 20], [1.0, 1.0, 1.0]), {"unit": "g^2/Hz"}, "strictly increasing: breakpoint 3 (20 Hz)"),
    (([10, 10], [1.0, 1.0]), {"unit": "g^2/Hz"}, "strictly increasing"),
    (([0, 10], [1.0, 1.0]), {"unit": "g^2/Hz"}, "must be > 0 Hz"),
    (([10, 20], [1.0]), {"unit": "g^2/Hz"}, "2 frequencies but 1 values"),
    (([10], [1.0]), {"unit": "g^2/Hz"}, "at least two breakpoints"),
    (([10, 20], [1.0, np.nan]), {"unit": "g^2/Hz"}, "NaN or inf"),
    (([10, 20], [1.0, 1.0]), {"unit": "G^2/Hz"}, "unknown unit 'G^2/Hz'"),
])
def test_psd_refusals(args, kwargs, words):
    with pytest.raises(vd.ModelError, match=None) as e:
        vd.PSD(*args, **kwargs)
    assert words in str(e.value)


def test_white_refusals():
    with pytest.raises(vd.ModelError, match="must not be negative"):
        vd.PSD.white(-1.0, unit="N^2/Hz")
    with pytest.raises(vd.ModelError, match="PSD band"):
        vd.PSD.white(1.0, unit="N^2/Hz", band=(20, 10))
    with pytest.raises(vd.ModelError, match="unbounded RMS"):
        vd.PSD.white(1.0, unit="N^2/Hz").rms()
    with pytest.raises(vd.ModelError, match="within \\[-1, 1\\]"):
        vd.Delay(0.1, coherence=1.5)


# ---------------------------------------------------------------------- acceptance: Irvine, Miles
@pytest.mark.parametrize("fn, published", [(100, 6.38), (200, 11.09), (1000, 16.06)])
def test_irvine_vibration_response_spectrum(fn, published):
    """Irvine, "An introduction to the vibration response spectrum" (2009): an SDOF of Q = 10 on the
    20/150/600/2000 Hz specification, absolute acceleration (G rms), published to 3-4 digits."""
    lin = sdof(fn)
    r = lin.random_response(IRVINE, support="base", direction=(0, 0, 1))
    a, e = r.rms("acceleration")[0] / G, r.rms_error("acceleration")[0] / G
    assert r.method.startswith("quadrature") and r.converged
    assert e <= 1e-8 * a
    assert abs(a - published) <= 0.005 + e + 10 * lin.relative_error * a


@pytest.mark.parametrize("zeta", [0.02, 0.005, 0.001])
def test_miles_equation_in_its_limit(zeta):
    """White base acceleration G₀ over all frequencies (Lyapunov): the absolute acceleration's variance is
    exactly G₀·(π/2)·f_n·Q·(1 + 4ζ²); Miles' √(π/2 f_n Q G₀) is its light-damping limit."""
    fn, G0 = 150.0, 0.04
    lin = sdof(fn, Q=1 / (2 * zeta))
    r = lin.random_response(vd.PSD.white(G0, unit="g^2/Hz"), support="base", direction=(0, 0, 1))
    assert r.method == "lyapunov"
    a, e = r.rms("acceleration")[0], r.rms_error("acceleration")[0]
    miles = math.sqrt(math.pi / 2 * fn / (2 * zeta) * G0) * G
    exact = miles * math.sqrt(1 + 4 * zeta ** 2)
    assert abs(a - exact) <= e + 10 * lin.relative_error * a
    assert abs(a / miles - 1) <= 2.01 * zeta ** 2  # Miles' error is O(ζ²): the limit
    with pytest.raises(vd.ModelError, match="displacement RMS is unbounded: the support itself drifts"):
        r.rms("displacement")


# ---------------------------------------------------------------------- Lyapunov: closed forms, W = G₀/2
def test_white_force_sdof_closed_form():
    m, k, c, G0 = 2.0, 800.0, 6.0, 3.0
    s = vd.Scene("f")
    s.add_body("mass", joint=vd.Slider((1, 0, 0)), mass=m)
    s.add_joint_spring("mass", k)
    s.add_joint_damper("mass", c)
    lin = s.build().linearize()
    r = lin.random_response({"mass": vd.PSD.white(G0, unit="N^2/Hz")})
    assert r.method == "lyapunov"
    assert abs(r.variance[0][0] - G0 / (4 * k * c)) <= r.variance_error[0][0] + 1e-12 * G0 / (4 * k * c)
    assert abs(r.variance[1][0] - G0 / (4 * m * c)) <= r.variance_error[1][0] + 1e-12 * G0 / (4 * m * c)
    with pytest.raises(vd.ModelError, match="acceleration RMS is unbounded: a white force"):
        r.rms("acceleration")


def test_lyapunov_2dof_chain_against_independent_quadrature():
    """Covariance of a 2-DOF chain under a white force on the outer mass: the Lyapunov solution (W = G₀/2)
    against scipy's quad of H G₀ Hᴴ with H = (K − ω²M + iωC)⁻¹ built by hand, ∫₀^∞ over f in Hz."""
    lin, M, K, C = chain2()
    G0 = 2.5
    r = lin.random_response({"m2": vd.PSD.white(G0, unit="N^2/Hz")}, outputs=["m1", "m2"])
    assert r.method == "lyapunov"
    P = r.covariance("displacement")

    def entry(i, j, power):
        def g(f):
            w = 2 * np.pi * f
            h = np.linalg.solve(K - w * w * M + 1j * w * C, [0.0, 1.0])
            return (w ** (2 * power) * h[i] * np.conj(h[j])).real * G0
        return quad(g, 0, np.inf, epsabs=0, epsrel=1e-12, limit=500, points=None)[0]

    for i in range(2):
        for j in range(2):
            ref = entry(i, j, 0)
            tol = r.variance_error[0].max() + (1e-9 + 10 * lin.relative_error) * abs(ref)
            assert abs(P[i, j] - ref) <= tol
    ref_v = entry(1, 1, 1)
    assert abs(r.variance[1][1] - ref_v) <= r.variance_error[1][1] + 1e-9 * ref_v + 10 * lin.relative_error * ref_v


def test_lyapunov_and_quadrature_agree_the_w_factor():
    """The Lyapunov intensity W = G₀/2 checked against vibdyn's own quadrature of the same white input
    (mapped to infinity): a factor 2 or 2π would show at once."""
    lin, *_ = chain2()
    w = {"m1": vd.PSD.white(1.0, unit="N^2/Hz"), "m2": vd.PSD.white(4.0, unit="N^2/Hz")}
    a = lin.random_response(w, cross={("m1", "m2"): 0.5})
    b = lin.random_response(w, cross={("m1", "m2"): 0.5}, method="quadrature")
    assert a.method == "lyapunov" and b.method.startswith("quadrature")
    for q in ("displacement", "velocity"):
        assert np.all(np.abs(a.rms(q) - b.rms(q)) <= a.rms_error(q) + b.rms_error(q))
        assert np.all(b.rms_error(q) <= 1e-8 * b.rms(q))
    np.testing.assert_allclose(a.covariance(), b.covariance(), rtol=1e-7, atol=1e-7 * np.abs(a.covariance()).max())


# ---------------------------------------------------------------------- the pieces
def test_response_psd_is_the_receptance_squared_times_the_input():
    lin, *_ = chain2()
    p = vd.PSD([5, 50], [1.0, 0.1], unit="N^2/Hz")
    r = lin.random_response({"m1": p}, outputs=["m1", "m2"])
    f = np.array([5.0, 7.3, 11.0, 49.0])
    H = lin.receptance(2 * np.pi * f, ["m1"], ["m1", "m2"])
    ref = np.abs(H.alpha[:, :, 0]) ** 2 * p(f)[:, None]
    np.testing.assert_allclose(r.psd(f), ref, rtol=1e-10 + 10 * H.relative_error)
    np.testing.assert_allclose(r.psd(f, "acceleration"), ref * (2 * np.pi * f[:, None]) ** 4,
                               rtol=1e-10 + 10 * H.relative_error)


def test_quadrature_of_a_table_against_scipy_quad():
    lin, M, K, C = chain2()
    p = vd.PSD([2, 8, 30], [0.5, 2.0, 0.1], unit="N^2/Hz")
    r = lin.random_response({"m1": p}, outputs=["m2"])
    assert r.converged and r.rms_error()[0] <= 1e-8 * r.rms()[0]

    def g(f):
        w = 2 * np.pi * f
        h = np.linalg.solve(K - w * w * M + 1j * w * C, [1.0, 0.0])[1]
        return abs(h) ** 2 * p(np.array([f]))[0]

    fd = lin.modes().damped_frequency_hz
    ref = quad(g, 2, 30, points=sorted([8.0, *fd]), epsabs=0, epsrel=1e-13, limit=500)[0]
    assert abs(r.variance[0][0] - ref) <= r.variance_error[0][0] + 1e-11 * ref + 10 * lin.relative_error * ref


def test_delay_equals_one_input_through_two_paths():
    """Inputs b = a delayed by τ: G_ab = G e^{i2πfτ}; the same as one input through H_a + H_b e^{-i2πfτ}."""
    lin, M, K, C = chain2()
    tau = 0.013
    p = vd.PSD.band_limited(1.0, 1.0, 40.0, unit="N^2/Hz")
    r = lin.random_response({"m1": p, "m2": p}, outputs=["m2"], cross={("m1", "m2"): vd.Delay(tau)})

    def g(f):
        w = 2 * np.pi * f
        h = np.linalg.solve(K - w * w * M + 1j * w * C, [1.0, np.exp(-1j * w * tau)])[1]
        return abs(h) ** 2

    fd = lin.modes().damped_frequency_hz
    ref = quad(g, 1, 40, points=sorted(fd), epsabs=0, epsrel=1e-13, limit=500)[0]
    assert abs(r.variance[0][0] - ref) <= r.variance_error[0][0] + 1e-11 * ref + 10 * lin.relative_error * ref
    fully = lin.random_response({"m1": p, "m2": p}, outputs=["m2"], cross={("m1", "m2"): 1.0})
    assert abs(fully.variance[0][0] - r.variance[0][0]) > 1e3 * (r.variance_error[0][0] + fully.variance_error[0][0])


def test_relative_motion_spectral_moments_and_peak():
    lin, *_ = chain2()
    p = vd.PSD.band_limited(1.0, 0.5, 60.0, unit="N^2/Hz")
    r = lin.random_response({"m2": p}, outputs=["m1", "m2"], relative=[("m2", "m1")])
    cov = r.covariance("displacement")
    assert r.outputs[2] == "m2 − m1"
    assert r.variance[0][2] == pytest.approx(cov[0, 0] + cov[1, 1] - 2 * cov[0, 1], rel=1e-7)
    _, m2, m4 = r.spectral_moments("displacement")
    np.testing.assert_array_equal(m2, r.variance[1])
    np.testing.assert_array_equal(m4, r.variance[2])
    nu = r.zero_crossing_rate()
    assert np.all((nu > 0.5) & (nu < 60))
    T = 100.0
    x = np.sqrt(2 * np.log(nu * T))
    np.testing.assert_allclose(r.expected_peak(T), (x + 0.5772 / x) * r.rms(), rtol=1e-15)


def test_hysteretic_and_prescribed_joint_against_direct_receptance():
    lin, *_ = chain2()
    p = vd.PSD([1, 40], [1.0, 1.0], unit="N^2/Hz")
    h = vd.Hysteretic(eta=0.05)
    r = lin.random_response({"m1": p}, outputs=["m2"], damping=h)
    f = np.linspace(1.5, 39, 7)
    H = lin.receptance(2 * np.pi * f, ["m1"], ["m2"], damping=h)
    np.testing.assert_allclose(r.psd(f)[:, 0], np.abs(H.alpha[:, 0, 0]) ** 2, rtol=1e-9 + 10 * H.relative_error)
    d = vd.PSD([1, 40], [1e-6, 1e-6], unit="m^2/Hz")
    pr = lin.random_response(d, support="m1", outputs=["m1", "m2"])
    T = lin.base_response(2 * np.pi * f, "m1", outputs=["m1", "m2"])
    np.testing.assert_allclose(pr.psd(f), np.abs(T.alpha[:, :, 0]) ** 2 * 1e-6, rtol=1e-9 + 10 * T.relative_error)


def test_gauss_kronrod_rule_is_exact_on_polynomials_and_its_estimate_covers():
    res = integrate(lambda f: np.stack([f ** 13, f ** 22, np.exp(-f)], axis=1), [0.0, 1.0], 2.0, rtol=1e-14)
    np.testing.assert_allclose(res.value[:2], [2 ** 14 / 14, 2 ** 23 / 23], rtol=1e-14)
    assert abs(res.value[2] - (1 - math.exp(-2))) <= res.error[2] + 1e-16
    tail = integrate(lambda f: np.stack([1 / (1 + f * f)], axis=1), [0.0, 1.0], np.inf, rtol=1e-12)
    assert abs(tail.value[0] - math.pi / 2) <= tail.error[0] + 1e-15


# ---------------------------------------------------------------------- refusals
def test_refusals_name_what_is_wrong():
    lin = sdof(100.0)
    white_f = vd.PSD.white(1.0, unit="N^2/Hz")
    cases = [
        (lambda: lin.random_response(white_f, support="base", direction=(0, 0, 1)), "support 'base' moves"),
        (lambda: lin.random_response(IRVINE, support="base"), "needs direction=(x, y, z)"),
        (lambda: lin.random_response(IRVINE, support="nowhere", direction=(0, 0, 1)), "nowhere"),
        (lambda: lin.random_response(IRVINE), "needs support=NAME"),
        (lambda: lin.random_response({"mass": vd.PSD.white(1.0, unit="(N*m)^2/Hz")}), "needs a PSD in N^2/Hz"),
        (lambda: lin.random_response({"mass": [1, 2]}), "expected a vibdyn.PSD"),
        (lambda: lin.random_response(IRVINE, support="base", direction=(0, 0, 1), method="fast"), "unknown method"),
        (lambda: lin.random_response(IRVINE, support="base", direction=(0, 0, 1), tolerance=0), "tolerance"),
        (lambda: lin.random_response(IRVINE, support="base", direction=(0, 0, 1)).rms("jerk"), "unknown quantity"),
    ]
    for call, words in cases:
        with pytest.raises(vd.ModelError) as e:
            call()
        assert words in str(e.value), (words, str(e.value))


def test_refusals_of_cross_spectra_and_models():
    lin, *_ = chain2()
    p = vd.PSD.band_limited(1.0, 1.0, 10.0, unit="N^2/Hz")
    two = {"m1": p, "m2": p}
    for cross, words in [({("m1", "m2"): 1.5}, "outside [-1, 1]"), ({("m1", "m3"): 0.5}, "'m3' is not one of"),
                         ({("m1", "m1"): 0.5}, "not a cross-spectrum"), ({("m1", "m2"): "x"}, "expected a PSD"),
                         ({("m1", "m2"): vd.PSD.band_limited(2.0, 1.0, 10.0, unit="N^2/Hz")}, "exceeds"),
                         ({("m1", "m2"): vd.PSD.band_limited(1.0, 1.0, 10.0, unit="m^2/Hz")}, "does not fit")]:
        with pytest.raises(vd.ModelError) as e:
            lin.random_response(two, cross=cross)
        assert words in str(e.value), (words, str(e.value))
    undamped = lin.with_damping(np.zeros((2, 2)))
    with pytest.raises(vd.ModelError, match="undamped mode at .* Hz lies where the input has power"):
        undamped.random_response({"m1": p})
    s = vd.Scene("pivot")
    s.add_body("bar", joint=vd.Pivot((0, 0, 1)), mass=1.0, com=(0.5, 0, 0))
    s.add_body("cart", parent="bar", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_joint_spring("bar", 10.0)
    s.add_joint_spring("cart", 10.0)
    pl = s.build().linearize().with_modal_damping(0.05)
    with pytest.raises(vd.ModelError, match="'bar' is an angle \\(rad\\): a motion PSD in m\\^2/Hz does not fit"):
        pl.random_response(vd.PSD([1, 2], [1.0, 1.0], unit="m^2/Hz"), support="bar")
    with pytest.raises(vd.ModelError, match="needs a PSD in \\(N\\*m\\)\\^2/Hz, got N\\^2/Hz"):
        pl.random_response({"bar": p})


def test_spring_forces_against_the_transmissibility():
    """Tyre and suspension forces of the quarter car: k_t (z_w − y) and k_s (z_b − z_w) per unit road motion,
    from the direct transmissibility; the tyre's road end moves with the support (a feedthrough)."""
    car = vd.load_scene("quarter_car").build().operating_point().linearize()
    road = vd.PSD.iso8608("C", speed=20.0)
    r = car.random_response(road, support="road", direction=(0, 0, 1), outputs=["body", "wheel"],
                            springs=["tyre", "suspension"])
    assert r.outputs[2:] == ("tyre (force)", "suspension (force)") and r.units[2:] == ("N", "N")
    f = np.array([0.5, 1.2, 5.0, 11.0, 40.0])
    T = car.base_response(2 * np.pi * f, "road", direction=(0, 0, 1), outputs=["body", "wheel"])
    tb, tw = T.alpha[:, 0, 0], T.alpha[:, 1, 0]
    tol = 1e-9 + 10 * T.relative_error + 10 * car.relative_error
    np.testing.assert_allclose(r.psd(f)[:, 2], 160000.0 ** 2 * np.abs(tw - 1) ** 2 * road(f), rtol=tol)
    np.testing.assert_allclose(r.psd(f)[:, 3], 16000.0 ** 2 * np.abs(tb - tw) ** 2 * road(f), rtol=tol)
    with pytest.raises(vd.ModelError, match="'shock_absorber'"):
        car.random_response(road, support="road", direction=(0, 0, 1), springs=["shock_absorber"])


@pytest.mark.parametrize("zeta, ratio", [(1e-4, 1.0), (0.02, 1e6), (1e-3, 1e4)])
def test_extreme_damping_and_stiffness_ratios_quadrature_against_lyapunov(zeta, ratio):
    """Very light damping (Q = 5000) and stiffness ratios up to 1e6 (poles 3 decades apart): the quadrature
    (white force mapped to infinity) against the exact Lyapunov solution, within both estimates, and its
    estimate at the requested 1e-8."""
    lin, *_ = chain2(k=(1000.0, 1000.0 * ratio), c=(0.0, 0.0))
    lin = lin.with_modal_damping(zeta)
    w = {"m1": vd.PSD.white(1.0, unit="N^2/Hz")}
    a = lin.random_response(w, outputs=["m1", "m2"])
    b = lin.random_response(w, outputs=["m1", "m2"], method="quadrature")
    assert a.method == "lyapunov" and b.converged
    for q in ("displacement", "velocity"):
        assert np.all(np.abs(a.rms(q) - b.rms(q)) <= a.rms_error(q) + b.rms_error(q)), q
        assert np.all(b.rms_error(q) <= 1e-8 * b.rms(q)) and np.all(a.rms_error(q) <= 1e-8 * a.rms(q))
