"""Closed loops (issue 13): constraint equations and Jacobians, assembly and mobility, constrained equilibria
with their loop forces, linearisation in the independent motions, simulation with projection; checked
against closed forms (the trammel of Vénizélos Ex. 2.4.1) and one-coordinate reductions of planar
mechanisms written here from their position analysis (no vibdyn inside the oracles)."""

import math

import numpy as np
import pytest
from conftest import MODELS
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import vibdyn as vd
from vibdyn.model.fd import tangent_derivative

EPS = np.finfo(float).eps
G = 9.81


def load(name, joint=None):
    """A loop model of models/, its loop closed by ``joint`` instead of its own if given."""
    scene = vd.load_scene(MODELS / f"{name}.toml")
    if joint is not None:
        (loop,) = scene.loops.values()
        scene.loops.clear()
        scene.add_loop(loop.name, loop.a, loop.b, joint=joint)
    return scene


# ------------------------------------------------------------------ equations and Jacobians

def spatial(joint, b_end):
    """A free body with a ball-jointed body on it (nv = 9), closed by ``joint`` between the second body and
    ``b_end`` (the world or the first body)."""
    s = vd.Scene("spatial", gravity=(0, 0, -G))
    s.add_body("b1", joint=vd.Free(), mass=1.0, inertia=vd.inertia.box(1.0, (0.3, 0.2, 0.1)))
    s.add_body("b2", parent="b1", joint=vd.Ball(at=(0.4, 0, 0)), mass=0.5, com=(0.2, 0, 0),
               inertia=vd.inertia.box(0.5, (0.4, 0.1, 0.1)))
    s.add_loop("close", ("b2", (0.4, 0.1, 0.0)), b_end, joint=joint)
    return s.build()


KINDS = [vd.Ball(), vd.Pivot(axis=(0, 0.6, 0.8)), vd.Slider(axis=(1, 0, 0)), vd.Cylindrical(axis=(0, 1, 0)),
         vd.Universal(axis1=(1, 0, 0), axis2=(0, 0, 1)), vd.Fixed()]


@pytest.mark.parametrize("joint", KINDS, ids=lambda j: j.type)
@pytest.mark.parametrize("b_end", [("world", (0.8, 0.1, 0.0)), ("b1", (0.8, 0.1, 0.0))], ids=["world", "body"])
def test_constraint_jacobian_is_the_tangent_derivative_of_the_residual(joint, b_end):
    system = spatial(joint, b_end)
    m = {"ball": 3, "pivot": 5, "slider": 5, "cylindrical": 4, "universal": 4, "fixed": 6}[joint.type]
    q = system.random_configuration(0.3, rng=1)
    J = system.constraint_jacobian(q)
    assert J.shape == (m, 9)
    h = np.full(9, 1e-5)
    J1 = tangent_derivative(system, system.constraint_residual, q, h)
    J2 = tangent_derivative(system, system.constraint_residual, q, 2 * h)
    # central differences: truncation ≈ |J(h) − J(2h)| / 3, round-off ~ eps / h
    assert np.abs(J - J1).max() <= np.abs(J1 - J2).max() + 100 * EPS / 1e-5
    # assembled from there the loop closes. To the world: mobility nv − m (no redundancy). To b1, on which
    # b2 turns by a ball (3 relative motions): a ball loop leaves the spin about the line from the ball's
    # centre to the loop point, every other kind removes all 3 (their other equations are redundant)
    qa = system.assemble(q)
    assert np.abs(system.constraint_residual(qa)).max() <= 1e-12 * system.length_scale
    expected = 9 - m if b_end[0] == "world" else (7 if joint.type == "ball" else 6)
    assert system.mobility(qa) == expected == system.dof


