"""Operating points a new user meets first (issue 8, points 4, 6, 7): equilibrium searches that start where
K = 0, forces with no stationary point, joint limits of robots, configurations held by drives, and the
text the CLI prints about them."""

import json
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import vibdyn as vd
from vibdyn._format import number
from vibdyn.faces.cli import main
from vibdyn.io import robots

MODELS = Path(__file__).resolve().parents[1] / "models"
G = 9.81


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


# ------------------------------------------------------------------ point 4: searches that used to fail
def test_search_from_a_start_where_k_is_zero_finds_the_hanging_equilibrium():
    # IFToMM A01 starts horizontal: gravity torque m g L, stiffness −m g L sin q = 0 there
    system = vd.load_scene(MODELS / "iftomm_a01.toml").build()
    eq = system.equilibrium()  # from neutral, not from the file's start
    assert abs(eq.coordinate("pendulum") + np.pi / 2) <= eq.q_error[0] + 1e-12
    assert eq.stability == "stable"
    m = eq.linearize().modes()
    assert m.omega[0] == pytest.approx(np.sqrt(G / 1.0), rel=10 * m.omega_relative_error[0] + 1e-12)


def test_a_constant_generalized_force_is_refused_as_having_no_stationary_point():
    scene = vd.load_scene(MODELS / "helical.toml")
    scene.set_operating_point()  # the file holds it; without that, a search
    with pytest.raises(vd.ConvergenceError, match=r"no static equilibrium: .*'screw' is constant.*held"):
        scene.build().operating_point()


def test_bundled_helical_is_held_by_the_torque_m_g_p(capsys):
    system = vd.load_scene(MODELS / "helical.toml").build()
    op = system.operating_point()
    assert op.regime == "held"
    assert abs(op.drive["screw"] - 2.0 * G * 0.1) <= op.tol  # m g p, N·m
    m = op.linearize().modes()
    assert m.rigid.tolist() == [True]  # gravity's torque does not depend on the angle: K = 0
    code, out, _ = run(capsys, "modes", "helical")
    assert code == 0 and "held configuration" in out and "1.962 N·m" in out


def test_non_convergence_names_the_unsettled_coordinates_and_suggests_a_start():
    s = vd.Scene("driven")
    s.add_body("wheel", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=vd.inertia.disc(1.0, 0.1))
    s.add_joint_force("wheel", lambda t, q, v: 2.0 + 0.5 * np.sin(q), velocity_dependent=False,
                      time_dependent=False)  # never zero, but not constant
    with pytest.raises(vd.ConvergenceError) as err:
        s.build().equilibrium(max_iter=10)
    text = str(err.value)
    assert "did not converge" in text and "not settled: 'wheel'" in text
    # no torque balance anywhere: no start converges, none is suggested (a suggested start is a checked one:
    # tests/test_probe_round5_lin.py)
    assert "--start" not in text and "No start was suggested" in text


def test_start_by_coordinate_name_in_files_and_on_the_command_line(tmp_path, capsys):
    text = (MODELS / "double_pendulum.toml").read_text()
    by_name = tmp_path / "named.toml"
    by_name.write_text(text + '\n[operating_point]\nstart = { mass2 = 3.0 }\n')
    scene = vd.load_scene(by_name)
    assert scene.operating_point["start"] == {"mass2": 3.0}
    eq = scene.build().operating_point()
    assert abs(abs(eq.coordinate("mass2")) - np.pi) <= eq.q_error[1] + 1e-9  # the upturned lower mass
    assert eq.stability == "unstable"
    scene.save(tmp_path / "again.toml")
    assert vd.load_scene(tmp_path / "again.toml").operating_point == scene.operating_point
    listed = tmp_path / "listed.toml"  # the original form: one offset per coordinate
    listed.write_text(text + '\n[operating_point]\nstart = [0.0, 3.0]\n')
    eq2 = vd.load_scene(listed).build().operating_point()
    assert np.abs(eq2.system.difference(eq.q, eq2.q)).max() <= 1e-9
    code, out, _ = run(capsys, "modes", str(listed), "--start", "mass2=0.1", "--json")
    assert code == 0 and json.loads(out)["operating_point"]["stability"] == "stable"
    code, _, err = run(capsys, "modes", "double_pendulum", "--start", "mass3=1")
    assert code == 2 and "mass3" in err and "mass1" in err
    code, _, err = run(capsys, "modes", "double_pendulum", "--start", "mass2")
    assert code == 2 and "NAME=VALUE" in err


