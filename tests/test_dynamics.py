"""Dynamics of vibdyn systems against independent truths.

Hand-derived Lagrange equations (double pendulum, trailer with a compound pendulum, helical joint),
Pinocchio-level identities computed outside vibdyn's force machinery (RNEA, frame Jacobians, log maps),
finite differences of scalar energies, Newton–Euler balances of subtrees for the link reactions, and
energy conservation of an RK4 integration written here.

Tolerances: direct evaluations (CRBA, RNEA, ABA, kinematics, energies, parsed numbers) carry no error
estimate; their error is round-off, a few ε × the size of the terms (× κ(M) where M is solved). Fixed
1e-15..1e-12 relative (≈ 4.5–4500 ε) bound it on these small, well-conditioned models; 1e-10 where M is
solved or another engine's arithmetic is compared. Results that carry an estimate are checked against it.
"""

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles import (
    REPORT,
    assert_close,
    bias,
    point_jacobian,
    random_chain,
    random_inertia,
    random_rotation,
    rk4_step,
    spring_force_q,
    tangent_gradient,
)

import vibdyn as vd

G = 9.81
FEW = settings(max_examples=12, deadline=None)

angle = st.floats(-math.pi, math.pi)
speed = st.floats(-6.0, 6.0)
mass = st.floats(0.1, 5.0)
length = st.floats(0.2, 2.0)


# ================================================================================================ 1. double pendulum
def double_pendulum(m1, m2, l1, l2):
    s = vd.Scene("double pendulum", gravity=(0, 0, -G))
    s.add_body("m1", joint=vd.Pivot((0, 1, 0)), mass=m1, com=(0, 0, -l1))
    s.add_body("m2", "m1", vd.Pivot((0, 1, 0), at=(0, 0, -l1)), mass=m2, com=(0, 0, -l2))
    return s


def double_pendulum_hand(m1, m2, l1, l2, th1, th2, w1, w2):
    """Lagrange in relative angles. Rotating (0, 0, −l) about +y by θ gives (−l sin θ, 0, −l cos θ):
    x1 = −l1 s1, z1 = −l1 c1, x2 = x1 − l2 s12, z2 = z1 − l2 c12 (s12 = sin(θ1 + θ2)).
    T = ½ m1 l1² θ̇1² + ½ m2 [l1² θ̇1² + l2² (θ̇1 + θ̇2)² + 2 l1 l2 θ̇1 (θ̇1 + θ̇2) cos θ2],
    V = −(m1 + m2) g l1 c1 − m2 g l2 c12.
    M θ̈ + c + ∂V/∂θ = 0 with h = m2 l1 l2 sin θ2:
    c1 = −h (2 θ̇1 θ̇2 + θ̇2²) (from Ṁ θ̇), c2 = −h θ̇1 θ̇2 + h θ̇1 (θ̇1 + θ̇2) = h θ̇1².
    """
    c2 = math.cos(th2)
    h = m2 * l1 * l2 * math.sin(th2)
    M = np.array([[(m1 + m2) * l1**2 + m2 * l2**2 + 2 * m2 * l1 * l2 * c2, m2 * l2**2 + m2 * l1 * l2 * c2],
                  [m2 * l2**2 + m2 * l1 * l2 * c2, m2 * l2**2]])
    c = np.array([-h * (2 * w1 * w2 + w2**2), h * w1**2])
    dV = np.array([(m1 + m2) * G * l1 * math.sin(th1) + m2 * G * l2 * math.sin(th1 + th2),
                   m2 * G * l2 * math.sin(th1 + th2)])
    return M, c + dV


@FEW
@given(th1=angle, th2=angle, w1=speed, w2=speed, m1=mass, m2=mass, l1=length, l2=length)
def test_double_pendulum_matches_lagrange(th1, th2, w1, w2, m1, m2, l1, l2):
    system = double_pendulum(m1, m2, l1, l2).build()
    q, v = np.array([th1, th2]), np.array([w1, w2])
    M, b = double_pendulum_hand(m1, m2, l1, l2, th1, th2, w1, w2)
    a_hand = np.linalg.solve(M, -b)
    scale = G / min(l1, l2) + max(w1**2, w2**2)  # the size of an angular acceleration here
    assert_close(system.accelerations(q, v), a_hand, 1e-9, scale=scale, what="double pendulum a")
    assert_close(system.mass_matrix(q), M, 1e-12, what="double pendulum M")
    assert_close(system.inverse_dynamics(q, v, np.zeros(2)), b, 1e-12,
                 scale=(m1 + m2) * (G + scale * max(l1, l2)) * max(l1, l2), what="double pendulum b")
    # where the masses are: the hand geometry
    x1 = np.array([-l1 * math.sin(th1), 0, -l1 * math.cos(th1)])
    x2 = x1 + np.array([-l2 * math.sin(th1 + th2), 0, -l2 * math.cos(th1 + th2)])
    assert_close(system.point_position("m2", (0, 0, -l2), q), x2, 1e-12, scale=l1 + l2, what="mass 2 position")


def test_double_pendulum_small_oscillations():
    """R3: m = l = 1: the linearised equations M θ̈ + K θ = 0 give ω = √((2 ∓ √2) g / l)."""
    system = double_pendulum(1.0, 1.0, 1.0, 1.0).build()
    q0 = system.neutral()
    M = system.mass_matrix(q0)
    # K = −∂g/∂q at rest by central differences (no springs: gravity is the only stiffness)
    h = 1e-6
    K = np.column_stack([-(system.gravity_forces(q0 + h * e) - system.gravity_forces(q0 - h * e)) / (2 * h)
                         for e in np.eye(2)])
    w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    exact = np.sqrt((2 - np.array([1, -1]) * math.sqrt(2)) * G)  # 2.397199, 5.787351 rad/s
    assert_close(w, exact, 1e-8, what="R3 double pendulum ω")


