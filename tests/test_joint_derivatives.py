"""Trust in Pinocchio's analytic derivatives, per joint type (issue 32): each type in ``JOINT_TYPES`` declares
(``analytic_derivatives``) whether ``computeRNEADerivatives`` and ``computeABADerivatives`` are right for it,
and the declaration is checked against converged central differences of ``rnea`` and ``aba`` below a moving
parent. Where they are wrong (Pinocchio 4.1's universal joint), vibdyn differences those columns: its analytic
linearisation, rows and variational equations agree with finite differences and with the conical pendulum's
closed-form Floquet multipliers. Tolerances: each difference's own estimate (|D(h) − D(2h)| and round-off)."""

import math

import numpy as np
import pinocchio as pin
import pytest

import vibdyn as vd
from vibdyn.analysis import linearize as linearize_module
from vibdyn.defaults import EPS
from vibdyn.description.joints import JOINT_TYPES
from vibdyn.model.derivatives import analytic_derivatives, analytic_derivatives_rows, linear_terms

G = 9.81
SKEW = tuple(np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8]))
SKEW2 = tuple(np.cross(SKEW, (1.0, 0, 0)) / np.linalg.norm(np.cross(SKEW, (1.0, 0, 0))))
# joints whose defaults cannot make one (a helical joint needs a pitch), and a second example on a skew axis
# (Pinocchio specialises x, y, z axes: another joint model)
EXAMPLES = {"helical": [vd.Helical((0, 0, 1), 0.05), vd.Helical(SKEW, 0.05)],
            "pivot": [vd.Pivot(), vd.Pivot(SKEW)], "slider": [vd.Slider(), vd.Slider(SKEW)],
            "cylindrical": [vd.Cylindrical(SKEW)], "universal": [vd.Universal(), vd.Universal(SKEW, SKEW2)],
            "planar": [vd.Planar(), vd.Planar(SKEW)]}
TYPES = [kind for kind, cls in JOINT_TYPES.items() if cls().nv]  # (a weld has no coordinate, no column)


def random_body(rng, scene, name, parent, joint):
    """A body of random mass, centre of mass and inertia (principal moments 0.5 to 1 kg·m², turned)."""
    R = pin.exp3(rng.normal(size=3))
    scene.add_body(name, parent, joint, mass=1.0 + rng.random(), com=tuple(rng.normal(size=3) * 0.3),
                   inertia=R @ np.diag(rng.uniform(0.5, 1.0, 3)) @ R.T)


def scene_with(joint, parent, rng):
    """The joint under test between a moving parent (a pivot, or a free body) and a child on a skew pivot."""
    s = vd.Scene("under test", gravity=(0.3, -1.0, -G))
    random_body(rng, s, "parent", "world", parent)
    at, rot = tuple(rng.normal(size=3) * 0.3), tuple(rng.normal(size=3))
    placed = type(joint)(**{**joint.params(), "at": at, "rotation": rot})
    random_body(rng, s, "body", "parent", placed)
    random_body(rng, s, "child", "body", vd.Pivot(SKEW, at=(0.1, -0.2, 0.3)))
    return s.build()


def differences(f, x0, step, h):
    """(D, error) of ∂f/∂x at x0 by central differences (x moved by ``step(x0, s·h e_k)``): D(h), and its
    error estimate |D(h) − D(2h)| + round-off 16ε·max|f|/h per entry."""
    n = len(h)
    cols, T, size = [], [], 0.0
    for k in range(n):
        e = np.zeros(n)
        r = {}
        for s in (1, 2, -1, -2):
            e[k] = s * h[k]
            r[s] = f(step(x0, e))
            size = max(size, float(np.max(np.abs(r[s]))))
        D1, D2 = (r[1] - r[-1]) / (2 * h[k]), (r[2] - r[-2]) / (4 * h[k])
        cols.append(D1)
        T.append(np.abs(D1 - D2) + 16 * EPS * size / h[k])
    return np.column_stack(cols), np.column_stack(T)


def agrees(analytic, D, err):
    return bool(np.all(np.abs(analytic - D) <= 10 * err))


