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
from typing import Any, Callable

import numpy as np
import scipy.linalg as sla

from ..defaults import EPS
from ..description import parameters as _parameters
from ..errors import ConvergenceError, ModelError

#: relative step of the pipeline's differences (h = STEP·|p|, or STEP × the parameter's scale at p = 0)
STEP = 1e-4


@dataclass(frozen=True, eq=False)
class Sensitivity:
    """Derivatives of the modes of a linear model with respect to named parameters.

    Per mode (rows, in the order of :class:`~vibdyn.analysis.modal.Modes`) and parameter (columns):
    ``omega`` ∂ω/∂p of the undamped natural frequencies (rad/s per unit of p) and ``omega_error`` (absolute,
    same unit); ``omega2`` ∂ω²/∂p (rad²/s² per unit); ``shapes`` ∂φ/∂p (nv × n_modes × n_params, of the
    mass-normalised shapes, zero where ``repeated``: a repeated mode's shape derivative is not unique) with
    ``shapes_error``. Damped modes (``omega_n``, ``zeta``: rows of the modes' damped eigenvalues): ∂ω_n/∂p
    (rad/s per unit), ∂ζ/∂p (1 per unit), ∂λ/∂p (``eigenvalues``, 1/s per unit) with their absolute errors.
    ``dM``, ``dC``, ``dK`` (n_params × nv × nv) and their errors ``dM_error`` …: the linear model's derivatives.
    """

    params: tuple
    units: tuple  # unit of each parameter
    values: np.ndarray  # each parameter's value (SI)
    omega0: np.ndarray  # the base undamped ω (rad/s)
    omega: np.ndarray
    omega_error: np.ndarray
    omega2: np.ndarray
    omega2_error: np.ndarray
    shapes: np.ndarray
    shapes_error: np.ndarray
    repeated: np.ndarray  # per mode: its frequency is repeated (derivatives over the subspace)
    eigenvalues: np.ndarray  # ∂λ/∂p of the damped eigenvalues (n_damped × n_params, 1/s per unit)
    eigenvalues_error: np.ndarray
    omega_n: np.ndarray
    omega_n_error: np.ndarray
    zeta: np.ndarray
    zeta_error: np.ndarray
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

    @property
    def normalised(self) -> np.ndarray:
        """(p/ω) ∂ω/∂p per mode and parameter (dimensionless: the % change of ω per % change of p; 0 for a rigid
        mode)."""
        w = self.omega0[:, None]
        return np.where(w > 0, self.omega * self.values[None, :] / np.where(w > 0, w, 1.0), 0.0)

    @property
    def error(self) -> float:
        """Largest error of ∂ω/∂p relative to the largest |∂ω/∂p| of its parameter."""
        scale = np.maximum(np.abs(self.omega).max(axis=0, initial=0.0), 1e-300)
        return float((self.omega_error / scale).max(initial=0.0))

    def column(self, param: str) -> int:
        try:
            return self.params.index(param)
        except ValueError:
            from .._check import unknown_name

            raise unknown_name(param, self.params, "parameter", "parameters", "sensitivity") from None

    def to_dict(self) -> dict[str, Any]:
        return {"params": list(self.params), "units": list(self.units), "values": self.values.tolist(),
                "omega_rad_s": self.omega0.tolist(), "d_omega_rad_s_per_unit": self.omega.tolist(),
                "d_omega_error_rad_s_per_unit": self.omega_error.tolist(), "normalised": self.normalised.tolist(),
                "d_zeta_per_unit": self.zeta.tolist(), "d_zeta_error_per_unit": self.zeta_error.tolist(),
                "d_omega_n_rad_s_per_unit": self.omega_n.tolist(), "repeated": self.repeated.tolist(),
                "method": self.method, "elapsed_s": self.elapsed, "note": self.note}

    def __str__(self) -> str:
        from .._format import table

        rows = []
        for i, w in enumerate(self.omega0):
            for j, p in enumerate(self.params):
                rows.append([str(i + 1), f"{w:.6g}", p, self.units[j], f"{self.omega[i, j]:.6g}",
                             f"{self.omega_error[i, j]:.1e}", f"{self.normalised[i, j]:.4g}"])
        head = ["mode", "ω (rad/s)", "parameter", "unit", "∂ω/∂p (rad/s per unit)", "error (abs)", "(p/ω) ∂ω/∂p"]
        return ("\n".join(table(head, rows)) + f"\n{self.method}, {self.elapsed * 1e3:.1f} ms"
                + (f"\nnote: {self.note}" if self.note else ""))

    def __repr__(self) -> str:
        from .._format import duration, number, summary

        return summary("Sensitivity", f"{self.omega.shape[0]} modes × {len(self.params)} parameters",
                       f"error {number(self.error, digits=2)}", duration(self.elapsed))


