"""Analytic K and C: Pinocchio's RNEA derivatives plus the derivatives of each force-element group.

r(q, v) = RNEA(q, v, a0, f(q, v)) − Q(q, v), with f the external forces of point elements in the local joint
frames. Pinocchio differentiates RNEA holding f fixed in those frames; the chain rule adds −Σ_j J_jᵀ ∂f_j
and the joint-space groups add −∂Q. ∂f_j/∂q includes the turning of joint j's frame:
∂(Rᵀ F) = Rᵀ ∂F + [Rᵀ F]× Ω_j with Ω_j the local angular Jacobian of joint j.

Pinocchio's derivatives are trusted per joint type (``analytic_derivatives`` of
:mod:`vibdyn.description.joints`): the columns of a distrusted joint's coordinates (a universal joint's) are
central differences instead (:func:`untrusted_columns`).
"""

import weakref

import numpy as np
import pinocchio as pin

from .._check import all_finite
from ..defaults import FD_STEP
from . import dynamics
from .fd import derivative, steps, tangent_derivative, vector_derivative, world_point_jacobian
from .points import skew

_skew = pin.skew


class Derivatives:
    """What a group's ``derivatives(d)`` uses: the state (``system``, ``q``, ``v``, ``t``), Jacobians of the
    joints point elements attach to and of points on them (world axes: ``point``, ``point_velocity_dq``, ``R``,
    ``J``), the accumulators of their forces' derivatives (``add_force``, ``dFq``, ``dFv``), the joint poses
    the forces were evaluated with (``fkin``), and finite differences of user callables (``element_fd``).
    With ``magnitudes``, also ``dFq_abs``: the sizes of the terms summed into ``dFq`` (their round-off scale;
    a term that cancels, as the turning of a force that turns with its joint, leaves round-off of its size).
    Computed in the workspace ``ws`` (its Data), copied out before any group runs."""

    def __init__(self, system, ws, q, v, a, t, need_velocity_derivatives, magnitudes=False, points=True):
        model, data = system.model, ws.data
        self.system, self.q, self.v, self.t = system, q, v, t
        self.nv = system.nv
        self.fkin = None
        self.differenced = False  # element_fd was used: these derivatives are exact only to ~1e-10 (relative)
        self.J, self.R, self.u, self.dV = {}, {}, {}, {}
        self.turns = {}  # per joint: whether it turns with some coordinate (a slider's frame does not)
        if not (points and system.point_groups):  # joint-space groups need no accumulators, no point Jacobians
            self.dFq, self.dFv, self.dFq_abs = {}, {}, {} if magnitudes else None
            return
        joints = system.point_joints
        self.dFq = {j: np.zeros((6, self.nv)) for j in joints}
        self.dFv = {j: np.zeros((6, self.nv)) for j in joints}
        self.dFq_abs = {j: np.zeros((6, self.nv)) for j in joints} if magnitudes else None
        pin.computeJointJacobians(model, data, q)
        if need_velocity_derivatives:  # (the joints' velocities are read only for the velocity derivatives)
            pin.forwardKinematics(model, data, q, v)
            pin.computeForwardKinematicsDerivatives(model, data, q, v, a)
        for j in system.point_joints:
            self.J[j] = J = pin.getJointJacobian(model, data, j, pin.LOCAL).reshape(6, self.nv).copy()
            self.turns[j] = bool(J[3:].any())
            self.R[j] = data.oMi[j].rotation.copy()
            if need_velocity_derivatives:
                vj = data.v[j]
                self.u[j] = (vj.linear.copy(), vj.angular.copy())
                dv_dq, _ = pin.getJointVelocityDerivatives(model, data, j, pin.LOCAL)
                self.dV[j] = np.asarray(dv_dq).reshape(6, self.nv).copy()

    def point(self, j, r):
        """World position Jacobian (3 × nv) of the point r (joint frame) on joint j (zero for the world)."""
        if j == 0:
            return np.zeros((3, self.nv))
        if not self.turns[j]:  # (no angular part: R (J_lin − [r]× 0))
            return self.R[j] @ self.J[j][:3]
        return world_point_jacobian(self.R[j], self.J[j], r)

    def point_velocity_dq(self, j, r):
        """∂(world velocity of the point)/∂q (3 × nv)."""
        if j == 0:
            return np.zeros((3, self.nv))
        vl, w = self.u[j]
        u = vl + np.cross(w, r)
        dV = self.dV[j]
        return self.R[j] @ (dV[:3] - _skew(r) @ dV[3:] - _skew(u) @ self.J[j][3:])

    def add_force(self, j, r, F_world, dF_dq, dF_dv, size_q=None):
        """Chain rule for a world force F applied at point r of joint j: ∂f_j/∂q, ∂f_j/∂v (6 × nv).
        ``size_q``: the size of dF_dq's own terms (3 × nv, default |dF_dq|) for the round-off estimate."""
        if j == 0:
            return
        R = self.R[j]
        f_loc = R.T @ F_world
        df_q = R.T @ dF_dq
        if self.turns[j]:  # (a joint frame that turns carries the force it is given in it)
            df_q += _skew(f_loc) @ self.J[j][3:]
        self.dFq[j][:3] += df_q
        moment = r.any()  # (a force at the joint's origin has no moment about it)
        if moment:
            self.dFq[j][3:] += _skew(r) @ df_q
        if self.dFq_abs is not None:
            m = np.abs(R.T) @ (np.abs(dF_dq) if size_q is None else size_q) + np.abs(_skew(f_loc)) @ np.abs(
                self.J[j][3:])
            self.dFq_abs[j][:3] += m
            self.dFq_abs[j][3:] += np.abs(_skew(r)) @ m
        if dF_dv is not None:
            df_v = R.T @ dF_dv
            self.dFv[j][:3] += df_v
            if moment:
                self.dFv[j][3:] += _skew(r) @ df_v

    def element_fd(self, fun, with_v=True):
        """Central differences (∂/∂q, ∂/∂v) of an element's own output ``fun(q, v)`` (for user callables,
        which have no derivative), with steps 1e-6 of each coordinate's scale or of its own size where larger
        (|Δq| from the neutral configuration, |v|: a slider at the origin has a length scale of 1 mm, and steps of
        1e-9 m left round-off of 1e-7 in the derivatives of a motion of metres)."""
        self.differenced = True
        system = self.system
        h = steps(system, 1e-6)
        offset = pin.difference(system.model, pin.neutral(system.model), self.q)
        hq = np.maximum(h, _power_of_two(1e-6 * np.abs(offset)))
        Dq = tangent_derivative(system, lambda qq: fun(qq, self.v), self.q, hq)
        if not with_v:
            return Dq, np.zeros_like(Dq)
        hv = np.maximum(h, _power_of_two(1e-6 * np.abs(self.v)))
        return Dq, vector_derivative(lambda vv: fun(self.q, vv), self.v, hv)

    def group_force(self, group, q, v):
        """One joint-space group's Q(q, v) at this time."""
        Q = np.zeros(self.system.nv)
        group.apply(self.t, q, v, None, Q, None)
        return Q