@pytest.mark.parametrize("joint", KINDS, ids=lambda j: j.type)
@pytest.mark.parametrize("b_end", [("world", (0.8, 0.1, 0.0)), ("b1", (0.8, 0.1, 0.0))], ids=["world", "body"])
def test_loop_bias_is_the_rate_of_the_jacobian_along_the_motion(joint, b_end):
    """γ = (dΦ_q/dt) v in closed form (frame motion at zero acceleration) against a fourth-order central
    difference of Φ_q(q ⊕ εv) v in ε, at a random state."""
    system = spatial(joint, b_end)
    c = system.constraints
    q = system.random_configuration(0.3, rng=2)
    v = np.random.default_rng(3).standard_normal(system.nv)

    def jv(e):
        return system.constraint_jacobian(system.integrate(q, e * v)) @ v

    def d(h):
        return (8 * (jv(h) - jv(-h)) - (jv(2 * h) - jv(-2 * h))) / (12 * h)

    g = c.bias(q, v)
    d1, d2 = d(1e-3), d(2e-3)
    # fourth order: the step-h difference's truncation ≈ |d(h) − d(2h)| / 15; round-off ~ eps / h
    assert np.abs(g - d1).max() <= np.abs(d1 - d2).max() / 15 * 3 + 1e4 * EPS / 1e-3 * np.abs(g).max()


def test_assembly_is_the_nearest_consistent_configuration_and_keeps_the_tree():
    system = load("four_bar").build()
    assert (system.nv, system.nq, system.dof) == (3, 3, 1)
    assert system.coordinates == ("crank", "coupler", "rocker")
    q = system.configuration([0.05, -0.1, 0.2])
    assert np.abs(system.constraint_residual(q)).max() > 1e-3
    qa = system.assemble(q)
    assert np.abs(system.constraint_residual(qa)).max() <= 1e-12 * system.length_scale
    # a planar four-bar closed by a pivot: 5 equations, 2 independent
    assert system.constraint_jacobian(qa).shape == (5, 3)
    assert system.constraints.rank(qa) == 2


# ------------------------------------------------------------------ the trammel (Vénizélos Ex. 2.4.1)

L, L0, MD, MA, R, K = 0.5, 0.3, 2.0, 0.5, 0.1, 137.386259
INERTIA = MD * R**2 / 2 + 2 * MA * L**2 + (MD + 2 * MA) * L**2


def trammel_force(gamma):
    """[C + (M+2m)ℓ²] γ̈ = f(γ) (N·m)."""
    return (MD + 2 * MA) * G * L * math.sin(gamma) - 4 * K * L * (L * math.sin(gamma) - L0) * math.cos(gamma)


def test_trammel_equilibrium_frequency_and_groove_reactions():
    system = load("trammel").build()
    assert system.dof == 1
    eq = system.operating_point()
    gamma = eq.coordinate("disk")  # the textbook's γ itself
    assert abs(gamma - math.pi / 4) <= 1e-9
    assert eq.stability == "stable" and eq.constraint_residual <= 1e-12
    # closed form: ω² = −f'(π/4) / I, f' by its derivative
    c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
    df = (MD + 2 * MA) * G * L * c - 4 * K * L * (L * c * c - (L * s - L0) * s)
    lin = eq.linearize()
    m = lin.modes()
    assert m.n == 1 and lin.nv == 1
    assert m.omega[0] == pytest.approx(math.sqrt(-df / INERTIA), rel=1e-7 + 10 * m.relative_error)
    assert m.omega[0] == pytest.approx(6.885411, abs=5e-7)  # the book's value, to its 7 digits
    assert m.shapes.shape == (3, 1)
    assert np.abs(system.constraint_jacobian(eq.q) @ m.shapes).max() <= 1e-12
    assert (m.shapes.T @ lin.tree.M @ m.shapes)[0, 0] == pytest.approx(1.0, rel=1e-12)
    # groove reactions: X on B (horizontal), Y on A (vertical)
    react = eq.reactions()
    X, Y = 2 * K * (L * math.sqrt(2) / 2 - L0), (MD + 2 * MA) * G
    assert X == pytest.approx(14.715, abs=1e-6) and Y == pytest.approx(29.43, abs=1e-12)
    fB, fA = react["B"][0], react["A"][0]
    tol = 1e-8 * Y
    assert abs(abs(fB[0]) - X) <= tol and abs(fA[1] - Y) <= tol
    # the joints' own coordinates carry nothing (the loop forces balance them)
    assert all(np.abs(f).max() <= tol for f in react.joint_force.values())
    # the loop force: the rod pushes B along −x by X and carries its weight
    assert eq.loop_forces["groove_B"][:2] == pytest.approx([-X, MA * G], abs=tol)


