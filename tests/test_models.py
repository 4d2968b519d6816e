"""Every scene of models/ loads, builds and reproduces its reference values from the 3-D multibody model.

Stiffness and damping come from central differences of ``System.inverse_dynamics`` (configurations
perturbed with ``System.integrate``), the mass matrix from CRBA: no hand-typed M or K. Frequencies are
compared to 1e-6 relative.

Tolerances: direct evaluations (CRBA, RNEA, ABA, kinematics, energies, parsed numbers) carry no error
estimate; their error is round-off, a few ε × the size of the terms (× κ(M) where M is solved). Fixed
1e-15..1e-12 relative (≈ 4.5–4500 ε) bound it on these small, well-conditioned models; 1e-10 where M is
solved or another engine's arithmetic is compared. Results that carry an estimate are checked against it.
"""

import math

import numpy as np
import pytest
import scipy.linalg as sl
from conftest import MODELS

import vibdyn as vd
from vibdyn.io.scenewrite import save_scene, scene_to_dict

FILES = sorted(MODELS.glob("*.toml"))
RTOL = 1e-6


def load(name):
    return vd.load_scene(MODELS / f"{name}.toml")


def _central(f, n, h):
    """Columns (f(+h e_k) − f(−h e_k)) / 2h, k = 0…n−1."""
    J = np.empty((n, n))
    for k in range(n):
        e = np.zeros(n)
        e[k] = h
        J[:, k] = (f(e) - f(-e)) / (2 * h)
    return J


def stiffness(system, q0, v0=None, a0=None, h=1e-6):
    """K = ∂/∂q inverse_dynamics(q, v0, a0) in the tangent space, by central differences."""
    v0 = np.zeros(system.nv) if v0 is None else v0
    a0 = np.zeros(system.nv) if a0 is None else a0
    return _central(lambda e: system.inverse_dynamics(system.integrate(q0, e), v0, a0), system.nv, h)


def damping(system, q0, v0=None, a0=None, h=1e-6):
    """C = ∂/∂v inverse_dynamics(q0, v, a0), by central differences (exact up to round-off: quadratic in v)."""
    v0 = np.zeros(system.nv) if v0 is None else v0
    a0 = np.zeros(system.nv) if a0 is None else a0
    return _central(lambda e: system.inverse_dynamics(q0, v0 + e, a0), system.nv, h)


def modes(system, q0):
    """(ω² ascending, mass-normalised modes) about a static equilibrium q0."""
    M, K = system.mass_matrix(q0), stiffness(system, q0)
    assert np.abs(K - K.T).max() <= 1e-6 * max(np.abs(K).max(), 1.0), "K not symmetric: not an equilibrium?"
    return sl.eigh(0.5 * (K + K.T), M)


def point_jacobian(system, q0, points, axis=0, h=1e-6):
    """∂(world coordinate ``axis`` of each (body, point))/∂q: maps joint-coordinate modes to displacements."""
    J = np.empty((len(points), system.nv))
    for k in range(system.nv):
        e = np.zeros(system.nv)
        e[k] = h
        qp, qm = system.integrate(q0, e), system.integrate(q0, -e)
        J[:, k] = [(system.point_position(b, p, qp)[axis] - system.point_position(b, p, qm)[axis]) / (2 * h)
                   for b, p in points]
    return J


def assert_omega(w2, reference):
    reference = np.asarray(reference, dtype=float)
    assert w2.shape == reference.shape
    scale = max(np.abs(w2).max(), 1.0)
    for lam, ref in zip(w2, reference):
        if ref == 0.0:
            assert abs(lam) <= 1e-8 * scale, (lam, ref)
        else:
            assert lam > 0 and math.sqrt(lam) == pytest.approx(ref, rel=RTOL), (math.sqrt(max(lam, 0)), ref)


def assert_shapes(phi, reference, tol=1e-6):
    """Columns of phi against reference shapes (one list per mode), up to scale and sign."""
    for j, ref in enumerate(reference):
        a, b = phi[:, j], np.asarray(ref, dtype=float)
        a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
        a = a * np.sign(a @ b)
        np.testing.assert_allclose(a, b, atol=tol, err_msg=f"mode {j + 1}")


# ------------------------------------------------------------------ every model


