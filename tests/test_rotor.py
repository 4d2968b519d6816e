"""Rotors (issue 43, items 1 and 2): bearings with cross-coupled and speed-dependent coefficients against their
force law and closed forms, and the unbalance response of a Jeffcott rotor against m e Ω² / |k − MΩ² + icΩ|,
its peak speed and half-power amplification factor."""

import numpy as np
import pytest
from scipy.optimize import brentq

import vibdyn as vd
from vibdyn import ModelError

M, K, C, U = 2.0, 8.0e4, 40.0, 2.0e-4


def jeffcott(kxx=K, kyy=K, kxy=0.0, kyx=0.0, c=C, com=0.0, unbalance=U, angle=0.0, **bearing):
    """A disk of mass M on two sliders (x, y) and a pivot about z (the spin), held by one bearing to the world."""
    s = vd.Scene("jeffcott")
    s.add_body("cx", joint=vd.Slider((1, 0, 0)), mass=0.0)
    s.add_body("cy", parent="cx", joint=vd.Slider((0, 1, 0)), mass=0.0)
    s.add_body("disk", parent="cy", joint=vd.Pivot((0, 0, 1)), mass=M, inertia=np.diag([0.01, 0.01, 0.02]),
               com=(com, 0.0, 0.0))
    stiffness = bearing.pop("stiffness", [[kxx, kxy], [kyx, kyy]])
    damping = bearing.pop("damping", [[c, 0.0], [0.0, c]])
    s.add_bearing("bearing", "world", "disk", stiffness=stiffness, damping=damping, **bearing)
    if unbalance:
        s.add_unbalance("u", "disk", unbalance, angle=angle)
    return s


def amplitude(W, k=K, c=C, u=U):
    return u * W ** 2 / np.abs(k - M * W ** 2 + 1j * c * W)


# ------------------------------------------------------------------------------------------------ bearings
def test_cross_coupled_bearing_stiffness_and_damping_are_the_force_law():
    Kb, Cb = [[1.0e4, 3.0e3], [-2.5e3, 1.2e4]], [[3.0, 1.0], [-0.5, 4.0]]
    system = jeffcott(stiffness=Kb, damping=Cb).build()
    for method in ("fd", "analytic"):
        lin = system.linearize(v=[0.0, 0.0, 50.0], method=method)
        assert lin.method == method
        np.testing.assert_allclose(lin.K[:2, :2], Kb, rtol=0, atol=10 * lin.K_error.max() + 1e-9)
        np.testing.assert_allclose(lin.C[:2, :2], Cb, rtol=0, atol=10 * lin.C_error.max() + 1e-12)
    # the force itself at a displaced, moving state: Q = −K d − C v (hand-written force law)
    q, v = np.array([1e-3, -2e-3, 0.4]), np.array([0.1, 0.3, 50.0])
    from vibdyn.model import dynamics

    tau = dynamics.inverse_dynamics(system, system.workspace(), q, v, np.zeros(3), 0.0)  # M·0 + b − Q: −Q here
    expected = -(np.array(Kb) @ q[:2] + np.array(Cb) @ v[:2])
    np.testing.assert_allclose(-tau[:2], expected, rtol=1e-12, atol=1e-12)


