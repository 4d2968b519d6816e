"""Browser viewer of modes and motions (meshcat): a self-contained offline page, a live server, pictures.

* :func:`export_html` writes one HTML file (meshcat's three.js viewer inlined, no request to any host)
  with every mode's animation and a panel to switch between them;
* :func:`view` starts meshcat's server on 127.0.0.1 and a small control page next to it, and returns a
  :class:`~vibdyn.faces.viewer.live.LiveViewer` (``.url``, ``.close()``; shown inline in Jupyter);
* :func:`vibdyn.faces.viewer.pictures.plot_modes` draws the modes with matplotlib (``Modes.plot``).

Each takes a :class:`vibdyn.analysis.modal.Modes`, a :class:`vibdyn.Trajectory`, a :class:`vibdyn.System` or a
:class:`vibdyn.Scene` (its modes at its operating point). This package imports meshcat only in
:mod:`vibdyn.faces.viewer.live`.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import ConvergenceError, ModelError
from . import motion as _motion
from .drawing import ROOT
from .drawing import drawing as _drawing
from .page import offline_page, scene_commands, view_direction

__all__ = ["export_html", "view", "content", "Content"]


@dataclass
class Content:
    """What a viewer shows: the system, its drawing, the operating configuration and the motions."""

    system: object
    drawing: object
    q0: np.ndarray
    linear: object = None
    views: list | None = None  # ModeView per mode
    trajectory: tuple | None = None  # (t, q) of a replay
    speed: float = 1.0
    title: str = ""
    subtitle: str = ""
    label: str = ""  # the trajectory's entry in the panel (default: its duration and samples)
    _jacobian: np.ndarray | None = None

    @property
    def n(self):
        return len(self.views or ()) + (self.trajectory is not None)

    def motions(self, amplitude=None):
        """The panel's entries: label, status, flags."""
        out = []
        if self.trajectory is not None:
            t = self.trajectory[0]
            out.append({"label": self.label or f"trajectory, {t[-1] - t[0]:.4g} s ({t.size} samples)",
                        "status": f"replay at {self.speed:g} × real time", "clock": True, "speed": self.speed})
        for v in self.views or ():
            status = {"rigid": "rigid-body mode: drifts (0 Hz)",
                      "unstable": "UNSTABLE: grows (shown as a loop)",
                      "overdamped": "overdamped: decays without oscillating (shown growing, as a loop)",
                      "oscillating": f"one cycle shown in {_motion.PERIOD:g} s"}[v.behaviour]
            a = self.amplitude(v, amplitude)
            out.append({"label": v.label, "status": f"{status}; amplitude factor {a:.3g}",
                        "unstable": v.behaviour == "unstable", "clock": False, "speed": 1.0})
        return out

    def amplitude(self, view, amplitude=None):
        """The factor the mode's shape is shown with (see :func:`vibdyn.faces.viewer.motion.scale`)."""
        if self._jacobian is None:
            d = self.drawing
            self._jacobian = (self.linear.point_jacobian(d.probes) if d.probes
                              else np.zeros((0, self.system.nv)))
        return _motion.scale(self.drawing, self.linear, view, amplitude, self._jacobian)

    def animation(self, k, amplitude=None):
        """meshcat animation of motion k (0-based, the trajectory first when there is one)."""
        if self.trajectory is not None:
            if k == 0:
                shown, frames, _ = _motion.trajectory_frames(self.system, self.trajectory, speed=self.speed)
                return _motion.animation(self.drawing, shown, frames, ROOT)
            k -= 1
        v = self.views[k]
        frames = _motion.mode_frames(self.system, self.q0, v, self.amplitude(v, amplitude))
        times = np.linspace(0.0, _motion.PERIOD, len(frames))
        return _motion.animation(self.drawing, times, frames, ROOT)

    def displacements(self):
        """Point displacements (m) of the motions shown: the modes' (complex, per unit factor) or those
        along the trajectory; (n × 3)."""
        d = self.drawing
        rows = []
        if self.views and d.probes:
            self.amplitude(self.views[0])  # the point Jacobian
            rows += [(self._jacobian @ v.shape).reshape(-1, 3) for v in self.views]
        if self.trajectory is not None and d.probes:
            p0 = d.points(self.q0)
            q = self.trajectory[1]
            rows += [d.points(q[k]) - p0 for k in np.linspace(0, len(q) - 1, min(len(q), 20)).astype(int)]
        return np.concatenate(rows) if rows else np.zeros((0, 3))

    def scene_commands(self):
        return scene_commands(self.drawing, self.q0, view_direction(self.displacements()))


