"""Responses of a linear model M δq̈ + C δq̇ + K δq = B u (:class:`vibdyn.linearize.LinearModel`).

- Free response from δq(0), δv(0): modal superposition with real modes (undamped or classical damping,
  closed-form modal solutions, also rigid, unstable and over-damped modes), complex modes of the state
  form (any viscous damping), or the matrix exponential.
- Harmonic steady state, receptance / mobility / accelerance α(ω) by direct solve of
  (K − ω²M + iωC + iD) X = B or by modal sum Σ φφᵀ/(ω_r² − ω² + iωc_r + id_r), with viscous and
  hysteretic (structural) damping; resonances, anti-resonances and half-power bandwidths.
- Base excitation: a moving support (its springs and dampers act as B_y y + B_v ẏ) or a prescribed joint
  coordinate; harmonic steady state (transmissibility) and transients.
- Forced transients: modal Duhamel integrals or the exact state-space discretisation (scipy expm), both
  with Gauss–Legendre quadrature of the force between time points; scipy's ``solve_ivp`` on the state form
  as the independent check.
- Modal appropriation: the force pattern that drives a single undamped mode in phase quadrature.

Conventions: δq are the tangent coordinates of the linear model (m or rad) measured from the operating
point; harmonic quantities are complex amplitudes: a force Re(F e^{iωt}) gives Re(X e^{iωt}) with X = αF.
ω in rad/s, Hz alongside (``frequency_hz``). Inputs and outputs are coordinate names (generalized forces
and displacements), body points with a direction ``(body, (x, y, z), (dx, dy, dz))`` (force along it and
displacement along it, world axes), or None (every coordinate).
"""

import time
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
import scipy.linalg as sla

from ._check import count, finite_array, scalar, unit_axis, unknown_name, vector3
from .errors import ModelError

EPS = np.finfo(float).eps
QUANTITY_FACTOR = {"receptance": lambda w: np.ones_like(w, dtype=complex), "mobility": lambda w: 1j * w,
                   "accelerance": lambda w: -(w ** 2) + 0j}
QUANTITY_UNIT = {"receptance": "", "mobility": "/s", "accelerance": "/s²"}


# ====================================================================== inputs and outputs
@dataclass(frozen=True, eq=False)
class Channels:
    """Inputs or outputs of a response. Row j of ``matrix`` (k × nv) is the displacement along channel j
    per tangent coordinate; a unit force on channel j is the generalized force ``matrix[j]`` (Jᵀd)."""

    matrix: np.ndarray
    labels: tuple
    units: tuple  # displacement unit per channel: "m" or "rad"

    @property
    def force_units(self):
        return tuple("N" if u == "m" else "N·m" for u in self.units)


def channels(lin, spec=None, direction=None, what="outputs"):
    """:class:`Channels` of a linear model from a spec: None (all coordinates), a coordinate name, a body
    point ``(body, (x, y, z), (dx, dy, dz))`` (or ``(body, (x, y, z))`` with ``direction``), or a list of
    them."""
    system = lin.system
    if spec is None:
        return Channels(np.eye(lin.nv), tuple(lin.coordinates), tuple(system.units))
    items = [spec] if isinstance(spec, str) or _is_point(spec) else _as_list(spec, what)
    if not items:
        raise ModelError(f"{what}: empty list (give coordinate names, body points or None)")
    rows, labels, units = [], [], []
    for item in items:
        if isinstance(item, str):
            row, unit = lin.coordinate_row(item)
            rows.append(row)
            labels.append(item)
            units.append(unit)
        elif _is_point(item):
            body = item[0]
            point = vector3(item[1], f"{what}: point of body '{body}'")
            d = item[2] if len(item) == 3 else direction
            if d is None:
                raise ModelError(f"{what}: point {body}{_fmt(point)} needs a direction: "
                                 "(body, (x, y, z), (dx, dy, dz)) or direction=(dx, dy, dz)")
            d = unit_axis(d, f"{what}: direction at {body}{_fmt(point)}")
            rows.append(d @ lin.point_jacobian([(body, point)]))
            labels.append(f"{body}{_fmt(point)}·{_fmt(d)}")
            units.append("m")
        else:
            raise ModelError(f"{what}: expected a coordinate name, a point (body, (x, y, z), (dx, dy, dz)) "
                             f"or None, got {item!r}")
    return Channels(np.array(rows), tuple(labels), tuple(units))


def _is_point(x):
    if not isinstance(x, (tuple, list)) or len(x) not in (2, 3) or not isinstance(x[0], str):
        return False
    try:
        return not isinstance(x[1], str) and np.shape(x[1]) == (3,)
    except ValueError:
        return False


def _as_list(spec, what):
    try:
        return list(spec)
    except TypeError:
        raise ModelError(f"{what}: expected a coordinate name, a body point, a list of them or None, "
                         f"got {spec!r}") from None


def _fmt(x):
    return "(" + ",".join(f"{float(v):g}" for v in np.ravel(x)) + ")"


# ====================================================================== damping models
@dataclass(frozen=True, eq=False)
class Hysteretic:
    """Hysteretic (structural) damping: a dynamic stiffness K − ω²M + iD with
    D = alpha·M + eta·K_s + MΦ diag(η_r ω_r²) ΦᵀM (``modal``: loss factor per undamped mode) + ``matrix``.

    ``Hysteretic(eta=0.02)`` is D = ηK; ``Hysteretic(alpha=a, eta=b)`` is D = aM + bK. The model's own
    viscous C is dropped unless ``viscous=True``. Frequency-domain only (no causal time response).
    """

    eta: float = 0.0
    alpha: float = 0.0
    modal: object = None
    matrix: object = None
    viscous: bool = False

    def __post_init__(self):
        object.__setattr__(self, "eta", scalar(self.eta, "hysteretic eta", nonnegative=True))
        object.__setattr__(self, "alpha", scalar(self.alpha, "hysteretic alpha", nonnegative=True))
        if self.modal is not None:
            m = finite_array(self.modal, None, "hysteretic modal loss factors")
            if np.any(m < 0):
                raise ModelError("hysteretic modal loss factors must be ≥ 0")
            object.__setattr__(self, "modal", m)
        if self.matrix is not None:
            object.__setattr__(self, "matrix", finite_array(self.matrix, (None, None), "hysteretic matrix D"))

    def damping_matrix(self, lin):
        """D (nv × nv) for a linear model."""
        D = self.alpha * lin.M + self.eta * lin.K_s
        if self.modal is not None:
            m = lin.modes()
            try:
                eta = np.broadcast_to(self.modal, m.omega.shape)
            except ValueError:
                raise ModelError(f"hysteretic modal loss factors: expected one number or {m.n} (one per mode), "
                                 f"got {self.modal.size}") from None
            MPhi = lin.M @ m.shapes
            D = D + MPhi @ np.diag(eta * m.omega2) @ MPhi.T
        if self.matrix is not None:
            if self.matrix.shape != lin.M.shape:
                raise ModelError(f"hysteretic matrix D: expected shape {lin.M.shape}, got {self.matrix.shape}")
            D = D + self.matrix
        return D

    def describe(self):
        parts = [f"{self.alpha:g} M"] if self.alpha else []
        parts += [f"{self.eta:g} K"] if self.eta else []
        parts += ["modal loss factors " + _fmt(self.modal)] if self.modal is not None else []
        parts += ["given matrix"] if self.matrix is not None else []
        return "hysteretic: D = " + (" + ".join(parts) or "0") + (" (with viscous C)" if self.viscous else "")


