"""The solver kit (issue 23): Newton on a manifold, pseudo-arclength continuation through folds, mode
tracking by MAC — against closed forms."""

import math
from dataclasses import replace

import numpy as np
import pytest

import vibdyn as vd
from vibdyn.solvers.continuation import Arclength, continuation
from vibdyn.solvers.newton import Steps, newton
from vibdyn.solvers.tracking import mac, match


def test_newton_solves_square_singular_and_manifold_problems():
    # a square system (a circle of radius 2 and the diagonal) from afar, its steps capped and searched
    r = newton(lambda x: np.array([x[0] ** 2 + x[1] ** 2 - 4.0, x[0] - x[1]]), [10.0, 0.1],
               steps=Steps(max_step=1.0), tol=1e-12)
    assert r.converged and np.allclose(r.x, [math.sqrt(2)] * 2, atol=1e-12) and r.iterations < 20
    # under-determined: the minimum-norm step lands on the closest solution, (1, 1) of x + y = 2 from 0
    r = newton(lambda x: np.array([x[0] + x[1] - 2.0]), [0.0, 0.0])
    assert r.converged and np.allclose(r.x, [1.0, 1.0])
    # on a manifold: the angle θ on the unit circle where (cos θ, sin θ) is closest to (1, 1) (a tangent
    # step on S¹ retracted by rotation), from (1, 0)
    def retract(p, d):
        c, s = math.cos(d[0]), math.sin(d[0])
        return np.array([c * p[0] - s * p[1], s * p[0] + c * p[1]])

    r = newton(lambda p: np.array([p[0] - p[1]]), np.array([1.0, 0.0]),
               lambda p: np.array([[-p[1] - p[0]]]), retract)
    assert r.converged and np.allclose(r.x, [math.sqrt(0.5)] * 2) and abs(np.linalg.norm(r.x) - 1) < 1e-15
    with pytest.raises(vd.ConvergenceError, match="Newton"):
        newton(lambda x: np.array([x[0] ** 2 + 1.0]), [1.0]).check()


def test_continuation_follows_an_s_curve_through_both_folds():
    """x³ − x − λ = 0 from λ = −1 (x ≈ −1.32) to λ = 1: the branch turns at the folds x = ±1/√3,
    λ = ∓2/(3√3), located exactly; every point is on the curve; the end is at λ = 1 exactly."""
    br = continuation(lambda x, lam: np.array([x[0] ** 3 - x[0] - lam]), [-1.3], -1.0, 1.0,
                      path=Arclength(step=0.05),
                      jacobian=lambda x, lam: np.array([[3 * x[0] ** 2 - 1.0, -1.0]]))
    assert br.status == "finished" and br.lam[-1] == 1.0
    assert np.abs(br.x[:, 0] ** 3 - br.x[:, 0] - br.lam).max() <= 1e-10
    assert len(br.folds) == 2
    f = sorted(br.folds, key=lambda f: f.lam)
    c = 2 / (3 * math.sqrt(3))
    assert f[0].lam == pytest.approx(-c, abs=1e-10) and f[0].x[0] == pytest.approx(1 / math.sqrt(3), abs=1e-8)
    assert f[1].lam == pytest.approx(c, abs=1e-10) and f[1].x[0] == pytest.approx(-1 / math.sqrt(3), abs=1e-8)
    assert br.x[-1, 0] == pytest.approx(1.3247179572447460, abs=1e-10)  # the real root of x³ − x − 1
    # without a Jacobian (central differences) and with a stop request
    br = continuation(lambda x, lam: np.array([x[0] ** 3 - x[0] - lam]), [-1.3], -1.0, 1.0,
                      path=Arclength(step=0.05),
                      stop=lambda x, lam: x[0] > 0.0)
    assert br.status == "stopped" and br.x[-1, 0] > 0 and len(br.folds) == 1


