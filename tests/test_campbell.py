"""Campbell diagrams: a gimballed disk rotor against its closed form, the R6 rotor against its held-speed
linearisation, tracking through a true crossing, critical speeds refined on the linearisation itself."""

import contextlib
import io
import json

import numpy as np
import pytest
from conftest import MODELS

import vibdyn as vd
from vibdyn.faces.cli import main

IT, IP, K = 0.08, 0.12, 300.0


def gimbal(It=IT, Ip=IP, k=K):
    s = vd.Scene("gimbal")
    s.add_body("outer", joint=vd.Pivot(axis=(1, 0, 0)), mass=0.0)
    s.add_body("inner", parent="outer", joint=vd.Pivot(axis=(0, 1, 0)), mass=0.0)
    s.add_body("rotor", parent="inner", joint=vd.Pivot(axis=(0, 0, 1)), mass=1.0, inertia=np.diag([It, It, Ip]))
    s.add_joint_spring("outer", k)
    s.add_joint_spring("inner", k)
    return s.build()


def closed_form(W, It=IT, Ip=IP, k=K):
    """(backward, forward) tilt frequencies of the gimballed rotor: It ω² ∓ Ip Ω ω − k = 0."""
    root = np.sqrt((Ip * W) ** 2 + 4 * It * k)
    return (-Ip * W + root) / (2 * It), (Ip * W + root) / (2 * It)


def test_gimballed_disk_frequencies_whirl_and_critical_speed():
    c = vd.campbell(gimbal(), "rotor", np.linspace(0, 150, 31), held=False)
    assert c.omega.shape == (31, 3)
    assert np.all(c.omega[:, 0] == 0.0)  # the spin itself: cyclic, exactly 0
    back, fwd = closed_form(c.speeds)
    lo, hi = c.omega[:, 1], c.omega[:, 2]
    # the tracked columns are one physical mode each: from Ω > 0 on, the higher is the forward whirl
    if hi[5] < lo[5]:
        lo, hi = hi, lo
    err = np.maximum(c.error[:, 1], c.error[:, 2])
    assert np.all(np.abs(lo - back) <= 1e-7 * back) and np.all(np.abs(hi - fwd) <= 1e-7 * fwd)
    assert np.all(np.abs(lo - back) <= 10 * err + 4 * np.finfo(float).eps * fwd)  # honest estimate
    col_hi = 2 if c.omega[5, 2] > c.omega[5, 1] else 1
    assert all(w == "forward" for w in c.whirl[1:, col_hi])
    assert all(w == "backward" for w in c.whirl[1:, 3 - col_hi])
    assert c.whirl[0, 1] == c.whirl[0, 2] == ""  # no spin, no whirl
    crit = c.critical_speeds(1)
    assert len(crit) == 1, crit  # a disk (Ip > It): backward only
    (cs,) = crit
    exact = np.sqrt(K / (IT + IP))
    assert cs.whirl == "backward" and cs.mode == 3 - col_hi
    assert abs(cs.speed - exact) <= 1e-8 * exact
    assert abs(cs.speed - exact) <= 10 * cs.error


def test_rod_like_rotor_has_forward_and_backward_critical_speeds():
    It, Ip = 0.12, 0.05
    c = vd.campbell(gimbal(It, Ip), "rotor", np.linspace(0, 200, 21))
    crit = {k.whirl: k.speed for k in c.critical_speeds(1)}
    assert crit["backward"] == pytest.approx(np.sqrt(K / (It + Ip)), rel=1e-8)
    assert crit["forward"] == pytest.approx(np.sqrt(K / (It - Ip)), rel=1e-8)
    # order 2: where a mode meets twice the spin speed: It(2Ω)² ∓ 2IpΩ² − k = 0
    crit2 = {k.whirl: k.speed for k in c.critical_speeds(2)}
    assert crit2["backward"] == pytest.approx(np.sqrt(K / (4 * It + 2 * Ip)), rel=1e-8)
    assert crit2["forward"] == pytest.approx(np.sqrt(K / (4 * It - 2 * Ip)), rel=1e-8)