@dataclass(frozen=True, eq=False)
class _Model:
    """The matrices a response uses: the linear model (possibly reduced), its C and hysteretic D."""

    lin: object
    C: np.ndarray
    D: np.ndarray
    damping: str

    @property
    def M(self):
        return self.lin.M

    @property
    def K(self):
        return self.lin.K

    @cached_property
    def modes(self):
        return self.lin.modes()

    @cached_property
    def modal(self):
        """(Φ, ω², c_r, d_r, coupling): undamped modes, modal damping diag(ΦᵀCΦ), diag(ΦᵀDΦ), and the largest
        part the modal sum neglects (off-diagonal ΦᵀCΦ, ΦᵀDΦ, skew K) relative to the diagonal."""
        m = self.modes
        Phi = m.shapes
        Cm, Dm = Phi.T @ self.C @ Phi, Phi.T @ self.D @ Phi
        Nm = Phi.T @ self.lin.N @ Phi
        off = lambda X: np.abs(X - np.diag(np.diag(X))).max(initial=0.0)  # noqa: E731

        def ratio(X):
            o, d = off(X), np.abs(np.diag(X)).max(initial=0.0)
            return 0.0 if o == 0 else (o / d if d > 0 else np.inf)

        w2max = np.abs(m.omega2).max(initial=0.0)
        coupling = max(ratio(Cm), ratio(Dm), np.abs(Nm).max(initial=0.0) / w2max if w2max > 0 else 0.0)
        return Phi, m.omega2, np.diag(Cm).copy(), np.diag(Dm).copy(), float(coupling)

    def z(self, w):
        """Dynamic stiffness K − ω²M + i(ωC + D)."""
        return self.K - w * w * self.M + 1j * (w * self.C + self.D)

    @property
    def classical(self):
        """The real modes decouple the equations (classical damping, symmetric K)."""
        return self.modal[4] <= 1e-8


def _model(lin, damping):
    if damping is None or damping == "viscous":
        return _Model(lin, lin.C, np.zeros_like(lin.M), "viscous (the model's C)")
    if damping in ("none", "undamped"):
        return _Model(lin, np.zeros_like(lin.M), np.zeros_like(lin.M), "undamped")
    if isinstance(damping, Hysteretic):
        C = lin.C if damping.viscous else np.zeros_like(lin.M)
        return _Model(replace(lin, C=C, C_error=np.zeros_like(C)) if not damping.viscous else lin, C,
                      damping.damping_matrix(lin), damping.describe())
    raise ModelError(f"damping: expected None/'viscous', 'none' or a vibdyn.Hysteretic(...), got {damping!r}")


# ====================================================================== frequency responses
@dataclass(frozen=True, eq=False)
class FRF:
    """A frequency response H(ω) (n_ω × n_out × n_in, complex).

    ``kind`` "receptance": displacement per force (m/N, rad/(N·m), ...); "transmissibility": displacement
    per support displacement (m/m). ``mobility`` = iωH and ``accelerance`` = −ω²H. ``residual``: largest
    normwise backward residual of (K − ω²M + iωC + iD) X = B over ω (modal sums included: it measures
    truncation and neglected coupling); ``error``: estimated relative error, condition number × (residual
    + the linear model's error estimate).
    ``elapsed`` (s). ``peaks()``, ``half_power()`` refine on the model, not on the grid.
    """

    omega: np.ndarray  # rad/s
    alpha: np.ndarray
    outputs: tuple
    inputs: tuple
    output_units: tuple
    input_units: tuple
    kind: str
    method: str
    damping: str
    residual: float
    condition: float
    error: float
    elapsed: float
    natural: np.ndarray = field(repr=False)  # natural frequencies of the model (rad/s): seeds for peaks
    evaluate: object = field(repr=False)  # ω array ↦ H (n_ω × n_out × n_in) with the same settings

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

    def units(self, output=0, input=0, quantity="receptance"):
        """Unit of H_jk, e.g. "m/N" (receptance), "m/N/s" (mobility)."""
        j, k = self.index(output, input)
        return f"{self.output_units[j]}{QUANTITY_UNIT[_quantity(quantity)]}/{self.input_units[k]}"

    def index(self, output=0, input=0):
        """(j, k) indices of an output and an input given by label or position."""
        return _pick(output, self.outputs, "output"), _pick(input, self.inputs, "input")

    def get(self, output=0, input=0, quantity="receptance"):
        """H_jk(ω) (n_ω complex) of one output and input (labels or indices): receptance, mobility or
        accelerance."""
        j, k = self.index(output, input)
        return QUANTITY_FACTOR[_quantity(quantity)](self.omega) * self.alpha[:, j, k]

    def peaks(self, output=0, input=0, quantity="receptance"):
        """Resonances (maxima) and anti-resonances (minima) of |H_jk| inside the frequency range, refined by
        bounded Brent search (scipy.optimize.minimize_scalar) on the model between grid neighbours; the
        model's natural frequencies are added to the grid so that sharp resonances are not missed.

        An undamped resonance (the dynamic stiffness singular at a natural frequency that H_jk sees) is a
        resonance at exactly that natural frequency with unbounded amplitude (``inf``, ``unbounded`` True)."""
        from .identify import extrema

        start = time.perf_counter()
        w, a, f, poles = self._curve(output, input, quantity)
        wr, ar, er = extrema(w, a, f, "max")
        wa, aa, ea = extrema(w, a, f, "min")
        if poles.size:  # Brent closes in on a pole: that maximum is the pole itself, exactly
            near = np.array([np.any(np.abs(x - poles) <= 1e-6 * x) for x in wr], dtype=bool)
            wr, ar, er = (np.concatenate([wr[~near], poles]), np.concatenate([ar[~near], np.full(poles.size, np.inf)]),
                          np.concatenate([er[~near], np.zeros(poles.size)]))
            order = np.argsort(wr)
            wr, ar, er = wr[order], ar[order], er[order]
        j, k = self.index(output, input)
        return Peaks(self.outputs[j], self.inputs[k], _quantity(quantity), wr, ar, wa, aa,
                     float(max(er.max(initial=0.0), ea.max(initial=0.0))), time.perf_counter() - start,
                     ~np.isfinite(ar))

    def half_power(self, output=0, input=0, quantity="receptance"):
        """Half-power bandwidth and damping ratio of each resonance of |H_jk|
        (:class:`vibdyn.identify.HalfPower`), refined on the model. Undamped resonances have no band: they
        are listed in ``undamped`` (rad/s; ζ = 0 there), the damped ones between them keep their bands."""
        from .identify import half_power

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

    def to_dict(self):
        """Plain data (JSON-ready): complex numbers as [re, im], SI units."""
        return {"kind": self.kind, "omega_rad_s": self.omega.tolist(), "frequency_hz": self.frequency_hz.tolist(),
                "outputs": list(self.outputs), "inputs": list(self.inputs),
                "output_units": list(self.output_units), "input_units": list(self.input_units),
                "alpha": [[[[z.real, z.imag] for z in row] for row in m] for m in self.alpha],
                "method": self.method, "damping": self.damping, "residual": self.residual,
                "condition": self.condition, "error_estimate": self.error, "elapsed_s": self.elapsed}


Receptance = FRF