def _power_of_two(x):
    """x rounded to the nearest power of two (zeros stay 0): steps a coordinate moves by exactly."""
    out = np.zeros_like(x)
    pos = x > 0
    out[pos] = np.exp2(np.round(np.log2(x[pos])))
    return out


# system -> (columns, their steps): made once per system
_UNTRUSTED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def untrusted(system):
    """(k, h): the tangent indices k of the coordinates of joints whose type distrusts Pinocchio's analytic
    derivatives (``analytic_derivatives = False``: universal joints; empty in most scenes) and their finite-
    difference steps h (rad or m, :func:`vibdyn.model.fd.steps` of FD_STEP)."""
    kh = _UNTRUSTED.get(system)
    if kh is None:
        k = np.array([i for b in system.body_infos.values() if not b.joint.analytic_derivatives
                      for i in b.v_indices], dtype=int)
        kh = _UNTRUSTED[system] = (k, steps(system, FD_STEP)[k])
    return kh


def _columns(f, X, k, h, estimate):
    """Columns k of X (changed in place) as the central differences (f(e_k h_k) − f(−e_k h_k)) / 2h_k of f
    (a function of a tangent or velocity offset); with ``estimate``, their truncation estimates D(h) − D(2h)."""
    e = np.zeros(X.shape[1])
    T = np.empty((X.shape[0], len(k))) if estimate else None
    for i, (kk, hk) in enumerate(zip(k, h)):
        def along(s, kk=kk):
            e[kk] = s
            return f(e)

        if estimate:
            X[:, kk], T[:, i] = derivative(along, 0.0, hk, estimate=True)
        else:
            X[:, kk] = derivative(along, 0.0, hk)
        e[kk] = 0.0
    return T


