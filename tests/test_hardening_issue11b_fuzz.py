"""Fuzzing the public API's numeric arguments and scene-file values (issue 11): the only outcomes are a
finite result or a vibdyn error — never NaN or inf, never a raw exception."""

import math
import warnings

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vibdyn as vd

FUZZ = settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)

anything = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-1e3, max_value=1e3),
    st.integers(min_value=-10 ** 400, max_value=10 ** 400),
    st.sampled_from([None, "1", "abc", True, 1 + 2j, [], [1.0, 2.0], {"a": 1}]),
)
REFUSED = object()
positive = st.one_of(st.floats(min_value=1e-300, max_value=1e300), anything)


def finite(x):
    if isinstance(x, (float, int, np.floating)):
        return math.isfinite(x)
    if isinstance(x, np.ndarray):
        return x.dtype.kind not in "fc" or bool(np.all(np.isfinite(x)))
    return True


def outcome(fn):
    """Run fn: a vibdyn error is fine; a result must be finite; any other exception fails the test. numpy's
    overflow warnings are recorded, not printed: they may come on the way to a refusal, never with a result."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            out = fn()
        except vd.VibdynError:
            out = REFUSED
    assert all(issubclass(w.category, RuntimeWarning) for w in caught), [str(w.message) for w in caught]
    if out is REFUSED:
        return None
    assert not caught, f"a result reached through numpy warnings: {[str(w.message) for w in caught]}"
    for x in out if isinstance(out, tuple) else (out,):
        assert finite(x), f"non-finite result {x!r}"
    return out


def scene(mass, stiffness, g, inertia):
    s = vd.Scene("fuzz", gravity=(0.0, 0.0, g))
    s.add_body("cart", joint=vd.Slider((1, 0, 0)), mass=1.0)
    s.add_body("rod", parent="cart", joint=vd.Pivot((0, 1, 0)), mass=mass, com=(0, 0, -0.5),
               inertia=[[inertia, 0, 0], [0, inertia, 0], [0, 0, inertia]])
    s.add_spring("k", ("world", (-1, 0, 0)), "cart", stiffness)
    s.add_joint_damper("rod", 0.1)
    return s.build()


@FUZZ
@given(mass=positive, stiffness=positive, g=anything, inertia=positive)
def test_fuzz_scene_numbers(mass, stiffness, g, inertia):
    system = outcome(lambda: scene(mass, stiffness, g, inertia))
    if system is not None:
        outcome(lambda: system.accelerations(system.neutral(), np.zeros(2)))
        outcome(lambda: (lambda m: (m.omega, m.omega_error))(system.linearize().modes()))


@FUZZ
@given(q=anything, v=anything, t=anything, tol=anything, step=anything, iters=anything)
def test_fuzz_state_and_tolerances(q, v, t, tol, step, iters):
    system = scene(1.0, 10.0, -9.81, 0.01)
    outcome(lambda: system.accelerations([0.0, q], [v, 0.0], t))
    outcome(lambda: system.energy([q, 0.0], [0.0, v]).total)
    outcome(lambda: system.generalized_forces([q, 0.0], [v, 0.0], t))
    outcome(lambda: system.linearize(step=step).K)
    outcome(lambda: system.equilibrium(tol=tol, max_iter=iters).q)
    outcome(lambda: system.linearize().modes(tol=tol).omega)


@FUZZ
@given(t_end=positive, dt=positive, v0=anything, rtol=anything,
       method=st.sampled_from(["dop853", "rk4", "radau", "symplectic"]))
def test_fuzz_simulate(t_end, dt, v0, rtol, method):
    system = scene(1.0, 10.0, -9.81, 0.01)
    if isinstance(t_end, float) and t_end > 1.0 or isinstance(dt, float) and (dt < 1e-3 or method == "radau"):
        return  # time limit: a legitimate long run is not what this test is about
    outcome(lambda: system.simulate(t_end, v0=[v0, 0.0], method=method, dt=dt, rtol=rtol).q)


KEYS = ["mass", "com", "stiffness", "gravity", "axis"]


@FUZZ
@given(key=st.sampled_from(KEYS), value=st.one_of(
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.integers(min_value=-10 ** 400, max_value=10 ** 400).map(str),
    st.sampled_from(['"1"', "true", "[]", "[1.0]", "[1e308, 1e308, 1e308]", "[0.0, 0.0, 0.0]", "-1.0",
                     "{ a = 1 }", "nan", "inf", "[[1.0]]"])))
def test_fuzz_scene_file_values(tmp_path_factory, key, value):
    v = {"mass": "1.0", "com": "[0.0, 0.0, -0.5]", "stiffness": "10.0", "gravity": "[0.0, 0.0, -9.81]",
         "axis": "[1.0, 0.0, 0.0]"}
    v[key] = value
    text = (f'[scene]\nname = "x"\ngravity = {v["gravity"]}\n[[body]]\nname = "a"\nmass = {v["mass"]}\n'
            f'com = {v["com"]}\njoint = {{ type = "pivot", axis = {v["axis"]} }}\n'
            f'[[joint_spring]]\nbody = "a"\nstiffness = {v["stiffness"]}\n')
    p = tmp_path_factory.mktemp("fuzz") / "x.toml"
    p.write_text(text)
    system = outcome(lambda: vd.load_scene(p).build())
    if system is not None:
        outcome(lambda: system.accelerations(system.neutral(), np.zeros(system.nv)))
        outcome(lambda: system.linearize().modes().omega)
