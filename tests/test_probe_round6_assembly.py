"""Issue 40 probes round six (closed loops, assembly): the closure called "the closure nearest the neutral
configuration" (``Assembly.nearest``) checked against an independent hand oracle. Planar linkages of random
(seeded) lengths and drawing rotations; the oracle enumerates every hand closure (circle intersections: each
assembly mode of the four-bar, slider-crank, Watt and Stephenson six-bars) on a dense grid of the crank angle
and refines each mode's best points (a bounded scalar search on the crank angle, and SLSQP on all coordinates
subject to the hand loop equations, which reaches minima at the turning points of a mode). Distance as the docs
define it: each angle wrapped within π of the drawn one (0), translations over the length scale."""

import math

import numpy as np
import pytest
from scipy.optimize import minimize, minimize_scalar
from test_branches import circle_intersections  # (the points at r1 from P and r2 from Q, or None)

import vibdyn as vd

I3 = np.diag([1e-5, 1e-3, 1e-3])
FOUR, SIX = ["crank", "coupler", "rocker"], ["crank", "coupler", "rocker", "link5", "link6"]


def rz(t):
    return np.array([[math.cos(t), -math.sin(t), 0.0], [math.sin(t), math.cos(t), 0.0], [0.0, 0.0, 1.0]])


def e(t):
    return np.array([math.cos(t), math.sin(t)])


def wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def ang(v):
    return math.atan2(v[1], v[0])


def four_bar(p):
    """Crank (drawn turned al) on the ground origin, coupler (turned be) at its tip, rocker (turned ga) at (d, 0);
    the loop joins the coupler's tip (b) to the rocker's (c), drawn open."""
    s = vd.Scene("four_bar_random", gravity=(0, -9.81, 0))
    s.add_body("crank", joint=vd.Pivot((0, 0, 1), rotation=rz(p["al"])), mass=1.0, com=(p["a"] / 2, 0, 0), inertia=I3)
    s.add_body("coupler", parent="crank", joint=vd.Pivot((0, 0, 1), at=(p["a"], 0, 0), rotation=rz(p["be"])),
               mass=0.5, com=(p["b"] / 2, 0, 0), inertia=I3)
    s.add_body("rocker", joint=vd.Pivot((0, 0, 1), at=(p["d"], 0, 0), rotation=rz(p["ga"])), mass=0.8,
               com=(p["c"] / 2, 0, 0), inertia=I3)
    s.add_loop("C", ("coupler", (p["b"], 0, 0)), ("rocker", (p["c"], 0, 0)), joint=vd.Pivot((0, 0, 1)))
    return s


def four_bar_modes(t, p):
    """Hand closure: (crank, coupler, rocker) of the four-bar's two assembly modes with the crank at t."""
    phi = p["al"] + t
    Bp, Dp = p["a"] * e(phi), np.array([p["d"], 0.0])
    pts = circle_intersections(Bp, p["b"], Dp, p["c"])
    if pts is None:
        return [None, None]
    return [np.array([t, ang(C - Bp) - phi - p["be"], ang(C - Dp) - p["ga"]]) for C in pts]


def four_bar_phi(x, p):
    phi1 = p["al"] + x[0]
    return (p["a"] * e(phi1) + p["b"] * e(phi1 + p["be"] + x[1]) - np.array([p["d"], 0]) - p["c"] * e(p["ga"] + x[2]))


def slider_crank(p):
    """Crank (turned al), rod (turned be) of length L, piston sliding along the direction de through (x0, y0)."""
    s = vd.Scene("slider_crank_random", gravity=(0, -9.81, 0))
    s.add_body("crank", joint=vd.Pivot((0, 0, 1), rotation=rz(p["al"])), mass=1.0, com=(p["r"] / 2, 0, 0), inertia=I3)
    s.add_body("rod", parent="crank", joint=vd.Pivot((0, 0, 1), at=(p["r"], 0, 0), rotation=rz(p["be"])), mass=0.5,
               com=(p["L"] / 2, 0, 0), inertia=I3)
    s.add_body("piston", joint=vd.Slider((*e(p["de"]), 0), at=(p["x0"], p["y0"], 0)), mass=2.0)
    s.add_loop("pin", ("rod", (p["L"], 0, 0)), ("piston", (0, 0, 0)), joint=vd.Pivot((0, 0, 1)))
    return s


