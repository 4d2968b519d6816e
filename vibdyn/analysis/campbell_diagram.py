"""Campbell diagrams: the modes of a spinning system against its spin speed, tracked by MAC, with their
whirl direction and the critical speeds where a mode meets an engine order.

At each speed Ω (rad/s) of the coordinate ``spin`` — held at that speed by its drive — vibdyn finds the
steady motion, linearises about it (gyroscopic terms included) in the coordinates the held spin leaves free
(the system's reduction holding it: :meth:`vibdyn.model.reduction.Reduction.holding`) and takes the state
eigenvalues λ. A mode's frequency is |Im λ| (a complex-conjugate pair counted once); a pair of real
eigenvalues (rigid, cyclic or overdamped motion) is one mode of frequency exactly 0. There are as many modes
as free coordinates (all of them, the spin's cyclic zero among them, when the spin is free: ``held=False``,
or a motor law on it).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from .._check import finite_array
from .._deprecation import Renamed
from .._format import number
from ..defaults import RPM
from ..errors import ConvergenceError, ModelError
from ..model.fd import tangent_derivative
from ..solvers.continuation import Arclength, continuation
from ..solvers.roots import bracketed_root, sign_changes, signs
from ..solvers.tracking import assign, mac


@dataclass(frozen=True)
class SpeedModes:
    """The modes of one steady motion: frequencies (rad/s), ζ, whirl, shapes (nv × m, complex, position part
    of the state eigenvectors), each frequency's estimated absolute error (rad/s)."""

    speed: float
    frequencies: np.ndarray
    zeta: np.ndarray
    whirl: np.ndarray
    shapes: np.ndarray
    error: np.ndarray
    q: np.ndarray
    sigma: np.ndarray  # Re λ (1/s) of each mode: the larger of a real pair's

    def log_dec(self) -> tuple[np.ndarray, np.ndarray]:
        """(δ, its error): δ = −2π Re λ / |Im λ| of each mode (see :attr:`Campbell.log_dec`)."""
        return eigen_log_dec(self.sigma, self.frequencies, self.error)


class _ModeAtSpeed:
    """What a critical speed and an onset share: the mode's number and the speed in rpm."""

    mode: int
    speed: float

    @property
    def number(self) -> int:
        """The mode's number as tables and pictures give it (from 1): ``mode + 1``."""
        return self.mode + 1

    @property
    def speed_rpm(self) -> float:
        return self.speed * RPM


@dataclass(frozen=True)
class CriticalSpeed(_ModeAtSpeed):
    """A speed (rad/s) where a mode of the diagram has the frequency ``order`` × speed: mode ``number`` as tables,
    legends and JSON number them (from 1, ascending ω at the first speed), ``mode`` = ``number`` − 1 its column of
    the diagram's arrays (``omega[:, mode]``, 0-based as Python indexes)."""

    speed: float
    mode: int
    whirl: str
    order: float
    omega: float  # rad/s, the mode's ω_d there = order × speed
    error: float  # estimated absolute error of the speed (rad/s)
    frequency = Renamed("omega")

    def __repr__(self) -> str:
        return (f"CriticalSpeed({self.speed:.8g} rad/s = {self.speed_rpm:.6g} rpm, mode {self.number}, "
                f"{self.whirl or 'no'} whirl, order {self.order:g})")


@dataclass(frozen=True)
class Onset(_ModeAtSpeed):
    """A speed (rad/s) where mode ``number`` (from 1; ``mode`` its 0-based column) has Re λ = 0: ``kind``
    "instability" (unstable above it) or "stability" (stable above it); ``omega`` its |Im λ| there (rad/s, in
    the diagram's frame), ``whirl`` its whirl there, ``speed_error`` the estimated error of the speed (rad/s)."""

    speed: float
    speed_error: float
    mode: int
    whirl: str
    omega: float
    kind: str

    def __repr__(self) -> str:
        return (f"Onset({self.kind} at {self.speed:.8g} ± {self.speed_error:.1e} rad/s = {self.speed_rpm:.6g} rpm, "
                f"mode {self.number}, {self.whirl or 'no'} whirl)")


