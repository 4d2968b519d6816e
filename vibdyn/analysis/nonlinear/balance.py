"""The H-harmonic balance of a system under a harmonic excitation (what :mod:`.harmonic_balance` continues):
the excitation as generalized forces or support shifts at τ = Ωt; the residual of x(τ) = c₀ + Σ_{k=1..H} (c_k cos kτ
+ s_k sin kτ) evaluated in time at N = 4H + 4 samples through vibdyn's own inverse dynamics (all samples in one
pass where the scene's elements can: :func:`vibdyn.model.dynamics.inverse_dynamics_rows`) and projected back
on the harmonics; its Jacobian from the samples' analytic derivatives; Hill's matrices and multipliers; and
each point's truncation estimate from the 2H + 1 balance. Units: SI; X the coefficients (m or rad), Ω (rad/s).
"""

from __future__ import annotations

import functools
import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..._check import finite_array, scalar
from ..._format import number
from ...defaults import EPS, FD_STEP
from ...errors import ModelError
from ...model import dynamics
from ...model.derivatives import analytic_derivatives_rows
from ...model.fd import derivative, point_jacobian, steps, tangent_derivative, vector_derivative

KEPT_BYTES = 32 * 2**20  # the per-sample derivatives kept for revisits, at most


@dataclass(frozen=True)
class PointForce:
    """A harmonic point force amplitude·direction·cos Ωt (N; ``direction`` in world axes, normalised) applied
    at ``point`` (m, in the frame of ``body``)."""

    body: str
    point: tuple
    direction: tuple
    amplitude: float


@dataclass(frozen=True)
class SupportMotion:
    """The support ``support`` (a :meth:`Scene.add_support`) moved by amplitude·cos Ωt (m, 3 numbers, world
    axes) in place of its own motion law: base excitation through its springs and dampers. The static
    equilibrium is the scene's at t = 0, its law's position there (zero for a HarmonicMotion's sine)."""

    support: str
    amplitude: tuple


class Excitation:
    """The excitation as generalized forces or support shifts at given τ = Ωt."""

    def __init__(self, system, force):
        self.system = system
        self.where = None
        what = "forced_response_curve: force"
        if isinstance(force, PointForce):
            b = system.body_info(force.body) if force.body in system.body_infos else None
            if b is None:
                raise ModelError(f"{what}: unknown body '{force.body}' (bodies: {', '.join(system.body_infos)})")
            self.point = (force.body, tuple(finite_array(force.point, (3,), f"{what}: point")))
            d = finite_array(force.direction, (3,), f"{what}: direction")
            if not np.any(d):
                raise ModelError(f"{what}: direction is the zero vector")
            self.F = _nonzero(force.amplitude, what) * d / np.linalg.norm(d)
            self.where, self.label = "point", (f"a point force {number(np.linalg.norm(self.F))} N·cos Ωt on "
                                              f"'{force.body}'")
        elif isinstance(force, SupportMotion):
            if force.support not in system.support_index:
                raise ModelError(f"{what}: unknown support '{force.support}' (supports: "
                                 f"{', '.join(system.support_index) or 'none'})")
            self.isup = system.support_index[force.support]
            self.Y = finite_array(force.amplitude, (3,), f"{what}: support amplitude")
            if not np.any(self.Y):
                raise ModelError(f"{what}: support amplitude is zero: there is no response to follow")
            self.where, self.label = "support", f"support '{force.support}' moving {self.Y.tolist()} m·cos Ωt"
        elif isinstance(force, (tuple, list)) and len(force) == 2 and isinstance(force[0], str):
            self.i = system.coordinate_index(force[0])
            self.P = _nonzero(force[1], what)
            u = "N" if system.units[self.i] == "m" else "N·m"
            self.where, self.label = "joint", f"{number(self.P)} {u}·cos Ωt on '{force[0]}'"
        else:
            raise ModelError(f"{what}: expected (coordinate, amplitude), a PointForce or a SupportMotion, got "
                             f"{force!r}")
        for k, s in enumerate(system.supports):  # other supports must stand still: their motion is not at Ω
            if self.where == "support" and k == self.isup:
                continue
            for t in (0.0, 0.37, 1.9, 7.3):
                if np.any(np.asarray(s.motion.velocity(t), float)):
                    raise ModelError(f"forced_response_curve: support '{s.name}' moves by its own law, which is "
                                     "not periodic at Ω; excite it with SupportMotion or make it still")

    def shift(self, tau, omega, t):
        """Supports' offsets (n_supports × 6) making the excited one move as Y cos τ (None: no support)."""
        sys_ = self.system
        if not sys_.supports:
            return None
        out = np.zeros((len(sys_.supports), 6))
        for k, s in enumerate(sys_.supports):
            p, v = np.asarray(s.motion.position(t), float), np.asarray(s.motion.velocity(t), float)
            out[k, :3], out[k, 3:] = -p, -v
            if self.where == "support" and k == self.isup:
                out[k, :3] += self.Y * math.cos(tau)
                out[k, 3:] += -omega * self.Y * math.sin(tau)
        return out

    def force(self, q, tau):
        """Generalized force of a joint or point excitation at τ (N or N·m per coordinate)."""
        if self.where == "joint":
            f = np.zeros(self.system.nv)
            f[self.i] = self.P * math.cos(tau)
            return f
        if self.where == "point":
            return point_jacobian(self.system, q, [self.point]).T @ self.F * math.cos(tau)
        return np.zeros(self.system.nv)

    def forces(self, Q, tau):
        """:meth:`force` at each row of Q and τ (rows of N or N·m)."""
        if self.where == "joint":
            f = np.zeros((len(tau), self.system.nv))
            f[:, self.i] = self.P * np.cos(tau)
            return f
        return np.array([self.force(q, t) for q, t in zip(Q, tau)])


