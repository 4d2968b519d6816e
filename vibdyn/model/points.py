"""Joint poses and points of the force elements, shared by every point element's compiled group: the poses
of the joints elements attach to (:class:`Kinematics`), and fixed points of joint frames with the forces on
them (:class:`PointSet` and :class:`ScatteredPoints`, chosen by :func:`point_set`). Numpy only, no element
kind here: the kinds (:mod:`vibdyn.description.elements`) use them.
"""

import math

import numpy as np
import pinocchio as pin

_LEVI_CIVITA = np.zeros((3, 3, 3))
_LEVI_CIVITA[0, 1, 2] = _LEVI_CIVITA[1, 2, 0] = _LEVI_CIVITA[2, 0, 1] = 1.0
_LEVI_CIVITA[0, 2, 1] = _LEVI_CIVITA[2, 1, 0] = _LEVI_CIVITA[1, 0, 2] = -1.0


def cross(a, b):
    """Row-wise cross product of (…, 3) arrays, (a × b)_i = ε_ijk a_j b_k in one einsum (numpy's own cross
    is slow on small arrays)."""
    return np.einsum("ijk,...j,...k->...i", _LEVI_CIVITA, a, b)


def skew(a):
    """[a]× of each row of a (…, 3): (…, 3, 3), [a]× b = a × b."""
    return np.einsum("ijk,...j->...ik", _LEVI_CIVITA, a)


SERIES_BELOW = 0.2  # rad: the SO(3) chart term's coefficients by their series below this rotation


def so3_chart_term(xi, v):
    """∂(J_r⁻¹(ξ) v)/∂ξ (3 × 3, 1/s): the chart's own term of a ball joint, with J_r⁻¹(ξ) = I + ½[ξ]× + c(θ)[ξ]×²
    (Pinocchio's Jlog3 of exp3(ξ)), c(θ) = 1/θ² − (1 + cos θ)/(2θ sin θ), θ = |ξ|, ξ (rad) and v (rad/s) the
    joint's chart and velocity. Pinocchio's Hlog3 is not finite at ξ = 0, where every step's chart starts:
    c and c′(θ)/θ are taken from their series there."""
    # f = v + ½ ξ × v + c (ξ (ξ·v) − θ² v): ∂f/∂ξ = −½[v]× + c((ξ·v) I + ξ vᵀ − 2 v ξᵀ) + (ξ (ξ·v) − θ² v) c′/θ ξᵀ,
    # entry by entry in floats, with math's functions (a 3 × 3 of small numpy operations, or numpy's sin and cos
    # of a float, cost several times more, twice per stage: the chart's and a ball spring's)
    x0, x1, x2 = xi.tolist()
    v0, v1, v2 = v.tolist()
    t2 = x0 * x0 + x1 * x1 + x2 * x2
    c, d = _jr_inv_coefficient(t2), _jr_inv_coefficient_rate(t2)
    xv = x0 * v0 + x1 * v1 + x2 * v2
    a0, a1, a2 = c * x0, c * x1, c * x2
    k, e = d * xv, d * t2 + 2 * c
    b0, b1, b2 = k * x0 - e * v0, k * x1 - e * v1, k * x2 - e * v2
    cxv, h0, h1, h2 = c * xv, 0.5 * v0, 0.5 * v1, 0.5 * v2
    return np.array([[a0 * v0 + b0 * x0 + cxv, a0 * v1 + b0 * x1 + h2, a0 * v2 + b0 * x2 - h1],
                     [a1 * v0 + b1 * x0 - h2, a1 * v1 + b1 * x1 + cxv, a1 * v2 + b1 * x2 + h0],
                     [a2 * v0 + b2 * x0 + h1, a2 * v1 + b2 * x1 - h0, a2 * v2 + b2 * x2 + cxv]])


# the series of (a, b, c, d) below in θ² (rows: a, b, c, d; columns: powers 0 … 4 of θ²)
_SO3_SERIES = np.array([[1 / 2, -1 / 24, 1 / 720, -1 / 40320, 1 / 3628800],
                        [1 / 6, -1 / 120, 1 / 5040, -1 / 362880, 1 / 39916800],
                        [1 / 12, 1 / 720, 1 / 30240, 1 / 1209600, 1 / 47900160],
                        [1 / 360, 1 / 7560, 1 / 201600, 1 / 5987520, 1 / 189243758]]).T