def test_there_are_models():
    names = {p.stem for p in FILES}
    assert {"trailer", "chain5_fixed_fixed", "chain5_fixed_free", "chain3_prestressed", "rao_three_mass_ground",
            "rao_three_mass_series", "double_pendulum", "triple_pendulum", "rod_pivot", "rod_ball",
            "inverted_bar_stable", "inverted_bar_unstable", "two_mass_modal", "receptance_damped", "rotor_slider",
            "iftomm_a01", "helical"} <= names


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_model_loads_builds_and_has_source_and_reference(path, tmp_path):
    scene = vd.load_scene(path)
    assert scene.name == path.stem
    assert isinstance(scene.source, str) and len(scene.source) > 10
    assert isinstance(scene.references, dict) and scene.references
    assert isinstance(scene.references.get("note"), str)
    system = scene.build()
    assert system.nv >= 1
    q0 = system.start_configuration()[0]  # (the trammel's spring has no direction at its neutral configuration)
    assert np.all(np.isfinite(system.accelerations(q0, np.zeros(system.nv))))
    # and it survives a write/read cycle unchanged
    save_scene(scene, tmp_path / path.name)
    assert scene_to_dict(vd.load_scene(tmp_path / path.name)) == scene_to_dict(scene)


# ------------------------------------------------------------------ R1, R2: chains of sliders


ABSOLUTE_CHAINS = ["chain5_fixed_fixed", "chain5_fixed_free", "rao_three_mass_ground", "rao_three_mass_series",
                   "two_mass_modal", "receptance_damped"]


@pytest.mark.parametrize("name", ABSOLUTE_CHAINS)
def test_chain_neutral_is_the_equilibrium(name):
    system = load(name).build()
    q0 = system.neutral()
    np.testing.assert_allclose(system.accelerations(q0, np.zeros(system.nv)), 0.0, atol=1e-12)


@pytest.mark.parametrize("name", ["chain5_fixed_fixed", "chain5_fixed_free", "rao_three_mass_ground",
                                  "rao_three_mass_series"])
def test_chain_frequencies_and_shapes(name):
    scene = load(name)
    system = scene.build()
    q0 = system.neutral()
    w2, phi = modes(system, q0)
    assert_omega(w2, scene.references["omega"])
    # shapes are given in absolute displacements of the masses: map the joint-coordinate modes
    masses = [(b, (0.0, 0.0, 0.0)) for b in system.bodies]
    assert_shapes(point_jacobian(system, q0, masses) @ phi, scene.references["shapes"])


def test_ground_and_series_chains_agree():
    a, b = load("rao_three_mass_ground").build(), load("rao_three_mass_series").build()
    wa, _ = modes(a, a.neutral())
    wb, _ = modes(b, b.neutral())
    np.testing.assert_allclose(wa, wb, rtol=1e-8)
    # relative coordinates: the series mass matrix is not diagonal, the ground one is
    assert np.count_nonzero(b.mass_matrix(b.neutral()) - np.diag(np.diag(b.mass_matrix(b.neutral())))) > 0
    np.testing.assert_array_equal(a.mass_matrix(a.neutral()), np.eye(3))


def test_prestressed_chain_equilibrium_and_frequencies():
    scene = load("chain3_prestressed")
    system = scene.build()
    ref = scene.references
    q = system.neutral()
    zero = np.zeros(system.nv)
    assert np.abs(system.accelerations(q, zero)).max() > 1.0  # the neutral guess is not the equilibrium
    for _ in range(20):  # Newton in the tangent space
        r = system.inverse_dynamics(q, zero, zero)
        if np.abs(r).max() < 1e-12:
            break
        q = system.integrate(q, -np.linalg.solve(stiffness(system, q), r))
    np.testing.assert_allclose(system.accelerations(q, zero), 0.0, atol=1e-10)
    np.testing.assert_allclose(system.difference(system.neutral(), q), ref["equilibrium_q"], atol=1e-10)
    centres = [system.point_position(b, (0, 0, 0), q)[0] for b in system.bodies]
    np.testing.assert_allclose(centres, ref["equilibrium"], atol=1e-10)
    w2, _ = modes(system, q)
    assert_omega(w2, ref["omega"])
    # the springs carry their pre-stress: the wall spring's tension, from the reaction on block 1
    sp = system.point_position("block1", (-0.05, 0, 0), q)[0]
    assert 100.0 * (sp - 0.2) == pytest.approx(ref["spring_tension"], rel=1e-9)


# ------------------------------------------------------------------ R3: pendulums


@pytest.mark.parametrize("name", ["double_pendulum", "triple_pendulum", "rod_pivot", "rod_ball", "inverted_bar_stable"])
def test_pendulum_frequencies(name):
    scene = load(name)
    system = scene.build()
    q0 = system.neutral()
    np.testing.assert_allclose(system.accelerations(q0, np.zeros(system.nv)), 0.0, atol=1e-12)
    w2, _ = modes(system, q0)
    assert_omega(w2, scene.references["omega"])


