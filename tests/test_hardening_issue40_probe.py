"""Adversarial probes of the features merged for issues 42 and 43 (issue 40's spirit: no confident wrong answer):
record spectra at long periods and extreme inputs, Campbell tracking and onset at high spin, response-spectrum
tables, and the CLI. Each number is checked against an independent oracle (a 50-digit matrix exponential, the
Jeffcott closed form), each estimate must cover the error."""


import numpy as np
import pytest
from oracles import cli as run
from test_rotor_stability import WN, K, M, fixed_rotor, spun_hub  # (the Jeffcott rotors of that file)

import vibdyn as vd
from vibdyn.errors import ModelError


# ----------------------------------------------------------------------------- record spectra
def _exact_undamped_long_period(acc, h, T):
    """S_a of ẍ + ω²x = −a(t) (a piecewise linear, then 0) at a long period, to ~40 digits (``decimal``): the exact
    step as the Taylor series of the exponential of the oscillator augmented with the input (a, ȧ), the peak the
    largest of the samples' |x| and the free vibration's amplitude after the record (at a long period the response
    grows through the record: no peak between samples)."""
    from decimal import Decimal, localcontext

    with localcontext() as ctx:
        ctx.prec = 50
        pi = Decimal("3.14159265358979323846264338327950288419716939937510")
        w, h = 2 * pi / Decimal(repr(float(T))), Decimal(repr(float(h)))
        X = [[Decimal(0)] * 4 for _ in range(4)]
        X[0][1], X[1][0], X[1][2], X[2][3] = h, -w * w * h, -h, h
        E = [[Decimal(int(i == j)) for j in range(4)] for i in range(4)]
        term = [row[:] for row in E]
        for k in range(1, 40):  # ‖X h‖ ≈ h: 40 terms are exact to the context's precision
            term = [[sum(term[i][m] * X[m][j] for m in range(4)) / k for j in range(4)] for i in range(4)]
            E = [[E[i][j] + term[i][j] for j in range(4)] for i in range(4)]
        x = v = best = Decimal(0)
        for a0, a1 in zip(acc[:-1], acc[1:]):
            a0, slope = Decimal(repr(float(a0))), (Decimal(repr(float(a1))) - Decimal(repr(float(a0)))) / h
            x, v = (E[0][0] * x + E[0][1] * v + E[0][2] * a0 + E[0][3] * slope,
                    E[1][0] * x + E[1][1] * v + E[1][2] * a0 + E[1][3] * slope)
            best = max(best, abs(x))
        return float(max(best, (x * x + (v / w) ** 2).sqrt()) * w * w)


@pytest.mark.parametrize("T", [3e3, 1e5, 1e12])
def test_record_spectrum_is_exact_at_long_periods(T):
    """The closed-form step cancels as ε/(ωh)² at long periods (1.6e-2 of B at T = 3000 s, ζ = 0.05): S_a was off
    by 2e-7 (stated 1e-8) at 3000 s and by 1e8 × at 1e12 s (1.7e-5 m/s² ± 3e-20 against 1.5e-13)."""
    acc = np.random.default_rng(1).normal(size=40)
    s = vd.laws.Record(acc, dt=0.01).pseudo_acceleration_spectrum([T], damping=0.0)
    exact = _exact_undamped_long_period(acc, 0.01, T)
    err = abs(s.pseudo_acceleration[0] - exact)
    assert err <= s.error[0], (s.pseudo_acceleration[0], exact, s.error[0])
    assert s.error[0] < 1e-11 * exact  # an estimate, not a shrug


