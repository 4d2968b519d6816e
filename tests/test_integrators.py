"""The integrators' protocol (vibdyn.simulation.integrators): every METHODS entry integrates a harmonic
oscillator to within its own error estimate (closed form x = X0 cos ωt), reports its counters (with the
evaluation counts the Runge–Kutta tableaus imply), and its dense output agrees with a second run's output
times; Hairer's starting step; the registry is what simulate() and its error message read.

Tolerances: each run's own error estimate plus round-off (a few ε × X0 per step). The "rerun" and
"richardson" estimates are per output and first-order accurate: the true error differs from them by the
check run's own error (rerun at tolerances / 100: ≥ 20 times smaller for these methods of order ≥ 2) or by
the next term of the expansion (Richardson: relative O(ω·dt) = 2 %), hence the stated factor ESTIMATE_SLACK;
an error that oscillates through zero is compared with the largest estimate so far (the estimate bounds
the error up to that time). The "local" estimate (DOP853's summed local errors) ignores how earlier errors
propagate, as documented: the run's largest error is compared with its largest estimate. Dense outputs are
compared with the run's largest estimate (BDF's interpolant in its first order-1 steps is less accurate
than its steps, and the rerun at tighter tolerances interpolates on other steps).
"""

import math

import numpy as np
import pytest
from conftest import numpy_overflow

import vibdyn as vd
from vibdyn.simulation.integrators import ALIASES, METHODS, Stepper, method_class
from vibdyn.simulation.integrators.base import StepError, initial_step
from vibdyn.studies.examples import chain

OMEGA, X0, T_END = 2.0, 0.1, 10.0  # rad/s, m, s (three periods)
ESTIMATE_SLACK = 1.25
SYSTEM = chain(1, k=OMEGA ** 2, m=1.0).build()  # 1 kg on a slider, spring 4 N/m: x = X0 cos 2t
Q0 = SYSTEM.integrate(SYSTEM.neutral(), [X0])


def exact(t):
    return X0 * np.cos(OMEGA * np.asarray(t))


def settings(cls):
    return {"rtol": 1e-8} if cls.adaptive else {"dt": 0.01}


def run(name, **kwargs):
    return SYSTEM.simulate(T_END, q0=Q0, method=name, **{**settings(METHODS[name]), **kwargs})


def roundoff(traj):
    return 16 * np.finfo(float).eps * X0 * (1 + traj.accepted)


def test_registry_declares_every_method():
    assert set(METHODS) == {"dop853", "rk4", "radau", "bdf", "symplectic"}
    for name, cls in METHODS.items():
        assert issubclass(cls, Stepper) and cls.name == name and cls.order >= 2 and cls.error_methods
        assert cls.dense_output == cls.adaptive  # fixed-step methods land on their output times
    assert method_class("Variational") is METHODS[ALIASES["variational"]] and method_class("euler") is None
    with pytest.raises(vd.ModelError, match="unknown method 'euler'") as e:
        SYSTEM.simulate(1.0, method="euler")
    assert all(name in str(e.value) for name in METHODS)


def within_estimate(traj, q_err, v_err):
    """The errors (at every output) within the run's own estimate (see the module docstring)."""
    if traj.error_method == "local":
        return (q_err.max() <= traj.error + roundoff(traj)
                and v_err.max() <= traj.velocity_error + OMEGA * roundoff(traj))
    so_far = np.maximum.accumulate
    return (np.all(q_err <= ESTIMATE_SLACK * so_far(traj.q_error) + roundoff(traj))
            and np.all(v_err <= ESTIMATE_SLACK * so_far(traj.v_error) + OMEGA * roundoff(traj)))


@pytest.mark.parametrize("name,error", [(n, e) for n in sorted(METHODS) for e in METHODS[n].error_methods])
def test_harmonic_oscillator_within_its_own_error_estimate(name, error):
    t = np.linspace(0.0, T_END, 41)  # inside steps for the adaptive methods: their dense output
    traj = run(name, t_eval=t, error_method=error)
    np.testing.assert_array_equal(traj.t, t)
    assert traj.error_method == error
    q_err = np.abs(traj.q[:, 0] - exact(t))
    v_err = np.abs(traj.v[:, 0] + OMEGA * X0 * np.sin(OMEGA * t))
    print(f"[integrators] {name}: largest error {q_err.max():.2e}, estimate {traj.error:.2e} ({error}), "
          f"{traj.accepted} steps, {traj.nfev} evaluations")
    assert within_estimate(traj, q_err, v_err)
    assert traj.error < 1e-3 * X0  # and the estimate is not vacuous


