"""Rotor stability and critical-speed maps from the Campbell machinery: the value of a parameter (a cross-coupled
stiffness: API 684 level I) at which a mode's log decrement reaches
zero, and the undamped critical speeds against a parameter (a bearing stiffness: API 684's map).

A parameter is given either as a builder ``build(x) -> Scene | System`` (any scene change: a force law's
coefficient, a bearing's coefficients) or as a scene and the name of one of its parameters
(:mod:`vibdyn.description.parameters`: ``"brg.stiffness"``), set by :func:`~vibdyn.description.parameters.with_values`.
Roots are refined by Brent's method (``scipy.optimize.brentq``) on the linearisation itself, the mode followed by
MAC (:mod:`vibdyn.solvers.tracking`); each carries its error: the root's own tolerance plus the error of the
quantity crossing zero over its slope.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from .._check import call_builder, finite_array
from ..defaults import RPM
from ..errors import ModelError
from ..solvers.roots import bracketed_root, sign_changes, signs
from .campbell_diagram import campbell, check_spin, coordinate_frame, hold, pick, speed_modes, track_columns


# ------------------------------------------------------------------------------------- parameter studies
def _builder(model, parameter, what, unit="") -> tuple[Callable[[float], Any], str, str]:
    """A function value -> System from a builder or a scene and a parameter name, the parameter's name and unit."""
    from ..description import parameters as params
    from ..description.scene import Scene
    from ..model.system import System

    if isinstance(model, Scene):
        if parameter is None:
            raise ModelError(f"{what}: with a scene, name the parameter to vary (parameter='brg.stiffness')")
        (p,) = params.parameters(model, [parameter]) if isinstance(parameter, str) else (None,)
        if p is None:
            raise ModelError(f"{what}: parameter must be one name such as 'k.stiffness', got {parameter!r}")
        return (lambda x: params.with_values(model, [p], [x]).build()), p.name, p.unit
    if not callable(model):
        raise ModelError(f"{what}: expected a builder build(value) -> Scene | System, or a Scene with "
                         f"parameter=NAME; got {type(model).__name__}")

    def build(x):
        s = call_builder(model, (x,), {}, what, f"{x:g}")
        s = s.build() if isinstance(s, Scene) else s
        if not isinstance(s, System):
            raise ModelError(f"{what}: the builder returned {type(s).__name__} for {x:g}, not a Scene or System")
        return s

    return build, parameter or "value", unit


def _values(values, what, positive=False) -> np.ndarray:
    v = finite_array(values, None, f"{what} values").astype(float).ravel()
    if v.size < 2 or np.any(np.diff(v) <= 0):
        bad = np.flatnonzero(np.diff(v) <= 0)
        where = f" (values[{bad[0] + 1}] = {v[bad[0] + 1]:g} after {v[bad[0]]:g})" if bad.size else ""
        raise ModelError(f"{what}: values must be at least two increasing numbers{where}")
    if positive and v[0] <= 0:
        raise ModelError(f"{what}: values must be positive for a log-log map, got {v[0]:g}")
    return v


def _speed(speed, what) -> float:
    s = finite_array(speed, None, f"{what} speed").ravel()
    if s.size != 1:
        raise ModelError(f"{what}: speed must be one number (rad/s), got {speed!r}")
    return float(s[0])


@dataclass(frozen=True, eq=False)
class StabilityLimit:
    """The log decrement of one tracked mode against a parameter at a held speed (see :func:`stability_limit`).

    ``values`` (n,) the parameter's values (SI); ``log_dec``, ``log_dec_error``, ``omega`` (rad/s), ``whirl``
    (n,) of the tracked mode, ``number`` its number (from 1, ascending ω at the first value); ``limit`` the value
    where δ = 0 (None if δ keeps its sign over ``values``), ``limit_error``; ``frame`` of Im λ; ``elapsed`` s."""

    parameter: str
    unit: str
    spin: str
    speed: float
    values: np.ndarray
    log_dec: np.ndarray
    log_dec_error: np.ndarray
    omega: np.ndarray
    whirl: np.ndarray
    number: int
    limit: float | None
    limit_error: float | None
    frame: str
    elapsed: float

    def plot(self, path: str | None = None, dpi: int = 100) -> Any:
        """δ against the parameter, the limit marked. Saves to ``path`` if given."""
        from ..faces import campbell_plot

        return campbell_plot.stability_limit(self, path=path, dpi=dpi)

    def to_dict(self) -> dict:
        return {"parameter": self.parameter, "unit": self.unit, "spin": self.spin, "speed_rad_s": self.speed,
                "values": self.values.tolist(), "log_dec": self.log_dec.tolist(),
                "log_dec_error": self.log_dec_error.tolist(), "omega_rad_s": self.omega.tolist(),
                "whirl": self.whirl.tolist(), "mode_number": self.number, "limit": self.limit,
                "limit_error": self.limit_error, "frame": self.frame, "elapsed_s": self.elapsed}

    def __repr__(self) -> str:
        lim = (f"δ = 0 at {self.parameter} = {self.limit:.8g} ± {self.limit_error:.1e}" if self.limit is not None
               else f"δ keeps its sign over {self.values[0]:g}…{self.values[-1]:g}")
        return f"StabilityLimit(mode {self.number} at {self.speed:g} rad/s: {lim}, {self.elapsed:.2f} s)"


