"""Finite-difference primitives in the tangent space (configurations moved with ``pin.integrate``, never
q + dq) and point Jacobians: the building blocks of linearisation and of the force elements' derivatives.

A derivative column k is the central difference D(h) = (f(+h_k) − f(−h_k)) / 2h_k along tangent
coordinate k, with truncation error h²/6·f‴ + O(h⁴). Where an error estimate is asked for, the central
difference with step 2h is made too, and T = D(h) − D(2h) = −h²/2·f‴ + O(h⁴) (Richardson: three times the
truncation error, to leading order). All displaced configurations of a sweep are made at once
(:class:`Stencil`) so that a caller can evaluate them in one pass
(:func:`vibdyn.model.dynamics.inverse_dynamics_rows`); a stencil with an estimate starts with the operating
point itself (the caller's round-off scale).

Every difference quotient of the package is made here or in the kit this module builds on and re-exports,
:mod:`vibdyn.solvers.differences` (difference quotients of plain functions of a scalar or a vector: it sits
below the model, so that the solvers use it too): central, one-sided and second differences, their truncation
estimates and round-off weights (``tests/test_fd_sites.py`` fails on one written elsewhere).
"""

import numpy as np
import pinocchio as pin

from ..defaults import EPS
from ..solvers.differences import (
    CENTRAL,
    ESTIMATED,
    ONE_SIDED,
    bend,
    derivative,
    differences,
    displaced_vectors,
    divisors,
    hessian,
    one_sided,
    pairs,
    round_off,
    secant,
    second_derivative,
    sides,
    vector_derivative,
)

# the kit's names offered here too (modules on the model take every difference from here; numpy-only ones, and
# the solvers, from the kit itself)
__all__ = ["CENTRAL", "ESTIMATED", "ONE_SIDED", "bend", "derivative", "differences", "displaced_vectors", "hessian",
           "one_sided", "round_off", "secant", "sides", "second_derivative", "vector_derivative",
           "steps", "Stencil", "stencil", "step_stencil", "tangent_derivative", "point_jacobian",
           "world_point_jacobian"]


def steps(system, step):
    """Finite-difference step per tangent coordinate: ``step`` rad, or ``step`` × length scale m, each rounded to
    the nearest power of two (within √2 of it)."""
    # a power of two adds exactly to a coordinate or a point's position (|x| < 2⁴² × it: ulp(x) ≤ h): any
    # other step is itself rounded in x + h, so the differences divide by an h the scene never moved by — a
    # bias of ε|x|/h on every entry of K that no truncation or round-off estimate sees (8e-13 on a storey
    # spring 10 m long, with h = 1.04e-4 m)
    return np.exp2(np.round(np.log2(step * system.coordinate_scales)))


class Stencil:
    """Central differences in the tangent space with steps h per coordinate, and (``estimate``) their
    Richardson truncation estimates D(h) − D(2h), after a first row at the operating point itself; made once
    per (system, steps) and kept in the workspace (:func:`stencil`). Holds the offsets of the displaced
    configurations of vector-space coordinates and the divisors of the differences."""

    def __init__(self, system, h, estimate):
        self.h, self.estimate = h.copy(), estimate
        self.signs = ESTIMATED if estimate else CENTRAL
        S, nv, first = len(self.signs), system.nv, int(estimate)
        self.offsets = np.zeros((first + S * nv, system.nq))
        k, iq = system.additive_coordinates
        if k.size:
            self.offsets[first:].reshape(S, nv, system.nq)[:, k, iq] = np.multiply.outer(self.signs, h[k])
        self.divisors = divisors(self.signs, h)
        self.round_off = 16 * EPS / h  # (16ε per unit of the terms that cancel, over h: see fd_error)

    def configurations(self, system, q0):
        """The displaced configurations as rows: q0 itself first if the stencil estimates, then q0 ⊕ s·h_k e_k
        step-major (row i·nv + k, after the centre, moves coordinate k by signs[i]·h_k). Vector-space
        coordinates (nq = nv joints: pivots, sliders, helical, cylindrical, universal; ``integrate`` is the
        sum) move in one numpy operation, those of ball, planar and free joints by ``pin.integrate``."""
        Q = q0 + self.offsets
        if system.curved_coordinates:
            model, e, nv, first = system.model, np.zeros(system.nv), system.nv, int(self.estimate)
            for k in system.curved_coordinates:
                for i, s in enumerate(self.signs):
                    e[k] = s * self.h[k]
                    Q[first + i * nv + k] = pin.integrate(model, q0, e)
                e[k] = 0.0
        return Q

    def derivatives(self, Y):
        """(D, T): the derivative (outputs × nv) from the evaluations Y at the rows of :meth:`configurations`
        (one row each), and its truncation estimate T = D(h) − D(2h) (None without ``estimate``). Each pair
        is subtracted before it is divided (exact for nearby values: no round-off of the products)."""
        return pairs(Y[int(self.estimate):], self.divisors, len(self.h))


def stencil(system, ws, h, estimate=False):
    """The :class:`Stencil` of these steps, from the workspace's few kept ones (made on first use)."""
    key = (h.tobytes(), estimate)
    kept = ws.stencils
    st = kept.get(key)
    if st is None:
        if len(kept) >= 8:
            kept.clear()
        st = kept[key] = Stencil(system, h, estimate)
    return st


def step_stencil(system, ws, step, estimate=False):
    """The :class:`Stencil` of the steps :func:`steps` gives for ``step``, kept in the workspace by ``step``
    (the steps' own computation skipped on every later use)."""
    key = (float(step), estimate)
    st = ws.stencils.get(key)
    if st is None:
        st = stencil(system, ws, steps(system, step), estimate)
        ws.stencils[key] = st
    return st










def tangent_derivative(system, fun, q0, h, estimate=False):
    """∂fun/∂q at q0 by central differences in the tangent space: column k is
    (fun(q0 ⊕ h_k e_k) − fun(q0 ⊖ h_k e_k)) / 2h_k, configurations moved with ``integrate``. With
    ``estimate``, (D, T) with T = D(h) − D(2h), the estimate of D's truncation error."""
    st = stencil(system, system.workspace(), h, estimate)
    D, T = st.derivatives(np.array([np.ravel(fun(q)) for q in st.configurations(system, q0)]))
    return (D, T) if estimate else D




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