def test_trammel_motion_matches_the_one_coordinate_equation():
    system = load("trammel").build()
    t = np.linspace(0.0, 1.0, 21)
    ref = solve_ivp(lambda _, y: [y[1], trammel_force(y[0]) / INERTIA], (0.0, 1.0), [0.6, 0.0], method="DOP853",
                    rtol=1e-12, atol=1e-14, t_eval=t)
    q0 = system.configuration({"A": 2 * L * math.sin(0.6), "disk": 0.6, "B": 2 * L * math.cos(0.6)})
    traj = system.simulate(1.0, q0, method="dop853", rtol=1e-11, t_eval=t)
    i = system.coordinate_index("disk")
    gamma = np.array([system.difference(system.neutral(), q)[i] for q in traj.q])
    assert np.abs(gamma - ref.y[0]).max() <= 1e-7
    assert np.abs([system.constraint_residual(q) for q in traj.q]).max() <= 1e-9
    assert np.abs(traj.constraint_residual).max() <= 1e-9
    assert traj.drift_relative <= 1e-8


def test_loop_simulation_methods_and_refusals():
    system = load("trammel").build()
    traj = system.simulate(0.1, method="rk4", dt=2e-3)
    assert np.abs(traj.constraint_residual).max() <= 1e-9
    with pytest.raises(vd.ModelError, match="closed loops"):
        system.simulate(0.1, method="symplectic", dt=1e-3)
    # BDF and Radau are projected once the drift passes their relative tolerance (then restarted; BDF restarts
    # at order one with a differenced Jacobian about every other step here, ~80 ms a step: 0.01 s of it, 75
    # steps, still projects many times)
    for method, t_end in (("bdf", 0.01), ("radau", 0.2)):
        traj = system.simulate(t_end, method=method, rtol=1e-8)
        assert np.abs(traj.constraint_residual).max() <= 1e-8 * system.length_scale
    # the free function refuses what the method refuses
    from vibdyn.simulation.simulate import simulate
    with pytest.raises(vd.ModelError, match="closed loops"):
        simulate(system, 0.1, method="symplectic", dt=1e-3)


# ------------------------------------------------------------------ planar mechanisms vs their reductions

def slider_crank(theta):
    """Closed-form position analysis: [(mass, J, com (2,), angle)] per moving part and the piston x."""
    r, length = 0.1, 0.3
    p = r * np.array([math.cos(theta), math.sin(theta)])
    phi = -math.asin(r * math.sin(theta) / length)
    xp = r * math.cos(theta) + length * math.cos(phi)
    parts = [(1.0, 1.0 * r**2 / 12, p / 2, theta),
             (0.5, 0.5 * length**2 / 12, p + length / 2 * np.array([math.cos(phi), math.sin(phi)]), phi),
             (2.0, 0.0, np.array([xp, 0.0]), 0.0)]
    elastic = 0.5 * 500.0 * (xp - 0.35)**2
    return parts, elastic