@pytest.mark.parametrize("kind", TYPES)
def test_declared_trust_in_pinocchio_derivatives_matches_central_differences(kind):
    """At three random states (q, v, a, external forces) below a pivot and below a free body, Pinocchio's RNEA
    and ABA derivatives agree with central differences of rnea and aba within the differences' estimate for a
    joint type declared right, and disagree somewhere for one declared wrong."""
    declared = JOINT_TYPES[kind].analytic_derivatives
    found = []
    rng = np.random.default_rng(sum(map(ord, kind)))
    for joint in EXAMPLES.get(kind, [JOINT_TYPES[kind]()]):
        for parent in (vd.Pivot((0, 1, 0)), vd.Free()):
            system = scene_with(joint, parent, rng)
            model, data = system.model, system.model.createData()
            for _ in range(3):
                q = pin.integrate(model, pin.neutral(model), rng.normal(size=model.nv))
                v, a = rng.normal(size=(2, model.nv))
                fext = pin.StdVec_Force()
                for _ in range(model.njoints):
                    fext.append(pin.Force(rng.normal(size=6)))
                h = np.full(model.nv, 1e-5)

                def moved(q0, dq):
                    return pin.integrate(model, q0, dq)

                def added(v0, dv):
                    return v0 + dv

                dtau = [x.copy() for x in pin.computeRNEADerivatives(model, data, q, v, a, fext)[:2]]
                ddq = [x.copy() for x in pin.computeABADerivatives(model, data, q, v, a, fext)[:2]]
                Kq = differences(lambda x: pin.rnea(model, data, x, v, a, fext), q, moved, h)
                Kv = differences(lambda x: pin.rnea(model, data, q, x, a, fext), v, added, h)
                Aq = differences(lambda x: pin.aba(model, data, x, v, a, fext), q, moved, h)
                Av = differences(lambda x: pin.aba(model, data, q, x, a, fext), v, added, h)
                found.append((agrees(dtau[0], *Kq) and agrees(dtau[1], *Kv),
                              agrees(ddq[0], *Aq) and agrees(ddq[1], *Av)))
    rnea_right, aba_right = all(f[0] for f in found), all(f[1] for f in found)
    assert rnea_right == declared, f"{kind}: Pinocchio's RNEA derivatives are {'right' if rnea_right else 'wrong'}"
    assert aba_right == declared, f"{kind}: Pinocchio's ABA derivatives are {'right' if aba_right else 'wrong'}"


# --------------------------------------------------------------------------------- vibdyn's own derivatives
def universal_chain():
    """A universal joint below a pivot, above a slider, with point springs and a damper (forces through RNEA's
    external forces: the chain rule around the differenced columns)."""
    s = vd.Scene("cardan chain", gravity=(0.3, -1.0, -G))
    s.add_body("arm", joint=vd.Pivot((0, 1, 0)), mass=2.0, com=(0.3, 0, 0), inertia=vd.inertia.sphere(2.0, 0.1))
    s.add_body("cardan", "arm", vd.Universal((1, 0, 0), (0, 1, 0), at=(0.5, 0, 0)), mass=1.0,
               com=(0.1, 0.05, -0.6), inertia=vd.inertia.box(1.0, (0.1, 0.2, 0.3)))
    s.add_body("slide", "cardan", vd.Slider((0, 0, 1), at=(0, 0, -0.5)), mass=0.5,
               inertia=vd.inertia.sphere(0.5, 0.05))
    s.add_spring("k", ("world", (0.4, 0.3, -1.0)), ("slide", (0.02, 0, 0)), stiffness=300.0, free_length=0.2)
    s.add_damper("c", ("world", (-0.2, 0.3, 0.0)), ("cardan", (0.0, 0.05, -0.3)), damping=2.0)
    s.add_joint_spring("slide", 80.0)
    return s.build()


@pytest.mark.parametrize("moving", [False, True])
def test_analytic_linearisation_of_a_universal_joint_equals_fd(moving):
    system = universal_chain()
    rng = np.random.default_rng(4)
    q = system.integrate(system.neutral(), 0.5 * rng.normal(size=system.nv))
    v = rng.normal(size=system.nv) if moving else None
    an, fd = system.linearize(q, v=v, method="analytic"), system.linearize(q, v=v, method="fd")
    assert an.method == "analytic"
    assert np.all(np.abs(an.K - fd.K) <= an.K_error + fd.K_error)
    assert np.all(np.abs(an.C - fd.C) <= an.C_error + fd.C_error)
    assert an.relative_error < 1e-6 and np.abs(an.K).max() > 1.0