def test_record_spectrum_damped_long_period_against_the_exponential():
    """ζ = 0.05 at T = 3000 s: the closed form's B was 1.6e-2 off; against the step from scipy's expm (the
    augmented oscillator, independent of Nigam & Jennings' formulas) propagated in long double steps."""
    import scipy.linalg as sla

    acc = np.random.default_rng(1).normal(size=40)
    T, z, h = 3000.0, 0.05, 0.01
    w = 2 * np.pi / T
    X = np.zeros((4, 4))
    X[0, 1], X[1, 0], X[1, 1], X[1, 2], X[2, 3] = 1.0, -w * w, -2 * z * w, -1.0, 1.0
    E = sla.expm(X * h)
    s = np.zeros(4)
    peak = 0.0
    for a0, a1 in zip(acc[:-1], acc[1:]):
        s = E @ np.array([s[0], s[1], a0, (a1 - a0) / h])
        peak = max(peak, abs(s[0]))
    # the free vibration after the record: its first extremum (the largest), ζ small
    wd = w * np.sqrt(1 - z * z)
    tau = np.mod(np.arctan2(s[1] * wd, w * w * s[0] + z * w * s[1]), np.pi) / wd
    F = sla.expm(X[:2, :2] * tau)
    peak = max(peak, abs(F[0] @ s[:2]))
    r = vd.laws.Record(acc, dt=h).pseudo_acceleration_spectrum([T], damping=z)
    assert abs(r.pseudo_acceleration[0] - w * w * peak) <= r.error[0] + 1e-12 * w * w * peak
    assert r.error[0] < 1e-10 * r.pseudo_acceleration[0]  # 1e-4 stated (and 2.5e-7 actual) before


@pytest.mark.parametrize("periods, dt", [([1e-300], 0.1), ([1e300], 0.1), ([0.1], 1e300)])
def test_record_spectrum_extreme_periods_and_steps_are_refused_or_finite(periods, dt):
    """A period of 1e-300 s gave NaN ± NaN (an int cast of inf sub-steps); dt = 1e300 s gave [3, inf] ± NaN."""
    try:
        s = vd.laws.Record([1.0, -1.0, 0.5], dt=dt).pseudo_acceleration_spectrum(periods)
    except ModelError as e:
        assert "record" in str(e)
        return
    assert np.all(np.isfinite(s.pseudo_acceleration)) and np.all(np.isfinite(s.error))
    assert np.all(np.abs(s.pseudo_acceleration) <= s.error + 1e-250)  # T = 1e300 s: S_a = ω² S_d = 0


@pytest.mark.parametrize("call", [lambda r: r.ground(float("nan")), lambda r: r.ground(float("inf")),
                                  lambda r: r.position("a"), lambda r: vd.laws.Record.from_file(3, dt=0.1)],
                         ids=["nan", "inf", "str", "path int"])
def test_record_refuses_non_numbers(call):
    """Raw ValueError / OverflowError / TypeError before."""
    with pytest.raises(ModelError, match="record"):
        call(vd.laws.Record([0.0, 1.0, -1.0], dt=0.1))


# ----------------------------------------------------------------------------- Campbell at high spin
def test_campbell_tracks_whirls_of_one_shape_at_high_spin_and_finds_jeffcotts_onset():
    """Above Ω = ω_n a rotating frame's forward and backward modes have one shape (MAC 1) and move by the same
    amount: the sum of frequency distances tied and the columns swapped at every other speed (σ and δ of two
    modes interleaved), and onset() raised 'the value jumps there' at a bracket with no root. The onset found
    next had 2.2e-6 rad/s stated for 1.35e-3 actual (the slope taken between Brent's last, noise-close points)."""
    cr, cn = 1e-3, 3.0
    threshold = WN * (1 + cn / cr)
    c = vd.campbell(spun_hub(cr, cn).build(), "hub", np.linspace(0.0, 2 * threshold, 9))
    for s, sig, err in zip(c.speeds, c.sigma, c.error):
        lam = np.roots([M, cn + cr, K - 1j * cr * s])  # fixed frame; the rotating one shifts Im λ only
        assert np.sort(sig) == pytest.approx(np.sort(lam.real), abs=10 * err.max())
    for j in range(2):  # one whirl per column beyond rest: no swaps
        assert len(set(c.whirl[1:, j])) == 1
        assert np.all(np.diff(c.sigma[1:, j]) * np.sign(c.sigma[-1, j] - c.sigma[1, j]) > 0)
    (onset,) = c.onset()
    assert onset.kind == "instability" and onset.whirl == "forward"
    assert abs(onset.speed - threshold) <= onset.speed_error
    assert onset.speed_error < 1e-4 * threshold


