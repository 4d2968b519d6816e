"""Plots with matplotlib: Bode and Nyquist diagrams of a frequency response, mode-shape bar charts, time
histories. matplotlib (a base dependency) is imported only inside these functions (``import vibdyn`` does not
load it); figures are drawn on the Agg canvas (no display needed, no pyplot state) and saved as PNG when
``path`` is given.

Each function returns the matplotlib ``Figure``.
"""

from typing import TYPE_CHECKING

import numpy as np

from ..errors import ModelError

if TYPE_CHECKING:
    from ..results import TimeResult


def figure(nrows=1, ncols=1, size=(7.0, 5.0), **kwargs):
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:  # pragma: no cover - depends on the installation
        raise ModelError("plots need matplotlib, a dependency of vibdyn missing from this environment: "
                         "pip install matplotlib") from None
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False, **kwargs)
    return fig, axes


def save(fig, path, dpi=100):
    """The figure, written as a PNG file at ``path`` first if given: a path that cannot be written (a missing
    folder, a folder itself) is a ModelError naming it, found before matplotlib draws anything."""
    if path is not None:
        from pathlib import Path

        from ..errors import ModelError

        p = Path(path)
        if p.is_dir():
            raise ModelError(f"picture {path}: is a directory, not a file name (give e.g. {p / 'modes.png'})")
        if not p.parent.is_dir():
            raise ModelError(f"picture {path}: no such directory '{p.parent}'")
        try:
            fig.savefig(p, dpi=dpi, format="png")
        except OSError as e:
            raise ModelError(f"picture {path}: cannot write: {e.strerror or e}") from None
    return fig


def _what(frf, quantity):
    """What a plot of ``frf`` shows: its type (receptance, transmissibility) or the quantity derived from it."""
    return frf.frf_type if quantity == "receptance" else f"{quantity} (of the {frf.frf_type})"


def bode(frf, output=0, input=0, *, quantity="receptance", hz=False, db=False, peaks=True, path=None, dpi=100):
    """Amplitude (log scale, or dB) and phase (degrees) of H_jk against frequency (rad/s, or Hz with
    ``hz``), resonances and anti-resonances marked (``peaks``)."""
    h = frf.get(output, input, quantity)
    j, k = frf.index(output, input)
    x = frf.frequency_hz if hz else frf.omega
    fig, ax = figure(2, 1, sharex=True)
    amp, ph = ax[0, 0], ax[1, 0]
    mag = np.abs(h)
    if db:
        amp.plot(x, 20 * np.log10(np.maximum(mag, 1e-300)), color="C0")
        amp.set_ylabel(f"|H| (dB re 1 {frf.units(j, k, quantity)})")
    else:
        amp.semilogy(x, np.maximum(mag, 1e-300), color="C0")
        amp.set_ylabel(f"|H| ({frf.units(j, k, quantity)})")
    if peaks and frf.omega.size >= 3:
        p = frf.peaks(j, k, quantity)
        scale = (lambda w: w / (2 * np.pi)) if hz else (lambda w: w)
        to_y = (lambda a: 20 * np.log10(np.maximum(a, 1e-300))) if db else (lambda a: np.maximum(a, 1e-300))
        finite = np.isfinite(p.amplitudes)
        amp.plot(scale(p.resonances[finite]), to_y(p.amplitudes[finite]), "v", color="C3", label="resonance")
        for w in p.resonances[~finite]:  # undamped: unbounded amplitude, drawn as a line at ω_r
            amp.axvline(scale(w), color="C3", lw=0.8, ls="--")
        if (~finite).any():
            amp.plot([], [], "--", color="C3", lw=0.8, label="undamped resonance (unbounded)")
        amp.plot(scale(p.antiresonances), to_y(p.antiresonance_amplitudes), "^", color="C2",
                 label="anti-resonance")
        if p.resonances.size or p.antiresonances.size:
            amp.legend(loc="best", fontsize="small")
    ph.plot(x, np.degrees(np.unwrap(np.angle(h))), color="C1")
    ph.set_ylabel("phase (deg)")
    ph.set_xlabel("frequency (Hz)" if hz else "ω (rad/s)")
    if x[0] > 0:
        amp.set_xscale("log")
    amp.margins(y=0.08)
    for a in (amp, ph):
        a.grid(True, which="both", alpha=0.3)
    amp.set_title(f"{_what(frf, quantity)} {frf.outputs[j]} / {frf.inputs[k]} ({frf.method}, {frf.damping})",
                  fontsize="medium")
    return save(fig, path, dpi)