@dataclass(frozen=True, eq=False)
class Peaks:
    """Resonances and anti-resonances of one |H_jk| (rad/s; ``*_hz`` alongside), with |H| there.
    ``tolerance``: estimated absolute error of the frequencies (rad/s)."""

    output: str
    input: str
    quantity: str
    resonances: np.ndarray
    amplitudes: np.ndarray
    antiresonances: np.ndarray
    antiresonance_amplitudes: np.ndarray
    tolerance: float
    elapsed: float
    unbounded: np.ndarray = None  # per resonance: an undamped resonance (amplitude inf)

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
                "tolerance_rad_s": self.tolerance, "elapsed_s": self.elapsed}


def _quantity(q):
    if q not in QUANTITY_FACTOR:
        raise ModelError(f"unknown quantity {q!r} (one of {', '.join(QUANTITY_FACTOR)})")
    return q


def _pick(x, labels, what):
    if isinstance(x, (int, np.integer)) and not isinstance(x, bool):
        if not -len(labels) <= x < len(labels):
            raise ModelError(f"{what} index {x} out of range ({len(labels)} {what}s)")
        return int(x) % len(labels)
    if x in labels:
        return labels.index(x)
    raise unknown_name(x, labels, what)


def _omegas(omega):
    w = np.atleast_1d(finite_array(omega, None, "omega (rad/s)")).astype(float)
    if w.ndim != 1 or w.size == 0:
        raise ModelError(f"omega: expected a frequency or a 1-D array of frequencies (rad/s), got shape {w.shape}")
    if np.any(w < 0):
        raise ModelError("omega: frequencies must be ≥ 0 rad/s")
    return w


def _transfer(model, omega, Bfun, out, method, n_modes=None, offset=None):
    """H(ω) = out · X(ω) (+ offset), X solving Z(ω) X = B(ω); with its backward residual and condition."""
    if method not in ("direct", "modal"):
        raise ModelError(f"frequency response: unknown method {method!r} (use 'direct' or 'modal')")
    nv = model.M.shape[0]
    if method == "modal":
        Phi, w2, c, d, _ = model.modal
        keep = slice(None) if n_modes is None else slice(0, _n_modes(n_modes, w2.size))
        Phi, w2, c, d = Phi[:, keep], w2[keep], c[keep], d[keep]
    H = None
    residual = condition = 0.0
    for i, w in enumerate(omega):
        B = np.asarray(Bfun(w), dtype=complex).reshape(nv, -1)
        Z = model.z(w)
        s = sla.svdvals(Z) if nv else np.ones(1)
        cond = s[0] / s[-1] if s[-1] > 0 else np.inf
        if method == "direct":
            if not cond < 1e14:
                _singular(w, model)
            X = sla.solve(Z, B, check_finite=False)
        else:
            den = w2 - w * w + 1j * (w * c + d)
            if np.any(np.abs(den) <= 64 * EPS * (np.abs(w2) + w * w + w * np.abs(c) + np.abs(d)) + 1e-300):
                _singular(w, model)
            X = Phi @ ((Phi.T @ B) / den[:, None])
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
    return H, residual, condition


class SingularResponse(ModelError):
    """The dynamic stiffness is singular at the requested frequency: an undamped resonance, or ω = 0 with a
    rigid-body mode (the steady response is unbounded)."""


def _singular(w, model):
    why = "a rigid-body mode (K is singular)" if w == 0 else "an undamped resonance"
    raise SingularResponse(f"the dynamic stiffness K − ω²M + i(ωC + D) is singular at ω = {w:g} rad/s "
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


def _frf(model, omega, Bfun, cout, labels_in, units_in, kind, method, n_modes, start, offset=None):
    w = _omegas(omega)
    H, res, cond = _transfer(model, w, Bfun, cout.matrix, method, n_modes, offset)
    evaluate = lambda ww: _transfer(model, _omegas(ww), Bfun, cout.matrix, method, n_modes, offset)[0]  # noqa: E731
    err = min(1.0, cond * (max(res, EPS) + model.lin.error))  # solve + the linear model's own error
    return FRF(w, H, cout.labels, tuple(labels_in), cout.units, tuple(units_in), kind, method, model.damping,
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
    model = _model(lin, damping)
    cin = channels(lin, inputs, direction, "inputs")
    cout = channels(lin, outputs, direction, "outputs")
    B = cin.matrix.T
    return _frf(model, omega, lambda w: B, cout, cin.labels, cin.force_units, "receptance", method, n_modes, start)


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

    @property
    def amplitude(self):
        return np.abs(self.x)

    @property
    def phase(self):
        return np.angle(self.x)

    @property
    def frequency_hz(self):
        return self.omega / (2 * np.pi)

    @property
    def error(self):
        return self.frf.error

    def at(self, t):
        """Output time histories Re(X e^{iωt}) (n_t × n_out) for a single frequency."""
        if self.omega.size != 1:
            raise ModelError("harmonic response: at(t) needs a single frequency")
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.real(np.exp(1j * self.omega[0] * t)[:, None] * self.x[0][None, :])


def harmonic_response(lin, omega, force, inputs=None, outputs=None, *, phase=0.0, direction=None,
                      method="direct", damping=None, n_modes=None):
    """Steady response to harmonic forces of amplitudes ``force`` (one per input: N, N·m, or complex) and
    phases ``phase`` (rad): f(t) = Re(force e^{i(ωt + phase)}) (:class:`HarmonicResponse`)."""
    start = time.perf_counter()
    frf = receptance(lin, omega, inputs, outputs, direction=direction, method=method, damping=damping,
                     n_modes=n_modes)
    n_in = len(frf.inputs)
    F = np.asarray(force, dtype=complex).ravel()
    if F.size == 1:
        F = np.full(n_in, F[0])
    if F.size != n_in or not np.all(np.isfinite(F)):
        raise ModelError(f"harmonic force: expected {count(n_in, 'finite amplitude')} (one per input), got {force!r}")
    ph = np.broadcast_to(finite_array(phase, None, "harmonic force phase"), (n_in,))
    F = F * np.exp(1j * ph)
    return HarmonicResponse(frf.omega, frf.alpha @ F, frf.outputs, frf.output_units, F, frf,
                            time.perf_counter() - start)


# ====================================================================== base excitation
def transmissibility(r, zeta):
    """Displacement transmissibility of a base-excited single-degree-of-freedom system,
    T(r, ζ) = √((1 + (2ζr)²) / ((1 − r²)² + (2ζr)²)), r = ω/ω_n; T(√2, ζ) = 1 for every ζ."""
    r = np.asarray(r, dtype=float)
    z = np.asarray(zeta, dtype=float)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(z))) or np.any(r < 0) or np.any(z < 0):
        raise ModelError(f"transmissibility: need finite r ≥ 0 and ζ ≥ 0, got r={r!r}, zeta={z!r}")
    num = 1 + (2 * z * r) ** 2
    den = (1 - r ** 2) ** 2 + (2 * z * r) ** 2
    if np.any(den == 0):
        raise ModelError("transmissibility: infinite at r = 1 with ζ = 0")
    return np.sqrt(num / den)


