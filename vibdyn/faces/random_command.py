"""``vibdyn random MODEL --psd FILE --support NAME`` (or ``--force COORDINATE``): RMS responses to a random
support motion or force given by a PSD table (one-sided, in Hz)."""

import json
import sys

import numpy as np

from .._format import json_ready
from ..errors import ModelError


def read_psd(path, unit=None):
    """A :class:`vibdyn.PSD` from a text file of two columns, frequency (Hz) and level, blank lines and ``#``
    comments skipped; the unit is ``unit``, else a comment line ``# unit: g^2/Hz``, else an error."""
    from ..description.psd import PSD

    rows, found = [], None
    try:
        with open(path, encoding="utf-8") as fh:
            text = fh.read()
    except OSError as e:
        raise ModelError(f"PSD file {path}: cannot read: {e.strerror or e}") from None
    for n, line in enumerate(text.splitlines(), 1):
        body = line.split("#", 1)
        if len(body) == 2 and body[1].strip().lower().startswith("unit:"):
            found = body[1].split(":", 1)[1].strip()
        words = body[0].replace(",", " ").split()
        if not words:
            continue
        try:
            f, g = (float(w) for w in words)
        except ValueError:
            raise ModelError(f"PSD file {path}, line {n}: expected two numbers (Hz, level), got {line.strip()!r}") \
                from None
        rows.append((f, g))
    if unit is None and found is None:
        raise ModelError(f"PSD file {path}: no unit: give --unit (e.g. g^2/Hz) or a line '# unit: g^2/Hz'")
    if not rows:
        raise ModelError(f"PSD file {path}: no breakpoints")
    a = np.array(rows)
    try:
        return PSD(a[:, 0], a[:, 1], unit=unit or found)
    except ModelError as e:
        raise ModelError(f"PSD file {path}: {e}") from None


def _check_kind(psd, args, system):
    """--force takes a force or torque PSD, --support a motion PSD (the other kind is refused, naming both; a
    declared support refuses a load PSD itself, and the API takes a load PSD on a coordinate as a force)."""
    from ..description.psd import ORDER

    load = ORDER[psd.quantity] is None
    if args.force and not load:
        raise ModelError(f"--force {args.force}: a force PSD is needed (N^2/Hz, or (N*m)^2/Hz on a rotation), got a "
                         f"PSD of {psd.quantity} ({psd.unit}): a motion PSD goes with --support")
    if args.support in system.coordinates and load:
        raise ModelError(f"--support {args.support}: a motion PSD is needed (g^2/Hz, (m/s^2)^2/Hz, (m/s)^2/Hz or "
                         f"m^2/Hz), got a PSD of {psd.quantity} ({psd.unit}): a force PSD goes with --force")


def add(sub, scene_help):
    r = sub.add_parser("random", help="RMS responses to a random support motion or force: a PSD table (one-sided, Hz)")
    r.add_argument("scene", help=scene_help)
    r.add_argument("--psd", required=True, help="text file: frequency (Hz) and level per line, log-log between")
    r.add_argument("--unit", help="the PSD's unit (g^2/Hz, (m/s^2)^2/Hz, (m/s)^2/Hz, m^2/Hz, N^2/Hz, (N*m)^2/Hz) "
                   "if the file has none")
    where = r.add_mutually_exclusive_group(required=True)
    where.add_argument("--support", help="the moving support (or a prescribed coordinate): a motion PSD")
    where.add_argument("--force", help="a coordinate the random force acts on: a force PSD (N^2/Hz or (N*m)^2/Hz)")
    r.add_argument("--direction", default="0,0,1", help="the support's direction, world axes (default 0,0,1)")
    r.add_argument("--outputs", nargs="+", help="coordinate names (default: all)")
    r.add_argument("--zeta", type=float, help="modal damping ratio on every mode, replacing the model's damping "
                   "(an undamped model's RMS is unbounded)")
    r.add_argument("--png", help="save the input and response PSDs (log-log) to this PNG file")
    r.add_argument("--json", action="store_true", help="print a JSON object instead of text")


def command(scene, args, out=None):
    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    psd = read_psd(args.psd, args.unit)
    try:
        d = tuple(float(x) for x in args.direction.split(","))
    except ValueError:
        d = ()
    if len(d) != 3:
        raise ModelError(f"--direction: expected three comma-separated numbers, got {args.direction!r}")
    system = scene.build()
    _check_kind(psd, args, system)
    lin = system.operating_point().linearize()
    if args.zeta is not None:
        lin = lin.with_modal_damping(args.zeta)
    target = args.force or args.support
    coordinate = target in system.coordinates
    if args.force:
        res = lin.random_response({args.force: psd}, outputs=args.outputs)
    else:
        res = lin.random_response(psd, support=args.support, direction=None if coordinate else d, outputs=args.outputs)
    if args.json:
        p(json.dumps(json_ready({"scene": system.name, "psd": psd.to_dict(), "support": args.support,
                                 "force": args.force, "direction": None if coordinate else list(d),
                                 **res.to_dict()}), indent=1))
    else:
        p(f"{system.name}: {psd!r} {'on' if args.force else 'at'} '{target}'" + ("" if coordinate else f" along {d}"))
        p(f"input RMS {psd.rms():.6g} {psd.si_unit.split('^2/Hz')[0].strip('()')}; method {res.method}; "
          f"{res.elapsed * 1e3:.1f} ms; linear model's relative error {res.model_error:.1e}")
        p(f"{'output':<24} {'quantity':<13} {'RMS':>14} {'± error':>10}  unit")
        for q in ("displacement", "velocity", "acceleration"):
            try:
                rms, err = res.rms(q), res.rms_error(q)
            except ModelError as e:
                p(f"{'(all)':<24} {q:<13} unbounded: {str(e).split(': ', 2)[-1]}")
                continue
            for j, name in enumerate(res.outputs):
                p(f"{name:<24} {q:<13} {rms[j]:>14.8g} {err[j]:>10.1e}  {res.unit(j, q)}")
    if args.png:
        res.plot(args.png, "acceleration" if res.unbounded[2] is None else "displacement")
        if not args.json:
            p(f"wrote {args.png}")
