"""Many states at once (what harmonic balance and finite differences evaluate): inverse dynamics and analytic
derivatives over rows of states equal the one-state functions row by row — springs and dampers in one numpy
pass over all rows (and their derivatives in world form, K −= Σ Pᵀ(∂F + [F]× W)), against the per-element,
per-joint chain rule of :func:`analytic_derivatives`."""

import numpy as np
import pinocchio as pin
import pytest

import vibdyn as vd
import vibdyn.model.points as points
from vibdyn.model import dynamics
from vibdyn.model.derivatives import analytic_derivatives, analytic_derivatives_rows

MODELS = ["two_mass_cubic", "trailer", "quarter_car", "iftomm_a05", "trammel", "rotor_slider", "andrews_squeezer",
          "three_storey_building", "chain3_prestressed"]


def states(system, rows, seed):
    rng = np.random.default_rng(seed)
    Q = np.array([pin.integrate(system.model, system.neutral(), 0.2 * rng.standard_normal(system.nv))
                  for _ in range(rows)])
    return Q, rng.standard_normal((rows, system.nv)), rng.standard_normal((rows, system.nv))


def one_by_one(system, Q, V, A, t, shift=None):
    ws = system.workspace()
    r = np.array([dynamics.inverse_dynamics(system, ws, Q[c], V[c], A[c], t[c],
                                            None if shift is None else shift[c]) for c in range(len(Q))])
    D = [analytic_derivatives(system, Q[c], V[c], A[c], t[c], shift=None if shift is None else shift[c])
         for c in range(len(Q))]
    return r, np.array([d[0] for d in D]), np.array([d[1] for d in D])


def scale(system, Q, V, A):
    """The size of the terms that cancel in r, K, C: their round-off scale."""
    return max(max(float(np.max(analytic_derivatives(system, Q[c], V[c], A[c], 0.0, with_terms=True)[2]))
                   for c in range(len(Q))), 1.0)


@pytest.mark.parametrize("dense", [True, False])
@pytest.mark.parametrize("name", MODELS)
def test_rows_equal_one_state_at_a_time(name, dense, monkeypatch):
    if not dense:  # the per-point gathers and scatter of large scenes
        monkeypatch.setattr(points, "DENSE_MAX", 0)
    system = vd.load_scene(name).build()
    assert system.point_groups and all(g.rows for g in system.point_groups)
    Q, V, A = states(system, 6, 3)
    t = np.linspace(0.0, 1.0, 6)
    r, K, C = one_by_one(system, Q, V, A, t)
    tau, F = dynamics.inverse_dynamics_rows(system, system.workspace(), Q, V, A, t)
    Kr, Cr = analytic_derivatives_rows(system, Q, V, A, t)
    s = scale(system, Q, V, A)
    assert np.max(np.abs(tau - F - r)) <= 1e-13 * s
    assert np.max(np.abs(Kr - K)) <= 1e-13 * max(s, float(np.max(np.abs(K))))
    assert np.max(np.abs(Cr - C)) <= 1e-13 * max(s, float(np.max(np.abs(C))))


def test_rows_with_a_moving_support_shifted_per_row():
    """A mass hung by a spring and a damper from a support moving by its law, each row at its own time and
    offset of the support (harmonic balance's samples of a base excitation)."""
    s = vd.Scene("sprung")
    s.add_support("ground", vd.laws.HarmonicMotion((0.0, 0.0, 0.02), 3.0))
    s.add_body("mass", mass=2.0, joint=vd.Slider(axis=(0, 0, 1)))
    s.add_spring("k", ("ground", (0.0, 0.0, -1.0)), "mass", stiffness=400.0, free_length=0.8)
    s.add_damper("c", ("ground", (0.0, 0.0, -1.0)), "mass", damping=3.0)
    system = s.build()
    Q, V, A = states(system, 5, 7)
    t = np.linspace(0.1, 0.9, 5)
    shift = np.random.default_rng(2).standard_normal((5, 1, 6)) * 0.01
    r, K, C = one_by_one(system, Q, V, A, t, shift)
    tau, F = dynamics.inverse_dynamics_rows(system, system.workspace(), Q, V, A, t, shift)
    Kr, Cr = analytic_derivatives_rows(system, Q, V, A, t, shift)
    assert np.max(np.abs(tau - F - r)) <= 1e-12 * np.max(np.abs(r))
    assert np.max(np.abs(Kr - K)) <= 1e-12 * np.max(np.abs(K))
    assert np.max(np.abs(Cr - C)) <= 1e-12 * np.max(np.abs(C))
    # the support's own motion is in the rows: without the shift they differ
    tau0, F0 = dynamics.inverse_dynamics_rows(system, system.workspace(), Q, V, A, t)
    assert np.max(np.abs(tau0 - F0 - r)) > 1.0


def test_a_spring_reaching_zero_length_in_one_row_is_named():
    s = vd.Scene("collapse")
    s.add_body("mass", mass=1.0, joint=vd.Slider(axis=(1, 0, 0)))
    s.add_spring("k", ("world", (0.5, 0.0, 0.0)), "mass", stiffness=10.0, free_length=0.2)
    system = s.build()
    Q = np.array([[0.1], [0.5], [0.9]])  # the ends meet at x = 0.5, the second row
    Z = np.zeros((3, 1))
    with pytest.raises(vd.ModelError, match=r"spring 'k' reached zero length at the configuration q = \[0\.5\]"):
        dynamics.inverse_dynamics_rows(system, system.workspace(), Q, Z, Z, 0.0)
    with pytest.raises(vd.ModelError, match=r"spring 'k' reached zero length .* q = \[0\.5\]"):
        analytic_derivatives_rows(system, Q, Z, Z, 0.0)


def test_rows_at_their_own_times_with_a_force_law_of_time():
    """A time law on a joint (a joint-space group that depends on t) beside springs: each row at its own time
    as the one-state function gives it (the law evaluated row by row, the springs all at once)."""
    s = vd.load_scene("two_mass_cubic")
    s.add_joint_force("m1", vd.laws.Harmonic(0.7, 3.0, phase=0.2))
    system = s.build()
    Q, V, A = states(system, 5, 11)
    t = np.array([0.0, 0.3, 0.9, 1.4, 2.0])
    r, K, C = one_by_one(system, Q, V, A, t)
    tau, F = dynamics.inverse_dynamics_rows(system, system.workspace(), Q, V, A, t)
    assert np.max(np.abs(tau - F - r)) <= 1e-13 * scale(system, Q, V, A)
    # the rows' own times matter: all at t = 0 they differ by the law's change, 0.7 (sin(3t + 0.2) − sin 0.2)
    tau0, F0 = dynamics.inverse_dynamics_rows(system, system.workspace(), Q, V, A, 0.0)
    change = 0.7 * (np.sin(3.0 * t + 0.2) - np.sin(0.2))
    assert np.max(np.abs((tau0 - F0)[:, 0] - r[:, 0] - change)) <= 1e-13 * scale(system, Q, V, A)
    assert np.max(np.abs(change)) > 0.5
