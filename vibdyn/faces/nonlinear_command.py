"""``vibdyn frc``, ``vibdyn floquet`` and ``vibdyn backbone``: the nonlinear analyses from the command line
(forced-response curves by harmonic balance, Floquet multipliers of a periodic orbit, backbones of nonlinear
normal modes), each as a readable table or ``--json``, with ``--png`` figures and ``--html`` viewer pages.

``PARSERS`` and ``RUNNERS`` list each one's parser and runner (a runner takes the loaded Scene, its ``--start``
applied, and the parsed arguments); :data:`vibdyn.faces.cli.COMMANDS` registers them. Nothing heavier than
argparse is imported until a command runs.
"""

import math
import sys

import numpy as np

from .._check import name_values
from .._format import json_ready, number, table
from ..errors import ModelError

SCENE_HELP = "scene file, bundled model name, or robot:NAME"


def _p(out):
    return lambda *a: print(*a, file=out or sys.stdout)


def write_files(p, files, announce=True):
    """Write each ``(path, write)`` of ``files`` whose path was given, after the results were printed: a picture
    or page that cannot be written (a missing folder, matplotlib missing) never throws away what was computed —
    the others are still written, then the first failure is raised (the CLI prints it and exits 2).
    ``announce``: print "saved PATH" for each file written (not with --json)."""
    failed = []
    for path, write in files:
        if not path:
            continue
        try:
            write()
        except ModelError as e:
            failed.append(e)
            continue
        if announce:
            p(f"saved {path}")
    if failed:
        raise ModelError(f"{failed[0]} (the results above were computed and printed; nothing else was lost)")


def _pair(text, option, what, sep=":"):
    """Two numbers A{sep}B (``--omega LO:HI``), or the force NAME:AMPLITUDE (a name and one number)."""
    a, s, b = text.rpartition(sep)
    try:
        if not s or not a:
            raise ValueError
        return a, float(b)
    except ValueError:
        raise ModelError(f"{option} '{text}': expected {what}") from None


def omega_range(text):
    """(lo, hi) rad/s from ``LO:HI``."""
    lo, hi = _pair(text, "--omega", "LO:HI, two frequencies in rad/s (e.g. 0.5:2)")
    try:
        lo = float(lo)
    except ValueError:
        raise ModelError(f"--omega '{text}': expected LO:HI, two frequencies in rad/s (e.g. 0.5:2)") from None
    return lo, hi


# ---------------------------------------------------------------------------------------------- frc
def _add_frc(sub):
    frc = sub.add_parser("frc", help="forced-response curve of a nonlinear scene (harmonic balance): folds, "
                         "peak, stability")
    frc.add_argument("scene", help=SCENE_HELP)
    frc.add_argument("--force", required=True, metavar="NAME:AMPLITUDE",
                     help="harmonic force AMPLITUDE·cos Ωt (N, or N·m on a pivot) on the coordinate NAME")
    frc.add_argument("--omega", required=True, metavar="LO:HI", help="range of the excitation's Ω, rad/s")
    frc.add_argument("--coordinate", help="the coordinate whose amplitude is reported (default: the forced one)")
    frc.add_argument("--harmonics", type=int, help="number of harmonics H (default: grown until the truncation "
                     "estimate is below --tol × the peak)")
    frc.add_argument("--tol", type=float, default=1e-8, help="relative truncation tolerance (default 1e-8)")
    frc.add_argument("--png", help="save the curve (amplitude against Ω) to this PNG file")
    frc.add_argument("--html", help="write a viewer page of the motion at the curve's largest amplitude")
    frc.add_argument("--json", action="store_true", help="print a JSON object instead of text")


def frc_dict(system, curve):
    """Plain data of a forced-response curve (SI units)."""
    u = curve.unit
    return json_ready({
        "scene": system.name, "coordinate": curve.coordinate, "unit": u, "excitation": curve.excitation,
        "method": "harmonic balance", "harmonics": curve.harmonics, "omega_rad_s": curve.omega,
        "frequency_hz": curve.frequency_hz, "amplitude": curve.amplitude, "amplitude_error": curve.error,
        "max_multiplier_modulus": np.abs(curve.multipliers[:, 0]), "multiplier_error": curve.multiplier_error,
        "stability": list(curve.stability),
        "peak": {"omega_rad_s": curve.peak.omega, "omega_error_rad_s": curve.peak.omega_error,
                 "frequency_hz": curve.peak.frequency_hz, "amplitude": curve.peak.amplitude,
                 "amplitude_error": curve.peak.error},
        "folds": [{"omega_rad_s": f.omega, "omega_error_rad_s": f.omega_error, "frequency_hz": f.frequency_hz,
                   "amplitude": f.amplitude, "amplitude_error": f.error} for f in curve.folds],
        "status": curve.status, "message": curve.message, "elapsed_s": curve.elapsed})


