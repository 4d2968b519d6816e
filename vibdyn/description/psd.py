"""Power spectral densities as inputs: one-sided, in Hz (the convention of test specifications).

A :class:`PSD` is plain data: a table of breakpoints interpolated log-log (straight lines in dB/octave), zero
outside its first and last breakpoints; a white level over a band (or over all frequencies); or a callable of
the frequency (Hz). Its ``unit`` says what it is a spectrum of, and every value is converted to SI inside
(g = 9.80665 m/s²). Variance = ∫₀^∞ G(f) df. :class:`Delay` correlates two inputs: the second a delayed copy
of the first (the same road reaching the rear wheel a wheelbase later).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._check import finite_array, scalar, user_callable
from ..errors import ModelError

G = 9.80665  # standard gravity, m/s²
#: unit → (quantity, factor to SI): the units a PSD may be given in, ASCII, per Hz, one-sided
UNITS = {"g^2/Hz": ("acceleration", G * G), "(m/s^2)^2/Hz": ("acceleration", 1.0),
         "(m/s)^2/Hz": ("velocity", 1.0), "m^2/Hz": ("displacement", 1.0),
         "N^2/Hz": ("force", 1.0), "(N*m)^2/Hz": ("torque", 1.0)}
#: quantity → SI unit of the spectrum
SI_UNIT = {"acceleration": "(m/s^2)^2/Hz", "velocity": "(m/s)^2/Hz", "displacement": "m^2/Hz",
           "force": "N^2/Hz", "torque": "(N*m)^2/Hz"}
#: quantity → its order of time derivative of a displacement (motions) or None (loads)
ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2, "force": None, "torque": None}


def _unit(unit):
    if unit not in UNITS:
        raise ModelError(f"PSD unit: unknown unit {unit!r}; give one of {', '.join(repr(u) for u in UNITS)} "
                         "(one-sided, per Hz)")
    return unit


@dataclass(frozen=True, eq=False)
class PSD:
    """A one-sided power spectral density G(f), f in Hz, in ``unit`` (see :data:`UNITS`).

    ``PSD(freq_hz, values, unit="g^2/Hz")``: breakpoints (Hz, > 0, strictly increasing) and levels (≥ 0),
    interpolated log-log between them (a segment with a zero end is zero), zero outside. Also
    :meth:`white`, :meth:`band_limited` and :meth:`function`. Calling it, ``psd(f_hz)``, gives SI values
    ((m/s²)²/Hz, (m/s)²/Hz, m²/Hz, N²/Hz or (N·m)²/Hz: see :attr:`si_unit`).
    """

    frequency: Any  # breakpoints (Hz: an array), or None (white, callable)
    values: Any = None  # levels in ``unit`` (a table's array, or the white level)
    unit: str = "(m/s^2)^2/Hz"
    band: tuple = (0.0, math.inf)  # (f_lo, f_hi) Hz where the PSD may be non-zero
    fun: Any = field(default=None, repr=False)  # callable f_hz ↦ levels in ``unit``
    points: tuple = ()  # extra frequencies (Hz) where a callable bends (quadrature breakpoints)

    def __post_init__(self):
        _unit(self.unit)
        lo, hi = (float(x) for x in self.band)
        if not (math.isfinite(lo) and lo >= 0 and hi > lo) or math.isnan(hi):
            raise ModelError(f"PSD band: expected 0 ≤ f_lo < f_hi (Hz, f_hi may be inf), got {self.band!r}")
        object.__setattr__(self, "band", (lo, hi))
        if self.fun is not None:
            user_callable(self.fun, 1, "PSD function (a callable of the frequency in Hz)")
            object.__setattr__(self, "points", tuple(float(x) for x in finite_array(self.points, None,
                                                                                     "PSD function points (Hz)")))
            return
        if self.frequency is None:  # white
            object.__setattr__(self, "values", scalar(self.values, "white PSD level", nonnegative=True))
            return
        f = finite_array(self.frequency, (None,), "PSD frequencies (Hz)")
        v = finite_array(self.values, (None,), f"PSD values ({self.unit})")
        if f.size != v.size:
            raise ModelError(f"PSD: {f.size} frequencies but {v.size} values (one value per breakpoint)")
        if f.size < 2:
            raise ModelError(f"PSD: a table needs at least two breakpoints, got {f.size}")
        if f[0] <= 0:
            raise ModelError(f"PSD frequencies: the first breakpoint must be > 0 Hz (log-log interpolation), "
                             f"got {f[0]:g} Hz")
        bad = np.flatnonzero(np.diff(f) <= 0)
        if bad.size:
            i = int(bad[0])
            raise ModelError(f"PSD frequencies must be strictly increasing: breakpoint {i + 2} ({f[i + 1]:g} Hz) "
                             f"does not exceed breakpoint {i + 1} ({f[i]:g} Hz)")
        neg = np.flatnonzero(v < 0)
        if neg.size:
            raise ModelError(f"PSD values must not be negative: {v[neg[0]]:g} {self.unit} at {f[neg[0]]:g} Hz")
        f.flags.writeable = v.flags.writeable = False
        object.__setattr__(self, "frequency", f)
        object.__setattr__(self, "values", v)
        object.__setattr__(self, "band", (float(f[0]), float(f[-1])))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def white(cls, level: float, unit: str = "(m/s^2)^2/Hz", band: tuple | None = None) -> PSD:
        """A flat spectrum ``level`` (in ``unit``) over ``band`` = (f_lo, f_hi) Hz, or over all frequencies."""
        return cls(None, level, unit, (0.0, math.inf) if band is None else tuple(band))

    @classmethod
    def band_limited(cls, level: float, f_lo: float, f_hi: float, unit: str = "(m/s^2)^2/Hz") -> PSD:
        """A flat spectrum ``level`` between ``f_lo`` and ``f_hi`` Hz, zero outside."""
        return cls.white(level, unit, (f_lo, f_hi))

    @classmethod
    def function(cls, fun, unit: str = "(m/s^2)^2/Hz", band: tuple = (0.0, math.inf), points: ArrayLike = ()) -> PSD:
        """A spectrum from a callable ``fun(f_hz)`` (levels in ``unit``, ≥ 0, vectorised over an array of Hz),
        zero outside ``band``; ``points``: frequencies (Hz) where it bends or jumps (the quadrature splits there)."""
        if not callable(fun):
            raise ModelError(f"PSD.function: expected a callable of the frequency (Hz), got {fun!r}")
        return cls(None, None, unit, tuple(band), fun, tuple(np.ravel(points)))

    @classmethod
    def iso8608(cls, road_class: str, speed: float, band: tuple = (0.011, 2.83)) -> PSD:
        """The vertical displacement PSD (m²/Hz, temporal) of an ISO 8608 road of class "A" … "H" driven at
        ``speed`` m/s: in spatial frequency n (cycles/m), G_d(n) = G_d(n0)·(n/n0)^-2 with n0 = 0.1 cycle/m and
        G_d(n0) the class's geometric mean (16e-6 m³ for A, ×4 per class), over ``band`` (cycles/m); in time,
        f = n·V and G(f) = G_d(f/V)/V over f = V·band (Hz). Exact as a two-breakpoint log-log table."""
        classes = "ABCDEFGH"
        if not (isinstance(road_class, str) and len(road_class) == 1 and road_class.upper() in classes):
            raise ModelError(f"ISO 8608 road class: one of {', '.join(classes)}, got {road_class!r}")
        V = scalar(speed, "ISO 8608 road speed (m/s)", positive=True)
        lo, hi = (scalar(x, "ISO 8608 band (cycles/m)", positive=True) for x in band)
        gd0 = 16e-6 * 4 ** classes.index(road_class.upper())
        n = np.array([lo, hi])
        return cls(n * V, gd0 * (n / 0.1) ** -2 / V, "m^2/Hz")

    # ------------------------------------------------------------------ what it is
    @property
    def quantity(self) -> str:
        """"acceleration", "velocity", "displacement", "force" or "torque"."""
        return UNITS[self.unit][0]

    @property
    def si_unit(self) -> str:
        return SI_UNIT[self.quantity]

    @property
    def kind(self) -> str:
        """"table", "white" or "function"."""
        return "function" if self.fun is not None else ("white" if self.frequency is None else "table")

    @property
    def is_white(self) -> bool:
        """Flat over all frequencies (0 … ∞): the Lyapunov equation applies."""
        return self.kind == "white" and self.band == (0.0, math.inf)

    @property
    def breakpoints(self) -> np.ndarray:
        """Frequencies (Hz) where G(f) bends or jumps: the table's breakpoints, the band's finite edges, a
        callable's points."""
        pts = [self.band[0]] + ([self.band[1]] if math.isfinite(self.band[1]) else [])
        if self.kind == "table":
            pts += list(self.frequency)
        pts += [p for p in self.points if self.band[0] <= p <= self.band[1]]
        return np.unique(np.array(pts, dtype=float))

    def __call__(self, f_hz: ArrayLike) -> np.ndarray:
        """G(f) in SI (:attr:`si_unit`) at the frequencies ``f_hz`` (Hz, ≥ 0)."""
        try:
            f = np.asarray(f_hz, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"PSD: frequencies (Hz) must be numbers, got {f_hz!r}") from None
        scale = UNITS[self.unit][1]
        lo, hi = self.band
        inside = (f >= lo) & (f <= hi)
        if self.kind == "white":
            return np.where(inside, self.values * scale, 0.0)
        if self.kind == "function":
            out = np.zeros(f.shape)
            if np.any(inside):
                v = np.broadcast_to(np.asarray(self.fun(f[inside]), dtype=float), f[inside].shape)
                if not np.all(np.isfinite(v)) or np.any(v < 0):
                    k = int(np.flatnonzero(~(np.isfinite(v) & (v >= 0)))[0])
                    raise ModelError(f"PSD function: value {float(v[k])!r} at {f[inside][k]:g} Hz (need finite levels "
                                     "≥ 0)")
                out[inside] = v * scale
            return out
        return self._table(f) * scale

    def _table(self, f):
        fb, vb = self.frequency, self.values
        out = np.zeros(f.shape)
        inside = (f >= fb[0]) & (f <= fb[-1])
        x = f[inside]
        i = np.clip(np.searchsorted(fb, x, side="right") - 1, 0, fb.size - 2)
        v0, v1 = vb[i], vb[i + 1]
        pos = (v0 > 0) & (v1 > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = np.where(pos, np.log(v1 / v0) / np.log(fb[i + 1] / fb[i]), 0.0)
            y = np.where(pos, v0 * (x / fb[i]) ** slope, 0.0)
        y = np.where(x == fb[i], v0, y)  # at a breakpoint: its own value (also a zero one)
        out[inside] = y
        return out

    def slopes_db_per_octave(self) -> np.ndarray:
        """The table's slope on each segment (dB/octave: 10·log10(G₂/G₁)/log2(f₂/f₁))."""
        if self.kind != "table":
            raise ModelError("PSD: slopes exist for a table of breakpoints only")
        with np.errstate(divide="ignore"):
            return 10 * np.diff(np.log10(self.values)) / np.diff(np.log2(self.frequency))

    def rms(self) -> float:
        """The input's RMS value (SI: m/s², m/s, m, N or N·m), √∫G df: exact for a table (power-law segments)
        and a band-limited white; for a callable, adaptive quadrature."""
        scale = UNITS[self.unit][1]
        if self.kind == "white":
            width = self.band[1] - self.band[0]
            if not math.isfinite(width):
                raise ModelError("PSD.rms: a white spectrum over all frequencies has an unbounded RMS (give a band)")
            return math.sqrt(self.values * scale * width)
        if self.kind == "table":
            f1, f2, g1, g2 = self.frequency[:-1], self.frequency[1:], self.values[:-1], self.values[1:]
            total = 0.0
            for a, b, ga, gb in zip(f1, f2, g1, g2):
                if ga <= 0 or gb <= 0:
                    continue
                s = math.log(gb / ga) / math.log(b / a)
                total += ga * a * math.log(b / a) if abs(s + 1) < 1e-12 else ga * a / (s + 1) * ((b / a) ** (s + 1) - 1)
            return math.sqrt(total * scale)
        from scipy.integrate import quad

        lo, hi = self.band
        pts = self.breakpoints
        edges = [lo, *[p for p in pts if lo < p < hi], hi]
        import warnings

        from scipy.integrate import IntegrationWarning

        with warnings.catch_warnings():
            warnings.simplefilter("error", IntegrationWarning)
            try:
                total = sum(quad(lambda x: float(self(np.array([x]))[0]), a, b, limit=200, epsrel=1e-10)[0]
                            for a, b in zip(edges[:-1], edges[1:]))
            except IntegrationWarning as e:  # (a function decaying no faster than 1/f: its integral diverges)
                raise ModelError(f"PSD.rms: the integral of the PSD over {lo:g}…{hi:g} Hz does not converge "
                                 f"({str(e).splitlines()[0].strip()}): band-limit it (band=) if its RMS is "
                                 "unbounded") from None
        return math.sqrt(total)

    def sample(self, duration: float, seed: int | None = None, f_max: float | None = None) -> RandomSignal:
        """A Gaussian sample path of the process (SI), seeded: Σ_k (A_k cos 2πf_k t − B_k sin 2πf_k t) at
        f_k = k/duration inside the band (up to ``f_max`` Hz, required for a band reaching infinity), A_k, B_k
        independent normal of variance ∫G df over the cell [f_k − Δf/2, f_k + Δf/2] (so the sample's expected
        variance is ∫G df over the band, exactly; numpy's default_rng(seed)). Periodic of period ``duration`` s."""
        T = scalar(duration, "PSD sample duration (s)", positive=True)
        hi = self.band[1] if f_max is None else min(self.band[1], scalar(f_max, "PSD sample f_max (Hz)",
                                                                         positive=True))
        if not math.isfinite(hi):
            raise ModelError("PSD.sample: the band reaches infinity: give f_max (Hz), the highest frequency to sample")
        lo = self.band[0]
        first, last = max(1, math.floor(lo * T + 0.5)), math.ceil(hi * T - 0.5)
        if last - first + 1 > 2_000_000:
            raise ModelError(f"PSD.sample: {last - first + 1} harmonics (duration × f_max): shorten the duration or "
                             "lower f_max")
        k = np.arange(first, last + 1)
        if k.size == 0:
            raise ModelError(f"PSD.sample: no frequency k/{T:g} Hz inside the band {lo:g}…{hi:g} Hz (a longer "
                             "duration)")
        f = k / T
        a = np.maximum((k - 0.5) / T, lo)
        b = np.minimum((k + 0.5) / T, hi)
        x, w = np.polynomial.legendre.leggauss(8)  # each cell's ∫G by 8-point Gauss–Legendre
        nodes = 0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * x[None, :]
        cell = 0.5 * (b - a) * (self(nodes.ravel()).reshape(nodes.shape) @ w)
        rng = np.random.default_rng(seed)
        z = rng.standard_normal((2, f.size)) * np.sqrt(np.maximum(cell, 0.0))
        return RandomSignal(f, np.hypot(z[0], z[1]), np.arctan2(z[1], z[0]), self.quantity)

    def to_dict(self) -> dict:
        """Plain data (JSON-ready; a callable cannot be written)."""
        if self.kind == "function":
            raise ModelError("a PSD given as a Python callable cannot be written as data (use a table)")
        if self.kind == "white":
            return {"kind": "white", "level": self.values, "unit": self.unit,
                    "band_hz": [self.band[0], self.band[1] if math.isfinite(self.band[1]) else None]}
        return {"kind": "table", "frequency_hz": self.frequency.tolist(), "values": self.values.tolist(),
                "unit": self.unit}

    def __repr__(self):
        if self.kind == "table":
            what = f"{self.frequency.size} breakpoints {self.frequency[0]:g}…{self.frequency[-1]:g} Hz, log-log"
        elif self.kind == "white":
            what = f"white {self.values:g}" + (f" over {self.band[0]:g}…{self.band[1]:g} Hz"
                                               if self.band != (0.0, math.inf) else " over all frequencies")
        else:
            what = f"callable over {self.band[0]:g}…{self.band[1]:g} Hz"
        return f"PSD({what}, {self.unit}, one-sided)"

    def plot(self, path=None, **kwargs):
        """Log-log plot of G(f) (SI) to ``path`` (see :func:`vibdyn.faces.random_plots.plot_psd`)."""
        from ..faces.random_plots import plot_psd

        return plot_psd(path, self, **kwargs)


@dataclass(frozen=True)
class Delay:
    """A cross-spectrum between two inputs (a, b): b is ``coherence`` × a delayed by ``delay`` s (the same road
    reaching the rear wheel a wheelbase later: delay = wheelbase / speed): G_ab(f) = coherence·√(G_aa G_bb)·
    e^{i2πfτ}, with G_ab = E[A B*] (one-sided)."""

    delay: float
    coherence: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "delay", scalar(self.delay, "cross-spectrum delay (s)"))
        c = scalar(self.coherence, "cross-spectrum coherence")
        if not -1.0 <= c <= 1.0:
            raise ModelError(f"cross-spectrum coherence must be within [-1, 1], got {c:g}")
        object.__setattr__(self, "coherence", c)