def test_tabulated_bearing_interpolates_in_the_journal_speed_with_its_derivative():
    speeds = [0.0, 100.0, 200.0]
    Kt = [[[1e4, 0.0], [0.0, 1e4]], [[2e4, 5e3], [-5e3, 2e4]], [[3e4, 1e4], [-1e4, 4e4]]]
    Ct = [[[10.0, 0.0], [0.0, 10.0]], [[20.0, 2.0], [-2.0, 20.0]], [[30.0, 4.0], [-4.0, 30.0]]]
    system = jeffcott(stiffness=Kt, damping=Ct, speeds=speeds).build()
    W = 130.0
    t = (W - 100.0) / 100.0
    Kw = (1 - t) * np.array(Kt[1]) + t * np.array(Kt[2])
    Cw = (1 - t) * np.array(Ct[1]) + t * np.array(Ct[2])
    q = np.array([2e-3, -1e-3, 0.0])  # off centre: the coefficients' change with speed acts through d
    for method in ("fd", "analytic"):
        lin = system.linearize(q, v=[0.0, 0.0, W], method=method)
        assert lin.method == method
        np.testing.assert_allclose(lin.K[:2, :2], Kw, atol=10 * lin.K_error.max() + 1e-9)
        np.testing.assert_allclose(lin.C[:2, :2], Cw, atol=10 * lin.C_error.max() + 1e-9)
        # ∂Q/∂Ω = −(dK/dΩ) d: the spin column of C
        dK = (np.array(Kt[2]) - np.array(Kt[1])) / 100.0
        np.testing.assert_allclose(lin.C[:2, 2], dK @ q[:2], rtol=1e-6, atol=10 * lin.C_error.max() + 1e-12)
    # at rest, on the table's first speed: the difference steps about Ω = 0 stay inside the table's end band
    for method in ("fd", "analytic"):
        at_rest = system.linearize(method=method)
        np.testing.assert_allclose(at_rest.K[:2, :2], Kt[0], atol=10 * at_rest.K_error.max() + 1e-9)


def test_bearing_refusals_name_the_bearing():
    cases = [
        (dict(stiffness=[[1.0, 2.0], [3.0]]), "stiffness"),
        (dict(stiffness=[[1.0, 2.0, 0.0], [3.0, 4.0, 0.0]]), "2 × 2"),
        (dict(stiffness=[[1.0, np.nan], [0.0, 1.0]]), "finite"),
        (dict(stiffness=[[1.0, 0.0], [0.0, 1.0]], damping=[[np.inf, 0.0], [0.0, 1.0]]), "damping"),
        (dict(stiffness=np.ones((2, 2, 2)), speeds=[10.0, 5.0]), "increasing"),
        (dict(stiffness=np.ones((2, 2, 2)), speeds=[10.0, 10.0]), "increasing"),
        (dict(stiffness=np.ones((3, 2, 2)), speeds=[1.0, 2.0]), "table of 2"),
        (dict(stiffness=np.ones((2, 2)), speeds=[1.0, 2.0]), "table of 2"),
        (dict(stiffness=np.ones((2, 2)), axis=(1.0, 1.0, 0.0)), "axis"),
        (dict(stiffness=np.ones((2, 2, 2)), speeds=[1.0, 2.0], interpolation="spline"), "interpolation"),
    ]
    for kwargs, words in cases:
        s = vd.Scene("refusals")
        s.add_body("disk", joint=vd.Pivot((0, 0, 1)), mass=1.0)
        with pytest.raises(ModelError, match=f"bearing 'b1'.*{words}|{words}.*bearing 'b1'"):
            s.add_bearing("b1", "world", "disk", **kwargs)
    s = vd.Scene("refusals")
    s.add_body("disk", joint=vd.Pivot((0, 0, 1)), mass=1.0)
    with pytest.raises(ModelError, match="bearing 'b1'.*journal"):
        s.add_bearing("b1", "disk", "world", stiffness=np.eye(2))


def test_a_speed_outside_the_table_is_refused_naming_the_bearing():
    system = jeffcott(stiffness=np.ones((2, 2, 2)) * 1e4, damping=np.zeros((2, 2, 2)), speeds=[100.0, 200.0]).build()
    with pytest.raises(ModelError, match="bearing 'bearing'.*250 rad/s.*outside its table"):
        system.linearize(v=[0.0, 0.0, 250.0])
    with pytest.raises(ModelError, match="bearing 'bearing'.*outside its table"):
        vd.campbell(system, "disk", [150.0, 250.0])
    with pytest.raises(ModelError, match=r"bearing 'bearing': its table covers 100…200 rad/s, not the speeds asked "
                                         r"\(150…250 rad/s\)"):
        vd.unbalance_response(system, "disk", [150.0, 250.0])