# ------------------------------------------------------------------ point 7: limits and held points
def test_robots_keep_the_position_limits_of_their_urdf():
    scene = vd.load_robot("panda")
    system = scene.build()
    model = scene.robot_source.pin_model()
    for name, (lo, up) in system.limits.items():
        j = model.getJointId(name)
        assert (lo, up) == (model.lowerPositionLimit[model.idx_qs[j]], model.upperPositionLimit[model.idx_qs[j]])
    assert system.limits["panda_finger_joint1"] == (0.0, 0.04)
    lower, upper = system.limit_bounds()
    assert np.all(lower <= upper) and len(system.limits) == 9


def test_modes_of_panda_keep_the_fingers_within_their_limits(capsys):
    code, out, _ = run(capsys, "modes", "robot:panda", "--json")
    assert code == 0
    d = json.loads(out)
    assert d["operating_point"]["regime"] == "held"
    offsets = dict(zip(d["coordinates"], d["operating_point"]["offsets"]))
    for finger in ("panda_finger_joint1", "panda_finger_joint2"):
        assert 0.0 <= offsets[finger] <= 0.04


def test_start_of_a_held_robot_moves_its_configuration_within_limits(capsys):
    code, out, _ = run(capsys, "modes", "robot:panda", "--start", "panda_joint4=-1.5", "--json")
    offsets = dict(zip(json.loads(out)["coordinates"], json.loads(out)["operating_point"]["offsets"]))
    assert code == 0 and offsets["panda_joint4"] == pytest.approx(-1.5, abs=1e-15)
    assert offsets["panda_joint2"] == pytest.approx(-0.785398, abs=1e-15)  # the SRDF posture for the others
    code, _, err = run(capsys, "modes", "robot:ur5", "--start", "elbow_joint=9")
    assert code == 2 and "'elbow_joint' = 9 rad is beyond its upper limit 3.14159 rad" in err


def test_a_search_that_would_leave_the_limits_refuses_naming_coordinate_and_limit():
    s = vd.Scene("stop")
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_spring("k", ("world", (-1, 0, 0)), ("cart", (0, 0, 0)), stiffness=10.0, free_length=2.0)  # rests at +1
    s.set_limits("cart", -0.5, 0.5)
    system = s.build()
    assert system.limits == {"cart": (-0.5, 0.5)}
    with pytest.raises(vd.ConvergenceError, match=r"'cart' is at its upper limit 0.5 m"):
        system.equilibrium()
    with pytest.raises(vd.ModelError, match=r"'cart' = 0.7 m is beyond its upper limit 0.5 m"):
        system.held(system.configuration({"cart": 0.7}))
    s.set_limits("cart", -0.5, 1.5)  # room for it: the search ends at +1 m
    eq = s.build().equilibrium()
    assert abs(eq.coordinate("cart") - 1.0) <= eq.q_error[0] + 1e-12


def test_panda_equilibrium_search_refuses_to_leave_the_limits():
    system = vd.load_robot("panda").build()
    with pytest.raises((vd.ConvergenceError, vd.ModelError), match=r"'panda_\w+'.* (lower|upper) limit"):
        system.equilibrium(system.operating_point().q)


@pytest.mark.parametrize("seed", [0, 1])
def test_held_drive_torques_are_the_gravity_torques_of_rnea(seed):
    system = vd.load_robot("ur5").build()
    lower, upper = system.limit_bounds()
    q = system.configuration(np.random.default_rng(seed).uniform(np.maximum(lower, -3), np.minimum(upper, 3)))
    held = system.held(q)
    model = system.scene.robot_source.pin_model()
    data = model.createData()
    qp = robots.to_pin(system, q)
    g = pin.computeGeneralizedGravity(model, data, qp)
    drive = np.array([held.drive[c] for c in system.coordinates])
    assert np.abs(drive - robots.from_pin(system, g)).max() <= held.tol
    # linearised with a = 0 and constant drives: K = ∂(g − Q)/∂q (Q: dampers only, zero at v = 0)
    lin = held.linearize()
    dg = pin.computeGeneralizedGravityDerivatives(model, data, qp)
    # K_error is an estimate (the difference of two steps), good to its order of magnitude: allow 10 × it
    assert np.all(np.abs(lin.K - dg) <= 10 * lin.K_error + 16 * np.finfo(float).eps * np.abs(dg).max())
    assert np.abs(dg).max() > 1.0  # gravity stiffness there is not trivially zero
    assert held.stability in ("stable", "unstable", "neutral")


