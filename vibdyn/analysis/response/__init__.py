"""Responses of a linear model M δq̈ + C δq̇ + K δq = B u (:class:`vibdyn.analysis.linearize.LinearModel`).

- Free response from δq(0), δv(0): modal superposition with real modes (undamped or classical damping,
  closed-form modal solutions, also rigid, unstable and over-damped modes), complex modes of the state
  form (any viscous damping), or the matrix exponential.
- Harmonic steady state, receptance / mobility / accelerance α(ω) by direct solve of
  (K − ω²M + iωC + iD) X = B or by modal sum Σ φφᵀ/(ω_r² − ω² + iωc_r + id_r), with viscous and
  hysteretic (structural) damping; resonances, anti-resonances and half-power bandwidths.
- Base excitation: a moving support (its springs and dampers act as B_y y + B_v ẏ) or a prescribed joint
  coordinate; harmonic steady state (transmissibility) and transients.
- Forced transients: modal Duhamel integrals or the exact state-space discretisation (scipy expm), both
  with Gauss–Legendre quadrature of the force between time points; scipy's ``solve_ivp`` on the state form
  as the independent check.
- Random response: one-sided PSD inputs (Hz), variances by the Lyapunov equation (white) or adaptive
  quadrature placed at the poles (tables), with error estimates.
- Modal appropriation: the force pattern that drives a single undamped mode in phase quadrature.

Conventions: δq are the tangent coordinates of the linear model (m or rad) measured from the operating
point; harmonic quantities are complex amplitudes: a force Re(F e^{iωt}) gives Re(X e^{iωt}) with X = αF.
ω in rad/s, Hz alongside (``frequency_hz``). Inputs and outputs are coordinate names (generalized forces
and displacements), body points with a direction ``(body, (x, y, z), (dx, dy, dz))`` (force along it and
displacement along it, world axes), or None (every coordinate).
"""

from .appropriation import Appropriation, appropriation
from .base import base_response, transmissibility
from .channels import Channels, channels
from .damping import Hysteretic
from .frf import (
           FRF,
           HarmonicResponse,
           Peaks,
           Receptance,
           SingularResponse,
           harmonic_response,
           receptance,
)
from .monte_carlo import MonteCarlo, monte_carlo
from .random import RandomResponse, random_response
from .transient import TimeResponse, forced_response, free_response

__all__ = ["Appropriation", "Channels", "FRF", "HarmonicResponse", "Hysteretic", "MonteCarlo", "Peaks",
           "RandomResponse", "Receptance", "SingularResponse", "TimeResponse", "appropriation", "base_response",
           "channels", "forced_response", "free_response", "harmonic_response", "monte_carlo", "random_response",
           "receptance", "transmissibility"]