def slider_crank_modes(t, p):
    """Hand closure: (crank, rod, piston) of both modes: the pin where the rod's circle meets the slider's line."""
    phi = p["al"] + t
    Bp, u, p0 = p["r"] * e(phi), e(p["de"]), np.array([p["x0"], p["y0"]])
    w = Bp - p0
    h2 = p["L"] ** 2 - (w @ w - (u @ w) ** 2)
    if h2 < 0:
        return [None, None]
    out = []
    for sg in (1.0, -1.0):
        s = u @ w + sg * math.sqrt(h2)
        out.append(np.array([t, ang(p0 + s * u - Bp) - phi - p["be"], s]))
    return out


def slider_crank_phi(x, p):
    phi1 = p["al"] + x[0]
    return p["r"] * e(phi1) + p["L"] * e(phi1 + p["be"] + x[1]) - np.array([p["x0"], p["y0"]]) - x[2] * e(p["de"])


def six_bar(p, stephenson=False):
    """The four-bar with a dyad: link 5 (turned b5, length l5) pivoted on the coupler at E3, link 6 (turned b6,
    length l6) pivoted at F4 on the rocker (Watt I) or on the ground (Stephenson III); their tips joined."""
    s = four_bar(p)
    s.add_body("link5", parent="coupler", joint=vd.Pivot((0, 0, 1), at=(*p["E3"], 0), rotation=rz(p["b5"])), mass=0.3,
               com=(p["l5"] / 2, 0, 0), inertia=I3)
    parent = {} if stephenson else {"parent": "rocker"}
    s.add_body("link6", **parent, joint=vd.Pivot((0, 0, 1), at=(*p["F4"], 0), rotation=rz(p["b6"])), mass=0.3,
               com=(p["l6"] / 2, 0, 0), inertia=I3)
    s.add_loop("G", ("link5", (p["l5"], 0, 0)), ("link6", (p["l6"], 0, 0)), joint=vd.Pivot((0, 0, 1)))
    return s


def _dyad_ends(x, p, stephenson):
    phi1 = p["al"] + x[0]
    psi3, phi3 = phi1 + p["be"] + x[1], p["ga"] + x[2]
    E = p["a"] * e(phi1) + rz(psi3)[:2, :2] @ p["E3"]
    if stephenson:
        return E, psi3, np.asarray(p["F4"], float), 0.0
    return E, psi3, np.array([p["d"], 0.0]) + rz(phi3)[:2, :2] @ p["F4"], phi3


def six_bar_modes(t, p, stephenson=False):
    """Hand closure: (crank, coupler, rocker, link5, link6) of the four modes (four-bar's i, dyad's j)."""
    out = []
    for x in four_bar_modes(t, p):
        E, psi3, F, base6 = _dyad_ends(x, p, stephenson) if x is not None else (None,) * 4
        G = None if x is None else circle_intersections(E, p["l5"], F, p["l6"])
        for j in (0, 1):
            if G is None:
                out.append(None)
                continue
            out.append(np.array([*x, ang(G[j] - E) - psi3 - p["b5"], ang(G[j] - F) - base6 - p["b6"]]))
    return out


def six_bar_phi(x, p, stephenson=False):
    E, psi3, F, base6 = _dyad_ends(x, p, stephenson)
    r2 = E + p["l5"] * e(psi3 + p["b5"] + x[3]) - F - p["l6"] * e(base6 + p["b6"] + x[4])
    return np.concatenate([four_bar_phi(x[:3], p), r2])


def hand_nearest(modes, phi, angles, scale, n=4000):
    """Distance of the hand closure nearest the drawn pose: every mode on a grid of n crank angles, its grid
    local minima and the ends of its closing ranges (turning points beside them) refined by a bounded scalar
    search on the crank angle and by SLSQP on all coordinates under the hand loop equations."""
    grid = np.linspace(-np.pi, np.pi, n, endpoint=False)
    h = grid[1] - grid[0]

    def dist(x):
        return float(np.linalg.norm(np.where(angles, wrap(x), x) / scale))

    table = [modes(t) for t in grid]
    best, cands = np.inf, []
    for k in range(len(table[0])):
        d = np.array([np.inf if m[k] is None else dist(m[k]) for m in table])
        left, right = np.roll(d, 1), np.roll(d, -1)
        pick = np.isfinite(d) & (((d <= left) & (d <= right)) | ~np.isfinite(left) | ~np.isfinite(right))
        cands += [(d[i], k, i) for i in np.flatnonzero(pick)]
    cands.sort()
    for d0, k, i in cands:
        best = min(best, d0)
        if d0 > cands[0][0] + 0.05:
            break
        r = minimize_scalar(lambda t: 1e3 if modes(t)[k] is None else dist(modes(t)[k]),
                            bounds=(grid[i] - h, grid[i] + h), method="bounded", options={"xatol": 1e-13})
        best = min(best, float(r.fun))
        x0 = np.where(angles, wrap(table[i][k]), table[i][k])
        res = minimize(lambda x: float(np.sum((x / scale) ** 2)), x0, jac=lambda x: 2 * x / scale**2,
                       constraints=[{"type": "eq", "fun": phi}], method="SLSQP",
                       options={"ftol": 1e-15, "maxiter": 500})
        if np.abs(phi(res.x)).max() < 1e-11:
            best = min(best, dist(res.x))
    return best