# ================================================================================================ 2. trailer
def trailer(Mc, m, L, k, c, l0, kt, a, b):
    s = vd.Scene("trailer", gravity=(0, 0, -G))
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=Mc, inertia=vd.inertia.box(Mc, (0.4, 0.2, 0.1)))
    s.add_body("rod", "cart", vd.Pivot((0, 1, 0)), mass=m, com=(0, 0, -L / 2),
               inertia=vd.inertia.rod(m, L, axis=(0, 0, 1)))
    s.add_spring("k", ("world", (-l0, 0, 0)), "cart", k, free_length=l0)
    s.add_damper("c", ("world", (-l0, 0, 0)), "cart", c)
    s.add_joint_spring("rod", kt)
    s.add_joint_force("rod", lambda t, q, v: a - b * v**2)
    return s


@FEW
@given(x=st.floats(-0.3, 0.3), th=angle, xd=speed, thd=speed, Mc=mass, m=mass, L=length,
       k=st.floats(0.0, 500.0), c=st.floats(0.0, 20.0), l0=st.floats(0.5, 2.0), kt=st.floats(0.0, 50.0),
       a=st.floats(-5.0, 5.0), b=st.floats(0.0, 2.0))
def test_trailer_with_compound_pendulum(x, th, xd, thd, Mc, m, L, k, c, l0, kt, a, b):
    """Rao's trailer: cart M on a slider along x (spring k of free length l0 from the wall point (−l0, 0, 0),
    damper c), uniform rod (m, L) pivoting about +y at the cart origin, torsion spring kt, motor a − b θ̇².
    Rod centre G = (x − (L/2) sin θ, 0, −(L/2) cos θ), I_G = m L²/12:
    T = ½ (M + m) ẋ² − (m L/2) cos θ ẋ θ̇ + ½ (m L²/3) θ̇²,  V = ½ k x² + ½ kt θ² − m g (L/2) cos θ.
      (M + m) ẍ − (m L/2)(cos θ θ̈ − sin θ θ̇²) + k x + c ẋ = 0
      −(m L/2) cos θ ẍ + (m L²/3) θ̈ + m g (L/2) sin θ + kt θ = a − b θ̇²
    """
    system = trailer(Mc, m, L, k, c, l0, kt, a, b).build()
    assert system.coordinates == ("cart", "rod")
    ct, st_ = math.cos(th), math.sin(th)
    M = np.array([[Mc + m, -m * L / 2 * ct], [-m * L / 2 * ct, m * L**2 / 3]])
    rhs = np.array([-(m * L / 2) * st_ * thd**2 - k * x - c * xd,
                    -m * G * L / 2 * st_ - kt * th + a - b * thd**2])
    q, v = np.array([x, th]), np.array([xd, thd])
    a_hand = np.linalg.solve(M, rhs)
    scale = np.abs(np.linalg.solve(M, np.abs(rhs) + 1.0)).max()
    assert_close(system.accelerations(q, v), a_hand, 1e-9, scale=scale, what="trailer a")
    assert_close(system.mass_matrix(q), M, 1e-12, what="trailer M")
    # the force elements alone: Q = (−k x − c ẋ, −kt θ + a − b θ̇²)
    Q = np.array([-k * x - c * xd, -kt * th + a - b * thd**2])
    assert_close(system.generalized_forces(q, v), Q, 1e-11, scale=1.0 + k * 0.3 + c * 6 + kt * 3,
                 what="trailer Q")


# ================================================================================================ 3. helical joint
def helical_scene(axis, pitch, m, inertia, com=(0, 0, 0), gravity=(0, 0, -G)):
    s = vd.Scene("screw", gravity=gravity)
    s.add_body("nut", joint=vd.Helical(axis, pitch), mass=m, com=com, inertia=inertia)
    return s


def test_helical_vertical_R8():
    """R8: generalized mass I + m p², holding torque m g p (gravity −z, the screw rises with +θ), one turn
    advances 2π p."""
    m, p, I = 2.0, 0.05, np.diag([0.3, 0.4, 0.25])
    system = helical_scene((0, 0, 1), p, m, I).build()
    q0 = system.neutral()
    assert_close(system.mass_matrix(q0), [[0.25 + m * p**2]], 1e-14, what="helical M")
    tau = system.inverse_dynamics(q0, [0.0], [0.0])
    assert tau[0] > 0  # positive: holding it up means turning the way that lifts it
    assert_close(tau, [m * G * p], 1e-14, what="helical holding torque")
    assert_close(system.gravity_forces(q0), [-m * G * p], 1e-14, what="helical gravity force")
    # released from rest it screws down: θ̈ = −m g p / (I + m p²)
    assert_close(system.accelerations(q0, [0.0]), [-m * G * p / (0.25 + m * p**2)], 1e-14, what="helical a")
    # rising: energy m g p θ
    assert_close(system.energy([1.0], [0.0]).gravity - system.energy(q0, [0.0]).gravity, m * G * p, 1e-12,
                 what="helical potential")
    # one turn advances 2π p; a point off the axis comes back above itself; half a turn mirrors it
    for theta in (2 * math.pi, -4 * math.pi):
        assert_close(system.point_position("nut", (0, 0, 0), [theta]), [0, 0, theta * p], 1e-14, scale=1.0,
                     what="helical advance")
        assert_close(system.point_position("nut", (0.2, 0.1, 0), [theta]), [0.2, 0.1, theta * p], 1e-13,
                     scale=1.0, what="helical point after turns")
    assert_close(system.point_position("nut", (0.2, 0.1, 0), [math.pi]), [-0.2, -0.1, math.pi * p], 1e-13,
                 scale=1.0, what="helical half turn")


def test_helical_per_turn():
    lead = 0.012  # m per turn
    j = vd.Helical.per_turn((0, 0, 1), lead)
    assert j.pitch == pytest.approx(lead / (2 * math.pi), rel=1e-15)
    s = vd.Scene("lead", gravity=(0, 0, -G))
    s.add_body("nut", joint=j, mass=1.0, inertia=np.eye(3) * 1e-3)
    system = s.build()
    assert_close(system.point_position("nut", (0, 0, 0), [2 * math.pi]), [0, 0, lead], 1e-13, scale=1.0,
                 what="one turn = one lead")


