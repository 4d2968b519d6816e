"""Spring on a joint's tangent coordinates: Q = −k·(q ⊖ q_rest) (torsion spring on a pivot, on the rotation
vector for a ball)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..._check import (
    degrees_hint,
    finite_array,
    hint,
    one_or_each,
    stiffness_like,
    value_nonnegative_number_or_list,
    value_number_or_list,
    value_string,
)
from ..._format import with_units
from ...errors import ModelError
from ...model.groups import ForceGroup, as_slice, tangent
from ...model.points import so3_chart_term, so3_jacobians, so3_jr_inv
from .base import ElementKind, scalar_or_list


class JointSprings(ForceGroup):
    """Springs on joint coordinates: Q = −Σ Jᵀ K (q ⊖ q_rest), J = ∂(q ⊖ q_rest)/∂q (identity for vector
    joints; for an isotropic ball spring Jᵀφ = φ, so the torque is −k φ exactly). Springs that share a joint
    (each with its own rest) are evaluated in layers of at most one spring per joint."""

    def __init__(self, system, elements):
        self.names = [e.name for e in elements]
        layers, count = [], {}
        for e in elements:
            joint = system.body_info(e.body).idx_v
            i = count[joint] = count.get(joint, -1) + 1
            if i == len(layers):
                layers.append([])
            layers[i].append(e)
        self.layers = [_Layer(system, members) for members in layers]

    def apply(self, t, q, v, kin, Q, F):
        for layer in self.layers:
            layer.apply(t, q, v, kin, Q, F)

    def apply_rows(self, t, q, v, Q):
        for layer in self.layers:
            layer.apply_rows(t, q, v, Q)

    def potential(self, q, kin):
        return sum(layer.potential(q, kin) for layer in self.layers)

    def joint_rows(self, q, v, t):
        if any(layer.differenced is not None for layer in self.layers):  # (planar and free joints: state by state)
            return None
        nv = self.layers[0].model.nv
        dQ = np.zeros((len(q), nv, nv))
        for layer in self.layers:
            layer.add_rows(q, dQ)
        return dQ, None

    def derivatives(self, d):
        dQ = self.layers[0].derivatives(d)[0]
        for layer in self.layers[1:]:
            dQ += layer.derivatives(d)[0]
        return dQ, None


class _Layer(ForceGroup):
    """Springs on distinct joints, one q_rest for all."""

    def __init__(self, system, elements):
        model = system.model
        self.names = [e.name for e in elements]
        neutral = system.neutral()
        self.q_rest = neutral.copy()
        iv, k, curved, balls, so3 = [], [], [], [], []
        for e in elements:
            b = system.body_info(e.body)
            iq = list(range(b.idx_q, b.idx_q + b.nq))
            if any(e.rest):  # (a rest at neutral is neutral's own coordinates)
                self.q_rest[iq] = pin.integrate(model, neutral, tangent(model, b, e.rest))[iq]
            iv += list(range(b.idx_v, b.idx_v + b.nv))
            k += list(e.stiffness)
            if b.joint.lie_group == "SO3":
                so3.append(len(iv) - 3 + np.arange(3))
            # SE(2)/SE(3) joints and anisotropic ball springs need the Jacobian of the difference
            if b.nq != b.nv and (not b.joint.isotropic_spring or len(set(e.stiffness)) > 1):
                # (ball joints' in closed form: see derivatives; planar and free joints' differenced)
                (balls if b.joint.lie_group == "SO3" else curved).append(len(iv) - b.nv + np.arange(b.nv))
        self.iv, self.k = np.array(iv), np.array(k)
        self.model = model
        self.vector = all(system.body_info(e.body).nq == system.body_info(e.body).nv for e in elements)
        if self.vector:
            self.iq = np.array([system.body_info(e.body).idx_q + i for e in elements
                                for i in range(system.body_info(e.body).nv)])
            self.rest = self.q_rest[self.iq]
            # the same coordinates as slices where they are contiguous (views instead of gathers)
            self.iq_at, self.iv_at = as_slice(self.iq), as_slice(self.iv)
        self.curved = np.concatenate(curved + balls) if curved or balls else None
        self.differenced = np.concatenate(curved) if curved else None
        # index grids made once (np.ix_ costs more than the 3 × 3 products it serves): the layer's block, its
        # curved block, and per anisotropic ball (its positions in iv, their block, its rows in v and their block)
        # (none for a layer of vector joints, which reads its coordinates directly: a sensitivity makes one such
        # group per parameter)
        self.block = None if self.vector else np.ix_(self.iv, self.iv)
        self.curved_block = None if self.curved is None else np.ix_(self.curved, self.curved)
        self.balls = [(b, np.ix_(b, b), self.iv[b], np.ix_(self.iv[b], self.iv[b])) for b in balls]
        self.so3 = [(b, np.ix_(b, b)) for b in so3]  # every ball (its positions in iv, their block)

    def jacobian(self, q, phi):
        """∂(q ⊖ q_rest)/∂q on the layer's block at q (``phi`` its deflection): the identity on vector joints,
        balls' J_r⁻¹(φ) in closed form (:func:`so3_jr_inv`; Pinocchio's Jlog3 rounds off to 2e-9 near 1e-3 rad),
        Pinocchio's on planar and free joints."""
        J = (pin.dDifference(self.model, self.q_rest, q, pin.ARG1)[self.block] if self.differenced is not None
             else np.eye(len(self.iv)))
        for b, own in self.so3:
            J[own] = so3_jr_inv(phi[b])
        return J

    def deflection(self, q):
        """q ⊖ q_rest on the sprung coordinates (m or rad; rotation vector for a ball)."""
        if self.vector:
            return q[self.iq] - self.rest
        return pin.difference(self.model, self.q_rest, q)[self.iv]

    def apply(self, t, q, v, kin, Q, F):
        if self.vector:
            Q[self.iv_at] -= self.k * (q[self.iq_at] - self.rest)
            return
        phi = self.deflection(q)
        force = self.k * phi
        if self.curved is not None:
            J = self.jacobian(q, phi)
            c = self.curved
            force[c] = J[self.curved_block].T @ force[c]
        Q[self.iv] -= force

    def apply_rows(self, t, q, v, Q):
        if not self.vector:
            return super().apply_rows(t, q, v, Q)
        Q[:, self.iv_at] -= self.k * (q[:, self.iq_at] - self.rest)

    def potential(self, q, kin):
        phi = self.deflection(q)
        return 0.5 * float(self.k @ phi**2)

    def joint_rows(self, q, v, t):
        """(∂Q/∂q at each row of q, None): −k on the diagonal for vector joints, whatever the state; balls' in closed
        form, every row at once; None for planar and free joints (their turning differenced: state by state)."""
        if self.differenced is not None:
            return None
        dQ = np.zeros((len(q), self.model.nv, self.model.nv))
        self.add_rows(q, dQ)
        return dQ, None

    def add_rows(self, q, dQ):
        """Add ∂Q/∂q at each row of q into dQ (B × nv × nv) (vector joints and balls only)."""
        if self.vector:
            dQ[:, self.iv, self.iv] -= self.k
            return
        # every row at once: each ball's J_r⁻¹(φ) and chart term by so3_jacobians
        phi = np.array([pin.difference(self.model, self.q_rest, qc) for qc in q])[:, self.iv]
        J = np.broadcast_to(np.eye(len(self.iv)), (len(q), len(self.iv), len(self.iv))).copy()
        for b, own in self.so3:
            J[(slice(None),) + own] = so3_jacobians(phi[:, b])[1]
        dQ[(slice(None),) + self.block] -= self.k[:, None] * J
        for b, own, _, rows in self.balls:  # (−Jᵀ K J + the chart term, in place of the −K J just added)
            Jb, kb = J[(slice(None),) + own], self.k[b]
            term = so3_jacobians(-phi[:, b], kb * phi[:, b])[2]
            dQ[(slice(None),) + rows] += -(np.swapaxes(Jb, 1, 2) * kb) @ Jb + term @ Jb + kb[:, None] * Jb

    def _curved_stiffness(self, q, dQ):
        """∂Q/∂q at q of a layer with curved joints, into dQ (nv × nv, zero outside the layer's block)."""
        phi = self.deflection(q)
        J = self.jacobian(q, phi)
        dQ[self.block] = -(self.k[:, None] * J)
        if self.balls:  # Q = −Jᵀ K φ, J = J_r⁻¹(φ), Jᵀ = J_r⁻¹(−φ): ∂Q/∂δ = −Jᵀ K J + [∂(J_r⁻¹(ξ) Kφ)/∂ξ]_(ξ=−φ) J
            for b, own, _, rows in self.balls:
                Jb, kb = J[own], self.k[b]
                dQ[rows] = -(Jb.T * kb) @ Jb + so3_chart_term(-phi[b], kb * phi[b]) @ Jb

    def derivatives(self, d):
        nv = d.system.nv
        dQ = np.zeros((nv, nv))
        if self.vector:
            dQ[self.iv, self.iv] = -self.k
            return dQ, None
        self._curved_stiffness(d.q, dQ)
        if self.differenced is not None:  # planar and free joints: the turning of J differenced on the group alone
            fd = d.element_fd(lambda qq, vv: d.group_force(self, qq, d.v), with_v=False)
            dQ[:, self.iv[self.differenced]] = fd[0][:, self.iv[self.differenced]]
        return dQ, None


