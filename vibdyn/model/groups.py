"""The compiled force group every element kind builds (:class:`Group`: all members of a kind at once) and the
two-point groups springs and dampers share (:class:`TwoPoint`), with their small helpers."""

import numpy as np

from ..errors import ModelError
from .points import ONES3, point_set


class ForceGroup:
    """One kind of force element, all members at once: adds its generalized force to ``Q`` (joint space,
    length nv) and, for point elements, spatial forces to ``F`` (one row (force, moment) per Pinocchio
    joint, in that joint's frame) that the system hands to ABA/RNEA as external forces."""

    uses_points = False  # needs joint poses (point elements)
    uses_point_velocities = False
    needs_velocity_derivatives = False  # its derivatives need ∂(point velocities)/∂q
    velocity_dependent = False
    time_dependent = False
    rows = False  # a point group whose apply takes many states at once (Kinematics.rows; Q, F with a row axis)
    joints: tuple = ()  # Pinocchio joints it applies forces to
    members: tuple = ()  # the names of its elements (set by vibdyn.model.forces.compile_groups)

    def apply(self, t, q, v, kin, Q, F):
        raise NotImplementedError

    def apply_rows(self, t, q, v, Q):
        """A joint-space group's generalized forces at many states at once: rows of q (B × nq) and v (B × nv,
        or one nv-vector for every row) add into the rows of Q (B × nv). A group whose force is plain numpy
        over coordinates overrides this with one evaluation of all rows; this default calls :meth:`apply`
        row by row."""
        for c in range(len(q)):
            self.apply(t, q[c], v[c] if v.ndim == 2 else v, None, Q[c], None)

    def potential(self, q, kin):
        return 0.0

    derivatives_rows = None  # a point group's derivatives at many states at once (RowDerivatives), if it has them
    # (U, s) = force_rounding(d) (d: a RowDerivatives of one state), where a force of the group is computed from
    # world positions that round off: U (m × nv) the generalized force per unit of each such force, s (m,) the
    # size of its rounding (N); None where the group's forces do not turn world-position round-off into force
    force_rounding = None

    def joint_rows(self, q, v, t):
        """A joint group's (∂Q/∂q, ∂Q/∂v) at many states at once — rows of q (B × nq) and v (B × nv), t (s, or B
        of them) — each B × nv × nv or None for zero; None where the group has them one state at a time only
        (:meth:`derivatives`)."""
        return None

    def derivatives(self, d):
        """Analytic derivatives (see :mod:`vibdyn.model.derivatives`, whose ``d`` gives the point Jacobians,
        force accumulators and finite differences of user callables): a point group adds its forces'
        derivatives through ``d.add_force``; a joint group returns (∂Q/∂q, ∂Q/∂v), each None for zero."""
        raise NotImplementedError


Group = ForceGroup  # (the former name, beside the Lie groups of the joints)


class TwoPoint(ForceGroup):
    """Elements between two points: ends a and b of each member (the ends' arrays: a's then b's)."""

    uses_points = True
    tiny: np.ndarray  # lengths at or below these are zero (negative: the member may reach zero length)

    def __init__(self, system, elements):
        self.names = [e.name for e in elements]
        self.ja, self.pa = system.attachments([e.a for e in elements])
        self.jb, self.pb = system.attachments([e.b for e in elements])
        self.sa = system.support_indices([e.a for e in elements])
        self.sb = system.support_indices([e.b for e in elements])
        self.joints = tuple(sorted(set(self.ja) | set(self.jb)))
        self.j_ends = np.concatenate([self.ja, self.jb])
        self.p_ends = np.concatenate([self.pa, self.pb])
        self.on_supports = bool(np.any(self.sa >= 0) or np.any(self.sb >= 0))
        n = len(elements)
        self.ends = point_set(self.j_ends, self.p_ends, system.model.njoints,
                             np.hstack([-np.eye(n), np.eye(n)]))  # combined: xb − xa

    def end_velocities(self, kin):
        """World velocities (m/s) of the two ends, supports' motion included."""
        return (kin.velocities(self.ja, self.pa) + kin.sv[..., self.sa, :],
                kin.velocities(self.jb, self.pb) + kin.sv[..., self.sb, :])

    def separation(self, kin):
        """d = xb − xa between the world ends (m), (rows ×) n × 3."""
        d = self.ends.positions(kin)
        if self.on_supports:
            d += kin.sp[..., self.sb, :] - kin.sp[..., self.sa, :]
        return d

    def geometry(self, kin):
        """(d, L): d = xb − xa between the world ends (m) and the lengths L (m); a length at or below ``tiny``
        is a ModelError naming the element."""
        d = self.separation(kin)
        L = np.sqrt((d * d) @ ONES3)
        zero = (L <= self.tiny).tolist() if L.ndim == 1 else (L <= self.tiny).ravel().tolist()  # (a list: faster
        # than a numpy reduction on a few elements)
        if True in zero:
            row, i = divmod(zero.index(True), len(self.names))
            one = (lambda a: a) if L.ndim == 1 else (lambda a: a[row])  # (the row of many states it is met at)
            sp = kin.sp if kin.sp.ndim == 2 else kin.sp[row]
            xa = one(kin.points(self.ja[i:i + 1], self.pa[i:i + 1]))[0] + sp[self.sa[i]]
            length = float(one(L)[i])
            if length > 1e-9 * max(1.0, float(np.abs(xa).max())):  # not zero by the scene's geometry: by its own
                raise ModelError(f"{self.noun} '{self.names[i]}': its length {length:.6g} m is zero to the "
                                 f"precision of its force (at most {self.tiny[i]:.3g} m counts as zero beside its "
                                 "free length): the free length is too large for the scene")
            raise ModelError(f"{self.noun} '{self.names[i]}' reached zero length at the configuration q = "
                             f"{np.round(one(kin.q), 9).tolist()} (its two ends coincide at "
                             f"{np.round(xa, 12).tolist()} m):"
                             " its direction, and so its force, is undefined there; start the analysis or the "
                             "motion away from it (q0=, or Scene.set_operating_point(start=...))")
        return d, L

    noun = "element"  # what error messages call a member


def as_slice(index):
    """An index array as the equal slice when its entries are consecutive and increasing (a view, not a
    gather), else the array itself."""
    index = np.asarray(index, dtype=int)
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + index.size)
    return index


def tangent(model, body, rest):
    """A tangent vector of the model with ``rest`` on ``body``'s coordinates and zeros elsewhere."""
    dv = np.zeros(model.nv)
    dv[body.idx_v:body.idx_v + body.nv] = rest
    return dv