# ------------------------------------------------------------------------------------------ the pipeline
class _Pipeline:
    """p -> (M, C, K with their errors) of the scene at p: rebuilt, its operating point found again as the
    base one was (static equilibrium from the base pose, the same held speeds, or the base pose held),
    linearised analytically (finite differences where the analytic path refuses)."""

    def __init__(self, make_scene: Callable, base_system, q0, v0, regime, speeds, names):
        self.make_scene, self.q0, self.v0 = make_scene, q0, v0
        self.regime, self.speeds, self.names = regime, speeds, names
        self.base_system = base_system

    def __call__(self, values):
        scene, speeds = self.make_scene(values)
        system = scene.build()
        if self.regime == "declared":
            op = system.operating_point()
        elif self.regime == "steady":
            op = system.steady_motion(speeds, q0=self.q0)
        elif self.regime == "static":
            op = system.equilibrium(q0=self.q0)
        elif self.regime == "held":
            op = system.held(self.q0, self.v0)
        else:
            op = self.q0
        try:
            lin = system.linearize(op, method="analytic") if self.regime != "pose" else \
                system.linearize(op, v=self.v0, method="analytic")
        except ModelError:
            lin = system.linearize(op, method="fd") if self.regime != "pose" else \
                system.linearize(op, v=self.v0, method="fd")
        return getattr(lin, "reduced", lin)  # a mechanism's: in its independent motions


def _regime(system, lin):
    """How the base linear model's point is found again: "steady" (held speeds), "held", "static" or "pose"."""
    op = system.scene.operating_point or {}
    if system.drives is not None:  # a driven scene: its declared operating point (the drives' motion)
        return "declared", {}
    if op.get("held"):
        return "held", {}
    if np.any(lin.v0):
        speeds = {system.coordinates[i]: float(lin.v0[i]) for i in np.flatnonzero(lin.v0)}
        return "steady", speeds
    try:
        eq = system.equilibrium(q0=lin.q0)
    except (ConvergenceError, ModelError):
        return "pose", {}
    d = np.abs(system.difference(eq.q, lin.q0))
    scale = np.where(np.array([u == "m" for u in system.units]), system.length_scale, 1.0) if d.size else d
    return ("static" if np.all(d <= 1e-6 * scale) else "pose"), {}


def _step(p: _parameters.Parameter | None, value, unit, length_scale):
    if value != 0:
        return STEP * abs(value)
    return STEP * (length_scale if unit == "m" else 1.0)


