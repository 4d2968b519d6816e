"""Motions to show: a mode as q(θ) = integrate(q₀, a·Re(φ e^{iθ})) over one cycle, or a trajectory at real
time; and their meshcat animations (node tracks of position, quaternion and scale per frame).

A mode's shape φ (rad and m mixed) is sized by what it does to the scene: ``a`` makes the largest
displacement of the probe points (body origins, centres of mass, anchors) equal to ``amplitude`` (m;
default 10 % of the scene's size), and no joint turns more than 0.6 rad. Damped and gyroscopic modes
animate their complex shape's phase (a travelling wave); rigid modes drift one way, unstable and
overdamped ones grow (sawtooth loops, labelled).
"""

from dataclasses import dataclass

import numpy as np

from ...errors import ModelError

MAX_ANGLE = 0.6  # rad: the largest joint rotation an animated mode may show
FRAMES = 40  # frames per cycle
PERIOD = 2.0  # s: one cycle of a shown mode lasts this long (whatever its frequency)


@dataclass(frozen=True)
class ModeView:
    """One mode as the viewer lists it, each number named after the glossary (docs/guide/glossary.md):
    ``omega`` is the undamped ω of the undamped problem, or the damped ω_d = |Im λ| of the state form
    (``damped``), rad/s; ``omega_n`` = |λ| (state form), ``zeta`` = −Re λ/|λ| (nan when undamped); ``rate``
    the growth (> 0) or decay (< 0) rate of a mode that does not oscillate, or the growth of an unstable
    oscillation (1/s: a rate, not a frequency)."""

    index: int  # 0-based
    omega: float  # rad/s: ω (undamped) or ω_d (damped); 0 for a mode that does not oscillate
    zeta: float  # damping ratio (nan when undamped analysis)
    behaviour: str  # "oscillating", "rigid", "unstable" or "overdamped"
    shape: np.ndarray  # complex, nv
    rate: float = 0.0  # 1/s
    omega_n: float = float("nan")  # rad/s (state form)
    damped: bool = False  # from the state form (ω_d, ω_n, ζ) rather than the undamped problem (ω)

    @property
    def frequency_hz(self) -> float:
        """ω in Hz (f or f_d)."""
        return self.omega / (2 * np.pi)

    @property
    def label(self):
        head = f"mode {self.index + 1}"
        if self.behaviour == "rigid":
            return f"{head}: rigid (ω = 0), drifts"
        if self.omega == 0.0:  # no oscillation: a rate (1/s), not a frequency
            what = "UNSTABLE, growth rate" if self.behaviour == "unstable" else "overdamped, decay rate"
            z = f", ζ = {self.zeta:.4g}" if self.damped else ""
            return f"{head}: {what} {abs(self.rate):.4g} 1/s (not a frequency){z}"
        if self.damped:
            text = (f"ω_d = {self.omega:.4g} rad/s (f_d = {self.frequency_hz:.4g} Hz), "
                    f"ω_n = {self.omega_n:.4g} rad/s, ζ = {self.zeta:.4g}")
        else:
            text = f"ω = {self.omega:.4g} rad/s (f = {self.frequency_hz:.4g} Hz), undamped"
        if self.behaviour == "unstable":
            text += f", UNSTABLE: growth rate {self.rate:.4g} 1/s"
        return f"{head}: {text}"


def mode_views(modes):
    """The modes of a :class:`vibdyn.analysis.modal.Modes` as the viewer shows them: the damped complex modes when the
    model has damping or gyroscopic terms, else the undamped real ones."""
    out = []
    if modes.eigenvalues.size:
        err = modes.eigenvalue_error  # (1/s): a growth within it is no growth
        for i, lam in enumerate(modes.damped_eigenvalues):
            phi = modes.complex_shapes[:, i]
            grows = lam.real > err[i]
            if modes.damped_zero[i]:
                behaviour, w = "rigid", 0.0
            elif lam.imag == 0:
                behaviour, w = ("unstable" if grows else "overdamped"), 0.0
                phi = _real(phi)
            else:
                behaviour, w = ("unstable" if grows else "oscillating"), abs(lam.imag)
            if behaviour == "rigid":
                phi = _real(phi)
            out.append(ModeView(i, float(w), float(modes.zeta[i]), behaviour, phi, float(lam.real),
                                float(modes.omega_n[i]), True))
    else:
        for i in range(modes.n):
            behaviour = "rigid" if modes.rigid[i] else ("unstable" if modes.unstable[i] else "oscillating")
            w = 0.0 if behaviour != "oscillating" else float(modes.omega[i])
            rate = float(modes.omega[i]) if behaviour == "unstable" else 0.0  # ω² < 0: e^{±√|ω²| t}
            out.append(ModeView(i, w, float("nan"), behaviour, modes.shapes[:, i].astype(complex), rate))
    return out


