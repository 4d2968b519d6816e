"""Modal analysis: normalisation, orthogonality, rigid and unstable modes, damping models, MAC.

Tolerances: a result's own error estimate (modes.relative_error/residual, lin.K_error, traj.error, ...) wherever the
comparison is one the estimate covers; fixed 1e-15..1e-12 ones are identities that hold to round-off (a
few ε × the size of the terms: ΦᵀMΦ = 1 from eigh, a unit quaternion, a closed form in a few flops).
"""

import numpy as np
import pytest

import vibdyn as vd

G = 9.81


def slider_chain(masses, springs, dampers=None, walls=(True, True)):
    """Masses on sliders along x (absolute coordinates), springs between neighbours and to the walls."""
    s = vd.Scene("chain")
    x = np.arange(1, len(masses) + 1, dtype=float)
    for i, m in enumerate(masses):
        s.add_body(f"m{i + 1}", joint=vd.Slider((1, 0, 0), at=(x[i], 0, 0)), mass=m)
    ends = [("world", (0.0, 0, 0))] + [f"m{i + 1}" for i in range(len(masses))] + [("world", (x[-1] + 1, 0, 0))]
    pairs = list(zip(ends[:-1], ends[1:]))
    if not walls[0]:
        pairs = pairs[1:]
    if not walls[1]:
        pairs = pairs[:-1]
    for j, ((a, b), k) in enumerate(zip(pairs, springs)):
        if k:
            s.add_spring(f"k{j}", a, b, stiffness=k)
    for j, ((a, b), c) in enumerate(zip(pairs, dampers or [])):
        if c:
            s.add_damper(f"c{j}", a, b, damping=c)
    return s.build()


def test_normalisation_orthogonality_and_closed_form():
    """R1 fixed–fixed chain: ω_j = 2√(k/m) sin(jπ/(2(n+1))), shapes ∝ sin(p jπ/(n+1))."""
    n, k, m = 5, 1000.0, 1.0
    modes = slider_chain([m] * n, [k] * (n + 1)).linearize().modes()
    j = np.arange(1, n + 1)
    np.testing.assert_allclose(modes.omega, 2 * np.sqrt(k / m) * np.sin(j * np.pi / (2 * (n + 1))), rtol=1e-9)
    np.testing.assert_allclose(modes.frequency_hz, modes.omega / (2 * np.pi))
    M = modes.linear.M
    np.testing.assert_allclose(modes.shapes.T @ M @ modes.shapes, np.eye(n), atol=1e-12)
    np.testing.assert_allclose(modes.modal_stiffness, modes.omega**2, rtol=1e-9)
    exact_omega = 2 * np.sqrt(k / m) * np.sin(j * np.pi / (2 * (n + 1)))
    # finite differences: the estimate covers the error and stays small (the springs' forces, computed from
    # world positions a few m out, round off by ε·k·|x| per evaluation: ~1e-10 of ω at steps of 1e-5 m)
    assert np.all(np.abs(modes.omega - exact_omega) <= modes.omega_error)  # (rad/s)
    assert modes.orthogonality < 1e-10 and modes.omega_relative_error.max() < 1e-9
    p = np.arange(1, n + 1)
    exact = np.sin(np.outer(p, j) * np.pi / (n + 1))
    assert np.allclose(np.diag(vd.mac(modes.shapes, exact)), 1.0, atol=1e-12)
    assert modes.stability == "stable" and not modes.rigid.any() and not modes.unstable.any()
    assert modes.relative_error < 1e-8 and modes.elapsed > 0


def test_rigid_body_mode_is_exactly_zero():
    modes = slider_chain([1.0, 2.0], [0.0, 50.0, 0.0]).linearize().modes()
    assert modes.omega[0] == 0.0 and modes.omega2[0] == 0.0 and modes.rigid[0]
    assert modes.omega[1] == pytest.approx(np.sqrt(50.0 * (1 + 1 / 2.0)), rel=1e-9)
    assert modes.stability == "neutral"
    # the rigid mode is a translation of both masses together
    assert vd.mac(modes.shapes[:, 0], np.ones(2)) == pytest.approx(1.0, abs=1e-12)


