"""Stationary random response of a linear model to inputs given by one-sided PSDs (in Hz).

Inputs: forces at coordinates or body points (N²/Hz, (N·m)²/Hz), supports moving along a direction and
prescribed joint coordinates (displacement, velocity or acceleration PSDs), correlated through cross-spectra
(a coefficient, a co-spectrum, or a :class:`vibdyn.Delay`). Outputs: coordinates, body points, relative
motion between two of them; quantities displacement, velocity, acceleration (absolute for a moving support).

White inputs over all frequencies (forces, or support accelerations) are solved exactly by the Lyapunov
equation A P + P Aᵀ + B W Bᵀ = 0 with W = G₀/2 (a one-sided G₀ per Hz is a two-sided G₀/(4π) per rad/s
times 2π); anything else by adaptive Gauss–Kronrod quadrature of diag(H G Hᴴ) split at the breakpoints and at
the damped natural frequencies ± multiples of their half-power widths, with its error estimate.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg as sla

from ..._check import unknown_name
from ...defaults import EPS
from ...description.elements import WORLD
from ...description.psd import ORDER, PSD, Delay
from ...errors import ModelError
from .base import reduced, support_input_of
from .channels import Channels, channels
from .damping import damped_model
from .quadrature import integrate

QUANTITIES = ("displacement", "velocity", "acceleration")
UNIT_SUFFIX = ("", "/s", "/s^2", "/s^3")
SPLIT = (0.0, 1.0)  # a pole's interval edges: f_d ± k × half-power half-width (then adaptive)


# ====================================================================== the result
@dataclass(frozen=True, eq=False)
class RandomResponse:
    """Variances and spectra of the outputs of a linear model under stationary random inputs (SI).

    ``variance[q]`` (q = 0 displacement, 1 velocity, 2 acceleration, 3 its rate) per output (m², rad², per s²
    …; inf where the input makes it unbounded, with the reason in ``unbounded``), ``variance_error[q]`` its
    error estimate (quadrature or Lyapunov residual, plus the transfer's round-off); ``method``: "lyapunov"
    or "quadrature". The linear model's own relative error (``model_error``) is not folded in.
    """

    outputs: tuple
    units: tuple  # displacement unit of each output: "m" or "rad"
    inputs: tuple
    method: str
    damping: str
    variance: np.ndarray = field(repr=False)  # 4 × n_out
    variance_error: np.ndarray = field(repr=False)
    unbounded: tuple = field(repr=False)  # per order: None or the reason
    evaluations: int
    elapsed: float
    model_error: float
    transfer: Any = field(repr=False)  # (f_hz array) ↦ (H: n_f × n_out × n_in, G: n_f × n_in × n_in)
    lyapunov: Any = field(default=None, repr=False)  # {order: output covariance} when solved exactly
    converged: bool = True

    def __repr__(self):
        from ..._format import duration, summary, values

        parts = []
        for q, name in enumerate(QUANTITIES):
            if self.unbounded[q] is None:
                parts.append(f"{name} RMS {values(np.sqrt(self.variance[q]))}")
        return summary("RandomResponse", f"{len(self.outputs)} outputs, {len(self.inputs)} inputs", *parts,
                       self.method, duration(self.elapsed))

    def _order(self, quantity):
        if quantity not in QUANTITIES:
            raise ModelError(f"random response: unknown quantity {quantity!r} (one of {', '.join(QUANTITIES)})")
        q = QUANTITIES.index(quantity)
        if self.unbounded[q] is not None:
            raise ModelError(f"random response: the {quantity} RMS is unbounded: {self.unbounded[q]}")
        return q

    def unit(self, output: int = 0, quantity: str = "displacement") -> str:
        """SI unit of an output's RMS: "m", "m/s", "m/s^2" (or "rad…")."""
        return self.units[output] + UNIT_SUFFIX[QUANTITIES.index(quantity)]

    def rms(self, quantity: str = "displacement") -> np.ndarray:
        """RMS per output (SI: m, m/s, m/s² or rad, rad/s, rad/s²; absolute for a moving support)."""
        return np.sqrt(self.variance[self._order(quantity)])

    def rms_error(self, quantity: str = "displacement") -> np.ndarray:
        """Estimated absolute error of :meth:`rms` per output (same unit)."""
        q = self._order(quantity)
        r = np.sqrt(self.variance[q])
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(r > 0, self.variance_error[q] / (2 * r), np.sqrt(self.variance_error[q]))

    def spectral_moments(self, quantity: str = "displacement") -> tuple:
        """(m0, m2, m4) per output of the quantity's one-sided PSD, m_k = ∫ ω^k G(f) df with ω = 2πf (rad/s):
        its variance, its rate's and its second rate's."""
        q = self._order(quantity)
        out = []
        for k in (q, q + 1, q + 2):
            if k > 3 or self.unbounded[k] is not None:
                raise ModelError(f"random response: spectral moment m{2 * (k - q)} of the {quantity} is unbounded"
                                 + (f": {self.unbounded[k]}" if k <= 3 else " (not computed: the fourth rate)"))
            out.append(self.variance[k])
        return tuple(out)

    def zero_crossing_rate(self, quantity: str = "displacement") -> np.ndarray:
        """Expected rate of up-crossings of zero per output, ν₀ = √(m2/m0)/(2π) (Hz)."""
        q = self._order(quantity)
        if q + 1 > 3 or self.unbounded[q + 1] is not None:
            raise ModelError(f"random response: the {quantity}'s zero up-crossing rate needs its rate's variance, "
                             f"which is unbounded: {self.unbounded[q + 1] if q + 1 <= 3 else 'not computed'}")
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.variance[q] > 0, np.sqrt(self.variance[q + 1] / self.variance[q]), 0.0) / (2 * np.pi)

    def peak_factor(self, duration: float, quantity: str = "displacement") -> np.ndarray:
        """Davenport's expected peak factor over ``duration`` s: √(2 ln ν₀T) + 0.5772/√(2 ln ν₀T) (ν₀T > 1)."""
        nT = self.zero_crossing_rate(quantity) * float(duration)
        if not float(duration) > 0 or np.any(nT <= 1):
            raise ModelError(f"peak factor: needs ν₀·T > 1 (ν₀T = {np.min(nT):.3g} for duration {duration} s): "
                             "a longer duration")
        r = np.sqrt(2 * np.log(nT))
        return r + 0.5772 / r

    def expected_peak(self, duration: float, quantity: str = "displacement") -> np.ndarray:
        """Davenport's expected largest |value| over ``duration`` s per output: peak factor × RMS (SI)."""
        return self.peak_factor(duration, quantity) * self.rms(quantity)

    def psd(self, frequency_hz, quantity: str = "displacement") -> np.ndarray:
        """One-sided response PSD per output at ``frequency_hz`` (n_f × n_out; SI per Hz: m²/Hz, …)."""
        q = QUANTITIES.index(quantity) if quantity in QUANTITIES else self._order(quantity)
        f = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
        if f.ndim != 1 or not np.all(np.isfinite(f)) or np.any(f < 0):
            raise ModelError("random response psd: frequencies must be a 1-D array of finite values ≥ 0 Hz")
        H, G = self.transfer(f)
        return _diagonal(H, G) * ((2 * np.pi * f) ** (2 * q))[:, None]

    def covariance(self, quantity: str = "displacement", rtol: float = 1e-8) -> np.ndarray:
        """Covariance matrix of the outputs (n_out × n_out, SI): from the Lyapunov solution when exact, else
        by quadrature of Re(H G Hᴴ) ω^{2q}."""
        q = self._order(quantity)
        if self.lyapunov is not None and q in self.lyapunov:
            return self.lyapunov[q]
        n = len(self.outputs)

        def g(f):
            H, G = self.transfer(f)
            S = np.einsum("foi,fij,fpj->fop", H, G, H.conj()).real
            return (S * ((2 * np.pi * f) ** (2 * q))[:, None, None]).reshape(f.size, n * n)

        res = integrate(g, self.split_points, self.upper_hz, rtol=rtol, groups=np.zeros(n * n, int))
        return res.value.reshape(n, n)

    def to_dict(self) -> dict:
        """Plain data (JSON-ready), SI; unbounded values as null with the reason."""
        out = {"outputs": list(self.outputs), "units": list(self.units), "inputs": list(self.inputs),
               "method": self.method, "damping": self.damping, "evaluations": self.evaluations,
               "elapsed_s": self.elapsed, "model_relative_error": self.model_error, "converged": self.converged,
               "convention": "one-sided PSD in Hz; RMS absolute for a moving support"}
        for q, name in enumerate(QUANTITIES):
            if self.unbounded[q] is None:
                out[f"{name}_rms"] = self.rms(name).tolist()
                out[f"{name}_rms_error"] = self.rms_error(name).tolist()
                out[f"{name}_rms_unit"] = [self.unit(j, name) for j in range(len(self.outputs))]
            else:
                out[f"{name}_rms"] = None
                out[f"{name}_unbounded"] = self.unbounded[q]
        return out

    def plot(self, path=None, quantity: str = "acceleration", **kwargs):
        """Log-log plot of the input and response PSDs (see :func:`vibdyn.faces.random_plots.plot_response`)."""
        from ...faces.random_plots import plot_response

        return plot_response(path, self, quantity, **kwargs)

    # the integration's settings, kept for the covariance and the plots
    split_points: Any = field(default=None, repr=False)  # Hz: where the quadrature starts split
    upper_hz: float = field(default=math.inf, repr=False)  # the inputs' highest frequency (may be inf)
    psds: tuple = field(default=(), repr=False)


