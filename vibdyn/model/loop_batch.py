"""The loop equations of many configurations at once: Φ and Φ_q of a batch of configurations (the restarts of an
assembly search), the rows of :meth:`Constraints.evaluate` with numpy's cost per call paid once per batch, not
once per configuration; and Gauss–Newton from many starts in step (:func:`close_many`)."""

from __future__ import annotations

import functools

import numpy as np
import pinocchio as pin

from ..defaults import ASSEMBLY_TOL, RANK_RTOL

HALVINGS = 4  # :func:`close_many` tries this many halvings of each refused step at once

def _cross(a, b):
    """a × b along axis 1 of arrays (B × 3 × k), k of a and b broadcast (by components: numpy's cross and a
    Levi-Civita einsum cost 2–3× more on these small arrays)."""
    a0, a1, a2, b0, b1, b2 = a[:, 0], a[:, 1], a[:, 2], b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)


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
        places = [P for i in self.loops for P in c.placements[i]]
        self.ends, self.moving = ends, [(jid, P) for (jid, _, _), P in zip(ends, places) if jid]
        self.rows = []
        for i in self.loops:
            (normals, pairs), kinds = c.axes[i], c.loops[i].joint.loop_rows
            aligned = (np.array([n for n, _ in pairs]).T, np.array([u for _, u in pairs]).T) if pairs else None
            self.rows.append((kinds, np.array(normals).T if normals else None, aligned))

    def evaluate(self, Q) -> tuple[np.ndarray, np.ndarray]:
        """(Φ (B × m), Φ_q (B × m × nv)) at each row of Q (B × nq): per configuration the rows of
        ``c.evaluate(q, loops=loops)`` (to round-off)."""
        c, ends, moving = self.c, self.ends, self.moving
        model, data, nv, B, E = c.model, c.data, c.nv, len(Q), len(moving)
        oMi, H, J = data.oMi, [], []
        for q in Q:
            pin.computeJointJacobians(model, data, q)
            for jid, P in moving:  # (each end's placement and LOCAL_WORLD_ALIGNED Jacobian at it: Pinocchio's)
                H.append((oMi[jid] * P).homogeneous)
                J.append(pin.getFrameJacobian(model, data, jid, P, pin.LOCAL_WORLD_ALIGNED))
        H = np.array(H).reshape(B, E, 4, 4).swapaxes(0, 1)
        J = np.array(J).reshape(B, E, 6, nv).swapaxes(0, 1)
        world = (np.zeros((B, 3, nv)),) * 2
        frames = [(H[k, :, :3, 3], H[k, :, :3, :3], J[k, :, :3], J[k, :, 3:]) for k in range(E)][::-1]
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
    """The closure (or None) each of the ``starts`` reaches by Gauss–Newton on the coordinates ``cols`` (indices in
    v; or one such array per start) and the equations of ``batch``, all in step, each as one Gauss–Newton would:
    minimum-norm dimensionless steps on the rank (RANK_RTOL), each halved until |Φ| decreases (dropped below
    1/10⁴), converged at ASSEMBLY_TOL; ``iterations`` = ((n₁, n₂), open): dropped where still above ``open``
    after n₁ iterations or open after n₁ + n₂; ``known`` = (step, gap): dropped where a step below ``step``
    lands within ``gap`` (``gaps(q, Q)``: dimensionless distances from q to the rows of Q) of a closure that a
    start of the same ``owner`` reached before (it converges to that one)."""
    c = batch.c
    model, rs = c.model, batch.row_scale
    (n1, n2), opened = iterations
    Q = np.array(starts)
    groups = _column_groups(cols, len(starts))
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
        dx, size = np.zeros((live.size, c.nv)), np.zeros(live.size)
        for cols, member in groups:  # (the minimum-norm step on each group's coordinates: one batched SVD)
            at = np.flatnonzero(member[live])
            if not at.size:
                continue
            scale = c.col_scale[cols]
            U, sv, Vt = np.linalg.svd(rs[None, :, None] * J[live[at]][:, :, cols] * scale, full_matrices=False)
            inv = np.divide(1.0, sv, out=np.zeros_like(sv), where=sv > RANK_RTOL * sv[:, :1])
            x = Vt.swapaxes(1, 2) @ (inv[:, :, None] * (U.swapaxes(1, 2) @ -R[live[at]][:, :, None]))
            dx[np.ix_(at, cols)] = scale * x[..., 0]
            size[at] = np.sqrt((x[..., 0] ** 2).sum(axis=1))  # (dimensionless)
        norm0, alpha, steps = (R[live] ** 2).sum(axis=1), np.ones(live.size), np.zeros(live.size)
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


def _column_groups(cols, n) -> list:
    """[(columns, member mask over the n starts)]: the starts of :func:`close_many` by the coordinates they solve
    (``cols``: one index array for all, or one per start)."""
    if isinstance(cols, np.ndarray):
        return [(cols, np.ones(n, dtype=bool))]
    keys = [tuple(int(i) for i in x) for x in cols]
    return [(np.array(key, dtype=int), np.array([k == key for k in keys])) for key in dict.fromkeys(keys)]
