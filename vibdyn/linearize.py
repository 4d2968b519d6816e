"""Linearisation about an operating point: M δv̇ + C δv + K δq = B δu, in the tangent space.

M comes from CRBA; K = ∂r/∂q and C = ∂r/∂v with r(q, v) = inverse_dynamics(q, v, a0, t0) = M a0 + b − Q,
by central finite differences (configurations perturbed with ``integrate``) or analytically
(``pin.computeRNEADerivatives`` plus the force elements' own derivatives). Units: K in N/m, N or N·m/rad
per coordinate pair, C in N·s/m or N·m·s/rad, M in kg, kg·m or kg·m².
"""

import time
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin
import scipy.linalg as sla

from ._check import unknown_name
from .errors import ModelError

EPS = np.finfo(float).eps


@dataclass(frozen=True, eq=False)
class LinearModel:
    """Linear model about (q0, v0, t0) with its error estimate and the time it took.

    ``K_error`` and ``C_error`` are elementwise estimates of the absolute error of K and C (zero for an
    exact part); ``error`` is the largest of them relative to the norm of K (or C).
    """

    system: object = field(repr=False)
    q0: np.ndarray
    v0: np.ndarray
    a0: np.ndarray
    t0: float
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    K_error: np.ndarray
    C_error: np.ndarray
    method: str
    elapsed: float  # s
    evaluations: int  # residual evaluations (finite differences) or derivative calls

    def __repr__(self):
        from ._format import duration, number, summary

        kind = "damped" if self.has_damping else "undamped"
        return summary("LinearModel", f"nv = {self.nv}", f"method {self.method}", kind,
                       f"error {number(self.error, digits=2)}", f"{self.evaluations} evaluations",
                       duration(self.elapsed))

    @property
    def coordinates(self):
        return self.system.coordinates

    @property
    def nv(self):
        return self.M.shape[0]

    @property
    def D(self):
        """Damping: symmetric part of C."""
        return 0.5 * (self.C + self.C.T)

    @property
    def G(self):
        """Gyroscopic: skew part of C."""
        return 0.5 * (self.C - self.C.T)

    @property
    def K_s(self):
        """Symmetric part of K (elastic + geometric stiffness)."""
        return 0.5 * (self.K + self.K.T)

    @property
    def N(self):
        """Circulatory: skew part of K (zero at a conservative equilibrium)."""
        return 0.5 * (self.K - self.K.T)

    @property
    def error(self):
        """Largest estimated error of K and C, relative to their norms."""
        k = float(self.K_error.max(initial=0.0) / max(np.abs(self.K).max(initial=0.0), 1e-300))
        c = float(self.C_error.max(initial=0.0) / max(np.abs(self.C).max(initial=0.0), 1e-300))
        return max(k if np.any(self.K) else 0.0, c if np.any(self.C) else 0.0)

    @property
    def has_damping(self):
        return bool(np.any(self.C))

    @property
    def A(self):
        """State matrix of x = (δq, δv): ẋ = A x + B_state u (2nv × 2nv)."""
        n = self.nv
        Minv_K, Minv_C = self._solve_M(self.K), self._solve_M(self.C)
        return np.block([[np.zeros((n, n)), np.eye(n)], [-Minv_K, -Minv_C]])

    def state_input(self, B):
        """State input matrix [[0], [M⁻¹ B]] for a generalized input matrix B (nv × m)."""
        B = np.asarray(B, dtype=float).reshape(self.nv, -1)
        return np.vstack([np.zeros_like(B), self._solve_M(B)])

    def coordinate_row(self, name):
        """(row, unit): the displacement of the coordinate ``name`` per coordinate of this model (nv), and its
        unit ("m" or "rad"); the same row is the generalized force of a unit force on it."""
        i = self.system.coordinate_index(name)
        row = np.zeros(self.nv)
        row[i] = 1.0
        return row, self.system.units[i]

    def joint_input(self, coordinates=None):
        """Input matrix of generalized forces on the named coordinates (nv × m; all if None)."""
        names = self.coordinates if coordinates is None else coordinates
        B = np.zeros((self.nv, len(names)))
        for j, name in enumerate(names):
            B[self.system.coordinate_index(name), j] = 1.0
        return B

    def point_jacobian(self, points):
        """Displacements (m, world axes) of body points per tangent coordinate: (3·npoints × nv).

        ``points``: body names (their origin) or ``(body, (x, y, z))`` with the point in the body frame.
        """
        return point_jacobian(self.system, self.q0, points)

    def point_input(self, points):
        """Input matrix of forces (N, world axes) at body points: Jᵀ (nv × 3·npoints)."""
        return self.point_jacobian(points).T

    def support_input(self, name, step=1e-5):
        """(B_y, B_v): generalized force (N or N·m) per unit displacement (m) and per unit velocity (m/s)
        of the support ``name`` along the world axes (nv × 3 each), by central differences: the linear
        model's base-excitation input, M δv̇ + C δv + K δq = B_y y + B_v ẏ."""
        system = self.system
        if name not in system._support_index:
            raise unknown_name(name, [s.name for s in system.supports], "support", what="support input")
        i = system._support_index[name]

        def residual(x):
            shift = np.zeros((len(system.supports), 6))
            shift[i] = x
            return system._residual(self.q0, self.v0, self.a0, self.t0, shift)

        out = -vector_derivative(residual, np.zeros(6), np.full(6, step * system.length_scale))  # Q = −r
        return out[:, :3], out[:, 3:]

    # responses (vibdyn.response): thin entry points
    def free_response(self, t, x0, v0=None, **kwargs):
        """Free response from δq(0) = x0, δv(0) = v0 at times t (s) (:func:`vibdyn.response.free_response`)."""
        from .response import free_response

        return free_response(self, t, x0, v0, **kwargs)

    def receptance(self, omega, inputs=None, outputs=None, **kwargs):
        """Receptance α(ω) (m/N, ...) between inputs and outputs (:func:`vibdyn.response.receptance`)."""
        from .response import receptance

        return receptance(self, omega, inputs, outputs, **kwargs)

    def harmonic_response(self, omega, force, inputs=None, outputs=None, **kwargs):
        """Steady response to harmonic forces (:func:`vibdyn.response.harmonic_response`)."""
        from .response import harmonic_response

        return harmonic_response(self, omega, force, inputs, outputs, **kwargs)

    def base_response(self, omega, support, direction=None, outputs=None, **kwargs):
        """Steady response to a harmonic motion of a support or prescribed joint: transmissibility
        (:func:`vibdyn.response.base_response`)."""
        from .response import base_response

        return base_response(self, omega, support, direction, outputs, **kwargs)

    def forced_response(self, t, force=None, inputs=None, **kwargs):
        """Transient response to force histories and/or base motion (:func:`vibdyn.response.forced_response`)."""
        from .response import forced_response

        return forced_response(self, t, force, inputs, **kwargs)

    def appropriation(self, mode, inputs=None, **kwargs):
        """Force pattern exciting one undamped mode alone (:func:`vibdyn.response.appropriation`)."""
        from .response import appropriation

        return appropriation(self, mode, inputs, **kwargs)

    def state_space(self, inputs=None, outputs=None, **kwargs):
        """State-space form ẋ = A x + B u, y = C x + D u, x = (δq, δv), for control tools
        (:func:`vibdyn.statespace.state_space`)."""
        from .statespace import state_space

        return state_space(self, inputs, outputs, **kwargs)

    def modes(self, **kwargs):
        """Modal analysis of this linear model (see :func:`vibdyn.modal.modes`)."""
        from .modal import modes

        return modes(self, **kwargs)

    def with_damping(self, C):
        """The same model with the damping matrix C (nv × nv) instead of its own."""
        C = np.asarray(C, dtype=float)
        if C.shape != self.M.shape or not np.all(np.isfinite(C)):
            raise ModelError(f"damping matrix: expected a finite {self.M.shape} array")
        return replace(self, C=C, C_error=np.zeros_like(C))

    def with_rayleigh(self, zeta, omega):
        """Rayleigh damping C = αM + βK_s giving ratios ``zeta`` = (ζ1, ζ2) at ``omega`` = (ω1, ω2) rad/s."""
        from .modal import rayleigh

        alpha, beta = rayleigh(zeta, omega)
        return self.with_damping(alpha * self.M + beta * self.K_s)

    def with_modal_damping(self, zeta):
        """Damping giving the ratio ``zeta`` (one number or one per mode) to each undamped mode:
        C = M Φ diag(2 ζ_r ω_r) Φᵀ M."""
        m = replace(self, C=np.zeros_like(self.C), C_error=np.zeros_like(self.C)).modes()
        z = np.broadcast_to(np.asarray(zeta, dtype=float), m.omega.shape)
        if np.any(z < 0) or not np.all(np.isfinite(z)):
            raise ModelError(f"modal damping ratios must be finite and ≥ 0, got {zeta!r}")
        MPhi = self.M @ m.shapes
        return self.with_damping(MPhi @ np.diag(2 * z * m.omega) @ MPhi.T)

    def summary(self):
        return (f"LinearModel({self.method}, nv={self.nv}, error ≈ {self.error:.1e}, "
                f"{self.elapsed * 1e3:.2f} ms, {self.evaluations} evaluations)")

    def _solve_M(self, B):
        try:
            return sla.cho_solve(sla.cho_factor(self.M), B)
        except (np.linalg.LinAlgError, ValueError):
            self.system._check_mass_matrix(self.q0, "the operating point")
            raise


