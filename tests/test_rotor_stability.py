"""Rotor stability and report pictures (issue 43, items 3 and 4; issue 40, item 12's numbering): log decrements,
onset speeds, the cross-coupled stiffness at zero log decrement and the critical-speed map, against closed forms."""

import contextlib
import io
import json

import numpy as np
import pytest
import scipy.linalg as sl

import vibdyn as vd
from vibdyn.errors import ConvergenceError, ModelError
from vibdyn.faces.cli import main

M, K = 2.0, 800.0
WN = np.sqrt(K / M)


def fixed_rotor(c=4.0, q=0.0, m=M, k=K):
    """A disk on two sliders of the ground (its coordinates in the fixed frame), spinning on a pivot: k, c in x
    and y (no damper where c = 0), and a cross-coupled stiffness q (F_x = −q y, F_y = +q x) as a force law."""
    s = vd.Scene("fixed jeffcott")
    s.add_body("x", joint=vd.Slider(axis=(1, 0, 0)), mass=0.0)
    s.add_body("y", parent="x", joint=vd.Slider(axis=(0, 1, 0)), mass=0.0)
    s.add_body("disk", parent="y", joint=vd.Pivot(axis=(0, 0, 1)), mass=m, inertia=np.diag([.01, .01, .02]))
    for b in ("x", "y"):
        s.add_joint_spring(b, k)
        if c:
            s.add_joint_damper(b, c)
    if q:
        s.add_force("cross", "disk", force=lambda t, qq, v: np.array([-q * qq[1], q * qq[0], 0.0]))
    return s


def spun_hub(cr=1.5, cn=3.0):
    """Jeffcott on a spun hub: the disk on two sliders carried by the hub (its coordinates rotate with it), the
    shaft's stiffness and rotating damping c_r on those sliders (they spin with the hub), the non-rotating
    damping c_n as two dampers to the ground along x and y."""
    s = vd.Scene("jeffcott")
    s.add_body("hub", joint=vd.Pivot(axis=(0, 0, 1)), mass=1.0, inertia=np.diag([.01, .01, .02]))
    s.add_body("u", parent="hub", joint=vd.Slider(axis=(1, 0, 0)), mass=0.0)
    s.add_body("disk", parent="u", joint=vd.Slider(axis=(0, 1, 0)), mass=M)
    for b in ("u", "disk"):
        s.add_joint_spring(b, K)
        s.add_joint_damper(b, cr)
    s.add_damper("cnx", ("world", (1.0, 0, 0)), ("disk", (0, 0, 0)), cn)
    s.add_damper("cny", ("world", (0, 1.0, 0)), ("disk", (0, 0, 0)), cn)
    return s


def test_log_decrement_of_a_damped_mode_is_the_closed_form():
    for c in (4.0, 24.0):  # ζ = 0.05 and 0.3
        zeta = c / (2 * np.sqrt(K * M))
        d = vd.campbell(fixed_rotor(c).build(), "disk", [0.0, 50.0, 100.0])
        exact = 2 * np.pi * zeta / np.sqrt(1 - zeta**2)
        assert d.frame == "fixed" and d.log_dec.shape == (3, 2)
        assert np.all(np.abs(d.log_dec - exact) <= 10 * d.log_dec_error + 1e-14)
        assert np.all(d.log_dec_error < 1e-8 * exact)  # an estimate, not a bound of convenience
        assert np.all(np.abs(d.sigma + zeta * WN) <= 10 * d.error)