def test_inverted_bar_unstable():
    scene = load("inverted_bar_unstable")
    ref = scene.references
    system = scene.build()
    q0 = system.neutral()
    w2, _ = modes(system, q0)
    assert ref["stable"] is False
    assert w2[0] == pytest.approx(ref["omega_squared"][0], rel=RTOL)
    # the tilted equilibria: at rest there, and stable with the reference frequency
    for sign in (1.0, -1.0):
        q = system.integrate(q0, np.array([sign * ref["tilted_equilibrium"]]))
        np.testing.assert_allclose(system.accelerations(q, np.zeros(1)), 0.0, atol=1e-10)
        w2, _ = modes(system, q)
        assert_omega(w2, ref["tilted_omega"])


# ------------------------------------------------------------------ R4: modal superposition


def test_two_mass_modal():
    scene = load("two_mass_modal")
    ref = scene.references
    system = scene.build()
    q0 = system.neutral()
    M = system.mass_matrix(q0)
    w2, phi = modes(system, q0)
    assert_omega(w2, ref["omega"])
    R = np.array(ref["modes"])  # columns, mass-normalised, sign free
    phi = phi * np.sign(np.sum(phi * R, axis=0))
    np.testing.assert_allclose(phi, R, atol=1e-7)
    x0, v0 = np.array(ref["x0"]), np.array(ref["v0"])
    w = np.sqrt(w2)
    for t, x_ref in zip(ref["times"], ref["response"]):
        x = phi @ ((phi.T @ M @ x0) * np.cos(w * t) + (phi.T @ M @ v0) / w * np.sin(w * t))
        np.testing.assert_allclose(x, x_ref, atol=1e-7)


# ------------------------------------------------------------------ R5: damped receptance


def test_receptance_damped():
    scene = load("receptance_damped")
    ref = scene.references
    system = scene.build()
    q0, zero = system.neutral(), np.zeros(2)
    M, K, C = system.mass_matrix(q0), stiffness(system, q0), damping(system, q0)
    np.testing.assert_allclose(M, ref["mass_matrix"], atol=1e-14)
    np.testing.assert_allclose(K, ref["stiffness_matrix"], atol=1e-7)
    np.testing.assert_allclose(C, ref["damping_matrix"], atol=1e-8)
    w2, _ = modes(system, q0)
    assert_omega(w2, ref["omega"])
    # damping ratios from the state-form eigenvalues
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    np.testing.assert_allclose(np.abs(lam), ref["omega"], rtol=RTOL)
    np.testing.assert_allclose(-lam.real / np.abs(lam), ref["zeta"], rtol=RTOL)
    w = ref["frequency"]
    alpha = np.linalg.inv(K - w**2 * M + 1j * w * C)
    for key, (i, j) in (("alpha11", (0, 0)), ("alpha12", (0, 1)), ("alpha22", (1, 1))):
        np.testing.assert_allclose([alpha[i, j].real, alpha[i, j].imag], ref[key], rtol=RTOL, atol=1e-9)
    assert alpha[0, 1] == pytest.approx(alpha[1, 0], rel=1e-9)

    def mag11(w):
        return abs(np.linalg.inv(K - w**2 * M + 1j * w * C)[0, 0])

    for wp in ref["peaks_alpha11"]:
        assert mag11(wp) > max(mag11(wp * (1 - 1e-4)), mag11(wp * (1 + 1e-4)))
    wa = ref["antiresonance_alpha11"]
    assert mag11(wa) < min(mag11(wa * (1 - 1e-4)), mag11(wa * (1 + 1e-4)))
    assert system.accelerations(q0, zero).tolist() == [0.0, 0.0]


# ------------------------------------------------------------------ R6: rotor with a sprung slider


def rotor_state(system, ref):
    q = system.integrate(system.neutral(), np.array([0.0, ref["s_rel_star"]]))
    return q, np.array([ref["omega_star"], 0.0])


