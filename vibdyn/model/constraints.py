"""Compiled closed loops: the constraint equations Φ(q) = 0 of a system's loops (see
:mod:`vibdyn.description.loops` for the kinds and their equations).
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import pinocchio as pin

from ..defaults import ASSEMBLY_TOL, EPS, RANK_RTOL
from ..description.elements import WORLD
from ..errors import ConvergenceError, ModelError
from .fd import derivative, hessian
from .workspace import create_data


def _cross(a, b):
    """a × b of two 3-vectors (np.cross costs ~20 µs a call on 3-vectors)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


_EYE, _ZERO = np.eye(3), np.zeros((3, 3))


class _End:
    """One end of a loop as evaluated at (q[, v]): world position p (m), rotation R, Jacobians Jv, Jw
    (LOCAL_WORLD_ALIGNED, 3 × nv) and, for the bias, the point velocity dp (m/s), its classical acceleration
    at zero joint acceleration ddp (m/s²), the angular velocity w (rad/s) and acceleration dw (rad/s²)."""

    __slots__ = ("p", "R", "Jv", "Jw", "dp", "ddp", "w", "dw")

    def turn(self, n):
        """(x, ẋ, ẍ) of the world vector x = R n, n fixed in the end's frame."""
        x = self.R @ n
        dx = _cross(self.w, x)
        return x, dx, _cross(self.dw, x) + _cross(self.w, dx)


DRIFT_RANK = 1e3  # singular values below this × the drift off the loops do not count (decompose)
MAX_STEP = 0.5  # largest tangent step of one assembly iteration (rad, or × the length scale m)
LOCK_SIGMA = 10.0  # singular values below this × √(residual) (relative) are lost at a closure (isolated)
LOCK_STEP = 1e-3  # step (dimensionless) of the second differences of the lost equations (isolated)
LOCK_CURVATURE = 1e-5  # least |eigenvalue| (dimensionless) of a definite second-order form (isolated)
LOCK_MAX_MOTIONS = 6  # more first-order motions than this at a closure: the isolation test is not tried