def test_rotating_damping_shows_in_the_real_parts_and_the_onset_is_jeffcotts():
    cr, cn = 1.5, 3.0
    threshold = WN * (1 + cn / cr)
    c = vd.campbell(spun_hub(cr, cn).build(), "hub", np.linspace(0.0, 2.3 * threshold, 17))
    assert c.frame == "rotating"
    for s, sig, om, err in zip(c.speeds, c.sigma, c.omega, c.error):
        # m λ² + (c_n + c_r) λ + k − i c_r Ω = 0 in the fixed frame; a rotating frame shifts Im λ by Ω only
        lam = np.roots([M, cn + cr, K - 1j * cr * s])
        assert np.sort(sig) == pytest.approx(np.sort(lam.real), abs=10 * err.max())
        assert np.sort(om) == pytest.approx(np.sort(np.abs(lam.imag - s)), abs=10 * err.max())
    # whirl in the fixed frame although the coordinates turn: the forward mode is |ω_f − Ω| here, at ω_f − Ω
    # against the spin in the hub's frame above ω_f, still forward for a fixed observer
    fwd = [j for j in range(2) if set(c.whirl[1:, j]) == {"forward"}]
    assert len(fwd) == 1 and set(c.whirl[1:, 1 - fwd[0]]) == {"backward"}
    (onset,) = c.onset()
    assert onset.kind == "instability" and onset.number == onset.mode + 1
    assert onset.mode == fwd[0] and onset.whirl == "forward"  # rotating damping destabilises forward whirl
    assert abs(onset.speed - threshold) <= 10 * onset.speed_error
    assert onset.speed_error < 1e-8 * threshold
    assert np.all(c.log_dec[-1].min() < 0) and np.all(c.log_dec[0] > 0)
    # no rotating damping, no onset: the same rotor stays stable at every speed
    assert vd.campbell(spun_hub(0.0, cn).build(), "hub", np.linspace(0, 2.3 * threshold, 9)).onset() == []


def test_a_jump_in_the_followed_mode_is_refused_not_called_a_root():
    # in the rotating frame the forward mode's |Im λ| passes through 0 at Ω = ω_n, where its shape flips to the
    # conjugate: on a grid that spans it the crossing cannot be followed — say so rather than return a number
    c = vd.campbell(spun_hub().build(), "hub", np.linspace(0, 1200, 5) * np.pi / 30)
    with pytest.raises(ConvergenceError, match="no continuous crossing"):
        c.critical_speeds(1)


def test_cross_coupled_stiffness_at_zero_log_decrement():
    c = 4.0
    exact = c * WN  # m z̈ + c ż + (k − i q) z = 0 is neutral at q = c ω_n, the forward whirl
    lim = vd.stability_limit(lambda q: fixed_rotor(c, q), np.linspace(0.1 * exact, 2 * exact, 6), "disk", 50.0,
                             method="fd", unit="N/m")
    assert set(lim.whirl) == {"forward"}
    assert lim.log_dec[0] > 0 > lim.log_dec[-1]
    assert abs(lim.limit - exact) <= 10 * lim.limit_error and lim.limit_error < 1e-8 * exact
    # a named parameter of a scene: the disk's mass at which the same rotor loses stability, m = k c² / q²
    q = 1.5 * exact
    by_mass = vd.stability_limit(fixed_rotor(c, q), np.linspace(0.3, 4.0, 6), "disk", 50.0, parameter="disk.mass",
                                 method="fd")
    m0 = K * c**2 / q**2
    assert by_mass.unit == "kg" and abs(by_mass.limit - m0) <= 10 * by_mass.limit_error
    json.dumps(by_mass.to_dict())


def test_non_rotating_damping_that_stabilises_the_spun_hub():
    # Jeffcott's threshold solved for c_n at a held speed: c_n = c_r (Ω/ω_n − 1); the coordinates turn with the
    # hub (δ in the hub's frame), the first forward mode found by its fixed-frame whirl
    cr, speed = 1.5, 50.0
    lim = vd.stability_limit(lambda cn: spun_hub(cr, cn), np.linspace(0.5, 5.0, 6), "hub", speed, unit="N·s/m")
    assert lim.frame == "rotating" and set(lim.whirl) == {"forward"}
    assert lim.log_dec[0] < 0 < lim.log_dec[-1]
    exact = cr * (speed / WN - 1)
    assert abs(lim.limit - exact) <= 10 * lim.limit_error and lim.limit_error < 1e-8 * exact


