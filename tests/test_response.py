"""Responses of linear models against closed forms, the reference cases R4 and R5 (values recomputed
exactly in the scene files' [reference] tables) and independent integrations (scipy's solve_ivp)."""

import numpy as np
import pytest
from conftest import MODELS

import vibdyn as vd
from vibdyn.analysis.response import Hysteretic, transmissibility

X = (1.0, 0.0, 0.0)
EPS = np.finfo(float).eps
# Tolerances: a result's own error estimate (modes.relative_error, frf.relative_error, response.error, ...) wherever it
# has one; where a test checks an identity that holds to round-off (the same solve read two ways, a copied input), a
# stated multiple of ε × the condition number of the solve, or a fixed 1e-12..1e-14 on O(1) values (≥ 45 ε) with a
# comment.


def solved(name):
    scene = vd.load_scene(MODELS / f"{name}.toml")
    return scene.references, scene.build().operating_point().linearize()


def sdof(zeta, m=2.0, k=800.0, support=False):
    """A mass on a slider held by a spring k and a damper c = 2ζ√(km) (ω_n = 20 rad/s by default), to the
    ground or to a moving support."""
    s = vd.Scene("sdof")
    end = "world"
    if support:
        s.add_support("ground", vd.laws.HarmonicMotion((0, 0, 0.01), 15.0))
        end = "ground"
    s.add_body("mass", joint=vd.Slider((0, 0, 1), at=(0, 0, 1.0)), mass=m)
    s.add_spring("k", (end, (0, 0, 0)), "mass", stiffness=k)
    s.add_damper("c", (end, (0, 0, 0)), "mass", damping=2 * zeta * np.sqrt(k * m))
    return s.build().linearize()


def free_free(c=0.0):
    """Two masses (1 and 3 kg) on sliders joined by a spring of 12 N/m (and a damper c): one rigid mode,
    ω² = k(1/m1 + 1/m2) = 16."""
    s = vd.Scene("free-free")
    s.add_body("a", joint=vd.Slider(X, at=(0, 0, 0)), mass=1.0)
    s.add_body("b", joint=vd.Slider(X, at=(1, 0, 0)), mass=3.0)
    s.add_spring("k", "a", "b", stiffness=12.0)
    if c:
        s.add_damper("c", "a", "b", damping=c)
    return s.build().linearize()


def rel(a, b):
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


# ---------------------------------------------------------------------- R4: modal superposition
def test_R4_modes_and_mass_normalised_shapes():
    ref, lin = solved("two_mass_modal")
    m = lin.modes()
    np.testing.assert_allclose(m.omega, ref["omega"], rtol=m.relative_error)
    shapes = np.array(ref["modes"])  # columns, sign free
    for r in range(2):
        s = np.sign(shapes[:, r] @ m.shapes[:, r])
        np.testing.assert_allclose(s * m.shapes[:, r], shapes[:, r], atol=1e-9)
    np.testing.assert_allclose(m.shapes.T @ lin.M @ m.shapes, np.eye(2), atol=1e-12)  # eigh: round-off (2 × 2)


@pytest.mark.parametrize("method", ["modal", "state", "expm", "ivp"])
def test_R4_free_response_at_1_and_5_s(method):
    ref, lin = solved("two_mass_modal")
    r = lin.free_response(ref["times"], ref["x0"], ref["v0"], method=method)
    assert r.method == method
    tol = r.error  # m or rad (r.relative_error is relative to max|δq|)
    np.testing.assert_allclose(r.x, ref["response"], rtol=0, atol=tol)
    assert 0 <= r.relative_error < 1e-8 and r.elapsed > 0  # acceptance: ≤ 1e-6
    # the same in the textbook's absolute coordinates, through the point Jacobians of the masses
    pts = [("m1", (0, 0, 0), X), ("m2", (0, 0, 0), X)]
    np.testing.assert_allclose(r.displacement(pts), ref["response"], rtol=0, atol=tol)