def test_unstable_direction_is_flagged_never_nan():
    s = vd.Scene("inverted", gravity=(0, 0, -G))
    s.add_body("bar", joint=vd.Pivot((0, 1, 0)), mass=2.0, com=(0, 0, 0.5), inertia=vd.inertia.rod(2.0, 1.0))
    s.add_joint_spring("bar", 5.0)
    modes = s.build().linearize().modes()
    assert modes.unstable[0] and modes.stability == "unstable"
    growth = np.sqrt((2.0 * G * 0.5 - 5.0) / (2.0 / 3.0))
    assert modes.omega[0] == pytest.approx(growth, rel=1e-9)
    assert modes.omega2[0] == pytest.approx(-growth**2, rel=1e-9)
    assert np.all(np.isfinite(modes.omega)) and np.all(np.isfinite(modes.shapes))


def test_classical_damping_matches_state_form():
    """R5: C = M/5 + K/10 is proportional: ζ_r = φ_rᵀ C φ_r / (2 ω_r) and the real shapes."""
    system = slider_chain([2.0, 5.0], [12.0, 10.0, 0.0], dampers=[1.6, 1.0, 1.0])
    modes = system.linearize().modes()
    np.testing.assert_allclose(modes.linear.C, modes.linear.M / 5 + modes.linear.K / 10, atol=1e-9)
    assert modes.classical
    np.testing.assert_allclose(modes.omega, [1.0, np.sqrt(12.0)], rtol=1e-9)
    zeta_modal = np.einsum("ir,ij,jr->r", modes.shapes, modes.linear.C, modes.shapes) / (2 * modes.omega)
    np.testing.assert_allclose(modes.zeta, zeta_modal, rtol=1e-8)
    np.testing.assert_allclose(modes.zeta, [0.15, 0.2020725942], rtol=1e-8)
    np.testing.assert_allclose(modes.omega_n, modes.omega, rtol=1e-8)
    np.testing.assert_allclose(modes.omega_d, modes.omega * np.sqrt(1 - modes.zeta**2), rtol=1e-8)
    # the complex shapes of classical damping are real up to a common phase
    assert np.diag(vd.mac(modes.complex_shapes, modes.shapes)) == pytest.approx([1, 1], abs=1e-10)
    assert modes.stability == "stable"


def test_non_classical_damping_detected():
    modes = slider_chain([1.0, 1.0], [100.0, 100.0, 100.0], dampers=[5.0, 0.0, 0.0]).linearize().modes()
    assert not modes.classical
    lam = modes.eigenvalues
    assert lam.size == 4 and np.all(lam.real < 0)
    # every state eigenvalue satisfies det(λ²M + λC + K) = 0
    lin = modes.linear
    for z in lam:
        s = np.linalg.svd(z * z * lin.M + z * lin.C + lin.K, compute_uv=False)
        assert s[-1] <= 1e-9 * s[0]


def test_rayleigh_and_modal_damping_options():
    lin = slider_chain([1.0] * 4, [1000.0] * 5).linearize()
    w = lin.modes().omega
    alpha, beta = vd.rayleigh((0.02, 0.05), (w[0], w[3]))
    assert alpha / (2 * w[0]) + beta * w[0] / 2 == pytest.approx(0.02)
    ray = lin.with_rayleigh(zeta=(0.02, 0.05), omega=(w[0], w[3])).modes()
    np.testing.assert_allclose(ray.zeta[[0, 3]], [0.02, 0.05], rtol=1e-9)
    np.testing.assert_allclose(ray.zeta, alpha / (2 * w) + beta * w / 2, rtol=1e-9)
    modal = lin.with_modal_damping([0.01, 0.02, 0.03, 0.04]).modes()
    np.testing.assert_allclose(modal.zeta, [0.01, 0.02, 0.03, 0.04], rtol=1e-9)
    np.testing.assert_allclose(modal.omega_n, w, rtol=1e-9)
    with pytest.raises(vd.ModelError):
        vd.rayleigh((0.02, 0.05), (10.0, 10.0))


def test_mac_properties():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(6, 3)) + 1j * rng.normal(size=(6, 3))
    assert vd.mac(a[:, 0], a[:, 0] * (2 - 3j)) == pytest.approx(1.0)
    assert vd.mac(np.array([1.0, 0]), np.array([0.0, 1])) == 0.0
    M = vd.mac(a)
    np.testing.assert_allclose(M, M.T)
    assert np.all((M >= 0) & (M <= 1 + 1e-12))


