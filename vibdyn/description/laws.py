"""Force laws as data: joint forces/torques that scene files can hold without code.

A law is a callable ``law(t, q, v)`` (SI units, joint coordinates) that also says what it depends on, so
that analyses skip what it does not need (no velocity differences for a law that ignores v).
"""

import math
from dataclasses import MISSING, dataclass, fields

import numpy as np

from .._check import finite_array, kind_of, scalar, user_callable
from ..errors import ModelError
from .record import Record  # vibdyn.laws.Record: a ground-acceleration record as a support's motion


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

    def describe(self, unit="", speed=""):
        """The law as a formula, e.g. "10 − 1·v² N·m (v in rad/s)"."""
        from .._format import number

        parts = []
        for k, c in enumerate(self.coefficients):
            if c == 0.0:
                continue
            term = number(abs(c)) + ("" if k == 0 else "·v" if k == 1 else "·v" + _POWERS.get(k, f"^{k}"))
            sign = "−" if c < 0 else "+"
            parts.append((f"−{term}" if c < 0 else term) if not parts else f"{sign} {term}")
        text = " ".join(parts) or "0"
        if unit:
            text += f" {unit}"
        if speed and any(self.coefficients[1:]):
            text += f" (v in {speed})"
        return text


_POWERS = {2: "²", 3: "³", 4: "⁴", 5: "⁵"}


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

    # as the motion of a drive (Scene.add_drive): the coordinate itself (m or rad) and its derivatives
    def position(self, t):
        """offset + amplitude·sin(ωt + phase) (m or rad)."""
        return self.offset + self.amplitude * math.sin(self.omega * t + self.phase)

    def velocity(self, t):
        """amplitude·ω·cos(ωt + phase) (m/s or rad/s)."""
        return self.amplitude * self.omega * math.cos(self.omega * t + self.phase)

    def acceleration(self, t):
        """−amplitude·ω²·sin(ωt + phase) (m/s² or rad/s²)."""
        return -self.amplitude * self.omega**2 * math.sin(self.omega * t + self.phase)

    def to_dict(self):
        return {"law": "harmonic", "amplitude": self.amplitude, "omega": self.omega, "phase": self.phase,
                "offset": self.offset}

    def describe(self, unit="", speed=""):
        """The law as a formula, e.g. "0.5 + 2·sin(15 t + 0) N·m (t in s)"."""
        from .._format import number

        u = f" {unit}" if unit else ""
        head = f"{number(self.offset)} + " if self.offset else ""
        return (f"{head}{number(self.amplitude)}·sin({number(self.omega)} t + {number(self.phase)}){u} "
                "(ω in rad/s, t in s)")


@dataclass(frozen=True)
class HarmonicMotion:
    """Harmonic motion of a support: displacement amplitude · sin(omega·t + phase) (m, world axes;
    omega in rad/s, phase in rad), velocity amplitude · omega · cos(omega·t + phase)."""

    amplitude: tuple
    omega: float
    phase: float = 0.0

    def __post_init__(self):
        a = finite_array(self.amplitude, (3,), "harmonic motion amplitude")
        object.__setattr__(self, "amplitude", tuple(float(x) for x in a))
        object.__setattr__(self, "omega", scalar(self.omega, "harmonic motion omega"))
        object.__setattr__(self, "phase", scalar(self.phase, "harmonic motion phase"))

    def position(self, t):
        return np.array(self.amplitude) * math.sin(self.omega * t + self.phase)

    def velocity(self, t):
        return np.array(self.amplitude) * (self.omega * math.cos(self.omega * t + self.phase))

    def to_dict(self):
        return {"law": "harmonic_motion", "amplitude": list(self.amplitude), "omega": self.omega,
                "phase": self.phase}


def road(amplitude, wavelength, speed, direction=(0.0, 0.0, 1.0), phase=0.0):
    """A road of harmonic profile (amplitude m, wavelength m) driven over at ``speed`` m/s: the wheel's
    support moves along ``direction`` at ω = 2π·speed/wavelength rad/s."""
    lam = scalar(wavelength, "road wavelength", positive=True)
    d = finite_array(direction, (3,), "road direction")
    if not np.any(d):
        raise ModelError("road direction: zero vector")
    amp = scalar(amplitude, "road amplitude") * d / np.linalg.norm(d)
    return HarmonicMotion(tuple(amp), 2 * math.pi * scalar(speed, "road speed") / lam, phase)


@dataclass(frozen=True)
class Motion:
    """A motion from callables of t: ``position(t)``, ``velocity(t)`` and, for a drive, ``acceleration(t)``.

    A support's motion (:meth:`vibdyn.Scene.add_support`): 3-vectors in m and m/s (world axes), no
    acceleration needed. A drive's (:meth:`vibdyn.Scene.add_drive`): the driven coordinate itself, numbers in
    m, m/s, m/s² (slider) or rad, rad/s, rad/s² (pivot, helical), checked finite where first evaluated."""

    position: object
    velocity: object
    acceleration: object = None

    def __post_init__(self):
        parts = ("position", "velocity") + (() if self.acceleration is None else ("acceleration",))
        for part in parts:
            if not callable(getattr(self, part)):
                raise ModelError(f"motion: {part} must be a callable of t, got {getattr(self, part)!r}")
            user_callable(getattr(self, part), 1, f"support motion (or drive motion): {part} (a callable of t)")

    def to_dict(self):
        raise ModelError("a motion given as Python callables cannot be written to a scene file "
                         "(use vibdyn.laws.HarmonicMotion for a support, vibdyn.laws.Harmonic for a drive)")


LAWS = {"polynomial": Polynomial, "harmonic": Harmonic, "harmonic_motion": HarmonicMotion, "record": Record}
#: the laws a joint force can follow (scene files: ``law = "polynomial"`` with the law's keys beside it)
FORCE_LAWS = ("polynomial", "harmonic")


def law_keys(name):
    """(allowed keys, required keys) of the law ``name``, read from its fields (its one declaration)."""
    fs = fields(LAWS[name])
    return tuple(f.name for f in fs), tuple(f.name for f in fs if f.default is MISSING)


def from_dict(d, what="law"):
    """A law from its plain-data form (``{"law": "polynomial", "coefficients": [...]}``)."""
    cls, params = kind_of(d, "law", LAWS, what, "{'law': 'harmonic', ...}", "law")
    try:
        return cls(**params)
    except (TypeError, ModelError) as e:  # bad keywords, or bad values: say which element has them
        raise ModelError(f"{what}: {e}") from None
