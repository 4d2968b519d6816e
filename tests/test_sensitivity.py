"""Design sensitivities (issue 35): closed forms, the whole pipeline differenced, repeated frequencies, bad input."""

import numpy as np
import pytest

import vibdyn as vd
from vibdyn.errors import ModelError


def oscillator(k=50.0, m=2.0, c=0.0):
    sc = vd.Scene("osc")
    sc.add_body("m1", joint=vd.Slider(axis=(1, 0, 0)), mass=m)
    sc.add_joint_spring("m1", stiffness=k, name="k1")
    if c:
        sc.add_joint_damper("m1", damping=c, name="c1")
    return sc


def two_masses(m1=1.0, m2=2.0, k1=100.0, k2=60.0):
    sc = vd.Scene("chain2")
    sc.add_body("m1", joint=vd.Slider(axis=(1, 0, 0)), mass=m1)
    sc.add_body("m2", parent="m1", joint=vd.Slider(axis=(1, 0, 0)), mass=m2)
    sc.add_joint_spring("m1", stiffness=k1, name="k1")
    sc.add_joint_spring("m2", stiffness=k2, name="k2")
    return sc


def test_one_dof_closed_forms():
    k, m = 50.0, 2.0
    s = oscillator(k, m).build().operating_point().linearize().modes().sensitivity(["k1.stiffness", "m1.mass"])
    assert s.params == ("k1.stiffness", "m1.mass") and s.units == ("N/m", "kg")
    exact = np.array([[1 / (2 * np.sqrt(k * m)), -np.sqrt(k / m) / (2 * m)]])
    assert np.all(np.abs(s.d_omega - exact) <= s.d_omega_error)
    assert np.all(s.d_omega_error < 1e-6 * np.abs(exact))  # an estimate that says something
    assert np.allclose(s.normalised, [[0.5, -0.5]], atol=1e-6)


def test_two_dof_chain_against_characteristic_polynomial():
    """Relative coordinates: x1 and the stretch of k2; det(K − xM) = P(x) with x = ω², ∂x/∂p = −P_p/P_x."""
    m1, m2, k1, k2 = 1.0, 2.0, 100.0, 60.0
    s = two_masses(m1, m2, k1, k2).build().operating_point().linearize().modes().sensitivity(
        ["k1.stiffness", "k2.stiffness", "m1.mass", "m2.mass"])

    def P(x, m1, m2, k1, k2):  # absolute displacements: the same frequencies
        return np.linalg.det(np.array([[k1 + k2, -k2], [-k2, k2]]) - x * np.diag([m1, m2]))

    p = np.array([k1, k2, m1, m2])
    order = [2, 3, 0, 1]  # P's argument order (m1, m2, k1, k2) from the parameters' (k1, k2, m1, m2)
    for i, w in enumerate(s.omega0):
        x = w**2
        args = p[order]
        hx = 1e-6 * x
        Px = (P(x + hx, *args) - P(x - hx, *args)) / (2 * hx)
        for j in range(4):
            dp = np.zeros(4)
            dp[j] = 1e-6 * p[j]
            Pp = (P(x, *(p + dp)[order]) - P(x, *(p - dp)[order])) / (2 * dp[j])
            dw = -Pp / Px / (2 * w)
            # the oracle's own differences: ~1e-9 relative
            assert abs(s.d_omega[i, j] - dw) <= s.d_omega_error[i, j] + 1e-8 * abs(dw), (i, j)


def pendulum(length=0.8):
    """A point mass hanging by a weld below a massless pivot link: ω = √(g/l), l the weld's placement."""
    sc = vd.Scene("pendulum", gravity=(0, 0, -9.81))
    sc.add_body("link", joint=vd.Pivot(axis=(0, 1, 0)), mass=0.0)
    sc.add_body("bob", parent="link", joint=vd.Fixed(at=(0.0, 0.0, -length)), mass=1.5)
    return sc


def test_pendulum_length_through_the_joint_placement():
    l, g = 0.8, 9.81
    s = pendulum(l).build().operating_point().linearize().modes().sensitivity(["bob.joint.at.z", "gravity"])
    w = np.sqrt(g / l)
    assert abs(s.omega0[0] - w) < 1e-9 * w
    # l = −at.z: ∂ω/∂at.z = −∂ω/∂l = ω/(2l); ∂ω/∂g = ω/(2g)
    assert abs(s.d_omega[0, 0] - w / (2 * l)) <= s.d_omega_error[0, 0]
    assert abs(s.d_omega[0, 1] - w / (2 * g)) <= s.d_omega_error[0, 1]
    assert s.units == ("m", "m/s²")


