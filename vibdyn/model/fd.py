"""Finite-difference primitives in the tangent space (configurations moved with ``pin.integrate``, never
q + dq) and point Jacobians: the building blocks of linearisation and of the force elements' derivatives."""

import numpy as np
import pinocchio as pin


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


def point_jacobian(system, q, points):
    """(3·npoints × nv) world displacement of body points per tangent coordinate at q."""
    model, data = system.model, system.workspace().data
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