@FEW
@given(theta=angle, m=mass, p=st.floats(-0.2, 0.2).filter(lambda x: abs(x) > 1e-3), seed=st.integers(0, 2**31))
def test_helical_oblique_axis(theta, m, p, seed):
    """Axis a = (1, 1, 0)/√2 (and a random one) with a full inertia, a com off the axis and an oblique
    gravity g. The com is G(θ) = R(θ) c + p θ a, so
      M = aᵀ I_G a + m |a × R c + p a|² = aᵀ I_G a + m (|a × c|² + p²),
      holding torque τ = −m g·(a × R(θ) c + p a)  (= m |g| p on a vertical axis with c = 0).
    """
    rng = np.random.default_rng(seed)
    gvec = np.array([-2.0, 1.5, -G])
    I = random_inertia(rng, m)
    for axis in (np.array([1.0, 1.0, 0.0]) / math.sqrt(2), rng.standard_normal(3)):
        a = axis / np.linalg.norm(axis)
        for c in (np.zeros(3), 0.3 * rng.standard_normal(3)):
            system = helical_scene(a, p, m, I, com=c, gravity=gvec).build()
            q, z = np.array([theta]), np.zeros(1)
            Rc = _rodrigues(a, theta) @ c
            M_hand = a @ I @ a + m * (np.cross(a, c) @ np.cross(a, c) + p * p)
            tau_hand = -m * gvec @ (np.cross(a, Rc) + p * a)
            assert_close(system.mass_matrix(q), [[M_hand]], 1e-12, what="oblique helical M")
            assert_close(system.inverse_dynamics(q, z, z), [tau_hand], 1e-12, scale=m * G * (abs(p) + 0.3),
                         what="oblique helical torque")
            if not c.any():
                assert_close(tau_hand, -m * p * (gvec @ a), 1e-12, scale=m * G * abs(p), what="m p (g·a)")
            assert_close(system.point_position("nut", c, q), Rc + p * theta * a, 1e-12, scale=1.0,
                         what="oblique helical com")


def _rodrigues(a, t):
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * K @ K


# ================================================================================================ 4. ball-joint chains
def ball_chain(n, rng, springs=True, torques=True):
    """n bodies on ball joints with offsets, random rotations, full inertias, coms off the links, gravity;
    point springs (with and without free length, body–body and body–world), ball joint springs (one
    with a rest rotation) and constant joint torques τ."""
    s = vd.Scene("balls", gravity=(0.3, -0.2, -G))
    parent = vd.WORLD
    for i in range(n):
        m = 0.5 + rng.random()
        at = (0, 0, 0) if i == 0 else tuple(np.r_[0.05 * rng.standard_normal(2), -0.5])
        s.add_body(f"b{i}", parent, vd.Ball(at=at, rotation=random_rotation(rng)), mass=m,
                   com=0.1 * rng.standard_normal(3) + np.array([0, 0, -0.25]), inertia=random_inertia(rng, m))
        parent = f"b{i}"
    data = {"springs": [], "joint_springs": [], "torques": {}}
    if springs:
        sp = [("s01", ("b0", (0.1, 0.0, -0.2)), (f"b{n - 1}", (0.0, 0.1, -0.3)), 40.0, 0.4),
              ("sw", ("world", (0.5, 0.2, -0.3)), ("b1", (0.05, 0.0, -0.1)), 25.0, None)]
        for name, a, b, k, l0 in sp:
            s.add_spring(name, a, b, k, free_length=l0)
            data["springs"].append((a, b, k, l0))
        for i, (k, rest) in enumerate([(3.0, (0.0, 0.0, 0.0)), (5.0, (0.2, -0.1, 0.3))]):
            s.add_joint_spring(f"b{i + 1}", k, rest=rest)
            data["joint_springs"].append((f"b{i + 1}", k, np.array(rest)))
    if torques:
        for i in range(0, n, 2):
            tau = rng.standard_normal(3)
            s.add_joint_force(f"b{i}", tau)
            data["torques"][f"b{i}"] = tau
    return s, data


def independent_Q(system, data, q):
    """Q rebuilt without vibdyn's force groups: springs by frame Jacobians (Jᵀ f), isotropic ball springs
    as −k log3(R_restᵀ R), constant torques as given."""
    Q = np.zeros(system.nv)
    for a, b, k, l0 in data["springs"]:
        if l0 is None:  # free length = distance at the neutral configuration
            ends = [np.asarray(p) if body == vd.WORLD else system.point_position(body, p, system.neutral())
                    for body, p in (a, b)]
            l0 = np.linalg.norm(ends[1] - ends[0])
        Q += spring_force_q(system, a, b, k, l0, q)
    for body, k, rest in data["joint_springs"]:
        info = system.body_info(body)
        quat = q[info.idx_q:info.idx_q + 4]
        R = pin.Quaternion(quat[3], *quat[:3]).toRotationMatrix()
        Q[info.idx_v:info.idx_v + 3] -= k * pin.log3(pin.exp3(rest).T @ R)
    for body, tau in data["torques"].items():
        info = system.body_info(body)
        Q[info.idx_v:info.idx_v + 3] += tau
    return Q


@pytest.mark.parametrize("n", [5, 10])
def test_ball_chain_rnea_aba_identity(n):
    rng = np.random.default_rng(n)
    scene, data = ball_chain(n, rng)
    system = scene.build()
    for _ in range(4):
        q = system.random_configuration(0.8, rng)
        v = rng.standard_normal(system.nv)
        a = system.accelerations(q, v)
        Q = independent_Q(system, data, q)
        b = bias(system, q, v)
        size = max(np.abs(Q).max(), np.abs(b).max())
        # RNEA(ABA) = identity: vibdyn's inverse dynamics of its own accelerations is zero
        assert_close(system.inverse_dynamics(q, v, a), np.zeros(system.nv), 1e-9, scale=size,
                     what=f"ball n={n} rnea(aba)")
        # equations of motion with every piece independent: M (CRBA) a + b (RNEA) = Q (Jacobians)
        assert_close(system.mass_matrix(q) @ a + b, Q, 1e-9, scale=size, what=f"ball n={n} M a + b = Q")
        assert_close(system.generalized_forces(q, v), Q, 1e-10, scale=size, what=f"ball n={n} Q")