def four_bar(theta):
    a, b, c, d = 0.1, 0.3, 0.25, 0.3
    B, D = a * np.array([math.cos(theta), math.sin(theta)]), np.array([d, 0.0])
    e = D - B
    dist = np.linalg.norm(e)
    x = (dist**2 + b**2 - c**2) / (2 * dist)
    C = B + x * e / dist + math.sqrt(b**2 - x**2) * np.array([-e[1], e[0]]) / dist
    pc, pr = math.atan2(*(C - B)[::-1]), math.atan2(*(C - D)[::-1])
    parts = [(1.0, 1.0 * a**2 / 12, B / 2, theta),
             (0.5, 0.5 * b**2 / 12, B + b / 2 * np.array([math.cos(pc), math.sin(pc)]), pc),
             (0.8, 0.8 * c**2 / 12, D + c / 2 * np.array([math.cos(pr), math.sin(pr)]), pr)]
    return parts, 0.0


def reduced_frequency(position, theta0, guess):
    """(θ_e, ω): the one-coordinate reduction in the crank angle θ: V(θ) (gravity, springs, torsion spring
    2 N·m/rad about θ0) and m(θ) = Σ m|dx/dθ|² + J (dφ/dθ)², derivatives by 5-point central differences."""
    def V(th):
        parts, elastic = position(th)
        return sum(m * G * x[1] for m, _, x, _ in parts) + elastic + 0.5 * 2.0 * (th - theta0)**2

    def d1(f, th, h):
        return (8 * (f(th + h) - f(th - h)) - (f(th + 2 * h) - f(th - 2 * h))) / (12 * h)

    def d2(f, th, h):
        return (-f(th + 2 * h) + 16 * f(th + h) - 30 * f(th) + 16 * f(th - h) - f(th - 2 * h)) / (12 * h * h)

    th = brentq(lambda x: d1(V, x, 1e-3), guess - 0.05, guess + 0.05, xtol=1e-15)
    h = 1e-4
    mass = 0.0
    for k in range(3):
        com = lambda x, k=k: position(x)[0][k][2]  # noqa: E731
        ang = lambda x, k=k: position(x)[0][k][3]  # noqa: E731
        m, J = position(th)[0][k][:2]
        mass += m * np.sum(d1(com, th, h)**2) + J * d1(ang, th, h)**2
    return th, math.sqrt(d2(V, th, 2e-3) / mass)


@pytest.mark.parametrize("joint", [None, vd.Ball()], ids=["pivot", "ball"])
@pytest.mark.parametrize("name,position", [("slider_crank", slider_crank), ("four_bar", four_bar)])
def test_planar_mechanism_frequency_equals_its_one_coordinate_reduction(name, position, joint):
    system = load(name, joint).build()
    assert system.dof == 1
    eq = system.operating_point()
    theta = (1.0 if name == "slider_crank" else 0.0) + eq.coordinate("crank")  # (the four-bar's is the angle)
    th_ref, omega_ref = reduced_frequency(position, 1.0, theta)
    assert abs(theta - th_ref) <= 1e-9
    lin = eq.linearize()
    m = lin.modes()
    assert m.n == 1
    assert m.omega[0] == pytest.approx(omega_ref, rel=1e-7)
    assert np.abs(system.constraint_jacobian(eq.q) @ m.shapes).max() <= 1e-10 * np.abs(m.shapes).max()
    # the equations: 3 (ball) or 5 (pivot), two independent either way
    assert system.constraint_jacobian(eq.q).shape[0] == (3 if joint is not None else 5)
    assert lin.rank == 2


# ------------------------------------------------------------------ scene files and bad input

def test_loop_scene_file_round_trip(tmp_path):
    scene = load("four_bar", vd.Universal(axis1=(0, 0, 1), axis2=(1, 0, 0)))
    scene.save(tmp_path / "fb.toml")
    again = vd.load_scene(tmp_path / "fb.toml")
    assert again.loops["pin"].joint.type == "universal"
    assert again.loops["pin"].a == scene.loops["pin"].a and again.loops["pin"].b == scene.loops["pin"].b


