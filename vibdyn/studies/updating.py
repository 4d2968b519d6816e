"""Model updating: the parameters of a scene fitted so that its natural frequencies (and, where given, its
mode shapes, paired by MAC) match measured ones.

Weighted least squares (``scipy.optimize.least_squares``, trust region within bounds) on the residuals
(ω_model − ω_measured)/σ, with the Jacobian from :func:`vibdyn.analysis.sensitivity.sensitivity`; the
model's modes are paired with the measured ones at every step (by MAC where shapes are given, else in
ascending order of the flexible modes). The fitted values' standard deviations come from the Jacobian and
the measurement uncertainty σ: cov = (JᵀJ)⁻¹ with J = ∂r/∂p; a parameter set the data cannot identify (a
rank-deficient J) is refused, naming the parameters that move together.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .._check import builder_values, integer, scalar, scene_builder, unknown_name, vector3
from ..errors import ConvergenceError, ModelError


@dataclass(frozen=True, eq=False)
class Update:
    """A fitted model: ``values`` and ``std`` (dicts name -> value, in the builder's units), ``covariance``
    (n_params × n_params), ``omega`` the fitted model's paired natural frequencies (rad/s), ``measured``
    (rad/s), ``residuals`` ω_model − ω_measured per measured mode (rad/s), ``normalised_residuals`` (the same
    over σ), ``pairs`` the model mode paired with each measured one (0-based), ``mac`` (n_measured × n_model
    modes, empty without measured shapes), ``iterations`` (Jacobian evaluations), ``cost`` ½Σ(r/σ)², and
    ``elapsed`` (s)."""

    values: dict
    std: dict
    covariance: np.ndarray
    omega: np.ndarray
    measured: np.ndarray
    sigma: np.ndarray
    residuals: np.ndarray
    pairs: np.ndarray
    mac: np.ndarray
    iterations: int
    cost: float
    elapsed: float
    message: str = ""

    @property
    def normalised_residuals(self) -> np.ndarray:
        return self.residuals / self.sigma

    def __str__(self) -> str:
        from .._format import table

        rows = [[k, f"{v:.8g}", f"{self.std[k]:.3g}"] for k, v in self.values.items()]
        out = table(["parameter", "fitted", "std (1σ)"], rows)
        rows = [[str(i + 1), f"{m:.8g}", f"{w:.8g}", f"{r:.3g}", f"{r / s:.3g}"]
                for i, (m, w, r, s) in enumerate(zip(self.measured, self.omega, self.residuals, self.sigma))]
        out += [""] + table(["measured mode", "ω measured (rad/s)", "ω model (rad/s)", "residual (rad/s)",
                             "residual / σ"], rows)
        return "\n".join(out) + f"\n{self.iterations} Jacobians, {self.elapsed:.2f} s"

    def __repr__(self) -> str:
        from .._format import duration, summary

        vals = ", ".join(f"{k} = {v:.6g} ± {self.std[k]:.2g}" for k, v in self.values.items())
        return summary("Update", vals, f"cost {self.cost:.3g}", duration(self.elapsed))

    def to_dict(self) -> dict[str, Any]:
        return {"values": dict(self.values), "std": dict(self.std), "covariance": self.covariance.tolist(),
                "omega_rad_s": self.omega.tolist(), "measured_rad_s": self.measured.tolist(),
                "sigma_rad_s": self.sigma.tolist(), "residuals_rad_s": self.residuals.tolist(),
                "pairs": self.pairs.tolist(), "mac": self.mac.tolist(), "iterations": self.iterations,
                "cost": self.cost, "elapsed_s": self.elapsed}


def _vector(x, n, what):
    try:
        a = np.atleast_1d(np.asarray(x, dtype=float)) if x is not None and not isinstance(x, str) else None
    except (TypeError, ValueError):
        a = None  # (not numbers: said below)
    if a is None or a.ndim != 1 or (n is not None and a.size not in (1, n)):
        raise ModelError(f"update: {what} must be {'one number or ' if n else ''}a list of "
                         f"{f'{n} ' if n else ''}numbers, got {x!r}")
    if not np.all(np.isfinite(a)):
        raise ModelError(f"update: {what} has a value that is not a finite number: {x!r}")
    return np.broadcast_to(a, (n,)).copy() if n else a


def _bounds(bounds, names, p0):
    """(lower, upper) arrays from ``bounds`` {name: (lower, upper)} (default: positive for a positive start)."""
    if bounds is None:
        bounds = {}
    if not isinstance(bounds, dict):
        raise ModelError(f"update: bounds must be a dict {{parameter: (lower, upper)}}, got {bounds!r}")
    unknown = [k for k in bounds if k not in names]
    if unknown:
        raise unknown_name(unknown[0], names, "parameter", "parameters (start's keys)", "update bounds")
    lo, hi = np.where(p0 > 0, 0.0, -np.inf), np.full(len(names), np.inf)
    for k, b in bounds.items():
        i = names.index(k)
        pair = np.asarray(b, dtype=float) if isinstance(b, (tuple, list, np.ndarray)) and len(b) == 2 \
            and all(isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool) for x in b) \
            else None
        if pair is None or np.any(np.isnan(pair)):
            raise ModelError(f"update: bounds[{k!r}] must be a pair (lower, upper) of numbers (±inf for none), got "
                             f"{b!r}")
        lo[i], hi[i] = pair
    bad = [k for i, k in enumerate(names) if not (lo[i] < hi[i] and lo[i] <= p0[i] <= hi[i])]
    if bad:
        k = bad[0]
        raise ModelError(f"update: each start must lie within its bounds (lower < upper): {k} starts at "
                         f"{p0[names.index(k)]:g}, bounds {bounds.get(k, (lo[names.index(k)], hi[names.index(k)]))}")
    return lo, hi


def _points(points):
    """The measuring points as :meth:`Modes.point_shapes` takes them: body names or (body, (x, y, z)) pairs."""
    if isinstance(points, str) or not isinstance(points, (list, tuple)) or not points:
        raise ModelError(f"update: points must be a list of body names or (body, (x, y, z)) pairs, got {points!r}")
    out: list = []
    for p in points:
        if isinstance(p, (tuple, list)) and len(p) == 2 and isinstance(p[0], str):
            out.append((p[0], tuple(vector3(p[1], f"update: the point on '{p[0]}'"))))
        elif isinstance(p, str):
            out.append(p)
        else:
            raise ModelError(f"update: each of points must be a body's name or a (body, (x, y, z)) pair, got {p!r}")
    return out


def _measured_shapes(shapes, points, w_meas):
    """The measured shapes as floats (None without), each a nonzero column; measured frequencies without shapes
    must ascend (they are paired with the model's flexible modes in ascending order)."""
    if shapes is None:
        if points is not None:
            raise ModelError("update: points name where measured shapes are: give shapes= too")
        if np.any(np.diff(w_meas) < 0):
            raise ModelError(f"update: measured frequencies {w_meas.tolist()} rad/s are not in ascending order: "
                             "without shapes they are paired with the model's flexible modes in ascending order; "
                             "sort them, or give shapes= to pair them by MAC")
        return None
    try:  # (complex shapes, as an experimental modal analysis gives them, pair by the complex MAC)
        meas = np.asarray(shapes)
        meas = meas.astype(complex if np.iscomplexobj(meas) else float)
    except (TypeError, ValueError):
        raise ModelError("update: shapes must be an array of numbers (displacements)") from None
    if not np.all(np.isfinite(meas)):
        raise ModelError("update: the measured shapes have a value that is not a finite number")
    if meas.ndim >= 1 and meas.shape[-1] == len(w_meas):
        zero = [i + 1 for i in range(len(w_meas)) if not np.any(meas[..., i])]
        if zero:
            raise ModelError(f"update: the measured shape{'s' if len(zero) > 1 else ''} of measured mode"
                             f"{'s' if len(zero) > 1 else ''} {', '.join(map(str, zero))} (from 1) "
                             f"{'are' if len(zero) > 1 else 'is'} all zero: a "
                             "zero shape pairs with no mode (its MAC is undefined); give the measured "
                             "displacements, or leave shapes out")
    return meas


def update(build: Callable, start: dict, measured: Any, sigma: Any = None, bounds: dict | None = None, *,
           shapes: Any = None, points: Any = None, direction: Any = None, relative_sigma: float = 0.005,
           max_iter: int = 30) -> Update:
    """Fit the parameters of ``build(**params)`` (a function returning a Scene or a System, as :func:`vibdyn.sweep`
    takes it) from ``start`` so that its natural frequencies match ``measured`` (rad/s, ascending, the lowest flexible
    modes unless ``shapes`` pairs them).

    ``sigma``: the measurements' standard deviations (rad/s, one or one per mode; default
    ``relative_sigma`` × measured); ``bounds``: {name: (lower, upper)} (default: positive for a positive start);
    ``shapes``: measured mode shapes to pair modes by MAC: at ``points`` (body names or (body, point) pairs, as
    :meth:`Modes.point_shapes` takes them; n_points × n_measured displacements along ``direction``, or
    n_points × 3 × n_measured without), else in the model's coordinates (nv × n_measured).
    """
    t0 = time.perf_counter()
    from ..analysis.sensitivity import sensitivity
    from ..solvers.tracking import assign
    from ..solvers.tracking import mac as mac_of
    build = scene_builder(build, "update")
    if not isinstance(start, dict) or not start:
        raise ModelError("update: start must be a dict {parameter: value} of build's keyword arguments")
    start = builder_values(start, "update: start")
    names = list(start)
    p0 = np.array(list(start.values()))
    max_iter = integer(max_iter, "update: max_iter (evaluations of the model)", minimum=1)
    relative_sigma = scalar(relative_sigma, "update: relative_sigma", positive=True)
    w_meas = _vector(measured, None, "measured (rad/s)")
    if not w_meas.size:
        raise ModelError("update: no measured frequency given (measured: rad/s, one per measured mode)")
    if direction is not None:
        direction = vector3(direction, "update: direction")
        if not np.any(direction):
            raise ModelError("update: direction (of the measured displacements) has zero length: give the axis the "
                             "sensors measure along, e.g. (1, 0, 0)")
    if np.any(w_meas <= 0):
        raise ModelError(f"update: measured natural frequencies must be positive (rad/s), got {w_meas.tolist()}")
    m = len(w_meas)
    sig = (_vector(sigma, m, "sigma (rad/s)") if sigma is not None else relative_sigma * w_meas)
    if np.any(sig <= 0):
        raise ModelError(f"update: sigma must be positive (rad/s), got {sig.tolist()}")
    # the fit weighs the modes by σ/σ_ref (σ_ref their geometric mean): the same minimum as weighing by 1/σ, the
    # residuals in rad/s, so that no σ (1e-100 rad/s or 1e100) overflows the solver's squares; cov scales by σ_ref²
    sig_ref = np.exp(np.mean(np.log(sig)))
    weight = sig / sig_ref
    lo, hi = _bounds(bounds, names, p0)
    meas_shapes = _measured_shapes(shapes, points, w_meas)
    if points is not None:
        points = _points(points)
    build(**start)  # (a builder returning no scene is refused here, not along the fit)
    scale = np.where(p0 != 0, np.abs(p0), 1.0)
    cache: dict = {}

    def model(x):
        key = tuple(np.round(x, 15))
        if key not in cache:
            values = dict(zip(names, (x * scale).tolist()))
            sens = sensitivity(build, values)
            cache.clear()
            cache[key] = sens
        return cache[key]

    def paired(sens):
        flexible = np.flatnonzero(sens.omega0 > 0)
        if len(flexible) < m:
            raise ModelError(f"update: {m} measured frequencies, but the model has only {len(flexible)} flexible "
                             f"modes (ω = {np.round(sens.omega0, 6).tolist()} rad/s)")
        if meas_shapes is None:
            return flexible[:m], np.zeros((m, 0))
        phi = sens.modes.shapes if points is None else sens.modes.point_shapes(points, direction)
        if meas_shapes.shape[:-1] != phi.shape[:-1] or meas_shapes.shape[-1] != m:
            where = "nv" if points is None else f"{len(points)} points" + ("" if direction is not None else " × 3")
            raise ModelError(f"update: shapes must be {where} × {m} measured modes, "
                             f"{phi.shape[:-1] + (m,)}, got {meas_shapes.shape}")
        a, b = meas_shapes.reshape(-1, m), phi.reshape(-1, phi.shape[-1])
        table = np.atleast_2d(mac_of(a, b))  # measured × model modes (one pair: a number)
        rows, cols = assign(-table[:, flexible])
        return flexible[cols[np.argsort(rows)]], table

    def residual(x):
        sens = model(x)
        idx, _ = paired(sens)
        return (sens.omega0[idx] - w_meas) / weight

    def jacobian(x):
        sens = model(x)
        idx, _ = paired(sens)
        return sens.d_omega[idx] * scale[None, :] / weight[:, None]

    from scipy.optimize import least_squares

    try:
        fit = least_squares(residual, p0 / scale, jac=jacobian, bounds=(lo / scale, hi / scale), method="trf",
                            x_scale="jac", max_nfev=max_iter, xtol=1e-12, ftol=1e-12, gtol=1e-12)
    except ModelError as e:
        raise ModelError(f"update: the model could not be analysed along the fit: {e}") from None
    x = fit.x
    sens = model(x)
    idx, mac_table = paired(sens)
    J = sens.d_omega[idx] / weight[:, None]  # σ_ref ∂r/∂p in the builder's units
    u, s, vt = np.linalg.svd(J, full_matrices=True)
    rank = int(np.sum(s > 1e-8 * max(s.max(initial=0.0), 1e-300)))
    if rank < len(names):
        null = vt[rank:]
        involved = [names[i] for i in np.flatnonzero(np.abs(null).max(axis=0) > 1e-3)]
        raise ModelError(f"update: the parameters {', '.join(involved)} cannot be identified from the "
                         f"{m} measured frequenc{'y' if m == 1 else 'ies'}: they change the paired frequencies only "
                         "together (the Jacobian has rank "
                         f"{rank} < {len(names)}); fix some of them, or measure more modes")
    root = vt.T / s[:len(names)]  # cov = σ_ref² root rootᵀ (σ_ref kept out of the squares: std of any σ)
    with np.errstate(over="ignore", under="ignore"):  # (σ beyond 1e±154: cov and cost as inf and 0, std kept)
        cov = sig_ref ** 2 * (root @ root.T)
        cost = float(0.5 * np.sum(((sens.omega0[idx] - w_meas) / sig) ** 2))
    std = sig_ref * np.sqrt(np.einsum("ij,ij->i", root, root))
    if fit.status <= 0:
        off = (sens.omega0[idx] - w_meas) / sig
        far = (f"; at the best point so far the residuals are {', '.join(f'{r:.3g}' for r in off)} σ: measurements the "
               "model cannot reach make the fit slow") if np.abs(off).max() > 3 else ""
        raise ConvergenceError(f"update: the fit did not converge in {max_iter} evaluations ({fit.message}){far}; "
                               "give more (max_iter=)", best=dict(zip(names, (x * scale).tolist())))
    omega = sens.omega0[idx]
    return Update(dict(zip(names, (x * scale).tolist())), dict(zip(names, std.tolist())), cov, omega, w_meas, sig,
                  omega - w_meas, idx, mac_table, int(fit.njev or 0), cost, time.perf_counter() - t0,
                  str(fit.message))