def nyquist(frf, output=0, input=0, *, quantity="receptance", path=None, dpi=100):
    """Nyquist diagram of H_jk: Im H against Re H, the frequency increasing along the curve."""
    h = frf.get(output, input, quantity)
    j, k = frf.index(output, input)
    fig, ax = figure(1, 1, size=(6.0, 6.0))
    a = ax[0, 0]
    a.plot(h.real, h.imag, color="C0")
    a.plot(h.real[:1], h.imag[:1], "o", color="C2", label=f"ω = {frf.omega[0]:.3g} rad/s")
    a.plot(h.real[-1:], h.imag[-1:], "s", color="C3", label=f"ω = {frf.omega[-1]:.3g} rad/s")
    a.axhline(0, color="0.6", lw=0.8)
    a.axvline(0, color="0.6", lw=0.8)
    a.set_aspect("equal", adjustable="datalim")
    unit = frf.units(j, k, quantity)
    a.set_xlabel(f"Re H ({unit})")
    a.set_ylabel(f"Im H ({unit})")
    a.legend(loc="best", fontsize="small")
    a.grid(True, alpha=0.3)
    a.set_title(f"Nyquist: {_what(frf, quantity)} {frf.outputs[j]} / {frf.inputs[k]}", fontsize="medium")
    return save(fig, path, dpi)


def mode_shapes(modes, which=None, *, points=None, direction=None, path=None, dpi=100):
    """Bar charts of mass-normalised mode shapes (one panel per mode): components per coordinate, or
    displacements of body ``points`` along ``direction`` (textbook absolute coordinates)."""
    idx = list(range(modes.n)) if which is None else [int(i) for i in np.atleast_1d(which)]
    if not idx or any(not 0 <= i < modes.n for i in idx):
        raise ModelError(f"mode_shapes: modes must be indices from 0 to {modes.n - 1}, got {which!r}")
    if points is None:
        values, labels = modes.shapes, list(modes.linear.coordinates)
    else:
        if direction is None:
            raise ModelError("mode_shapes: points need a direction (dx, dy, dz)")
        values = modes.point_shapes(points, direction=direction)
        labels = [p if isinstance(p, str) else f"{p[0]}{tuple(p[1])}" for p in points]
    fig, ax = figure(len(idx), 1, size=(7.0, 1.0 + 1.8 * len(idx)), sharex=True)
    pos = np.arange(len(labels))
    for a, r in zip(ax[:, 0], idx):
        a.bar(pos, values[:, r], color=np.where(values[:, r] >= 0, "C0", "C3"))
        a.axhline(0, color="0.4", lw=0.8)
        note = " (rigid)" if modes.rigid[r] else (" (unstable)" if modes.unstable[r] else "")
        a.set_ylabel(f"mode {r + 1}")
        a.set_title(f"mode {r + 1}: ω = {modes.omega[r]:.6g} rad/s, f = {modes.frequency_hz[r]:.6g} Hz{note}",
                    fontsize="small")
        a.grid(True, axis="y", alpha=0.3)
    ax[-1, 0].set_xticks(pos)
    ax[-1, 0].set_xticklabels(labels, rotation=30, ha="right")
    return save(fig, path, dpi)


def time_history(response: "TimeResult", outputs=None, *, direction=None, quantity: str = "displacement", path=None,
                 dpi: int = 100):
    """Time histories of a time result (:class:`vibdyn.results.TimeResult`: a linear
    :class:`~vibdyn.analysis.response.TimeResponse` or a simulated :class:`~vibdyn.simulation.simulate.Trajectory`):
    displacement, velocity or acceleration of its outputs (one curve per output; see the result's ``series``)."""
    labels, units, y = response.series(quantity, outputs, direction)
    fig, ax = figure(1, 1, size=(8.0, 4.5))
    a = ax[0, 0]
    for i, (label, unit) in enumerate(zip(labels, units)):
        a.plot(response.t, y[:, i], label=f"{label} ({unit})")
    a.set_xlabel("t (s)")
    a.set_ylabel(quantity)
    a.grid(True, alpha=0.3)
    a.legend(loc="best", fontsize="small")
    unit = " or ".join(sorted(set(response.units)))  # the positions' error: absolute (the error convention)
    a.set_title(f"{quantity} ({response.method}, position error ≈ {response.error:.1e} {unit})", fontsize="medium")
    return save(fig, path, dpi)