@dataclass(frozen=True, eq=False)
class Campbell:
    """A Campbell diagram (see :func:`campbell`).

    ``speeds`` (n,) rad/s; ``omega`` (n × m) rad/s, the damped ω_d = |Im λ| (the glossary's) of each
    mode (``frequency_hz`` in Hz), one column per mode tracked by MAC from one speed
    to the next (0 for rigid, cyclic and overdamped modes); ``zeta`` (n × m) damping ratios;
    ``whirl`` (n × m) "forward", "backward" or "" (no whirl: a planar or non-oscillating mode);
    ``error`` (n × m) estimated absolute error of each ω (rad/s), and of each λ; ``elapsed`` s; ``held``: True if
    the spin was held at each speed by its drive (it is then no coordinate of the modes), False if it was free;
    ``sigma`` (n × m) Re λ (1/s), the growth rate (negative: the mode decays; the larger of a real pair's);
    ``frame``: the frame in which Im λ, hence ``omega`` and :attr:`log_dec`, is given — vibdyn's coordinates are
    joint coordinates, each measured in its parent body's frame: "fixed" when no coordinate of the modes lies
    below the spinning body, "rotating" when all do (a disk on sliders carried by a spun hub: a rotating frame
    shifts Im λ by Ω, so ω and δ differ from a fixed frame's, Re λ does not), "mixed" otherwise;
    ``undamped``: True if the modes are those of the conservative model (see :func:`campbell`).
    Modes are numbered from 1 in tables, legends and JSON ("mode 1" is column 0 of the arrays).
    """

    system: object = field(repr=False)
    spin: str
    speeds: np.ndarray
    omega: np.ndarray
    zeta: np.ndarray
    whirl: np.ndarray
    error: np.ndarray
    orders: tuple
    method: str
    elapsed: float
    _shapes: list = field(repr=False)
    _q: list = field(repr=False)
    sigma: np.ndarray = field(repr=False)
    held: bool = True
    frame: str = "fixed"
    undamped: bool = False
    frequencies = Renamed("omega")

    @property
    def log_dec(self) -> np.ndarray:
        """Logarithmic decrement δ = −2π Re λ / |Im λ| of every mode at every speed (n × m), in the frame of
        :attr:`frame` (Im λ = ``omega``); 2πζ/√(1 − ζ²) for a mode λ = −ζω_n ± iω_n√(1 − ζ²); negative: unstable.
        A mode of frequency 0 has δ = +inf if it decays (overdamped), −inf if it diverges, 0 if Re λ is 0 within
        its error (rigid or cyclic)."""
        return eigen_log_dec(self.sigma, self.omega, self.error)[0]

    @property
    def log_dec_error(self) -> np.ndarray:
        """Estimated absolute error of :attr:`log_dec` (n × m), from the error of λ."""
        return eigen_log_dec(self.sigma, self.omega, self.error)[1]

    def onset(self) -> list:
        """Each speed where a mode's real part Re λ crosses zero between two speeds of the diagram (outside its
        error at both), refined by Brent's method on the linearisation at that speed, the mode followed by MAC:
        items (:class:`Onset`) with ``.speed``, ``.speed_error`` (rad/s),
        ``.number``, ``.whirl``, ``.omega`` and ``.kind`` ("instability" when the mode turns unstable with
        increasing speed, "stability" when it turns stable), sorted by speed."""
        found = []
        for j in range(self.omega.shape[1]):
            sign = signs(self.sigma[:, j], self.error[:, j])
            for i, n in sign_changes(sign):
                refs = (self._shapes[i][:, j], self._shapes[n][:, j])
                osc = bool(self.omega[i, j] > 0 and self.omega[n, j] > 0)

                def f(speed, refs=refs, osc=osc, q0=self._q[i], near=0.5 * (self.omega[i, j] + self.omega[n, j])):
                    sm = self.at(speed, q0)
                    k = pick(refs, sm, osc, near)
                    return (sm.sigma[k], sm.error[k]), (str(sm.whirl[k]), float(sm.frequencies[k]))

                s, err, extra = bracketed_root(f, float(self.speeds[i]), float(self.speeds[n]),
                                               (self.sigma[i, j], self.error[i, j]),
                                               (self.sigma[n, j], self.error[n, j]),
                                               f"campbell: the onset of mode {j + 1}")
                whirl, omega = extra or (str(self.whirl[i, j]), float(self.omega[i, j]))
                found.append(Onset(s, err, j, whirl, omega, "instability" if sign[n] > 0 else "stability"))
        return sorted(found, key=lambda o: o.speed)

    @property
    def frequency_hz(self) -> np.ndarray:
        """ω_d / 2π (Hz), n × m."""
        return self.omega / (2 * np.pi)

    def at(self, speed: float, q0: ArrayLike | None = None) -> SpeedModes:
        """The modes at one ``speed`` (rad/s) as the diagram finds them (its spin, method, hold and damping),
        sorted by frequency (not yet tracked); the steady-motion search starts from ``q0``."""
        return speed_modes(self.system, self.spin, speed, q0, self.method, self.held, self.undamped)

    def critical_speeds(self, order: float = 1) -> list[CriticalSpeed]:
        """Speeds in the diagram's range where a mode's frequency equals ``order`` × |Ω|, refined on the
        linearisation itself: the crossing of the engine-order line μ|Ω| with the mode's line is continued in μ
        (the solver kit's pseudo-arclength, :func:`vibdyn.solvers.continuation.continuation`) from the
        bracket's end, where μ = ω/|Ω|, to μ = ``order``, solved there to 1e-12 relative (a fold on the way, a
        mode line tangent to an order line, is located, not stepped over); zero-frequency modes never count.
        The frequencies are those of the diagram's :attr:`frame`: in a rotating frame an unbalance is a static
        load, and its resonance is where a mode's frequency there is 0, not a crossing of the 1× line. Where the
        followed mode changes identity inside a bracket, a ConvergenceError asks for more speeds there."""
        order = finite_array(order, None, "critical_speeds order").item()
        if order <= 0:
            raise ModelError(f"critical_speeds: order must be positive, got {order}")
        found = []
        for j in range(self.omega.shape[1]):
            f = self.omega[:, j]
            g = f - order * np.abs(self.speeds)
            for i in range(len(self.speeds) - 1):
                # (a mode of frequency 0 at one end only, an eigenvalue pair lost in round-off beside a fast one, or a
                # mode turning overdamped, still meets the order line: zero at both ends, or at a crossing, it does not)
                if (f[i] <= 0 and (f[i + 1] <= 0 or g[i] == 0)) or (f[i + 1] <= 0 and g[i + 1] == 0) \
                        or g[i] * g[i + 1] > 0 or (g[i] == 0 and i > 0):
                    continue
                a, b = self.speeds[i], self.speeds[i + 1]
                refs = (self._shapes[i][:, j], self._shapes[i + 1][:, j])
                q0 = self._q[i]

                what = f"campbell: the crossing of mode {j + 1} with order {order:g}"

                def h(x, refs=refs, q0=q0, near=0.5 * (f[i] + f[i + 1])):
                    sm = self.at(x, q0)
                    k = pick(refs, sm, near=near)
                    return (sm.frequencies[k] - order * abs(x), sm.error[k]), None

                root_error = 0.0
                if g[i] == 0:
                    s = a
                elif g[i + 1] == 0:
                    s = b
                else:
                    try:
                        s = self._crossing(refs, q0, a, b, f[i], f[i + 1], order,
                                           max(self.error[i, j], self.error[i + 1, j]))
                    except ConvergenceError:  # (a mode line far below the bracket's end: Ω = ω/μ bends sharply)
                        s = np.nan
                    if not a <= s <= b:  # the continuation left the bracket (|Ω| is even in Ω) or stalled: Brent
                        s, root_error = _root(h, a, b, (g[i], self.error[i, j]), (g[i + 1], self.error[i + 1, j]),
                                              what)
                sm = self.at(s, q0)
                k = pick(refs, sm, near=0.5 * (f[i] + f[i + 1]))
                slope = abs(order - (f[i + 1] - f[i]) / (b - a) * np.sign(s)) or 1.0
                error = float(max(sm.error[k] / slope + 1e-12 * abs(s), root_error))
                if g[i] != 0 and g[i + 1] != 0 and not _brackets(h, s, error, a, b):
                    # (the continuation's tolerance, or a secant slope across a wide bracket, does not hold the root
                    # within the stated error: Brent on the bracket, narrowed)
                    s, error = _root(h, a, b, (g[i], self.error[i, j]), (g[i + 1], self.error[i + 1, j]), what)
                    sm = self.at(s, q0)
                    k = pick(refs, sm, near=0.5 * (f[i] + f[i + 1]))
                found.append(CriticalSpeed(float(s), j, str(sm.whirl[k]), order, float(order * abs(s)), error))
        return sorted(found, key=lambda c: c.speed)

    def _crossing(self, refs, q0, a, b, fa, fb, order, error) -> float:
        """The speed in (a, b) where the mode most like ``refs`` has ω = order·|Ω|: F(Ω, μ) = (ω(Ω) − μ|Ω|)/ω₀
        continued in μ from the end with Ω ≠ 0 (ω₀ = ω there) to μ = order, solved to 1e-12 or, where ω itself
        is less accurate, to its ``error`` (rad/s)."""
        seen = [(a, fa), (b, fb)]  # (Ω, ω) evaluated so far: the Jacobian is the secant of the last two

        cache = {a: fa, b: fb}

        def omega(speed):
            if speed in cache:  # the continuation's end solve starts where its corrector stopped
                return cache[speed]
            sm = self.at(speed, q0)
            w = cache[speed] = sm.frequencies[pick(refs, sm, near=0.5 * (fa + fb))]
            if all(abs(speed - x) > 1e-9 * abs(b - a) for x, _ in seen[-2:]):
                seen.append((speed, w))
            return w

        s0, f0 = (a, fa) if a != 0 and fa > 0 else (b, fb)
        if s0 == 0 or f0 <= 0:  # (no end to start μ = ω/|Ω| from: Brent on the bracket instead)
            raise ConvergenceError("campbell: no end of the bracket to continue the crossing from", best=None)
        mu0 = f0 / abs(s0)
        scale = np.array([abs(b - a), max(abs(order - mu0), 1e-12 * order)])
        tol = max(1e-13, 1e-3 * error / f0)
        def jacobian(x, mu):  # the secant method's slope (superlinear), no eigen-solves of its own
            (x1, w1), (x2, w2) = seen[-2:]
            return np.array([[((w2 - w1) / (x2 - x1) - mu * np.sign(x[0])) / f0, -abs(x[0]) / f0]])

        branch = continuation(lambda x, mu: np.array([(omega(x[0]) - mu * abs(x[0])) / f0]), np.array([s0]), mu0,
                              order, jacobian=jacobian, path=Arclength(step=2.0, tol=tol, scale=scale, max_steps=50),
                              parameter="the mode's frequency over the speed (the engine order)")
        if branch.status != "finished":
            raise ConvergenceError(f"campbell: the crossing of a mode with engine order {order:g} in "
                                   f"[{a:g}, {b:g}] rad/s could not be followed: {branch.message}",
                                   residual=branch.residual, best=None)
        return float(branch.x[-1, 0])

    def plot(self, path: str | None = None, dpi: int = 100, *, units: str = "rad/s", frequency: str = "Hz") -> Any:
        """The Campbell diagram (matplotlib): each mode's frequency against the speed, forward whirl solid,
        backward dashed, engine orders thin grey lines labelled inside the axes, critical speeds circled and
        labelled clear of the curves, modes numbered from 1. ``units``: the speed axis, "rad/s" or "rpm";
        ``frequency``: "Hz" or "rad/s". Saves to ``path`` if given."""
        from ..faces import campbell_plot

        return campbell_plot.campbell(self, path=path, units=units, frequency=frequency, dpi=dpi)

    def to_dict(self) -> dict:
        """Plain JSON: SI values under keys naming their units, modes numbered from 1 (each critical speed's
        ``mode_number``; row k of the arrays is mode k + 1), an infinite log decrement as "inf" or "-inf"."""
        return {"spin": self.spin, "spin_held": self.held, "speeds_rad_s": self.speeds.tolist(),
                "omega_rad_s": self.omega.tolist(), "zeta": self.zeta.tolist(),
                "whirl": self.whirl.tolist(), "error_rad_s": self.error.tolist(), "method": self.method,
                "sigma_1_s": self.sigma.tolist(), "frame": self.frame, "undamped": self.undamped,
                "log_dec": _json_numbers(self.log_dec), "log_dec_error": self.log_dec_error.tolist(),
                "modes_numbered_from": 1,
                "critical_speeds": [
                    {"order": c.order, "speed_rad_s": c.speed, "mode_number": c.number, "whirl": c.whirl,
                     "error_rad_s": c.error}
                    for o in self.orders for c in self.critical_speeds(o)],
                "elapsed_s": self.elapsed}

    def __repr__(self) -> str:
        n, m = self.omega.shape
        return (f"Campbell('{self.spin}', {n} speeds {number(self.speeds[0])}…{number(self.speeds[-1])} rad/s, "
                f"{m} modes, {self.elapsed:.2f} s)")