def test_r6_rotor_at_its_regime_speed_equals_the_held_speed_model():
    system = vd.load_scene(MODELS / "rotor_slider.toml").build()
    w_star = np.sqrt(10.0)
    c = vd.campbell(system, "rotor", [0.0, 1.0, 2.0, 3.0, w_star, 4.0])
    row = c.omega[4]
    lam = system.steady_motion({"rotor": w_star}).linearize(method="analytic").modes().damped_eigenvalues
    assert sorted(row) == pytest.approx(sorted([0.0, np.abs(lam.imag).max()]), abs=10 * c.error[4].max())
    assert np.abs(row).max() == pytest.approx(9.8697688, abs=1e-7)  # reference-cases R6
    assert c.zeta[4].max() == pytest.approx(1.8225996 / np.hypot(1.8225996, 9.8697688), abs=1e-7)


def crossing_rotor():
    """A heavy rotor carrying a radial slider (ω² ≈ k/m − Ω²: its frequency falls with the speed) and an
    axial slider (uncoupled from the spin: its frequency stays √(k/m) = 7 rad/s): their curves truly cross."""
    s = vd.Scene("crossing")
    s.add_body("rotor", joint=vd.Pivot(axis=(0, 0, 1)), mass=1.0, inertia=np.diag([1e3, 1e3, 1e3]))
    s.add_body("radial", parent="rotor", joint=vd.Slider(axis=(1, 0, 0), at=(0.5, 0, 0)), mass=1.0,
               inertia=vd.inertia.point())
    s.add_spring("k_radial", ("rotor", (0, 0, 0)), ("radial", (0, 0, 0)), stiffness=100.0, free_length=0.5)
    s.add_body("axial", parent="rotor", joint=vd.Slider(axis=(0, 0, 1)), mass=1.0, inertia=vd.inertia.point())
    s.add_joint_spring("axial", 49.0)
    return s.build()


def test_tracking_follows_each_mode_through_a_true_crossing():
    c = vd.campbell(crossing_rotor(), "rotor", np.linspace(0, 8, 33), held=False)
    const = [j for j in range(3) if c.omega[0, j] > 0 and np.ptp(c.omega[:, j]) <= 1e-9 * 7.0]
    assert len(const) == 1 and c.omega[0, const[0]] == pytest.approx(7.0, rel=1e-12)
    moving = [j for j in range(3) if j not in const and c.omega[0, j] > 0]
    assert len(moving) == 1
    f = c.omega[:, moving[0]]
    assert f[0] > 7.0 > f[-1] and np.all(np.diff(f) < 0)  # it crosses the constant one and stays itself


def test_campbell_cli_table_json_and_png(tmp_path):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["campbell", str(MODELS / "gimbal_rotor.toml"), "--spin", "rotor", "--speeds", "0:150:7",
                     "--png", str(tmp_path / "c.png")])
    assert code == 0
    text = out.getvalue()
    assert "critical speed 38.7298334" in text and "backward whirl" in text
    assert (tmp_path / "c.png").stat().st_size > 10_000
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["campbell", "gimbal_rotor", "--spin", "rotor", "--speeds", "0,40,80", "--json"]) == 0
    data = json.loads(out.getvalue(), parse_constant=lambda s: pytest.fail(f"non-JSON constant {s}"))
    assert data["critical_speeds"][0]["speed_rad_s"] == pytest.approx(np.sqrt(K / (IT + IP)), rel=1e-8)
    assert data["spin_held"] is True and len(data["critical_speeds"]) == 1


