"""vibdyn: vibration analysis of sets of rigid solids, built on Pinocchio.

Describe a :class:`Scene` (bodies, joints, springs, dampers, forces, gravity), ``build()`` it into a
:class:`System`, and compute. ``import vibdyn`` loads only the description and the compiled model (numpy,
Pinocchio); the analyses (linearisation, modes, responses, identification, simulation, plots) and scipy load
on first use, as do the viewer, matplotlib and MuJoCo.
"""

import os
from importlib import import_module
from importlib import metadata as _metadata
from typing import Any

from ._deprecation import warn_once as _warn_once
from .description import inertia, laws
from .description.elements import WORLD as _WORLD
from .description.joints import (
    Ball,
    Cylindrical,
    Fixed,
    Free,
    Helical,
    Pivot,
    Planar,
    Slider,
    Universal,
)
from .description.scene import Body, Scene
from .errors import ConvergenceError, ModelError, SceneFileError, VibdynError
from .model.system import BodyInfo, Energy, Reactions, System

#: ``"world"``: the name of the fixed frame. A body whose ``parent`` is WORLD (the default) is joined to the ground,
#: and an attachment ``(WORLD, (x, y, z))`` is a point fixed in space, in world coordinates (m): e.g.
#: ``scene.add_spring("k", (vd.WORLD, (-1, 0, 0)), "cart", stiffness=100.0)``. No body may take this name.
WORLD = _WORLD

try:  # one source: the version in pyproject.toml, as installed
    __version__ = _metadata.version("vibdyn")
except _metadata.PackageNotFoundError:  # pragma: no cover - a source tree on sys.path, never installed
    __version__ = "0+unknown"

# public names loaded on first use (the user's third rule: a scene pays only for what it uses)
_WHERE = {  # module (relative to vibdyn) -> the public names it defines
    "analysis.equilibrium": ("OperatingPoint", "Equilibrium", "equilibrium"),
    "analysis.modal": ("Modes", "rayleigh"),
    "solvers.tracking": ("mac",),
    "analysis.response": ("FRF", "Peaks", "HarmonicResponse", "TimeResponse", "Appropriation", "Hysteretic",
                          "transmissibility"),
    "analysis.response.seismic": ("SeismicResponse",),
    "description.design_spectra": ("DesignSpectrum", "eurocode8", "asce7"),
    "analysis.response.record_spectrum": ("RecordSpectrum",),
    "analysis.identify": ("fit_rayleigh", "log_decrement", "HalfPower", "LogDecrement", "RayleighFit"),
    "analysis.statespace": ("StateSpace",),
    "description.psd": ("PSD", "Delay"),
    "analysis.response.random": ("RandomResponse",),
    "analysis.response.monte_carlo": ("monte_carlo", "MonteCarlo"),
    "results": ("TimeResult",),
    "analysis.campbell_diagram": ("campbell", "Campbell", "CriticalSpeed", "Onset"),
    "analysis.rotor_stability": ("stability_limit", "StabilityLimit", "critical_speed_map", "CriticalSpeedMap"),
    "analysis.unbalance": ("unbalance_response", "UnbalanceResponse", "Peak", "Orbit"),
    "analysis.nonlinear.periodic": ("periodic_orbit", "floquet", "PeriodicOrbit"),
    "analysis.nonlinear.backbone": ("backbone", "Backbone"),
    "simulation.simulate": ("Trajectory", "SimulationError", "simulate"),
    "analysis.sensitivity": ("sensitivity", "Sensitivity"),
    "analysis.linearize": ("LinearModel", "linearize"),
    "studies.updating": ("update", "Update"),
    "description.parameters": ("parameters", "with_values", "Parameter"),
    "studies.sweeps": ("sweep", "sample", "Sweep", "Samples", "Statistic", "Tracked"),
    "analysis.nonlinear.harmonic_balance": ("forced_response_curve", "ForcedResponseCurve", "PointForce",
                                            "SupportMotion"),
    "model.reduction": ("Reduction",),
    "model.assembly": ("Assembly",),
    "model.forcing": ("forcing",),
}
# the modules themselves, under their short public names (vd.response, vd.simulate, ...)
# (never under a function's name: vd.simulate, vd.linearize and vd.equilibrium are the functions)
_MODULES = {"modal": "analysis.modal",
            "response": "analysis.response", "identify": "analysis.identify", "statespace": "analysis.statespace",
            "campbell_diagram": "analysis.campbell_diagram",
            "sweeps": "studies.sweeps", "examples": "studies.examples", "plots": "faces.plots",
            "loops": "description.loops", "viewer": "faces.viewer"}
