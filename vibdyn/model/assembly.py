"""Assembly of a looped scene from its described pose: with no declared start, analyses begin at the closure
of the loops nearest the neutral configuration (every joint at its zero, as the scene was drawn).

Distance: the dimensionless tangent-space norm |x| of x = difference(q_d, q) / s (s: 1 for angles, the length
scale for translations), each periodic angle (pivots, the angles of cylindrical and universal joints) taken
within π of the described one (q and q ± 2π are one pose: the shorter way round counts).

1. The loops' Gauss–Newton (:meth:`Constraints.assemble`) from the described pose q_d; where it does not
   close them (or closes them beyond the limits), trust-region least squares (scipy's ``least_squares``) on
   the dimensionless loop residual Φ in the chart q(x) = integrate(q_d, s·x), polished to round-off by the
   same Gauss–Newton.
2. Where that fails (a linkage laid flat is a stationary point of |Φ|²), restarts from perturbed poses:
   ±r along each coordinate for each r of :data:`RESTART_RADII`, then seeded random poses; the first round
   that closes the loops ends the search.
   A closure beyond a coordinate's position limits (``Scene.set_limits``) does not count: the search goes on
   to the next round, and if every closure found is beyond them the assembly is refused naming the first
   coordinate and its limit.
3. Each closure found is slid along the loops to the closure nearest q_d (steps towards q_d projected on the null space
   of Φ_q, each closed again). Unless the described pose closes the loops itself (distance 0), the branches are then
   enumerated before one is called nearest: with mobility 1, each branch is traced by arclength continuation until it
   comes back to its start (a closed curve, traced whole), the local minima of its distance are slid to the nearest, and
   at points spread along it (and at the nearest minimum of all) the other assembly modes (the other closures with the
   same independent coordinates: a four-bar's mirror-image coupler and rocker) are sought by Gauss–Newton restarts of
   the dependent coordinates, loop block by loop block where the loops can be solved one after another (a Watt six-bar's
   four-bar, then its dyad from each of the four-bar's closures), and traced in turn. The nearest of all is taken, and
   called "the closure nearest the neutral configuration" (``Assembly.nearest``) only when every branch met was traced
   whole, each search for the other modes tried its whole grid of restarts (up to three dependent coordinates a block:
   :func:`.partners`), no loop solved after others closes over part of their motion only (it folds along a branch, or
   does not close from one of their closures: closures over the rest may lie on branches no search meets) and no slide
   ended beyond a limit; otherwise (mobility 2 or more: surfaces, not traced; a branch cut by a singular position; modes
   sampled, not enumerated, with more dependent coordinates solved together) it is "a closure found near the neutral
   configuration", the nearest of those compared, and ``.note`` says why it is not proven. Ties (the mirror images of a
   symmetric description) go to the closure whose first differing coordinate is larger, and are noted.
4. A closure that is isolated (the loops close only there: links whose lengths add up, stretched flat) locks
   the mechanism: refused (:meth:`Constraints.check_mobility`). The mobility is taken there. A singular
   position (rank of Φ_q below its rank at the closures beside it: a change point) is kept in the
   :class:`Assembly` and refused as a start, naming the loop; a closure where the scene's forces are
   undefined (a spring whose ends meet) is left along the mechanism's motion, the first coordinate that
   moves increasing.
"""

import functools
import itertools
import math
import time
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..defaults import ASSEMBLY_TOL, RANK_RTOL
from ..errors import ConvergenceError, ModelError
from . import assembly_modes
from .assembly_modes import partners, rows
from .configuration import beyond_limits
from .loop_metric import SAME, gap, gaps, offsets