def test_R4_free_response_is_the_modal_sum_and_conserves_energy():
    ref, lin = solved("two_mass_modal")
    m = lin.modes()
    t = np.linspace(0, 20, 201)
    x0 = np.array(ref["x0"])
    r = lin.free_response(t, x0)
    expected = sum(np.outer(np.cos(m.omega[k] * t), m.shapes[:, k] * (m.shapes[:, k] @ lin.M @ x0)) for k in range(2))
    np.testing.assert_allclose(r.x, expected, rtol=0, atol=r.error)
    energy = 0.5 * np.einsum("ti,ij,tj->t", r.v, lin.M, r.v) + 0.5 * np.einsum("ti,ij,tj->t", r.x, lin.K, r.x)
    np.testing.assert_allclose(energy, energy[0], rtol=2 * r.relative_error + 100 * EPS)  # E ∝ amplitude²
    # the accelerations are K q through M⁻¹: round-off of that solve (κ(M) × ε), not the response's error
    a_scale = np.abs(r.a).max()
    np.testing.assert_allclose(r.a, -np.linalg.solve(lin.M, lin.K @ r.x.T).T, rtol=0,
                               atol=100 * EPS * np.linalg.cond(lin.M) * a_scale)


# ---------------------------------------------------------------------- R5: receptance
@pytest.mark.parametrize("method", ["direct", "modal"])
def test_R5_receptances_at_1_rad_s(method):
    ref, lin = solved("receptance_damped")
    f = lin.receptance(ref["frequency"], method=method)
    a = f.alpha[0]
    for key, (j, k) in {"alpha11": (0, 0), "alpha12": (0, 1), "alpha22": (1, 1)}.items():
        assert abs(a[j, k] - complex(*ref[key])) <= f.relative_error * np.abs(a).max()
    assert abs(a[0, 1] - a[1, 0]) <= 10 * EPS * f.condition * np.abs(a).max()  # reciprocity, to round-off
    assert f.units(0, 0) == "m/N" and f.units(0, 0, "mobility") == "m/s/N"
    assert f.residual < 1e-13 and f.relative_error < 1e-9 and f.elapsed > 0  # a backward-stable solve: residual ~ ε


def test_R5_modal_sum_equals_direct_inverse_and_reciprocity():
    ref, lin = solved("receptance_damped")
    w = np.linspace(0.0, 8.0, 161)
    d, m = lin.receptance(w), lin.receptance(w, method="modal")
    M, K, C = (np.array(ref[k]) for k in ("mass_matrix", "stiffness_matrix", "damping_matrix"))
    exact = np.array([np.linalg.inv(K - x * x * M + 1j * x * C) for x in w])
    assert rel(d.alpha, exact) <= d.relative_error and rel(m.alpha, exact) <= m.relative_error
    np.testing.assert_allclose(d.alpha, d.alpha.transpose(0, 2, 1), rtol=0,
                               atol=10 * EPS * d.condition * np.abs(d.alpha).max())  # reciprocity, to round-off
    np.testing.assert_allclose(d.mobility, 1j * w[:, None, None] * d.alpha)
    np.testing.assert_allclose(d.accelerance, -(w ** 2)[:, None, None] * d.alpha)


def test_R5_peaks_and_antiresonance_of_alpha11():
    ref, lin = solved("receptance_damped")
    f = lin.receptance(np.linspace(0.1, 5.0, 60), "m1", "m1")  # a coarse grid: refinement does the work
    p = f.peaks()
    np.testing.assert_allclose(p.resonances, ref["peaks_alpha11"], rtol=1e-7)
    np.testing.assert_allclose(p.antiresonances, [ref["antiresonance_alpha11"]], rtol=1e-7)
    assert 0 < p.omega_error < 1e-6
    for w in p.resonances:  # true local maxima of |α11|
        a = np.abs(f.evaluate([w * (1 - 1e-4), w, w * (1 + 1e-4)])[:, 0, 0])
        assert a[1] > a[0] and a[1] > a[2]


def test_R5_point_channels_equal_coordinates():
    ref, lin = solved("receptance_damped")
    w = [0.5, 1.0, 3.0]
    by_name = lin.receptance(w, ["m1", "m2"], ["m1", "m2"])
    by_point = lin.receptance(w, [("m1", (0, 0, 0), X), ("m2", (0, 0, 0))], [("m1", (0, 0, 0), X), "m2"],
                              direction=X)
    # the same solve read through Jacobian rows equal to the unit rows up to round-off: 1e-12 ≈ 4500 ε
    np.testing.assert_allclose(by_point.alpha, by_name.alpha, rtol=1e-12)
    flipped = lin.receptance(w, [("m1", (0, 0, 0), (-2, 0, 0))], ["m1"])
    np.testing.assert_allclose(flipped.alpha[:, 0, 0], -by_name.alpha[:, 0, 0], rtol=1e-12)
    assert by_point.inputs[0] == "m1(0,0,0)·(1,0,0)"