def _real(phi):
    """A real shape from a complex one (rotated so that its largest component is real)."""
    k = int(np.argmax(np.abs(phi)))
    return (phi * np.exp(-1j * np.angle(phi[k]))).real.astype(complex)


def _phases(view, n=FRAMES):
    """Multipliers of the shape over one loop: e^{iθ} for oscillations, a real sawtooth otherwise."""
    u = np.arange(n + 1) / n
    if view.behaviour in ("oscillating",) or (view.behaviour == "unstable" and np.any(view.shape.imag != 0)):
        return np.exp(2j * np.pi * u)
    if view.behaviour == "rigid":
        return (2 * u - 1).astype(complex)
    return (np.expm1(3 * u) / np.expm1(3) * 2 - 1).astype(complex)  # grows (or decays, shown growing)


def scale(drawing, linear, view, amplitude=None, J=None):
    """The factor a: largest probe displacement = ``amplitude`` m (default 10 % of the scene size), joints
    turning at most 0.6 rad. ``J``: the probes' point Jacobian at the operating point, if known."""
    try:
        target = 0.1 * drawing.size if amplitude is None else float(amplitude)
    except (TypeError, ValueError):
        raise ModelError(f"amplitude must be a positive length in m, got {amplitude!r}") from None
    if not np.isfinite(target) or target <= 0:
        raise ModelError(f"amplitude must be a positive length in m, got {amplitude!r}")
    if target > 100 * drawing.size:  # a mode is a small motion: shown a hundred times the scene, it is noise
        raise ModelError(f"amplitude {target:g} m is more than 100 times the scene's size ({drawing.size:.3g} m): "
                         "give a displacement of the order of the scene")
    if J is None:
        J = linear.point_jacobian(drawing.probes) if drawing.probes else np.zeros((0, linear.nv))
    ph = np.exp(2j * np.pi * np.arange(8) / 8)
    d = (J @ view.shape)[:, None] * ph[None, :]  # (3P × 8)
    disp = np.sqrt((d.real.reshape(-1, 3, 8) ** 2).sum(axis=1)).max(initial=0.0)
    rad = np.array([u == "rad" for u in linear.units])
    turn = np.abs(view.shape[rad]).max(initial=0.0)
    a = target / disp if disp > 1e-12 * max(1.0, np.abs(view.shape).max()) else np.inf
    if turn > 0:
        a = min(a, MAX_ANGLE / turn)
    if not np.isfinite(a):
        a = target / max(np.abs(view.shape).max(), 1e-300)
    return float(a)


def mode_frames(system, q0, view, a, n=FRAMES):
    """Configurations of one loop of the mode (n + 1 frames, the last equal to the first for a cycle)."""
    return [system.integrate(q0, a * (view.shape * z).real) for z in _phases(view, n)]


def trajectory_frames(trajectory_or_system, data=None, fps=30.0, speed=1.0, max_frames=3000):
    """(times shown (s), configurations) of a trajectory replayed at ``speed`` × real time, ``fps`` frames
    per shown second; configurations between samples are interpolated on the Lie group."""
    if data is None:
        tr = trajectory_or_system
        system, t, q = tr.system, np.asarray(tr.t, float), np.asarray(tr.q, float)
    else:
        system, (t, q) = trajectory_or_system, data
    if speed <= 0 or not np.isfinite(speed):
        raise ModelError(f"replay speed must be positive, got {speed!r}")
    if t.ndim != 1 or q.shape != (t.size, system.nq) or t.size < 1:
        raise ModelError(f"trajectory: expected t (n) and q (n × {system.nq}) for scene '{system.name}', "
                         f"got {t.shape} and {q.shape}")
    duration = (t[-1] - t[0]) / speed
    n = int(min(max_frames, max(2, np.ceil(duration * fps) + 1)))
    ts = np.linspace(t[0], t[-1], n)
    frames = []
    for x in ts:
        k = int(np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 1))
        if k == t.size - 1 or t[k + 1] == t[k]:
            frames.append(q[k].copy())
        else:
            s = (x - t[k]) / (t[k + 1] - t[k])
            frames.append(system.integrate(q[k], s * system.difference(q[k], q[k + 1])))
    return (ts - t[0]) / speed, frames, ts


