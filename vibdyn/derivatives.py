"""Analytic K and C: Pinocchio's RNEA derivatives plus the derivatives of each force-element group.

r(q, v) = RNEA(q, v, a0, f(q, v)) − Q(q, v), with f the external forces of point elements in the local joint
frames. Pinocchio differentiates RNEA holding f fixed in those frames; the chain rule adds −Σ_j J_jᵀ ∂f_j
and the joint-space groups add −∂Q. ∂f_j/∂q includes the turning of joint j's frame:
∂(Rᵀ F) = Rᵀ ∂F + [Rᵀ F]× Ω_j with Ω_j the local angular Jacobian of joint j.
"""

import numpy as np
import pinocchio as pin

from . import forces as F
from .linearize import steps, tangent_derivative, vector_derivative, world_point_jacobian

_skew = pin.skew


class _PointKinematics:
    """Jacobians of the joints that point elements attach to, and of points on them (world axes)."""

    def __init__(self, system, q, v, a, need_velocity_derivatives):
        model, data = system.model, system.data
        self.nv = system.nv
        pin.computeJointJacobians(model, data, q)
        pin.forwardKinematics(model, data, q, v)
        if need_velocity_derivatives:
            pin.computeForwardKinematicsDerivatives(model, data, q, v, a)
        self.J, self.R, self.u, self.dV = {}, {}, {}, {}
        for j in system._point_joints:
            self.J[j] = pin.getJointJacobian(model, data, j, pin.LOCAL).reshape(6, self.nv).copy()
            self.R[j] = data.oMi[j].rotation.copy()
            vj = data.v[j]
            self.u[j] = (vj.linear.copy(), vj.angular.copy())
            if need_velocity_derivatives:
                dv_dq, _ = pin.getJointVelocityDerivatives(model, data, j, pin.LOCAL)
                self.dV[j] = np.asarray(dv_dq).reshape(6, self.nv).copy()

    def point(self, j, r):
        """World position Jacobian (3 × nv) of the point r (joint frame) on joint j (zero for the world)."""
        if j == 0:
            return np.zeros((3, self.nv))
        return world_point_jacobian(self.R[j], self.J[j], r)

    def point_velocity_dq(self, j, r):
        """∂(world velocity of the point)/∂q (3 × nv)."""
        if j == 0:
            return np.zeros((3, self.nv))
        vl, w = self.u[j]
        u = vl + np.cross(w, r)
        dV = self.dV[j]
        return self.R[j] @ (dV[:3] - _skew(r) @ dV[3:] - _skew(u) @ self.J[j][3:])

    def add_force(self, dFq, dFv, j, r, F_world, dF_dq, dF_dv):
        """Chain rule for a world force F applied at point r of joint j: ∂f_j/∂q, ∂f_j/∂v (6 × nv)."""
        if j == 0:
            return
        R = self.R[j]
        f_loc = R.T @ F_world
        df_q = R.T @ dF_dq + _skew(f_loc) @ self.J[j][3:]
        dFq[j][:3] += df_q
        dFq[j][3:] += _skew(r) @ df_q
        if dF_dv is not None:
            df_v = R.T @ dF_dv
            dFv[j][:3] += df_v
            dFv[j][3:] += _skew(r) @ df_v


def analytic_derivatives(system, q, v, a, t):
    """(K, C) = (∂r/∂q, ∂r/∂v) at (q, v, a, t), analytically."""
    model, data = system.model, system.data
    nv = system.nv
    Q, fext = system._forces(q, v, t)
    out = (pin.computeRNEADerivatives(model, data, q, v, a) if fext is None
           else pin.computeRNEADerivatives(model, data, q, v, a, fext))
    K, C = np.array(out[0]).copy(), np.array(out[1]).copy()  # Pinocchio overwrites them on the next call
    if system._point_groups:
        kin = _PointKinematics(system, q, v, a, need_velocity_derivatives=any(
            isinstance(g, F.Dampers) for g in system.groups))
        fkin = system._kinematics(q, v if system._point_velocities else None, t)
        dFq = {j: np.zeros((6, nv)) for j in system._point_joints}
        dFv = {j: np.zeros((6, nv)) for j in system._point_joints}
        for g in system._point_groups:
            _POINT[type(g)](g, system, kin, fkin, dFq, dFv, q, v, t)
        for j in system._point_joints:
            K -= kin.J[j].T @ dFq[j]
            C -= kin.J[j].T @ dFv[j]
    for g in system.groups:
        if not g.uses_points:
            dq, dv = _JOINT[type(g)](g, system, q, v, t)
            if dq is not None:
                K -= dq
            if dv is not None:
                C -= dv
    return K, C


# ------------------------------------------------------------------ point groups: world-force derivatives
def _springs(g, system, kin, fkin, dFq, dFv, q, v, t):
    xa, xb, d, L = g._geometry(fkin, g.zero_l0)
    for i in range(len(g.k)):
        ja, jb = int(g.ja[i]), int(g.jb[i])
        Jrel = kin.point(jb, g.pb[i]) - kin.point(ja, g.pa[i])
        if g.zero_l0[i]:
            Fb, Ks = -g.k[i] * d[i], g.k[i] * np.eye(3)
        else:
            u = d[i] / L[i]
            ratio = g.l0[i] / L[i]
            Fb = -g.k[i] * (L[i] - g.l0[i]) * u
            Ks = g.k[i] * ((1 - ratio) * np.eye(3) + ratio * np.outer(u, u))
        dF = -Ks @ Jrel
        kin.add_force(dFq, dFv, jb, g.pb[i], Fb, dF, None)
        kin.add_force(dFq, dFv, ja, g.pa[i], -Fb, -dF, None)