def _support(lin, support, direction):
    """How a base motion enters: ("support", B_y·d, B_v·d, labels) or ("joint", index, free indices)."""
    system = lin.system
    if not isinstance(support, str):
        raise ModelError(f"base excitation: expected a support or coordinate name, got {support!r}")
    if support in system._support_index:
        By, Bv = lin.support_input(support)
        if direction is None:
            dirs, labels = np.eye(3), [f"{support}.{a}" for a in "xyz"]
        else:
            d = unit_axis(direction, f"support '{support}' direction")
            dirs, labels = d[:, None], [f"{support}·{_fmt(d)}"]
        return "support", By @ dirs, Bv @ dirs, labels
    if support in system.coordinates:
        if system.nv < 2:
            raise ModelError(f"base excitation: prescribing '{support}' leaves no free coordinate")
        p = system.coordinate_index(support)
        return "joint", p, np.array([i for i in range(system.nv) if i != p]), [support]
    raise unknown_name(support, [*(s.name for s in system.supports), *system.coordinates], "support or coordinate",
                       "supports and coordinates", "base excitation")


def _reduced(model, free):
    """The model with only the coordinates ``free`` (the others prescribed)."""
    ix = np.ix_(free, free)
    lin = model.lin
    sub = replace(lin, M=lin.M[ix], K=lin.K[ix], C=model.C[ix], K_error=lin.K_error[ix], C_error=lin.C_error[ix])
    return _Model(sub, model.C[ix], model.D[ix], model.damping)


def base_response(lin, omega, support, direction=None, outputs=None, *, method="direct", damping=None,
                  n_modes=None):
    """Steady response to a harmonic base motion (:class:`FRF` of kind "transmissibility"): outputs per unit
    displacement of ``support``.

    ``support``: a support's name (a moving frame carrying springs and dampers, ``scene.add_support``):
    the input is its displacement along ``direction`` (world axes; None: x, y, z as three inputs), acting
    as (B_y + iωB_v) Y; or a coordinate name (a prescribed joint): its motion Y drives the other
    coordinates through −(K_fp − ω²M_fp + iωC_fp) Y, and the prescribed coordinate itself moves as Y.
    Outputs are absolute: for a single-degree-of-freedom system H = T(r, ζ) e^{iφ}."""
    start = time.perf_counter()
    model = _model(lin, damping)
    cout = channels(lin, outputs, None, "outputs")
    how = _support(lin, support, direction)
    if how[0] == "support":
        _, By, Bv, labels = how
        return _frf(model, omega, lambda w: By + 1j * w * Bv, cout, labels, ("m",) * len(labels),
                    "transmissibility", method, n_modes, start)
    _, p, free = how[:3]
    sub = _reduced(model, free)
    M, K, C, D = model.M[free, p], model.K[free, p], model.C[free, p], model.D[free, p]
    out = replace(cout, matrix=cout.matrix[:, free])
    unit = lin.system.units[p]
    return _frf(sub, omega, lambda w: -(K - w * w * M + 1j * (w * C + D))[:, None], out, [support], (unit,),
                "transmissibility", method, n_modes, start, offset=cout.matrix[:, [p]])