def test_held_with_a_speed_reports_the_drives_and_the_speeds():
    system = vd.load_scene(MODELS / "rotor_slider.toml").build()
    v = np.array([2.0, 0.0])
    held = system.held(v=v)
    r = system.inverse_dynamics(held.q, v, np.zeros(2))  # what must be added to move without acceleration
    assert held.speeds == {"rotor": 2.0}
    assert np.abs(np.array(list(held.drive.values())) - r).max() <= held.tol


def test_limits_and_held_round_trip_through_scene_files(tmp_path):
    scene = vd.load_robot("ur5")
    scene.save(tmp_path / "ur5.toml")
    again = vd.load_scene(tmp_path / "ur5.toml")
    assert again.limits == scene.limits and again.operating_point == scene.operating_point
    bad = tmp_path / "bad.toml"
    bad.write_text('[[body]]\nname = "a"\nmass = 1.0\njoint = { type = "ball" }\n[limits]\na = [0, 1]\n')
    with pytest.raises(vd.SceneFileError, match=r"limits\.a.*one-coordinate joints"):
        vd.load_scene(bad)


# ------------------------------------------------------------------ point 6: readable output
NOISE = re.compile(r"(?<![\w.])[+-]0(?![.\d])|-0\.0*(?!\d*[1-9])|\de-1\d (rad|m)\b")


def _table_rows(out, header):
    lines = out.splitlines()
    i = next(k for k, line in enumerate(lines) if line.strip().startswith(header))
    rows = []
    for line in lines[i + 1:]:
        if not line.startswith("  ") or not line.strip() or line.strip().startswith("note"):
            break
        rows.append(line.split())
    return rows


def test_modes_table_is_in_ascending_order_of_omega2(capsys):
    code, out, _ = run(capsys, "modes", "robot:panda")
    assert code == 0
    rows = _table_rows(out, "mode     ω²") if "mode     ω²" in out else _table_rows(out, "mode  ")
    w2 = [float(r[1]) for r in rows]
    assert w2 == sorted(w2) and w2[0] < 0  # unstable directions first
    assert all(r[2] == "-" for r in rows if float(r[1]) < 0)  # no growth rate in the frequency column


def test_modes_prints_shapes_normalised_to_one(capsys):
    code, out, _ = run(capsys, "modes", "two_mass_modal")
    assert code == 0 and "mode shapes" in out
    rows = _table_rows(out, "coordinate  unit")
    S = np.array([[float(x) for x in r[2:]] for r in rows])
    assert [r[:2] for r in rows] == [["m1", "m"], ["m2", "m"]]
    assert np.allclose(np.abs(S).max(axis=0), 1.0)
    m = vd.load_scene(MODELS / "two_mass_modal.toml").build().operating_point().linearize().modes()
    ref = m.shapes / np.abs(m.shapes).max(axis=0)
    assert np.abs(S - ref).max() <= 5e-4 * 1.0001  # printed with 4 significant digits


def test_damped_table_explains_its_length(capsys):
    code, out, _ = run(capsys, "modes", "rotor_slider")
    assert code == 0
    assert "4 eigenvalues for 2 coordinates" in out and "1 pair" in out
    assert "1 zero (rigid or cyclic), 1 decaying (overdamped)" in out and "hence 3 rows against 2" in out


@pytest.mark.parametrize("model", ["chain5_fixed_free", "robot:ur5", "rotor_slider", "iftomm_a01"])
def test_no_signed_zeros_or_round_off_noise(capsys, model):
    code, out, _ = run(capsys, "modes", model)
    assert code == 0
    assert not NOISE.search(out), NOISE.search(out)


def test_info_shows_joint_mass_centre_of_mass_inertia_and_elements(capsys):
    code, out, _ = run(capsys, "info", "iftomm_a01")
    assert code == 0
    assert "joint    pivot, axis (0, 0, 1), at (0, 0, 0) m; coordinates pendulum (rad)" in out
    assert "mass     1 kg, centre of mass (1, 0, 0) m" in out and "inertia  diag(0, 0, 0) kg·m²" in out
    code, out, _ = run(capsys, "info", "trailer")
    assert "wall_spring" in out and "k = 100 N/m" in out and "free length 1 m" in out
    code, out, _ = run(capsys, "info", "robot:panda")
    assert "limits 0 … 0.04" in out and not NOISE.search(out)