def test_campbell_cli_says_whether_the_spin_is_held():
    for extra, words, modes in (([], "'rotor' held at each speed by its drive", 2),
                                (["--free-spin"], "'rotor' free at each steady motion", 3)):
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            assert main(["campbell", "gimbal_rotor", "--spin", "rotor", "--speeds", "0,40,80"] + extra) == 0
        text = out.getvalue()
        assert words in text and f"{modes} modes tracked" in text


@pytest.mark.parametrize("argv, words", [
    (["--spin", "rotr", "--speeds", "0:10:3"], "did you mean 'rotor'"),
    (["--spin", "rotor", "--speeds", "0:10"], "--speeds"),
    (["--spin", "rotor", "--speeds", "5,1"], "increasing"),
    (["--spin", "rotor", "--speeds", "0:10:3", "--orders", "x"], "--orders"),
])
def test_campbell_cli_refuses_bad_input(argv, words):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["campbell", "gimbal_rotor"] + argv)
    assert code == 2 and words in err.getvalue()


def test_campbell_refuses_a_translation_as_spin():
    with pytest.raises(vd.ModelError, match="not a rotation"):
        vd.campbell(crossing_rotor(), "axial", [0.0, 1.0])


def test_modes_of_the_spinning_gimbal_print_no_round_off_noise():
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["modes", "gimbal_rotor"]) == 0
    text = out.getvalue()
    assert "0 ± 21.824584i" in text and "0 ± 171.82458i" in text and "e-10" not in text


def test_slow_precession_at_extreme_spin_is_not_rounded_to_zero():
    """It θ̈ + b φ̇ + k θ = 0, It φ̈ − b θ̇ + k φ = 0 (b = Ip Ω): It ω² ∓ b ω − k = 0, so the slow precession
    2k / (b + √(b² + 4 It k)) (written without cancellation) and the nutation (b + √(b² + 4 It k)) / (2 It). At
    1e6 rad/s the precession is 2.5e-3 rad/s, far below √ε of the nutation but with an error of its own ~1e-17:
    it once came out as 0 ± 1.5e-6 (taken for the split zero of the spin)."""
    speeds = np.array([1e3, 1e5, 1e6])
    c = vd.campbell(gimbal(), "rotor", speeds, held=False)
    b = IP * speeds
    root = np.sqrt(b**2 + 4 * IT * K)
    slow, fast = 2 * K / (b + root), (b + root) / (2 * IT)
    eps = np.finfo(float).eps
    for i in range(len(speeds)):
        order = np.argsort(c.omega[i])
        f, e = c.omega[i][order], c.error[i][order]
        assert f[0] == 0.0  # the spin: cyclic
        assert abs(f[1] - slow[i]) <= e[1] + 4 * eps * slow[i]  # (the closed form's own rounding)
        assert abs(f[2] - fast[i]) <= e[2] + 4 * eps * fast[i]
        assert e[1] < 1e-6 * slow[i] and e[2] < 1e-6 * fast[i]


G, L_ARM, M_BEAD, J_HUB = 9.81, 0.5, 0.2, 0.05


def bead_on_hoop():
    """The bead on a rotating hoop (Taylor, Classical Mechanics, §7.6): a point mass m on a massless arm of
    length l hinged on a hub that spins about the vertical (hub inertia J about it); θ from the downward
    vertical. With the hub's speed Ω held, cos θ₀ = g/(lΩ²) and θ oscillates at Ω sin θ₀."""
    s = vd.Scene("bead_on_hoop")
    s.gravity = (0.0, 0.0, -G)
    s.add_body("hub", joint=vd.Pivot(axis=(0, 0, 1)), mass=1.0, inertia=np.diag([J_HUB, J_HUB, J_HUB]))
    s.add_body("bead", parent="hub", joint=vd.Pivot(axis=(0, 1, 0)), mass=M_BEAD, com=(0, 0, -L_ARM),
               inertia=vd.inertia.point())
    return s.build()


