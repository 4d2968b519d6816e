"""Response-spectrum analysis: peak responses to a ground motion from a design or record spectrum, mode by
mode, combined by SRSS, CQC (Der Kiureghian 1981) or absolute sum, with the missing-mass correction.

The ground (the world and every support, together) moves along ``d``; in its frame every body feels the
inertial load −L ü_g, L = A_linᵀ d (the momentum matrix: the generalized load of a unit ground acceleration),
so the coordinates (relative to the ground) obey M ü + C u̇ + K u = −M r ü_g with the influence vector
r = M⁻¹ L (for floors on sliders along d: r = 1, each coordinate follows a rigid ground translation one to one).
With mass-normalised modes, Γ_n = φ_nᵀ M r and mode n peaks at u_n = Γ_n φ_n S_a(T_n)/ω_n². The modes left out
respond rigidly (their periods are short): u_rigid = (K⁻¹ L − Σ_kept Γ_n φ_n/ω_n²) · S_a(0) (the missing mass),
added to the modes above ``rigid_frequency`` algebraically and combined with the others by SRSS.

SRSS, CQC and ABS are combination rules: estimates of the peak of a sum from the peaks of its terms; their own
error is not estimated (for well-separated modes SRSS and CQC agree; for close modes SRSS can be far off). The
error estimates propagate the modal errors (frequencies, shapes, the spectrum's slope) through the rule.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..._check import finite_array, integer, scalar, unit_axis
from ...defaults import EPS
from ...errors import ModelError
from ...solvers.differences import secant

COMBINATIONS = ("srss", "cqc", "abs")


def correlation(omega: ArrayLike, zeta: ArrayLike) -> np.ndarray:
    """Der Kiureghian's modal correlation coefficients ρ_ij (n × n) for frequencies ω (rad/s) and damping
    ratios ζ (one, or one per mode): ρ_ij = 8√(ζ_iζ_j)(ζ_i + βζ_j)β^{3/2} / ((1 − β²)² + 4ζ_iζ_jβ(1 + β²)
    + 4(ζ_i² + ζ_j²)β²), β = ω_j/ω_i; for equal ζ, 8ζ²(1 + β)β^{3/2} / ((1 − β²)² + 4ζ²β(1 + β)²)."""
    w = np.asarray(omega, float)
    z = np.broadcast_to(np.asarray(zeta, float), w.shape)
    b = w[None, :] / w[:, None]
    zi, zj = z[:, None], z[None, :]
    num = 8 * np.sqrt(zi * zj) * (zi + b * zj) * b ** 1.5
    den = (1 - b * b) ** 2 + 4 * zi * zj * b * (1 + b * b) + 4 * (zi * zi + zj * zj) * b * b
    rho = np.divide(num, den, out=np.zeros_like(num), where=den > 0)
    np.fill_diagonal(rho, 1.0)
    return rho


def spectrum_function(spectrum, what="response spectrum"):
    """(S_a(T) vectorised m/s², its description, the value at T = 0 or None, slope dS_a/dT) of a spectrum: a
    callable of the period (s), a table (periods s, S_a m/s²) (two rows — a tuple (periods, S_a) always —, or
    n × 2; a 2 × 2 list only where one reading has increasing periods), or a record's spectrum (an object with
    ``periods`` and ``pseudo_acceleration``), interpolated linearly in T."""
    error = None
    if hasattr(spectrum, "pseudo_acceleration_spectrum"):  # a record, not its spectrum
        raise ModelError(f"{what}: got a record; pass its spectrum, record.pseudo_acceleration_spectrum(periods, "
                         "damping), on periods from 0 s past the longest mode's")
    if hasattr(spectrum, "periods") and hasattr(spectrum, "pseudo_acceleration"):
        if hasattr(spectrum, "error"):  # a record's spectrum: its own error estimate, interpolated alike
            error = (np.asarray(spectrum.periods, float), np.asarray(spectrum.error, float))
        spectrum = (spectrum.periods, spectrum.pseudo_acceleration)
    if callable(spectrum):
        def S(T):
            T = np.atleast_1d(np.asarray(T, float))
            try:
                out = np.array([float(spectrum(float(t))) for t in T])
            except (TypeError, ValueError, ArithmeticError) as e:
                raise ModelError(f"{what}: the spectrum callable failed at T = {T.tolist()} s ({e})") from None
            bad = ~np.isfinite(out) | (out < 0)
            if bad.any():
                raise ModelError(f"{what}: the spectrum callable gave {float(out[bad][0])!r} at T = {T[bad][0]:g} s "
                                 "(pseudo-accelerations must be finite and ≥ 0, m/s²)")
            return out

        def slope(T):
            h = 1e-6 * np.maximum(T, 1e-3)
            return secant(S, np.maximum(T - h, 0), T + h)  # (central; one-sided at T = 0)

        try:
            zero = float(S(0.0)[0])
        except ModelError:
            zero = None
        return S, "a function of the period", zero, slope
    rows = isinstance(spectrum, tuple) and len(spectrum) == 2  # the documented (periods, S_a): two rows
    arr = finite_array(spectrum, None, f"{what}: table (periods s, pseudo-accelerations m/s²)")
    if arr.shape == (2, 2) and not rows:  # two rows (periods; S_a) or two (period, S_a) pairs: read it if one fits
        fits = [bool(x[0, 0] >= 0 and x[0, 1] > x[0, 0] and np.all(x[1] >= 0)) for x in (arr, arr.T)]
        if all(fits) and not np.array_equal(arr, arr.T):
            raise ModelError(f"{what}: the 2 × 2 table {arr.tolist()} reads both as two rows (periods; "
                             "pseudo-accelerations) and as two (period, pseudo-acceleration) pairs; add a third "
                             "period (a point on the line between the two changes nothing)")
        arr = arr.T if fits[1] and not fits[0] else arr
    elif arr.ndim == 2 and arr.shape[1] == 2 and not (rows and arr.shape[0] == 2):
        arr = arr.T
    if arr.ndim != 2 or arr.shape[0] != 2 or arr.shape[1] < 2:
        raise ModelError(f"{what}: expected a callable of the period, or a table of periods (s) and "
                         f"pseudo-accelerations (m/s²) with at least two rows, got shape {arr.shape}")
    T, Sa = arr
    if np.any(T < 0) or np.any(np.diff(T) <= 0):
        raise ModelError(f"{what}: the table's periods must be ≥ 0 and strictly increasing (s), got {T.tolist()}")
    if np.any(Sa < 0):
        raise ModelError(f"{what}: the table's pseudo-accelerations must be ≥ 0 (m/s²), got {Sa[Sa < 0][0]:g}")

    def S_table(x):
        x = np.atleast_1d(np.asarray(x, float))
        out = (x < T[0] - 1e-12 * T[-1]) | (x > T[-1] * (1 + 1e-12))
        if out.any():
            raise ModelError(f"{what}: period {x[out][0]:.6g} s is outside the table ({T[0]:g} … {T[-1]:g} s); "
                             "extend the table, or keep fewer modes (n_modes=)")
        return np.interp(x, T, Sa)

    def slope_table(x):
        k = np.clip(np.searchsorted(T, x) - 1, 0, T.size - 2)
        slope = np.abs((Sa[k + 1] - Sa[k]) / (T[k + 1] - T[k]))
        if error is not None:  # (returned as a slope: the caller multiplies by δT; add the table's own error)
            return slope, np.interp(x, *error)
        return slope

    return S_table, f"a table of {T.size} periods {T[0]:g} … {T[-1]:g} s", float(Sa[0]), slope_table


@dataclass(frozen=True, eq=False)
class SeismicResponse:
    """Peaks of a response-spectrum analysis (:meth:`vibdyn.analysis.modal.Modes.response_spectrum`).

    Per kept mode (``n_modes`` of them, numbered from 1 in tables): ``periods`` T_n (s), ``omega`` ω_n (rad/s,
    undamped), ``participation`` Γ_n (√kg), ``effective_mass`` Γ_n² (kg), ``spectral_acceleration``
    S_a(T_n) (m/s²), ``spectral_displacement`` S_a/ω_n² (m), ``modal_displacement`` (n × nv: Γ_n φ_n S_a/ω_n²,
    m or rad), ``modal_base_shear`` (N), ``modal_overturning_moment`` (N·m). ``rigid_displacement`` (nv): the
    missing mass's rigid response plus the rigid modes', at ``zpa`` (m/s², the spectrum at T = 0).

    Combined peaks with their estimated absolute errors (modal errors propagated; the rule's own error is not
    estimated): ``displacement`` (per coordinate, m or rad, relative to the ground), ``base_shear`` (N, along
    the ground motion), ``overturning_moment`` (N·m, about ``axis`` through ``base``), ``spring_forces``
    (N, {name: peak tension change}; ``modal_spring_forces`` mode by mode); :meth:`point_displacement` for body
    points; ``modal_relative_error``: each mode's values' estimated relative error. ``mass`` (kg): what the ground
    moves (Lᵀ M⁻¹ L), ``missing_mass`` (kg) that of the modes left out, ``modes_for_90`` how many modes reach
    90 % of ``mass``."""

    direction: tuple
    combination: str
    damping: np.ndarray
    periods: np.ndarray
    omega: np.ndarray
    participation: np.ndarray
    effective_mass: np.ndarray
    spectral_acceleration: np.ndarray
    spectral_displacement: np.ndarray
    modal_displacement: np.ndarray
    rigid_displacement: np.ndarray
    zpa: float | None
    mass: float
    missing_mass: float
    modes_for_90: int
    displacement: np.ndarray
    displacement_error: np.ndarray
    base_shear: float
    base_shear_error: float
    modal_base_shear: np.ndarray
    overturning_moment: float
    overturning_moment_error: float
    modal_overturning_moment: np.ndarray
    spring_forces: dict
    spring_force_errors: dict
    modal_spring_forces: dict  # {name: per kept mode (N)}
    modal_relative_error: np.ndarray  # estimated relative error of each kept mode's values (ω, shape, spectrum)
    axis: tuple
    base: tuple
    coordinates: tuple
    units: tuple
    rigid_modes: np.ndarray  # kept modes counted rigid (above rigid_frequency)
    elapsed: float
    note: str = ""
    rule: str = "SRSS, CQC and ABS are combination rules: their own error is not estimated"
    spectrum: Any = field(default=None, repr=False)  # the S_a(T) function (for plots)
    _rows: Any = field(default=None, repr=False)  # (combine(rows) -> (peaks, errors))

    @property
    def n_modes(self) -> int:
        return self.periods.size

    @property
    def frequency_hz(self) -> np.ndarray:
        return self.omega / (2 * np.pi)

    def combine(self, rows: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(peaks, errors) of any outputs linear in the coordinates: ``rows`` (k × nv) maps the coordinates'
        displacements to the outputs; the modal values are combined by this result's rule."""
        nv = self._rows.linear.nv
        rows = np.atleast_2d(finite_array(rows, None, "response spectrum combine rows"))
        if rows.ndim != 2 or rows.shape[1] != nv:
            raise ModelError(f"response spectrum combine: rows must be k × {nv} (one column per coordinate), got "
                             f"shape {rows.shape}")
        return self._rows(rows)

    def point_displacement(self, points: list, direction: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(peaks, errors) (m) of the displacements of body points (names or (body, (x, y, z)) pairs) along
        ``direction``, relative to the ground."""
        lin = self._rows.linear
        d = unit_axis(direction, "point displacement direction")
        J = lin.point_jacobian(points).reshape(len(points), 3, lin.nv)
        return self.combine(np.einsum("pin,i->pn", J, d))

    def plot(self, path: str | None = None, **kwargs: Any) -> Any:
        """The spectrum with the modes' periods and S_a marked (see
        :func:`vibdyn.faces.spectrum_plots.plot_response_spectrum`); PNG at ``path``."""
        from ...faces.spectrum_plots import plot_response_spectrum

        return plot_response_spectrum(path, self, **kwargs)

    def to_dict(self) -> dict:
        return {"direction": list(self.direction), "combination": self.combination, "rule_note": self.rule,
                "damping_ratio": self.damping.tolist(), "period_s": self.periods.tolist(),
                "omega_rad_s": self.omega.tolist(), "frequency_hz": self.frequency_hz.tolist(),
                "participation_sqrt_kg": self.participation.tolist(), "effective_mass_kg": self.effective_mass.tolist(),
                "spectral_acceleration_m_s2": self.spectral_acceleration.tolist(),
                "spectral_displacement_m": self.spectral_displacement.tolist(),
                "rigid_modes": self.rigid_modes.tolist(), "zpa_m_s2": self.zpa, "mass_kg": self.mass,
                "missing_mass_kg": self.missing_mass, "modes_for_90_percent": self.modes_for_90,
                "coordinates": list(self.coordinates), "units": list(self.units),
                "displacement": self.displacement.tolist(), "displacement_error": self.displacement_error.tolist(),
                "modal_displacement": self.modal_displacement.tolist(),
                "rigid_displacement": self.rigid_displacement.tolist(),
                "base_shear_N": self.base_shear, "base_shear_error_N": self.base_shear_error,
                "modal_base_shear_N": self.modal_base_shear.tolist(),
                "overturning_moment_N_m": self.overturning_moment,
                "overturning_moment_error_N_m": self.overturning_moment_error,
                "modal_overturning_moment_N_m": self.modal_overturning_moment.tolist(), "axis": list(self.axis),
                "base_m": list(self.base), "spring_forces_N": dict(self.spring_forces),
                "spring_force_errors_N": dict(self.spring_force_errors),
                "modal_spring_forces_N": {k: v.tolist() for k, v in self.modal_spring_forces.items()},
                "modal_relative_error": self.modal_relative_error.tolist(), "note": self.note,
                "elapsed_s": self.elapsed}

    def __repr__(self):
        from ..._format import duration, number, summary

        return summary("SeismicResponse", f"{self.n_modes} modes", self.combination.upper(),
                       f"base shear {number(self.base_shear, 'N')} ± {number(self.base_shear_error, digits=2)}",
                       f"{self.modes_for_90} modes reach 90 % of the mass", duration(self.elapsed))

    def __str__(self):
        from ..._format import number

        zeta = ", ".join(f"{z:g}" for z in np.unique(self.damping))
        kept = f"ζ = {zeta}" if zeta else "no mode kept: the whole mass by its static missing-mass response at S_a(0)"
        lines = [f"response spectrum along {list(self.direction)}, {self.combination.upper()} ({kept}); {self.rule}",
                 f"{'mode':>4} {'T s':>10} {'f Hz':>10} {'Γ √kg':>12} {'m_eff kg':>12} {'S_a m/s²':>10} "
                 f"{'V_n N':>12}"]
        for i in range(self.n_modes):
            lines.append(f"{i + 1:>4} {self.periods[i]:>10.5g} {self.frequency_hz[i]:>10.5g} "
                         f"{self.participation[i]:>12.6g} {self.effective_mass[i]:>12.6g} "
                         f"{self.spectral_acceleration[i]:>10.5g} {self.modal_base_shear[i]:>12.6g}"
                         + ("  (rigid)" if self.rigid_modes[i] else ""))
        lines.append(f"mass moved {number(self.mass, 'kg')}, missing {number(self.missing_mass, 'kg')} "
                     f"(at S_a(0) = {number(self.zpa, 'm/s²')}); {self.modes_for_90} modes reach 90 %")
        lines.append(f"{'coordinate':>14} {'peak':>14} {'error':>10}")
        for name, unit, x, e in zip(self.coordinates, self.units, self.displacement, self.displacement_error):
            lines.append(f"{name:>14} {x:>12.6g} {unit:<2}{e:>9.2g}")
        for name, f in self.spring_forces.items():
            lines.append(f"{'spring ' + name:>14} {f:>12.6g} N {self.spring_force_errors[name]:>8.2g}")
        lines.append(f"base shear {number(self.base_shear, 'N')} ± {number(self.base_shear_error, digits=2)}; "
                     f"overturning moment {number(self.overturning_moment, 'N·m')} ± "
                     f"{number(self.overturning_moment_error, digits=2)} about {list(self.axis)}")
        if self.note:
            lines.append(self.note)
        return "\n".join(lines)


def spring_rows(lin):
    """(names, rows k·∂L/∂q): each point spring's tension change (N) per coordinate displacement."""
    from ...description.elements.spring import Spring

    system = lin.system
    names, rows = [], []
    for s in system.scene.elements_of(Spring):
        ends, jac = [], []
        for body, point in (s.a, s.b):
            if body == "world":
                ends.append(np.asarray(point, float))
                jac.append(np.zeros((3, lin.nv)))
            elif body in system.support_index:
                motion = system.supports[system.support_index[body]].motion
                ends.append(np.asarray(point, float) + np.asarray(motion.position(lin.t), float))
                jac.append(np.zeros((3, lin.nv)))
            else:
                ends.append(system.point_position(body, point, lin.q))
                jac.append(lin.point_jacobian([(body, point)]))
        dx = ends[1] - ends[0]
        L = float(np.linalg.norm(dx))
        if L == 0.0:
            continue  # (a zero-length spring has no line: its tension change is undefined to first order)
        names.append(s.name)
        rows.append(s.stiffness * (dx / L) @ (jac[1] - jac[0]))
    return names, np.array(rows).reshape(len(rows), lin.nv)


