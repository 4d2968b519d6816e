"""The other assembly modes of a closure of a looped system: the closures with its independent coordinates (a
four-bar's mirror-image coupler and rocker), found block by block of loops solved one after another (a Watt
six-bar's four-bar, then its dyad from each of the four-bar's closures), by Gauss–Newton restarts of each block's
dependent coordinates from a grid, all in step (:func:`~vibdyn.model.loop_batch.close_many`)."""

from __future__ import annotations

import functools
import itertools

import numpy as np
import pinocchio as pin

from ..defaults import RANK_RTOL
from .loop_batch import LoopBatch, close_many, rows_of
from .loop_metric import SAME, gap, gaps

PARTNER_MAX = 26  # restarts of the dependent coordinates per point: the whole grid of up to 3 (see partners)
PARTNER_ITER, PARTNER_OPEN = (4, 6), 1e-2  # Newton iterations of a restart, the last 6 only for a restart whose
# dimensionless residual is below PARTNER_OPEN after the first 4
KNOWN_STEP, KNOWN_GAP = 1e-2, 1e-3  # a restart's Newton step and gap below which it is taken to converge to the
# closure it is beside (quadratic convergence: it ends within about the step² of where it is)
MAX_BLOCK_LOOPS = 8  # more loops than this: their dependent coordinates are one block (:func:`_blocks`)
MAX_TRIED = 8  # other independent coordinates tried for smaller blocks (:func:`_fibres`)


def rows(c, loops) -> np.ndarray:
    """Indices of the equations of the ``loops`` (indices), in order."""
    return rows_of(tuple(c.sizes), tuple(loops))


def _blocks(c, J, used, dep):
    """[(loops, columns)]: the dependent coordinates ``dep`` of a closure where Φ_q is J in blocks solved one
    after another, each the fewest loops (one to three, else all those left) whose new coordinates (those their
    equations use, ``used``: rows × coordinates, not solved by an earlier block) their equations fix (Φ_q on them
    of full column rank), with every other loop then closed by what is solved; one block of every loop where no
    such order exists (or more than MAX_BLOCK_LOOPS loops). The equations of a block use no coordinate of a later
    one: its closures, then each later block's from each of them, are every closure with the same independent
    coordinates."""
    n = len(c.sizes)
    if n > MAX_BLOCK_LOOPS:
        return [(tuple(range(n)), dep)]
    uses = [set(dep[used[rows(c, (i,))][:, dep].any(axis=0)]) for i in range(n)]
    solved, left, out = set(), list(range(n)), []
    while left:
        sizes = sorted({*range(1, min(3, len(left)) + 1), len(left)})  # (at most three loops a block, or all)
        for group in itertools.chain.from_iterable(itertools.combinations(left, k) for k in sizes):
            new = set().union(*(uses[i] for i in group)) - solved
            loops = tuple(i for i in left if i in group or uses[i] <= solved | new)
            cols = np.array(sorted(new), dtype=int)
            if cols.size and _full_rank(c, J, rows(c, loops), cols):
                break
        else:
            return [(tuple(range(n)), dep)]
        out.append((loops, cols))
        solved |= new
        left = [i for i in left if i not in loops]
    return out


def _full_rank(c, J, eqs, cols):
    """Whether Φ_q's rows ``eqs`` have full column rank on ``cols`` (dimensionless, singular values above RANK_RTOL
    of the largest)."""
    s = np.linalg.svd(c.row_scale[eqs, None] * J[eqs][:, cols] * c.col_scale[None, cols], compute_uv=False)
    return s.size >= cols.size and s[cols.size - 1] > RANK_RTOL * s[0]


def _fibres(c, q):
    """The blocks (:func:`_blocks`) of the dependent coordinates at the closure q: those of the independent ones
    QR with column pivoting keeps (:meth:`Constraints.partition`) or, with mobility 1 where those leave a block
    of more than two, of the coordinate (of MAX_TRIED others) whose largest block is smallest (the fewest
    coordinates restarted together). A loop uses the coordinates with a nonzero column in Φ_q at q or at two poses
    near it (the ones its ends move with: structural zeros are exact)."""
    model, cs, nv = c.model, c.col_scale, c.nv
    J = c.jacobian(q)
    ind, _ = c.partition(J)
    dep = np.setdiff1d(np.arange(nv), ind)
    if len(c.sizes) == 1 or dep.size <= 2:  # (one block, or blocks no smaller than the grid of the whole)
        return [(tuple(range(len(c.sizes))), dep)]
    rng = np.random.default_rng(0)
    used = J != 0  # (a non-finite entry counts as used)
    with np.errstate(all="ignore"):
        for _ in range(2):
            used |= c.jacobian(pin.integrate(model, q, cs * rng.standard_normal(nv))) != 0
    tried = [ind] + ([np.array([k]) for k in range(nv) if k != ind[0]][:MAX_TRIED] if ind.size == 1 else [])
    best = None
    for ind in tried:
        dep = np.setdiff1d(np.arange(nv), ind)
        if best is not None and not _full_rank(c, J, np.arange(c.m), dep):
            continue
        blocks = _blocks(c, J, used, dep)
        size = max(cols.size for _, cols in blocks)
        if best is None or size < best[0]:
            best = (size, blocks)
        if best[0] <= 2:
            break
    return best[1]