#: radii (rad, or × the length scale) of the restarts along ± each coordinate, one round each
RESTART_RADII = (0.25, 1.0, np.pi / 2)
RANDOM_RESTARTS = 8  # the last round: seeded random poses, half with std 1, half with std 2 (dimensionless)
OPEN_TOL = 1e-6  # a least-squares result with dimensionless |Φ| below this is polished by Gauss–Newton
SLIDE_TOL, SLIDE_ITER = 1e-10, 300  # the slide to the nearest closure: last projected step (dimensionless)
SLIDE_HALVINGS = 20  # a slide's step halved this many times where the closure reached is farther or not found
# (down to a millionth: a four-bar 2e-5 of its length short of flat closes on a curve a few mrad long)
TIE_RTOL = 1e-7  # distances within this (relative) are a tie
BESIDE = 1e-3  # step to the closures beside one, for the rank there (dimensionless)
LEAVE = (1e-3, 1e-2, 1e-1)  # steps along the motion off a closure where the forces are undefined
TRACE_STEP, TRACE_MAX_STEP, TRACE_MIN_STEP = 0.2, 0.8, 1e-3  # arclength steps (dimensionless) of the trace
TRACE_TOL = 1e-7  # dimensionless |Φ| a trace's samples are closed to (each closed on to ASSEMBLY_TOL where it is used)
CORRECT_ITER = 8  # Gauss–Newton iterations of one corrector (a trace step, a slide step)
TRACE_MAX = 2000  # samples of one branch before its trace is given up (the nearest is then not proven)
PARTNER_POINTS = 2  # points along each traced branch where the other assembly modes are sought
MAX_BRANCHES = 16  # branches traced before the search gives up proving the nearest
WHERE = "the closure nearest the neutral configuration"
WHERE_FOUND = "a closure found near the neutral configuration"  # (the nearest of those found, not proven)


@dataclass(frozen=True, eq=False)
class Assembly:
    """The closure of a scene's loops nearest its described (neutral) pose, where analyses start when no
    start is declared. ``q`` the configuration, ``where`` its name in messages; ``constraint_residual`` the
    largest |Φ(q)| (dimensionless: m / length scale, or rad: its error); ``offsets`` (m or rad per
    coordinate) and ``distance`` (dimensionless) from the neutral configuration; ``dof`` = nv − ``rank`` the
    mobility found there, ``generic_rank`` the rank of Φ_q at the closures beside it; ``singular`` when
    rank < generic_rank (a change point: refused as a start); ``starts`` the least-squares runs; ``note``
    what was chosen and why (ties, a start moved off a singular force, the singular position, why it is not
    proven the nearest); ``elapsed`` (s); ``nearest`` True when it is proven the nearest closure (distance 0,
    or every branch of a mobility-1 mechanism traced whole; ``where`` then says "nearest"), False when it is
    only the nearest of the closures the search compared."""

    q: np.ndarray = field(repr=False)
    where: str
    constraint_residual: float
    offsets: np.ndarray = field(repr=False)
    distance: float
    dof: int
    rank: int
    generic_rank: int
    singular: bool
    starts: int
    note: str
    elapsed: float
    nearest: bool = True

    def __repr__(self):
        state = "SINGULAR" if self.singular else f"dof {self.dof}"
        return (f"Assembly({self.where}: residual {self.constraint_residual:.1e}, distance {self.distance:.4g}, "
                f"{state} (rank {self.rank}), {self.starts} starts" + (", see .note)" if self.note else ")"))


def _chart(c, qd):
    """(q(x), Φ̃(x), Φ̃_x(x)): the chart at qd in dimensionless tangent coordinates and the dimensionless
    loop residual and its Jacobian there."""
    model, cs = c.model, c.col_scale

    def at(x):
        return pin.integrate(model, qd, cs * x)

    def fun(x):
        return c.scaled_phi(c.phi(at(x)))

    def jac(x):
        D = pin.dIntegrate(model, qd, cs * x, pin.ARG1)
        return c.row_scale[:, None] * (c.jacobian(at(x)) @ D) * cs[None, :]

    return at, fun, jac