def test_bead_on_rotating_hoop_held_and_free_hub():
    """Held hub: ω = Ω sin θ₀ (Taylor 7.6). Free hub (its angular momentum p = I(θ)φ̇ conserved, I = J + m l²
    sin²θ): the Routhian's stiffness at fixed p adds p² I'²/I³, so ω² = Ω² sin²θ₀ (1 + 4 m l² cos²θ₀ / I(θ₀))."""
    system = bead_on_hoop()
    speeds = np.array([5.0, 6.0, 8.0, 10.0])
    theta0 = np.arccos(G / (L_ARM * speeds**2))
    held = vd.campbell(system, "hub", speeds, q0=[0.0, 0.9])
    assert held.held and held.omega.shape == (4, 1)
    exact = speeds * np.sin(theta0)
    assert np.all(np.abs(held.omega[:, 0] - exact) <= held.error[:, 0] + 4 * np.finfo(float).eps * exact)
    assert np.all(held.error[:, 0] <= 1e-9 * exact)  # the accuracy, by the result's own estimate
    free = vd.campbell(system, "hub", speeds, q0=[0.0, 0.9], held=False)
    inertia = J_HUB + M_BEAD * L_ARM**2 * np.sin(theta0) ** 2
    exact_free = exact * np.sqrt(1 + 4 * M_BEAD * L_ARM**2 * np.cos(theta0) ** 2 / inertia)
    f = np.sort(free.omega, axis=1)
    assert np.all(f[:, 0] == 0.0)  # the free hub: cyclic
    assert np.all(np.abs(f[:, 1] - exact_free) <= np.max(free.error, axis=1) + 4 * np.finfo(float).eps * exact_free)
    assert np.all(np.abs(exact_free / exact - 1) > 0.03)  # the two differ (4 to 67 %): the test tells them apart
    assert json.loads(json.dumps(held.to_dict()))["spin_held"] is True


def test_held_spin_removes_only_the_cyclic_zero_of_a_symmetric_rotor():
    """The gimballed disk's tilt modes do not move the spin: held or free, It ω² ∓ Ip Ω ω − k = 0."""
    speeds = np.linspace(0, 150, 7)
    c = vd.campbell(gimbal(), "rotor", speeds)
    assert c.held and c.omega.shape == (7, 2)
    back, fwd = closed_form(speeds)
    f = np.sort(c.omega, axis=1)
    assert np.all(np.abs(f[:, 0] - back) <= c.error.max(axis=1) + 1e-12 * fwd)
    assert np.all(np.abs(f[:, 1] - fwd) <= c.error.max(axis=1) + 1e-12 * fwd)


def test_held_spin_of_the_crossing_rotor_is_the_rotating_frame_closed_form():
    """A radial slider on a hub held at Ω: m(r̈ − Ω² r) = −k (r − r₀), so ω² = k/m − Ω² exactly (free, the
    Coriolis coupling with the hub's own motion moves it)."""
    speeds = np.linspace(0, 8, 9)
    c = vd.campbell(crossing_rotor(), "rotor", speeds)
    f = np.sort(c.omega, axis=1)
    radial = np.sqrt(100.0 - speeds**2)
    k = np.argmin(np.abs(f - radial[:, None]), axis=1)
    got = f[np.arange(len(speeds)), k]
    assert np.all(np.abs(got - radial) <= c.error.max(axis=1) + 1e-12 * 10)


def test_motor_law_on_the_spin_keeps_it_free_by_default():
    """R6: a motor law τ(ω) on the rotor is its drive; the default diagram keeps its speed stiffness."""
    system = vd.load_scene(MODELS / "rotor_slider.toml").build()
    assert not vd.campbell(system, "rotor", [1.0, 2.0]).held
    held = vd.campbell(system, "rotor", [1.0, 2.0], held=True)
    assert held.held and held.omega.shape == (2, 1)
    with pytest.raises(vd.ModelError, match="held must be"):
        vd.campbell(system, "rotor", [1.0, 2.0], held="yes")
