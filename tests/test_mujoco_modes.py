"""Natural frequencies and damped modes against MuJoCo on random pivot/slider chains at their equilibria.

Acceptance: vibdyn's natural frequencies equal MuJoCo's to ≤ 1e-8 (relative, per mode) on random chains of
3, 10 and 30 bodies with joint springs (nonzero rest offsets) and joint dampers, under a tilted gravity, at
their asymmetric static equilibria.

The MuJoCo side is built here, independently of vibdyn's linearisation:

* M = ``mj_fullM`` after ``mj_forward`` at the equilibrium found by vibdyn (hinge/slide ``qpos`` equal
  vibdyn's q one to one; vibdyn's joint-spring rest offset is MuJoCo's ``springref`` about qpos0 = 0);
* K = ∂qfrc_inverse/∂qpos by *central* differences of ``mj_inverse`` (qvel = 0, qacc = vibdyn's a0, zero
  at an exact equilibrium), Richardson-extrapolated from steps h and h/2 (error O(h⁴) ≈ 1e-11 at
  h = 2e-3, round-off ≈ ε/h ≈ 1e-13): ``qfrc_inverse = M qacc + bias − qfrc_passive``, so its derivative is
  vibdyn's K = ∂/∂q [rnea − Q] (gravity + joint springs);
* C = ∂qfrc_inverse/∂qvel by central differences (the bias is quadratic in qvel and the dampers linear, so
  the central difference is exact up to round-off).

MuJoCo's own ``mjd_inverseFD`` is not used: it differences on one side only (measured here: K to ~1e-8,
C to ~1e-6), and it refuses the RK4 integrator of the oracle's model.

Run with ``-s`` to see the measured errors.
"""

import numpy as np
import pytest
import scipy.linalg as sla
from oracles import MuJoCoOracle, random_chain, rel_error
from scipy.optimize import linear_sum_assignment

mujoco = pytest.importorskip("mujoco")

OMEGA_TOL = 1e-8  # the acceptance: natural frequencies, relative per mode
MATRIX_TOL = 1e-9  # M, K (relative to max |entry|); measured ≤ 2e-12
C_TOL = {"fd": 1e-8, "analytic": 1e-12}  # vibdyn's C by FD in v carries the round-off of the gravity terms
LAMBDA_TOL = 1e-8  # state eigenvalues, relative to |λ|
ZETA_TOL = 1e-9  # damping ratios, absolute (ζ ~ 0.003 … 0.2 here)


def sprung_chain(n, seed):
    """A random pivot/slider chain (oracles.random_chain: random axes, placements, masses, full inertias)
    under a tilted gravity, with a spring (random rest offset) and a damper on every joint.

    Stiffnesses scale with the mass each joint carries so that every equilibrium is stable, yet gravity and
    the rest offsets move it far from the neutral configuration and from the springs' rests.
    """
    rng = np.random.default_rng(seed)
    tilt = np.array([*(0.4 * rng.standard_normal(2)), -1.0])
    g = 9.81 * tilt / np.linalg.norm(tilt)
    scene = random_chain(rng, n, ("pivot", "slider"), gravity=tuple(g), name=f"sprung{n}")
    masses = np.array([b.mass for b in scene.bodies.values()])
    carried = np.cumsum(masses[::-1])[::-1]  # a chain: body i carries bodies i..n-1
    rests = []
    for i, (name, b) in enumerate(list(scene.bodies.items())):
        if b.joint.type == "pivot":  # N·m/rad, rad
            k, rest = 30.0 * (1 + rng.random()) * carried[i], rng.uniform(-0.5, 0.5)
        else:  # N/m, m
            k, rest = 300.0 * (1 + rng.random()) * carried[i], rng.uniform(-0.1, 0.1)
        scene.add_joint_spring(name, k, rest=rest)
        scene.add_joint_damper(name, 0.05 * (0.2 + rng.random()) * np.sqrt(k * carried[i]))
        rests.append(rest)
    return scene, np.array(rests)


def mujoco_matrices(oracle, q, a0, h=2e-3, hv=1e-2):
    """(M, K, C) of MuJoCo at configuration q, zero velocity and acceleration a0, in vibdyn's order."""
    m, d, dof = oracle.model, oracle.data, oracle.dof
    nv = m.nv
    oracle.set_state(q, np.zeros(nv))
    qpos0, qvel0 = d.qpos.copy(), np.zeros(nv)
    qacc = np.zeros(nv)
    qacc[dof] = a0

    def r(qpos, qvel):
        d.qpos[:], d.qvel[:], d.qacc[:] = qpos, qvel, qacc
        mujoco.mj_inverse(m, d)
        return d.qfrc_inverse[dof].copy()

    def central(f, x0, step, k):
        e = np.zeros(nv)
        e[k] = step
        return (f(x0 + e) - f(x0 - e)) / (2 * step)

    K, C = np.empty((nv, nv)), np.empty((nv, nv))
    for j, k in enumerate(dof):
        fq = lambda x: r(x, qvel0)  # noqa: E731
        K[:, j] = (4 * central(fq, qpos0, h / 2, k) - central(fq, qpos0, h, k)) / 3  # Richardson
        C[:, j] = central(lambda x: r(qpos0, x), qvel0, hv, k)
    d.qpos[:], d.qvel[:], d.qacc[:] = qpos0, 0.0, 0.0
    mujoco.mj_forward(m, d)
    M = np.zeros((nv, nv))
    mujoco.mj_fullM(m, d, M)
    return M[np.ix_(dof, dof)], K, C


