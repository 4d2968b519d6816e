"""The loop equations of many configurations at once: Φ and Φ_q of a batch of configurations (the restarts of an
assembly search), the rows of :meth:`Constraints.evaluate` with numpy's cost per call paid once per batch, not
once per configuration; and Gauss–Newton from many starts in step (:func:`close_many`)."""

from __future__ import annotations

import functools

import numpy as np
import pinocchio as pin

from ..defaults import ASSEMBLY_TOL, RANK_RTOL

HALVINGS = 4  # :func:`close_many` tries this many halvings of each refused step at once

_LEVI = np.zeros((3, 3, 3))
_LEVI[0, 1, 2] = _LEVI[1, 2, 0] = _LEVI[2, 0, 1] = 1.0
_LEVI[0, 2, 1] = _LEVI[2, 1, 0] = _LEVI[1, 0, 2] = -1.0


def _cross(a, b):
    """a × b along axis 1 of arrays (B × 3 × k), k of a and b broadcast (Levi-Civita: one numpy call)."""
    return np.einsum("ijk,bjn,bkn->bin", _LEVI, a, b)


@functools.lru_cache(maxsize=256)
def rows_of(sizes: tuple, loops: tuple) -> np.ndarray:
    """Indices of the equations of the ``loops`` (indices, in order) of loops with ``sizes`` equations each."""
    ends = np.cumsum((0,) + sizes)
    out = np.concatenate([np.arange(ends[i], ends[i + 1]) for i in loops])
    out.flags.writeable = False
    return out


class LoopBatch:
    """The equations of the ``loops`` (indices) of the loop equations c (a :class:`Constraints`), evaluated at
    many configurations at once (:meth:`evaluate`)."""

    def __init__(self, c, loops):
        self.c, self.loops = c, tuple(loops)
        self.row_scale = c.row_scale[rows_of(tuple(c.sizes), self.loops)]
        ends = [end for i in self.loops for end in c.ends[i]]
        self.ends, self.moving = ends, [k for k, (jid, _, _) in enumerate(ends) if jid]
        self.joints = [ends[k][0] for k in self.moving]
        r = np.array([ends[k][1] for k in self.moving]).reshape(-1, 3)
        # a point r fixed in a joint's frame moves at R (v + ω × r) of the joint's local (v, ω): [I, −[r]×; 0, I]
        self.G = np.zeros((len(r), 1, 6, 6))
        self.G[:, 0] = np.eye(6)
        for k, x in enumerate(r):
            self.G[k, 0, :3, 3:] = -pin.skew(x)
        self.r, self.Rl = r[:, None, :, None], np.array([ends[k][2] for k in self.moving]).reshape(-1, 1, 3, 3)
        self.rows = []
        for i in self.loops:
            (normals, pairs), kinds = c.axes[i], c.loops[i].joint.loop_rows
            aligned = (np.array([n for n, _ in pairs]).T, np.array([u for _, u in pairs]).T) if pairs else None
            self.rows.append((kinds, np.array(normals).T if normals else None, aligned))

    def evaluate(self, Q) -> tuple[np.ndarray, np.ndarray]:
        """(Φ (B × m), Φ_q (B × m × nv)) at each row of Q (B × nq): per configuration the rows of
        ``c.evaluate(q, loops=loops)`` (to round-off)."""
        c, ends, joints = self.c, self.ends, self.joints
        model, data, nv, B, E = c.model, c.data, c.nv, len(Q), len(self.joints)
        oMi, H, JL = data.oMi, [], []
        for q in Q:
            pin.computeJointJacobians(model, data, q)
            for jid in joints:
                H.append(oMi[jid].homogeneous)
                JL.append(pin.getJointJacobian(model, data, jid, pin.LOCAL))
        H = np.array(H).reshape(B, E, 4, 4).swapaxes(0, 1)
        T, Rj, JL = H[:, :, :3, 3], H[:, :, :3, :3], np.array(JL).reshape(B, E, 6, nv).swapaxes(0, 1)
        P, R = T + (Rj @ self.r)[..., 0], Rj @ self.Rl
        J = (Rj[:, :, None] @ (self.G @ JL).reshape(E, B, 2, 3, nv))  # (E × B × (linear, angular) × 3 × nv)
        world = (np.zeros((B, 3, nv)),) * 2
        frames = [(P[k], R[k], J[k, :, 0], J[k, :, 1]) for k in range(E)][::-1]
        frames = [frames.pop() if jid else (np.broadcast_to(r, (B, 3)), np.broadcast_to(Rl, (B, 3, 3))) + world
                  for jid, r, Rl in ends]
        phis, jacs = [], []
        for n, (kinds, normals, pairs) in enumerate(self.rows):
            (pa, Ra, Jva, Jwa), (pb, Rb, Jvb, Jwb) = frames[2 * n], frames[2 * n + 1]
            e, de = pb - pa, Jvb - Jva
            if "position" in kinds:
                phis.append(e)
                jacs.append(de)
            if normals is not None:
                W = Ra @ normals  # (B × 3 × normals)
                phis.append((W * e[:, :, None]).sum(axis=1))
                jacs.append(W.swapaxes(1, 2) @ de + _cross(W, e[:, :, None]).swapaxes(1, 2) @ Jwa)
            if pairs is not None:
                Wa, Wb = Ra @ pairs[0], Rb @ pairs[1]
                phis.append((Wa * Wb).sum(axis=1))
                jacs.append(_cross(Wa, Wb).swapaxes(1, 2) @ (Jwa - Jwb))
            if "locked" in kinds:
                Rab = Ra.swapaxes(1, 2) @ Rb
                phis.append(np.array([pin.log3(x) for x in Rab]))
                jacs.append(np.array([pin.Jlog3(x) for x in Rab]) @ Rb.swapaxes(1, 2) @ (Jwb - Jwa))
        return np.concatenate(phis, axis=1), np.concatenate(jacs, axis=1)