class _Combiner:
    """Combines modal values of linear outputs (rows × nv) by the rule, with errors propagated."""

    def __init__(self, linear, rule, rho, drho, U, U_err_rel, shape_err, gamma_d, Phi, rigid_u, rigid_err, dyn):
        self.linear, self.rule, self.rho, self.drho = linear, rule, rho, drho
        self.U, self.rel, self.shape_err, self.gd, self.Phi = U, U_err_rel, shape_err, gamma_d, Phi
        self.rigid_u, self.rigid_err, self.dyn = rigid_u, rigid_err, dyn

    def __call__(self, rows):
        R = rows @ self.U[self.dyn].T  # k × n_dyn modal values
        E = np.abs(R) * self.rel[self.dyn] + (np.abs(rows) @ np.abs(self.Phi[:, self.dyn])) * np.abs(
            self.gd[self.dyn]) * self.shape_err[self.dyn]
        if self.rule == "abs":
            peak, err = np.abs(R).sum(axis=1), E.sum(axis=1)
        else:
            rho = self.rho if self.rule == "cqc" else np.eye(R.shape[1])
            drho = self.drho if self.rule == "cqc" else np.zeros_like(rho)
            sq = np.maximum(np.einsum("ki,ij,kj->k", R, rho, R), 0.0)
            peak = np.sqrt(sq)
            safe = np.where(peak > 0, peak, 1.0)
            err = np.where(peak > 0, (np.einsum("ki,ij,kj->k", np.abs(R), np.abs(rho), E)
                                      + 0.5 * np.einsum("ki,ij,kj->k", np.abs(R), drho, np.abs(R))) / safe,
                           E.sum(axis=1))
        rigid = rows @ self.rigid_u
        rigid_err = np.abs(rows) @ self.rigid_err
        total = np.sqrt(peak ** 2 + rigid ** 2)
        safe = np.where(total > 0, total, 1.0)
        err = np.where(total > 0, (peak * err + np.abs(rigid) * rigid_err) / safe, err + rigid_err)
        return total, err + 8 * EPS * total