def state_eigenvalues(M, C, K):
    n = len(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    return np.linalg.eigvals(A)


def assert_eigenvalues(lam, ref, tol):
    ref = np.array([complex(re, im) for re, im in ref])
    assert len(lam) == len(ref)
    for z in ref:  # each reference eigenvalue has a computed partner
        d = np.abs(lam - z)
        assert d.min() <= tol * max(abs(z), 1.0), (z, lam)


def test_rotor_slider_steady_regime_and_linearisation():
    scene = load("rotor_slider")
    ref = scene.references
    system = scene.build()
    q, v = rotor_state(system, ref)
    zero = np.zeros(2)
    np.testing.assert_allclose(system.accelerations(q, v), 0.0, atol=1e-12)  # a relative equilibrium
    assert system.point_position("slider", (0, 0, 0), q)[0] == pytest.approx(ref["s_star"], rel=1e-14)
    M, K, C = system.mass_matrix(q), stiffness(system, q, v), damping(system, q, v)
    np.testing.assert_allclose(M, ref["mass_matrix"], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(K, ref["stiffness_matrix"], rtol=1e-7, atol=1e-7)
    np.testing.assert_allclose(C, ref["damping_matrix"], rtol=1e-8, atol=1e-8)
    assert_eigenvalues(state_eigenvalues(M, C, K), ref["eigenvalues"], RTOL)
    # without the slider's damper
    bare = scene.copy()
    del bare.elements["slide_damper"]
    sb = bare.build()
    Cb = damping(sb, q, v)
    np.testing.assert_allclose(Cb[1, 1], 0.0, atol=1e-8)
    assert_eigenvalues(state_eigenvalues(sb.mass_matrix(q), Cb, stiffness(sb, q, v)),
                       ref["eigenvalues_undamped_slider"], RTOL)
    assert np.all(np.isfinite(system.accelerations(system.neutral(), zero)))


# ------------------------------------------------------------------ R7: IFToMM A01


def test_iftomm_a01_pendulum():
    from scipy.integrate import solve_ivp

    scene = load("iftomm_a01")
    ref = scene.references
    system = scene.build()
    q0 = system.neutral()
    mass_point = scene.bodies["pendulum"].com
    np.testing.assert_allclose(system.point_position("pendulum", mass_point, q0), [1.0, 0.0, 0.0], atol=1e-15)
    assert system.mass_matrix(q0)[0, 0] == pytest.approx(1.0, rel=1e-14)

    def rhs(t, y):  # one pivot: q and v share their coordinate, q + h v is the Lie-group step here
        return [y[1], system.accelerations(np.array([y[0]]), np.array([y[1]]), t)[0]]

    times = [t for t in ref["times"] if t <= 5.0]
    sol = solve_ivp(rhs, (0.0, times[-1]), [ref["q0"], ref["v0"]], method="DOP853", rtol=1e-12, atol=1e-12,
                    t_eval=times)
    for k, t in enumerate(times):
        x = system.point_position("pendulum", mass_point, np.array([sol.y[0, k]]))
        np.testing.assert_allclose(x[:2], ref["positions"][ref["times"].index(t)], atol=1e-8)
        assert x[2] == 0.0
    # the period: the mass is back at rest at the release point
    P = ref["period"]
    sol = solve_ivp(rhs, (0.0, P), [ref["q0"], ref["v0"]], method="DOP853", rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sol.y[:, -1], [ref["q0"], ref["v0"]], atol=1e-8)


# ------------------------------------------------------------------ R8: helical joint


def test_helical_generalized_mass_and_gravity_torque():
    scene = load("helical")
    ref = scene.references
    system = scene.build()
    q0 = system.neutral()
    zero = np.zeros(1)
    assert system.mass_matrix(q0)[0, 0] == pytest.approx(ref["generalized_mass"], rel=1e-14)
    assert system.inverse_dynamics(q0, zero, zero)[0] == pytest.approx(ref["gravity_torque"], rel=1e-14)
    assert system.gravity_forces(q0)[0] == pytest.approx(-ref["gravity_torque"], rel=1e-14)
    assert system.accelerations(q0, zero)[0] == pytest.approx(-ref["gravity_torque"] / ref["generalized_mass"])
    q = system.integrate(q0, np.array([2 * math.pi]))  # one turn
    R, p = system.body_pose("screw", q)
    np.testing.assert_allclose(p, [0.0, 0.0, ref["advance_per_turn"]], atol=1e-14)
    np.testing.assert_allclose(R, np.eye(3), atol=1e-14)


# ------------------------------------------------------------------ the demo scene


def test_trailer():
    scene = load("trailer")
    ref = scene.references
    system = scene.build()
    q0 = system.neutral()
    zero = np.zeros(2)
    np.testing.assert_allclose(system.accelerations(q0, zero), 0.0, atol=1e-12)
    np.testing.assert_allclose(system.mass_matrix(q0), ref["mass_matrix"], rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(stiffness(system, q0), ref["stiffness_matrix"], rtol=1e-8, atol=1e-7)
    np.testing.assert_allclose(damping(system, q0), ref["damping_matrix"], rtol=1e-8, atol=1e-9)
    w2, _ = modes(system, q0)
    assert_omega(w2, ref["omega"])
