"""Response-spectrum pictures: pseudo-acceleration S_a (m/s²) against period T (s) of a design spectrum or a
record, with the modes of a response-spectrum analysis marked at their periods (numbered from 1, as the tables)."""

from typing import Any

import numpy as np

from ..errors import ModelError
from .plots import figure, save


def plot_response_spectrum(path: Any = None, *results: Any, periods: Any = None, labels: Any = None,
                           g_units: bool = False, dpi: int = 100) -> Any:
    """Draw S_a against T for each result: a record's spectrum (:class:`RecordSpectrum`, its curve with the
    error band where visible), a response-spectrum analysis (:class:`SeismicResponse`: its spectrum on
    ``periods`` (s; default up to 1.5 × its longest mode's) and its modes marked), or a table (T s, S_a m/s²).
    ``g_units``: S_a in g. Saved as PNG at ``path`` (first, as every vibdyn plot); returns the Figure."""
    if not results:
        raise ModelError("response-spectrum plot: nothing to draw (give a record spectrum, a response-spectrum "
                         "analysis or a table of periods and pseudo-accelerations)")
    from ..description.record import G

    scale, unit = (1 / G, "g") if g_units else (1.0, "m/s²")
    fig, axes = figure(size=(7.0, 4.5))
    ax = axes[0, 0]
    labels = list(labels) if labels is not None else [None] * len(results)
    if len(labels) != len(results):
        raise ModelError(f"response-spectrum plot: {len(labels)} labels for {len(results)} curves")
    for r, label in zip(results, labels):
        if hasattr(r, "modal_displacement"):  # a response-spectrum analysis
            T = np.asarray(periods, float) if periods is not None else np.linspace(0.0, 1.5 * r.periods.max(), 300)
            line, = ax.plot(T, r.spectrum(T) * scale, label=label or f"spectrum ({r.combination.upper()})")
            ax.plot(r.periods, r.spectral_acceleration * scale, "o", color=line.get_color())
            for i, (t, s) in enumerate(zip(r.periods, r.spectral_acceleration)):
                ax.annotate(f"{i + 1}", (t, s * scale), textcoords="offset points", xytext=(4, 4), fontsize="small")
        elif hasattr(r, "pseudo_acceleration"):  # a record's spectrum
            sa, err = r.pseudo_acceleration * scale, r.error * scale
            line, = ax.plot(r.periods, sa, label=label or f"record, ζ = {r.damping:g}")
            ax.fill_between(r.periods, sa - err, sa + err, color=line.get_color(), alpha=0.3, lw=0)
        else:
            arr = np.asarray(r, float)
            arr = arr.T if arr.ndim == 2 and arr.shape[0] != 2 else arr
            ax.plot(arr[0], arr[1] * scale, label=label or "spectrum")
    ax.set_xlabel("period T (s)")
    ax.set_ylabel(f"pseudo-acceleration S_a = ω² S_d ({unit})")
    ax.grid(True, alpha=0.3)
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.legend(fontsize="small")
    ax.set_title("response spectrum (modes numbered from 1)", fontsize="medium")
    return save(fig, path, dpi)
