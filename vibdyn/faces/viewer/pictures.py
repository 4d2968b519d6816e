"""Mode shapes as pictures (matplotlib, Agg; no display needed): one panel per mode, the deformed
skeleton of the scene drawn over the undeformed one, projected on the plane the modes move in."""

import numpy as np

from ...description.elements import Damper, Spring
from ...errors import ModelError
from . import motion as _motion


def skeleton(system, q):
    """World segments (n × 2 × 3) of the scene's skeleton at q: each body from its centre of mass to its own
    joint and to every point where it meets the rest (children's joints, spring and damper ends, loop points:
    :func:`vibdyn.faces.viewer.drawing.link_points`), so that a closed loop's links meet and a pendulum shows
    its full length; springs and dampers between their anchors; and the centres of mass (m × 3)."""
    from .drawing import link_points

    scene = system.scene
    segs, coms = [], []
    links = link_points(scene)
    for b in scene.bodies.values():
        c = system.point_position(b.name, b.com, q)
        for p in [np.zeros(3)] + links[b.name]:
            x = system.point_position(b.name, p, q)
            if np.any(x != c):
                segs.append((c, x))
        if b.mass > 0:
            coms.append(c)
    for e in list(scene.elements_of(Spring)) + list(scene.elements_of(Damper)):
        ends = [np.asarray(p, float) if body not in scene.bodies else system.point_position(body, p, q)
                for body, p in (e.a, e.b)]
        segs.append(tuple(ends))
    return np.array(segs, float).reshape(-1, 2, 3), np.array(coms, float).reshape(-1, 3)