def test_ball_chain_20_links_accurate_accelerations():
    """Regression guard for the Pinocchio 4.1 trap: computeMinverse / ABA derivatives lose accuracy on
    chains of multi-DoF joints (M⁻¹ error 0.5 at 20 links). vibdyn's accelerations must satisfy
    M a = τ − b to 1e-8 relative on a 20-link ball chain."""
    rng = np.random.default_rng(20)
    scene, data = ball_chain(20, rng)
    system = scene.build()
    worst = 0.0
    for _ in range(3):
        q = system.random_configuration(1.0, rng)
        v = rng.standard_normal(system.nv)
        a = system.accelerations(q, v)
        M = system.mass_matrix(q)
        Q = independent_Q(system, data, q)
        b = bias(system, q, v)
        r = M @ a + b - Q
        scale = max(np.abs(M @ a).max(), np.abs(b).max(), np.abs(Q).max())
        worst = max(worst, np.abs(r).max() / scale)
        # the accelerations themselves, against a direct dense solve of the same equations
        a_ref = np.linalg.solve(M, Q - b)
        assert_close(a, a_ref, 1e-6, what="20-link a vs dense solve")
    if REPORT:
        print(f"[err] 20-link ball chain |M a + b - Q| / scale: {worst:.3g}")
    assert worst <= 1e-8, worst


# ================================================================================================ 5. energy
def energy_scene(damped=False):
    s = vd.Scene("energy", gravity=(0, 0, -G))
    s.add_body("l1", joint=vd.Pivot((0, 1, 0)), mass=1.0, com=(0, 0, -0.5),
               inertia=vd.inertia.rod(1.0, 1.0))
    s.add_body("l2", "l1", vd.Pivot((0, 1, 0), at=(0, 0, -1)), mass=0.8, com=(0, 0, -0.4),
               inertia=vd.inertia.rod(0.8, 0.8))
    s.add_body("top", "l2", vd.Ball(at=(0, 0, -0.8), rotation=(0.2, -0.1, 0.3)), mass=0.5, com=(0.05, 0.02, -0.15),
               inertia=vd.inertia.box(0.5, (0.1, 0.2, 0.3)))
    s.add_spring("spring", ("world", (0.6, 0.1, -1.0)), ("top", (0.0, 0.05, -0.2)), 30.0, free_length=0.5)
    s.add_joint_spring("l1", 4.0, rest=0.2)
    s.add_joint_spring("top", (2.0, 3.0, 1.5), rest=(0.1, 0.0, -0.2))
    if damped:
        s.add_damper("dashpot", ("world", (0.6, 0.1, -1.0)), ("top", (0.0, 0.05, -0.2)), 0.7)
        s.add_joint_damper("l2", 0.3)
        s.add_joint_force("l1", lambda t, q, v: 1.0 - 0.2 * v**2)
    return s


def test_energy_conservation_rk4():
    """Undamped scene (double pendulum of rods, ball-jointed body, point spring, pivot spring, anisotropic
    ball spring): RK4 in a local chart for 1 s keeps the total energy to 1e-6 of the energy exchanged."""
    system = energy_scene().build()
    q = system.integrate(system.neutral(), np.array([0.6, -0.4, 0.3, -0.5, 0.2]))
    v = np.array([1.0, -2.0, 3.0, 1.0, -2.0])
    q0, E0 = q.copy(), system.energy(q, v)
    h, kin_max, drift, drift_wrong = 1e-3, 0.0, 0.0, 0.0
    for _ in range(1000):
        q, v = rk4_step(system, q, v, h)
        E = system.energy(q, v)
        kin_max = max(kin_max, E.kinetic)
        drift = max(drift, abs(E.total - E0.total))
        # negative control: the same measure with a pivot-spring potential 1 % too stiff must drift
        wrong = 0.01 * 0.5 * 4.0 * ((q[0] - 0.2) ** 2 - (q0[0] - 0.2) ** 2)
        drift_wrong = max(drift_wrong, abs(E.total + wrong - E0.total))
    assert kin_max > 1.0 and abs(E.elastic - E0.elastic) > 0.01  # energy really moved between its forms
    rel = drift / kin_max
    if REPORT:
        print(f"[err] RK4 energy drift / max kinetic: {rel:.3g} (1 % wrong potential: {drift_wrong / kin_max:.3g})")
    assert rel <= 1e-6, rel
    assert drift_wrong / kin_max > 1e-4


def test_energy_rate_equals_power_of_nonconservative_forces():
    """dE/dt (central difference along the motion) = power of dampers and motor, computed by hand:
    −c_joint θ̇2² − c (rate of length)² + (1 − 0.2 θ̇1²) θ̇1; zero without them."""
    for damped in (False, True):
        system = energy_scene(damped).build()
        rng = np.random.default_rng(5)
        for _ in range(3):
            q = system.random_configuration(0.5, rng)
            v = rng.standard_normal(system.nv)
            a = system.accelerations(q, v)
            def E(t):
                return system.energy(system.integrate(q, t * v + 0.5 * t * t * a), v + t * a).total

            def D(h):
                return (E(h) - E(-h)) / (2 * h)

            dEdt = (4 * D(1e-4) - D(2e-4)) / 3  # Richardson: the h² error (here ~3e3 h²) cancels
            P = 0.0
            if damped:
                Ja, xa = np.zeros((3, system.nv)), np.array([0.6, 0.1, -1.0])
                Jb, xb = point_jacobian(system, "top", (0.0, 0.05, -0.2), q)
                u = (xb - xa) / np.linalg.norm(xb - xa)
                rate = u @ (Jb - Ja) @ v
                P = -0.7 * rate**2 - 0.3 * v[1] ** 2 + (1.0 - 0.2 * v[0] ** 2) * v[0]
            scale = abs(v @ system.mass_matrix(q) @ a) + abs(P) + 1.0
            assert_close(dEdt, P, 1e-8, scale=scale, what=f"dE/dt damped={damped}")