# ====================================================================== time responses
@dataclass(frozen=True, eq=False)
class TimeResponse:
    """A response in time: δq, δv, δa (n_t × nv, m or rad and their rates) at times ``t`` (s), measured
    from the operating point. ``error``: estimated error relative to max|δq| (quadrature, eigenvector
    conditioning or the integrator's tolerance, plus the linear model's error drifting the phase over the
    time span); ``imaginary``: largest imaginary part left by complex modes
    (relative, round-off). ``displacement(outputs)`` maps to body points or coordinates."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    coordinates: tuple
    units: tuple
    method: str
    error: float
    elapsed: float
    linear: object = field(repr=False)
    imaginary: float = 0.0

    def displacement(self, outputs=None, direction=None):
        """Displacements of outputs (coordinate names, body points with a direction; None: all) (n_t × k)."""
        return self.q @ channels(self.linear, outputs, direction).matrix.T

    def velocity(self, outputs=None, direction=None):
        return self.v @ channels(self.linear, outputs, direction).matrix.T

    def acceleration(self, outputs=None, direction=None):
        return self.a @ channels(self.linear, outputs, direction).matrix.T

    def coordinate(self, name):
        return self.q[:, self.linear.system.coordinate_index(name)]

    def to_dict(self):
        return {"t_s": self.t.tolist(), "coordinates": list(self.coordinates), "units": list(self.units),
                "q": self.q.tolist(), "v": self.v.tolist(), "a": self.a.tolist(), "method": self.method,
                "error_estimate": self.error, "imaginary": self.imaginary, "elapsed_s": self.elapsed}


def _sdof(k, c, t):
    """(E·C, E·S) for x″ + c x′ + k x = 0, E = e^{−ct/2}, ω_d² = k − c²/4, C = cos ω_d t, S = sin(ω_d t)/ω_d
    (cosh, sinh when ω_d² < 0): x(t) = EC·x0 + ES·(v0 + c x0/2), x′(t) = EC·v0 − ES·(k x0 + c v0/2); ES is
    the unit impulse response. Exact for oscillating, rigid (k = 0), critically and over-damped and
    unstable (k < 0) modes; broadcasts."""
    k, c, t = np.broadcast_arrays(np.asarray(k, float), np.asarray(c, float), np.asarray(t, float))
    wd2 = k - c * c / 4
    osc = wd2 >= 0
    wd = np.sqrt(np.where(osc, wd2, 0.0))
    g = np.sqrt(np.where(osc, 0.0, -wd2))
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        E = np.exp(-c * t / 2)
        ec_o = E * np.cos(wd * t)
        es_o = E * t * np.sinc(wd * t / np.pi)
        # real exponents s1 = g − c/2 (written −k/(g + c/2) when c > 0: no cancellation) and s2 = −g − c/2
        s1 = np.where(c > 0, -k / np.where(c > 0, g + c / 2, 1.0), g - c / 2)
        s2 = -g - c / 2
        e1, e2 = np.exp(s1 * t), np.exp(s2 * t)
        x = 2 * g * t
        small = np.abs(x) <= 1.0
        rel = np.where(x == 0, 1.0, np.expm1(x) / np.where(x == 0, 1.0, x))
        ec_h = np.where(small, e2 * (1 + np.expm1(x) / 2), (e1 + e2) / 2)
        es_h = np.where(small, e2 * t * rel, (e1 - e2) / np.where(g > 0, 2 * g, 1.0))
    return np.where(osc, ec_o, ec_h), np.where(osc, es_o, es_h)


def _times(t, what, increasing):
    t = np.atleast_1d(finite_array(t, None, f"{what}: times (s)")).astype(float)
    if t.ndim != 1 or t.size == 0:
        raise ModelError(f"{what}: times must be a number or a 1-D array (s), got shape {t.shape}")
    if increasing and np.any(np.diff(t) <= 0):
        raise ModelError(f"{what}: times must be strictly increasing (t[0] is the initial instant)")
    return t


def _state0(lin, x0, v0, what):
    n = lin.nv
    out = []
    for name, x in (("x0", x0), ("v0", v0)):
        if x is None:
            out.append(np.zeros(n))
        elif isinstance(x, dict):
            arr = np.zeros(n)
            for key, val in x.items():
                arr[lin.system.coordinate_index(key)] = scalar(val, f"{what} {name}['{key}']")
            out.append(arr)
        else:
            out.append(finite_array(x, (n,), f"{what} {name} (one value per coordinate: {', '.join(lin.coordinates)})"))
    return out


def _method(model, method, what):
    allowed = ("auto", "modal", "state", "expm", "ivp")
    if method not in allowed:
        raise ModelError(f"{what}: unknown method {method!r} (one of {', '.join(allowed)})")
    if np.any(model.D):
        raise ModelError(f"{what}: hysteretic damping has no time-domain form; use viscous damping")
    if method == "auto":
        return "modal" if model.classical else "state"
    if method == "modal" and not model.classical:
        raise ModelError(f"{what}: the real modes do not decouple this model (non-classical damping, "
                         f"gyroscopic or circulatory terms: coupling {model.modal[4]:.1e}); use method='state'")
    return method


def _finish(lin, t, q, v, a, method, error, imag, start):
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise ModelError("time response: the response overflows (an unstable mode grows without bound over "
                         "these times)")
    if lin.error:  # the linear model's own error: a relative frequency error drifting the phase over time
        m = lin.modes()
        wmax = max(m.omega.max(initial=0.0), m.omega_n.max(initial=0.0))
        error = error + lin.error * (1 + wmax * float(np.ptp(np.concatenate([[0.0], t]))))
    return TimeResponse(t, q, v, a, tuple(lin.coordinates), tuple(lin.system.units), method, float(error),
                        time.perf_counter() - start, lin, float(imag))


def _accelerations(model, q, v, g=None):
    rhs = -(q @ model.K.T) - v @ model.C.T
    if g is not None:
        rhs = rhs + g
    return model.lin._solve_M(rhs.T).T


def free_response(lin, t, x0, v0=None, *, method="auto"):
    """Free response δq(t), δv(t) from δq(0) = ``x0`` and δv(0) = ``v0`` (arrays, or dicts by coordinate
    name) at times ``t`` (s) (:class:`TimeResponse`).

    ``method``: "modal" (real modes: x = Σ φ_r q_r(t), q_r(0) = φ_rᵀ M x0, closed-form modal solutions;
    needs classical damping), "state" (complex modes of the state form; the result is real to round-off,
    reported in ``imaginary``; falls back to "expm" when the state matrix is defective, e.g. rigid modes),
    "expm" (scipy.linalg.expm(A t)), "ivp" (scipy's solve_ivp) or "auto" (modal when classical, else state).
    """
    start = time.perf_counter()
    model = _model(lin, None)
    t = _times(t, "free response", increasing=False)
    x0, v0 = _state0(lin, x0, v0, "free response")
    method = _method(model, method, "free response")
    imag = 0.0
    if method == "modal":
        Phi, k, c, _, _ = model.modal
        m = model.modes
        q0, qd0 = Phi.T @ (lin.M @ x0), Phi.T @ (lin.M @ v0)
        EC, ES = _sdof(k, c, t[:, None])
        qm = EC * q0 + ES * (qd0 + c * q0 / 2)
        vm = EC * qd0 - ES * (k * q0 + c * qd0 / 2)
        q, v = qm @ Phi.T, vm @ Phi.T
        a = (-k * qm - c * vm) @ Phi.T
        recon = max(np.linalg.norm(Phi @ q0 - x0) / max(np.linalg.norm(x0), 1e-300) if np.any(x0) else 0.0,
                    np.linalg.norm(Phi @ qd0 - v0) / max(np.linalg.norm(v0), 1e-300) if np.any(v0) else 0.0)
        growth = m.residual.max(initial=0.0) * (1 + m.omega.max(initial=0.0) * np.abs(t).max())
        error = recon + growth + m.orthogonality
    elif method == "ivp":
        return _free_by_ivp(lin, model, t, x0, v0, start)
    else:
        A = lin.A
        z0 = np.concatenate([x0, v0])
        Z, method, error, imag = _state_free(A, z0, t, method)
        q, v = Z[:, :lin.nv], Z[:, lin.nv:]
        a = _accelerations(model, q, v)
    return _finish(lin, t, q, v, a, method, error, imag, start)


def _state_free(A, z0, t, method):
    """State z(t) = e^{At} z0 by complex modes (or expm): (Z, method used, error estimate, imaginary part)."""
    n2 = A.shape[0]
    scale = max(np.linalg.norm(z0), 1e-300)
    if method == "state":
        lam, V = sla.eig(A)
        cond = np.linalg.cond(V)
        if cond < 1e8:
            coef = np.linalg.solve(V, z0)
            Zc = (np.exp(np.outer(t, lam)) * coef) @ V.T
            peak = max(np.abs(Zc).max(), 1e-300)
            imag = float(np.abs(Zc.imag).max() / peak)
            error = cond * EPS * n2 * (1 + np.abs(lam).max(initial=0.0) * np.abs(t).max()) + imag
            return Zc.real, "state", error, imag
        method = "expm"  # defective (rigid or critically damped modes): the matrix exponential instead
    Z = np.array([sla.expm(A * ti) @ z0 for ti in t]).reshape(t.size, n2)
    error = 16 * EPS * n2 * (1 + np.linalg.norm(A, 1) * np.abs(t).max()) * max(np.abs(Z).max(), scale) / scale
    return Z, "expm", error, 0.0


def _free_by_ivp(lin, model, t, x0, v0, start):
    order = np.argsort(t)
    ts = t[order]
    fwd = ts >= 0
    Z = np.zeros((t.size, 2 * lin.nv))
    err = 0.0
    for mask, sign in ((fwd, 1.0), (~fwd, -1.0)):
        if not np.any(mask):
            continue
        tt = np.abs(ts[mask])
        if sign < 0:
            tt = tt[::-1]
        grid = np.concatenate([[0.0], tt]) if tt[0] > 0 else tt
        A = sign * lin.A
        Zi, e = _ivp(lambda s, z: A @ z, np.concatenate([x0, v0]), grid)
        Zi = Zi[-tt.size:]
        Z[np.flatnonzero(mask)] = Zi[::-1] if sign < 0 else Zi
        err = max(err, e)
    Zo = np.empty_like(Z)
    Zo[order] = Z
    q, v = Zo[:, :lin.nv], Zo[:, lin.nv:]
    return _finish(lin, t, q, v, _accelerations(model, q, v), "ivp", err, 0.0, start)


def _ivp(fun, z0, grid, segments=None):
    """solve_ivp (DOP853, rtol 1e-12) through ``grid``; error from a second run at rtol 1e-10. ``segments``:
    indices of grid points where the right-hand side has kinks (restart there)."""
    from scipy.integrate import solve_ivp

    scale = max(np.abs(z0).max(), 1e-12)
    runs = []
    for rtol in (1e-12, 1e-10):
        z = np.asarray(z0, dtype=float)
        out = [z]
        cuts = [0, grid.size - 1] if segments is None else segments
        for i0, i1 in zip(cuts[:-1], cuts[1:]):
            if i1 == i0:
                continue
            sol = solve_ivp(fun, (grid[i0], grid[i1]), z, method="DOP853", t_eval=grid[i0:i1 + 1],
                            rtol=rtol, atol=rtol * scale * 1e-3)
            if not sol.success:
                raise ModelError(f"time integration failed: {sol.message}")
            out += list(sol.y.T[1:])
            z = sol.y[:, -1]
        runs.append(np.array(out))
    Z = runs[0]
    return Z, float(np.abs(Z - runs[1]).max() / max(np.abs(Z).max(), 1e-300))


# ---------------------------------------------------------------------- forced transients
def _force_function(lin, t, force, inputs, direction, what):
    """Generalized force g (nv) as (callable of t or None, samples at t or None)."""
    if force is None:
        return None, None
    B = channels(lin, inputs, direction, "inputs").matrix.T  # nv × m
    m = B.shape[1]
    if callable(force):
        def g(s):
            f = np.asarray(force(s), dtype=float).ravel()
            if f.size == 1 and m > 1:
                raise ModelError(f"{what}: force(t) must return {m} values (one per input), got 1")
            if f.size != m or not np.all(np.isfinite(f)):
                raise ModelError(f"{what}: force(t) must return {count(m, 'finite value')} (one per input) at t = {s}, "
                                 f"got {f!r}")
            return B @ f

        return g, None
    F = finite_array(force, None, f"{what}: force samples")
    if F.ndim == 1 and m == 1:
        F = F[:, None]
    if F.shape != (t.size, m):
        raise ModelError(f"{what}: force samples must have shape (len(t), n_inputs) = ({t.size}, {m}), got {F.shape}")
    return None, F @ B.T


def _nodes(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return (x + 1) / 2, w / 2


def _subgrid(t, rho):
    """The time grid with each interval cut into equal parts of length ≤ 1/ρ; indices of the original
    points in it."""
    h = np.diff(t)
    parts = np.maximum(1, np.ceil(h * rho)).astype(int)
    if parts.sum() > 5_000_000:
        raise ModelError(f"forced response: the fastest mode (|λ| = {rho:.3g} 1/s) needs {parts.sum()} "
                         "sub-steps over these times; shorten the time span or reduce the model")
    pieces = [t[:1]] + [t[i] + h[i] * np.arange(1, parts[i] + 1) / parts[i] for i in range(h.size)]
    fine = np.concatenate(pieces)
    fine[np.cumsum(np.concatenate([[0], parts]))] = t  # original points exactly
    return fine, np.cumsum(np.concatenate([[0], parts]))


def _evaluate(g, G, t, times):
    """Generalized forces at ``times`` (n × nv): the callable, or the samples G at t linearly interpolated."""
    if G is not None:
        return np.column_stack([np.interp(times, t, G[:, j]) for j in range(G.shape[1])])
    return np.array([g(s) for s in times]).reshape(len(times), -1)


def forced_response(lin, t, force=None, inputs=None, *, direction=None, x0=None, v0=None, support=None,
                    motion=None, support_direction=None, method="auto"):
    """Transient response to forces and/or a base motion, from δq(t[0]) = ``x0``, δv(t[0]) = ``v0`` (zero by
    default) at the increasing times ``t`` (s) (:class:`TimeResponse`).

    ``force``: a callable f(t) giving one value per input (N at points along their direction, or
    generalized forces on coordinates), or samples at ``t`` (n_t × n_inputs), taken as piecewise linear.
    ``support``: a support's name — its springs and dampers push with B_y (y − y(t0)) + B_v (ẏ − ẏ(t0)),
    y(t) from the scene's motion or ``motion`` (position(t), velocity(t): 3-vectors, m), along
    ``support_direction`` if given — or a coordinate name, a prescribed joint moving as ``motion``
    (position(t), velocity(t) and, if it has one, acceleration(t), scalars; else ÿ by central differences).

    ``method``: "modal" (modal Duhamel integrals with closed-form modal kernels: classical damping),
    "state" (exact discretisation e^{Ah} with scipy.linalg.expm, any viscous damping), "ivp" (scipy's
    solve_ivp DOP853 at rtol 1e-12: the independent check) or "auto". Modal and state integrate the force
    between time points with 8-point Gauss–Legendre quadrature on sub-steps no longer than 1/|λ|max.
    """
    start = time.perf_counter()
    what = "forced response"
    model = _model(lin, None)
    t = _times(t, what, increasing=True)
    x0, v0 = _state0(lin, x0, v0, what)
    g, G = _force_function(lin, t, force, inputs, direction, what)
    prescribed = None
    if support is not None:
        how = _support(lin, support, None)
        if how[0] == "support":
            g, G = _support_force(lin, support, motion, support_direction, t, g, G)
        else:
            prescribed = how[1], how[2], _prescribed_motion(motion, support, t[0])
    method = _method(model, method, what)
    if prescribed is None:
        q, v, a, method, error = _integrate(model, t, g, G, x0, v0, method)
        return _finish(lin, t, q, v, a, method, error, 0.0, start)
    p, free, (y, yd, ydd) = prescribed
    sub = _reduced(model, free)
    Mfp, Cfp, Kfp = model.M[free, p], model.C[free, p], model.K[free, p]
    y0, yd0, ydd0 = y(t[0]), yd(t[0]), ydd(t[0])

    def gsub(s):
        out = -(Mfp * (ydd(s) - ydd0) + Cfp * (yd(s) - yd0) + Kfp * (y(s) - y0))
        if g is not None:
            out = out + g(s)[free]
        elif G is not None:
            out = out + _evaluate(None, G, t, [s])[0][free]
        return out

    qf, vf, af, method, error = _integrate(sub, t, gsub, None, x0[free], v0[free], method)
    n = lin.nv
    q, v, a = (np.zeros((t.size, n)) for _ in range(3))
    q[:, free], v[:, free], a[:, free] = qf, vf, af
    q[:, p] = x0[p] + np.array([y(s) - y0 for s in t])
    v[:, p] = v0[p] + np.array([yd(s) - yd0 for s in t])
    a[:, p] = np.array([ydd(s) - ydd0 for s in t])
    return _finish(lin, t, q, v, a, method, error, 0.0, start)


def _support_force(lin, name, motion, direction, t, g, G):
    """Add the generalized force of a moving support to g (callable)."""
    By, Bv = lin.support_input(name)
    if motion is None:
        motion = lin.system.supports[lin.system._support_index[name]].motion
    if not (hasattr(motion, "position") and hasattr(motion, "velocity")):
        raise ModelError(f"support '{name}' motion: needs position(t) and velocity(t) (vibdyn.laws.Motion)")
    d = None if direction is None else unit_axis(direction, f"support '{name}' direction")

    def vec(f, s):
        x = np.asarray(f(s), dtype=float).ravel()
        if x.size != 3 or not np.all(np.isfinite(x)):
            raise ModelError(f"support '{name}': motion must give finite 3-vectors (m, m/s), got {x!r} at t = {s}")
        return x if d is None else d * (d @ x)

    p0, v0 = vec(motion.position, t[0]), vec(motion.velocity, t[0])
    base = lambda s: By @ (vec(motion.position, s) - p0) + Bv @ (vec(motion.velocity, s) - v0)  # noqa: E731
    if G is not None:
        Gs = G
        return (lambda s: base(s) + _evaluate(None, Gs, t, [s])[0]), None
    if g is not None:
        gs = g
        return (lambda s: base(s) + gs(s)), None
    return base, None


def _prescribed_motion(motion, name, t0):
    if motion is None or not (hasattr(motion, "position") and hasattr(motion, "velocity")):
        raise ModelError(f"prescribed joint '{name}': give motion= with position(t) and velocity(t) "
                         "(vibdyn.laws.Motion of scalars)")

    def scalar_of(f, label):
        def fn(s):
            x = np.asarray(f(s), dtype=float)
            if x.size != 1 or not np.isfinite(x).all():
                raise ModelError(f"prescribed joint '{name}': {label}(t) must be one finite number, got {x!r}")
            return float(x.ravel()[0])

        return fn

    y, yd = scalar_of(motion.position, "position"), scalar_of(motion.velocity, "velocity")
    if hasattr(motion, "acceleration"):
        ydd = scalar_of(motion.acceleration, "acceleration")
    else:
        def ydd(s, h=1e-4):  # fourth-order central differences of the velocity
            return (8 * (yd(s + h) - yd(s - h)) - (yd(s + 2 * h) - yd(s - 2 * h))) / (12 * h)
    return y, yd, ydd


def _integrate(model, t, g, G, x0, v0, method):
    """(q, v, a, method, error) of M q̈ + C q̇ + K q = g(t) from (x0, v0) at t[0], on the grid t."""
    lin = model.lin
    nv = lin.nv
    has_force = g is not None or G is not None
    force_at = (lambda times: _evaluate(g, G, t, times)) if has_force else (lambda times: np.zeros((len(times), nv)))
    if method == "ivp":
        A = lin.A
        Minv = lin._solve_M(np.eye(nv))

        def fun(s, z):
            dz = A @ z
            if has_force:
                dz[nv:] += Minv @ force_at([s])[0]
            return dz

        Z, err = _ivp(fun, np.concatenate([x0, v0]), t, None if G is None else list(range(t.size)))
        q, v = Z[:, :nv], Z[:, nv:]
        a = _accelerations(model, q, v, force_at(t) if has_force else None)
        return q, v, a, "ivp", err
    if method == "modal":
        Phi, k, c, _, _ = model.modal
        rho = float(np.max(np.sqrt(np.abs(k)) + np.abs(c), initial=0.0))
        fine, idx = _subgrid(t, rho)
        h = np.diff(fine)
        EC, ES = _sdof(k, c, h[:, None])
        T = (EC + c / 2 * ES, ES, -k * ES, EC - c / 2 * ES)  # e^{A_r h} per interval and mode
        if has_force:
            (dq, dv), err = _modal_increments(fine, k, c, force_at, Phi)
        else:
            dq = dv = np.zeros((h.size, k.size))
            err = 0.0
        qm = np.empty((fine.size, k.size))
        vm = np.empty_like(qm)
        qm[0], vm[0] = Phi.T @ (lin.M @ x0), Phi.T @ (lin.M @ v0)
        for j in range(h.size):
            qm[j + 1] = T[0][j] * qm[j] + T[1][j] * vm[j] + dq[j]
            vm[j + 1] = T[2][j] * qm[j] + T[3][j] * vm[j] + dv[j]
        q, v = qm[idx] @ Phi.T, vm[idx] @ Phi.T
        err = err * np.abs(Phi).max(initial=0.0)
        method_used = "modal"
    else:  # "state" (or "expm"): exact discretisation with scipy.linalg.expm
        A = lin.A
        Bs = np.vstack([np.zeros((nv, nv)), lin._solve_M(np.eye(nv))])
        rho = float(np.abs(np.linalg.eigvals(A)).max(initial=0.0)) if nv else 0.0
        fine, idx = _subgrid(t, rho)
        h = np.diff(fine)
        # intervals of (nearly) equal length share their exponentials
        hmax = max(h.max(initial=0.0), 1e-300)
        keys, group = np.unique(np.round(h / hmax, 13), return_inverse=True)
        E = [sla.expm(A * (u * hmax)) for u in keys]
        if has_force:
            incs = []
            for n in (8, 4):
                x, w = _nodes(n)
                F = force_at((fine[:-1, None] + h[:, None] * x).ravel()).reshape(h.size, n, nv)
                inc = np.empty((h.size, 2 * nv))
                for u, key in enumerate(keys):
                    J = group == u
                    Kn = np.array([sla.expm(A * (key * hmax * (1 - xi))) @ Bs for xi in x])  # (n, 2nv, nv)
                    inc[J] = h[J, None] * np.einsum("i,isk,jik->js", w, Kn, F[J])
                incs.append(inc)
            inc, err = incs[0], float(np.abs(incs[0] - incs[1]).max(axis=1).sum())
        else:
            inc, err = np.zeros((h.size, 2 * nv)), 0.0
        Z = np.empty((fine.size, 2 * nv))
        Z[0] = np.concatenate([x0, v0])
        for j in range(h.size):
            Z[j + 1] = E[group[j]] @ Z[j] + inc[j]
        Z = Z[idx]
        q, v = Z[:, :nv], Z[:, nv:]
        method_used = "state"
    peak = max(np.abs(q).max(initial=0.0), 1e-300)
    error = err / peak + 16 * EPS * max(t.size, 1)
    a = _accelerations(model, q, v, force_at(t) if has_force else None)
    return q, v, a, method_used, float(error)


def _modal_increments(fine, k, c, force_at, Phi):
    """Duhamel integrals over each fine interval [t_j, t_j + h] of every mode,
    ∫ e^{A_r(h − τ)} [0; 1] φ_rᵀ g(t_j + τ) dτ, by 8-point Gauss–Legendre with the closed-form modal
    kernels; the error estimate is the difference from the 4-point rule, summed over intervals."""
    h = np.diff(fine)
    incs = []
    for n in (8, 4):
        x, w = _nodes(n)
        P = force_at((fine[:-1, None] + h[:, None] * x).ravel()).reshape(h.size, n, -1) @ Phi
        ec, es = _sdof(k, c, (h[:, None] * (1 - x))[..., None])  # (n_int, n, n_modes)
        incs.append((h[:, None] * np.einsum("i,jir->jr", w, es * P),
                     h[:, None] * np.einsum("i,jir->jr", w, (ec - c / 2 * es) * P)))
    err = np.maximum(np.abs(incs[0][0] - incs[1][0]), np.abs(incs[0][1] - incs[1][1])).max(axis=1).sum()
    return incs[0], float(err)


# ====================================================================== modal appropriation
@dataclass(frozen=True, eq=False)
class Appropriation:
    """The force pattern that drives one undamped mode alone (phase resonance).

    At ω = ω_r the generalized force F* = (ω_r C + D) φ_r gives exactly δq = −iφ_r: a pure quadrature
    response in the undamped mode shape, whatever the damping distribution, since (K − ω_r²M) φ_r = 0.
    When the exciters ``inputs`` can apply F* (``exact``), ``force`` is that pattern at ω_r. Otherwise
    ``force`` minimises the in-phase part of the response (multivariate mode indicator function: the
    smallest eigenvalue of Re Xᵀ Re X f = λ (Re Xᵀ Re X + Im Xᵀ Im X) f, X = Z(ω)⁻¹B) and ``omega`` is
    tuned to the minimum of λ near ω_r. The force is scaled so that the response's modal coordinate is −i.

    ``response``: computed δq (complex, nv) to ``force`` at ``omega``; ``in_phase`` = |Re δq| / |δq|
    (0 for a pure mode; √λ); ``mac``: MAC of Im δq with φ_r; ``residual``: backward residual of the solve.
    """

    mode: int
    omega: float
    omega_r: float
    force: np.ndarray
    inputs: tuple
    generalized_force: np.ndarray
    response: np.ndarray
    shape: np.ndarray
    in_phase: float
    mac: float
    exact: bool
    residual: float
    elapsed: float

    @property
    def frequency_hz(self):
        return self.omega / (2 * np.pi)


def appropriation(lin, mode, inputs=None, *, direction=None, damping=None):
    """Modal appropriation of mode ``mode`` (0-based, ascending ω) with exciters ``inputs`` (None: every
    coordinate; or coordinate names / body points with a direction) (:class:`Appropriation`)."""
    from scipy.optimize import minimize_scalar

    from .modal import mac

    start = time.perf_counter()
    model = _model(lin, damping)
    m = model.modes
    if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)) or not 0 <= mode < m.n:
        raise ModelError(f"appropriation: mode must be an index from 0 to {m.n - 1}, got {mode!r}")
    if m.rigid[mode] or m.unstable[mode]:
        raise ModelError(f"appropriation: mode {mode} is {'a rigid-body' if m.rigid[mode] else 'an unstable'} "
                         "mode; it has no resonance to appropriate")
    phi, wr = m.shapes[:, mode], float(m.omega[mode])
    target = (wr * model.C + model.D) @ phi
    if not np.any(target):
        raise ModelError(f"appropriation: mode {mode} is undamped; any force at its frequency is unbounded")
    cin = channels(lin, inputs, direction, "inputs")
    B = cin.matrix.T
    f, *_ = np.linalg.lstsq(B, target, rcond=None)
    exact = bool(np.linalg.norm(B @ f - target) <= 1e-10 * np.linalg.norm(target))
    w = wr
    if not exact:
        if np.linalg.matrix_rank(B) < B.shape[1]:
            raise ModelError(f"appropriation: the exciters {', '.join(cin.labels)} are not independent")

        def mmif(x):
            X = sla.solve(model.z(x), B.astype(complex))
            R, Im = X.real, X.imag
            lam, V = sla.eigh(R.T @ R, R.T @ R + Im.T @ Im)
            return lam[0], V[:, 0]

        others = np.delete(m.omega[~m.rigid], np.flatnonzero(m.omega[~m.rigid] == wr)[:1])
        gap = np.abs(others - wr).min(initial=wr)
        lo, hi = wr - 0.5 * min(gap, wr), wr + 0.5 * gap
        w = float(minimize_scalar(lambda x: mmif(x)[0], bounds=(lo, hi), method="bounded",
                                  options={"xatol": 1e-10 * wr}).x)
        f = mmif(w)[1]
    F = B @ f
    Z = model.z(w)
    x = sla.solve(Z, F.astype(complex))
    scale = -(phi @ lin.M @ x.imag)  # modal coordinate of the quadrature part: make it −i
    if not abs(scale) > 0:
        raise ModelError(f"appropriation: the exciters {', '.join(cin.labels)} cannot excite mode {mode}")
    f, F, x = f / scale, F / scale, x / scale
    res = float(np.linalg.norm(Z @ x - F) / (np.linalg.norm(Z) * np.linalg.norm(x) + np.linalg.norm(F)))
    return Appropriation(mode, w, wr, f, cin.labels, F, x, phi, float(np.linalg.norm(x.real) / np.linalg.norm(x)),
                         float(mac(x.imag, phi)), exact, res, time.perf_counter() - start)


# ====================================================================== command-line helpers (vibdyn frf)
def parse_channel(spec):
    """A CLI channel: a coordinate name, or BODY:X,Y,Z:DX,DY,DZ (a body point, in the body frame, m, and a
    direction in world axes)."""
    parts = spec.split(":")
    if len(parts) == 1:
        return spec
    if len(parts) != 3:
        raise ModelError(f"channel '{spec}': expected a coordinate name or BODY:X,Y,Z:DX,DY,DZ")
    return parts[0], _numbers(parts[1], spec), _numbers(parts[2], spec)


def frf_report(system, input_spec, output_spec, w0=None, w1=None, points=400, method="direct"):
    """The receptance (or, for ``support:NAME:DX,DY,DZ`` inputs, the transmissibility) between two channels
    at the scene's operating point: (FRF, peaks, half power, plain-data dict)."""
    from ._format import json_ready

    lin = system.operating_point().linearize()
    m = lin.modes()
    notes = []
    if m.stability == "unstable":
        notes.append("the operating point is unstable: no steady harmonic response exists; this is the transfer "
                     "function H(iω) of the linear model (as used in control design)")
    if w0 is None or w1 is None:
        w = m.omega[(~m.rigid) & (m.omega > 0)]  # unstable directions give their growth rate as the scale
        if w.size:
            lo, hi = 0.1 * w.min(), 2.0 * w.max()
        else:
            lo, hi = 0.1, 100.0
            notes.append("no natural frequency (every mode is rigid): default range 0.1 … 100 rad/s; "
                         "give --from and --to")
        w0 = lo if w0 is None else w0
        w1 = hi if w1 is None else w1
    if not (0 <= w0 < w1) or points < 3:
        raise ModelError(f"frf: need 0 ≤ --from < --to and --points ≥ 3, got {w0}, {w1}, {points}")
    omega = np.geomspace(w0, w1, points) if w0 > 0 else np.linspace(w0, w1, points)
    out = parse_channel(output_spec)
    if input_spec.startswith("support:"):
        parts = input_spec.split(":")
        if len(parts) not in (2, 3):
            raise ModelError(f"input '{input_spec}': expected support:NAME or support:NAME:DX,DY,DZ")
        d = _numbers(parts[2], input_spec) if len(parts) == 3 else (0.0, 0.0, 1.0)
        frf = lin.base_response(omega, parts[1], direction=d, outputs=[out], method=method)
    else:
        frf = lin.receptance(omega, [parse_channel(input_spec)], [out], method=method)
    peaks, hp = frf.peaks(), frf.half_power()
    data = json_ready({"scene": system.name, **frf.to_dict(), "peaks": peaks.to_dict(), "half_power": hp.to_dict(),
                       "units": frf.units(), "notes": notes})
    return frf, peaks, hp, data


def print_frf(frf, peaks, hp, out=None, notes=()):
    """Print a frequency response's summary: resonances with half-power ζ (undamped ones: unbounded, no
    band), anti-resonances, and ``notes``."""
    import sys

    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    p(f"{frf.kind} {frf.outputs[0]} / {frf.inputs[0]} ({frf.units()}), {frf.omega.size} frequencies "
      f"{frf.omega[0]:.6g} … {frf.omega[-1]:.6g} rad/s")
    p(f"method {frf.method}, damping {frf.damping}; residual {frf.residual:.1e}, error ≈ {frf.error:.1e}, "
      f"{frf.elapsed * 1e3:.1f} ms")
    for n in notes:
        p(f"note: {n}")
    p(f"{'':<16} {'omega rad/s':>14} {'f Hz':>12} {'|H|':>12} {'zeta (half power)':>18}")
    for w, a in zip(peaks.resonances, peaks.amplitudes):
        if not np.isfinite(a):
            p(f"{'resonance':<16} {w:>14.8g} {w / (2 * np.pi):>12.6g} {'unbounded':>12} {'0 (undamped)':>18}")
            continue
        i = np.flatnonzero(np.isclose(hp.omega_peak, w, rtol=1e-9))
        z = f"{hp.zeta[i[0]]:.6g}" if i.size else "-"
        p(f"{'resonance':<16} {w:>14.8g} {w / (2 * np.pi):>12.6g} {a:>12.6g} {z:>18}")
    for w, a in zip(peaks.antiresonances, peaks.antiresonance_amplitudes):
        p(f"{'anti-resonance':<16} {w:>14.8g} {w / (2 * np.pi):>12.6g} {a:>12.6g}")


def _numbers(text, spec):
    try:
        x = tuple(float(v) for v in text.split(","))
    except ValueError:
        x = ()
    if len(x) != 3:
        raise ModelError(f"channel '{spec}': '{text}' is not three comma-separated numbers")
    return x