def test_campbell_slope_of_the_gimbal_rotor():
    """It ω² ∓ Ip Ω ω − k = 0 (forward/backward whirl): ∂ω/∂Ω = ±Ip ω / (2 It ω ∓ Ip Ω)."""
    It, Ip, k, W = 0.08, 0.12, 300.0, 100.0
    m = vd.load_scene("gimbal_rotor").build().operating_point().linearize().modes()
    s = m.sensitivity(["rotor.speed"])
    assert s.units == ("rad/s",)
    flexible = ~m.damped_zero
    got = s.d_eigenvalues[flexible, 0].imag
    err = s.d_eigenvalues_error[flexible, 0]
    exact = []
    for sgn in (-1, +1):  # ascending: backward whirl first
        w = (sgn * Ip * W + np.sqrt((Ip * W) ** 2 + 4 * It * k)) / (2 * It)
        exact.append(sgn * Ip * w / (2 * It * w - sgn * Ip * W))
    assert np.all(np.abs(got - exact) <= err)
    assert np.allclose(s.d_omega_n[flexible, 0], exact, atol=0, rtol=1e-6)


def pipeline_difference(make, p, h, modes_of):
    """(∂(sorted ω, ζ, ω_n)/∂p, their noise) of the whole pipeline (rebuild, operating point, linearise, modes)
    at step h: central differences, and the values' own errors over the step (their sizes, not differences)."""
    (a, ea), (b, eb) = modes_of(make(p + h)), modes_of(make(p - h))
    return [(x - y) / (2 * h) for x, y in zip(a, b)], [(x + y) / (2 * h) for x, y in zip(ea, eb)]


def check_against_pipeline(base, params):
    """Every ∂ω, ∂ζ, ∂ω_n against the whole pipeline differenced at two steps (Richardson-combined), within the
    stated error plus the pipeline's own difference error; returns the sensitivities."""
    from vibdyn.description.parameters import parameters, with_values

    s = base.build().operating_point().linearize().modes().sensitivity(params)

    def modes_of(sc):
        m = sc.build().operating_point().linearize(method="analytic").modes()
        # (with each quantity's own error: ω, ζ and ω_n to their modes' relative estimates)
        return ((np.asarray(m.omega), np.asarray(m.zeta), np.asarray(m.omega_n)),
                (m.omega_error * m.omega, m.eigenvalue_error, m.eigenvalue_error * m.omega_n))

    for j, p in enumerate(parameters(base, params)):
        h = 1e-3 * max(abs(p.value), 0.1)
        make = lambda x, p=p: with_values(base, [p], [x])  # noqa: E731
        (d1, n1), (d2, _) = pipeline_difference(make, p.value, h, modes_of), pipeline_difference(
            make, p.value, 2 * h, modes_of)
        for k, (got, err) in enumerate(((s.d_omega[:, j], s.d_omega_error[:, j]),
                                        (s.d_zeta[:, j], s.d_zeta_error[:, j]),
                                        (s.d_omega_n[:, j], s.d_omega_n_error[:, j]))):
            a, b = d1[k], d2[k]
            rich = a + (a - b) / 3
            # the oracle's own error: its truncation (|a − b|/3) and its values' error over the step
            assert np.all(np.abs(got - rich) <= err + np.abs(a - b) / 3 + 2 * n1[k]), (p.name, got, rich)
    return s


def test_every_sensitivity_against_the_whole_pipeline_at_two_steps():
    """The trailer (cart on a spring, damped rod on a pivot, gravity): ∂ω, ∂ζ, ∂ω_n for masses, stiffness,
    damping, a centre of mass, an inertia."""
    params = ["trailer.mass", "wall_spring.stiffness", "rod.damper.damping", "rod.com.z", "rod.inertia.yy"]
    s = check_against_pipeline(vd.load_scene("trailer"), params)
    assert s.method.startswith("element (2 parameters)")  # stiffness and damping: no rebuild
    assert np.any(np.abs(s.d_zeta[:, params.index("rod.damper.damping")]) > 0)


def test_a_stiffness_that_moves_the_pose():
    """Torsion springs loaded by a tilted gravity: a stiffness moves the equilibrium, and K through it (the
    element path's pose term) — against the pipeline, which finds the equilibrium again."""
    sc = vd.Scene("tilted", gravity=(-4.0, 0.0, -9.0))
    sc.add_body("l0", joint=vd.Pivot(axis=(0, 1, 0)), mass=1.0, com=(0, 0, -0.5),
                inertia=vd.inertia.rod(1.0, 1.0, axis=(0, 0, 1)))
    sc.add_body("l1", parent="l0", joint=vd.Pivot(axis=(0, 1, 0), at=(0, 0, -1.0)), mass=0.5, com=(0, 0, -0.4),
                inertia=vd.inertia.rod(0.5, 0.8, axis=(0, 0, 1)))
    sc.add_joint_spring("l0", stiffness=20.0)
    sc.add_joint_spring("l1", stiffness=8.0)
    op = sc.build().operating_point()
    assert np.abs(op.q).max() > 0.1  # the springs are loaded
    s = check_against_pipeline(sc, ["l0.spring.stiffness", "l1.spring.stiffness"])
    assert s.method == "element"


