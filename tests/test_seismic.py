"""Response-spectrum analysis and ground-motion records (issue 42, items 4 and 5), against independent references:
SRSS and CQC by hand on a shear frame (numpy eigh of its M and K, Der Kiureghian's ρ written out here), a
record's spectrum against scipy's solve_ivp (extrema located by events), the exactness of the Nigam–Jennings step
for a piecewise-linear input, the missing-mass correction's static limit, and the refusals."""

import json

import numpy as np
import pytest
import scipy.linalg as sla
from conftest import MODELS
from oracles import cli as _run
from scipy.integrate import solve_ivp

import vibdyn as vd
from vibdyn.analysis.response.record_spectrum import _exponential_step, nigam_jennings
from vibdyn.analysis.response.seismic import correlation

M_BOOK = np.array([2000.0, 1500.0, 1000.0])
K_BOOK = np.array([[1e6, -4e5, 0.0], [-4e5, 6e5, -2e5], [0.0, -2e5, 2e5]])
H_BOOK = np.array([3.0, 6.0, 9.0])


@pytest.fixture(scope="module")
def building():
    return vd.load_scene("three_storey_building").build().operating_point().linearize(method="analytic").modes()


def book_modes():
    w2, Phi = sla.eigh(K_BOOK, np.diag(M_BOOK))
    return np.sqrt(w2), Phi, Phi.T @ M_BOOK  # ω, mass-normalised shapes, Γ (r = 1: floors follow the ground)


def spectrum(T):
    """A made-up smooth design spectrum (m/s²)."""
    return 2.5 + 4.0 * T * np.exp(-2.0 * T)


def rho_book(w, z):
    """Der Kiureghian (1981), equal damping: ρ_ij = 8ζ²(1 + β)β^{3/2} / ((1 − β²)² + 4ζ²β(1 + β)²)."""
    b = w[None, :] / w[:, None]
    return 8 * z * z * (1 + b) * b ** 1.5 / ((1 - b * b) ** 2 + 4 * z * z * b * (1 + b) ** 2)


def modal_peaks(Sa_of=spectrum):
    w, Phi, G = book_modes()
    T = 2 * np.pi / w
    return w, (G * np.array([Sa_of(t) for t in T]) / w ** 2) * Phi  # nv × n: Γ_n φ_n S_a/ω_n²


# ------------------------------------------------------------------ combinations by hand
@pytest.mark.parametrize("rule", ["srss", "cqc", "abs"])
def test_combinations_by_hand_on_the_shear_frame(building, rule):
    w, U = modal_peaks()
    if rule == "srss":
        ref = np.sqrt((U ** 2).sum(axis=1))
    elif rule == "cqc":
        ref = np.sqrt(np.einsum("ki,ij,kj->k", U, rho_book(w, 0.05), U))
    else:
        ref = np.abs(U).sum(axis=1)
    r = building.response_spectrum(spectrum, (1, 0, 0), rule, damping=0.05)
    # the book's M, K are exact; the tolerance: the result's own estimate (and the book's eigh round-off)
    assert np.all(np.abs(r.displacement - ref) <= r.displacement_error + 1e-12 * np.abs(ref))
    assert np.all(r.displacement_error < 1e-8 * ref)  # an estimate, not a shrug
    # base shear by hand: Σ_n (Γ_n² S_a) combined; storey 1's spring carries it (equilibrium of the frame)
    Vn = book_modes()[2] ** 2 * spectrum(2 * np.pi / w)
    V = {"srss": np.sqrt((Vn ** 2).sum()), "cqc": np.sqrt(Vn @ rho_book(w, 0.05) @ Vn), "abs": np.abs(Vn).sum()}[rule]
    assert abs(r.base_shear - V) <= r.base_shear_error + 1e-12 * V
    assert abs(r.spring_forces["storey1"] - V) <= r.spring_force_errors["storey1"] + 1e-9 * V
    # overturning moment about y through the base: Σ m h u_n ω_n² per mode, combined
    Mn = (M_BOOK * H_BOOK) @ U * w ** 2
    Mo = {"srss": np.sqrt((Mn ** 2).sum()), "cqc": np.sqrt(Mn @ rho_book(w, 0.05) @ Mn), "abs": np.abs(Mn).sum()}[rule]
    assert abs(r.overturning_moment - Mo) <= r.overturning_moment_error + 1e-12 * Mo
    # storey 2's spring force: k2 × the drift between floors 1 and 2, mode by mode
    drift = 4e5 * (U[1] - U[0])
    F2 = {"srss": np.sqrt((drift ** 2).sum()), "cqc": np.sqrt(drift @ rho_book(w, 0.05) @ drift),
          "abs": np.abs(drift).sum()}[rule]
    assert abs(r.spring_forces["storey2"] - F2) <= r.spring_force_errors["storey2"] + 1e-12 * F2
    assert np.allclose(np.abs(r.modal_spring_forces["storey2"]), np.abs(drift), rtol=1e-9)
    assert np.all(r.modal_relative_error < 1e-8)