_POWERS = np.arange(5)
_C_SERIES, _D_SERIES = (tuple(column) for column in _SO3_SERIES[:, 2:].T.tolist())  # (floats: the scalar hot paths)


def _jr_inv_coefficient(t2):
    """c(θ) = 1/θ² − (1 + cos θ)/(2θ sin θ) of J_r⁻¹ = I + ½[ξ]× + c[ξ]×² at θ² (rad², a float), by its series below
    SERIES_BELOW."""
    if t2 < SERIES_BELOW ** 2:
        c0, c1, c2, c3, c4 = _C_SERIES
        return c0 + t2 * (c1 + t2 * (c2 + t2 * (c3 + t2 * c4)))
    t = math.sqrt(t2)
    return 1 / t2 - (1 + math.cos(t)) / (2 * t * math.sin(t))


def _jr_inv_coefficient_rate(t2):
    """d = c′(θ)/θ (rad⁻⁴) at θ² (rad², a float), by its series below SERIES_BELOW."""
    if t2 < SERIES_BELOW ** 2:
        d0, d1, d2, d3, d4 = _D_SERIES
        return d0 + t2 * (d1 + t2 * (d2 + t2 * (d3 + t2 * d4)))
    t = math.sqrt(t2)
    sin, cos = math.sin(t), math.cos(t)
    return -2 / (t2 * t2) + (t * sin * sin + (1 + cos) * (sin + t * cos)) / (2 * t2 * t * sin * sin)


def so3_dexp_inv(xi, v, starts=(0,)):
    """ξ̇ (rad/s, a list) of a chart ξ (rad) and velocities v whose balls start at ``starts`` (their three rotation
    components): J_r⁻¹(ξ_b) v_b = v_b + ½ ξ_b × v_b + c (ξ_b (ξ_b·v_b) − θ² v_b) on each ball, c as in
    :func:`so3_chart_term`, v elsewhere. Pinocchio 4.1's Jlog3 (its dDifference on a ball) is off by up to 2e-9
    for θ between about 1.2e-4 and 2.4e-3 rad (past its series threshold), where every step's chart starts: a
    vector-field error no tolerance sees; this closed form is exact to round-off (floats: a stage's hot path)."""
    out = v.tolist()
    x = xi.tolist()
    for i in starts:
        j, k = i + 1, i + 2
        x0, x1, x2, v0, v1, v2 = x[i], x[j], x[k], out[i], out[j], out[k]
        t2 = x0 * x0 + x1 * x1 + x2 * x2
        c = _jr_inv_coefficient(t2)
        xv = c * (x0 * v0 + x1 * v1 + x2 * v2)
        w = 1.0 - c * t2
        out[i] = w * v0 + 0.5 * (x1 * v2 - x2 * v1) + xv * x0
        out[j] = w * v1 + 0.5 * (x2 * v0 - x0 * v2) + xv * x1
        out[k] = w * v2 + 0.5 * (x0 * v1 - x1 * v0) + xv * x2
    return out


def so3_jr_inv(xi):
    """J_r⁻¹(ξ) (3 × 3) of one rotation vector ξ (rad): (1 − cθ²) I + ½[ξ]× + c ξξᵀ, c as in :func:`so3_chart_term`
    (floats: a state's hot path; :func:`so3_jacobians` for many at once). Pinocchio's Jlog3 instead: see
    :func:`so3_dexp_inv`."""
    x0, x1, x2 = xi.tolist()
    t2 = x0 * x0 + x1 * x1 + x2 * x2
    c = _jr_inv_coefficient(t2)
    w = 1.0 - c * t2
    h0, h1, h2 = 0.5 * x0, 0.5 * x1, 0.5 * x2
    c0, c1, c2 = c * x0, c * x1, c * x2
    return np.array([[w + c0 * x0, c0 * x1 - h2, c0 * x2 + h1],
                     [c1 * x0 + h2, w + c1 * x1, c1 * x2 - h0],
                     [c2 * x0 - h1, c2 * x1 + h0, w + c2 * x2]])