def _differences(pipeline, base_values, j, h, one_sided):
    """(D_h, D_2h, noise) of (M, C, K) along parameter j: central (or one-sided second order, at a bound)."""
    def at(x):
        vals = np.array(base_values, float)
        vals[j] = x
        lin = pipeline(vals)
        noise = (np.abs(lin.K_error), np.abs(lin.C_error), EPS * np.abs(lin.M) * lin.nv)
        return (lin.M, lin.C, lin.K), noise

    p = base_values[j]
    if one_sided:
        xs = [p, p + h, p + 2 * h, p + 4 * h]
        X = [at(x) for x in xs]
        Dh = [(-3 * a + 4 * b - c) / (2 * h) for a, b, c in zip(X[0][0], X[1][0], X[2][0])]
        D2 = [(-3 * a + 4 * c - d) / (4 * h) for a, c, d in zip(X[0][0], X[2][0], X[3][0])]
        noise = [(3 * n0 + 4 * n1 + n2) / (2 * h) for n0, n1, n2 in zip(X[0][1], X[1][1], X[2][1])]
    else:
        xs = [p - 2 * h, p - h, p + h, p + 2 * h]
        X = [at(x) for x in xs]
        Dh = [(b - a) / (2 * h) for a, b in zip(X[1][0], X[2][0])]
        D2 = [(b - a) / (4 * h) for a, b in zip(X[0][0], X[3][0])]
        noise = [(n1 + n2) / (2 * h) for n1, n2 in zip(X[1][1], X[2][1])]
    # (M, C, K) order in Dh; noise is (K, C, M): reorder to (M, C, K)
    noise = [noise[2], noise[1], noise[0]]
    err = [np.abs(a - b) / 3 + n for a, b, n in zip(Dh, D2, noise)]
    return Dh, err


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
    """(∂ω², its error, ∂ω, its error, ∂φ, its error, repeated) over the parameters."""
    M, Ks, Phi, w2, _ = modes.eigenproblem
    w2 = np.where(modes.rigid, 0.0, w2)
    n_m, n_p = len(w2), len(dK)
    omega = modes.omega
    # absolute uncertainty of each ω² (the modes' own estimate: ω_error is relative, half that of ω²)
    dw2_base = np.where(modes.rigid, modes.omega_error * max(np.abs(w2).max(initial=0.0), 1e-300),
                        2 * modes.omega_error * np.abs(w2))
    groups = _clusters(w2, dw2_base)
    repeated = np.zeros(n_m, bool)
    for g in groups:
        if len(g) > 1:
            repeated[g] = True
    A = np.abs(Phi)
    d_w2, e_w2 = np.zeros((n_m, n_p)), np.zeros((n_m, n_p))
    d_phi, e_phi = np.zeros((Phi.shape[0], n_m, n_p)), np.zeros((Phi.shape[0], n_m, n_p))
    gaps = np.full(n_m, np.inf)
    for g in groups:  # distance to the nearest other cluster
        others = [k for k in range(n_m) if k not in g]
        if others:
            gaps[g] = np.abs(w2[others][None, :] - w2[g][:, None]).min(axis=1)
    for j in range(n_p):
        dKs = 0.5 * (dK[j] + dK[j].T)
        eKs = 0.5 * (eK[j] + eK[j].T)
        for g in groups:
            wbar = float(np.mean(w2[g]))
            P = Phi[:, g]
            S = P.T @ (dKs - wbar * dM[j]) @ P
            vals = np.linalg.eigvalsh(0.5 * (S + S.T)) if len(g) > 1 else np.diag(S)
            d_w2[g, j] = vals
            quad = np.einsum("ik,ik->k", A[:, g], (eKs + abs(wbar) * eM[j]) @ A[:, g])
            # conditioning: the shapes are known to δω²/gap, coupling this mode to its neighbours' terms
            coupling = np.abs(Phi.T @ (dKs - wbar * dM[j]) @ P)
            coupling[g, :] = 0.0
            cond = 2 * dw2_base[g] / np.where(np.isfinite(gaps[g]), gaps[g], np.inf) * coupling.max(axis=0, initial=0.0)
            e_w2[g, j] = quad + dw2_base[g] * np.abs(np.diag(P.T @ dM[j] @ P)) + cond + 8 * EPS * np.abs(vals)
    d_w, e_w = np.zeros((n_m, n_p)), np.zeros((n_m, n_p))
    pos = omega > 0
    d_w[pos] = d_w2[pos] / (2 * omega[pos, None])
    e_w[pos] = e_w2[pos] / (2 * omega[pos, None])
    zero = ~pos
    leaves = zero[:, None] & (np.abs(d_w2) > e_w2)
    e_w[zero] = np.where(leaves[zero], np.inf, 0.0)
    # shapes: Nelson's method for distinct, non-rigid modes
    K_w = Ks
    for i in range(n_m):
        if repeated[i] or not pos[i]:
            continue
        phi = Phi[:, i]
        k = int(np.argmax(np.abs(phi)))
        keep = np.arange(len(phi)) != k
        A_i = (K_w - w2[i] * M)[np.ix_(keep, keep)]
        try:
            lu = sla.lu_factor(A_i)
            Ainv_abs = np.abs(sla.lu_solve(lu, np.eye(A_i.shape[0])))
        except (ValueError, np.linalg.LinAlgError):
            continue
        for j in range(n_p):
            dKs = 0.5 * (dK[j] + dK[j].T)
            F = -(dKs - w2[i] * dM[j] - d_w2[i, j] * M) @ phi
            v = np.zeros_like(phi)
            v[keep] = sla.lu_solve(lu, F[keep])
            c = -phi @ M @ v - 0.5 * phi @ dM[j] @ phi
            d_phi[:, i, j] = v + c * phi
            eF = (0.5 * (eK[j] + eK[j].T) + abs(w2[i]) * eM[j] + e_w2[i, j] * np.abs(M)) @ np.abs(phi)
            ev = np.zeros_like(phi)
            ev[keep] = Ainv_abs @ eF[keep] + Ainv_abs @ (dw2_base[i] * np.abs(M[np.ix_(keep, keep)]) @ np.abs(v[keep]))
            e_phi[:, i, j] = ev + (np.abs(phi) @ np.abs(M) @ ev + 0.5 * np.abs(phi) @ eM[j] @ np.abs(phi)) * np.abs(phi)
    return d_w2, e_w2, d_w, e_w, d_phi, e_phi, repeated