def test_undamped_log_decrement_is_plus_zero():
    d = vd.campbell(fixed_rotor(c=0.0).build(), "disk", [0.0, 100.0])
    assert np.all(d.log_dec == 0) and not np.any(np.signbit(d.log_dec))  # "-0" in tables and JSON before


# ----------------------------------------------------------------------------- response-spectrum tables
def test_two_by_two_spectrum_table_is_ambiguous_and_refused():
    """[[0, 1], [5, 3]] read as the rows (periods 0, 1; S_a 5, 3) though written as (T, S_a) pairs, silently."""
    s = vd.Scene("sdof")
    s.add_body("m", joint=vd.Slider((1, 0, 0)), mass=2.0)
    s.add_joint_spring("m", 800.0)
    modes = s.build().linearize(np.zeros(1), method="analytic").modes()
    with pytest.raises(ModelError, match="2 × 2"):
        modes.response_spectrum([[0.0, 1.0], [5.0, 3.0]], (1, 0, 0))
    # an unambiguous 2 × 2 (only one reading has increasing periods) is read that way
    r = modes.response_spectrum([[0.0, 0.0], [5.0, 3.0]], (1, 0, 0))  # pairs (0 s, 0), (5 s, 3 m/s²)
    T = 2 * np.pi / np.sqrt(400.0)
    assert r.spectral_acceleration[0] == pytest.approx(3.0 * T / 5.0, rel=1e-12)


# ----------------------------------------------------------------------------- the CLI
@pytest.mark.parametrize("extra, words", [(["--damping", "-0.1"], "damping ratio"), (["--damping", "nan"], "damping"),
                                          (["--design", "ec8:0.3:Z"], "ground type"),
                                          (["--design", "asce7:1:0.5:-3"], "T_L")])
def test_spectrum_cli_names_the_wrong_value(extra, words):
    """A negative damping ratio was reported as '--design: expected ec8:AG:GROUND…, got 'ec8:0.3:B'' (the code's
    own refusal swallowed by the parser's except ValueError)."""
    argv = ["spectrum", "three_storey_building", "--direction", "1", "0", "0"]
    argv += extra if extra[0] == "--design" else ["--design", "ec8:0.3:B", *extra]
    code, out, err = run(argv)
    assert code == 2 and err.startswith("vibdyn: error:") and words in err and "expected ec8" not in err, err


def test_design_spectra_take_arrays_and_refuse_non_numbers():
    """S_a('a') ended in float()'s ValueError and S_a([0.1, 0.2]) in a TypeError; EN 1998-1 type 1, ground B:
    S = 1.2, T_B = 0.15 s, T_C = 0.5 s, η = 1 at 5 %."""
    s = vd.eurocode8(0.3 * 9.80665, "B")
    ag = 0.3 * 9.80665
    expected = [ag * 1.2 * (1 + 0.1 / 0.15 * 1.5), 2.5 * ag * 1.2, 2.5 * ag * 1.2 * 0.5 / 1.0]
    assert s(np.array([0.1, 0.3, 1.0])) == pytest.approx(expected, rel=1e-14)
    assert s([[0.1, 0.3]]).shape == (1, 2)
    for bad in ("a", float("nan"), None):
        with pytest.raises(ModelError, match="period"):
            s(bad)


def test_a_tuple_of_periods_and_accelerations_is_two_rows():
    """The documented (periods, S_a) form stays two rows even at two periods (the CLI passes its file so)."""
    s = vd.Scene("sdof")
    s.add_body("m", joint=vd.Slider((1, 0, 0)), mass=2.0)
    s.add_joint_spring("m", 800.0)
    modes = s.build().linearize(np.zeros(1), method="analytic").modes()
    r = modes.response_spectrum((np.array([0.0, 1.0]), np.array([5.0, 3.0])), (1, 0, 0))
    T = 2 * np.pi / np.sqrt(400.0)
    assert r.spectral_acceleration[0] == pytest.approx(5.0 - 2.0 * T, rel=1e-12)