def content(obj, trajectory=None, speed=1.0):
    """The :class:`Content` of a Modes, Trajectory, System or Scene (plus an optional trajectory: a
    Trajectory or a ``.npz`` file of ``vibdyn simulate --out``), or of one period of a nonlinear orbit (a
    PeriodicOrbit, a Backbone's largest orbit, or ``ForcedResponseCurve.orbit(i)``: its real motion, looped)."""
    from ..._check import scalar

    speed = scalar(speed, "replay speed (× real time)", positive=True)
    orbit = _motion.orbit_motion(obj)
    if orbit is not None:
        system, data, label, slow = orbit
        d = _drawing(system, data[1][0])
        d.frame(data[1])
        return Content(system, d, data[1][0], None, [], data, float(speed) * slow, f"vibdyn: {system.name}",
                       "one period of the orbit, looped", label)
    from ...analysis.modal import Modes
    from ...description.scene import Scene
    from ...model.system import System
    from ...simulation.simulate import Trajectory

    modes = None
    if isinstance(obj, Scene):
        obj = obj.build()
    if isinstance(obj, Trajectory):
        trajectory, obj = obj, obj.system
    if isinstance(obj, Modes):
        modes, system = obj, obj.linear.system
    elif isinstance(obj, System):
        system = obj
    else:
        raise ModelError(f"the viewer shows a Modes, Trajectory, System, Scene, PeriodicOrbit, Backbone or "
                         f"ForcedResponseCurve.orbit(i), got {type(obj).__name__}")
    data = None
    if trajectory is not None:
        if isinstance(trajectory, Trajectory):
            if trajectory.system is not system and trajectory.system.coordinates != system.coordinates:
                raise ModelError("trajectory: it is not a motion of this system")
            data = (np.asarray(trajectory.t, float), np.asarray(trajectory.q, float))
        else:
            data = _motion.load_trajectory(system, trajectory)
    note = ""
    if modes is None and data is None and system.nv:
        try:
            modes = system.operating_point().linearize().modes()
        except ConvergenceError as e:  # no operating point: show the modes about the start, and say so
            q, where = system.start_configuration()
            modes = system.linearize(q).modes()
            note = f" (no operating point found: {e}; modes about {where}, not an equilibrium)"
    lin = modes.linear if modes is not None else None
    q0 = lin.q if lin is not None else (data[1][0] if data is not None else system.neutral())
    d = _drawing(system, q0)
    if data is not None:
        d.frame(data[1])  # the camera frames the whole replayed motion
    views = _motion.mode_views(modes) if modes is not None and data is None else []
    if not views and data is None:
        raise ModelError(f"scene '{system.name}' has no coordinate: nothing moves, nothing to show")
    if data is not None:
        sub = "trajectory replay"
    else:
        sub = f"{len(views)} modes at the operating point; stability {modes.stability}{note}"
    return Content(system, d, q0, lin, views, data, float(speed), f"vibdyn: {system.name}", sub)


def export_html(obj, path, *, amplitude=None, trajectory=None, speed=1.0, mode=1):
    """Write a self-contained HTML page showing ``obj`` (every mode, the trajectory, or one period of a periodic
    orbit or of a forced-response point, looped) and return its path.

    ``amplitude``: the largest point displacement shown (m; default 10 % of the scene's size); ``trajectory``: a
    motion to replay (a Trajectory or a ``.npz`` of ``vibdyn simulate --out``); ``speed``: the replay's speed
    (× real time); ``mode``: the motion shown first (1-based, as the page lists them). The file makes no request to
    any host: meshcat's viewer is inlined (:func:`vibdyn.export_html` says more).
    """
    c = content(obj, trajectory, speed)
    if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)) or not 1 <= mode <= c.n:
        raise ModelError(f"mode {mode!r}: choose a motion from 1 to {c.n} (as the page lists them)")
    anims = [c.animation(k, amplitude) for k in range(c.n)]
    text = offline_page(c.title, c.subtitle, c.motions(amplitude), c.scene_commands(), anims, int(mode) - 1)
    path = Path(path)
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as e:
        raise ModelError(f"cannot write the page {path}: {e.strerror or e}") from None
    return path


def view(obj, *, amplitude=None, trajectory=None, speed=1.0, mode=1, open_browser=False):
    """Show ``obj`` in the browser through a live meshcat server on 127.0.0.1; returns a
    :class:`~vibdyn.faces.viewer.live.LiveViewer` (``.url``, ``.close()``; displays inline in Jupyter).
    ``mode``: the motion shown first (1-based)."""
    from .live import LiveViewer

    return LiveViewer(content(obj, trajectory, speed), amplitude=amplitude, mode=mode, open_browser=open_browser)

