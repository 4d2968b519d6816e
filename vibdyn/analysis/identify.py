"""Calculation/test correlation: modal damping identified from measured resonance peaks (half-power
bandwidth) or from the logarithmic decrement of a free-decay signal, and Rayleigh damping fitted to it.

Every function works on sampled data (arrays, as measured); the half-power and peak search also accept a
``function`` ω ↦ |H(ω)| to refine on (what :meth:`vibdyn.analysis.response.FRF.peaks` uses). Frequencies in rad/s.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from .._check import finite_array, scalar
from ..defaults import EPS
from ..errors import ModelError
from ..solvers.differences import second_derivative

QUANTITIES = ("receptance", "mobility", "accelerance")


# ---------------------------------------------------------------- half-power bandwidth
def zeta_from_half_power(omega_1, omega_2, quantity="receptance"):
    """Damping ratio of a single-degree-of-freedom resonance from its half-power frequencies ω1 < ω2 (rad/s).

    Exact for an isolated mode: for the mobility ζ = (ω2 − ω1) / (2√(ω1ω2)); for the receptance and the
    accelerance (ω1, ω2 solve (1 − r²)² + (2ζr)² = 8ζ²(1 − ζ²)) ζ² = (1 − 1/√(1 + s²))/2 with
    s = (ω2² − ω1²)/(ω2² + ω1²). Both tend to the textbook (ω2 − ω1)/(2ω_r) for light damping.
    """
    w1, w2 = np.asarray(omega_1, dtype=float), np.asarray(omega_2, dtype=float)
    if quantity not in QUANTITIES:
        raise ModelError(f"half power: unknown quantity {quantity!r} (one of {', '.join(QUANTITIES)})")
    if not (np.all(np.isfinite(w1)) and np.all(np.isfinite(w2))) or np.any(w1 <= 0) or np.any(w2 <= w1):
        raise ModelError(f"half power: need finite frequencies 0 < omega_1 < omega_2, got {omega_1}, {omega_2}")
    if quantity == "mobility":
        return (w2 - w1) / (2 * np.sqrt(w1 * w2))
    s2 = ((w2 ** 2 - w1 ** 2) / (w2 ** 2 + w1 ** 2)) ** 2
    r = np.sqrt(1 + s2)
    return np.sqrt(s2 / (2 * r * (r + 1)))  # (1 − 1/√(1+s²))/2 without cancellation


@dataclass(frozen=True, eq=False)
class HalfPower:
    """Half-power (−3 dB) bandwidth of each resonance of |H(ω)| and the damping ratio it gives.

    Arrays per resolved resonance: ``omega_peak`` (rad/s), ``amplitude`` (|H| there), ``lower``/``upper``
    (rad/s, where |H| = peak/√2), ``bandwidth`` = upper − lower, ``zeta`` (exact single-mode inversion,
    :func:`zeta_from_half_power`), ``zeta_approx`` = bandwidth / (2 ω_peak). ``error``: estimated absolute
    error of each ζ. ``unresolved``: resonances whose two half-power points are not both in the data.
    """

    omega_peak: np.ndarray
    amplitude: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    bandwidth: np.ndarray
    zeta: np.ndarray
    zeta_approx: np.ndarray
    error: np.ndarray
    unresolved: np.ndarray
    quantity: str
    elapsed: float  # s
    undamped: np.ndarray = field(default_factory=lambda: np.zeros(0))  # undamped resonances (rad/s): no band

    def __repr__(self):
        from .._format import summary, values

        return summary("HalfPower", f"{self.omega_peak.size} resonances at {values(self.omega_peak, 'rad/s', digits=6)}"
                       if self.omega_peak.size or not self.undamped.size else "",
                       f"ζ = {values(self.zeta)}" if self.zeta.size else "",
                       f"undamped (ζ = 0, no band) at {values(self.undamped, 'rad/s', digits=6)}"
                       if self.undamped.size else "",
                       f"{self.unresolved.size} unresolved" if self.unresolved.size else "")

    @property
    def frequency_hz(self):
        return self.omega_peak / (2 * np.pi)

    @property
    def eta(self):
        """Equivalent loss factor 2ζ."""
        return 2 * self.zeta

    def to_dict(self):
        return {"omega_peak_rad_s": self.omega_peak.tolist(), "frequency_hz": self.frequency_hz.tolist(),
                "amplitude": self.amplitude.tolist(), "lower_rad_s": self.lower.tolist(),
                "upper_rad_s": self.upper.tolist(), "zeta": self.zeta.tolist(), "zeta_error": self.error.tolist(),
                "unresolved_rad_s": self.unresolved.tolist(), "undamped_rad_s": self.undamped.tolist(),
                "quantity": self.quantity, "elapsed_s": self.elapsed}


def extrema(omega, values, function=None, which="max", precision=0.0):
    """Local maxima (``which`` "max") or minima ("min") of sampled values, refined between the neighbouring
    samples: by bounded Brent search on ``function`` (ω ↦ value) if given, else on a cubic spline through
    the samples. Returns (positions, values, errors): the errors estimate the positions' absolute error
    (Brent's tolerance plus the flat extremum's resolution √(2 δa / |a''|), δa the values' precision —
    ``precision`` relative, at least a few ε — or the spline's difference from a three-point parabola). End
    samples are no extrema."""
    from scipy.optimize import minimize_scalar

    w, a = _curve(omega, values, "extrema")
    if which not in ("max", "min"):
        raise ModelError(f"extrema: which must be 'max' or 'min', got {which!r}")
    sign = -1.0 if which == "max" else 1.0
    f = _function(w, a, function)
    i = np.arange(1, w.size - 1)
    s = sign * a
    cand = i[(s[i] <= s[i - 1]) & (s[i] < s[i + 1])]
    pos, val, err, last = [], [], [], -10
    for j in cand:
        lo, hi = w[j - 1], w[j + 1]
        # (an unbounded value, a pole within the bracket, is clamped: Brent's arithmetic stays finite)
        res = minimize_scalar(lambda x: sign * min(f(x), 1e300), bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-12 * hi, "maxiter": 500})
        x = float(res.x)
        if function is None:  # data only: compare with the vertex of the parabola through three samples
            e = abs(x - _parabola(w[j - 1:j + 2], a[j - 1:j + 2])[0])
        else:
            e = 2 * (math.sqrt(EPS) * abs(x) + 1e-12 * hi) + _flatness(f, x, hi - lo, precision)
        if pos and j - last <= 2 and abs(x - pos[-1]) <= max(e, err[-1]) + 1e-6 * abs(x):
            continue  # the same extremum reached from two overlapping brackets
        last = j
        pos.append(x)
        val.append(float(f(x)))
        err.append(e)
    return np.array(pos), np.array(val), np.array(err)


def _flatness(f, x, width, precision):
    """How far from x (rad/s) an extremum of f looks alike when f's values are known to a relative
    ``precision`` (plus 4ε): √(2 δa / |a''|), a'' by a second difference over width/8; ``width`` where f
    is not curved there or not finite (a pole: there the maximum is the pole, found exactly)."""
    h = width / 8
    a0 = f(x)
    curvature = abs(second_derivative(f, x, h, a0)[1])
    if not math.isfinite(curvature):  # (f not finite at one of the three points)
        return 0.0
    da = (precision + 4 * EPS) * abs(a0)
    return math.sqrt(2 * da / curvature) if curvature > 0 else width


def half_power(omega, amplitude, quantity="receptance", function=None):
    """Damping of each resonance of |H| from its half-power bandwidth (:class:`HalfPower`).

    ``omega`` (rad/s, increasing) and ``amplitude`` = |H(ω)| sampled (measured, or computed); ``quantity``
    says which FRF H is ("receptance", "mobility" or "accelerance": the exact inversion depends on it).
    Peaks and crossings are refined on ``function`` (ω ↦ |H|) if given, else on a cubic spline of the
    samples (error estimated against linear interpolation)."""
    start = time.perf_counter()
    w, a = _curve(omega, amplitude, "half power")
    if np.any(a < 0):
        raise ModelError("half power: amplitudes must be magnitudes |H| ≥ 0")
    f = _function(w, a, function)
    peaks, amps, perr = extrema(w, a, function, "max")
    rows, unresolved = [], []
    for wp, ap, ep in zip(peaks, amps, perr):
        if not math.isfinite(ap):  # unbounded within the model's error: an undamped resonance has no band
            unresolved.append(wp)
            continue
        level = ap / math.sqrt(2)
        k = int(np.searchsorted(w, wp))
        lower = _crossing(w, a, f, level, wp, k - 1, -1, function is None)
        upper = _crossing(w, a, f, level, wp, k, +1, function is None)
        if lower is None or upper is None:
            unresolved.append(wp)
            continue
        (w1, e1), (w2, e2) = lower, upper
        z = float(zeta_from_half_power(w1, w2, quantity))
        dz = float(abs(zeta_from_half_power(w1 - e1, w2 + e2, quantity) - z)) + 16 * EPS * z
        rows.append((wp, ap, w1, w2, z, (w2 - w1) / (2 * wp), dz))
    cols = np.array(rows, dtype=float).reshape(-1, 7).T
    wp, ap, w1, w2, z, za, dz = cols
    return HalfPower(wp, ap, w1, w2, w2 - w1, z, za, dz, np.array(unresolved), quantity, time.perf_counter() - start)


def _crossing(w, a, f, level, wp, k, step, data_only):
    """Where |H| falls to ``level`` walking from the peak ``wp`` along the samples from index k in the
    direction ``step``; None if it rises again (another mode) or the data end first."""
    from scipy.optimize import brentq

    prev = wp
    while 0 <= k < w.size:
        if a[k] < level:
            lo, hi = sorted((prev, w[k]))
            x = brentq(lambda x: f(x) - level, lo, hi, xtol=1e-14 * hi, rtol=4 * EPS)
            if data_only:  # the spline against linear interpolation between the two samples bracketing it
                j = min(max(int(np.searchsorted(w, x)), 1), w.size - 1)
                xl = np.interp(level, *(([a[j - 1], a[j]], [w[j - 1], w[j]]) if a[j] > a[j - 1]
                                        else ([a[j], a[j - 1]], [w[j], w[j - 1]])))
                return x, abs(x - xl)
            return x, 1e-14 * hi + 4 * EPS * abs(x)
        nxt = k + step
        if 0 <= nxt < w.size and a[nxt] > a[k] and a[k] >= level:
            return None  # a minimum above the half-power level: overlapping modes
        prev, k = w[k], nxt
    return None


# ---------------------------------------------------------------- logarithmic decrement
@dataclass(frozen=True, eq=False)
class LogDecrement:
    """Damping from the decay of successive maxima of a free-vibration signal.

    ``delta``: logarithmic decrement ln(x_k / x_{k+1}); ``zeta`` = δ / √(4π² + δ²); ``omega_d`` = 2π / T_d
    (rad/s) from the spacing of the maxima; ``omega_n`` = ω_d / √(1 − ζ²). ``error``: estimated absolute
    error of ζ (regression standard error plus peak-refinement error). ``peak_times`` (s) and
    ``peak_values``: the refined maxima used.
    """

    zeta: float
    delta: float
    omega_d: float
    omega_n: float
    peak_times: np.ndarray
    peak_values: np.ndarray
    error: float
    elapsed: float

    def __repr__(self):
        from .._format import number, summary

        return summary("LogDecrement", f"ζ = {number(self.zeta)} ± {number(self.error, digits=2)}",
                       f"δ = {number(self.delta)}", f"ω_d = {number(self.omega_d)} rad/s",
                       f"{self.peak_times.size} peaks")

    @property
    def frequency_hz(self):
        return self.omega_n / (2 * np.pi)


def log_decrement(t: ArrayLike, x: ArrayLike, offset: float = 0.0) -> LogDecrement:
    """Modal damping from a free decay x(t) (one dominant mode) about ``offset`` (:class:`LogDecrement`).

    The positive maxima are refined on a cubic spline of the samples; ln x_k is fitted by least squares
    against their times (scipy.stats.linregress): slope −ζω_n; the period T_d comes from a fit of the
    times against the index. The error adds the fits' standard errors to the change of ζ when the maxima
    are refined by three-point parabolas instead of the spline, and to its difference from the ζ of the minima
    (an ``offset`` off the rest value moves the two apart)."""
    start = time.perf_counter()
    t, x = _curve(t, x, "log decrement")
    y = x - scalar(offset, "log decrement: offset")
    tk, yk, _ = extrema(t, y, None, "max")
    keep = yk > 0
    tk, yk = tk[keep], yk[keep]
    if tk.size < 2:
        raise ModelError(f"log decrement: need at least two positive maxima of the signal, found {tk.size}")
    _one_mode(t, y, tk, float(offset))
    zeta, delta, Td, dzeta = _decay(tk, yk)
    idx = np.clip(np.searchsorted(t, tk), 1, t.size - 2)
    idx = np.where(np.abs(t[idx - 1] - tk) < np.abs(t[idx] - tk), idx - 1, idx)
    idx = np.clip(idx, 1, t.size - 2)
    alt = np.array([_parabola(t[i - 1:i + 2], y[i - 1:i + 2]) for i in idx]).reshape(-1, 2)
    dzeta += abs(_decay(alt[:, 0], alt[:, 1])[0] - zeta) if np.all(alt[:, 1] > 0) else 0.0
    tm, ym, _ = extrema(t, y, None, "min")
    tm, ym = tm[ym < 0], -ym[ym < 0]
    if tm.size >= 2:
        dzeta += abs(_decay(tm, ym)[0] - zeta)
    wd = 2 * math.pi / Td
    return LogDecrement(float(zeta), float(delta), float(wd), float(wd / math.sqrt(1 - zeta ** 2)), tk, yk,
                        float(dzeta + 16 * EPS), time.perf_counter() - start)


def _one_mode(t, y, tk, offset):
    """Refuse maxima that are no free decay of one mode about ``offset``: the signal must fall below the offset
    between each two (else the rest value is wrong, and ln of the peaks is not linear in t), and the maxima come
    one per period (equal spacing; noise or a second mode adds maxima between)."""
    if not np.min(y[(t > tk[0]) & (t < tk[-1])], initial=0.0) < 0:
        raise ModelError(f"log decrement: the signal does not fall below offset = {offset:g} between its maxima: a "
                         "free decay oscillates about its rest value; give offset= (the value it settles to)")
    crossed = [np.min(y[(t > a) & (t < b)], initial=0.0) < 0 for a, b in zip(tk[:-1], tk[1:])]
    gaps = np.diff(tk)
    if not all(crossed) or np.max(np.abs(gaps - np.median(gaps))) > 0.25 * np.median(gaps):
        raise ModelError(f"log decrement: the maxima are not one per period (their spacing ranges from "
                         f"{gaps.min():.4g} to {gaps.max():.4g} s): noise or a second mode adds maxima; filter the "
                         "signal to its one mode first")


def _decay(tk, yk):
    """(ζ, δ, T_d, standard error of ζ) from the times and values of successive maxima."""
    if tk.size == 2:
        Td, sigma = tk[1] - tk[0], math.log(yk[0] / yk[1]) / (tk[1] - tk[0])
        dTd = dsig = 0.0
    else:
        from scipy.stats import linregress

        k = np.arange(tk.size)
        fit_t, fit_y = linregress(k, tk), linregress(tk, np.log(yk))
        Td, sigma, dTd, dsig = fit_t.slope, -fit_y.slope, fit_t.stderr, fit_y.stderr
    if not Td > 0 or not np.isfinite(sigma):
        raise ModelError("log decrement: the maxima do not form a decaying oscillation")
    z = lambda d: d / math.hypot(2 * math.pi, d)  # noqa: E731
    delta = sigma * Td
    return z(delta), delta, Td, abs(z(delta + dsig * Td + abs(sigma) * dTd) - z(delta))


# ---------------------------------------------------------------- Rayleigh fit
@dataclass(frozen=True, eq=False)
class RayleighFit:
    """Rayleigh damping C = αM + βK fitted to modal damping ratios: ζ(ω) = α/(2ω) + βω/2.

    ``residual``: rms of ζ_fit − ζ; ``error``: standard errors of (α, β) (zero for two points, an exact
    fit). ``damping(lin)`` returns the linear model with this damping.
    """

    alpha: float  # 1/s
    beta: float  # s
    omega: np.ndarray
    zeta: np.ndarray
    zeta_fit: np.ndarray
    residual: float
    error: tuple
    elapsed: float

    def __repr__(self):
        from .._format import number, summary

        return summary("RayleighFit", f"α = {number(self.alpha)} 1/s", f"β = {number(self.beta)} s",
                       f"{self.omega.size} points", f"rms residual {number(self.residual, digits=2)}")

    def ratio(self, omega):
        """ζ of this damping at ω (rad/s)."""
        w = np.asarray(omega, dtype=float)
        return self.alpha / (2 * w) + self.beta * w / 2

    def damping(self, lin):
        """``lin`` with C = αM + βK_s."""
        return lin.with_damping(self.alpha * lin.M + self.beta * lin.K_s)


def fit_rayleigh(omega: ArrayLike, zeta: ArrayLike, weights: ArrayLike | None = None) -> RayleighFit:
    """Least-squares Rayleigh damping (α, β) through identified ratios ``zeta`` at ``omega`` (rad/s), two or
    more modes (:class:`RayleighFit`); with two it equals :func:`vibdyn.rayleigh`."""
    start = time.perf_counter()
    w = finite_array(omega, (None,), "fit_rayleigh omega")
    z = finite_array(zeta, (None,), "fit_rayleigh zeta")
    if w.size != z.size or w.size < 2:
        raise ModelError(f"fit_rayleigh: need as many ratios as frequencies, at least two ({w.size}, {z.size})")
    if np.any(w <= 0) or np.unique(w).size < 2:
        raise ModelError("fit_rayleigh: frequencies must be positive with at least two distinct")
    W = np.ones_like(w) if weights is None else finite_array(weights, (w.size,), "fit_rayleigh weights")
    if np.any(W <= 0):
        raise ModelError("fit_rayleigh: weights must be positive")
    A = np.column_stack([1 / (2 * w), w / 2])
    sq = np.sqrt(W)
    coef, *_ = np.linalg.lstsq(A * sq[:, None], z * sq, rcond=None)
    fit = A @ coef
    r = fit - z
    dof = w.size - 2
    if dof > 0:
        s2 = float(np.sum(W * r ** 2) / dof)
        cov = s2 * np.linalg.inv((A * W[:, None]).T @ A)
        err = (float(math.sqrt(cov[0, 0])), float(math.sqrt(cov[1, 1])))
    else:
        err = (0.0, 0.0)
    return RayleighFit(float(coef[0]), float(coef[1]), w, z, fit, float(np.sqrt(np.mean(r ** 2))), err,
                       time.perf_counter() - start)


# ---------------------------------------------------------------- helpers
def _curve(x, y, what):
    x = finite_array(x, (None,), f"{what}: abscissae")
    y = finite_array(y, (x.size,), f"{what}: values")
    if x.size < 3:
        raise ModelError(f"{what}: need at least three samples, got {x.size}")
    if np.any(np.diff(x) <= 0):
        raise ModelError(f"{what}: abscissae must be strictly increasing")
    return x, y


def _function(w, a, function):
    if function is not None:
        return lambda x: float(function(x))
    from scipy.interpolate import CubicSpline

    spline = CubicSpline(w, a)
    return lambda x: float(spline(x))


def _parabola(x, y):
    """(abscissa, value) of the vertex of the parabola through three points."""
    c = np.polyfit(np.asarray(x) - x[1], y, 2)
    if c[0] == 0:
        return float(x[1]), float(y[1])
    dx = -c[1] / (2 * c[0])
    return float(x[1] + dx), float(np.polyval(c, dx))
