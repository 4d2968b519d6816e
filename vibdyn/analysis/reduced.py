"""Linear models in a system's independent coordinates (:class:`vibdyn.model.reduction.Reduction`): loops, drives,
coordinates held at their speed, and their composition, through one path.

About a state (q0, v0) at t0 whose held coordinates follow their laws or speeds and whose independent ones do not
accelerate (or, with drives, move as the equations say), the tree is linearised (:func:`tree_linearize`) and
reduced by the basis N (nv × n, ``null_space``) of the motions the reduction allows: M_r = NᵀMN, C_r = NᵀCN,
K_r = Nᵀ(K − ∂(Φ_qᵀλ)/∂q)N, λ the loop forces there. Where N depends on q (loops) and the state moves, the
reduced equations F(z, ż) = N(q)ᵀ r(q, N ż, a) are differenced in the chart of the independent coordinates
instead (:func:`moving_terms`): their K holds the constraint curvature, the centrifugal and gyroscopic terms
together. Held rows are gone: a held coordinate does not vibrate (its holder absorbs what would move it).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from .._deprecation import Renamed
from ..defaults import EPS, FD_STEP
from ..errors import ModelError
from ..model import dynamics
from ..model.fd import differences, displaced_vectors, stencil, steps
from .linearize import LinearModel, fd_error, reference_state, tree_linearize
from .modal import modes as _modes


@dataclass(frozen=True, eq=False)
class ReducedLinearModel(LinearModel):
    """Linear model in the independent coordinates ``independent`` (indices in v) of its ``reduction``: M, C,
    K (n × n) are NᵀM N, NᵀC N and Nᵀ(K − ∂(Φ_qᵀλ)/∂q)N, N (``null_space``, nv × n) the motions the reduction
    allows, whose rows at the independent coordinates are the identity. ``system`` is the whole system and
    ``tree`` the nv × nv model (K with the constraint-force curvature); ``coordinates``, ``units`` and
    :meth:`coordinate_index` are the independent ones'. ``rank``: rank of the loops' Φ_q at q (0 without
    loops). Inputs and outputs of responses are any tree coordinate (its row of N) and body points (J N)."""

    null_space: np.ndarray | None = field(repr=False, default=None)
    tree: LinearModel | None = field(repr=False, default=None)
    multipliers: np.ndarray | None = field(repr=False, default=None)
    rank: int = 0
    independent: tuple = ()
    reduction: Any = field(repr=False, default=None)
    basis = Renamed("null_space")

    @property
    def coordinates(self):
        return tuple(self.system.coordinates[i] for i in self.independent)

    @property
    def units(self):
        return tuple(self.system.units[i] for i in self.independent)

    def coordinate_index(self, name: str) -> int:
        names = self.coordinates
        if name in names:
            return names.index(name)
        raise self.reduction.refuse(name, names)

    def point_jacobian(self, points):
        """Displacements (m, world axes) of body points per independent coordinate (3·npoints × n)."""
        return self.tree.point_jacobian(points) @ self.null_space

    def coordinate_row(self, name):
        """(row of N, unit): the tree coordinate ``name`` (independent or not) per independent coordinate."""
        system = self.system
        i = system.coordinate_index(name)
        return self.null_space[i].copy(), system.units[i]

    def joint_input(self, coordinates=None):
        """Reduced input Nᵀ B of generalized forces on the named tree coordinates (n × m; None: the
        independent ones)."""
        names = self.coordinates if coordinates is None else coordinates
        return self.null_space.T @ self.tree.joint_input(names)

    def support_input(self, name, step=FD_STEP):
        """(Nᵀ B_y, Nᵀ B_v): the tree's base-excitation inputs reduced (see :meth:`LinearModel.support_input`)."""
        By, Bv = self.tree.support_input(name, step)
        return self.null_space.T @ By, self.null_space.T @ Bv

    @property
    def hold(self) -> tuple[str, ...]:
        """Names of the coordinates held at their speed (what :func:`vibdyn.analysis.linearize.linearize` was given as
        ``hold``; the drives' coordinates are the system's own)."""
        return self.reduction.held_at_speed()

    @property
    def drive(self) -> dict[str, float]:
        """{drive, or coordinate held at its speed: τ}: the force (N or N·m) each holder exerts along its
        coordinate at the operating point (empty without held coordinates)."""
        tau = dynamics.inverse_dynamics(self.system, self.system.workspace(), self.q, self.v, self.a, self.t)
        return self.reduction.held_forces(tau)

    def relinearize(self, method):
        """The same operating point linearised again with ``method`` (the tree's part: "fd" or "analytic")."""
        again = linearize(self.system, self.reduction, self.q, v=self.v, t=self.t, method=method,
                          multipliers=self.multipliers, a=self.a)  # (with loops: their reference motion's)
        return type(self)(**{f.name: getattr(again, f.name) for f in fields(type(self))})

    def summary(self):
        return (f"{type(self).__name__}({self.method}, nv={self.tree.nv}, dof={self.nv}, rank {self.rank}, "
                f"relative error ≈ {self.relative_error:.1e}, {self.elapsed * 1e3:.2f} ms)")


