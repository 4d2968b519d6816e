"""The equilibrium of a mechanism with closed loops (:mod:`vibdyn.description.loops`) and its loop forces.

The loops' equations Φ(q) = 0 add the generalized forces Φ_qᵀ λ to the tree: M v̇ + b − Q = Φ_qᵀ λ, λ the
loop forces (per equation: N for a position equation, N·m for an orientation one; for a point coincidence
λ is the force that body_a exerts on body_b through the loop, world axes). Everything is reduced to the
mechanism's independent motions: a basis N (nv × dof) of Φ_q N = 0. The search itself is every scene's
(:func:`vibdyn.analysis.equilibrium.search`).
"""

from dataclasses import dataclass, field

import numpy as np

from .equilibrium import OperatingPoint


@dataclass(frozen=True, eq=False)
class LoopEquilibrium(OperatingPoint):
    """An equilibrium of a mechanism with loops: also its loop forces.

    ``multipliers``: λ per loop equation (N or N·m, see :mod:`vibdyn.analysis.constrained`); ``loop_forces``: the same
    split per loop {name: array}; ``constraint_residual``: largest |Φ| there (dimensionless: m / length
    scale, rad).
    """

    multipliers: np.ndarray | None = field(repr=False, default=None)
    loop_forces: dict | None = field(default=None)
    constraint_residual: float = 0.0

    def linearize(self, **kwargs):
        return self.system.linearize(self, **kwargs)

    def reactions(self):
        """Link wrenches of the tree at this equilibrium, loop forces included (:meth:`System.reactions`)."""
        nv = self.system.nv
        return self.system.reactions(self.q, self.v, np.zeros(nv), self.t, loop_forces=self.multipliers)