def crank_scene():
    s = vd.Scene("crank", gravity=(0, -G, 0))
    s.add_body("crank", joint=vd.Pivot(axis=(0, 0, 1)), mass=1.0, com=(0.05, 0, 0),
               inertia=vd.inertia.rod(1.0, 0.1, axis=(1, 0, 0)))
    s.add_body("rod", parent="crank", joint=vd.Pivot(axis=(0, 0, 1), at=(0.1, 0, 0)), mass=0.5, com=(0.15, 0, 0),
               inertia=vd.inertia.rod(0.5, 0.3, axis=(1, 0, 0)))
    s.add_body("piston", joint=vd.Slider(axis=(1, 0, 0), at=(0.4, 0, 0)), mass=2.0)
    return s


BAD = [
    (("nope", (0.3, 0, 0)), ("piston", (0, 0, 0)), vd.Ball(), "unknown body 'nope'.*crank, rod, piston"),
    (("rod", (0.3, 0, 0)), ("ghost", (0, 0, 0)), vd.Ball(), "unknown body 'ghost'"),
    (("rod", (0.3, 0, 0)), ("rod", (0, 0, 0)), vd.Ball(), "joins body 'rod' to itself"),
    (("world", (0.3, 0, 0)), ("rod", (0, 0, 0)), vd.Ball(), "body_a must be a body"),
    (("rod", (0.3, 0, 0)), ("piston", (0, 0, 0)), vd.Free(), "free joint cannot close a loop"),
    (("rod", (0.3, 0, 0)), ("piston", (0, 0, 0)), vd.Planar(), "planar joint cannot close a loop"),
    (("rod", (0.3, 0, 0)), ("piston", (0, 0, 0)), "ball", "must be a vibdyn joint"),
    (("rod", (0.3, 0, 0)), ("piston", (0, 0, 0)), vd.Ball(at=(1, 0, 0)), "'at'/'rotation' are not used"),
    (("rod", (0.3, 0)), ("piston", (0, 0, 0)), vd.Ball(), "loop 'pin' end a"),
    (("rod", (0.3, float("nan"), 0)), ("piston", (0, 0, 0)), vd.Ball(), "loop 'pin' end a"),
    (("rod", (0.3, 0, 0)), ("piston", "origin"), vd.Ball(), "loop 'pin' end b"),
]


@pytest.mark.parametrize("a,b,joint,message", BAD)
def test_bad_loops_are_refused_naming_the_loop(a, b, joint, message):
    with pytest.raises(vd.ModelError, match=message) as info:
        crank_scene().add_loop("pin", a, b, joint=joint)
    assert "loop 'pin'" in str(info.value)


def test_bad_loops_found_at_build_name_the_loop():
    s = crank_scene()
    s.add_loop("pin", ("rod", (0.3, 0, 0)), ("piston", (0, 0, 0)), joint=vd.Fixed())
    with pytest.raises(vd.ModelError, match="loop 'pin' locks the mechanism"):
        s.build()
    s = crank_scene()
    s.add_loop("pin", ("rod", (0.3, 0, 0)), ("world", (2.0, 0, 0)), joint=vd.Ball())  # out of reach
    system = s.build()  # nothing at build assumes the neutral configuration closes the loops
    for ask in (lambda: system.dof, system.equilibrium, lambda: system.simulate(0.1)):
        with pytest.raises(vd.ConvergenceError, match="from the neutral configuration.*loop 'pin' stays open by"):
            ask()
    with pytest.raises(vd.ConvergenceError, match=r"assembly from q0: .*loop 'pin' stays open"):
        system.equilibrium(system.neutral())
    s = crank_scene()
    s.add_loop("pin", ("rod", (0.3, 0, 0)), ("piston", (0, 0, 0)))
    with pytest.raises(vd.ModelError, match="duplicate name 'pin'"):
        s.add_loop("pin", ("rod", (0.3, 0, 0)), ("piston", (0, 0, 0)))