def _damped(modes, lin, dM, dC, dK, eM, eC, eK):
    """(∂λ, error, ∂ω_n, error, ∂ζ, error) of the damped eigenvalues (one per mode, as the modes list them)."""
    lam_m = modes.damped_eigenvalues
    n_d, n_p, n = len(lam_m), len(dK), lin.nv
    if not n_d:
        z = np.zeros((0, n_p))
        return z.astype(complex), z, z, z, z, z
    A = lin.A
    lam, W, V = sla.eig(A, left=True, right=True)
    idx = [int(np.argmin(np.abs(lam - x))) for x in lam_m]
    Minv = np.linalg.inv(lin.M)
    aMinv = np.abs(Minv)
    MiK, MiC = Minv @ lin.K, Minv @ lin.C
    d_l = np.zeros((n_d, n_p), complex)
    e_l = np.zeros((n_d, n_p))
    for j in range(n_p):
        dA = np.zeros_like(A)
        dA[n:, :n] = -Minv @ (dK[j] - dM[j] @ MiK)
        dA[n:, n:] = -Minv @ (dC[j] - dM[j] @ MiC)
        eA = np.zeros_like(A)
        eA[n:, :n] = aMinv @ (eK[j] + eM[j] @ np.abs(MiK))
        eA[n:, n:] = aMinv @ (eC[j] + eM[j] @ np.abs(MiC))
        eA += 4 * n * EPS * np.abs(dA)
        for r, k in enumerate(idx):
            w, v = W[:, k], V[:, k]
            den = w.conj() @ v
            d_l[r, j] = (w.conj() @ dA @ v) / den
            e_l[r, j] = (np.abs(w) @ eA @ np.abs(v)) / abs(den)
    # the eigenvalue's own uncertainty moves the formula's terms: its relative error times the derivative
    e_l += np.abs(d_l) * np.asarray(modes.eigenvalue_error)[:, None] * 2
    zero = np.asarray(modes.damped_zero) if modes.damped_zero.size else np.zeros(n_d, bool)
    d_l[zero] = 0.0
    e_l[zero] = 0.0
    mag = np.abs(lam_m)[:, None]
    safe = np.where(mag > 0, mag, 1.0)
    d_wn = np.where(mag > 0, (np.conj(lam_m)[:, None] * d_l).real / safe, 0.0)
    e_wn = e_l.copy()
    d_z = np.where(mag > 0, -d_l.real / safe + lam_m.real[:, None] * d_wn / safe**2, 0.0)
    e_z = np.where(mag > 0, 2 * e_l / safe, 0.0)
    return d_l, e_l, d_wn, e_wn, d_z, e_z


# ------------------------------------------------------------------------------------------ entry point
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
    from .modal import Modes

    if callable(source) and not hasattr(source, "build") and not isinstance(source, Modes) \
            and not hasattr(source, "linearize"):
        return _of_builder(source, params, start, unused)
    if hasattr(source, "build") and not hasattr(source, "linearize"):  # a Scene
        source = source.build()
    if isinstance(source, Modes):
        base_modes = source
    elif hasattr(source, "modes") and hasattr(source, "K"):  # a LinearModel
        base_modes = source.modes()
    elif hasattr(source, "operating_point"):  # a System
        base_modes = source.operating_point().linearize(method="analytic").modes()
    else:
        raise ModelError(f"sensitivity: expected modes, a linear model, a system, a scene or a builder, got "
                         f"{type(source).__name__}")
    lin = base_modes.linear
    system = lin.system
    regime, speeds = _regime(system, lin)
    scene = system.scene
    requested = [params] if isinstance(params, str) else params
    if not isinstance(requested, (list, tuple)) or not requested:
        raise ModelError("sensitivity: params must be a list of names such as ['k.stiffness', 'cart.mass']")
    # each name in the order given: a held speed ("<coordinate>.speed") or the scene's parameters it names
    entries = []  # (Parameter, None) or (None, coordinate)
    for name in requested:
        coordinate = name[:-len(".speed")] if isinstance(name, str) and name.endswith(".speed") else None
        if coordinate in speeds:
            entries.append((None, coordinate))
        else:
            entries += [(p, None) for p in _parameters.parameters(scene, [name])]
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

    pipeline = _Pipeline(make_scene, system, lin.q0, lin.v0, regime, speeds, names)
    steps = np.array([_step(None, values[j], units[j], system.length_scale) for j in range(len(names))])
    # the base model again through the pipeline: M, C, K, modes in the coordinates the differences are in (a
    # mechanism's independent motions), analytic
    lin = pipeline(values)
    return _assemble(pipeline, lin.modes(), lin, names, units, values, steps, nonneg, start, unused)