@pytest.mark.parametrize("method", ["direct", "modal"])
def test_R5_hysteretic_variant(method):
    ref, lin = solved("receptance_damped")
    M, K = np.array(ref["mass_matrix"]), np.array(ref["stiffness_matrix"])
    w = np.linspace(0.0, 6.0, 61)
    f = lin.receptance(w, method=method, damping=Hysteretic(eta=0.02))
    exact = np.array([np.linalg.inv(K + 0.02j * K - x * x * M) for x in w])
    assert rel(f.alpha, exact) <= f.relative_error
    assert f.damping == "hysteretic: D = 0.02 K"
    # D = αM + βK, and per-mode loss factors: modal denominators ω_r²(1 + iη_r) − ω²
    g = lin.receptance(w, method=method, damping=Hysteretic(alpha=0.1, eta=0.03))
    assert (rel(g.alpha, np.array([np.linalg.inv(K + 1j * (0.1 * M + 0.03 * K) - x * x * M) for x in w]))
            <= g.relative_error)
    m = lin.modes()
    eta = np.array([0.01, 0.05])
    h = lin.receptance(w, method=method, damping=Hysteretic(modal=eta))
    modal = np.array([sum(np.outer(m.shapes[:, r], m.shapes[:, r]) / (m.omega2[r] * (1 + 1j * eta[r]) - x * x)
                          for r in range(2)) for x in w])
    assert rel(h.alpha, modal) <= h.relative_error


def test_mobility_and_half_power_of_a_single_degree_of_freedom():
    for zeta in (0.01, 0.05, 0.2):
        lin = sdof(zeta)
        f = lin.receptance(np.linspace(5.0, 40.0, 120))
        assert f.peaks(quantity="mobility").resonances == pytest.approx([20.0], rel=1e-7)  # ω_n exactly
        assert f.peaks().resonances == pytest.approx([20 * np.sqrt(1 - 2 * zeta ** 2)], rel=1e-7)
        for q in ("receptance", "mobility", "accelerance"):
            hp = f.half_power(quantity=q)
            # hp.error covers the refinement only (~1e-14); a relative error f.relative_error of the half-power
            # frequencies moves ζ = (ω2 − ω1)/2ω_n by up to f.relative_error (absolute)
            assert hp.zeta == pytest.approx([zeta], abs=hp.error[0] + f.relative_error)
            assert hp.error[0] < 1e-10 and hp.unresolved.size == 0


# ---------------------------------------------------------------------- base excitation
@pytest.mark.parametrize("zeta", [0.05, 0.5])
def test_transmissibility_of_a_base_excited_mass(zeta):
    lin = sdof(zeta, support=True)
    r = np.linspace(0.0, 4.0, 161)
    f = lin.base_response(20.0 * r, "ground", direction=(0, 0, 1))
    assert f.frf_type == "transmissibility" and f.units() == "m/m"
    np.testing.assert_allclose(np.abs(f.alpha[:, 0, 0]), transmissibility(r, zeta), rtol=1e-8)
    # the phase: X/Y = (k + icω)/(k − mω² + icω)
    H = (1 + 2j * zeta * r) / (1 - r ** 2 + 2j * zeta * r)
    np.testing.assert_allclose(f.alpha[:, 0, 0], H, rtol=1e-8, atol=1e-12)


def test_transmissibility_is_one_at_root_two_for_every_zeta():
    # a closed form evaluated in a few flops: 1e-15 ≈ 4.5 ε
    np.testing.assert_allclose(transmissibility(np.sqrt(2), [0.0, 0.01, 0.1, 1.0, 10.0]), 1.0, rtol=1e-15)
    for zeta in (0.01, 0.05, 0.2, 0.5, 1.0, 2.0):
        lin = sdof(zeta, support=True)
        for method in ("direct", "modal"):
            f = lin.base_response(20.0 * np.sqrt(2), "ground", direction=(0, 0, 1), method=method)
            assert abs(f.alpha[0, 0, 0]) == pytest.approx(1.0, rel=f.relative_error)


