"""Frequency responses: receptance / mobility / accelerance by direct solve or modal sum, peaks,
anti-resonances, half-power bandwidths, harmonic steady states."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.linalg as sla

from ..._check import count, finite_array, unknown_name
from ..._deprecation import Renamed
from ...defaults import EPS
from ...errors import ModelError
from .channels import channels, vector_label
from .damping import damped_model

QUANTITY_FACTOR = {"receptance": lambda w: np.ones_like(w, dtype=complex), "mobility": lambda w: 1j * w,
                   "accelerance": lambda w: -(w ** 2) + 0j}
QUANTITY_UNIT = {"receptance": "", "mobility": "/s", "accelerance": "/s²"}


# ====================================================================== frequency responses
@dataclass(frozen=True, eq=False)
class FRF:
    """A frequency response H(ω) (n_ω × n_out × n_in, complex).

    ``frf_type`` "receptance": displacement per force (m/N, rad/(N·m), ...); "transmissibility": displacement
    per support displacement (m/m). ``mobility`` = iωH and ``accelerance`` = −ω²H. ``residual``: largest
    normwise backward residual of (K − ω²M + iωC + iD) X = B over ω (modal sums included: it measures
    truncation and neglected coupling); ``relative_error``: estimated relative error, condition number ×
    (residual + the linear model's relative error).
    ``elapsed`` (s). ``peaks()``, ``half_power()`` refine on the model, not on the grid.
    """

    omega: np.ndarray  # rad/s
    alpha: np.ndarray
    outputs: tuple
    inputs: tuple
    output_units: tuple
    input_units: tuple
    frf_type: str
    method: str
    damping: str
    residual: float
    condition: float
    relative_error: float
    elapsed: float
    natural: np.ndarray = field(repr=False)  # natural frequencies of the model (rad/s): seeds for peaks
    evaluate: object = field(repr=False)  # ω array ↦ H (n_ω × n_out × n_in) with the same settings
    error = Renamed("relative_error")

    def __repr__(self):
        from ..._format import duration, number, summary

        return summary("FRF", f"{self.frf_type} {'/'.join(self.outputs[:2])}{'…' if len(self.outputs) > 2 else ''} per "
                       f"{'/'.join(self.inputs[:2])}{'…' if len(self.inputs) > 2 else ''}",
                       f"{self.omega.size} frequencies {number(self.omega[0])}…{number(self.omega[-1])} rad/s",
                       self.method, self.damping, f"relative error {number(self.relative_error, digits=2)}",
                       duration(self.elapsed))

    def _repr_html_(self):
        from ..._format import html_table, number

        rows = []
        for j, o in enumerate(self.outputs):
            for k, i in enumerate(self.inputs):
                p = self.peaks(j, k)
                rows.append([f"{o} / {i}", self.units(j, k),
                             ", ".join("∞ at " + number(w) if not np.isfinite(a) else f"{number(a)} at {number(w)}"
                                       for w, a in zip(p.resonances, p.amplitudes)) or "-",
                             ", ".join(number(w) for w in p.antiresonances) or "-"])
        return html_table(f"{self.frf_type}: {self.omega.size} frequencies {number(self.omega[0])} … "
                          f"{number(self.omega[-1])} rad/s, relative error {number(self.relative_error, digits=2)}",
                          ["output / input", "unit", "resonances |H| at ω (rad/s)", "anti-resonances (rad/s)"], rows)

    @property
    def frequency_hz(self):
        return self.omega / (2 * np.pi)

    @property
    def receptance(self):
        return self.alpha

    @property
    def mobility(self):
        """iωH (m/s per N for a receptance)."""
        return 1j * self.omega[:, None, None] * self.alpha

    @property
    def accelerance(self):
        """−ω²H (m/s² per N for a receptance)."""
        return -(self.omega ** 2)[:, None, None] * self.alpha

    @property
    def amplitude(self):
        return np.abs(self.alpha)

    @property
    def phase(self):
        """Phase of H (rad): the response lags the input by −phase."""
        return np.angle(self.alpha)

    def units(self, output: int | str = 0, input: int | str = 0, quantity: str = "receptance") -> str:
        """Unit of H_jk, e.g. "m/N" (receptance), "m/N/s" (mobility)."""
        j, k = self.index(output, input)
        return f"{self.output_units[j]}{QUANTITY_UNIT[_quantity(quantity)]}/{self.input_units[k]}"

    def index(self, output: int | str = 0, input: int | str = 0) -> tuple[int, int]:
        """(j, k) indices of an output and an input given by label or position."""
        return _pick(output, self.outputs, "output"), _pick(input, self.inputs, "input")

    def get(self, output: int | str = 0, input: int | str = 0, quantity: str = "receptance") -> np.ndarray:
        """H_jk(ω) (n_ω complex) of one output and input (labels or indices): receptance, mobility or
        accelerance."""
        j, k = self.index(output, input)
        return QUANTITY_FACTOR[_quantity(quantity)](self.omega) * self.alpha[:, j, k]

    def peaks(self, output: int | str = 0, input: int | str = 0, quantity: str = "receptance") -> Peaks:
        """Resonances (maxima) and anti-resonances (minima) of |H_jk| inside the frequency range, refined by
        bounded Brent search (scipy.optimize.minimize_scalar) on the model between grid neighbours; the
        model's natural frequencies are added to the grid so that sharp resonances are not missed.

        An undamped resonance (the dynamic stiffness singular at a natural frequency that H_jk sees) is a
        resonance at exactly that natural frequency with unbounded amplitude (``inf``, ``unbounded`` True).
        On such an undamped channel an anti-resonance is a zero of H_jk (a sign change); minima of |H_jk|
        where H_jk keeps its sign are not listed. On a damped one a minimum is an anti-resonance only when it
        is at least :data:`ANTIRESONANCE_DEPTH` (3 dB) below the curve on both sides of it (the highest |H|
        between it and the neighbouring minima or the range's ends) and the phase of H_jk rises there (on the
        frequency axis each stable pole turns the phase down and each zero near it up: a rising phase at a
        minimum is a zero's): a shallow dip, or the valley between two modes of a transfer without zeros,
        is not one."""
        from ..identify import extrema

        start = time.perf_counter()
        w, a, f, poles = self._curve(output, input, quantity)
        wr, ar, er = extrema(w, a, f, "max", self.condition * EPS)
        wa, aa, ea = extrema(w, a, f, "min", self.condition * EPS)
        if poles.size:  # Brent closes in on a pole: that maximum is the pole itself, exactly
            near = np.array([np.any(np.abs(x - poles) <= 1e-6 * x) for x in wr], dtype=bool)
            wr, ar, er = (np.concatenate([wr[~near], poles]), np.concatenate([ar[~near], np.full(poles.size, np.inf)]),
                          np.concatenate([er[~near], np.zeros(poles.size)]))
            order = np.argsort(wr)
            wr, ar, er = wr[order], ar[order], er[order]
            zero = np.array([self._crosses_zero(x, output, input) for x in wa], dtype=bool)
            wa, aa, ea = wa[zero], aa[zero], ea[zero]
        elif wa.size:
            deep = _prominent(w, a, wa, aa) & np.array([self._leads(x, output, input) for x in wa], dtype=bool)
            wa, aa, ea = wa[deep], aa[deep], ea[deep]
        j, k = self.index(output, input)
        return Peaks(self.outputs[j], self.inputs[k], _quantity(quantity), wr, ar, wa, aa,
                     float(max(er.max(initial=0.0), ea.max(initial=0.0))), time.perf_counter() - start,
                     ~np.isfinite(ar))

    def _crosses_zero(self, w, output, input, step=1e-4):
        """Whether the (real) undamped H_jk changes sign across ``w`` (rad/s): a true anti-resonance, a zero
        of H_jk. A minimum of |H_jk| between two poles without a sign change (an end-to-end transfer of a
        chain has no zeros at all) is no anti-resonance."""
        j, k = self.index(output, input)
        try:
            h = self.evaluate(np.array([w * (1 - step), w * (1 + step)]))[:, j, k].real
        except SingularResponse:
            return True  # a pole within the step: keep the minimum rather than guess
        return bool(h[0] * h[1] <= 0)

    def _leads(self, w, output, input, step=1e-4):
        """Whether the phase of H_jk rises across ``w`` (rad/s): a zero of H_jk near the frequency axis (an
        anti-resonance) turns it up; the poles alone turn it down."""
        j, k = self.index(output, input)
        try:
            h = self.evaluate(np.array([w * (1 - step), w * (1 + step)]))[:, j, k]
        except SingularResponse:
            return False
        return bool(np.angle(h[1] / h[0]) > 0)

    def half_power(self, output: int | str = 0, input: int | str = 0, quantity: str = "receptance") -> Any:
        """Half-power bandwidth and damping ratio of each resonance of |H_jk|
        (:class:`vibdyn.analysis.identify.HalfPower`), refined on the model. Undamped resonances have no band: they
        are listed in ``undamped`` (rad/s; ζ = 0 there), the damped ones between them keep their bands."""
        from ..identify import half_power

        start = time.perf_counter()
        w, a, f, poles = self._curve(output, input, quantity)
        q = _quantity(quantity)
        if not poles.size:
            return half_power(w, a, q, function=f)
        edges = np.concatenate([[-np.inf], poles, [np.inf]])
        parts = []
        for lo, hi in zip(edges[:-1], edges[1:]):
            inside = (w > lo) & (w < hi)
            if inside.sum() >= 3:
                parts.append(half_power(w[inside], a[inside], q, function=f))
        cat = lambda name: np.concatenate([getattr(p, name) for p in parts] or [np.zeros(0)])  # noqa: E731
        return replace(parts[0] if parts else half_power(w[:0], a[:0], q), omega_peak=cat("omega_peak"),
                       amplitude=cat("amplitude"), lower=cat("lower"), upper=cat("upper"),
                       bandwidth=cat("bandwidth"), zeta=cat("zeta"), zeta_approx=cat("zeta_approx"),
                       error=cat("error"), unresolved=cat("unresolved"), undamped=poles,
                       elapsed=time.perf_counter() - start)

    def _curve(self, output, input, quantity):
        """|H_jk| on the grid plus the natural frequencies in range, the function ω ↦ |H_jk(ω)| (inf where the
        dynamic stiffness is singular), and the undamped resonances of H_jk in the range (rad/s)."""
        j, k = self.index(output, input)
        factor = QUANTITY_FACTOR[_quantity(quantity)]

        def f(x):
            x = np.array([x])
            try:
                return float(np.abs(factor(x)[0] * self.evaluate(x)[0, j, k]))
            except SingularResponse:
                return np.inf

        extra = self.natural[(self.natural > self.omega[0]) & (self.natural < self.omega[-1])]
        extra = extra[~np.isin(extra, self.omega)]
        h_extra = np.array([f(x) for x in extra])
        # a singular Z is a pole of H_jk only if H_jk grows as 1/|ω − ω_r| towards it (not a cancelled mode)
        poles = np.array([x for x in extra[~np.isfinite(h_extra)] if f(x * (1 - 1e-7)) > 3 * f(x * (1 - 1e-6))])
        keep = np.isfinite(h_extra)
        w = np.concatenate([self.omega, extra[keep]])
        h = np.concatenate([np.abs(factor(self.omega) * self.alpha[:, j, k]), h_extra[keep]])
        order = np.argsort(w)
        return w[order], h[order], f, poles

    def to_dict(self) -> dict:
        """Plain data (JSON-ready): complex numbers as [re, im], SI units."""
        return {"frf_type": self.frf_type, "omega_rad_s": self.omega.tolist(),
                "frequency_hz": self.frequency_hz.tolist(),
                "outputs": list(self.outputs), "inputs": list(self.inputs),
                "output_units": list(self.output_units), "input_units": list(self.input_units),
                "alpha": [[[[z.real, z.imag] for z in row] for row in m] for m in self.alpha],
                "method": self.method, "damping": self.damping, "residual": self.residual,
                "condition": self.condition, "relative_error": self.relative_error, "elapsed_s": self.elapsed}


Receptance = FRF


@dataclass(frozen=True, eq=False)
class Peaks:
    """Resonances and anti-resonances of one |H_jk| (rad/s; ``*_hz`` alongside), with |H| there.
    ``omega_error``: estimated absolute error of the frequencies (rad/s)."""

    output: str
    input: str
    quantity: str
    resonances: np.ndarray
    amplitudes: np.ndarray
    antiresonances: np.ndarray
    antiresonance_amplitudes: np.ndarray
    omega_error: float
    elapsed: float
    unbounded: np.ndarray | None = None  # per resonance: an undamped resonance (amplitude inf)
    tolerance = Renamed("omega_error")

    def __repr__(self):
        from ..._format import summary, values

        res = ", ".join(f"{w:.6g}" + (" (unbounded)" if not np.isfinite(a) else "")
                        for w, a in zip(self.resonances, self.amplitudes)) or "none"
        return summary("Peaks", f"{self.output} / {self.input}", f"resonances {res} rad/s",
                       f"anti-resonances {values(self.antiresonances, 'rad/s', digits=6)}")

    @property
    def resonances_hz(self):
        return self.resonances / (2 * np.pi)

    @property
    def antiresonances_hz(self):
        return self.antiresonances / (2 * np.pi)

    def to_dict(self):
        return {"output": self.output, "input": self.input, "quantity": self.quantity,
                "resonances_rad_s": self.resonances.tolist(), "resonances_hz": self.resonances_hz.tolist(),
                "amplitudes": [float(a) if np.isfinite(a) else None for a in self.amplitudes],
                "unbounded": [bool(u) for u in (self.unbounded if self.unbounded is not None
                                                else np.zeros(self.resonances.size, bool))],
                "antiresonances_rad_s": self.antiresonances.tolist(),
                "antiresonances_hz": self.antiresonances_hz.tolist(),
                "antiresonance_amplitudes": self.antiresonance_amplitudes.tolist(),
                "omega_error_rad_s": self.omega_error, "elapsed_s": self.elapsed}


ANTIRESONANCE_DEPTH = math.sqrt(2.0)  # (3 dB) how far a damped minimum must fall below both its sides


def _prominent(w, a, wa, aa):
    """Which minima (wa, aa) of the sampled curve (w, a) fall ANTIRESONANCE_DEPTH below the highest value on
    each side of them, up to the neighbouring minima or the ends."""
    edges = np.concatenate([[-np.inf], wa, [np.inf]])
    keep = []
    for i, (x, y) in enumerate(zip(wa, aa)):
        left = a[(w > edges[i]) & (w < x)]
        right = a[(w > x) & (w < edges[i + 2])]
        keep.append(left.size > 0 and right.size > 0 and min(left.max(), right.max()) >= ANTIRESONANCE_DEPTH * y)
    return np.array(keep, dtype=bool)


def _quantity(q):
    if q not in QUANTITY_FACTOR:
        raise ModelError(f"unknown quantity {q!r} (one of {', '.join(QUANTITY_FACTOR)})")
    return q


def _pick(x, labels, what):
    """A channel by position, by label, by the plain name before a label's "·" (a support "road", a body
    point "mass(0,0,0)") when only one channel has it, or by (name, direction) — (body, point, direction) for
    a body point — in place of the label "name·(dx,dy,dz)"."""
    if isinstance(x, (int, np.integer)) and not isinstance(x, bool):
        if not -len(labels) <= x < len(labels):
            raise ModelError(f"{what} index {x} out of range ({len(labels)} {what}s)")
        return int(x) % len(labels)
    if isinstance(x, (tuple, list)) and len(x) in (2, 3) and isinstance(x[0], str):
        try:
            name = x[0] + (vector_label(x[1]) if len(x) == 3 else "")
            d = np.asarray(x[-1], dtype=float)
            x = f"{name}·{vector_label(d / np.linalg.norm(d))}"
        except (TypeError, ValueError):
            raise ModelError(f"{what}: expected a label, an index, or (name, direction), got {x!r}") from None
    if x in labels:
        return labels.index(x)
    if isinstance(x, str):
        named = [i for i, label in enumerate(labels) if label.split("·")[0] == x]
        if len(named) == 1:
            return named[0]
        if named:
            raise ModelError(f"{what} '{x}' is ambiguous: {', '.join(labels[i] for i in named)} (give (name, "
                             "direction))")
    raise unknown_name(x, labels, what)


def _omegas(omega):
    w = np.atleast_1d(finite_array(omega, None, "omega (rad/s)")).astype(float)
    if w.ndim != 1 or w.size == 0:
        raise ModelError(f"omega: expected a frequency or a 1-D array of frequencies (rad/s), got shape {w.shape}")
    if np.any(w < 0):
        raise ModelError("omega: frequencies must be ≥ 0 rad/s")
    return w


def _transfer(model, omega, Bfun, out, method, n_modes=None, offset=None):
    """H(ω) = out · X(ω) (+ offset), X solving Z(ω) X = B(ω); with its backward residual, condition and the
    amplification of the linear model's own error, max over ω of ‖δZ‖/σ_min(Z) (the relative error of X
    that K's and C's errors cause: near a resonance σ_min → 0). A Z singular within that error (σ_min ≤
    ‖δZ‖) is an undamped resonance within the error: SingularResponse."""
    if method not in ("direct", "modal"):
        raise ModelError(f"frequency response: unknown method {method!r} (use 'direct' or 'modal')")
    nv = model.M.shape[0]
    if method == "modal":
        Phi, w2, c, d, _ = model.modal
        keep = slice(None) if n_modes is None else slice(0, _n_modes(n_modes, w2.size))
        Phi, w2, c, d = Phi[:, keep], w2[keep], c[keep], d[keep]
        # each ω²'s uncertainty (residual: relative, of ω)
        dw2 = 2 * np.abs(w2) * model.modes.omega_relative_error[keep]
    H = None
    residual = condition = amplification = 0.0
    for i, w in enumerate(omega):
        B = np.asarray(Bfun(w), dtype=complex).reshape(nv, -1)
        Z = model.z(w)
        s = sla.svdvals(Z) if nv else np.ones(1)
        cond = s[0] / s[-1] if s[-1] > 0 else np.inf
        dz = model.z_error(w) if nv else 0.0
        if method == "direct":
            if not cond < 1e14 or s[-1] <= dz:
                _singular(w, model, s[-1], dz)
            X = sla.solve(Z, B, check_finite=False)
        else:
            den = w2 - w * w + 1j * (w * c + d)
            small = 64 * EPS * (np.abs(w2) + w * w + w * np.abs(c) + np.abs(d)) + 1e-300
            if np.any(np.abs(den) <= np.maximum(small, dw2)):
                k = int(np.argmin(np.abs(den) - np.maximum(small, dw2)))
                _singular(w, model, abs(den[k]), max(small[k], dw2[k]))
            X = Phi @ ((Phi.T @ B) / den[:, None])
        amplification = max(amplification, dz / s[-1] if s[-1] > 0 else np.inf)
        r = np.linalg.norm(Z @ X - B) / (np.linalg.norm(Z) * np.linalg.norm(X) + np.linalg.norm(B) + 1e-300)
        residual, condition = max(residual, float(r)), max(condition, float(min(cond, 1 / EPS)))
        h = out @ X
        if offset is not None:
            h = h + offset
        if H is None:
            H = np.empty((omega.size,) + h.shape, dtype=complex)
        H[i] = h
    if H is None:
        H = np.zeros((0, out.shape[0], 0), dtype=complex)
    return H, residual, condition, amplification


class SingularResponse(ModelError):
    """The dynamic stiffness is singular at the requested frequency: an undamped resonance, or ω = 0 with a
    rigid-body mode (the steady response is unbounded)."""


def _singular(w, model, smallest=0.0, error=0.0):
    why = "a rigid-body mode (K is singular)" if w == 0 else "an undamped resonance"
    within = ""
    if smallest > 0:  # not singular to the arithmetic, but within the linear model's own error
        within = (f" within its own error (smallest singular value {smallest:.3g} ≤ its error {error:.3g}: at a "
                  "resonance, within the error)")
    raise SingularResponse(f"the dynamic stiffness K − ω²M + i(ωC + D) is singular{within} at ω = {w:g} rad/s "
                           f"({w / (2 * np.pi):g} Hz): {why}; the steady response is unbounded there")


def _n_modes(n, total):
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= total:
        raise ModelError(f"n_modes: expected an integer from 1 to {total}, got {n!r}")
    return int(n)


def _natural(model):
    m = model.modes
    w = [m.omega[~m.rigid]]
    if m.omega_n.size:
        w += [m.omega_n[m.omega_n > 0], m.omega_d[m.omega_d > 0]]
    w = np.unique(np.concatenate(w))
    return w[np.concatenate([[True], np.diff(w) > 1e-9 * w[1:]])] if w.size else w  # round-off twins


def frf_of(model, omega, Bfun, cout, labels_in, units_in, frf_type, method, n_modes, start, offset=None):
    w = _omegas(omega)
    H, res, cond, amp = _transfer(model, w, Bfun, cout.matrix, method, n_modes, offset)
    evaluate = lambda ww: _transfer(model, _omegas(ww), Bfun, cout.matrix, method, n_modes, offset)[0]  # noqa: E731
    # the solve's error, and the linear model's own error amplified by 1/σ_min(Z) (large near a resonance)
    err = min(1.0, cond * max(res, EPS) + amp)
    return FRF(w, H, cout.labels, tuple(labels_in), cout.units, tuple(units_in), frf_type, method, model.damping,
               res, cond, err, time.perf_counter() - start, _natural(model), evaluate)


def receptance(lin, omega, inputs=None, outputs=None, *, direction=None, method="direct", damping=None,
               n_modes=None):
    """Receptance α(ω) = outputs · (K − ω²M + iωC + iD)⁻¹ · inputs (:class:`FRF`, n_ω × n_out × n_in).

    ``omega``: a frequency or an array (rad/s, ≥ 0). ``inputs``/``outputs``: coordinate names, body points
    ``(body, (x, y, z), (dx, dy, dz))`` (``direction`` for points given without one), or None (all
    coordinates). ``method``: "direct" (a linear solve per ω) or "modal" (sum over the undamped modes,
    rigid modes included; ``n_modes`` truncates): equal for classical damping. ``damping``: None/"viscous"
    (the model's C), "none", or :class:`Hysteretic`.
    """
    start = time.perf_counter()
    model = damped_model(lin, damping)
    cin = channels(lin, inputs, direction, "inputs")
    cout = channels(lin, outputs, direction, "outputs")
    B = cin.matrix.T
    return frf_of(model, omega, lambda w: B, cout, cin.labels, cin.force_units, "receptance", method, n_modes, start)


@dataclass(frozen=True, eq=False)
class HarmonicResponse:
    """Steady state under harmonic forces Re(F e^{iωt}): complex amplitudes X (n_ω × n_out), so that the
    outputs move as Re(X e^{iωt}); ``amplitude`` |X| (m or rad), ``phase`` arg X (rad; −phase is the lag)."""

    omega: np.ndarray
    x: np.ndarray
    outputs: tuple
    units: tuple
    force: np.ndarray
    frf: FRF = field(repr=False)
    elapsed: float = 0.0

    def __repr__(self):
        from ..._format import summary, values

        return summary("HarmonicResponse", f"{np.size(self.omega)} frequencies", f"outputs {', '.join(self.outputs)}",
                       f"|x| = {values(np.abs(self.x))}")

    @property
    def amplitude(self):
        return np.abs(self.x)

    @property
    def phase(self):
        return np.angle(self.x)

    @property
    def frequency_hz(self):
        return self.omega / (2 * np.pi)

    error = Renamed("relative_error")

    @property
    def relative_error(self):
        """The FRF's estimated relative error."""
        return self.frf.relative_error

    def at(self, t):
        """Output time histories Re(X e^{iωt}) (n_t × n_out) for a single frequency."""
        if self.omega.size != 1:
            raise ModelError("harmonic response: at(t) needs a single frequency")
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.real(np.exp(1j * self.omega[0] * t)[:, None] * self.x[0][None, :])


def harmonic_response(lin, omega, force, inputs=None, outputs=None, *, phase=0.0, direction=None,
                      method="direct", damping=None, n_modes=None):
    """Steady response to harmonic forces of amplitudes ``force`` (one per input: N, N·m, or complex) and
    phases ``phase`` (rad): f(t) = Re(force e^{i(ωt + phase)}) (:class:`HarmonicResponse`); ``force`` may be a dict
    {input: amplitude} instead of ``inputs`` and its amplitudes."""
    start = time.perf_counter()
    if isinstance(force, dict):
        if inputs is not None:
            raise ModelError("harmonic force: give the inputs as the keys of force={input: amplitude} or as inputs=, "
                             "not both")
        inputs, force = list(force), list(force.values())
    frf = receptance(lin, omega, inputs, outputs, direction=direction, method=method, damping=damping,
                     n_modes=n_modes)
    n_in = len(frf.inputs)
    try:
        F = np.asarray(force, dtype=complex).ravel()
    except (TypeError, ValueError):
        F = np.full(0, np.nan)  # (not numbers: refused below, naming them)
    if F.size == 1:
        F = np.full(n_in, F[0])
    if F.size != n_in or not np.all(np.isfinite(F)):
        raise ModelError(f"harmonic force: expected {count(n_in, 'finite amplitude')} (one per input), got {force!r}")
    ph = np.broadcast_to(finite_array(phase, None, "harmonic force phase"), (n_in,))
    F = F * np.exp(1j * ph)
    return HarmonicResponse(frf.omega, frf.alpha @ F, frf.outputs, frf.output_units, F, frf,
                            time.perf_counter() - start)