def test_rows_and_linear_terms_of_a_universal_joint_equal_fd():
    """analytic_derivatives_rows (harmonic balance) and linear_terms (the integrators' Newton iterations and
    variational equations) difference the same columns: equal to the linear model's FD K and C."""
    system = universal_chain()
    rng = np.random.default_rng(6)
    Q = np.array([system.integrate(system.neutral(), 0.4 * rng.normal(size=system.nv)) for _ in range(3)])
    V, A = rng.normal(size=(2, 3, system.nv))
    Kr, Cr = analytic_derivatives_rows(system, Q, V, A, 0.0)
    for c in range(3):
        fd = system.linearize(Q[c], v=V[c], a=A[c])
        assert np.all(np.abs(Kr[c] - fd.K) <= 2 * fd.K_error)
        assert np.all(np.abs(Cr[c] - fd.C) <= 2 * fd.C_error)
        K, C = analytic_derivatives(system, Q[c], V[c], A[c], 0.0)[:2]
        np.testing.assert_array_equal(K, Kr[c])
        M, K, C = linear_terms(system, Q[c], V[c], 0.0)
        free = system.linearize(Q[c], v=V[c])  # about the free acceleration, as linear_terms
        assert np.all(np.abs(K - free.K) <= 2 * free.K_error)
        assert np.all(np.abs(C - free.C) <= 2 * free.C_error)


def test_guard_catches_a_joint_type_wrongly_declared_right(monkeypatch):
    """A universal joint declared right: the analytic K is Pinocchio's, wrong by O(1); the guard's central
    differences along a random direction catch it, warn, and the linear model is the FD one."""
    monkeypatch.setattr(vd.Universal, "analytic_derivatives", True)
    system = universal_chain()
    q = system.integrate(system.neutral(), np.array([0.3, -0.4, 0.5, 0.02]))
    with pytest.warns(UserWarning, match="disagree with central differences.*universal"):
        lin = system.linearize(q, method="analytic")
    fd = system.linearize(q, method="fd")
    assert lin.method == "fd"
    np.testing.assert_array_equal(lin.K, fd.K)


def test_guard_sees_every_column(monkeypatch):
    """An error in any one entry of K or C, 1e3 × the largest entry of the analytic model's estimate, makes the
    guard refuse (its direction weighs every coordinate by 1/2 to 1 of its step; it sees 585 to 1570 × its
    estimate here, against the 10 × it refuses beyond)."""
    system = universal_chain()
    rng = np.random.default_rng(2)
    q, v = system.integrate(system.neutral(), 0.3 * rng.normal(size=system.nv)), rng.normal(size=system.nv)
    good = system.linearize(q, v=v, method="analytic")
    real = linearize_module.analytic_derivatives
    for name, i, j in (("K", 0, 1), ("K", 3, 2), ("C", 2, 0), ("C", 1, 3)):
        X_err = good.K_error if name == "K" else good.C_error
        bump = 1e3 * max(X_err.max(), 1e-9 * np.abs(good.K).max())

        def wrong(*args, _n=name, _i=i, _j=j, _b=bump, **kwargs):
            out = real(*args, **kwargs)
            out[0 if _n == "K" else 1][_i, _j] += _b
            return out

        monkeypatch.setattr(linearize_module, "analytic_derivatives", wrong)
        with pytest.warns(UserWarning, match="disagree"):  # (a new system: the guard checks each one once)
            assert universal_chain().linearize(q, v=v, method="analytic").method == "fd"
    monkeypatch.setattr(linearize_module, "analytic_derivatives", real)
    assert universal_chain().linearize(q, v=v, method="analytic").method == "analytic"


def test_guard_runs_once_per_system_and_kind_of_state():
    """The guard checks formulas: the first analytic linearisation of a system at rest and the first moving
    one pay its evaluations (4 states), the later ones not."""
    system, q, v, _ = conical(30)  # (no damper: at rest, C is not checked)
    assert not system.depends_on_velocity
    first, again = (system.linearize(q, method="analytic").evaluations for _ in range(2))
    assert first == again + 4
    first, again = (system.linearize(q, v=v, method="analytic").evaluations for _ in range(2))
    assert first == again + 4


