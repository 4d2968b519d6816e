"""Force-element groups: each kind of element of a scene compiled into one numpy evaluation.

A group adds its share of generalized force to ``Q`` (joint space, length nv) and, for elements acting at
body points, spatial forces to ``F`` (one row (force, moment) per Pinocchio joint, in that joint's local
frame) that the system hands to ABA/RNEA as external forces. Only the kinds a scene has are compiled.
"""

import numpy as np
import pinocchio as pin

from ._check import call_user, count, finite_array
from .elements import BodyForce, Damper, JointDamper, JointForce, JointSpring, Spring
from .errors import ModelError


def cross(a, b):
    """Row-wise cross product of (n, 3) arrays (numpy's own is slow on small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


_NO_SUPPORT = np.zeros((1, 3))


class Kinematics:
    """Poses (and local velocities if asked) of the joints that point elements attach to."""

    __slots__ = ("R", "p", "v", "w", "sp", "sv")

    def __init__(self, model, data, joints, q, v=None, supports=None):
        # support displacements and velocities (m, m/s), one row per support and a last zero row, so that
        # index −1 (an end on no support) adds nothing
        self.sp, self.sv = supports if supports is not None else (_NO_SUPPORT, _NO_SUPPORT)
        if v is None:
            pin.forwardKinematics(model, data, q)
        else:
            pin.forwardKinematics(model, data, q, v)
        nj = model.njoints
        self.R = np.empty((nj, 3, 3))
        self.p = np.empty((nj, 3))
        self.R[0], self.p[0] = np.eye(3), 0.0
        for j in joints:
            M = data.oMi[j]
            self.R[j], self.p[j] = M.rotation, M.translation
        if v is not None:
            self.v = np.zeros((nj, 3))
            self.w = np.zeros((nj, 3))
            for j in joints:
                vj = data.v[j]
                self.v[j], self.w[j] = vj.linear, vj.angular

    def points(self, joints, local):
        """World positions (m) of points given in their joint frames."""
        return np.einsum("nij,nj->ni", self.R[joints], local) + self.p[joints]

    def velocities(self, joints, local):
        """World velocities (m/s) of points given in their joint frames."""
        lin = self.v[joints] + cross(self.w[joints], local)
        return np.einsum("nij,nj->ni", self.R[joints], lin)


def add_point_forces(F, kin, joints, world_points, world_forces):
    """Accumulate forces (world axes) applied at world points into the local spatial forces ``F``."""
    # Rᵀ applied to the force and to the lever arm at once: (n, 3, 3)ᵀ @ (n, 3, 2)
    fr = np.matmul(np.transpose(kin.R[joints], (0, 2, 1)),
                   np.stack([world_forces, world_points - kin.p[joints]], axis=2))
    f, r = fr[:, :, 0], fr[:, :, 1]
    np.add.at(F, joints, np.concatenate([f, cross(r, f)], axis=1))


class Group:
    """One kind of force element, all members at once."""

    uses_points = False  # needs joint poses (point elements)
    uses_point_velocities = False
    velocity_dependent = False
    time_dependent = False
    joints = ()  # Pinocchio joints it applies forces to

    def apply(self, t, q, v, kin, Q, F):
        raise NotImplementedError

    def potential(self, q, kin):
        return 0.0


class _TwoPoint(Group):
    uses_points = True

    def __init__(self, system, elements):
        self.names = [e.name for e in elements]
        self.ja, self.pa = system.attachments([e.a for e in elements])
        self.jb, self.pb = system.attachments([e.b for e in elements])
        self.sa = system.support_indices([e.a for e in elements])
        self.sb = system.support_indices([e.b for e in elements])
        self.joints = tuple(sorted(set(self.ja) | set(self.jb)))
        self.j_ends = np.concatenate([self.ja, self.jb])

    def _add_end_forces(self, F, kin, xa, xb, fb):
        """Force fb (world axes) on every end b and −fb on every end a, in one accumulation."""
        add_point_forces(F, kin, self.j_ends, np.concatenate([xa, xb]), np.concatenate([-fb, fb]))

    def end_velocities(self, kin):
        """World velocities (m/s) of the two ends, supports' motion included."""
        return (kin.velocities(self.ja, self.pa) + kin.sv[self.sa],
                kin.velocities(self.jb, self.pb) + kin.sv[self.sb])

    def _geometry(self, kin, zero_ok=None):
        xa = kin.points(self.ja, self.pa) + kin.sp[self.sa]
        xb = kin.points(self.jb, self.pb) + kin.sp[self.sb]
        d = xb - xa
        L = np.linalg.norm(d, axis=1)
        tiny = L <= self._tiny
        if zero_ok is not None:
            tiny &= ~zero_ok
        if tiny.any():
            i = int(np.flatnonzero(tiny)[0])
            raise ModelError(f"{self.kind} '{self.names[i]}' reached zero length (its two ends coincide at "
                             f"{np.round(xa[i], 12).tolist()}): its direction is undefined")
        return xa, xb, d, L


