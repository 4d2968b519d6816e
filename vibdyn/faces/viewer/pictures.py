"""Mode shapes as pictures (matplotlib, Agg; no display needed): one panel per mode, the deformed
skeleton of the scene drawn over the undeformed one, projected on the plane the modes move in."""

import numpy as np

from ...description.elements import WORLD, Damper, Spring
from ...errors import ModelError
from . import motion as _motion


def _segments(system, q):
    """World segments (n × 2 × 3) of the scene's skeleton at q: each joint to its body's origin and centre
    of mass, springs and dampers between their anchors; and the centres of mass (m × 3)."""
    scene = system.scene
    segs, coms = [], []
    for b in scene.bodies.values():
        o = system.point_position(b.name, (0, 0, 0), q)
        start = (system.point_position(b.parent, (0, 0, 0), q) if b.parent != WORLD
                 else np.zeros(3) if not np.any(b.joint.at) else np.asarray(b.joint.at, float))
        segs.append((start, o))
        c = system.point_position(b.name, b.com, q)
        segs.append((o, c))
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
    from .page import view_direction

    lin = modes.linear
    system, q0 = lin.system, lin.q0
    views = _motion.mode_views(modes)
    idx = list(range(len(views))) if which is None else [int(i) for i in np.atleast_1d(which)]
    if not idx or any(not 0 <= i < len(views) for i in idx):
        raise ModelError(f"plot: modes must be indices from 0 to {len(views) - 1}, got {which!r}")
    d = drawing(system, q0)
    J = lin.point_jacobian(d.probes) if d.probes else np.zeros((0, lin.nv))
    axes3 = _projection(view_direction(np.concatenate([(J @ views[i].shape).reshape(-1, 3) for i in idx])))
    ncol = min(columns, len(idx))
    nrow = -(-len(idx) // ncol)
    fig, ax = figure(nrow, ncol, size=(3.6 * ncol, 3.4 * nrow))
    base, base_m = _segments(system, q0)
    for a in ax.ravel()[len(idx):]:
        a.set_axis_off()
    for a, i in zip(ax.ravel(), idx):
        v = views[i]
        s = _motion.scale(d, lin, v, amplitude)
        _draw(a, base, base_m, axes3, color="0.7", lw=1.5, label="operating point")
        phases = (1.0, 1j) if np.any(v.shape.imag != 0) else (1.0,)
        for k, z in enumerate(phases):
            seg, m = _segments(system, system.integrate(q0, s * (v.shape * z).real))
            _draw(a, seg, m, axes3, color="C0" if v.kind != "unstable" else "C3", lw=2.0,
                  ls="-" if k == 0 else "--", label="mode" if k == 0 else "mode, 90° later")
        a.set_aspect("equal", adjustable="datalim")
        a.set_xticks([])
        a.set_yticks([])
        a.set_title(v.label, fontsize="small")
    return save(fig, path, dpi)


def _projection(direction):
    """Two screen axes (2 × 3) perpendicular to the viewing direction, the second as close to z as can be."""
    n = np.array([0.55, -1.0, 0.45]) if direction is None else np.asarray(direction, float)
    n = n / np.linalg.norm(n)
    up = np.array([0.0, 0.0, 1.0])
    if abs(n @ up) > 0.95:
        up = np.array([0.0, 1.0, 0.0])
    x = np.cross(up, n)  # right, for a camera at +n looking back along −n
    x /= np.linalg.norm(x)
    return np.vstack([x, np.cross(x, -n)])


def _draw(a, segs, masses, P, color, lw, ls="-", label=None):
    for k, (p, q) in enumerate(segs):
        u, w = P @ p, P @ q
        a.plot([u[0], w[0]], [u[1], w[1]], color=color, lw=lw, ls=ls, label=label if k == 0 else None)
    if masses.size:
        m = masses @ P.T
        a.plot(m[:, 0], m[:, 1], "o", color=color, ms=5)
