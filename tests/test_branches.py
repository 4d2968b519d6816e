"""Branches and locking of closed loops (issue 40, items 4 and 5). The assembly of a described pose compares
every branch of the closures before calling one the nearest, against hand closures (the two assembly modes
of a four-bar and of a slider-crank by circle intersection); a linkage whose lengths add up closes only flat
and is refused as locked, while one merely near that flat position still works."""

import math

import numpy as np
import pytest
from conftest import MODELS
from scipy.optimize import minimize_scalar
from test_assembly import rssr  # (the spatial linkage of that file)

import vibdyn as vd
from vibdyn.defaults import ASSEMBLY_TOL
from vibdyn.model import assembly, assembly_modes
from vibdyn.model.loop_batch import LoopBatch, close_many

A, B, C, D = 0.1, 0.3, 0.25, 0.3  # the bundled four-bar: crank, coupler, rocker, ground (m)
NEAREST = "the closure nearest the neutral configuration"
ALL, CRANK = np.array([True, True, True]), np.array([True, True, False])  # which coordinates are angles


def wrap(x):
    """Angles taken within π of zero (the described pose's), as the assembly's distance does."""
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def rz(t):
    return [[math.cos(t), -math.sin(t), 0.0], [math.sin(t), math.cos(t), 0.0], [0.0, 0.0, 1.0]]


def four_bar(tmp_path, rotation=0.0, ground=D, start=None):
    """The bundled four-bar with its crank joint drawn rotated by ``rotation`` (rad) and its ground pivot D at
    ``ground`` (m), no start unless one is given."""
    text = (MODELS / "four_bar.toml").read_text()
    crank = 'joint = { type = "pivot", axis = [0.0, 0.0, 1.0], at = [0.0, 0.0, 0.0] }'
    ground_pivot = "at = [0.3, 0.0, 0.0] }\n\n[[joint_spring]]"
    assert crank in text and ground_pivot in text
    text = text.replace(crank, crank[:-2] + f", rotation = {rz(rotation)} }}")
    text = text.replace(ground_pivot, f"at = [{ground}, 0.0, 0.0] }}\n\n[[joint_spring]]")
    path = tmp_path / "four_bar.toml"
    path.write_text(text)
    scene = vd.load_scene(path)
    scene.operating_point = None
    if start is not None:
        scene.set_operating_point(start=start)
    return scene


def circle_intersections(P, r1, Q, r2):
    """The two points at r1 from P and r2 from Q (the left one of P→Q first); None where the circles miss."""
    e = np.asarray(Q, float) - P
    dist = np.linalg.norm(e)
    x = (dist**2 + r1**2 - r2**2) / (2 * dist)
    h2 = r1**2 - x**2
    if h2 < 0:
        return None
    n = np.array([-e[1], e[0]]) / dist
    m = P + x * e / dist
    return m + math.sqrt(h2) * n, m - math.sqrt(h2) * n


def four_bar_branches(theta, rotation, a=A, b=B, c=C, d=D):
    """Hand closure: the joint coordinates (crank, coupler, rocker) of the four-bar's two assembly modes with
    its crank joint at ``theta`` (rad, from the drawn angle ``rotation``); None where the loop cannot close."""
    phi = rotation + theta
    Bp, Dp = a * np.array([math.cos(phi), math.sin(phi)]), np.array([d, 0.0])
    points = circle_intersections(Bp, b, Dp, c)
    if points is None:
        return None
    return [np.array([theta, math.atan2(*(Cp - Bp)[::-1]) - phi, math.atan2(*(Cp - Dp)[::-1])]) for Cp in points]


