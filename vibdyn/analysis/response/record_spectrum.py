"""Response spectrum of a ground-acceleration record: the peak response of linear oscillators
ẍ + 2ζωẋ + ω²x = −a_g(t), exact for a piecewise-linear record (Nigam & Jennings 1969 step solution).

The step matrices are the closed form of Nigam & Jennings; a second computation of them (the matrix exponential
of the oscillator augmented with the linear input, scipy.linalg.expm) measures their round-off, and that
difference, propagated over the steps, is the error estimate. The closed form's round-off grows as ε/(ωh)² at
long periods (1e-2 of B at T = 3000 s, h = 0.01 s, ζ = 0.05): below ωh = 0.1 the exponential is the step, and
the square of its half step the check. Peaks
between samples are found where the velocity vanishes (safeguarded Newton on the exact solution within the
step); a step longer than T/8 is cut into equal parts (exact: the input is linear within it), and the free
vibration after the record's end is included (its first extremum, the largest).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike

from ..._check import finite_array, scalar
from ...defaults import EPS
from ...errors import ModelError


def nigam_jennings(omega, zeta, h):
    """(A, B) of the exact step of ẍ + 2ζωẋ + ω²x = −a(t), a linear from a_k to a_{k+1} over the step h (s):
    (x, ẋ)_{k+1} = A (x, ẋ)_k + B (a_k, a_{k+1}); arrays (..., 2, 2) broadcast over ω (rad/s, > 0), ζ ∈ [0, 1)."""
    w, z, h = np.broadcast_arrays(np.asarray(omega, float), np.asarray(zeta, float), np.asarray(h, float))
    s1 = np.sqrt(1 - z * z)
    wd = w * s1
    E, S, C = np.exp(-z * w * h), np.sin(wd * h), np.cos(wd * h)
    r = z / s1
    c1, c2 = (2 * z * z - 1) / (w * w * h), 2 * z / (w ** 3 * h)
    A = _free(w, z, h)
    b11 = E * ((c1 + z / w) * S / wd + (c2 + 1 / w ** 2) * C) - c2
    b12 = -E * (c1 * S / wd + c2 * C) - 1 / w ** 2 + c2
    b21 = E * ((c1 + z / w) * (C - r * S) - (c2 + 1 / w ** 2) * (wd * S + z * w * C)) + 1 / (w * w * h)
    b22 = -E * (c1 * (C - r * S) - c2 * (wd * S + z * w * C)) - 1 / (w * w * h)
    return A, np.stack([np.stack([b11, b12], -1), np.stack([b21, b22], -1)], -2)


def _free(omega, zeta, h):
    """A of the free step (no input): (x, ẋ)(h) = A (x, ẋ)(0); arrays (..., 2, 2) broadcast over ω, ζ, h."""
    w, z, h = np.broadcast_arrays(np.asarray(omega, float), np.asarray(zeta, float), np.asarray(h, float))
    s1 = np.sqrt(1 - z * z)
    wd, r = w * s1, z / s1
    E, S, C = np.exp(-z * w * h), np.sin(wd * h), np.cos(wd * h)
    return np.stack([np.stack([E * (r * S + C), E * S / wd], -1), np.stack([-w / s1 * E * S, E * (C - r * S)], -1)],
                    -2)


def _exponential_step(omega, zeta, h, halves=False):
    """(A, B) of the same step from expm of the oscillator augmented with the input (a, ȧ): the check of the
    closed form, and the step itself at long periods (ωh < ``LONG``), where the closed form cancels; with
    ``halves``, also (A, B) from the square of the half step's exponential (the check of that step)."""
    out, out_half = ([], []), ([], [])
    for w in np.atleast_1d(omega):
        X = np.zeros((4, 4))
        X[0, 1], X[1, 0], X[1, 1], X[1, 2], X[2, 3] = 1.0, -w * w, -2 * zeta * w, -1.0, 1.0
        for E, dest in ((sla.expm(X * h), out),) + (((lambda F: F @ F)(sla.expm(X * h / 2)), out_half),) * halves:
            dest[0].append(E[:2, :2])
            dest[1].append(np.column_stack([E[:2, 2] - E[:2, 3] / h, E[:2, 3] / h]))
    first = (np.array(out[0]), np.array(out[1]))
    return first + (np.array(out_half[0]), np.array(out_half[1])) if halves else first


#: below this ωh the closed-form step loses ε/(ωh)² to cancellation: the exponential's step is used instead
LONG = 0.1