def mu_digits(error):
    """Significant digits that show a multiplier |μ| ≈ 1 to its ``error`` (8 at least, 17 at most): an
    "unstable" 1.000000000001 ± 2e-16 must not print as 1."""
    return int(min(17, max(8, 1 - math.floor(math.log10(max(float(error), 1e-17))))))


def frc_command(scene, args, out=None):
    """``vibdyn frc``: the curve's peak, folds and points (Ω, amplitude, |μ|, stability), or JSON."""
    from ..analysis.nonlinear.harmonic_balance import forced_response_curve

    p = _p(out)
    system = scene.build()
    name, amplitude = _pair(args.force, "--force", "NAME:AMPLITUDE, a coordinate and a force amplitude (N or N·m)")
    if name not in system.coordinates:
        raise ModelError(f"--force '{args.force}': no coordinate '{name}' in scene '{system.name}' (coordinates: "
                         f"{', '.join(system.coordinates)})")
    coordinate = args.coordinate or name
    if coordinate not in system.coordinates:
        raise ModelError(f"--coordinate '{coordinate}': no such coordinate in scene '{system.name}' (coordinates: "
                         f"{', '.join(system.coordinates)})")
    curve = forced_response_curve(system, (name, amplitude), omega_range(args.omega), coordinate, args.harmonics,
                                  tol=args.tol)

    def html():
        from .viewer import export_html

        export_html(curve.orbit(int(np.argmax(curve.amplitude))), args.html)

    files = [(args.png, lambda: curve.plot(args.png)), (args.html, html)]
    if args.json:
        import json

        p(json.dumps(frc_dict(system, curve), indent=1))
        write_files(p, files, announce=False)
        return curve
    p(str(curve))
    u = curve.unit
    rows = [[number(w, digits=8), number(w / (2 * math.pi), digits=6), number(a, digits=8), f"{e:.1e}",
             number(abs(m[0]), digits=mu_digits(me)), f"{me:.1e}", s]
            for w, a, e, m, me, s in zip(curve.omega, curve.amplitude, curve.error, curve.multipliers,
                                          curve.multiplier_error, curve.stability)]
    p(f"points: amplitude = max over a period of |{curve.coordinate} − equilibrium| ({u}) ± its error "
      "(truncation, residual, round-off); largest Floquet multiplier |μ| (Hill's method) ± its error; stability "
      "'within the error' where |μ| = 1 within it")
    for line in table(["Ω rad/s", "Ω/2π Hz", f"amplitude {u}", "±", "max |μ|", "± |μ|", "stability"], rows):
        p("  " + line)
    write_files(p, files)
    return curve


# ---------------------------------------------------------------------------------------------- floquet
def _add_floquet(sub):
    fl = sub.add_parser("floquet", help="periodic orbit through the scene's start and its Floquet multipliers "
                        "(shooting)")
    fl.add_argument("scene", help=SCENE_HELP)
    fl.add_argument("--period", type=float, help="the period T (s): a guess for an autonomous scene; a driven or "
                    "forced scene's default is its drive's 2π/ω")
    fl.add_argument("--start", nargs="+", metavar="NAME=VALUE",
                    help="the start's offsets from neutral by coordinate, m or rad (others: the scene's start)")
    fl.add_argument("--velocity", nargs="+", metavar="NAME=VALUE",
                    help="the start's velocities by coordinate, m/s or rad/s (others 0)")
    fl.add_argument("--t0", type=float, default=0.0, help="the start's time in the forcing period (s, default 0)")
    fl.add_argument("--phase", help="autonomous scenes: this coordinate's velocity is zero at the start")
    fl.add_argument("--html", help="write a viewer page of one period of the orbit (looped)")
    fl.add_argument("--json", action="store_true", help="print a JSON object instead of text")