def spherical_pendulum():
    sc = vd.Scene("spherical", gravity=(0, 0, -9.81))
    sc.add_body("rod", joint=vd.Ball(), mass=2.0, com=(0, 0, -1.0),
                inertia=[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.02]])
    return sc


def test_repeated_frequency_of_a_symmetric_spherical_pendulum():
    """Two equal frequencies: their derivatives are the subspace's eigenvalues; a change that breaks the
    symmetry (Ixx) moves one mode only, against one-sided differences of the sorted frequencies."""
    base = spherical_pendulum()
    m = base.build().operating_point().linearize().modes()
    flexible = np.flatnonzero(m.omega > 0)
    assert len(flexible) == 2 and abs(m.omega[flexible[0]] - m.omega[flexible[1]]) < 1e-9 * m.omega[flexible[0]]
    s = m.sensitivity(["rod.inertia.xx", "gravity"])
    assert s.repeated[flexible].all() and "repeated" in s.note
    from vibdyn.description.parameters import parameters, with_values

    for j, name in enumerate(("rod.inertia.xx", "gravity")):
        p = parameters(base, [name])[0]
        h = 1e-4 * p.value
        w = [np.sort(with_values(base, [p], [p.value + k * h]).build().operating_point().linearize(
            method="analytic").modes().omega)[-2:] for k in (0, 1, 2)]
        forward = (-3 * w[0] + 4 * w[1] - w[2]) / (2 * h)  # second order, one side: the split's ascending order
        got = s.d_omega[flexible, j]
        assert np.all(np.abs(got - forward)
                      <= s.d_omega_error[flexible, j] + 1e-5 * np.abs(forward).max()), (name, got, forward)
    # Ixx moves the mode about x alone (one derivative ≈ 0); gravity both equally
    assert min(abs(s.d_omega[flexible, 0])) < 1e-6 * max(abs(s.d_omega[flexible, 0]))
    assert abs(s.d_omega[flexible[0], 1] - s.d_omega[flexible[1], 1]) <= s.d_omega_error[flexible, 1].sum()


def test_nelson_shape_derivatives_against_differences():
    base = two_masses()
    s = base.build().operating_point().linearize().modes().sensitivity(["k2.stiffness"])
    from vibdyn.description.parameters import parameters, with_values

    p = parameters(base, ["k2.stiffness"])[0]
    h = 1e-4 * p.value

    def shapes(x):
        return with_values(base, [p], [x]).build().operating_point().linearize(method="analytic").modes().shapes

    d = (shapes(p.value + h) - shapes(p.value - h)) / (2 * h)
    assert np.all(np.abs(s.d_shapes[:, :, 0] - d) <= s.d_shapes_error[:, :, 0] + 1e-6 * np.abs(d).max())
    assert np.abs(s.d_shapes).max() > 0


def test_builder_form_matches_names():
    def build(k1, k2):
        return two_masses(k1=k1, k2=k2)

    a = vd.sensitivity(build, {"k1": 100.0, "k2": 60.0})
    b = two_masses().build().operating_point().linearize().modes().sensitivity(["k1.stiffness", "k2.stiffness"])
    assert np.all(np.abs(a.d_omega - b.d_omega) <= a.d_omega_error + b.d_omega_error)


def test_bad_input():
    m = two_masses().build().operating_point().linearize().modes()
    with pytest.raises(ModelError, match="did you mean 'k1.stiffness'"):
        m.sensitivity(["k1.stifness"])
    with pytest.raises(ModelError, match="unknown parameter"):
        m.sensitivity(["nobody.mass"])
    with pytest.raises(ModelError, match="does not change the linear model"):
        m.sensitivity(["m1.com.y"])  # a slider's mass off its axis: nothing moves with it
    with pytest.raises(ModelError, match="named twice"):
        m.sensitivity(["k1.stiffness", "k1.stiffness"])
    with pytest.raises(ModelError, match="finite"):
        vd.sensitivity(lambda k1: two_masses(k1=k1), {"k1": float("nan")})