def test_simulate_names_the_coordinates_of_its_final_state(capsys):
    code, out, _ = run(capsys, "simulate", "double_pendulum", "--t-end", "0.2", "--offset", "0.1", "0",
                       "--no-progress")
    assert code == 0
    rows = _table_rows(out, "coordinate")
    assert [r[0] for r in rows] == ["mass1", "mass2"] and rows[0][2] == "rad"


def test_number_formatting():
    assert number(0.0) == "0" and number(-0.0, "m") == "0 m"
    assert number(3e-10, "rad", error=1e-9) == "0 rad" and number(-3e-10, "rad") == "-3e-10 rad"
    assert number(1.234567891, digits=4) == "1.235" and number(-2.5, "N") == "-2.5 N"
    assert number(1e-320, digits=3) != "-0"


def test_zero_eigenvalues_of_a_held_floating_robot_have_a_bounded_error():
    # the floating base's rigid modes are Jordan blocks in the state form (left ⟂ right eigenvectors):
    # first-order perturbation gave errors of 1e292; their error is the split that still counts as zero
    m = vd.load_robot("solo12").build().operating_point().linearize().modes()
    zero = np.abs(m.damped_eigenvalues) <= m.zero_threshold
    assert zero.sum() >= 4 and np.all(np.isfinite(m.eigenvalue_error))
    assert np.all(m.eigenvalue_relative_error[zero] <= m.zero_threshold / np.abs(m.damped_eigenvalues).max())
    assert np.all(m.eigenvalue_error[zero] <= m.zero_threshold * (1 + 1e-12))  # 1/s
    assert m.relative_error < 1.0


@pytest.mark.parametrize("tol", [1e-4, 1e-8, 1e-10])
def test_modes_at_a_loosely_solved_equilibrium_are_within_their_error(tol):
    """A bar on a pivot, a torsion spring against gravity: V = ½kθ² − mg(l/2) sin θ, ω² = V″/I at V′ = 0 (brentq).
    Solved to tol = 1e-4 the search stopped at a residual of 1.8e-7 and the modes were 7.5e-9 off with a stated
    1.3e-9: the linear model cannot see K′ δq, so the search now goes on to round-off past its tol."""
    from scipy.optimize import brentq

    m, l, k, g = 1.0, 1.0, 20.0, 9.81
    s = vd.Scene("bar", gravity=(0, 0, -g))
    s.add_body("rod", joint=vd.Pivot(axis=(0, 1, 0)), mass=m, com=(l / 2, 0, 0),
               inertia=vd.inertia.rod(m, l, axis=(1, 0, 0)))
    s.add_joint_spring("rod", stiffness=k, rest=0.0)
    theta = brentq(lambda x: k * x - m * g * l / 2 * np.cos(x), 0.0, 1.0, xtol=1e-15)
    omega = np.sqrt((k + m * g * l / 2 * np.sin(theta)) / (m * l**2 / 3))
    eq = s.build().equilibrium(tol=tol)
    assert abs(eq.q[0] - theta) <= eq.q_error[0] + 4e-16
    for method in ("fd", "analytic"):
        modes = eq.linearize(method=method).modes()
        assert abs(modes.omega[0] - omega) <= modes.omega_relative_error[0] * omega + 4e-16 * omega, method


def test_a_bundled_steady_motion_is_polished_to_round_off():
    """iftomm_a05's declared steady motion stopped at a residual of 7.7e-9 (tol × a force scale of 6e5): its modes
    were 3e-10 and 7.7e-10 rad/s from those at a search to round-off, stated 1.2e-12 and 4.8e-12."""
    system = vd.load_scene("iftomm_a05").build()
    modes = system.operating_point().linearize(method="analytic").modes()
    tight = system.operating_point(tol=1e-16, max_iter=200).linearize(method="analytic").modes()
    err = modes.omega_relative_error * modes.omega + tight.omega_relative_error * tight.omega
    assert np.all(np.abs(modes.omega - tight.omega) <= err + 1e-15 * modes.omega)