# ====================================================================== inputs
@dataclass
class _Input:
    label: str
    psd: PSD
    b: tuple  # (B0, B1, B2): generalized force per unit input as B0 + sB1 + s²B2 (full nv)
    order: int  # s-power dividing the transfer (0 force, 0/1/2 displacement/velocity/acceleration)
    prescribed: int | None = None  # coordinate index if the input is a prescribed joint
    support: str | None = None  # the support's name if the input is a support's motion
    direction: np.ndarray | None = None  # its direction (world axes)


def _inputs(lin, spec, support, direction):
    system = lin.system
    if isinstance(spec, PSD):
        if support is None:
            raise ModelError("random response: a single PSD needs support=NAME (a support or a coordinate); "
                             "for forces give a dict {coordinate or point: PSD}")
        spec = {support: spec}
    elif support is not None:
        raise ModelError("random response: give support=NAME with a single PSD, not with a dict of inputs")
    if not isinstance(spec, dict) or not spec:
        raise ModelError(f"random response: expected a vibdyn.PSD or a dict {{input: PSD}}, got {spec!r}")
    out = []
    nv = lin.nv
    for key, psd in spec.items():
        if not isinstance(psd, PSD):
            raise ModelError(f"random response: input {key!r}: expected a vibdyn.PSD, got {psd!r}")
        q = psd.quantity
        motion = ORDER[q] is not None
        zero = np.zeros(nv)
        if isinstance(key, str) and key in system.support_index:
            if not motion:
                raise ModelError(f"random response: support '{key}' moves: give a displacement, velocity or "
                                 f"acceleration PSD, not {psd.unit}")
            if direction is None:
                raise ModelError(f"random response: support '{key}' needs direction=(x, y, z) (world axes)")
            how = support_input_of(lin, key, direction)
            d = np.asarray(direction, dtype=float)
            out.append(_Input(how[3][0], psd, (how[1][:, 0], how[2][:, 0], zero), ORDER[q], None, key,
                              d / np.linalg.norm(d)))
        elif isinstance(key, str) and key in system.coordinates:
            p = lin.coordinate_index(key)
            unit = lin.units[p]
            if motion:
                if unit != "m":
                    raise ModelError(f"random response: coordinate '{key}' is an angle (rad): a motion PSD in "
                                     f"{psd.unit} does not fit it (prescribed rotations need an angular spectrum)")
                if lin.nv < 2:
                    raise ModelError(f"random response: prescribing '{key}' leaves no free coordinate")
                model = damped_model(lin, None)
                out.append(_Input(key, psd, (-model.K[:, p], -model.C[:, p], -model.M[:, p]), ORDER[q], p))
            else:
                want = "N^2/Hz" if unit == "m" else "(N*m)^2/Hz"
                if psd.unit != want:
                    raise ModelError(f"random response: a force on coordinate '{key}' ({unit}) needs a PSD in "
                                     f"{want}, got {psd.unit}")
                row, _ = lin.coordinate_row(key)
                out.append(_Input(key, psd, (row, zero, zero), 0))
        elif isinstance(key, tuple) and len(key) == 3 and isinstance(key[0], str):
            if psd.unit != "N^2/Hz":
                raise ModelError(f"random response: a force at point {key!r} needs a PSD in N^2/Hz, got {psd.unit}")
            ch = channels(lin, [key], None, "inputs")
            out.append(_Input(ch.labels[0], psd, (ch.matrix[0], zero, zero), 0))
        else:
            raise unknown_name(key, [*(s.name for s in system.supports), *lin.coordinates],
                               "input (support, coordinate or point (body, (x, y, z), (dx, dy, dz)))",
                               "supports and coordinates", "random response")
    if sum(i.prescribed is not None for i in out) > 1:
        raise ModelError("random response: at most one prescribed coordinate per analysis")
    return out


