"""Mechanisms as people describe them (issue 21): loops open at the neutral configuration, springs through a
point, singular points refused where they are met, loops about steady motions (checked against a hand
reduction written here), energy balances of the states integrated."""

import dataclasses
import io
import math
import re
import warnings

import numpy as np
import pytest
from conftest import MODELS, ROOT
from oracles import a05_mjcf_run, bricard_cut_at_c
from scipy.optimize import brentq

import vibdyn as vd
from vibdyn.description.elements import JointSpring

G = 9.81
LOOPED = sorted(p.stem for p in MODELS.glob("*.toml") if "[[loop]]" in p.read_text())


def points(system, q):
    """World origins and centres of mass of every body at q (m), one row each."""
    rows = []
    for name, body in system.scene.bodies.items():
        rows += [system.point_position(name, (0, 0, 0), q), system.point_position(name, body.com, q)]
    return np.array(rows)


# ------------------------------------------------------------------ described with every joint angle zero

def test_four_bar_and_trammel_described_at_zero_angles_equal_their_previous_descriptions():
    """The bundled four-bar and trammel now have every joint angle zero at neutral (loop open there; the
    trammel's coordinate is the textbook's γ and its spring starts at the origin O): their equilibria,
    frequencies and motions equal those of the previous descriptions (joints rotated so that neutral was
    closed; kept in tests/data) to 1e-9."""
    for name, old in (("four_bar", "four_bar_rotated"), ("trammel", "trammel_shifted")):
        new_sys = vd.load_scene(MODELS / f"{name}.toml").build()
        old_sys = vd.load_scene(ROOT / "tests" / "data" / f"{old}.toml").build()
        assert np.abs(new_sys.constraint_residual(new_sys.neutral())).max() > 1e-2  # open at neutral
        assert np.abs(old_sys.constraint_residual(old_sys.neutral())).max() < 1e-12
        assert new_sys.dof == old_sys.dof == 1
        assert new_sys.constraints.closed[1].startswith("the declared start")
        eq_new, eq_old = new_sys.operating_point(), old_sys.operating_point()
        scale = new_sys.length_scale
        assert np.abs(points(new_sys, eq_new.q) - points(old_sys, eq_old.q)).max() <= 1e-9 * scale
        w_new, w_old = eq_new.linearize().modes().omega, eq_old.linearize().modes().omega
        assert w_new == pytest.approx(w_old, rel=1e-9)
        # the same motion: released from the same pose (the old neutral: each old joint's placement as a
        # coordinate of the new description), 0.5 s
        q_old = old_sys.neutral()
        q_new = np.array([placement_coordinate(b.joint) for b in old_sys.scene.bodies.values()])
        assert np.abs(points(new_sys, q_new) - points(old_sys, q_old)).max() <= 1e-10 * scale
        t = np.linspace(0.0, 0.5, 11)
        tr_new = new_sys.simulate(0.5, q_new, rtol=1e-11, t_eval=t)
        tr_old = old_sys.simulate(0.5, q_old, rtol=1e-11, t_eval=t)
        gap = max(np.abs(points(new_sys, a) - points(old_sys, b)).max() for a, b in zip(tr_new.q, tr_old.q))
        assert gap <= 1e-9 * scale + 10 * (tr_new.error + tr_old.error) * scale


def placement_coordinate(joint):
    """What the old description put in a joint's placement, as that joint's coordinate in the new one: a
    pivot's rotation angle about z, a slider's offset along its axis (both from the origin)."""
    if isinstance(joint, vd.Pivot):
        R = np.array(joint.rotation) if joint.rotation is not None else np.eye(3)
        return math.atan2(R[1, 0], R[0, 0])
    return float(np.dot(joint.at, joint.axis))