class Springs(_TwoPoint):
    """Point-to-point linear springs: force on end b = −k (L − l0) u, u from a to b."""

    kind = "spring"

    def __init__(self, system, elements, free_lengths):
        super().__init__(system, elements)
        self.k = np.array([e.stiffness for e in elements])
        self.l0 = np.asarray(free_lengths, dtype=float)
        self.zero_l0 = self.l0 == 0.0  # a zero-free-length spring pulls as −k d: no direction needed
        self._tiny = 1e-9 * np.maximum(self.l0, 1e-3)

    def apply(self, t, q, v, kin, Q, F):
        xa, xb, d, L = self._geometry(kin, self.zero_l0)
        Ls = np.where(self.zero_l0, 1.0, L)
        fb = (-self.k * np.where(self.zero_l0, 1.0, (L - self.l0) / Ls))[:, None] * d
        self._add_end_forces(F, kin, xa, xb, fb)

    def potential(self, q, kin):
        _, _, _, L = self._geometry(kin, self.zero_l0)
        return 0.5 * float(self.k @ (L - self.l0) ** 2)


class Dampers(_TwoPoint):
    """Point-to-point viscous dampers: force on end b = −c (u·(v_b − v_a)) u."""

    kind = "damper"
    uses_point_velocities = True
    velocity_dependent = True

    def __init__(self, system, elements):
        super().__init__(system, elements)
        self.c = np.array([e.damping for e in elements])
        self._tiny = np.full(len(elements), 1e-12)

    def apply(self, t, q, v, kin, Q, F):
        xa, xb, d, L = self._geometry(kin)
        u = d / L[:, None]
        va, vb = self.end_velocities(kin)
        rate = np.einsum("ni,ni->n", u, vb - va)
        fb = (-self.c * rate)[:, None] * u
        self._add_end_forces(F, kin, xa, xb, fb)


class BodyForces(Group):
    """External forces and torques on body points, constant or callables of (t, q, v)."""

    uses_points = True

    def __init__(self, system, elements):
        self.elements = elements
        self.jp, self.pp = system.attachments([(e.body, e.at) for e in elements])
        self.Rb = np.array([system.body_in_joint(e.body).rotation for e in elements])
        self.body_axes = np.array([e.frame == "body" for e in elements])
        self.joints = tuple(sorted(set(self.jp)))
        self.velocity_dependent = any(e.velocity_dependent for e in elements)
        self.time_dependent = any(e.time_dependent for e in elements)

    def _vectors(self, attr, t, q, v):
        out = np.zeros((len(self.elements), 3))
        for i, e in enumerate(self.elements):
            x = getattr(e, attr)
            if x is None:
                continue
            val = call_user(x, (t, q, v), f"force '{e.name}' ({attr})", t) if callable(x) else x
            arr = _numbers(val, (3,))
            if arr is None:
                raise ModelError(f"force '{e.name}': {attr} must be 3 finite numbers, got {val!r} at t = {t}")
            out[i] = arr
        return out

    def apply(self, t, q, v, kin, Q, F):
        f, tq = self._vectors("force", t, q, v), self._vectors("torque", t, q, v)
        Rw = np.einsum("nij,njk->nik", kin.R[self.jp], self.Rb)  # body axes -> world
        f = np.where(self.body_axes[:, None], np.einsum("nij,nj->ni", Rw, f), f)
        tq = np.where(self.body_axes[:, None], np.einsum("nij,nj->ni", Rw, tq), tq)
        add_point_forces(F, kin, self.jp, kin.points(self.jp, self.pp), f)
        Rt = np.transpose(kin.R[self.jp], (0, 2, 1))
        np.add.at(F[:, 3:], self.jp, np.einsum("nij,nj->ni", Rt, tq))


