"""Linear models of scenes with drives (rheonomic joints, :mod:`vibdyn.model.drives`): about a state of the
prescribed motion, in the free coordinates.

The driven coordinates are given (q_d, v_d, a_d: the laws' at the operating time t), so a perturbation moves the
free ones only: M, C, K are the rows and columns of the free coordinates of the tree's (K and C about the
motion's accelerations a, a_d the laws' and a_f from the free rows), and modes, receptances and responses
run on them, shapes given in the tree's coordinates (zero on the driven ones). Equilibria and steady motions
hold the driven coordinates at their laws' position and speed at t (:func:`vibdyn.analysis.equilibrium.
driven_start`: refused where a law accelerates); held points of a driven scene are refused.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, fields

import numpy as np

from .._check import all_finite
from ..defaults import FD_STEP
from ..errors import ModelError
from ..model import dynamics
from .constrained import ConstrainedLinearModel, IndependentView
from .linearize import reference_state, tree_linearize


class FreeView(IndependentView):
    """A system with drives seen in its free coordinates (what the responses of a :class:`DrivenLinearModel`
    name): ``coordinates``, ``units`` and ``coordinate_index`` are the free ones'."""

    def coordinate_index(self, name):
        if name in self.coordinates:
            return self.coordinates.index(name)
        drives = self.system.drives
        if name in drives.coordinates:
            k = drives.coordinates.index(name)
            raise ModelError(f"coordinate '{name}' is driven (drive '{drives.names[k]}' prescribes it): it is no "
                             f"coordinate of the linear model (free: {', '.join(self.coordinates)})")
        raise ModelError(f"unknown coordinate '{name}' (free coordinates: {', '.join(self.coordinates)})")


@dataclass(frozen=True, eq=False)
class DrivenLinearModel(ConstrainedLinearModel):
    """Linear model of a scene with drives in its free coordinates (nf × nf M, C, K; ``null_space`` the columns of
    the identity at the free coordinates; ``tree`` the nv × nv model). ``drive``: {drive name: τ_d}, the force
    (N or N·m) each drive exerts at the operating point."""

    @property
    def drive(self) -> dict[str, float]:
        assert self.tree is not None  # (always set by linearize)
        system = self.tree.system
        tau = dynamics.inverse_dynamics(system, system.workspace(), self.q, self.v, self.a, self.t)
        return system.drives.of(tau)

    def relinearize(self, method):
        """The same operating point linearised again with ``method`` ("fd" or "analytic")."""
        return linearize(self.tree.system, self.q, v=self.v, t=self.t, a=self.a, method=method)

    def summary(self):
        return (f"{type(self).__name__}({self.method}, nv={self.tree.nv}, free={self.nv}, relative error ≈ {self.relative_error:.1e}, "
                f"{self.elapsed * 1e3:.2f} ms)")


def linearize(system, at=None, *, v=None, t=0.0, a=None, method="fd", step=FD_STEP) -> DrivenLinearModel:
    """Linear model of a scene with drives about the state (``at``, ``v``) at time ``t`` (s) (see
    :func:`vibdyn.analysis.linearize.linearize`), the driven entries of q and v replaced by the laws' at t;
    ``a`` the reference motion's accelerations (None: the motion's, a_d the laws' and a_f from the free
    rows; given, its driven entries must be the laws'). In the free coordinates: :class:`DrivenLinearModel`."""
    start = time.perf_counter()
    drives = system.drives
    q0, v0, t0 = reference_state(system, at, v, t)
    q0, v0 = drives.impose(q0, v0, t0)
    ad = drives.values(t0)[2]
    if a is None:
        a0 = dynamics.accelerations(system, system.workspace(), q0, v0, t0).copy()
        if not all_finite(a0):
            system.check_mass_matrix(q0, "the operating point")
            raise ModelError(f"linearize: the accelerations are not finite at the operating point (t = {t0})")
    else:
        a0 = system.check_velocity(a, "a")
        # (within the tolerance of the equilibria's drives at rest: 1e-10 per s² × 1 rad or the length scale)
        if np.any(np.abs(a0[drives.index] - ad) > 1e-10 * system.coordinate_scales[drives.index]):
            raise ModelError(f"linearize: a at the driven coordinates ({', '.join(drives.coordinates)}) must be "
                             f"the drives' accelerations at t = {t0:g} s, {ad.tolist()}; got "
                             f"{a0[drives.index].tolist()} (give a = None for the motion's)")
    tree = tree_linearize(system, q0, v=v0, t=t0, a=a0, method=method, step=step)
    f = drives.free
    if not f.size:
        raise ModelError(f"linearize: every coordinate of scene '{system.name}' is driven: nothing is free to vibrate")
    ff = np.ix_(f, f)
    basis = np.eye(system.nv)[:, f]
    parts = {"system": FreeView(system, f), "q": q0, "v": v0, "a": a0, "t": t0, "M": tree.M[ff],
             "C": tree.C[ff], "K": tree.K[ff], "K_error": tree.K_error[ff], "C_error": tree.C_error[ff],
             "method": tree.method, "elapsed": time.perf_counter() - start, "evaluations": tree.evaluations,
             "null_space": basis, "tree": tree, "multipliers": None, "rank": 0,
             "K_error_terms": None if tree.K_error_terms is None else (tree.K_error_terms[0][:, f],
                                                                       tree.K_error_terms[1][:, f])}
    return DrivenLinearModel(**{fl.name: parts[fl.name] for fl in fields(DrivenLinearModel)})