def campbell(system: Any, spin: str, speeds: ArrayLike, orders: ArrayLike = (1,), *, q0: ArrayLike | None = None,
             method: str = "analytic", held: bool | None = None, undamped: bool = False) -> Campbell:
    """Campbell diagram of ``system`` against the speed of coordinate ``spin`` (rad/s), held by its drive.

    ``held``: True, the spin is held at each speed by its drive, which absorbs whatever would change it: the
    modes are those of the other coordinates (a pendulum on a hub spun at Ω: the bead on a rotating hoop);
    False, the spin is free at each steady motion (its own coordinate of the modes, a cyclic zero among
    them); None (default): held, unless a joint-force law on the spin depends on its speed (a motor law
    τ(ω): the motor is the drive, its speed stiffness dτ/dω part of the modes), then free.

    ``speeds``: increasing speeds (rad/s); ``orders``: engine orders for :meth:`Campbell.critical_speeds`
    and the plot; ``q0``: where the first steady-motion search starts (each next one starts from the
    previous); ``method``: the linearisation method ("analytic" or "fd"); ``undamped``: True for the modes of the
    conservative model — the linearisation's symmetric damping D and circulatory stiffness N left out, its mass,
    gyroscopic G and symmetric stiffness K_s kept — whose critical speeds are the undamped critical speeds
    (API 684's map, :func:`vibdyn.analysis.rotor_stability.critical_speed_map`).
    """
    start = time.perf_counter()
    speeds = finite_array(speeds, None, "campbell speeds").astype(float).ravel()
    if speeds.size < 2 or np.any(np.diff(speeds) <= 0):
        bad = np.flatnonzero(np.diff(speeds) <= 0)
        where = f" (speeds[{bad[0] + 1}] = {speeds[bad[0] + 1]:g} after {speeds[bad[0]]:g})" if bad.size else ""
        raise ModelError(f"campbell: speeds must be at least two increasing values (rad/s){where}")
    if not isinstance(undamped, bool):
        raise ModelError(f"campbell: undamped must be True or False, got {undamped!r}")
    orders = tuple(float(finite_array(o, None, "campbell order").item()) for o in np.atleast_1d(orders))
    check_spin(system, spin, "campbell")
    held = hold(system, spin, held, "campbell")
    rows, q = [], q0
    for s in speeds:
        row = speed_modes(system, spin, s, q, method, held, undamped)
        rows.append(row)
        q = row.q
    cols = [np.arange(rows[0].frequencies.size)]
    for r in range(1, len(rows)):
        cols.append(track_columns(rows[r - 1], rows[r], cols[-1], rows[r - 2].frequencies[cols[-2]] if r > 1 else None,
                           speeds[r - 2:r + 1]))
    freq = np.array([r.frequencies[c] for r, c in zip(rows, cols)])
    zeta = np.array([r.zeta[c] for r, c in zip(rows, cols)])
    whirl = np.array([r.whirl[c] for r, c in zip(rows, cols)])
    err = np.array([r.error[c] for r, c in zip(rows, cols)])
    sigma = np.array([r.sigma[c] for r, c in zip(rows, cols)])
    shapes = [r.shapes[:, c] for r, c in zip(rows, cols)]
    return Campbell(system, spin, speeds, freq, zeta, whirl, err, orders, method, time.perf_counter() - start,
                    shapes, [r.q for r in rows], sigma, held, coordinate_frame(system, spin, held), undamped)