def _within(x, v, a, slope, w, z, tau, h):
    """(x, ẋ) at τ into a step (of h) from (x, v) with input a + slope·τ: particular part (linear) + free part;
    at long periods (ωh < ``LONG``, where the particular part a/ω² cancels) the exponential of the oscillator
    augmented with the input (a, ȧ) instead."""
    long = w * h < LONG
    ws = np.where(long, 1.0, w)
    beta = -slope / (ws * ws)
    alpha = -a / (ws * ws) + 2 * z * slope / ws ** 3
    A = _free(ws, z, tau)
    x0, v0 = x - alpha, v - beta
    xt, vt = A[..., 0, 0] * x0 + A[..., 0, 1] * v0 + alpha + beta * tau, A[..., 1, 0] * x0 + A[..., 1, 1] * v0 + beta
    if long.any():
        k = np.flatnonzero(long)
        X = np.zeros((k.size, 4, 4))
        X[:, 0, 1], X[:, 1, 0], X[:, 1, 1], X[:, 1, 2], X[:, 2, 3] = 1.0, -w[k] ** 2, -2 * z * w[k], -1.0, 1.0
        state = sla.expm(X * tau[k, None, None]) @ np.stack([x[k], v[k], a[k], slope[k]], -1)[..., None]
        xt[k], vt[k] = state[:, 0, 0], state[:, 1, 0]
    return xt, vt


def _peaks(acc, h, w, z):
    """Peak |x| of the oscillators ω (array) on the record acc (samples every h), its time, and the error
    estimate of the peak (m)."""
    n = acc.size
    with np.errstate(all="ignore"):  # (at long periods the closed form may overflow: the exponential replaces it)
        A, B = nigam_jennings(w, z, h)
    Ae, Be, Ah, Bh = _exponential_step(w, z, h, halves=True)
    long = w * h < LONG  # long periods: the exponential's step, checked against its half step squared
    A, B, Ae, Be = (np.where(long[:, None, None], x, y) for x, y in ((Ae, A), (Be, B), (Ah, Ae), (Bh, Be)))
    X, V = np.zeros((n, w.size)), np.zeros((n, w.size))
    x, v = np.zeros(w.size), np.zeros(w.size)
    a11, a12, a21, a22 = A[:, 0, 0], A[:, 0, 1], A[:, 1, 0], A[:, 1, 1]
    b11, b12, b21, b22 = B[:, 0, 0], B[:, 0, 1], B[:, 1, 0], B[:, 1, 1]
    # the input's part of every step at once (n − 1 × periods), then the 2 × 2 recursion, vectorised over periods
    X[1:] = np.outer(acc[:-1], b11) + np.outer(acc[1:], b12)
    V[1:] = np.outer(acc[:-1], b21) + np.outer(acc[1:], b22)
    t1, t2 = np.empty(w.size), np.empty(w.size)
    for k in range(1, n):
        np.multiply(a11, x, out=t1)
        t1 += X[k]
        np.multiply(a12, v, out=t2)
        t1 += t2
        np.multiply(a21, x, out=t2)
        t2 += V[k]
        v *= a22
        v += t2
        x[:] = t1
        X[k], V[k] = x, v
    absX = np.abs(X)
    kmax = absX.argmax(axis=0)
    peak = absX[kmax, np.arange(w.size)]
    when = kmax * h
    # extremes between samples: steps where ẋ changes sign near the peak (h ≤ T/8: an extremum inside a step
    # exceeds its ends by at most 1/cos(π/8) − 1 ≈ 8 %, so 0.5 of the sampled peak leaves a wide margin)
    flip = (V[:-1] * V[1:] <= 0) & (np.maximum(absX[:-1], absX[1:]) >= 0.5 * peak)
    ks, ps = np.nonzero(flip)
    if ks.size:
        ww, xk, vk = w[ps], X[ks, ps], V[ks, ps]
        ak, slope = acc[ks], (acc[ks + 1] - acc[ks]) / h
        lo, hi = np.zeros(ks.size), np.full(ks.size, h)
        sign_lo = np.sign(vk)
        tau = np.where(vk == V[ks + 1, ps], 0.0, h * vk / np.where(vk == V[ks + 1, ps], 1.0, vk - V[ks + 1, ps]))
        for _ in range(60):  # safeguarded Newton on ẋ(τ) = 0, ẍ = −a − 2ζωẋ − ω²x
            xt, vt = _within(xk, vk, ak, slope, ww, z, tau, h)
            same = np.sign(vt) == sign_lo
            lo, hi = np.where(same, tau, lo), np.where(same, hi, tau)
            acc_t = -(ak + slope * tau) - 2 * z * ww * vt - ww * ww * xt
            step = np.where(acc_t != 0, -vt / np.where(acc_t != 0, acc_t, 1.0), 0.0)
            new = tau + step
            new = np.where((new > lo) & (new < hi), new, (lo + hi) / 2)
            if np.all(np.abs(new - tau) <= 1e-13 * h):
                tau = new
                break
            tau = new
        xt = np.abs(_within(xk, vk, ak, slope, ww, z, tau, h)[0])
        for p in np.unique(ps):
            sel = ps == p
            j = int(np.argmax(xt[sel]))
            if xt[sel][j] > peak[p]:
                peak[p], when[p] = xt[sel][j], (ks[sel][j] + tau[sel][j] / h) * h
    # the free vibration after the last sample: its first extremum, the largest of its decaying ones
    wd = w * np.sqrt(1 - z * z)
    xN, vN = X[-1], V[-1]
    tau = np.mod(np.arctan2(vN * wd, w * w * xN + z * w * vN), np.pi) / wd
    A_end = _free(w, z, tau)
    x_end = np.abs(np.where(tau > 0, A_end[:, 0, 0] * xN + A_end[:, 0, 1] * vN, xN))
    later = x_end > peak
    peak, when = np.where(later, x_end, peak), np.where(later, (n - 1) * h + tau, when)
    # error: the step matrices' round-off (closed form against expm), propagated over the steps it persists
    dA, dB = np.abs(A - Ae) + 4 * EPS * np.abs(A), np.abs(B - Be) + 4 * EPS * np.abs(B)
    xm, vm, am = np.abs(X).max(axis=0), np.abs(V).max(axis=0), np.abs(acc).max()
    per_step = dA[:, 0, 0] * xm + dA[:, 0, 1] * vm + (dB[:, 0, 0] + dB[:, 0, 1]) * am
    per_step += h * (dA[:, 1, 0] * xm + dA[:, 1, 1] * vm + (dB[:, 1, 0] + dB[:, 1, 1]) * am)
    memory = np.minimum(n, 1.0 / np.maximum(-np.expm1(-z * w * h), 1e-300))
    # (+ the recursion's own round-off, a few ε of the state per step over the steps it persists)
    return peak, when, (per_step + 4 * EPS * peak) * memory + 8 * EPS * peak