def _on_reduced(name):
    """A response method of ConstrainedLinearModel that runs on its reduced model."""
    def method(self, *args, **kwargs):
        return getattr(self.reduced, name)(*args, **kwargs)

    method.__name__ = name
    method.__doc__ = getattr(LinearModel, name).__doc__
    return method


@dataclass(frozen=True, eq=False)
class ConstrainedLinearModel(ReducedLinearModel):
    """:class:`ReducedLinearModel` whose :meth:`modes` give their shapes in the tree's coordinates (nv each,
    φ = N ψ, Φ_q φ = 0 and zero on held coordinates, φᵀ M φ = 1 with the tree's M; ``modes.linear`` is the tree
    model). Responses run on :attr:`reduced` (modes in the independent coordinates): receptances between tree
    coordinates are N (K_r − ω²M_r + iωC_r)⁻¹ Nᵀ."""

    @property
    def reduced(self):
        return ReducedLinearModel(**{f.name: getattr(self, f.name) for f in fields(ReducedLinearModel)})

    def modes(self, **kwargs):
        """Exactly n modes, shapes in the tree's coordinates (see the class)."""
        m = _modes(self, **kwargs)
        N = self.null_space
        cs = m.complex_shapes
        return replace(m, linear=self.tree, reduced=self, shapes=N @ m.shapes, complex_shapes=N @ cs if cs.size else cs)

    def with_modal_damping(self, zeta):
        return self.with_damping(self.reduced.with_modal_damping(zeta).C)

    # the responses run on the reduced model
    free_response = _on_reduced("free_response")
    receptance = _on_reduced("receptance")
    harmonic_response = _on_reduced("harmonic_response")
    base_response = _on_reduced("base_response")
    forced_response = _on_reduced("forced_response")
    appropriation = _on_reduced("appropriation")


@dataclass(frozen=True, eq=False)
class DrivenLinearModel(ConstrainedLinearModel):
    """:class:`ConstrainedLinearModel` of a scene with drives or coordinates held at their speed, in its free
    coordinates (``null_space`` the identity's columns there); ``drive``: {holder: τ} (N or N·m)."""

    def summary(self):
        return (f"{type(self).__name__}({self.method}, nv={self.tree.nv}, free={self.nv}, "
                f"relative error ≈ {self.relative_error:.1e}, {self.elapsed * 1e3:.2f} ms)")


