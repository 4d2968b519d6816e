"""State-space form of a linear model, for control tools: ẋ = A x + B u, y = C x + D u with x = (δq, δv).

Inputs u are forces on the receptance's channels (generalized forces on coordinates, N or N·m, or forces
along a direction at body points, N); outputs y are the displacements (m or rad) or velocities (m/s or
rad/s) along the output channels. ``to_scipy()`` gives a ``scipy.signal.StateSpace``, ``to_control()`` a
python-control ``StateSpace`` (if python-control is installed).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._deprecation import Renamed
from ..errors import ModelError

OUTPUTS = ("displacement", "velocity")


@dataclass(frozen=True, eq=False)
class StateSpace:
    """ẋ = A x + B u, y = C x + D u about the linear model's operating point; x = (δq, δv) in the tangent
    space (``states`` names them, ``state_units`` in m, rad, m/s, rad/s). ``relative_error``: the linear
    model's estimated relative error of K and C, hence of A."""

    A: np.ndarray  # 2nv × 2nv, 1/s and 1/s²
    B: np.ndarray  # 2nv × n_in
    C: np.ndarray  # n_out × 2nv
    D: np.ndarray  # n_out × n_in (zero: forces do not reach displacements or velocities instantly)
    inputs: tuple
    outputs: tuple
    states: tuple
    input_units: tuple  # "N" or "N·m" per input
    output_units: tuple  # "m"/"rad" (displacement) or "m/s"/"rad/s" (velocity) per output
    state_units: tuple
    output: str  # "displacement" or "velocity"
    relative_error: float
    error = Renamed("relative_error")

    def __repr__(self):
        from .._format import number, summary

        return summary("StateSpace", f"{self.A.shape[0]} states", f"inputs {', '.join(map(str, self.inputs))}",
                       f"outputs {', '.join(map(str, self.outputs))} ({self.output})",
                       f"relative error {number(self.relative_error, digits=2)}")

    @property
    def poles(self):
        """Eigenvalues of A (1/s)."""
        return np.linalg.eigvals(self.A)

    def transfer(self, s: complex) -> np.ndarray:
        """C (sI − A)⁻¹ B + D at the complex frequency ``s`` (1/s): n_out × n_in (at s = iω, the
        receptance for displacement outputs)."""
        n = self.A.shape[0]
        return self.C @ np.linalg.solve(s * np.eye(n) - self.A, self.B.astype(complex)) + self.D

    def to_scipy(self) -> Any:
        """A ``scipy.signal.StateSpace`` (continuous time) with the same matrices."""
        from scipy.signal import StateSpace as ScipyStateSpace

        return ScipyStateSpace(self.A, self.B, self.C, self.D)

    def to_control(self) -> Any:
        """A python-control ``control.StateSpace`` with named inputs, outputs and states."""
        try:
            import control
        except ImportError:
            raise ImportError("StateSpace.to_control() needs python-control, which is not installed "
                              "(pip install control); to_scipy() needs only scipy") from None
        return control.ss(self.A, self.B, self.C, self.D, inputs=list(self.inputs), outputs=list(self.outputs),
                          states=list(self.states))


def state_space(lin, inputs=None, outputs=None, *, output="displacement", direction=None):
    """:class:`StateSpace` of a :class:`vibdyn.analysis.linearize.LinearModel` (its M, C, K).

    ``inputs``/``outputs``: as for :meth:`LinearModel.receptance` — coordinate names, body points
    ``(body, (x, y, z), (dx, dy, dz))`` (``direction`` for points given without one), or None (every
    coordinate). ``output``: "displacement" or "velocity" of the output channels.
    """
    from .response import channels

    if output not in OUTPUTS:
        raise ModelError(f"state_space: output must be 'displacement' or 'velocity', got {output!r}")
    cin = channels(lin, inputs, direction, "inputs")
    cout = channels(lin, outputs, direction, "outputs")
    n = lin.nv
    zero = np.zeros((len(cout.labels), n))
    C = np.hstack([cout.matrix, zero] if output == "displacement" else [zero, cout.matrix])
    names, units = tuple(lin.coordinates), tuple(lin.units)
    out_units = cout.units if output == "displacement" else tuple(u + "/s" for u in cout.units)
    return StateSpace(lin.A, lin.state_input(cin.matrix.T), C, np.zeros((len(cout.labels), len(cin.labels))),
                      cin.labels, cout.labels, tuple(f"q[{c}]" for c in names) + tuple(f"v[{c}]" for c in names),
                      cin.force_units, out_units, units + tuple(u + "/s" for u in units), output, lin.relative_error)
