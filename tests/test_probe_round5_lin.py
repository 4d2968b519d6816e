"""Issue 40, round five (linear core): probes that found a fault, each against an independent oracle."""
import re

import numpy as np
import pytest
from scipy.optimize import brentq

import vibdyn as vd

G = 9.81


def _torqued_pendulum():
    """A pendulum (1 kg at 0.5 m) with a joint torque 3 − 0.1 a (N·m): equilibrium 3 − 0.1 a = m g l sin a."""
    s = vd.Scene("p", gravity=(0, 0, -G))
    s.add_body("a", joint=vd.Pivot((1, 0, 0)), mass=1.0, com=(0, 0, -0.5), inertia=np.diag([.01, .01, .01]))
    s.add_joint_force("a", lambda t, q, v: 3.0 - 0.1 * q, velocity_dependent=False, time_dependent=False)
    return s.build()


@pytest.mark.parametrize("max_iter", [2, 3])
def test_a_suggested_start_is_one_the_search_converges_from(max_iter):
    """The start a failed search suggests was checked: from it the same search (same max_iter) converges, to the
    equilibrium the message quotes (was a half-unit step, a = 1.14, farther off than where it stopped, 0.6417)."""
    truth = brentq(lambda a: 3.0 - 0.1 * a - 1.0 * G * 0.5 * np.sin(a), 0.0, 1.5)
    S = _torqued_pendulum()
    with pytest.raises(vd.ConvergenceError) as err:
        S.equilibrium(max_iter=max_iter)
    text = str(err.value)
    start = float(re.search(r"`--start a=([-0-9.e+]+)`", text).group(1))
    assert "(checked)" in text
    quoted = float(re.search(r"converges to the static equilibrium at a = ([-0-9.e+]+) rad", text).group(1))
    assert abs(quoted - truth) <= 1e-5
    eq = S.equilibrium([start], max_iter=max_iter)
    assert abs(eq.q[0] - truth) <= eq.q_error[0] + 1e-12


def test_no_start_is_suggested_where_none_converges():
    """A torque 2 + 0.5 sin q never balances: no start is suggested (was `--start wheel=-1.07`)."""
    s = vd.Scene("driven")
    s.add_body("wheel", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=vd.inertia.disc(1.0, 0.1))
    s.add_joint_force("wheel", lambda t, q, v: 2.0 + 0.5 * np.sin(q), velocity_dependent=False,
                      time_dependent=False)
    with pytest.raises(vd.ConvergenceError) as err:
        s.build().equilibrium(max_iter=10)
    assert "--start" not in str(err.value) and "No start was suggested" in str(err.value)


def test_an_unknown_speed_that_did_not_settle_is_named_and_its_checked_guess_suggested():
    """A rotor driven by τ = 10 − ω² (steady speed √10) sought with too few iterations: the message names the
    speed that did not settle (was "not settled: none") and suggests a guess from which the same search converges
    to √10 (was no usable hint: a start changing only the configuration)."""
    s = vd.Scene("r")
    s.add_body("rotor", joint=vd.Pivot((0, 0, 1)), mass=1.0, inertia=np.diag([.1, .1, .1]))
    s.add_body("sl", parent="rotor", joint=vd.Slider((1, 0, 0)), mass=0.5, inertia=np.eye(3) * 1e-3)
    s.add_joint_spring("sl", 100.0)
    s.add_joint_force("rotor", lambda t, q, v: 10 - v ** 2, velocity_dependent=True, time_dependent=False)
    S = s.build()
    with pytest.raises(vd.ConvergenceError) as err:
        S.steady_motion({"rotor": None}, max_iter=3)
    text = str(err.value)
    assert "not settled: the speed of 'rotor'" in text and "(checked)" in text
    guess = float(re.search(r"guess=([0-9.e+-]+)", text).group(1))
    quoted = float(re.search(r"'rotor' turning at ([0-9.e+-]+) rad/s", text).group(1))
    assert abs(quoted - np.sqrt(10.0)) <= 1e-5
    st = S.steady_motion({"rotor": None}, max_iter=3, guess=guess)
    assert abs(st.speeds["rotor"] - np.sqrt(10.0)) <= 1e-9


