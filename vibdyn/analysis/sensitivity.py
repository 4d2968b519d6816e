"""Design sensitivities of modes: how each natural frequency, damping ratio and mode shape moves with each
parameter of a scene (a mass, a stiffness, a damping, a centre of mass, a joint placement, gravity, a held
speed), with its error estimate.

The linear model's derivatives ∂M/∂p, ∂C/∂p, ∂K/∂p come from central differences of the whole pipeline —
the scene with p ± h and p ± 2h rebuilt, its operating point found again (a parameter that moves the static
pose changes K through it), linearised analytically — with the error of the h step estimated from the 2h one.
The modes' derivatives are then exact first-order perturbation formulas on the base modes:

- undamped ω² of K_s φ = ω² M φ (mass-normalised φ): ∂ω² = φᵀ(∂K_s − ω² ∂M)φ, ∂ω = ∂ω²/(2ω); a repeated
  frequency's derivatives are the eigenvalues of Φ_cᵀ(∂K_s − ω² ∂M)Φ_c over its subspace;
- shapes by Nelson's method (distinct frequencies; the derivative of a repeated mode's shape is not unique);
- damped eigenvalues λ of the state matrix A: ∂λ = wᴴ ∂A v / wᴴ v (left w, right v), then ω_n = |λ| and
  ζ = −Re λ / |λ|.

Units: ∂ω/∂p in rad/s per the parameter's unit (``Sensitivity.units``), ∂ζ/∂p per that unit; every error is
absolute, in the unit of its quantity.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import scipy.linalg as sla

from .._check import builder_values, scene_builder
from .._deprecation import Renamed, former_names
from ..defaults import EPS
from ..description import parameters as _parameters
from ..description.scene import Scene
from ..errors import ConvergenceError, ModelError
from ..model.fd import round_off
from ..model.system import System
from .linearize import LinearModel
from .modal import Modes, invariant_pair
from .parameter_differences import STEP, Pipeline, differences_along, richardson, step


@former_names(**{name: f"d_{name}" for name in ("omega", "omega_error", "omega2", "omega2_error", "eigenvalues",
                                                 "eigenvalues_error", "omega_n", "omega_n_error", "zeta", "zeta_error",
                                                 "shapes", "shapes_error")})
@dataclass(frozen=True, eq=False)
class Sensitivity:
    """Derivatives of the modes of a linear model with respect to named parameters.

    Per mode (rows: the modes of the linear model asked about — a held or looped model's own, in the order of
    its :class:`~vibdyn.analysis.modal.Modes`) and parameter (columns), each derivative named ``d_`` and its
    quantity (as ``dM``, ``dK``): ``d_omega`` ∂ω/∂p of the undamped natural frequencies ``omega0`` (rad/s per
    unit of p; of the growth rate √|ω²| (1/s) where ``unstable``) and ``d_omega_error`` (absolute, same unit);
    ``d_omega2`` ∂ω²/∂p (rad²/s² per unit); ``d_shapes`` ∂φ/∂p (nv × n_modes × n_params, of the mass-normalised
    shapes in the coordinates of ``modes``, a reduced model's independent ones; zero where ``repeated``: a
    repeated mode's shape derivative is not unique) with ``d_shapes_error``. Damped modes (``d_omega_n``,
    ``d_zeta``: rows of the modes' damped eigenvalues): ∂ω_n/∂p (rad/s per unit), ∂ζ/∂p (1 per unit), ∂λ/∂p
    (``d_eigenvalues``, 1/s per unit) with their absolute errors (``defective``: a pair at critical damping).
    ``dM``, ``dC``, ``dK`` (n_params × nv × nv) and their errors ``dM_error`` …: the linear model's derivatives.
    """

    params: tuple
    units: tuple  # unit of each parameter
    values: np.ndarray  # each parameter's value (SI)
    omega0: np.ndarray  # the base undamped ω (rad/s)
    d_omega: np.ndarray  # ∂ω/∂p (rad/s per unit)
    d_omega_error: np.ndarray
    d_omega2: np.ndarray
    d_omega2_error: np.ndarray
    repeated: np.ndarray  # per mode: its frequency is repeated (derivatives over the subspace)
    d_eigenvalues: np.ndarray  # ∂λ/∂p of the damped eigenvalues (n_damped × n_params, 1/s per unit)
    d_eigenvalues_error: np.ndarray
    d_omega_n: np.ndarray
    d_omega_n_error: np.ndarray
    d_zeta: np.ndarray
    d_zeta_error: np.ndarray
    dM: np.ndarray = field(repr=False)
    dC: np.ndarray = field(repr=False)
    dK: np.ndarray = field(repr=False)
    dM_error: np.ndarray = field(repr=False)
    dC_error: np.ndarray = field(repr=False)
    dK_error: np.ndarray = field(repr=False)
    steps: np.ndarray = field(repr=False)  # the difference step of each parameter (its unit)
    method: str = "pipeline"
    elapsed: float = 0.0  # s
    note: str = ""
    modes: Any = field(default=None, repr=False)  # the base modes the derivatives are of
    nelson: Any = field(default=None, repr=False)  # () -> (∂φ, its error): computed on first use
    #: per mode: ω² < 0, so ``omega0`` is the growth rate √|ω²| (1/s) and ``d_omega`` its derivative
    unstable: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    #: per damped mode: its eigenvalue is repeated and not diagonalisable within the error (a defective pair,
    #: critical damping): ``d_eigenvalues`` is then the derivative of the pair's mean ½(λ₁ + λ₂) (well defined),
    #: and ``d_omega_n``, ``d_zeta`` are not defined there (their errors inf)
    defective: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))

    @cached_property
    def _shape_derivatives(self):
        return self.nelson()

    @property
    def d_shapes(self) -> np.ndarray:
        """∂φ/∂p of the mass-normalised shapes (nv × n_modes × n_params, per the parameter's unit; 0 where
        ``repeated`` or rigid), by Nelson's method (computed on first use)."""
        return self._shape_derivatives[0]

    @property
    def d_shapes_error(self) -> np.ndarray:
        """Absolute error of :attr:`d_shapes` (same shape)."""
        return self._shape_derivatives[1]

    @property
    def normalised(self) -> np.ndarray:
        """(p/ω) ∂ω/∂p per mode and parameter (dimensionless: the % change of ω per % change of p; 0 for a rigid
        mode)."""
        w = self.omega0[:, None]
        return np.where(w > 0, self.d_omega * self.values[None, :] / np.where(w > 0, w, 1.0), 0.0)

    error = Renamed("relative_error")

    @property
    def relative_error(self) -> float:
        """Largest error of ∂ω/∂p relative to the largest |∂ω/∂p| of its parameter."""
        scale = np.maximum(np.abs(self.d_omega).max(axis=0, initial=0.0), 1e-300)
        return float((self.d_omega_error / scale).max(initial=0.0))

    def column(self, param: str) -> int:
        try:
            return self.params.index(param)
        except ValueError:
            from .._check import unknown_name

            raise unknown_name(param, self.params, "parameter", "parameters", "sensitivity") from None

    def to_dict(self) -> dict[str, Any]:
        return {"params": list(self.params), "units": list(self.units), "values": self.values.tolist(),
                "omega_rad_s": self.omega0.tolist(), "d_omega_rad_s_per_unit": self.d_omega.tolist(),
                "d_omega_error_rad_s_per_unit": self.d_omega_error.tolist(), "normalised": self.normalised.tolist(),
                "d_zeta_per_unit": self.d_zeta.tolist(), "d_zeta_error_per_unit": self.d_zeta_error.tolist(),
                "d_omega_n_rad_s_per_unit": self.d_omega_n.tolist(), "repeated": self.repeated.tolist(),
                "unstable": self.unstable.tolist(), "defective": self.defective.tolist(),
                "d_eigenvalues_1_s_per_unit": [[[z.real, z.imag] for z in row] for row in self.d_eigenvalues],
                "d_eigenvalues_error_1_s_per_unit": self.d_eigenvalues_error.tolist(),
                "method": self.method, "elapsed_s": self.elapsed, "note": self.note}

    def __str__(self) -> str:
        from .._format import table

        rows = []
        for i, w in enumerate(self.omega0):
            for j, p in enumerate(self.params):
                rows.append([str(i + 1), f"{w:.6g}", p, self.units[j], f"{self.d_omega[i, j]:.6g}",
                             f"{self.d_omega_error[i, j]:.1e}", f"{self.normalised[i, j]:.4g}"])
                if self.unstable.size and self.unstable[i]:
                    rows[-1][1] += " (growth rate, 1/s)"
        head = ["mode", "ω (rad/s)", "parameter", "unit", "∂ω/∂p (rad/s per unit)", "error (rad/s per unit)",
                "(p/ω) ∂ω/∂p"]
        return ("\n".join(table(head, rows)) + f"\n{self.method}, {self.elapsed * 1e3:.1f} ms"
                + (f"\nnote: {self.note}" if self.note else ""))

    def __repr__(self) -> str:
        from .._format import duration, number, summary

        return summary("Sensitivity", f"{self.d_omega.shape[0]} modes × {len(self.params)} parameters",
                       f"relative error {number(self.relative_error, digits=2)}", duration(self.elapsed))


# ------------------------------------------------------------------------------------------ the pipeline
def _regime(system, lin):
    """How the base linear model's point is found again: "steady" (held speeds), "held", "static" or "pose"."""
    op = system.scene.operating_point or {}
    if not system.reduction.allows("operating points found from a state"):  # its declared one (drives' motion)
        return "declared", {}
    if op.get("held"):
        return "held", {}
    if np.any(lin.v):
        speeds = {system.coordinates[i]: float(lin.v[i]) for i in np.flatnonzero(lin.v)}
        return "steady", speeds
    # an equilibrium to the solver's own tolerance already (one inverse dynamics), else solved for again
    from ..defaults import EQUILIBRIUM_TOL

    unit = system.coordinate_scales
    r = system.inverse_dynamics(lin.q, np.zeros(system.nv), np.zeros(system.nv), lin.t)
    if np.abs(r).max(initial=0.0) <= EQUILIBRIUM_TOL * (np.abs(np.diag(lin.K)) * unit).max(initial=0.0):
        return "static", {}
    try:
        eq = system.equilibrium(q0=lin.q)
    except (ConvergenceError, ModelError):
        return "pose", {}
    d = np.abs(system.difference(eq.q, lin.q))
    return ("static" if np.all(d <= 1e-6 * system.coordinate_scales) else "pose"), {}


# ------------------------------------------------------------------------------------------ modes' derivatives
def _clusters(w2, dw2):
    """Groups of modes whose ω² are equal within their uncertainties (lists of indices, ascending)."""
    groups, n = [], len(w2)
    scale = max(np.abs(w2).max(initial=0.0), 1e-300)
    i = 0
    while i < n:
        j = i + 1
        while j < n and abs(w2[j] - w2[j - 1]) <= 10 * (dw2[j] + dw2[j - 1]) + 1e-10 * scale:
            j += 1
        groups.append(list(range(i, j)))
        i = j
    return groups


def _undamped(modes, dM, dK, eM, eK):
    """(∂ω², its error, ∂ω, its error, repeated, the shapes' derivatives as a function) over the parameters:
    every parameter at once (modal projections of all ∂K, ∂M as one batched product); a repeated frequency's
    cluster by the eigenvalues of its subspace's projection."""
    M, Ks, Phi, w2, _ = modes.eigenproblem
    w2 = np.where(modes.rigid, 0.0, w2)
    n_m, n_p = len(w2), len(dK)
    omega = modes.omega
    # absolute uncertainty of each ω² (the modes' own estimate: ω_error is relative, half that of ω²)
    dw2_base = np.where(modes.rigid, modes.omega_relative_error * max(np.abs(w2).max(initial=0.0), 1e-300),
                        2 * modes.omega_relative_error * np.abs(w2))
    groups = _clusters(w2, dw2_base)
    repeated = np.zeros(n_m, bool)
    cluster = np.arange(n_m)  # each mode's cluster label
    for g in groups:
        cluster[g] = g[0]
        repeated[g] = len(g) > 1
    G = Phi.T @ (dK @ Phi)  # n_p × n_m × n_m: Φᵀ ∂K_s Φ (the symmetric part of Φᵀ ∂K Φ)
    G += G.transpose(0, 2, 1)
    G *= 0.5
    mass = bool(np.any(dM)) or bool(np.any(eM))  # (a stiffness or a damping leaves M as it is)
    H = Phi.T @ dM @ Phi if mass else np.zeros_like(G)  # Φᵀ ∂M Φ
    T = G - H * w2[None, None, :] if mass else G  # column i: Φᵀ(∂K_s − ω_i² ∂M)φ_i
    d_w2 = np.diagonal(T, axis1=1, axis2=2).T.copy()  # n_m × n_p
    for g in groups:
        if len(g) > 1:
            wbar = float(np.mean(w2[g]))
            for j in range(n_p):
                S = G[j][np.ix_(g, g)] - wbar * H[j][np.ix_(g, g)]
                d_w2[g, j] = np.linalg.eigvalsh(0.5 * (S + S.T))
    A = np.abs(Phi)
    # |φ|ᵀ E |φ| per mode (a quadratic form: E's symmetric part is E's own value)
    quad = np.einsum("ai,pai->ip", A, eK @ A)
    if mass:
        quad += np.abs(w2)[:, None] * np.einsum("ai,pai->ip", A, eM @ A)
    # conditioning: each shape is known to δω²/gap (gap: to the nearest other cluster), which couples the mode to
    # its neighbours' terms of Φᵀ(∂K_s − ω² ∂M)Φ
    gaps = np.abs(w2[:, None] - w2[None, :])
    same = cluster[:, None] == cluster[None, :]
    gaps[same] = np.inf
    gap = gaps.min(axis=1, initial=np.inf)
    coupling = np.where(same[None, :, :], 0.0, np.abs(T)).max(axis=1, initial=0.0).T  # n_m × n_p
    cond = np.where(np.isfinite(gap), 2 * dw2_base / np.where(np.isfinite(gap), gap, 1.0), 0.0)[:, None] * coupling
    rel_w2 = np.where(modes.rigid, 0.0, 2 * modes.omega_relative_error)[:, None]  # (shapes normalised on M as known)
    H_diag = np.abs(np.diagonal(H, axis1=1, axis2=2).T)  # n_m × n_p
    e_w2 = (quad + dw2_base[:, None] * H_diag + cond + (8 * EPS + rel_w2) * np.abs(d_w2))
    for g in groups:
        if len(g) > 1:  # (a cluster's derivatives are its subspace's eigenvalues, ascending: not one mode's each)
            e_w2[g] = _cluster_error(g, A, eK, eM if mass else None, w2, H, e_w2[g])
    d_w, e_w = np.zeros((n_m, n_p)), np.zeros((n_m, n_p))
    pos = omega > 0
    # ω = √|ω²|: an unstable mode's (ω² < 0, ω its growth rate) moves as −∂ω²/(2ω)
    d_w[pos] = np.where(w2[pos] < 0, -1.0, 1.0)[:, None] * d_w2[pos] / (2 * omega[pos, None])
    e_w[pos] = e_w2[pos] / (2 * omega[pos, None]) + np.abs(d_w[pos]) * rel_w2[pos] / 2  # (ω's own error)
    zero = ~pos
    leaves = zero[:, None] & (np.abs(d_w2) > e_w2)
    # a mode at zero within its error ω_e that stays there: ∂ω = −ω φᵀ∂Mφ/2 for some ω ≤ ω_e (0 for a rigid one)
    e_w[zero] = np.where(leaves[zero], np.inf, 0.5 * np.asarray(modes.omega_error)[zero, None] * H_diag[zero])

    def shapes():
        sym = lambda X: 0.5 * (X + X.transpose(0, 2, 1))  # noqa: E731
        return _nelson(M, Ks, Phi, w2, sym(dK), dM, sym(eK), eM, d_w2, e_w2, dw2_base, repeated | ~pos)

    return d_w2, e_w2, d_w, e_w, repeated, shapes


def _cluster_error(g, A, eK, eM, w2, H, e_g):
    """The error of each derivative of a cluster g of repeated ω² (eigenvalues of its subspace's projection, in
    ascending order): the projection's own error bound (the 2-norm of |Φ_g|ᵀ E |Φ_g|, which moves every eigenvalue
    by at most that: Weyl), the largest of the members' other terms, and the spread of the cluster's ω² (the projection
    takes their mean for all) times ‖Φ_gᵀ ∂M Φ_g‖."""
    Ag = A[:, g]
    Q = Ag.T @ eK @ Ag  # n_p × k × k
    if eM is not None:
        Q = Q + np.abs(w2[g]).max() * (Ag.T @ eM @ Ag)
    quad_g = np.array([np.linalg.norm(q, 2) for q in Q])
    diag_q = np.einsum("pii->ip", Q)  # (the members' own quadratic forms, already in e_g)
    spread = float(np.ptp(w2[g]))
    Hg = np.array([np.linalg.norm(h[np.ix_(g, g)], 2) for h in H])
    return np.broadcast_to((e_g - diag_q).max(axis=0) + quad_g + spread * Hg, e_g.shape).copy()


def _nelson(M, Ks, Phi, w2, dKs, dM, eKs, eM, d_w2, e_w2, dw2_base, skip):
    """(∂φ, its error) by Nelson's method for every mode not in ``skip`` (repeated or rigid: zeros)."""
    nv, n_m = Phi.shape
    n_p = len(dKs)
    d_phi, e_phi = np.zeros((nv, n_m, n_p)), np.zeros((nv, n_m, n_p))
    aM = np.abs(M)
    for i in np.flatnonzero(~skip):
        phi = Phi[:, i]
        k = int(np.argmax(np.abs(phi)))
        keep = np.arange(nv) != k
        A_i = (Ks - w2[i] * M)[np.ix_(keep, keep)]
        try:
            lu = sla.lu_factor(A_i, check_finite=False)
        except (ValueError, np.linalg.LinAlgError):
            continue
        Ainv_abs = np.abs(sla.lu_solve(lu, np.eye(nv - 1), check_finite=False))
        F = -((dKs - w2[i] * dM) @ phi - d_w2[i][:, None] * (M @ phi)[None, :])  # n_p × nv
        v = np.zeros((n_p, nv))
        v[:, keep] = sla.lu_solve(lu, F[:, keep].T, check_finite=False).T
        c = -(v @ (M @ phi)) - 0.5 * (dM @ phi) @ phi
        d_phi[:, i, :] = (v + c[:, None] * phi[None, :]).T
        a = np.abs(phi)
        eF = (eKs + abs(w2[i]) * eM) @ a + e_w2[i][:, None] * (aM @ a)[None, :]  # n_p × nv
        ev = np.zeros((n_p, nv))
        ev[:, keep] = (Ainv_abs @ (eF[:, keep].T + dw2_base[i] * (aM[np.ix_(keep, keep)] @ np.abs(v[:, keep]).T))).T
        e_phi[:, i, :] = (ev + ((ev @ aM) @ a + 0.5 * (eM @ a) @ a)[:, None] * a[None, :]).T
    return d_phi, e_phi


def _damped(modes, lin, dM, dC, dK, eM, eC, eK):
    """(∂λ, error, ∂ω_n, error, ∂ζ, error, defective) of the damped eigenvalues (one per mode, as the modes list
    them); a defective pair's ∂λ is its mean's, its ∂ω_n and ∂ζ not defined (errors inf)."""
    lam_m = modes.damped_eigenvalues
    n_d, n_p, n = len(lam_m), len(dK), lin.nv
    if not n_d:
        z = np.zeros((0, n_p))
        return z.astype(complex), z, z, z, z, z, np.zeros(0, bool)
    A = lin.A
    lam, W, V = sla.eig(A, left=True, right=True)
    idx = [int(np.argmin(np.abs(lam - x))) for x in lam_m]
    defective = np.asarray(modes.defective, bool) if modes.defective.size else np.zeros(n_d, bool)
    err_m = np.asarray(modes.eigenvalue_error, float)
    zero = np.asarray(modes.damped_zero) if modes.damped_zero.size else np.zeros(n_d, bool)
    clusters = _damped_clusters(lam, lam_m, err_m, defective | zero)
    # a defective pair's eigenvalues have no derivative (they split as √δp): the pair's mean does, ½ trace(Y ∂A Z)
    # over its invariant subspace (Z right, Y left basis, Y Z = I)
    pairs = {}
    for r in np.flatnonzero(defective):
        near = np.sort(np.abs(lam - lam_m[r]))
        pairs[r] = invariant_pair(A, lam_m[r], 0.5 * (near[1] + near[2]) if near.size > 2 else np.inf)
    Minv = np.linalg.inv(lin.M)
    aMinv = np.abs(Minv)
    MiK, MiC = Minv @ lin.K, Minv @ lin.C
    d_l = np.zeros((n_d, n_p), complex)
    e_l = np.zeros((n_d, n_p))
    clustered = {r for rows, _ in clusters for r in rows}
    for j in range(n_p):
        dA = np.zeros_like(A)
        dA[n:, :n] = -Minv @ (dK[j] - dM[j] @ MiK)
        dA[n:, n:] = -Minv @ (dC[j] - dM[j] @ MiC)
        eA = np.zeros_like(A)
        eA[n:, :n] = aMinv @ (eK[j] + eM[j] @ np.abs(MiK))
        eA[n:, n:] = aMinv @ (eC[j] + eM[j] @ np.abs(MiC))
        eA += 4 * n * EPS * np.abs(dA)
        for rows, ks in clusters:  # a repeated, diagonalisable eigenvalue: its eigenspace's Y ∂A Z, ascending
            d_l[rows, j], e_l[rows, j] = _cluster_derivatives(W[:, ks], V[:, ks], dA, eA, lam_m[rows[0]], len(rows))
        for r, k in enumerate(idx):
            if r in pairs or r in clustered:
                continue
            w, v = W[:, k], V[:, k]
            den = w.conj() @ v
            d_l[r, j] = (w.conj() @ dA @ v) / den
            e_l[r, j] = (np.abs(w) @ eA @ np.abs(v)) / abs(den)
        for r, pair in pairs.items():
            if pair is None:  # (not isolated from the others: no mean to give)
                e_l[r, j] = np.inf
            else:
                Y, Z = pair[:2]
                d_l[r, j] = 0.5 * np.trace(Y @ dA @ Z)
                e_l[r, j] = 0.5 * np.trace(np.abs(Y) @ eA @ np.abs(Z))
    # the eigenvalue's own uncertainty moves the formula's terms: its error relative to its distance to the
    # nearest other eigenvalue (the conditioning of wᴴv: a nearly defective pair's derivatives are large and
    # known only to δλ/gap) or to |λ|, times the derivative
    gaps = np.abs(lam[:, None] - lam[None, :])
    np.fill_diagonal(gaps, np.inf)
    for rows, ks in clusters:  # (a cluster's members: their distance to the eigenvalues outside it)
        gaps[np.ix_(ks, ks)] = np.inf
    near = np.minimum(gaps.min(axis=1)[idx], np.abs(lam_m))
    near = np.where(defective, np.abs(lam_m), near)
    rel = np.where(near > 0, err_m / np.where(near > 0, near, 1.0), np.asarray(modes.eigenvalue_relative_error))
    e_l += np.abs(d_l) * rel[:, None] * 2
    d_l[zero] = 0.0  # (a zero within its error only, λ ≠ 0 — coalescing defective pairs — moves as none can say)
    e_l[zero] = np.where(lam_m[zero] == 0, 0.0, np.inf)[:, None]
    mag = np.abs(lam_m)[:, None]
    safe = np.where(mag > 0, mag, 1.0)
    d_wn = np.where(mag > 0, (np.conj(lam_m)[:, None] * d_l).real / safe, 0.0)
    e_wn = e_l.copy()
    d_z = np.where(mag > 0, -d_l.real / safe + lam_m.real[:, None] * d_wn / safe**2, 0.0)
    e_z = np.where(mag > 0, 2 * e_l / safe, 0.0)
    # |λ| and −Re λ/|λ| of each of a defective pair have no derivative there (one-sided ones differ): not defined
    e_wn[defective] = np.inf
    e_z[defective] = np.inf
    return d_l, e_l, d_wn, e_wn, d_z, e_z, defective


def _damped_clusters(lam, lam_m, err, skip):
    """[(rows, indices in lam)] of the modes' eigenvalues repeated within their errors (10 × their sum, as the
    undamped frequencies are clustered), but for ``skip`` ones (defective, zero); the usual case, none, costs one
    comparison."""
    close = np.abs(lam_m[:, None] - lam_m[None, :]) <= 10 * (err[:, None] + err[None, :])
    close &= ~skip[:, None] & ~skip[None, :]
    if np.count_nonzero(close) == np.count_nonzero(~skip):
        return []
    out, seen = [], set()
    for r in range(len(lam_m)):
        rows = [int(x) for x in np.flatnonzero(close[r])]
        if len(rows) < 2 or r in seen:
            continue
        seen.update(rows)
        radius = float(np.abs(lam_m[rows] - lam_m[r]).max() + 10 * err[rows].max())
        ks = [int(x) for x in np.flatnonzero(np.abs(lam - lam_m[r]) <= radius)]
        out.append((rows, ks))
    return out


def _cluster_derivatives(Wc, Vc, dA, eA, lam, k):
    """(∂λ, error) of a repeated, diagonalisable eigenvalue's members: the eigenvalues of B = Y ∂A Z over its
    eigenspace (Z = Vc right, Y = (Wcᴴ Vc)⁻¹ Wcᴴ left, Y Z = I), in ascending order of ∂|λ|; each error ‖|Y| E |Z|‖₂
    times the condition of B's eigenvectors (Bauer–Fike). Infinite where the rows and the eigenspace differ in size
    or its basis is singular (not diagonalisable after all)."""
    if Vc.shape[1] != k:
        return 0.0, np.inf
    try:
        Y = np.linalg.solve(Wc.conj().T @ Vc, Wc.conj().T)
        mu, X = np.linalg.eig(Y @ dA @ Vc)
        cond = np.linalg.cond(X)
    except np.linalg.LinAlgError:
        return 0.0, np.inf
    if not np.all(np.isfinite(mu)) or not np.isfinite(cond):
        return 0.0, np.inf
    mu = mu[np.lexsort((mu.imag, (np.conj(lam) * mu).real))]
    e = np.linalg.norm(np.abs(Y) @ eA @ np.abs(Vc), 2) * cond
    return mu, np.full(k, e)


# ------------------------------------------------------------------------------------------ entry point
def _scene_parameters(scene, name, system):
    """The scene's parameters ``name`` names; "<coordinate>.speed" of a coordinate that does not turn at the point
    analysed is refused saying why (a held speed is a parameter of a steady motion only)."""
    try:
        return _parameters.parameters(scene, [name])
    except ModelError:
        coordinate = name[:-len(".speed")] if isinstance(name, str) and name.endswith(".speed") else None
        if coordinate not in system.coordinates:
            raise
        unit = "m/s" if system.units[system.coordinate_index(coordinate)] == "m" else "rad/s"
        raise ModelError(
            f"sensitivity: '{name}': '{coordinate}' is at rest at this operating point (its speed is 0), and a speed "
            f"is a parameter only of a steady motion in which the coordinate turns; declare its speed "
            f"(scene.set_operating_point(cyclic={{'{coordinate}': <speed in {unit}>}}), or `cyclic = {{ {coordinate} = "
            f"<speed> }}` under [operating_point]), or differentiate at one: system.steady_motion({{'{coordinate}': "
            f"<speed>}}).linearize().modes().sensitivity(['{name}'])") from None


def sensitivity(source: Any, params: Any, *, unused: str = "raise") -> Sensitivity:
    """Derivatives of the modes with respect to ``params``.

    ``source``: a :class:`~vibdyn.analysis.modal.Modes` (what ``modes.sensitivity(params)`` passes), a
    LinearModel, a System or a Scene (its operating point), with ``params`` names ``"<body or
    element>.<attribute>"`` (:mod:`vibdyn.description.parameters`; ``"<coordinate>.speed"`` for a held speed
    of a steady motion, rad/s or m/s); or a callable ``build(**values)`` returning a Scene, with ``params`` a
    dict {keyword: value} (its units are the builder's). A parameter no mode depends on is refused, or with
    ``unused="drop"`` left out and named in ``note``. See the module docstring for the method.
    """
    if unused not in ("raise", "drop"):
        raise ModelError(f"sensitivity: unused must be 'raise' or 'drop', got {unused!r}")
    start = time.perf_counter()
    if isinstance(source, type):  # (a class is callable, but no builder: its instances are not scenes)
        raise ModelError(f"sensitivity: got the class {source.__name__} itself; pass an instance (a scene: "
                         f"{source.__name__}(...), its system, modes or linear model) or a builder function")
    if isinstance(source, Scene):
        source = source.build()
    if isinstance(source, Modes):
        base_modes = source
    elif isinstance(source, LinearModel):
        base_modes = source.modes()
    elif isinstance(source, System):
        base_modes = source.operating_point().linearize(method="analytic").modes()
    elif callable(source):
        return _of_builder(source, params, start, unused)
    else:
        raise ModelError(f"sensitivity: expected modes, a linear model, a system, a scene or a builder, got "
                         f"{type(source).__name__}")
    # the linear model the modes were solved on (a mechanism's or a held model's reduced one, not its tree): the
    # derivatives are of it, reduced as it is
    lin = base_modes.linear if base_modes.reduced is None else base_modes.reduced
    system = lin.system
    hold = lin.hold
    regime, speeds = _regime(system, getattr(lin, "tree", None) or lin)
    scene = system.scene
    requested = [params] if isinstance(params, str) else params
    if not isinstance(requested, (list, tuple)) or not requested:
        raise ModelError("sensitivity: params must be a list of names such as ['k.stiffness', 'cart.mass']")
    # each name in the order given: a held speed ("<coordinate>.speed") or the scene's parameters it names
    entries: list[tuple[Any, Any]] = []  # (Parameter, None) or (None, coordinate)
    for name in requested:
        coordinate = name[:-len(".speed")] if isinstance(name, str) and name.endswith(".speed") else None
        if coordinate in speeds:
            entries.append((None, coordinate))
        else:
            entries += [(p, None) for p in _scene_parameters(scene, name, system)]
    plist = [p for p, _ in entries if p is not None]
    names = [p.name if p is not None else f"{c}.speed" for p, c in entries]
    if len(set(names)) != len(names):
        raise ModelError(f"sensitivity: a parameter is named twice in {names}")
    units = [p.unit if p is not None else ("m/s" if system.units[system.coordinate_index(c)] == "m" else "rad/s")
             for p, c in entries]
    values = np.array([p.value if p is not None else speeds[c] for p, c in entries])
    nonneg = [p is not None and p.nonnegative for p, _ in entries]

    def make_scene(vals):
        sp = dict(speeds)
        sc_vals = []
        for (p, c), x in zip(entries, vals):
            if p is None:
                sp[c] = float(x)
            else:
                sc_vals.append(x)
        return _parameters.with_values(scene, plist, sc_vals), sp

    pipeline = Pipeline(make_scene, lin.q, lin.v, regime, hold, getattr(lin, "independent", None), names,
                        system.coordinates)
    # about a pose that is no equilibrium, the reference motion's acceleration: the free one there, which moves with
    # p (a stiffness changes it, and M(q) a with it: not the element's terms alone), or one given, kept
    moving = False
    if regime == "pose":
        free = system.accelerations(lin.q, lin.v, lin.t)
        if np.allclose(lin.a, free, rtol=1e-9, atol=1e-12 * np.abs(free).max(initial=0.0)):
            moving = bool(np.any(lin.a))
        else:
            pipeline.a0 = np.array(lin.a, float)
    steps = np.array([step(values[j], units[j], system.length_scale) for j in range(len(names))])
    direct: dict[int, tuple] = {}
    from ..model.derivatives import untrusted

    # (the element path takes Pinocchio's joint velocity derivatives, wrong for some joint types: not there)
    if system.reduction.allows("derivatives on the tree's elements") and not hold and not moving \
            and regime in ("static", "pose", "held") and not untrusted(system)[0].size:
        # a tree about a point it holds or finds again: the analytic model is the base, and a parameter a force
        # is proportional to (a stiffness, a damping) is differentiated on its element alone, no rebuild
        if lin.method != "analytic":
            lin = lin.relinearize("analytic")
            base_modes = lin.modes()
        for j, (p, _) in enumerate(entries):
            col = _linear_column(system, lin, p, regime) if p is not None else None
            if col is not None:
                direct[j] = col
    else:  # the base model again through the pipeline: in the coordinates the differences are in (a mechanism's
        lin = pipeline(values)  # independent motions), analytic
        if pipeline.independent is None and getattr(lin, "independent", None) is not None:
            pipeline.independent = np.asarray(lin.independent, dtype=int)
        base_modes = lin.modes()
        pipeline.base = lin
    return _assemble(pipeline, base_modes, lin, names, units, values, steps, nonneg, start, unused, direct)


def _linear_column(system, lin, p, regime):
    """(∂M, ∂C, ∂K, and their errors) along a parameter the force of one element is proportional to, from that
    element alone with the parameter 1 (no rebuild); at a static equilibrium the pose moves by
    dq/dp = K⁻¹ Q₁ (Q₁: the unit element's force there), and M, C, K along it (analytic models at q ± ε dq/dp
    and ± 2ε, differenced). None where the parameter is not such a one, or the pose's motion is singular."""
    import dataclasses

    from ..model.derivatives import element_terms

    element = system.scene.elements.get(p.owner)
    if element is None or p.attribute not in type(element).linear_in:
        return None
    old = getattr(element, p.attribute)
    unit = 1.0 if not isinstance(old, tuple) else tuple(
        1.0 if p.index is None or i == p.index else 0.0 for i in range(len(old)))
    group = type(element).group(system, [dataclasses.replace(element, **{p.attribute: unit})])
    Q1, K1, C1 = element_terms(system, [group], lin.q, lin.v, lin.t)
    n = lin.nv
    noise = 4 * n * EPS
    damped = bool(np.any(C1))
    dM, dC, dK = None, C1 if damped else None, K1  # (None: zero, no array made)
    eM, eC, eK = None, noise * np.abs(C1) if damped else None, noise * np.abs(K1)
    if regime == "static" and np.any(Q1):
        try:
            dq = np.linalg.solve(lin.K, Q1)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(dq)) or np.any(np.abs(lin.K @ dq - Q1) > 1e-8 * np.abs(Q1).max()):
            return None  # (a rigid or cyclic direction: the pipeline finds the pose again)
        scale = np.where(np.array([u == "m" for u in system.units]), system.length_scale, 1.0)
        eps = 1e-4 / max(float(np.max(np.abs(dq) / scale)), 1e-300)
        zero = np.zeros(n)
        at = {k: system.linearize(system.integrate(lin.q, k * eps * dq), a=zero, method="analytic")
              for k in (-2, -1, 1, 2)}
        D, T = richardson([(at[k].M, at[k].C, at[k].K) for k in (1, 2, -1, -2)], eps)
        for name, d1, t, X1 in zip(("M", "C", "K"), D, T, (at[1].M, at[1].C, at[1].K)):
            err = np.abs(t) / 3 + (at[1].K_error if name == "K" else 0.0) / eps + EPS * np.abs(X1) * round_off(eps)
            if name == "M":
                dM, eM = d1, err
            elif name == "C":
                dC, eC = (d1, err) if dC is None else (dC + d1, eC + err)
            else:
                dK, eK = dK + d1, eK + err
    return dM, dC, dK, eM, eC, eK