def _root(h, a, b, fa, fb, what) -> tuple[float, float]:
    """(root, its error) of h in [a, b] by Brent's method, whose tolerance (1e-12 of the bracket) is narrowed by
    new brackets of 4 errors' width around the root while they still bracket it (a speed list to 1e9 rad/s)."""
    s, err = bracketed_root(h, a, b, fa, fb, what)[:2]
    for _ in range(4):
        lo, hi = max(a, s - 2 * err), min(b, s + 2 * err)
        if err <= 1e-11 * abs(s) or (lo, hi) == (a, b):
            break
        ends = h(lo)[0], h(hi)[0]
        if ends[0][0] * ends[1][0] > 0:
            break
        s, err = bracketed_root(h, lo, hi, *ends, what)[:2]
    return s, err


def _brackets(h, s, error, a, b) -> bool:
    """Whether h changes sign across [s − 2·error, s + 2·error] (within [a, b]), or is there zero within its own
    error at an end: the root's stated error holds it."""
    ends = [h(x)[0] for x in (max(a, s - 2 * error), min(b, s + 2 * error))]
    return ends[0][0] * ends[1][0] <= 0 or any(abs(v) <= e for v, e in ends)


def eigen_log_dec(sigma: ArrayLike, omega: ArrayLike, error: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(δ, δ error) from Re λ = ``sigma`` (1/s), |Im λ| = ``omega`` (rad/s) and the absolute error of λ (rad/s):
    δ = −2π σ/ω; a mode of frequency 0: +inf (decays), −inf (diverges) or 0 (σ = 0 within its error)."""
    sigma, omega, error = (np.asarray(x, float) for x in (sigma, omega, error))
    osc = omega > 0
    w = np.where(osc, omega, 1.0)
    still = np.where(sigma < -error, np.inf, np.where(sigma > error, -np.inf, 0.0))
    delta = np.where(osc, -2 * np.pi * sigma / w, still) + 0.0  # (+ 0.0: no −0 for an undamped mode)
    delta_error = np.where(osc, 2 * np.pi * error * (1 / w + np.abs(sigma) / w**2), 0.0)
    return delta, delta_error


def _json_numbers(a: np.ndarray) -> list:
    """An array as JSON numbers, ±inf as the strings "inf" and "-inf" (JSON has no infinity)."""
    return [[x if np.isfinite(x) else ("inf" if x > 0 else "-inf") for x in row] for row in a.tolist()]


def coordinate_frame(system, spin: str, held: bool) -> str:
    """Where the modes' coordinates are measured: "fixed" if none lies below the spinning body in the tree,
    "rotating" if all do, else "mixed" (the held spin, or a free spin's own angle, does not count)."""
    bodies = system.scene.bodies
    spinning = next(b.name for b in bodies.values() if spin in b.coordinates)
    below = []
    for b in bodies.values():
        coords = [c for c in b.coordinates if c != spin]
        if not coords:
            continue
        p = b.parent
        while p in bodies and p != spinning:
            p = bodies[p].parent
        below.append(p == spinning)
    return "mixed" if any(below) and not all(below) else "rotating" if below and all(below) else "fixed"


def check_spin(system, spin: str, what: str) -> None:
    """Refuse a ``spin`` that is no rotation coordinate of ``system`` (a ModelError naming it and ``what``), and a
    ``system`` that is none."""
    if not (hasattr(system, "coordinate_index") and hasattr(system, "units")):
        build = " (build it first: scene.build())" if hasattr(system, "build") else ""
        raise ModelError(f"{what}: expected a system{build}, got {type(system).__name__}")
    unit = system.units[system.coordinate_index(spin)]
    if unit != "rad":
        raise ModelError(f"{what}: '{spin}' is not a rotation (its unit is {unit})")


def hold(system, spin: str, held: bool | None, what: str) -> bool:
    """Whether the spin is held at each speed: ``held`` itself, or for None held unless a motor law drives it."""
    if held is None:
        return motor_law(system, spin) is None
    if not isinstance(held, bool):
        raise ModelError(f"{what}: held must be True, False or None, got {held!r}")
    return held


def motor_law(system, spin: str) -> str | None:
    """Name of a joint-force law on coordinate ``spin`` that depends on its speed (a motor law), else None."""
    from ..description.elements import JointForce

    for e in system.scene.elements_of(JointForce):
        if e.velocity_dependent and spin in system.scene.bodies[e.body].coordinates:
            return e.name
    return None


def track_columns(a: SpeedModes, b: SpeedModes, cols_a: np.ndarray, before: np.ndarray | None = None,
           speeds: np.ndarray | None = None) -> np.ndarray:
    """Columns of b in the order of a's tracked columns: the assignment of largest total MAC
    (:func:`vibdyn.solvers.tracking.assign`), ties between shapes alike (a rotating frame's forward and backward
    whirls at high spin have one shape) broken by the squared distance of b's frequencies to each tracked
    mode's, extrapolated linearly from the two speeds before (``before``: their frequencies at ``speeds[0]``).
    Two modes moving by the same amount tie in a sum of distances; their squares do not."""
    fa = np.asarray(a.frequencies[cols_a], float)
    if before is not None and speeds is not None and speeds.size == 3 and speeds[1] > speeds[0]:
        fa = fa + (fa - np.asarray(before, float)) * (speeds[2] - speeds[1]) / (speeds[1] - speeds[0])
    score = np.reshape(mac(a.shapes[:, cols_a], b.shapes), (cols_a.size, b.frequencies.size))
    scale = max(np.abs(fa).max(initial=0.0), np.abs(b.frequencies).max(initial=0.0), 1e-300)
    score = score - 1e-3 * ((fa[:, None] - b.frequencies[None, :]) / scale) ** 2
    return assign(-score)[1]


def pick(refs, sm: SpeedModes, oscillating: bool = True, near: float | None = None) -> int:
    """The oscillating mode (any mode, unless ``oscillating``) of ``sm`` most like the shapes ``refs`` (both ends
    of a bracket: at a degenerate end, such as two whirls at rest, one end's shape alone is ambiguous), the
    frequency nearest ``near`` (rad/s) breaking ties between equal shapes (in a rotating frame a forward and a
    backward whirl can have one shape), as :func:`vibdyn.solvers.tracking.match` does."""
    score = sum(np.atleast_1d(mac(r.reshape(-1, 1), sm.shapes)).ravel() for r in refs)
    if near is not None:
        score = score - 1e-3 * np.abs(sm.frequencies - near) / max(float(np.abs(sm.frequencies).max()), 1e-300)
    return int(np.argmax(np.where(sm.frequencies > 0, score, -np.inf) if oscillating else score))


def speed_modes(system, spin: str, speed: float, q0, method: str, held: bool = True,
                 undamped: bool = False) -> SpeedModes:
    try:
        st = system.steady_motion({spin: float(speed)}, q0=q0)
    except ConvergenceError as e:
        raise ConvergenceError(f"campbell: no steady motion at {spin} = {speed:g} rad/s: {e}",
                               residual=getattr(e, "residual", None), best=getattr(e, "best", None)) from None
    lin = st.linearize(method=method, hold=spin if held else ())
    if undamped:  # the conservative model: M, G, K_s (errors kept)
        lin = replace(lin, C=lin.G, K=lin.K_s)
    m = lin.modes()
    n = lin.nv
    if m.eigenvalues.size:
        lam, shapes, lam_err, zero = m.damped_eigenvalues, m.complex_shapes, m.eigenvalue_relative_error, m.damped_zero
    else:  # undamped and not gyroscopic: real modes, λ = ±iω (or ±ω when unstable)
        lam = np.where(m.unstable, m.omega + 0j, 1j * m.omega)
        shapes, lam_err, zero = m.shapes.astype(complex), m.omega_relative_error, m.rigid
    # zeros are the modes' own verdict (within 10 × their uncertainty of 0): a cyclic coordinate's double
    # zero is a Jordan block, which round-off splits by ±√δ — its uncertainty says so —, while a slow
    # precession (2.5e-3 rad/s beside a spin of 1e6) is an imaginary pair with its own small error
    osc = ~zero & (lam.imag > 0)
    # 2nv state eigenvalues = 2·(oscillating modes) + (real ones): the real ones pair into modes of
    # frequency 0, taken smallest |λ| first (their shapes pair the same way); a zero split into ±iδ is one
    split = zero & (lam.imag > 0)
    idx_real = np.flatnonzero(~osc & ~split)
    idx_real = idx_real[np.argsort(np.abs(lam[idx_real]), kind="stable")]
    pairs = [idx_real[k:k + 2] for k in range(0, len(idx_real), 2)] if m.eigenvalues.size else \
        [np.array([k]) for k in idx_real]
    pairs += [np.array([k]) for k in np.flatnonzero(split)]
    idx_osc = np.flatnonzero(osc)
    freq = np.concatenate([np.abs(lam[idx_osc].imag), np.zeros(len(pairs))])
    mag = np.abs(lam[idx_osc])
    zeta = np.concatenate([-lam[idx_osc].real / np.where(mag > 0, mag, 1.0),
                           [_real_pair_zeta(lam[p]) for p in pairs]])
    sigma = np.concatenate([lam[idx_osc].real, [float(lam[p].real.max()) for p in pairs]])
    # a frequency rounded to 0 is wrong by at least what was rounded away
    err = np.concatenate([lam_err[idx_osc] * mag,
                          [max(m.zero_threshold, float(np.abs(lam[p].imag).max())) for p in pairs]])
    vecs = np.concatenate([shapes[:, idx_osc], np.stack([shapes[:, p[0]] for p in pairs], axis=1)
                           if pairs else np.zeros((shapes.shape[0], 0), complex)], axis=1)
    if freq.size != n:
        raise ModelError(f"campbell: {freq.size} modes at {spin} = {speed:g} rad/s for {n} coordinates "
                         "(a defective state matrix)")
    order = np.argsort(freq, kind="stable")
    whirl = _whirl(system, spin, st.q, vecs[:, order], freq[order], speed)
    return SpeedModes(float(speed), freq[order], zeta[order], whirl, vecs[:, order], err[order], st.q.copy(),
                      sigma[order])


def _real_pair_zeta(lam) -> float:
    """ζ of a mode with real eigenvalues: (λ1 + λ2)/(2√(λ1λ2)) for an overdamped pair, 0 with a zero one."""
    if len(lam) < 2 or np.any(np.abs(lam) == 0):
        return 0.0
    prod = float((lam[0] * lam[1]).real)
    return float(-(lam[0] + lam[1]).real / (2 * np.sqrt(prod))) if prod > 0 else 0.0


def _whirl(system, spin: str, q, shapes, freq, speed) -> np.ndarray:
    """Whirl of each mode in the fixed frame, relative to the spin: the sense in which the spinning body's axis
    (and its origin, on the axis) orbits, and the origins of the massive bodies it carries (a disk on sliders of
    a spun hub). Displacements d(t) = Re(d e^{iωt}) turn about the spin axis e counterclockwise when
    e · Im(d̄ × d) < 0. A carried body's coordinates turn with the spin: a whirl at ω against the spin in that
    frame is, in the fixed frame, at Ω − ω: forward while ω < |Ω|."""
    bodies = system.scene.bodies
    body = next(b.name for b in bodies.values() if spin in b.coordinates)
    i = system.coordinate_index(spin)
    q = system.check_configuration(q)
    carried = [b.name for b in bodies.values() if b.name != body and b.mass > 0 and _below(bodies, b.name, body)]
    poses = [system.body_pose(b, q)[0] for b in [body] + carried]

    def pose(qq):  # each body's rotation (relative to its pose at q) and position
        out = []
        for name, R0 in zip([body] + carried, poses):
            R, p = system.body_pose(name, qq)
            out.append(np.concatenate([pin.log3(R @ R0.T), p]))
        return np.concatenate(out)

    J = tangent_derivative(system, pose, q, np.full(system.nv, 1e-6)).reshape(-1, 6, system.nv)
    axis = J[0, :3, i]
    if np.linalg.norm(axis) == 0:
        return np.full(len(freq), "", dtype=object)
    axis = axis / np.linalg.norm(axis)
    L = system.length_scale
    out = np.full(len(freq), "", dtype=object)
    sense_of_spin = np.sign(speed)

    def sense(d):  # (+ counterclockwise about the axis, the size of d)
        return -float(axis @ np.imag(_cross(d.conj(), d))), float(np.vdot(d, d).real)

    # the coordinates that turn with the spin: those of the bodies below the spinning one
    turning = np.zeros(system.nv, bool)
    for b in carried + [c.name for c in bodies.values() if c.mass == 0 and _below(bodies, c.name, body)]:
        turning[[system.coordinate_index(c) for c in bodies[b].coordinates]] = True
    for k in range(len(freq)):
        if freq[k] <= 0 or sense_of_spin == 0:
            continue
        parts = [sense(L * _cross(J[0, :3] @ shapes[:, k], axis)), sense(J[0, 3:] @ shapes[:, k])]
        total, size = sum(p[0] for p in parts), sum(p[1] for p in parts)
        for b in range(1, len(poses)):  # carried: its sense in the fixed frame from the coordinates that do not
            fixed = sense(J[b, 3:] @ np.where(turning, 0, shapes[:, k]))  # turn, and from those that do, turned
            t, z = sense(J[b, 3:] @ np.where(turning, shapes[:, k], 0))  # into the fixed frame's
            size += z + fixed[1]
            total += fixed[0] + (abs(t) * sense_of_spin if t * sense_of_spin < 0 and freq[k] < abs(speed) else t)
        if abs(total) <= 1e-6 * size:
            continue
        out[k] = "forward" if total * sense_of_spin > 0 else "backward"
    return out


def _cross(a, b):
    """a × b of two 3-vectors, real or complex (np.cross costs ~20 µs a call on 3-vectors)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _below(bodies, name: str, ancestor: str) -> bool:
    """Whether body ``name`` lies below body ``ancestor`` in the tree."""
    p = bodies[name].parent
    while p in bodies and p != ancestor:
        p = bodies[p].parent
    return p == ancestor
