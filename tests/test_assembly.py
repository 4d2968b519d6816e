"""Assembly from a described pose (issue 34): a looped scene without a declared start begins at the closure of
its loops nearest the neutral configuration. Checked against the four-bar's position analysis in closed form,
the bundled models (with their hand-made starts), the trammel's textbook balance, the gap of a four-bar that
cannot close, and a change-point four-bar whose nearest closure is its singular flat position."""

import math

import numpy as np
import pytest
from conftest import MODELS
from scipy.optimize import brentq, minimize_scalar

import vibdyn as vd
from vibdyn.defaults import ASSEMBLY_TOL

A, B, C, D = 0.1, 0.3, 0.25, 0.3  # the bundled four-bar: crank, coupler, rocker, ground (m)


def described(name, text=None, tmp_path=None):
    """A bundled scene (or its text edited) without its declared start: every joint angle zero, loops open."""
    if text is None:
        scene = vd.load_scene(MODELS / f"{name}.toml")
    else:
        path = tmp_path / f"{name}.toml"
        path.write_text(text)
        scene = vd.load_scene(path)
    scene.operating_point = None
    return scene


def upper_branch(theta, a=A, b=B, c=C, d=D):
    """Closed-form position analysis: (coupler angle relative to the crank, rocker angle) of the four-bar's
    branch with C above the line BD, the crank at ``theta`` (rad)."""
    Bp, Dp = a * np.array([math.cos(theta), math.sin(theta)]), np.array([d, 0.0])
    e = Dp - Bp
    dist = np.linalg.norm(e)
    x = (dist**2 + b**2 - c**2) / (2 * dist)
    Cp = Bp + x * e / dist + math.sqrt(b**2 - x**2) * np.array([-e[1], e[0]]) / dist
    return math.atan2(*(Cp - Bp)[::-1]) - theta, math.atan2(*(Cp - Dp)[::-1])


def points(system, q):
    return np.array([system.point_position(n, p, q) for n, b in system.scene.bodies.items()
                     for p in ((0, 0, 0), b.com)])


@pytest.mark.parametrize("name", ["four_bar", "trammel"])
def test_described_four_bar_and_trammel_equal_the_bundled_models_with_no_start(name):
    """Acceptance: equilibrium and frequency of the scene with no start equal those of the bundled model
    (assembled from its hand-made start) to 1e-9, and within the two results' own error estimates."""
    system = described(name).build()
    assembly = system.constraints.assembly()
    assert assembly.constraint_residual <= ASSEMBLY_TOL and not assembly.singular
    assert system.dof == assembly.dof == 1 and assembly.rank == 2
    assert system.constraints.closed[1] == assembly.where == "the closure nearest the neutral configuration"
    assert system.start_configuration()[1] == assembly.where
    bundled = vd.load_scene(MODELS / f"{name}.toml").build()
    eq, ref = system.operating_point(), bundled.operating_point()
    assert eq.stability == ref.stability == "stable"
    L = system.length_scale
    gap = np.abs(points(system, eq.q) - points(bundled, ref.q)).max()
    assert gap <= 1e-9 * L
    assert np.abs(eq.q - ref.q).max() <= 10 * (eq.q_error + ref.q_error).max() + 1e-12
    m, mr = eq.linearize().modes(), ref.linearize().modes()
    assert m.omega == pytest.approx(mr.omega, rel=1e-9)
    assert abs(m.omega[0] - mr.omega[0]) <= 10 * (m.omega_error[0] + mr.omega_error[0])


def test_four_bar_assembles_at_the_closure_nearest_its_flat_description():
    """Laid flat, the four-bar's residual is stationary (|Φ|² has zero gradient): the first least squares
    fails and the restarts find both branches. The closure taken is, on the position analysis's closed form,
    the point of the upper branch nearest the described pose (its mirror image on the lower branch is as
    near: the tie is noted)."""
    system = described("four_bar").build()
    a = system.constraints.assembly()
    assert a.starts > 1 and "mirror images" in a.note and "'crank'" in a.note
    theta, coupler, rocker = system.difference(system.neutral(), a.q)
    cpl, rck = upper_branch(theta)
    assert (coupler, rocker) == pytest.approx((cpl, rck), abs=1e-10)  # on the upper branch (C above BD)
    assert np.abs(system.constraint_residual(a.q)).max() <= ASSEMBLY_TOL * system.length_scale

    def dist2(th):
        return th**2 + sum(x**2 for x in upper_branch(th))

    best = minimize_scalar(dist2, bracket=(0.3, 0.5, 0.7), tol=1e-12)
    assert theta == pytest.approx(best.x, abs=1e-6)  # (the distance is flat there: d² varies as Δθ²)
    assert a.distance == pytest.approx(math.sqrt(best.fun), abs=1e-10)
    assert a.offsets == pytest.approx(system.difference(system.neutral(), a.q), abs=1e-15)
    mirror = system.configuration(-system.difference(system.neutral(), a.q))  # on the lower branch, as near
    assert np.abs(system.constraint_residual(mirror)).max() <= 10 * ASSEMBLY_TOL * system.length_scale
    text = repr(a)
    assert len(text) < 400 and "\n" not in text and "dof 1" in text and "residual" in text