def stability_limit(model: Any, values: ArrayLike, spin: str, speed: float, parameter: str | None = None, *,
                    mode: str | int = "forward", method: str = "analytic", held: bool | None = None,
                    q0: ArrayLike | None = None, unit: str = "") -> StabilityLimit:
    """The value of a parameter at which the log decrement of a mode reaches zero at the held ``speed`` (rad/s)
    of ``spin``: API 684 level I stability with the cross-coupled stiffness as the parameter.

    ``model``: a builder ``build(value) -> Scene | System`` or a Scene with ``parameter`` the name of one of its
    parameters; ``values`` increasing values sampled for δ (the crossing between two samples refined by
    Brent's method); ``mode``: "forward" (default: the first forward mode, lowest ω at the first value),
    "backward", or a mode number (from 1, ascending ω at the first value); the mode is tracked by MAC from
    value to value. ``held``, ``method``, ``q0`` as in :func:`vibdyn.campbell`; with a builder, ``parameter`` and
    ``unit`` only name the parameter for tables and pictures (a scene's named parameter has its own unit)."""
    start = time.perf_counter()
    what = "stability_limit"
    build, name, unit = _builder(model, parameter, what, unit)
    values = _values(values, what)
    speed = _speed(speed, what)

    def at(x, q):
        system = build(x)
        check_spin(system, spin, what)
        return speed_modes(system, spin, speed, q, method, hold(system, spin, held, what)), system

    rows, q = [], q0
    for x in values:
        sm, system = at(x, q)
        rows.append(sm)
        q = sm.q
    frame = coordinate_frame(system, spin, hold(system, spin, held, what))
    first = rows[0]
    if isinstance(mode, str):
        if mode not in ("forward", "backward"):
            raise ModelError(f"{what}: mode must be 'forward', 'backward' or a mode number from 1, got {mode!r}")
        cand = np.flatnonzero((first.whirl == mode) & (first.frequencies > 0))
        if not cand.size:
            raise ModelError(f"{what}: no {mode}-whirling mode at {name} = {values[0]:g}, {spin} = {speed:g} rad/s "
                             f"(whirls there: {', '.join(w or 'none' for w in first.whirl)})")
        k = int(cand[0])
    elif isinstance(mode, (int, np.integer)) and not isinstance(mode, bool) and 1 <= mode <= first.frequencies.size:
        k = int(mode) - 1
    else:
        raise ModelError(f"{what}: mode must be 'forward', 'backward' or a mode number from 1 to "
                         f"{first.frequencies.size}, got {mode!r}")
    picks, cols = [k], [np.arange(first.frequencies.size)]
    for r in range(1, len(rows)):
        cols.append(track_columns(rows[r - 1], rows[r], cols[-1], rows[r - 2].frequencies[cols[-2]] if r > 1 else None,
                                  values[r - 2:r + 1]))
        picks.append(int(cols[-1][k]))
    dec = [r.log_dec() for r in rows]
    delta = np.array([d[0][p] for d, p in zip(dec, picks)])
    delta_err = np.array([d[1][p] for d, p in zip(dec, picks)])
    omega = np.array([r.frequencies[p] for r, p in zip(rows, picks)])
    whirl = np.array([r.whirl[p] for r, p in zip(rows, picks)], dtype=object)
    sign = signs(delta, delta_err)
    limit = limit_error = None
    for i, n in sign_changes(sign)[:1]:  # the first crossing: δ = 0 nearest the first value
        refs = (rows[i].shapes[:, picks[i]], rows[n].shapes[:, picks[n]])

        def f(x, refs=refs, q=rows[i].q, near=0.5 * (omega[i] + omega[n])):
            sm, _ = at(x, q)
            j = pick(refs, sm, near=near)
            d, e = sm.log_dec()
            return (d[j], e[j]), None

        limit, limit_error, _ = bracketed_root(f, float(values[i]), float(values[n]), (delta[i], delta_err[i]),
                                               (delta[n], delta_err[n]), f"{what} of mode {k + 1}")
    return StabilityLimit(name, unit, spin, speed, values, delta, delta_err, omega, whirl, k + 1, limit, limit_error,
                          frame, time.perf_counter() - start)


