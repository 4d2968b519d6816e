"""The mass-matrix policy: M(q) must be regular against the scene's inertia scales (kg for lengths, kg·m² for
angles: ``System.inertia_scales``). Checked at build (:func:`check_inertia`) and where an analysis starts
(:func:`check_mass_matrix`, also ``System.check_mass_matrix``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .._check import all_finite
from ..defaults import EPS
from ..errors import ModelError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from .system import System


def check_inertia(system: System) -> None:
    """At build: a body without inertia along one of its coordinates is refused. The test is made at
    neutral and, only if M is singular there, at a second configuration: a mass matrix singular at
    neutral alone is a singular point of the motion (a slider at the axis of a pivot), refused where
    an analysis meets it, not a fault of the description."""
    try:
        check_mass_matrix(system, system.neutral(), "the neutral configuration")
    except ModelError:
        try:
            check_mass_matrix(system, system.random_configuration(0.5, rng=0), "a random configuration")
        except ModelError:
            pass
        else:
            return
        raise


def check_mass_matrix(system: System, q: ArrayLike, where: str, M: np.ndarray | None = None) -> None:
    """ModelError naming the body and coordinate if M(q) (or the given M) is singular against the scene's
    scales: an eigenvalue of S^-½ M S^-½ (S: ``inertia_scales``) below 1000·nv·ε is round-off, not inertia."""
    M = system.mass_matrix(q) if M is None else M
    Ms = M * system.inertia_weights
    tol = 1e3 * system.nv * EPS
    # fast sufficient test: Ms = LLᵀ gives λ_min(Ms) = 1/‖L⁻¹‖₂² ≥ 1/‖L⁻¹‖_F² (at most nv times too
    # cautious; a NaN or inf anywhere fails it); only where that bound is not enough do the eigenvalues
    # decide (LAPACK directly: the wrappers of numpy and scipy cost more than these solves on small models)
    from scipy.linalg import lapack  # (on first use: not at `import vibdyn`)

    L, info = lapack.dpotrf(Ms, lower=1)
    if info == 0:
        Linv, info = lapack.dtrtri(L, lower=1, overwrite_c=1)  # (L's other triangle is zero: so is Linv's)
        x = Linv.ravel(order="K")  # (LAPACK's column order: a view)
        if info == 0 and (x @ x) * tol < 1.0:
            return
    if not all_finite(Ms):
        raise ModelError(f"mass matrix at {where} is not finite")
    w, V, info = lapack.dsyevd(Ms)
    s = np.sqrt(system.inertia_scales)
    if info == 0 and w[0] > tol:
        return
    i = int(np.argmax(np.abs(V[:, 0])))
    coord = system.coordinates[i]
    body = next(b.name for b in system.body_infos.values() if i in b.v_indices)
    raise ModelError(f"singular mass matrix at {where}: body '{body}' has no inertia along its coordinate "
                     f"'{coord}' (smallest eigenvalue of M {w[0] * s[i] ** 2:.3g}, {w[0]:.2g} of the scene's "
                     "inertia scale); give it mass or inertia")