def _of_builder(build, params, start, unused):
    if not isinstance(params, dict) or not params:
        raise ModelError("sensitivity: with a builder, params must be a dict {keyword: value} of build(**params)")
    params, build = builder_values(params, "sensitivity"), scene_builder(build, "sensitivity")
    names = list(params)
    values = np.array([float(params[k]) for k in names])
    if not np.all(np.isfinite(values)):
        raise ModelError(f"sensitivity: parameter values must be finite, got {params!r}")
    scene0 = build(**params)
    system = scene0.build()
    tree = system.operating_point().linearize(method="analytic")
    regime, speeds = _regime(system, tree)
    if regime == "steady" and (scene0.operating_point or {}).get("cyclic"):
        regime = "declared"  # (the builder's scene declares its speeds: a parameter may be one, or move a found one)

    def make_scene(vals):
        return build(**{k: float(x) for k, x in zip(names, vals)}), speeds

    lin = getattr(tree, "reduced", tree)  # (a mechanism's: in its independent motions, as the pipeline's)
    pipeline = Pipeline(make_scene, tree.q, tree.v, regime, independent=getattr(lin, "independent", None),
                        names=names, coordinates=system.coordinates)
    pipeline.base = lin  # (the model at p, found as the pipeline finds it: not made again for the kink test)
    steps = np.array([STEP * (abs(x) if x else 1.0) for x in values])
    return _assemble(pipeline, lin.modes(), lin, names, ["(the builder's)"] * len(names), values, steps,
                     [False] * len(names), start, unused)


