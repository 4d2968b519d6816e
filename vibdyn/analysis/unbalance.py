"""Unbalance response: the steady response of a spinning system to its unbalances, speed by speed.

At each speed Ω (rad/s) of the coordinate ``spin``, held there by its drive as in a Campbell diagram
(:func:`vibdyn.campbell`), vibdyn finds the steady motion and linearises about it (M, C, K with their errors,
in the coordinates the held spin leaves free: bearings, gyroscopic and rotating damping included). Each
unbalance U = m·e (kg·m) at a point of a body turning with the spin pulls there with the force U Ω² along its
radius, which turns with the body: over one revolution (T = 2π/|Ω|, sampled at ``samples`` instants of the
spin angle) its generalized force Q(t) is split into harmonics of |Ω| (a rotor whose flexible coordinates are
fixed in space sees Q at 1 × |Ω|; a coordinate turning with the spin, such as a radial slider's, sees it as a
constant), each solved as (K − (k|Ω|)² M + i k|Ω| C) X_k = Q_k, and the outputs are sampled again and
decomposed: the **synchronous** component (1 × |Ω|) of each output, in its own frame (a coordinate's own, a
body point's along a world direction), is the response: y(t) = Re(x e^{i|Ω|t}), t = 0 at the steady
configuration found (the spin coordinate's angle there: the unbalances' angles are measured from it). The linear
model must not change as the spin turns (checked once, at the first speed): a rotor that is not axisymmetric,
seen in coordinates that do not turn with it, is refused.

Unbalances are the scene's :class:`~vibdyn.description.elements.Unbalance` elements and the centres of mass of
the spin's body and of the bodies welded to it that lie off its axis: such a body is linearised with its centre
of mass moved onto the axis (its inertia about that point kept), its offset m·r taken as an unbalance.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from .._check import finite_array
from .._format import number
from ..defaults import RPM
from ..errors import ConvergenceError, ModelError
from ..model.fd import derivative, point_jacobian, second_derivative

EPS = np.finfo(float).eps


@dataclass(frozen=True)
class Load:
    """One unbalance as the analysis uses it: ``amount`` (kg·m) at ``point`` of ``body`` (m, body frame), along
    ``direction`` (body frame, normal to the spin axis); ``source`` "element" or "centre of mass"."""

    name: str
    body: str
    amount: float
    point: tuple
    direction: tuple
    source: str


@dataclass(frozen=True)
class Peak:
    """A resonance of one output: ``speed`` (rad/s, N_c) refined by Brent's method, ``speed_error`` its estimated
    absolute error (rad/s); ``amplitude`` 0-peak there (m or rad) with ``amplitude_error``; ``half_power`` (N₁,
    N₂) rad/s where the amplitude is 1/√2 of the peak (None where the speeds asked do not reach them);
    ``amplification`` N_c/(N₂ − N₁) (API 684's amplification factor, None without both half-power points) with
    ``amplification_error``; ``separation_margin``: the distance from the operating range, as a fraction of its
    nearer end (0 inside it; None without a range)."""

    output: str
    speed: float
    speed_error: float
    amplitude: float
    amplitude_error: float
    half_power: tuple | None
    amplification: float | None
    amplification_error: float | None
    separation_margin: float | None = None

    @property
    def speed_rpm(self) -> float:
        return self.speed * RPM

    def __repr__(self) -> str:
        af = "no amplification factor (a half-power point outside the speeds)" if self.amplification is None else \
            f"AF {self.amplification:.4g} ± {self.amplification_error:.1e}"
        sm = "" if self.separation_margin is None else f", separation margin {100 * self.separation_margin:.1f} %"
        return (f"Peak('{self.output}' at {self.speed:.8g} ± {self.speed_error:.1e} rad/s = {self.speed_rpm:.6g} rpm, "
                f"{self.amplitude:.4g} (0-peak), {af}{sm})")


@dataclass(frozen=True)
class Orbit:
    """The synchronous orbit of a point in the plane normal to the spin axis: ``major`` and ``minor`` semi-axes
    (m, n_speeds each), ``whirl`` "forward", "backward" (relative to the spin) or "" (a line: no whirl within
    the error), ``error`` (m) of the semi-axes, ``angle`` (rad) of the major axis from the plane's x axis."""

    point: str
    major: np.ndarray
    minor: np.ndarray
    whirl: np.ndarray
    angle: np.ndarray
    error: np.ndarray


@dataclass(frozen=True, eq=False)
class UnbalanceResponse:
    """The synchronous response to the unbalances (see :func:`unbalance_response`).

    ``speeds`` (n,) rad/s; ``x`` (n × m) complex synchronous amplitudes, y(t) = Re(x e^{i|Ω|t}); ``amplitude``
    |x| 0-peak (m or rad, ``units``) and ``peak_to_peak`` 2|x|; ``amplitude_error`` the estimated bound of the
    error of each output's response (of its amplitude and of its static part); ``phase`` arg x (rad; −phase is
    the lag behind the angle reference); ``static`` (n × m) the constant part (coordinates turning with the spin
    see the unbalance as a steady load); ``stability`` per speed "stable", "unstable" or "within the error" (the
    largest real part ``growth_rate`` (1/s) of the linear model's eigenvalues against its error: a steady
    response is reached only where stable); ``loads`` the unbalances used; ``elapsed`` s.
    """

    system: object = field(repr=False)
    spin: str
    speeds: np.ndarray
    x: np.ndarray
    amplitude_error: np.ndarray
    static: np.ndarray
    outputs: tuple
    units: tuple
    stability: np.ndarray
    growth_rate: np.ndarray
    loads: tuple
    elapsed: float
    _solver: Any = field(repr=False)
    _q: np.ndarray = field(repr=False)
    _planes: dict = field(repr=False, default_factory=dict)

    @property
    def amplitude(self) -> np.ndarray:
        """0-peak amplitude |x| (m or rad), n_speeds × n_outputs."""
        return np.abs(self.x)

    @property
    def peak_to_peak(self) -> np.ndarray:
        """Peak-to-peak amplitude 2|x| (m or rad), n_speeds × n_outputs."""
        return 2.0 * np.abs(self.x)

    @property
    def phase(self) -> np.ndarray:
        """arg x (rad), n_speeds × n_outputs."""
        return np.angle(self.x)

    @property
    def speeds_rpm(self) -> np.ndarray:
        return self.speeds * RPM

    def column(self, output: Any) -> int:
        """The column of an output, by label or index."""
        if isinstance(output, (int, np.integer)) and not isinstance(output, bool):
            if not 0 <= output < len(self.outputs):
                raise ModelError(f"unbalance response: output index {output} out of range (0…{len(self.outputs) - 1})")
            return int(output)
        if output in self.outputs:
            return self.outputs.index(output)
        raise ModelError(f"unbalance response: no output {output!r}; outputs are {', '.join(self.outputs)}")

    def orbit(self, point: Any) -> Orbit:
        """The orbit at a point given among the outputs as ``(body, (x, y, z))`` (its label or that pair)."""
        try:
            key = point if isinstance(point, str) else _point_label(point)
        except (TypeError, IndexError, ValueError):
            key = repr(point)  # (no point: refused below, listing the orbits there are)
        if key not in self._planes:
            raise ModelError(f"unbalance response: no orbit at {key!r}: give the point as (body, (x, y, z)) among the "
                             f"outputs (orbits: {', '.join(self._planes) or 'none'})")
        i, j, orient = self._planes[key]
        X, Y = self.x[:, i], self.x[:, j]
        fwd, bwd = np.abs(X + 1j * Y) / 2, np.abs(np.conj(X) + 1j * np.conj(Y)) / 2
        err = self.amplitude_error[:, i] + self.amplitude_error[:, j]
        sense = np.sign(self.speeds) * orient
        whirl = np.where(np.abs(fwd - bwd) <= err, "", np.where((fwd - bwd) * sense > 0, "forward", "backward"))
        angle = 0.5 * (np.angle(X + 1j * Y) + np.angle(np.conj(X) + 1j * np.conj(Y)))
        return Orbit(key, fwd + bwd, np.abs(fwd - bwd), whirl.astype(object), angle, err)

    def peaks(self, output: Any = 0, operating: ArrayLike | None = None, *, xtol: float = 1e-10) -> list[Peak]:
        """The resonances of one output: each local maximum of the amplitude on the speeds' grid refined by
        Brent's method (each evaluation a steady motion, a linearisation and a solve), its half-power speeds
        by Brent's root finder, the amplification factor N_c/(N₂ − N₁) and, with ``operating`` = (lowest,
        highest) speed (rad/s), the separation margin. A maximum at the first or last speed, or one within ten
        times its error of zero, is no peak: the speeds must bracket a resonance."""
        from scipy.optimize import brentq, minimize_scalar

        j = self.column(output)
        label = self.outputs[j]
        rng = None if operating is None else finite_array(operating, (2,), "peaks operating range")
        if rng is not None and not rng[0] <= rng[1]:
            raise ModelError(f"peaks: operating range must be (lowest, highest) speed in rad/s, got {operating!r}")
        s, a, e = self.speeds, self.amplitude[:, j], self.amplitude_error[:, j]
        out = []
        for i in range(1, len(s) - 1):
            if not (a[i] > a[i - 1] and a[i] >= a[i + 1]) or a[i] <= 10 * e[i]:
                continue
            cache: dict = {}

            def amp(w, cache=cache):
                if w not in cache:
                    cache[w] = self._solver(w, self._start(w))
                return abs(cache[w][0][j]), cache[w][1][j]

            res = minimize_scalar(lambda w: -amp(w)[0], bracket=(s[i - 1], s[i], s[i + 1]), method="brent",
                                  tol=xtol)
            Nc = float(res.x)
            A, dA = amp(Nc)
            h = 1e-3 * (s[i + 1] - s[i - 1])
            curv = abs(second_derivative(lambda w: amp(w)[0], Nc, h, A)[1])  # |A''| at the peak
            Nc_err = float(np.sqrt(2 * dA / curv) if curv > 0 else s[i + 1] - s[i - 1]) + 2 * xtol * abs(Nc)
            target = A / np.sqrt(2)
            found: list[float] = []
            found_err: list[float] = []
            for side in (-1, 1):
                k = i
                while 0 <= k + side < len(s) and a[k + side] > target:
                    k += side
                if not 0 <= k + side < len(s):
                    break
                lo, hi = sorted((s[k + side], Nc if k == i else s[k]))
                r = brentq(lambda w, target=target: amp(w)[0] - target, lo, hi, xtol=xtol * max(abs(lo), 1.0))
                slope = abs(derivative(lambda w: amp(w)[0], r, h))
                found.append(r)
                found_err.append((amp(r)[1] + dA / np.sqrt(2)) / max(slope, 1e-300))
            half = tuple(found) if len(found) == 2 else None
            af = af_err = None
            if half is not None:
                width = half[1] - half[0]
                af = Nc / width
                af_err = af * (Nc_err / abs(Nc) + (found_err[0] + found_err[1]) / width)
            sm = None
            if rng is not None:
                sm = (rng[0] - abs(Nc)) / rng[0] if abs(Nc) < rng[0] else (abs(Nc) - rng[1]) / rng[1] \
                    if abs(Nc) > rng[1] else 0.0
            out.append(Peak(label, Nc, Nc_err, A, dA, half, af, af_err, sm))
        return out

    def _start(self, speed):
        """The steady configuration at the grid speed nearest ``speed`` (where a refinement starts)."""
        return self._q[int(np.argmin(np.abs(self.speeds - speed)))]

    def plot(self, path: str | None = None, outputs: Any = None, *, units: str = "rad/s", peak_to_peak: bool = False,
             dpi: int = 100) -> Any:
        """Bode plot (matplotlib): amplitude (0-peak, or peak-to-peak) and phase against speed (``units`` "rad/s"
        or "rpm") of ``outputs`` (labels or indices; None: all), error band shaded; saved to ``path`` if given."""
        from ..faces import rotor_plots

        return rotor_plots.bode(self, path, outputs, units=units, peak_to_peak=peak_to_peak, dpi=dpi)

    def polar(self, path: str | None = None, output: Any = 0, *, dpi: int = 100) -> Any:
        """Polar plot (matplotlib) of one output's synchronous response x (real and imaginary parts, speeds
        marked); saved to ``path`` if given."""
        from ..faces import rotor_plots

        return rotor_plots.polar(self, path, output, dpi=dpi)

    def to_dict(self) -> dict:
        return {"spin": self.spin, "speeds_rad_s": self.speeds.tolist(), "outputs": list(self.outputs),
                "units": list(self.units), "amplitude_0_peak": self.amplitude.tolist(),
                "amplitude_peak_to_peak": self.peak_to_peak.tolist(), "amplitude_error": self.amplitude_error.tolist(),
                "phase_rad": self.phase.tolist(), "static": self.static.tolist(),
                "stability": self.stability.tolist(), "growth_rate_1_s": self.growth_rate.tolist(),
                "unbalances": [{"name": u.name, "body": u.body, "amount_kg_m": u.amount, "source": u.source}
                               for u in self.loads], "elapsed_s": self.elapsed}

    def __repr__(self) -> str:
        n, m = self.x.shape
        return (f"UnbalanceResponse('{self.spin}', {n} speeds {number(self.speeds[0])}…{number(self.speeds[-1])} "
                f"rad/s, {m} outputs, {len(self.loads)} unbalances, {self.elapsed:.2f} s)")


def unbalance_response(system: Any, spin: str, speeds: ArrayLike, outputs: Any = None, *, q0: ArrayLike | None = None,
                       method: str = "analytic", samples: int = 16) -> UnbalanceResponse:
    """Steady synchronous response of ``system`` to its unbalances at each speed (rad/s) of the coordinate
    ``spin``, held by its drive (see the module docstring).

    ``outputs``: coordinate names (rad or m), ``(body, (x, y, z), (dx, dy, dz))`` a body point along a world
    direction (m), ``(body, (x, y, z))`` a body point's two world axes normal to the spin axis (two outputs
    labelled ``…·x`` and ``…·y``, and :meth:`UnbalanceResponse.orbit`); None: every free coordinate. ``q0``:
    where the first steady-motion search starts; ``method``: the linearisation's ("analytic" or "fd");
    ``samples``: instants per revolution at which the unbalance forces and the outputs are sampled (even, ≥ 8).
    """
    start = time.perf_counter()
    speeds = finite_array(speeds, None, "unbalance_response speeds").astype(float).ravel()
    if speeds.size < 1 or np.any(np.diff(speeds) <= 0):
        raise ModelError("unbalance_response: speeds must be increasing values (rad/s)")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 8 or samples % 2:
        raise ModelError(f"unbalance_response: samples must be an even integer ≥ 8, got {samples!r}")
    i_spin = system.coordinate_index(spin)
    if system.units[i_spin] != "rad":
        raise ModelError(f"unbalance_response: '{spin}' is not a rotation (its unit is {system.units[i_spin]})")
    _check_tables(system, spin, speeds)
    solver = _Solver(system, spin, outputs, method, int(samples))
    if not solver.loads:
        raise ModelError(f"unbalance_response: no unbalance turns with '{spin}': add one (Scene.add_unbalance) or "
                         "give a body turning with it a centre of mass off the spin axis")
    rows, q, qs = [], q0, []
    for s in speeds:
        rows.append(solver(s, q))
        q = solver.last_q
        qs.append(q)
    x = np.array([r[0] for r in rows])
    err = np.array([r[1] for r in rows])
    static = np.array([r[2] for r in rows])
    growth = np.array([r[3][0] for r in rows])
    stab = np.array([r[3][1] for r in rows], dtype=object)
    return UnbalanceResponse(system, spin, speeds, x, err, static, solver.labels, solver.units, stab, growth,
                             tuple(solver.loads), time.perf_counter() - start, solver, np.array(qs), solver.planes)


class _Solver:
    """The response at one speed: steady motion, linearisation, harmonics of the unbalance forces, outputs."""

    def __init__(self, system, spin, outputs, method, samples):
        self.spin, self.method, self.N = spin, method, samples
        self.i_spin = system.coordinate_index(spin)
        self.last_q = None
        self.steady_checked = False
        self.loads, self.balanced = _loads(system, spin)
        self.system = self.balanced
        self.labels, self.units, self.specs, self.planes = _outputs(system, spin, outputs)

    def __call__(self, speed, q0):
        sys = self.system
        try:
            st = sys.steady_motion({self.spin: float(speed)}, q0=q0)
        except ConvergenceError as e:
            raise ConvergenceError(f"unbalance_response: no steady motion at {self.spin} = {speed:g} rad/s: {e}",
                                   residual=getattr(e, "residual", None), best=getattr(e, "best", None)) from None
        self.last_q = st.q.copy()
        lin = st.linearize(method=self.method, hold=self.spin)
        if not self.steady_checked and speed != 0:
            self._check_steady(lin, st, speed)
        Nsp = getattr(lin, "null_space", None)
        Nsp = np.eye(sys.nv) if Nsp is None else Nsp
        stability = _stability(lin)
        n_out = len(self.labels)
        w0 = abs(float(speed))
        if w0 == 0.0:  # no unbalance force at rest
            return np.zeros(n_out, complex), np.zeros(n_out), np.zeros(n_out), stability
        t = np.arange(self.N) * (2 * np.pi / w0) / self.N
        qs = [pin.integrate(sys.model, st.q, _unit(sys.nv, self.i_spin) * (speed * tj)) for tj in t]
        Q = np.array([Nsp.T @ self._force(qj, speed) for qj in qs])  # N × n
        Qk = np.fft.rfft(Q, axis=0) / self.N  # Q(t) = Σ Re(c_k Qk e^{ikω0t}), c_0 = 1, c_k = 2
        dq = np.zeros((self.N, lin.nv))
        dq_err = np.zeros(lin.nv)
        scale = np.abs(Qk).max()
        for k in range(self.N // 2):
            if np.abs(Qk[k]).max() <= 1e-14 * scale:
                continue
            X, dX = _solve(lin, k * w0, Qk[k] * (1.0 if k == 0 else 2.0))
            dq += np.real(np.exp(1j * k * w0 * t)[:, None] * X[None, :])
            dq_err += dX
        rows = np.array([self._rows(qj, Nsp) for qj in qs])  # N × n_out × n
        y = np.einsum("tok,tk->to", rows, dq)
        Y = np.fft.rfft(y, axis=0) / self.N
        err = np.abs(rows).max(axis=0) @ dq_err + 1e-13 * np.abs(y).max(initial=0.0)
        return 2 * Y[1], err, Y[0].real, stability

    def _check_steady(self, lin, st, speed):
        """Refuse a linear model that changes as the spin turns (a rotor not axisymmetric, seen in coordinates
        that do not turn with it): its response to a rotating force is not harmonic (Hill's method would be
        needed). Checked once, at the first speed, against the model a radian further on."""
        sys = self.system
        q1 = pin.integrate(sys.model, st.q, _unit(sys.nv, self.i_spin))
        other = sys.linearize(q1, v=st.v, method=self.method, hold=self.spin)
        for name in ("M", "C", "K"):
            A, B = getattr(lin, name), getattr(other, name)
            err = 0 if name == "M" else getattr(lin, name + "_error") + getattr(other, name + "_error")
            gap = np.abs(A - B) - 10 * err - 1e-9 * max(np.abs(A).max(initial=0.0), np.abs(B).max(initial=0.0))
            if np.any(gap > 0):
                raise ModelError(f"unbalance_response: the linear model at {self.spin} = {speed:g} rad/s changes as "
                                 f"the spin turns (its {name} by up to {np.abs(A - B).max():.3g}, beyond its error): "
                                 "a rotor that is not axisymmetric, seen in coordinates that do not turn with it, "
                                 "has no harmonic steady response (this analysis assumes one)")
        self.steady_checked = True

    def _force(self, q, speed):
        """Generalized force (nv) of every unbalance at the configuration q: U Ω² along its turned radius."""
        sys = self.system
        out = np.zeros(sys.nv)
        for u in self.loads:
            R, _ = sys.body_pose(u.body, q)
            J = point_jacobian(sys, q, [(u.body, u.point)])
            out += J.T @ (u.amount * speed ** 2 * (R @ np.array(u.direction)))
        return out

    def _rows(self, q, Nsp):
        """Each output's displacement per free coordinate at q (n_out × n)."""
        points = [a for kind, a, _ in self.specs if kind == "point"]
        J = point_jacobian(self.system, q, list(dict.fromkeys(points))) if points else None  # each point once
        where = {p: 3 * k for k, p in enumerate(dict.fromkeys(points))}
        rows = []
        for kind, a, b in self.specs:
            if kind == "coordinate":
                rows.append(Nsp[a])
            else:
                rows.append(b @ J[where[a]:where[a] + 3] @ Nsp)
        return np.array(rows)


def _check_tables(system, spin, speeds):
    """Refuse, before any work, a bearing whose journal turns with the spin and whose table does not cover the
    speeds asked."""
    from ..description.elements import Bearing

    scene = system.scene
    body = next(b for b in scene.bodies.values() if spin in b.coordinates)
    turning = _turning(scene, body)
    lo, hi = float(np.min(speeds)), float(np.max(speeds))
    for e in scene.elements_of(Bearing):
        if e.journal[0] in turning and not e.covers(lo, hi):
            raise ModelError(f"bearing '{e.name}': its table covers {e.speeds[0]:g}…{e.speeds[-1]:g} rad/s, not the "
                             f"speeds asked ({lo:g}…{hi:g} rad/s): extend the table or ask fewer speeds")


def _unit(n, i):
    e = np.zeros(n)
    e[i] = 1.0
    return e


def _solve(lin, w, F):
    """X = (K − w²M + iwC)⁻¹ F and its error bound |A⁻¹| (|δK| + w|δC|) |X| + round-off."""
    A = lin.K - w * w * lin.M + 1j * w * lin.C
    try:
        Ainv = np.linalg.inv(A)
    except np.linalg.LinAlgError:
        raise ModelError(f"unbalance_response: the linear model is singular at {w:.6g} rad/s (a mode of zero "
                         "stiffness or a speed at the stability limit): no steady response there") from None
    X = Ainv @ F
    E = lin.K_error + w * lin.C_error
    cond = np.linalg.norm(A, 1) * np.linalg.norm(Ainv, 1)
    if not np.all(np.isfinite(X)) or cond * EPS > 1e-2:
        raise ModelError(f"unbalance_response: the linear model is singular at {w:.6g} rad/s to double precision "
                         f"(condition number {cond:.2e}): no steady response there")
    return X, np.abs(Ainv) @ (E @ np.abs(X)) + cond * EPS * np.abs(X)


def _stability(lin):
    """(largest Re λ (1/s), verdict) of the linear model's state eigenvalues, against its error."""
    lam = np.linalg.eigvals(lin.A)
    g = float(lam.real.max())
    tol = lin.relative_error * np.abs(lam).max() + 1e-12 * np.abs(lam).max()
    return g, "within the error" if abs(g) <= tol else ("stable" if g < 0 else "unstable")


def _point_label(p):
    from .response.channels import vector_label

    return f"{p[0]}{vector_label(p[1])}"


def _axis(system, spin, q):
    """(world spin axis, a world point on it) at q: the spin joint's axis through its origin."""
    body = next(b for b in system.scene.bodies.values() if spin in b.coordinates)
    i = system.coordinate_index(spin)
    J = point_jacobian(system, q, [(body.name, (0.0, 0.0, 0.0))])
    from ..model.fd import tangent_derivative

    R0, p0 = system.body_pose(body.name, q)
    dR = tangent_derivative(system, lambda qq: pin.log3(system.body_pose(body.name, qq)[0] @ R0.T), q,
                            np.full(system.nv, 1e-6))[:, i]
    a = dR / np.linalg.norm(dR)
    # the origin moves as a × (p0 − c) for a point c on the axis: c = p0 − a × v / |a|² … (v = J[:, i])
    c = p0 + np.cross(a, J[:, i])
    return a, c, body


def _spinning(scene, body):
    """The spin's body and the bodies welded to it (they share its rotation)."""
    out, todo = [body.name], [body.name]
    while todo:
        p = todo.pop()
        for b in scene.children(p):
            if b.joint.nv == 0:
                out.append(b.name)
                todo.append(b.name)
    return out


def _turning(scene, body):
    """The spin's body and all its descendants (every body that turns with the spin)."""
    out, todo = {body.name}, [body.name]
    while todo:
        for b in scene.children(todo.pop()):
            out.add(b.name)
            todo.append(b.name)
    return out


def _loads(system, spin):
    """(unbalances, the system they act on): the scene's Unbalance elements and the off-axis centres of mass of
    the spinning bodies (then a rebuilt system with them on the axis)."""
    from ..description.elements import Unbalance

    scene = system.scene
    q = system.neutral()
    a, c, body = _axis(system, spin, q)
    turning = _turning(scene, body)
    loads, moved = [], {}
    for u in scene.elements_of(Unbalance):
        if u.body not in turning:
            raise ModelError(f"unbalance '{u.name}': body '{u.body}' does not turn with '{spin}'")
        R, _ = system.body_pose(u.body, q)
        ab = R.T @ a
        ref = np.eye(3)[0] if abs(ab[0]) < 0.9 else np.eye(3)[1]
        e1 = ref - ab * (ab @ ref)
        e1 /= np.linalg.norm(e1)
        d = np.cos(u.angle) * e1 + np.sin(u.angle) * np.cross(ab, e1)
        loads.append(Load(u.name, u.body, u.amount, tuple(u.at), tuple(d), "element"))
    L = system.length_scale
    for name in _spinning(scene, body):
        b = scene.bodies[name]
        if b.mass <= 0:
            continue
        R, p = system.body_pose(name, q)
        x = R @ np.array(b.com) + p - c
        r = x - a * (a @ x)
        if np.linalg.norm(r) <= 1e-12 * L:
            continue
        rb = R.T @ r
        loads.append(Load(f"{name} (centre of mass)", name, b.mass * float(np.linalg.norm(r)), tuple(b.com),
                          tuple(rb / np.linalg.norm(rb)), "centre of mass"))
        moved[name] = tuple(np.array(b.com) - rb)
    if not moved:
        return loads, system
    new = scene.copy()
    for name, com in moved.items():
        b = scene.bodies[name]
        delta = np.array(b.com) - np.array(com)
        I = np.array(b.inertia) + b.mass * (delta @ delta * np.eye(3) - np.outer(delta, delta))
        new.bodies[name] = replace(b, com=com, inertia=tuple(tuple(r) for r in I))
    return loads, new.build()


def _outputs(system, spin, outputs):
    """(labels, units, specs, planes): specs ("coordinate", index, None) or ("point", (body, point), direction)."""
    from .._check import unit_axis, vector3

    a, _, _ = _axis(system, spin, system.neutral())
    held = system.coordinate_index(spin)
    items = [c for i, c in enumerate(system.coordinates) if i != held] if outputs is None else (
        [outputs] if isinstance(outputs, str) or _is_point(outputs) else list(outputs))
    if not items:
        raise ModelError("unbalance_response outputs: empty list")
    labels, units, specs, planes = [], [], [], {}
    plane = next(v for k, v in {(0, 0, 1): ((1, 0, 0), (0, 1, 0)), (1, 0, 0): ((0, 1, 0), (0, 0, 1)),
                                (0, 1, 0): ((0, 0, 1), (1, 0, 0))}.items() if abs(np.dot(k, a)) > 1 - 1e-9) \
        if max(abs(a)) > 1 - 1e-9 else _plane(a)
    for item in items:
        if isinstance(item, str):
            i = system.coordinate_index(item)
            labels.append(item)
            units.append(system.units[i])
            specs.append(("coordinate", i, None))
        elif _is_point(item):
            body = system.body_info(item[0]).name
            point = tuple(float(x) for x in vector3(item[1], f"unbalance_response output: point of body '{body}'"))
            key = _point_label((body, point))
            if len(item) == 3:
                d = unit_axis(item[2], f"unbalance_response output: direction at {key}")
                labels.append(f"{key}·{_point_label(('', d))}")
                units.append("m")
                specs.append(("point", (body, point), np.asarray(d, float)))
                continue
            planes[key] = (len(labels), len(labels) + 1, float(np.sign(np.cross(plane[0], plane[1]) @ a)))
            for axis_name, e in zip("xy", plane):
                labels.append(f"{key}·{axis_name}")
                units.append("m")
                specs.append(("point", (body, point), np.asarray(e, float)))
        else:
            raise ModelError(f"unbalance_response outputs: expected a coordinate name, (body, (x, y, z)) or "
                             f"(body, (x, y, z), (dx, dy, dz)), got {item!r}")
    return tuple(labels), tuple(units), specs, planes


def _plane(a):
    ref = np.eye(3)[int(np.argmin(np.abs(a)))]
    e1 = ref - a * (a @ ref)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def _is_point(x):
    if not (isinstance(x, (tuple, list)) and len(x) in (2, 3) and isinstance(x[0], str)) or isinstance(x[1], str):
        return False
    try:
        return np.shape(x[1]) == (3,)
    except ValueError:  # (a list of outputs whose second is a point)
        return False