def slider_crank(alpha, r=0.1, L=0.3, x0=0.3):
    """A slider-crank drawn with its crank at ``alpha`` (rad), the rod along it and the piston at x0 (m) on
    its slider along x: the loop (rod tip on the piston pin) open there."""
    s = vd.Scene("slider_crank_drawn", gravity=(0, -9.81, 0))
    s.add_body("crank", joint=vd.Pivot((0, 0, 1), rotation=np.array(rz(alpha))), mass=1.0, com=(r / 2, 0, 0),
               inertia=np.diag([1e-5, 1e-3, 1e-3]))
    s.add_body("rod", parent="crank", joint=vd.Pivot((0, 0, 1), at=(r, 0, 0)), mass=0.5, com=(L / 2, 0, 0),
               inertia=np.diag([1e-5, 4e-3, 4e-3]))
    s.add_body("piston", joint=vd.Slider((1, 0, 0), at=(x0, 0, 0)), mass=2.0)
    s.add_loop("pin", ("rod", (L, 0, 0)), ("piston", (0, 0, 0)), joint=vd.Pivot((0, 0, 1)))
    return s


def slider_crank_branches(theta, alpha, r=0.1, L=0.3, x0=0.3):
    """Hand closure: (crank, rod, piston) joint coordinates of the slider-crank's two assembly modes (the pin
    right or left of the crank tip: x = r cos φ ± √(L² − r² sin² φ))."""
    phi = alpha + theta
    Bp = r * np.array([math.cos(phi), math.sin(phi)])
    out = []
    for sign in (1.0, -1.0):
        x = Bp[0] + sign * math.sqrt(L**2 - Bp[1] ** 2)
        out.append(np.array([theta, math.atan2(-Bp[1], x - Bp[0]) - phi, x - x0]))
    return out


def hand_nearest(branches, scale, angles):
    """(distance, closure) of the closure nearest the described pose over both hand branches: the distance as
    the docs define it, √Σ (offset / scale)² with angles wrapped within π; a fine grid of the crank's turn,
    then a bounded scalar search around each branch's best grid point."""

    def distance(theta, k):
        x = branches(theta)[k]
        return float(np.linalg.norm(np.where(angles, wrap(x), x) / scale))

    grid = np.linspace(-np.pi, np.pi, 4001)
    best = (np.inf, None)
    for k in (0, 1):
        d = [distance(t, k) for t in grid]
        i = int(np.argmin(d))
        r = minimize_scalar(lambda t: distance(t, k), bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 4000)]),
                            method="bounded", options={"xatol": 1e-12})
        if r.fun < best[0]:
            best = (float(r.fun), branches(r.x)[k])
    return best


def assert_on_a_branch(x, branches, scale, angles, tol):
    """The closure x (joint offsets) equals one of the hand branches at its own crank angle: the index of
    that branch."""
    gaps = [np.abs(np.where(angles, wrap(x - h), x - h) / scale).max() for h in branches(x[0])]
    assert min(gaps) <= tol
    return int(np.argmin(gaps))


@pytest.mark.parametrize("rotation", [0.3, 6.0])
def test_a_four_bar_drawn_with_its_crank_turned_assembles_at_the_nearest_of_both_branches(tmp_path, rotation):
    """Issue 40 item 4: drawn with the crank joint turned 0.3 rad (or 6.0), the four-bar was assembled at
    distance 1.740 on one branch and called nearest while the other branch closes at 1.555. The hand closure
    over both branches (circle intersection, the crank's whole turn) gives the nearest; the assembly equals it
    and says it is proven."""
    system = four_bar(tmp_path, rotation).build()
    a = system.constraints.assembly()
    assert a.where == NEAREST and a.nearest and a.dof == 1
    assert a.constraint_residual <= ASSEMBLY_TOL
    scale = system.constraints.col_scale
    x = system.difference(system.neutral(), a.q)
    hand_d, hand_x = hand_nearest(lambda t: four_bar_branches(t, rotation), scale, ALL)
    assert hand_d < 1.6  # (the hand search itself sees the nearer branch)
    # the slide stops where the distance is flat (it varies as the square of the offset there): distances
    # agree to the square of the stopping offset, the points to its first power
    assert a.distance == pytest.approx(hand_d, abs=1e-8)
    assert np.abs(wrap(x - hand_x)).max() <= 1e-4
    assert_on_a_branch(x, lambda t: four_bar_branches(t, rotation), scale, ALL, 1e-9)
    assert a.distance == pytest.approx(float(np.linalg.norm(wrap(x))), abs=1e-12)  # the distance is the wrapped one