def test_bearing_scene_file_round_trip(tmp_path):
    scene = jeffcott(stiffness=np.ones((2, 2, 2)) * 1e4, damping=np.ones((2, 2, 2)), speeds=[0.0, 300.0],
                     interpolation="pchip", angle=0.25)
    path = tmp_path / "rotor.toml"
    scene.save(path)
    again = vd.load_scene(path)
    assert again.elements["bearing"] == scene.elements["bearing"]
    assert again.elements["u"] == scene.elements["u"]
    a = vd.unbalance_response(scene.build(), "disk", [100.0, 120.0])
    b = vd.unbalance_response(again.build(), "disk", [100.0, 120.0])
    np.testing.assert_array_equal(a.x, b.x)


def test_cross_coupled_jeffcott_modes_and_instability_onset():
    """Isotropic Jeffcott with cross-coupling q: in z = x + iy, M s² + c s + k − iq = 0; the forward mode's
    real part crosses zero at q = c √(k/M)."""
    q_th = C * np.sqrt(K / M)
    for q in (0.5 * q_th, 1.5 * q_th):
        system = jeffcott(kxy=q, kyx=-q).build()
        lin = system.steady_motion({"disk": 100.0}).linearize(method="analytic", hold="disk")
        m = lin.modes()
        lam = np.sort_complex(m.eigenvalues)
        roots = []
        for sign in (1, -1):  # z and its conjugate
            roots += list(np.roots([M, C, K - sign * 1j * q]))
        exact = np.sort_complex(np.array(roots))
        np.testing.assert_allclose(lam, exact, rtol=0, atol=10 * m.relative_error * np.abs(exact).max() + 1e-9)
        assert (lam.real.max() > 0) == (q > q_th)


def test_simulate_with_a_bearing_matches_its_linear_free_response():
    system = jeffcott(kxy=3e3, kyx=-3e3, unbalance=0.0).build()
    q0 = np.array([1e-3, 0.0, 0.0])
    v0 = np.array([0.0, 0.0, 100.0])
    t = np.linspace(0.0, 0.2, 41)
    traj = system.simulate(0.2, q0, v0, t_eval=t, rtol=1e-10)
    lin = system.linearize(system.neutral(), v=v0, method="analytic")
    free = lin.free_response(t, q0 - system.neutral(), np.zeros(3))
    np.testing.assert_allclose(traj.q[:, :2], free.x[:, :2], atol=10 * (traj.error + free.error) + 1e-12)


# ------------------------------------------------------------------------------------------- unbalance
@pytest.mark.parametrize("source", ["element", "centre of mass"])
def test_jeffcott_unbalance_amplitude_per_direction(source):
    scene = jeffcott(unbalance=U, angle=0.3) if source == "element" else jeffcott(unbalance=0.0, com=U / M)
    W = np.linspace(50.0, 400.0, 15)
    r = vd.unbalance_response(scene.build(), "disk", W, outputs=["cx", "cy", ("disk", (0.0, 0.0, 0.0))])
    assert [u.source for u in r.loads] == [source]
    exact = amplitude(W)
    for j in range(4):
        assert np.all(np.abs(r.amplitude[:, j] - exact) <= r.amplitude_error[:, j] + 1e-14 * exact)
        assert np.all(r.amplitude_error[:, j] < 1e-6 * exact)
    np.testing.assert_allclose(r.peak_to_peak, 2 * r.amplitude)
    # x = U Ω² e^{iφ} / (k − MΩ² + icΩ): phase; y lags x by a quarter turn (forward circular whirl)
    phi = 0.3 if source == "element" else 0.0
    ref = np.angle(np.exp(1j * phi) / (K - M * W ** 2 + 1j * C * W))
    np.testing.assert_allclose(np.angle(np.exp(1j * (r.phase[:, 0] - ref))), 0.0, atol=1e-9)
    np.testing.assert_allclose(np.angle(np.exp(1j * (r.phase[:, 1] - r.phase[:, 0] + np.pi / 2))), 0.0, atol=1e-9)
    o = r.orbit(("disk", (0.0, 0.0, 0.0)))
    np.testing.assert_allclose(o.major, exact, rtol=1e-9)
    np.testing.assert_allclose(o.minor, exact, rtol=1e-9)  # a circle
    assert set(o.whirl) == {"forward"}
    assert set(r.stability) == {"stable"}