# ================================================================================================ 6. reactions
def hanging_chain(kind="pivot", n=4):
    s = vd.Scene("hanging", gravity=(0, 0, -G))
    parent, masses = vd.WORLD, []
    for i in range(n):
        L, m = 0.5 + 0.1 * i, 1.0 + 0.5 * i
        at = (0, 0, 0) if i == 0 else (0, 0, -(0.5 + 0.1 * (i - 1)))
        joint = vd.Pivot((0, 1, 0) if i % 2 else (1, 0, 0), at=at) if kind == "pivot" else vd.Ball(at=at)
        s.add_body(f"b{i}", parent, joint, mass=m, com=(0, 0, -L / 2),
                   inertia=vd.inertia.box(m, (0.05, 0.08, L)))
        parent = f"b{i}"
        masses.append(m)
    return s, masses


@pytest.mark.parametrize("kind", ["pivot", "ball"])
def test_hanging_chain_reactions_at_rest(kind):
    scene, masses = hanging_chain(kind)
    system = scene.build()
    q, z = system.neutral(), np.zeros(system.nv)
    r = system.reactions(q, z, z)
    assert r.bodies == tuple(f"b{i}" for i in range(len(masses)))
    for i, name in enumerate(r.bodies):
        below = sum(masses[i:])
        F, Mo = r[name]
        assert_close(F, [0, 0, below * G], 1e-13, what=f"{kind} hanging force {name}")
        assert_close(Mo, np.zeros(3), 1e-13, scale=below * G, what=f"{kind} hanging moment {name}")
        assert_close(r.joint_force[name], np.zeros(system.body_info(name).nv), 1e-13, scale=below * G,
                     what="hanging joint force")


def _static_check(system, q, what):
    """Static subtree balance at (q, 0, 0): the link force is −Σ m g, its moment about the joint origin
    −Σ (G_j − O) × m_j g, and the joint force along a pivot the axis component of that moment."""
    z = np.zeros(system.nv)
    r = system.reactions(q, z, z)
    g = np.array(system.scene.gravity)
    for name in r.bodies:
        sub = _subtree(system.scene, name)
        O = system.body_pose(name, q)[1]
        F = -sum(system.scene.bodies[j].mass for j in sub) * g
        Mo = -sum(np.cross(system.point_position(j, system.scene.bodies[j].com, q) - O,
                           system.scene.bodies[j].mass * g) for j in sub)
        scale = np.abs(F).max()
        assert_close(r.force[r.bodies.index(name)], F, 1e-12, what=f"{what} static force {name}")
        assert_close(r.moment[r.bodies.index(name)], Mo, 1e-12, scale=scale, what=f"{what} static moment {name}")
        J = system.scene.bodies[name].joint
        if J.type == "pivot":
            axis = system.body_pose(name, q)[0] @ np.array(J.axis)
            assert_close(r.joint_force[name], [axis @ Mo], 1e-12, scale=scale, what=f"{what} pivot torque {name}")
            # and that is the gravity torque the joint must hold: the coordinate of inverse dynamics
            tau = system.inverse_dynamics(q, z, z)[system.body_info(name).idx_v]
            assert_close(r.joint_force[name], [tau], 1e-12, scale=scale, what=f"{what} holding torque {name}")


def _subtree(scene, name):
    out = [name]
    for c in scene.children(name):
        out += _subtree(scene, c.name)
    return out


def test_static_reactions_non_vertical():
    rng = np.random.default_rng(60)
    for kind in ("pivot", "ball"):
        scene, _ = hanging_chain(kind)
        system = scene.build()
        _static_check(system, system.random_configuration(0.7, rng), f"{kind} chain")
    scene = random_chain(rng, 5, ("pivot", "slider", "ball"), gravity=(1.0, -2.0, -G))
    system = scene.build()
    _static_check(system, system.random_configuration(1.0, rng), "mixed chain")


def branched_tree(depth_first=True):
    """trunk → (left, right), left → leaf: a body with two children (Y shape)."""
    s = vd.Scene("tree", gravity=(0, 0, -G))
    s.add_body("trunk", joint=vd.Pivot((0, 1, 0)), mass=2.0, com=(0, 0, -0.5), inertia=vd.inertia.rod(2.0, 1.0))
    order = [("left", "trunk", vd.Pivot((1, 0, 0), at=(0.1, 0, -1)), 1.0),
             ("leaf", "left", vd.Ball(at=(0, 0, -0.6)), 0.7),
             ("right", "trunk", vd.Pivot((0, 1, 0), at=(-0.1, 0, -1)), 1.5)]
    if not depth_first:  # trunk, left, right, then leaf: left's subtree is not contiguous
        order = [order[0], order[2], order[1]]
    for name, parent, joint, m in order:
        s.add_body(name, parent, joint, mass=m, com=(0.02, 0.01, -0.3), inertia=vd.inertia.box(m, (0.1, 0.1, 0.6)))
    return s


def test_branched_tree_reactions():
    system = branched_tree().build()
    q0, z = system.neutral(), np.zeros(system.nv)
    r = system.reactions(q0, z, z)
    assert_close(r["trunk"][0], [0, 0, (2.0 + 1.0 + 0.7 + 1.5) * G], 1e-13, what="tree trunk force")
    assert_close(r["left"][0], [0, 0, 1.7 * G], 1e-13, what="tree left force")
    assert_close(r["right"][0], [0, 0, 1.5 * G], 1e-13, what="tree right force")
    rng = np.random.default_rng(61)
    for _ in range(3):
        _static_check(system, system.random_configuration(0.8, rng), "tree")


def test_reactions_do_not_depend_on_previous_calls():
    """World-axis reactions at q must not depend on what the system computed before: RNEA updates only
    the joint-to-parent placements (data.liMi), not data.oMi, which reactions() uses to rotate the local
    wrench to world axes."""
    scene, _ = hanging_chain("pivot")
    system = scene.build()
    q = np.array([0.4, -0.3, 0.5, 0.2])
    z = np.zeros(system.nv)
    system.body_pose("b3", q)  # leaves data.oMi at q
    fresh = system.reactions(q, z, z)
    system.body_pose("b3", system.neutral())  # leaves data.oMi at the neutral configuration
    after = system.reactions(q, z, z)
    assert_close(after.force, fresh.force, 1e-14, what="reactions after another call (force)")
    assert_close(after.moment, fresh.moment, 1e-14, scale=np.abs(fresh.force).max(),
                 what="reactions after another call (moment)")