@pytest.mark.parametrize("alpha", [1.8, 2.6])
def test_a_slider_crank_drawn_open_assembles_at_the_nearest_of_both_branches(alpha):
    """The class of fault on a second mechanism: a slider-crank drawn with its crank at 1.8 (or 2.6) rad and
    its rod straight along it was assembled with the pin left of the crank tip (distance 2.50, 2.36) where the
    right branch is nearer. Hand oracle: both branches x = r cos φ ± √(L² − r² sin² φ); the piston's offset
    divided by the length scale, as the distance is defined."""
    system = slider_crank(alpha).build()
    a = system.constraints.assembly()
    assert a.where == NEAREST and a.nearest
    scale = system.constraints.col_scale
    assert scale[2] == system.length_scale and scale[0] == scale[1] == 1.0
    x = system.difference(system.neutral(), a.q)
    hand_d, hand_x = hand_nearest(lambda t: slider_crank_branches(t, alpha), scale, CRANK)
    assert a.distance == pytest.approx(hand_d, abs=1e-8)
    assert np.abs(np.where(CRANK, wrap(x - hand_x), x - hand_x) / scale).max() <= 1e-4
    assert assert_on_a_branch(x, lambda t: slider_crank_branches(t, alpha), scale, CRANK, 1e-9) == 0  # pin right of B


def test_a_closure_of_a_two_mobility_linkage_is_not_called_nearest():
    """With mobility 2 (RSSR: the coupler spins about its own axis) the closures form surfaces, which are not
    traced: the assembly names its closure 'a closure found near the neutral configuration' and says why."""
    system = rssr().build()
    a = system.constraints.assembly()
    assert a.dof == 2 and not a.nearest and "nearest" not in a.where
    assert system.constraints.closed[1] == a.where == "a closure found near the neutral configuration"
    assert "not proven the nearest: the mechanism has mobility 2" in a.note


def reach_gap(a, b, c, d, phi):
    """|BD| − (b + c) with the crank at φ: > 0 where the coupler and rocker cannot reach (hand geometry)."""
    return math.hypot(d - a * math.cos(phi), a * math.sin(phi)) - (b + c)


@pytest.mark.parametrize("start", [None, {"crank": 0.02, "coupler": -0.02, "rocker": 3.1}])
def test_a_four_bar_whose_lengths_add_up_is_refused_as_locked(tmp_path, start):
    """Issue 40 item 5: ground 0.65 m = 0.1 + 0.3 + 0.25: the loop closes only stretched flat (hand geometry:
    |BD| − (b + c) is 0 at φ = 0 and positive at every other crank angle, so no motion is left). It was
    accepted with mobility 1, a 6504 rad/s mode and a 3.7e6 N loop force; now it is refused at build, from
    the described pose or from a declared start, as a bar pinned at its tip is ('locks the mechanism')."""
    d = A + B + C
    assert reach_gap(A, B, C, d, 0.0) == pytest.approx(0.0, abs=1e-15)
    assert min(reach_gap(A, B, C, d, p) for p in np.linspace(1e-3, 2 * np.pi - 1e-3, 2001)) > 0
    scene = four_bar(tmp_path, ground=d, start=start)
    with pytest.raises(vd.ModelError, match=r"loop 'pin' locks the mechanism: .*lengths add up.*rank 1 .*mobility 0"):
        scene.build()