def _so3_coefficients(t2):
    """For rows of θ² (rad²): (a, b, c, d) with J_r = I − a[ξ]× + b[ξ]×², J_r⁻¹ = I + ½[ξ]× + c[ξ]×² and d = c′(θ)/θ
    (:func:`so3_chart_term`'s): a = (1 − cos θ)/θ², b = (θ − sin θ)/θ³, c = 1/θ² − (1 + cos θ)/(2θ sin θ), by their
    series below SERIES_BELOW (B × 4, one column each)."""
    out = np.power.outer(t2, _POWERS) @ _SO3_SERIES
    big = t2 >= SERIES_BELOW ** 2
    if big.any():
        T2 = t2[big]
        t = np.sqrt(T2)
        sin, cos = np.sin(t), np.cos(t)
        out[big] = np.stack([(1 - cos) / T2, (t - sin) / (T2 * t), 1 / T2 - (1 + cos) / (2 * t * sin),
                             -2 / (T2 * T2) + (t * sin * sin + (1 + cos) * (sin + t * cos)) / (2 * T2 * t * sin * sin)],
                            axis=-1)
    return out


def so3_jacobians(xi, v=None):
    """(J_r(ξ), J_r⁻¹(ξ)) at rows of rotation vectors ξ (B × 3, rad), B × 3 × 3 each: a ball joint's blocks of
    Pinocchio's dIntegrate(c, ξ, ARG1) and dDifference(c, c ⊕ ξ, ARG1), for many states in one pass; with
    velocities ``v`` (B × 3, rad/s), also :func:`so3_chart_term` at each row."""
    t2 = np.einsum("bi,bi->b", xi, xi)
    k = _so3_coefficients(t2)
    X = skew(xi)
    X2 = X @ X
    eye = np.eye(3)
    out = (eye - k[:, 0, None, None] * X + k[:, 1, None, None] * X2, eye + 0.5 * X + k[:, 2, None, None] * X2)
    if v is None:
        return out
    c, d = k[:, 2], k[:, 3]
    xv = np.einsum("bi,bi->b", xi, v)
    a = c[:, None] * xi
    b = (d * xv)[:, None] * xi - (d * t2 + 2 * c)[:, None] * v
    term = (a[:, :, None] * v[:, None, :] + b[:, :, None] * xi[:, None, :] + (c * xv)[:, None, None] * eye
            - 0.5 * skew(v))
    return out + (term,)


_NO_SUPPORT = np.zeros((1, 3))
ONES3 = np.ones(3)


