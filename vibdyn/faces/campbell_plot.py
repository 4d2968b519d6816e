"""Pictures of rotors for a report: the Campbell diagram (speeds in rad/s or rpm, frequencies in Hz or rad/s,
modes numbered from 1 as the tables number them, engine orders labelled inside the axes, critical speeds
listed beside the axes rather than written over the curves), the critical-speed map (log-log) and the log
decrement against a parameter (the stability limit). matplotlib is imported only here, on call."""

from __future__ import annotations

import numpy as np

from ..defaults import RPM
from ..errors import ModelError
from .plots import figure, save

SPEED_UNITS = {"rad/s": 1.0, "rpm": RPM}
FREQUENCY_UNITS = {"Hz": 1.0 / (2 * np.pi), "rad/s": 1.0}
WHIRL_STYLES = {"forward": "-", "backward": "--", "": ":"}


def unit_factor(units: str, table: dict, what: str) -> float:
    """The factor from rad/s to ``units`` (one of ``table``), or a ModelError naming ``what``."""
    if units not in table:
        raise ModelError(f"{what}: expected one of {', '.join(repr(u) for u in table)}, got {units!r}")
    return table[units]


def _order_label(ax, order, xs, fy, top, color="0.35"):
    """Label the engine-order line y = order·fy·|x| inside the axes, near where it leaves them, along it."""
    x_end = min(xs[-1], top / (order * fy)) if order * fy > 0 else xs[-1]
    x = xs[0] + 0.94 * (x_end - xs[0])
    y = order * fy * abs(x)
    ax.annotate(f"{order:g}×", (x, y), xytext=(-3, 3), textcoords="offset points", ha="right", va="bottom",
                fontsize=8, color=color, bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85))


def campbell(diagram, *, path=None, units="rad/s", frequency="Hz", dpi=100):
    """Campbell diagram: each tracked mode's frequency against the spin speed, forward whirl solid, backward
    dashed, no whirl dotted; engine orders as thin grey lines labelled inside the axes; stretches where a mode
    is unstable (Re λ > 0 beyond its error) overdrawn with red crosses; critical speeds circled, numbered on
    the top axis and listed in the legend beside the axes (never written over the curves)."""
    kx = unit_factor(units, SPEED_UNITS, "Campbell.plot units (the speed axis)")
    ky = unit_factor(frequency, FREQUENCY_UNITS, "Campbell.plot frequency (the frequency axis)")
    fig, ax = figure(size=(9.0, 5.2))
    ax = ax[0, 0]
    x = diagram.speeds * kx
    f = diagram.omega * ky
    for j in range(f.shape[1]):
        if not np.any(f[:, j] > 0):
            continue
        kinds = [k for k in ("forward", "backward", "") if np.any(diagram.whirl[:, j] == k)]
        kind = max(kinds, key=lambda k: np.sum(diagram.whirl[:, j] == k))
        ax.plot(x, f[:, j], WHIRL_STYLES[kind], lw=1.6, label=f"mode {j + 1} ({kind or 'no'} whirl)")
    unstable = diagram.sigma > diagram.error
    if np.any(unstable):
        ax.plot(x[np.nonzero(unstable)[0]], f[unstable], "x", color="tab:red", ms=6, label="unstable (Re λ > 0)")
    top = max(f.max(initial=0.0) * 1.12, 1e-12)
    fy = ky / kx  # an order line in plot units: order · |Ω| → order · ky/kx · |x|
    marks = []
    for order in diagram.orders:
        ax.plot(x, order * fy * np.abs(x), color="0.55", lw=0.8, zorder=1)
        _order_label(ax, order, x, fy, top)
        for c in diagram.critical_speeds(order):
            marks.append(c)
            ax.plot(c.speed * kx, c.omega * ky, "o", mfc="none", mec="k", ms=8, zorder=3)
            ax.axvline(c.speed * kx, color="0.75", lw=0.6, ls=":", zorder=0)
    if marks:
        marks.sort(key=lambda c: c.speed)
        sec = ax.secondary_xaxis("top")
        sec.set_xticks([c.speed * kx for c in marks], labels=[f"c{i + 1}" for i in range(len(marks))], fontsize=7)
        sec.tick_params(length=2, pad=1)
        for i, c in enumerate(marks):
            ax.plot([], [], " ", label=f"c{i + 1}: {c.speed * kx:.5g} {units}, mode {c.number} "
                                       f"({c.whirl or 'no'} whirl), {c.order:g}×")
    ax.set_ylim(0, top)
    ax.set_xlim(x[0], x[-1])
    ax.set_xlabel(f"speed of {diagram.spin} ({units})")
    what = "f_d = ω_d/2π (Hz)" if frequency == "Hz" else "ω_d (rad/s)"
    frame = "" if diagram.frame == "fixed" else f", in the {diagram.frame} frame"
    ax.set_ylabel(f"damped frequency {what}{frame}")
    kind = "undamped " if diagram.undamped else ""
    ax.set_title(f"{kind}Campbell diagram: {diagram.system.name} ({diagram.spin} "
                 f"{'held' if diagram.held else 'free'})", fontsize="medium")
    ax.grid(True, alpha=0.3)
    fig.legend(loc="outside right upper", fontsize=7.5, frameon=False)
    return save(fig, path, dpi)