def test_anisotropic_bearing_elliptic_orbit_backward_between_criticals():
    kx, ky = 6.0e4, 1.0e5
    W = np.array([150.0, 200.0, 205.0, 260.0])
    r = vd.unbalance_response(jeffcott(kxx=kx, kyy=ky).build(), "disk", W, outputs=[("disk", (0.0, 0.0, 0.0))])
    ax, ay = amplitude(W, k=kx), amplitude(W, k=ky)
    assert np.all(np.abs(r.amplitude[:, 0] - ax) <= r.amplitude_error[:, 0] + 1e-14 * ax)
    assert np.all(np.abs(r.amplitude[:, 1] - ay) <= r.amplitude_error[:, 1] + 1e-14 * ay)
    o = r.orbit("disk(0,0,0)")
    wx, wy = np.sqrt(kx / M), np.sqrt(ky / M)
    between = (W > wx) & (W < wy)
    assert list(o.whirl[between]) == ["backward"] * between.sum()
    assert list(o.whirl[~between]) == ["forward"] * (~between).sum()
    # the ellipse traced by the closed-form x(t), y(t) (forces U Ω² (cos Ωt, sin Ωt)), sampled finely
    theta = np.linspace(0.0, 2 * np.pi, 200001)
    for k, w in enumerate(W):
        X = U * w ** 2 / (kx - M * w ** 2 + 1j * C * w)
        Y = -1j * U * w ** 2 / (ky - M * w ** 2 + 1j * C * w)
        radius = np.hypot(np.real(X * np.exp(1j * theta)), np.real(Y * np.exp(1j * theta)))
        assert abs(o.major[k] - radius.max()) <= 1e-9 * radius.max() + o.error[k]
        assert abs(o.minor[k] - radius.min()) <= 1e-9 * radius.max() + o.error[k]


def test_jeffcott_peak_speed_and_half_power_amplification():
    W = np.linspace(100.0, 300.0, 21)
    r = vd.unbalance_response(jeffcott().build(), "disk", W, outputs=["cx"])
    (p,) = r.peaks("cx", operating=(250.0, 300.0))
    wn, zeta = np.sqrt(K / M), C / (2 * np.sqrt(K * M))
    peak = wn / np.sqrt(1 - 2 * zeta ** 2)  # maximum of Ω²/|k − MΩ² + icΩ|
    assert abs(p.speed - peak) <= 10 * p.speed_error and p.speed_error < 1e-6 * peak
    A = amplitude(peak)
    assert abs(p.amplitude - A) <= 10 * p.amplitude_error + 1e-14 * A
    n1 = brentq(lambda w: amplitude(w) - A / np.sqrt(2), 100.0, peak)
    n2 = brentq(lambda w: amplitude(w) - A / np.sqrt(2), peak, 300.0)
    af = peak / (n2 - n1)
    np.testing.assert_allclose(p.half_power, (n1, n2), rtol=1e-8)
    assert abs(p.amplification - af) <= 10 * p.amplification_error + 1e-10 * af
    assert abs(p.amplification - 1 / (2 * zeta)) < 0.05 / (2 * zeta)  # (the light-damping estimate Q = 1/2ζ)
    assert p.separation_margin == pytest.approx((250.0 - peak) / 250.0)
    assert r.peaks("cx")[0].separation_margin is None