def test_each_modes_contribution_participation_and_90_percent(building):
    w, Phi, G = book_modes()
    r = building.response_spectrum(spectrum, (1, 0, 0))
    sign = np.sign(np.sum(r.modal_displacement * (G[:, None] * Phi.T), axis=1))  # shapes' sign is free
    _, U = modal_peaks()
    assert np.allclose(r.modal_displacement, U.T, rtol=1e-10, atol=1e-15)
    assert np.all(sign > 0)
    assert np.allclose(r.effective_mass, G ** 2, rtol=1e-10)
    assert abs(r.mass - M_BOOK.sum()) <= 1e-9 * M_BOOK.sum()
    cum = np.cumsum(G ** 2) / M_BOOK.sum()
    assert r.modes_for_90 == int(np.argmax(cum >= 0.9)) + 1 == 2  # 81.4 % then 95.8 %
    assert np.allclose(r.periods, 2 * np.pi / w, rtol=1e-10)


@pytest.mark.parametrize("m2, k2", [(1e-6, 1e9), (1e3, 1e-3), (1e-8, 1e12)])
def test_stiff_and_extreme_two_mass_chains(m2, k2):
    """Mass ratios to 1e8 and stiffness ratios to 1e9: SRSS and CQC as by hand (eigh of the exact M and K)."""
    s = vd.Scene("stiff")
    s.add_body("a", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_body("b", parent="a", joint=vd.Slider((1, 0, 0)), mass=m2)
    s.add_joint_spring("a", 1e3)
    s.add_joint_spring("b", k2)
    modes = s.build().linearize(np.zeros(2), method="analytic").modes()
    M, K = np.array([[1 + m2, m2], [m2, m2]]), np.diag([1e3, k2])
    w2, Phi = sla.eigh(K, M)
    w = np.sqrt(w2)
    U = (Phi.T @ (M @ [1.0, 0.0])) * np.array([spectrum(2 * np.pi / x) for x in w]) / w2 * Phi
    for rule, ref in (("srss", np.sqrt((U ** 2).sum(axis=1))),
                      ("cqc", np.sqrt(np.einsum("ki,ij,kj->k", U, rho_book(w, 0.05), U)))):
        r = modes.response_spectrum(spectrum, (1, 0, 0), rule)
        assert np.all(np.abs(r.displacement - ref) <= r.displacement_error + 1e-13 * ref)


def test_cqc_unequal_damping_and_limits():
    w = np.array([10.0, 10.5, 30.0])
    z = np.array([0.02, 0.05, 0.05])
    rho = correlation(w, z)
    i, j = 0, 1
    b = w[j] / w[i]
    by_hand = (8 * np.sqrt(z[i] * z[j]) * (z[i] + b * z[j]) * b ** 1.5
               / ((1 - b * b) ** 2 + 4 * z[i] * z[j] * b * (1 + b * b) + 4 * (z[i] ** 2 + z[j] ** 2) * b * b))
    assert rho[i, j] == pytest.approx(by_hand, rel=1e-14)
    assert np.allclose(correlation(w, 0.05), rho_book(w, 0.05), rtol=1e-14)  # the equal-ζ form
    assert np.allclose(np.diag(rho), 1.0) and np.all(rho > 0) and np.all(rho <= 1 + 1e-12)
    assert correlation([10.0, 10.0 + 1e-9], 0.05)[0, 1] == pytest.approx(1.0, abs=1e-12)  # equal frequencies
    assert correlation([1.0, 100.0], 0.05)[0, 1] < 1e-3  # far apart: SRSS


def test_cqc_with_close_modes_differs_from_srss():
    """Two equal floors on a soft coupling: close modes, where CQC and SRSS disagree (the rule, not its error)."""
    s = vd.Scene("twins")
    for name, x in (("a", 0.0), ("b", 1.0)):
        s.add_body(name, joint=vd.Slider((1, 0, 0), at=(x, 0, 0)), mass=100.0)
    s.add_spring("ka", ("world", (-10.0, 0, 0)), "a", stiffness=1e5, free_length=10.0)
    s.add_spring("kb", ("world", (-9.0, 0, 0)), "b", stiffness=1.1e5, free_length=10.0)
    s.add_spring("c", ("a", (0, 0, 0)), "b", stiffness=1e3, free_length=1.0)
    modes = s.build().linearize(np.zeros(2), method="analytic").modes()
    srss = modes.response_spectrum(lambda T: 3.0, (1, 0, 0), "srss")
    cqc = modes.response_spectrum(lambda T: 3.0, (1, 0, 0), "cqc", damping=0.05)
    U = cqc.modal_displacement
    rho = rho_book(modes.omega, 0.05)
    assert np.allclose(cqc.displacement, np.sqrt(np.einsum("ik,ij,jk->k", U, rho, U)), rtol=1e-10)
    assert np.all(np.abs(cqc.displacement - srss.displacement) > 0.05 * srss.displacement)


# ------------------------------------------------------------------ missing mass
def test_missing_mass_makes_the_static_limit_exact(building):
    """No mode kept: the whole mass responds rigidly, u = K⁻¹ L S_a(0), the static response, exactly."""
    zpa = 3.0
    static = np.linalg.solve(K_BOOK, M_BOOK * zpa)
    r = building.response_spectrum(lambda T: zpa, (1, 0, 0), n_modes=0)
    assert np.all(np.abs(r.displacement - static) <= r.displacement_error + 1e-12 * static)
    assert abs(r.base_shear - M_BOOK.sum() * zpa) <= r.base_shear_error + 1e-12 * M_BOOK.sum() * zpa
    assert r.missing_mass == pytest.approx(M_BOOK.sum(), rel=1e-12)
    # one mode kept, the others rigid: mode 1 by its spectrum, the rest with the missing mass, algebraically;
    # with a flat spectrum and every kept mode counted rigid, the static answer again
    r1 = building.response_spectrum(lambda T: zpa, (1, 0, 0), n_modes=1, rigid_frequency=0.1)
    assert np.all(np.abs(r1.displacement - static) <= r1.displacement_error + 1e-12 * static)
    # and with mode 1 dynamic (SRSS with the residual): mode 1's peak and the residual by hand
    w, U = modal_peaks(lambda T: zpa)
    residual = static - U[:, 0]
    r2 = building.response_spectrum(lambda T: zpa, (1, 0, 0), n_modes=1)
    ref = np.sqrt(U[:, 0] ** 2 + residual ** 2)
    assert np.all(np.abs(r2.displacement - ref) <= r2.displacement_error + 1e-12 * ref)
    assert r2.missing_mass == pytest.approx(M_BOOK.sum() - book_modes()[2][0] ** 2, rel=1e-10)
    # without the correction: mode 1 alone
    r3 = building.response_spectrum(lambda T: zpa, (1, 0, 0), n_modes=1, missing_mass=False)
    assert np.allclose(r3.displacement, np.abs(U[:, 0]), rtol=1e-10)


def test_influence_vector_from_the_model_supports_and_pendulums():
    """The ground's load comes from the model (its momentum matrix), not assumed: a mass on a slider held by a
    spring to a moving support has r = 1; a pendulum's Γ² is its m (the mass the ground moves sideways)."""
    s = vd.Scene("sdof")
    s.add_body("mass", joint=vd.Slider((1, 0, 0)), mass=10.0)
    s.add_support("ground", vd.laws.HarmonicMotion((0.0, 0.0, 0.0), 1.0))
    s.add_spring("k", ("ground", (-1.0, 0, 0)), "mass", stiffness=1000.0, free_length=1.0)
    modes = s.build().linearize(np.zeros(1), method="analytic").modes()
    r = modes.response_spectrum(lambda T: 2.0, (1, 0, 0))
    assert r.displacement[0] == pytest.approx(2.0 / 100.0, rel=1e-12)  # S_d = S_a/ω², ω² = k/m
    assert r.effective_mass[0] == pytest.approx(10.0, rel=1e-12)
    # along y: the slider moves nothing
    with pytest.raises(vd.ModelError, match="moves no mass"):
        modes.response_spectrum(lambda T: 2.0, (0, 1, 0))
    p = vd.Scene("pendulum", gravity=(0, 0, -9.81))
    p.add_body("bob", joint=vd.Pivot((0, 1, 0)), mass=2.0, com=(0, 0, -1.5))
    pm = p.build().operating_point().linearize(method="analytic").modes()
    rp = pm.response_spectrum(lambda T: 1.0, (1, 0, 0))
    assert rp.effective_mass[0] == pytest.approx(2.0, rel=1e-10)
    assert rp.displacement[0] == pytest.approx(1.0 / (9.81 / 1.5) / 1.5, rel=1e-8)  # rad: x/L, x = S_d


# ------------------------------------------------------------------ records
def _record(n=400, dt=0.01, seed=1):
    rng = np.random.default_rng(seed)
    a = np.convolve(rng.standard_normal(n), np.ones(4) / 4, "same") * 3 * np.sin(np.pi * np.arange(n) / n)
    return vd.laws.Record(a, dt=dt)


def _ivp_peak(record, T, z):
    """Peak |x| of ẍ + 2ζωẋ + ω²x = −a_g by solve_ivp (DOP853, rtol 1e-13), restarted at each sample, extrema
    located by events on ẋ = 0, and the free vibration after the record for 3 periods."""
    w = 2 * np.pi / T

    def f(t, y):
        return [y[1], -2 * z * w * y[1] - w * w * y[0] - record.ground(t)[2]]

    def ev(t, y):
        return y[1]

    y, peak = [0.0, 0.0], 0.0
    ts = list(record.times) + [record.times[-1] + 3 * T]
    for t0, t1 in zip(ts[:-1], ts[1:]):
        sol = solve_ivp(f, (t0, t1), y, rtol=1e-13, atol=1e-16, method="DOP853", events=ev)
        peak = max([peak, abs(sol.y[0, -1])] + [abs(e[0]) for e in sol.y_events[0]])
        y = sol.y[:, -1]
    return peak


@pytest.mark.parametrize("T", [0.015, 0.1, 0.7, 6.0])
def test_record_spectrum_against_solve_ivp(T):
    rec = _record()
    z = 0.05
    s = rec.pseudo_acceleration_spectrum([T], damping=z)
    ref = _ivp_peak(rec, T, z)
    assert abs(s.displacement[0] - ref) <= s.displacement_error[0] + 1e-11 * ref
    w = 2 * np.pi / T
    assert s.pseudo_acceleration[0] == pytest.approx(w * w * s.displacement[0], rel=1e-15)
    assert s.pseudo_velocity[0] == pytest.approx(w * s.displacement[0], rel=1e-15)


def test_nigam_jennings_step_is_exact_for_piecewise_linear_input():
    # the closed-form step against the exponential of the oscillator augmented with its linear input
    for w, z, h in [(10.0, 0.05, 0.01), (3.0, 0.02, 0.2), (100.0, 0.3, 0.01), (0.6, 0.0, 0.05)]:
        A, B = nigam_jennings(w, z, h)
        Ae, Be = _exponential_step(np.array([w]), z, h)
        assert np.allclose(A, Ae[0], rtol=0, atol=1e-13 * np.abs(Ae).max())
        assert np.allclose(B, Be[0], rtol=0, atol=1e-9 * np.abs(Be).max())
    # the same piecewise-linear input sampled 7 times finer: the same spectrum (the step is exact, not O(h²))
    coarse = _record(n=120, dt=0.05, seed=4)
    fine_t = np.arange(0, coarse.times[-1] + 1e-9, 0.05 / 7)
    fine = vd.laws.Record(np.interp(fine_t, coarse.times, coarse.acceleration), dt=0.05 / 7)
    T = [0.05, 0.3, 1.0, 4.0]
    a, b = coarse.pseudo_acceleration_spectrum(T), fine.pseudo_acceleration_spectrum(T)
    assert np.all(np.abs(a.displacement - b.displacement) <= a.displacement_error + b.displacement_error
                  + 1e-13 * a.displacement)
    # a trapezoid-rule or central-difference integration would differ at O((ωh)²): 0.05 s at T = 0.3 s is 1.0 rad
    assert a.displacement[1] > 0


def test_record_spectrum_zero_period_and_long_period_limits():
    a = _record().acceleration
    a = a - np.trapezoid(a, dx=0.01) / (0.01 * (a.size - 1))  # the ground ends at rest (a corrected baseline)
    rec = vd.laws.Record(a, dt=0.01)
    assert abs(rec.ground(rec.times[-1])[1]) < 1e-14
    s = rec.pseudo_acceleration_spectrum([0.0, 0.001, 200.0], damping=0.05)
    assert s.pseudo_acceleration[0] == rec.peak_acceleration  # rigid: the ground's peak
    assert s.pseudo_acceleration[1] == pytest.approx(rec.peak_acceleration, rel=1e-2)  # nearly rigid
    # very flexible: the mass stays put, S_d → the ground's peak displacement
    ug = np.array([rec.ground(t)[0] for t in np.linspace(0, rec.times[-1], 20001)])
    assert s.displacement[2] == pytest.approx(np.abs(ug).max(), rel=0.05)


def test_record_integrals_are_exact():
    rec = vd.laws.Record([0.0, 1.0, 3.0, -2.0], dt=0.5, direction=(0, 2, 0), start=1.0)
    assert rec.direction == (0.0, 1.0, 0.0)

    def exact(t):  # integrate the piecewise-linear a by hand (polynomial pieces)
        ts, a = rec.times, rec.acceleration
        u = v = 0.0
        for k in range(3):
            h = min(max(t - ts[k], 0.0), 0.5)
            s = (a[k + 1] - a[k]) / 0.5
            u += v * h + a[k] * h * h / 2 + s * h ** 3 / 6
            v += a[k] * h + s * h * h / 2
        if t > ts[-1]:
            u += v * (t - ts[-1])
        return u, v

    for t in [0.5, 1.0, 1.2, 1.5, 1.77, 2.5, 3.0]:
        u, v = exact(t)
        assert rec.position(t)[1] == pytest.approx(u, abs=1e-15)
        assert rec.velocity(t)[1] == pytest.approx(v, abs=1e-15)
        assert rec.position(t)[0] == 0.0
    assert rec.ground_acceleration(1.75)[1] == pytest.approx(2.0, abs=1e-15)
    assert rec.ground(0.9) == (0.0, 0.0, 0.0)
    assert rec.max_step == 0.5 and rec.peak_acceleration == 3.0


def _on_record(rec, m, k, c):
    """A mass on a slider, a spring k and a damper c (none at 0) to a support moved by the record ``rec``."""
    s = vd.Scene("oscillator")
    s.add_body("mass", joint=vd.Slider((1, 0, 0)), mass=m)
    s.add_support("ground", rec)
    s.add_spring("k", ("ground", (-1.0, 0, 0)), "mass", stiffness=k, free_length=1.0)
    if c:
        s.add_damper("c", ("ground", (-1.0, 0, 0)), "mass", damping=c)
    return s.build()


def test_record_drives_forced_response_and_simulate():
    """An oscillator on a support moved by a record: the linear forced response, the nonlinear simulation and
    the record's spectrum (three methods) agree on the peak relative displacement."""
    rec = _record(n=150, dt=0.02, seed=2)
    m, k, z = 10.0, 1000.0, 0.05
    w = np.sqrt(k / m)
    system = _on_record(rec, m, k, 2 * z * w * m)
    lin = system.linearize(np.zeros(1))
    t = np.linspace(0.0, rec.times[-1] + 1.0, 997)  # not on the record's samples: integrated through them
    r = lin.forced_response(t, support="ground")
    ug = np.array([rec.ground(x)[0] for x in t])
    rel = r.x[:, 0] - ug
    tr = system.simulate(t[-1], t_eval=t, rtol=1e-10)
    assert np.abs(tr.q[:, 0] - r.x[:, 0]).max() <= 10 * (tr.error + r.error) + 1e-12
    # the same through the record given as motion=, on the record's own grid
    r2 = lin.forced_response(rec.times, support="ground", motion=rec)
    assert np.allclose(r2.x[:, 0], np.interp(rec.times, t, r.x[:, 0]), atol=5e-3 * np.abs(r.x).max())
    spec = rec.pseudo_acceleration_spectrum([2 * np.pi / w], z)
    # the sampled time history can only miss the peak between its samples: by about (ωΔt)²/8 of it (a forced,
    # damped motion: /2 here)
    dt = t[1] - t[0]
    assert spec.displacement[0] * (1 - (w * dt) ** 2 / 2) - 1e-9 <= np.abs(rel).max() <= spec.displacement[0] + 1e-9
    # and the response-spectrum analysis of this one mode, with the record's spectrum: its S_d
    rs = lin.modes().response_spectrum(rec.pseudo_acceleration_spectrum([0.0, 2 * np.pi / w, 1.0], z), (1, 0, 0))
    assert rs.displacement[0] == pytest.approx(spec.displacement[0], rel=1e-7)


def test_forced_response_integrates_through_the_records_samples():
    """Output times that are not the record's samples: the exact discretisation still steps on every sample (no
    quadrature across a kink), against solve_ivp; without it the estimate was 1e-4 and the error 2e-7 here."""
    rec = _record(n=150, dt=0.02, seed=2)
    lin = _on_record(rec, 10.0, 1000.0, 10.0).linearize(np.zeros(1))
    t = np.linspace(0.0, rec.times[-1] + 1.0, 61)
    r = lin.forced_response(t, support="ground", method="state")
    ref = lin.forced_response(t, support="ground", method="ivp")
    assert r.relative_error < 1e-8
    assert np.abs(r.x - ref.x).max() <= r.error + ref.error


def test_simulate_steps_are_bounded_by_the_record():
    rec = vd.laws.Record(np.sin(np.arange(40) * 0.7), dt=0.01)
    tr = _on_record(rec, 1.0, 1.0, 0.0).simulate(0.35)
    assert np.diff(tr.t).max() <= 0.01 + 1e-15  # a soft oscillator would otherwise step over many samples


def test_steps_past_the_records_end_are_bound_no_more():
    """Past its last sample a record moves the ground uniformly: the steps are no longer bound by its dt (a 0.4 s
    record on a 20 s run took every step of dt), and the motion still equals the exact linear forced response
    within the two estimates."""
    rec = _record(n=40, dt=0.01, seed=3)
    system = _on_record(rec, 1.0, 100.0, 0.5)
    t = np.linspace(0.0, 20.0, 401)
    for method in ("dop853", "radau"):
        steps = system.simulate(t[-1], method=method, rtol=1e-9).t  # (every step recorded)
        inside = steps <= rec.bounded_until
        assert np.diff(steps[inside]).max() <= rec.dt + 1e-15
        assert np.diff(steps[~inside]).max() > 2 * rec.dt, method
        tr = system.simulate(t[-1], t_eval=t, method=method, rtol=1e-9)
        r = system.linearize(np.zeros(1)).forced_response(t, support="ground")
        assert np.abs(tr.q[:, 0] - r.x[:, 0]).max() <= tr.error + r.error, method


def test_record_in_a_scene_file(tmp_path):
    s = vd.Scene("filed")
    s.add_body("mass", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_support("ground", vd.laws.Record([0.0, 1.0, -0.5, 0.0], dt=0.1, direction=(1, 0, 0)))
    s.add_spring("k", ("ground", (-1.0, 0, 0)), "mass", stiffness=100.0, free_length=1.0)
    path = tmp_path / "filed.toml"
    s.save(path)
    back = vd.load_scene(path)
    motion = back.elements["ground"].motion
    assert isinstance(motion, vd.laws.Record)
    assert motion.acceleration.tolist() == [0.0, 1.0, -0.5, 0.0] and motion.dt == 0.1


def test_record_files(tmp_path):
    a = np.array([0.0, 0.1, -0.2, 0.05, 0.0])
    one = tmp_path / "one.txt"
    one.write_text("# a comment\nACCELERATION (g)\n" + "\n".join(f"{x}" for x in a) + "\n")
    rec = vd.laws.Record.from_file(one, dt=0.01, unit="g")
    assert np.allclose(rec.acceleration, a * 9.80665) and rec.dt == 0.01
    two = tmp_path / "two.csv"
    two.write_text("time,acc\n" + "\n".join(f"{0.5 + 0.02 * k:.2f}, {x}" for k, x in enumerate(a)) + "\n")
    rec2 = vd.laws.Record.from_file(two)
    assert rec2.dt == pytest.approx(0.02, rel=1e-12) and rec2.start == 0.5
    assert np.allclose(rec2.acceleration, a)


@pytest.mark.parametrize("text, kwargs, words", [
    ("", {"dt": 0.01}, "no samples"),
    ("# only a comment\n", {"dt": 0.01}, "no samples"),
    ("0.1\nnan\n0.2\n", {"dt": 0.01}, "line 2: NaN"),
    ("0.1\n0.2\n", {}, "give dt"),
    ("0 0.1\n0.01 0.2\n0.03 0.1\n", {}, "non-uniform time steps"),
    ("0 0.1\n0.01 0.2\n0.02 0.1\n", {"dt": 0.02}, "contradicts"),
    ("0 0.1 3\n", {}, "3 columns"),
    ("0 0.1\n0.01\n", {}, "1 columns where the file has 2"),
    ("0.1\nabc\n", {"dt": 0.01}, "line 2: not a number"),
    ("0.1\n", {"dt": 0.01, "unit": "furlong"}, "unknown unit"),
    ("0 0.1\n", {}, "one sample"),
])
def test_record_file_refusals(tmp_path, text, kwargs, words):
    path = tmp_path / "rec.txt"
    path.write_text(text)
    with pytest.raises(vd.ModelError, match=words) as e:
        vd.laws.Record.from_file(path, **kwargs)
    assert "rec.txt" in str(e.value)


def test_record_file_missing(tmp_path):
    with pytest.raises(vd.ModelError, match="nowhere.txt.*cannot be read"):
        vd.laws.Record.from_file(tmp_path / "nowhere.txt", dt=0.01)


@pytest.mark.parametrize("args, words", [
    (([], 0.01), "record acceleration.*no samples"),
    (([0.0, np.nan], 0.01), "record acceleration.*NaN"),
    (([0.0, 1.0], 0.0), "record dt"),
    (([0.0, 1.0], -1.0), "record dt"),
    (([0.0, 1.0], 0.01, (0, 0, 0)), "record direction"),
    ((["a", 1.0], 0.01), "record acceleration"),
])
def test_record_refusals(args, words):
    with pytest.raises(vd.ModelError, match=words):
        vd.laws.Record(*args)


def test_record_spectrum_refusals():
    rec = _record(n=20)
    with pytest.raises(vd.ModelError, match="periods.*≥ 0"):
        rec.pseudo_acceleration_spectrum([-1.0])
    with pytest.raises(vd.ModelError, match="damping ratio.*≥ 1"):
        rec.pseudo_acceleration_spectrum([1.0], damping=1.0)
    with pytest.raises(vd.ModelError, match="periods.*NaN"):
        rec.pseudo_acceleration_spectrum([np.nan])
    with pytest.raises(vd.ModelError, match="damping ratio"):
        rec.pseudo_acceleration_spectrum([1.0], damping=-0.1)
    with pytest.raises(vd.ModelError, match="need steps ≤ T/8.*too many"):
        vd.laws.Record(np.zeros(20001), dt=0.01).pseudo_acceleration_spectrum([1e-5])


def test_response_spectrum_refusals(building):
    with pytest.raises(vd.ModelError, match="unknown combination 'sum'"):
        building.response_spectrum(spectrum, (1, 0, 0), "sum")
    with pytest.raises(vd.ModelError, match="direction"):
        building.response_spectrum(spectrum, (0, 0, 0))
    with pytest.raises(vd.ModelError, match="strictly increasing"):
        building.response_spectrum(([0.0, 1.0, 0.5], [1.0, 2.0, 3.0]), (1, 0, 0))
    with pytest.raises(vd.ModelError, match="≥ 0 \\(m/s²\\)"):
        building.response_spectrum(([0.0, 1.0], [1.0, -2.0]), (1, 0, 0))
    with pytest.raises(vd.ModelError, match="period 0.749.* outside the table"):
        building.response_spectrum(([0.0, 0.5], [1.0, 2.0]), (1, 0, 0))
    with pytest.raises(vd.ModelError, match="callable gave nan at T"):
        building.response_spectrum(lambda T: float("nan"), (1, 0, 0))
    with pytest.raises(vd.ModelError, match="damping ratios must be in"):
        building.response_spectrum(spectrum, (1, 0, 0), "cqc", damping=1.5)
    with pytest.raises(vd.ModelError, match="one per mode"):
        building.response_spectrum(spectrum, (1, 0, 0), "cqc", damping=[0.05, 0.02])
    with pytest.raises(vd.ModelError, match="n_modes"):
        building.response_spectrum(spectrum, (1, 0, 0), n_modes=7)
    with pytest.raises(vd.ModelError, match="needs S_a at T = 0"):
        building.response_spectrum(lambda T: 1.0 / T, (1, 0, 0), n_modes=1)
    with pytest.raises(vd.ModelError, match="moves no mass"):
        building.response_spectrum(spectrum, (0, 0, 1))
    with pytest.raises(vd.ModelError, match="zpa"):
        building.response_spectrum(spectrum, (1, 0, 0), zpa=-1.0)
    free = vd.Scene("free")
    free.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=1.0)
    fm = free.build().linearize(np.zeros(1)).modes()
    with pytest.raises(vd.ModelError, match="mode 1 is rigid"):
        fm.response_spectrum(spectrum, (1, 0, 0))


# ------------------------------------------------------------------ faces
def test_cli_spectrum_file_and_record(tmp_path, building):
    T = np.linspace(0.0, 3.0, 301)
    table = tmp_path / "ec8.txt"
    np.savetxt(table, np.column_stack([T, spectrum(T)]), header="T (s)  Sa (m/s^2)")
    code, out, err = _run(["spectrum", "three_storey_building", "--spectrum", str(table), "--direction", "1", "0",
                           "0", "--combination", "cqc", "--json"])
    assert code == 0, err
    d = json.loads(out)
    ref = building.response_spectrum((T, spectrum(T)), (1, 0, 0), "cqc")
    assert np.allclose(d["displacement"], ref.displacement, rtol=1e-12)
    assert d["modes_for_90_percent"] == 2 and d["combination"] == "cqc" and "rule" in d["rule_note"]
    rec = tmp_path / "rec.txt"
    np.savetxt(rec, _record().acceleration)
    png = tmp_path / "s.png"
    code, out, err = _run(["spectrum", "three_storey_building", "--record", str(rec), "--dt", "0.01",
                           "--direction", "1", "0", "0", "--png", str(png)])
    assert code == 0, err
    assert "base shear" in out and "SRSS" in out and png.stat().st_size > 1000
    code, out, err = _run(["spectrum", "three_storey_building", "--direction", "1", "0", "0"])
    assert code == 2 and "give one of --spectrum" in err
    code, out, err = _run(["spectrum", "three_storey_building", "--record", str(rec), "--direction", "1", "0", "0"])
    assert code == 2 and "give dt" in err and "rec.txt" in err


@pytest.mark.parametrize("path", sorted(MODELS.glob("*.toml")), ids=lambda p: p.stem)
def test_cli_spectrum_on_every_model(tmp_path, path):
    table = tmp_path / "flat.txt"
    np.savetxt(table, [[0.0, 1.0], [1e6, 1.0]])
    code, out, err = _run(["spectrum", str(path), "--spectrum", str(table), "--direction", "1", "0", "0"])
    assert code == 0 or (code == 2 and any(w in err for w in ("rigid", "unstable", "moves no mass", "vertical",
                                                                "equilibrium", "singular"))), err
    assert "Traceback" not in err


def test_plots(tmp_path, building):
    rec = _record()
    s = rec.pseudo_acceleration_spectrum(np.linspace(0, 2, 41))
    fig = s.plot(tmp_path / "rec.png")
    assert (tmp_path / "rec.png").stat().st_size > 1000 and fig.axes
    r = building.response_spectrum(s, (1, 0, 0), "cqc")
    r.plot(tmp_path / "rs.png")
    from vibdyn.faces.spectrum_plots import plot_response_spectrum

    plot_response_spectrum(tmp_path / "both.png", s, r, (np.array([0.0, 2.0]), np.array([1.0, 1.0])), g_units=True)
    with pytest.raises(vd.ModelError, match="nothing to draw"):
        plot_response_spectrum(tmp_path / "none.png")


def test_record_support_in_a_scene_file_runs_from_the_command_line(tmp_path):
    path = tmp_path / "rec.toml"
    path.write_text('[scene]\nname = "rec"\n[[body]]\nname = "mass"\nmass = 1.0\n'
                    'joint = { type = "slider", axis = [1.0, 0.0, 0.0] }\n[[support]]\nname = "ground"\n'
                    'motion = { law = "record", acceleration = [0.0, 1.0, -0.5, 0.0], dt = 0.1 }\n[[spring]]\n'
                    'name = "k"\na = ["ground", [-1.0, 0.0, 0.0]]\nb = "mass"\nstiffness = 100.0\nfree_length = 1.0\n')
    code, out, err = _run(["info", str(path)])
    assert code == 0 and "ground-acceleration record, 4 samples every 0.1 s" in out, err
    code, out, err = _run(["simulate", str(path), "--t-end", "1", "--no-progress"])
    assert code == 0, err
    bad = tmp_path / "bad.toml"
    bad.write_text(path.read_text().replace("dt = 0.1", "dt = -0.1"))
    with pytest.raises(vd.ModelError, match="support 'ground' motion.*record dt"):
        vd.load_scene(bad)


def test_design_spectra_of_the_codes():
    g = 9.80665
    ec8 = vd.eurocode8(0.25 * g, "C")
    a, S, TB, TC, TD = 0.25 * g, 1.15, 0.2, 0.6, 2.0  # EN 1998-1 Table 3.2, type 1, ground C
    for T, ref in ((0.0, a * S), (0.1, a * S * (1 + 0.1 / TB * 1.5)), (0.2, 2.5 * a * S), (0.6, 2.5 * a * S),
                   (1.2, 2.5 * a * S * TC / 1.2), (3.0, 2.5 * a * S * TC * TD / 9.0)):
        assert ec8(T) == pytest.approx(ref, rel=1e-14)
    assert vd.eurocode8(a, "C", damping=0.02)(0.4) == pytest.approx(2.5 * a * S * np.sqrt(10 / 7), rel=1e-14)
    assert vd.eurocode8(a, "A", spectrum_type=2)(0.1) == pytest.approx(2.5 * a, rel=1e-14)
    asce = vd.asce7(1.0, 0.6, 8.0)  # T_0 = 0.12 s, T_S = 0.6 s
    for T, ref in ((0.0, 0.4), (0.06, 0.7), (0.3, 1.0), (1.2, 0.5), (10.0, 0.6 * 8 / 100)):
        assert asce(T) == pytest.approx(ref * g, rel=1e-14)
    for bad, words in ((lambda: vd.eurocode8(2.0, "F"), "ground type"), (lambda: vd.eurocode8(2.0, "C", 3), "1 or 2"),
                       (lambda: vd.eurocode8(-1.0), "a_g"), (lambda: vd.asce7(0.5, 5.0, 4.0), "T_L"),
                       (lambda: ec8(-1.0), "period")):
        with pytest.raises(vd.ModelError, match=words):
            bad()
    code, out, err = _run(["spectrum", "three_storey_building", "--design", "ec8:0.25:C", "--direction", "1", "0",
                           "0", "--json"])
    assert code == 0, err
    modes = vd.load_scene("three_storey_building").build().operating_point().linearize(method="analytic").modes()
    assert np.allclose(json.loads(out)["displacement"], modes.response_spectrum(ec8, (1, 0, 0)).displacement,
                       rtol=1e-12)
    code, out, err = _run(["spectrum", "three_storey_building", "--design", "ec8:0.25", "--direction", "1", "0", "0"])
    assert code == 2 and "--design: expected" in err