def test_trammel_start_leaves_the_closure_where_its_spring_has_no_direction():
    """The trammel drawn with every coordinate zero closes nearest at γ = 0, A at O, B at 2ℓ: there the spring
    O–A has zero length (no direction). The start leaves it along the motion, A increasing, and the
    equilibrium is the textbook's γ = π/4 branch, found from the file's rounded k by a root search here."""
    system = described("trammel").build()
    a = system.constraints.assembly()
    assert "spring 'k' reached zero length" in a.note and "'A' increasing" in a.note
    x = system.difference(system.neutral(), a.q)
    A_, gamma, B_ = x
    assert 0 < gamma < 2e-3 and A_ == pytest.approx(math.sin(gamma), abs=1e-12)
    assert B_ == pytest.approx(math.cos(gamma), abs=1e-12)
    eq = system.equilibrium()
    M, m_ab, ell, g, k, l0 = 2.0, 0.5, 0.5, 9.81, 137.386259, 0.6
    hand = brentq(lambda c: (M + 2 * m_ab) * g * ell * math.sin(c)
                  - 2 * k * (2 * ell * math.sin(c) - l0) * ell * math.cos(c), 0.6, 1.0, xtol=1e-16)
    i = system.coordinate_index("disk")
    assert eq.coordinate("disk") == pytest.approx(hand, abs=10 * eq.q_error[i] + 1e-15)


@pytest.mark.parametrize("edit,gap", [
    (("a = [\"coupler\", [0.3, 0.0, 0.0]]", "a = [\"coupler\", [0.8, 0.0, 0.0]]"), 0.8 - (A + C + D)),  # b too long
    (("b = [\"rocker\", [0.25, 0.0, 0.0]]", "b = [\"rocker\", [0.05, 0.0, 0.0]]",
      "a = [\"coupler\", [0.3, 0.0, 0.0]]", "a = [\"coupler\", [0.02, 0.0, 0.0]]"), D - A - 0.02 - 0.05),  # too short
])
def test_a_four_bar_that_cannot_close_is_refused_naming_its_loop_and_its_gap(tmp_path, edit, gap):
    """Link lengths with the longest one beyond the sum of the others: no closure. The scene builds; any
    analysis needing a start is refused naming the loop, and the smallest residual the search reached is the
    closed-form gap (longest − sum of the others, m)."""
    text = (MODELS / "four_bar.toml").read_text()
    for old, new in zip(edit[::2], edit[1::2]):
        assert old in text
        text = text.replace(old, new)
    system = described("four_bar", text, tmp_path).build()
    for ask in (lambda: system.dof, system.equilibrium, system.assemble, system.constraints.assembly):
        with pytest.raises(vd.ConvergenceError, match=r"assembly from the neutral configuration: the loops cannot "
                                                      r"be closed .*loop 'pin' stays open by") as info:
            ask()
    assert f"loop 'pin' stays open by {gap:.4g} m at best" in str(info.value)
    assert info.value.residual * system.length_scale == pytest.approx(gap, abs=1e-6)
    assert np.abs(system.constraint_residual(info.value.best)).max() == pytest.approx(gap, abs=1e-6)


