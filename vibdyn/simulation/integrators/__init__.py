"""Time integrators behind :func:`vibdyn.simulation.simulate.simulate`, in the manner of scipy's ``_ivp``:
one base class :class:`~.base.Stepper` (order, fixed or adaptive, error estimates, counters, dense output),
one subclass per method, and the registry :data:`METHODS` (name → class) that ``simulate(method=...)``, its
error message and the command line read. Modules: the chart ODE (:mod:`.chart`), explicit Runge–Kutta
(:mod:`.explicit`), scipy's public implicit solvers (:mod:`.implicit`, scipy.integrate loaded on first use)
and the variational integrator (:mod:`.variational`).
"""

from .base import StepError, Stepper
from .explicit import DOP853, RK4
from .implicit import BDF, Radau
from .variational import Variational

METHODS: dict[str, type[Stepper]] = {cls.name: cls for cls in (DOP853, RK4, Radau, BDF, Variational)}
ALIASES = {"variational": "symplectic"}  # other names accepted for a method


def method_class(name: str | type[Stepper]) -> type[Stepper] | None:
    """The stepper class of a method name (case-insensitive, aliases allowed) or the class itself (a
    :class:`Stepper` subclass with a ``name``), or None."""
    if isinstance(name, type) and issubclass(name, Stepper) and name.name:
        return name
    if not isinstance(name, str):
        return None
    key = name.lower()
    return METHODS.get(ALIASES.get(key, key))


__all__ = ["ALIASES", "BDF", "DOP853", "METHODS", "RK4", "Radau", "StepError", "Stepper", "Variational",
           "method_class"]