def _runs(flags):
    """(start, stop) index ranges of equal consecutive flags (or labels), each run sharing its end point with the
    next."""
    cuts = [k for k in range(1, len(flags)) if flags[k] != flags[k - 1]]
    edges = [0, *cuts, len(flags)]
    return [(a, min(b + 1, len(flags))) for a, b in zip(edges[:-1], edges[1:])]


def dense_response(curve, per_step=16):
    """A forced-response curve drawn densely: (s, Ω, amplitude) at ``per_step`` samples per continuation step and
    ``s_points``, the arclength of each computed point. Between the points the harmonic-balance coefficients of
    the reported coordinate and Ω are cubic splines of the chord length (coefficients scaled by the largest
    amplitude, Ω by the swept range) and the amplitude max over a period of |x(τ)| is taken from the interpolated
    coefficients; at the points it is the curve's own. None when the curve has fewer than 3 points or no
    system."""
    from scipy.interpolate import CubicSpline

    w, amp, X = np.asarray(curve.omega, float), np.asarray(curve.amplitude, float), np.asarray(curve.coefficients)
    if len(w) < 3 or curve.system is None:
        return None
    a = X[:, :, curve.system.coordinate_index(curve.coordinate)]  # points × (2H + 1): c0, a1, b1, a2, b2, …
    ref = max(float(np.max(amp)), 1e-300)
    span = max(float(np.ptp(w)), 1e-300)
    step = np.sqrt(np.sum((np.diff(X.reshape(len(w), -1), axis=0) / ref) ** 2, axis=1) + (np.diff(w) / span) ** 2)
    if not np.all(step > 0):
        return None
    s_pts = np.concatenate([[0.0], np.cumsum(step)])
    s = np.unique(np.concatenate([np.linspace(s0, s1, per_step + 1) for s0, s1 in zip(s_pts[:-1], s_pts[1:])]))
    s = np.union1d(s, s_pts)
    coef = CubicSpline(s_pts, a, axis=0)(s)
    H = (a.shape[1] - 1) // 2
    tau = np.linspace(0.0, 2 * np.pi, max(512, 32 * (2 * H + 1)), endpoint=False)
    k = np.arange(1, H + 1)
    E = np.ones((tau.size, 2 * H + 1))
    E[:, 1::2], E[:, 2::2] = np.cos(np.multiply.outer(tau, k)), np.sin(np.multiply.outer(tau, k))
    sampled = np.abs(E @ coef.T).max(axis=0)
    at_points = np.abs(E @ a.T).max(axis=0)
    # the sampled maximum misses the refined one by O((π/N)²): the points' own difference, carried between them
    dense_amp = sampled + np.interp(s, s_pts, amp - at_points)
    return s, CubicSpline(s_pts, w)(s), dense_amp, s_pts