def _distinct(found: list) -> tuple:
    """The critical speeds, each speed once: two modes reaching it within their errors (an isotropic rotor's x
    and y modes without gyroscopic coupling) count as one, the first mode's."""
    out: list = []
    for c in found:
        if out and abs(c.speed - out[-1].speed) <= c.error + out[-1].error + 1e-9 * c.speed:
            continue
        out.append(c)
    return tuple(out)


@dataclass(frozen=True, eq=False)
class CriticalSpeedMap:
    """Undamped critical speeds against a parameter (see :func:`critical_speed_map`).

    ``values`` (n,) the parameter's values (SI); ``speeds`` (n × k) the 1st, 2nd, … critical speeds (rad/s)
    at each value, ascending, each once (modes reaching one speed within their errors count once), a masked array
    (masked where fewer were found in the speed range); ``errors``
    alike (rad/s); ``critical`` the :class:`~vibdyn.analysis.campbell_diagram.CriticalSpeed` items per value;
    ``order`` the engine order; ``speed_range`` (rad/s) searched; ``elapsed`` s."""

    parameter: str
    unit: str
    spin: str
    order: float
    values: np.ndarray
    speeds: np.ma.MaskedArray
    errors: np.ma.MaskedArray
    critical: tuple = field(repr=False)
    speed_range: tuple = (0.0, 0.0)
    elapsed: float = 0.0

    @property
    def speeds_rpm(self) -> np.ma.MaskedArray:
        return self.speeds * RPM

    def plot(self, path: str | None = None, dpi: int = 100, *, units: str = "rad/s") -> Any:
        """The map, log-log: each critical speed (rad/s or rpm: ``units``) against the parameter."""
        from ..faces import campbell_plot

        return campbell_plot.critical_speed_map(self, path=path, units=units, dpi=dpi)

    def to_dict(self) -> dict:
        return {"parameter": self.parameter, "unit": self.unit, "spin": self.spin, "order": self.order,
                "values": self.values.tolist(),
                "critical_speeds_rad_s": [[c.speed for c in row] for row in self.critical],
                "errors_rad_s": [[c.error for c in row] for row in self.critical],
                "mode_numbers": [[c.number for c in row] for row in self.critical],
                "speed_range_rad_s": list(self.speed_range), "elapsed_s": self.elapsed}

    def __repr__(self) -> str:
        return (f"CriticalSpeedMap({self.parameter}: {len(self.values)} values {self.values[0]:g}…"
                f"{self.values[-1]:g}, up to {self.speeds.shape[1]} critical speeds, {self.elapsed:.2f} s)")


def critical_speed_map(model: Any, values: ArrayLike, spin: str, speeds: ArrayLike, parameter: str | None = None, *,
                       order: float = 1, method: str = "analytic", held: bool | None = None,
                       unit: str = "") -> CriticalSpeedMap:
    """Undamped critical speeds (rad/s) against a parameter (a bearing stiffness): at each of ``values``
    (increasing, positive: the map is log-log) the Campbell diagram of the conservative model over ``speeds``
    (:func:`vibdyn.campbell` with ``undamped=True``: damping and circulatory terms left out, gyroscopic ones
    kept) and its critical speeds of engine ``order``, refined on the linearisation. ``model``: a builder
    ``build(value) -> Scene | System`` or a Scene with ``parameter`` the name of one of its parameters; with a
    builder, ``parameter`` and ``unit`` only name it for tables and pictures."""
    start = time.perf_counter()
    what = "critical_speed_map"
    build, name, unit = _builder(model, parameter, what, unit)
    values = _values(values, what, positive=True)
    rows = []
    for x in values:
        c = campbell(build(x), spin, speeds, (order,), method=method, held=held, undamped=True)
        rows.append(_distinct(c.critical_speeds(order)))
    width = max((len(r) for r in rows), default=0)
    sp = np.ma.masked_all((len(values), width))
    er = np.ma.masked_all((len(values), width))
    for i, row in enumerate(rows):
        for j, cs in enumerate(row):
            sp[i, j], er[i, j] = cs.speed, cs.error
    return CriticalSpeedMap(name, unit, spin, float(order), values, sp, er, tuple(rows),
                            (float(c.speeds[0]), float(c.speeds[-1])), time.perf_counter() - start)


