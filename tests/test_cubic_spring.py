"""The cubic joint spring (Q = −k₃ x³), the kind added to prove that an element kind lives in one module
(vibdyn/description/elements/cubic_joint_spring.py): closed forms, FD = analytic derivatives, energy, scene
files, the CLI and bad input."""

import io

import numpy as np
import pytest

import vibdyn as vd
from vibdyn.description.elements import KINDS, CubicJointSpring
from vibdyn.faces.cli import describe


def duffing_slider(m=2.0, k3=5.0e3, F=40.0):
    """A mass on a slider held by a cubic spring and pushed by a constant force F."""
    s = vd.Scene("duffing")
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=m)
    s.add_cubic_joint_spring("cart", k3)
    s.add_joint_force("cart", F)
    return s


def test_the_kind_is_registered_with_its_scene_method_and_file_table():
    assert KINDS["cubic_joint_spring"] is CubicJointSpring
    s = duffing_slider()
    assert isinstance(s.elements["cart.cubic_spring"], CubicJointSpring)


def test_equilibrium_and_frequency_of_a_hardening_spring_under_a_constant_force():
    """x₀ = (F/k₃)^⅓, K = 3 k₃ x₀² = 3 (k₃ F²)^⅓, ω = √(K/m)."""
    m, k3, F = 2.0, 5.0e3, 40.0
    system = duffing_slider(m, k3, F).build()
    eq = system.equilibrium([0.19])  # near x₀ = 0.2 m (at x = 0 the stiffness is zero)
    x0 = (F / k3) ** (1 / 3)
    assert abs(eq.q[0] - x0) <= 10 * eq.q_error.max() + 1e-12 * x0
    for method in ("fd", "analytic"):
        lin = eq.linearize(method=method)
        K = 3 * (k3 * F**2) ** (1 / 3)
        assert abs(lin.K[0, 0] - K) <= 10 * lin.K_error[0, 0] + 1e-9 * K
        w = lin.modes().omega[0]
        assert abs(w - np.sqrt(K / m)) <= 10 * lin.modes().relative_error * w + 1e-9 * w


def test_fd_equals_analytic_on_a_pendulum_with_a_cubic_torsion_spring():
    s = vd.Scene("cubic pendulum", gravity=(0, 0, -9.81))
    s.add_body("arm", joint=vd.Pivot((0, 1, 0)), mass=1.5, com=(0, 0, -0.4), inertia=vd.inertia.rod(1.5, 0.8))
    s.add_body("tip", "arm", vd.Pivot((0, 1, 0), at=(0, 0, -0.8)), mass=0.5, com=(0, 0, -0.3))
    s.add_cubic_joint_spring("arm", 80.0, rest=0.2)
    s.add_cubic_joint_spring("tip", 30.0, name="wrist")
    s.add_joint_spring("tip", 4.0)
    system = s.build()
    q = system.configuration([0.7, -0.4])
    fd, exact = system.linearize(q, method="fd"), system.linearize(q, method="analytic")
    assert np.all(np.abs(fd.K - exact.K) <= 4 * fd.K_error + 1e-12 * np.abs(exact.K).max())
    # the cubic part alone: −∂Q/∂q = 3 k₃ x² on each joint, beside the gravity and linear spring parts
    bare = vd.Scene("bare", gravity=(0, 0, -9.81))
    for b in s.bodies.values():
        bare.add_body(b.name, b.parent, b.joint, mass=b.mass, com=b.com, inertia=b.inertia)
    bare.add_joint_spring("tip", 4.0)
    zero = np.zeros(2)  # a = 0: no ∂M/∂q·a terms, so the parts add
    K0 = bare.build().linearize(q, a=zero, method="analytic").K
    x = np.array([0.7 - 0.2, -0.4])
    K1 = system.linearize(q, a=zero, method="analytic").K
    np.testing.assert_allclose(np.diag(K1 - K0), 3 * np.array([80.0, 30.0]) * x**2, rtol=1e-12)


def test_energy_is_conserved_within_the_trajectory_error_estimate():
    """No damping, no gravity: kinetic + k₃x⁴/4 stays constant; its change is bounded by the forces times the
    trajectory's own position error plus the momentum times its velocity error."""
    m, k3 = 2.0, 5.0e3
    s = vd.Scene("free duffing")
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=m)
    s.add_cubic_joint_spring("cart", k3)
    tr = s.build().simulate(2.0, q0=[0.1], rtol=1e-10, error_method="rerun")
    E = tr.energy
    assert abs(E[0] - (0.25 * k3 * 0.1**4)) <= 1e-15 * E[0]
    bound = k3 * 0.1**3 * tr.error + m * np.abs(tr.v).max() * tr.velocity_error
    assert np.abs(E - E[0]).max() <= 10 * bound
    # and it oscillates: the period of x'' = −(k₃/m) x³ from rest at A is 7.4163 / (A √(k₃/m))
    period = 7.416298709205487 / (0.1 * np.sqrt(k3 / m))
    crossings = tr.t[1:][np.diff(np.sign(tr.q[:, 0])) != 0]
    assert abs((crossings[2] - crossings[0]) - period) <= 2 * np.diff(tr.t).max()


def test_scene_file_round_trip_and_info_line(tmp_path):
    s = duffing_slider()
    s.add_body("arm", "cart", vd.Pivot((0, 0, 1)), mass=1.0, com=(0.3, 0, 0))
    s.add_cubic_joint_spring("arm", 12.0, rest=-0.1, name="c2")
    path = tmp_path / "d.toml"
    s.save(path)
    text = path.read_text()
    assert "[[cubic_joint_spring]]" in text and "k3 = 12.0" in text and "rest = -0.1" in text
    back = vd.load_scene(path)
    assert back.to_dict() == s.to_dict()
    q = np.array([0.03, 0.4])
    a, b = s.build().linearize(q, method="analytic"), back.build().linearize(q, method="analytic")
    np.testing.assert_array_equal(a.K, b.K)
    out = io.StringIO()
    system = back.build()
    describe(back, system, out)
    assert "cubic joint spring" in out.getvalue() and "k3 = 12 N" in out.getvalue()  # (with its unit)


@pytest.mark.parametrize("call, message", [
    (lambda s: s.add_cubic_joint_spring("cart", -1.0), "k3"),
    (lambda s: s.add_cubic_joint_spring("cart", float("nan")), "k3"),
    (lambda s: s.add_cubic_joint_spring("carr", 1.0), "did you mean 'cart'"),
    (lambda s: s.add_cubic_joint_spring("ball", 1.0), "one-coordinate joints"),
    (lambda s: s.add_cubic_joint_spring("cart", 1.0, rest=[0.1, 0.2]), "rest"),
    (lambda s: s.add_cubic_joint_spring("cart", 1.0, name="cart.cubic_spring") and
     s.add_cubic_joint_spring("cart", 2.0), "duplicate name"),
])
def test_bad_cubic_springs_are_clear_errors(call, message):
    s = vd.Scene("bad")
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_body("ball", "cart", vd.Ball(), mass=1.0, inertia=np.eye(3))
    with pytest.raises(vd.ModelError, match=message):
        call(s)


def test_bad_cubic_spring_in_a_scene_file_names_the_key(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('[[body]]\nname = "cart"\nmass = 1.0\njoint = { type = "slider", axis = [1.0, 0.0, 0.0] }\n'
                    '[[cubic_joint_spring]]\nbody = "cart"\nk3 = -3.0\n')
    with pytest.raises(vd.SceneFileError) as e:
        vd.load_scene(path)
    assert e.value.key == "cubic_joint_spring[0].k3" and "negative" in str(e.value)
