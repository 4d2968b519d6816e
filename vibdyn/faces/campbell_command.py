"""``vibdyn campbell``: the Campbell diagram of a rotor as a table (Hz, whirl) and its critical speeds."""

import sys

import numpy as np

from .._format import number, table
from ..defaults import RPM
from ..errors import ModelError


def speed_list(text, unit="rad/s"):
    """Speeds (in ``unit``) from ``FROM:TO:N`` (N equally spaced, ends included) or ``a,b,c``."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            if int(n) < 2:
                raise ValueError
            ends = float(a), float(b)
            if not np.all(np.isfinite(ends)):
                raise ValueError
            return np.linspace(*ends, int(n))
        speeds = np.array([float(x) for x in text.split(",")])
        if not np.all(np.isfinite(speeds)):
            raise ValueError
        return speeds
    except ValueError:
        raise ModelError(f"--speeds: expected FROM:TO:N (N ≥ 2) or a comma list of speeds in {unit}, finite, got "
                         f"'{text}'") from None


def spin_state(c) -> str:
    """How the diagram treats its spin, in words."""
    return (f"'{c.spin}' held at each speed by its drive (not a coordinate of the modes)" if c.held else
            f"'{c.spin}' free at each steady motion (its own coordinate, a cyclic zero among the modes)")


def command(system, args, out=None):
    """``vibdyn campbell``: the diagram as a table (Hz, whirl) and its critical speeds, or JSON."""
    from ..analysis.campbell_diagram import campbell

    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    try:
        orders = tuple(float(x) for x in args.orders.split(","))
        if not all(np.isfinite(orders)):
            raise ValueError
    except ValueError:
        raise ModelError(f"--orders: expected finite numbers separated by commas, got '{args.orders}'") from None
    held = False if getattr(args, "free_spin", False) else None
    unit = "rpm" if getattr(args, "rpm", False) else "rad/s"
    k = RPM if unit == "rpm" else 1.0  # rad/s -> the unit shown
    c = campbell(system, args.spin, speed_list(args.speeds, unit) / k, orders, method=args.method, held=held)
    from .nonlinear_command import write_files  # the picture after the table: a failure to write it keeps the table

    files = [(args.png, lambda: c.plot(args.png, units=unit))]
    if args.json:
        import json

        p(json.dumps(c.to_dict(), indent=1))
        write_files(p, files, announce=False)
        return c
    m = c.omega.shape[1]
    p(f"Campbell diagram of {system.name}: {len(c.speeds)} speeds of '{c.spin}', {m} modes tracked by MAC "
      f"({c.method} linearisation, {c.elapsed:.2f} s); {spin_state(c)}")
    rows = [[number(s * k)] + [f"{number(f / (2 * np.pi), digits=6)} {w[:1]}".rstrip() for f, w in zip(fr, wh)]
            for s, fr, wh in zip(c.speeds, c.omega, c.whirl)]
    frame = "" if c.frame == "fixed" else f", in the {c.frame} frame (the coordinates' own)"
    p(f"frequencies: damped f_d = ω_d/2π (Hz) of each tracked mode (the glossary's ω_d = |Im λ|{frame})")
    for line in table([f"speed {unit}"] + [f"mode {j + 1} f_d Hz" for j in range(m)], rows):
        p(line)
    p("whirl: f forward, b backward (relative to the spin); 0 Hz: rigid, cyclic or overdamped")
    if np.any(np.abs(c.sigma) > c.error):  # damped or circulatory: the log decrements and where a mode turns unstable
        dec = [[number(s * k)] + [_decrement(d, e) for d, e in zip(dr, er)]
               for s, dr, er in zip(c.speeds, c.log_dec, c.log_dec_error)]
        p(f"log decrement δ = −2π Re λ/|Im λ| of each mode{frame} (negative: unstable; inf: aperiodic decay)")
        for line in table([f"speed {unit}"] + [f"mode {j + 1} δ" for j in range(m)], dec):
            p(line)
        for o in c.onset():
            p(f"onset of {o.kind}: mode {o.number} at {o.speed * k:.10g} {unit} ± {o.speed_error * k:.1e} "
              f"({o.whirl or 'no'} whirl, Re λ = 0 there)")
    for o in orders:
        crit = c.critical_speeds(o)
        if not crit:
            p(f"order {o:g}: no critical speed in {number(c.speeds[0] * k)}…{number(c.speeds[-1] * k)} {unit}")
        for cs in crit:
            other = (f"{cs.speed_rpm:.6g} rpm" if unit == "rad/s" else f"{cs.speed:.6g} rad/s")
            p(f"order {o:g}: critical speed {cs.speed * k:.10g} {unit} ({other}), mode {cs.number}, "
              f"{cs.whirl or 'no'} whirl, ± {cs.error * k:.1e} {unit}")
    write_files(p, files)
    return c


def _decrement(d: float, e: float) -> str:
    """A log decrement for the table, "0 (within the error)" when |δ| is within its error."""
    if not np.isfinite(d):
        return "inf" if d > 0 else "-inf"
    return "0 (within the error)" if abs(d) <= e else number(d, digits=6)