def linearize(system, reduction, at=None, *, v=None, t=0.0, a=None, method="fd", step=FD_STEP,
              multipliers=None, independent=None) -> ReducedLinearModel:
    """Linear model of ``system`` in the independent coordinates of ``reduction`` about ``at`` (an operating
    point, or a configuration, closed first) with velocity ``v`` (zero if None; it must keep the loops
    closed) at time ``t`` (s); the held coordinates' q and v are their laws' or speeds (see the module).

    ``a``: the reference motion's accelerations. None: the independent coordinates do not accelerate about an
    operating point or with loops (the dependent ones keep Φ_q a + γ = 0); otherwise (a state of a driven
    motion) the motion's own. Given, its driven entries must be the laws' (and with loops it must be zero).
    ``multipliers``: the loop forces λ (None: the operating point's, or the minimum-norm λ with Φ_qᵀλ = r).
    ``independent``: the independent coordinates (indices in v) to keep instead of choosing them."""
    start = time.perf_counter()
    R = reduction
    q0, v0, t0 = reference_state(system, at, v, t)
    q0, v0 = R.impose(q0, v0, t0)
    if R.closure(q0) > 1e-9:
        q0 = R.close(q0)
    moving = bool(np.any(v0))
    opening = R.opening(q0, v0)
    if opening > 1e-9:
        raise ModelError("linearize: the velocity v of the operating point opens the loops (Φ_q v ≠ 0: "
                         f"{opening:.3e} dimensionless): give a motion the loops allow (a steady motion's v, or "
                         "v = N ż)")
    ind, N = R.independent(q0, independent)
    if not ind.size:
        raise ModelError(f"linearize: every coordinate of scene '{system.name}' is held ({R.describe()}): nothing "
                         "is free to vibrate")
    ws = system.workspace()
    a0 = R.motion_acceleration(system, ws, q0, v0, t0, ind, a, steady=a is None and hasattr(at, "drive"))
    tree = tree_linearize(system, q0, v=v0, t=t0, a=a0, method=method, step=step)
    evaluations = tree.evaluations
    terms = None
    if multipliers is None:
        multipliers = getattr(at, "multipliers", None)
    lam = R.multipliers(q0, lambda: dynamics.inverse_dynamics(system, ws, q0, v0, a0, t0)) if multipliers is None \
        else np.asarray(multipliers, dtype=float)
    force = R.constraint_force(lam)
    if force is not None:  # the loops' forces Φ_qᵀλ turn with q: their curvature joins K
        terms = dynamics.cancelling_terms(system, ws, q0, v0, a0, t0)
        G, change, rounding = curvature(system, force, q0)
        tree_error = tree.K_error
        tree = replace(tree, K=tree.K - G, K_error=tree_error + rounding + np.abs(change))
        evaluations += 4 * system.nv + 1

    def differenced():
        nonlocal evaluations
        evaluations += 8 * ind.size
        return moving_terms(system, R, q0, v0, t0, ind, steps(system, step), np.abs(N).T @ terms)

    if force is None or moving:
        M_r, C_r, K_r, K_err, C_err, terms_r = R.reduce_model(ind, N, tree, moving, differenced)
    else:
        # G's error in the reduced model: its Richardson change as N projects it, signed (the change of NᵀGN
        # between the steps, as it is of G's own entries), and its round-off through |N| on the rows (one
        # evaluation's rows may round alike) and as a root sum of squares over the columns (each column its own
        # evaluations, rounding independently: |N|ᵀ R |N| adds up what cancels at random)
        M_r, C_r, K_r, K_err, C_err, terms_r = R.reduce_model(ind, N, replace(tree, K_error=tree_error), moving,
                                                              differenced)
        K_err += np.abs(N.T @ change @ N)
        rows = np.abs(N).T @ rounding
        rows *= rows
        K_err += np.sqrt(rows @ (N * N))
    if not moving:
        K_err = K_err + _pose_spread(system, R, at, q0, N, K_r, lambda q: linearize(
            system, R, q, t=t0, method=method, step=step, independent=ind).K)
    rank = R.free.size - ind.size  # (what the loops tie; 0 without them)
    cls = ConstrainedLinearModel if rank else DrivenLinearModel
    return cls(system, q0, v0, a0, t0, M_r, C_r, K_r, K_err, C_err, tree.method, time.perf_counter() - start,
               evaluations, terms_r, null_space=N, tree=tree, multipliers=lam if lam.size else None, rank=rank,
               independent=tuple(int(i) for i in ind), reduction=R)


POSE_CONDITIONING = 1e-2  # σ_min/σ_max of the loops' Jacobian below which K's change over the pose error joins K_error
POSE_STEP = 1e-7  # dimensionless step along each motion of the mechanism for that change