@pytest.mark.parametrize("ground", [0.649, 0.6499])
def test_a_four_bar_near_its_flat_position_still_moves(tmp_path, ground):
    """Ground 0.649 m (or 0.6499): 1 (0.1) mm short of flat, the loop closes over a small range of crank
    angles (hand geometry: |BD| ≤ b + c for |φ| up to φ_max) and keeps mobility 1: the lock test at its
    closure does not refuse it. Its closure and equilibrium lie on a hand branch."""
    phi_max = math.acos((A**2 + ground**2 - (B + C) ** 2) / (2 * A * ground))
    assert 0 < phi_max < 0.5
    system = four_bar(tmp_path, ground=ground).build()
    a = system.constraints.assembly()
    assert system.dof == a.dof == 1 and not a.singular and a.nearest
    scale = system.constraints.col_scale

    def branches(t):
        return four_bar_branches(t, 0.0, d=ground)

    x = system.difference(system.neutral(), a.q)
    assert abs(x[0]) < phi_max
    assert_on_a_branch(x, branches, scale, ALL, 1e-9)
    eq = system.equilibrium()
    xe = system.difference(system.neutral(), eq.q)
    assert abs(xe[0]) < phi_max
    assert_on_a_branch(xe, branches, scale, ALL, 1e-9)


@pytest.mark.parametrize("gap,locked", [(0.0, True), (1e-3, False)])
def test_a_slider_crank_whose_slider_line_touches_its_reach_is_locked(gap, locked):
    """The lock on a second mechanism: a slider-crank whose piston slides along y on the line x = r + L − gap.
    With gap 0 the pin reaches that line only with crank and rod stretched along x (hand: the reach circle
    |P| ≤ r + L touches the line at one point): refused as locked. 1 mm inside, it moves (mobility 1) and its
    closure is the hand one, crank and rod each at ±acos-determined angles with |P| ≤ r + L."""
    r, L = 0.1, 0.3
    s = vd.Scene("slider_crank_locked", gravity=(0, -9.81, 0))
    s.add_body("crank", joint=vd.Pivot((0, 0, 1)), mass=1.0, com=(r / 2, 0, 0), inertia=np.diag([1e-5, 1e-3, 1e-3]))
    s.add_body("rod", parent="crank", joint=vd.Pivot((0, 0, 1), at=(r, 0, 0)), mass=0.5, com=(L / 2, 0, 0),
               inertia=np.diag([1e-5, 4e-3, 4e-3]))
    s.add_body("piston", joint=vd.Slider((0, 1, 0), at=(r + L - gap, 0, 0)), mass=2.0)
    s.add_loop("pin", ("rod", (L, 0, 0)), ("piston", (0, 0, 0)), joint=vd.Pivot((0, 0, 1)))
    if locked:
        with pytest.raises(vd.ModelError, match=r"loop 'pin' locks the mechanism: .*mobility 0"):
            s.build()
        return
    system = s.build()
    assert system.dof == 1
    q = system.assemble()
    crank, rod, y = system.difference(system.neutral(), q)
    pin = r * np.array([math.cos(crank), math.sin(crank)]) + L * np.array([math.cos(crank + rod),
                                                                           math.sin(crank + rod)])
    assert pin == pytest.approx([r + L - gap, y], abs=1e-12)
    assert abs(y) <= math.sqrt((r + L) ** 2 - (r + L - gap) ** 2) + 1e-12


E3, F4, E5, F6 = (0.15, 0.05), (0.125, -0.05), 0.2, 0.2  # Watt six-bar: dyad pivots on coupler and rocker (m)


