"""``vibdyn frf``: a frequency response between two channels, its resonances and half-power damping."""

import sys

import numpy as np

from .._format import json_ready
from ..errors import ModelError


def parse_channel(spec):
    """A CLI channel: a coordinate name, or BODY:X,Y,Z:DX,DY,DZ (a body point, in the body frame, m, and a
    direction in world axes)."""
    parts = spec.split(":")
    if len(parts) == 1:
        return spec
    if len(parts) != 3:
        raise ModelError(f"channel '{spec}': expected a coordinate name or BODY:X,Y,Z:DX,DY,DZ")
    return parts[0], _numbers(parts[1], spec), _numbers(parts[2], spec)


def frf_report(system, input_spec, output_spec, w0=None, w1=None, points=400, method="direct"):
    """The receptance (or, for ``support:NAME:DX,DY,DZ`` inputs, the transmissibility) between two channels
    at the scene's operating point: (FRF, peaks, half power, plain-data dict)."""
    lin = system.operating_point().linearize()
    m = lin.modes()
    notes = []
    if m.stability == "unstable":
        notes.append("the operating point is unstable: no steady harmonic response exists; this is the transfer "
                     "function H(iω) of the linear model (as used in control design)")
    if w0 is None or w1 is None:
        w = m.omega[(~m.rigid) & (m.omega > 0)]  # unstable directions give their growth rate as the scale
        if w.size:
            lo, hi = 0.1 * w.min(), 2.0 * w.max()
        else:
            lo, hi = 0.1, 100.0
            notes.append("no natural frequency (every mode is rigid): default range 0.1 … 100 rad/s; "
                         "give --from and --to")
        w0 = lo if w0 is None else w0
        w1 = hi if w1 is None else w1
    if not (0 <= w0 < w1 < np.inf) or points < 3:
        raise ModelError(f"frf: need 0 ≤ --from < --to (finite, rad/s) and --points ≥ 3, got --from {w0:.6g}, "
                         f"--to {w1:.6g}, --points {points}")
    omega = np.geomspace(w0, w1, points) if w0 > 0 else np.linspace(w0, w1, points)
    out = parse_channel(output_spec)
    if input_spec.startswith("support:"):
        parts = input_spec.split(":")
        if len(parts) not in (2, 3):
            raise ModelError(f"input '{input_spec}': expected support:NAME or support:NAME:DX,DY,DZ")
        d = _numbers(parts[2], input_spec) if len(parts) == 3 else (0.0, 0.0, 1.0)
        frf = lin.base_response(omega, parts[1], direction=d, outputs=[out], method=method)
    else:
        frf = lin.receptance(omega, [parse_channel(input_spec)], [out], method=method)
    peaks, hp = frf.peaks(), frf.half_power()
    data = json_ready({"scene": system.name, **frf.to_dict(), "peaks": peaks.to_dict(), "half_power": hp.to_dict(),
                       "units": frf.units(), "notes": notes})
    return frf, peaks, hp, data


def print_frf(frf, peaks, hp, out=None, notes=()):
    """Print a frequency response's summary: resonances with half-power ζ (undamped ones: unbounded, no
    band), anti-resonances, and ``notes``."""
    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    p(f"{frf.frf_type} {frf.outputs[0]} / {frf.inputs[0]} ({frf.units()}), {frf.omega.size} frequencies "
      f"{frf.omega[0]:.6g} … {frf.omega[-1]:.6g} rad/s")
    p(f"method {frf.method}, damping {frf.damping}; residual {frf.residual:.1e}, relative error ≈ "
      f"{frf.relative_error:.1e}, {frf.elapsed * 1e3:.1f} ms")
    for n in notes:
        p(f"note: {n}")
    p("frequencies of the peaks and troughs of |H| (a damped peak is at neither ω_n nor ω_d exactly); ζ by the "
      "half-power band (ω₂ − ω₁)/(2ω), an estimate of the modal ζ that `vibdyn modes` lists")
    p(f"{'':<16} {'ω rad/s':>14} {'f = ω/2π Hz':>12} {'|H|':>12} {'ζ (half power)':>18}")
    for w, a in zip(peaks.resonances, peaks.amplitudes):
        if not np.isfinite(a):  # undamped, or damped less than the linear model's own error resolves
            zeta = "0 (undamped)" if frf.damping.startswith("undamped") else "within the error"
            p(f"{'resonance':<16} {w:>14.8g} {w / (2 * np.pi):>12.6g} {'unbounded':>12} {zeta:>18}")
            continue
        i = np.flatnonzero(np.isclose(hp.omega_peak, w, rtol=1e-9))
        z = f"{hp.zeta[i[0]]:.6g}" if i.size else "-"
        p(f"{'resonance':<16} {w:>14.8g} {w / (2 * np.pi):>12.6g} {a:>12.6g} {z:>18}")
    undamped = peaks.unbounded is not None and peaks.unbounded.any()
    for w, a in zip(peaks.antiresonances, peaks.antiresonance_amplitudes):
        # undamped: an anti-resonance is a zero of H; what Brent leaves of it is round-off
        p(f"{'anti-resonance':<16} {w:>14.8g} {w / (2 * np.pi):>12.6g} {'0' if undamped else f'{a:.6g}':>12}")


def _numbers(text, spec):
    try:
        x = tuple(float(v) for v in text.split(","))
    except ValueError:
        x = ()
    if len(x) != 3:
        raise ModelError(f"channel '{spec}': '{text}' is not three comma-separated numbers")
    return x