# ------------------------------------------------------------------- conical pendulum on a universal joint
def conical(deg):
    """A point mass at L = 1 m on a universal joint, in conical motion at θ₀ from the downward vertical:
    (system, q0, v0, Ω), Ω² = g/(L cos θ₀). The outer axis (the joint is singular when the rod lies along it)
    is vertical for a wide cone and horizontal for a narrow one: 45° or more from the rod all along."""
    th = math.radians(deg)
    wide = deg >= 45
    s = vd.Scene("conical", gravity=(0, 0, -G))
    joint = vd.Universal((0, 0, 1), (1, 0, 0)) if wide else vd.Universal((1, 0, 0), (0, 1, 0))
    s.add_body("bob", joint=joint, mass=1.0, com=(0, 0, -1.0), inertia=np.zeros((3, 3)))
    omega = math.sqrt(G / math.cos(th))
    # wide: azimuth θ1 = Ωt, tilt θ2 = θ₀; narrow: θ2 = θ₀ about y, the turn about x at θ1' = −Ω tan θ₀
    v0 = np.array([omega, 0.0]) if wide else np.array([-omega * math.tan(th), 0.0])
    return s.build(), np.array([0.0, th]), v0, omega


@pytest.mark.parametrize("deg", [10, 30, 60, 85])
def test_conical_pendulum_on_a_universal_joint_analytic_equals_fd(deg):
    system, q0, v0, _ = conical(deg)
    an, fd = system.linearize(q0, v=v0, method="analytic"), system.linearize(q0, v=v0, method="fd")
    assert an.method == "analytic"
    assert np.all(np.abs(an.K - fd.K) <= an.K_error + fd.K_error)
    assert np.all(np.abs(an.C - fd.C) <= an.C_error + fd.C_error)


@pytest.mark.parametrize("deg", [10, 30, 60, 85])
def test_conical_pendulum_on_a_universal_joint_floquet_multipliers(deg):
    """Multipliers of the conical orbit (T = 2π/Ω): a double 1 (the flow, the energy family) and the pair
    exp(±iω_n T) with ω_n = Ω√(1 + 3cos²θ₀) on the unit circle (Pinocchio's derivatives gave 1.0709 and 0.9338,
    "unstable", at 30°)."""
    system, q0, v0, omega = conical(deg)
    period = 2 * math.pi / omega
    orbit = vd.periodic_orbit(system, q0, v0, period=1.01 * period)
    assert abs(orbit.period - period) <= orbit.period_error + 1e-12 * period
    mu, err = orbit.multipliers, orbit.multiplier_error
    assert np.all(np.abs(np.abs(mu) - 1.0) <= err)
    ones = np.abs(mu - 1.0) <= err
    assert ones.sum() == 2
    wn = omega * math.sqrt(1 + 3 * math.cos(math.radians(deg)) ** 2)
    expected = np.exp(1j * wn * period * np.array([1, -1]))
    assert np.abs(np.sort_complex(mu[~ones]) - np.sort_complex(expected)).max() <= \
        err[~ones].max() + wn * (orbit.period_error + abs(orbit.period - period))
    # (an estimate small enough for the comparison to mean something: Pinocchio's derivatives were off by 0.8 to
    # 1.1 in the pair at 60 and 85 deg, and moved the double 1 by 7e-3 at 10 and 30 deg)
    assert err[~ones].max() < 1e-5 and orbit.stability == "neutral within the error"


def test_guard_catches_pinocchio_at_tiny_masses():
    """Pinocchio 4.1's computeRNEADerivatives loses the gravity stiffness of a light pendulum carrying a slider
    that accelerates (mass 1e-20 kg, 0.5 m lever, gravity 1 m/s² up, the free acceleration 1 m/s² of the
    slider: −4.5e-25 against −m g l = −5e-21 N·m/rad, whatever the step of the differences; 1 kg is right): the
    guard sees it on joint types nobody distrusts, warns, and the model is the finite-difference one, right."""
    for mass in (1e-20, 4.7e-26):
        s = vd.Scene("tiny", gravity=(0.0, 0.0, 1.0))
        s.add_body("rod", joint=vd.Pivot((0, 1, 0)), mass=mass, com=(0, 0, -0.5), inertia=np.zeros((3, 3)))
        s.add_body("cart", parent="rod", joint=vd.Slider((0, 0, 1)), mass=mass)
        system = s.build()
        with pytest.warns(UserWarning, match="disagree with central differences"):
            lin = system.linearize(method="analytic")  # (about the free acceleration: the cart's 1 m/s²)
        assert lin.method == "fd"
        assert abs(lin.K[0, 0] + mass * 0.5) <= 10 * lin.K_error[0, 0] + 1e-9 * mass * 0.5