@pytest.mark.parametrize("values, top", [([100.0, 1e3, 1e4], 200.0), ([1e-2, 1e10], 2e5)])
def test_critical_speed_map_of_an_isotropic_rotor_is_sqrt_k_over_m(values, top):
    """A critical speed far below its bracket's end (ω_n = 7.07 rad/s in [0, 25]) stalled the continuation in μ
    ('50 steps taken'): the map of the textbook Jeffcott ended in a ConvergenceError; Brent's method inside the
    bracket now takes over."""
    m = vd.critical_speed_map(lambda k: fixed_rotor(c=0.0, k=k), values, "disk", np.linspace(0.0, top, 9))
    for k, row, err in zip(values, m.speeds, m.errors):
        exact = np.sqrt(k / M)
        assert row.count() == 1  # the x and y modes reach one speed: counted once
        assert abs(row[0] - exact) <= err[0] and err[0] < 1e-6 * exact


def test_base_shear_of_a_chain_with_mass_ratio_1e8_is_the_modal_sum():
    """Masses 1.4e-6 … 243 kg, stiffnesses 70 … 2.4e8 N/m (ω from 0.53 to 8.5e6 rad/s): the base shear came out
    631 or 657 N ± 0.005 against 663.01 N (M⁻¹K as a matrix amplified a low mode's round-off by (ω_max/ω_1)²).
    Oracle: scipy's eigh of the exact M and K in the sliders' relative coordinates, V = SRSS of Γ_n² S_a(T_n)
    (equal to k_1 u_1 mode by mode)."""
    import scipy.linalg as sla

    m = np.array([3.32e-06, 3.53e-06, 242.536833, 22.6677637, 1.38e-06])
    k = np.array([2.42041916e+08, 109.4, 240.3, 181752.6, 69.6])
    s = vd.Scene("chain")
    parent = "world"
    for i, (mi, ki) in enumerate(zip(m, k)):
        s.add_body(f"b{i}", parent=parent, joint=vd.Slider((1, 0, 0)), mass=float(mi))
        s.add_joint_spring(f"b{i}", float(ki))
        parent = f"b{i}"
    modes = s.build().linearize(np.zeros(m.size), method="analytic").modes()
    spectrum = lambda T: 2.5 + 4.0 * T * np.exp(-2.0 * T)  # noqa: E731
    Tr = np.tril(np.ones((m.size, m.size)))  # absolute displacements = Tr @ relative ones
    w2, Phi = sla.eigh(np.diag(k), Tr.T @ np.diag(m) @ Tr)
    gamma = Phi.T @ (Tr.T @ m)
    Vn = gamma ** 2 * np.array([spectrum(2 * np.pi / np.sqrt(x)) for x in w2])
    for rule, ref in (("srss", np.sqrt(Vn @ Vn)), ("abs", np.abs(Vn).sum())):
        r = modes.response_spectrum(spectrum, (1, 0, 0), rule)
        assert abs(r.base_shear - ref) <= r.base_shear_error, (rule, r.base_shear, ref, r.base_shear_error)
        assert r.modal_base_shear == pytest.approx(Vn, rel=1e-6, abs=1e-12 * ref)