def _cross(inputs, keys, cross):
    """Cross terms: list of (i, j, kind, value)."""
    out = []
    for pair, value in (cross or {}).items():
        if not (isinstance(pair, tuple) and len(pair) == 2):
            raise ModelError(f"random response cross: keys must be pairs (a, b) of inputs, got {pair!r}")
        idx = []
        for k in pair:
            if k not in keys:
                raise ModelError(f"random response cross {pair!r}: {k!r} is not one of the inputs "
                                 f"({', '.join(map(repr, keys))})")
            idx.append(keys.index(k))
        i, j = idx
        if i == j:
            raise ModelError(f"random response cross {pair!r}: an input's own PSD is not a cross-spectrum")
        if isinstance(value, Delay):
            out.append((i, j, "delay", value))
        elif isinstance(value, PSD):
            if not (inputs[i].psd.quantity == inputs[j].psd.quantity == value.quantity):
                raise ModelError(f"random response cross {pair!r}: a co-spectrum in {value.unit} does not fit "
                                 f"inputs in {inputs[i].psd.unit} and {inputs[j].psd.unit} (give a coefficient)")
            out.append((i, j, "psd", value))
        else:
            try:
                rho = float(value)
            except (TypeError, ValueError):
                raise ModelError(f"random response cross {pair!r}: expected a PSD, a coefficient in [-1, 1] or a "
                                 f"vibdyn.Delay, got {value!r}") from None
            if not -1.0 <= rho <= 1.0:
                raise ModelError(f"random response cross {pair!r}: coefficient {rho:g} outside [-1, 1]")
            out.append((i, j, "coefficient", rho))
    return out


