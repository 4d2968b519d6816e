"""Damping identification (half-power bandwidth, logarithmic decrement) and Rayleigh fits, against
closed forms and the damping the models were built with.

Tolerances: a result's own error estimate (modes.relative_error/residual, lin.K_error, traj.error, ...) wherever the
comparison is one the estimate covers; fixed 1e-15..1e-12 ones are identities that hold to round-off (a
few ε × the size of the terms: ΦᵀMΦ = 1 from eigh, a unit quaternion, a closed form in a few flops).
"""

import numpy as np
import pytest
from conftest import MODELS

import vibdyn as vd
from vibdyn import identify


def sdof(zeta, m=2.0, k=800.0):
    s = vd.Scene("sdof")
    s.add_body("mass", joint=vd.Slider((1, 0, 0), at=(1, 0, 0)), mass=m)
    s.add_spring("k", ("world", (0, 0, 0)), "mass", stiffness=k)
    s.add_damper("c", ("world", (0, 0, 0)), "mass", damping=2 * zeta * np.sqrt(k * m))
    return s.build().linearize()  # ω_n = 20 rad/s


@pytest.mark.parametrize("zeta", [0.001, 0.01, 0.05, 0.2, 0.35])
def test_half_power_inversion_is_exact_for_one_mode(zeta):
    # half-power points of the receptance: r² = 1 − 2ζ² ∓ 2ζ√(1 − ζ²); of the mobility: r = √(1 + ζ²) ∓ ζ
    u = 1 - 2 * zeta ** 2 + np.array([-1, 1]) * 2 * zeta * np.sqrt(1 - zeta ** 2)
    w1, w2 = 20 * np.sqrt(u)
    assert identify.zeta_from_half_power(w1, w2) == pytest.approx(zeta, rel=1e-12)
    # the accelerance's points are the receptance's mirrored: r → 1/r
    assert identify.zeta_from_half_power(400 / w2, 400 / w1, "accelerance") == pytest.approx(zeta, rel=1e-12)
    r1, r2 = np.sqrt(1 + zeta ** 2) - zeta, np.sqrt(1 + zeta ** 2) + zeta
    assert identify.zeta_from_half_power(20 * r1, 20 * r2, "mobility") == pytest.approx(zeta, rel=1e-12)
    # the textbook approximation (ω2 − ω1)/(2ω_n) is first order only
    assert abs((w2 - w1) / 40 - zeta) <= 2 * zeta ** 2 + 1e-15


@pytest.mark.parametrize("zeta", [0.01, 0.05, 0.2])
def test_half_power_from_sampled_data(zeta):
    lin = sdof(zeta)
    f = lin.receptance(np.linspace(5.0, 40.0, 300))
    for q in ("receptance", "mobility", "accelerance"):
        hp = identify.half_power(f.omega, np.abs(f.get(quantity=q)), q)  # the samples only, as measured
        assert hp.zeta.size == 1 and hp.unresolved.size == 0
        assert abs(hp.zeta[0] - zeta) < 1e-4
        assert abs(hp.zeta[0] - zeta) <= 2 * hp.error[0]  # the error estimate covers the spline's error
        refined = f.half_power(quantity=q)  # refined on the model
        assert refined.zeta[0] == pytest.approx(zeta, rel=1e-9)


def test_close_and_overlapping_modes():
    w = np.linspace(0.5, 3.0, 500)
    # two close, light modes (ζ = 0.05 at 1 and 1.2 rad/s): both resolved, ζ within a few per cent
    h = np.abs(1 / (1 - w ** 2 + 0.1j * w) + 0.8 / (1.44 - w ** 2 + 0.12j * w))
    hp = identify.half_power(w, h)
    assert hp.unresolved.size == 0
    np.testing.assert_allclose(hp.zeta, 0.05, rtol=0.05)
    # a heavy first mode whose lower half-power point is below the data, and a second mode sitting on its
    # flank (the dip between them stays above the half-power level): both reported unresolved, no guess
    h = np.abs(1 / (1 - w ** 2 + 0.6j * w) + 1 / (4 - w ** 2 + 0.8j * w))
    hp = identify.half_power(w, h)
    assert hp.zeta.size == 0 and hp.unresolved.size == 2