def test_unbalance_response_refusals():
    system = jeffcott().build()
    with pytest.raises(ModelError, match="increasing"):
        vd.unbalance_response(system, "disk", [100.0, 50.0])
    with pytest.raises(ModelError, match="not a rotation"):
        vd.unbalance_response(system, "cx", [100.0])
    with pytest.raises(ModelError, match="no unbalance"):
        vd.unbalance_response(jeffcott(unbalance=0.0).build(), "disk", [100.0])
    with pytest.raises(ModelError, match="samples"):
        vd.unbalance_response(system, "disk", [100.0], samples=7)
    s = jeffcott()
    s.add_unbalance("wrong", "cx", 1e-3)
    with pytest.raises(ModelError, match="unbalance 'wrong'.*does not turn with 'disk'"):
        vd.unbalance_response(s.build(), "disk", [100.0])
    gimbal = vd.Scene("asymmetric")  # transverse inertias 0.05 and 0.08: M turns with the spin
    gimbal.add_body("outer", joint=vd.Pivot((1, 0, 0)), mass=0.0)
    gimbal.add_body("inner", parent="outer", joint=vd.Pivot((0, 1, 0)), mass=0.0)
    gimbal.add_body("rotor", parent="inner", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=np.diag([0.05, 0.08, 0.12]))
    gimbal.add_joint_spring("outer", 300.0)
    gimbal.add_joint_spring("inner", 300.0)
    gimbal.add_unbalance("u", "rotor", 1e-4, at=(0.0, 0.0, 0.1))
    with pytest.raises(ModelError, match="changes as the spin turns"):
        vd.unbalance_response(gimbal.build(), "rotor", [10.0, 20.0])
    r = vd.unbalance_response(system, "disk", [100.0, 200.0])
    with pytest.raises(ModelError, match="no output"):
        r.peaks("nothing")
    with pytest.raises(ModelError, match="no orbit"):
        r.orbit(("disk", (1.0, 0.0, 0.0)))


def test_bode_and_polar_plots(tmp_path):
    r = vd.unbalance_response(jeffcott().build(), "disk", np.linspace(150, 250, 11), outputs=["cx", "cy"])
    r.plot(tmp_path / "bode.png", units="rpm", peak_to_peak=True)
    r.polar(tmp_path / "polar.png", "cy")
    assert (tmp_path / "bode.png").stat().st_size > 0 and (tmp_path / "polar.png").stat().st_size > 0
    with pytest.raises(ModelError, match="rpm"):
        r.plot(None, units="Hz")


def hub_rotor(k=100.0, m=1.0, c_n=0.5, c_r=1.0):
    """A disk on two sliders fixed in a hub spun about z (its spring k and damper c_r turn with the hub: rotating
    damping), the disk damped c_n to the world by a bearing (non-rotating damping)."""
    s = vd.Scene("hub")
    s.add_body("hub", joint=vd.Pivot((0, 0, 1)), mass=0.0)
    s.add_body("xr", parent="hub", joint=vd.Slider((1, 0, 0)), mass=0.0)
    s.add_body("disk", parent="xr", joint=vd.Slider((0, 1, 0)), mass=m, inertia=np.diag([0.01, 0.01, 0.02]))
    for body in ("xr", "disk"):
        s.add_joint_spring(body, k)
        s.add_joint_damper(body, c_r)
    s.add_bearing("outer_damper", "world", "disk", stiffness=np.zeros((2, 2)), damping=c_n * np.eye(2))
    s.add_unbalance("u", "disk", U)
    return s.build()


def test_rotating_damping_shows_in_stability_and_drops_out_of_the_synchronous_response():
    """Jeffcott with rotating damping c_r and non-rotating c_n: unstable above Ω_th = ω_n (1 + c_n/c_r); in the
    fixed frame m z̈ + (c_n + c_r) ż + (k − iΩ c_r) z = U Ω² e^{iΩt}, whose synchronous response U Ω² / (k − mΩ² +
    i c_n Ω) has no c_r (the disk whirls with the hub: its rotating damper does not move)."""
    k, m, c_n, c_r = 100.0, 1.0, 0.5, 1.0
    th = np.sqrt(k / m) * (1 + c_n / c_r)
    W = np.array([5.0, 9.0, 12.0, th - 0.3, th + 0.3, 20.0])
    r = vd.unbalance_response(hub_rotor(k, m, c_n, c_r), "hub", W, outputs=["xr", ("disk", (0.0, 0.0, 0.0))])
    growth = [max(np.roots([m, c_n + c_r, k - 1j * w * c_r]).real.max(),
                  np.roots([m, c_n + c_r, k + 1j * w * c_r]).real.max()) for w in W]
    np.testing.assert_allclose(r.growth_rate, growth, atol=1e-8)
    assert list(r.stability) == ["stable"] * 4 + ["unstable"] * 2
    exact = U * W ** 2 / np.abs(k - m * W ** 2 + 1j * c_n * W)
    o = r.orbit(("disk", (0.0, 0.0, 0.0)))
    assert np.all(np.abs(o.major - exact) <= o.error + 1e-12 * exact)
    np.testing.assert_allclose(o.minor, o.major, rtol=1e-9)
    # in the hub's frame the response is steady: the slider's coordinate has no synchronous part
    assert np.all(r.amplitude[:, 0] <= 1e-9 * exact)
    assert np.all(np.abs(np.abs(r.static[:, 0]) - exact * np.abs(np.cos(np.angle(
        W ** 2 / (k - m * W ** 2 + 1j * c_n * W))))) <= r.amplitude_error[:, 0] + 1e-12 * exact)