# ------------------------------------------------------------------------------------------ model updating
def building(k1, k2, k3):
    sc = vd.load_scene("three_storey_building")
    from vibdyn.description.parameters import parameters, with_values

    plist = parameters(sc, ["storey1.stiffness", "storey2.stiffness", "storey3.stiffness"])
    return with_values(sc, plist, [k1, k2, k3])


def test_update_recovers_a_synthetic_building_within_its_standard_deviations():
    truth = {"k1": 6e5, "k2": 4e5, "k3": 2e5}
    w_true = building(**truth).build().operating_point().linearize().modes().omega
    rng = np.random.default_rng(20261127)
    inside, total = 0, 0
    for _ in range(20):
        noisy = w_true * (1 + 0.005 * rng.standard_normal(3))
        fit = vd.update(building, {"k1": 5e5, "k2": 5e5, "k3": 3e5}, noisy, sigma=0.005 * w_true)
        for k in truth:
            z = abs(fit.values[k] - truth[k]) / fit.std[k]
            assert z < 4.0, (k, fit.values[k], fit.std[k])
            inside += z <= 2.0
            total += 1
        assert np.all(np.abs(fit.residuals) < 1e-3 * noisy + 5 * fit.sigma)
    assert inside >= 0.85 * total  # 2σ holds 95 % of normal draws


def test_update_refuses_springs_in_series_from_one_frequency():
    def series(ka, kb):
        sc = vd.Scene("series")
        sc.add_body("mid", joint=vd.Slider(axis=(1, 0, 0)), mass=1e-3)
        sc.add_body("m", parent="mid", joint=vd.Slider(axis=(1, 0, 0)), mass=2.0)
        sc.add_joint_spring("mid", stiffness=ka, name="ka")
        sc.add_joint_spring("m", stiffness=kb, name="kb")
        return sc

    with pytest.raises(ModelError, match="ka, kb cannot be identified"):
        vd.update(series, {"ka": 100.0, "kb": 100.0}, [np.sqrt(50.0 / 2.0)])


def test_update_bad_input():
    with pytest.raises(ModelError, match="only 3 flexible modes"):
        vd.update(building, {"k1": 5e5, "k2": 5e5, "k3": 3e5}, [10.0, 20.0, 30.0, 40.0])
    with pytest.raises(ModelError, match="not a finite number"):
        vd.update(building, {"k1": 5e5, "k2": 5e5, "k3": 3e5}, [10.0, float("nan"), 30.0])
    with pytest.raises(ModelError, match="unknown parameter 'k4'"):
        vd.update(building, {"k1": 5e5, "k2": 5e5, "k3": 3e5}, [10.0, 20.0, 30.0], bounds={"k4": (0, 1)})


def test_cli_table_and_json():
    import contextlib
    import io
    import json

    from vibdyn.faces.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["sensitivity", "three_storey_building", "--param", "storey1.stiffness", "--json"]) == 0
    d = json.loads(out.getvalue())
    assert d["params"] == ["storey1.stiffness"] and d["units"] == ["N/m"]
    # ω₁ grows with the first storey's stiffness: (k/ω) ∂ω/∂k between 0 and 1/2 for every mode
    assert all(0 < r[0] < 0.5 for r in d["normalised"])
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert main(["sensitivity", "three_storey_building", "--param", "storey1.stifness"]) == 2
    assert "did you mean 'storey1.stiffness'" in err.getvalue()


def test_update_pairs_measured_modes_by_mac_at_named_points():
    """Only the first and third modes measured, their shapes as floor drifts: the fit pairs them by MAC (in
    ascending order it would take mode 2 for the second measurement) and recovers two stiffnesses."""
    truth = {"k1": 6e5, "k2": 4e5, "k3": 2e5}
    m = building(**truth).build().operating_point().linearize().modes()
    floors = ["floor1", "floor2", "floor3"]
    drifts = m.point_shapes(floors, direction=(1, 0, 0))[:, [0, 2]]

    def two(k1, k3):
        return building(k1, 4e5, k3)

    fit = vd.update(two, {"k1": 5e5, "k3": 3e5}, m.omega[[0, 2]], sigma=1e-6 * m.omega[[0, 2]], shapes=drifts,
                    points=floors, direction=(1, 0, 0))
    assert list(fit.pairs) == [0, 2]
    assert fit.mac.shape == (2, 3) and np.all(fit.mac[[0, 1], [0, 2]] > 0.999)
    for k in ("k1", "k3"):
        assert abs(fit.values[k] - truth[k]) <= 5 * fit.std[k] + 1e-9 * truth[k]
    with pytest.raises(ModelError, match="shapes must be 3 points × 2"):
        vd.update(two, {"k1": 5e5, "k3": 3e5}, m.omega[[0, 2]], shapes=drifts[:2], points=floors, direction=(1, 0, 0))
