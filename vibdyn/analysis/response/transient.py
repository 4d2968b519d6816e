"""Time responses of the linear model: free response (modal, complex modes, matrix exponential, solve_ivp)
and forced transients (modal Duhamel integrals or exact state-space discretisation with Gauss–Legendre
quadrature of the force).

Why these do not use the steppers of :mod:`vibdyn.simulation` (its ``METHODS`` registry):

- a linear model has closed-form modal solutions and an exact discretisation (e^{Ah} by expm, the force by
  Gauss–Legendre quadrature): "modal" and "state" are exact up to quadrature and round-off, which no
  stepper matches at any cost;
- ``method="ivp"`` exists as the *independent* check of those two and of the simulation itself (the tests
  compare the nonlinear simulation of linear scenes with these responses): it must not share the stepping
  code under test, so it is scipy's public ``solve_ivp`` (DOP853) — an independent implementation;
- layers: the time-response analyses live in the analysis layer (3), the steppers in the time layer (4),
  which builds on the analyses (implicit Jacobians from the linearisation), not the reverse.

Results are :class:`TimeResponse` objects, which follow the time-result protocol shared with the simulation's
``Trajectory`` (:mod:`vibdyn.results`)."""

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from ..._check import count, finite_array, scalar, unit_axis
from ...errors import ModelError
from ...results import TimeResult, check_quantity
from ...solvers.differences import derivative
from .base import reduced, support_input_of
from .channels import channels
from .damping import damped_model
from .frf import EPS


