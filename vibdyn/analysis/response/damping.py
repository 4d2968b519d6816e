"""Damping models of a response: the linear model's viscous C, none, or hysteretic (structural) D."""

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ..._check import finite_array, scalar
from ...errors import ModelError
from .channels import vector_label


# ====================================================================== damping models
@dataclass(frozen=True, eq=False)
class Hysteretic:
    """Hysteretic (structural) damping: a dynamic stiffness K − ω²M + iD with
    D = alpha·M + eta·K_s + MΦ diag(η_r ω_r²) ΦᵀM (``modal``: loss factor per undamped mode) + ``matrix``.

    ``Hysteretic(eta=0.02)`` is D = ηK; ``Hysteretic(alpha=a, eta=b)`` is D = aM + bK. The model's own
    viscous C is dropped unless ``viscous=True``. Frequency-domain only (no causal time response).
    """

    eta: float = 0.0
    alpha: float = 0.0
    modal: object = None
    matrix: object = None
    viscous: bool = False

    def __post_init__(self):
        object.__setattr__(self, "eta", scalar(self.eta, "hysteretic eta", nonnegative=True))
        object.__setattr__(self, "alpha", scalar(self.alpha, "hysteretic alpha", nonnegative=True))
        if self.modal is not None:
            m = finite_array(self.modal, None, "hysteretic modal loss factors")
            if np.any(m < 0):
                raise ModelError("hysteretic modal loss factors must be ≥ 0")
            object.__setattr__(self, "modal", m)
        if self.matrix is not None:
            object.__setattr__(self, "matrix", finite_array(self.matrix, (None, None), "hysteretic matrix D"))

    def damping_matrix(self, lin):
        """D (nv × nv) for a linear model."""
        D = self.alpha * lin.M + self.eta * lin.K_s
        if self.modal is not None:
            m = lin.modes()
            try:
                eta = np.broadcast_to(self.modal, m.omega.shape)
            except ValueError:
                raise ModelError(f"hysteretic modal loss factors: expected one number or {m.n} (one per mode), "
                                 f"got {self.modal.size}") from None
            MPhi = lin.M @ m.shapes
            D = D + MPhi @ np.diag(eta * m.omega2) @ MPhi.T
        if self.matrix is not None:
            if self.matrix.shape != lin.M.shape:
                raise ModelError(f"hysteretic matrix D: expected shape {lin.M.shape}, got {self.matrix.shape}")
            D = D + self.matrix
        return D

    def describe(self):
        parts = [f"{self.alpha:g} M"] if self.alpha else []
        parts += [f"{self.eta:g} K"] if self.eta else []
        parts += ["modal loss factors " + vector_label(self.modal)] if self.modal is not None else []
        parts += ["given matrix"] if self.matrix is not None else []
        return "hysteretic: D = " + (" + ".join(parts) or "0") + (" (with viscous C)" if self.viscous else "")


@dataclass(frozen=True, eq=False)
class DampedModel:
    """The matrices a response uses: the linear model (possibly reduced), its C and hysteretic D."""

    lin: object
    C: np.ndarray
    D: np.ndarray
    damping: str

    @property
    def M(self):
        return self.lin.M

    @property
    def K(self):
        return self.lin.K

    @cached_property
    def modes(self):
        return self.lin.modes()

    @cached_property
    def modal(self):
        """(Φ, ω², c_r, d_r, coupling): undamped modes, modal damping diag(ΦᵀCΦ), diag(ΦᵀDΦ), and the largest
        part the modal sum neglects (off-diagonal ΦᵀCΦ, ΦᵀDΦ, skew K) relative to the diagonal."""
        m = self.modes
        Phi = m.shapes
        Cm, Dm = Phi.T @ self.C @ Phi, Phi.T @ self.D @ Phi
        Nm = Phi.T @ self.lin.N @ Phi
        off = lambda X: np.abs(X - np.diag(np.diag(X))).max(initial=0.0)  # noqa: E731

        def ratio(X):
            o, d = off(X), np.abs(np.diag(X)).max(initial=0.0)
            return 0.0 if o == 0 else (o / d if d > 0 else np.inf)

        w2max = np.abs(m.omega2).max(initial=0.0)
        coupling = max(ratio(Cm), ratio(Dm), np.abs(Nm).max(initial=0.0) / w2max if w2max > 0 else 0.0)
        return Phi, m.omega2, np.diag(Cm).copy(), np.diag(Dm).copy(), float(coupling)

    def z(self, w):
        """Dynamic stiffness K − ω²M + i(ωC + D)."""
        return self.K - w * w * self.M + 1j * (w * self.C + self.D)

    @cached_property
    def _error_norms(self):
        """(‖δK‖₂, ‖δC‖₂) bounds from the linear model's elementwise error estimates (the model's own C only)."""
        lin = self.lin
        dC = lin.C_error if self.C is lin.C else np.zeros_like(self.C)
        norm = lambda X: float(np.linalg.norm(X, 2)) if X.size else 0.0  # noqa: E731
        return norm(lin.K_error), norm(dC)

    def z_error(self, w):
        """A bound of the 2-norm of the dynamic stiffness's error at ω (rad/s): ‖δK‖ + ω‖δC‖ (N/m, N·m/rad)."""
        dK, dC = self._error_norms
        return dK + w * dC

    @property
    def classical(self):
        """The real modes decouple the equations (classical damping, symmetric K)."""
        return self.modal[4] <= 1e-8


def damped_model(lin, damping):
    if damping is None or damping == "viscous":
        return DampedModel(lin, lin.C, np.zeros_like(lin.M),
                      "viscous (the model's C)" if np.any(lin.C) else "undamped (the model's C = 0)")
    if damping in ("none", "undamped"):
        return DampedModel(lin, np.zeros_like(lin.M), np.zeros_like(lin.M), "undamped")
    if isinstance(damping, Hysteretic):
        C = lin.C if damping.viscous else np.zeros_like(lin.M)
        return DampedModel(replace(lin, C=C, C_error=np.zeros_like(C)) if not damping.viscous else lin, C,
                      damping.damping_matrix(lin), damping.describe())
    raise ModelError(f"damping: expected None/'viscous', 'none' or a vibdyn.Hysteretic(...), got {damping!r}")