@dataclass(frozen=True, eq=False)
class RandomSignal:
    """A sample path Σ_k a_k cos(2πf_k t + φ_k) of a random process (SI, of ``quantity``) and, for a motion, its
    displacement, velocity and acceleration (exact derivatives and integrals of each harmonic, without the
    constants of integration: zero-mean)."""

    frequency: np.ndarray  # Hz
    amplitude: np.ndarray
    phase: np.ndarray  # rad
    quantity: str

    def _derived(self, t, k):
        w = 2 * np.pi * self.frequency
        t = np.asarray(t, dtype=float)
        arg = np.multiply.outer(t, w) + self.phase + k * np.pi / 2
        return np.cos(arg) @ (self.amplitude * w ** k)

    def __call__(self, t):
        """The sampled quantity at times t (s)."""
        return self._derived(t, 0)

    def _motion(self, t, order):
        if ORDER[self.quantity] is None:
            raise ModelError(f"random signal: a {self.quantity} has no displacement, velocity or acceleration")
        return self._derived(t, order - ORDER[self.quantity])

    def displacement(self, t):
        """Displacement (m) of a motion sample at t (s)."""
        return self._motion(t, 0)

    def velocity(self, t):
        """Velocity (m/s) of a motion sample at t (s)."""
        return self._motion(t, 1)

    def acceleration(self, t):
        """Acceleration (m/s²) of a motion sample at t (s)."""
        return self._motion(t, 2)

    @property
    def variance(self) -> float:
        """Σ a_k²/2 (SI²): this sample's mean square over its period."""
        return float(np.sum(self.amplitude ** 2) / 2)
