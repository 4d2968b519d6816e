"""``vibdyn spectrum``: response-spectrum analysis of a scene shaken by its ground, from a design spectrum file
(two columns: period s, pseudo-acceleration m/s²) or a ground-acceleration record (the record's own spectrum),
as a table or JSON."""

import sys

import numpy as np

from .._format import json_ready
from ..errors import ModelError


def add(sub, scene_help):
    s = sub.add_parser("spectrum", help="response-spectrum analysis (SRSS/CQC/ABS) from a spectrum or a record")
    s.add_argument("scene", help=scene_help)
    s.add_argument("--spectrum", metavar="FILE", help="design spectrum: two columns, period (s) and "
                   "pseudo-acceleration (in --unit), increasing periods")
    s.add_argument("--design", metavar="CODE", help="a code's spectrum: ec8:AG:GROUND[:TYPE] (EN 1998-1, a_g in g, "
                   "ground A-E, type 1 or 2) or asce7:SDS:SD1[:TL] (ASCE 7, in g; T_L s)")
    s.add_argument("--record", metavar="FILE", help="ground-acceleration record: one column (give --dt), two "
                   "(time s, acceleration in --unit) or a PEER .AT2 file; its pseudo-acceleration spectrum is used")
    s.add_argument("--dt", type=float, help="the record's time step (s), for a one-column file")
    s.add_argument("--unit", default=None, choices=("m/s^2", "g", "cm/s^2", "mm/s^2"),
                   help="unit of the accelerations in the file (default m/s^2; g for a PEER .AT2 file)")
    s.add_argument("--direction", nargs=3, type=float, required=True, metavar=("X", "Y", "Z"),
                   help="direction of the ground motion (world axes)")
    s.add_argument("--combination", choices=("srss", "cqc", "abs"), default="srss", help="modal combination rule")
    s.add_argument("--damping", type=float, default=0.05, help="damping ratio of the spectrum and of CQC (0.05)")
    s.add_argument("--modes", type=int, metavar="N", help="keep the first N modes (the rest: missing mass)")
    s.add_argument("--method", choices=("fd", "analytic"), default="analytic", help="linearisation method")
    s.add_argument("--png", help="also draw the spectrum with the modes marked into this PNG file")
    s.add_argument("--json", action="store_true", help="print a JSON object instead of text")


def spectrum_of(args, modes):
    """The spectrum the options name: a table read from --spectrum, or --record's spectrum at the modes' periods
    (and T = 0, the peak ground acceleration)."""
    from ..description.record import UNITS, Record

    if sum(x is not None for x in (args.spectrum, args.record, args.design)) != 1:
        raise ModelError("spectrum: give one of --spectrum FILE (a table), --design CODE (a code's spectrum) or "
                         "--record FILE (a record)")
    if args.design is not None:
        return design(args.design, args.damping)
    if args.record is not None:
        record = Record.from_file(args.record, dt=args.dt, unit=args.unit)
        modal = 2 * np.pi / modes.omega[modes.omega > 0]
        top = 1.5 * modal.max(initial=1.0)
        periods = np.union1d(np.linspace(0.0, top, 61), modal)  # the modes' own periods exactly, and a curve
        return record.pseudo_acceleration_spectrum(periods, args.damping), f"record {args.record} ({record!r})"
    try:
        data = np.loadtxt(args.spectrum, comments=("#", "%"), delimiter=None, ndmin=2)
    except (OSError, ValueError) as e:
        raise ModelError(f"spectrum file '{args.spectrum}': cannot be read as two columns of numbers ({e})") from None
    if data.ndim != 2 or data.shape[1] != 2 or data.shape[0] < 2:
        raise ModelError(f"spectrum file '{args.spectrum}': expected two columns (period s, pseudo-acceleration) "
                         f"and at least two rows, got shape {data.shape}")
    if not np.all(np.isfinite(data)):
        raise ModelError(f"spectrum file '{args.spectrum}': NaN or inf in the table")
    return (data[:, 0], data[:, 1] * UNITS[args.unit or "m/s^2"]), f"spectrum {args.spectrum}"


def design(text, damping):
    """A code's spectrum from ``ec8:AG:GROUND[:TYPE]`` or ``asce7:SDS:SD1[:TL]`` (accelerations in g)."""
    from ..description.design_spectra import G, asce7, eurocode8

    parts = text.split(":")
    code = parts[0].lower()
    try:  # the text's form here; the values' own refusals (ground type, a_g, damping) from the codes' builders
        if code == "ec8" and len(parts) in (3, 4):
            values = (float(parts[1]) * G, parts[2], int(parts[3]) if len(parts) == 4 else 1)
        elif code == "asce7" and len(parts) in (3, 4):
            values = tuple(float(x) for x in parts[1:])
        else:
            raise ValueError
    except ValueError:
        raise ModelError(f"--design: expected ec8:AG:GROUND[:TYPE] (e.g. ec8:0.25:C) or asce7:SDS:SD1[:TL] "
                         f"(e.g. asce7:1.0:0.6:8), got '{text}'") from None
    s = eurocode8(*values, damping) if code == "ec8" else asce7(*values)
    return s, s.describe()


def command(scene, args, out=None):
    """Run ``vibdyn spectrum`` on ``scene`` with the parsed ``args``."""
    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    system = scene.build()
    modes = system.operating_point().linearize(method=args.method).modes()
    spectrum, source = spectrum_of(args, modes)
    r = modes.response_spectrum(spectrum, args.direction, args.combination, args.damping, n_modes=args.modes)
    if args.json:
        import json

        p(json.dumps(json_ready({"scene": system.name, "source": source, **r.to_dict()}), indent=1))
    else:
        p(f"{system.name}: {source}")
        p(str(r))
    if args.png:
        r.plot(args.png)
        if not args.json:
            p(f"wrote {args.png}")
    return r