def test_dynamic_reactions_newton_euler():
    """Moving chain of pivots and sliders at arbitrary (q, v, a): the link wrench on each subtree equals
    Σ m (a_G − g) and, about the joint origin O, Σ [(G − O) × m (a_G − g) + dH_G/dt], with a_G and dH_G/dt
    from central differences of point velocities along q + t v + t²/2 a (a vector space here)."""
    rng = np.random.default_rng(62)
    scene = random_chain(rng, 5, ("pivot", "slider", "pivot"), gravity=(0.5, 1.0, -G))
    system = scene.build()
    g = np.array(scene.gravity)
    q, v, a = rng.standard_normal(system.nv), rng.standard_normal(system.nv), rng.standard_normal(system.nv)
    r = system.reactions(q, v, a)
    h = 1e-4

    def state(t):
        return q + t * v + 0.5 * t * t * a, v + t * a

    def momentum(name, t):
        """(velocity of G, angular momentum about G in world axes) of a body at time t on the path."""
        qt, vt = state(t)
        b = scene.bodies[name]
        R, p = system.body_pose(name, qt)
        v0 = system.point_velocity(name, (0, 0, 0), qt, vt)
        # ω from three body points: Σ_k r_k × (v_k − v_0) = 2 ω for orthonormal r_k
        w = 0.5 * sum(np.cross(R[:, k], system.point_velocity(name, np.eye(3)[k], qt, vt) - v0) for k in range(3))
        return system.point_velocity(name, b.com, qt, vt), R @ np.array(b.inertia) @ R.T @ w

    rates = {}
    for name in system.bodies:
        (vp, Hp), (vm, Hm) = momentum(name, h), momentum(name, -h)
        rates[name] = ((vp - vm) / (2 * h), (Hp - Hm) / (2 * h))
    for name in r.bodies:
        O = system.body_pose(name, q)[1]
        F = sum(scene.bodies[j].mass * (rates[j][0] - g) for j in _subtree(scene, name))
        Mo = sum(np.cross(system.point_position(j, scene.bodies[j].com, q) - O,
                          scene.bodies[j].mass * (rates[j][0] - g)) + rates[j][1] for j in _subtree(scene, name))
        F_vd, M_vd = r[name]
        assert_close(F_vd, F, 1e-7, what=f"dynamic force {name}")
        assert_close(M_vd, Mo, 1e-7, scale=np.abs(F).max(), what=f"dynamic moment {name}")


# ================================================================================================ 7. Q = −∂V/∂q
def springs_scene():
    """Pivot + slider + welded body + point springs (free length, none, zero; body–body, body–world)."""
    s = vd.Scene("springs", gravity=(0.4, -1.0, -G))
    s.add_body("arm", joint=vd.Pivot((0, 0.6, 0.8), at=(0.1, 0, 0)), mass=1.2, com=(0.3, 0, -0.1),
               inertia=vd.inertia.box(1.2, (0.6, 0.1, 0.1)))
    s.add_body("slide", "arm", vd.Slider((1, 0, 0), at=(0.2, 0.0, 0.1), rotation=(0.0, 0.3, 0.0)), mass=0.7,
               com=(0.05, 0.02, 0), inertia=vd.inertia.box(0.7, (0.1, 0.1, 0.1)))
    s.add_body("weld", "slide", vd.Fixed(at=(0.1, 0.1, 0), rotation=(0.4, 0, 0)), mass=0.2, com=(0, 0.05, 0),
               inertia=vd.inertia.sphere(0.2, 0.05))
    s.add_spring("bb", ("arm", (0.5, 0.1, 0)), ("weld", (0.0, 0.1, 0.05)), 80.0, free_length=0.15)
    s.add_spring("bw", ("world", (0.0, 0.5, 0.3)), ("slide", (0.1, 0, 0)), 50.0)  # unstressed at neutral
    s.add_spring("zero", ("world", (-0.2, 0.0, 0.0)), ("weld", (0.02, 0, 0)), 20.0, free_length=0.0)
    s.add_joint_spring("arm", 6.0, rest=0.3)
    s.add_joint_spring("slide", 150.0, rest=-0.05)
    return s


def lie_scene():
    """Ball (isotropic and anisotropic springs with rest rotations), free and planar joints with springs."""
    s = vd.Scene("lie", gravity=(0.0, -3.0, -G))
    s.add_body("ball", joint=vd.Ball(at=(0, 0, 1.0), rotation=(0.1, 0.2, 0.3)), mass=1.0, com=(0.1, 0, -0.3),
               inertia=vd.inertia.box(1.0, (0.2, 0.3, 0.5)))
    s.add_body("ball2", "ball", vd.Ball(at=(0, 0.1, -0.6)), mass=0.6, com=(0, 0.05, -0.2),
               inertia=vd.inertia.box(0.6, (0.1, 0.2, 0.3)))
    s.add_body("free", joint=vd.Free(at=(1.0, 0, 0), rotation=(0.0, 0.5, 0.0)), mass=2.0, com=(0.05, 0.1, 0.0),
               inertia=vd.inertia.box(2.0, (0.3, 0.4, 0.5)))
    s.add_body("plane", joint=vd.Planar((0.3, 0.2, 1.0), at=(-1.0, 0, 0)), mass=1.5, com=(0.1, 0.05, 0.02),
               inertia=vd.inertia.box(1.5, (0.2, 0.2, 0.2)))
    s.add_joint_spring("ball", 7.0, rest=(0.2, -0.3, 0.1))
    s.add_joint_spring("ball2", (3.0, 5.0, 9.0), rest=(0.1, 0.2, -0.2))
    s.add_joint_spring("free", (100.0, 80.0, 120.0, 5.0, 6.0, 7.0), rest=(0.1, 0.0, -0.1, 0.2, 0.0, 0.3))
    s.add_joint_spring("plane", (60.0, 40.0, 3.0), rest=(0.1, -0.2, 0.4))
    s.add_spring("tether", ("world", (1.5, 0.5, 0.5)), ("free", (0.1, 0.0, 0.2)), 30.0, free_length=0.3)
    s.add_spring("link", ("ball2", (0.05, 0, -0.3)), ("plane", (0.0, 0.1, 0.0)), 20.0, free_length=1.0)
    return s