@pytest.mark.parametrize("zeta", [0.02, 0.1])
def test_log_decrement_of_a_free_decay(zeta):
    lin = sdof(zeta)
    t = np.linspace(0, 3, 3001)
    x = lin.free_response(t, [0.01], [0.0]).x[:, 0]
    ld = identify.log_decrement(t, x)
    assert ld.zeta == pytest.approx(zeta, rel=1e-8)
    assert abs(ld.zeta - zeta) <= ld.error + 1e-15
    assert ld.omega_n == pytest.approx(20.0, rel=1e-6)
    assert ld.delta == pytest.approx(2 * np.pi * zeta / np.sqrt(1 - zeta ** 2), rel=1e-8)
    # an offset signal about a static deflection
    assert identify.log_decrement(t, x + 0.5, offset=0.5).zeta == pytest.approx(ld.zeta, rel=1e-12)


def test_rayleigh_fit_recovers_R5_damping():
    """R5's damping is C = M/5 + K/10: its modal ratios give α = 0.2, β = 0.1 back."""
    ref = vd.load_scene(MODELS / "receptance_damped.toml").references
    fit = identify.fit_rayleigh(ref["omega"], ref["zeta"])
    assert fit.alpha == pytest.approx(0.2, rel=1e-12) and fit.beta == pytest.approx(0.1, rel=1e-12)
    assert (fit.alpha, fit.beta) == pytest.approx(vd.rayleigh(ref["zeta"], ref["omega"]), rel=1e-12)
    assert fit.residual < 1e-15 and fit.error == (0.0, 0.0)


def test_rayleigh_fit_least_squares_over_many_modes():
    lin = vd.load_scene(MODELS / "chain5_fixed_fixed.toml").build().linearize()
    m = lin.modes()
    zeta = 0.3 / (2 * m.omega) + 0.002 * m.omega / 2
    fit = identify.fit_rayleigh(m.omega, zeta)
    assert (fit.alpha, fit.beta) == pytest.approx((0.3, 0.002), rel=1e-10)
    damped = fit.damping(lin).modes()
    np.testing.assert_allclose(damped.zeta, zeta, rtol=1e-8)
    noisy = identify.fit_rayleigh(m.omega, zeta * (1 + 0.01 * np.array([1, -1, 1, -1, 1])))
    assert noisy.error[0] > 0 and noisy.error[1] > 0
    assert abs(noisy.alpha - 0.3) < 5 * noisy.error[0] and abs(noisy.beta - 0.002) < 5 * noisy.error[1]


def test_calculation_test_correlation_on_R5():
    """A lightly damped R5 (C/10) 'measured' as |α11| on a grid: half-power ζ per resonance, then a Rayleigh
    fit, give back the model's modal damping and (α, β) = (0.02, 0.01) within 1 %."""
    lin = vd.load_scene(MODELS / "receptance_damped.toml").build().linearize()
    lin = lin.with_damping(lin.C / 10)
    measured = lin.receptance(np.linspace(0.3, 5.0, 2000), "m1", "m1")
    hp = identify.half_power(measured.omega, np.abs(measured.alpha[:, 0, 0]))
    m = lin.modes()
    np.testing.assert_allclose(hp.omega_peak, m.omega, rtol=2e-3)
    np.testing.assert_allclose(hp.zeta, m.zeta, rtol=1e-2)
    fit = identify.fit_rayleigh(hp.omega_peak, hp.zeta)
    assert fit.alpha == pytest.approx(0.02, rel=1e-2) and fit.beta == pytest.approx(0.01, rel=1e-2)


def test_identification_errors():
    t = np.linspace(0, 1, 100)
    with pytest.raises(vd.ModelError, match="at least two positive maxima"):
        identify.log_decrement(t, t)
    with pytest.raises(vd.ModelError, match="strictly increasing"):
        identify.log_decrement(t[::-1], np.sin(t))
    with pytest.raises(vd.ModelError, match="NaN"):
        identify.half_power(t, np.full(100, np.nan))
    with pytest.raises(vd.ModelError, match="magnitudes"):
        identify.half_power(t, -np.ones(100))
    with pytest.raises(vd.ModelError, match="0 < omega_1 < omega_2"):
        identify.zeta_from_half_power(2.0, 1.0)
    with pytest.raises(vd.ModelError, match="at least two"):
        identify.fit_rayleigh([1.0], [0.1])
    with pytest.raises(vd.ModelError, match="positive"):
        identify.fit_rayleigh([1.0, -2.0], [0.1, 0.1])