def test_base_excitation_through_a_prescribed_joint():
    """A base body on a slider carrying the mass on a second slider (relative coordinate) with k and c
    between them: prescribing the base coordinate, the absolute motion of the mass is T(r, ζ)."""
    zeta, m, k = 0.1, 2.0, 800.0
    s = vd.Scene("prescribed")
    s.add_body("base", joint=vd.Slider((0, 0, 1)), mass=5.0)
    s.add_body("mass", parent="base", joint=vd.Slider((0, 0, 1), at=(0, 0, 1.0)), mass=m)
    s.add_joint_spring("mass", stiffness=k)
    s.add_joint_damper("mass", damping=2 * zeta * np.sqrt(k * m))
    lin = s.build().linearize()
    r = np.linspace(0.1, 3.0, 30)
    absolute = ("mass", (0, 0, 0), (0, 0, 1))
    for method in ("direct", "modal"):
        f = lin.base_response(20.0 * r, "base", outputs=[absolute, "base", "mass"], method=method)
        np.testing.assert_allclose(np.abs(f.alpha[:, 0, 0]), transmissibility(r, zeta), rtol=1e-9)
        np.testing.assert_allclose(f.alpha[:, 1, 0], 1.0)  # the prescribed coordinate follows Y
        np.testing.assert_allclose(f.alpha[:, 2, 0], f.alpha[:, 0, 0] - 1.0,  # relative motion
                                   atol=f.relative_error * np.abs(f.alpha).max())
    # in time: the prescribed base moving as Y sin(ωt) from rest, against solve_ivp
    Y, w = 0.01, 25.0
    motion = vd.laws.Motion(lambda t: Y * np.sin(w * t), lambda t: Y * w * np.cos(w * t))
    t = np.linspace(0, 3, 601)
    a = lin.forced_response(t, support="base", motion=motion)
    b = lin.forced_response(t, support="base", motion=motion, method="ivp")
    assert rel(a.x, b.x) < 1e-8
    np.testing.assert_allclose(a.coordinate("base"), Y * np.sin(w * t), atol=1e-15)  # the input, copied


def test_road_profile_drives_the_steady_state_and_the_transient():
    """The documented road example: a harmonic road of wavelength λ driven over at speed v excites the
    support at ω = 2πv/λ; after the transient the linear response is the transmissibility times the road
    amplitude (about the operating point, which carries the damper's pre-load c·ẏ(0))."""
    zeta = 0.05
    lin = sdof(zeta, support=True)
    road = vd.laws.road(0.01, wavelength=2.0, speed=5.0)  # ω = 15.7 rad/s
    f = lin.base_response(road.omega, "ground", direction=(0, 0, 1))
    amplitude = 0.01 * abs(f.alpha[0, 0, 0])
    assert amplitude == pytest.approx(0.01 * transmissibility(road.omega / 20.0, zeta), rel=1e-8)
    t = np.linspace(0, 30, 6001)
    tr = lin.forced_response(t, support="ground", motion=road)
    tail = t[-1000:]
    fit, *_ = np.linalg.lstsq(np.column_stack([np.sin(road.omega * tail), np.cos(road.omega * tail),
                                               np.ones_like(tail)]), tr.x[-1000:, 0], rcond=None)
    assert np.hypot(fit[0], fit[1]) == pytest.approx(amplitude, rel=1e-8)
    check = lin.forced_response(t[:1201], support="ground", motion=road, method="ivp")
    assert rel(tr.x[:1201], check.x) < 1e-8