def test_point_shapes_give_absolute_coordinates():
    """R2 built with sliders in series: point shapes along x give Rao's absolute-coordinate shapes."""
    s = vd.Scene("series")
    parent = "world"
    for i in range(3):
        s.add_body(f"m{i + 1}", parent, vd.Slider((1, 0, 0), at=(1.0, 0, 0)), mass=1.0)
        s.add_joint_spring(f"m{i + 1}", 1.0)
        parent = f"m{i + 1}"
    modes = s.build().linearize().modes()
    np.testing.assert_allclose(modes.omega, [0.4450419, 1.2469796, 1.8019377], rtol=1e-6)
    X = modes.point_shapes(["m1", "m2", "m3"], direction=(1, 0, 0))
    X = X / X[0]
    np.testing.assert_allclose(X[:, 0], [1, 1.801938, 2.246980], rtol=1e-6)
    np.testing.assert_allclose(X[:, 1], [1, 0.445042, -0.801938], rtol=1e-6)
    np.testing.assert_allclose(X[:, 2], [1, -1.246980, 0.554958], rtol=1e-6)


def test_modes_to_dict_is_json_ready():
    import json

    modes = slider_chain([2.0, 5.0], [12.0, 10.0, 0.0], dampers=[1.6, 1.0, 1.0]).linearize().modes()
    d = json.loads(json.dumps(modes.to_dict()))
    assert d["omega_rad_s"] == pytest.approx([1.0, np.sqrt(12)], rel=1e-9)
    assert len(d["eigenvalues"]) == 4 and "1" in str(modes).split("\n")[1]


@pytest.mark.parametrize("method", ["fd", "analytic"])
def test_stiff_spectrum_keeps_its_low_modes(method):
    """Stiffness ratio 1e8 along a chain: the soft mode is genuine, not rigid, and its own error estimate
    bounds its actual error (rule 2: right, or says how wrong). K = [[k_s + k_t, −k_t], [−k_t, k_t]], unit
    masses: ω² = (k_s + 2k_t ∓ √(k_s² + 4k_t²))/2, the low root in its cancellation-free form."""
    ks, kt = 1.0, 1e8  # wall–m1 soft, m1–m2 stiff
    modes = slider_chain([1.0, 1.0], [ks, kt, 0.0]).linearize(method=method).modes()
    assert not modes.rigid.any() and modes.stability == "stable"
    root = np.hypot(ks, 2 * kt)
    exact = np.sqrt([2 * ks * kt / (ks + 2 * kt + root), (ks + 2 * kt + root) / 2])
    actual = np.abs(modes.omega - exact)
    assert np.all(actual <= modes.omega_error)  # rad/s
    assert modes.omega_relative_error[0] < 1e-3
    np.testing.assert_allclose(modes.omega_error, modes.omega_relative_error * modes.omega, rtol=1e-14)


def test_frequency_error_is_the_first_order_effect_of_the_stiffness_error():
    """δω² = ‖Kφ − ω²Mφ‖_M⁻¹ + |φ|ᵀ(E + n·ε·|K|)|φ| per mode: with a stiffness error estimate E far above
    round-off, the relative error of ω reported per mode is |φ|ᵀE|φ| / 2ω² (the eigen residual and the
    ε terms are 1e-10 of it here)."""
    from dataclasses import replace

    lin = slider_chain([1.0, 2.0, 0.5], [100.0, 50.0, 80.0, 30.0]).linearize(method="analytic")
    rng = np.random.default_rng(5)
    E = 1e-6 * np.abs(lin.K).max() * rng.random(lin.K.shape)  # not symmetric: its quadratic form is
    m = replace(lin, K_error=E).modes()
    A = np.abs(m.shapes)
    expected = 0.5 * np.einsum("ij,ik,kj->j", A, E, A) / m.omega2
    np.testing.assert_allclose(m.omega_relative_error, expected, rtol=1e-8)
    np.testing.assert_allclose(m.omega_error, expected * m.omega, rtol=1e-8)  # the convention: *_error absolute
    assert m.relative_error == pytest.approx(expected.max(), rel=1e-8)