def _grid(c, cols):
    """(restarts, complete) of the coordinates ``cols``: each moved by 0, ±2π/3 (angles) or 0, ±1 × the length
    scale (others), every combination but all 0 where there are at most PARTNER_MAX, else each coordinate moved
    alone and a seeded sample of the other combinations up to PARTNER_MAX (``complete`` False)."""
    choices = [(0.0, 2 * np.pi / 3, -2 * np.pi / 3) if c.units[i] == "rad" else (0.0, 1.0, -1.0) for i in cols]
    combos = list(itertools.islice(itertools.product(*choices), 1, None))
    if len(combos) <= PARTNER_MAX:
        return combos, True
    singles = [x for x in combos if np.count_nonzero(x) == 1]
    others = [x for x in combos if np.count_nonzero(x) > 1]
    pick = np.random.default_rng(0).choice(len(others), max(PARTNER_MAX - len(singles), 0), replace=False)
    return singles + [others[i] for i in np.sort(pick)], False


def partners(c, points, qd) -> list[tuple[list, bool, list, str]]:
    """[(closures, complete, blocks, open)] per closure of ``points``: the other closures with its independent
    coordinates (the other assembly modes there: the mirror image of a four-bar's coupler and rocker about the line
    they span), block by block of the dependent coordinates (:func:`_blocks`): from each closure of the blocks
    before, Gauss–Newton on the block's coordinates and equations from each restart of its grid (:func:`_grid`;
    ``complete`` False where one is sampled; ``blocks`` [(loops, coordinates)] as solved there; ``open`` the name of
    a loop no restart closes from some closure of the blocks before it, '' if none), all in step, those of points
    whose blocks solve the same loops together (:func:`~vibdyn.model.loop_batch.close_many`: a restart still open by
    PARTNER_OPEN after PARTNER_ITER[0] iterations is dropped, as is one converging to a closure found already from
    the same one)."""
    model, cs, nv = c.model, c.col_scale, c.nv
    fibres = [_fibres(c, q) for q in points]
    grids = [[_grid(c, cols) for _, cols in blocks] for blocks in fibres]
    opened = [""] * len(points)
    groups: dict = {}
    for i, blocks in enumerate(fibres):
        groups.setdefault(tuple(loops for loops, _ in blocks), []).append(i)
    found_at: dict = {}
    for key, members in groups.items():
        partial = [(i, points[i]) for i in members]  # (the point searched, a closure of the blocks so far)
        for b, loops in enumerate(key):
            starts, owner, columns = [], [], []
            for j, (i, p) in enumerate(partial):
                cols, (combos, _) = fibres[i][b][1], grids[i][b]
                for combo in [np.zeros(cols.size)] + combos:  # (p's own first: it closes the block's loops from q's)
                    x = np.zeros(nv)
                    x[cols] = combo
                    starts.append(pin.integrate(model, p, cs * x))
                    owner.append(j)
                    columns.append(cols)
            closed = close_many(LoopBatch(c, loops), starts, owner, columns, (PARTNER_ITER, PARTNER_OPEN),
                                (KNOWN_STEP, KNOWN_GAP), functools.partial(gaps, c))
            reached: list = []
            for j, (i, _) in enumerate(partial):
                found: list = []
                for q1 in (c.within_pi(x, qd) for x, o in zip(closed, owner) if o == j and x is not None):
                    if all(gap(c, o, q1) > SAME for o in found):
                        found.append(q1)
                reached += [(i, p) for p in found]
                opened[i] = opened[i] or ("" if found else c.loops[loops[0]].name)
            partial = reached
        for i in members:
            found_at[i] = [p for k, p in partial if k == i and gap(c, points[i], p) > SAME]
    return [(found_at[i], all(whole for _, whole in grids[i]), fibres[i], opened[i]) for i in range(len(points))]
