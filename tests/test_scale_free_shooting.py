"""Shooting does not depend on where the scene sits (issue 40, item 11): a slider at the origin (a scene with no
length scale: 1 mm) and the same slider 1 m away converge alike, against an independent scipy shooting.

Ueda's oscillator x'' + 0.1 x' + x³ = B cos t (B = 7.5) and a forced Rayleigh oscillator
x'' − μ(1 − x'²) x' + x = F cos Ωt (μ = 0.2, F = 0.5, Ω = 1.1): the orbit and its multipliers by solve_ivp
(DOP853, rtol 1e-13) with the variational equations, Newton on x(T) − x(0)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import vibdyn as vd
from vibdyn.simulation import flow as flow_module

B, C = 7.5, 0.1
MU, F, OMEGA = 0.2, 0.5, 1.1


def ueda(at):
    s = vd.Scene("ueda")
    s.add_body("x", joint=vd.Slider((1, 0, 0), at=(at, 0, 0)), mass=1.0)
    s.add_cubic_joint_spring("x", 1.0)
    s.add_joint_damper("x", C)
    s.add_joint_force("x", vd.laws.Harmonic(B, 1.0, phase=math.pi / 2))  # B sin(t + π/2) = B cos t
    return s.build()


def rayleigh(at):
    s = vd.Scene("rayleigh")
    s.add_body("x", joint=vd.Slider((1, 0, 0), at=(at, 0, 0)), mass=1.0)
    s.add_joint_spring("x", 1.0)
    s.add_joint_force("x", lambda t, q, v: MU * (1 - v * v) * v, velocity_dependent=True, time_dependent=False)
    s.add_joint_force("x", vd.laws.Harmonic(F, OMEGA, phase=math.pi / 2), name="drive")
    return s.build()


def scipy_shooting(f, dfdx, dfdv, period, start):
    """(x0, v0) of the orbit and its monodromy: an independent single shooting of x'' = f(t, x, v)."""
    def rhs(t, y):
        x, v = y[0], y[1]
        A = np.array([[0.0, 1.0], [dfdx(t, x, v), dfdv(t, x, v)]])
        return np.concatenate([[v, f(t, x, v)], (A @ y[2:].reshape(2, 2)).ravel()])

    z = np.array(start, dtype=float)
    for _ in range(30):
        y = solve_ivp(rhs, (0.0, period), np.concatenate([z, np.eye(2).ravel()]), method="DOP853", rtol=1e-13,
                      atol=1e-15).y[:, -1]
        P, r = y[2:].reshape(2, 2), y[:2] - z
        if np.abs(r).max() < 1e-13:
            return z, P
        z = z - np.linalg.solve(P - np.eye(2), r)
    raise AssertionError("the reference shooting did not converge")


CASES = {
    "ueda": (ueda, 2 * math.pi, (3.1567, 0.6356),
             (lambda t, x, v: B * math.cos(t) - C * v - x**3, lambda t, x, v: -3 * x * x, lambda t, x, v: -C)),
    "rayleigh": (rayleigh, 2 * math.pi / OMEGA, (-1.0701, 1.2638),
                 (lambda t, x, v: F * math.cos(OMEGA * t) + MU * (1 - v * v) * v - x, lambda t, x, v: -1.0,
                  lambda t, x, v: MU * (1 - 3 * v * v))),
}


def counted(monkeypatch, system, start, period):
    """The orbit and the right-hand-side evaluations of every flow the shooting integrated."""
    calls = []
    real = flow_module.Flow.__call__

    def call(self, *args, **kwargs):
        out = real(self, *args, **kwargs)
        calls.append(out.nfev)
        return out

    monkeypatch.setattr(flow_module.Flow, "__call__", call)
    orbit = vd.periodic_orbit(system, [start[0]], [start[1]], period)
    monkeypatch.setattr(flow_module.Flow, "__call__", real)
    return orbit, calls


@pytest.mark.parametrize("name", CASES)
@pytest.mark.parametrize("start", ["near", "rest"])
def test_a_slider_at_the_origin_shoots_as_one_a_metre_away(monkeypatch, name, start):
    """Same Newton iterations, same flows, about the same steps (they were 65 × more at the origin: the flows'
    step bound took the slider's speed over the 1 mm length scale for a frequency)."""
    make, period, near, _ = CASES[name]
    x0 = near if start == "near" else (0.0, 0.0)
    shifted, n_shifted = counted(monkeypatch, make(1.0), x0, period)
    origin, n_origin = counted(monkeypatch, make(0.0), x0, period)
    assert origin.iterations == shifted.iterations and len(n_origin) == len(n_shifted)
    assert sum(n_origin) <= 1.25 * sum(n_shifted)
    assert abs(origin.q0[0] - shifted.q0[0]) <= origin.error + shifted.error


@pytest.mark.parametrize("name", CASES)
@pytest.mark.parametrize("at", [0.0, 1.0])
def test_orbit_and_multipliers_against_scipy_shooting(name, at):
    """The orbit within its stated errors; each multiplier within its stated uncertainty, which tracks the largest
    actual error within about a decade (it stated 80 × the error of Ueda's, and at the origin the Rayleigh
    oscillator's user callable was differenced with steps of 1e-9 m/s: its multipliers were 2e-8 off)."""
    make, period, near, (f, dfdx, dfdv) = CASES[name]
    z, P = scipy_shooting(f, dfdx, dfdv, period, near)
    orbit = vd.periodic_orbit(make(at), [near[0]], [near[1]], period)
    assert abs(orbit.q0[0] - z[0]) <= orbit.error + 1e-12
    assert abs(orbit.v0[0] - z[1]) <= orbit.velocity_error + 1e-12
    exact = np.linalg.eigvals(P)
    exact = exact[np.argsort(-np.abs(exact))]
    err = np.abs(orbit.multipliers - exact)
    reference = 1e-12  # (the reference's own error: rtol 1e-13 over a period)
    assert np.all(err <= orbit.multiplier_error + reference)
    assert orbit.multiplier_error.max() <= 20 * max(err.max(), reference)


def test_a_unit_at_rest_on_the_orbit_keeps_its_scale():
    """The shaken pendulum held upright (an exact orbit of the forced scene: the pendulum never moves, the cart
    does): the flows' scale of the pendulum is its own 1 rad, not the round-off it "moves" by in a run (rtol of
    1e-17 rad made the Kapitza example's flows take hours), while the moving cart keeps its motion's size."""
    from types import SimpleNamespace

    from vibdyn.analysis.nonlinear.shooting import flow_scales

    system = vd.load_scene("shaken_pendulum").build()
    t = np.linspace(0.0, 0.09, 50)
    cart, pend = system.coordinate_index("cart"), system.coordinate_index("pend")
    q = np.array([system.configuration([0.01 * np.sin(70 * s), np.pi]) for s in t])
    q[:, system.body_info("pend").idx_q] += 1e-17 * np.cos(3 * t)  # (round-off)
    v = np.zeros((t.size, system.nv))
    v[:, cart] = 0.7 * np.cos(70 * t)
    scales = flow_scales(system, SimpleNamespace(t=t, q=q, v=v), 70.0, relative=False)
    assert scales[pend] == system.coordinate_scales[pend]
    assert scales[cart] == pytest.approx(0.01, rel=1e-3)
