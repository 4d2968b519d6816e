"""Drives (rheonomic joints): a coordinate prescribed in time. Physics against hand-derived equations of motion
integrated independently, closed forms, the energy balance with the drives' work, and bad input.
Tolerances come from the results' own error estimates."""

import io
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import vibdyn as vd

G = 9.81
EPS = np.finfo(float).eps
REF_RTOL = 1e-12  # the independent reference integrations (solve_ivp, DOP853)
REF_ERROR = 1e3 * REF_RTOL  # their global error on these O(1) motions over a few periods: rtol × growth margin


def upto(error):
    """The error estimate's largest value so far at each output (a rerun's difference can pass through zero
    where the actual error does not)."""
    return np.maximum.accumulate(error)


def carriage_pendulum(amplitude=0.05, omega=7.0, phase=0.0, m_c=2.0, m_p=0.5, l=0.8):
    """A carriage sliding along z (gravity −z) driven by Harmonic(amplitude, omega), carrying a point-mass
    pendulum (pivot about y, length l)."""
    s = vd.Scene("carriage pendulum", (0.0, 0.0, -G))
    s.add_body("carriage", joint=vd.Slider((0, 0, 1)), mass=m_c)
    s.add_body("pendulum", "carriage", joint=vd.Pivot((0, 1, 0)), mass=m_p, com=(0.0, 0.0, -l))
    law = vd.laws.Harmonic(amplitude, omega, phase)
    s.add_drive("carriage", law)
    return s, law


def pendulum_reference(law, l, theta0, dtheta0, t0, t_eval):
    """θ'' = −(g + ÿ_s(t)) sin θ / l, by hand, integrated by scipy."""
    def f(t, y):
        return [y[1], -(G + law.acceleration(t)) * math.sin(y[0]) / l]

    sol = solve_ivp(f, (t0, t_eval[-1]), [theta0, dtheta0], method="DOP853", rtol=REF_RTOL, atol=REF_RTOL,
                    t_eval=t_eval)
    return sol.y


def test_carriage_pendulum_against_hand_derived_equation_and_drive_force():
    l, m_c, m_p = 0.8, 2.0, 0.5
    scene, law = carriage_pendulum(m_c=m_c, m_p=m_p, l=l)
    system = scene.build()
    assert system.nq == system.nv == 2 and system.coordinates == ("carriage", "pendulum")
    assert system.drives.coordinates == ("carriage",) and system.drives.free_coordinates == ("pendulum",)
    t = np.linspace(0.0, 4.0, 41)
    traj = system.simulate(4.0, [0.0, 0.6], [0.0, 0.0], t_eval=t, rtol=1e-9)
    theta, dtheta = pendulum_reference(law, l, 0.6, 0.0, 0.0, t)
    assert np.all(np.abs(traj.q[:, 1] - theta) <= 3 * upto(traj.q_error) + REF_ERROR)
    assert np.all(np.abs(traj.v[:, 1] - dtheta) <= 3 * upto(traj.v_error) + REF_ERROR / l * 10)
    assert traj.q_error.max() > 0  # (an estimate was made)
    # the drive force, by Newton along the slider for the whole set: F − (m_c + m_p) g = m_c ÿ + m_p z̈_p,
    # z_p = y − l cos θ: z̈_p = ÿ + l (sin θ θ̈ + cos θ θ̇²)
    for ti, q, v in zip(traj.t[::8], traj.q[::8], traj.v[::8]):
        y_dd = law.acceleration(ti)
        th, th_d = q[1], v[1]
        th_dd = -(G + y_dd) * math.sin(th) / l
        hand = (m_c + m_p) * (G + y_dd) + m_p * l * (math.sin(th) * th_dd + math.cos(th) * th_d**2)
        scale = (m_c + m_p) * (G + abs(y_dd)) + m_p * l * (abs(th_dd) + th_d**2)
        F = system.drives.forces(q, v, ti)["carriage.drive"]
        assert abs(F - hand) <= 100 * EPS * scale
        a = system.accelerations(q, v, ti)
        assert a[0] == pytest.approx(y_dd, abs=100 * EPS * abs(y_dd) + 1e-300)
        assert abs(a[1] - th_dd) <= 100 * EPS * (G + abs(y_dd)) / l
        assert system.reactions(q, v, a, ti).drive["carriage.drive"] == pytest.approx(F, abs=100 * EPS * scale)


