"""Design sensitivities, probe round four (issue 40): a tiny stiffness is a parameter, a builder started at 0 or
at the edge of its domain, a model with a kink or a jump at p, a scene that gains a body with p, a class passed
for a builder — each against an oracle the code does not use (closed forms of the 2×2 pencil, rebuilt scenes)."""

import numpy as np
import pytest

import vibdyn as vd
from vibdyn.errors import ModelError


def chain(m1=1.0, m2=1.0, k1=1.0, k2=1.0, k3=None):
    """Body 1 on a slider with joint spring k1 (and k3 beside it) to ground, body 2 on a slider on body 1 (k2)."""
    sc = vd.Scene("chain2")
    sc.add_body("m1", joint=vd.Slider(axis=(1, 0, 0)), mass=m1)
    sc.add_body("m2", parent="m1", joint=vd.Slider(axis=(1, 0, 0)), mass=m2)
    sc.add_joint_spring("m1", stiffness=k1, name="k1")
    sc.add_joint_spring("m2", stiffness=k2, name="k2")
    if k3 is not None:
        sc.add_joint_spring("m1", stiffness=k3, name="k3")
    return sc


def pencil(m1, m2, k1, k2):
    """(ω, ∂ω/∂k1) of the chain in relative coordinates, M = [[m1 + m2, m2], [m2, m2]], K = diag(k1, k2), by implicit
    differentiation of P(x) = det(K − xM) = (k1 − x(m1 + m2))(k2 − x m2) − x² m2², x = ω² (ascending)."""
    x = np.sort(np.roots([m1 * m2, -(k1 * m2 + k2 * (m1 + m2)), k1 * k2]).real)
    P_k1 = k2 - x * m2
    P_x = -(m1 + m2) * (k2 - x * m2) - m2 * (k1 - x * (m1 + m2)) - 2 * x * m2**2
    return np.sqrt(x), -P_k1 / P_x / (2 * np.sqrt(x))


# ------------------------------------------------------------------------------------------ 1: a tiny stiffness
def test_a_tiny_stiffness_is_a_parameter_with_its_closed_form_derivative():
    """k1 = 1e-12 N/m beside k2 = 1: ω₁ ≈ √(k1/2) = 7.1e-7 rad/s, ∂ω₁/∂k1 ≈ 3.5e5 (was refused as "does not change
    the linear model")."""
    m = chain(k1=1e-12).build().operating_point().linearize().modes()
    s = m.sensitivity(["k1.stiffness"])
    w, dw = pencil(1.0, 1.0, 1e-12, 1.0)
    assert np.allclose(s.omega0, w, rtol=1e-6)
    assert abs(dw[0]) > 3e5
    assert np.all(np.abs(s.d_omega[:, 0] - dw) <= s.d_omega_error[:, 0])
    assert np.all(s.d_omega_error[:, 0] < 1e-6 * np.abs(dw))
    b = vd.sensitivity(lambda k1: chain(k1=k1), {"k1": 1e-12})  # the builder's pipeline too
    assert np.all(np.abs(b.d_omega[:, 0] - dw) <= b.d_omega_error[:, 0])
    assert np.all(b.d_omega_error[:, 0] < 1e-3 * np.abs(dw))
    with pytest.raises(ModelError, match="does not change the linear model"):  # a parameter nothing moves with
        m.sensitivity(["m1.com.y"])


# ------------------------------------------------------------------------------------------ 2: a builder at 0
def test_a_builder_started_at_zero_takes_one_sided_differences():
    """k3 = 0 beside k1 = 1 (the builder refuses k3 < 0): ∂ω/∂k3 = ∂ω/∂k1 of the pencil with k1 + k3."""
    s = vd.sensitivity(lambda k3: chain(k3=k3), {"k3": 0.0})
    w, dw = pencil(1.0, 1.0, 1.0, 1.0)
    assert np.allclose(s.omega0, w, rtol=1e-9)
    assert np.all(np.abs(s.d_omega[:, 0] - dw) <= s.d_omega_error[:, 0])
    assert np.all(s.d_omega_error[:, 0] < 1e-5 * np.abs(dw))
    assert "one-sided" in s.note and "k3" in s.note