def watt(rotation):
    """A Watt I six-bar: the bundled four-bar (crank drawn turned by ``rotation``) with a dyad (links 5 and
    6, 0.2 m each) joining a point E of the coupler to a point F of the rocker, two loops, drawn open."""
    s = vd.Scene("watt", gravity=(0, -9.81, 0))
    inertia = np.diag([1e-5, 1e-3, 1e-3])
    s.add_body("crank", joint=vd.Pivot((0, 0, 1), rotation=np.array(rz(rotation))), mass=1.0, com=(0.05, 0, 0),
               inertia=inertia)
    s.add_body("coupler", parent="crank", joint=vd.Pivot((0, 0, 1), at=(A, 0, 0)), mass=0.5, com=(0.15, 0, 0),
               inertia=inertia)
    s.add_body("link5", parent="coupler", joint=vd.Pivot((0, 0, 1), at=(*E3, 0)), mass=0.3, com=(0.1, 0, 0),
               inertia=inertia)
    s.add_body("rocker", joint=vd.Pivot((0, 0, 1), at=(D, 0, 0)), mass=0.8, com=(0.125, 0, 0), inertia=inertia)
    s.add_body("link6", parent="rocker", joint=vd.Pivot((0, 0, 1), at=(*F4, 0)), mass=0.3, com=(0.1, 0, 0),
               inertia=inertia)
    s.add_loop("C", ("coupler", (B, 0, 0)), ("rocker", (C, 0, 0)), joint=vd.Pivot((0, 0, 1)))
    s.add_loop("G", ("link5", (E5, 0, 0)), ("link6", (F6, 0, 0)), joint=vd.Pivot((0, 0, 1)))
    return s


def watt_branches(theta, rotation):
    """Hand closure: {(i, j): joint coordinates (crank, coupler, link5, rocker, link6)} of the Watt six-bar's
    four assembly modes (the four-bar's mode i, the dyad's j) with the crank at ``theta``; the modes that
    cannot close there are left out."""
    out = {}
    for i, x in enumerate(four_bar_branches(theta, rotation) or []):
        phi = rotation + theta
        psi3, psi4 = phi + x[1], x[2]
        Bp, Dp = A * np.array([math.cos(phi), math.sin(phi)]), np.array([D, 0.0])
        E = Bp + np.array(rz(psi3))[:2, :2] @ E3
        F = Dp + np.array(rz(psi4))[:2, :2] @ F4
        for j, G in enumerate(circle_intersections(E, E5, F, F6) or []):
            psi5, psi6 = math.atan2(*(G - E)[::-1]), math.atan2(*(G - F)[::-1])
            out[i, j] = np.array([theta, x[1], psi5 - psi3, psi4, psi6 - psi4])
    return out


def watt_hand_nearest(rotation):
    """Distance (dimensionless) of the hand closure nearest the described pose over the Watt six-bar's four
    assembly modes: the four-bar's circle intersection, then the dyad's, on a fine grid of the crank's turn
    refined by a bounded search on each mode."""
    grid = np.linspace(-np.pi, np.pi, 4001)
    best = np.inf
    for k in ((0, 0), (0, 1), (1, 0), (1, 1)):
        def distance(t):
            mode = watt_branches(t, rotation).get(k)
            return np.inf if mode is None else float(np.linalg.norm(wrap(mode)))

        d = np.array([distance(t) for t in grid])
        i = int(np.argmin(d))
        r = minimize_scalar(distance, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 4000)]), method="bounded",
                            options={"xatol": 1e-12})
        best = min(best, float(r.fun))
    return best


def on_a_watt_mode(system, q, rotation):
    """Whether q is on a hand assembly mode of the Watt six-bar (to 1e-9 rad)."""
    x = system.difference(system.neutral(), q)
    return min(np.abs(wrap(x - h)).max() for h in watt_branches(x[0], rotation).values()) <= 1e-9


@pytest.mark.parametrize("rotation", [0.0, 0.5, 3.0])
def test_a_watt_six_bar_drawn_open_assembles_at_the_nearest_of_its_four_modes(rotation):
    """Two loops, four dependent coordinates: the Watt six-bar's assembly modes are four (the four-bar's two,
    each with the dyad's two). Its loops are solved one after another (the four-bar's coordinates, then the
    dyad's from each of its closures), so the modes are enumerated, not sampled, and the closure is called the
    nearest. Drawn with the crank turned 0, 0.5, 3.0 rad the assembly once took closures at 2.04, 3.21, 4.13 and
    called them nearest where a hand mode closes at 1.65, 1.55, 2.47; later it found the nearest but could not
    prove it (26 sampled restarts of the four coordinates together). The closure is the hand nearest."""
    system = watt(rotation).build()
    a = system.constraints.assembly()
    assert a.nearest and a.where == NEAREST and a.dof == 1 and "not proven" not in a.note
    assert on_a_watt_mode(system, a.q, rotation)
    assert a.distance == pytest.approx(watt_hand_nearest(rotation), abs=1e-8)