@pytest.mark.parametrize("make", [springs_scene, lie_scene])
def test_potential_consistency(make):
    """Q(q) = −∂V_elastic/∂q and g(q) = −∂V_gravity/∂q in the tangent space (perturbation by integrate)."""
    system = make().build()
    rng = np.random.default_rng(70)
    z = np.zeros(system.nv)
    for _ in range(3):
        q = system.random_configuration(0.4, rng)
        Q = system.generalized_forces(q, z)
        dV = tangent_gradient(lambda x: system.energy(x, z).elastic, system, q)
        assert_close(Q, -dV, 1e-7, scale=1.0, what=f"{make.__name__} Q = -dV/dq")
        gq = system.gravity_forces(q)
        dVg = tangent_gradient(lambda x: system.energy(x, z).gravity, system, q)
        assert_close(gq, -dVg, 1e-7, scale=1.0, what=f"{make.__name__} g = -dVg/dq")
    # and against Jacobian forces for the point springs alone (independent of the potentials)
    if make is springs_scene:
        q = system.random_configuration(0.4, rng)
        s = system.scene
        l0 = {"bb": 0.15, "zero": 0.0}
        n0 = system.neutral()
        l0["bw"] = np.linalg.norm(system.point_position("slide", (0.1, 0, 0), n0) - np.array([0.0, 0.5, 0.3]))
        Q = sum(spring_force_q(system, e.a, e.b, e.stiffness, l0[e.name], q)
                for e in s.elements_of(vd.description.elements.Spring))
        Q = Q + np.array([-6.0 * (q[0] - 0.3), -150.0 * (q[1] + 0.05)])
        assert_close(system.generalized_forces(q, z), Q, 1e-12, scale=1.0, what="springs Jᵀf")


def test_anisotropic_ball_spring_stiffness_in_closed_form():
    """Q = −Jᵀ K φ of a ball spring with three stiffnesses and a rest rotation: its ∂Q/∂q in closed form (no
    differences: the workspace is not marked differenced) equals central differences of Q in the tangent space
    within their own Richardson truncation estimate, at rotations up to ~2 rad (past the series' range)."""
    from vibdyn.defaults import EPS
    from vibdyn.model.derivatives import Derivatives
    from vibdyn.model.fd import tangent_derivative

    s = vd.Scene("aniso ball")
    s.add_body("ball", joint=vd.Ball(), mass=1.0, com=(0.1, 0, -0.3), inertia=vd.inertia.box(1.0, (0.2, 0.3, 0.5)))
    s.add_joint_spring("ball", (3.0, 5.0, 9.0), rest=(0.1, 0.2, -0.2))
    system = s.build()
    (group,) = system.joint_groups
    rng = np.random.default_rng(3)
    z = np.zeros(3)
    ws = system.workspace()
    for amplitude in (0.05, 0.5, 2.0):
        q = system.integrate(system.neutral(), amplitude * rng.standard_normal(3))
        d = Derivatives(system, ws, q, z, z, 0.0, False, points=False)
        dQ, _ = group.derivatives(d)
        assert not d.differenced

        def Q(x):
            out = np.zeros(3)
            group.apply(0.0, x, z, None, out, None)
            return out

        D, T = tangent_derivative(system, Q, q, np.full(3, 2.0**-12), estimate=True)
        assert np.abs(dQ - D).max() <= np.abs(T).max() + 1e3 * EPS * np.abs(D).max()
        assert np.abs(T).max() < 1e-4 * np.abs(D).max()  # (the differences resolve it: the check can fail)


def test_joint_springs_stiffness_rows_at_once_equal_each_state_and_differences():
    """Joint springs on a ball (anisotropic, with a rest rotation; a second, isotropic one on the same ball: two
    layers), a pivot and an isotropic ball: their ∂Q/∂q at many states at once (``joint_rows``, as the variational
    equations ask for a step's stages) equals the one-state closed form at each, and central differences of Q in
    the tangent space within their own Richardson truncation estimate, at rotations from 1e-3 to ~2 rad."""
    from vibdyn.defaults import EPS
    from vibdyn.model.derivatives import Derivatives
    from vibdyn.model.fd import tangent_derivative

    s = vd.Scene("sprung chain")
    box = vd.inertia.box(1.0, (0.1, 0.2, 1.0))
    s.add_body("a", joint=vd.Ball(), mass=1.0, com=(0, 0, -0.5), inertia=box)
    s.add_body("b", parent="a", joint=vd.Pivot(axis=(1, 0, 0), at=(0, 0, -1)), mass=1.0, com=(0, 0, -0.5),
               inertia=box)
    s.add_body("c", parent="b", joint=vd.Ball(at=(0, 0, -1)), mass=1.0, com=(0, 0, -0.5), inertia=box)
    s.add_joint_spring("a", (1.0, 2.0, 5.0), rest=(0.1, 0.0, 0.2))
    s.add_joint_spring("a", 0.7, name="a.second")
    s.add_joint_spring("b", 3.0)
    s.add_joint_spring("c", 4.0)
    system = s.build()
    (group,) = system.joint_groups
    rng = np.random.default_rng(5)
    Q = np.array([system.integrate(system.neutral(), a * rng.standard_normal(system.nv))
                  for a in (1e-3, 0.05, 0.5, 1.0, 2.0)])
    V = rng.standard_normal((len(Q), system.nv))
    rows, _ = group.joint_rows(Q, V, np.zeros(len(Q)))
    ws = system.workspace()
    for q, v, dQ_rows in zip(Q, V, rows):
        dQ, _ = group.derivatives(Derivatives(system, ws, q, v, np.zeros(system.nv), 0.0, False, points=False))
        assert np.abs(dQ_rows - dQ).max() <= 1e3 * EPS * max(1.0, np.abs(dQ).max())

        def force(x):
            out = np.zeros(system.nv)
            group.apply(0.0, x, v, None, out, None)
            return out

        D, T = tangent_derivative(system, force, q, np.full(system.nv, 2.0**-12), estimate=True)
        assert np.abs(dQ_rows - D).max() <= np.abs(T).max() + 1e3 * EPS * np.abs(D).max()