def plot_modes(modes, path=None, which=None, amplitude=None, dpi=100, columns=3):
    """A figure with a panel per mode (``which``: 0-based indices; default all): the scene at the operating
    point (grey) and deformed by the mode (colour; a complex mode at phases 0 and 90°, dashed), frequency
    in Hz and rad/s and damping ratio in the title. ``amplitude``: largest point displacement (m; default
    10 % of the scene's size). Saved as PNG when ``path`` is given; returns the matplotlib Figure."""
    from ..plots import figure, save
    from .drawing import drawing
    from .page import plane_normal

    lin = modes.linear
    system, q0 = lin.system, lin.q
    views = _motion.mode_views(modes)
    idx = list(range(len(views))) if which is None else [int(i) for i in np.atleast_1d(which)]
    if not idx or any(not 0 <= i < len(views) for i in idx):
        raise ModelError(f"plot: modes must be indices from 0 to {len(views) - 1}, got {which!r}")
    d = drawing(system, q0)
    J = lin.point_jacobian(d.probes) if d.probes else np.zeros((0, lin.nv))
    if one_dimensional(J, skeleton(system, q0)):  # masses sliding along their own line: drawn on top of it
        return _bar_charts(modes, views, idx, path, dpi)
    # face-on to the plane the modes move in (a planar mechanism is drawn in its own plane), up against gravity
    axes3 = projection(plane_normal(np.concatenate([(J @ views[i].shape).reshape(-1, 3) for i in idx])),
                       -np.asarray(system.scene.gravity, float))
    ncol = min(columns, len(idx))
    nrow = -(-len(idx) // ncol)
    fig, ax = figure(nrow, ncol, size=(3.6 * ncol, 3.4 * nrow))
    base, base_m = skeleton(system, q0)
    shift = _beside(base, axes3, d.size)
    for a in ax.ravel()[len(idx):]:
        a.set_axis_off()
    for a, i in zip(ax.ravel(), idx):
        v = views[i]
        s = _motion.scale(d, lin, v, amplitude)
        _draw(a, base, base_m, axes3, color="0.7", lw=1.5, label="operating point")
        phases = (1.0, 1j) if np.any(v.shape.imag != 0) else (1.0,)
        for k, z in enumerate(phases):
            seg, m = skeleton(system, system.integrate(q0, s * (v.shape * z).real))
            _draw(a, seg, m, axes3, color="C0" if v.behaviour != "unstable" else "C3", lw=2.0,
                  ls="-" if k == 0 else "--", label="mode" if k == 0 else "mode, 90° later", shift=shift)
        a.set_aspect("equal", adjustable="datalim")
        a.set_xticks([])
        a.set_yticks([])
        a.set_title(_wrap(v.label), fontsize="small")
    return save(fig, path, dpi)


def _bar_charts(modes, views, idx, path, dpi):
    """The modes of a scene moving along one line as bar charts of their coordinates, a panel per mode (as
    :func:`vibdyn.faces.plots.mode_shapes`), titled as the skeleton pictures are (ω, f; ζ, ω_n, ω_d when damped):
    a complex (non-classically damped) shape as its two phases, 0 and 90° later (hatched)."""
    from ..plots import figure, save

    labels = list(modes.linear.coordinates)
    fig, ax = figure(len(idx), 1, size=(7.0, 1.2 + 1.9 * len(idx)), sharex=True)
    pos = np.arange(len(labels))
    for a, i in zip(ax[:, 0], idx):
        v = views[i]
        phases = [(v.shape.real, "phase 0")]
        if np.any(v.shape.imag != 0):
            phases.append((v.shape.imag, "90° later"))
        width = 0.8 / len(phases)
        for k, (values, label) in enumerate(phases):
            a.bar(pos + (k - (len(phases) - 1) / 2) * width, values, width=width, label=label,
                  color=np.where(values >= 0, "C0", "C3"), hatch="//" if k else None, edgecolor="white" if k else None)
        a.axhline(0, color="0.4", lw=0.8)
        a.set_ylabel(f"mode {i + 1}")
        a.set_title(v.label, fontsize="small")
        a.grid(True, axis="y", alpha=0.3)
        if len(phases) > 1:
            a.legend(loc="best", fontsize="x-small")
    ax[-1, 0].set_xticks(pos)
    ax[-1, 0].set_xticklabels(labels, rotation=30, ha="right")
    return save(fig, path, dpi)


def one_dimensional(J, skeleton_at_rest, tol=1e-9):
    """Whether the scene moves along one line only: every point's motion (the rows of the point Jacobian ``J``,
    3 per point) along one direction u and the skeleton at rest (segments, centres of mass) on one line along u
    (a chain of sliders on a line, a quarter car). Its deformed drawing would lie on the undeformed one: such a
    scene's modes are drawn as bar charts of their coordinates (:func:`vibdyn.faces.plots.mode_shapes`)."""
    motions = np.asarray(J, float).reshape(-1, 3, J.shape[1]).transpose(0, 2, 1).reshape(-1, 3)
    motions = motions[np.linalg.norm(motions, axis=1) > 0]
    if not len(motions):
        return False
    _, sv, Vt = np.linalg.svd(motions, full_matrices=False)
    if sv.size > 1 and sv[1] > tol * sv[0]:
        return False
    u = Vt[0]
    segs, masses = skeleton_at_rest
    pts = np.concatenate([np.asarray(segs, float).reshape(-1, 3), np.asarray(masses, float).reshape(-1, 3)])
    if len(pts) < 2:
        return True
    c = pts - pts.mean(axis=0)
    across = c - np.outer(c @ u, u)
    return bool(np.abs(across).max() <= tol * max(np.abs(c).max(), 1e-300))


def projection(direction, up=None):
    """Two screen axes (2 × 3): perpendicular to the viewing ``direction`` (None: the usual oblique view),
    the second as close to ``up`` (default z; a zero vector, e.g. no gravity, counts as none) as can be."""
    n = np.array([0.55, -1.0, 0.45]) if direction is None else np.asarray(direction, float)
    n = n / np.linalg.norm(n)
    up = np.array([0.0, 0.0, 1.0]) if up is None or not np.any(up) else np.asarray(up, float) / np.linalg.norm(up)
    if abs(n @ up) > 0.95:  # looking along "up": z, else y, becomes the screen's vertical
        up = np.array([0.0, 0.0, 1.0]) if abs(n[2]) <= 0.95 else np.array([0.0, 1.0, 0.0])
    x = np.cross(up, n)  # right, for a camera at +n looking back along −n
    x /= np.linalg.norm(x)
    return np.vstack([x, np.cross(n, x)])


def _wrap(label, width=44):
    """A title on several lines, broken only after its commas (a number keeps its name on its line)."""
    lines, line = [], ""
    for part in label.split(", "):
        if line and len(line) + 2 + len(part) > width:
            lines.append(line + ",")
            line = part
        else:
            line = f"{line}, {part}" if line else part
    return "\n".join(lines + [line])


def _beside(segs, P, size):
    """Screen offset (2,) of the deformed drawing: none, unless the undeformed one is a single line on the
    screen (masses on one vertical line, as a quarter car), where the deformed shape would be drawn on top
    of it; then a quarter of the scene's size across that line."""
    pts = segs.reshape(-1, 3) @ P.T
    if len(pts) < 2:
        return np.zeros(2)
    c = pts - pts.mean(axis=0)
    _, sv, Vt = np.linalg.svd(c, full_matrices=False)
    if sv.size > 1 and sv[1] > 1e-6 * max(sv[0], 1e-300):
        return np.zeros(2)
    across = np.array([-Vt[0, 1], Vt[0, 0]]) if sv[0] > 0 else np.array([1.0, 0.0])
    return 0.25 * size * across * np.sign(across[0] or 1.0)


def _draw(a, segs, masses, P, color, lw, ls="-", label=None, shift=(0.0, 0.0)):
    shift = np.asarray(shift, float)
    for k, (p, q) in enumerate(segs):
        u, w = P @ p + shift, P @ q + shift
        a.plot([u[0], w[0]], [u[1], w[1]], color=color, lw=lw, ls=ls, label=label if k == 0 else None)
    if masses.size:
        m = masses @ P.T + shift
        a.plot(m[:, 0], m[:, 1], "o", color=color, ms=5)