def forced_response(curve, *, path=None, dpi=100):
    """A forced-response curve (:func:`vibdyn.forced_response_curve`): the amplitude max over a period of
    |q − q_eq| of its coordinate (m or rad) against the excitation's Ω (rad/s; Hz on the top axis), drawn densely
    through the computed points (:func:`dense_response`: splines of the harmonic coefficients along the arc),
    the points marked; stable stretches solid (and those neutral within the error of |μ|), unstable dashed (Hill's
    method), folds marked ×, the peak ▼."""
    fig, ax = figure(1, 1, size=(7.0, 4.8))
    a = ax[0, 0]
    w, amp = curve.omega, curve.amplitude
    dense = dense_response(curve)
    solid = np.array([s != "unstable" for s in curve.stability])  # (a verdict within its error is none)
    for i, j in _runs(solid):
        style = "-" if solid[i] else "--"
        if dense is None:
            a.plot(w[i:j], amp[i:j], style, color="C0", lw=1.6)
        else:
            s, dw, da, s_pts = dense
            inside = (s >= s_pts[i]) & (s <= s_pts[j - 1])
            a.plot(dw[inside], da[inside], style, color="C0", lw=1.6)
    a.plot(w, amp, "o", color="C0", ms=2.5, label=f"computed points ({len(w)})")
    neutral = "within the error" in curve.stability
    a.plot([], [], "-", color="C0", label="stable, or neutral within the error" if neutral else "stable")
    if not np.all(solid):
        a.plot([], [], "--", color="C0", label="unstable (Hill)")
    if curve.folds:
        a.plot([f.omega for f in curve.folds], [f.amplitude for f in curve.folds], "x", color="C3", ms=8, mew=2,
               label="fold")
    p = curve.peak
    a.plot([p.omega], [p.amplitude], "v", color="C2", ms=8,
           label=f"peak {p.amplitude:.6g} {curve.unit} at Ω = {p.omega:.6g} rad/s")
    u = curve.unit
    a.set_xlabel("excitation frequency Ω (rad/s)")
    a.set_ylabel(f"amplitude max |{curve.coordinate} − {curve.coordinate}_eq| ({u})")
    top = a.secondary_xaxis("top", functions=(lambda x: x / (2 * np.pi), lambda f: 2 * np.pi * f))
    top.set_xlabel("Ω/2π (Hz)")
    a.set_ylim(bottom=0)
    a.grid(True, alpha=0.3)
    a.legend(loc="best", fontsize="small")
    a.set_title(f"forced response, {curve.excitation}; harmonic balance H = {curve.harmonics}, truncation ≤ "
                f"{float(np.max(curve.error)):.1e} {u}", fontsize="small")
    return save(fig, path, dpi)


#: line style per orbit verdict: an undamped orbit that is bounded is neutral (|μ| = 1 within the error): drawn solid
#: like a stable one; unstable dashed; anything else dotted
_VERDICT_STYLE = {"stable": "-", "neutral within the error": "-", "unstable": "--"}
_VERDICT_LABEL = {"stable": "stable (attracting)", "neutral within the error": "neutral: |μ| = 1 within the error "
                  "(bounded)", "unstable": "unstable: |μ| > 1 beyond the error"}


def frequency_energy(backbones, *, path=None, ax=None, dpi=100):
    """Frequency–energy plot of one or several backbones (:func:`vibdyn.backbone`): the nonlinear normal mode's
    fundamental ω (rad/s; Hz on the right axis) against its energy above the equilibrium (J, log scale), each
    requested orbit marked ● and the curve drawn through them smoothly (ω a shape-preserving cubic of log energy:
    the backbone keeps only its requests, not the branch between them); by each orbit's Floquet verdict, stable
    or neutral within the error (|μ| = 1 within its uncertainty: the bounded orbits of an undamped scene) solid,
    unstable dashed, anything else dotted; the linear ω of each mode as a thin dotted line; internal resonances
    (tongues) marked ◆ and labelled. Draws on ``ax`` if given (a matplotlib Axes), else on a new figure; returns
    the Figure."""
    items = list(backbones) if isinstance(backbones, (list, tuple)) else [backbones]
    if not items:
        raise ModelError("frequency_energy: no backbone to plot")
    if ax is None:
        fig, axes = figure(1, 1, size=(7.0, 4.8))
        a = axes[0, 0]
    else:
        a, fig = ax, ax.figure
    styles_used = set()
    for n, bb in enumerate(items):
        color = f"C{n}"
        e, w = np.asarray(bb.energy, float), np.asarray(bb.omega, float)
        order = np.argsort(e)
        e, w = e[order], w[order]
        kinds = np.asarray(bb.stability, dtype=object)[order]
        through = _through(e, w)
        for i, j in _runs(kinds):
            style = _VERDICT_STYLE.get(kinds[i], ":")
            styles_used.add(kinds[i])
            if through is None:
                a.plot(e[i:j], w[i:j], style, color=color, lw=1.6)
            else:
                dense = np.geomspace(e[i], e[j - 1], 24 * (j - i) + 1)
                a.plot(dense, through(np.log(dense)), style, color=color, lw=1.6)
        a.plot(e, w, "o", color=color, ms=3.5, zorder=4)  # the requests: each orbit solved exactly
        a.axhline(bb.linear_omega, color=color, lw=0.8, ls=":", alpha=0.7)
        a.plot([], [], "-", color=color, lw=1.6, label=f"NNM of mode {bb.mode + 1} (amplitude of {bb.coordinate}); "
               f"linear ω = {bb.linear_omega:.6g} rad/s ⋯")
        for r in bb.resonances:
            a.plot([r.energy], [r.omega], "D", color=color, mec="k", ms=7, zorder=5)
            a.annotate(_resonance_label(r), (r.energy, r.omega), xytext=(6, 6), textcoords="offset points",
                       fontsize=8)
        if bb.resonances:
            a.plot([], [], "D", color=color, mec="k", ms=7, ls="none", label="internal resonance (tongue)")
    for kind in sorted(styles_used):
        a.plot([], [], _VERDICT_STYLE.get(kind, ":"), color="0.3", label=_VERDICT_LABEL.get(kind, kind))
    a.set_xscale("log")
    log_ticks(a.xaxis, min(float(np.min(bb.energy)) for bb in items), max(float(np.max(bb.energy)) for bb in items))
    a.set_xlabel("energy above the equilibrium (J)")
    a.set_ylabel("fundamental frequency ω (rad/s)")
    right = a.secondary_yaxis("right", functions=(lambda w: w / (2 * np.pi), lambda f: 2 * np.pi * f))
    right.set_ylabel("f = ω/2π (Hz)")
    a.grid(True, which="both", alpha=0.3)
    a.legend(loc="best", fontsize="small")
    names = sorted({bb.system.name for bb in items})
    err = max(float(np.max(bb.error)) for bb in items)
    a.set_title(f"frequency–energy plot of {', '.join(names)}: backbones (nonlinear normal modes, undamped)\n"
                f"ω by shooting, error ≤ {err:.1e} rad/s", fontsize="small")
    return save(fig, path, dpi)