class Constraints:
    """The compiled loop equations of a system: Φ(q), Φ_q(q) (tangent space), rank, null space, assembly.
    ``closed``: (q, where) of the first closed configuration met, None before; ``dof`` the mobility there.

    The table a System compiles (``system.compiled_loops``) keeps what it needs of the System, not the System;
    those of its methods that need it take it (:meth:`assembly`, :meth:`start`). ``system.constraints`` is the
    table bound to the system on each access (:meth:`bound`), sharing what the table found."""

    _system: Any  # the System of a bound table (held by the caller only, never by a compiled object), else None

    def __init__(self, system, loops):
        # what it needs of the system, not the system: a reference back would be a cycle keeping every System
        # built with loops (and its Pinocchio Data) alive until the garbage collector runs (as Reduction's)
        self.model, self.nv, self.units = system.model, system.nv, tuple(system.units)
        self.length_scale, self.periodic_coordinates = system.length_scale, system.periodic_coordinates
        self._system = None  # (compiled: bound to no System, :meth:`bound`)
        # what the searches found, shared with the bound copies: "closed" (q, where) of the first closed
        # configuration met, "dof" the mobility there, "assembly" the described pose's (or its ConvergenceError)
        self._found: dict = {"closed": None, "dof": None, "assembly": None}
        self._local = threading.local()  # (Pinocchio Data per thread: the building thread's is the System's own)
        self._local.data = system.data
        self.loops = tuple(loops)
        self.ends = []  # per loop: its two ends (joint id, point in the joint's frame (m), rotation in it); 0: world
        self.axes = []  # per loop: (normals n_i of "normal" rows, (n, u) pairs of "aligned" ones)
        for lp in self.loops:
            ends = []
            for body, point in (lp.a, lp.b):
                if body == WORLD:
                    ends.append((0, np.array(point), np.eye(3)))
                else:
                    info = system.body_info(body)
                    B = info.body_in_joint
                    ends.append((info.joint_id, B.act(np.array(point)), B.rotation.copy()))
            self.ends.append(ends)
            self.axes.append((lp.joint.loop_normals(), lp.joint.loop_alignments()))
        self.placements = [[pin.SE3(Rl, r) for _, r, Rl in ends] for ends in self.ends]  # (the ends' in their joints)
        self._rows = [(list(zip(e, P)), n, u, "position" in lp.joint.loop_rows, "locked" in lp.joint.loop_rows)
                      for lp, e, P, (n, u) in zip(self.loops, self.ends, self.placements, self.axes)]
        self.sizes, self._every = tuple(lp.equations for lp in self.loops), tuple(range(len(self.loops)))
        self.m = sum(self.sizes)
        L = system.length_scale
        # dimensionless scaling: position rows / L, translation columns × L
        units = (np.concatenate([self._row_units(lp, n, len(normals))
                                 for lp, n, (normals, _) in zip(self.loops, self.sizes, self.axes)])
                 if self.loops else np.zeros(0))
        self.row_units = tuple("m" if u == 1 else "rad" for u in units)  # the unit of each equation
        self.row_scale = np.where(units == 1, 1.0 / L, 1.0)
        self.col_scale = system.coordinate_scales

    def bound(self, system: Any) -> Constraints:
        """This table bound to ``system`` (what ``system.constraints`` is): a copy sharing what the table found
        (:attr:`closed`, the assembly), made on each access and kept by no compiled object, so nothing refers
        back to the System (a System is freed by its last reference, without the garbage collector)."""
        out = object.__new__(Constraints)
        out.__dict__.update(self.__dict__)
        out._system = system
        return out

    def _owner(self, system: Any, what: str) -> Any:
        """``system``, else the System this table is bound to; a ModelError if neither."""
        system = self._system if system is None else system
        if system is None:
            raise ModelError(f"Constraints.{what}: this table is bound to no System (pass the system, or use "
                             f"system.constraints.{what})")
        return system

    def __getstate__(self):
        """What a pickle keeps: everything but the per-thread Data (scratch: a copy makes its own)."""
        state = dict(self.__dict__)
        del state["_local"]
        return state

    def __setstate__(self, state):
        self.__dict__.update(state, _local=threading.local())

    @property
    def data(self) -> pin.Data:
        """The calling thread's Pinocchio Data of the loops' kinematics (scratch, made on first use)."""
        if getattr(self._local, "data", None) is None:
            self._local.data = create_data(self.model)
        return self._local.data

    closed = property(lambda self: self._found["closed"])
    dof_closed = property(lambda self: self._found["dof"])

    @staticmethod
    def _row_units(lp, equations, normals):
        """1 for a position equation (m), 0 for an orientation one (rad), of a loop of ``equations`` rows with
        ``normals`` "normal" rows."""
        pos = 3 * ("position" in lp.joint.loop_rows) + normals
        return np.array([1] * pos + [0] * (equations - pos))

    # ----------------------------------------------------------------- equations
    def _frames(self, q, jacobians=False, v=None):
        """[[_End a, _End b] per loop] at q; Jacobians if asked; with v, the motion at zero acceleration."""
        model, data = self.model, self.data
        if v is not None:
            pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
        if jacobians:
            pin.computeJointJacobians(model, data, q)
        elif v is None:
            pin.forwardKinematics(model, data, q)
        nv = model.nv
        out = []
        for ends, places in zip(self.ends, self.placements):
            fr = []
            for (jid, r, Rl), P in zip(ends, places):
                e = _End()
                if jid == 0:
                    e.p, e.R = r.copy(), Rl.copy()
                    e.Jv = e.Jw = np.zeros((3, nv))
                    e.dp = e.ddp = e.w = e.dw = np.zeros(3)
                    fr.append(e)
                    continue
                e.p, e.R, e.Jv, e.Jw = self._end(data, jid, P, jacobians)
                if v is not None:
                    R = data.oMi[jid].rotation
                    vel, acc = data.v[jid], data.a[jid]  # LOCAL: d/dt of the local components
                    w, dw = vel.angular, acc.angular
                    dp = vel.linear + _cross(w, r)
                    e.dp, e.w, e.dw = R @ dp, R @ w, R @ dw
                    e.ddp = R @ (acc.linear + _cross(dw, r) + _cross(w, dp))
                fr.append(e)
            out.append(fr)
        return out

    def _end(self, data, jid, placement, jacobian):
        """(p, R, Jv, Jw) of a loop end at ``placement`` (SE3) in joint jid's frame (jid > 0): world position (m),
        rotation and LOCAL_WORLD_ALIGNED Jacobians at the end (3 × nv each; None without ``jacobian``)."""
        H = (data.oMi[jid] * placement).homogeneous
        if not jacobian:
            return H[:3, 3], H[:3, :3], None, None
        J = pin.getFrameJacobian(self.model, data, jid, placement, pin.LOCAL_WORLD_ALIGNED)
        return H[:3, 3], H[:3, :3], J[:3], J[3:]

    def evaluate(self, q, jacobian=True, wrenches=False, loops=None):
        """(Φ (m,), Φ_q (m × nv) or None) at q: positions in m, orientations in rad; ``loops`` (indices): their
        rows only. With ``wrenches`` (every loop), also per loop the coefficient matrices (C_a, C_b) (rows × 6)
        with Φ_q = C_a J_a + C_b J_b, J the LOCAL_WORLD_ALIGNED Jacobians (linear; angular) of the loop frames:
        the wrench (N; N·m, world axes, at the loop point) multipliers λ exert on end a is C_aᵀ λ, on b C_bᵀ λ."""
        if not wrenches:
            return self._equations(q, jacobian, self._every if loops is None else loops)
        phis, jacs, coeffs = [], [], []
        for lp, (normals, pairs), (a, b) in zip(self.loops, self.axes, self._frames(q, jacobian)):
            kinds = lp.joint.loop_rows
            e = b.p - a.p
            rows, Ca, Cb = [], [], []
            if "position" in kinds:
                rows.append(e)
                Ca.append(np.hstack([-_EYE, _ZERO]))
                Cb.append(np.hstack([_EYE, _ZERO]))
            for n in normals:
                w = a.R @ n
                rows.append([w @ e])
                Ca.append(np.concatenate([-w, _cross(w, e)])[None, :])
                Cb.append(np.concatenate([w, np.zeros(3)])[None, :])
            for n, u in pairs:
                wa, wb = a.R @ n, b.R @ u
                rows.append([wa @ wb])
                c = _cross(wa, wb)
                Ca.append(np.concatenate([np.zeros(3), c])[None, :])
                Cb.append(np.concatenate([np.zeros(3), -c])[None, :])
            if "locked" in kinds:
                R = a.R.T @ b.R
                rows.append(pin.log3(R))
                L = pin.Jlog3(R) @ b.R.T
                Ca.append(np.hstack([_ZERO, -L]))
                Cb.append(np.hstack([_ZERO, L]))
            phis.append(np.concatenate([np.ravel(x) for x in rows]))
            if jacobian:
                Ca, Cb = np.vstack(Ca), np.vstack(Cb)
                jacs.append(Ca @ np.vstack([a.Jv, a.Jw]) + Cb @ np.vstack([b.Jv, b.Jw]))
                coeffs.append((Ca, Cb))
        nv = self.nv
        phi = np.concatenate(phis) if phis else np.zeros(0)
        J = (np.vstack(jacs) if jacs else np.zeros((0, nv))) if jacobian else None
        return (phi, J, coeffs) if wrenches else (phi, J)

    def _equations(self, q, jacobian, loops):
        """(Φ, Φ_q or None) of :meth:`evaluate` for the ``loops`` (indices), each row written out from the ends'
        frames into one array (no coefficient matrices: the hot path of every closure, search and step)."""
        model, data = self.model, self.data
        if jacobian:
            pin.computeJointJacobians(model, data, q)
        else:
            pin.forwardKinematics(model, data, q)
        nv, m = model.nv, self.m if loops is self._every else sum(self.sizes[i] for i in loops)
        phi, J, zero, k = np.empty(m), np.empty((m, nv)) if jacobian else None, None, 0
        for i in loops:
            ends, normals, pairs, position, locked = self._rows[i]
            frames = []
            for (jid, r, Rl), P in ends:
                if jid == 0:
                    if jacobian and zero is None:
                        zero = np.zeros((3, nv))
                    frames.append((r, Rl, zero, zero))
                    continue
                frames.append(self._end(data, jid, P, jacobian))
            (pa, Ra, Jva, Jwa), (pb, Rb, Jvb, Jwb) = frames
            e = pb - pa
            de = Jvb - Jva if jacobian else None
            if position:
                phi[k:k + 3] = e
                if jacobian:
                    J[k:k + 3] = de
                k += 3
            for n in normals:
                w = Ra @ n
                phi[k] = w @ e
                if jacobian:
                    J[k] = w @ de + (pin.skew(w) @ e) @ Jwa
                k += 1
            dw = Jwa - Jwb if jacobian and pairs else None
            for n, u in pairs:
                wa, wb = Ra @ n, Rb @ u
                phi[k] = wa @ wb
                if jacobian:
                    J[k] = (pin.skew(wa) @ wb) @ dw
                k += 1
            if locked:
                Rab = Ra.T @ Rb
                phi[k:k + 3] = pin.log3(Rab)
                if jacobian:
                    J[k:k + 3] = pin.Jlog3(Rab) @ Rb.T @ (Jwb - Jwa)
                k += 3
        return phi, J

    def phi(self, q):
        return self.evaluate(q, jacobian=False)[0]

    def jacobian(self, q):
        return self.evaluate(q)[1]

    def scaled_phi(self, phi):
        """Dimensionless residual: positions / length scale, angles in rad."""
        return self.row_scale * phi

    # ----------------------------------------------------------------- rank and null space
    def decompose(self, J, drift=0.0):
        """(rank, U, s, Vt) of the dimensionless Jacobian (J: the first rows of Φ_q, or all of them).
        ``drift``: how far (dimensionless |Φ|) the configuration is off the loops; singular values below
        DRIFT_RANK × drift (relative) are taken as that drift's, not the mechanism's (a mechanism whose
        equations are redundant on its loops only, as Bricard's, gains rank off them by about the drift)."""
        Js = self.row_scale[:len(J), None] * J * self.col_scale[None, :]
        if Js.size == 0:
            return 0, None, np.zeros(0), np.eye(J.shape[1])
        U, s, Vt = np.linalg.svd(Js)
        tol = max(RANK_RTOL, DRIFT_RANK * drift)
        rank = int(np.sum(s > tol * s[0])) if s.size and s[0] > 0 else 0
        return rank, U, s, Vt

    def rank(self, q):
        return self.decompose(self.jacobian(q))[0]

    def conditioning(self, q):
        """σ_min / σ_max of the retained singular values of the dimensionless Φ_q at q: how far the
        mechanism is from a singular position (0 there, where the rank drops)."""
        return self._conditioning(self.decompose(self.jacobian(q)))

    @staticmethod
    def _conditioning(dec):
        rank, _, s, _ = dec
        return float(s[rank - 1] / s[0]) if rank else 1.0

    def null_space(self, q, J=None):
        """Basis N (nv × dof) of the motions that keep the loops closed at q (Φ_q N = 0), in the tree's
        tangent coordinates; its columns are orthonormal in the dimensionless metric."""
        return self._null(self.decompose(self.jacobian(q) if J is None else J))

    def correction(self, phi, J):
        """Minimum-norm (dimensionless metric) tangent step dq with Φ + Φ_q dq = 0 on the rank's range."""
        return self._min_norm(self.decompose(J), phi, J.shape[1])

    def _null(self, dec):
        rank, _, _, Vt = dec
        return self.col_scale[:, None] * Vt[rank:].T

    def _min_norm(self, dec, phi, nv):
        """−Φ_q⁺ Φ on the rank's range, from the decomposition of Φ_q."""
        rank, U, s, Vt = dec
        if rank == 0:
            return np.zeros(nv)
        y = (U[:, :rank].T @ (self.row_scale * phi)) / s[:rank]
        return -self.col_scale * (Vt[:rank].T @ y)

    def partition(self, J, independent=None):
        """(independent, N): the tree coordinates kept as the mechanism's independent motions (dof of them,
        chosen by QR with column pivoting of the dimensionless Jacobian: the best-conditioned dependent set)
        and the basis N (nv × dof) of Φ_q N = 0 whose rows at the independent coordinates are the identity.
        ``independent``: keep these (a smooth basis along a path) instead of choosing."""
        import scipy.linalg as sla

        rank, _, _, _ = self.decompose(J)
        nv = J.shape[1]
        Js = self.row_scale[:, None] * J * self.col_scale[None, :]
        if rank == 0:
            return np.arange(nv), np.eye(nv)
        if independent is None:
            _, _, piv = sla.qr(Js, pivoting=True, mode="economic")
            dep, ind = np.sort(piv[:rank]), np.sort(piv[rank:])
        else:
            ind = np.asarray(independent, dtype=int)
            dep = np.setdiff1d(np.arange(nv), ind)
        # dimensionless: Js_dep x_dep + Js_ind x_ind = 0 (consistent, J_dep of full column rank)
        X = -np.linalg.lstsq(Js[:, dep], Js[:, ind], rcond=None)[0]
        N = np.zeros((nv, ind.size))
        N[ind, np.arange(ind.size)] = 1.0
        N[dep] = X
        N = self.col_scale[:, None] * N / self.col_scale[None, ind]
        return ind, N

    def dependent_solution(self, J, rhs, dep):
        """x (nv) with Φ_q x = rhs (least squares on the rank: redundant equations are consistent) that moves
        only the ``dep`` coordinates (x = 0 on the others), in the dimensionless metric."""
        Js = self.row_scale[:, None] * J[:, dep] * self.col_scale[None, dep]
        x = np.zeros(J.shape[1])
        x[dep] = self.col_scale[dep] * np.linalg.lstsq(Js, self.row_scale * rhs, rcond=RANK_RTOL)[0]
        return x

    def close(self, q, dep, max_iter=20):
        """q on the loops by Gauss–Newton steps of the ``dep`` coordinates only (the others held): the chart
        of the mechanism in its independent coordinates, to round-off (:func:`vibdyn.solvers.newton.newton`
        in the dimensionless metric, configurations moved by ``integrate``)."""
        from ..solvers.newton import newton

        model, nv, scale = self.model, self.nv, self.col_scale[dep]

        def retract(qq, dx):
            step = np.zeros(nv)
            step[dep] = scale * dx
            return pin.integrate(model, qq, step)

        r = newton(lambda qq: self.scaled_phi(self.phi(qq)), q,
                   lambda qq: self.row_scale[:, None] * self.jacobian(qq)[:, dep] * scale[None, :], retract,
                   tol=16 * EPS, max_iter=max_iter, rcond=RANK_RTOL)
        q, res = r.x, r.residual
        if res > ASSEMBLY_TOL:
            raise ConvergenceError(f"the loops cannot be closed by their dependent coordinates here (residual "
                                   f"{res:.3e}): the mechanism is at or near a singular position", residual=res,
                                   best=q)
        return q

    def multipliers(self, J, r):
        """Minimum-norm λ (dimensionless metric) with Φ_qᵀ λ = r in the least-squares sense (redundant
        equations share their load evenly): N for position equations, N·m for orientation ones."""
        rank, U, s, Vt = self.decompose(J)
        if rank == 0:
            return np.zeros(J.shape[0])
        mu = U[:, :rank] @ ((Vt[:rank] @ (self.col_scale * r)) / s[:rank])
        return self.row_scale * mu

    def add_to(self, q, lam, fext=None):
        """A new external-force vector for RNEA: ``fext`` (None: none) plus the loop forces λ."""
        model = self.model
        out = pin.StdVec_Force()
        for j in range(model.njoints):
            out.append(pin.Force.Zero() if fext is None else pin.Force(fext[j].vector.copy()))
        for jid, (f, m) in self.external_forces(q, lam).items():
            out[jid] = pin.Force(out[jid].linear + f, out[jid].angular + m)
        return out

    def external_forces(self, q, lam):
        """{joint id: (force, moment) in the joint's local axes, moment about its origin} of the loop forces
        λ on the bodies they join (world ends dropped)."""
        _, _, coeffs = self.evaluate(q, wrenches=True)
        data = self.data
        out, k = {}, 0
        for ends, n, (Ca, Cb) in zip(self.ends, self.sizes, coeffs):
            for (jid, r, _), C in zip(ends, (Ca, Cb)):
                if jid == 0:
                    continue
                w = C.T @ lam[k:k + n]
                R = data.oMi[jid].rotation
                f, m = R.T @ w[:3], R.T @ w[3:] + np.cross(r, R.T @ w[:3])
                f0, m0 = out.get(jid, (np.zeros(3), np.zeros(3)))
                out[jid] = (f0 + f, m0 + m)
            k += n
        return out

    def assemble(self, q0, tol=ASSEMBLY_TOL, max_iter=50, start="q0", record=True, refine=None):
        """The consistent configuration near q0: Gauss–Newton with minimum-norm steps (SVD) in the tangent
        space, each at most :data:`MAX_STEP` (rad, or × the length scale), configurations moved with
        ``pin.integrate``; dimensionless residual ≤ tol. Angles of pivots (and the periodic coordinates of
        cylindrical and universal joints) end within π of q0's. ``start`` names q0 in the error (a
        ConvergenceError naming the loop and the residual reached from it). ``record``: False for a trial
        closure (a search's), never kept as :attr:`closed`. ``refine``: a residual to go on to, past tol (round-off)."""
        return self._assemble(q0, tol, max_iter, start, record, refine)[0]

    def _assemble(self, q0, tol=ASSEMBLY_TOL, max_iter=50, start="q0", record=True, refine=None):
        """(q, Φ(q), Φ_q(q)) of :meth:`assemble`; Φ_q is None where it was not evaluated at q. The solver
        kit's Newton (:func:`vibdyn.solvers.newton.newton`) in the dimensionless metric: minimum-norm
        least-squares steps on the rank of Φ_q, each at most MAX_STEP, moved by ``pin.integrate``."""
        from ..solvers.newton import Steps, newton

        model, cs = self.model, self.col_scale
        q0 = np.array(q0, dtype=float)
        last = {}

        def fun(q):
            last["q"], last["phi"], last["J"] = q, self.phi(q), None
            return self.scaled_phi(last["phi"])

        def jacobian(q):
            J = self.jacobian(q)
            if last.get("q") is q:
                last["J"] = J
            return self.row_scale[:, None] * J * cs[None, :]

        # trial points far off (a step through a near-singular Jacobian) may overflow: such a step is
        # rejected by the line search like any step that does not reduce the residual, so numpy's warnings
        # are not news
        with np.errstate(over="ignore", invalid="ignore"):
            out = newton(fun, q0, jacobian, lambda q, dx: pin.integrate(model, q, cs * dx), tol=tol,
                         max_iter=max_iter, rcond=RANK_RTOL, steps=Steps(max_step=MAX_STEP, refine=refine))
        best = (out.residual, out.x)
        if best[0] <= tol:
            phi, J = (last["phi"], last["J"]) if last.get("q") is out.x else (None, None)
            return self._closed_at(best[1], q0, start, record, phi, J), phi, J
        phi = self.scaled_phi(self.phi(best[1]))
        worst = self.loop_of_row(int(np.argmax(np.abs(phi))))
        raise ConvergenceError(f"assembly from {start}: the loops cannot be closed near it: loop '{worst}' "
                               f"stays open by {np.abs(phi).max():.3e} (dimensionless: m / length scale "
                               f"{self.length_scale:g} m, or rad); start nearer a closed configuration "
                               "(q0=, or Scene.set_operating_point(start=...))",
                               residual=float(np.abs(phi).max()), best=best[1])

    def _closed_at(self, q, q0, start, record=True, phi=None, J=None):
        """q with its periodic angles within π of q0's; the first closed configuration met is kept
        (:attr:`closed`, where the mobility is taken; not with ``record`` False) after the check that no loop
        locks the mechanism. ``phi``, ``J``: Φ and Φ_q at q where the caller has them (None: evaluated)."""
        q = self.within_pi(q, q0)
        found = self._found
        if found["closed"] is None and record:
            J = self.jacobian(q) if J is None else J
            found["dof"] = self.nv - self.check_mobility(q, J, phi)
            found["closed"] = (q.copy(), start)
        return q

    def within_pi(self, q, q0):
        """q (changed in place) with its periodic angles (pivots, ...) within π of q0's: the same pose."""
        iq = self.periodic_coordinates
        if iq.size:
            d = q[iq] - q0[iq]
            q[iq] = q0[iq] + (d - 2 * np.pi * np.rint(d / (2 * np.pi)))
        return q

    def assembly(self, system: Any = None) -> Any:
        """The :class:`~vibdyn.model.assembly.Assembly` of the described pose: the closure of the loops nearest
        the neutral configuration (searched once, then kept; a ConvergenceError naming the loop that stays
        open and its residual if there is none). ``system``: the System (None: the one this table is bound to)."""
        from .assembly import assemble_described

        found = self._found
        if found["assembly"] is None:
            try:
                found["assembly"] = assemble_described(self, self._owner(system, "assembly"))
            except ConvergenceError as e:
                found["assembly"] = e
        a = found["assembly"]
        if isinstance(a, ConvergenceError):
            raise ConvergenceError(str(a), residual=a.residual, best=a.best)
        return a

    def start(self, system: Any = None) -> tuple[np.ndarray, str]:
        """(q, what) where a scene without a declared start begins: its :meth:`assembly`; a ModelError naming
        the loop if that closure is a singular position of the mechanism (refused where it is met). ``system``:
        the System (None: the one this table is bound to)."""
        a = self.assembly(system)
        if a.singular:
            raise ModelError(a.note)
        return a.q.copy(), a.where

    @property
    def dof(self) -> int | None:
        """Mobility at :attr:`closed` (assembled from the system's start first if no closed configuration
        is known yet: a ConvergenceError naming that start if the loops cannot be closed from it; that needs
        the table bound to its System, ``system.constraints``)."""
        if self.closed is None:
            q, label = self._owner(None, "dof").start_configuration()
            self.assemble(q, start=label)
        return self.dof_closed

    def bias(self, q, v):
        """γ = (dΦ_q/dt) v: the loops' acceleration terms at zero acceleration (Φ_q v̇ + γ = 0 along a motion),
        in closed form from the frames' velocities and zero-acceleration motion (one forward-kinematics pass):
        round-off only, so that near a singular position, where γ is divided by a vanishing singular value
        of Φ_q, the accelerations stay accurate. The d/dt of log3's Jacobian (slider and fixed loops) by a
        fourth-order central difference along v (step 1e-4 of the dimensionless speed)."""
        out = []
        for lp, (normals, pairs), (a, b) in zip(self.loops, self.axes, self._frames(q, v=v)):
            kinds = lp.joint.loop_rows
            e, de, dde = b.p - a.p, b.dp - a.dp, b.ddp - a.ddp
            if "position" in kinds:
                out.append(dde)
            for n in normals:
                w, dw, ddw = a.turn(n)
                out.append([ddw @ e + 2 * dw @ de + w @ dde])
            for n, u in pairs:
                wa, dwa, ddwa = a.turn(n)
                wb, dwb, ddwb = b.turn(u)
                out.append([ddwa @ wb + 2 * dwa @ dwb + wa @ ddwb])
            if "locked" in kinds:
                out.append(self._log_rate(lp, q, v, b.w - a.w) + pin.Jlog3(a.R.T @ b.R) @ b.R.T @ (b.dw - a.dw))
        return np.concatenate([np.ravel(x) for x in out]) if out else np.zeros(0)

    def _log_rate(self, lp, q, v, dw):
        """(d/dt of Jlog3(R_aᵀR_b) R_bᵀ) (ω_b − ω_a) for loop lp, by a fourth-order central difference."""
        model = self.model
        speed = np.abs(v / self.col_scale).max(initial=0.0)
        if speed == 0.0:
            return np.zeros(3)
        h = 1e-4 / speed
        i = self.loops.index(lp)

        def L(eps):
            a, b = self._frames(pin.integrate(model, q, eps * v))[i]
            return pin.Jlog3(a.R.T @ b.R) @ b.R.T @ dw

        return derivative(L, 0.0, h, order=4)

    def accelerations(self, q, v, a_free, M):
        """Accelerations of the constrained motion from the tree's free ones (ABA) and its mass matrix M:
        Φ_q a = −γ, and a − a_free M-orthogonal to the motions the loops allow (Gauss's principle), on the
        null space N of the rank decision: a = a_p + N z, (NᵀMN) z = NᵀM (a_free − a_p). A state too large for
        the arithmetic (an integrator's trial stage far off) gives NaN accelerations, which reject its step."""
        if not (np.all(np.isfinite(v)) and np.all(np.isfinite(a_free)) and np.all(np.isfinite(M))):
            return np.full(len(v), np.nan)
        with np.errstate(over="ignore", invalid="ignore"):
            phi, J = self.evaluate(q)
            gamma = self.bias(q, v)
        if not (np.all(np.isfinite(J)) and np.all(np.isfinite(gamma))):
            return np.full(len(v), np.nan)
        dec = self.decompose(J, np.abs(self.scaled_phi(phi)).max(initial=0.0))
        a_p = self._min_norm(dec, gamma, J.shape[1])
        N = self._null(dec)
        if N.shape[1] == 0:
            return a_p
        MN = M @ N
        z = np.linalg.solve(N.T @ MN, MN.T @ (a_free - a_p))
        return a_p + N @ z

    def project(self, q, v, M=None, conditioning=False):
        """(q, v) projected on the loops: q assembled (Φ = 0), v the M-orthogonal projection (the kinetic-
        energy metric; the dimensionless one if M is None) of v on Φ_q v = 0 at that q. With
        ``conditioning``, also :meth:`conditioning` at the projected q."""
        q, phi, J = self._assemble(q)
        if J is None:
            phi, J = self.evaluate(q)
        # one more Gauss–Newton step, always: near a singular position a residual below the assembly
        # tolerance still allows a drift across to the other branch (Φ ≈ x·y there), which the step removes
        q = pin.integrate(self.model, q, self.correction(phi, J))
        dec = self.decompose(self.jacobian(q))
        N = self._null(dec)
        if N.shape[1] == 0:
            v = np.zeros_like(v)
        else:
            W = M @ N if M is not None else N / (self.col_scale ** 2)[:, None]
            v = N @ np.linalg.solve(W.T @ N, W.T @ v)
        return (q, v, self._conditioning(dec)) if conditioning else (q, v)

    def loop_of_row(self, i):
        """Name of the loop that equation i belongs to."""
        for lp, n in zip(self.loops, self.sizes):
            if i < n:
                return lp.name
            i -= n
        raise IndexError(i)

    def split(self, lam):
        """Per-loop pieces of a vector over the equations: {loop name: array}."""
        out, k = {}, 0
        for lp, n in zip(self.loops, self.sizes):
            out[lp.name] = np.array(lam[k:k + n])
            k += n
        return out

    def check_mobility(self, q, J=None, phi=None):
        """The rank of Φ_q at the consistent q, after a ModelError naming the loop that locks the mechanism (no
        motion left) there: its equations leave no motion (rank nv), or q is an isolated closure
        (:meth:`isolated`). ``J``, ``phi``: Φ_q and Φ at q where the caller has them."""
        J = self.jacobian(q) if J is None else J
        rank = self.decompose(J)[0]
        if rank < self.nv:
            why = self.isolated(q, J, phi)
            if why:
                raise ModelError(why)
            return rank
        k = 0
        for lp, n in zip(self.loops, self.sizes):
            k += n
            if self.decompose(J[:k])[0] == self.nv:
                before = "" if k == n else " (with the loops before it)"
                raise ModelError(f"loop '{lp.name}' locks the mechanism{before}: with it the loops leave no motion "
                                 f"at all (mobility 0: rank {self.nv} of the constraint Jacobian = nv)")

    def isolated(self, q, J=None, phi=None):
        """Why the closure q is isolated ('' if it is not shown to be): a rank test at q whose tolerance comes
        from q's own residual (singular values of the dimensionless Φ_q below LOCK_SIGMA·√|Φ| relative are
        lost: a closure that close to an exactly singular one cannot tell them apart), then, for each lost
        equation u (a left singular vector), the second differences of uᵀΦ along the motions N that Φ_q
        leaves (steps LOCK_STEP, dimensionless): where the form Nᵀ(uᵀΦ_qq)N is definite, every motion the
        first order allows opens the loop at the second (the Lyapunov–Schmidt reduction), so no closure lies
        beside q: mobility 0 (a four-bar whose lengths add up, closed only stretched flat). An indefinite
        form is a change point (branches cross), a zero one a redundant equation: both keep their motion."""
        model, cs = self.model, self.col_scale
        J = self.jacobian(q) if J is None else J
        phi0 = self.scaled_phi(self.phi(q) if phi is None else phi)
        res = float(np.abs(phi0).max(initial=0.0))
        Js = self.row_scale[:, None] * J * cs[None, :]
        if Js.size == 0:
            return ""
        U, s, Vt = np.linalg.svd(Js)
        tol = max(RANK_RTOL, LOCK_SIGMA * np.sqrt(res)) * s[0]
        rank = int(np.sum(s > tol))
        N, lost = Vt[rank:], U[:, rank:]
        if lost.shape[1] == 0 or not 0 < len(N) <= LOCK_MAX_MOTIONS:
            return ""
        h, k = LOCK_STEP, len(N)

        def g(x):
            return lost.T @ self.scaled_phi(self.phi(pin.integrate(model, q, cs * (N.T @ x))))

        w = np.linalg.eigvalsh(hessian(g, np.zeros(k), h, lost.T @ phi0))  # (per lost equation, ascending)
        for u, definite in zip(lost.T, (w[:, 0] > LOCK_CURVATURE) | (w[:, -1] < -LOCK_CURVATURE)):
            if definite:
                loop = self.loop_of_row(int(np.argmax(np.abs(u))))
                return (f"loop '{loop}' locks the mechanism: it closes here only at an isolated configuration, "
                        "typically with its links in line, stretched out or folded flat (their lengths add up "
                        f"exactly): the constraint Jacobian has rank {rank} there (singular values below "
                        f"{tol / s[0]:.1e} relative, from the closure's residual {res:.1e}, are lost) and each of "
                        f"the {k} motion(s) it leaves to first order opens the loop at second order, so no motion is "
                        "left (mobility 0); change a length so that the loop can move, or remove the loop")
        return ""


def compile_loops(system):
    """The :class:`Constraints` of a system's scene. Nothing here assumes that the neutral configuration
    closes the loops: the mobility is taken at the first closed configuration met (:attr:`closed`), tried
    here from the declared start, else by the assembly of the described pose (:meth:`Constraints.assembly`;
    a start that does not close, or a closure at a singular position, is left to the first analysis, which
    names it). A loop that locks the mechanism there is a ModelError naming it."""
    c = Constraints(system, system.scene.loops.values())
    try:
        if (system.scene.operating_point or {}).get("start") is None:
            c.assembly(system)
        else:
            q, label = system.start_configuration()
            c.assemble(q, start=label)
    except ConvergenceError:
        pass
    return c
