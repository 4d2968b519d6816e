"""Public names (issue 33, item 4): vd.<name> is never a module shadowing the function of the same name."""

import warnings

import numpy as np
import pytest

import vibdyn as vd


def test_simulate_linearize_equilibrium_are_the_functions():
    """vd.simulate(system, 1.0) runs (it raised "module is not callable"): the same trajectory as
    System.simulate; vd.linearize and vd.equilibrium give System's results."""
    system = vd.load_scene("rod_pivot").build()
    q0 = system.configuration([0.3])
    a, b = vd.simulate(system, 1.0, q0), system.simulate(1.0, q0)
    np.testing.assert_array_equal(a.q, b.q)
    eq = vd.equilibrium(system)
    assert np.array_equal(eq.q, system.equilibrium().q)
    np.testing.assert_array_equal(vd.linearize(system, eq).K, system.linearize(eq).K)
    for name in ("simulate", "linearize", "equilibrium"):
        assert callable(getattr(vd, name)) and name in vd.__all__


def test_former_module_attributes_warn_once():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        err = vd.simulate.SimulationError
        again = vd.simulate.SimulationError
    assert err is again is vd.SimulationError
    assert len(caught) == 1 and issubclass(caught[0].category, DeprecationWarning)
    assert "vibdyn.SimulationError" in str(caught[0].message)
    with pytest.raises(AttributeError):
        vd.linearize.no_such_name  # noqa: B018


# ------------------------------------------------------------------ one meaning per name: the former names
def _objects():
    """One object per class that keeps a former attribute name: (class name -> object)."""
    from vibdyn.analysis.nonlinear.backbone import Resonance
    from vibdyn.description.shapes import Shape

    scene = vd.Scene("oscillator")
    scene.add_body("m1", joint=vd.Slider(axis=(1, 0, 0)), mass=2.0)
    scene.add_joint_spring("m1", stiffness=50.0, name="k1")
    scene.add_joint_damper("m1", 0.4)
    system = scene.build()
    op = system.operating_point()
    lin = op.linearize()
    modes = lin.modes()
    frf = lin.receptance(np.linspace(1.0, 10.0, 40), ["m1"], ["m1"])
    event = lambda t, q, v: v[0]  # noqa: E731  (a turning point)
    traj = system.simulate(2.0, [0.1], events=event)
    gimbal = vd.load_scene("gimbal_rotor").build()
    campbell = vd.campbell(gimbal, "rotor", [0.0, 20.0, 40.0])
    return {"Joint": vd.Pivot((0, 0, 1)), "Shape": Shape("box", (1.0, 2.0, 3.0)),
            "Resonance": Resonance("fold", 1.0, 2.0, (0.9, 1.1)),
            "ReducedLinearModel": vd.load_scene("four_bar").build().operating_point().linearize(),
            "Trajectory": traj, "Campbell": campbell,
            "CriticalSpeed": vd.CriticalSpeed(3.0, 1, "forward", 1.0, 3.0, 1e-9), "LinearModel": lin,
            "Modes": modes, "FRF": frf, "HarmonicResponse": lin.harmonic_response(2.0, [1.0], ["m1"], ["m1"]),
            "StateSpace": lin.state_space(["m1"], ["m1"]), "Sensitivity": modes.sensitivity(["k1.stiffness"]),
            "Peaks": frf.peaks(), "OperatingPoint": op, "System": system,
            "Reduction": vd.load_scene("four_bar").build().reduction}


def _same(a, b):
    return a is b or (np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b)


