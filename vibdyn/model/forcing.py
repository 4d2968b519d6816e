"""What makes a scene non-autonomous, and its common period: :func:`forcing` → :class:`Forcing`.

The time-dependent parts of a scene are its moving supports, its drives and its forces that depend on time
(joint forces with a law of time, body forces given as callables). A harmonic one (``vibdyn.laws.Harmonic``,
``HarmonicMotion``) declares its angular frequency ω; several are periodic together when their frequencies
are commensurate (ω_i/ω_j a ratio of integers, denominators up to ``MAX_DENOMINATOR``), with the common period
2π/ω_c, ω_c the largest ω of which every ω_i is a whole multiple. Callables of time declare none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from ..description.elements import Drive, Support

__all__ = ["Forcing", "forcing", "MAX_DENOMINATOR", "RATIO_RTOL"]
MAX_DENOMINATOR = 1000  # the largest denominator of a frequency ratio taken as commensurate
RATIO_RTOL = 1e-9  # how close (relative) a ratio of frequencies must be to that fraction


@dataclass(frozen=True)
class Forcing:
    """The time-dependent parts of a scene (see :func:`forcing`): ``sources`` ((element name, ω rad/s or None
    for a law of time that declares no frequency), ...); ``period`` (s) the common period of the harmonic
    sources (None: there are none, or their frequencies are not commensurate); ``commensurate``; ``complete``:
    every source declares its frequency (``period`` is then the whole scene's)."""

    sources: tuple
    period: float | None
    commensurate: bool

    @property
    def complete(self) -> bool:
        return all(w is not None for _, w in self.sources)

    @property
    def harmonic(self) -> tuple:
        """(name, ω rad/s) of the sources that declare a frequency."""
        return tuple((n, w) for n, w in self.sources if w is not None)

    def describe(self) -> str:
        """The harmonic sources in words, e.g. "ω = 3 rad/s ('m.force'), ω = 4.5 rad/s ('base')"."""
        return ", ".join(f"ω = {w:.10g} rad/s ('{n}')" for n, w in self.harmonic)


def forcing(system: Any) -> Forcing:
    """The time-dependent parts of a System's scene and their common period (see the module docstring).
    A harmonic law of zero frequency or zero amplitude is constant: not a source."""
    sources = []
    for e in system.scene.elements.values():
        for law in _laws(e):
            w = getattr(law, "omega", None)
            if w is not None and (w == 0 or not np.any(getattr(law, "amplitude", 1.0))):
                continue  # a constant
            sources.append((e.name, None if w is None else abs(float(w))))
    if not sources and any(g.time_dependent for g in system.force_groups):
        sources.append(("forces", None))  # (an element kind whose time dependence is not read here)
    omegas = [w for _, w in sources if w is not None]
    if not omegas:
        return Forcing(tuple(sources), None, True)
    w_ref = min(omegas)
    ratios = []
    for w in omegas:
        r = Fraction(w / w_ref).limit_denominator(MAX_DENOMINATOR)
        if abs(w / w_ref - float(r)) > RATIO_RTOL * w / w_ref:
            return Forcing(tuple(sources), None, False)
        ratios.append(r)
    num = math.gcd(*(r.numerator for r in ratios))
    den = math.lcm(*(r.denominator for r in ratios))
    return Forcing(tuple(sources), 2 * math.pi / (w_ref * num / den), True)


def _laws(e):
    """The element's laws of time (a support's or drive's motion; a time-dependent force's callables)."""
    if isinstance(e, (Support, Drive)):
        return [e.motion]
    if not getattr(e, "time_dependent", False):
        return []
    return [x for x in (getattr(e, p, None) for p in ("value", "force", "torque"))
            if callable(x) and getattr(x, "time_dependent", True)]