def test_equilibria_without_starts_says_so():
    """`equilibria([])` was "no start converged" (a ConvergenceError, not a ValueError) when none was given."""
    with pytest.raises(ValueError, match="equilibria: starts is empty"):
        _torqued_pendulum().equilibria([])


def _slider_chain(ms, ks):
    s = vd.Scene("chain")
    parent = "world"
    for i, (m, k) in enumerate(zip(ms, ks)):
        s.add_body(f"b{i}", parent=parent, joint=vd.Slider((1, 0, 0)), mass=m, inertia=np.eye(3) * m * 1e-3)
        s.add_joint_spring(f"b{i}", k)
        parent = f"b{i}"
    return s.build()


def test_modes_stay_ascending_when_a_mode_within_its_error_of_zero_lies_above_a_resolved_one():
    """Masses 1e-3..1e4 kg and springs 1e-4..1e7 N/m in series: two modes whose ω² is within its error of 0 are
    zeroed; they were left in place above a resolved one (ω = [0, 8.4e-4, 0, ...]), against the documented
    ascending order. The spectrum still matches scipy's of the hand-assembled M = LᵀdiagmL, K = diag k within the
    stated errors (each true ω in a computed ω ± error, one to one)."""
    from scipy.linalg import eigh

    logm = [3.8, 3.4, -2.6, 0.9, 1.6, 3.5, 1.3, -2.9, -0.0, -0.1, 0.0, 3.7]
    logk = [-2.4, -4.4, 0.4, 2.3, 7.0, 1.3, -3.7, 6.9, -0.1, 2.8, -0.4, -4.5]
    ms, ks = 10.0 ** np.array(logm), 10.0 ** np.array(logk)
    m = _slider_chain(ms, ks).linearize().modes()
    assert m.rigid.any() and np.all(np.diff(m.omega2) >= 0)
    L = np.tril(np.ones((len(ms), len(ms))))
    truth = np.sqrt(np.abs(eigh(np.diag(ks), L.T @ np.diag(ms) @ L, eigvals_only=True)))
    lo, hi, used = m.omega - m.omega_error, m.omega + m.omega_error, np.zeros(len(ms), bool)
    for w in np.sort(truth):
        slack = 1e-9 * w  # (the reference's own round-off)
        fits = np.flatnonzero(~used & (lo <= w + slack) & (w - slack <= hi))
        assert fits.size, w
        used[fits[np.argmin(hi[fits])]] = True


def test_a_weak_spring_under_a_weight_is_not_called_no_dependence_on_q():
    """A 2 kg slider under gravity on a 1e-8 N/m spring balances at x = −m g / k = −1.96e9 m: its force does depend
    on x. The refusal said "it does not depend on q ... there is no stationary point"; it now says the force is
    nearly constant and no balance is within reach (a weightless one, exactly constant, keeps the plain words)."""
    s = vd.Scene("weak", gravity=(0, 0, -G))
    s.add_body("b", joint=vd.Slider((0, 0, 1)), mass=2.0, inertia=np.eye(3) * 1e-3)
    s.add_joint_spring("b", 1e-8)
    with pytest.raises(vd.ConvergenceError) as err:
        s.build().equilibrium()
    text = str(err.value)
    assert "does not depend on q" not in text and "nearly" in text and "within reach" in text


def test_an_equilibrium_far_off_is_suggested_from_the_linear_models_whole_step():
    """A 1 kg slider on a 0.1 N/m spring in a scene a millimetre across balances at −m g/k = −98.1 m, beyond the
    search's capped steps (it stops near −1e-4 m). The suggested start is the linear model's whole step from there,
    checked: the same search converges from it to −98.1 m."""
    s = vd.Scene("weak", gravity=(0, 0, -G))
    s.add_body("b", joint=vd.Slider((0, 0, 1)), mass=1.0, inertia=np.eye(3) * 1e-6)
    s.add_joint_spring("b", 0.1)
    S = s.build()
    with pytest.raises(vd.ConvergenceError) as err:
        S.equilibrium()
    text = str(err.value)
    start = float(re.search(r"`--start b=([-0-9.e+]+)`", text).group(1))
    assert "(checked)" in text
    eq = S.equilibrium([start])
    assert abs(eq.q[0] + G / 0.1) <= eq.q_error[0] + 1e-12 * G / 0.1