def operating_point(system, at=None, v=None, t=0.0):
    """(q0, v0, t0) from an equilibrium/steady-motion result, a configuration, or None (neutral)."""
    if at is None:
        q0 = system.neutral()
    elif hasattr(at, "q") and hasattr(at, "v"):
        q0, v = at.q, at.v if v is None else v
        t = getattr(at, "t", t)
    else:
        q0 = at
    q0 = system._q(q0, "operating point q")
    v0 = system._v(np.zeros(system.nv) if v is None else v, "operating point v")
    return q0, v0, system._t(t)


def linearize(system, at=None, *, v=None, t=0.0, a=None, method="fd", step=1e-5):
    """Linear model of ``system`` about ``at`` (an Equilibrium/SteadyMotion, a configuration q, or None
    for the neutral configuration) with velocity ``v`` (zero if None) at time ``t``.

    ``a``: the acceleration of the reference motion; default zero about an equilibrium or steady motion
    (a given speed is held by its drive), else the free acceleration at (q, v, t).
    ``method``: "fd" (central differences with steps ``step`` × scale, scale 1 rad or the scene's length
    scale; error estimated from a second step 2h) or "analytic" (Pinocchio's RNEA derivatives plus the
    force elements' derivatives).
    """
    from ._check import scalar

    start = time.perf_counter()
    step = scalar(step, "linearize step", positive=True)
    q0, v0, t0 = operating_point(system, at, v, t)
    M = system.mass_matrix(q0)
    system._check_mass_matrix(q0, "the operating point", M)
    if a is not None:
        a0 = system._v(a, "a")
    elif hasattr(at, "drive"):  # an equilibrium or steady motion: the reference motion does not accelerate
        a0 = np.zeros(system.nv)
    else:
        a0 = system.accelerations(q0, v0, t0)
    terms = _terms(system, q0, v0, a0, t0)
    if method == "fd":
        K, C, K_err, C_err, n = _finite_differences(system, q0, v0, a0, t0, step, terms)
    elif method == "analytic":
        from .derivatives import analytic_derivatives

        K, C = analytic_derivatives(system, q0, v0, a0, t0)
        # round-off of the terms that cancel in r, per unit coordinate (1 m: length scale, 1 rad)
        unit = steps(system, 1.0)
        K_err = 16 * EPS * (np.abs(K) + terms[:, None] / unit[None, :])
        C_err = 16 * EPS * (np.abs(C) + terms[:, None] / unit[None, :]) if np.any(C) else np.zeros_like(C)
        n = 1
    else:
        raise ModelError(f"linearize: unknown method {method!r} (use 'fd' or 'analytic')")
    for name, X in (("K", K), ("C", C)):
        if not np.all(np.isfinite(X)):
            raise ModelError(f"linearize: {name} is not finite at the operating point")
    return LinearModel(system, q0, v0, a0, t0, M, C, K, K_err, C_err, method, time.perf_counter() - start, n)