def test_unstressed_spring_and_rest_positions():
    """A spring without free length is unstressed at the neutral configuration; joint springs on ball,
    free and planar joints vanish exactly at their rest offsets (and not elsewhere)."""
    s = springs_scene()
    for name in ("bb", "zero", "arm.spring", "slide.spring"):
        del s.elements[name]
    system = s.build()  # only the spring "bw", built without free length
    z = np.zeros(system.nv)
    assert_close(system.generalized_forces(system.neutral(), z), z, 1e-14, scale=1.0, what="unstressed at neutral")
    assert np.abs(system.generalized_forces(np.array([0.1, 0.02]), z)).max() > 0.1
    s = lie_scene()
    for name in ("tether", "link"):
        del s.elements[name]
    system = s.build()
    z = np.zeros(system.nv)
    dv = np.concatenate([[0.2, -0.3, 0.1], [0.1, 0.2, -0.2], [0.1, 0.0, -0.1, 0.2, 0.0, 0.3], [0.1, -0.2, 0.4]])
    q = system.integrate(system.neutral(), dv)
    assert_close(system.generalized_forces(q, z), z, 1e-12, scale=1.0, what="joint springs at rest")
    assert system.energy(q, z).elastic == pytest.approx(0.0, abs=1e-24)
    assert np.abs(system.generalized_forces(system.neutral(), z)).max() > 0.1


def test_elements_sharing_a_joint_add_up():
    """Two joint springs with their own rests and two joint dampers on one slider, two springs with different
    rests on one ball joint: every element acts (a later one used to overwrite an earlier one on the same
    joint, silently). Q is the sum of the elements alone; K and C are the sums, by both linearisations."""
    def scene(*springs, dampers=()):
        s = vd.Scene("shared")
        s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=2.0, inertia=vd.inertia.box(2.0, (0.2, 0.1, 0.1)))
        s.add_body("top", "cart", vd.Ball(at=(0, 0, 0.1)), mass=1.0, com=(0, 0, 0.3),
                   inertia=vd.inertia.box(1.0, (0.1, 0.2, 0.3)))
        for i, (body, k, rest) in enumerate(springs):
            s.add_joint_spring(body, k, rest=rest, name=f"k{i}")
        for i, c in enumerate(dampers):
            s.add_joint_damper("cart", c, name=f"c{i}")
        return s.build()

    springs = [("cart", 10.0, 0.0), ("cart", 20.0, 0.05), ("top", 3.0, (0.1, 0.0, 0.0)), ("top", 5.0, (0.0, -0.2, 0.1))]
    both = scene(*springs, dampers=(1.0, 2.0))
    alone = [scene(sp) for sp in springs]
    q = both.integrate(both.neutral(), [0.1, 0.3, -0.1, 0.2])
    v = np.array([0.7, 0.0, 0.0, 0.0])
    Q = both.generalized_forces(q, v)
    z = np.zeros(both.nv)
    Q_sum = sum(a.generalized_forces(q, z) for a in alone)
    assert_close(Q_sum[0], -10.0 * 0.1 - 20.0 * (0.1 - 0.05), 1e-15, scale=1.0, what="slider springs alone")
    assert_close(Q, Q_sum - np.array([3.0 * 0.7, 0, 0, 0]), 1e-14, scale=1.0, what="Q of elements sharing joints")
    # the elements' stiffness: K of the scene less K of the bare bodies (RNEA's own part), analytically
    K_bare = scene().linearize(q, a=z, method="analytic").K
    K_sum = sum(a.linearize(q, a=z, method="analytic").K - K_bare for a in alone)
    for method in ("analytic", "fd"):
        lin = both.linearize(q, a=z, method=method)
        assert np.all(np.abs(lin.K - K_bare - K_sum) <= 10 * lin.K_error + 1e-12), method
        assert lin.C[0, 0] == pytest.approx(3.0, rel=1e-9) and not lin.C[1:].any() and not lin.C[:, 1:].any(), method


# ========================================================================================= trees: coordinate order
def test_tree_added_out_of_depth_first_order():
    """The same Y-shaped tree added trunk, left, right, leaf (not depth-first) must have the same dynamics
    as when added depth-first. CRBA (mass_matrix) assumes each subtree's coordinates are contiguous."""
    a_sys, b_sys = branched_tree(True).build(), branched_tree(False).build()
    # map coordinates by name
    perm = [b_sys.coordinates.index(c) for c in a_sys.coordinates]
    rng = np.random.default_rng(80)
    for _ in range(3):
        qa = a_sys.random_configuration(0.7, rng)
        va = rng.standard_normal(a_sys.nv)
        # same state in b's ordering (each body's q block moved as a whole)
        qb = np.empty(b_sys.nq)
        for name in a_sys.bodies:
            ia, ib = a_sys.body_info(name), b_sys.body_info(name)
            qb[ib.idx_q:ib.idx_q + ib.nq] = qa[ia.idx_q:ia.idx_q + ia.nq]
        vb = np.empty(b_sys.nv)
        vb[perm] = va
        Ma = a_sys.mass_matrix(qa)
        # M independently: columns of RNEA (inverse dynamics is linear in a)
        z = np.zeros(b_sys.nv)
        M_rnea = np.column_stack([b_sys.inverse_dynamics(qb, z, e) - b_sys.inverse_dynamics(qb, z, z)
                                  for e in np.eye(b_sys.nv)])
        assert_close(M_rnea[np.ix_(perm, perm)], Ma, 1e-12, what="tree M (rnea columns)")
        assert_close(b_sys.mass_matrix(qb)[np.ix_(perm, perm)], Ma, 1e-12, what="tree M out of order")
        assert_close(b_sys.accelerations(qb, vb)[perm], a_sys.accelerations(qa, va), 1e-10, scale=10.0,
                     what="tree a out of order")