# ---------------------------------------------------------------------- forced transients
@pytest.mark.parametrize("method", ["modal", "state"])
def test_forced_transient_equals_direct_integration(method):
    ref, lin = solved("receptance_damped")
    t = np.linspace(0, 10, 501)
    force = lambda s: [np.sin(2.3 * s) + 0.5, 0.3 * np.cos(0.7 * s) ** 2]  # noqa: E731
    kw = dict(x0=[0.01, -0.02], v0=[0.1, 0.0])
    a = lin.forced_response(t, force, ["m1", "m2"], method=method, **kw)
    b = lin.forced_response(t, force, ["m1", "m2"], method="ivp", **kw)
    assert a.method == method and b.method == "ivp"
    assert rel(a.x, b.x) < 1e-8 and rel(a.v, b.v) < 1e-8  # acceptance: 1e-8
    assert a.relative_error < 1e-9 and b.relative_error < 1e-7
    # the equation of motion holds at every time point
    F = np.array([force(s) for s in t])
    # a is solved from M a = F − C v − K q: that holds to round-off, ε × κ(M) × the size of the terms
    terms = max(np.abs(F).max(), np.abs(a.x @ lin.K.T).max(), np.abs(a.v @ lin.C.T).max())
    np.testing.assert_allclose(a.a @ lin.M.T + a.v @ lin.C.T + a.x @ lin.K.T, F, rtol=0,
                               atol=100 * EPS * np.linalg.cond(lin.M) * terms)


def test_sampled_force_is_piecewise_linear_and_point_forces_act_through_the_jacobian():
    ref, lin = solved("receptance_damped")
    t = np.linspace(0, 8, 81)
    F = np.where(t < 2, t, np.maximum(0, 4 - t))  # a triangular pulse, exact on this grid
    a = lin.forced_response(t, F, [("m2", (0, 0, 0), X)], method="modal")
    b = lin.forced_response(t, lambda s: [np.interp(s, t, F)], ["m2"], method="ivp")
    c = lin.forced_response(t, F, ["m2"], method="state")
    assert rel(a.x, b.x) < 1e-8 and rel(c.x, b.x) < 1e-8


def test_harmonic_response_is_the_steady_state_of_the_transient():
    ref, lin = solved("receptance_damped")
    w = 2.0
    hr = lin.harmonic_response(w, 1.0, ["m1"], phase=0.3)
    t = np.linspace(0, 250, 12501)
    tr = lin.forced_response(t, lambda s: [np.cos(w * s + 0.3)], ["m1"])
    np.testing.assert_allclose(tr.x[-200:], hr.at(t[-200:]), rtol=0,
                               atol=(tr.error + hr.frf.relative_error) * np.abs(tr.x).max())
    assert hr.amplitude[0, 0] == pytest.approx(abs(lin.receptance(w).alpha[0, 0, 0]), rel=1e-14)  # the same solve


def test_general_damping_free_response_is_real_and_matches_integration():
    ref, lin = solved("receptance_damped")
    lin = lin.with_damping(np.diag([1.6, 0.0]))  # a damper on m1 only: not classical
    t = np.linspace(0, 10, 41)
    r = lin.free_response(t, [0.01, 0.02], [0.0, 0.1])
    ivp = lin.free_response(t, [0.01, 0.02], [0.0, 0.1], method="ivp")
    assert r.method == "state" and r.imaginary <= r.relative_error
    assert rel(r.x, ivp.x) <= r.relative_error + ivp.relative_error
    with pytest.raises(vd.ModelError, match="non-classical damping"):
        lin.free_response(t, [0.01, 0.0], method="modal")
    f = lambda s: [np.sin(3 * s), 0.0]  # noqa: E731
    assert rel(lin.forced_response(t, f).x, lin.forced_response(t, f, method="ivp").x) < 1e-8


def test_gyroscopic_R6_responses():
    lin = vd.load_scene(MODELS / "rotor_slider.toml").build().operating_point().linearize()
    t = np.linspace(0, 3, 31)
    r = lin.free_response(t, [0.0, 0.01], [0.1, 0.0])
    ivp = lin.free_response(t, [0.0, 0.01], [0.1, 0.0], method="ivp")
    assert r.method == "state" and r.imaginary <= r.relative_error
    assert rel(r.x, ivp.x) <= r.relative_error + ivp.relative_error
    # gyroscopic coupling breaks reciprocity: α(C)ᵀ = α(Cᵀ)
    w = np.linspace(0.5, 20, 40)
    a = lin.receptance(w).alpha
    assert np.abs(a[:, 0, 1] - a[:, 1, 0]).max() > 1e-3 * np.abs(a).max()
    f = lin.receptance(w)
    np.testing.assert_allclose(lin.with_damping(lin.C.T).receptance(w).alpha, a.transpose(0, 2, 1), rtol=0,
                               atol=2 * f.relative_error * np.abs(a).max())
    assert lin.receptance(w, method="modal").residual > 1e-2  # the modal sum says it is wrong here