P7, G8, L7, L8 = (0.1, 0.0), (0.1, -0.2), 0.15, 0.15  # a second dyad: link 7 on link 5, link 8 on the ground (m)


def watt_with_dyad():
    """Three loops: the Watt six-bar drawn open, with a second dyad (links 7 and 8, 0.15 m each) joining a point
    of link 5 to a ground pivot."""
    s = watt(0.0)
    inertia = np.diag([1e-5, 1e-3, 1e-3])
    s.add_body("link7", parent="link5", joint=vd.Pivot((0, 0, 1), at=(*P7, 0)), mass=0.3, com=(0.07, 0, 0),
               inertia=inertia)
    s.add_body("link8", joint=vd.Pivot((0, 0, 1), at=(*G8, 0)), mass=0.3, com=(0.07, 0, 0), inertia=inertia)
    s.add_loop("H", ("link7", (L7, 0, 0)), ("link8", (L8, 0, 0)), joint=vd.Pivot((0, 0, 1)))
    return s


def watt_with_dyad_branches(theta):
    """Hand closure: {name: joint coordinate} of each of the (up to eight) assembly modes with the crank at theta:
    the Watt six-bar's four, each with the second dyad's two (its circle intersection)."""
    out = []
    for x in watt_branches(theta, 0.0).values():
        crank, coupler, link5, rocker, link6 = x
        psi3, psi5 = crank + coupler, crank + coupler + link5
        E = A * np.array([math.cos(crank), math.sin(crank)]) + np.array(rz(psi3))[:2, :2] @ E3
        P = E + np.array(rz(psi5))[:2, :2] @ P7
        for H in circle_intersections(P, L7, G8, L8) or []:
            psi7, psi8 = math.atan2(*(H - P)[::-1]), math.atan2(*(H - np.array(G8))[::-1])
            out.append({"crank": crank, "coupler": coupler, "link5": link5, "rocker": rocker, "link6": link6,
                        "link7": psi7 - psi5, "link8": psi8})
    return out


def test_three_loops_solved_one_after_another_assemble_at_the_hand_nearest():
    """Three loops (the Watt six-bar and a second dyad hung from its link 5): the loops are solved in turn (the
    four-bar, then each dyad from each closure before), and the closure equals the nearest of the hand closures
    over the crank's whole turn (a fine grid of the crank angle over the eight modes, refined by a bounded search
    on each). The second dyad closes over part of the six-bar's motion only (it folds: five branches, not eight):
    closures over the rest would lie on branches of their own, which the search for the other modes need not meet
    (a six-bar whose dyad closes over two separate ranges of the crank was called nearest 1.2 short of the hand
    nearest, probes round six), so it is not called the nearest, and the note says why."""
    system = watt_with_dyad().build()
    a = system.constraints.assembly()
    assert not a.nearest and a.where != NEAREST and a.dof == 1
    assert "loop 'H' closes over part of the motion of the loops solved before it only" in a.note
    names = system.coordinates

    def distances(t):
        return [float(np.linalg.norm(wrap([m[n] for n in names]))) for m in watt_with_dyad_branches(t)]

    def nearest(t):
        return min(distances(t), default=np.inf)

    grid = np.linspace(-np.pi, np.pi, 2001)
    d = [nearest(t) for t in grid]
    i = int(np.argmin(d))
    r = minimize_scalar(nearest, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 2000)]), method="bounded",
                        options={"xatol": 1e-12})
    x = system.difference(system.neutral(), a.q)
    crank = x[names.index("crank")]
    on = [np.abs(wrap(x - np.array([m[n] for n in names]))).max() for m in watt_with_dyad_branches(crank)]
    assert min(on) <= 1e-9  # on a hand assembly mode
    assert a.distance == pytest.approx(min(r.fun, min(d)), abs=1e-8)


