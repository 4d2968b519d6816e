"""A rigid rotor on anisotropic bearings, linearised analytically about steady spin (issue 40, item 10).

The rotor (mass m, transverse and polar inertias It, Ip) translates (x, y), tilts (θx, θy) and spins (φ) on a
chain of sliders and pivots, held at two bearing planes z = ±a by springs along x (kx) and y (ky) to the world,
unstressed at rest. About the steady spin Ω the exact linear model (Lagrange, T = ½m(ẋ² + ẏ²) + ½It(ωx² + ωy²)
+ ½Ip ωz², ωz = φ̇ + θ̇x sin θy) is M = diag(m, m, It, It, Ip), K = diag(2kx, 2ky, 2ky a², 2kx a², 0) and the
gyroscopic C with C[θx, θy] = −C[θy, θx] = Ip Ω."""

import numpy as np
import pytest

import vibdyn as vd
from vibdyn.analysis import linearize as linearize_module

KX, KY, MASS, IT, IP, A, L, SPIN = 1e6, 4e6, 10.0, 0.05, 0.08, 0.1, 0.5, 100.0


def rotor(kx=KX, ky=KY):
    s = vd.Scene("rigid rotor")
    s.add_body("x", joint=vd.Slider(axis=(1, 0, 0)), mass=0.0)
    s.add_body("y", parent="x", joint=vd.Slider(axis=(0, 1, 0)), mass=0.0)
    s.add_body("tilt_x", parent="y", joint=vd.Pivot(axis=(1, 0, 0)), mass=0.0)
    s.add_body("tilt_y", parent="tilt_x", joint=vd.Pivot(axis=(0, 1, 0)), mass=0.0)
    s.add_body("rotor", parent="tilt_y", joint=vd.Pivot(axis=(0, 0, 1)), mass=MASS, inertia=np.diag([IT, IT, IP]))
    for z, plane in ((A, "A"), (-A, "B")):
        s.add_spring(f"{plane}x", ("rotor", (0, 0, z)), ("world", (L, 0, z)), stiffness=kx, free_length=L)
        s.add_spring(f"{plane}y", ("rotor", (0, 0, z)), ("world", (0, L, z)), stiffness=ky, free_length=L)
    return s.build()


def closed_form(spin=SPIN, kx=KX, ky=KY):
    M = np.diag([MASS, MASS, IT, IT, IP])
    K = np.diag([2 * kx, 2 * ky, 2 * ky * A**2, 2 * kx * A**2, 0.0])
    G = np.zeros((5, 5))
    G[2, 3], G[3, 2] = IP * spin, -IP * spin
    return M, K, G


@pytest.mark.parametrize("spin", [SPIN, 1e4])
def test_analytic_path_is_taken_and_equals_the_closed_form(spin):
    """Issue 40 item 10: the guard's estimate left out the round-off of the spin row, where tilt × spin products
    cancel while every force of the operating point is 0 (it refused the analytic model by 31 × its estimate)."""
    lin = rotor().steady_motion({"rotor": spin}).linearize(method="analytic")  # (a warning fails the test)
    assert lin.method == "analytic"
    M, K, G = closed_form(spin)
    np.testing.assert_allclose(lin.M, M, rtol=4 * np.finfo(float).eps, atol=0)
    assert np.all(np.abs(lin.K - K) <= lin.K_error + 4 * np.finfo(float).eps * np.abs(K))
    assert np.all(np.abs(lin.C - G) <= lin.C_error + 4 * np.finfo(float).eps * np.abs(G))
    assert lin.K_error.max() <= 1e-9 * np.abs(K).max() and lin.C_error.max() <= 1e-9 * np.abs(G).max()


@pytest.mark.parametrize("name, i, j, size", [("C", 2, 3, 1e-4), ("C", 3, 2, 1e-4), ("K", 2, 2, 1e-4),
                                               ("K", 4, 2, 1e-7), ("C", 4, 3, 1e-7)])
def test_the_guard_still_catches_a_wrong_term_of_the_rotor(monkeypatch, name, i, j, size):
    """The spin row's round-off floor does not blind the guard: a gyroscopic or spring term wrong by 1e-4 of the
    largest entry of C or K (the guard's differences are exact to a few 1e-6 of them: the springs' geometry), or a
    spin-row entry that should be 0 wrong by 1e-7 of it, makes it fall back to differences."""
    real = linearize_module.analytic_derivatives
    K, G = closed_form()[1:]
    bump = size * (np.abs(K).max() if name == "K" else np.abs(G).max())

    def wrong(*args, **kwargs):
        out = real(*args, **kwargs)
        out[0 if name == "K" else 1][i, j] += bump
        return out

    monkeypatch.setattr(linearize_module, "analytic_derivatives", wrong)
    with pytest.warns(UserWarning, match="disagree with central differences"):
        lin = rotor().steady_motion({"rotor": SPIN}).linearize(method="analytic")
    assert lin.method == "fd"