# ---------------------------------------------------------------------- rigid and unstable modes
@pytest.mark.parametrize("c", [0.0, 0.8])
def test_rigid_body_modes(c):
    lin = free_free(c)
    m = lin.modes()
    assert m.rigid[0] and m.omega[1] == pytest.approx(4.0, rel=10 * m.omega_relative_error[1])
    w = np.linspace(0.3, 6, 40)
    d, s = lin.receptance(w), lin.receptance(w, method="modal")
    assert rel(s.alpha, d.alpha) <= d.relative_error + s.relative_error
    # far above the elastic mode both masses act as free masses: α_aa → −1/(m_a ω²)
    hi = lin.receptance(1e4, "a", "a").alpha[0, 0, 0]
    assert hi.real == pytest.approx(-1e-8, rel=1e-6)
    with pytest.raises(vd.ModelError, match="singular at ω = 0.*rigid-body"):
        lin.receptance(0.0, method="modal")
    # free response: the centre of mass moves as x̄0 + v̄0 t
    t = np.linspace(0, 5, 11)
    x0, v0 = [0.1, 0.0], [0.3, -0.2]
    ref = lin.free_response(t, x0, v0, method="expm")
    for method in ("modal", "state", "ivp"):
        r = lin.free_response(t, x0, v0, method=method)
        # both relative to max|δq|: "state" has an ill-conditioned basis here (~1e-6)
        tol = r.relative_error + ref.relative_error
        assert rel(r.x, ref.x) <= tol
        np.testing.assert_allclose(r.x @ [1, 3] / 4, 0.1 / 4 + (0.3 - 0.6) / 4 * t, atol=tol * np.abs(ref.x).max())
    f = lambda s: [np.sin(3 * s), 0.0]  # noqa: E731
    tt = np.linspace(0, 5, 201)
    assert rel(lin.forced_response(tt, f).x, lin.forced_response(tt, f, method="ivp").x) < 1e-8


def test_unstable_mode_grows_as_cosh():
    lin = vd.load_scene(MODELS / "inverted_bar_unstable.toml").build().linearize()
    m = lin.modes()
    assert m.unstable[0]
    s = np.sqrt(-m.omega2[0])
    t = np.linspace(0, 2, 9)
    r = lin.free_response(t, [0.01], [0.0], method="modal")
    np.testing.assert_allclose(r.x[:, 0], 0.01 * np.cosh(s * t), rtol=r.relative_error)


def test_modal_truncation_shows_in_the_residual():
    lin = vd.load_scene(MODELS / "chain5_fixed_fixed.toml").build().linearize().with_modal_damping(0.02)
    w = np.linspace(1, 70, 50)
    full = lin.receptance(w, method="modal")
    cut = lin.receptance(w, method="modal", n_modes=2)
    direct = lin.receptance(w)
    assert full.residual < 1e-12 and cut.residual > 1e-3  # every mode: the residual is round-off
    assert rel(full.alpha, direct.alpha) <= full.relative_error + direct.relative_error


