"""The one protocol of results in time: the linear model's :class:`~vibdyn.analysis.response.TimeResponse`
and the simulation's :class:`~vibdyn.simulation.simulate.Trajectory` both derive from :class:`TimeResult`.

A time result has ``t`` (s, n_t), its positions — ``q`` (configurations) in a Trajectory, ``x``
(displacements from the operating point) in a TimeResponse, named by ``position_name`` — and ``v``, ``a``
(one row per time: m or rad, velocities in m/s or rad/s, accelerations in m/s² or rad/s²), ``coordinates`` and ``units``
(one per velocity component), ``method``, ``error`` (the result's own estimated error of its positions, absolute: m or
rad), ``elapsed`` (s), :meth:`~TimeResult.to_dict` (JSON-ready) and :meth:`~TimeResult.series` (the curves of chosen
outputs, which :func:`vibdyn.faces.plots.time_history` and :meth:`~TimeResult.plot` draw).
"""

from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import ModelError

QUANTITIES = {"displacement": "", "velocity": "/s", "acceleration": "/s²"}  # name -> rate suffix of the unit


class TimeResult:
    """Base class of results in time (see the module docstring). Subclasses provide the attributes and
    :meth:`series`; this class gives ``len``, :meth:`to_dict`'s common part and :meth:`plot`."""

    t: np.ndarray
    v: np.ndarray
    method: str
    elapsed: float
    position_name = "q"  # "q": configurations (Trajectory); "x": displacements (TimeResponse)
    if TYPE_CHECKING:  # fields of one subclass, computed properties of the other
        @property
        def a(self) -> np.ndarray: ...

        @property
        def coordinates(self) -> tuple: ...

        @property
        def units(self) -> tuple: ...

        @property
        def error(self) -> float: ...

    def __len__(self) -> int:
        return len(self.t)

    def series(self, quantity: str = "displacement", outputs: Any = None,
               direction: Any = None) -> tuple[list, list, np.ndarray]:
        """(labels, units, values n_t × k) of the outputs' displacement, velocity or acceleration."""
        raise NotImplementedError

    def time_dict(self) -> dict[str, Any]:
        """The protocol's part of :meth:`to_dict`: times (s), coordinates, units, the positions (q or x), v, a,
        method, error estimate and elapsed time (s)."""
        return {"t_s": self.t.tolist(), "coordinates": list(self.coordinates), "units": list(self.units),
                self.position_name: getattr(self, self.position_name).tolist(), "v": self.v.tolist(),
                "a": self.a.tolist(), "method": self.method,
                "error_estimate": self.error, "elapsed_s": self.elapsed}

    def to_dict(self) -> dict[str, Any]:
        return self.time_dict()

    def plot(self, outputs: Any = None, *, direction: Any = None, quantity: str = "displacement", path: Any = None,
             dpi: int = 100) -> Any:
        """Time histories of the outputs (:func:`vibdyn.faces.plots.time_history`): a matplotlib Figure."""
        from .faces.plots import time_history

        return time_history(self, outputs, direction=direction, quantity=quantity, path=path, dpi=dpi)


def check_quantity(quantity: str, what: str) -> str:
    """The quantity's rate suffix ("", "/s", "/s²"); a ModelError (a ValueError) for anything else."""
    if quantity not in QUANTITIES:
        raise ModelError(f"{what}: quantity must be displacement, velocity or acceleration, got {quantity!r}")
    return QUANTITIES[quantity]