def _input_matrix(inputs, cross, f):
    """G(f): n_f × n_in × n_in one-sided (cross-)spectral matrix in SI, G_ij = E[X_i X_j*]."""
    n = len(inputs)
    G = np.zeros((f.size, n, n), dtype=complex)
    for i, inp in enumerate(inputs):
        G[:, i, i] = inp.psd(f)
    for i, j, kind, value in cross:
        root = np.sqrt(G[:, i, i].real * G[:, j, j].real)
        if kind == "coefficient":
            g = value * root
        elif kind == "delay":
            g = value.coherence * root * np.exp(2j * np.pi * f * value.delay)
        else:
            g = value(f).astype(complex)
            over = np.abs(g) > root * (1 + 1e-12) + 1e-300
            if over.any():
                k = int(np.flatnonzero(over)[0])
                raise ModelError(f"random response cross ({inputs[i].label}, {inputs[j].label}): |G_ab| = "
                                 f"{abs(g[k]):.4g} exceeds √(G_aa G_bb) = {root[k]:.4g} at {f[k]:g} Hz (the input "
                                 "matrix must be positive semidefinite)")
        G[:, i, j], G[:, j, i] = g, np.conj(g)
    return G


# ====================================================================== transfer
class _Plant:
    """Z(s)⁻¹ (B0 + sB1 + s²B2) on a batch of s = iω: by the eigen-decomposition of the state matrix (viscous
    damping), or a batched direct solve (hysteretic)."""

    def __init__(self, model, rows, bs):
        self.model, self.rows = model, rows
        n = model.M.shape[0]
        self.hysteretic = bool(np.any(model.D))
        self.bs = [np.column_stack(b) for b in bs]  # 3 × (n × n_in)
        Minv = sla.solve(model.M, np.eye(n), assume_a="pos") if n else np.zeros((0, 0))
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ model.K, -Minv @ model.C]])
        self.A, self.Minv = A, Minv
        self.lam, V = sla.eig(A)
        self.cond = float(np.linalg.cond(V)) if n else 1.0
        if not self.hysteretic and self.cond < 1e8:
            W = sla.inv(V)
            OV = rows @ V[:n]
            # H(s) = Σ_k s^k D(s) C_k with D = diag(1/(s − λ)): C_k (2n × n_in·n_out) folds W·M⁻¹·B_k into the
            # outputs, so that a batch of frequencies costs a GEMM per non-zero B_k
            self.C = [None if not np.any(b) else
                      np.concatenate([(OV * (W[:, n:] @ (Minv @ b[:, j]))[None, :]).T for j in range(b.shape[1])],
                                     axis=1) for b in self.bs]
            self.n_out = rows.shape[0]
            self.direct = False
        else:
            self.direct = True
        # the transfer's relative round-off: the eigenvectors' condition amplifies ε (a direct solve: ε·κ(Z), small
        # next to the quadrature's tolerance away from an undamped pole, which is refused)
        self.relative_error = 8 * EPS * (self.cond if not self.direct else 1.0) * math.sqrt(max(2 * n, 1))

    def poles(self):
        """(f_d Hz, half-power half-width Hz) of each oscillating or real pole."""
        lam = self.lam
        if self.hysteretic:
            _, w2, c, d, _ = self.model.modal
            w = np.sqrt(np.abs(w2))
            with np.errstate(divide="ignore", invalid="ignore"):
                hw = 0.5 * c + np.where(w > 0, 0.5 * d / w, 0.0)
            return w / (2 * np.pi), np.abs(hw) / (2 * np.pi)
        return np.abs(lam.imag) / (2 * np.pi), np.abs(lam.real) / (2 * np.pi)

    def __call__(self, f):
        s = 2j * np.pi * f
        if not self.direct:
            D = 1.0 / (s[:, None] - self.lam[None, :])
            H = np.zeros((f.size, self.bs[0].shape[1] * self.n_out), dtype=complex)
            for k, Ck in enumerate(self.C):
                if Ck is not None:
                    H = H + ((s[:, None] ** k) * D if k else D) @ Ck
            return H.reshape(f.size, -1, self.n_out).transpose(0, 2, 1)
        m = self.model
        out = np.empty((f.size, self.rows.shape[0], self.bs[0].shape[1]), dtype=complex)
        for lo in range(0, f.size, 256):
            ss = s[lo:lo + 256]
            w = ss.imag
            Z = (m.K[None] - (w * w)[:, None, None] * m.M[None] + 1j * (w[:, None, None] * m.C[None] + m.D[None]))
            B = self.bs[0][None] + ss[:, None, None] * self.bs[1][None] + (ss * ss)[:, None, None] * self.bs[2][None]
            out[lo:lo + 256] = self.rows[None] @ np.linalg.solve(Z, B)
        return out


