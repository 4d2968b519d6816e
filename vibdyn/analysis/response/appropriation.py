"""Modal appropriation: the force pattern that drives a single undamped mode in phase quadrature."""

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ...errors import ModelError
from .channels import channels
from .damping import damped_model


# ====================================================================== modal appropriation
@dataclass(frozen=True, eq=False)
class Appropriation:
    """The force pattern that drives one undamped mode alone (phase resonance).

    At ω = ω_r the generalized force F* = (ω_r C + D) φ_r gives exactly δq = −iφ_r: a pure quadrature
    response in the undamped mode shape, whatever the damping distribution, since (K − ω_r²M) φ_r = 0.
    When the exciters ``inputs`` can apply F* (``exact``), ``force`` is that pattern at ω_r. Otherwise
    ``force`` minimises the in-phase part of the response (multivariate mode indicator function: the
    smallest eigenvalue of Re Xᵀ Re X f = λ (Re Xᵀ Re X + Im Xᵀ Im X) f, X = Z(ω)⁻¹B) and ``omega`` is
    tuned to the minimum of λ near ω_r. The force is scaled so that the response's modal coordinate is −i.

    ``response``: computed δq (complex, nv) to ``force`` at ``omega``; ``in_phase`` = |Re δq| / |δq|
    (0 for a pure mode; √λ); ``mac``: MAC of Im δq with φ_r; ``residual``: backward residual of the solve.
    """

    mode: int
    omega: float
    omega_r: float
    force: np.ndarray
    inputs: tuple
    generalized_force: np.ndarray
    response: np.ndarray
    shape: np.ndarray
    in_phase: float
    mac: float
    exact: bool
    residual: float
    elapsed: float

    def __repr__(self):
        from ..._format import number, summary

        return summary("Appropriation", f"mode {self.mode}",
                       f"ω = {number(self.omega)} rad/s (ω_r {number(self.omega_r)})",
                       f"inputs {', '.join(self.inputs)}", f"in-phase {number(self.in_phase, digits=2)}")

    @property
    def frequency_hz(self):
        return self.omega / (2 * np.pi)


def appropriation(lin, mode, inputs=None, *, direction=None, damping=None):
    """Modal appropriation of mode ``mode`` (0-based, ascending ω) with exciters ``inputs`` (None: every
    coordinate; or coordinate names / body points with a direction) (:class:`Appropriation`)."""
    from scipy.optimize import minimize_scalar

    from ..modal import mac

    start = time.perf_counter()
    model = damped_model(lin, damping)
    m = model.modes
    if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)) or not 0 <= mode < m.n:
        raise ModelError(f"appropriation: mode must be an index from 0 to {m.n - 1}, got {mode!r}")
    if m.rigid[mode] or m.unstable[mode]:
        raise ModelError(f"appropriation: mode {mode} is {'a rigid-body' if m.rigid[mode] else 'an unstable'} "
                         "mode; it has no resonance to appropriate")
    phi, wr = m.shapes[:, mode], float(m.omega[mode])
    target = (wr * model.C + model.D) @ phi
    if not np.any(target):
        raise ModelError(f"appropriation: mode {mode} is undamped; any force at its frequency is unbounded")
    cin = channels(lin, inputs, direction, "inputs")
    B = cin.matrix.T
    f, *_ = np.linalg.lstsq(B, target, rcond=None)
    exact = bool(np.linalg.norm(B @ f - target) <= 1e-10 * np.linalg.norm(target))
    w = wr
    if not exact:
        if np.linalg.matrix_rank(B) < B.shape[1]:
            raise ModelError(f"appropriation: the exciters {', '.join(cin.labels)} are not independent")

        def mmif(x):
            X = sla.solve(model.z(x), B.astype(complex))
            R, Im = X.real, X.imag
            lam, V = sla.eigh(R.T @ R, R.T @ R + Im.T @ Im)
            return lam[0], V[:, 0]

        others = np.delete(m.omega[~m.rigid], np.flatnonzero(m.omega[~m.rigid] == wr)[:1])
        gap = np.abs(others - wr).min(initial=wr)
        lo, hi = wr - 0.5 * min(gap, wr), wr + 0.5 * gap
        w = float(minimize_scalar(lambda x: mmif(x)[0], bounds=(lo, hi), method="bounded",
                                  options={"xatol": 1e-10 * wr}).x)
        f = mmif(w)[1]
    F = B @ f
    Z = model.z(w)
    x = sla.solve(Z, F.astype(complex))
    scale = -(phi @ lin.M @ x.imag)  # modal coordinate of the quadrature part: make it −i
    if not abs(scale) > 0:
        raise ModelError(f"appropriation: the exciters {', '.join(cin.labels)} cannot excite mode {mode}")
    f, F, x = f / scale, F / scale, x / scale
    res = float(np.linalg.norm(Z @ x - F) / (np.linalg.norm(Z) * np.linalg.norm(x) + np.linalg.norm(F)))
    return Appropriation(mode, w, wr, f, cin.labels, F, x, phi, float(np.linalg.norm(x.real) / np.linalg.norm(x)),
                         float(mac(x.imag, phi)), exact, res, time.perf_counter() - start)