def crank_with_sprung_slider(omega=2.0, k=50.0, m=1.0, x0=0.3):
    """A crank turning about z at the constant speed omega (Motion of three callables) carrying a slider along
    its x axis on a joint spring (stiffness k, rest x0)."""
    s = vd.Scene("crank")
    s.add_body("crank", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=np.diag([0.1, 0.1, 0.1]))
    s.add_body("slider", "crank", joint=vd.Slider((1, 0, 0)), mass=m)
    s.add_joint_spring("slider", k, rest=x0)
    s.add_drive("crank", vd.laws.Motion(lambda t: omega * t, lambda t: omega, lambda t: 0.0))
    return s


@pytest.mark.parametrize("method,options", [("dop853", {}), ("rk4", {"dt": 2e-3}), ("radau", {}), ("bdf", {})])
def test_crank_slider_against_rotating_frame_closed_form(method, options):
    omega, k, m, x0 = 2.0, 50.0, 1.0, 0.3
    system = crank_with_sprung_slider(omega, k, m, x0).build()
    t = np.linspace(0.0, 3.0, 31)
    traj = system.simulate(3.0, [0.0, 0.4], [0.0, 0.1], t_eval=t, method=method, rtol=1e-8, **options)
    # rotating frame: x'' = ω² x − k/m (x − x0), by hand; Ω² = k/m − ω²
    W = math.sqrt(k / m - omega**2)
    xs = (k / m) * x0 / W**2
    x = xs + (0.4 - xs) * np.cos(W * t) + 0.1 / W * np.sin(W * t)
    xd = -(0.4 - xs) * W * np.sin(W * t) + 0.1 * np.cos(W * t)
    assert np.all(np.abs(traj.q[:, 1] - x) <= 3 * upto(traj.q_error) + 1e3 * EPS)
    assert np.all(np.abs(traj.v[:, 1] - xd) <= 3 * upto(traj.v_error) + 1e3 * EPS)
    # the crank follows its law exactly; its torque is d(m x² ω)/dt = 2 m x ẋ ω
    assert np.all(np.abs(traj.q[:, 0] - omega * t) <= 4 * EPS * np.maximum(1.0, omega * t))
    assert np.all(traj.v[:, 0] == omega)
    tau = np.array([system.drives.forces(q, v, ti)["crank.drive"] for ti, q, v in zip(traj.t, traj.q, traj.v)])
    hand = 2 * m * traj.q[:, 1] * traj.v[:, 1] * omega
    assert np.all(np.abs(tau - hand) <= 1e3 * EPS * (k * 1.0 + m * omega**2) * 1.0)
    # its work: ∫ 2 m ω² x ẋ dt = m ω² (x² − x(0)²); the spring is conservative, so it is all the work
    W = m * omega**2 * (traj.q[:, 1] ** 2 - 0.4**2)
    bound = energy_bound(system, traj)
    assert np.all(np.abs(traj.drive_work - W) <= bound)
    assert np.all(np.abs(traj.work - traj.drive_work) <= bound)


def test_drive_overwrites_initial_state_and_t0_shifts_the_phase():
    l = 0.8
    scene, law = carriage_pendulum(amplitude=0.05, omega=7.0, phase=0.4, l=l)
    system = scene.build()
    t0 = 0.7
    t = np.linspace(t0, t0 + 2.0, 21)
    traj = system.simulate(t0 + 2.0, [5.0, 0.3], [-3.0, 0.2], t0=t0, t_eval=t, rtol=1e-9)
    assert traj.q[0, 0] == law.position(t0) and traj.v[0, 0] == law.velocity(t0)  # overwritten at t0
    assert traj.q[0, 1] == 0.3 and traj.v[0, 1] == 0.2  # the free ones kept
    pos = np.array([law.position(x) for x in t])
    vel = np.array([law.velocity(x) for x in t])
    assert np.all(np.abs(traj.q[:, 0] - pos) <= 1e-12 * max(1.0, abs(law.amplitude)))
    assert np.all(np.abs(traj.v[:, 0] - vel) <= 1e-12 * max(1.0, abs(law.amplitude * law.omega)))
    theta, _ = pendulum_reference(law, l, 0.3, 0.2, t0, t)  # the phase of the forcing is that of t, not t − t0
    assert np.all(np.abs(traj.q[:, 1] - theta) <= 3 * upto(traj.q_error) + REF_ERROR)
    shifted, _ = pendulum_reference(vd.laws.Harmonic(0.05, 7.0, 0.4 - 7.0 * t0), l, 0.3, 0.2, t0, t)
    assert np.abs(traj.q[:, 1] - shifted).max() > 100 * (traj.q_error.max() + REF_ERROR)  # it would show


