"""Ground-motion records: a ground acceleration sampled at a fixed step, as a support's motion law.

The acceleration is taken piecewise linear between samples (zero before the first, zero after the last); the
velocity and displacement are its exact integrals (piecewise quadratic and cubic), both zero at the start:
the ground starts at rest and, after the record, keeps the velocity it ends with (no baseline correction).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._check import finite_array, scalar, unit_axis
from ..errors import ModelError

G = 9.80665  # m/s², standard gravity
#: units of a record's samples, and their factor to m/s²
UNITS = {"m/s^2": 1.0, "g": G, "cm/s^2": 0.01, "mm/s^2": 0.001}


@dataclass(frozen=True, eq=False)
class Record:
    """A ground-acceleration record: ``acceleration`` samples (m/s²) every ``dt`` s from ``start`` (s), along
    ``direction`` (world axes, normalised), as the motion of a support (:meth:`vibdyn.Scene.add_support`) or as
    ``lin.forced_response(t, support=NAME, motion=record)``.

    :meth:`position`, :meth:`velocity` and :meth:`acceleration` are 3-vectors (m, m/s, m/s²): the exact
    integrals of the piecewise-linear acceleration. Integrators do not step over its kinks: ``max_step`` (= dt)
    bounds their steps and ``breakpoints`` are the sample times."""

    acceleration: Any
    dt: float
    direction: tuple = (1.0, 0.0, 0.0)
    start: float = 0.0

    def __post_init__(self):
        a = finite_array(self.acceleration, (None,), "record acceleration (m/s²)")
        if a.size == 0:
            raise ModelError("record acceleration: no samples (an empty record)")
        dt = scalar(self.dt, "record dt (s)", positive=True)
        d = unit_axis(self.direction, "record direction")
        start = scalar(self.start, "record start (s)")
        a = a.copy()
        a.flags.writeable = False
        h = dt
        # exact integrals at the samples: v_{k+1} = v_k + h(a_k + a_{k+1})/2,
        # u_{k+1} = u_k + h v_k + h²(2a_k + a_{k+1})/6
        with np.errstate(all="ignore"):
            v = np.concatenate([[0.0], np.cumsum(h * (a[:-1] + a[1:]) / 2)])
            du = h * v[:-1] + h * h * (2 * a[:-1] + a[1:]) / 6
            u = np.concatenate([[0.0], np.cumsum(du)])
        if not (np.all(np.isfinite(v)) and np.all(np.isfinite(u))):
            raise ModelError(f"record: the ground's velocity or displacement overflows (dt = {dt:g} s, peak "
                             f"{float(np.abs(a).max()):g} m/s²): check dt and the unit of the samples")
        for name, value in (("acceleration", a), ("dt", dt), ("direction", tuple(float(x) for x in d)),
                            ("start", start), ("_table", (a, v, u))):  # (_table: not a field, no key)
            object.__setattr__(self, name, value)

    # the support-motion protocol (3-vectors along the direction) ---------------------------------
    def ground(self, t: float) -> tuple[float, float, float]:
        """(displacement m, velocity m/s, acceleration m/s²) of the ground along ``direction`` at t (s)."""
        try:
            t = float(t)
        except (TypeError, ValueError):
            raise ModelError(f"record: the time must be a number (s), got {t!r}") from None
        if not math.isfinite(t):
            raise ModelError(f"record: the time must be finite (s), got {t!r}")
        a, v, u = self._table  # type: ignore[attr-defined]
        n = a.size
        s = (t - self.start) / self.dt
        if s <= 0.0:
            return 0.0, 0.0, (float(a[0]) if s == 0.0 else 0.0)
        k = int(s)
        if k >= n - 1:
            tau = t - self.start - (n - 1) * self.dt
            return float(u[-1] + v[-1] * tau), float(v[-1]), (float(a[-1]) if tau == 0.0 else 0.0)
        tau = t - self.start - k * self.dt
        ak, slope = float(a[k]), float(a[k + 1] - a[k]) / self.dt
        return (float(u[k] + tau * (v[k] + tau * (ak / 2 + tau * slope / 6))),
                float(v[k] + tau * (ak + tau * slope / 2)), ak + slope * tau)

    def position(self, t: float) -> np.ndarray:
        """Ground displacement (m, world axes) at t (s)."""
        return self.ground(t)[0] * np.array(self.direction)

    def velocity(self, t: float) -> np.ndarray:
        """Ground velocity (m/s, world axes) at t (s)."""
        return self.ground(t)[1] * np.array(self.direction)

    def ground_acceleration(self, t: float) -> np.ndarray:
        """Ground acceleration (m/s², world axes) at t (s): the samples linearly interpolated."""
        return self.ground(t)[2] * np.array(self.direction)

    @property
    def max_step(self) -> float:
        """Largest step (s) an integrator may take over this law: ``dt``, so that no step crosses two kinks."""
        return self.dt

    @property
    def bounded_until(self) -> float:
        """Time (s) of the last sample: past it the ground moves uniformly and :attr:`max_step` bounds no step."""
        return self.start + self.duration

    @property
    def times(self) -> np.ndarray:
        """Sample times (s)."""
        return self.start + self.dt * np.arange(self.acceleration.size)

    breakpoints = times

    @property
    def duration(self) -> float:
        """Time from the first to the last sample (s)."""
        return self.dt * (self.acceleration.size - 1)

    @property
    def peak_acceleration(self) -> float:
        """Peak ground acceleration, max |a| (m/s²) (exact: the extremes of a piecewise-linear signal are samples)."""
        return float(np.abs(self.acceleration).max())

    def pseudo_acceleration_spectrum(self, periods, damping: float = 0.05):
        """The record's response spectrum: the peak relative displacement S_d of a linear oscillator
        ẍ + 2ζωẋ + ω²x = −a_g(t) per period T = 2π/ω (s), and S_a = ω² S_d (m/s², pseudo-acceleration), exact for
        the piecewise-linear record (Nigam & Jennings 1969 step solution), with an error estimate
        (:class:`vibdyn.analysis.response.record_spectrum.RecordSpectrum`). A period 0 gives the peak ground
        acceleration (a rigid oscillator)."""
        from ..analysis.response.record_spectrum import record_spectrum

        return record_spectrum(self, periods, damping)

    def to_dict(self) -> dict:
        return {"law": "record", "acceleration": self.acceleration.tolist(), "dt": self.dt,
                "direction": list(self.direction), "start": self.start}

    def describe(self) -> str:
        """One line: samples, step, duration, direction and peak."""
        return (f"ground-acceleration record, {self.acceleration.size} samples every {self.dt:g} s "
                f"({self.duration:g} s from {self.start:g} s) along {list(self.direction)}, peak "
                f"{self.peak_acceleration:.4g} m/s²")

    def __repr__(self):
        return (f"Record({self.acceleration.size} samples every {self.dt:g} s from {self.start:g} s, "
                f"direction {list(self.direction)}, peak {self.peak_acceleration:.4g} m/s²)")

    @classmethod
    def from_file(cls, path: str | os.PathLike, dt: float | None = None, direction=(1.0, 0.0, 0.0),
                  unit: str | None = None) -> Record:
        """A record read from a text file of one column (accelerations: give ``dt``) or two (time s,
        acceleration), blank-, comma- or semicolon-separated; lines starting with ``#`` or ``%`` and header
        lines before the numbers are skipped. ``unit``: that of the accelerations, one of "m/s^2" (the default),
        "g", "cm/s^2", "mm/s^2". A PEER NGA record (``.AT2``: four header lines, the fourth "NPTS= 5000, DT= .0050
        SEC" or "5000 0.0050 NPTS, DT", then the samples in g, several per row) is read as such, its unit g
        unless ``unit`` says otherwise and its step the header's. Refused: an empty file, NaN or inf, rows of
        unequal length, non-uniform time steps (the step must be constant to 1e-6 of itself), a ``dt`` that
        contradicts the time column or the header, an AT2 file whose samples are not NPTS."""
        if not isinstance(path, (str, os.PathLike)):
            raise ModelError(f"record file: expected a path (str or os.PathLike), got {type(path).__name__} {path!r}")
        what = f"record file '{os.fspath(path)}'"
        if unit is not None and unit not in UNITS:
            raise ModelError(f"{what}: unknown unit {unit!r} (one of {', '.join(UNITS)})")
        try:
            with open(path, encoding="utf-8", errors="replace") as f:
                lines = f.read().splitlines()
        except OSError as e:
            raise ModelError(f"{what}: cannot be read ({e.strerror or e})") from None
        peer = _peer_at2(lines, what)
        if peer is not None:
            samples, step = peer
            if dt is not None and abs(scalar(dt, f"{what}: dt (s)", positive=True) - step) > 1e-6 * step:
                raise ModelError(f"{what}: dt = {dt:g} s contradicts the header's DT = {step:g} s")
            return cls(samples * UNITS[unit or "g"], step, direction)
        unit = unit or "m/s^2"
        rows: list = []
        first = None
        for number, line in enumerate(lines, 1):
            text = line.strip()
            if not text or text[0] in "#%":
                continue
            fields = text.replace(",", " ").replace(";", " ").split()
            try:
                values = [float(x) for x in fields]
            except ValueError:
                if not rows:  # a header line before the numbers
                    continue
                raise ModelError(f"{what}, line {number}: not a number in {text!r}") from None
            if not all(math.isfinite(x) for x in values):
                raise ModelError(f"{what}, line {number}: NaN or inf in {text!r}")
            if first is None:
                first = len(values)
                if first not in (1, 2):
                    raise ModelError(f"{what}, line {number}: {first} columns; expected one (acceleration, with dt "
                                     "given) or two (time s, acceleration)")
            elif len(values) != first:
                raise ModelError(f"{what}, line {number}: {len(values)} columns where the file has {first}")
            rows.append(values)
        if not rows:
            raise ModelError(f"{what}: no samples (an empty record)")
        data = np.array(rows)
        start = 0.0
        if first == 1:
            if dt is None:
                raise ModelError(f"{what}: one column (accelerations only): give dt= (s)")
            dt = scalar(dt, f"{what}: dt (s)", positive=True)
        else:
            t = data[:, 0]
            if t.size < 2:
                raise ModelError(f"{what}: one sample: its time step is undefined (give at least two rows)")
            steps = np.diff(t)
            step = float((t[-1] - t[0]) / (t.size - 1))
            if step <= 0 or np.any(steps <= 0):
                raise ModelError(f"{what}: times must increase (line of sample {int(np.argmax(steps <= 0)) + 2})")
            worst = int(np.argmax(np.abs(steps - step)))
            if abs(steps[worst] - step) > 1e-6 * step:
                raise ModelError(f"{what}: non-uniform time steps ({steps[worst]:.6g} s between samples {worst + 1} "
                                 f"and {worst + 2}, {step:.6g} s on average); resample to a fixed step")
            if dt is not None and abs(scalar(dt, f"{what}: dt (s)", positive=True) - step) > 1e-6 * step:
                raise ModelError(f"{what}: dt = {dt:g} s contradicts the time column's step {step:.6g} s")
            dt, start = step, float(t[0])
        return cls(data[:, -1] * UNITS[unit], dt, direction, start)


_NPTS = (re.compile(r"NPTS\s*=\s*(\d+)\s*,?\s*DT\s*=\s*([-+0-9.eE]+)", re.IGNORECASE),
         re.compile(r"^\s*(\d+)\s+([-+0-9.eE]+)\s+NPTS\s*,\s*DT", re.IGNORECASE))


def _peer_at2(lines: list, what: str) -> tuple[np.ndarray, float] | None:
    """(samples, dt) of a PEER NGA .AT2 file (its NPTS/DT line among the first six, the samples after it), else
    None."""
    for number, line in enumerate(lines[:6]):
        match = next((m for m in (rx.search(line) for rx in _NPTS) if m), None)
        if match is None:
            continue
        npts = int(match.group(1))
        try:
            step = float(match.group(2))
            values = [float(x) for text in lines[number + 1:] for x in text.replace(",", " ").split()]
        except ValueError as e:
            raise ModelError(f"{what}: a PEER AT2 file (header line {number + 1}: {line.strip()!r}) with "
                             f"something not a number after it ({e})") from None
        if not (math.isfinite(step) and step > 0):
            raise ModelError(f"{what}: the header's DT = {match.group(2)} s is not a positive time step")
        if len(values) != npts or not npts:
            raise ModelError(f"{what}: the header says NPTS = {npts} samples, the file has {len(values)}")
        samples = np.array(values)
        if not np.all(np.isfinite(samples)):
            raise ModelError(f"{what}: NaN or inf among the samples")
        return samples, step
    return None