def close_many(batch: LoopBatch, starts, owner, cols, iterations, known, gaps) -> list:
    """The closure (or None) each of the ``starts`` reaches by Gauss–Newton on the coordinates ``cols`` and the
    equations of ``batch``, all in step, each as one Gauss–Newton would: minimum-norm dimensionless steps on the
    rank (RANK_RTOL), each halved until |Φ| decreases (dropped below 1/10⁴), converged at ASSEMBLY_TOL;
    ``iterations`` = ((n₁, n₂), open): dropped where still above ``open`` after n₁ iterations or open after
    n₁ + n₂; ``known`` = (step, gap): dropped where a step below ``step`` lands within ``gap`` (``gaps(q, Q)``:
    dimensionless distances from q to the rows of Q) of a closure that a start of the same ``owner`` reached
    before (it converges to that one)."""
    c = batch.c
    model, rs, scale = c.model, batch.row_scale, c.col_scale[cols]
    (n1, n2), opened = iterations
    Q = np.array(starts)
    phi, J = batch.evaluate(Q)
    R, out = rs * phi, [None] * len(starts)
    live = np.arange(len(starts))
    for k in range(n1 + n2 + 1):
        res = np.abs(R[live]).max(axis=1, initial=0.0)
        for i in live[res <= ASSEMBLY_TOL]:
            out[i] = Q[i]
        keep = (res > ASSEMBLY_TOL) & np.isfinite(J[live]).all(axis=(1, 2)) & ~((k >= n1) & (res > opened))
        keep &= np.isfinite(res)
        live = live[keep] if k < n1 + n2 else live[:0]
        if not live.size:
            break
        U, sv, Vt = np.linalg.svd(rs[None, :, None] * J[live][:, :, cols] * scale, full_matrices=False)
        inv = np.divide(1.0, sv, out=np.zeros_like(sv), where=sv > RANK_RTOL * sv[:, :1])
        dx = np.zeros((live.size, c.nv))
        x = Vt.swapaxes(1, 2) @ (inv[:, :, None] * (U.swapaxes(1, 2) @ -R[live][:, :, None]))  # (minimum norm)
        dx[:, cols] = scale * x[..., 0]
        norm0, alpha, steps = (R[live] ** 2).sum(axis=1), np.ones(live.size), np.zeros(live.size)
        size = np.sqrt((x[..., 0] ** 2).sum(axis=1))  # (dimensionless)
        trying, ladder = np.arange(live.size), np.ones(1)
        while trying.size:  # (the full steps, then the next HALVINGS halvings of each refused one at once)
            a = alpha[trying, None] * ladder
            Q1 = np.array([pin.integrate(model, Q[live[j]], t * dx[j]) for j, row in zip(trying, a) for t in row])
            with np.errstate(over="ignore", invalid="ignore"):
                phi1, J1 = batch.evaluate(Q1)
            R1 = rs * phi1
            ok = ((R1 ** 2).sum(axis=1).reshape(a.shape) <= (1 - 1e-4 * a) * norm0[trying, None]) & (a >= 1e-4)
            first, took = ok.argmax(axis=1), ok.any(axis=1)
            j, i = trying[took], np.flatnonzero(took) * ladder.size + first[took]
            Q[live[j]], R[live[j]], J[live[j]], alpha[j] = Q1[i], R1[i], J1[i], a[took, first[took]]
            steps[j] = alpha[j] * size[j]
            alpha[trying[~took]] = 0.5 * a[~took, -1]
            trying, ladder = trying[~took & (alpha[trying] >= 1e-4)], 0.5 ** np.arange(HALVINGS)
        moved = alpha >= 1e-4
        for j in np.flatnonzero(moved & (steps <= known[0])):
            near = [q for q, o in zip(out, owner) if q is not None and o == owner[live[j]]]
            if near and gaps(Q[live[j]], np.array(near)).min() <= known[1]:
                moved[j] = False
        live = live[moved]
    return out