def test_a_branch_goes_on_as_one_from_where_it_stopped():
    """Branch.then: the S-curve x³ − x − λ = 0 stopped at x > 0.7 (past both folds), then continued from its last
    point to λ = 1, is one
    branch — its points in order and on the curve (the joint point once), the arclength increasing, both folds,
    the steps summed, the end and status of the second — as a branch that did not stop; a first branch with no
    point gives the second's points."""
    def F(x, lam):
        return np.array([x[0] ** 3 - x[0] - lam])

    def J(x, lam):
        return np.array([[3 * x[0] ** 2 - 1.0, -1.0]])

    first = continuation(F, [-1.3], -1.0, 1.0, path=Arclength(step=0.05), jacobian=J,
                         stop=lambda x, lam: x[0] > 0.7)
    more = continuation(F, first.x[-1], float(first.lam[-1]), 1.0, path=Arclength(step=first.step), jacobian=J)
    whole = first.then(more)
    assert whole.status == "finished" and whole.lam[-1] == 1.0 and len(whole.folds) == 2
    assert len(whole.lam) == len(first.lam) + len(more.lam) - 1 and whole.x.shape == (len(whole.lam), 1)
    assert np.abs(whole.x[:, 0] ** 3 - whole.x[:, 0] - whole.lam).max() <= 1e-10
    assert np.all(np.diff(whole.s) > 0) and whole.steps == first.steps + more.steps
    empty = replace(first, x=first.x[:0], lam=first.lam[:0], s=first.s[:0])
    assert np.array_equal(empty.then(more).x, more.x) and empty.then(more).steps == first.steps + more.steps


def test_continuation_round_a_circle_finds_its_two_folds():
    """x² + λ² = 1 from (0, −1) towards λ = 2 (never reached): it goes round through the folds at λ = ±1."""
    br = continuation(lambda x, lam: np.array([x[0] ** 2 + lam ** 2 - 1.0]), [0.99], 0.0, 2.0,
                      path=Arclength(step=0.1, max_steps=80))
    assert br.status == "stopped"
    lams = sorted(f.lam for f in br.folds)
    assert lams[0] == pytest.approx(-1.0, abs=1e-10) and lams[-1] == pytest.approx(1.0, abs=1e-10)


def test_mode_tracking_recovers_a_permutation_and_breaks_ties_by_frequency():
    rng = np.random.default_rng(1)
    shapes = np.linalg.qr(rng.standard_normal((6, 6)))[0]
    perm = np.array([3, 0, 5, 1, 4, 2])
    assert np.array_equal(match(shapes, shapes[:, perm] * (1 + 0.01 * rng.standard_normal(6))), np.argsort(perm))
    # two identical shapes (a degenerate pair): the frequencies decide
    a = np.array([[1.0, 1.0], [0.0, 0.0]])
    assert list(match(a, a[:, ::-1], [1.0, 2.0], [2.0, 1.0])) == [1, 0]
    assert mac(np.array([1.0, 0.0]), np.array([0.0, 1.0])) == 0.0 and vd.mac is mac


def test_newton_trust_region_expands_towards_a_far_root():
    """x − 1000 = 0 from 0 with steps capped at 1: a fixed cap needs 1000 steps, the expanding one doubles it
    after every whole capped step and lands in about log₂(1000) of them."""
    fixed = newton(lambda x: x - 1000.0, [0.0], steps=Steps(max_step=1.0), max_iter=50)
    assert not fixed.converged and fixed.x[0] == pytest.approx(50.0)
    grown = newton(lambda x: x - 1000.0, [0.0], steps=Steps(max_step=1.0, expand=True), max_iter=50)
    assert grown.converged and grown.x[0] == pytest.approx(1000.0, abs=1e-10) and grown.iterations <= 12


def test_newton_chord_keeps_a_jacobian_while_it_contracts_and_replaces_a_stale_one():
    """The circle-and-diagonal system from near its root: chord steps (one Jacobian for several steps) reach
    the same root; a Jacobian handed in that is far off (a neighbour's gone stale) is replaced, not trusted."""
    def F(x):
        return np.array([x[0] ** 2 + x[1] ** 2 - 4.0, x[0] - x[1]])

    def J(x):
        return np.array([[2 * x[0], 2 * x[1]], [1.0, -1.0]])

    root = [math.sqrt(2)] * 2
    full = newton(F, [1.5, 1.4], J, tol=1e-13)
    chord = newton(F, [1.5, 1.4], J, tol=1e-13, chord=0.3)
    assert full.converged and chord.converged and np.allclose(chord.x, root, atol=1e-13)
    assert full.jacobians == full.iterations and chord.jacobians < chord.iterations
    stale = newton(F, [1.5, 1.4], J, tol=1e-13, chord=0.3, start=(None, np.array([[-5.0, 0.0], [0.0, 3.0]])))
    assert stale.converged and np.allclose(stale.x, root, atol=1e-13) and stale.jacobians >= 1