def steps(system, step):
    """Finite-difference step per tangent coordinate: ``step`` rad, or ``step`` × length scale m."""
    L = system.length_scale
    return np.array([step * (L if u == "m" else 1.0) for u in system.units])


def tangent_derivative(system, fun, q0, h):
    """∂fun/∂q at q0 by central differences in the tangent space: column k is
    (fun(q0 ⊕ h_k e_k) − fun(q0 ⊖ h_k e_k)) / 2h_k, configurations moved with ``integrate``."""
    model, e = system.model, np.zeros(system.nv)

    def shifted(k, hk):
        e[k] = hk
        y = np.ravel(fun(pin.integrate(model, q0, e)))
        e[k] = 0.0
        return y

    return _columns(shifted, h)


def vector_derivative(fun, x0, h):
    """∂fun/∂x at x0 for a plain vector x, by central differences with steps h (one per component)."""
    def shifted(k, hk):
        x = x0.copy()
        x[k] += hk
        return np.ravel(fun(x))

    return _columns(shifted, h)


def _columns(shifted, h):
    J = None
    for k, hk in enumerate(h):
        col = (shifted(k, hk) - shifted(k, -hk)) / (2 * hk)
        if J is None:
            J = np.empty((col.size, len(h)))
        J[:, k] = col
    return J