@dataclass(frozen=True, eq=False)
class RecordSpectrum:
    """Response spectrum of a record (:meth:`vibdyn.laws.Record.pseudo_acceleration_spectrum`), per period
    ``periods`` (s): ``displacement`` S_d (m, peak relative displacement of the oscillator),
    ``pseudo_velocity`` ω S_d (m/s), ``pseudo_acceleration`` S_a = ω² S_d (m/s²), each with its estimated
    absolute error (``displacement_error`` m, ``error`` m/s²: that of S_a); ``peak_time`` (s) when each peak
    occurs; ``damping`` ζ; ``elapsed`` (s). Exact for the piecewise-linear record up to the estimate."""

    periods: np.ndarray
    damping: float
    displacement: np.ndarray
    displacement_error: np.ndarray
    peak_time: np.ndarray
    peak_ground_acceleration: float
    elapsed: float
    method: str = "nigam-jennings"

    @property
    def omega(self) -> np.ndarray:
        """ω = 2π/T (rad/s; inf at T = 0)."""
        with np.errstate(divide="ignore"):
            return 2 * np.pi / self.periods

    @property
    def pseudo_acceleration(self) -> np.ndarray:
        """S_a = ω² S_d (m/s²); at T = 0 the peak ground acceleration."""
        rigid = self.periods == 0
        w = np.where(rigid, 1.0, self.omega)
        return np.where(rigid, self.peak_ground_acceleration, w * w * self.displacement)

    @property
    def pseudo_velocity(self) -> np.ndarray:
        """ω S_d (m/s); 0 at T = 0."""
        return np.where(self.periods == 0, 0.0, np.where(self.periods == 0, 1.0, self.omega) * self.displacement)

    @property
    def error(self) -> np.ndarray:
        """Estimated absolute error of ``pseudo_acceleration`` (m/s²)."""
        w = np.where(self.periods == 0, 0.0, np.where(self.periods == 0, 1.0, self.omega))
        return w * w * self.displacement_error

    @property
    def relative_error(self) -> float:
        """Largest estimated error relative to each S_a."""
        sa = self.pseudo_acceleration
        return float(np.max(self.error / np.where(sa > 0, sa, 1.0), initial=0.0))

    def plot(self, path: str | None = None, **kwargs: Any) -> Any:
        """Draw S_a against T (see :func:`vibdyn.faces.spectrum_plots.plot_response_spectrum`); PNG at ``path``."""
        from ...faces.spectrum_plots import plot_response_spectrum

        return plot_response_spectrum(path, self, **kwargs)

    def to_dict(self) -> dict:
        return {"periods_s": self.periods.tolist(), "damping_ratio": self.damping,
                "displacement_m": self.displacement.tolist(), "displacement_error_m": self.displacement_error.tolist(),
                "pseudo_velocity_m_s": self.pseudo_velocity.tolist(),
                "pseudo_acceleration_m_s2": self.pseudo_acceleration.tolist(),
                "pseudo_acceleration_error_m_s2": self.error.tolist(), "peak_time_s": self.peak_time.tolist(),
                "peak_ground_acceleration_m_s2": self.peak_ground_acceleration, "method": self.method,
                "elapsed_s": self.elapsed}

    def __repr__(self):
        from ..._format import duration, number, summary

        return summary("RecordSpectrum", f"{self.periods.size} periods {number(self.periods.min())}…"
                       f"{number(self.periods.max())} s", f"ζ = {self.damping:g}",
                       f"max S_a = {number(self.pseudo_acceleration.max(), 'm/s²')}",
                       f"relative error {number(self.relative_error, digits=2)}", duration(self.elapsed))