def _of_builder(build, params, start, unused):
    if not isinstance(params, dict) or not params:
        raise ModelError("sensitivity: with a builder, params must be a dict {keyword: value} of build(**params)")
    names = list(params)
    values = np.array([float(params[k]) for k in names])
    if not np.all(np.isfinite(values)):
        raise ModelError(f"sensitivity: parameter values must be finite, got {params!r}")
    scene0 = build(**params)
    system = scene0.build()
    lin = system.operating_point().linearize(method="analytic")
    base_modes = lin.modes()
    regime, speeds = _regime(system, lin)

    def make_scene(vals):
        return build(**{k: float(x) for k, x in zip(names, vals)}), speeds

    pipeline = _Pipeline(make_scene, system, lin.q0, lin.v0, regime, speeds, names)
    steps = np.array([STEP * (abs(x) if x else 1.0) for x in values])
    lin = pipeline(values)
    return _assemble(pipeline, lin.modes(), lin, names, ["(the builder's)"] * len(names), values, steps,
                     [False] * len(names), start, unused)


def _assemble(pipeline, base_modes, lin, names, units, values, steps, nonneg, start, unused="raise"):
    n_p, nv = len(names), lin.nv
    dM, dC, dK = (np.zeros((n_p, nv, nv)) for _ in range(3))
    eM, eC, eK = (np.zeros((n_p, nv, nv)) for _ in range(3))
    for j in range(n_p):
        one_sided = nonneg[j] and values[j] - 2 * steps[j] < 0
        (dM[j], dC[j], dK[j]), (eM[j], eC[j], eK[j]) = _differences(pipeline, values, j, steps[j], one_sided)
    # a parameter nothing depends on cannot be designed with nor fitted: refused, or left out and named
    unchanged = [j for j in range(n_p) if all(
        np.abs(d).max(initial=0.0) * max(abs(values[j]), steps[j]) <= 1e-12 * np.abs(X).max(initial=0.0)
        for d, X in ((dM[j], lin.M), (dC[j], lin.C), (dK[j], lin.K)))]
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
    d_w2, e_w2, d_w, e_w, d_phi, e_phi, repeated = _undamped(base_modes, dM, dK, eM, eK)
    d_l, e_l, d_wn, e_wn, d_z, e_z = _damped(base_modes, lin, dM, dC, dK, eM, eC, eK)
    note = dropped
    if repeated.any():
        listed = ", ".join(str(i + 1) for i in np.flatnonzero(repeated))
        note += ("; " if note else "") + (
            f"modes {listed} have repeated frequencies: their derivatives are those of the subspace's eigenvalues "
            "(ascending), their shape derivatives are not unique (given as 0)")
    if np.isinf(e_w).any():
        note += ("; " if note else "") + "a rigid mode leaves zero: its ∂ω/∂p is unbounded (see omega2, rad²/s² per unit)"
    for name, arr in (("∂ω/∂p", d_w), ("∂ζ/∂p", d_z)):
        if not np.all(np.isfinite(arr)):
            raise ModelError(f"sensitivity: {name} is not finite (the scene's scales are too extreme)")
    return Sensitivity(tuple(names), tuple(units), np.asarray(values, float), base_modes.omega.copy(), d_w, e_w,
                       d_w2, e_w2, d_phi, e_phi, repeated, d_l, e_l, d_wn, e_wn, d_z, e_z, dM, dC, dK, eM, eC, eK,
                       np.asarray(steps), "pipeline", time.perf_counter() - start, note, base_modes)