def untrusted_columns(system, ws, q, v, a, t, shift, K, C, fext, estimate=False):
    """Columns ``untrusted(system)[0]`` of K and C (changed in place) by central differences, for joints whose
    type Pinocchio gets wrong (its RNEA derivatives and joint velocity derivatives, in these columns only):
    K's of the whole residual r(q) (configurations moved by ``integrate``, ±h; the point forces in the
    workspace's buffers are put back after), C's of RNEA with the external forces ``fext`` held in the joint
    frames, Pinocchio's part only, before the elements' chain rule (±h·max(1, |v_k|): exact up to round-off,
    RNEA being quadratic in v; C's columns are kept where v = 0, since every RNEA ∂/∂v vanishes there).
    With ``estimate``, (k, h, T_q, hv, T_v): steps and truncation estimates D(h) − D(2h) (hv, T_v None where C's
    columns are kept), else None. Call with C before the elements' terms are subtracted and K after."""
    k, h = untrusted(system)
    model, data = system.model, ws.data
    hv = T_v = None
    if C is not None and np.count_nonzero(v):
        args = () if fext is None else (fext,)
        hv = h * np.maximum(1.0, np.abs(v[k]))
        T_v = _columns(lambda dv: pin.rnea(model, data, q, v + dv, a, *args), C, k, hv, estimate)
    T_q = None
    if K is not None:
        kept = [ws.forces[j].copy() for j in system.point_joints]
        T_q = _columns(lambda dq: dynamics.inverse_dynamics(system, ws, pin.integrate(model, q, dq), v, a, t,
                                                            shift), K, k, h, estimate)
        for j, f in zip(system.point_joints, kept):
            ws.forces[j][:] = f
    return (k, h, T_q, hv, T_v) if estimate else None