def load_trajectory(system, path):
    """(t, q) of a trajectory file written by ``vibdyn simulate --out``: ``.npz`` (``Trajectory.to_npz``) or
    ``.csv`` (``Trajectory.to_csv``: its ``t`` and ``q:…`` columns)."""
    from pathlib import Path

    suffix = Path(path).suffix.lower()
    if suffix not in (".npz", ".csv"):
        raise ModelError(f"trajectory {path}: reads the .npz and .csv files of `vibdyn simulate --out` "
                         f"(Trajectory.to_npz, to_csv), not '{suffix or 'no extension'}'")
    names = None
    try:
        if suffix == ".csv":
            t, q = _read_csv(path)
        else:
            with np.load(path, allow_pickle=False) as z:
                t, q = np.asarray(z["t"], float), np.asarray(z["q"], float)
                names = [str(x) for x in z["coordinates"]] if "coordinates" in z else None
    except (OSError, ValueError, KeyError) as e:
        raise ModelError(f"trajectory {path}: cannot read a vibdyn {suffix} trajectory ({e})") from None
    if names is not None and tuple(names) != tuple(system.coordinates):
        raise ModelError(f"trajectory {path}: its coordinates {names} are not those of scene '{system.name}' "
                         f"{list(system.coordinates)}")
    if q.ndim != 2 or q.shape[1] != system.nq or t.shape != (q.shape[0],) or not np.all(np.isfinite(q)):
        raise ModelError(f"trajectory {path}: q must be (n × {system.nq}) finite numbers, got {q.shape}")
    return t, q


def _read_csv(path):
    """(t, q) of a ``Trajectory.to_csv`` file: its last '#' header line names the columns."""
    header = None
    with open(path, encoding="utf-8") as f:
        for line in f:
            if not line.startswith("#"):
                break
            header = line[1:].strip()
    names = header.split(",") if header else []
    if "t" not in names or not any(n.startswith("q:") for n in names):
        raise ValueError("no 't' and 'q:…' columns in its header")
    table = np.loadtxt(path, delimiter=",", comments="#", ndmin=2)
    cols = [i for i, n in enumerate(names) if n.startswith("q:")]
    return table[:, names.index("t")], table[:, cols]


def animation(drawing, times, frames, root):
    """meshcat ``set_animation`` payload (list of per-node clips) of configurations at the given times (s)."""
    times = np.asarray(times, float)
    states = [drawing.state(q) for q in frames]
    names = states[0][0]
    mats = np.array([s[1] for s in states]).reshape(len(frames), len(names), 4, 4)
    ends = np.array([s[2] for s in states]).reshape(len(frames), -1, 2, 3)
    out = [_clip(f"{root}/{name}", times, mats[:, i, :3, 3], quaternions(mats[:, i, :3, :3]), None)
           for i, name in enumerate(names)]
    for j, (name, _, _) in enumerate(drawing.links):
        a, b = ends[:, j, 0], ends[:, j, 1]
        d = b - a
        L = np.linalg.norm(d, axis=1)
        u = d / np.where(L > 0, L, 1.0)[:, None]
        u[L == 0] = (0.0, 0.0, 1.0)
        quat = np.column_stack([-u[:, 1], u[:, 0], np.zeros(len(u)), 1.0 + u[:, 2]])  # z → u (x, y, z, w)
        flip = quat[:, 3] < 1e-9  # u = −z: half a turn about x
        quat[flip] = (1.0, 0.0, 0.0, 0.0)
        quat /= np.linalg.norm(quat, axis=1)[:, None]
        scale = np.column_stack([np.ones_like(L), np.ones_like(L), np.maximum(L, 1e-9)])
        out.append(_clip(f"{root}/links/{name}", times, a, quat, scale))
    return out