# ====================================================================== the analysis
def random_response(lin, psd, support=None, direction=None, outputs=None, *, cross=None, relative=None,
                    springs=None, damping=None, method="auto", tolerance=1e-8):
    """Stationary response of the linear model to random inputs (:class:`RandomResponse`), one-sided PSDs in Hz.

    ``psd``: a :class:`vibdyn.PSD` with ``support=NAME`` (a support, moving along ``direction`` (world axes),
    or a coordinate, prescribed), or a dict {input: PSD} whose keys are supports (along ``direction``),
    coordinates (a force PSD: a generalized force on it; a motion PSD: the coordinate prescribed) or body
    points ``(body, (x, y, z), (dx, dy, dz))`` (a force along the direction). ``cross``: {(a, b): value}, the
    cross-spectrum of inputs a and b: a coefficient ρ in [-1, 1] (G_ab = ρ√(G_aa G_bb)), a co-spectrum PSD
    (real), or a :class:`vibdyn.Delay` (b is a lagging copy of a). ``outputs``: as :func:`receptance`;
    ``relative``: pairs (a, b) of output specs whose difference a − b is added (a spring's deflection, a
    rattle space); ``springs``: names of point springs whose axial force (N, its change from the operating
    point: k·δL; the "displacement" quantity of such an output is the force) is added. ``damping``:
    None/"viscous", "none" or :class:`vibdyn.Hysteretic`. ``method``: "auto"
    (Lyapunov when every input is white over all frequencies and the case allows it, else quadrature),
    "lyapunov" or "quadrature". ``tolerance``: relative accuracy of the RMS values by quadrature.
    """
    start = time.perf_counter()
    if method not in ("auto", "lyapunov", "quadrature"):
        raise ModelError(f"random response: unknown method {method!r} (use 'auto', 'lyapunov' or 'quadrature')")
    if not (isinstance(tolerance, (int, float)) and 1e-14 <= tolerance <= 0.1):
        raise ModelError(f"random response: tolerance must be a number in [1e-14, 0.1], got {tolerance!r}")
    model = damped_model(lin, damping)
    inputs = _inputs(lin, psd, support, direction)
    keys = list(psd) if isinstance(psd, dict) else [support]
    cr = _cross(inputs, keys, cross)
    out, ends = _outputs(lin, outputs, relative, springs)
    rows = out.matrix
    # feedthrough per unit input: a prescribed coordinate's own motion, a support's motion at a spring's end
    offset = np.zeros((rows.shape[0], len(inputs)))
    for k, inp in enumerate(inputs):
        if inp.prescribed is not None:
            offset[:, k] = rows[:, inp.prescribed]
        elif inp.support is not None:
            for j, end in enumerate(ends):
                offset[j, k] += sum(c @ inp.direction for body, c in end if body == inp.support)
    p = next((i.prescribed for i in inputs if i.prescribed is not None), None)
    if p is not None:
        free = np.array([i for i in range(lin.nv) if i != p])
        model = reduced(model, free)
        rows = rows[:, free]
        bs = [[inp.b[k][free] for inp in inputs] for k in range(3)]
    else:
        bs = [[inp.b[k] for inp in inputs] for k in range(3)]
    if not offset.any():
        offset = None
    plant = _Plant(model, rows, bs)
    _check_stable(plant, inputs)
    orders = np.array([i.order for i in inputs])

    def transfer(f):
        f = np.asarray(f, dtype=float)
        H = plant(f)
        if offset is not None:
            H = H + offset[None]
        s = 2j * np.pi * f
        with np.errstate(divide="ignore", invalid="ignore"):
            H = H / (s[:, None] ** orders[None, :])[:, None, :]
        return H, _input_matrix(inputs, cr, f)

    lo = min(i.psd.band[0] for i in inputs)
    hi = max(i.psd.band[1] for i in inputs)
    fd, hw = plant.poles()
    pts = [np.concatenate([i.psd.breakpoints for i in inputs])]
    for k in SPLIT:
        pts += [fd - k * hw, fd + k * hw]
    pts = np.concatenate(pts)
    if math.isinf(hi):
        top = max(pts.max(initial=0.0), lo, 1e-300)
        pts = np.append(pts, 4 * top)
    pts = np.unique(np.clip(pts[np.isfinite(pts)], lo, hi if math.isfinite(hi) else np.inf))
    pts = pts[(pts >= lo)]
    pts = np.unique(np.append(pts, lo))
    exact = _lyapunov(plant, model, inputs, cr, offset) if method != "quadrature" else None
    if method == "lyapunov" and exact is None:
        raise ModelError("random response: the Lyapunov equation needs every input white over all frequencies, "
                         "viscous damping, and forces only or support accelerations only")
    n_out = rows.shape[0]
    if exact is not None:
        var, err, unbounded, cov = exact
        how, evaluations, converged = "lyapunov", 0, True
    else:
        var, err, unbounded, evaluations, converged = _quadrature(transfer, pts, hi, lo, n_out, tolerance)
        err = err + 2 * plant.relative_error * np.where(np.isfinite(var), var, 0.0)
        how, cov = "quadrature (Gauss–Kronrod 7/15, split at the poles and breakpoints)", None
    return RandomResponse(out.labels, out.units, tuple(i.label for i in inputs), how, model.damping, var, err,
                          tuple(unbounded), evaluations, time.perf_counter() - start, float(lin.relative_error),
                          transfer, cov, converged, pts, hi, tuple(i.psd for i in inputs))


