"""The arguments of a backbone (:func:`vibdyn.analysis.nonlinear.backbone.backbone`): its requests (amplitudes
in m or rad, or energies in J), coordinate and mode, refused with a ModelError naming what is wrong."""

from __future__ import annotations

import math

import numpy as np

from ..._check import integer
from ...errors import ModelError


def checked_requests(amplitudes, energies, what) -> tuple[str, np.ndarray]:
    """("amplitude" or "energy", the requests as a float array): exactly one given, each positive and finite."""
    if (amplitudes is None) == (energies is None):
        raise ModelError(f"{what}: give exactly one of amplitudes (m or rad) or energies (J), got "
                         f"{'both' if amplitudes is not None else 'neither'}")
    name, value = ("amplitude", amplitudes) if amplitudes is not None else ("energy", energies)
    try:
        arr = np.atleast_1d(np.asarray(value, dtype=float))
    except (TypeError, ValueError):
        raise ModelError(f"{what}: {name} requests must be numbers, got {value!r}") from None
    if arr.ndim != 1 or arr.size == 0:
        raise ModelError(f"{what}: {name} requests must be a non-empty list of numbers, got shape {arr.shape}")
    bad = np.flatnonzero(~(np.isfinite(arr) & (arr > 0)))
    if bad.size:
        raise ModelError(f"{what}: {name} requests must be positive and finite: entry {int(bad[0])} is "
                         f"{float(arr[bad[0]])!r}")
    return name, arr


def bad_coordinate(coordinate, what):
    """A ModelError: the coordinate given is no coordinate's name."""
    raise ModelError(f"{what}: coordinate must be a coordinate's name, got {coordinate!r}")


def mode_index(mode, modes, what) -> int:
    """The index of the mode followed, refused where it is out of range, rigid or unstable, or where the scene
    has rigid modes."""
    n = len(modes.omega)
    k = integer(mode, f"{what}: mode", minimum=0)
    if k >= n:
        raise ModelError(f"{what}: mode {k} out of range: the linearisation has {n} mode{'s' if n > 1 else ''} "
                         f"(0 … {n - 1})")
    if np.all(modes.rigid | modes.unstable):
        raise ModelError(f"{what}: the scene has no oscillating mode (every mode is rigid/cyclic or unstable): "
                         "nothing to follow")
    if modes.rigid[k] or modes.unstable[k]:
        raise ModelError(f"{what}: mode {k} is {'rigid (ω = 0)' if modes.rigid[k] else 'unstable (ω² < 0)'}: "
                         "no oscillation grows out of it")
    if np.any(modes.rigid):
        raise ModelError(f"{what}: the scene has rigid or cyclic modes ({int(np.count_nonzero(modes.rigid))}): "
                         "their free drift makes the orbits a larger family; hold those coordinates")
    return k


def within_a_turn(system, c, requests, what) -> None:
    """Refuses an amplitude of an angle whose q and q ± 2π are one pose (a pivot's) at π or beyond: a swing
    reaches π at most, where it turns over (the separatrix); beyond, the angle names the pose of a smaller swing."""
    if c in system.periodic_tangents and float(np.max(requests)) >= math.pi:
        raise ModelError(f"{what}: amplitude {float(np.max(requests)):.6g} rad of '{system.coordinates[c]}', an angle "
                         "(q and q ± 2π one pose): a swing reaches π at most, where it turns over (the separatrix)")