def _reads_once(read):
    """(values read twice, the DeprecationWarnings caught)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        values = read(), read()
    return values, [w for w in caught if issubclass(w.category, DeprecationWarning)]


def test_every_former_attribute_warns_once_and_reads_the_new_one():
    from vibdyn import _deprecation

    objects = _objects()
    attributes = {k: v for k, v in _deprecation.RENAMED.items() if "(" not in k}
    assert len(attributes) >= 20
    for former, new in attributes.items():
        cls, old = former.split(".")
        obj = objects[cls]  # (a former name registered here is tested here)
        _deprecation._warned.discard(former)
        (a, b), caught = _reads_once(lambda: getattr(obj, old))
        assert len(caught) == 1, former
        assert former in str(caught[0].message) and new in str(caught[0].message)
        assert _same(a, getattr(obj, new.split(".")[1])) and _same(b, a), former
    # read on the class as well: a joint type's name
    _deprecation._warned.discard("Joint.kind")
    (a, _), caught = _reads_once(lambda: vd.Slider.kind)
    assert a == vd.Slider.type == "slider" and len(caught) == 1


def test_former_keywords_warn_once_and_mean_the_new_ones():
    from vibdyn import _deprecation

    system = vd.load_scene("rod_pivot").build()
    lin = system.linearize()
    for key in ("modes(tolerance=)", "simulate(error=)"):
        _deprecation._warned.discard(key)
    (a, b), caught = _reads_once(lambda: lin.modes(tolerance=2.0))
    assert len(caught) == 1 and "modes(tol=" in str(caught[0].message)
    assert a.rigid.all() and not lin.modes().rigid.any()  # the threshold did apply
    np.testing.assert_array_equal(a.omega, lin.modes(tol=2.0).omega)
    q0 = system.configuration([0.3])
    (a, b), caught = _reads_once(lambda: vd.simulate(system, 0.5, q0, error="local"))
    assert len(caught) == 1 and "error_method" in str(caught[0].message)
    assert a.error_method == "local" == vd.simulate(system, 0.5, q0, error_method="local").error_method
    with pytest.raises(vd.ModelError, match="error_method"):
        vd.simulate(system, 0.5, q0, error="local", error_method="rerun")
    assert set(_deprecation.RENAMED) >= {"modes(tolerance=)", "simulate(error=)"}


def test_a_joint_type_declared_with_the_former_names_still_works():
    from dataclasses import dataclass

    from vibdyn import _deprecation
    from vibdyn.description.joints import JOINT_TYPES, Pivot, joint_type

    _deprecation._warned.difference_update({"Joint.kind", "Joint.group"})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")

        @joint_type
        @dataclass(frozen=True, eq=False)
        class OldStyle(Pivot):
            kind = "old_style"
            group = None

    assert JOINT_TYPES.pop("old_style") is OldStyle and OldStyle.type == "old_style"
    assert {str(w.message).split(" ")[0] for w in caught} == {"Joint.kind", "Joint.group"}


def test_errors_follow_one_convention():
    """*_error is absolute in its quantity's unit, relative_error relative (docs/guide/names.md)."""
    modes = vd.load_scene("quarter_car").build().linearize().modes()
    live = ~modes.rigid
    np.testing.assert_allclose(modes.omega_error[live], (modes.omega_relative_error * modes.omega)[live], rtol=1e-12)
    lam = np.abs(modes.damped_eigenvalues)
    np.testing.assert_allclose(modes.eigenvalue_error, modes.eigenvalue_relative_error * lam, rtol=1e-12)
    response = modes.linear.free_response(np.linspace(0, 1, 11), [0.01, 0.0])
    assert response.error == pytest.approx(response.relative_error * np.abs(response.x).max(), rel=1e-12)


def test_the_names_page_lists_every_former_and_changed_name():
    from conftest import ROOT

    from vibdyn import _deprecation

    _objects()  # every module that declares a former name is loaded
    page = (ROOT / "docs" / "guide" / "names.md").read_text(encoding="utf-8")
    missing = [n for n in [*_deprecation.RENAMED, *_deprecation.CHANGED_MEANING, *_deprecation.CHANGED_MEANING.values()]
               if f"`{n}`" not in page]
    assert not missing, f"docs/guide/names.md does not list {missing}"
    assert "## Errors: one convention" in page and "absolute" in page and "relative_error" in page