@pytest.mark.parametrize("name", sorted(METHODS))
def test_counters(name):
    traj = run(name)
    cls = METHODS[name]
    assert traj.accepted > 0 and traj.nfev > traj.accepted and traj.error_nfev > 0 or traj.error_method == "local"
    if name == "rk4":  # f(t0) once, then 4 evaluations a step (the last one is the next step's first stage)
        assert traj.nfev == 1 + 4 * traj.accepted
    if name == "dop853":  # f(t0), one Euler probe of the starting step, then 12 per attempted step (FSAL)
        assert traj.nfev == 2 + 12 * (traj.accepted + traj.rejected)
    if name in ("radau", "bdf", "symplectic"):  # Newton iterations: Jacobians and factorisations
        assert traj.njev >= 1 and traj.nlu >= 1
    else:
        assert traj.njev == traj.nlu == 0
    assert (traj.rejected is None) == (name in ("radau", "bdf"))
    if not cls.adaptive:
        assert traj.accepted == math.ceil(T_END / 0.01 / 2) * 2  # an even number of equal steps ≤ dt


@pytest.mark.parametrize("name", sorted(n for n, c in METHODS.items() if c.dense_output))
def test_dense_output_agrees_with_a_second_run(name):
    """Output times do not change the steps: a run asked for its own step times plus the midpoints gives
    the first run's states exactly at the steps, and the dense output at the midpoints within its estimate."""
    first = run(name, error_method="rerun")
    mid = 0.5 * (first.t[1:] + first.t[:-1])
    t = np.sort(np.concatenate([first.t, mid]))
    second = run(name, t_eval=t, error_method="rerun")
    at_steps = np.isin(second.t, first.t)
    np.testing.assert_array_equal(second.q[at_steps], first.q)
    np.testing.assert_array_equal(second.v[at_steps], first.v)
    assert second.accepted == first.accepted and second.nfev >= first.nfev
    t_mid = second.t[~at_steps]
    q_err = np.abs(second.q[~at_steps, 0] - exact(t_mid))
    v_err = np.abs(second.v[~at_steps, 0] + OMEGA * X0 * np.sin(OMEGA * t_mid))
    assert q_err.max() <= ESTIMATE_SLACK * second.error + roundoff(second)
    assert v_err.max() <= ESTIMATE_SLACK * second.velocity_error + OMEGA * roundoff(second)


@pytest.mark.parametrize("name", sorted(METHODS))
def test_a_stepper_used_directly(name):
    """The constructor every method shares, and the stepping protocol (step or step_to) to t_end."""
    cls = METHODS[name]
    atol = np.array([1e-10])
    stepper = cls(SYSTEM, Q0, np.zeros(1), 1.0, rtol=1e-8, atol_q=atol, atol_v=atol)
    if cls.adaptive:
        while stepper.t < 1.0:
            stepper.step()
    else:
        for t in np.linspace(0.01, 1.0, 100):
            stepper.step_to(t)
    q, v, w = stepper.state
    assert stepper.t == 1.0 and w == 0.0
    # adaptive: 1e-8 per step; fixed: the leading phase error ~ X0·ωt·(ω·dt)^order (far above it)
    bound = 1e-5 * X0 if cls.adaptive else X0 * OMEGA * (OMEGA * 0.01) ** cls.order
    assert abs(SYSTEM.difference(SYSTEM.neutral(), q)[0] - exact(1.0)) < bound
    nfev, njev, nlu, accepted, rejected = stepper.counters
    assert nfev == stepper.nfev > 0 and accepted == stepper.accepted > 0
    with pytest.raises(NotImplementedError):
        (stepper.step_to(2.0) if cls.adaptive else stepper.step())


def test_initial_step_is_hairers():
    """y' = λy: h0 = 0.01·‖y‖/‖f‖ = 0.01/|λ|, h1 = (0.01/max(‖f‖, ‖f′‖))^(1/(p+1)); the step is min(100 h0, h1)."""
    lam, rtol = -3.0, 1e-6
    y0 = np.array([1.0])
    f = lambda t, y: lam * y  # noqa: E731
    atol = np.array([1e-9])
    scale = atol + rtol
    d1 = abs(lam) / scale[0]
    h0 = 0.01 / abs(lam)
    d2 = abs(lam * (lam * h0)) / scale[0] / h0
    expected = min(100 * h0, (0.01 / max(d1, d2)) ** (1 / 8))
    h = initial_step(f, 0.0, y0, f(0.0, y0), 10.0, np.inf, 7, rtol, atol)
    assert h == pytest.approx(expected, rel=1e-12)
    assert initial_step(f, 0.0, y0, f(0.0, y0), 1e-9, np.inf, 7, rtol, atol) == 1e-9  # never past t_end
    assert initial_step(f, 0.0, y0, f(0.0, y0), 10.0, 1e-7, 7, rtol, atol) == 1e-7  # nor above max_step