def response_spectrum(modes, spectrum, direction, combination: str = "srss", damping: Any = 0.05, *,
                      n_modes: int | None = None, missing_mass: bool = True, rigid_frequency: float | None = None,
                      zpa: float | None = None, base: ArrayLike = (0.0, 0.0, 0.0),
                      axis: ArrayLike | None = None) -> SeismicResponse:
    """:meth:`vibdyn.analysis.modal.Modes.response_spectrum` (see there)."""
    start = time.perf_counter()
    what = "response spectrum"
    lin = modes.linear
    d = unit_axis(direction, f"{what} direction")
    if combination not in COMBINATIONS:
        raise ModelError(f"{what}: unknown combination {combination!r} (one of {', '.join(COMBINATIONS)})")
    n_all = modes.n
    if n_all == 0:
        raise ModelError(f"{what}: the model has no coordinates")
    bad = np.flatnonzero(modes.rigid | modes.unstable)
    if bad.size:
        k = int(bad[0])
        kind = "rigid (ω = 0: the structure follows the ground without a period)" if modes.rigid[k] else \
            "unstable (ω² < 0)"
        raise ModelError(f"{what}: mode {k + 1} is {kind}; a response spectrum needs every mode to vibrate "
                         "(fix the structure to its ground, or hold the free coordinates)")
    n = n_all if n_modes is None else integer(n_modes, f"{what} n_modes", minimum=0, maximum=n_all)
    zeta = np.broadcast_to(finite_array(damping, None, f"{what} damping ratio"), (n_all,)) \
        if np.ndim(damping) == 0 else finite_array(damping, (n_all,), f"{what} damping ratios (one per mode)")
    zeta = np.array(zeta, float)
    if np.any(zeta < 0) or np.any(zeta >= 1):
        raise ModelError(f"{what}: damping ratios must be in [0, 1), got {zeta.tolist()}")
    S, described, zero, slope = spectrum_function(spectrum, what)
    if zpa is None:
        zpa = zero
    elif zpa is not None:
        zpa = scalar(zpa, f"{what} zpa (m/s²)", nonnegative=True)
    need_zpa = missing_mass and (n < n_all or rigid_frequency is not None)
    if need_zpa and zpa is None:
        raise ModelError(f"{what}: the missing-mass correction needs S_a at T = 0, which {described} does not "
                         "give: pass zpa= (m/s²), or missing_mass=False")
    fr = None if rigid_frequency is None else scalar(rigid_frequency, f"{what} rigid_frequency (Hz)", positive=True)
    # the ground's load and influence vector
    A_lin, _ = lin.system.momentum_matrix(lin.q)
    L = A_lin.T @ d
    Phi_all, w_all = modes.shapes, modes.omega
    mm = modes.modal_mass
    gamma_all = (Phi_all.T @ L) / mm
    eff_all = (Phi_all.T @ L) ** 2 / mm
    # the modes are a complete basis of the motions the model has (a mechanism's: those its loops allow), so
    # Σ_all Γ_n φ_n/ω_n² = K⁻¹ L (the static response to a unit ground acceleration) and Σ_all Γ_n² = Lᵀ M⁻¹ L
    mass = float(eff_all.sum())
    if mass <= 0:
        raise ModelError(f"{what}: a ground motion along {d.tolist()} moves no mass of this model (no coordinate "
                         "responds to it)")
    cum = np.cumsum(eff_all) / mass
    modes_90 = int(np.argmax(cum >= 0.9 - 1e-12)) + 1 if cum[-1] >= 0.9 - 1e-12 else n_all
    # per kept mode
    Phi, w, gamma, z = Phi_all[:, :n], w_all[:n], gamma_all[:n], zeta[:n]
    T = 2 * np.pi / w
    Sa = S(T) if n else np.zeros(0)
    D = Sa / w ** 2
    U = (gamma * D)[None, :] * Phi  # nv × n
    U = U.T
    rigid_modes = (w / (2 * np.pi) >= fr) if fr is not None else np.zeros(n, bool)
    dyn = ~rigid_modes
    # errors: ω (relative, per mode), shapes (δω²/gap + orthogonality), the spectrum's slope
    wrel = modes.omega_relative_error[:n]
    w2 = modes.omega2
    gaps_all = np.array([np.min(np.abs(w2[r] - np.delete(w2, r)), initial=np.inf) for r in range(n_all)])
    gaps = gaps_all[:n]
    shape_err = np.minimum(2 * wrel * w2[:n] / np.where(gaps > 0, gaps, 1e-300), 1.0) + modes.orthogonality
    dT = 2 * np.pi * wrel / w
    slopes = slope(T) if n else np.zeros(0)
    own = np.zeros(n)
    if isinstance(slopes, tuple):  # a record's spectrum: its own error too
        slopes, own = slopes
    Sa_rel = (np.abs(slopes) * dT + own) / np.where(Sa > 0, Sa, 1.0) if n else np.zeros(0)
    rel = 2 * wrel + Sa_rel + 2 * shape_err  # of each modal value (the shape enters Γ too)
    # the rigid part: the missing mass and the rigid modes, algebraically
    rigid_u = np.zeros(lin.nv)
    rigid_err = np.zeros(lin.nv)
    rigid_f, rigid_f_err = np.zeros(lin.nv), np.zeros(lin.nv)  # M⁻¹K of the rigid part, mode by mode (exact)
    if missing_mass and n < n_all:
        out = slice(n, n_all)  # the modes left out, as one rigid response at S_a(0)
        rel_out = 2 * modes.omega_relative_error[out] + 2 * (np.minimum(
            2 * modes.omega_relative_error[out] * w2[out] / np.where(gaps_all[out] > 0, gaps_all[out], 1e-300), 1.0)
            + modes.orthogonality)
        static = gamma_all[out] / w_all[out] ** 2
        rigid_u += Phi_all[:, out] @ static * zpa
        rigid_err += np.abs(Phi_all[:, out]) @ (np.abs(static) * rel_out) * zpa
        rigid_f += Phi_all[:, out] @ gamma_all[out] * zpa
        rigid_f_err += np.abs(Phi_all[:, out]) @ (np.abs(gamma_all[out]) * rel_out) * zpa
    if rigid_modes.any():
        rigid_u += U[rigid_modes].sum(axis=0)
        rigid_err += (np.abs(U[rigid_modes]) * rel[rigid_modes, None]).sum(axis=0)
        UK = U[rigid_modes] * (w[rigid_modes] ** 2)[:, None]
        rigid_f += UK.sum(axis=0)
        rigid_f_err += (np.abs(UK) * rel[rigid_modes, None]).sum(axis=0)
    rho = correlation(w[dyn], z[dyn]) if dyn.any() else np.zeros((0, 0))
    drho = np.abs(correlation(w[dyn] * (1 + wrel[dyn]), z[dyn]) - rho) if dyn.any() else rho
    gd = gamma * D
    # a shape's error mixes the other modes into it (each by at most that shape's error, in mass-normalised
    # terms), so it reaches every coordinate any mode moves, not only those φ_n moves: a stiff last spring's
    # 4.6e-12 m (a 40-digit eigen-solution) was given as 7.5e-11 ± 2.3e-12 when the error was spread by |φ_n| alone
    mm_all = np.broadcast_to(np.asarray(mm, float), w_all.shape)
    spread = (np.abs(Phi_all) / np.sqrt(mm_all)).sum(axis=1)[:, None] * np.sqrt(mm_all[:n])[None, :]
    comb = _Combiner(lin, combination, rho, drho, U, rel, shape_err, gd, np.maximum(np.abs(Phi), spread), rigid_u,
                     rigid_err, np.flatnonzero(dyn))
    disp, disp_err = comb(np.eye(lin.nv))
    # base shear and overturning moment: forces K u applied to the ground, as rows on u
    g = np.asarray(lin.system.scene.gravity, float)
    up = -g if np.any(g) else np.array([0.0, 0.0, 1.0])
    note = ""
    if axis is None:
        ax = np.cross(up, d)
        if np.linalg.norm(ax) < 1e-12:  # a vertical ground motion overturns about no horizontal axis of its own
            ax = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
            note = "vertical ground motion: the overturning moment is about an arbitrary horizontal axis (give axis=)"
        ax = ax / np.linalg.norm(ax)
    else:
        ax = unit_axis(axis, f"{what} axis")
    base = finite_array(base, (3,), f"{what} base point (m)")
    _, A_ang = lin.system.momentum_matrix(lin.q, base)
    # the inertia the stiffness balances, M⁻¹K u, taken mode by mode (M⁻¹K φ_n = ω_n² φ_n exactly): through a
    # matrix M⁻¹K = Φ Ω² Φᵀ M, the round-off of a low mode's shape in a high mode's direction came back ×
    # (ω_max/ω_n)² (a base shear 1 % off, stated to 7e-6, at a mass ratio of 1e8)
    UK = U * (w ** 2)[:, None]
    comb_f = _Combiner(lin, combination, rho, drho, UK, rel, shape_err, gd * w ** 2, Phi, rigid_f, rigid_f_err,
                       np.flatnonzero(dyn))
    shear_row, moment_row = L, A_ang.T @ ax  # rows on the accelerations M⁻¹K u
    (shear, moment), (shear_err, moment_err) = comb_f(np.vstack([shear_row, moment_row]))
    names, srows = spring_rows(lin)
    sforces, serrs = comb(srows) if names else (np.zeros(0), np.zeros(0))
    if lin.has_damping:
        note = "; ".join(x for x in (note, "the model's own damping is not used: undamped modes with the damping "
                                     "ratios given (the spectrum's and CQC's)") if x)
    return SeismicResponse(tuple(float(x) for x in d), combination, zeta[:n], T, w, gamma, eff_all[:n], Sa, D, U,
                           rigid_u, None if zpa is None else float(zpa), mass,
                           float(mass - eff_all[:n].sum()), modes_90, disp, disp_err, float(shear), float(shear_err),
                           UK @ shear_row, float(moment), float(moment_err), UK @ moment_row,
                           dict(zip(names, sforces.tolist())), dict(zip(names, serrs.tolist())),
                           {name: U @ row for name, row in zip(names, srows)}, rel,
                           tuple(float(x) + 0.0 for x in ax), tuple(float(x) + 0.0 for x in base),
                           tuple(lin.coordinates),
                           tuple(lin.units), rigid_modes, time.perf_counter() - start, note, spectrum=S, _rows=comb)
