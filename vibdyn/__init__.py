"""vibdyn: vibration analysis of sets of rigid solids, built on Pinocchio.

Describe a :class:`Scene` (bodies, joints, springs, dampers, forces, gravity), ``build()`` it into a
:class:`System`, and compute. ``import vibdyn`` loads only the description and the compiled model (numpy,
Pinocchio); the analyses (linearisation, modes, responses, identification, simulation, plots) and scipy load
on first use, as do the viewer, matplotlib and MuJoCo.
"""

from importlib import import_module

from . import inertia, laws
from .elements import WORLD
from .errors import ConvergenceError, ModelError, SceneFileError, VibdynError
from .joints import Ball, Cylindrical, Fixed, Free, Helical, Pivot, Planar, Slider, Universal
from .scene import Body, Scene
from .system import BodyInfo, Energy, Reactions, System

__version__ = "0.1.0"

# public names loaded on first use: name -> module (relative to vibdyn) that defines it
_LAZY = {
    "response": "response", "identify": "identify", "plots": "plots", "modal": "modal",
    "linearize": "linearize", "equilibrium": "equilibrium", "simulate": "simulate", "statespace": "statespace",
    "mac": "modal", "rayleigh": "modal", "Modes": "modal",
    "LinearModel": "linearize", "Equilibrium": "equilibrium",
    "FRF": "response", "Peaks": "response", "HarmonicResponse": "response", "TimeResponse": "response",
    "Appropriation": "response", "Hysteretic": "response", "transmissibility": "response",
    "fit_rayleigh": "identify", "log_decrement": "identify", "HalfPower": "identify",
    "LogDecrement": "identify", "RayleighFit": "identify",
    "Trajectory": "simulate", "SimulationError": "simulate",
    "StateSpace": "statespace",
    "campbell": "campbell_diagram", "Campbell": "campbell_diagram", "CriticalSpeed": "campbell_diagram",
    "sweep": "sweeps", "sample": "sweeps", "Sweep": "sweeps", "Samples": "sweeps", "Statistic": "sweeps",
    "Tracked": "sweeps", "examples": "examples", "sweeps": "sweeps", "campbell_diagram": "campbell_diagram",
}
_MODULES = {"response", "identify", "plots", "modal", "linearize", "equilibrium", "simulate", "statespace",
            "examples", "sweeps", "campbell_diagram"}


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'vibdyn' has no attribute {name!r}")
    mod = import_module(f".{module}", __name__)
    value = mod if name in _MODULES else getattr(mod, name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


def load_scene(path):
    """Read a TOML scene file (see the README for its format) into a :class:`Scene`."""
    from .io.scenefile import load_scene as _load

    return _load(path)


def load_robot(name, **kwargs):
    """A :class:`Scene` of a robot of example-robot-data ("ur5", "panda", "talos", ...)."""
    from .io.robots import load_robot as _load

    return _load(name, **kwargs)


def load_urdf(path, **kwargs):
    """A :class:`Scene` from a URDF file (fixed base unless ``floating=True``)."""
    from .io.robots import load_urdf as _load

    return _load(path, **kwargs)


def load_mjcf(path, **kwargs):
    """A :class:`Scene` from a MuJoCo MJCF file (parsed by Pinocchio)."""
    from .io.robots import load_mjcf as _load

    return _load(path, **kwargs)


def view(obj, **kwargs):
    """Show a Modes, Trajectory, System or Scene in the browser (live meshcat server on 127.0.0.1); returns
    a handle with ``.url`` and ``.close()`` (see :func:`vibdyn.viewer.view`)."""
    from .viewer import view as _view

    return _view(obj, **kwargs)


def export_html(obj, path, **kwargs):
    """Write a self-contained HTML page of every mode (or a trajectory) of ``obj`` (see
    :func:`vibdyn.viewer.export_html`); returns its path."""
    from .viewer import export_html as _export

    return _export(obj, path, **kwargs)


__all__ = ["Scene", "System", "Body", "BodyInfo", "Energy", "Reactions", "Pivot", "Slider", "Helical", "Ball",
           "Cylindrical", "Universal", "Planar", "Free", "Fixed", "inertia", "laws", "WORLD", "ModelError",
           "ConvergenceError", "SceneFileError", "VibdynError", "load_scene", "load_robot", "load_urdf",
           "load_mjcf", "mac", "rayleigh", "response", "identify", "plots", "FRF", "Hysteretic",
           "transmissibility", "fit_rayleigh", "log_decrement", "Trajectory", "SimulationError",
           "LinearModel", "Modes", "Equilibrium", "Peaks", "HarmonicResponse", "TimeResponse", "Appropriation",
           "HalfPower", "LogDecrement", "RayleighFit", "StateSpace", "view", "export_html",
           "campbell", "Campbell", "CriticalSpeed", "sweep", "sample", "Sweep", "Samples", "Statistic", "Tracked",
           "examples"]