def _dampers(g, system, kin, fkin, dFq, dFv, q, v, t):
    xa, xb, d, L = g._geometry(fkin)
    va, vb = g.end_velocities(fkin)
    vrel = vb - va
    for i in range(len(g.c)):
        ja, jb = int(g.ja[i]), int(g.jb[i])
        u = d[i] / L[i]
        Jrel = kin.point(jb, g.pb[i]) - kin.point(ja, g.pa[i])
        dvrel_dq = kin.point_velocity_dq(jb, g.pb[i]) - kin.point_velocity_dq(ja, g.pa[i])
        rate = u @ vrel[i]
        du_dq = (np.eye(3) - np.outer(u, u)) / L[i] @ Jrel
        drate_dq = vrel[i] @ du_dq + u @ dvrel_dq
        Fb = -g.c[i] * rate * u
        dF_dq = -g.c[i] * (np.outer(u, drate_dq) + rate * du_dq)
        dF_dv = -g.c[i] * np.outer(u, u @ Jrel)
        kin.add_force(dFq, dFv, jb, g.pb[i], Fb, dF_dq, dF_dv)
        kin.add_force(dFq, dFv, ja, g.pa[i], -Fb, -dF_dq, -dF_dv)


def _body_forces(g, system, kin, fkin, dFq, dFv, q, v, t):
    """Given vectors: constant (no own derivative) or callables (differenced); body-axes vectors turn with
    the body, world-axes ones turn relative to the joint frame (both handled by the chain rule)."""
    nv = system.nv
    values = lambda qq, vv: np.hstack([g._vectors("force", t, qq, vv), g._vectors("torque", t, qq, vv)])  # noqa
    y = values(q, v).ravel()
    if g.velocity_dependent or any(callable(e.force) or callable(e.torque) for e in g.elements):
        Dq, Dv = _element_fd(system, q, v, t, values)
    else:
        Dq = Dv = np.zeros((y.size, nv))
    for i in range(len(g.elements)):
        j, r = int(g.jp[i]), g.pp[i]
        if j == 0:
            continue
        (f, df_q, df_v), (tq, dt_q, dt_v) = (_to_world(kin, j, g.Rb[i], g.body_axes[i], y[6 * i + o:6 * i + o + 3],
                                                        Dq[6 * i + o:6 * i + o + 3], Dv[6 * i + o:6 * i + o + 3])
                                              for o in (0, 3))
        kin.add_force(dFq, dFv, j, r, f, df_q, df_v)
        R = kin.R[j]
        dFq[j][3:] += R.T @ dt_q + _skew(R.T @ tq) @ kin.J[j][3:]
        dFv[j][3:] += R.T @ dt_v


def _to_world(kin, j, Rb, body_axes, x, dx_q, dx_v):
    """A vector given in world or body axes, in world axes, with its derivatives (3 × nv)."""
    if not body_axes:
        return x, dx_q, dx_v
    Rw = kin.R[j] @ Rb
    return Rw @ x, Rw @ dx_q - kin.R[j] @ _skew(Rb @ x) @ kin.J[j][3:], Rw @ dx_v


_POINT = {F.Springs: _springs, F.Dampers: _dampers, F.BodyForces: _body_forces}


# ------------------------------------------------------------------ joint-space groups: ∂Q/∂q, ∂Q/∂v
def _joint_springs(g, system, q, v, t):
    nv = system.nv
    dQ = np.zeros((nv, nv))
    if g.vector:
        dQ[g.iv, g.iv] = -g.k
        return dQ, None
    J = pin.dDifference(g.model, g.q_rest, q, pin.ARG1)[np.ix_(g.iv, g.iv)]
    dQ[np.ix_(g.iv, g.iv)] = -(g.k[:, None] * J)
    if g.curved is not None:  # Q = −Jᵀ K φ: the turning of J is differenced on the group alone
        Qg = lambda qq: _group_force(g, system, qq, v, t)  # noqa: E731
        fd = _element_fd(system, q, v, t, lambda qq, vv: Qg(qq), with_v=False)
        dQ[:, g.iv[g.curved]] = fd[0][:, g.iv[g.curved]]
    return dQ, None


def _joint_dampers(g, system, q, v, t):
    dV = np.zeros((system.nv, system.nv))
    np.add.at(dV, (g.iv, g.iv), -g.c)
    return None, dV


def _joint_forces(g, system, q, v, t):
    if not g.laws:
        return None, None
    from .laws import Harmonic, Polynomial

    nv = system.nv
    dQ, dV = np.zeros((nv, nv)), np.zeros((nv, nv))
    for e, b in g.laws:
        law = e.value
        if isinstance(law, Polynomial):
            c = np.asarray(law.coefficients)
            dV[b.idx_v, b.idx_v] += np.polynomial.polynomial.polyval(v[b.idx_v], np.arange(1, c.size) * c[1:])
        elif not isinstance(law, Harmonic):  # a user callable: differenced on its own
            one = F.JointForces(system, [e])
            fd = _element_fd(system, q, v, t, lambda qq, vv: _group_force(one, system, qq, vv, t))
            dQ += fd[0]
            dV += fd[1]
    return dQ, dV


_JOINT = {F.JointSprings: _joint_springs, F.JointDampers: _joint_dampers, F.JointForces: _joint_forces}


def _group_force(g, system, q, v, t):
    Q = np.zeros(system.nv)
    g.apply(t, q, v, None, Q, None)
    return Q


def _element_fd(system, q, v, t, fun, with_v=True):
    """Central differences of an element's own output (for user callables, which have no derivative)."""
    h = steps(system, 1e-6)
    Dq = tangent_derivative(system, lambda qq: fun(qq, v), q, h)
    Dv = vector_derivative(lambda vv: fun(q, vv), v, h) if with_v else np.zeros_like(Dq)
    return Dq, Dv