def energy_bound(system, traj):
    """What the error estimate allows an energy (J) to be off by, at each output and before: 10 × (|p|·δv +
    Σ|generalized forces|·δq), p = M v the momenta, the forces those of gravity, the elements and the drives."""
    bound = []
    for ti, q, v, eq, ev in zip(traj.t, traj.q, traj.v, upto(traj.q_error), upto(traj.v_error)):
        p = system.mass_matrix(q) @ v
        f = (np.abs(system.gravity_forces(q)) + np.abs(system.generalized_forces(q, v, ti))
             + np.abs(system.inverse_dynamics(q, v, system.accelerations(q, v, ti), ti)))
        bound.append(np.abs(p).sum() * ev + f.sum() * eq)
    return np.maximum.accumulate(10 * np.array(bound) + 1e3 * EPS * traj.energy_scale)


def test_energy_balance_closes_with_the_drives_work():
    scene, law = carriage_pendulum(amplitude=0.1, omega=6.0)
    scene.add_joint_damper("pendulum", 0.05)
    system = scene.build()
    traj = system.simulate(3.0, [0.0, 0.8], [0.0, 0.0], rtol=1e-10)
    bound = energy_bound(system, traj)
    assert np.all(np.abs(traj.energy_balance) <= bound)
    # the drive does work: without it the balance would be far from closed
    assert np.abs(traj.energy - traj.energy0.total).max() > 1e3 * bound.max()
    # the rest of the work is the damper's: it only dissipates
    damper = traj.work - traj.drive_work
    assert np.all(np.diff(damper) <= bound[1:]) and damper[-1] < -1e3 * bound.max()


def test_state_transition_over_free_coordinates_against_finite_differences():
    scene, _ = carriage_pendulum(amplitude=0.05, omega=7.0)
    system = scene.build()
    q0, v0, T = np.array([0.0, 0.5]), np.array([0.0, 0.3]), 1.5
    traj = system.simulate(T, q0, v0, variational=True, rtol=1e-11)
    Phi = traj.state_transition
    assert Phi.shape == (2, 2)  # (δθ, δθ̇) only: the carriage is driven
    free = system.drives.free

    def column(k, h):
        dq, dv = np.zeros(system.nv), np.zeros(system.nv)
        (dq if k < len(free) else dv)[free[k % len(free)]] = h
        runs = [system.simulate(T, system.integrate(q0, s * dq), v0 + s * dv, rtol=1e-11) for s in (1, -1)]
        x = [np.concatenate([r.q[-1][free], r.v[-1][free]]) for r in runs]
        err = sum(max(r.q_error[-1], r.v_error[-1]) for r in runs) / (2 * h)
        return (x[0] - x[1]) / (2 * h), err

    for k in range(2):
        D1, e1 = column(k, 1e-4)
        D2, e2 = column(k, 2e-4)
        fd_error = np.abs(D1 - D2) + e1 + e2  # truncation (Richardson) and the runs' errors
        assert np.all(np.abs(Phi[:, k] - D1) <= 3 * (traj.state_transition_error + fd_error))
    # a conservative driven pendulum: det Φ = 1 (Liouville, tr A = 0 in (θ, θ̇))
    assert abs(np.linalg.det(Phi) - 1.0) <= 10 * traj.state_transition_error * np.abs(Phi).max()
    # the estimate is the error's size, not a pessimistic bound: against a run at rtol 1e-13 (the rerun's
    # Jacobian is evaluated at each step's own time, also after a dense output's extra stages)
    tight = system.simulate(T, q0, v0, variational=True, rtol=1e-13)
    actual = np.abs(Phi - tight.state_transition).max()
    floor = 1e3 * EPS * np.abs(Phi).max()  # the tight run's own error: round-off over its steps
    assert actual <= 3 * traj.state_transition_error + floor
    assert traj.state_transition_error <= 100 * (actual + floor)


def test_state_transition_error_of_a_time_dependent_force():
    """The variational equations of a scene without drives but with a harmonic torque (its Jacobian depends
    on t): the transition's estimate is of the size of its actual error."""
    s = vd.Scene("forced pendulum", (0.0, 0.0, -G))
    s.add_body("pendulum", joint=vd.Pivot((0, 1, 0)), mass=0.5, com=(0.0, 0.0, -0.8))
    s.add_joint_force("pendulum", lambda t, q, v: 0.8 * math.sin(5.0 * t) * math.cos(q),
                      velocity_dependent=False)
    system = s.build()
    runs = [system.simulate(2.0, [0.4], [0.0], variational=True, rtol=r) for r in (1e-9, 1e-13)]
    actual = np.abs(runs[0].state_transition - runs[1].state_transition).max()
    floor = 1e3 * EPS * np.abs(runs[1].state_transition).max()  # the tight run's own error: round-off
    assert actual <= 3 * runs[0].state_transition_error + floor
    assert runs[0].state_transition_error <= 100 * (actual + floor)