def jacobian_q(system, q0, v0, a0, t0, h):
    """∂r/∂q by central differences in the tangent space (steps h per coordinate)."""
    return tangent_derivative(system, lambda q: system._residual(q, v0, a0, t0), q0, h)


def jacobian_v(system, q0, v0, a0, t0, h):
    """∂r/∂v by central differences (steps h per coordinate)."""
    return vector_derivative(lambda v: system._residual(q0, v, a0, t0), v0, h)


def _two_steps(jac, terms, h):
    """Central difference with step h and its error estimate: the change from step 2h (truncation, and
    round-off noise) plus the round-off of the terms that cancel in r (|RNEA| + |Q| + |g| per row)."""
    J1, J2 = jac(h), jac(2 * h)
    return J1, np.abs(J1 - J2) + 16 * EPS * terms[:, None] / h[None, :] + 4 * EPS * np.abs(J1)


def _terms(system, q0, v0, a0, t0):
    """|RNEA| + |Q| + |g| per coordinate: the size of the terms that cancel in r (for round-off)."""
    Q, fext = system._forces(q0, v0, t0)
    tau = pin.rnea(system.model, system.data, q0, v0, a0) if fext is None else pin.rnea(
        system.model, system.data, q0, v0, a0, fext)
    return np.abs(tau) + np.abs(Q) + np.abs(system._gravity_forces(q0))


def _finite_differences(system, q0, v0, a0, t0, step, terms):
    h = steps(system, step)
    K, K_err = _two_steps(lambda hh: jacobian_q(system, q0, v0, a0, t0, hh), terms, h)
    evaluations = 4 * system.nv
    if system.depends_on_velocity or np.any(v0):
        hv = h * np.maximum(1.0, np.abs(v0))
        C, C_err = _two_steps(lambda hh: jacobian_v(system, q0, v0, a0, t0, hh), terms, hv)
        evaluations *= 2
    else:  # nothing depends on velocity and v0 = 0: C is exactly zero
        C, C_err = np.zeros_like(K), np.zeros_like(K)
    return K, C, K_err, C_err, evaluations


def point_jacobian(system, q, points):
    """(3·npoints × nv) world displacement of body points per tangent coordinate at q."""
    model, data = system.model, system.data
    pin.computeJointJacobians(model, data, q)
    rows = []
    for p in points:
        body, point = (p, (0.0, 0.0, 0.0)) if isinstance(p, str) else p
        b = system.body_info(body)
        local = b.body_in_joint.act(np.asarray(point, dtype=float))
        J = pin.getJointJacobian(model, data, b.joint_id, pin.LOCAL).reshape(6, model.nv)
        rows.append(world_point_jacobian(data.oMi[b.joint_id].rotation, J, local))
    return np.vstack(rows) if rows else np.zeros((0, system.nv))


def world_point_jacobian(R, J, r):
    """World-axes velocity Jacobian (3 × nv) of the point r (joint frame) of a joint with rotation R and
    LOCAL Jacobian J (6 × nv): R (J_lin − [r]× J_ang)."""
    return R @ (J[:3] - pin.skew(r) @ J[3:])

