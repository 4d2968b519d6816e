"""Force laws as data: joint forces/torques that scene files can hold without code.

A law is a callable ``law(t, q, v)`` (SI units, joint coordinates) that also says what it depends on, so
that analyses skip what it does not need (no velocity differences for a law that ignores v).
"""

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ._check import finite_array, scalar
from .errors import ModelError


@dataclass(frozen=True)
class Polynomial:
    """Motor law in the joint speed: value = Σ_k coefficients[k] · v^k (e.g. τ = 10 − ω²: (10, 0, -1))."""

    coefficients: tuple

    velocity_dependent = property(lambda self: len(self.coefficients) > 1)
    time_dependent = False

    def __post_init__(self):
        c = finite_array(self.coefficients, (None,), "polynomial law coefficients")
        if c.size == 0:
            raise ModelError("polynomial law: needs at least one coefficient")
        object.__setattr__(self, "coefficients", tuple(float(x) for x in c))

    def __call__(self, t, q, v):
        return np.polynomial.polynomial.polyval(v, self.coefficients)

    def to_dict(self):
        return {"law": "polynomial", "coefficients": list(self.coefficients)}


@dataclass(frozen=True)
class Harmonic:
    """Harmonic forcing: value = offset + amplitude · sin(omega·t + phase) (omega in rad/s, phase in rad)."""

    amplitude: float
    omega: float
    phase: float = 0.0
    offset: float = 0.0

    velocity_dependent = False
    time_dependent = True

    def __post_init__(self):
        for name in ("amplitude", "omega", "phase", "offset"):
            object.__setattr__(self, name, scalar(getattr(self, name), f"harmonic law {name}"))

    def __call__(self, t, q, v):
        return self.offset + self.amplitude * math.sin(self.omega * t + self.phase)

    def to_dict(self):
        return {"law": "harmonic", "amplitude": self.amplitude, "omega": self.omega, "phase": self.phase,
                "offset": self.offset}


LAWS = {"polynomial": Polynomial, "harmonic": Harmonic}


def from_dict(d, what="law"):
    """A law from its plain-data form (``{"law": "polynomial", "coefficients": [...]}``)."""
    if not isinstance(d, Mapping):
        raise ModelError(f"{what}: expected a table such as {{'law': 'harmonic', ...}}, got {d!r}")
    d = dict(d)
    kind = d.pop("law", None)
    if not isinstance(kind, str) or kind not in LAWS:
        raise ModelError(f"{what}: unknown law {kind!r} (one of {', '.join(LAWS)})")
    try:
        return LAWS[kind](**d)
    except (TypeError, ModelError) as e:  # bad keywords, or bad values: say which element has them
        raise ModelError(f"{what}: {e}") from None
