"""Modal analysis: natural frequencies (rad/s, Hz), mass-normalised shapes, damped complex modes, MAC.

Undamped modes solve K_s φ = ω² M φ (LAPACK's sygv, sygvd above 32 coordinates, through
``scipy.linalg.lapack``). With damping, gyroscopic or circulatory terms the first-order state form gives
complex eigenvalues λ = −ζω ± iω√(1−ζ²) and complex shapes.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike
from scipy.linalg import lapack

from .._check import all_finite, scalar, vector3
from .._deprecation import Renamed, RenamedKeyword
from ..defaults import EPS
from ..errors import ModelError
from ..solvers.tracking import mac  # noqa: F401  (vd.mac, and the modes' own use)

if TYPE_CHECKING:
    from .linearize import LinearModel



@dataclass(frozen=True, eq=False)
class Modes:
    """Modes of a linear model. Arrays are per mode, ascending in ω² (undamped) or |λ| (damped).

    ``omega2`` is signed: a negative ω² is an unstable direction (``unstable`` flag), with
    ``omega`` = √|ω²| then its growth rate (1/s). Rigid-body / cyclic modes have ω² cleaned to exactly 0
    (``rigid`` flag) when |ω²| is within 10 times its own uncertainty (see :func:`modes`).

    ``modal_mass`` = diag(ΦᵀMΦ) (1: mass-normalised shapes, to the eigensolver's round-off),
    ``modal_stiffness`` = diag(ΦᵀK_sΦ) = ω² (per unit modal mass) and ``orthogonality`` (the largest of
    |ΦᵀMΦ − 1| and |ΦᵀK_sΦ − Λ| / max|ω²|) are computed on first use, from the eigenproblem that was
    solved (kept in ``eigenproblem``).

    Errors (the error convention, docs/guide/names.md): ``omega_error`` (rad/s) and ``eigenvalue_error`` (1/s)
    are absolute; ``omega_relative_error``, ``eigenvalue_relative_error`` and ``relative_error`` (the largest of
    both) relative.
    """

    linear: LinearModel = field(repr=False)
    omega2: np.ndarray  # rad²/s²
    omega: np.ndarray  # rad/s
    shapes: np.ndarray  # nv × n, φᵀ M φ = 1
    rigid: np.ndarray
    unstable: np.ndarray
    omega_relative_error: np.ndarray  # estimated error of ω per mode (eigen residual + K's error), relative
    zero_threshold: float  # 1/s: state eigenvalues this small count as rigid/cyclic
    # damped / non-symmetric part (state form); empty when the model is undamped and symmetric
    eigenvalues: np.ndarray  # all 2nv state eigenvalues (1/s), sorted by |Im|, then Re
    damped_eigenvalues: np.ndarray  # one per mode: Im ≥ 0 of each pair, and the real ones
    zeta: np.ndarray  # damping ratio −Re λ / |λ| per damped mode
    omega_n: np.ndarray  # |λ| rad/s
    omega_d: np.ndarray  # |Im λ| rad/s
    eigenvalue_relative_error: np.ndarray  # estimated error of each damped eigenvalue, relative to |λ|
    complex_shapes: np.ndarray  # nv × m, largest component 1
    classical: bool  # C M⁻¹ K = K M⁻¹ C (proportional damping: real shapes diagonalise C)
    stability: str  # "stable", "unstable" or "neutral"
    elapsed: float  # s
    note: str = ""  # e.g. that an unresolved finite-difference model was replaced by the analytic one
    eigenproblem: tuple = field(default=(), repr=False)  # (M, K_s, Φ, ω², scale) of the solved eigenproblem
    #: per state eigenvalue: rigid/cyclic
    zero: np.ndarray = field(default_factory=lambda: np.zeros(0, bool), repr=False)
    #: per damped mode: rigid/cyclic
    damped_zero: np.ndarray = field(default_factory=lambda: np.zeros(0, bool), repr=False)
    #: 1/s, per state eigenvalue
    eigenvalue_uncertainty: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    #: estimated absolute error of ω per mode (rad/s; a rigid mode's: the √δω² its zero may hide)
    omega_error: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: estimated absolute error of each damped eigenvalue (1/s)
    eigenvalue_error: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: per damped mode: its eigenvalue is one of a pair repeated and not diagonalisable within the error (a
    #: defective pair, as at critical damping c = 2√(km)); its ``eigenvalue_error`` is the pair's ~√(|t| η) split
    defective: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    #: the reduced linear model the eigenproblem was solved on, where ``linear`` is its tree (a mechanism's or a held
    #: model's modes: shapes in the tree's coordinates); None when it is ``linear`` itself
    reduced: Any = field(default=None, repr=False)
    error = Renamed("relative_error")

    def verdict(self, ignore_zeros: int = 0) -> str:
        """Stability with ``ignore_zeros`` zero modes not counted (the cyclic coordinates of a steady motion)."""
        return classify(self.rigid, self.unstable, self.eigenvalues, self.zero, self.eigenvalue_uncertainty,
                        ignore_zeros)[0]

    @cached_property
    def _products(self):
        """(diag ΦᵀMΦ, diag ΦᵀK_sΦ, orthogonality residual) of the solved eigenproblem."""
        M, Ks, Phi, w2, scale = self.eigenproblem
        n = len(w2)
        Mm, Km = Phi.T @ (M @ Phi), Phi.T @ (Ks @ Phi)
        modal_m, modal_k = Mm.diagonal().copy(), Km.diagonal().copy()
        Mm.flat[::n + 1] -= 1.0  # now the residuals of ΦᵀMΦ = I and ΦᵀKΦ = diag(ω²)
        Km.flat[::n + 1] -= w2
        return modal_m, modal_k, float(max(np.abs(Mm).max(initial=0.0), np.abs(Km).max(initial=0.0) / scale))

    @property
    def modal_mass(self) -> np.ndarray:
        """diag(ΦᵀMΦ) per mode (kg, kg·m² per unit modal coordinate²: 1 for mass-normalised shapes)."""
        return self._products[0]

    @property
    def modal_stiffness(self) -> np.ndarray:
        """diag(ΦᵀK_sΦ) per mode (= ω², rad²/s², for mass-normalised shapes)."""
        return self._products[1]

    @property
    def orthogonality(self) -> float:
        """The largest of |ΦᵀMΦ − 1| and |ΦᵀK_sΦ − Λ| / max|ω²| (relative)."""
        return self._products[2]

    @property
    def frequency_hz(self):
        return self.omega / (2 * np.pi)

    @property
    def damped_frequency_hz(self):
        return self.omega_d / (2 * np.pi)

    @property
    def n(self):
        return self.omega.size

    @property
    def relative_error(self) -> float:
        """Largest estimated relative error of the frequencies and damped eigenvalues (per mode:
        ``omega_relative_error`` and ``eigenvalue_relative_error``)."""
        return float(max(self.omega_relative_error.max(initial=0.0), self.eigenvalue_relative_error.max(initial=0.0)))

    def sensitivity(self, params: Any) -> Any:
        """How each mode moves with each named scene parameter (``["k1.stiffness", "m1.mass"]``): a
        :class:`vibdyn.analysis.sensitivity.Sensitivity` (∂ω/∂p in rad/s per the parameter's unit, ∂ζ/∂p,
        shape derivatives, each with its absolute error)."""
        from .sensitivity import sensitivity

        return sensitivity(self, params)

    def participation(self, direction: ArrayLike, rotation: bool = False,
                      point: ArrayLike = (0.0, 0.0, 0.0)) -> np.ndarray:
        """Participation factor of each mode in a base excitation: Γ_r = φ_rᵀ L / φ_rᵀ M φ_r, with L the
        generalized inertia load of a unit base acceleration — a translation along ``direction`` (L = A_linᵀ
        d: √kg for mass-normalised shapes), or with ``rotation`` an angular acceleration about the axis
        ``direction`` through ``point`` (m; L = A_angᵀ a: √kg·m). See :meth:`vibdyn.System.momentum_matrix`."""
        return (self.shapes.T @ self._base_load(direction, rotation, point)) / self.modal_mass

    def effective_mass(self, direction: ArrayLike, rotation: bool = False,
                       point: ArrayLike = (0.0, 0.0, 0.0)) -> np.ndarray:
        """Effective modal mass of each mode in a base excitation (see :meth:`participation`): (φ_rᵀ L)² /
        φ_rᵀ M φ_r, kg for a translation (kg·m² for a rotation). Over all modes they sum to Lᵀ M⁻¹ L
        (:meth:`moved_mass`): for a fixed-base building shaken along its floors, the floors' total mass."""
        g = self.shapes.T @ self._base_load(direction, rotation, point)
        return g * g / self.modal_mass

    def moved_mass(self, direction: ArrayLike, rotation: bool = False, point: ArrayLike = (0.0, 0.0, 0.0)) -> float:
        """The mass (kg; kg·m² for a rotation) that the base excitation moves: Lᵀ M⁻¹ L in the motions the
        model has (a mechanism's: those its loops allow), the sum of every mode's effective mass (rigid modes
        included; the mass-normalised shapes are a complete basis, Φ Φᵀ = M⁻¹)."""
        return float(self.effective_mass(direction, rotation, point).sum())

    def _base_load(self, direction, rotation, point):
        d = vector3(direction, "direction")
        n = float(np.linalg.norm(d))
        if n == 0:
            raise ModelError("participation: direction must be a non-zero 3-vector (a translation, or with "
                             "rotation=True an axis)")
        lin = self.linear
        A_lin, A_ang = lin.system.momentum_matrix(lin.q, point)
        return (A_ang if rotation else A_lin).T @ (d / n)

    def response_spectrum(self, spectrum: Any, direction: ArrayLike, combination: str = "srss",
                          damping: Any = 0.05, **kwargs: Any) -> Any:
        """Peak responses to a ground motion along ``direction`` (the world and every support together) from a
        response ``spectrum`` of pseudo-acceleration S_a (m/s²) against period T (s) — a callable S_a(T), a table
        (periods, S_a), or a record's spectrum — combined by ``combination`` "srss", "cqc" (Der Kiureghian's
        ρ_ij with the ``damping`` ratios, one or one per mode) or "abs", with the missing-mass correction
        (:class:`vibdyn.analysis.response.seismic.SeismicResponse`; keywords ``n_modes``, ``missing_mass``,
        ``rigid_frequency`` Hz, ``zpa`` m/s², ``base`` m, ``axis``: see
        :func:`vibdyn.analysis.response.seismic.response_spectrum`)."""
        from .response.seismic import response_spectrum

        return response_spectrum(self, spectrum, direction, combination, damping, **kwargs)

    def point_shapes(self, points: list, direction: ArrayLike | None = None, complex: bool = False) -> np.ndarray:
        """Mode shapes as displacements (m per unit modal coordinate, world axes) of body points.

        ``points``: body names (origins) or (body, point) pairs. Returns (npoints, 3, n), or
        (npoints, n) along ``direction`` (3-vector). ``complex=True`` maps the damped complex shapes.
        """
        J = self.linear.point_jacobian(points)
        shapes = self.complex_shapes if complex else self.shapes
        S = (J @ shapes).reshape(len(points), 3, shapes.shape[1])
        if direction is None:
            return S
        d = np.asarray(direction, dtype=float)
        return np.einsum("pin,i->pn", S, d / np.linalg.norm(d))

    def plot(self, path: str | None = None, which: Any = None, amplitude: float | None = None, dpi: int = 100) -> Any:
        """Draw each mode (or those of ``which``, 0-based) as the deformed scene over the undeformed one, a
        panel per mode with its frequency (Hz, rad/s) in the title; saved as PNG when ``path`` is given. A scene
        that moves along its own line only (a chain of sliders on that line, a quarter car) is drawn as bar charts
        of its coordinates instead. ``amplitude``: largest point displacement (m; default 10 % of the scene's
        size). Returns the matplotlib Figure (see :func:`vibdyn.faces.viewer.pictures.plot_modes`)."""
        from ..faces.viewer.pictures import plot_modes

        return plot_modes(self, path=path, which=which, amplitude=amplitude, dpi=dpi)

    def to_dict(self) -> dict:
        """Plain data (JSON-ready): SI units, complex numbers as [re, im]; ``glossary`` says what each
        frequency is."""
        d = {"glossary": dict(GLOSSARY),
             "omega_rad_s": self.omega.tolist(), "frequency_hz": self.frequency_hz.tolist(),
             "omega2": self.omega2.tolist(), "rigid": self.rigid.tolist(), "unstable": self.unstable.tolist(),
             "shapes": self.shapes.tolist(), "coordinates": list(self.linear.coordinates),
             "stability": self.stability, "orthogonality_residual": self.orthogonality,
             "omega_error_rad_s": self.omega_error.tolist(), "relative_error": self.relative_error,
             "elapsed_s": self.elapsed}
        if self.note:
            d["note"] = self.note
        if self.eigenvalues.size:
            d.update({"eigenvalues": [[z.real, z.imag] for z in self.eigenvalues],
                      "zeta": self.zeta.tolist(), "omega_n_rad_s": self.omega_n.tolist(),
                      "omega_d_rad_s": self.omega_d.tolist(), "frequency_d_hz": self.damped_frequency_hz.tolist(),
                      "damped_eigenvalues": [[z.real, z.imag] for z in self.damped_eigenvalues],
                      "eigenvalue_error_1_s": self.eigenvalue_error.tolist(),
                      "classical_damping": self.classical})
        return d

    def __repr__(self):
        from .._format import duration, number, summary, values

        return summary("Modes", f"{self.n} modes", f"ω = {values(self.omega, 'rad/s')}",
                       f"f = {values(self.frequency_hz, 'Hz')}",
                       f"{int(self.rigid.sum())} rigid" if self.rigid.any() else "",
                       f"{int(self.unstable.sum())} unstable" if self.unstable.any() else "",
                       f"ζ = {values(self.zeta)}" if self.zeta.size else "", self.stability,
                       f"relative error {number(self.relative_error, digits=2)}", duration(self.elapsed))

    def _repr_html_(self):
        from .._format import html_table, number

        rows = [[i + 1, number(w), number(f), "rigid" if r else "unstable" if u else "", number(e, digits=2)]
                for i, (w, f, r, u, e) in enumerate(zip(self.omega, self.frequency_hz, self.rigid, self.unstable,
                                                        self.omega_error))]
        return html_table(f"{self.n} modes, {self.stability}", ["mode", "ω rad/s", "f Hz", "", "ω error rad/s"], rows)

    def __str__(self):
        lines = [f"{'mode':>4} {'ω rad/s':>14} {'f Hz':>12}  note (undamped: ω the undamped natural frequency)"]
        for i in range(self.n):
            note = "rigid" if self.rigid[i] else ("UNSTABLE: ω column is a growth rate, 1/s" if self.unstable[i]
                                                  else "")
            lines.append(f"{i + 1:>4} {self.omega[i]:>14.8g} {self.frequency_hz[i]:>12.6g}  {note}")
        if self.eigenvalues.size:
            lines.append(f"{'':>4} {'λ 1/s':>30} {'ζ':>10} {'ω_n rad/s':>12} {'ω_d rad/s':>12}  (damped)")
            for i, lam in enumerate(self.damped_eigenvalues):
                lines.append(f"{i + 1:>4} {lam.real:>14.8g}{lam.imag:>+14.8g}i {self.zeta[i]:>10.6g} "
                             f"{self.omega_n[i]:>12.8g} {self.omega_d[i]:>12.8g}")
        lines.append(f"stability {self.stability}; relative error ≈ {self.relative_error:.1e}; "
                     f"{self.elapsed * 1e3:.2f} ms")
        if self.note:
            lines.append(self.note)
        return "\n".join(lines)


#: what each frequency of a modal analysis is (the glossary, docs/guide/glossary.md; every output names its numbers so)
GLOSSARY = {
    "omega": "ω (rad/s): undamped natural frequency, from K_s φ = ω² M φ (damping and gyroscopic terms left out)",
    "frequency": "f = ω/2π (Hz), of the undamped ω",
    "omega_n": "ω_n = |λ| (rad/s): natural frequency of a damped (state-form) mode",
    "omega_d": "ω_d = |Im λ| = ω_n √(1 − ζ²) (rad/s): damped frequency, the one a free vibration oscillates at",
    "frequency_d": "f_d = ω_d/2π (Hz)",
    "zeta": "ζ = −Re λ / |λ|: damping ratio",
    "rate": "σ (1/s): growth (> 0) or decay rate of a mode that does not oscillate (a real λ, or ω² < 0): a "
            "rate, not a frequency",
}


#: largest eigenproblem solved by LAPACK's QR iterations (sygv); divide and conquer (sygvd) is faster beyond
#: (measured: 72.9 against 77.3 µs at n = 30, 9.6 against 10.0 µs at n = 10)
QR_LIMIT = 24


_TOLERANCE = RenamedKeyword("modes", "tolerance", "tol")


def modes(lin: Any, tol: float | None = None, *, tolerance: float | None = None) -> Modes:
    """Modes of a :class:`vibdyn.analysis.linearize.LinearModel`.

    A mode is rigid (ω² cleaned to exactly 0) when |ω²| ≤ 10 × its own uncertainty δω² — the eigen
    residual ‖Kφ − ω²Mφ‖_M⁻¹ plus φᵀ(K's error estimate + n·ε·|K|)φ — so stiff spectra keep their genuine
    low modes. ``tol`` (relative to max|ω²|) overrides this with a fixed threshold (``tolerance``: its former
    name).

    A finite-difference model cannot tell a rigid mode from a soft one whose ω² is below its round-off
    (stiffness ratios ~1e12): when the "fd" model flags a rigid mode, the analytic model at the same point
    checks it; if that one resolves the mode, its modes are returned (``linear`` is then the analytic model)
    and ``note`` says so.
    """
    return _modes(lin, _TOLERANCE(tol, tolerance))


def _modes(lin: Any, tolerance: float | None = None, rigid_only: bool = False) -> Any:
    """:func:`modes`; with ``rigid_only``, the rigid flags alone (the undamped problem solved, nothing else:
    what the check of a finite-difference model's rigid modes compares)."""
    start = time.perf_counter()
    if tolerance is not None:
        tolerance = scalar(tolerance, "modes tol", nonnegative=True)
    M, K, Ke = lin.M, lin.K, lin.K_error
    Kt = K.T
    Ks = K + Kt
    Ks *= 0.5  # lin.K_s
    n = M.shape[0]
    # LAPACK directly (on small models the wrappers of numpy and scipy cost more than the solves): sygv(d)
    # factors M = LLᵀ (uplo "L", scipy's default), left in the lower triangle of its copy of M, and solves the
    # symmetric problem of L⁻¹ Ks L⁻ᵀ (QR iterations while small, divide and conquer beyond)
    L = M.copy(order="F")
    if n:
        w2, Phi, info = (lapack.dsygv if n <= QR_LIMIT else lapack.dsygvd)(Ks, L, overwrite_b=1)
    else:
        w2, Phi, info = np.zeros(0), np.zeros((0, 0)), 0
    # finite inputs give finite shapes; a non-finite one shows in w2 or, through |Φ|, in the uncertainty below
    if info or not all_finite(w2):
        lin.system.check_mass_matrix(lin.q, "the operating point")
        raise ModelError("modal analysis: the generalized eigenproblem (K, M) failed")
    scale = max(abs(w2[0]), abs(w2[-1]), 1e-300) if n else 1e-300  # w2 is ascending
    # shapes mass-normalised by sygv (φᵀMφ = 1 to its round-off, which ``orthogonality`` reports), with a
    # reproducible sign: the largest component positive (−min > max, i.e. min + max < 0, flips; a tie keeps +)
    if n:
        Phi *= np.copysign(1.0, np.minimum.reduce(Phi) + np.maximum.reduce(Phi))
    # δω² per mode: the eigen residual in the M⁻¹ norm (‖R‖²_M⁻¹ = ‖L⁻¹R‖²), and |φ|ᵀ(K's error + n·ε·|K|)|φ|
    # (a quadratic form: K's error needs no symmetrising)
    R = Ks.dot(Phi) - M.dot(Phi) * w2  # (ndarray.dot: half matmul's fixed cost on small matrices)
    LR = lapack.dtrtrs(L, R, lower=1)[0] if n else R
    A = np.abs(Phi)
    abs_Ks = np.abs(Ks)
    abs_w2 = np.abs(w2)
    # M's own round-off (n·ε|M|: CRBA sums the bodies' inertias) moves ω² by |ω²| |φ|ᵀ(n·ε|M|)|φ|: on an
    # ill-conditioned M (masses 1e-6 and 1e6 in series) |φ|ᵀ|M||φ| ≫ φᵀMφ = 1; it joins K's quadratic form
    # (one sum over both: |φ|ᵀ(|M| |φ| n·ε|ω²| + (K's error + n·ε·|K|)|φ|))
    X = np.abs(M).dot(A * ((n * EPS) * abs_w2))
    terms = getattr(lin, "K_error_terms", None)
    if terms is None:
        X += ((n * EPS) * abs_Ks + Ke).dot(A)
        quadratic = np.add.reduce(A * X)
    else:  # rank-one parts of K's error: a mode that does not stretch a spring takes none of its rounding
        U, V = terms
        base = np.maximum(Ke - np.abs(U).T @ V, 0.0)
        X += ((n * EPS) * abs_Ks + base).dot(A)
        quadratic = np.add.reduce(A * X) + np.add.reduce(np.abs(U @ Phi) * (V @ A))
    # (einsum's sum of squares overflows to inf without a warning: caught below and scaled)
    uncertainty = np.sqrt(np.einsum("ij,ij->j", LR, LR))
    uncertainty += quadratic
    if not all_finite(uncertainty):  # the squares overflowed (huge ω²)? the same, column by column scaled
        r = np.abs(R).max(axis=0, initial=0.0)
        LR = lapack.dtrtrs(L, R / np.maximum(r, 1e-300), lower=1)[0]
        uncertainty = r * np.sqrt(np.add.reduce(LR * LR)) + quadratic
        if not all_finite(uncertainty):
            raise ModelError("modal analysis: the frequencies or their error estimate overflow (scene scales "
                             f"too extreme: max |ω²| = {scale:.3g} rad²/s²)")
    if tolerance is None:
        rigid = abs_w2 <= 10 * uncertainty
        n_rigid = np.count_nonzero(rigid)
        if lin.method == "fd" and n_rigid:
            analytic = lin.relinearize("analytic")
            # (an analytic model the guard refused comes back as finite differences: nothing to compare with)
            exact_rigid = _modes(analytic, rigid_only=True) if analytic.method == "analytic" else rigid
            if exact_rigid.sum() != rigid.sum():  # the analytic model resolves what FD could not
                exact = _modes(analytic)
                why = (f"{int(rigid.sum() - exact.rigid.sum())} mode(s) unresolved by finite differences (ω² "
                       "within their round-off): modes from the analytic linear model")
                return replace(exact, note="; ".join(x for x in (why, exact.note) if x))
    else:
        rigid = abs_w2 <= float(tolerance) * scale
        n_rigid = np.count_nonzero(rigid)
    if rigid_only:
        return rigid
    any_rigid = n_rigid > 0
    if any_rigid:
        # (a rigid mode's error covers the ω² set to zero as well: the truth is near what was computed)
        cleaned = uncertainty + np.where(rigid, abs_w2, 0.0)
        w2 = np.where(rigid, 0.0, w2)
        if np.any(w2[1:] < w2[:-1]):  # (zeroed above a resolved mode, at stiffness ratios ~1e16: ascending again)
            order = np.argsort(w2, kind="stable")
            w2, Phi, rigid, uncertainty, cleaned = w2[order], Phi[:, order], rigid[order], uncertainty[order], \
                cleaned[order]
        abs_w2 = np.abs(w2)
    unstable = w2 < 0
    omega = np.sqrt(abs_w2)
    # relative error of ω per mode (half that of ω²); a rigid mode's, relative to the spectrum's scale (or,
    # when every mode is rigid, to the largest |ω²| that still counts as rigid); a rigid mode's zero may
    # split by ±√δω² in the state form (a Jordan block): that is still zero
    if any_rigid:
        rigid_scale = max(scale, 10 * uncertainty.max(initial=0.0))
        rel = np.where(rigid, cleaned / rigid_scale, 0.5 * uncertainty / np.where(rigid, 1.0, abs_w2))
        zero_threshold = float(np.sqrt(10 * uncertainty[rigid].max(initial=0.0))) + 1e-12 * np.sqrt(scale)
    else:
        rel = 0.5 * uncertainty / abs_w2
        zero_threshold = 1e-12 * math.sqrt(scale)

    # circulatory: |K − Kᵀ| = 2|N| beyond 10 × its error (K's symmetrised error bound, twice)
    damped = lin.has_damping
    if not damped and n:
        N2 = K - Kt
        np.abs(N2, out=N2)
        sym_floor = 2e-13 * np.maximum.reduce(abs_Ks, axis=None)
        if 0.1 * np.maximum.reduce(N2, axis=None) > sym_floor:  # (else within it before K's errors are taken off)
            N2 *= 0.1
            N2 -= Ke
            N2 -= Ke.T
            damped = bool(np.maximum.reduce(N2, axis=None) > sym_floor)
    if damped:
        A, Mi, MiK, MiC = _state_matrix(lin, L)
        lam, lam_modes, shapes_c, lam_error, lam_abs, modes_abs, defective = _state_modes(lin, A, Mi)
        mag = np.abs(lam_modes)
        # an eigenvalue is zero (rigid or cyclic) when it is within 10 × its own uncertainty of 0 (or at
        # round-off of the largest): a genuine slow mode (a precession at 0.0025 rad/s beside a spin of 1e6)
        # keeps its value. A rigid mode's zero is a Jordan block (x = a + b t; left and right eigenvectors
        # orthogonal) split by round-off: first-order perturbation gives it a large uncertainty, so it counts
        # as zero, and its error is then the split that still counts as zero
        lam_scale = max(mag.max(initial=0.0), 1e-300)
        floor = 1e-12 * lam_scale
        zero = np.abs(lam) <= np.maximum(10 * lam_abs, floor)
        zero_modes = mag <= np.maximum(10 * modes_abs, floor)
        # (the floor is known as the largest |λ| is: M's round-off at masses 1e-6 and 1e6 moved it by 4e-6)
        zero_threshold = float(mag[zero_modes].max(initial=floor)) + floor * float(lam_error[np.argmax(mag)])
        lam_error = np.where(zero_modes, np.minimum(lam_error, zero_threshold / lam_scale), lam_error)
        zeta = np.where(mag > 0, -lam_modes.real / np.where(mag > 0, mag, 1.0), 0.0)
        classical = _is_classical(lin, MiK, MiC)
        omega_d = np.abs(lam_modes.imag)
    else:
        lam = lam_modes = _NO_COMPLEX
        lam_error = mag = zeta = omega_d = lam_abs = _NO_REAL
        lam_scale = 1.0
        zero = zero_modes = defective = _NO_BOOL
        shapes_c = np.zeros((n, 0), complex)
        classical = True
    stability, within = classify(rigid, unstable, lam, zero, lam_abs)
    note = ""
    if within:
        note = (f"growth rate {within[0]:.2g} 1/s within its own error {within[1]:.2g} 1/s: neutral within the "
                "error, not unstable")
    if damped and defective.any():
        listed = ", ".join(str(i + 1) for i in np.flatnonzero(defective))
        note += ("; " if note else "") + (
            f"damped modes {listed}: a repeated eigenvalue λ = {lam_modes[defective][0]:.6g} 1/s, not diagonalisable "
            "within the error (a defective pair: critical damping, or two modes coalescing): its modes are one, "
            "its shape and its derivatives not defined there")
        if stability == "stable" and np.any(lam_modes.real[defective] >= -(lam_error * mag)[defective]):
            # (on the imaginary axis a Jordan block grows as t: bounded no more, nor unstable beyond the error)
            stability = "neutral"
            note += "; that pair is on the imaginary axis within its error (it grows as t there): neutral"
    return Modes(lin, w2, omega, Phi, rigid, unstable, rel, zero_threshold, lam, lam_modes, zeta, mag, omega_d,
                 lam_error, shapes_c, bool(classical), stability, time.perf_counter() - start, note,
                 eigenproblem=(M, Ks, Phi, w2, scale), zero=zero, damped_zero=zero_modes,
                 eigenvalue_uncertainty=lam_abs,
                 omega_error=np.where(rigid, np.sqrt(cleaned), rel * omega) if any_rigid else rel * omega,
                 # (a zero eigenvalue's relative error is relative to the largest |λ|)
                 eigenvalue_error=lam_error * np.where(zero_modes, lam_scale, mag),
                 defective=defective)


_NO_REAL, _NO_COMPLEX, _NO_BOOL = np.zeros(0), np.zeros(0, complex), np.zeros(0, bool)  # undamped: no state form
_NO_REAL.flags.writeable = _NO_COMPLEX.flags.writeable = _NO_BOOL.flags.writeable = False


def rayleigh(zeta: ArrayLike, omega: ArrayLike) -> tuple[float, float]:
    """(α, β) of Rayleigh damping C = αM + βK with ratios ζ = (ζ1, ζ2) at ω = (ω1, ω2) rad/s:
    ζ_i = α/(2ω_i) + βω_i/2."""
    from .._check import finite_array

    z = finite_array(zeta, (2,), "rayleigh: damping ratios zeta")
    w = finite_array(omega, (2,), "rayleigh: frequencies omega (rad/s)")
    if not np.all(np.isfinite(z)) or not np.all(np.isfinite(w)) or np.any(w <= 0) or w[0] == w[1] or np.any(z < 0):
        raise ModelError(f"rayleigh: need two distinct positive frequencies and finite ratios ≥ 0, got {omega!r}, "
                         f"{zeta!r}")
    A = np.array([[1 / (2 * w[0]), w[0] / 2], [1 / (2 * w[1]), w[1] / 2]])
    alpha, beta = np.linalg.solve(A, z)
    return float(alpha), float(beta)


#: the eigensolver's backward error per pair is trusted up to this many × (2n)ε‖A‖ (LAPACK's promise, with room)
BACKWARD_FACTOR = 1e3


def _state_matrix(lin, L):
    """(A, M⁻¹, M⁻¹K, M⁻¹C): ``lin.A`` and the inverse of M from L, M's Cholesky factor that sygv left (its lower
    triangle): the state matrix's solves with the factor already made."""
    n = lin.nv
    MiK, info = lapack.dpotrs(L, lin.K, lower=1)
    MiC, info_c = lapack.dpotrs(L, lin.C, lower=1)
    Mi, info_i = lapack.dpotrs(L, np.eye(n), lower=1)
    if info or info_c or info_i or not (all_finite(MiK) and all_finite(MiC)):
        A = lin.A  # (its own solves, which say what failed)
        return A, np.linalg.inv(lin.M), -A[n:, :n], -A[n:, n:]
    A = np.zeros((2 * n, 2 * n))
    A.ravel()[n:2 * n * n:2 * n + 1] = 1.0  # the identity block A[:n, n:]
    np.negative(MiK, out=A[n:, :n])
    np.negative(MiC, out=A[n:, n:])
    return A, Mi, MiK, MiC


def _state_modes(lin, A, Mi):
    """State eigenvalues (all, and one per mode), complex shapes, each mode's estimated relative error, and
    the absolute uncertainties (1/s) of all eigenvalues and of the modes': first-order perturbation
    |wᴴ δA v| / |wᴴ v| with δA from the error estimates of K and C (and the round-off of the eigensolver), w
    and v the left and right eigenvectors. ``A``: the state matrix, ``Mi``: M⁻¹."""
    n, M = lin.nv, lin.M
    Minv = np.abs(Mi)
    abs_A = np.abs(A)
    E = 2 * n * EPS * abs_A
    E[n:, :n] += Minv.dot(lin.K_error)
    E[n:, n:] += Minv.dot(lin.C_error)
    size = abs_A.sum(axis=0).max()
    abs_M = np.abs(M)
    for qz in (False, True):
        lam, W, V = sla.eig(A, np.eye(len(A)) if qz else None, left=True, right=True)
        aW, aV, Wc = np.abs(W), np.abs(V), W.conj()
        eta = np.einsum("ij,ij->j", aW, E.dot(aV))
        wv = np.maximum(np.abs(np.einsum("ij,ij->j", Wc, V)), 1e-300)
        # M's own round-off δM (n·ε|M|, and that of solving M⁻¹[K C] for A) moves A's rows by M⁻¹δM M⁻¹[K C], and
        # wᴴδA v = −λ² yᴴ δM v₁ with y = M⁻¹w₂ (the left vector of λ²M + λC + K): on an ill-conditioned M
        # (masses 1e-6 and 1e6 in series) far more than ε|A|, yet not on the slow modes
        mag = np.abs(lam)
        # (|λ|² beyond the floats: no such term is measurable, left to the backward error below)
        with np.errstate(over="ignore", invalid="ignore"):
            mass = (n * EPS * mag) * (mag * np.einsum("ij,ij->j", np.abs(Mi.dot(W[n:])), abs_M.dot(aV[:n])))
            # the pairs' own backward errors ‖Av − λv‖ / (‖A‖ ‖v‖): the QR algorithm is not always as accurate as
            # it promises (LAPACK's caps a gyroscopic λ near 1.5e138 at higher spins), the QZ one then is; a pair
            # neither resolves says so through its residual (‖w‖ / |wᴴv| × it); and its Newton step
            # wᴴ(Av − λv) / wᴴv, the eigensolver's error on a badly scaled A (rows of k1/m1 = 1e12 beside 1e-12:
            # a slow pair of those sliders 1 % off, ± 0.3 % from ε|A|)
            R = A.dot(V) - V * lam
            residual = np.abs(R).sum(axis=0)
            resolved = residual <= BACKWARD_FACTOR * len(A) * EPS * size * aV.sum(axis=0)
            newton = 2 * np.abs(np.einsum("ij,ij->j", Wc, R)) / wv
            if not all_finite(mass + newton):  # (both ≥ 0: a sum is finite where each is)
                mass[~np.isfinite(mass)] = 0.0
                newton[~np.isfinite(newton)] = 0.0
        eta += mass
        dlam = eta / wv
        dlam += newton
        if resolved.all():
            break
        failed = ~resolved
        if qz:
            with np.errstate(over="ignore", invalid="ignore"):
                bound = residual * aW.sum(axis=0) / wv
            dlam = np.where(failed, np.maximum(dlam, np.where(np.isfinite(bound), bound, np.inf)), dlam)
    defective = _defective_pairs(A, E, lam, dlam, eta)
    scale = max(np.abs(lam).max(initial=0.0), 1e-300)
    computed = lam
    lam = np.where(np.abs(lam.imag) <= 1e-12 * scale, lam.real + 0j, lam)
    lam = np.where(np.abs(lam) <= 1e-12 * scale, 0j, lam)
    dlam += np.abs(computed - lam)  # (what was cleaned away: the truth is near what was computed)
    order = np.lexsort((lam.real, np.abs(lam.imag)))
    lam, V, dlam, defective = lam[order], V[:, order], dlam[order], defective[order]
    keep = lam.imag >= 0  # one of each conjugate pair, and the real eigenvalues
    lm, Vm, dm, dfm = lam[keep], V[:n, keep], dlam[keep], defective[keep]
    order = np.argsort(np.abs(lm), kind="stable")
    lm, Vm, dm, dfm = lm[order], Vm[:, order], dm[order], dfm[order]
    big = np.argmax(np.abs(Vm), axis=0)
    piv = Vm[big, np.arange(Vm.shape[1])]
    Vm = Vm / np.where(np.abs(piv) > 0, piv, 1.0)
    rel = dm / np.where(np.abs(lm) > 0, np.abs(lm), scale)
    return lam, lm, Vm, rel, dlam, dm, dfm


def invariant_pair(A, mu, radius, count=2):
    """(Y, Z, T₁₁) of the ``count`` eigenvalues of A within ``radius`` of ``mu`` (None unless exactly that many): Z
    (2n × count) an orthonormal basis of their invariant subspace, Y (count × 2n) the left one with Y Z = I (the
    spectral projector Z Y), T₁₁ = Y A Z their upper triangular Schur block."""
    T, Z, sdim = sla.schur(A, output="complex", sort=lambda z: abs(z - mu) <= radius)
    if sdim != count:
        return None
    c = count
    X = sla.solve_sylvester(T[:c, :c], -T[c:, c:], T[:c, c:]) if T.shape[0] > c else np.zeros((c, 0))
    return np.hstack([np.eye(c), -X]) @ Z.conj().T, Z[:, :c], T[:c, :c]


#: a pair whose split s satisfies s² ≤ DEFECTIVE_FACTOR · |t| η (t its Jordan coupling, η the size of A's error
#: on it) coalesces within the error: repeated and not diagonalisable (as a rigid mode is "within 10 × its error")
DEFECTIVE_FACTOR = 10.0


def _defective_pairs(A, E, lam, dlam, eta):
    """Per eigenvalue of A: one of a pair that is repeated and not diagonalisable within the error (a Jordan
    block: critical damping). ``dlam`` (first-order uncertainties, 1/s) is corrected in place for such a pair: a
    perturbation η of a Jordan block of coupling t splits it by ~√(|t| η), which first-order theory (∝ 1/|wᴴv|,
    unbounded there) cannot say.

    Only pairs whose first-order discs overlap are examined (the ordered complex Schur form of A, the pair first,
    gives its 2×2 block [[a, t], [0, b]] and, through the Sylvester equation of the spectral projector, its left
    basis, so η is the block's own error); pairs at zero within √(‖A‖ η) are left to the rigid-mode test."""
    m = lam.size
    defective = np.zeros(m, bool)
    # pairs inside each other's first-order uncertainty (an exact eigenvalue, δλ = 0, is no pair's); the usual
    # case, every eigenvalue told apart, costs this much alone
    close = np.abs(np.subtract.outer(lam, lam)) < np.add.outer(dlam, dlam)
    if np.count_nonzero(close) == np.count_nonzero(dlam):  # (the diagonal: each uncertain eigenvalue with itself)
        return defective
    ii, jj = np.nonzero(close)
    # (a rigid or cyclic zero, within a Jordan block's split of it, is the rigid-mode test's)
    with np.errstate(over="ignore"):  # (√‖A‖ √η: no product overflows at extreme scales; an infinite ‖A‖, no pair)
        size = np.sqrt(np.abs(A).sum(axis=0).max())
    pairs = (ii < jj) & (np.abs(lam[ii] + lam[jj]) > 20 * size * np.sqrt(np.maximum(eta[ii], eta[jj])))
    done = np.zeros(m, bool)
    for i, j in zip(ii[pairs], jj[pairs]):
        if done[i] or done[j]:
            continue
        mu, half = 0.5 * (lam[i] + lam[j]), 0.5 * abs(lam[i] - lam[j])
        others = np.delete(np.abs(lam - mu), [i, j])
        members = np.array([i, j])
        pair = invariant_pair(A, mu, 0.5 * (half + others.min(initial=np.inf)) if others.size else np.inf)
        if pair is None:  # (more coalesce: several Jordan blocks at one λ, two critically damped oscillators alike)
            members = np.flatnonzero(np.abs(lam - mu) <= np.maximum(dlam, dlam[[i, j]].max()))
            far = np.delete(np.abs(lam - mu), members)
            reach = 0.5 * (np.abs(lam[members] - mu).max() + far.min(initial=np.inf)) if far.size else np.inf
            pair = invariant_pair(A, mu, reach, members.size) if members.size > 2 and not done[members].any() else None
            if pair is None:
                continue
        done[members] = True
        Y, Z, T = pair
        t = np.abs(np.triu(T, 1)).max()
        eta2 = float((np.abs(Y) @ E @ np.abs(Z)).max())
        split = np.abs(np.diag(T) - np.diag(T).mean()).max()
        if t > DEFECTIVE_FACTOR * eta2 and split**2 <= DEFECTIVE_FACTOR * t * eta2:
            defective[members] = True
            dlam[members] = np.sqrt(split**2 + t * eta2) + eta2
    return defective


def classify(rigid, unstable, eigenvalues, zero, uncertainty, ignore_zeros=0):
    """(verdict, within): "stable", "unstable" or "neutral" from the undamped flags, or from the state
    eigenvalues if any; ``within`` = (growth rate, its uncertainty) (1/s) of the largest growth found within
    its own error (which is then no verdict of instability: "neutral within the error"), else None.

    State eigenvalues flagged ``zero`` are rigid/cyclic; up to ``ignore_zeros`` of them (zero modes of cyclic
    positions in a steady motion) do not make the point neutral. A real part above its ``uncertainty``
    (1/s, per eigenvalue) is a growth; other eigenvalues on the imaginary axis are undamped oscillations:
    bounded, so stable (in the linear sense).
    """
    if eigenvalues.size == 0:
        if np.count_nonzero(unstable):
            return "unstable", None
        return ("neutral" if np.count_nonzero(rigid) > ignore_zeros else "stable"), None
    scale = max(np.abs(eigenvalues).max(initial=0.0), 1e-300)
    growth = eigenvalues.real > 1e-10 * scale
    if np.any(growth & ~zero & (eigenvalues.real > uncertainty)):
        return "unstable", None
    within = growth & ~zero
    if within.any():  # a growth rate inside its own error: not a verdict
        k = int(np.argmax(np.where(within, eigenvalues.real, -np.inf)))
        return "neutral", (float(eigenvalues[k].real), float(uncertainty[k]))
    return ("neutral" if zero.sum() > ignore_zeros else "stable"), None  # an undamped oscillation is bounded


def _is_classical(lin, MiK, MiC):
    C, K = lin.C, lin.K
    CMK = C.dot(MiK)
    X = CMK - K.dot(MiC)
    return bool(np.abs(X).max() <= 1e-8 * max(np.abs(CMK).max(), 1e-300))

