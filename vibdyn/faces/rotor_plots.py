"""Rotor pictures (matplotlib, Agg, imported on call): the Bode and polar plots of an unbalance response.

Each function returns the matplotlib ``Figure``, saved as a PNG at ``path`` when given.
"""

import numpy as np

from .campbell_plot import SPEED_UNITS, unit_factor
from .plots import figure, save


def bode(response, path=None, outputs=None, *, units="rad/s", peak_to_peak=False, dpi=100):
    """Amplitude (log scale, 0-peak or peak-to-peak, with its error band) and phase (degrees) of each output
    against the spin speed (``units`` "rad/s" or "rpm"); resonance peaks marked on the amplitude."""
    scale = unit_factor(units, SPEED_UNITS, "UnbalanceResponse.plot units (the speed axis)")
    cols = range(len(response.outputs)) if outputs is None else [response.column(o) for o in (
        [outputs] if isinstance(outputs, (str, int)) else outputs)]
    fig, ax = figure(2, 1, size=(7.0, 6.0), sharex=True)
    top, bottom = ax[0, 0], ax[1, 0]
    w = response.speeds * scale
    factor = 2.0 if peak_to_peak else 1.0
    for j in cols:
        a = factor * response.amplitude[:, j]
        e = factor * response.amplitude_error[:, j]
        (line,) = top.semilogy(w, np.where(a > 0, a, np.nan), lw=1.5,
                               label=f"{response.outputs[j]} ({response.units[j]})")
        top.fill_between(w, np.maximum(a - e, a * 1e-3), a + e, color=line.get_color(), alpha=0.2, lw=0)
        bottom.plot(w, np.degrees(np.unwrap(response.phase[:, j])), lw=1.5, color=line.get_color())
        for k in range(1, len(a) - 1):
            if a[k] > a[k - 1] and a[k] >= a[k + 1]:
                top.plot(w[k], a[k], "v", color=line.get_color(), ms=6)
    kind = "peak-to-peak" if peak_to_peak else "0-peak"
    units = sorted({response.units[j] for j in cols})
    top.set_ylabel(f"amplitude, {kind} ({' or '.join(units)})")
    top.legend(fontsize=8)
    top.grid(True, which="both", alpha=0.3)
    top.set_title(f"Unbalance response: {response.system.name} ({response.spin} held at each speed)")
    bottom.set_ylabel("phase (deg)")
    bottom.set_xlabel(f"speed of {response.spin} ({units})")
    bottom.grid(True, alpha=0.3)
    return save(fig, path, dpi)


def polar(response, path=None, output=0, *, dpi=100):
    """The synchronous response x of one output in the complex plane (Re, Im), speeds marked along it."""
    j = response.column(output)
    fig, ax = figure(size=(6.0, 6.0))
    ax = ax[0, 0]
    x = response.x[:, j]
    ax.plot(x.real, x.imag, "-o", ms=3, lw=1.2)
    step = max(1, len(x) // 8)
    for k in range(0, len(x), step):
        ax.annotate(f"{response.speeds[k]:.4g} rad/s", (x[k].real, x[k].imag), xytext=(4, 4),
                    textcoords="offset points", fontsize=7)
    ax.axhline(0, color="0.6", lw=0.6)
    ax.axvline(0, color="0.6", lw=0.6)
    ax.set_aspect("equal", adjustable="datalim")
    unit = response.units[j]
    ax.set_xlabel(f"Re x ({unit}, 0-peak)")
    ax.set_ylabel(f"Im x ({unit}, 0-peak)")
    ax.set_title(f"Polar plot: {response.outputs[j]}")
    ax.grid(True, alpha=0.3)
    return save(fig, path, dpi)