def test_initial_step_of_a_state_too_large_for_the_arithmetic_is_a_step_error():
    """‖f0‖ in tolerance units overflows: no first step can be chosen; the RMS
    norm must not overflow to a zero step (a raw ZeroDivisionError before), and simulate says why."""
    y0 = np.array([0.0, 1e305])  # f0 / atol = 1e313: inf in double precision
    with numpy_overflow(), pytest.raises(StepError, match="too large"):
        initial_step(lambda t, y: np.array([y[1], 0.0]), 0.0, y0, np.array([1e305, 0.0]), 1.0, np.inf, 7, 1e-8,
                     1e-8)
    s = vd.Scene("spin")
    s.add_body("r", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=np.eye(3))
    with pytest.raises(vd.VibdynError):
        s.build().simulate(1e-3, v0=[1e160])


def test_a_chains_chart_velocity_is_exact_on_every_ball():
    """ξ̇ = J_r⁻¹(ξ) v on each ball of a chart (ChartODE.into), for chains of 2 and 6 balls: equal to the exact
    oracle (the inverse of ∫₀¹ exp(−s[ξ]×) ds by scipy's expm) to 1e-14 with each ball's rotation at 1e-5 … 0.3 rad,
    inside Pinocchio 4.1's inexact Jlog3 band too (1.2e-4 … 2.4e-3 rad, where its product is off by up to 2e-9).
    Its effect on a run: the 10-ball chain at rtol 1e-11 and 1e-13 differed by 7.3e-10 rad with estimates of 2.1e-10
    and 3.3e-10 (the tighter run's larger: noise); now by 9.9e-11, estimates 1.1e-10 and 2.1e-11."""
    import pinocchio as pin
    from scipy.linalg import expm

    from benchmarks.bench_simulate import ball_chain
    from vibdyn.simulation.integrators.chart import make_ode

    def exact_inverse(xi):
        block = np.zeros((6, 6))
        block[:3, :3], block[:3, 3:] = -pin.skew(xi), np.eye(3)
        return np.linalg.inv(expm(block)[:3, 3:])

    rng = np.random.default_rng(12)
    thetas = [1e-5, 1.3e-4, 5e-4, 2e-3, 0.05, 0.3]
    for n in (2, 6):
        system = ball_chain(n)
        q0 = system.integrate(system.neutral(), 0.3 * rng.standard_normal(system.nv))
        ode, y = make_ode(system, q0, np.zeros(system.nv))
        for _ in range(3):
            xi = np.concatenate([t * u / np.linalg.norm(u) for t, u in
                                 zip(rng.permutation(thetas)[:n], rng.standard_normal((n, 3)))])
            v = rng.standard_normal(system.nv)
            y[:system.nv], y[system.nv:2 * system.nv] = xi, v
            out = np.empty(ode.n)
            ode.into(0.0, y, out)
            exact = np.concatenate([exact_inverse(xi[3 * i:3 * i + 3]) @ v[3 * i:3 * i + 3] for i in range(n)])
            assert np.abs(out[:system.nv] - exact).max() <= 1e-14 * max(1.0, np.abs(v).max())