def test_bad_loop_tables_in_scene_files(tmp_path):
    text = (MODELS / "four_bar.toml").read_text()
    for old, new, message in [('joint = { type = "pivot", axis = [0.0, 0.0, 1.0] }', 'joint = { type = "free" }',
                               "free joint cannot close a loop"),
                              ('name = "pin"', 'name = "pin"\nspeed = 3', "unknown key 'speed'"),
                              ('b = ["rocker"', 'b = ["nobody"', "unknown body 'nobody'")]:
        assert old in text
        path = tmp_path / "bad.toml"
        path.write_text(text.replace(old, new))
        with pytest.raises(vd.SceneFileError, match=message) as info:
            vd.load_scene(path)
        assert "loop" in str(info.value)


def test_trammel_receptance_and_free_response_in_the_independent_motion():
    """A vertical force on B: α(ω) = (dy_B/dγ)² / (I (ω_n² − ω²)), y_B = 2ℓ cos γ, at γ = π/4."""
    lin = load("trammel").build().operating_point().linearize()
    wn = lin.modes().omega[0]
    point = ("B", (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    omega = np.array([0.5, 3.0, 10.0])
    frf = lin.receptance(omega, inputs=[point], outputs=[point, ("A", (0, 0, 0), (1, 0, 0))])
    dy, dx = 2 * L * math.sin(math.pi / 4), 2 * L * math.cos(math.pi / 4)  # |dy_B/dγ|, |dx_A/dγ|
    alpha = dy**2 / (INERTIA * (wn**2 - omega**2))
    assert frf.alpha[:, 0, 0].real == pytest.approx(alpha, rel=1e-7)
    assert frf.alpha[:, 1, 0].real == pytest.approx(-dx * dy / (INERTIA * (wn**2 - omega**2)), rel=1e-7)
    # tree coordinates, independent or not: A's travel is x_A = 2ℓ sin γ (dx/dγ = dx), same receptance
    assert lin.receptance(omega, inputs=["A"], outputs=["A"]).alpha[:, 0, 0].real == pytest.approx(
        dx**2 / (INERTIA * (wn**2 - omega**2)), rel=1e-7)
    with pytest.raises(vd.ModelError, match="not an independent motion"):
        lin.free_response([0.0, 1.0], {"disk" if lin.coordinates != ("disk",) else "A": 1e-3})
    # free response from an offset of the independent coordinate: a cosine at ω_n
    t = np.linspace(0, 1, 5)
    r = lin.free_response(t, [1e-3])
    assert r.x[:, 0] == pytest.approx(1e-3 * np.cos(wn * t), abs=1e-12)


def squeezer_angles(system, ref, q):
    """The squeezer's seven angles (rad) at q: the initial ones plus the coordinates' offsets."""
    dq = system.difference(system.neutral(), q)
    return {a: ref["initial"][a] + dq[system.coordinate_index(b)] for a, b in ref["bodies"].items()}


def test_andrews_squeezer_against_the_test_set_reference():
    """IFToMM A03 / Hairer–Wanner's Andrew's squeezer: 7 rods, three loops at E, 1 dof; the angles at
    t = 0.03 s against the CWI test set's reference solution (models/andrews_squeezer.toml)."""
    scene = vd.load_scene(MODELS / "andrews_squeezer.toml")
    system = scene.build()
    assert (system.nv, system.dof) == (7, 1)
    ref = scene.references
    traj = system.simulate(ref["t"], method="dop853", rtol=1e-9, error_method="rerun", t_eval=[0.0, ref["t"]])
    for angle, x in squeezer_angles(system, ref, traj.q[-1]).items():
        # the reference carries ~1e-10 relative error (1.1e-9 rad on beta after 2.5 turns: independent runs
        # at rtol 1e-12 agree with each other to 1e-11 and differ from it by that much)
        assert abs(x - ref[angle]) <= 10 * traj.error + 1e-10 * abs(ref[angle]) + 1e-12, (angle, x, traj.error)
    # the loops stay closed, and the energy balance T + V − E0 − τ(β − β0) holds (the motor's work is W_nc)
    assert traj.constraint_residual.max() <= 1e-12
    assert traj.drift_relative <= 1e-8


def test_iftomm_a02_n_four_bar_through_its_singular_positions():
    """IFToMM A02 (N = 4): from the neutral configuration with ẋ(B0) = 1 m/s the cranks turn over and pass
    the singular positions (every link horizontal, mobility 1 → 5) ten times in 10 s. The exact motion is the
    parallelogram's, one angle φ: ((N+1)/3 + N) φ̈ = −g ((N+1)/2 + N) cos φ, integrated here; B0 = (cos φ,
    sin φ). Checked: B0 within the run's own error estimate (and the IFToMM high-precision band), energy to
    1e-6, loops closed, and the hanging mode's frequency from the same one-coordinate equation."""
    scene = vd.load_scene(MODELS / "iftomm_a02.toml")
    ref = scene.references
    n = ref["N"]
    system = scene.build()
    assert (system.nv, system.dof) == (2 * n + 1, 1)
    # every link horizontal: the mobility jumps to N + 1 and the Jacobian's conditioning drops to round-off
    flat = system.integrate(system.neutral(), [-math.pi / 2 if c.startswith("crank") else math.pi / 2
                                               for c in system.coordinates])
    assert np.abs(system.constraint_residual(flat)).max() <= 1e-14
    assert system.mobility(flat) == n + 1
    assert system.constraints.conditioning(flat) > 0.1  # the rank dropped: what is retained is well conditioned
    near = system.integrate(flat, 1e-6 * np.array([1.0 if c.startswith("crank") else -1.0
                                                   for c in system.coordinates]))
    assert system.mobility(near) == 1 and system.constraints.conditioning(near) < 1e-5
    mass, weight = (n + 1) / 3 + n, G * ((n + 1) / 2 + n)
    t = np.linspace(0.0, ref["t_end"], 401)
    exact = solve_ivp(lambda _, y: [y[1], -weight * math.cos(y[0]) / mass], (0.0, t[-1]), [math.pi / 2, -1.0],
                      method="DOP853", rtol=1e-13, atol=1e-14, t_eval=t, dense_output=True)
    crossings = brentq_all(lambda x: math.sin(exact.sol(x)[0]), t)
    assert len(crossings) == 10
    v0 = np.array([ref["v0_crank"] if c.startswith("crank") else ref["v0_coupler"] for c in system.coordinates])
    traj = system.simulate(ref["t_end"], system.neutral(), v0=v0, t_eval=t)  # (its declared start: hanging)
    b0 = traj.point_positions("crank0", (1.0, 0.0, 0.0))
    err = np.hypot(b0[:, 0] - np.cos(exact.y[0]), b0[:, 1] - np.sin(exact.y[0])).max()
    # the estimate (a rerun at rtol/100) is of the tangent coordinates; B0 is 1 m from its pivot
    assert err <= 10 * traj.error + 1e-12, (err, traj.error)
    assert err <= ref["band_high"]
    assert traj.drift_relative <= 1e-6
    # projected after each step; the outputs between steps are interpolated, open by their own error
    assert traj.constraint_residual.max() <= 10 * traj.error
    # the hanging configuration: one mode, ω² = weight / mass
    modes = system.linearize(system.operating_point()).modes()
    assert modes.omega[0] ** 2 == pytest.approx(weight / mass, rel=10 * modes.relative_error + 1e-9)


def test_rk4_richardson_estimate_through_a02s_singular_positions():
    """RK4 at dt = 4 ms through A02's singular positions (4 s, four of them): the error does not yet fall as
    dt⁴ there (y_2dt − y_4dt is ~100× y_dt − y_2dt, not 16×), so |y_dt − y_2dt|/15 was 8× short of the error
    (1.6e-10 for 1.3e-9 m at B0); the observed convergence says so, and the estimate covers the error."""
    scene = vd.load_scene(MODELS / "iftomm_a02.toml")
    ref, system = scene.references, scene.build()
    n, T = ref["N"], 4.0
    mass, weight = (n + 1) / 3 + n, G * ((n + 1) / 2 + n)
    phi = solve_ivp(lambda _, y: [y[1], -weight * math.cos(y[0]) / mass], (0.0, T), [math.pi / 2, ref["v0_crank"]],
                    method="DOP853", rtol=1e-13, atol=1e-14).y[0, -1]
    v0 = np.array([ref["v0_crank"] if c.startswith("crank") else ref["v0_coupler"] for c in system.coordinates])
    traj = system.simulate(T, system.neutral(), v0, method="rk4", dt=4e-3, t_eval=[T])
    b0 = system.point_position("crank0", (1.0, 0.0, 0.0), traj.q[-1])
    assert traj.error_method == "richardson"
    assert math.hypot(b0[0] - math.cos(phi), b0[1] - math.sin(phi)) <= traj.error  # (B0 is 1 m out)


def brentq_all(f, t):
    """Every root of f between consecutive samples t where f changes sign."""
    v = [f(x) for x in t]
    return [brentq(f, a, b) for a, b, fa, fb in zip(t, t[1:], v, v[1:]) if fa * fb < 0]


def test_loop_model_modal_damping_and_four_bar_shapes_in_tree_coordinates():
    lin = load("four_bar").build().operating_point().linearize()
    damped = lin.with_modal_damping(0.05)
    m = damped.modes()
    assert m.zeta == pytest.approx([0.05], rel=1e-9)
    # the shape moves all three tree coordinates and keeps the loop closed
    assert m.shapes.shape == (3, 1) and np.all(np.abs(m.shapes) > 1e-3)
    assert lin.tree.nv == 3 and lin.nv == 1 and lin.null_space.shape == (3, 1)


def test_loop_equilibria_from_several_starts_and_refused_operating_points():
    system = load("trammel").build()
    found = system.equilibria([system.configuration({"disk": 0.8}), system.configuration({"disk": 0.7})])
    assert len(found) == 1 and abs(found[0].coordinate("disk") - math.pi / 4) <= 1e-9
    with pytest.raises(vd.ModelError, match="closed loops.*groove_B"):
        system.held()
    with pytest.raises(vd.ModelError, match="turning disk opens the loops"):  # (a rotor under them may turn)
        system.steady_motion({"disk": 1.0})


def test_info_lists_the_loops_with_their_rank_and_mobility():
    import io

    from vibdyn.faces.cli import describe

    scene = vd.load_scene(MODELS / "four_bar.toml")
    out = io.StringIO()
    describe(scene, scene.build(), out)
    text = out.getvalue()
    # a planar four-bar closed by a 3-D pivot: 5 equations of which 2 independent, one motion left
    assert "closed loops: 5 equations, rank 2, mobility 1" in text
    assert "pin   pivot axis (0, 0, 1)  coupler(0.3, 0, 0) m – rocker(0.25, 0, 0) m" in text


def test_a_run_stopped_at_a_singular_position_says_so():
    """The failure message of a mechanism's run names the singular position it stopped at (and nothing for
    a run stopped elsewhere)."""
    from types import SimpleNamespace

    from vibdyn.simulation.runs import singular_note

    system = vd.load_scene(MODELS / "iftomm_a02.toml").build()
    flat = system.integrate(system.neutral(), [-math.pi / 2 if c.startswith("crank") else math.pi / 2
                                               for c in system.coordinates])
    near = system.integrate(flat, 1e-6 * np.array([1.0 if c.startswith("crank") else -1.0
                                                   for c in system.coordinates]))
    note = singular_note(system, SimpleNamespace(t=[0.0, 1.0], q=[system.neutral(), near]))
    assert "singular position" in note and "loosen rtol" in note
    assert singular_note(system, SimpleNamespace(t=[0.0], q=[system.neutral()])) == ""