def quaternions(R):
    """Unit quaternions (x, y, z, w) of rotation matrices (n × 3 × 3), each on the side of its predecessor
    (so that interpolation between frames takes the short way)."""
    q = _quaternions(np.asarray(R, float).reshape(-1, 3, 3))
    for k in range(1, len(q)):
        if np.dot(q[k], q[k - 1]) < 0:
            q[k] = -q[k]
    return q


def _quaternions(R):
    """Vectorised rotation matrix → quaternion (x, y, z, w), the best-conditioned of the four formulas."""
    t = np.einsum("nii->n", R)
    cand = np.column_stack([t, R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]])
    k = np.argmax(cand, axis=1)
    q = np.empty((len(R), 4))
    for case in range(4):
        m = k == case
        if not m.any():
            continue
        r = R[m]
        if case == 0:
            s = 2 * np.sqrt(1 + t[m])
            q[m] = np.column_stack([(r[:, 2, 1] - r[:, 1, 2]) / s, (r[:, 0, 2] - r[:, 2, 0]) / s,
                                    (r[:, 1, 0] - r[:, 0, 1]) / s, s / 4])
        else:
            i = case - 1
            j, l = (i + 1) % 3, (i + 2) % 3
            s = 2 * np.sqrt(1 + r[:, i, i] - r[:, j, j] - r[:, l, l])
            v = np.empty((m.sum(), 4))
            v[:, i] = s / 4
            v[:, j] = (r[:, j, i] + r[:, i, j]) / s
            v[:, l] = (r[:, l, i] + r[:, i, l]) / s
            v[:, 3] = (r[:, l, j] - r[:, j, l]) / s
            q[m] = v
    return q / np.linalg.norm(q, axis=1)[:, None]


def _clip(path, times, pos, quat, scale):
    tracks = [_track(".position", "vector3", times, pos), _track(".quaternion", "quaternion", times, quat)]
    if scale is not None:
        tracks.append(_track(".scale", "vector3", times, scale))
    return {"path": path, "clip": {"fps": 1, "name": "default", "tracks": tracks}}


def _track(name, kind, times, values):
    return {"name": name, "type": kind, "times": np.round(times, 6).tolist(),
            "values": np.round(values, 6).ravel().tolist()}


def orbit_motion(obj):
    """(system, (t, q), label, slow-down) of one period of a nonlinear orbit — a
    :class:`~vibdyn.analysis.nonlinear.periodic.PeriodicOrbit` (its trajectory) or a forced-response point
    (:class:`~vibdyn.analysis.nonlinear.response_orbit.ResponseOrbit`, the harmonic-balance motion) — or None for
    anything else; a :class:`~vibdyn.analysis.nonlinear.backbone.Backbone` shows the orbit of its largest energy.
    The slow-down (≤ 1) shows a period shorter than ``PERIOD`` s over ``PERIOD`` s."""
    from ...analysis.nonlinear.backbone import Backbone
    from ...analysis.nonlinear.periodic import PeriodicOrbit
    from ...analysis.nonlinear.response_orbit import ResponseOrbit

    head = ""
    if isinstance(obj, Backbone):
        i = int(np.argmax(obj.energy))
        head = (f"backbone of mode {obj.mode + 1}, its largest request: amplitude of {obj.coordinate} "
                f"{obj.amplitude[i]:.6g} {obj.unit}, energy {obj.energy[i]:.6g} J; ")
        obj = obj.orbits[i]
    if isinstance(obj, PeriodicOrbit):
        tr = obj.trajectory
        data = (np.asarray(tr.t, float), np.asarray(tr.q, float))
        label = (f"{head}periodic orbit: T = {obj.period:.6g} s (ω = {obj.omega:.6g} rad/s, {obj.frequency_hz:.4g} "
                 f"Hz), {obj.stability}")
    elif isinstance(obj, ResponseOrbit):
        data = (np.asarray(obj.t, float), np.asarray(obj.q, float))
        label = (f"forced response at Ω = {obj.omega:.6g} rad/s ({obj.frequency_hz:.4g} Hz): amplitude of "
                 f"{obj.coordinate} {obj.amplitude:.6g} {obj.unit}, {obj.stability}")
    else:
        return None
    period = float(data[0][-1] - data[0][0])
    return obj.system, data, label, min(1.0, period / PERIOD)