def test_continuation_with_chord_corrector_finds_the_same_branch_with_fewer_jacobians():
    calls = {True: 0, False: 0}

    def run(chord):
        def jac(x, lam):
            calls[chord] += 1
            return np.array([[3 * x[0] ** 2 - 1.0, -1.0]])

        return continuation(lambda x, lam: np.array([x[0] ** 3 - x[0] - lam]), [-1.3], -1.0, 1.0, jacobian=jac,
                            path=Arclength(step=0.05, chord=0.1 if chord else None))

    plain, chord = run(False), run(True)
    assert chord.status == "finished" and chord.lam[-1] == 1.0
    assert np.abs(chord.x[:, 0] ** 3 - chord.x[:, 0] - chord.lam).max() <= 1e-10
    assert sorted(f.lam for f in chord.folds) == pytest.approx(sorted(f.lam for f in plain.folds), abs=1e-10)
    assert calls[True] < calls[False]


def test_continuation_ends_at_once_where_the_residual_has_a_floor_above_tol():
    """Beyond λ = 0.5, F = x − λ² is evaluated only to a quantum q (|F| ≥ q/2 everywhere: no root): with
    q/2 = 2·tol the corrector stalls just above tol however short the step, and the branch ends "failed" at
    the floor after three such corrections, saying so, not after halving its step down to ``min_step``;
    with q/2 below tol the same branch finishes."""
    def quantised(q, calls):
        def F(x, lam):
            calls.append(lam)
            r = x[0] - lam ** 2
            return np.array([q * (math.floor(r / q) + 0.5) if lam > 0.5 else r])
        return F

    def jac(x, lam):
        return np.array([[1.0, -2.0 * lam]])

    calls: list = []
    br = continuation(quantised(4e-10, calls), [0.0], 0.0, 1.0, jacobian=jac,
                      path=Arclength(step=0.05, tol=1e-10, min_step=1e-9))
    assert br.status == "failed" and "stalls just above the tolerance" in br.message
    assert 0.4 < br.lam[-1] <= 0.5 and np.abs(br.x[:, 0] - br.lam ** 2).max() <= 1e-10
    assert br.rejected <= 3 and len(calls) < 150  # (halving down to min_step took 35 rejections, 587 calls)
    br = continuation(quantised(1e-10, []), [0.0], 0.0, 1.0, jacobian=jac,
                      path=Arclength(step=0.05, tol=1e-10, min_step=1e-9))
    assert br.status == "finished" and br.lam[-1] == 1.0


def test_continuation_shortens_a_step_whose_predictor_leaves_the_domain():
    """Issue 32: F(x, λ) = log x − λ is defined for x > 0 only (as a shooting residual for a period T > 0): its
    Jacobian raises outside. Followed from (1, 0) to λ = −6 with long steps, the predictor lands at x ≤ 0 on the
    way; Newton takes no step from a non-finite residual (no Jacobian there), the step is halved, and the
    branch ends at x = e^λ. Newton alone from such a point says "diverged"."""
    def F(x, lam):
        return np.array([math.log(x[0]) - lam if x[0] > 0 else math.inf])

    def jac(x, lam):
        if not x[0] > 0:
            raise ValueError("outside the domain")
        return np.array([[1.0 / x[0], -1.0]])

    br = continuation(F, [1.0], 0.0, -6.0, jacobian=jac,
                      path=Arclength(step=1.0, max_step=20.0, tol=1e-12, scale=[0.01, 1.0]))
    assert br.status == "finished" and br.lam[-1] == -6.0 and br.rejected >= 1
    assert np.abs(np.log(br.x[:, 0]) - br.lam).max() <= 1e-12  # (every point solved to tol)
    res = newton(lambda x: F(x, 0.0), [-1.0], lambda x: jac(x, 0.0)[:, :1])
    assert res.status == "diverged" and not res.converged and res.iterations == 0 and res.jacobians == 0


def test_newton_keeps_to_eight_options():
    """The solver kit stays small (issue 33): Newton takes at most 8 optional or keyword-only parameters, the
    step's trust region and line search grouped in :class:`Steps`, F and J at the start in one ``start``."""
    import inspect

    options = [p for p in inspect.signature(newton).parameters.values()
               if p.default is not p.empty or p.kind is p.KEYWORD_ONLY]
    assert len(options) <= 8, [p.name for p in options]