def analytic_derivatives(system, q, v, a, t, with_terms=False, shift=None, applied=None, flags=None):
    """(K, C, terms, K_size) = (∂r/∂q, ∂r/∂v, |RNEA| + |Q| + |g|, sizes of K's terms) at (q, v, a, t), analytically;
    ``terms`` (N or N·m per coordinate) is the size of what cancels in r, ``K_size`` (nv × nv) that of the terms
    summed into K (:func:`rnea_part_sizes`, with ``terms`` per unit coordinate; Σ |J|ᵀ |∂f| of the point
    elements, |∂Q/∂q| of the joint elements): the scales of their round-off (None unless ``with_terms``; then also
    ``C_size``, |C|'s of RNEA and the elements, after ``K_size``). ``shift``: offsets of the supports' motion, as
    :func:`vibdyn.model.dynamics.forces` takes them; ``applied``: the forces at (q, v, t) as that function gives
    them, if already evaluated. With ``with_terms``, a last item: None, or (k, h, T_q, hv, T_v) of
    :func:`untrusted_columns` (the columns of joints Pinocchio gets wrong, differenced: their steps and truncation
    estimates). ``flags``: a dict in which ``"differenced"`` is set (whether a user callable or a joint's columns
    were differenced: exact to ~1e-10 only)."""
    ws = system.workspace()
    model, data = system.model, ws.data
    Q, fext = dynamics.forces(system, ws, q, v, t, shift) if applied is None else applied
    out = (pin.computeRNEADerivatives(model, data, q, v, a) if fext is None
           else pin.computeRNEADerivatives(model, data, q, v, a, fext))
    K, C = out[0].copy(), out[1].copy()  # Pinocchio overwrites them on the next call
    terms = None
    moving = False
    if with_terms:
        moving, accelerating = bool(np.count_nonzero(v)), bool(np.count_nonzero(a))
        terms = np.abs(data.tau)  # the derivatives' pass leaves RNEA's τ in data.tau
        # (+ |g|: RNEA's τ itself where it is the gravity term alone)
        terms += terms if dynamics.is_gravity(system, v, a) else np.abs(dynamics.gravity_term(system, ws, q))
        terms += np.abs(Q)
        K_parts = rnea_part_sizes(system, ws, q, v, a, fext, K, 0.0, terms, (moving, accelerating))
    differenced = untrusted(system)[0].size != 0
    if differenced:  # (after data.tau is read: the differences overwrite it)
        in_v = untrusted_columns(system, ws, q, v, a, t, shift, None, C, fext, with_terms)
    d = Derivatives(system, ws, q, v, a, t, bool(system.point_groups) and any(
        g.needs_velocity_derivatives for g in system.point_groups), magnitudes=with_terms)
    K_size = K_parts if with_terms else None
    if system.point_groups:
        d.fkin = dynamics.kinematics(system, ws, q, v if system.uses_point_velocities else None, t, shift)
    # (C is zero unless the state moves or an element depends on velocity)
    C_rnea = C.copy() if with_terms and (system.depends_on_velocity or moving) else None
    subtract_group_derivatives(system, d, system.point_groups, system.joint_groups, K, C, K_size)
    C_size = None
    if C_rnea is not None and np.count_nonzero(C):  # the elements' dampings beside RNEA's gyroscopic terms (may cancel)
        C_size = np.abs(C_rnea)
        C_rnea -= C
        C_size += np.abs(C_rnea, out=C_rnea)
    if differenced:
        in_q = untrusted_columns(system, ws, q, v, a, t, shift, K, None, None, with_terms)
        if with_terms:
            differenced = in_q[:3] + in_v[3:]
    if flags is not None:
        flags["differenced"] = d.differenced or bool(differenced)
    return (K, C, terms, K_size, C_size, differenced or None) if with_terms else (K, C, terms, K_size)