def _outputs(lin, outputs, relative, springs):
    """(Channels, spring ends): the outputs' rows, with relative motions and springs' axial forces appended;
    spring ends: per spring row, [(support name, coefficient 3-vector)] of its ends on supports (a support's
    displacement y moves the force by coefficient·y)."""
    out = channels(lin, outputs, None, "outputs")
    rows, labels, units = [out.matrix], list(out.labels), list(out.units)
    for pair in relative or ():
        if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
            raise ModelError(f"random response relative: expected pairs (a, b) of outputs, got {pair!r}")
        a, b = (channels(lin, [x], None, "relative outputs") for x in pair)
        if a.units != b.units:
            raise ModelError(f"random response relative {pair!r}: {a.units[0]} and {b.units[0]} do not subtract")
        rows.append(a.matrix - b.matrix)
        labels.append(f"{a.labels[0]} − {b.labels[0]}")
        units.append(a.units[0])
    ends = [[] for _ in labels]
    for name in [springs] if isinstance(springs, str) else list(springs or ()):
        row, end = _spring_row(lin, name)
        rows.append(row[None, :])
        labels.append(f"{name} (force)")
        units.append("N")
        ends.append(end)
    return Channels(np.vstack(rows), tuple(labels), tuple(units)), ends


def _spring_row(lin, name):
    """The change of a point spring's axial force, k·u·(δp_b − δp_a) (N), as a row over the coordinates, and its
    ends on supports."""
    from ...description.elements.spring import Spring, anchor

    system = lin.system
    element = system.scene.elements.get(name)
    if not isinstance(element, Spring):
        springs = [e.name for e in system.scene.elements.values() if isinstance(e, Spring)]
        raise unknown_name(name, springs, "spring", what="random response springs")
    xa, xb = anchor(system, element.a, lin.q, lin.t), anchor(system, element.b, lin.q, lin.t)
    L = float(np.linalg.norm(xb - xa))
    if not L > 0:
        raise ModelError(f"random response: spring '{name}' has zero length at the operating point: its line of "
                         "action (and its force's change) is undefined")
    u = (xb - xa) / L
    row = np.zeros(lin.nv)
    ends = []
    for sign, (body, point) in ((-1.0, element.a), (1.0, element.b)):
        if body in system.support_index:
            ends.append((body, sign * element.stiffness * u))
        elif body != WORLD:
            row += sign * element.stiffness * (u @ lin.point_jacobian([(body, point)]))
    return row, ends