def _pose_spread(system, R, at, q0, N, K, again):
    """What an operating point's pose error (its ``q_error``) can change K by near a singular position of the
    loops (a four-bar short of locking: K's loop-force curvature turns fast with the pose): the change of K
    (``again(q)``: K at q in the same coordinates) along each of the mechanism's motions N over POSE_STEP, times
    the error's dimensionless size; 0 elsewhere, or without an error."""
    err = getattr(at, "q_error", None)
    if err is None or not np.any(err) or R.conditioning(q0) >= POSE_CONDITIONING:
        return 0.0
    scales = system.coordinate_scales
    size, out = float(np.linalg.norm(err / scales)), np.zeros_like(K)
    for n in N.T:
        out += np.abs(again(system.integrate(q0, POSE_STEP * n / np.linalg.norm(n / scales))) - K)
    return out * (size / POSE_STEP)


CURVATURE_STEP = 1e-3  # rad, or × the length scale: the step of the loops' curvature (smooth in q at fixed λ)


def curvature(system, force, q0):
    """(G, E, R): G = ∂f/∂q of the loops' forces f(q) = Φ_q(q)ᵀλ at fixed λ (nv × nv) by central differences D(h),
    D(2h) with steps h of ``CURVATURE_STEP``, extrapolated: G = D(h) + (D(h) − D(2h))/3 (fourth order). Along one
    coordinate f is a·sin + b·cos + c of its angle (one rotation, frequency 1 per rad; linear in a slider's
    displacement, each joint entering the loops' Jacobian once), so G's truncation h⁴f⁽⁵⁾/30 is (h/s)²/15 times
    D(h) − D(2h) ≈ −h²f‴/2 (s: the coordinate's scale): E = (h/s)² (D(h) − D(2h)), signed, fifteen times that (a
    frequency up to 3.9 per unit covered). R ≥ 0: the round-off, 1.5 ε|f|/h carried by the extrapolation, as
    2 ε|f|/h (the largest row's |f| reaching every row through the tree's transforms), and that of G itself. The
    step of 1e-3 keeps the round-off a hundredth of the linearisation step's, with as many evaluations."""
    s = system.coordinate_scales
    h = steps(system, CURVATURE_STEP)
    st = stencil(system, system.workspace(), h, estimate=True)
    Y = np.array([np.ravel(force(q)) for q in st.configurations(system, q0)])
    D, T = st.derivatives(Y)
    G = T / 3
    G += D
    scaled = h / s
    T *= scaled * scaled
    f = np.abs(Y[0])  # (the stencil's first row: q0 itself)
    f += float((f * s).max(initial=0.0)) / s
    rounding = np.multiply.outer(f, 2 * EPS / h)
    rounding += 4 * EPS * np.abs(G)
    return G, T, rounding


def moving_terms(system, R, q0, v0, t0, ind, h, terms):
    """(K_r, C_r, K_error, C_error) of the reduced equations about the steady motion (q0, v0) (see
    :func:`linearize`): central differences in the independent coordinates z (q moved by N₀ δz, then closed
    by the dependent ones: :meth:`Reduction.chart`) and in their speeds ż, steps h and 2h (Richardson);
    ``terms`` the reduced round-off scale (N or N·m)."""
    ws = system.workspace()
    zd0 = v0[ind]

    def residual(q, zd):
        _, N = R.independent(q, ind)
        v = R.impose(q, N @ zd, t0)[1]
        a = R.reference_acceleration(ws, q, v, t0, ind)
        return N.T @ dynamics.inverse_dynamics(system, ws, q, v, a, t0)

    hz = h[ind]
    hv = hz * np.maximum(1.0, np.abs(zd0))
    Z = displaced_vectors(np.zeros(ind.size), hz, estimate=True)
    K, T = differences(np.array([residual(R.chart(q0, ind, z), zd0) for z in Z]), hz)
    K_err = fd_error(K, T, terms, hz)
    V = displaced_vectors(zd0, hv, estimate=True)
    C, T = differences(np.array([residual(q0, zd) for zd in V]), hv)
    C_err = fd_error(C, T, terms, hv)
    return K, C, K_err, C_err