MD, MJ, KS = 10.0, 0.1, 1e6


def simple_rotor(kb=1e5):
    """A disk (mass MD) on a shaft of stiffness KS whose journal (mass MJ) sits on an isotropic bearing kb (a
    spring of zero free length to the ground), spinning on a pivot."""
    s = vd.Scene("simple rotor")
    s.add_body("jx", joint=vd.Slider(axis=(1, 0, 0)), mass=0.0)
    s.add_body("jy", parent="jx", joint=vd.Slider(axis=(0, 1, 0)), mass=MJ)
    s.add_body("dx", parent="jy", joint=vd.Slider(axis=(1, 0, 0)), mass=0.0)
    s.add_body("dy", parent="dx", joint=vd.Slider(axis=(0, 1, 0)), mass=0.0)
    s.add_body("disk", parent="dy", joint=vd.Pivot(axis=(0, 0, 1)), mass=MD, inertia=np.diag([.1, .1, .2]))
    s.add_spring("brg", ("world", (0, 0, 0)), ("jy", (0, 0, 0)), kb, free_length=0.0)
    s.add_joint_spring("dx", KS)
    s.add_joint_spring("dy", KS)
    s.add_joint_damper("dx", 50.0)  # left out of the undamped map
    return s


def test_critical_speed_map_against_the_two_mass_rotor_and_its_asymptotes(tmp_path):
    kb = np.logspace(2, 10, 9)
    cmap = vd.critical_speed_map(simple_rotor(), kb, "disk", np.linspace(1.0, 5000.0, 6), parameter="brg.stiffness")
    assert cmap.unit == "N/m" and cmap.speeds.shape[0] == 9
    first = cmap.speeds[:, 0]
    for k, row, err in zip(kb, cmap.speeds, cmap.errors):
        exact = np.sqrt(sl.eigh(np.array([[KS, -KS], [-KS, KS + k]]), np.diag([MD, MJ]), eigvals_only=True))
        found = row.compressed()
        assert found == pytest.approx(exact[:found.size], abs=10 * err.compressed().max())
    rigid, soft = np.sqrt(KS / MD), np.sqrt(kb / (MD + MJ))
    assert abs(first[-1] / rigid - 1) <= KS / kb[-1]  # rigid bearings: the shaft alone
    assert abs(first[0] / soft[0] - 1) <= kb[0] / KS  # soft bearings: the whole rotor on the bearing
    slopes = np.diff(np.log(first)) / np.diff(np.log(kb))
    assert slopes[0] == pytest.approx(0.5, abs=1e-3) and abs(slopes[-1]) < 1e-3
    fig = cmap.plot(tmp_path / "map.png", units="rpm")
    ax = fig.axes[0]
    assert ax.get_xscale() == ax.get_yscale() == "log"
    assert ax.lines[0].get_ydata()[0] == pytest.approx(first[0] * 30 / np.pi)
    json.dumps(cmap.to_dict())


def test_modes_are_numbered_from_one_in_critical_speeds_tables_json_and_pictures(tmp_path):
    c = vd.campbell(vd.load_scene("gimbal_rotor").build(), "rotor", np.linspace(0, 150, 16))
    (cs,) = c.critical_speeds(1)
    assert cs.number == cs.mode + 1 and f"mode {cs.number}," in repr(cs)
    assert c.omega[:, cs.mode][0] > 0  # ``mode`` stays the 0-based column
    assert c.to_dict()["critical_speeds"][0]["mode_number"] == cs.number
    fig = c.plot(tmp_path / "c.png", units="rpm", frequency="rad/s")
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "mode 1 (forward whirl)" in labels or "mode 1 (backward whirl)" in labels
    assert not any(t.startswith("mode 0") for t in labels)
    assert any(t.startswith("c1:") and f"mode {cs.number}" in t for t in labels)
    ax = fig.axes[0]
    assert "rpm" in ax.get_xlabel() and "rad/s" in ax.get_ylabel()
    line = ax.lines[0]
    assert line.get_xdata() == pytest.approx(c.speeds * 30 / np.pi)
    assert line.get_ydata() == pytest.approx(c.omega[:, 0])
    # the order line's label sits inside the axes
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    (order,) = [t for t in ax.texts if t.get_text() == "1×"]
    x, y = order.xy
    assert x0 < x < x1 and y0 < y < y1