def _diagonal(H, G):
    """diag(H G Hᴴ) (n_f × n_out, real): the outputs' one-sided PSDs."""
    if G.shape[1] == 1:
        return (H.real[:, :, 0] ** 2 + H.imag[:, :, 0] ** 2) * G[:, 0, 0].real[:, None]
    return np.einsum("foi,fij,foj->fo", H, G, H.conj()).real


def _check_stable(plant, inputs):
    lam = plant.lam
    scale = np.abs(lam).max(initial=1.0)
    if np.any(lam.real > 1e-9 * scale):
        raise ModelError("random response: the operating point is unstable (an eigenvalue with Re λ > 0): no "
                         "stationary response exists")
    fd, hw = plant.poles()
    for f, h in zip(fd, hw):
        undamped = h <= 1e-12 * max(f, 1e-300) and f > 1e-9 * scale / (2 * np.pi) or (f == 0 and h == 0)
        if undamped and any(i.psd(np.array([f]))[0] > 0 for i in inputs):
            what = "a rigid-body mode (0 Hz)" if f == 0 else f"an undamped mode at {f:.6g} Hz"
            raise ModelError(f"random response: {what} lies where the input has power: the response variance "
                             "is unbounded; add damping (lin.with_modal_damping(ζ)) or band-limit the input")


def _quadrature(transfer, pts, hi, lo, n_out, tol):
    """Variances of orders 0…3 per output by adaptive quadrature; orders whose integral diverges at 0 or ∞
    are flagged (their local slope in log-log)."""
    unbounded = [None] * 4

    def g_all(f):
        H, G = transfer(f)
        S = _diagonal(H, G)
        w2 = (2 * np.pi * f) ** 2
        out = np.empty((f.size, 4 * n_out))
        for q in range(4):
            np.multiply(S, (w2 ** q)[:, None], out=out[:, q * n_out:(q + 1) * n_out])
        return out

    def slope(f1, f2):
        y1, y2 = g_all(np.array([f1])), g_all(np.array([f2]))
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.log(y2 / y1).reshape(4, n_out) / math.log(f2 / f1), (y1 + y2).reshape(4, n_out)

    if math.isinf(hi):
        top = pts[-1]
        p, y = slope(1e3 * top, 1e4 * top)
        bad = np.any((p > -1.2) & (y > 0), axis=1) | ~np.all(np.isfinite(y), axis=1)
        for q in np.flatnonzero(bad):
            unbounded[q] = (f"its PSD decays no faster than f^{p[q].max():.2g} at high frequency (a white input "
                            "over all frequencies reaches it directly): give a band-limited PSD")
    if lo == 0:
        bottom = pts[1] if pts.size > 1 else 1.0
        p, y = slope(1e-5 * bottom, 1e-6 * bottom)
        bad = np.any((p < -0.8) & (y > 0), axis=1) | ~np.all(np.isfinite(y), axis=1)
        for q in np.flatnonzero(bad):
            if unbounded[q] is None:
                unbounded[q] = ("its PSD grows like f^{:.2g} towards 0 Hz (a motion that drifts without bound, e.g. "
                                "a support's displacement under white acceleration): give a band-limited PSD"
                                ).format(p[q][np.isfinite(p[q])].min(initial=0.0))
    keep = [q for q in range(4) if unbounded[q] is None]
    var = np.full((4, n_out), np.inf)
    err = np.zeros((4, n_out))
    if not keep:
        return var, err, unbounded, 0, True
    cols = np.concatenate([np.arange(q * n_out, (q + 1) * n_out) for q in keep])

    def g(f):
        y = g_all(f)
        y = y if len(keep) == 4 else y[:, cols]
        if not np.isfinite(y.sum()):
            k = np.flatnonzero(~np.all(np.isfinite(y), axis=1))[0]
            raise ModelError(f"random response: the response PSD is not finite at {f[k]:.6g} Hz")
        return y

    res = integrate(g, pts, hi, rtol=tol, groups=np.repeat(np.arange(len(keep)), n_out))
    var[keep] = res.value.reshape(len(keep), n_out)
    err[keep] = res.error.reshape(len(keep), n_out)
    return var, err, unbounded, res.evaluations, res.converged