def test_a_ball_joints_chart_term_in_closed_form_matches_pinocchios_hessian_and_its_limit():
    """∂(J_r⁻¹(ξ) v)/∂ξ, the chart's own term in the Jacobian of a ball joint (variational equations, implicit
    steps): equal to Pinocchio's Hlog3(exp3 ξ, v)ᵀ Jexp3(−ξ) where that is finite (θ ≥ 0.05 rad, to 1e-12), to
    −½[v]× at ξ = 0 (where Hlog3 is NaN: every step's chart starts there), continuous across the series' threshold,
    and the derivative of Pinocchio's Jlog3 · v by fourth-order differences at rotations where Jlog3 is exact."""
    import pinocchio as pin

    from vibdyn.model.points import SERIES_BELOW, so3_chart_term

    rng = np.random.default_rng(7)
    for theta in (0.05, 0.19, 0.21, 0.5, 1.0, 2.0, 3.0):
        u, v = rng.standard_normal(3), rng.standard_normal(3)
        xi = theta * u / np.linalg.norm(u)
        ref = pin.Hlog3(pin.exp3(xi), v).T @ pin.Jexp3(-xi)
        assert np.abs(so3_chart_term(xi, v) - ref).max() <= 1e-12 * max(1.0, np.abs(ref).max())

        def f(x):
            return pin.Jlog3(pin.exp3(x)) @ v

        h = 1e-3
        fd = np.array([(8 * (f(xi + h * e) - f(xi - h * e)) - (f(xi + 2 * h * e) - f(xi - 2 * h * e))) / (12 * h)
                       for e in np.eye(3)]).T
        assert np.abs(so3_chart_term(xi, v) - fd).max() <= 1e-10 * max(1.0, np.abs(fd).max())
    v = rng.standard_normal(3)
    assert np.array_equal(so3_chart_term(np.zeros(3), v), pin.skew(-0.5 * v))
    assert not np.all(np.isfinite(pin.Hlog3(np.eye(3), v)))  # (why the closed form is ours)
    u = rng.standard_normal(3)
    below, above = (SERIES_BELOW * (1 + s * 1e-12) * u / np.linalg.norm(u) for s in (-1, 1))
    assert np.abs(so3_chart_term(below, v) - so3_chart_term(above, v)).max() <= 1e-13


def test_a_ball_joints_chart_jacobians_in_closed_form_match_an_exact_oracle():
    """J_r(ξ) and J_r⁻¹(ξ) of a ball joint (the chart's ξ̇ = J_r⁻¹(ξ) v, the Jacobians of the variational equations
    and of the joint springs), one state at a time and many at once: J_r equals ∫₀¹ exp(−s[ξ]×) ds (scipy's expm of
    the block matrix [[−[ξ]×, I], [0, 0]]: an oracle exact to round-off) and J_r⁻¹ its inverse, to 1e-14 at every
    rotation, across the series' threshold — also between 1.2e-4 and 3e-3 rad, where Pinocchio 4.1's Jlog3 is off
    by up to 2e-9 and its Jexp3 by 1e-13 (why the closed forms are ours: every step's chart starts at ξ = 0 and passes
    there, a vector-field error no tolerance would see); the rows' chart terms equal so3_chart_term's."""
    import pinocchio as pin
    from scipy.linalg import expm

    from vibdyn.model.points import SERIES_BELOW, so3_chart_term, so3_dexp_inv, so3_jacobians, so3_jr_inv

    rng = np.random.default_rng(11)
    thetas = [0.0, 1e-8, 1e-5, 1.7e-4, 5e-4, 1e-3, 2e-3, 0.05, SERIES_BELOW * 0.999, SERIES_BELOW * 1.001, 0.5, 1.5,
              3.0]
    xis = np.array([t * u / np.linalg.norm(u) for t, u in zip(thetas, rng.standard_normal((len(thetas), 3)))])
    vs = rng.standard_normal(xis.shape)
    Jr, Jri, terms = so3_jacobians(xis, vs)
    for xi, v, a, b, term in zip(xis, vs, Jr, Jri, terms):
        block = np.zeros((6, 6))
        block[:3, :3], block[:3, 3:] = -pin.skew(xi), np.eye(3)
        exact = expm(block)[:3, 3:]
        inverse = np.linalg.inv(exact)
        scale = max(1.0, np.abs(inverse).max())
        assert np.abs(a - exact).max() <= 1e-14 * scale
        assert np.abs(b - inverse).max() <= 1e-14 * scale
        assert np.abs(so3_jr_inv(xi) - inverse).max() <= 1e-14 * scale
        assert np.abs(np.array(so3_dexp_inv(np.r_[1.0, xi], np.r_[2.0, v], [1])) - np.r_[2.0, inverse @ v]).max() <= (
            1e-14 * scale * max(1.0, np.abs(v).max()))
        assert np.abs(term - so3_chart_term(xi, v)).max() <= 1e-13 * max(1.0, np.abs(term).max())


def test_the_stepper_base_keeps_time_direction_status_and_its_last_step():
    """scipy's OdeSolver bookkeeping in the base class: t_old is the last step's start, direction +1, status
    "running" until t_end is reached, then "finished", and a step past it is refused; the last step's dense
    output (on demand) meets the state at both ends of the step and the closed form inside it."""
    cls = METHODS["dop853"]
    atol = np.array([1e-10])
    stepper = cls(SYSTEM, Q0, np.zeros(1), 1.0, rtol=1e-10, atol_q=atol, atol_v=atol)
    assert stepper.t_old is None and stepper.direction == 1.0 and stepper.status == "running"
    with pytest.raises(StepError):
        stepper.interpolant()
    while stepper.status == "running":
        q_old = stepper.state[0]
        stepper.step()
        dense = stepper.interpolant()
        assert dense is stepper.interpolant()  # (made once per step)
        assert abs(dense(stepper.t_old)[0][0] - q_old[0]) <= 1e-14
        assert abs(dense(stepper.t)[0][0] - stepper.state[0][0]) <= 1e-14
        mid = 0.5 * (stepper.t_old + stepper.t)
        assert abs(dense(mid)[0][0] - exact(mid)) <= 1e-8 * X0
    assert stepper.t == 1.0 and stepper.status == "finished" and stepper.t_old < 1.0
    with pytest.raises(StepError, match="finished"):
        stepper.step()