def _nonzero(amplitude, what):
    a = scalar(amplitude, f"{what}: amplitude")
    if a == 0.0:
        raise ModelError(f"{what}: amplitude is zero: there is no response to follow")
    return a


class Balance:
    """The H-harmonic balance of one system and excitation: residual, Jacobian, Hill's matrices."""

    def __init__(self, system, excitation, q_eq, H):
        self.system, self.exc, self.q_eq, self.H, self.n = system, excitation, q_eq, H, system.nv
        self.N = N = 4 * H + 4
        self.tau = 2 * np.pi * np.arange(N) / N
        self.E, self.E1, self.E2 = fourier_basis(self.tau, H)
        w = np.full(2 * H + 1, 2.0 / N)
        w[0] = 1.0 / N
        self.P = w[:, None] * self.E.T  # Galerkin projection: exact coefficients of a trig polynomial ≤ H
        self.k, self.iq = system.additive_coordinates
        self.h = steps(system, FD_STEP)
        self.support = excitation.where == "support"
        self.charted = bool(system.curved_coordinates)  # q ⊕ x is no sum on some joints
        self._memo, self._kept = None, OrderedDict()
        X0 = np.zeros((2 * H + 1) * self.n)
        r0 = self._samples(X0, 1.0)[3]
        self.scale = max(float(np.max(np.abs(r0))), 1e-300)  # the excitation's generalized force

    def _samples(self, X, omega):
        Xm = X.reshape(2 * self.H + 1, self.n)
        x, xd, xdd = self.E @ Xm, omega * (self.E1 @ Xm), omega**2 * (self.E2 @ Xm)
        if self.charted:
            r = np.array([self._sample(j, x[j], xd[j], xdd[j], omega) for j in range(self.N)])
            return x, xd, xdd, r
        Q = np.repeat(self.q_eq[None, :], self.N, axis=0)
        Q[:, self.iq] += x[:, self.k]  # q_eq ⊕ x: a sum on these joints
        t, shift = self._times(omega)
        tau, F = dynamics.inverse_dynamics_rows(self.system, self.system.workspace(), Q, xd, xdd, t, shift)
        return Q, xd, xdd, tau - F - self.exc.forces(Q, self.tau)

    def _times(self, omega):
        """The samples' times t = τ/Ω (s) and the supports' offsets there (None: no support)."""
        t = self.tau / omega
        if not self.system.supports:
            return t, None
        return t, np.array([self.exc.shift(tau, omega, tj) for tau, tj in zip(self.tau, t)])

    def _state(self, x, xd, xdd):
        """(q, v, a) of the tangent coordinates x and their rates on a curved group: q = q_eq ⊕ x,
        v = J(x) ẋ and a = J(x) ẍ + (∂J/∂x · ẋ) ẋ with J = ∂(q_eq ⊕ x)/∂x (``pin.dIntegrate``), its derivative
        along ẋ by a fourth-order central difference."""
        model = self.system.model
        J = pin.dIntegrate(model, self.q_eq, x, pin.ARG1)
        e = 1e-3 / max(float(np.linalg.norm(xd)), 1e-300)
        dJ = derivative(lambda s: pin.dIntegrate(model, self.q_eq, x + s * xd, pin.ARG1), 0.0, e, order=4)
        return pin.integrate(model, self.q_eq, x), J @ xd, J @ xdd + dJ @ xd

    def _sample(self, j, x, xd, xdd, omega):
        """The time residual at sample j as a function of the tangent coordinates and their rates."""
        tau = self.tau[j]
        t = tau / omega
        q, v, a = self._state(x, xd, xdd)
        return (dynamics.inverse_dynamics(self.system, self.system.workspace(), q, v, a, t,
                                          self.exc.shift(tau, omega, t)) - self.exc.force(q, tau))

    def residual(self, X, omega):
        """R (the harmonics of the time residual, flattened) / the excitation's force scale."""
        return (self.P @ self._samples(X, omega)[3]).ravel() / self.scale

    def derivatives(self, X, omega):
        """Per sample: r, K = ∂r/∂q, C = ∂r/∂v, M = ∂r/∂a (kept for the latest points, up to KEPT_BYTES: the
        continuation's tangent, the truncation step and Hill's matrices ask at the same branch points)."""
        key = (X.tobytes(), omega)
        if key in self._kept:
            return self._kept[key]
        out = self._evaluate(X, omega)
        self._kept[key] = out
        size = sum(a.nbytes for a in out)
        while len(self._kept) > 1 and size * len(self._kept) > KEPT_BYTES:
            self._kept.popitem(last=False)
        return out

    def _evaluate(self, X, omega):
        Q, xd, xdd, r = self._samples(X, omega)
        N, n, sys_, ws = self.N, self.n, self.system, self.system.workspace()
        K, C, M = np.empty((N, n, n)), np.empty((N, n, n)), np.empty((N, n, n))
        if self.charted:  # ∂/∂x, ∂/∂ẋ, ∂/∂ẍ of each sample's residual by central differences
            for j in range(N):
                K[j] = vector_derivative(lambda y: self._sample(j, y, xd[j], xdd[j], omega), Q[j], self.h)
                C[j] = vector_derivative(lambda y: self._sample(j, Q[j], y, xdd[j], omega), xd[j], self.h)
                M[j] = vector_derivative(lambda y: self._sample(j, Q[j], xd[j], y, omega), xdd[j], self.h)
            return xd, xdd, r, K, C, M
        t, shift = self._times(omega)
        K, C = analytic_derivatives_rows(sys_, Q, xd, xdd, t, shift)
        for j, tau in enumerate(self.tau):
            M[j] = dynamics.mass_matrix(sys_.model, ws.data, Q[j])
            if self.exc.where == "point":  # J(q)ᵀF turns with the body: its own ∂/∂q, by differences
                K[j] -= tangent_derivative(sys_, lambda q: self.exc.force(q, tau), Q[j], self.h)
        return xd, xdd, r, K, C, M

    def jacobian(self, X, omega, derivatives=None):
        """[∂R/∂X, ∂R/∂Ω] / the force scale (from the given per-sample ``derivatives`` if any)."""
        key = (X.tobytes(), omega)
        if derivatives is None and self._memo is not None and self._memo[0] == key:
            return self._memo[1]
        xd, xdd, r, K, C, M = self.derivatives(X, omega) if derivatives is None else derivatives
        JX = self._galerkin((K, self.E), (C, omega * self.E1), (M, omega**2 * self.E2))
        if self.support:  # the support's velocity Ω·Y·sin τ depends on Ω too: a central difference
            d = 1e-6 * omega
            JW = derivative(lambda w: self.residual(X, w), omega, d) * self.scale
        else:  # ẋ ∝ Ω, ẍ ∝ Ω²
            JW = (self.P @ (np.einsum("jpi,ji->jp", C, xd) + 2 * np.einsum("jpi,ji->jp", M, xdd))).ravel() / omega
        out = np.column_stack([JX, JW]) / self.scale
        if derivatives is None:
            self._memo = (key, out)
        return out

    def _galerkin(self, *terms):
        """The Galerkin matrix Σ P · diag_j(A_j) · B of the per-sample n × n matrices A_j and sample bases B:
        rows (harmonic, equation), columns (harmonic, coordinate), as X is ordered."""
        W = sum(A[:, :, :, None] * B[:, None, None, :] for A, B in terms)  # (N, n, n, 2H + 1)
        G = np.tensordot(self.P, W, axes=(1, 0))  # (2H + 1, n, n, 2H + 1): (a, p, i, b)
        m = (2 * self.H + 1) * self.n
        return G.transpose(0, 1, 3, 2).reshape(m, m)

    def hill_matrices(self, X, omega):
        """(Δ₀, Δ₁, Δ₂) of Hill's quadratic eigenproblem (Δ₀ + λΔ₁ + λ²Δ₂) Y = 0 at this solution."""
        xd, xdd, r, K, C, M = self.derivatives(X, omega)
        D0 = self.jacobian(X, omega)[:, :X.size] * self.scale
        D1 = self._galerkin((C, self.E), (M, 2 * omega * self.E1))
        D2 = self._galerkin((M, self.E))
        return D0, D1, D2

    def hill(self, X, omega, vectors=False):
        """The 2n Floquet multipliers by Hill's method, by decreasing modulus (and, with ``vectors``, their
        exponents λ and the eigenvectors Y, in that order)."""
        m, n = X.size, self.n
        D0, D1, D2 = self.hill_matrices(X, omega)
        A = np.block([[np.zeros((m, m)), np.eye(m)],
                      [-np.linalg.solve(D2, D0), -np.linalg.solve(D2, D1)]])
        lam, V = np.linalg.eig(A)
        # each exponent appears shifted by ikΩ; keep the 2n whose eigenvectors, in complex exponentials
        # e^{ikτ}, are centred nearest to k = 0 (a real exponent of the resonant harmonic weighs on k = ±1
        # alike), ties (the same nearest k) to the least |Im λ| (a symmetric scene's truncated constant mode is
        # centred on 0 too, far from |Im λ| ≤ Ω/2), skipping copies of one already kept (λ' − λ ≈ ikΩ)
        Y = V[:m].reshape(2 * self.H + 1, n, 2 * m)
        w0 = (np.abs(Y[0]) ** 2).sum(axis=0)
        wp = (np.abs(Y[1::2] - 1j * Y[2::2]) ** 2).sum(axis=1) / 4  # k = +1..H
        wm = (np.abs(Y[1::2] + 1j * Y[2::2]) ** 2).sum(axis=1) / 4  # k = −1..−H
        k = np.arange(1, self.H + 1)[:, None]
        centroid = (k * (wp - wm)).sum(axis=0) / np.maximum(w0 + (wp + wm).sum(axis=0), 1e-300)
        keep = []
        for j in np.lexsort((np.abs(lam.imag), np.floor(np.abs(centroid) + 0.5))):
            shift = (lam[j] - lam[keep]) / (1j * omega)
            if not np.any((np.abs(shift.imag) <= 1e-6) & (np.abs(shift.real - np.round(shift.real)) <= 1e-6)):
                keep.append(j)
            if len(keep) == 2 * n:
                break
        mu = np.exp(lam[keep] * 2 * np.pi / omega)
        order = np.argsort(-np.abs(mu), kind="stable")
        if vectors:
            return mu[order], lam[keep][order], V[:m, keep][:, order]
        return mu[order]

    def refined_multipliers(self, X2, omega, lam, Y):
        """The multipliers of the 2H + 1 balance (``self`` is it) at X2, from the H ones' exponents ``lam`` and
        eigenvectors ``Y`` (H harmonics) by nonlinear inverse iteration on its Hill problem (one complex solve
        per step, no eigenproblem of the larger size)."""
        D0, D1, D2 = self.hill_matrices(X2, omega)
        out = np.empty(len(lam), complex)
        H = (Y.shape[0] // self.n - 1) // 2
        for k, (l, y) in enumerate(zip(lam, Y.T)):
            w = embed(y, H, self.H, self.n)
            w = w / np.linalg.norm(w)
            y = w.copy()
            for _ in range(8):
                L, dL = D0 + l * D1 + l * l * D2, D1 + 2 * l * D2
                try:
                    u = np.linalg.solve(L, dL @ y)
                except np.linalg.LinAlgError:  # λ is an exact eigenvalue
                    break
                step = (np.conj(w) @ y) / (np.conj(w) @ u)
                l, y = l - step, u / (np.conj(w) @ u)
                if abs(step) <= 1e-14 * max(abs(l), omega):
                    break
            out[k] = np.exp(l * 2 * np.pi / omega)
        return out

    def amplitude(self, X, c):
        """max over a period of |x_c(τ)| (m or rad), the maximum refined by Newton on dx/dτ = 0."""
        a = X.reshape(2 * self.H + 1, self.n)[:, c]
        k = np.arange(1, self.H + 1)
        ac, as_ = a[1::2], a[2::2]
        grid, E = sampled_basis(self.H)
        vals = E @ a
        j = int(np.argmax(np.abs(vals)))
        tau, best = grid[j], abs(vals[j])
        for _ in range(8):
            d1 = np.sum(k * (-ac * np.sin(k * tau) + as_ * np.cos(k * tau)))
            d2 = np.sum(k**2 * (-ac * np.cos(k * tau) - as_ * np.sin(k * tau)))
            if d2 == 0.0:
                break
            tau -= d1 / d2
        val = abs(a[0] + np.sum(ac * np.cos(k * tau) + as_ * np.sin(k * tau)))
        return float(max(val, best))

    def precision(self, X, omega, c):
        """The amplitude's precision at this point and Ω (m or rad): the balance's residual (the corrector's, ≤ its
        tolerance) plus its round-off — ε × the size of the terms in each sample's residual, |K x| + |C ẋ| + |M ẍ|
        + the excitation's and the static loads', projected — carried to the amplitude at fixed Ω through ∂R/∂X
        (Σ |gᵀ (∂R/∂X)⁻¹| (|R| + round-off), g the amplitude's gradient), plus the amplitude's own rounding.
        Infinite where ∂R/∂X is singular (a fold: the amplitude at that Ω is not a function of the residual)."""
        xd, xdd, r, K, C, M = self.derivatives(X, omega)
        m = 2 * self.H + 1
        x = self.E @ X.reshape(m, self.n)
        static = self.__dict__.get("_static")
        if static is None:
            sys_ = self.system
            static = self._static = dynamics.cancelling_terms(sys_, sys_.workspace(), self.q_eq,
                                                              np.zeros(self.n), np.zeros(self.n), 0.0)
        size = (np.einsum("jpi,ji->jp", np.abs(K), np.abs(x)) + np.einsum("jpi,ji->jp", np.abs(C), np.abs(xd))
                + np.einsum("jpi,ji->jp", np.abs(M), np.abs(xdd)) + np.abs(r) + static + self.scale)
        rounding = EPS * (np.abs(self.P) @ size).ravel() / self.scale
        R = np.abs(self.residual(X, omega))
        E = sampled_basis(self.H)[1]
        x_c = E @ X.reshape(m, self.n)[:, c]
        j = int(np.argmax(np.abs(x_c)))
        g = np.zeros(X.size)
        g.reshape(m, self.n)[:, c] = np.sign(x_c[j]) * E[j]
        try:
            z = np.linalg.solve(self.jacobian(X, omega)[:, :X.size].T, g)
        except np.linalg.LinAlgError:
            return math.inf
        A = float(np.abs(x_c[j]))
        return float(np.abs(z) @ (R + rounding)) + EPS * m * A if np.all(np.isfinite(z)) else math.inf

    def refined(self):
        """The balance with 2H + 1 harmonics (the next odd one too, which odd forces excite), made once."""
        big = self.__dict__.get("_refined")
        if big is None:
            big = self._refined = Balance.__new__(Balance)
            big.__dict__.update(self.__dict__)
            H2 = 2 * self.H + 1
            big.H, big.N = H2, 4 * H2 + 4
            big.tau = 2 * np.pi * np.arange(big.N) / big.N
            big.E, big.E1, big.E2 = fourier_basis(big.tau, H2)
            w = np.full(2 * H2 + 1, 2.0 / big.N)
            w[0] = 1.0 / big.N
            big.P, big._memo, big._kept, big._refined = w[:, None] * big.E.T, None, OrderedDict(), None
        return big

    def truncation(self, X, omega, c, at_omega=False):
        """(error, omega_error, X2, omega2): the estimated truncation errors of this point of the branch — one
        Newton step of the 2H + 1 balance from it, normal to the branch (the continuation's corrector: regular
        at folds too), its largest displacement of coordinate c over a period and its change of Ω — and the
        coefficients and Ω that step reaches. ``at_omega``: the step from the residual's harmonics above H alone
        (the rest is this balance's residual, :meth:`precision`), its error the larger of that and the same step at
        fixed Ω (the amplitude's error at this Ω: larger where the branch is steep, as just past a fold)."""
        t = np.linalg.svd(self.jacobian(X, omega))[2][-1]  # the branch's tangent (X, Ω)
        big = self.refined()
        X2 = embed(X, self.H, big.H, self.n)
        t2 = np.append(embed(t[:-1], self.H, big.H, self.n), t[-1])
        # the 2H + 1 Jacobian there from this balance's per-sample derivatives, interpolated to its samples
        # (the points between these: exact where they are trig polynomials of degree < N/2, as a cubic
        # force's 3x² at an H-harmonic x; elsewhere off by their harmonics above, in a step that is an estimate)
        xd, xdd, r = big._samples(X2, omega)[1:]
        K, C, M = (doubled(a) for a in self.derivatives(X, omega)[3:])
        A = np.vstack([big.jacobian(X2, omega, (xd, xdd, r, K, C, M)), t2])
        R2 = big.residual(X2, omega)
        b = np.append(-R2, 0.0)
        if at_omega:  # (the harmonics up to H carry this balance's own residual: the precision's, not truncation)
            R2[:X.size] = 0.0
            b = np.column_stack([b, np.append(-R2, 0.0)])  # (both steps from one factorisation of A)
        Y = np.linalg.lstsq(A, b, rcond=None)[0]
        dY = Y if Y.ndim == 1 else Y[:, 0]
        dX = dY[:-1]
        E = sampled_basis(big.H, 8)[1]

        def largest(d):  # largest displacement of coordinate c over a period (m or rad)
            return float(np.max(np.abs(E @ d.reshape(2 * big.H + 1, self.n)[:, c])))

        error = largest(dX)
        if at_omega:
            error = largest(Y[:-1, 1])
            try:
                error = max(error, largest(np.linalg.solve(A[:-1, :-1], -R2)))
            except np.linalg.LinAlgError:
                error = math.inf
        return error, float(abs(dY[-1])), X2 + dX, omega + float(dY[-1])


def fourier_basis(tau, H):
    """E, dE/dτ, d²E/dτ² at the samples τ: columns 1, cos τ, sin τ, …, cos Hτ, sin Hτ."""
    k = np.arange(1, H + 1)
    kt = np.multiply.outer(tau, k)
    c, s = np.cos(kt), np.sin(kt)
    N = len(tau)
    E, E1, E2 = np.zeros((N, 2 * H + 1)), np.zeros((N, 2 * H + 1)), np.zeros((N, 2 * H + 1))
    E[:, 0] = 1.0
    E[:, 1::2], E[:, 2::2] = c, s
    E1[:, 1::2], E1[:, 2::2] = -k * s, k * c
    E2[:, 1::2], E2[:, 2::2] = -k**2 * c, -k**2 * s
    return E, E1, E2


@functools.lru_cache(maxsize=64)
def sampled_basis(H, per=16):
    """(τ, E): max(64, per·(2H + 1)) uniform samples τ of a period (rad) and the Fourier basis E there (columns 1,
    cos τ, sin τ, …, cos Hτ, sin Hτ), made once per (H, per) and shared (read-only)."""
    tau = np.linspace(0, 2 * np.pi, max(64, per * (2 * H + 1)), endpoint=False)
    E = fourier_basis(tau, H)[0]
    tau.flags.writeable = E.flags.writeable = False
    return tau, E


def doubled(A):
    """Samples A (N × …, N even) of a trig polynomial of degree < N/2 at τ_j = 2πj/N, at the 2N points
    πj/N (theirs and the midpoints), by the FFT."""
    N = A.shape[0]
    c = np.fft.fft(A, axis=0)
    c[N // 2] = 0.0  # the Nyquist term cos(Nτ/2) vanishes at the midpoints
    k = np.fft.fftfreq(N, 1.0 / N).reshape((N,) + (1,) * (A.ndim - 1))
    out = np.empty((2 * N,) + A.shape[1:])
    out[0::2], out[1::2] = A, np.fft.ifft(c * np.exp(1j * np.pi * k / N), axis=0).real
    return out


def embed(X, H, H2, n):
    """The coefficients of H harmonics as those of H2 ≥ H (zeros above)."""
    out = np.zeros((2 * H2 + 1, n), dtype=X.dtype)
    out[:2 * H + 1] = X.reshape(2 * H + 1, n)
    return out.ravel()
