"""Issue 40 acceptance, round four of adversarial probes: each test is a probe that returned a wrong number with a
confident estimate, a raw traceback or a hang, checked against an independent oracle."""

import numpy as np
import pytest

import vibdyn as vd


def _chain(k1=120.0, k2=50.0):
    s = vd.Scene("chain")
    s.add_body("a", joint=vd.Slider(axis=(1, 0, 0)), mass=1.0)
    s.add_body("b", parent="a", joint=vd.Slider(axis=(1, 0, 0)), mass=1.0)
    s.add_joint_spring("a", k1, name="k1")
    s.add_joint_spring("b", k2, name="k2")
    return s


def _chain_omega(k1, k2):
    """The two-slider chain by hand: b slides on a, so M = [[2, 1], [1, 1]] kg, K = diag(k1, k2)."""
    return np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve([[2.0, 1.0], [1.0, 1.0]], np.diag([k1, k2]))).real))


@pytest.mark.parametrize("sigma", [1e-300, 1e-100, 1e100, 1e300])
def test_update_fits_whatever_the_scale_of_sigma(sigma):
    # σ = 1e-100 rad/s returned the start (130, 45) with std 8e-99 (scipy's squares overflowed); 1e-300 a raw
    # "array must not contain infs or NaNs". The fit's minimum does not depend on σ's scale, std scales with it.
    fit = vd.update(_chain, {"k1": 130.0, "k2": 45.0}, _chain_omega(120.0, 50.0), sigma=sigma)
    assert fit.values["k1"] == pytest.approx(120.0, rel=1e-9) and fit.values["k2"] == pytest.approx(50.0, rel=1e-9)
    reference = vd.update(_chain, {"k1": 130.0, "k2": 45.0}, _chain_omega(120.0, 50.0), sigma=1.0)
    for k in ("k1", "k2"):
        assert fit.std[k] == pytest.approx(reference.std[k] * sigma, rel=1e-6)