def rnea_part_sizes(system, ws, q, v, a, fext, K, floor=0.0, terms=None, motion=None):
    """|∂g/∂q| + |∂(C(q, v)v)/∂q| + |∂(M(q)a)/∂q| + |∂(−Jᵀf)/∂q| (nv × nv, N·m per rad or N per m): the sizes of
    RNEA's stiffness terms (gravity, centrifugal and gyroscopic, inertial, the point forces' turning with their
    frames), ``K`` their sum at (q, v, a, fext). They may cancel in K (a pendulum on a spun hub at the speed
    where gravity and the centrifugal stiffness balance): K's round-off is ε times their sizes, not ε|K|. Each
    entry also takes the larger of its row's and column's diagonal sizes (through the coordinates' scales): RNEA
    sums a joint's terms over its subtree, and an entry may cancel inside one kind (a spun hub's row, 0 by
    symmetry, read −1e-17 beside terms of 0.1), and at least ``floor`` (N·m: the largest force that cancels in r,
    reaching every entry through the tree's transforms). With ``terms`` (N or N·m per coordinate, the forces
    that cancel in r): that floor is their largest (through the scales), and each row i also takes terms_i / s_j
    (their round-off per unit coordinate j). ``motion``: (v ≠ 0, a ≠ 0) if known."""
    moving, accelerating = (bool(np.count_nonzero(v)), bool(np.count_nonzero(a))) if motion is None else motion
    one_kind = fext is None and not (moving and accelerating) and not (system.has_gravity and (moving or accelerating))
    sizes = np.abs(K) if one_kind else _part_sizes(system, ws, q, v, a, fext, K, moving, accelerating)
    if system.unit_scales:  # (no product of scales to take)
        if terms is not None:
            floor = max(floor, float(np.maximum.reduce(terms, initial=0.0)))
        floors = np.maximum(sizes.diagonal(), floor)
        floors = np.maximum(floors[:, None], floors)
        if terms is not None:
            floors += terms[:, None]
        sizes += floors
        return sizes
    s = system.coordinate_scales
    scaled = None
    if terms is not None:
        scaled = terms * s
        floor = max(floor, float(np.maximum.reduce(scaled, initial=0.0)))
    d = sizes.diagonal() * (s * s)
    np.maximum(d, floor, out=d)
    floors = np.maximum(d[:, None], d)
    if scaled is not None:  # (terms_i / s_j = terms_i s_i / (s_i s_j))
        floors += scaled[:, None]
    floors *= system.inverse_scale_products
    sizes += floors
    return sizes


def _part_sizes(system, ws, q, v, a, fext, K, moving, accelerating):
    """The elementwise sum of :func:`rnea_part_sizes` where K has more than one kind of term, without its floor."""
    model, data = system.model, ws.data
    zero = np.zeros(system.nv)
    gravity = pin.computeGeneralizedGravityDerivatives(model, data, q).copy() if system.has_gravity else None
    free = K if fext is None else pin.computeRNEADerivatives(model, data, q, v, a)[0].copy()
    sizes = np.abs(K - free)  # the point forces' turning
    if moving and accelerating:
        velocity = pin.computeRNEADerivatives(model, data, q, v, zero)[0].copy()
        sizes += np.abs(free - velocity)
        free = velocity
    if gravity is not None:
        sizes += np.abs(gravity)
        free = free - gravity
    sizes += np.abs(free)
    return sizes


class RowDerivatives:
    """What a point group's ``derivatives_rows(d)`` uses, at B states at once: ``kin`` (a
    :meth:`Kinematics.rows`), the world Jacobians of points (``points``), and ``add_forces``, which sums
    the world forces' derivatives into ``K`` (B × nv × nv, ∂r/∂q of the point elements beyond RNEA's)."""

    def __init__(self, kin, W):
        self.kin, self.W = kin, W  # W: B × njoints × 6 × nv, LOCAL_WORLD_ALIGNED joint Jacobians
        self.K = np.zeros((W.shape[0], W.shape[-1], W.shape[-1]))

    def points(self, joints, local):
        """World velocity Jacobians (B × n × 3 × nv) of points ``local`` (n × 3, joint frames) of ``joints``:
        J_lin − [R r]× J_ang (zeros on the world)."""
        rw = np.einsum("bnij,nj->bni", self.kin.R[:, joints], local)
        W = self.W[:, joints]
        return W[..., :3, :] - skew(rw) @ W[..., 3:, :]

    def add_forces(self, joints, P, F, dF):
        """World forces F (B × n × 3) at points of Jacobians P (B × n × 3 × nv) on ``joints``, with their
        derivatives dF = ∂F/∂q (B × n × 3 × nv): K −= Σ Pᵀ (dF + [F]× W_ang) (the second term: the turning of
        the joint frame the force is handed to RNEA in)."""
        turning = skew(F) @ self.W[:, joints, 3:, :]
        self.K -= np.einsum("bnai,bnaj->bij", P, dF + turning)