def _rounds(nv):
    """The starts (dimensionless offsets from the described pose), round by round."""
    yield [np.zeros(nv)]
    for r in RESTART_RADII:
        yield [s * r * e for e in np.eye(nv) for s in (1.0, -1.0)]
    rng = np.random.default_rng(0)
    yield [r * rng.standard_normal(nv) for r in (1.0, 2.0) for _ in range(RANDOM_RESTARTS // 2)]


def _close(c, q, qd):
    """The closure by Gauss–Newton from q (a trial: not recorded), angles within π of qd's; None if none."""
    try:
        return c.within_pi(c.assemble(q, start="a trial pose", record=False), qd)
    except ConvergenceError:
        return None


def _tangent(c, J, previous):
    """The unit (dimensionless) direction of the one motion the loops allow where Φ_q is J, turned to go on
    along ``previous``; None where the mobility there is not 1."""
    rank, _, _, Vt = c.decompose(J)
    if c.nv - rank != 1:
        return None
    t = Vt[-1]
    return -t if previous is not None and t @ previous < 0 else t


def _correct(c, q, dep=None, iterations=CORRECT_ITER, give_up=(np.inf, np.inf), loops=None, tol=ASSEMBLY_TOL):
    """(q, Φ_q, corrections) of the closure reached from q by Gauss–Newton (minimum-norm dimensionless steps of
    all coordinates, or of ``dep`` only, each halved until |Φ| decreases), Φ and Φ_q from one evaluation per
    point, of the ``loops`` (indices; None: all, and Φ_q is then the whole Jacobian); ``corrections`` the sizes
    of the steps taken. None where |Φ| stays above ``tol`` after ``iterations``, stops decreasing, or is
    above give_up[1] after give_up[0] iterations."""
    model, cs = c.model, c.col_scale
    rs = c.row_scale if loops is None else c.row_scale[rows(c, loops)]
    cols = slice(None) if dep is None else dep
    scale = rs[:, None] * cs[None, cols]
    phi, J = c.evaluate(q, loops=loops)
    r = rs * phi
    steps: list = []
    with np.errstate(over="ignore", invalid="ignore"):  # (a trial step too far: its |Φ| is not finite, refused)
        for k in range(iterations + 1):
            res = float(np.abs(r).max(initial=0.0))
            if res <= tol:
                return q, J, steps
            if k == iterations or not np.isfinite(res) or (k >= give_up[0] and res > give_up[1]):
                return None
            dx = np.zeros(c.nv)
            dx[cols] = _min_norm(J[:, cols] * scale, -r)
            norm0, alpha = float(r @ r), 1.0
            while True:
                q1 = pin.integrate(model, q, cs * (alpha * dx))
                phi1, J1 = c.evaluate(q1, loops=loops)
                r1 = rs * phi1
                if float(r1 @ r1) <= (1 - 1e-4 * alpha) * norm0:
                    break
                alpha *= 0.5
                if alpha < 1e-4:
                    return None
            steps.append(alpha * math.sqrt(dx @ dx))
            q, J, r = q1, J1, r1
    return None


def _polish(c, q):
    """A trace's sample q (closed to TRACE_TOL) closed on to ASSEMBLY_TOL (q itself where that fails)."""
    out = _correct(c, q)
    return q if out is None else out[0]


@functools.cache
def _lapack():
    """scipy's LAPACK wrappers (imported on first use: not at `import vibdyn`)."""
    from scipy.linalg import lapack

    return lapack


def _min_norm(A, b):
    """The minimum-norm least-squares x of A x ≈ b on A's rank (LAPACK's complete orthogonal factorisation,
    gelsy, rank to RANK_RTOL: numpy's lstsq, an SVD, costs several times more on these small systems)."""
    m, n = A.shape
    B = np.zeros((max(m, n), 1))
    B[:m, 0] = b
    x = _lapack().dgelsy(A, B, np.zeros(n, dtype=np.int32), RANK_RTOL, max(4 * n + 1, 2 * min(m, n) + 64))[1]
    return x[:n, 0]


def _trace(c, q0, qd):
    """(samples, tangents, whole) of the branch through the closure q0 of a one-mobility mechanism: arclength
    steps along the motion (second-order predictions) from TRACE_STEP up to TRACE_MAX_STEP (dimensionless), each
    closed again by Gauss–Newton (:func:`_correct`; halved down to TRACE_MIN_STEP where the corrector fails, moves
    more than half the step, contracts slowly, jumps or turns back); ``whole`` when the trace comes back to q0 (the
    branch is a closed curve, traced whole), False where it stops (a singular position, a step that cannot be closed
    on it, TRACE_MAX samples)."""
    model, cs = c.model, c.col_scale
    t = _tangent(c, c.jacobian(q0), None)
    samples, tangents, q, h, bend = [q0], [t], q0, TRACE_STEP, 0.0
    while t is not None and len(samples) < TRACE_MAX:
        # (second order: the tangent's turn per unit length over the last step, the corrector's work then O(h³))
        out = _correct(c, pin.integrate(model, q, cs * (h * t + 0.5 * h * h * bend)), tol=TRACE_TOL)
        t1 = None if out is None else _tangent(c, out[1], t)
        if t1 is not None:
            q1, _, steps = out
            q1 = c.within_pi(q1, qd)
        if (t1 is None or (steps and steps[0] > 0.5 * h) or (len(steps) > 1 and steps[1] > 0.5 * steps[0])
                or gap(c, q, q1) > 2 * h or t1 @ t < 0.5):
            if h / 2 < TRACE_MIN_STEP:
                return samples, tangents, False
            h /= 2
            continue
        ahead = offsets(c, q1, c.within_pi(q0.copy(), q1))  # (q0 ahead along the motion: the loop is closing)
        if len(samples) > 1 and np.linalg.norm(ahead) <= h and ahead @ t1 > 0:
            return samples, tangents, True
        samples.append(q1)
        tangents.append(t1)
        grow = len(steps) <= 4 and t1 @ t >= 0.9
        q, t, h, bend = q1, t1, min(TRACE_MAX_STEP, 1.5 * h) if grow else h, (t1 - t) / h
    return samples, tangents, False


def _on_branch(c, p, S, steps, T):
    """Whether the closure p lies on the traced branch of samples S (``steps``: the chord from each sample to
    the next; T: the unit tangents there): near a sample (within 0.6 of its longer chord), and reached from it
    along the motion by steps of p's offset projected on the tangent, each closed again (:func:`_correct`), until
    the offset is below SAME or its projection is (p is then beside the branch, not on it)."""
    d = gaps(c, p, S)
    i = int(np.argmin(d))
    if d[i] > 0.6 * max(steps[i], steps[i - 1]):
        return False
    q, t = S[i], T[i]
    for _ in range(CORRECT_ITER):
        x = offsets(c, q, c.within_pi(p.copy(), q))
        if np.linalg.norm(x) <= SAME:
            return True
        if t is None or abs(x @ t) <= SAME:
            return False
        out = _correct(c, pin.integrate(c.model, q, c.col_scale * ((x @ t) * t)))
        if out is None:
            return False
        q, t = out[0], _tangent(c, out[1], None)
    return False


def _local_minima(d, whole):
    """Indices of the local minima of the distances d along a branch (cyclic where ``whole``; else its ends
    count)."""
    n = len(d)
    if whole:
        return [i for i in range(n) if d[i] <= d[i - 1] and d[i] <= d[(i + 1) % n]]
    return [i for i in range(n) if (i == 0 or d[i] <= d[i - 1]) and (i == n - 1 or d[i] <= d[i + 1])]


def _branches(c, qd, seeds, system):
    """(candidates, branches, whole, complete, folded) of a one-mobility mechanism: each branch of the loops' closures
    reached from the ``seeds`` is traced (:func:`_trace`); the local minima of its distance to qd (among its samples
    within the position limits) are the candidates (to be slid to the nearest). The other assembly modes
    (:func:`.partners`) are sought at PARTNER_POINTS points spread along each branch not reached as one of them,
    and, once every branch met is traced, at the nearest candidate (where its own were not sought yet: the closures
    beside the answer), each not on a traced branch traced in turn, until the nearest candidate's were sought.
    ``whole``: every branch met was traced whole (closed curves) within MAX_BRANCHES; ``complete``: every search for
    the other modes tried its whole grid of restarts (:func:`.partners`); ``folded``: a loop solved after others
    that closes over part of their motion only (no restart closed it from one of their closures, or it folds along a
    branch: :func:`_folded`), '' if none. (A branch reached as a partner is searched at its spread points only where
    fewer than PARTNER_POINTS searches found it or partners found on it.)"""
    queue, branches, candidates, whole, complete = [(q, False) for q in seeds], [], [], True, True
    searched: list = []  # closures whose other assembly modes were sought (or were found by a search)
    blocks: list = []  # the blocks of loops solved one after another, as the first search solved them
    opened: list = []  # loops that no restart closed from a closure of the blocks before them

    def search(points):
        grid = True
        for q, (found, whole, solved, loop) in zip(points, partners(c, points, qd)):
            searched.extend([q] + found)
            queue.extend((p, True) for p in found)
            grid = grid and whole
            blocks[:] = blocks or solved
            opened.extend([loop] if loop else [])
        return grid

    def done():
        return candidates, len(branches), whole, complete, (opened or [_folded(c, blocks, branches)])[0]

    while True:
        while queue:
            q, partner = queue.pop(0)
            if any(_on_branch(c, q, *b) for b in branches):  # (on a traced branch)
                continue
            if len(branches) == MAX_BRANCHES:
                whole = False
                return done()
            samples, tangents, closed = _trace(c, q, qd)
            whole = whole and closed
            S = np.array(samples)
            ends = samples[1:] + (samples[:1] if closed else [samples[-1]])
            branches.append((S, [gap(c, p, r) for p, r in zip(samples, ends)], tangents))
            d = np.where(_within(system, S), gaps(c, qd, S), np.inf)  # (the minima within the position limits)
            candidates += [_polish(c, samples[i]) for i in _local_minima(d, closed) if np.isfinite(d[i])]
            met = [p for p, _ in queue if _on_branch(c, p, *branches[-1])]  # (searched there: not queued again)
            queue = [(p, f) for p, f in queue if not any(p is m for m in met)]
            if partner + len(met) < PARTNER_POINTS:
                spread = set(np.arange(PARTNER_POINTS) * len(samples) // PARTNER_POINTS) - ({0} if partner else set())
                complete = search([samples[i] for i in sorted(spread)]) and complete
        if not candidates:
            return done()
        best = candidates[int(np.argmin(gaps(c, qd, np.array(candidates))))]
        if searched and gaps(c, best, np.array(searched)).min() <= SAME:
            return done()
        complete = search([best]) and complete


def _folded(c, blocks, branches):
    """The name of a loop solved after others (``blocks``, in order) that folds along a traced branch ('' if none):
    the branch's motion of the coordinates the loop does not solve turns back between two samples (the loop's
    own coordinates alone move there: it reaches the end of its reach), so it closes over part of the motion of
    the loops before it only, and closures over the rest lie on branches of their own that no search for the
    other modes need meet."""
    for k in range(1, len(blocks)):
        before = np.setdiff1d(np.arange(c.nv), np.concatenate([cols for _, cols in blocks[k:]]))
        for _, _, tangents in branches:
            T = np.array([t for t in tangents if t is not None])[:, before]
            if len(T) > 1 and np.any(np.einsum("ij,ij->i", T, np.roll(T, -1, axis=0))[:-1] < 0):
                return c.loops[blocks[k][0][0]].name
    return ""


def _nearest(c, qd, q):
    """The closure nearest qd reached from the closure q along the loops: the step towards qd projected on
    the null space of Φ_q (dimensionless metric), closed again, until it vanishes or stops shortening. With
    mobility 1 the step is scaled by the secant of the projected offset along the motion (the distance's
    curvature there: superlinear where the plain step converges linearly), the plain step where that fails,
    halved up to SLIDE_HALVINGS times (a small branch, curved more than the step)."""
    model, cs = c.model, c.col_scale
    dist, J, last = np.linalg.norm(offsets(c, qd, q)), c.jacobian(q), None
    for _ in range(SLIDE_ITER):
        rank, _, _, Vt = c.decompose(J)
        V0 = Vt[rank:]
        v = pin.difference(model, q, qd) / cs
        step = V0.T @ (V0 @ v)
        if np.abs(step).max(initial=0.0) <= SLIDE_TOL:
            break
        tries, t = (step * 0.5**k for k in range(SLIDE_HALVINGS + 1)), None
        if len(V0) == 1:
            t = V0[0] if last is None or V0[0] @ last[2] >= 0 else -V0[0]
            g = float(t @ v)
            if last is not None and last[0] != 0:
                H = (last[1] - g) / last[0]
                if 0.02 <= H <= 50 and abs(H - 1) > 1e-3:
                    tries = itertools.chain([(g / H) * t], tries)
        for st in tries:
            out = _correct(c, pin.integrate(model, q, cs * st))
            q1 = _close(c, pin.integrate(model, q, cs * st), qd) if out is None else c.within_pi(out[0], qd)
            if q1 is None:
                continue
            d1 = np.linalg.norm(offsets(c, qd, q1))
            # (near the nearest the distance changes by step², below its round-off; a closure that neither moves
            # with the step nor comes nearer is no slide: the loops allow no motion there, an isolated closure's)
            if d1 <= dist * (1 + 1e-9) and (d1 < dist * (1 - 1e-12) or gap(c, q, q1) > 0.5 * np.linalg.norm(st)):
                break
        else:
            break
        J = c.jacobian(q1) if out is None else out[1]
        last = None if t is None else (float(t @ st), g, t)
        q, dist = q1, d1
    return q


def _beyond(system, q):
    """Why q is beyond the scene's position limits ('' within them)."""
    try:
        system.check_limits(q, "the closure")
    except ModelError as e:
        return str(e)
    return ""


def _within(system, samples):
    """Which of ``samples`` (configurations, one a row) lie within the scene's position limits."""
    if not system.limits:
        return np.ones(len(samples), dtype=bool)
    x = np.array([system.difference(system.neutral(), q) for q in samples])
    return ~beyond_limits(system, x).any(axis=1)


def _inside(c, qd, closures, system):
    """Closures within the position limits reached from ``closures`` (beyond them) along the mechanism's
    motion: where it has one motion, the sample nearest qd within the limits of each branch traced from them."""
    out: list = []
    for q in closures:
        if system.nv - c.rank(q) != 1 or any(gap(c, q, p) <= SAME for p in out):
            continue
        S = np.array(_trace(c, q, qd)[0])
        d = np.where(_within(system, S), gaps(c, qd, S), np.inf)
        if np.isfinite(d.min()):
            out.append(_polish(c, S[int(np.argmin(d))]))
    return out


def _compared(c, qd, closures, system):
    """([(distance, offsets, q)] of the distinct closures reached from ``closures`` by :func:`_nearest`, each
    kept where it ends within the position limits (else the closure it started from, if that one is within
    them), held): ``held`` when some slide ended beyond the limits. Distances dimensionless, periodic angles
    within π of qd's."""
    out, held = [], False
    for q in closures:
        q1 = _nearest(c, qd, q)
        if _beyond(system, q1):
            held = True
            if _beyond(system, q):
                continue
            q1 = q
        x = offsets(c, qd, q1)
        if all(np.abs(x - y).max() > SAME for _, y, _ in out):
            out.append((float(np.linalg.norm(x)), x, q1))
    return out, held


def _closures(c, qd, system):
    """(closures found within the limits, starts tried, (best open residual, its q), why the first closure
    beyond the limits is, the closures found beyond them): Gauss–Newton from the described pose, else least
    squares from it, then from each round of perturbed poses until one closes the loops within the limits."""
    from scipy.optimize import least_squares

    q = _close(c, qd, qd)
    if q is not None and not _beyond(system, q):
        return [q], 1, (0.0, q), "", []
    at, fun, jac = _chart(c, qd)
    found, tried, best, beyond, outside = [], 0, (np.inf, qd), "", [] if q is None else [q]
    for starts in _rounds(c.nv):
        for x0 in starts:
            tried += 1
            try:
                with np.errstate(over="ignore", invalid="ignore"):
                    r = least_squares(fun, x0, jac, method="trf", xtol=1e-10, ftol=1e-10, gtol=1e-10)
            except ValueError:  # (a start where Φ is not finite)
                continue
            res = float(np.abs(r.fun).max(initial=0.0))
            if res < best[0]:
                best = (res, at(r.x))
            q = _close(c, at(r.x), qd) if res <= OPEN_TOL else None
            if q is not None:
                why = _beyond(system, q)
                (outside if why else found).append(q)
                beyond = beyond or why
        if found:
            break
    return found, tried, best, beyond, outside


def _beside_ranks(c, q, qd):
    """Ranks of Φ_q (the first k rows, for each loop's last row k) at the closures BESIDE q along ± each
    null-space direction: their largest, per loop."""
    model, cs = c.model, c.col_scale
    rank, _, _, Vt = c.decompose(c.jacobian(q))
    ends = np.cumsum(c.sizes)
    out = np.zeros(len(ends), dtype=int)
    for v in Vt[rank:]:
        for s in (1.0, -1.0):
            q1 = _close(c, pin.integrate(model, q, cs * (s * BESIDE * v)), qd)
            if q1 is not None:
                J = c.jacobian(q1)
                out = np.maximum(out, [c.decompose(J[:k])[0] for k in ends])
    return out


def _coordinate_text(system, q):
    x = system.difference(system.neutral(), q)
    return ", ".join(f"{n} = {v:.6g} {u}" for n, v, u in zip(system.coordinates, x, system.units))


def _leave(c, q, qd, system):
    """(q, note): q itself where the scene's forces are defined; else the first closure, LEAVE steps along
    the motion, where they are (the first coordinate that moves increasing), with why."""
    model, cs = c.model, c.col_scale
    zero = np.zeros(system.nv)
    try:
        system.generalized_forces(q, zero)
        return q, ""
    except ModelError as e:
        why = str(e).split(" at the configuration")[0].split(":")[0]
    rank, _, _, Vt = c.decompose(c.jacobian(q))
    V0 = Vt[rank:]
    for k in range(system.nv):
        p = V0.T @ V0[:, k]  # e_k projected on the motions: moving along it increases coordinate k
        if np.linalg.norm(p) > 1e-6:
            break
    else:
        return q, ""
    p = p / np.linalg.norm(p)
    for h in LEAVE:
        q1 = _close(c, pin.integrate(model, q, cs * (h * p)), qd)
        if q1 is None:
            continue
        try:
            system.generalized_forces(q1, zero)
        except ModelError:
            continue
        return q1, (f"{why} at the nearest closure: the start is moved {h:g} (dimensionless) along the "
                    f"mechanism's motion, '{system.coordinates[k]}' increasing")
    return q, ""


def assemble_described(c, system):
    """The :class:`Assembly` of the described pose of the loops ``c`` (a :class:`Constraints`) of ``system``; see
    the module. A ConvergenceError naming the loop left most open, and by how much, if no start closes them."""
    start = time.perf_counter()
    qd = system.neutral()
    found, tried, (res, q_open), beyond, outside = _closures(c, qd, system)
    found = found or _inside(c, qd, outside, system)
    if not found and beyond:
        raise ConvergenceError(f"assembly from the neutral configuration: every closure found lies beyond the "
                               f"scene's position limits ({tried} starts tried, and the mechanism's motion followed "
                               f"from them where it has one): {beyond}; widen the limits or declare a start "
                               "(Scene.set_operating_point(start=...))", residual=0.0, best=None)
    if not found:
        phi = c.phi(q_open)
        i = int(np.argmax(np.abs(c.scaled_phi(phi))))
        raise ConvergenceError(
            f"assembly from the neutral configuration: the loops cannot be closed near it nor from {tried - 1} "
            f"perturbed poses (trust-region least squares): loop '{c.loop_of_row(i)}' stays open by "
            f"{abs(phi[i]):.4g} {c.row_units[i]} at best ({res:.3e} dimensionless: m / length scale "
            f"{system.length_scale:g} m, or rad), at {_coordinate_text(system, q_open)}"
            ": its bodies cannot reach each other as described (check the loop's points and the links' lengths), "
            "or declare a start near a closed configuration (Scene.set_operating_point(start=...))",
            residual=res, best=q_open)
    unique, held = _compared(c, qd, found, system)
    d_min, notes, why = min(d for d, _, _ in unique), [], ""
    if d_min > SAME:  # (the described pose closes: nothing is nearer)
        dof = system.nv - c.rank(min(unique, key=lambda u: u[0])[2])
        seeds = [q for _, _, q in unique]
        if dof == 1:
            more, branches, whole, complete, folded = _branches(c, qd, seeds, system)
            why = "" if whole else (f"a branch of its closures could not be traced whole ({branches} traced: a "
                                    "singular position, a step that could not be closed on it, or too many)")
            if whole and not complete:
                why = (f"its {branches} branches were traced whole, but its assembly modes were sampled "
                       f"({assembly_modes.PARTNER_MAX} restarts of its dependent coordinates at each point), not "
                       "enumerated")
            elif whole and folded:
                why = (f"its {branches} branches were traced whole, but loop '{folded}' closes over part of the "
                       "motion of the loops solved before it only (it folds along a branch, or does not close from "
                       "one of their closures): closures over the rest lie on branches of their own, which the "
                       "search need not meet")
        else:
            more = [p for found, _, _, _ in partners(c, seeds, qd) for p in found]
            why = (f"the mechanism has mobility {dof} there: its closures form surfaces, which are not traced (the "
                   f"closures of {tried} starts and their other assembly modes were compared)")
        unique, held = _compared(c, qd, seeds + more, system)
        d_min = min(d for d, _, _ in unique)
        if held and not why:
            why = ("the nearest closure on some branch is beyond the position limits: the one taken is the nearest "
                   "of the search within them")
    where = WHERE_FOUND if why else WHERE
    tied = [u for u in unique if u[0] <= d_min * (1 + TIE_RTOL) + SAME]
    chosen, k = tied[0], 0
    for other in tied[1:]:
        k = int(np.flatnonzero(np.abs(other[1] - chosen[1]) > SAME)[0])
        if other[1][k] > chosen[1][k]:
            chosen = other
    if why:
        notes.append(f"not proven the nearest: {why}; the nearest of {len(unique)} distinct closures compared")
    if len(tied) > 1:
        i = int(np.flatnonzero(np.abs(tied[0][1] - tied[1][1]) > SAME)[0])
        notes.append(f"{len(tied)} closures at the same distance {d_min:.6g} (mirror images of a symmetric "
                     f"description): took the one with the larger '{system.coordinates[i]}' (the first coordinate "
                     "where they differ); declare a start to take another")
    q = chosen[2]
    J = c.jacobian(q)
    ends = np.cumsum(c.sizes)
    here = np.array([c.decompose(J[:k])[0] for k in ends])
    beside = _beside_ranks(c, q, qd)
    for _, _, other in unique:
        if other is q:  # (its rank is `here`)
            continue
        Jo = c.jacobian(other)
        beside = np.maximum(beside, [c.decompose(Jo[:k])[0] for k in ends])
    rank, generic = int(here[-1]), int(max(beside[-1], here[-1]))
    singular = rank < generic
    if singular:
        c.check_mobility(q)  # (an isolated closure, exactly flat, looks singular: it locks the mechanism)
        lost = int(np.flatnonzero(here < beside)[0])
        notes.append(f"loop '{c.loops[lost].name}': {where} ({_coordinate_text(system, q)}) is a singular position "
                     f"of the mechanism: the loops' Jacobian has rank {rank} there and {generic} at the closures "
                     f"beside it (mobility {system.nv - rank} there, {system.nv - generic} elsewhere: branches of the "
                     "motion cross there); declare a start off it (Scene.set_operating_point(start=...), or q0=)")
    else:
        q, moved = _leave(c, q, qd, system)
        if moved:
            notes.append(moved)
        q = c.assemble(q, start=where)  # (recorded: the mobility is taken here; a locking loop is named)
    phi = float(np.abs(c.scaled_phi(c.phi(q))).max(initial=0.0))
    x = offsets(c, qd, q)
    return Assembly(q, where, phi, x * c.col_scale, float(np.linalg.norm(x)), system.nv - rank, rank, generic,
                    singular, tried, "; ".join(notes), time.perf_counter() - start, not why)