def check(scene, modes, phi, names, angles, n=4000):
    """(assembly, hand nearest distance): the assembly's closure lies on a hand mode at its own crank angle and
    its distance is the wrapped one."""
    system = scene.build()
    a = system.constraints.assembly()
    perm = [list(system.coordinates).index(n) for n in names]
    scale = np.asarray(system.constraints.col_scale)[perm]
    x = np.asarray(system.difference(system.neutral(), a.q))[perm]
    assert a.distance == pytest.approx(float(np.linalg.norm(np.where(angles, wrap(x), x) / scale)), abs=1e-12)
    gaps = [np.abs(np.where(angles, wrap(x - m), x - m) / scale).max() for m in modes(x[0]) if m is not None]
    assert min(gaps) <= 1e-7
    return a, hand_nearest(modes, phi, angles, scale, n)


def random_four_bar(rng):
    a, b, c, d = rng.uniform(0.05, 0.5, 4)
    return dict(a=a, b=b, c=c, d=d, al=rng.uniform(-np.pi, 2 * np.pi), be=rng.uniform(-np.pi, np.pi),
                ga=rng.uniform(-np.pi, np.pi))


def closes(modes):
    return any(m is not None for t in np.linspace(-np.pi, np.pi, 721) for m in modes(t))


@pytest.mark.parametrize("seed", [3, 8])
def test_random_four_bars_drawn_turned_assemble_at_the_hand_nearest(seed):
    """Four-bars of random lengths (Grashof or not), every joint drawn turned: proven nearest, at the hand
    nearest over both modes (in the probe: 160 such four-bars, none wrong)."""
    rng = np.random.default_rng(seed)
    done = 0
    while done < 3:
        p = random_four_bar(rng)
        if not closes(lambda t: four_bar_modes(t, p)):
            continue
        a, hand = check(four_bar(p), lambda t: four_bar_modes(t, p), lambda x: four_bar_phi(x, p), FOUR,
                        np.ones(3, bool))
        assert a.nearest and a.dof == 1
        assert a.distance == pytest.approx(hand, abs=1e-8)
        done += 1


def test_random_slider_cranks_assemble_at_the_hand_nearest():
    """Slider-cranks of random crank, rod, slider line (offset and direction) and drawing angles: proven
    nearest, at the hand nearest (the piston's offset over the length scale)."""
    rng = np.random.default_rng(14)
    done = 0
    while done < 3:
        r, L = rng.uniform(0.05, 0.4, 2)
        p = dict(r=r, L=L, x0=rng.uniform(-0.5, 0.5), y0=rng.uniform(-0.3, 0.3), de=rng.uniform(-np.pi, np.pi),
                 al=rng.uniform(-np.pi, np.pi), be=rng.uniform(-np.pi, np.pi))
        if not closes(lambda t: slider_crank_modes(t, p)):
            continue
        a, hand = check(slider_crank(p), lambda t: slider_crank_modes(t, p), lambda x: slider_crank_phi(x, p),
                        ["crank", "rod", "piston"], np.array([True, True, False]))
        assert a.nearest and a.dof == 1
        assert a.distance == pytest.approx(hand, abs=1e-8)
        done += 1