def _assemble(pipeline, base_modes, lin, names, units, values, steps, nonneg, start, unused="raise", direct=None):
    n_p, nv = len(names), lin.nv
    direct = direct or {}
    columns = []  # per parameter: (∂M, ∂C, ∂K, and their errors), None for a zero one
    notes = []
    pipeline.base_values = values
    for j in range(n_p):
        if j in direct:
            columns.append(direct[j])
        else:
            one_sided = nonneg[j] and values[j] - 2 * steps[j] < 0
            if pipeline.base is None and not one_sided:  # (the model at p: its left and right slopes compared)
                pipeline.base = pipeline(values)
            d, e, side = differences_along(pipeline, values, j, steps[j], one_sided, pipeline.base)
            columns.append((*d, *e))
            notes += [side] if side else []
    zero = np.zeros((nv, nv))
    # each of the six as one n_p × nv × nv stack; where every parameter's is zero, a view of one zero matrix
    dM, dC, dK, eM, eC, eK = (
        np.broadcast_to(zero, (n_p, nv, nv)) if all(c[k] is None for c in columns)
        else np.array([zero if c[k] is None else c[k] for c in columns]) for k in range(6))
    method = ("element" if len(direct) == n_p else "pipeline" if not direct else
              f"element ({len(direct)} parameters), pipeline ({n_p - len(direct)})")
    # a parameter nothing depends on cannot be designed with nor fitted: refused, or left out and named
    # (one that moves an entry over the parameter's size by more than the model's own error of that entry, with
    # a derivative beyond its error or a change beyond 1e-12 of the matrix: a stiffness of 1e-12 N/m beside one of
    # 1 moves ω₁ by its whole size)
    moved = np.zeros(n_p, bool)
    span = np.maximum(np.abs(values), steps)[:, None, None]
    for d, e, X, own in ((dM, eM, lin.M, 0.0), (dC, eC, lin.C, lin.C_error), (dK, eK, lin.K, lin.K_error)):
        change = np.abs(d) * span
        moved |= ((change > own + 10 * EPS * np.abs(X))
                  & ((np.abs(d) > e) | (change > 1e-12 * np.abs(X).max(initial=0.0)))).any(axis=(1, 2))
    unchanged = np.flatnonzero(~moved).tolist()
    dropped = ""
    if unchanged:
        listed = ", ".join(f"'{names[j]}'" for j in unchanged)
        if unused == "raise":
            raise ModelError(f"sensitivity: parameter {listed} does not change the linear model (M, C and K are "
                             "the same for nearby values): no mode depends on it")
        keep = [j for j in range(n_p) if j not in unchanged]
        if not keep:
            raise ModelError(f"sensitivity: no parameter named changes the linear model ({listed})")
        dropped = f"left out, as no mode depends on them: {listed}"
        names, units = [names[j] for j in keep], [units[j] for j in keep]
        values, steps = np.asarray(values)[keep], np.asarray(steps)[keep]
        dM, dC, dK, eM, eC, eK = (x[keep] for x in (dM, dC, dK, eM, eC, eK))
    d_w2, e_w2, d_w, e_w, repeated, nelson = _undamped(base_modes, dM, dK, eM, eK)
    d_l, e_l, d_wn, e_wn, d_z, e_z, defective = _damped(base_modes, lin, dM, dC, dK, eM, eC, eK)
    unstable = np.asarray(base_modes.unstable, bool).copy()
    notes = ([dropped] if dropped else []) + notes
    for mask, text in (
            (repeated, "modes {} have repeated frequencies: their derivatives are those of the subspace's eigenvalues "
                       "(ascending), their shape derivatives are not unique (given as 0)"),
            (defective, "damped modes {}: a repeated eigenvalue, not diagonalisable within the error (critical "
                        "damping): ∂λ/∂p, ∂ω_n/∂p and ∂ζ/∂p of each are not defined there (errors inf); d_eigenvalues "
                        "gives the pair's mean ½∂(λ₁ + λ₂)/∂p"),
            (unstable, "mode(s) {} unstable (ω² < 0): omega0 is the growth rate √|ω²| (1/s) and d_omega its "
                       "derivative −∂ω²/∂p / (2√|ω²|)")):
        if mask.any():
            notes.append(text.format(", ".join(str(i + 1) for i in np.flatnonzero(mask))))
    note = "; ".join(notes)
    if np.isinf(e_w).any():
        note += (("; " if note else "")
                 + "a rigid mode leaves zero: its ∂ω/∂p is unbounded (see omega2, rad²/s² per unit)")
    for name, arr in (("∂ω/∂p", d_w), ("∂ζ/∂p", d_z)):
        if not np.all(np.isfinite(arr)):
            raise ModelError(f"sensitivity: {name} is not finite (the scene's scales are too extreme)")
    return Sensitivity(tuple(names), tuple(units), np.asarray(values, float), base_modes.omega.copy(), d_w, e_w,
                       d_w2, e_w2, repeated, d_l, e_l, d_wn, e_wn, d_z, e_z, dM, dC, dK, eM, eC, eK,
                       np.asarray(steps), method, time.perf_counter() - start, note, base_modes, nelson,
                       unstable=unstable, defective=defective)