def test_update_started_at_zero_fits_the_parameter():
    truth = 0.5
    measured = chain(k3=truth).build().operating_point().linearize().modes().omega
    u = vd.update(lambda k3: chain(k3=k3), {"k3": 0.0}, measured, sigma=1e-6 * measured)
    assert abs(u.values["k3"] - truth) <= 3 * u.std["k3"] + 1e-9


# ------------------------------------------------------------------------------------------ 3: kinks and jumps
def jump(k):
    return chain(k1=1000.0 if k < 1.0 else 1200.0)


def kink(k):
    return chain(k1=1000.0 + 200.0 * abs(k - 1.0))


def curved(k):
    return chain(k1=1000.0 + 200.0 * (k - 1.0) + 5e4 * (k - 1.0) ** 2)


@pytest.mark.parametrize("build", [jump, kink], ids=["jump", "kink"])
def test_a_model_not_differentiable_at_p_is_refused_naming_it(build):
    """A stiffness with a jump at k = 1 (45.6 ± 22.8 was given) or a kink (refused as "does not change")."""
    with pytest.raises(ModelError, match=r"'k': not differentiable at k = 1: the left and right slopes differ"):
        vd.sensitivity(build, {"k": 1.0})


def test_a_smooth_curved_model_is_differentiated():
    """k1 = 1000 + 200 (k − 1) + 5e4 (k − 1)²: ∂ω/∂k = 200 ∂ω/∂k1, not taken for a kink."""
    s = vd.sensitivity(curved, {"k": 1.0})
    dw = 200.0 * pencil(1.0, 1.0, 1000.0, 1.0)[1]
    assert np.all(np.abs(s.d_omega[:, 0] - dw) <= s.d_omega_error[:, 0])
    assert np.all(s.d_omega_error[:, 0] < 1e-3 * np.abs(dw))


# ------------------------------------------------------------------------------------------ 4, 5: the builder
def test_a_scene_that_gains_a_body_with_p_says_so():
    def grow(k):
        sc = vd.Scene("grow")
        sc.add_body("m1", joint=vd.Slider(axis=(1, 0, 0)), mass=1.0)
        sc.add_joint_spring("m1", stiffness=10.0 * k, name="k1")
        if k > 1.0:
            sc.add_body("m2", parent="m1", joint=vd.Slider(axis=(1, 0, 0)), mass=1.0)
            sc.add_joint_spring("m2", stiffness=10.0, name="k2")
        return sc

    with pytest.raises(ModelError, match=r"at k = 1\.0001 has the coordinates \['m1', 'm2'\], and at k = 1 \['m1'\]"):
        vd.sensitivity(grow, {"k": 1.0})


def test_the_scene_class_passed_is_refused_by_name():
    for params in ({"name": 1.0}, {"k": 1.0}):
        with pytest.raises(ModelError, match="the class Scene itself"):
            vd.sensitivity(vd.Scene, params)
    with pytest.raises(ModelError, match="the class Scene itself"):
        vd.update(vd.Scene, {"k": 1.0}, [1.0])


def test_the_kits_left_and_right_slopes():
    """sides(): equal to O(h³) on a smooth function (e^x at 0.3), the one-sided slopes of a kink (|x − 1|·200)."""
    from vibdyn.model.fd import sides

    h = 1e-3
    left, right = sides([np.exp(0.3 + s * h) for s in (-2, -1, 0, 1, 2)], h)
    assert abs(left - np.exp(0.3)) < h**2 and abs(right - left) < 10 * h**3
    left, right = sides([200 * abs(s * h) for s in (-2, -1, 0, 1, 2)], h)
    assert np.isclose(left, -200) and np.isclose(right, 200)


def test_a_builder_at_the_top_of_its_domain_takes_differences_from_the_left():
    """k3 = 1 − k at k = 1 (the builder refuses k > 1): ∂ω/∂k = −∂ω/∂k1 of the pencil."""
    s = vd.sensitivity(lambda k: chain(k3=1.0 - k), {"k": 1.0})
    dw = -pencil(1.0, 1.0, 1.0, 1.0)[1]
    assert np.all(np.abs(s.d_omega[:, 0] - dw) <= s.d_omega_error[:, 0])
    assert np.all(s.d_omega_error[:, 0] < 1e-5 * np.abs(dw))
    assert "from the left" in s.note