class JointSprings(Group):
    """Springs on joint coordinates: Q = −Jᵀ K (q ⊖ q_rest), J = ∂(q ⊖ q_rest)/∂q (identity for vector
    joints; for an isotropic ball spring Jᵀφ = φ, so the torque is −k φ exactly)."""

    def __init__(self, system, elements):
        model = system.model
        self.names = [e.name for e in elements]
        self.q_rest = system.neutral()
        iv, k, curved = [], [], []
        for e in elements:
            b = system.body_info(e.body)
            iq = list(range(b.idx_q, b.idx_q + b.nq))
            self.q_rest[iq] = pin.integrate(model, system.neutral(), _tangent(model, b, e.rest))[iq]
            iv += list(range(b.idx_v, b.idx_v + b.nv))
            k += list(e.stiffness)
            # SE(2)/SE(3) joints and anisotropic ball springs need the Jacobian of the difference
            if b.nq != b.nv and (b.joint.kind != "ball" or len(set(e.stiffness)) > 1):
                curved.append(len(iv) - b.nv + np.arange(b.nv))
        self.iv, self.k = np.array(iv), np.array(k)
        self.model = model
        self.vector = all(system.body_info(e.body).nq == system.body_info(e.body).nv for e in elements)
        if self.vector:
            self.iq = np.array([system.body_info(e.body).idx_q + i for e in elements
                                for i in range(system.body_info(e.body).nv)])
            self.rest = self.q_rest[self.iq]
        self.curved = np.concatenate(curved) if curved else None

    def deflection(self, q):
        """q ⊖ q_rest on the sprung coordinates (m or rad; rotation vector for a ball)."""
        if self.vector:
            return q[self.iq] - self.rest
        return pin.difference(self.model, self.q_rest, q)[self.iv]

    def apply(self, t, q, v, kin, Q, F):
        phi = self.deflection(q)
        force = self.k * phi
        if self.curved is not None:
            J = pin.dDifference(self.model, self.q_rest, q, pin.ARG1)[np.ix_(self.iv, self.iv)]
            c = self.curved
            force[c] = J[np.ix_(c, c)].T @ force[c]
        Q[self.iv] -= force

    def potential(self, q, kin):
        phi = self.deflection(q)
        return 0.5 * float(self.k @ phi**2)


class JointDampers(Group):
    """Viscous dampers on joint coordinates: Q = −c v."""

    velocity_dependent = True

    def __init__(self, system, elements):
        self.iv = np.array([i for e in elements for i in system.body_info(e.body).v_indices])
        self.c = np.array([c for e in elements for c in e.damping])

    def apply(self, t, q, v, kin, Q, F):
        Q[self.iv] -= self.c * v[self.iv]


class JointForces(Group):
    """Forces/torques along joint coordinates: constants summed once, laws and callables per call."""

    def __init__(self, system, elements):
        self.constant = np.zeros(system.nv)
        self.laws = []
        for e in elements:
            b = system.body_info(e.body)
            if callable(e.value):
                self.laws.append((e, b))
            else:
                self.constant[list(b.v_indices)] += e.value
        self.has_constant = bool(np.any(self.constant))
        self.velocity_dependent = any(e.velocity_dependent for e, _ in self.laws)
        self.time_dependent = any(e.time_dependent for e, _ in self.laws)

    def apply(self, t, q, v, kin, Q, F):
        if self.has_constant:
            Q += self.constant
        for e, b in self.laws:
            if b.nv == 1:
                # numpy scalars, not Python floats: an overflow gives inf (caught as a blow-up), not OverflowError
                args = (t, q[b.idx_q], v[b.idx_v])
            else:
                args = (t, q[b.idx_q:b.idx_q + b.nq].copy(), v[b.idx_v:b.idx_v + b.nv].copy())
            val = call_user(e.value, args, f"joint force '{e.name}'", t)
            arr = _numbers(val, None)
            if arr is None or np.atleast_1d(arr).shape != (b.nv,):
                raise ModelError(f"joint force '{e.name}' returned {val!r} at t = {t}: expected "
                                 f"{count(b.nv, 'finite number')}")
            Q[b.idx_v:b.idx_v + b.nv] += np.atleast_1d(arr)


def _numbers(value, shape):
    """``value`` as finite floats of ``shape`` (None: any), or None if it is not (the caller says why)."""
    try:
        return finite_array(value, shape, "")
    except ModelError:
        return None


def _tangent(model, body, rest):
    dv = np.zeros(model.nv)
    dv[body.idx_v:body.idx_v + body.nv] = rest
    return dv


def compile_groups(system, scene, free_lengths):
    """The groups of the kinds this scene has, in a fixed order."""
    groups = []
    for kind, make in ((Spring, lambda es: Springs(system, es, free_lengths)),
                       (Damper, lambda es: Dampers(system, es)),
                       (BodyForce, lambda es: BodyForces(system, es)),
                       (JointSpring, lambda es: JointSprings(system, es)),
                       (JointDamper, lambda es: JointDampers(system, es)),
                       (JointForce, lambda es: JointForces(system, es))):
        members = scene.elements_of(kind)
        if members:
            groups.append(make(members))
    return groups