def test_campbell_cli_in_rpm_numbers_modes_from_one(tmp_path):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["campbell", "gimbal_rotor", "--spin", "rotor", "--speeds", "0:1500:7", "--rpm",
                     "--png", str(tmp_path / "c.png")]) == 0
    text = out.getvalue()
    assert "speed rpm" in text and "mode 1 f_d Hz" in text and "mode 0" not in text
    exact = np.sqrt(300.0 / (0.08 + 0.12))
    assert f"critical speed {exact * 30 / np.pi:.9}" in text and "rpm" in text


@pytest.mark.parametrize("call, words", [
    (lambda: vd.campbell(fixed_rotor().build(), "disk", [0.0, 20.0, 10.0]), "speeds[2] = 10 after 20"),
    (lambda: vd.campbell(fixed_rotor().build(), "disk", [0.0, 1.0], undamped="yes"), "undamped"),
    (lambda: vd.stability_limit(lambda q: fixed_rotor(q=q), [2.0, 1.0], "disk", 10.0), "values must be"),
    (lambda: vd.stability_limit(lambda q: None, [1.0, 2.0], "disk", 10.0), "returned NoneType"),
    (lambda: vd.stability_limit(fixed_rotor(), [1.0, 2.0], "disk", 10.0), "name the parameter"),
    (lambda: vd.stability_limit(fixed_rotor(), [1.0, 2.0], "disk", 10.0, parameter="disk.mas"), "disk.mass"),
    (lambda: vd.stability_limit(lambda c: fixed_rotor(c), [1.0, 2.0], "disk", 10.0, mode=0), "mode"),
    (lambda: vd.stability_limit(lambda c: fixed_rotor(c), [1.0, 2.0], "disk", [1.0, 2.0]), "speed must be one"),
    (lambda: vd.stability_limit(lambda c: fixed_rotor(c), [1.0, 2.0], "x", 10.0), "'x' is not a rotation"),
    (lambda: vd.critical_speed_map(simple_rotor(), [0.0, 1.0], "disk", [1.0, 2.0], parameter="brg.stiffness"),
     "positive"),
    (lambda: vd.critical_speed_map(simple_rotor(), [1.0, np.nan], "disk", [1.0, 2.0], parameter="brg.stiffness"),
     "values"),
    (lambda: vd.critical_speed_map(lambda k: 1 / 0, [1.0, 2.0], "disk", [1.0, 2.0]),
     "the builder <lambda> failed at 1: ZeroDivisionError"),
    (lambda: vd.stability_limit(lambda c: fixed_rotor(c=c / 0), [1.0, 2.0], "disk", 10.0),
     "the builder <lambda> failed at 1: "),
    (lambda: vd.campbell(fixed_rotor().build(), "disk", [0.0, 1.0]).plot(units="rpms"), "units"),
    (lambda: vd.campbell(fixed_rotor().build(), "disk", [0.0, 1.0]).plot(frequency="kHz"), "frequency"),
])
def test_bad_input_is_refused_naming_it(call, words):
    with pytest.raises(ModelError, match=None) as e:
        call()
    assert words in str(e.value)


def test_cli_refuses_bad_rpm_speeds():
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        assert main(["campbell", "gimbal_rotor", "--spin", "rotor", "--speeds", "0:x:3", "--rpm"]) == 2
    assert "speeds in rpm" in err.getvalue()