class Kinematics:
    """Poses (and local velocities if asked) of the joints that point elements attach to: ``R``, ``p`` (and
    ``v``, ``w``) indexed by Pinocchio joint id, rows of other joints zero; joint 0 (the world) is the
    identity at rest. Computed in the workspace ``ws`` (its Data, and its live views of the Data's joint
    poses and velocities, one per joint: ``rotations``, ``translations``, ``linear``, ``angular``), read
    after forward kinematics in one copy per array. ``R`` and ``p`` are views of one vector ``pose`` =
    (R, p), of which point positions are linear functions (:class:`PointSet`). :meth:`rows` makes them for
    many configurations at once: every array with a leading axis of rows (the element groups' numpy takes
    either)."""

    __slots__ = ("R", "p", "pose", "v", "w", "sp", "sv", "q")

    def __init__(self, model, ws, joints, q, v=None, supports=None):
        self.q = q  # (where an element that cannot be evaluated says it met its singular point)
        # support displacements and velocities (m, m/s), one row per support and a last zero row, so that
        # index −1 (an end on no support) adds nothing
        self.sp, self.sv = supports if supports is not None else (_NO_SUPPORT, _NO_SUPPORT)
        if v is None:
            pin.forwardKinematics(model, ws.data, q)
        else:
            pin.forwardKinematics(model, ws.data, q, v)
        nj = len(ws.rotations)
        self.pose = np.empty(12 * nj) if len(joints) == nj - 1 else np.zeros(12 * nj)
        self.R = gather(ws.rotations, joints, self.pose[:9 * nj].reshape(nj, 3, 3))
        self.p = gather(ws.translations, joints, self.pose[9 * nj:].reshape(nj, 3))
        if v is not None:
            self.v, self.w = gather(ws.linear, joints, np.zeros((nj, 3))), gather(ws.angular, joints, np.zeros((nj, 3)))

    @classmethod
    def rows(cls, model, ws, joints, Q, V=None, supports=None):
        """The poses (and velocities) at each row of Q (B × nq) and V (B × nv): ``R`` B × njoints × 3 × 3, …;
        ``supports`` (sp, sv) of B × (n_supports + 1) × 3 each."""
        kin = cls.__new__(cls)
        B, nj = len(Q), len(ws.rotations)
        kin.q = Q
        kin.sp, kin.sv = supports if supports is not None else (_NO_SUPPORT, _NO_SUPPORT)
        kin.pose = np.zeros((B, 12 * nj))
        kin.R, kin.p = kin.pose[:, :9 * nj].reshape(B, nj, 3, 3), kin.pose[:, 9 * nj:].reshape(B, nj, 3)
        if V is not None:
            kin.v, kin.w = np.zeros((B, nj, 3)), np.zeros((B, nj, 3))
        for c in range(B):
            if V is None:
                pin.forwardKinematics(model, ws.data, Q[c])
            else:
                pin.forwardKinematics(model, ws.data, Q[c], V[c])
                gather(ws.linear, joints, kin.v[c])
                gather(ws.angular, joints, kin.w[c])
            gather(ws.rotations, joints, kin.R[c])
            gather(ws.translations, joints, kin.p[c])
        return kin

    def points(self, joints, local):
        """World positions (m) of points given in their joint frames."""
        return np.einsum("...nij,nj->...ni", self.R[..., joints, :, :], local) + self.p[..., joints, :]

    def velocities(self, joints, local):
        """World velocities (m/s) of points given in their joint frames."""
        lin = self.v[..., joints, :] + cross(self.w[..., joints, :], local)
        return np.einsum("...nij,...nj->...ni", self.R[..., joints, :, :], lin)


def gather(views, joints, out):
    """``out`` with the arrays ``views[j]`` of joint 0 (the world's identity pose, zero velocity) and of the
    sorted ``joints`` as its rows, indexed by joint id (rows of other joints left as they are: zeros, as
    PointSet's constant maps take every row)."""
    if len(joints) == len(views) - 1:  # every joint: one copy
        out[:] = views
    else:
        out[0] = views[0]
        for j in joints:
            out[j] = views[j]
    return out


# Above this many numbers in PointSet's dense maps (points × joints), the per-point gather and scatter of
# ScatteredPoints is faster (measured: 30 springs on 30 pivots 75 µs dense vs 280 µs per point; 300 on 300,
# 7.8 ms dense vs 1.2 ms per point)
DENSE_MAX = 200_000


def point_set(joints, local, nj, D=None):
    """The faster of :class:`PointSet` (dense constant maps, small scenes) and :class:`ScatteredPoints`
    (per-point gather and scatter, large ones) for these points: same protocol, same results."""
    joints = np.asarray(joints, dtype=int)
    moving = joints[joints > 0]
    span = int(moving.max() - moving.min() + 1) if moving.size else 0
    n = len(joints) if D is None else len(D)
    size = 3 * n * 12 * nj + 54 * span * 3 * n
    return (PointSet if size <= DENSE_MAX else ScatteredPoints)(joints, local, nj, D)