def per_coordinate(value, nv, what, key):
    """``key`` of the element ``what``: one number for every coordinate of a joint, or one per coordinate
    (a tuple of nv floats)."""
    r = np.atleast_1d(finite_array(value, None, f"{what} {key}"))
    if r.size == 1:
        r = np.full(nv, float(r[0]))
    if r.shape != (nv,):
        raise ModelError(f"{what}: {key} needs {one_or_each(nv)}, got {r.size}")
    return tuple(map(float, r))


def rest_offsets(rest, body, what):
    """:func:`per_coordinate` rest of ``body``'s joint (m or rad), with a hint when an angle of it looks like
    degrees (beyond a full turn: a spring wound that far is rarer than degrees given for radians)."""
    r = per_coordinate(rest, body.joint.nv, what, "rest")
    names = [body.name] if len(r) == 1 else [f"{body.name}[{i}]" for i in range(len(r))]
    hint(degrees_hint([(n, x) for n, u, x in zip(names, body.joint.units, r) if u == "rad"], "from neutral"),
         f"{what}: rest")
    return r


@dataclass(frozen=True)
class JointSpring(ElementKind):
    """Spring on a joint's tangent coordinates: Q = −k·(q ⊖ q_rest) (N/m or N·m/rad).

    ``stiffness`` is one number or one per coordinate; ``rest`` is the rest offset from the neutral
    configuration in tangent coordinates (for a ball joint: the rotation vector, rad).
    """

    table = "joint_spring"
    keys = {"body": value_string, "stiffness": value_nonnegative_number_or_list, "rest": value_number_or_list,
            "name": value_string}
    required = ("body", "stiffness")
    group = JointSprings
    linear_in = ("stiffness",)

    name: str
    body: str
    stiffness: tuple
    rest: tuple

    @classmethod
    def add(cls, scene, body, stiffness, rest=0.0, name=None) -> JointSpring:
        b = scene.joint_body(body, "joint spring")
        name = name or f"{b.name}.spring"
        what = f"joint spring '{name}'"
        scene.check_new_name(name, "element")
        k = stiffness_like(stiffness, b.joint.nv, f"{what} stiffness")
        r = rest_offsets(rest, b, what)
        return scene.add_element(cls(name, b.name, tuple(map(float, k)), r))

    def to_dict(self):
        d = {"name": self.name, "body": self.body, "stiffness": scalar_or_list(self.stiffness)}
        if np.any(self.rest):
            d["rest"] = scalar_or_list(self.rest)
        return d

    def describe(self, scene=None):
        units = self.joint_units(scene)
        k = with_units(self.stiffness, units, {"m": "N/m", "rad": "N·m/rad"})
        return f"on {self.body}, k = {k}, rest {with_units(self.rest, units, {'m': 'm', 'rad': 'rad'})}"