def test_simulate_takes_a_stepper_class():
    """method= a Stepper subclass (here DOP853 under another name): the same run as by its registered name."""
    class Renamed(METHODS["dop853"]):
        name = "my dop853"

    a, b = run("dop853"), SYSTEM.simulate(T_END, q0=Q0, method=Renamed, rtol=1e-8)
    assert b.method == "my dop853" and np.array_equal(a.q, b.q) and np.array_equal(a.q_error, b.q_error)
    assert method_class(Renamed) is Renamed and method_class(Stepper) is None  # (a class without a name: no method)
    with pytest.raises(vd.ModelError, match="unknown method"):
        SYSTEM.simulate(T_END, q0=Q0, method=int)


def test_a_flow_is_simulate_without_its_per_call_checks():
    """vibdyn.simulation.flow.Flow, checked once, then called per state: the same end state, error estimate,
    state transition and its error as simulate with the same settings (bit for bit: the same pieces); bad
    settings refused when it is made; a Trajectory (energies) when asked for."""
    from vibdyn.simulation.flow import Flow

    v0 = np.array([0.05])
    for error in ("local", "rerun"):
        flow = Flow(SYSTEM, rtol=1e-9, variational=True, error_method=error)
        for t0, t1 in ((0.0, 1.0), (0.5, 3.0)):
            r = flow(Q0, v0, t0, t1)
            s = vd.simulate(SYSTEM, t1, Q0, v0, t0=t0, rtol=1e-9, variational=True, error_method=error)
            assert np.array_equal(r.q[-1], s.q[-1]) and np.array_equal(r.v[-1], s.v[-1])
            assert np.array_equal(r.state_transition, s.state_transition)
            assert r.state_transition_error == s.state_transition_error and r.error == s.error
            assert r.error_method == s.error_method == error
    traj = flow(Q0, v0, 0.0, 1.0, t_eval=[0.25, 0.5, 1.0], trajectory=True)
    assert isinstance(traj, vd.Trajectory) and len(traj.energy) == 3
    with pytest.raises(vd.ModelError, match="rtol"):
        Flow(SYSTEM, rtol=2.0)


def test_a_flows_state_transition_may_be_held_to_its_own_looser_tolerance():
    """Flow(transition_rtol=): DOP853 holds Φ's error to it instead of rtol (never tighter than rtol's). On the
    ball pendulum with a point spring, Φ at 1e-6 beside a state at 1e-10 takes fewer steps than Φ at 1e-10, the
    state's end the same within both runs' own error estimates (the state is still held to rtol), Φ within 100×
    its looser tolerance of the tight Φ; a rerun's estimate of Φ's error reruns it at transition_rtol / 100 too, and
    covers the difference to the tight Φ. A transition_rtol below rtol is refused."""
    from benchmarks.nonlinear_speed import ball_point_spring
    from vibdyn.simulation.flow import Flow

    system = ball_point_spring()
    q0 = system.integrate(system.neutral(), np.array([0.0, 0.8, 0.0]))
    v0 = np.zeros(3)
    tight = Flow(system, q0, v0, rtol=1e-10, variational=True, error_method="rerun")(q0, v0, 0.0, 1.5)
    loose = Flow(system, q0, v0, rtol=1e-10, variational=True, transition_rtol=1e-6,
                 error_method="rerun")(q0, v0, 0.0, 1.5)
    assert loose.accepted < tight.accepted
    assert np.abs(system.difference(tight.q[-1], loose.q[-1])).max() <= tight.error + loose.error
    gap = np.abs(loose.state_transition - tight.state_transition).max()
    scale = np.abs(tight.state_transition).max()
    assert gap <= 100 * 1e-6 * scale
    assert gap <= loose.state_transition_error + tight.state_transition_error
    with pytest.raises(vd.ModelError, match="transition_rtol"):
        Flow(system, q0, v0, rtol=1e-8, variational=True, transition_rtol=1e-9)