def axes_first(path, dpi, ax):
    """{path, dpi, ax} of a ``plot(path, dpi, *, ax)`` called with an Axes first (the former order of
    ``Backbone.plot``: ``plot(ax)`` or ``plot(ax, path)``), else as given."""
    if hasattr(path, "figure") and ax is None:
        return {"ax": path, "path": None, "dpi": dpi} if isinstance(dpi, (int, float)) else \
            {"ax": path, "path": dpi, "dpi": 100}
    return {"ax": ax, "path": path, "dpi": dpi}


def log_ticks(axis, lo, hi):
    """Plain labels ("0.2", "1", "50") on a log axis spanning [lo, hi]: every decade, and between decades 2 and 5
    (spans up to 3 decades) or 2…8 (under one), so that labels never crowd (matplotlib's "2×10⁻¹" labels of
    every minor tick overlapped)."""
    from matplotlib.ticker import FuncFormatter, LogLocator

    decades = np.log10(hi / lo) if lo > 0 and hi > lo else 0.0
    labelled = {2, 3, 4, 5, 6, 8} if decades < 1 else {2, 5} if decades <= 3 else set()

    def minor(x, _):
        mantissa = round(x / 10 ** np.floor(np.log10(x) + 1e-9), 6) if x > 0 else 0
        return f"{x:g}" if mantissa in labelled else ""

    axis.set_major_locator(LogLocator(base=10))
    axis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    axis.set_minor_locator(LogLocator(base=10, subs=np.arange(2, 10)))
    axis.set_minor_formatter(FuncFormatter(minor))


def _through(e, w):
    """ω as a smooth function of log energy through the requests (energies increasing, positive): a
    shape-preserving cubic (PCHIP: no overshoot between the points, monotone where they are), so that a backbone
    is drawn as a curve on the log-energy axis; None when it cannot be (fewer than 2 points, a repeated energy)."""
    if len(e) < 2 or not np.all(e > 0) or not np.all(np.diff(e) > 0):
        return None
    from scipy.interpolate import PchipInterpolator

    return PchipInterpolator(np.log(e), w)


def _resonance_label(r):
    """"3:1 with mode 2" (a tongue: mode numbers from 1) or "fold"."""
    if r.category == "fold":
        return "fold"
    return f"{r.ratio}:1 with mode {r.other_mode + 1}" if r.ratio is not None else r.category
