"""Fuzzing (issue 11): over the public API's numeric arguments and over scene-file values, the only outcomes
are a finite result or a vibdyn error — never NaN/inf, never a raw exception, never a run past a deadline.
"""

import math
import time
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vibdyn as vd

# numbers a hostile caller passes: ordinary, tiny, huge, signed zeros, NaN, inf, wrong types
EXTREME = st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e-18, 1e300, -1e300, 1e200, float("nan"), float("inf"),
                           -float("inf"), 10**400, True, "1", None, 1 + 1j])
NUMBER = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-1e3, 1e3), EXTREME)
SANE = st.floats(1e-3, 1e3)
LIMIT_S = 10.0  # wall time of one example (s): far above what a finite result or a refusal takes here


def finite(x):
    """Every number reachable in a result is finite."""
    if x is None or isinstance(x, (str, bool)):
        return True
    if isinstance(x, (int, float, complex, np.number, np.ndarray)):
        return bool(np.all(np.isfinite(x)))
    if isinstance(x, dict):
        return all(finite(v) for v in x.values())
    if isinstance(x, (list, tuple)):
        return all(finite(v) for v in x)
    return all(finite(getattr(x, k)) for k in ("q", "v", "omega", "omega2", "shapes", "K", "M", "C", "residual",
                                                "kinetic", "gravity", "elastic") if hasattr(x, k))


def outcome(call):
    """'ok' (finite result) or 'refused' (vibdyn error); anything else fails the test. numpy's overflow
    warnings are recorded, not printed: they may come on the way to a refusal, never with a result."""
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = call()
        except vd.VibdynError:
            result = REFUSED
        finally:
            assert time.perf_counter() - start < LIMIT_S
    # vibdyn's own warnings that say what it did (a start in degrees?, an analytic model refused by its check
    # against differences and replaced by them) may come with a result; numpy's may not
    told = [w for w in caught if issubclass(w.category, UserWarning) and str(w.message).startswith(TOLD)]
    caught = [w for w in caught if w not in told]
    assert all(issubclass(w.category, RuntimeWarning) for w in caught), [str(w.message) for w in caught]
    if result is REFUSED:
        return "refused"
    assert not caught, f"a result reached through numpy warnings: {[str(w.message) for w in caught]}"
    assert finite(result), f"non-finite result without an error: {result!r}"
    return "ok"


REFUSED = object()
TOLD = ("simulate: q0:", "linearize: the analytic")  # vibdyn's warnings that come with a right result


def pendulum(mass, inertia, stiffness, gravity):
    s = vd.Scene("fuzz", gravity=(0.0, 0.0, gravity))
    s.add_body("rod", joint=vd.Pivot((0, 1, 0)), mass=mass, com=(0, 0, -0.5), inertia=np.eye(3) * inertia)
    s.add_body("cart", parent="rod", joint=vd.Slider((0, 0, 1)), mass=mass, com=(0, 0, 0))
    s.add_joint_spring("cart", stiffness)
    s.add_joint_damper("cart", 0.1)
    return s.build()


FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)


@FUZZ
@given(mass=NUMBER, inertia=NUMBER, stiffness=NUMBER, gravity=NUMBER)
def test_fuzz_scene_parameters(mass, inertia, stiffness, gravity):
    def run():
        system = pendulum(mass, inertia, stiffness, gravity)
        lin = system.linearize()
        return system.accelerations(system.neutral(), np.zeros(2)), lin, lin.modes()

    outcome(run)


GOOD = pendulum(1.0, 0.01, 100.0, -9.81)


@FUZZ
@given(q=st.lists(NUMBER, min_size=2, max_size=2), v=st.lists(NUMBER, min_size=2, max_size=2), t=NUMBER)
def test_fuzz_states(q, v, t):
    outcome(lambda: GOOD.accelerations(q, v, t))
    outcome(lambda: GOOD.generalized_forces(q, v, t))
    outcome(lambda: GOOD.energy(q, v, t))
    outcome(lambda: GOOD.inverse_dynamics(q, v, v, t))
    outcome(lambda: GOOD.mass_matrix(q))


@FUZZ
@given(step=NUMBER, tolerance=NUMBER, tol=NUMBER, max_iter=st.one_of(st.integers(-5, 50), NUMBER),
       method=st.sampled_from(["fd", "analytic", "x", 3]))
def test_fuzz_analysis_arguments(step, tolerance, tol, max_iter, method):
    outcome(lambda: GOOD.linearize(step=step, method=method).modes())
    outcome(lambda: GOOD.linearize().modes(tol=tolerance))
    outcome(lambda: GOOD.equilibrium([0.1, 0.0], tol=tol, max_iter=max_iter))
    outcome(lambda: vd.rayleigh((tol, tolerance), (1.0, 10.0)))


@FUZZ
@given(t_end=st.one_of(st.floats(1e-6, 0.05), NUMBER), steps=st.integers(-3, 200),
       method=st.sampled_from(["dop853", "rk4", "radau", "symplectic"]), q0=st.lists(NUMBER, min_size=2, max_size=2),
       v0=st.lists(st.one_of(SANE, NUMBER), min_size=2, max_size=2), rtol=st.one_of(st.just(1e-6), NUMBER))
def test_fuzz_simulation(t_end, steps, method, q0, v0, rtol):
    # the step count is bounded by construction (an absurd one is refused, see test_hardening.py)
    dt = t_end / steps if isinstance(t_end, float) and steps and math.isfinite(t_end) else steps
    with np.errstate(all="ignore"):
        outcome(lambda: GOOD.simulate(t_end, q0=q0, v0=v0, method=method, rtol=rtol,
                                      dt=dt if method in ("rk4", "symplectic") else None, max_step=0.01))


TOML_VALUE = st.sampled_from(["1.0", "0.0", "-1.0", "1e-18", "1e300", "-1e300", "nan", "inf", "-inf", "1" + "0" * 400,
                              "-1" + "0" * 400, '"1"', "true", "[]", "[1.0, 2.0]", "{}", "0x10", "1e-320"])


@FUZZ
@given(mass=TOML_VALUE, com=TOML_VALUE, inertia=TOML_VALUE, stiffness=TOML_VALUE, gravity=TOML_VALUE,
       axis=st.sampled_from(["[1, 0, 0]", "[0, 0, 0]", "[1e300, 1e300, 0]", "[nan, 0, 0]", "1.0"]))
def test_fuzz_scene_file_values(tmp_path_factory, mass, com, inertia, stiffness, gravity, axis):
    text = f"""
[scene]
name = "fuzz"
gravity = [0.0, 0.0, {gravity}]
[[body]]
name = "b"
mass = {mass}
com = [0.0, 0.0, {com}]
inertia = [{inertia}, {inertia}, {inertia}]
joint = {{ type = "pivot", axis = {axis} }}
[[joint_spring]]
body = "b"
stiffness = {stiffness}
"""
    f = tmp_path_factory.mktemp("fuzz") / "s.toml"
    f.write_text(text)

    def run():
        system = vd.load_scene(f).build()
        return system.accelerations(system.neutral(), np.zeros(system.nv)), system.linearize().modes()

    outcome(run)


@pytest.mark.parametrize("value", ["1" + "0" * 400, "nan", "inf"])
def test_scene_file_number_keys_refuse_extremes(tmp_path, value):
    f = tmp_path / "s.toml"
    f.write_text(f'[[body]]\nname = "b"\nmass = {value}\njoint = {{ type = "slider", axis = [1, 0, 0] }}\n')
    with pytest.raises(vd.SceneFileError, match="mass"):
        vd.load_scene(f)
