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