def state_eigenvalues(M, C, K):
    n = M.shape[0]
    X = np.linalg.solve(M, np.hstack([K, C]))
    return np.linalg.eigvals(np.block([[np.zeros((n, n)), np.eye(n)], [-X[:, :n], -X[:, n:]]]))


def matched(a, b):
    """Indices (i, j) pairing the complex numbers a[i] and b[j] (minimal total distance)."""
    return linear_sum_assignment(np.abs(a[:, None] - b[None, :]))


@pytest.fixture(scope="module", params=[3, 10, 30])
def case(request):
    n = request.param
    scene, rests = sprung_chain(n, seed=1000 + n)
    system = scene.build()
    eq = system.equilibrium()
    oracle = MuJoCoOracle(scene, system, joint_elements=True)
    return n, scene, system, eq, rests, oracle


@pytest.mark.parametrize("method", ["fd", "analytic"])
def test_natural_frequencies_equal_mujoco(case, method):
    n, scene, system, eq, rests, oracle = case
    # the operating point: a converged, stable and asymmetric equilibrium
    assert eq.regime == "static" and eq.residual <= eq.tol and eq.stability == "stable"
    dq = system.difference(system.neutral(), eq.q)
    assert np.abs(dq).max() > 0.1 and np.abs(dq - rests).max() > 1e-2  # gravity moved it off the rests
    lin = eq.linearize() if method == "fd" else eq.linearize(method="analytic")
    m = lin.modes()
    assert m.stability == "stable" and not m.rigid.any() and not m.unstable.any()

    M, K, C = mujoco_matrices(oracle, eq.q, lin.a)
    e_M, e_K, e_C = rel_error(lin.M, M), rel_error(lin.K, K), rel_error(lin.C, C)
    e_asym = rel_error(K, K.T)

    w2 = sla.eigh(0.5 * (K + K.T), M, eigvals_only=True)
    assert w2.min() > 0
    omega = np.sqrt(w2)
    e_omega = float(np.max(np.abs(m.omega - omega) / omega))

    lam = state_eigenvalues(M, C, K)
    i, j = matched(lam, m.eigenvalues)
    e_lam = float(np.max(np.abs(lam[i] - m.eigenvalues[j]) / np.abs(lam[i])))
    up = lam[lam.imag > 0]  # every mode is underdamped here: one of each conjugate pair
    assert up.size == n and m.damped_eigenvalues.size == n
    i, j = matched(up, m.damped_eigenvalues)
    zeta = -up.real / np.abs(up)
    e_zeta = float(np.max(np.abs(zeta[i] - m.zeta[j])))

    print(f"\n[mujoco modes] n={n:>2} {method:>8}: omega {e_omega:.1e} (estimate {m.relative_error:.1e}) | "
          f"M {e_M:.1e}  K {e_K:.1e}  C {e_C:.1e} (MuJoCo K asym {e_asym:.1e}) | lambda {e_lam:.1e}  "
          f"zeta {e_zeta:.1e} (zeta {m.zeta.min():.3f}..{m.zeta.max():.3f}) | "
          f"omega {omega.min():.3g}..{omega.max():.3g} rad/s")
    assert e_omega <= OMEGA_TOL, f"natural frequencies differ by {e_omega:.2e}"
    assert e_M <= MATRIX_TOL and e_K <= MATRIX_TOL, (e_M, e_K)
    assert e_C <= C_TOL[method], e_C
    assert e_lam <= LAMBDA_TOL and e_zeta <= ZETA_TOL, (e_lam, e_zeta)
    # vibdyn's own error estimate is not optimistic (beyond the oracle's ~1e-12 precision)
    assert e_omega <= max(m.relative_error, 1e-11)


def test_comparison_sees_a_one_ppm_change():
    """The comparison can fail: a 1e-6 relative change of one spring's stiffness (or of its rest) in the
    MuJoCo model is seen well above the tolerance."""
    scene, _ = sprung_chain(10, seed=1010)
    system = scene.build()
    eq = system.equilibrium()
    m = eq.linearize().modes()
    for attr in ("jnt_stiffness", "qpos_spring"):
        oracle = MuJoCoOracle(scene, system, joint_elements=True)
        getattr(oracle.model, attr)[4] *= 1 + 1e-6
        M, K, C = mujoco_matrices(oracle, eq.q, np.zeros(system.nv))
        if attr == "jnt_stiffness":
            omega = np.sqrt(sla.eigh(0.5 * (K + K.T), M, eigvals_only=True))
            assert np.max(np.abs(m.omega - omega) / omega) > 10 * OMEGA_TOL  # measured 2e-7
        else:  # a moved rest is no longer an equilibrium in MuJoCo: the static force is off
            oracle.set_state(eq.q, np.zeros(system.nv))
            mujoco.mj_inverse(oracle.model, oracle.data)
            g = np.abs(system.gravity_forces(eq.q)).max()
            assert np.abs(oracle.data.qfrc_inverse).max() > 1e-8 * g