def critical_speed_map(cmap, *, path=None, units="rad/s", dpi=100):
    """Critical-speed map: the 1st, 2nd, … undamped critical speeds against the parameter, log-log."""
    kx = unit_factor(units, SPEED_UNITS, "CriticalSpeedMap.plot units")
    fig, ax = figure(size=(7.5, 5.0))
    ax = ax[0, 0]
    for k in range(cmap.speeds.shape[1]):
        col = cmap.speeds[:, k]
        ax.loglog(cmap.values, col * kx, "o-", ms=3, lw=1.4, label=_ordinal(k + 1) + " critical speed")
    lo, hi = cmap.speed_range
    for s in (lo, hi):
        if s > 0:
            ax.axhline(s * kx, color="0.6", lw=0.7, ls="--")
    ax.set_xlabel(f"{cmap.parameter} ({cmap.unit})" if cmap.unit else cmap.parameter)
    ax.set_ylabel(f"undamped critical speed ({units}), engine order {cmap.order:g}")
    ax.set_title(f"critical-speed map of {cmap.spin} (searched in {lo * kx:.4g}…{hi * kx:.4g} {units})",
                 fontsize="medium")
    ax.grid(True, which="both", alpha=0.3)
    if cmap.speeds.shape[1]:
        ax.legend(fontsize=8, loc="best")
    return save(fig, path, dpi)


def _ordinal(n: int) -> str:
    return f"{n}{'th' if 10 <= n % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(n % 10, 'th')}"


def stability_limit(limit, *, path=None, dpi=100):
    """The log decrement of the tracked mode against the parameter, with its error band; the limit marked."""
    fig, ax = figure(size=(7.0, 4.5))
    ax = ax[0, 0]
    v, d, e = limit.values, limit.log_dec, limit.log_dec_error
    ax.plot(v, d, "o-", ms=3, lw=1.4, label=f"mode {limit.number} ({limit.whirl[0] or 'no'} whirl at the first value)")
    ax.fill_between(v, d - e, d + e, color="tab:blue", alpha=0.2, lw=0)
    ax.axhline(0.0, color="k", lw=0.8)
    if limit.limit is not None:
        ax.axvline(limit.limit, color="tab:red", lw=1.0, ls="--",
                   label=f"δ = 0 at {limit.limit:.6g} ± {limit.limit_error:.1e}")
    ax.set_xlabel(f"{limit.parameter} ({limit.unit})" if limit.unit else limit.parameter)
    frame = "" if limit.frame == "fixed" else f", Im λ in the {limit.frame} frame"
    ax.set_ylabel(f"log decrement δ = −2π Re λ/|Im λ|{frame}")
    ax.set_title(f"stability at {limit.spin} = {limit.speed:.5g} rad/s ({limit.speed * RPM:.5g} rpm)",
                 fontsize="medium")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return save(fig, path, dpi)
