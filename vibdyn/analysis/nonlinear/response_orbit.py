"""The steady motion at one point of a forced-response curve, rebuilt from its harmonic-balance coefficients:
:class:`ResponseOrbit` (``ForcedResponseCurve.orbit(i)``), one period of configurations the viewer animates.

x(τ) = c₀ + Σ_k (c_k cos kτ + s_k sin kτ), τ = Ωt, is the tangent displacement of the coordinates from the
curve's static equilibrium, and q(t) = q_eq ⊕ x(Ωt) (``System.integrate``: a sum on pivots and sliders, the
exponential map on ball, free and planar joints), as the balance itself evaluates it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..._check import integer
from ..._format import number, summary
from ...errors import ModelError

POINTS = 64  # samples per period (the viewer interpolates between them on the group)


@dataclass(frozen=True, eq=False)
class ResponseOrbit:
    """One period of the harmonic-balance motion at point ``index`` of a forced-response curve: ``omega`` Ω
    (rad/s) and ``period`` 2π/Ω (s); ``t`` (s, ``points`` + 1 times from 0 to the period, the last closing the
    loop), ``q`` (configurations, one row per time), ``x`` (tangent displacements from ``q_eq``, m or rad);
    ``coordinate`` the curve's, its ``amplitude`` (max |x_c| over the period, m or rad) with ``error`` (the
    curve's truncation estimate), ``stability`` (Hill's verdict) and ``excitation``."""

    system: Any = field(repr=False)
    index: int
    omega: float
    t: np.ndarray
    q: np.ndarray
    x: np.ndarray
    q_eq: np.ndarray
    coordinate: str
    unit: str
    amplitude: float
    error: float
    stability: str
    excitation: str

    @property
    def period(self) -> float:
        """2π/Ω (s)."""
        return 2 * math.pi / self.omega

    @property
    def frequency_hz(self) -> float:
        """Ω in Hz."""
        return self.omega / (2 * math.pi)

    def __repr__(self):
        return summary("ResponseOrbit", f"point {self.index}", f"Ω = {number(self.omega, 'rad/s', digits=8)} "
                       f"({number(self.frequency_hz, 'Hz', digits=6)})",
                       f"amplitude {number(self.amplitude, self.unit)} ± {self.error:.1e}", self.stability)


def response_orbit(curve: Any, index: int, points: int = POINTS) -> ResponseOrbit:
    """The :class:`ResponseOrbit` of point ``index`` of ``curve`` (a ForcedResponseCurve), ``points`` samples per
    period."""
    n = len(curve.omega)
    i = integer(index, "ForcedResponseCurve.orbit: index", minimum=-n, maximum=n - 1) % n
    points = integer(points, "ForcedResponseCurve.orbit: points", minimum=4, maximum=100000)
    system = curve.system
    if system is None:
        raise ModelError("ForcedResponseCurve.orbit: this curve does not carry its system (made by hand?)")
    coef = np.asarray(curve.coefficients[i], float)  # (2H + 1) × nv
    H = (coef.shape[0] - 1) // 2
    tau = np.linspace(0.0, 2 * math.pi, points + 1)
    kt = np.multiply.outer(tau, np.arange(1, H + 1))
    x = coef[0] + np.cos(kt) @ coef[1::2] + np.sin(kt) @ coef[2::2]
    q = np.array([system.integrate(curve.q_eq, xi) for xi in x])
    omega = float(curve.omega[i])
    return ResponseOrbit(system, i, omega, tau / omega, q, x, np.array(curve.q_eq, float), curve.coordinate, curve.unit,
                         float(curve.amplitude[i]), float(curve.error[i]), curve.stability[i], curve.excitation)
