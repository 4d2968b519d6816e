"""Log-log plots of power spectral densities: an input PSD (:class:`vibdyn.PSD`) and the response PSDs of a
random response beside its inputs (one-sided, per Hz, SI). Each function takes the path first and returns the
matplotlib ``Figure`` (written as PNG when ``path`` is given)."""

import numpy as np

from ..errors import ModelError
from .plots import figure, save


def _grid(points, lo, hi, n):
    lo = max(lo, 1e-3 * hi) if lo > 0 else 1e-3 * hi
    f = np.geomspace(lo, hi, n)
    return np.unique(np.concatenate([f, [p for p in points if lo <= p <= hi]]))


def plot_psd(path, psd, *, band=None, points=600, dpi=100):
    """G(f) of one input PSD, log-log (SI per Hz), over its band (or ``band`` = (f_lo, f_hi) Hz for an
    unbounded one); breakpoints marked."""
    lo, hi = psd.band if band is None else band
    if not np.isfinite(hi):
        raise ModelError("plot of a PSD over all frequencies: give band=(f_lo, f_hi) Hz")
    f = _grid(psd.breakpoints, lo, hi, points)
    fig, ax = figure(size=(7.0, 4.5))
    ax = ax[0, 0]
    g = psd(f)
    ax.loglog(f[g > 0], g[g > 0], label=f"input ({psd.unit} given; SI shown)")
    if psd.kind == "table":
        ax.loglog(psd.frequency, psd(psd.frequency), "o", ms=4, label="breakpoints (log-log between)")
    ax.set_xlabel("frequency f (Hz)")
    ax.set_ylabel(f"one-sided PSD ({psd.si_unit})")
    ax.set_title(f"{psd.quantity} PSD, one-sided, per Hz")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return save(fig, path, dpi)


def plot_response(path, result, quantity="acceleration", *, outputs=None, band=None, points=1500, dpi=100):
    """The response PSDs of ``result`` (:class:`vibdyn.analysis.response.RandomResponse`) for ``quantity``
    ("displacement", "velocity", "acceleration"), one curve per output (all, or the indices ``outputs``), above
    the input PSDs, log-log, with each output's RMS in the legend."""
    lo = min(p.band[0] for p in result.psds) if band is None else band[0]
    hi = max(p.band[1] for p in result.psds) if band is None else band[1]
    if not np.isfinite(hi):
        raise ModelError("plot of a response to inputs over all frequencies: give band=(f_lo, f_hi) Hz")
    f = _grid(result.split_points, lo, hi, points)
    idx = range(len(result.outputs)) if outputs is None else list(outputs)
    fig, axes = figure(2, 1, size=(7.0, 7.0), sharex=True)
    top, bottom = axes[0, 0], axes[1, 0]
    S = result.psd(f, quantity)
    try:
        rms = result.rms(quantity)
    except ModelError:
        rms = None
    for j in idx:
        label = f"{result.outputs[j]}" + ("" if rms is None else f": RMS {rms[j]:.4g} {result.unit(j, quantity)}")
        top.loglog(f[S[:, j] > 0], S[S[:, j] > 0, j], label=label)
    unit = result.unit(0, quantity)
    top.set_ylabel(f"response PSD (({unit})²/Hz)".replace("((m)", "(m").replace("((rad)", "(rad"))
    top.set_title(f"{quantity} response, one-sided PSD per Hz ({result.method.split(' (')[0]})")
    top.legend(fontsize=8)
    for label, p in zip(result.inputs, result.psds):
        g = p(f)
        bottom.loglog(f[g > 0], g[g > 0], label=f"{label}: {p.quantity} ({p.si_unit})")
    bottom.set_xlabel("frequency f (Hz)")
    bottom.set_ylabel("input PSD (SI per Hz)")
    bottom.legend(fontsize=8)
    for ax in (top, bottom):
        ax.grid(True, which="both", alpha=0.3)
    return save(fig, path, dpi)