def analytic_derivatives_rows(system, Q, V, A, t, shift=None):
    """(K, C) = (∂r/∂q, ∂r/∂v) at each row of Q, V, A (B × nq, B × nv, B × nv), t (a time or B of them, s)
    and ``shift`` (None or B × n_supports × 6), as :func:`analytic_derivatives` gives them one by one: the
    point groups with ``derivatives_rows`` at all rows at once, the others row by row."""
    B, nv = len(Q), system.nv
    ts = np.broadcast_to(np.asarray(t, float), (B,))
    if not all(g.derivatives_rows is not None for g in system.point_groups):
        K, C = np.empty((B, nv, nv)), np.empty((B, nv, nv))
        for c in range(B):
            K[c], C[c] = analytic_derivatives(system, Q[c], V[c], A[c], float(ts[c]),
                                              shift=None if shift is None else shift[c])[:2]
        return K, C
    ws = system.workspace()
    model, data = system.model, ws.data
    K, C = np.empty((B, nv, nv)), np.empty((B, nv, nv))
    if system.point_groups:
        d = row_derivatives(system, ws, Q, V, t, shift)
        Fx, Fq = np.zeros((B, model.njoints, 6)), np.zeros((B, nv))
        for g in system.point_groups:
            g.apply(t, Q, V, d.kin, Fq, Fx)
    distrusted = untrusted(system)[0].size != 0
    batched = [(g, g.joint_rows(Q, V, ts)) for g in system.joint_groups]  # (None: row by row)
    single = [g for g, rows in batched if rows is None]
    for c in range(B):
        if system.point_groups:
            for j in system.point_joints:
                ws.forces[j][:] = Fx[c, j]
            out = pin.computeRNEADerivatives(model, data, Q[c], V[c], A[c], ws.fext)
        else:
            out = pin.computeRNEADerivatives(model, data, Q[c], V[c], A[c])
        K[c], C[c] = out[0], out[1]
        if distrusted:
            untrusted_columns(system, ws, Q[c], V[c], A[c], ts[c], None, None, C[c],
                              ws.fext if system.point_groups else None)
        if single:
            dj = Derivatives(system, ws, Q[c], V[c], A[c], float(ts[c]), False, points=False)
            for g in single:
                dq, dv = g.derivatives(dj)
                if dq is not None:
                    K[c] -= dq
                if dv is not None:
                    C[c] -= dv
    for _, rows in batched:
        if rows is not None:
            if rows[0] is not None:
                K -= rows[0]
            if rows[1] is not None:
                C -= rows[1]
    if system.point_groups:
        for g in system.point_groups:
            g.derivatives_rows(d)
        K += d.K
    if distrusted:
        for c in range(B):
            untrusted_columns(system, ws, Q[c], V[c], A[c], float(ts[c]), None if shift is None else shift[c],
                              K[c], None, None)
    return K, C


def row_derivatives(system, ws, Q, V=None, t=0.0, shift=None):
    """The :class:`RowDerivatives` of the states (rows of Q, V; t and ``shift`` as
    :func:`vibdyn.model.dynamics.kinematics_rows` takes them): their point elements' kinematics and the world
    Jacobians of the joints those attach to."""
    model, data, nv = system.model, ws.data, system.nv
    kin = dynamics.kinematics_rows(system, ws, Q, V if system.uses_point_velocities else None, t, shift)
    W = np.zeros((len(Q), model.njoints, 6, nv))
    for c in range(len(Q)):
        pin.computeJointJacobians(model, data, Q[c])
        for j in system.point_joints:
            W[c, j] = pin.getJointJacobian(model, data, j, pin.LOCAL_WORLD_ALIGNED).reshape(6, nv)
    return RowDerivatives(kin, W)