def opened(scene, delta=0.3):
    """The scene with its first pivot's placement turned by ``delta`` about its axis (so that the neutral
    configuration no longer closes the loops) and its start moved to the same poses."""
    name, body = next((n, b) for n, b in scene.bodies.items() if isinstance(b.joint, vd.Pivot))
    axis = np.array(body.joint.axis)
    R = np.eye(3) if body.joint.rotation is None else np.array(body.joint.rotation)
    c, s = math.cos(delta), math.sin(delta)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    turn = np.eye(3) + s * K + (1 - c) * K @ K
    scene.bodies[name] = dataclasses.replace(body, joint=dataclasses.replace(body.joint, rotation=R @ turn))
    for key, e in list(scene.elements.items()):  # a torsion spring's rest is an angle of that joint too
        if isinstance(e, JointSpring) and e.body == name:
            scene.elements[key] = dataclasses.replace(e, rest=tuple(r - delta for r in e.rest))
    op = dict(scene.operating_point or {})
    start = op.get("start") or {}
    if not isinstance(start, dict):
        start = dict(zip([c for b in scene.bodies.values() for c in b.coordinates], start))
    start = {**start, body.coordinates[0]: start.get(body.coordinates[0], 0.0) - delta}
    scene.set_operating_point(op.get("cyclic"), start, op.get("held", False))
    return scene


@pytest.mark.parametrize("name", LOOPED)
def test_each_bundled_looped_model_builds_with_its_neutral_pose_open(name):
    original = vd.load_scene(MODELS / f"{name}.toml").build()
    system = opened(vd.load_scene(MODELS / f"{name}.toml")).build()
    assert np.abs(system.constraint_residual(system.neutral())).max() > 1e-3 * system.length_scale
    assert system.dof == original.dof
    assert "the declared start" in system.constraints.closed[1]
    qa, qb = original.assemble(), system.assemble()
    assert np.abs(points(original, qa) - points(system, qb)).max() <= 1e-9 * original.length_scale
    try:
        omega = original.operating_point().linearize().modes().omega
    except vd.ConvergenceError:  # (no equilibrium: Andrews' squeezer is driven by a constant torque)
        with pytest.raises(vd.ConvergenceError):
            system.operating_point()
    else:
        assert system.operating_point().linearize().modes().omega == pytest.approx(omega, rel=1e-9)


def test_loop_errors_of_scene_files_name_the_start_they_were_assembled_from(tmp_path):
    """A coupler too short to close the four-bar anywhere: the scene builds (nothing at build assumes a
    closed neutral configuration), and every command that needs a closed configuration says which start it
    assembled from, which loop stays open and by how much."""
    from vibdyn.faces.cli import main

    text = (MODELS / "four_bar.toml").read_text().replace("a = [\"coupler\", [0.3, 0.0, 0.0]]",
                                                          "a = [\"coupler\", [0.8, 0.0, 0.0]]")
    path = tmp_path / "short.toml"
    path.write_text(text)
    scene = vd.load_scene(path)
    system = scene.build()
    with pytest.raises(vd.ConvergenceError, match=r"assembly from the declared start \(crank = 1, coupler = "
                                                  r"-0.4144, rocker = 1.5546\).*loop 'pin' stays open by"):
        system.dof
    for command in (["modes", str(path)], ["info", str(path)], ["simulate", str(path), "--t-end", "0.1"]):
        err = io.StringIO()
        with redirect(err):
            code = main(command)
        assert code == 2
        assert "the declared start (crank = 1" in err.getvalue() and "loop 'pin' stays open" in err.getvalue()
    scene.operating_point = None
    with pytest.raises(vd.ConvergenceError, match="assembly from the neutral configuration.*loop 'pin'"):
        scene.build().equilibrium()


class redirect:
    """stderr into a StringIO for the duration."""

    def __init__(self, buf):
        self.buf = buf

    def __enter__(self):
        import contextlib

        self.cm = contextlib.redirect_stderr(self.buf)
        return self.cm.__enter__()

    def __exit__(self, *exc):
        return self.cm.__exit__(*exc)


def test_trammel_spring_through_the_origin_is_refused_only_where_its_ends_meet():
    system = vd.load_scene(MODELS / "trammel.toml").build()
    with pytest.raises(vd.ModelError, match=r"spring 'k' reached zero length at the configuration q = \[0.0, 0.0, "
                                            r"0.0\].*start the analysis or the motion away from it"):
        system.generalized_forces(system.neutral(), np.zeros(3))
    eq = system.operating_point()
    # the textbook's balance [(M+2m) g l sin γ = 2k (2l sin γ − l0) l cos γ] with the file's k (rounded to 1e-6
    # N/m, so γ = π/4 + 2.8e-10 rad, more than the search's error)
    M, m_ab, l, g, k, l0 = 2.0, 0.5, 0.5, 9.81, 137.386259, 0.6
    hand = brentq(lambda c: (M + 2 * m_ab) * g * l * math.sin(c) - 2 * k * (2 * l * math.sin(c) - l0) * l * math.cos(c),
                  0.6, 1.0, xtol=1e-16)
    assert abs(hand - math.pi / 4) < 1e-9
    assert eq.coordinate("disk") == pytest.approx(hand, abs=10 * eq.q_error[system.coordinate_index("disk")] + 1e-15)


