"""Reference cases R1, R2, R3, R5, R6 solved from their 3-D scenes in models/ through vibdyn's own
pipeline (operating point → linearisation → modes), to ≤ 1e-6 relative (values: ../shared/reference-cases.md,
recomputed exactly in each file's [reference]).

Tolerances: a result's own error estimate (modes.relative_error/residual, lin.K_error, traj.error, ...) wherever the
comparison is one the estimate covers; fixed 1e-15..1e-12 ones are identities that hold to round-off (a
few ε × the size of the terms: ΦᵀMΦ = 1 from eigh, a unit quaternion, a closed form in a few flops).
"""

import json

import numpy as np
import pytest
from conftest import MODELS

import vibdyn as vd
from vibdyn.faces.cli import main

RTOL = 1e-6


def solve(name, method="fd"):
    scene = vd.load_scene(MODELS / f"{name}.toml")
    system = scene.build()
    op = system.operating_point()
    return scene.references, system, op, op.linearize(method=method).modes()


def masses(system):
    return [b for b in system.bodies]


@pytest.mark.parametrize("name", ["chain5_fixed_fixed", "chain5_fixed_free", "rao_three_mass_ground",
                                  "rao_three_mass_series"])
@pytest.mark.parametrize("method", ["fd", "analytic"])
def test_chains_R1_R2_frequencies_and_absolute_shapes(name, method):
    ref, system, op, modes = solve(name, method)
    np.testing.assert_allclose(modes.omega, ref["omega"], rtol=RTOL)
    X = modes.point_shapes(masses(system), direction=(1, 0, 0))  # absolute displacements of the masses
    for r, shape in enumerate(ref["shapes"]):
        assert vd.mac(X[:, r], np.array(shape)) == pytest.approx(1.0, abs=1e-10)
        i = int(np.argmax(np.abs(shape)))
        np.testing.assert_allclose(X[:, r] / X[i, r] * shape[i], shape, rtol=RTOL, atol=RTOL)
    assert op.stability == "stable" and modes.relative_error < 1e-8


def test_R2_built_both_ways_agrees():
    a = solve("rao_three_mass_ground")[3]
    b = solve("rao_three_mass_series")[3]
    np.testing.assert_allclose(a.omega, b.omega, rtol=a.relative_error + b.relative_error)


def test_R1_prestressed_equilibrium_moves_and_matches():
    ref, system, op, modes = solve("chain3_prestressed")
    assert op.iterations > 0  # the scene starts away from equilibrium
    offsets = system.difference(system.neutral(), op.q)
    np.testing.assert_allclose(offsets, ref["equilibrium_q"], rtol=RTOL, atol=1e-12)
    centres = [system.point_position(b, (0, 0, 0), op.q)[0] for b in system.bodies]
    np.testing.assert_allclose(centres, ref["equilibrium"], rtol=RTOL)
    np.testing.assert_allclose(modes.omega, ref["omega"], rtol=RTOL)


@pytest.mark.parametrize("name", ["double_pendulum", "triple_pendulum", "rod_pivot", "rod_ball",
                                  "inverted_bar_stable"])
def test_R3_pendulums(name):
    ref, system, op, modes = solve(name)
    np.testing.assert_allclose(modes.omega, ref["omega"], rtol=RTOL, atol=1e-9)
    if name == "rod_ball":
        assert modes.rigid[0] and modes.omega[0] == 0.0  # spin about the rod axis
        assert op.stability == "neutral"
    else:
        assert op.stability == "stable"


def test_R3_inverted_bar_unstable_and_its_tilted_equilibria():
    ref, system, op, modes = solve("inverted_bar_unstable")
    assert op.stability == "unstable" and modes.unstable[0]
    np.testing.assert_allclose(modes.omega2, ref["omega_squared"], rtol=RTOL)
    theta = ref["tilted_equilibrium"]
    found = system.equilibria([system.integrate(system.neutral(), [x]) for x in (-2.5, 2.5)])
    for eq in found:
        assert abs(eq.coordinate("bar")) == pytest.approx(theta, rel=RTOL)
        assert eq.stability == "stable"
        np.testing.assert_allclose(eq.modes.omega, ref["tilted_omega"], rtol=RTOL)


def test_R5_frequencies_and_damping_ratios():
    ref, system, op, modes = solve("receptance_damped")
    lin = modes.linear
    np.testing.assert_allclose(lin.M, ref["mass_matrix"], rtol=RTOL, atol=1e-12)
    np.testing.assert_allclose(lin.K, ref["stiffness_matrix"], rtol=RTOL, atol=1e-8)
    np.testing.assert_allclose(lin.C, ref["damping_matrix"], rtol=RTOL, atol=1e-8)
    np.testing.assert_allclose(modes.omega, ref["omega"], rtol=RTOL)
    np.testing.assert_allclose(modes.zeta, ref["zeta"], rtol=RTOL)
    assert modes.classical


def test_R6_steady_motion_matrices_and_state_eigenvalues():
    ref, system, op, modes = solve("rotor_slider")
    assert op.regime == "steady" and op.stability == "stable"
    assert op.speeds["rotor"] == pytest.approx(ref["omega_star"], rel=1e-9)
    assert op.coordinate("slider") == pytest.approx(ref["s_rel_star"], rel=RTOL)
    lin = modes.linear
    np.testing.assert_allclose(lin.M, ref["mass_matrix"], rtol=RTOL)
    np.testing.assert_allclose(lin.C, ref["damping_matrix"], rtol=RTOL)
    np.testing.assert_allclose(lin.K, ref["stiffness_matrix"], rtol=RTOL, atol=1e-7)
    expected = np.array([complex(*z) for z in ref["eigenvalues"]])
    np.testing.assert_allclose(np.sort_complex(modes.eigenvalues), np.sort_complex(expected), rtol=RTOL,
                               atol=1e-7)


def test_cli_modes_json(capsys):
    assert main(["modes", str(MODELS / "double_pendulum.toml"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    ref = vd.load_scene(MODELS / "double_pendulum.toml").references
    np.testing.assert_allclose(d["modes"]["omega_rad_s"], ref["omega"], rtol=RTOL)
    np.testing.assert_allclose(d["modes"]["frequency_hz"], np.array(ref["omega"]) / (2 * np.pi), rtol=RTOL)
    assert d["operating_point"]["stability"] == "stable"
    assert 0 < d["linearization"]["relative_error"] < 1e-6
    assert main(["modes", str(MODELS / "rotor_slider.toml")]) == 0
    out = capsys.readouterr().out
    assert "steady equilibrium: stable" in out and "3.16227766" in out


def test_cli_reports_model_errors(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[[body]]\nname = "b"\nmass = -1.0\n')
    assert main(["modes", str(bad)]) == 2
    assert "bad.toml" in capsys.readouterr().err


@pytest.mark.parametrize("path", sorted(MODELS.glob("*.toml")), ids=lambda p: p.stem)
def test_cli_info_on_every_model(path, capsys):
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    scene = vd.load_scene(path)
    assert f"scene      {scene.name}" in out
    assert all(name in out for name in scene.bodies) and all(name in out for name in scene.elements)


def test_cli_info_on_a_robot(capsys):
    assert main(["info", "robot:ur5"]) == 0
    assert "shoulder_pan_joint" in capsys.readouterr().out