def test_a_change_point_four_bar_is_refused_at_its_singular_nearest_closure(tmp_path):
    """Ground d = 0.15 m makes a + b = c + d: the flat description closes, at the change point where the two
    branches cross (all four pivots aligned: rank 1 instead of 2, mobility 2 there). The scene builds; the
    analyses refuse that start naming the loop; a declared start off it works (mobility 1)."""
    text = (MODELS / "four_bar.toml").read_text()
    old = "at = [0.3, 0.0, 0.0] }\n\n[[joint_spring]]"
    assert old in text
    text = text.replace(old, "at = [0.15, 0.0, 0.0] }\n\n[[joint_spring]]")
    scene = described("four_bar", text, tmp_path)
    system = scene.build()
    a = system.constraints.assembly()
    assert a.singular and (a.rank, a.generic_rank, a.dof) == (1, 2, 2) and a.distance == 0.0
    assert np.abs(system.constraint_residual(a.q)).max() == 0.0
    for ask in (lambda: system.dof, system.equilibrium, lambda: system.simulate(0.1)):
        with pytest.raises(vd.ModelError, match=r"loop 'pin': the closure nearest the neutral configuration .* is a "
                                                r"singular position .*rank 1 there and 2 .*declare a start"):
            ask()
    cpl, rck = upper_branch(1.0, d=0.15)
    scene.set_operating_point(start={"crank": 1.0, "coupler": cpl, "rocker": rck})
    system = scene.build()
    assert system.dof == 1 and system.constraints.closed[1].startswith("the declared start")


def rssr():
    """RSSR: a crank pivot, a coupler on a ball joint (a quaternion), a rocker pivot about y, a ball loop:
    mobility 2 (the coupler spins about its own axis)."""
    s = vd.Scene("rssr", gravity=(0, -9.81, 0))
    s.add_body("crank", joint=vd.Pivot((0, 0, 1)), mass=1.0, com=(0.05, 0, 0), inertia=np.diag([1e-4, 1e-3, 1e-3]))
    s.add_body("coupler", parent="crank", joint=vd.Ball(at=(0.1, 0, 0)), mass=0.5, com=(0.15, 0, 0),
               inertia=np.diag([1e-4, 4e-3, 4e-3]))
    s.add_body("rocker", joint=vd.Pivot((0, 1, 0), at=(0.3, 0, 0.05)), mass=0.8, com=(0.125, 0, 0),
               inertia=np.diag([1e-4, 4e-3, 4e-3]))
    s.add_loop("S", ("coupler", (0.3, 0, 0)), ("rocker", (0.25, 0, 0)), joint=vd.Ball())
    return s


def test_a_spatial_linkage_with_a_ball_joint_assembles_at_a_local_nearest_closure():
    """RSSR (crank pivot, coupler on a ball joint: a quaternion, rocker pivot about y, ball loop): the assembly
    works in the tangent space of the ball joint; its closure is a unit quaternion on the loops, and the
    closures beside it along ± each motion the loops allow are farther from the described pose."""
    system = rssr().build()
    a = system.constraints.assembly()
    assert a.dof == system.dof == 2 and a.distance > 0.1  # (the coupler's spin about its own axis is free)
    quaternion = a.q[1:5]
    assert abs(np.linalg.norm(quaternion) - 1.0) <= 1e-14
    assert np.abs(system.constraint_residual(a.q)).max() <= ASSEMBLY_TOL * system.length_scale
    c, neutral = system.constraints, system.neutral()
    N = c.null_space(a.q)
    for v in N.T:
        for sign in (1.0, -1.0):
            beside = system.assemble(system.integrate(a.q, sign * 1e-3 * v / np.linalg.norm(v / c.col_scale)))
            x = system.difference(neutral, beside) / c.col_scale
            assert np.linalg.norm(x) >= a.distance - 1e-12


def test_assembly_keeps_to_the_joint_limits():
    """The flat four-bar's two nearest closures are mirror images (crank ±θ*): with the crank limited to
    θ ≤ 0 the assembly takes the lower one, with no tie; a rocker limited to ±0.1 rad, which no closure
    reaches (the rocker stands near ±1.5 rad on both branches), is refused naming it and its limit."""
    scene = described("four_bar")
    free = scene.build().constraints.assembly()
    scene.set_limits("crank", upper=0.0)
    system = scene.build()
    a = system.constraints.assembly()
    x, x_free = system.difference(system.neutral(), a.q), free.offsets
    assert x[0] < 0 and "mirror images" not in a.note
    assert x == pytest.approx(-x_free, abs=1e-9)  # the mirror image of the unconstrained choice
    scene = described("four_bar")
    scene.set_limits("rocker", -0.1, 0.1)
    system = scene.build()  # (refused where met: at the first analysis, not at build)
    with pytest.raises(vd.ConvergenceError,
                       match=r"every closure found lies beyond the scene's position limits.*'rocker'.*limit 0\.1"):
        system.constraints.assembly()
    with pytest.raises(vd.ConvergenceError, match="position limits"):
        system.operating_point()