def test_events_and_linearisation_with_drives():
    scene, law = carriage_pendulum()
    system = scene.build()
    crossing = lambda t, q, v: q[1]  # noqa: E731  (the pendulum passes its vertical)
    traj = system.simulate(2.0, [0.0, 0.4], [0.0, 0.0], events=crossing)
    assert len(traj.t_events[0]) >= 2
    for te, qe in zip(traj.t_events[0], traj.q_events[0]):
        assert qe[0] == pytest.approx(law.position(te), abs=1e-12)
    # linearised about a state of the motion, in the free coordinate: m l² δθ'' + m l (g + ÿ) cos θ δθ = 0
    t, th = 0.3, 0.2
    lm = system.linearize([0.0, th], v=[0.0, 0.0], t=t)
    m_p, l = 0.5, 0.8
    assert lm.coordinates == ("pendulum",)
    assert lm.M[0, 0] == pytest.approx(m_p * l**2, rel=1e3 * EPS)
    K = m_p * l * (G + law.acceleration(t)) * math.cos(th)
    assert abs(lm.K[0, 0] - K) <= 10 * lm.K_error[0, 0] + 1e3 * EPS * abs(K)
    assert lm.modes().omega[0] == pytest.approx(math.sqrt(K / (m_p * l**2)), rel=10 * lm.relative_error + 1e-12)
    assert lm.drive == system.drives.forces(lm.q, lm.v, t)
    exact = lm.relinearize("analytic")
    assert abs(exact.K[0, 0] - lm.K[0, 0]) <= 3 * (lm.K_error[0, 0] + exact.K_error[0, 0])


def test_steady_motion_of_a_driven_crank_and_its_vibration():
    """The crank at constant speed ω holds the sprung slider at x* = k x0 / (k − m ω²) (rotating frame), about
    which the slider vibrates at √(k/m − ω²); the drive needs no torque there (ẋ = 0)."""
    omega, k, m, x0 = 2.0, 50.0, 1.0, 0.3
    system = crank_with_sprung_slider(omega, k, m, x0).build()
    op = system.equilibrium(q0=[0.0, 0.3], t=0.4)
    assert op.q[0] == omega * 0.4 and op.v[0] == omega and op.v[1] == 0.0  # the driven crank: its law at t
    x_star = k * x0 / (k - m * omega**2)
    assert abs(op.q[1] - x_star) <= 3 * op.q_error[1] + 1e3 * EPS * x_star
    assert abs(op.drive["crank"]) <= 10 * op.tol
    lm = op.linearize()
    assert lm.coordinates == ("slider",) and lm.M[0, 0] == pytest.approx(m, rel=1e3 * EPS)
    assert abs(lm.K[0, 0] - (k - m * omega**2)) <= 3 * lm.K_error[0, 0] + 1e3 * EPS * k
    W = math.sqrt(k / m - omega**2)
    assert abs(lm.modes().omega[0] - W) <= W * (3 * lm.relative_error + 1e3 * EPS)
    assert lm.drive["crank.drive"] == pytest.approx(0.0, abs=1e3 * EPS * k * x_star**2)
    # a drive that accelerates at t leaves no equilibrium: refused, naming it
    scene, _ = carriage_pendulum(amplitude=0.05, omega=7.0)
    with pytest.raises(vd.ModelError, match=r"equilibrium: drive 'carriage.drive' accelerates at t = 0.3 s"):
        scene.build().equilibrium(t=0.3)