def test_assembly_modes_sampled_not_enumerated_are_not_called_nearest(monkeypatch):
    """Where the restarts of a block of dependent coordinates are sampled (more combinations than PARTNER_MAX:
    forced here with PARTNER_MAX = 4 for the Watt six-bar's blocks of two), the closure is not called the nearest
    and the note says why; it is on a hand assembly mode, no nearer than the hand nearest."""
    monkeypatch.setattr(assembly_modes, "PARTNER_MAX", 4)
    system = watt(0.0).build()
    a = system.constraints.assembly()
    assert not a.nearest and a.where == "a closure found near the neutral configuration" and a.dof == 1
    assert "not proven the nearest" in a.note and "sampled (4 restarts" in a.note
    assert on_a_watt_mode(system, a.q, 0.0)
    assert a.distance >= watt_hand_nearest(0.0) - 1e-8


def test_restarts_solved_in_step_reach_what_each_reaches_alone():
    """The restarts of the other assembly modes run in step (one batched evaluation of the loops per iteration,
    each refused step's halvings tried at once) and each end where Gauss–Newton from it alone (:func:`_correct`,
    the scalar path) ends: the same closure, or none, for every restart of the Watt six-bar's two blocks, each
    from both closures of the first block; and among them the four hand modes at that crank angle."""
    system = watt(0.0).build()
    c = system.constraints
    q = c.assembly().q
    found = [q]
    for loops, cols in assembly_modes._fibres(c, q):
        combos, _ = assembly_modes._grid(c, cols)
        starts = []
        for p in found:
            for combo in [np.zeros(cols.size)] + combos:
                x = np.zeros(system.nv)
                x[cols] = combo
                starts.append(system.integrate(p, c.col_scale * x))
        iterations, opened = assembly_modes.PARTNER_ITER, assembly_modes.PARTNER_OPEN
        batch = close_many(LoopBatch(c, loops), starts, [0] * len(starts), cols, (iterations, opened), (-1.0, 0.0),
                           None)  # (no start dropped as converging to another)
        alone = [assembly._correct(c, p, cols, sum(iterations), (iterations[0], opened), loops) for p in starts]
        assert [b is None for b in batch] == [a is None for a in alone]
        assert all(np.abs(system.difference(a[0], b)).max() <= 1e-9 for a, b in zip(alone, batch) if a is not None)
        found = []
        for b in (b for b in batch if b is not None):
            if all(np.abs(wrap(system.difference(f, b))).max() > 1e-6 for f in found):
                found.append(b)
    assert len(found) == len(watt_branches(system.difference(system.neutral(), q)[0], 0.0)) == 4
    assert all(on_a_watt_mode(system, f, 0.0) for f in found)


@pytest.mark.parametrize("ground", [0.649, 0.6499])
def test_a_near_flat_four_bar_drawn_turned_slides_to_the_nearest_of_its_small_branches(tmp_path, ground):
    """Near flat (1 or 0.1 mm short) and drawn with its crank turned 0.4 rad, the four-bar closes only over a
    small range of crank angles, on two small branches curved more than a plain slide step: the assembly was
    taken at 3.0949 (3.1432) where the hand closure over both branches (a fine grid of that range refined by
    a bounded search) gives 3.0909 (3.1428). The slide's halved steps reach it."""
    phi_max = math.acos((A**2 + ground**2 - (B + C) ** 2) / (2 * A * ground))
    system = four_bar(tmp_path, 0.4, ground=ground).build()
    a = system.constraints.assembly()
    assert a.nearest and a.dof == 1
    best = np.inf
    for k in (0, 1):
        def distance(t):
            return float(np.linalg.norm(wrap(four_bar_branches(t, 0.4, d=ground)[k])))

        grid = np.linspace(-0.4 - phi_max * (1 - 1e-9), -0.4 + phi_max * (1 - 1e-9), 20001)
        i = int(np.argmin([distance(t) for t in grid]))
        r = minimize_scalar(distance, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 20000)]), method="bounded",
                            options={"xatol": 1e-13})
        best = min(best, float(r.fun))
    assert a.distance == pytest.approx(best, abs=1e-8)
    x = system.difference(system.neutral(), a.q)
    assert_on_a_branch(x, lambda t: four_bar_branches(t, 0.4, d=ground), np.ones(3), ALL, 1e-9)