def test_a_mass_matrix_singular_at_neutral_only_is_refused_where_it_is_met():
    """A massless arm carrying a bead on a radial slider: M = diag(m s², m) is singular at s = 0 only (a
    singular point of the motion, not a fault of the description)."""
    s = vd.Scene("bead")
    s.add_body("arm", joint=vd.Pivot((0, 0, 1)), mass=0.0)
    s.add_body("bead", parent="arm", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_joint_spring("bead", 10.0, rest=0.5)
    system = s.build()
    with pytest.raises(vd.ModelError, match="singular mass matrix at the operating point: body 'arm'"):
        system.linearize(system.neutral())
    m = system.linearize(system.configuration([0.0, 0.5])).modes()
    assert np.all(np.abs(m.omega - [0.0, math.sqrt(10.0)]) <= 10 * m.omega_error + 1e-15)
    s = vd.Scene("dead")  # a body with no inertia along its coordinate anywhere is still refused at build
    s.add_body("arm", joint=vd.Pivot((0, 0, 1)), mass=1.0)
    with pytest.raises(vd.ModelError, match="singular mass matrix at the neutral configuration: body 'arm'"):
        s.build()


# ------------------------------------------------------------------ assembly

def flat_four_bar(eps=1e-3):
    """The bundled four-bar with every link laid along x turned by ``eps`` (rad): nearly flat, open."""
    scene = vd.load_scene(MODELS / "four_bar.toml")
    scene.operating_point = None
    for name, b in list(scene.bodies.items()):
        scene.bodies[name] = dataclasses.replace(b, joint=dataclasses.replace(b.joint, rotation=(0, 0, eps)))
    return scene


def test_a_nearly_flat_four_bar_assembles_near_its_description_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning escapes
        system = flat_four_bar().build()
        q = system.assemble()
        assert np.abs(system.constraint_residual(q)).max() <= 1e-12 * system.length_scale
        assert np.abs(q).max() <= math.pi  # angles within π of the start: no 29, 33, 86 rad jumps
        eq = system.equilibrium()
        assert eq.stability == "stable" and np.abs(eq.q).max() <= 2 * math.pi


def test_a_second_loop_that_locks_a_closed_four_bar_is_named():
    scene = vd.load_scene(MODELS / "four_bar.toml")
    scene.add_loop("lock", ("crank", (0.1, 0, 0)), ("world", (0.1 * math.cos(1), 0.1 * math.sin(1), 0.0)),
                   joint=vd.Ball())
    with pytest.raises(vd.ModelError, match="loop 'lock' locks the mechanism"):
        scene.build()


# ------------------------------------------------------------------ energy of the states integrated

def test_energy_balance_of_a_start_off_the_loops_counts_the_projected_start():
    """`vibdyn simulate four_bar --offset 0.3 0 0` reported a 48 % imbalance that was not in the motion:
    the balance now starts from the state actually integrated (assembled, velocity projected)."""
    system = vd.load_scene(MODELS / "four_bar.toml").build()
    q0 = system.integrate(system.start_configuration()[0], [0.3, 0.0, 0.0])
    v0 = np.array([1.0, 0.0, 0.0])  # also off the loops
    assert np.abs(system.constraint_residual(q0)).max() > 1e-3
    traj = system.simulate(2.0, q0, v0, rtol=1e-10)
    assert np.abs(system.constraint_residual(traj.q[0])).max() <= 1e-12
    e0 = system.energy(traj.q[0], traj.v[0])
    assert traj.energy0.total == pytest.approx(e0.total, rel=1e-12)
    assert abs(traj.drift) <= 1e-6 * traj.energy_scale
    from vibdyn.faces.cli import main

    out = io.StringIO()
    import contextlib

    with contextlib.redirect_stdout(out):
        main(["simulate", str(MODELS / "four_bar.toml"), "--t-end", "2", "--offset", "0.3", "0", "0",
              "--no-progress"])
    balance = float(out.getvalue().split("balance ")[1].split(" J")[0])
    assert abs(balance) <= 1e-6 * traj.energy_scale


# ------------------------------------------------------------------ loops about steady motions

L, L0, MD, MA, R, JR = 0.5, 0.6, 2.0, 0.5, 0.1, 0.3


def spun_trammel(k):
    """Vénizélos's trammel on a turntable: the rotor turns about the vertical y; on it the trammel in its x–y
    plane (A slides along the rotor's x, B along y, the spring from the rotor's centre O to A)."""
    s = vd.Scene("spun_trammel", gravity=(0, -G, 0))
    s.add_body("rotor", joint=vd.Pivot((0, 1, 0)), mass=1.0, inertia=np.diag([0.2, JR, 0.2]))
    s.add_body("A", parent="rotor", joint=vd.Slider((1, 0, 0)), mass=MA)
    s.add_body("disk", parent="A", joint=vd.Pivot((0, 0, 1)), mass=MD, com=(0, L, 0),
               inertia=np.diag([MD * R**2 / 4, MD * R**2 / 4, MD * R**2 / 2]))
    s.add_body("B", parent="rotor", joint=vd.Slider((0, 1, 0)), mass=MA)
    s.add_spring("k", ("rotor", (0, 0, 0)), ("A", (0, 0, 0)), k, free_length=L0)
    s.add_loop("groove_B", ("disk", (0, 2 * L, 0)), ("B", (0, 0, 0)), joint=vd.Ball())
    return s


def hand_reduction(gamma, spin):
    """The trammel on the turntable by hand, coordinates (ψ, γ): T = ½ I_y(γ) ψ̇² + ½ m_γ γ̇², I_y = J_r +
    MR²/4 + (M + 4m) ℓ² sin²γ, m_γ = MR²/2 + (M + 4m) ℓ²; V = (M + 2m) g ℓ cos γ + ½ k (2ℓ sin γ − l0)².
    Steady at (γ, Ω) when V'(γ) = ½ I_y'(γ) Ω² (this fixes k). Linearised: M = diag(I_y, m_γ),
    C = [[0, I_y' Ω], [−I_y' Ω, 0]], K = diag(0, V'' − ½ I_y'' Ω²); ω_n² = (K_γ + (I_y' Ω)²/I_y) / m_γ."""
    s, c = math.sin(gamma), math.cos(gamma)
    Iy = JR + MD * R**2 / 4 + (4 * MA + MD) * L**2 * s**2
    dIy, ddIy = (4 * MA + MD) * L**2 * math.sin(2 * gamma), 2 * (4 * MA + MD) * L**2 * math.cos(2 * gamma)
    mg = MD * R**2 / 2 + (MD + 4 * MA) * L**2
    k = (0.5 * dIy * spin**2 + (MD + 2 * MA) * G * L * s) / ((2 * L * s - L0) * 2 * L * c)
    Vpp = -(MD + 2 * MA) * G * L * c + 4 * k * L**2 * c**2 - 2 * k * L * (2 * L * s - L0) * s
    Kg = Vpp - 0.5 * ddIy * spin**2
    M = np.diag([Iy, mg])
    C = np.array([[0.0, dIy * spin], [-dIy * spin, 0.0]])
    K = np.diag([0.0, Kg])
    return k, M, C, K, math.sqrt((Kg + (dIy * spin) ** 2 / Iy) / mg)


def test_steady_spin_linearisation_of_a_looped_rotor_equals_its_hand_reduction():
    gamma, spin = 0.7, 3.0
    k, M, C, K, omega_n = hand_reduction(gamma, spin)
    system = spun_trammel(k).build()
    q0 = system.configuration({"A": 2 * L * math.sin(gamma), "disk": gamma, "B": 2 * L * math.cos(gamma)})
    v0 = np.array([spin, 0.0, 0.0, 0.0])
    lin = system.linearize(q0, v=v0)
    # the reduced model in the tree's independent coordinates, mapped to (ψ, γ) by v = N_hand (ψ̇, γ̇)
    N_hand = np.array([[1, 0], [0, 2 * L * math.cos(gamma)], [0, 1], [0, -2 * L * math.sin(gamma)]])
    T = N_hand[list(lin.independent)]
    scale = np.abs(K).max()
    for mine, hand, err in ((lin.M, M, np.zeros((2, 2))), (lin.C, C, lin.C_error), (lin.K, K, lin.K_error)):
        bound = np.abs(T).T @ err @ np.abs(T) + 1e-7 * max(np.abs(hand).max(), 1.0)
        assert np.all(np.abs(T.T @ mine @ T - hand) <= bound + 1e-7 * scale * (hand is K))
    m = lin.modes()
    oscillating = m.omega_n[np.abs(m.damped_eigenvalues.imag) > 1.0]
    assert oscillating == pytest.approx([omega_n], rel=1e-7)
    # the steady motion found from another start, and its drive (none needed: nothing resists the spin)
    st = system.steady_motion({"rotor": spin}, q0=system.configuration({"A": 0.56, "disk": 0.6, "B": 0.83}))
    assert st.regime == "steady" and st.speeds == {"rotor": spin}
    assert np.abs(points(system, st.q) - points(system, q0)).max() <= 1e-8 * system.length_scale
    assert abs(st.drive["rotor"]) <= 1e-8 * np.abs(K).max()
    assert st.linearize().modes().omega == pytest.approx(m.omega, rel=1e-7)


def test_campbell_diagram_of_a_looped_rotor_follows_the_hand_reduction():
    """At each spin the steady γ moves (the spring is set for γ = 0.7 at 3 rad/s); ω_n from the hand
    reduction at the steady γ found by a scalar root search of V'(γ) = ½ I_y'(γ) Ω² written here."""

    k = hand_reduction(0.7, 3.0)[0]
    system = spun_trammel(k).build()
    q0 = system.configuration({"A": 2 * L * math.sin(0.7), "disk": 0.7, "B": 2 * L * math.cos(0.7)})
    speeds = [0.0, 1.5, 3.0, 4.0]
    cd = vd.campbell(system, "rotor", speeds, q0=q0, held=False)
    held = vd.campbell(system, "rotor", speeds, q0=q0)  # the loops' reduction composed with the held spin
    for i, spin in enumerate(speeds):
        def steady(g, spin=spin):
            s, c = math.sin(g), math.cos(g)
            return (-(MD + 2 * MA) * G * L * s + 2 * k * L * c * (2 * L * s - L0)
                    - 0.5 * (4 * MA + MD) * L**2 * math.sin(2 * g) * spin**2)
        gamma = brentq(steady, 0.65, 0.9, xtol=1e-14)
        s, c = math.sin(gamma), math.cos(gamma)
        Iy = JR + MD * R**2 / 4 + (4 * MA + MD) * L**2 * s**2
        dIy, ddIy = (4 * MA + MD) * L**2 * math.sin(2 * gamma), 2 * (4 * MA + MD) * L**2 * math.cos(2 * gamma)
        mg = MD * R**2 / 2 + (MD + 4 * MA) * L**2
        Vpp = -(MD + 2 * MA) * G * L * c + 4 * k * L**2 * c**2 - 2 * k * L * (2 * L * s - L0) * s
        omega_n = math.sqrt((Vpp - 0.5 * ddIy * spin**2 + (dIy * spin) ** 2 / Iy) / mg)
        assert np.nanmax(cd.omega[i]) == pytest.approx(omega_n, rel=1e-6)
        # held at Ω by its drive, the spin's momentum no longer stiffens γ: the (I_y' Ω)² / I_y term goes
        omega_held = math.sqrt((Vpp - 0.5 * ddIy * spin**2) / mg)
        assert held.omega.shape[1] == 1
        assert held.omega[i, 0] == pytest.approx(omega_held, rel=1e-6)


def test_a_cyclic_coordinate_that_opens_the_loops_is_refused():
    system = vd.load_scene(MODELS / "four_bar.toml").build()
    with pytest.raises(vd.ModelError, match="opens the loops"):
        system.steady_motion({"crank": 1.0})
    with pytest.raises(vd.ModelError, match="must be given"):
        system.steady_motion({"crank": None})
    eq = system.operating_point()
    with pytest.raises(vd.ModelError, match="opens the loops"):
        system.linearize(eq.q, v=[1.0, 0.0, 0.0])


# ------------------------------------------------------------------ IFToMM A04: Bricard's mechanism

def test_iftomm_a04_bricard_mechanism_moves_with_one_degree_of_freedom_against_its_count():
    """Grübler's count 6·5 − 5·6 = 0 (five moving rods, six revolute joints), yet the mechanism moves: the
    rank of the loop's Jacobian is 4 of its 5 equations. 10 s from rest at the published configuration:
    energy conserved to 1e-6 (E = −29.43 J), the loop closed, and P3's trajectory equal to that of the same
    mechanism cut at C (another tree and loop) within the two runs' own error estimates."""
    scene = vd.load_scene(MODELS / "iftomm_a04.toml")
    ref = scene.references
    system = scene.build()
    links, joints = len(scene.bodies) + 1, len(scene.bodies) + len(scene.loops)
    assert 6 * (links - 1) - 5 * joints == ref["grubler"] == 0
    assert system.dof == ref["mobility"] == 1
    assert system.constraints.rank(system.neutral()) == 4
    assert system.energy(system.neutral(), np.zeros(5)).total == pytest.approx(ref["energy"], abs=1e-12)
    t = np.linspace(0.0, ref["t_end"], 51)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning escapes a successful run
        traj = system.simulate(ref["t_end"], rtol=1e-10, t_eval=t)
    assert traj.status == "finished"
    assert abs(traj.energy - ref["energy"]).max() <= 1e-6 * abs(ref["energy"])
    assert np.abs(traj.constraint_residual).max() <= 1e-9
    other = bricard_cut_at_c(vd.load_scene(MODELS / "iftomm_a04.toml")).build()
    assert other.dof == 1
    q0 = other.assemble(other.neutral())
    assert np.abs(other.point_position("rod2", (0, -1, 0), q0) - [1, -1, 0]).max() <= 1e-12
    check = other.simulate(ref["t_end"], q0, rtol=1e-10, t_eval=t)
    p3 = traj.point_positions("rod3", (0, 0, 0))
    p3_other = check.point_positions("rod2", (0, -1, 0))
    assert np.abs(p3[0] - [1, -1, 0]).max() <= 1e-15
    # the rods swing through (P3 travels about 1.8 m along x and back, period ~5 s)
    assert p3[:, 0].min() < -0.7
    # the estimates are of the tangent coordinates (rad); P3 is at most 2 m from A
    assert np.abs(p3 - p3_other).max() <= 2 * 10 * (traj.error + check.error) + 1e-12


# ------------------------------------------------------------------ large and deep scene files

def test_a_value_nested_too_deep_for_the_parser_names_its_key(tmp_path):
    """Nested past the TOML parser's own recursion (1000 levels), inside a body and in [reference] alike."""
    deep = "[" * 1000 + "]" * 1000
    body = ('[scene]\nname = "x"\n[[body]]\nname = "b"\nmass = 1.0\ncom = ' + deep
            + '\njoint = { type = "pivot", axis = [0.0, 0.0, 1.0] }\n')
    ref = ('[scene]\nname = "x"\n[[body]]\nname = "b"\nmass = 1.0\njoint = { type = "pivot", axis = [0.0, 0.0, 1.0] }'
           '\n[reference]\nv = ' + deep + '\n')
    for text, key, line in ((body, "body[0].com", 6), (ref, "reference.v", 8)):
        path = tmp_path / "deep.toml"
        path.write_text(text)
        with pytest.raises(vd.SceneFileError, match=rf"key '{re.escape(key)}': nested more than 64 levels deep "
                                                     rf"\(line {line}\)"):
            vd.load_scene(path)


def test_building_copies_the_scene_without_copying_its_immutable_bodies():
    """The build's own copy of the scene is linear in the number of bodies: its tables are new, their frozen
    entries shared (a deep copy of every body made a 20 000-body build superlinear; see benchmarks/speed.py
    for the timing). The copy stays independent of later edits."""
    scene = vd.load_scene(MODELS / "four_bar.toml")
    scene.references["list"] = [1, 2]
    system = scene.build()
    assert system.scene.bodies is not scene.bodies
    assert all(system.scene.bodies[n] is b for n, b in scene.bodies.items())
    scene.add_body("extra", joint=vd.Slider((1, 0, 0)), mass=1.0)
    scene.references["list"].append(3)
    assert "extra" not in system.scene.bodies and system.scene.references["list"] == [1, 2]


# ------------------------------------------------------------------ IFToMM A05: the stiff flyball governor

def a05_mujoco(t_out, q0, v0, dt):
    """MuJoCo's RK4 run of A05 (tests/oracles.py): s at the times ``t_out``."""
    mujoco = pytest.importorskip("mujoco")
    return a05_mjcf_run(mujoco, t_out, q0, v0, dt)[:, 1]


def a05_steady_by_hand(spin):
    """(s, β) of the steady spin at ``spin`` rad/s: the effective potential V = V_gravity + V_springs − ½ I_z(β) Ω²
    stationary, every term written here from the benchmark's definition (no vibdyn)."""
    from scipy.optimize import root

    g, k, l0, mr, mt = G, 8e5, 0.5, 0.3, 5.0

    def gradient(x):
        s, b = x
        a, c = 0.5 * math.cos(b), 1 - 0.5 * math.sin(b) - s
        L = math.hypot(a, c)
        dL_ds, dL_db = -c / L, (a * -0.5 * math.sin(b) + c * -0.5 * math.cos(b)) / L
        dIz = 2 * ((5e-6 - 0.0250025) * 2 * math.sin(b) * math.cos(b)
                   + mr * 2 * (0.05 + 0.5 * math.cos(b)) * (-0.5 * math.sin(b))
                   + mt * 2 * (0.05 + math.cos(b)) * (-math.sin(b)))
        return [3 * g + 2 * k * (L - l0) * dL_ds,
                -2 * g * math.cos(b) * (0.5 * mr + mt) + 2 * k * (L - l0) * dL_db - 0.5 * dIz * spin**2]

    sol = root(gradient, [0.69, 0.31], method="hybr", tol=1e-15)
    assert sol.success
    return sol.x


def test_iftomm_a05_flyball_governor_steady_spin_modes_and_transient():
    """A05, stiff (the spring-dampers' fastest mode decays at ~3e3 1/s over a 10 s run): the steady spin
    at 2π rad/s against the effective potential written here; its modes stable (the cyclic shaft's zero
    within the error, not an instability); the transient's s(t) against MuJoCo (tendons, RK4 at two steps:
    their difference is MuJoCo's error), with the shaft's angular momentum conserved and the energy balanced."""
    scene = vd.load_scene(MODELS / "iftomm_a05.toml")
    ref = scene.references
    system = scene.build()
    st = system.operating_point()
    s_hand, b_hand = a05_steady_by_hand(ref["spin0"])
    for name, hand in (("sleeve", s_hand), ("rod1", b_hand), ("rod2", b_hand)):  # within the search's own error
        assert st.coordinate(name) == pytest.approx(hand, abs=st.q_error[system.coordinate_index(name)])
    m = st.linearize().modes()
    assert m.stability in ("stable", "neutral")
    assert np.all(m.damped_eigenvalues.real <= m.eigenvalue_error + m.zero_threshold)
    # the transient from the benchmark's start, everything co-rotating
    q0 = system.configuration({"sleeve": ref["s0"], "rod1": ref["beta0"], "rod2": ref["beta0"]})
    v0 = np.array([ref["spin0"], 0.0, 0.0, 0.0])
    t = np.linspace(0.0, ref["t_end"], 11)
    traj = system.simulate(ref["t_end"], q0, v0, method="radau", rtol=1e-9, t_eval=t)
    s = np.array([system.difference(system.neutral(), q)[1] for q in traj.q])
    qm = [0.0, ref["s0"], ref["beta0"], ref["beta0"]]
    s1, s2 = a05_mujoco(t, qm, v0, 5e-5), a05_mujoco(t, qm, v0, 2.5e-5)
    mujoco_error = np.abs(s1 - s2) * 16 / 15  # RK4: the error of the finer run is 1/15 of the difference
    assert np.abs(s - s2).max() <= 10 * (traj.error * system.length_scale + mujoco_error.max()) + 1e-9
    assert np.ptp(s) > 0.05  # (the sleeve moves)
    momentum = [(system.mass_matrix(q) @ v)[0] for q, v in zip(traj.q, traj.v)]
    assert np.ptp(momentum) <= 10 * traj.error * abs(momentum[0]) + 1e-10
    assert abs(traj.drift) <= 1e-6 * traj.energy_scale