def floquet_command(scene, args, out=None):
    """``vibdyn floquet``: the orbit through the scene's start state (period, multipliers |μ| ± their error,
    verdict, Liouville's check), or JSON."""
    from ..analysis.nonlinear.periodic import floquet, periodic_orbit
    from ..model.forcing import forcing

    p = _p(out)
    system = scene.build()
    q0, where = system.start_configuration()
    v0 = np.zeros(system.nv)
    for name, value in _velocities(args.velocity).items():
        if name not in system.coordinates:
            raise ModelError(f"--velocity {name}: no such coordinate in scene '{system.name}' (coordinates: "
                             f"{', '.join(system.coordinates)})")
        v0[system.coordinates.index(name)] = value
    period, source = args.period, "given"
    if system.depends_on_time:
        if period is None:
            f = forcing(system)
            period = f.period if f.complete else None
            source = "the forcing's 2π/ω" if len(f.harmonic) == 1 else "the forcing's common period"
            if period is None and f.commensurate:
                timed = ", ".join(f"'{n}'" for n, w in f.sources if w is None)
                raise ModelError(f"floquet: scene '{system.name}' depends on time through laws that declare no "
                                 f"frequency ({timed}): give --period (s)")
        orbit = floquet(system, period, q0, v0, args.t0)
    else:
        if period is None:
            source = "found from the first return"
        orbit = periodic_orbit(system, q0, v0, period, args.t0, phase=args.phase)

    def html():
        from .viewer import export_html

        export_html(orbit, args.html)

    if args.json:
        import json

        p(json.dumps(json_ready({"scene": system.name, "start": where, "period_source": source,
                                 **orbit.to_dict()}), indent=1))
        write_files(p, [(args.html, html)], announce=False)
        return orbit
    driven = "; driven coordinates follow their drives" if system.depends_on_time else ""
    p(f"scene {system.name}: orbit through {where}, velocities {_state(system, v0)}{driven}; period {source}")
    p(str(orbit))
    g, e = orbit.growth
    verdict = " (within the error)" if abs(g) <= e else ""
    p(f"largest |μ| − 1 = {g:.3e} ± {e:.1e}{verdict}: {orbit.stability}")
    write_files(p, [(args.html, html)])
    return orbit


def _velocities(items):
    return name_values(items, "--velocity", "a coordinate and its velocity (m/s or rad/s)")


def _state(system, v):
    return ", ".join(f"{c} {number(x, u + '/s')}" for c, x, u in zip(system.coordinates, v, system.units)) or "-"


# ---------------------------------------------------------------------------------------------- backbone
#: without --amplitudes or --energies: these fractions of the coordinate's scale, 1 rad for a rotation and
#: TRANSLATION_SCALE × the scene's length scale for a translation (a larger share may close a spring's gap)
DEFAULT_FRACTIONS = (0.1, 0.2, 0.5, 1.0)
TRANSLATION_SCALE = 0.2


def _add_backbone(sub):
    bb = sub.add_parser("backbone", help="backbone of a nonlinear normal mode (undamped): its frequency against "
                        "amplitude and energy, continued from a linear mode")
    bb.add_argument("scene", help=SCENE_HELP)
    bb.add_argument("--mode", type=int, required=True, metavar="K",
                    help="the linear mode it is continued from (1 = the lowest)")
    bb.add_argument("--amplitudes", metavar="A1,A2,…", help="requested amplitudes, max over the orbit of "
                    "|q − q_eq| of --coordinate (m or rad), comma separated (default: 0.1, 0.2, 0.5, 1 × 1 rad "
                    "for a rotation, × 20 %% of the scene's length scale for a translation)")
    bb.add_argument("--energies", metavar="E1,E2,…", help="requested energies above the equilibrium (J), comma "
                    "separated (instead of --amplitudes)")
    bb.add_argument("--coordinate", help="the coordinate whose amplitude is requested and reported (default: the "
                    "one with the largest share of the linear mode)")
    bb.add_argument("--png", help="save the frequency–energy plot to this PNG file")
    bb.add_argument("--html", help="write a viewer page of the orbit of the largest request (one period, looped)")
    bb.add_argument("--json", action="store_true", help="print a JSON object instead of text")


def _numbers(text, option, what):
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        raise ModelError(f"{option} '{text}': expected {what} separated by commas (e.g. 0.1,0.5,1)") from None
    bad = [x for x in values if not (math.isfinite(x) and x > 0)]
    if bad:
        raise ModelError(f"{option} '{text}': {what} must be positive and finite, got {bad[0]!r}")
    return values