# ---------------------------------------------------------------------- appropriation
def test_appropriation_excites_one_mode_in_quadrature():
    ref, lin = solved("receptance_damped")
    non_classical = lin.with_damping(np.diag([1.6, 0.0]))
    for model in (lin, non_classical):
        m = model.modes()
        for r in range(2):
            ap = model.appropriation(r)
            assert ap.exact and ap.omega == m.omega[r]
            w = m.omega[r]  # δq = −iφ_r up to the solve's round-off, ε × κ(K − ω²M + iωC)
            tol = 100 * EPS * np.linalg.cond(model.K - w * w * model.M + 1j * w * model.C)
            np.testing.assert_allclose(ap.response, -1j * m.shapes[:, r], rtol=0, atol=tol)
            np.testing.assert_allclose(ap.generalized_force, w * model.C @ m.shapes[:, r], rtol=0, atol=tol)
            assert ap.in_phase < tol and ap.mac == pytest.approx(1.0, abs=tol)
    # a damper on m1 only: a single exciter on m1 reproduces Cφ exactly
    assert non_classical.appropriation(0, ["m1"]).exact
    # one exciter elsewhere: tuned by the mode indicator function, nearly pure
    ap = lin.appropriation(0, [("m2", (0, 0, 0), X)])
    assert not ap.exact and 0 < ap.in_phase < 0.02 and ap.mac > 0.9999
    assert abs(ap.omega - 1.0) < 0.01
    Xw = lin.receptance(np.linspace(0.9, 1.1, 401), "m2").alpha[:, :, 0]  # every coordinate's response
    in_phase = np.linalg.norm(Xw.real, axis=1) / np.linalg.norm(Xw, axis=1)
    assert ap.in_phase <= in_phase.min() + 1e-9  # no frequency does better with this exciter


# ---------------------------------------------------------------------- bad input
def test_bad_inputs_are_model_errors():
    ref, lin = solved("receptance_damped")
    undamped = lin.with_damping(np.zeros((2, 2)))
    bad = [
        (lambda: lin.receptance(-1.0), "≥ 0"),
        (lambda: lin.receptance([1.0, np.nan]), "NaN"),
        (lambda: lin.receptance(1.0, "nope"), "unknown coordinate 'nope'"),
        (lambda: lin.receptance(1.0, [("m1", (0, 0, 0))]), "needs a direction"),
        (lambda: lin.receptance(1.0, [("m1", (0, 0, 0), (0, 0, 0))]), "zero length"),
        (lambda: lin.receptance(1.0, [("ghost", (0, 0, 0), X)]), "unknown body 'ghost'"),
        (lambda: lin.receptance(1.0, method="magic"), "unknown method"),
        (lambda: lin.receptance(1.0, damping="sticky"), "damping"),
        (lambda: undamped.receptance(undamped.modes().omega[1]), "singular.* at ω = 3.46"),
        (lambda: lin.receptance(1.0).peaks(quantity="jerk"), "unknown quantity"),
        (lambda: lin.receptance(1.0).get("m3"), "unknown output"),
        (lambda: lin.free_response([1.0], [0.0]), "x0"),
        (lambda: lin.free_response([1.0], [0.0, 0.0], method="magic"), "unknown method"),
        (lambda: lin.forced_response([0.0, 1.0, 0.5], lambda t: [0, 0]), "strictly increasing"),
        (lambda: lin.forced_response([0.0, 1.0], lambda t: [1.0, 2.0, 3.0]), "2 finite value"),
        (lambda: lin.forced_response([0.0, 1.0], lambda t: [np.nan, 0.0]), "finite"),
        (lambda: lin.forced_response([0.0, 1.0], np.zeros((3, 2))), "shape"),
        (lambda: lin.base_response(1.0, "nowhere"), "unknown support or coordinate 'nowhere'"),
        (lambda: lin.base_response(1.0, "m1"), None),  # a prescribed joint: valid
        (lambda: lin.forced_response([0.0, 1.0], support="m1"), "give motion="),
        (lambda: lin.harmonic_response(1.0, [1.0, 2.0, 3.0]), "one per input"),
        (lambda: lin.appropriation(5), "mode must be an index"),
        (lambda: undamped.appropriation(0), "undamped"),
        (lambda: free_free().with_modal_damping(0.1).appropriation(0), "rigid-body"),
        (lambda: Hysteretic(eta=-0.1), "must not be negative"),
        (lambda: lin.receptance(1.0, damping=Hysteretic(modal=[0.1, 0.2, 0.3])), "one per mode"),
        (lambda: transmissibility(1.0, 0.0), "infinite at r = 1"),
    ]
    for call, message in bad:
        if message is None:
            call()
            continue
        with pytest.raises(vd.ModelError, match=message):
            call()
    with pytest.raises(vd.ModelError, match="hysteretic damping has no time-domain form"):
        from vibdyn.analysis.response.damping import damped_model as _model
        from vibdyn.analysis.response.transient import _method

        _method(_model(lin, Hysteretic(eta=0.02)), "auto", "forced response")