def test_displacement_error_covers_a_coordinate_that_barely_moves():
    """Masses 4.9e-5 … 794 kg, stiffnesses 4.6 … 5.3e7 N/m: the last (stiff) spring's deflection is 4.59e-12 m
    (a 40-digit eigen-solution), float64 eigen-solvers give 7.5e-11 (vibdyn) or 6.0e-11 (scipy) — a shape's
    error mixes other modes into it — and vibdyn stated ± 2.3e-12 (the error spread by |φ_n| alone)."""
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 40
    m = np.array([0.48186453, 259.806402, 205.63132, 8.8338e-04, 793.869708, 4.887e-05])
    k = np.array([2.56606801e+07, 26.0, 4424.7, 4.6, 5.27655392e+07, 2.87860873e+07])
    n = m.size
    s = vd.Scene("chain")
    parent = "world"
    for i in range(n):
        s.add_body(f"b{i}", parent=parent, joint=vd.Slider((1, 0, 0)), mass=float(m[i]))
        s.add_joint_spring(f"b{i}", float(k[i]))
        parent = f"b{i}"
    spectrum = lambda T: 2.5 + 4.0 * T * np.exp(-2.0 * T)  # noqa: E731
    r = s.build().linearize(np.zeros(n), method="analytic").modes().response_spectrum(spectrum, (1, 0, 0))
    Tr = mp.matrix(n, n)
    for i in range(n):
        for j in range(i + 1):
            Tr[i, j] = 1
    Mr = Tr.T * mp.diag([mp.mpf(float(x)) for x in m]) * Tr
    Li = mp.cholesky(Mr) ** -1
    E, Q = mp.eigsy(Li * mp.diag([mp.mpf(float(x)) for x in k]) * Li.T)
    Phi = Li.T * Q
    L = Tr.T * mp.matrix([mp.mpf(float(x)) for x in m])
    peaks = [mp.mpf(0)] * n
    for j in range(n):
        w2, ph = E[j], Phi[:, j]
        g = (ph.T * L)[0]
        Sa = 2.5 + 4 * (2 * mp.pi / mp.sqrt(w2)) * mp.exp(-2 * (2 * mp.pi / mp.sqrt(w2)))
        peaks = [p + (ph[i] * g * Sa / w2) ** 2 for i, p in enumerate(peaks)]
    exact = np.array([float(mp.sqrt(p)) for p in peaks])
    assert np.all(np.abs(r.displacement - exact) <= r.displacement_error), (r.displacement, exact)


def test_seismic_combine_refuses_wrong_rows_and_a_record_itself():
    """combine() of NaN rows gave NaN ± NaN, of rows of the wrong width numpy's matmul error; a Record given as
    the spectrum said only 'expected numbers'."""
    modes = vd.load_scene("three_storey_building").build().operating_point().linearize(method="analytic").modes()
    r = modes.response_spectrum(lambda T: 3.0, (1, 0, 0))
    for rows in (np.full((1, 3), np.nan), np.ones((2, 5)), "abc"):
        with pytest.raises(ModelError, match="combine"):
            r.combine(rows)
    with pytest.raises(ModelError, match="pseudo_acceleration_spectrum"):
        modes.response_spectrum(vd.laws.Record([0.0, 1.0, -1.0], dt=0.01), (1, 0, 0))


@pytest.mark.parametrize("spin", [1e100, 1e140, 1e200, 1e300])
def test_gyroscopic_whirl_at_absurd_spins_is_right_or_not_claimed(spin):
    """A rigid rotor on a gimbal: its forward whirl tends to I_p Ω / I_t (1.5 Ω here). LAPACK's QR algorithm caps
    the eigenvalue near 1.5e138 (it said 1.49e138 ± 7e125 at 1e140 rad/s); the QZ one, asked when a pair's backward
    error exceeds the QR's promise, gives 1.5 Ω within the stated error."""
    system = vd.load_scene("gimbal_rotor").build()
    c = vd.campbell(system, "rotor", [0.0, spin])
    fast = c.omega[-1].max()
    G = 0.12 * spin  # (I_p Ω; I_t = 0.08 kg·m², k = 300 N·m/rad: ω = (G + √(G² + 4 I_t k)) / 2 I_t)
    closed = G * (1 + np.sqrt(1 + 96.0 / G / G)) / 0.16
    assert abs(fast - closed) <= c.error[-1].max() + 1e-14 * closed
    assert c.error[-1].max() <= 1e-10 * closed