def solve_mass(M, B):
    """M⁻¹B by Cholesky, LAPACK directly (once per stage of the variational equations: scipy's wrappers cost
    more than the solve); a singular or non-finite M is a LinAlgError (the steppers' failure)."""
    from scipy.linalg import lapack  # (on first use: not at `import vibdyn`)

    L, info = lapack.dpotrf(M, lower=1)
    if info == 0:
        X, info = lapack.dpotrs(L, B, lower=1)
        if info == 0 and all_finite(X):
            return X
    raise np.linalg.LinAlgError("the mass matrix is singular or not finite at this state")


def linear_terms(system, q, v, t, a=None, applied=None, flags=None):
    """(M, K, C) at (q, v, t) for the Newton iterations of implicit integrators: M by CRBA, K = ∂r/∂q and
    C = ∂r/∂v analytically about the acceleration ``a`` (the free one if None), in the tree's coordinates;
    ``applied``: the forces at (q, v, t) as :func:`vibdyn.model.dynamics.forces` gives them, if already
    evaluated; ``flags`` as :func:`analytic_derivatives` takes it. No error estimate, no checks (the analyses'
    :func:`vibdyn.analysis.linearize.linearize` adds them)."""
    ws = system.workspace()
    if a is None:
        a = dynamics.accelerations(system, ws, q, v, t, applied).copy()
    M = dynamics.mass_matrix(system.model, ws.data, q)
    K, C, _, _ = analytic_derivatives(system, q, v, a, t, applied=applied, flags=flags)
    return M, K, C


def element_terms(system, groups, q, v, t):
    """(Q, K, C) of some compiled force groups alone at (q, v, t): their generalized force Q (N or N·m per
    coordinate; point forces through the joints' Jacobians) and their part of the linear model, K = −∂Q/∂q and
    C = −∂Q/∂v (what a parameter that enters those groups linearly, a stiffness or a damping, changes)."""
    nv = system.nv
    point = [g for g in groups if g.uses_points]
    Q, K, C = np.zeros(nv), np.zeros((nv, nv)), np.zeros((nv, nv))
    ws = system.workspace()
    d = Derivatives(system, ws, q, v, np.zeros(nv), t, any(g.needs_velocity_derivatives for g in point),
                    points=bool(point))
    joint = [g for g in groups if not g.uses_points]
    if point:
        d.fkin = dynamics.kinematics(system, ws, q, v if system.uses_point_velocities else None, t)
        F = np.zeros((system.model.njoints, 6))
        for g in point:
            g.apply(t, q, v, d.fkin, Q, F)
        for j in system.point_joints:
            Q += d.J[j].T @ F[j]
    for g in joint:
        g.apply(t, q, v, None, Q, None)
    subtract_group_derivatives(system, d, point, joint, K, C)
    return Q, K, C


def subtract_group_derivatives(system, d, point, joint, K, C, K_size=None):
    """K −= ∂Q/∂q and C −= ∂Q/∂v of the force groups ``point`` (point elements: their world forces'
    derivatives through the joints' Jacobians, d.fkin set) and ``joint`` (joint-space elements), in place;
    ``K_size`` (an array): also Σ |Jᵀ| |∂F/∂q|, the point terms' magnitudes (for the round-off estimate)."""
    for g in point:
        g.derivatives(d)
    if point:
        velocity = any(g.velocity_dependent or g.uses_point_velocities for g in point)  # (else no dFv)
        for j in system.point_joints:
            K -= d.J[j].T.dot(d.dFq[j])  # (ndarray.dot: half matmul's fixed cost on small matrices)
            if velocity:
                C -= d.J[j].T.dot(d.dFv[j])
            if K_size is not None:
                K_size += np.abs(d.J[j].T).dot(d.dFq_abs[j])
    for g in joint:
        dq, dv = g.derivatives(d)
        if dq is not None:
            K -= dq
            if K_size is not None:
                K_size += np.abs(dq)
        if dv is not None:
            C -= dv