_LAZY = {**{name: mod for mod, names in _WHERE.items() for name in names}, **_MODULES}


#: functions whose names were those of their modules until 0.1 (vd.simulate was the module): for one release,
#: an attribute of the former module read through the function still works and warns (DeprecationWarning)
_FORMER_MODULES = {"simulate": "simulation.simulate", "linearize": "analysis.linearize",
                   "equilibrium": "analysis.equilibrium"}


class _FormerModule:
    """A public function that was its module's name: calls go to the function; any other attribute is read
    from the former module with a DeprecationWarning (once per name)."""

    def __init__(self, fn, module, short):
        import functools

        functools.update_wrapper(self, fn)
        self._module, self._short = module, short  # (short: the public name the user wrote, vd.equilibrium)

    def __call__(self, *args, **kwargs):
        return self.__wrapped__(*args, **kwargs)

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        mod = import_module(f".{self._module}", __name__)
        value = getattr(mod, name)  # (an AttributeError as the module would give it)
        short = self._short
        public = f"from vibdyn (vibdyn.{name}) or " if name in _LAZY or name in globals() else ""
        _warn_once(f"vibdyn.{short}.{name}", f"vibdyn.{short}.{name}: vibdyn.{short} is the function {short}() now; "
                   f"read {name} {public}from vibdyn.{self._module}")
        return value


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'vibdyn' has no attribute {name!r}")
    mod = import_module(f".{module}", __name__)
    value = mod if name in _MODULES else getattr(mod, "static_equilibrium" if name == "equilibrium" else name)
    if name in _FORMER_MODULES:
        value = _FormerModule(value, _FORMER_MODULES[name], name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


def load_scene(path: str | os.PathLike) -> Scene:
    """Read a TOML scene file (its format: docs/guide/scene-files.md) into a :class:`Scene`; a bare name that is no
    file here ("four_bar" or "four_bar.toml") loads the bundled model of that name (:func:`bundled_models`)."""
    from .io.scenefile import load_scene as _load

    return _load(path)


def bundled_models() -> tuple[str, ...]:
    """The names of the scene files bundled with vibdyn ("four_bar", "trailer", ...), sorted: each loads by
    name, ``vd.load_scene("four_bar")`` or ``vibdyn modes four_bar``."""
    from .io.bundled import bundled_models as _names

    return _names()


def load_robot(name: str, **kwargs: Any) -> Scene:
    """A :class:`Scene` of a robot of example-robot-data ("ur5", "panda", "talos", ...)."""
    from .io.robots import load_robot as _load

    return _load(name, **kwargs)


def load_urdf(path: str | os.PathLike, **kwargs: Any) -> Scene:
    """A :class:`Scene` from a URDF file (fixed base unless ``floating=True``)."""
    from .io.robots import load_urdf as _load

    return _load(path, **kwargs)


def load_mjcf(path: str | os.PathLike, **kwargs: Any) -> Scene:
    """A :class:`Scene` from a MuJoCo MJCF file (parsed by Pinocchio)."""
    from .io.robots import load_mjcf as _load

    return _load(path, **kwargs)


def add_servo(scene: Scene, stiffness: float, damping: float = 0.0) -> None:
    """Hold every pivot, slider and helical joint of ``scene`` by a position servo: a joint spring
    ``stiffness`` (N·m/rad or N/m) about the held posture and a joint damper ``damping`` (N·m·s/rad or
    N·s/m) (see :func:`vibdyn.io.robots.add_servo`)."""
    from .io.robots import add_servo as _add

    _add(scene, stiffness, damping)


def view(obj: Any, *, amplitude: float | None = None, trajectory: Any = None, speed: float = 1.0, mode: int = 1,
         open_browser: bool = False) -> Any:
    """Show ``obj`` in the browser through a live meshcat server on 127.0.0.1; returns a handle with ``.url`` and
    ``.close()`` (displayed inline in Jupyter). ``obj``, ``amplitude``, ``trajectory`` and ``speed`` as
    :func:`export_html` takes them; ``mode``: the motion shown first (from 1); ``open_browser``: open the page
    in the default browser."""
    from .faces.viewer import view as _view

    return _view(obj, amplitude=amplitude, trajectory=trajectory, speed=speed, mode=mode, open_browser=open_browser)


def export_html(obj: Any, path: str | os.PathLike, *, amplitude: float | None = None, trajectory: Any = None,
                speed: float = 1.0, mode: int = 1) -> Any:
    """Write one self-contained HTML page showing ``obj`` and return its path (a ``pathlib.Path``). The page
    works offline (meshcat's viewer is inlined: no request to any host); its address takes ``#mode=2&t=0.25``
    (the motion shown, from 1, and the time in s).

    ``obj``: a Modes (every mode animated about the operating point, one entry each in the page's panel), a
    Trajectory (replayed), a System or Scene (at rest, or replaying ``trajectory``), a PeriodicOrbit, a Backbone
    (its largest request's orbit) or ``ForcedResponseCurve.orbit(i)`` (one period of the real motion, looped).
    ``amplitude``: the largest point displacement of a mode's animation (m; default 10 % of the scene's size).
    ``trajectory``: a motion to replay with a System, Scene or Modes: a Trajectory, or the ``.npz`` file that
    ``vibdyn simulate --out`` writes. ``speed``: the replay's speed, × real time (default 1: a trajectory or
    an orbit plays at its own pace). ``mode``: the motion the page shows first (from 1; its address's ``#mode=``
    overrides it).
    """
    from .faces.viewer import export_html as _export

    return _export(obj, path, amplitude=amplitude, trajectory=trajectory, speed=speed, mode=mode)


__all__ = ["Scene", "System", "Body", "BodyInfo", "Energy", "Reactions", "Pivot", "Slider", "Helical", "Ball",
           "Cylindrical", "Universal", "Planar", "Free", "Fixed", "inertia", "laws", "WORLD", "ModelError",
           "ConvergenceError", "SceneFileError", "VibdynError", "load_scene", "bundled_models", "load_robot",
           "load_urdf", "load_mjcf", "add_servo", "mac", "rayleigh", "response", "identify", "plots", "FRF",
           "Hysteretic", "transmissibility", "fit_rayleigh", "log_decrement", "Trajectory", "SimulationError",
           "LinearModel", "Modes", "OperatingPoint", "Equilibrium", "TimeResult", "Peaks", "HarmonicResponse",
           "TimeResponse", "Appropriation", "HalfPower", "LogDecrement", "RayleighFit", "StateSpace", "view",
           "export_html", "campbell", "Campbell", "CriticalSpeed", "Onset", "stability_limit", "StabilityLimit",
           "critical_speed_map", "CriticalSpeedMap", "unbalance_response", "UnbalanceResponse", "Peak", "Orbit",
           "sweep", "sample", "Sweep", "Samples", "Statistic", "Tracked",
           "examples", "forced_response_curve", "ForcedResponseCurve", "PointForce", "SupportMotion",
           "periodic_orbit", "floquet", "PeriodicOrbit", "backbone", "Backbone", "sensitivity", "Sensitivity",
           "update", "Update", "parameters", "with_values", "Parameter", "simulate", "linearize", "equilibrium",
           "Reduction", "Assembly", "forcing", "SeismicResponse", "RecordSpectrum", "DesignSpectrum", "eurocode8",
           "asce7", "PSD", "Delay", "RandomResponse", "monte_carlo", "MonteCarlo"]
