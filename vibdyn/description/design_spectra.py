"""Design response spectra of the codes, as callables S_a(T) (pseudo-acceleration m/s², period s) for
:meth:`vibdyn.Modes.response_spectrum`: Eurocode 8's elastic spectrum and ASCE 7's design spectrum."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._check import scalar
from ..errors import ModelError
from .record import G  # standard gravity (m/s²): the codes' g

#: EN 1998-1 Tables 3.2 (type 1) and 3.3 (type 2): ground type -> (S, T_B s, T_C s, T_D s)
EC8_GROUNDS = {
    1: {"A": (1.0, 0.15, 0.4, 2.0), "B": (1.2, 0.15, 0.5, 2.0), "C": (1.15, 0.20, 0.6, 2.0),
        "D": (1.35, 0.20, 0.8, 2.0), "E": (1.4, 0.15, 0.5, 2.0)},
    2: {"A": (1.0, 0.05, 0.25, 1.2), "B": (1.35, 0.05, 0.25, 1.2), "C": (1.5, 0.10, 0.25, 1.2),
        "D": (1.8, 0.10, 0.30, 1.2), "E": (1.6, 0.05, 0.25, 1.2)},
}


@dataclass(frozen=True)
class DesignSpectrum:
    """A code's spectrum: ``code`` ("EN 1998-1" or "ASCE 7"), its ``parameters`` (name -> value, SI or as the
    code states them) and ``corners`` (T_B, T_C, T_D or T_0, T_S, T_L, s); called with a period T (s), it gives
    S_a (m/s²). ``damping``: the ratio it is for."""

    code: str
    parameters: tuple  # ((name, value), ...)
    damping: float

    def __call__(self, T: float | np.ndarray) -> float | np.ndarray:
        if np.ndim(T):  # periods of any shape: S_a of each, alike
            return np.vectorize(self, otypes=[float])(np.asarray(T, dtype=object))
        T = scalar(T, f"{self.code} spectrum: the period (s)")
        if not T >= 0:
            raise ModelError(f"{self.code} spectrum: the period must be ≥ 0 s, got {T!r}")
        p = dict(self.parameters)
        if self.code == "EN 1998-1":
            ag, S, TB, TC, TD, eta = (p[k] for k in ("a_g", "S", "T_B", "T_C", "T_D", "eta"))
            if T <= TB:
                return ag * S * (1 + T / TB * (2.5 * eta - 1))
            if T <= TC:
                return 2.5 * ag * S * eta
            return 2.5 * ag * S * eta * (TC / T if T <= TD else TC * TD / T ** 2)
        sds, sd1, TL = p["S_DS"] * G, p["S_D1"] * G, p["T_L"]
        T0, TS = 0.2 * p["S_D1"] / p["S_DS"], p["S_D1"] / p["S_DS"]
        if T < T0:
            return sds * (0.4 + 0.6 * T / T0)
        if T <= TS:
            return sds
        return sd1 / T if T <= TL else sd1 * TL / T ** 2

    def table(self, periods) -> tuple[np.ndarray, np.ndarray]:
        """(periods s, S_a m/s²) on ``periods``."""
        T = np.asarray(periods, dtype=float)
        return T, np.array([self(t) for t in T])

    def describe(self) -> str:
        return f"{self.code}: " + ", ".join(f"{k} = {v:g}" for k, v in self.parameters) + f" (ζ = {self.damping:g})"


def eurocode8(a_g: float, ground: str = "C", spectrum_type: int = 1, damping: float = 0.05) -> DesignSpectrum:
    """Eurocode 8's horizontal elastic spectrum (EN 1998-1 §3.2.2.2) for the design ground acceleration
    ``a_g`` (m/s²) on ground type "A" … "E", of type 1 (large earthquakes) or 2 (Ms ≤ 5.5), at ``damping`` ζ:
    η = √(10/(5 + 100ζ)) ≥ 0.55."""
    a_g = scalar(a_g, "eurocode8 a_g (m/s²)", positive=True)
    if spectrum_type not in EC8_GROUNDS:
        raise ModelError(f"eurocode8: spectrum_type must be 1 or 2, got {spectrum_type!r}")
    grounds = EC8_GROUNDS[spectrum_type]
    if not isinstance(ground, str) or ground.upper() not in grounds:
        raise ModelError(f"eurocode8: ground type must be one of {', '.join(grounds)}, got {ground!r}")
    z = scalar(damping, "eurocode8 damping ratio", nonnegative=True)
    eta = max(math.sqrt(10 / (5 + 100 * z)), 0.55)
    S, TB, TC, TD = grounds[ground.upper()]
    return DesignSpectrum("EN 1998-1", (("a_g", a_g), ("S", S), ("T_B", TB), ("T_C", TC), ("T_D", TD),
                                        ("eta", eta), ("type", spectrum_type)), z)


def asce7(S_DS: float, S_D1: float, T_L: float = 8.0) -> DesignSpectrum:
    """ASCE 7's design response spectrum (ASCE/SEI 7-16 §11.4.6) from the design spectral accelerations
    ``S_DS`` (short periods) and ``S_D1`` (1 s), both in g, and the long-period transition ``T_L`` (s); 5 %
    damping."""
    sds = scalar(S_DS, "asce7 S_DS (g)", positive=True)
    sd1 = scalar(S_D1, "asce7 S_D1 (g)", positive=True)
    TL = scalar(T_L, "asce7 T_L (s)", positive=True)
    if sd1 / sds >= TL:
        raise ModelError(f"asce7: T_S = S_D1/S_DS = {sd1 / sds:g} s must be below T_L = {TL:g} s")
    return DesignSpectrum("ASCE 7", (("S_DS", sds), ("S_D1", sd1), ("T_L", TL)), 0.05)