@pytest.mark.parametrize("stephenson", [False, True])
def test_six_bars_whose_modes_share_the_cranks_range_assemble_at_the_hand_nearest(stephenson):
    """A Watt I and a Stephenson III six-bar (the bundled four-bar drawn turned, with a dyad whose modes the search
    for the other modes meets): at the hand nearest of the four modes. The Stephenson's is proven the nearest; the
    Watt's dyad folds along one of its three branches (it closes over part of the four-bar's motion only), so its
    closure is not called the nearest, and the note says why."""
    p = {"watt": dict(a=0.1, b=0.3, c=0.25, d=0.3, al=0.7, be=0.0, ga=0.0, E3=np.array([0.15, 0.05]),
                      F4=np.array([0.125, -0.05]), l5=0.22, l6=0.18, b5=0.4, b6=-1.0),
         "steph": dict(a=0.1, b=0.3, c=0.25, d=0.3, al=2.0, be=0.3, ga=0.0, E3=np.array([0.1, 0.08]),
                       F4=np.array([0.15, 0.3]), l5=0.2, l6=0.2, b5=0.0, b6=0.5)}["steph" if stephenson else "watt"]
    a, hand = check(six_bar(p, stephenson), lambda t: six_bar_modes(t, p, stephenson),
                    lambda x: six_bar_phi(x, p, stephenson), SIX, np.ones(5, bool))
    assert a.nearest == stephenson and a.dof == 1
    assert stephenson or "loop 'G' closes over part of the motion of the loops solved before it only" in a.note
    assert a.distance == pytest.approx(hand, abs=1e-8)


def watt_case(**kw):
    p = dict(be=0.0, ga=0.0, b5=0.0, b6=0.0)
    p.update(kw)
    p["E3"], p["F4"] = np.array(p["E3"]), np.array(p["F4"])
    return p


def test_a_watt_six_bar_whose_closures_are_separate_curves_is_not_called_nearest_short_of_the_hand_nearest():
    """Watt I, crank drawn turned -2.169 rad: the four-bar's second mode carries the dyad over one range of the
    crank only (0.36 of its turn), a closed curve of its own that the search for the other modes (at two points
    of each branch and beside the nearest candidate) never meets. The assembly said nearest at 3.8012 (also at
    9b7d8c9), where the hand nearest is 2.6029 (on that curve). The dyad does not close from the four-bar's other
    mode where it was sought: the closure is not called the nearest."""
    p = watt_case(a=0.056, b=0.194, c=0.198, d=0.183, al=-2.169, E3=[0.128, -0.178], F4=[-0.067, 0.208], l5=0.358,
                  l6=0.16)
    a, hand = check(six_bar(p), lambda t: six_bar_modes(t, p), lambda x: six_bar_phi(x, p), SIX, np.ones(5, bool))
    assert hand == pytest.approx(2.6029255636, abs=1e-6)
    assert not a.nearest or a.distance <= hand + 1e-8


def test_a_watt_six_bar_nearest_on_a_curve_met_only_at_a_branchs_minimum_is_found():
    """Watt I with every joint drawn turned: the hand nearest (2.7604) lies on a curve the search for the other
    modes met from a branch's local minimum (9b7d8c9 took it), which the two spread points miss: 61f6f11 said
    nearest at 3.8269. The dyad closes over part of the four-bar's motion only: not called the nearest."""
    p = watt_case(a=0.317, b=0.196, c=0.179, d=0.329, al=2.681, be=2.63, ga=0.789, E3=[0.083, -0.192],
                  F4=[0.13, 0.239], l5=0.274, l6=0.232, b5=3.102, b6=1.767)
    a, hand = check(six_bar(p), lambda t: six_bar_modes(t, p), lambda x: six_bar_phi(x, p), SIX, np.ones(5, bool))
    assert hand == pytest.approx(2.7603586561, abs=1e-6)
    assert not a.nearest or a.distance <= hand + 1e-8


def test_a_four_bar_very_near_flat_slides_to_the_hand_nearest_of_its_small_branch():
    """Ground 0.83297965 m, 2.4e-5 of a + b + c short of flat: the closures form one small closed curve (a few
    mrad of crank) traced in 8 samples; the sample taken as its nearest was not slid on to the nearest point
    between it and the next (3.87624 called nearest, also at 9b7d8c9; hand: the crank's closing range on a fine
    grid, refined, 3.87457): the slide's step, halved only 6 times, stayed larger than the curve. It is halved
    down to a millionth now."""
    p = dict(a=0.283, b=0.363, c=0.187, d=0.83297965, al=3.992, be=0.0, ga=0.0)
    a, hand = check(four_bar(p), lambda t: four_bar_modes(t, p), lambda x: four_bar_phi(x, p), FOUR, np.ones(3, bool),
                    20000)
    assert hand == pytest.approx(3.8745659452, abs=1e-6)
    assert not a.nearest or a.distance <= hand + 1e-8