def test_campbell_diagram_with_a_cross_coupled_bearing():
    """The Campbell diagram of the cross-coupled Jeffcott rotor: its damped frequencies and ζ are the roots of
    M s² + c s + k − iq = 0 in z = x + iy (a bearing's coefficients in every analysis): the forward whirl the
    root with Im s > 0, less damped (q > 0 feeds it), the backward one the other, at every held speed."""
    q = 0.5 * C * np.sqrt(K / M)
    diagram = vd.campbell(jeffcott(kxy=q, kyx=-q).build(), "disk", np.linspace(0.0, 300.0, 4))
    roots = np.roots([M, C, K - 1j * q])
    forward, backward = roots[roots.imag > 0][0], roots[roots.imag < 0][0]
    for row, err, zeta, whirl in zip(diagram.omega[1:], diagram.error[1:], diagram.zeta[1:], diagram.whirl[1:]):
        for r, kind in ((forward, "forward"), (backward, "backward")):
            (j,) = np.flatnonzero(whirl == kind)
            assert abs(row[j] - abs(r.imag)) <= 10 * err[j] + 1e-12 * abs(r)
            assert abs(zeta[j] + r.real / abs(r)) <= 1e-9


def test_tabulated_bearings_analytic_derivatives_on_a_tilting_rotor_match_differences():
    """The journal's spin speed a·(R ω) depends on the tilts and their rates: the analytic K and C (with
    dK/dΩ ∂Ω/∂q, ∂Ω/∂v) against central differences, off centre and moving, within the differences' error."""
    s = vd.Scene("tilt")
    s.add_body("x", joint=vd.Slider((1, 0, 0)))
    s.add_body("y", parent="x", joint=vd.Slider((0, 1, 0)))
    s.add_body("tx", parent="y", joint=vd.Pivot((1, 0, 0)))
    s.add_body("ty", parent="tx", joint=vd.Pivot((0, 1, 0)))
    s.add_body("rotor", parent="ty", joint=vd.Pivot((0, 0, 1)), mass=10.0, inertia=np.diag([0.5, 0.5, 0.3]))
    Kt = [[[1e5, 2e4], [-2e4, 1.2e5]], [[2e5, 5e4], [-6e4, 2.5e5]], [[3e5, 1e5], [-1e5, 4e5]]]
    Ct = [[[100.0, 10.0], [-10.0, 120.0]], [[150.0, 20.0], [-30.0, 160.0]], [[200.0, 40.0], [-40.0, 250.0]]]
    for i, z in enumerate((-0.2, 0.25)):
        s.add_bearing(f"b{i}", ("world", (0, 0, z)), ("rotor", (0, 0, z)), stiffness=Kt, damping=Ct,
                      speeds=[0.0, 200.0, 400.0])
    system = s.build()
    q = system.neutral()
    q[:4] = [1e-3, -2e-3, 0.01, -0.02]
    v = np.array([0.1, -0.2, 0.3, 0.5, 250.0])
    an = system.linearize(q, v=v, method="analytic", a=np.zeros(5))
    fd = system.linearize(q, v=v, method="fd", a=np.zeros(5))
    assert an.method == "analytic"
    assert np.all(np.abs(an.K - fd.K) <= 10 * (fd.K_error + an.K_error) + 1e-9 * np.abs(fd.K).max())
    assert np.all(np.abs(an.C - fd.C) <= 10 * (fd.C_error + an.C_error) + 1e-9 * np.abs(fd.C).max())
    # (without the dK/dΩ terms the guard falls back to differences and the method assertion fails: checked)
