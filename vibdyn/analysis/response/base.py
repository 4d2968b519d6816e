"""Base excitation: transmissibility from a moving support or a prescribed joint coordinate."""

import time
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from ..._check import unit_axis, unknown_name
from ...errors import ModelError
from .channels import channels, vector_label
from .damping import DampedModel, damped_model
from .frf import frf_of


# ====================================================================== base excitation
def transmissibility(r: ArrayLike, zeta: ArrayLike) -> np.ndarray:
    """Displacement transmissibility of a base-excited single-degree-of-freedom system,
    T(r, ζ) = √((1 + (2ζr)²) / ((1 − r²)² + (2ζr)²)), r = ω/ω_n; T(√2, ζ) = 1 for every ζ."""
    r = np.asarray(r, dtype=float)
    z = np.asarray(zeta, dtype=float)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(z))) or np.any(r < 0) or np.any(z < 0):
        raise ModelError(f"transmissibility: need finite r ≥ 0 and ζ ≥ 0, got r={r!r}, zeta={z!r}")
    num = 1 + (2 * z * r) ** 2
    den = (1 - r ** 2) ** 2 + (2 * z * r) ** 2
    if np.any(den == 0):
        raise ModelError("transmissibility: infinite at r = 1 with ζ = 0")
    return np.sqrt(num / den)


def support_input_of(lin, support, direction):
    """How a base motion enters: ("support", B_y·d, B_v·d, labels) or ("joint", index, free indices)."""
    system = lin.system
    if not isinstance(support, str):
        raise ModelError(f"base excitation: expected a support or coordinate name, got {support!r}")
    if support in system.support_index:
        By, Bv = lin.support_input(support)
        if direction is None:
            dirs, labels = np.eye(3), [f"{support}.{a}" for a in "xyz"]
        else:
            d = unit_axis(direction, f"support '{support}' direction")
            dirs, labels = d[:, None], [f"{support}·{vector_label(d)}"]
        return "support", By @ dirs, Bv @ dirs, labels
    if support in system.coordinates:
        if lin.nv < 2:
            raise ModelError(f"base excitation: prescribing '{support}' leaves no free coordinate")
        p = lin.coordinate_index(support)
        return "joint", p, np.array([i for i in range(lin.nv) if i != p]), [support]
    raise unknown_name(support, [*(s.name for s in system.supports), *lin.coordinates], "support or coordinate",
                       "supports and coordinates", "base excitation")


def reduced(model, free):
    """The model with only the coordinates ``free`` (the others prescribed)."""
    ix = np.ix_(free, free)
    lin = model.lin
    sub = replace(lin, M=lin.M[ix], K=lin.K[ix], C=model.C[ix], K_error=lin.K_error[ix], C_error=lin.C_error[ix],
                  K_error_terms=None)  # (K_error[ix] holds them elementwise)
    return DampedModel(sub, model.C[ix], model.D[ix], model.damping)


def base_response(lin, omega, support, direction=None, outputs=None, *, method="direct", damping=None,
                  n_modes=None):
    """Steady response to a harmonic base motion (:class:`FRF` of kind "transmissibility"): outputs per unit
    displacement of ``support``.

    ``support``: a support's name (a moving frame carrying springs and dampers, ``scene.add_support``):
    the input is its displacement along ``direction`` (world axes; None: x, y, z as three inputs), acting
    as (B_y + iωB_v) Y; or a coordinate name (a prescribed joint): its motion Y drives the other
    coordinates through −(K_fp − ω²M_fp + iωC_fp) Y, and the prescribed coordinate itself moves as Y.
    Outputs are absolute: for a single-degree-of-freedom system H = T(r, ζ) e^{iφ}."""
    start = time.perf_counter()
    model = damped_model(lin, damping)
    cout = channels(lin, outputs, None, "outputs")
    how = support_input_of(lin, support, direction)
    if how[0] == "support":
        _, By, Bv, labels = how
        return frf_of(model, omega, lambda w: By + 1j * w * Bv, cout, labels, ("m",) * len(labels),
                    "transmissibility", method, n_modes, start)
    _, p, free = how[:3]
    sub = reduced(model, free)
    M, K, C, D = model.M[free, p], model.K[free, p], model.C[free, p], model.D[free, p]
    out = replace(cout, matrix=cout.matrix[:, free])
    unit = lin.units[p]
    return frf_of(sub, omega, lambda w: -(K - w * w * M + 1j * (w * C + D))[:, None], out, [support], (unit,),
                "transmissibility", method, n_modes, start, offset=cout.matrix[:, [p]])