def backbone_command(scene, args, out=None):
    """``vibdyn backbone``: the backbone of linear mode ``--mode`` (numbered from 1 as ``vibdyn modes`` lists them)
    at each request — amplitude, energy, ω, f, ω/ω_lin, ω's error, stability — and the internal resonances met,
    or JSON."""
    from ..analysis.nonlinear.backbone import backbone

    p = _p(out)
    system = scene.build()
    if args.amplitudes and args.energies:
        raise ModelError("backbone: give --amplitudes or --energies, not both")
    if args.mode < 1:
        raise ModelError(f"--mode {args.mode}: modes are numbered from 1 (the lowest ω, as vibdyn modes lists them)")
    if args.coordinate is not None and args.coordinate not in system.coordinates:
        raise ModelError(f"--coordinate '{args.coordinate}': no such coordinate in scene '{system.name}' "
                         f"(coordinates: {', '.join(system.coordinates) or 'none'})")
    amplitudes = _numbers(args.amplitudes, "--amplitudes", "amplitudes (m or rad)") if args.amplitudes else None
    energies = _numbers(args.energies, "--energies", "energies (J)") if args.energies else None
    default = ""
    if amplitudes is None and energies is None:
        amplitudes, default = _default_amplitudes(system, args.coordinate)
    try:
        bb = backbone(system, args.mode - 1, amplitudes=amplitudes, energies=energies, coordinate=args.coordinate)
    except ModelError as e:
        if "mode" not in str(e):
            raise
        raise ModelError(f"{e} (--mode {args.mode} is vd.backbone's mode index {args.mode - 1})") from None

    def png():
        from .plots import frequency_energy

        frequency_energy(bb, path=args.png)

    def html():
        from .viewer import export_html

        export_html(bb, args.html)

    files = [(args.png, png), (args.html, html)]
    if args.json:
        import json

        p(json.dumps(json_ready({"scene": system.name, "mode_number": args.mode, **bb.to_dict()}), indent=1))
        write_files(p, files, announce=False)
        return bb
    u, lin = bb.unit, bb.linear_omega
    requests = energies if energies is not None else amplitudes
    p(f"scene {system.name}: backbone of mode {args.mode} (linear ω_lin = {number(lin, 'rad/s', digits=10)}, "
      f"{number(lin / (2 * math.pi), 'Hz', digits=8)}), amplitude of '{bb.coordinate}'; {len(bb.omega)} "
      f"{bb.requested} requests, each solved by shooting; {bb.points} branch points, {bb.elapsed:.2f} s")
    if default:
        p(default)
    p(f"amplitude = max over the orbit of |{bb.coordinate} − equilibrium| ({u}); energy above the equilibrium (J); "
      "ω the fundamental frequency 2π/T ± its estimated error (rad/s); stability from the orbit's Floquet "
      "multipliers")
    rows = [[number(r, digits=8), number(a, digits=10), number(e, digits=10), number(w, digits=12),
             number(w / (2 * math.pi), digits=10), number(w / lin, digits=10), f"{err:.1e}", s]
            for r, a, e, w, err, s in zip(requests, bb.amplitude, bb.energy, bb.omega, bb.error, bb.stability)]
    kind = "energy J" if bb.requested == "energy" else f"amplitude {u}"
    for line in table([f"request: {kind}", f"amplitude {u}", "energy J", "ω rad/s", "f Hz", "ω/ω_lin",
                       "± ω rad/s", "stability"], rows):
        p("  " + line)
    for r in bb.resonances:
        p(f"{r.category}: {r.message}")
    if not bb.resonances:
        p("no internal resonance or fold met on the branch")
    p(f"note: {bb.note}")
    write_files(p, files)
    return bb


def _default_amplitudes(system, coordinate):
    """DEFAULT_FRACTIONS × the coordinate's scale (1 rad, or TRANSLATION_SCALE × the scene's length scale in m;
    without a coordinate named, the smallest of the scene's), and a line saying so."""
    scales = np.array([1.0 if u == "rad" else TRANSLATION_SCALE * system.length_scale for u in system.units])
    if not scales.size:
        return [1.0], ""  # no coordinate: the backbone itself says so
    k = system.coordinates.index(coordinate) if coordinate is not None else int(np.argmin(scales))
    scale, u = float(scales[k]), system.units[k]
    return ([f * scale for f in DEFAULT_FRACTIONS],
            f"amplitudes by default: {', '.join(f'{f:g}' for f in DEFAULT_FRACTIONS)} × {number(scale, u)} (1 rad for "
            f"a rotation, 20 % of the scene's length scale for a translation; give --amplitudes or --energies)")


#: name -> add its parser; name -> run it on (scene, args)
PARSERS = {"frc": _add_frc, "floquet": _add_floquet, "backbone": _add_backbone}
RUNNERS = {"frc": frc_command, "floquet": floquet_command, "backbone": backbone_command}