def record_spectrum(record, periods: ArrayLike, damping: float = 0.05) -> RecordSpectrum:
    """:meth:`vibdyn.laws.Record.pseudo_acceleration_spectrum` (see there)."""
    start = time.perf_counter()
    T = np.atleast_1d(finite_array(periods, None, "record spectrum periods (s)")).astype(float)
    if T.ndim != 1 or T.size == 0:
        raise ModelError(f"record spectrum periods (s): expected a number or a 1-D list, got shape {T.shape}")
    if np.any(T < 0):
        raise ModelError(f"record spectrum periods (s): must be ≥ 0 (0: the peak ground acceleration), got "
                         f"{T[T < 0][0]:g}")
    z = scalar(damping, "record spectrum damping ratio", nonnegative=True)
    if z >= 1:
        raise ModelError(f"record spectrum damping ratio: {z:g} ≥ 1 (critically or over-damped oscillators "
                         "do not oscillate: no response spectrum); give 0 ≤ ζ < 1, e.g. 0.05")
    acc, h = np.asarray(record.acceleration, float), float(record.dt)
    disp, err, when = np.zeros(T.size), np.zeros(T.size), np.zeros(T.size)
    live = T > 0
    ratio = np.where(live, 8 * h / np.where(live, T, 1.0), 0.0)
    if np.any(ratio * acc.size > 5_000_000):
        raise ModelError(f"record spectrum: periods down to {T[live].min():g} s need steps ≤ T/8 over "
                         f"{acc.size} samples: too many; give longer periods (or 0 for the peak ground acceleration)")
    parts = np.where(live, np.maximum(np.ceil(ratio - 1e-12), 1), 0).astype(int)
    if np.sum(np.unique(parts[live]) * acc.size) > 5_000_000:
        raise ModelError(f"record spectrum: periods down to {T[live].min():g} s need steps ≤ T/8 over "
                         f"{acc.size} samples: too many; give longer periods (or 0 for the peak ground acceleration)")
    for m in np.unique(parts[live]):
        fine = acc if m == 1 else np.interp(np.arange((acc.size - 1) * m + 1) / m, np.arange(acc.size), acc)
        # the oscillators' histories (2 × steps × periods floats) in pieces of at most ~40 MB each
        group = np.flatnonzero(parts == m)
        size = max(1, 2_500_000 // fine.size)
        for start_at in range(0, group.size, size):
            sel = group[start_at:start_at + size]
            p, tt, e = _peaks(fine, h / m, 2 * np.pi / T[sel], z)
            disp[sel], when[sel], err[sel] = p, tt + record.start, e
    pga = record.peak_acceleration
    when[~live] = record.start + h * float(np.argmax(np.abs(acc)))
    return RecordSpectrum(T, z, disp, err, when, pga, time.perf_counter() - start)
