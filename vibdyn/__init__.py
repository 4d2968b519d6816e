"""vibdyn: vibration analysis of sets of rigid solids, built on Pinocchio.

Describe a :class:`Scene` (bodies, joints, springs, dampers, forces, gravity), ``build()`` it into a
:class:`System`, and compute. Viewer, plots and MuJoCo are imported only when asked for.
"""

from . import inertia, laws
from .elements import WORLD
from .errors import ConvergenceError, ModelError, SceneFileError, VibdynError
from .modal import mac, rayleigh
from . import identify, plots, response
from .identify import fit_rayleigh, log_decrement
from .response import FRF, Hysteretic, transmissibility
from .joints import Ball, Cylindrical, Fixed, Free, Helical, Pivot, Planar, Slider, Universal
from .scene import Body, Scene
from .simulate import SimulationError, Trajectory
from .system import Energy, Reactions, System

__version__ = "0.1.0"


def campbell(system, spin, speeds, orders=(1,), **kwargs):
    """Campbell diagram of ``system`` against the speed (rad/s) of coordinate ``spin``
    (see :func:`vibdyn.campbell_diagram.campbell`)."""
    from .campbell_diagram import campbell as _campbell

    return _campbell(system, spin, speeds, orders, **kwargs)


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


__all__ = ["Scene", "System", "Body", "Energy", "Reactions", "Pivot", "Slider", "Helical", "Ball",
           "Cylindrical", "Universal", "Planar", "Free", "Fixed", "inertia", "laws", "WORLD", "ModelError",
           "ConvergenceError", "SceneFileError", "VibdynError", "load_scene", "load_robot", "load_urdf",
           "load_mjcf", "campbell", "mac", "rayleigh", "response", "identify", "plots", "FRF", "Hysteretic",
           "transmissibility", "fit_rayleigh", "log_decrement", "Trajectory", "SimulationError", "view",
           "export_html"]