# ====================================================================== time responses
@dataclass(frozen=True, eq=False)
class TimeResponse(TimeResult):
    """A response in time (a :class:`~vibdyn.results.TimeResult`): ``x`` = δq, ``v`` = δv, ``a`` = δa (n_t × nv,
    m or rad and their rates) at times ``t`` (s), measured from the operating point (displacements, not
    configurations: a :class:`~vibdyn.simulation.trajectory.Trajectory`'s ``q``). ``relative_error``: estimated
    error relative to max|δq| (quadrature, eigenvector conditioning or the integrator's tolerance, plus the linear
    model's error drifting the phase over the time span) and ``error`` that absolute, m or rad (as a
    Trajectory's); ``imaginary``: largest imaginary part left by complex modes (relative, round-off).
    ``displacement(outputs)`` maps to body points or coordinates."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    coordinates: tuple
    units: tuple
    method: str
    relative_error: float
    elapsed: float
    linear: object = field(repr=False)
    imaginary: float = 0.0
    position_name = "x"  # the protocol's positions: displacements from the operating point

    def __repr__(self):
        from ..._format import duration, number, summary

        return summary("TimeResponse", f"{self.t.size} times {number(self.t[0])}…{number(self.t[-1])} s" if self.t.size
                       else "empty", f"{len(self.coordinates)} coordinates", self.method,
                       f"relative error {number(self.relative_error, digits=2)}", duration(self.elapsed))

    @property
    def error(self) -> float:
        """Estimated error of the displacements (m or rad), largest over the times and coordinates."""
        return self.relative_error * float(np.abs(self.x).max(initial=0.0))

    def displacement(self, outputs=None, direction=None):
        """Displacements of outputs (coordinate names, body points with a direction; None: all) (n_t × k)."""
        return self.series("displacement", outputs, direction)[2]

    def velocity(self, outputs=None, direction=None):
        return self.series("velocity", outputs, direction)[2]

    def acceleration(self, outputs=None, direction=None):
        return self.series("acceleration", outputs, direction)[2]

    def coordinate(self, name):
        return self.x[:, self.linear.coordinate_index(name)]

    def series(self, quantity="displacement", outputs=None, direction=None):
        """(labels, units, values n_t × k) of outputs (coordinate names, body points with a direction;
        None: every coordinate): δ displacement (m or rad), velocity or acceleration."""
        rate = check_quantity(quantity, "time response")
        ch = channels(self.linear, outputs, direction)
        values = {"displacement": self.x, "velocity": self.v, "acceleration": self.a}[quantity] @ ch.matrix.T
        return list(ch.labels), [u + rate for u in ch.units], values

    def to_dict(self):
        return {**self.time_dict(), "imaginary": self.imaginary}


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
                arr[lin.coordinate_index(key)] = scalar(val, f"{what} {name}['{key}']")
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
    if lin.relative_error:  # the linear model's own error: a relative frequency error drifting the phase over time
        m = lin.modes()
        wmax = max(m.omega.max(initial=0.0), m.omega_n.max(initial=0.0))
        error = error + lin.relative_error * (1 + wmax * float(np.ptp(np.concatenate([[0.0], t]))))
    return TimeResponse(t, q, v, a, tuple(lin.coordinates), tuple(lin.units), method, float(error),
                        time.perf_counter() - start, lin, float(imag))


def _accelerations(model, q, v, g=None):
    rhs = -(q @ model.K.T) - v @ model.C.T
    if g is not None:
        rhs = rhs + g
    return model.lin.solve_mass(rhs.T).T


def free_response(lin, t, x0, v0=None, *, method="auto"):
    """Free response δq(t), δv(t) from δq(0) = ``x0`` and δv(0) = ``v0`` (arrays, or dicts by coordinate
    name) at times ``t`` (s) (:class:`TimeResponse`).

    ``method``: "modal" (real modes: x = Σ φ_r q_r(t), q_r(0) = φ_rᵀ M x0, closed-form modal solutions;
    needs classical damping), "state" (complex modes of the state form; the result is real to round-off,
    reported in ``imaginary``; falls back to "expm" when the state matrix is defective, e.g. rigid modes),
    "expm" (scipy.linalg.expm(A t)), "ivp" (scipy's solve_ivp) or "auto" (modal when classical, else state).
    """
    start = time.perf_counter()
    model = damped_model(lin, None)
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
        growth = m.omega_relative_error.max(initial=0.0) * (1 + m.omega.max(initial=0.0) * np.abs(t).max())
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
    y(t) from the scene's motion or ``motion`` (position(t), velocity(t): 3-vectors, m; a ground record
    :class:`vibdyn.laws.Record` is integrated through each of its samples), along
    ``support_direction`` if given — or a coordinate name, a prescribed joint moving as ``motion``
    (position(t), velocity(t) and, if it has one, acceleration(t), scalars; else ÿ by central differences).

    ``method``: "modal" (modal Duhamel integrals with closed-form modal kernels: classical damping),
    "state" (exact discretisation e^{Ah} with scipy.linalg.expm, any viscous damping), "ivp" (scipy's
    solve_ivp DOP853 at rtol 1e-12: the independent check) or "auto". Modal and state integrate the force
    between time points with 8-point Gauss–Legendre quadrature on sub-steps no longer than 1/|λ|max.
    """
    start = time.perf_counter()
    what = "forced response"
    model = damped_model(lin, None)
    t = _times(t, what, increasing=True)
    x0, v0 = _state0(lin, x0, v0, what)
    g, G = _force_function(lin, t, force, inputs, direction, what)
    prescribed = None
    breaks = np.zeros(0)
    if support is not None:
        how = support_input_of(lin, support, None)
        if how[0] == "support":
            g, G = _support_force(lin, support, motion, support_direction, t, g, G)
            law = motion if motion is not None else lin.system.supports[lin.system.support_index[support]].motion
            breaks = np.asarray(getattr(law, "breakpoints", breaks), dtype=float)  # a record's kinks
        else:
            prescribed = how[1], how[2], _prescribed_motion(motion, support, t[0])
    method = _method(model, method, what)
    if prescribed is None:
        inside = breaks[(breaks > t[0]) & (breaks < t[-1])]
        if inside.size:  # integrate through every kink of a sampled law (no quadrature across one), report at t
            grid = np.union1d(t, inside)
            q, v, a, method, error = _integrate(model, grid, g, G, x0, v0, method)
            keep = np.searchsorted(grid, t)
            return _finish(lin, t, q[keep], v[keep], a[keep], method, error, 0.0, start)
        q, v, a, method, error = _integrate(model, t, g, G, x0, v0, method)
        return _finish(lin, t, q, v, a, method, error, 0.0, start)
    p, free, (y, yd, ydd) = prescribed
    sub = reduced(model, free)
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
        motion = lin.system.supports[lin.system.support_index[name]].motion
    if not (hasattr(motion, "position") and hasattr(motion, "velocity")):
        raise ModelError(f"support '{name}' motion: needs position(t) and velocity(t) (vibdyn.description.laws.Motion)")
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
                         "(vibdyn.description.laws.Motion of scalars)")

    def scalar_of(f, label):
        def fn(s):
            x = np.asarray(f(s), dtype=float)
            if x.size != 1 or not np.isfinite(x).all():
                raise ModelError(f"prescribed joint '{name}': {label}(t) must be one finite number, got {x!r}")
            return float(x.ravel()[0])

        return fn

    y, yd = scalar_of(motion.position, "position"), scalar_of(motion.velocity, "velocity")
    if callable(getattr(motion, "acceleration", None)):  # (a Motion of two callables has none)
        ydd = scalar_of(motion.acceleration, "acceleration")
    else:
        def ydd(s, h=1e-4):  # fourth-order central differences of the velocity
            return derivative(yd, s, h, order=4)
    return y, yd, ydd


def _integrate(model, t, g, G, x0, v0, method):
    """(q, v, a, method, error) of M q̈ + C q̇ + K q = g(t) from (x0, v0) at t[0], on the grid t."""
    lin = model.lin
    nv = lin.nv
    has_force = g is not None or G is not None
    force_at = (lambda times: _evaluate(g, G, t, times)) if has_force else (lambda times: np.zeros((len(times), nv)))
    if method == "ivp":
        A = lin.A
        Minv = lin.solve_mass(np.eye(nv))

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
        Bs = np.vstack([np.zeros((nv, nv)), lin.solve_mass(np.eye(nv))])
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


