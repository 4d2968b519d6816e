"""``vibdyn campbell``: the Campbell diagram of a rotor as a table (Hz, whirl) and its critical speeds."""

import sys

import numpy as np

from .._format import number, table
from ..errors import ModelError


def speed_list(text):
    """Speeds (rad/s) from ``FROM:TO:N`` (N equally spaced, ends included) or ``a,b,c``."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            if int(n) < 2:
                raise ValueError
            return np.linspace(float(a), float(b), int(n))
        return np.array([float(x) for x in text.split(",")])
    except ValueError:
        raise ModelError(f"--speeds: expected FROM:TO:N (N ≥ 2) or a comma list of speeds in rad/s, got "
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
    except ValueError:
        raise ModelError(f"--orders: expected numbers separated by commas, got '{args.orders}'") from None
    held = False if getattr(args, "free_spin", False) else None
    c = campbell(system, args.spin, speed_list(args.speeds), orders, method=args.method, held=held)
    from .nonlinear_command import write_files  # the picture after the table: a failure to write it keeps the table

    files = [(args.png, lambda: c.plot(args.png))]
    if args.json:
        import json

        p(json.dumps(c.to_dict(), indent=1))
        write_files(p, files, announce=False)
        return c
    m = c.omega.shape[1]
    p(f"Campbell diagram of {system.name}: {len(c.speeds)} speeds of '{c.spin}', {m} modes tracked by MAC "
      f"({c.method} linearisation, {c.elapsed:.2f} s); {spin_state(c)}")
    rows = [[number(s)] + [f"{number(f / (2 * np.pi), digits=6)} {w[:1]}".rstrip() for f, w in zip(fr, wh)]
            for s, fr, wh in zip(c.speeds, c.omega, c.whirl)]
    p("frequencies: damped f_d = ω_d/2π (Hz) of each tracked mode (the glossary's ω_d = |Im λ|)")
    for line in table(["speed rad/s"] + [f"mode {j} f_d Hz" for j in range(m)], rows):
        p(line)
    p("whirl: f forward, b backward (relative to the spin); 0 Hz: rigid, cyclic or overdamped")
    for o in orders:
        crit = c.critical_speeds(o)
        if not crit:
            p(f"order {o:g}: no critical speed in {number(c.speeds[0])}…{number(c.speeds[-1])} rad/s")
        for k in crit:
            p(f"order {o:g}: critical speed {k.speed:.10g} rad/s ({k.speed_rpm:.6g} rpm), mode {k.mode}, "
              f"{k.whirl or 'no'} whirl, ± {k.error:.1e} rad/s")
    write_files(p, files)
    return c