@pytest.mark.parametrize("ground,rotation,was", [(0.12, 0.3, 0.98411), (0.62, 2.0, 3.18928), (0.62, 4.0, 3.33223)])
def test_four_bars_whose_slide_stopped_short_reach_the_hand_nearest(tmp_path, ground, rotation, was):
    """Ground 0.12 m (a crank longer than the ground: both links turn) or 0.62 m (just short of flat), drawn turned:
    the slide along the nearest branch stopped where a whole step went farther (at 0.98411, 3.18928, 3.33223)
    and called that the nearest; halving the step it reaches the hand nearest over both branches (a fine grid of
    the crank's turn refined by a bounded search)."""
    system = four_bar(tmp_path, rotation, ground=ground).build()
    a = system.constraints.assembly()
    assert a.nearest and a.dof == 1

    def branches(t):
        return four_bar_branches(t, rotation, d=ground)

    best = np.inf
    grid = np.linspace(-np.pi, np.pi, 40001)
    for k in (0, 1):
        def distance(t):
            b = branches(t)
            return np.inf if b is None else float(np.linalg.norm(wrap(b[k])))

        i = int(np.argmin([distance(t) for t in grid]))
        with np.errstate(invalid="ignore"):
            r = minimize_scalar(distance, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 40000)]), method="bounded",
                                options={"xatol": 1e-13})
        best = min(best, float(r.fun))
    assert best < was - 5e-5
    assert a.distance == pytest.approx(best, abs=1e-8)
    x = system.difference(system.neutral(), a.q)
    assert_on_a_branch(x, branches, np.ones(3), ALL, 1e-9)


def test_other_modes_of_closures_solving_different_coordinates_searched_together_are_those_of_each_alone():
    """The searches for the other assembly modes of several closures run in one batch, each start on its own
    block's coordinates (the Watt six-bar's four-bar solves its crank and rocker at one closure, its coupler and
    rocker at another: QR's choice there). Together they find what each finds alone, closed, with the
    coordinates left independent unchanged, and the four-bar's two modes times the dyad's two at each."""
    system = watt(0.0).build()
    c = system.constraints
    q1 = c.assembly().q
    samples = assembly._trace(c, q1, system.neutral())[0]
    cols = [tuple(x) for _, x in assembly_modes._fibres(c, q1)]
    q2 = next(q for q in samples if [tuple(x) for _, x in assembly_modes._fibres(c, q)] != cols)
    together = assembly_modes.partners(c, [q1, q2], system.neutral())
    for q, (found, complete, _, _) in zip([q1, q2], together):
        (alone, whole, _, _), = assembly_modes.partners(c, [q], system.neutral())
        assert complete and whole and len(found) == len(alone) == 3
        assert all(np.abs(system.difference(a, b)).max() <= 1e-12 for a, b in zip(alone, found))
        free = np.setdiff1d(np.arange(system.nv), np.concatenate([x for _, x in assembly_modes._fibres(c, q)]))
        for p in found:
            assert np.abs(c.scaled_phi(c.phi(p))).max() <= ASSEMBLY_TOL
            assert np.abs(system.difference(q, p)[free]).max() <= 1e-12