def _lyapunov(plant, model, inputs, cross, offset):
    """Exact variances for white inputs over all frequencies: (var, err, unbounded, {order: covariance}) or None."""
    if plant.hysteretic or offset is not None or not all(i.psd.is_white for i in inputs):
        return None
    if any(kind == "delay" for _, _, kind, _ in cross) or any(kind == "psd" and not v.is_white
                                                              for _, _, kind, v in cross):
        return None
    forces = all(i.order == 0 and not np.any(i.b[1]) and not np.any(i.b[2]) for i in inputs)
    accel = all(i.order == 2 and not np.any(i.b[2]) for i in inputs)
    if not (forces or accel):
        return None
    n = model.M.shape[0]
    A, Minv = plant.A, plant.Minv
    E = [np.vstack([np.zeros((n, len(inputs))), Minv @ b]) for b in plant.bs]
    B = E[0] if forces else E[0] + A @ E[1]  # support: H_d(s) = Cq (sI − A)⁻¹ (E0 + A E1)
    G0 = _input_matrix(inputs, cross, np.array([1.0]))[0].real
    W = G0 / 2  # one-sided G₀ per Hz → intensity: two-sided G₀/(4π) per rad/s, times 2π
    Q = B @ W @ B.T
    P = sla.solve_continuous_lyapunov(A, -Q)
    # iterative refinement: each correction solves the same equation with the residual; the second one's
    # size is the error left after the first (the twice-corrected P is more accurate still)
    for _ in range(2):
        dP = sla.solve_continuous_lyapunov(A, -(A @ P + P @ A.T + Q))
        P = 0.5 * (P + dP + (P + dP).T)
    rows = plant.rows
    Cq, Cv = np.hstack([rows, np.zeros_like(rows)]), np.hstack([np.zeros_like(rows), rows])
    cov = {}
    var = np.full((4, rows.shape[0]), np.inf)
    err = np.zeros((4, rows.shape[0]))
    unbounded = [None] * 4
    first = 0 if forces else 2
    for k, C in ((first, Cq), (first + 1, Cv)):
        if k == 3 and np.any(rows @ (Minv @ plant.bs[1])):
            continue  # the support's damper passes the white acceleration straight to the jerk (Cq B ≠ 0)
        cov[k] = C @ P @ C.T
        var[k] = np.diag(cov[k]).copy()
        # per output: the refinement's own size there (a bound of what it left), plus round-off of the
        # eigenvector conditioning on the output's scale (never the whole P's: a stiff model's blocks differ)
        err[k] = np.abs(np.diag(C @ dP @ C.T)) + 16 * EPS * plant.cond * np.sqrt(A.shape[0]) * np.abs(var[k])
    why_force = "a white force acts directly on the masses: their acceleration is white (unbounded variance); " \
                "give a band-limited PSD"
    why_motion = "the support itself drifts without bound under a white acceleration (its velocity and " \
                 "displacement are Brownian): give a band-limited PSD"
    for k in range(4):
        if not np.all(np.isfinite(var[k])):
            unbounded[k] = why_force if forces else (why_motion if k < 2 else "the support's damper passes the white "
                                                     "acceleration straight to the rate of acceleration")
    return var, err, unbounded, cov
