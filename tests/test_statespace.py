"""State-space interop (LinearModel.state_space) on the reference case R5: its transfer function at s = iω
is the receptance, its poles are the damped modes' eigenvalues, and scipy / python-control agree."""

import numpy as np
import pytest
from conftest import MODELS

import vibdyn as vd

W = np.array([0.3, 0.9452737864722964, 1.0, 1.4766747048245257, 3.3527111380241066, 7.0])  # rad/s, R5 peaks


@pytest.fixture(scope="module")
def lin():
    return vd.load_scene(MODELS / "receptance_damped.toml").build().operating_point().linearize()


def bound(frf, H):
    """Allowed difference: the FRF's own error estimate plus the state solve's (ε × cond(iωI − A))."""
    return (frf.relative_error + 16 * np.finfo(float).eps * frf.condition) * np.abs(H).max()


def test_transfer_at_i_omega_is_the_receptance(lin):
    ss = lin.state_space()
    assert ss.A.shape == (4, 4) and ss.B.shape == (4, 2) and ss.C.shape == (2, 4) and not ss.D.any()
    assert ss.inputs == ss.outputs == tuple(lin.coordinates)
    assert ss.input_units == ("N", "N") and ss.output_units == ("m", "m") and ss.state_units[2:] == ("m/s",) * 2
    frf = lin.receptance(W)
    H = np.array([ss.transfer(1j * w) for w in W])
    assert np.abs(H - frf.alpha).max() <= bound(frf, frf.alpha)
    ref = vd.load_scene(MODELS / "receptance_damped.toml").references  # α at ω = 1 rad/s, exact values
    alpha = {k: complex(*ref[k]) for k in ("alpha11", "alpha12", "alpha22")}
    exact = np.array([[alpha["alpha11"], alpha["alpha12"]], [alpha["alpha12"], alpha["alpha22"]]])
    assert np.abs(H[2] - exact).max() <= bound(frf, exact)


def test_velocity_outputs_and_points(lin):
    """Velocity outputs give the mobility iω α; a point channel with a direction is the same as the slider's
    coordinate (the sliders move along x), with units N in and m/s out."""
    point = ("m2", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    ss = lin.state_space("m1", [point], output="velocity")
    assert ss.output_units == ("m/s",) and ss.input_units == ("N",) and ss.output == "velocity"
    frf = lin.receptance(W, "m1", "m2")
    H = np.array([ss.transfer(1j * w) for w in W])
    assert np.abs(H - frf.mobility).max() <= bound(frf, frf.mobility)


def test_poles_are_the_damped_eigenvalues(lin):
    m = lin.modes()
    poles = lin.state_space().poles
    key = lambda z: (round(z.imag, 6), round(z.real, 6))  # noqa: E731
    got, want = sorted(poles, key=key), sorted(m.eigenvalues, key=key)
    tol = (m.eigenvalue_relative_error.max() + 16 * np.finfo(float).eps) * np.abs(m.eigenvalues).max()
    assert np.abs(np.array(got) - np.array(want)).max() <= tol


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")
def test_scipy_freqresp_agrees(lin):
    from scipy import signal

    ss = lin.state_space("m1", "m2")  # scipy's freqresp is single-input single-output
    sys = ss.to_scipy()
    assert isinstance(sys, signal.StateSpace)
    _, H = signal.freqresp(sys, W)
    frf = lin.receptance(W, "m1", "m2")
    assert np.abs(H - frf.alpha[:, 0, 0]).max() <= bound(frf, frf.alpha)


def test_to_control_names_channels_and_agrees(lin):
    control = pytest.importorskip("control")
    ss = lin.state_space()
    sys = ss.to_control()
    assert isinstance(sys, control.StateSpace)
    assert list(sys.input_labels) == list(ss.inputs) and list(sys.output_labels) == list(ss.outputs)
    frf = lin.receptance(W)
    H = np.moveaxis(sys(1j * W), -1, 0)  # (n_out, n_in, n_ω) -> (n_ω, n_out, n_in)
    assert np.abs(H - frf.alpha).max() <= bound(frf, frf.alpha)


def test_to_control_without_python_control(lin, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "control", None)  # import control raises ImportError
    with pytest.raises(ImportError, match="pip install control"):
        lin.state_space().to_control()


def test_bad_output_kind(lin):
    with pytest.raises(vd.ModelError, match="displacement"):
        lin.state_space(output="acceleration")
    with pytest.raises(vd.ModelError, match="unknown|coordinate"):
        lin.state_space(inputs="nope")
