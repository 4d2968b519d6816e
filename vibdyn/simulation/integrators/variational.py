"""A variational (symplectic) integrator on the configuration Lie group, for long conservative runs.

Discrete Lagrangian of the midpoint rule along the group's one-parameter subgroups:

    L_d(q0, q1) = h T(q_m, u),   ξ = q1 ⊖ q0 (= difference),  q_m = q0 ⊕ ξ/2,  u = ξ/h,

whose velocity u is exact along q0 ⊕ sξ/h (Pinocchio's integrate is the body-frame exponential). Every
applied force — gravity and springs included — enters by the discrete Lagrange–d'Alembert principle at the
midpoint, h F(q_m, u, t_m) · δq_m; for a conservative force that is exactly the variation of −h V(q_m), so the
map is symplectic and, for a symmetric scene, conserves the discrete momentum maps (discrete Noether).
In left-trivialised momenta p (p = M v at a step point), with A0, A1 = ∂ξ/∂q0, ∂ξ/∂q1 (dDifference) and
I0, I1 = ∂q_m/∂q0, ∂q_m/∂(ξ/2) (dIntegrate), G = ∂T/∂q(q_m, u) + F:

    p0 = −A0ᵀ M(q_m) u − h (I0 + ½ I1 A0)ᵀ G      (solved for ξ by Newton)
    p1 =  A1ᵀ M(q_m) u + ½ h (I1 A1)ᵀ G

(vector joints: A0 = −1, A1 = I0 = I1 = 1, the classical midpoint variational integrator). The left-
trivialised gradient of the kinetic energy at fixed v is ∂T/∂q = C(q, v)ᵀ v − ad*_v(M v) with Pinocchio's
Coriolis matrix (Ṁ = C + Cᵀ) and ad* on each ball, free or planar joint (zero on vector joints).
Second order, time-symmetric; velocities at step points are v = M⁻¹ p.
"""

import numpy as np
import pinocchio as pin

from ...model import dynamics
from ...model.derivatives import linear_terms
from ...model.points import cross
from .base import StepError, Stepper

ARG0, ARG1 = pin.ArgumentPosition.ARG0, pin.ArgumentPosition.ARG1


def kinetic_gradient(system, q, v):
    """∂T/∂q at fixed v (left-trivialised: d/dε T(integrate(q, ε δ), v) = ∂T/∂q · δ), exactly:
    C(q, v)ᵀ v − ad*_v(M v)."""
    M = system.mass_matrix(q)
    C = pin.computeCoriolisMatrix(system.model, system.data, q, v)
    return C.T @ v - AdStar(system)(v, M @ v)


class AdStar:
    """ad*_u(μ) on the curved joints (zero on vector joints): μ × ω on a ball; on SE(3) with u = (v, ω),
    μ = (f, n): (f × ω, f × v + n × ω); on SE(2) the same restricted to the plane."""

    def __init__(self, system):
        def blocks(group, width):
            return np.array([b.idx_v + np.arange(width) for b in system.body_infos.values()
                             if b.joint.lie_group == group], dtype=int).reshape(-1, width)

        self.nv = system.nv
        self.ball, self.free, self.planar = blocks("SO3", 3), blocks("SE3", 6), blocks("SE2", 3)

    def __call__(self, u, mu):
        out = np.zeros(self.nv)
        if self.ball.size:
            out[self.ball] = cross(mu[self.ball], u[self.ball])
        if self.free.size:
            i, j = self.free[:, :3], self.free[:, 3:]
            out[i] = cross(mu[i], u[j])
            out[j] = cross(mu[i], u[i]) + cross(mu[j], u[j])
        if self.planar.size:
            (vx, vy, w), (fx, fy, _) = u[self.planar].T, mu[self.planar].T
            out[self.planar] = np.stack([fy * w, -fx * w, fx * vy - fy * vx], axis=-1)
        return out