def test_bad_drives_are_refused_clearly(tmp_path):
    s = vd.Scene("bad")
    s.add_body("ball", joint=vd.Ball(), mass=1.0, inertia=np.eye(3))
    s.add_body("arm", "ball", joint=vd.Pivot((0, 0, 1)), mass=1.0, com=(1, 0, 0))
    with pytest.raises(vd.ModelError, match=r"drive on 'ball'.*one-coordinate.*'ball' has a ball joint"):
        s.add_drive("ball", vd.laws.Harmonic(0.1, 1.0))
    with pytest.raises(vd.ModelError, match=r"drive: unknown body 'nobody'"):
        s.add_drive("nobody", vd.laws.Harmonic(0.1, 1.0))
    with pytest.raises(vd.ModelError, match=r"drive 'arm.drive': motion must be a law of time"):
        s.add_drive("arm", 0.3)
    with pytest.raises(vd.ModelError, match=r"no acceleration"):
        s.add_drive("arm", vd.laws.HarmonicMotion((0, 0, 0.1), 2.0))
    s.add_drive("arm", vd.laws.Harmonic(0.1, 1.0))
    with pytest.raises(vd.ModelError, match=r"already driven by drive 'arm.drive' \(one drive per joint\)"):
        s.add_drive("arm", vd.laws.Harmonic(0.2, 1.0), name="second")
    with pytest.raises(vd.ModelError, match=r"support 'ground': vibdyn.laws.Harmonic moves one coordinate"):
        s.add_support("ground", vd.laws.Harmonic(0.1, 1.0))
    with pytest.raises(vd.ModelError, match=r"motion: acceleration must be a callable"):
        vd.laws.Motion(lambda t: 0.0, lambda t: 0.0, 3.0)
    # a Motion returning NaN: named where it is first evaluated
    scene, _ = carriage_pendulum()
    del scene.elements["carriage.drive"]
    scene.add_drive("carriage", vd.laws.Motion(lambda t: 0.0, lambda t: math.nan, lambda t: 0.0), name="lift")
    system = scene.build()
    with pytest.raises(vd.ModelError, match=r"drive 'lift': its motion's velocity\(t\) returned nan at t = 0 s"):
        system.simulate(1.0, [0.0, 0.1])
    with pytest.raises(vd.ModelError, match=r"drive 'lift'"):
        system.accelerations([0.0, 0.1], [0.0, 0.0], 0.0)
    with pytest.raises(vd.ModelError, match=r"held: scene .* has drives \(lift\)"):
        system.held()
    with pytest.raises(vd.ModelError, match=r"method 'symplectic' does not integrate a scene with drives"):
        carriage_pendulum()[0].build().simulate(1.0, [0.0, 0.1], method="symplectic", dt=1e-3)
    # a Python callable cannot be saved
    with pytest.raises(vd.ModelError, match=r"drive 'lift': a motion given as Python callables cannot be written"):
        scene.save(tmp_path / "lift.toml")


def test_scene_file_drive_errors_name_file_and_key(tmp_path):
    head = ('[[body]]\nname = "cart"\nmass = 1.0\njoint = { type = "slider", axis = [0.0, 0.0, 1.0] }\n'
            '[[body]]\nname = "ball"\nparent = "cart"\nmass = 1.0\ninertia = { shape = "sphere", radius = 0.1 }\n'
            'joint = { type = "ball" }\n')
    cases = {
        '[[drive]]\nbody = "cart"\nmotion = { law = "harmonic", amplitude = 0.1 }\n': r"key 'drive\[0\]'.*omega",
        '[[drive]]\nbody = "ball"\nmotion = { law = "harmonic", amplitude = 0.1, omega = 2.0 }\n':
            r"key 'drive\[0\]'.*ball joint",
        '[[drive]]\nbody = "cart"\nmotion = 3.0\n': r"key 'drive\[0\]\.motion'",
        '[[drive]]\nbody = "cart"\nmotion = { law = "harmonic", amplitude = 0.1, omega = 2.0 }\nspeed = 1.0\n':
            r"key 'drive\[0\]\.speed'",
        '[[drive]]\nmotion = { law = "harmonic", amplitude = 0.1, omega = 2.0 }\n': r"key 'drive\[0\]\.body'",
    }
    for i, (text, pattern) in enumerate(cases.items()):
        path = tmp_path / f"bad{i}.toml"
        path.write_text(head + text)
        with pytest.raises(vd.SceneFileError, match=rf"file .*bad{i}\.toml, {pattern}"):
            vd.load_scene(path)


def test_scene_file_round_trip_with_a_harmonic_drive(tmp_path):
    scene, law = carriage_pendulum(amplitude=0.05, omega=7.0, phase=0.25)
    path = tmp_path / "driven.toml"
    scene.save(path)
    assert "[[drive]]" in path.read_text()
    back = vd.load_scene(path)
    assert back.to_dict() == scene.to_dict()
    assert back.elements["carriage.drive"].motion == law
    a, b = scene.build(), back.build()
    q, v = np.array([0.0, 0.3]), np.array([0.0, -0.2])
    assert np.array_equal(a.accelerations(q, v, 0.37), b.accelerations(q, v, 0.37))
    from vibdyn.faces.cli import describe

    out = io.StringIO()
    describe(back, b, out)
    assert "carriage prescribed: 0.05·sin(7 t + 0.25) m" in out.getvalue()