class ScatteredPoints:
    """:class:`PointSet`'s protocol by per-point gathers of the joint poses and one scatter of the forces:
    O(points) work and memory, for scenes too large for dense maps."""

    def __init__(self, joints, local, nj, D=None):
        self.joints = np.asarray(joints, dtype=int)
        self.local = np.asarray(local, dtype=float).reshape(-1, 3)
        self.D = None if D is None else np.asarray(D, dtype=float)

    def positions(self, kin):
        """The combined world positions D x (m), (rows ×) n × 3."""
        x = kin.points(self.joints, self.local)
        return x if self.D is None else self.D @ x

    def add_forces(self, F, kin, f):
        """Accumulate the forces Dᵀ f (world axes; ``f`` (rows ×) n × 3) on the points into ``F``."""
        f = f if self.D is None else self.D.T @ f
        fl = np.einsum("...nji,...nj->...ni", kin.R[..., self.joints, :, :], f)  # Rᵀ f, in each joint frame
        wrench = np.concatenate([fl, cross(self.local, fl)], axis=-1)
        np.add.at(F, self.joints if F.ndim == 2 else (slice(None), self.joints), wrench)


class PointSet:
    """Fixed points of joint frames (``joints``, ``local`` points in those frames, of a model of ``nj``
    joints) seen through n combinations ``D`` (n × points; None: the points themselves): the combined
    positions D x and the forces Dᵀ f on the points for n given forces f, as constant linear maps of the
    joint poses.

    A position R r + p is linear in joint j's (R, p): D x is one constant matrix times the joints' poses
    (:attr:`Kinematics.pose`). In j's frame a force f (world axes) at r is (Rᵀ f, r × Rᵀ f), bilinear in
    (R, f): one constant matrix times f gives its coefficients on the rotations of the contiguous span of
    joints the points are on (the world, joint 0, takes no force). The matrices are dense, of size
    (points × joints): a few matrix products for the tens of elements of a scene, in place of per-point
    indexing and scatter."""

    def __init__(self, joints, local, nj, D=None):
        joints = np.asarray(joints, dtype=int)
        local = np.asarray(local, dtype=float).reshape(-1, 3)
        D = np.eye(len(joints)) if D is None else np.asarray(D, dtype=float)
        moving = np.flatnonzero(joints)
        lo, hi = (int(joints[moving].min()), int(joints[moving].max()) + 1) if len(moving) else (0, 0)
        self.span, k, n = slice(lo, hi), hi - lo, len(D)
        G = np.zeros((len(joints), 3, 12 * nj))  # x[e, i] = G[e, i] · (R, p)
        B = np.zeros((k, 6, len(joints), 3))  # (force, moment) on each joint per local force at each point
        for e, (j, r) in enumerate(zip(joints, local)):
            for i in range(3):
                G[e, i, 9 * j + 3 * i:9 * j + 3 * i + 3], G[e, i, 9 * nj + 3 * j + i] = r, 1.0
            if j != 0:
                B[j - lo, :3, e], B[j - lo, 3:, e] = np.eye(3), pin.skew(r)
        self.G = np.einsum("me,eX->mX", D, G.reshape(len(joints), -1)).reshape(3 * n, 12 * nj)
        # F_j,a = Σ_ik C[j, a, i, k] R_j[i, k] with C = K f: K[j, a, i, k, l, i] = Σ_e B[j, a, e, k] D[l, e]
        BD = np.einsum("jaek,le->jakl", B, D)
        K = np.zeros((k, 6, 3, 3, n, 3))
        for i in range(3):
            K[:, :, i, :, :, i] = BD
        self.K = K.reshape(54 * k, 3 * n)

    def positions(self, kin):
        """The combined world positions D x (m), (rows ×) n × 3."""
        if kin.pose.ndim == 1:
            return (self.G @ kin.pose).reshape(-1, 3)
        return (kin.pose @ self.G.T).reshape(len(kin.pose), -1, 3)

    def add_forces(self, F, kin, f):
        """Accumulate the forces Dᵀ f (world axes; ``f`` (rows ×) n × 3) on the points into ``F``."""
        s = self.span
        if F.ndim == 2:
            R = kin.R[s]
            F[s] += ((self.K @ f.ravel()).reshape(len(R), 6, 9) @ R.reshape(len(R), 9, 1)).reshape(len(R), 6)
            return
        R = kin.R[:, s]
        B, k = R.shape[:2]
        C = (f.reshape(B, -1) @ self.K.T).reshape(B, k, 6, 9)
        F[:, s] += (C @ R.reshape(B, k, 9, 1)).reshape(B, k, 6)