class Variational(Stepper):
    """Fixed-step midpoint variational integrator (see the module docstring); ``step_to`` advances it."""

    name = "symplectic"
    order = 2
    error_methods = ("richardson",)
    MAX_ITER = 12

    def __init__(self, system, q0, v0, t_end, **kwargs):
        super().__init__(system, q0, v0, t_end, **kwargs)
        self.model = system.model
        self.ws = system.workspace()  # the calling thread's: one simulation runs in one thread
        self.curved = system.nq != system.nv
        self.q, self.v = np.array(q0, dtype=float), np.array(v0, dtype=float)
        self.p = system.mass_matrix(self.q) @ self.v
        self.w = 0.0
        self.nfev = 0
        self._W = None  # inverse of the Newton matrix ∂R/∂ξ, and the step it was made for
        self.adstar = AdStar(system) if self.curved else None
        self._lower = np.tril_indices(system.nv, -1)

    @property
    def state(self):
        return self.q.copy(), self.v.copy(), self.w

    def _terms(self, xi, h, t_mid):
        """Residual R(ξ) of the first equation, and q1, p1 and the step's work of the force elements.

        G = ∂T/∂q + F with F = Q + Jᵀf − g the applied forces, computed as G = −r + Ṁu − ad*_u(M u) from the
        inverse-dynamics residual r = RNEA(q, u, 0) − Q = C u + g − Q − Jᵀf and Ṁ = C + Cᵀ."""
        system, model, ws, q0 = self.system, self.model, self.ws, self.q
        data = ws.data
        self.nfev += 1
        half = 0.5 * xi
        q_m = pin.integrate(model, q0, half) if self.curved else q0 + half
        u = xi / h
        r = dynamics.inverse_dynamics(system, ws, q_m, u, np.zeros_like(u), t_mid)
        C = pin.computeCoriolisMatrix(model, data, q_m, u)
        Cu = C @ u
        M = self._mass(q_m)
        mu = M @ u
        G = Cu + C.T @ u - r
        work = h * (u @ (Cu - r + dynamics.gravity_term(system, ws, q_m))) if self.work else 0.0
        if self.curved:
            G -= self.adstar(u, mu)
            q1 = pin.integrate(model, q0, xi)
            A0, A1 = pin.dDifference(model, q0, q1, ARG0), pin.dDifference(model, q0, q1, ARG1)
            I0, I1 = pin.dIntegrate(model, q0, half, ARG0), pin.dIntegrate(model, q0, half, ARG1)
            R = self.p + A0.T @ mu + h * ((I0 + 0.5 * I1 @ A0).T @ G)
            p1 = A1.T @ mu + 0.5 * h * ((I1 @ A1).T @ G)
        else:
            q1 = q0 + xi
            R = self.p - mu + 0.5 * h * G
            p1 = mu + 0.5 * h * G
        return R, q1, p1, work

    def _mass(self, q):
        """M(q) by CRBA (upper triangle) made symmetric, without input checks."""
        M = pin.crba(self.model, self.ws.data, q)
        M[self._lower] = M.T[self._lower]
        return M

    def _newton_matrix(self, xi, h, t_mid):
        """Inverse of −(M/h + h K/4 + C/2) at the midpoint (analytic linearisation): ∂R/∂ξ to leading order
        (the simplified Newton iteration reuses it while it contracts)."""
        system = self.system
        q_m = pin.integrate(self.model, self.q, 0.5 * xi) if self.curved else self.q + 0.5 * xi
        M, K, C = linear_terms(system, q_m, xi / h, t_mid)
        self.njev += 1
        self.nlu += 1
        self._W = (np.linalg.inv(-(M / h + 0.25 * h * K + 0.5 * C)), h)

    def _step_impl(self, t_new):
        h = t_new - self.t
        t_mid = self.t + 0.5 * h
        a = dynamics.accelerations(self.system, self.ws, self.q, self.v, self.t)
        self.nfev += 1
        guess = h * self.v + 0.5 * h * h * a  # second-order guess
        fresh = False
        if self._W is None or abs(self._W[1] - h) > 1e-6 * h:
            self._newton_matrix(guess, h, t_mid)
            fresh = True
        while True:
            done, xi, terms = self._solve(guess, h, t_mid)
            if done:
                break
            if fresh:
                raise StepError(f"the variational step of {h:.3g} s did not converge (Newton): take a smaller dt "
                                "or, for a stiff or strongly damped scene, method='radau'")
            self._newton_matrix(guess, h, t_mid)  # an old Newton matrix: refresh it and start again
            fresh = True
        _, q1, p1, work = terms
        if not (np.all(np.isfinite(q1)) and np.all(np.isfinite(p1))):
            raise StepError(f"the state is not finite after a step of {h:.3g} s")
        self.q, self.p, self.t = q1, p1, t_new
        self.v = np.linalg.solve(self._mass(q1), p1)
        if self.work:
            self.w += work
        self.accepted += 1

    def _solve(self, xi, h, t_mid):
        """Simplified Newton on R(ξ) = 0 down to round-off: (converged, ξ, terms at ξ)."""
        W_inv = self._W[0]
        previous = np.inf
        for _ in range(self.MAX_ITER):
            terms = self._terms(xi, h, t_mid)
            if not np.all(np.isfinite(terms[0])):
                return False, xi, terms
            delta = W_inv @ terms[0]
            size, scale = np.abs(delta).max(), np.abs(xi).max()
            if size <= 4 * np.finfo(float).eps * scale or size == 0.0:
                return True, xi, terms
            if size > 0.5 * previous:  # no longer contracting: round-off floor, or a poor Newton matrix
                return size <= 1e-11 * scale, xi, terms
            xi = xi - delta
            previous = size
        return False, xi, terms
