"""The ``vibdyn`` command: ``info``, ``modes``, ``demo``, ``frf``, ``bench``, ``simulate``, ``view``,
``campbell``, ``random`` and the nonlinear ``frc``, ``floquet``, ``backbone`` (:mod:`vibdyn.faces.nonlinear_command`)
(``vibdyn COMMAND --help``; ``COMMANDS`` below lists each one's parser and runner).

SCENE is a TOML scene file, a bundled model name, or ``robot:NAME`` for a robot of example-robot-data (e.g.
``robot:ur5``).
"""

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from .._check import name_values
from .._format import number, table, vector
from ..errors import ModelError, VibdynError
from .nonlinear_command import PARSERS as NONLINEAR


def benchmarks_dir():
    """The repository's ``benchmarks/`` folder (override with the VIBDYN_BENCHMARKS environment variable).
    It is not part of the installed package: it exists in a source checkout (an editable install)."""
    return Path(os.environ.get("VIBDYN_BENCHMARKS", Path(__file__).resolve().parents[2] / "benchmarks"))


def bench(argv):
    """``vibdyn bench ARGS``: run ``python -m benchmarks ARGS`` from the repository's benchmarks folder."""
    folder = benchmarks_dir()
    if not (folder / "suite.py").is_file():
        raise ModelError(f"vibdyn bench: no benchmark suite at {folder} (it lives in the source repository, not "
                         "in an installed package): run it from a checkout (pip install -e .) or set "
                         "VIBDYN_BENCHMARKS to the repository's benchmarks/ folder")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    root = str(folder.resolve().parent)
    if root not in sys.path:
        sys.path.insert(0, root)
    from benchmarks.suite import main as bench_main

    return bench_main(argv, prog="vibdyn bench")


def load(spec):
    """A Scene from a scene file path, a bundled model name (``four_bar``), or ``robot:NAME``."""
    if spec.startswith("robot:"):
        from ..io.robots import load_robot

        return load_robot(spec[len("robot:"):])
    from ..io.scenefile import load_scene

    return load_scene(spec)


def describe(scene, system, out=None):
    """Print a scene's bodies (joint, mass, centre of mass, inertia), coordinates and force elements."""
    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    p(f"scene      {scene.name}")
    if scene.source:
        p(f"source     {scene.source}")
    p(f"gravity    {vector(scene.gravity, 'm/s²')}")
    p(f"size       {len(scene.bodies)} bodies, nq = {system.nq}, nv = {system.nv}")
    p("")
    p("bodies: joint placed at `at` (m) in the parent's frame, axes in the body frame; centre of mass (m) in the "
      "body frame; inertia (kg·m²) about the centre of mass, body axes")
    for b in scene.bodies.values():
        J = b.joint
        place = f"at {vector(J.at, 'm')}" + (f", rotated {_rotation(J.rotation)}" if J.rotation is not None else "")
        if J.nv == 0 and b.mass == 0.0:
            p(f"  {b.name} (on {b.parent}): fixed {place}, no mass (a marker)")
            continue
        p(f"  {b.name} (on {b.parent})")
        params = ", ".join(f"{k} {vector(v) if isinstance(v, (list, tuple)) else number(v)}"
                           for k, v in J.params().items())
        coords = ", ".join(f"{c} ({u}{_limits(system, c)})" for c, u in zip(b.coordinates, J.units))
        p(f"    joint    {J.type}{', ' + params if params else ''}, {place}"
          + (f"; coordinates {coords}" if coords else ""))
        p(f"    mass     {number(b.mass, 'kg')}, centre of mass {vector(b.com, 'm')}")
        p(f"    inertia  {_inertia(b.inertia)}")
    if scene.elements:
        p("")
        p("force elements")
        for line in table(["name", "kind", "details"],
                          [[e.name, e.label, e.describe(scene)] for e in scene.elements.values()], ["<", "<", "<"]):
            p("  " + line)
    if scene.loops:
        c = system.constraints
        p("")
        p(f"closed loops: {c.m} equations, rank {system.nv - system.dof}, mobility {system.dof} at the configuration "
          f"assembled from {c.closed[1]} (points in the body frames, m; axes in body_a's frame)")
        rows = []
        for lp, n in zip(scene.loops.values(), c.sizes):
            j = lp.joint
            params = ", ".join(f"{k} {vector(v)}" for k, v in j.params().items())
            rows.append([lp.name, f"{j.type}{' ' + params if params else ''}",
                         f"{lp.a[0]}{vector(lp.a[1], 'm')} – {lp.b[0]}{vector(lp.b[1], 'm')}", str(n)])
        for line in table(["name", "joint", "ends", "equations"], rows, ["<", "<", "<", ">"]):
            p("  " + line)
    values = sorted(k for k in scene.references if k not in ("source", "note"))
    if values:  # (a note alone is no reference value)
        p("")
        p("reference values: " + ", ".join(values))
    if system.nv:
        t0 = time.perf_counter()
        q, where = system.start_configuration()
        M = system.mass_matrix(q)
        dt = time.perf_counter() - t0
        w = np.linalg.eigvalsh(M)
        p("")
        condition = f"condition {w[-1] / w[0]:.3g}" if w[0] > 0 else "singular there"
        p(f"mass matrix at {where}: eigenvalues {w[0]:.4g} … {w[-1]:.4g} ({condition}), {dt * 1e3:.2f} ms")
    needs = [n for n, f in (("velocity", system.depends_on_velocity), ("time", system.depends_on_time)) if f]
    p(f"forces depend on: q{''.join(', ' + n for n in needs)}")


def modal_report(system, method="fd"):
    """Operating point, linear model and modes of a system, as plain data (the ``--json`` object)."""
    op = system.operating_point()
    lin = op.linearize(method=method)
    m = lin.modes()
    return op, lin, m, {
        "scene": system.name,
        "coordinates": list(system.coordinates),
        "units": list(system.units),
        "operating_point": {
            "regime": op.regime, "stability": op.stability, "residual": op.residual, "iterations": op.iterations,
            "q": op.q.tolist(), "v": op.v.tolist(),
            "offsets": system.difference(system.neutral(), op.q).tolist(),
            "speeds": op.speeds, "drive": op.drive, "elapsed_s": op.elapsed},
        "linearization": {"method": lin.method, "relative_error": lin.relative_error, "elapsed_s": lin.elapsed,
                          "evaluations": lin.evaluations, "M": lin.M.tolist(), "C": lin.C.tolist(),
                          "K": lin.K.tolist()},
        "modes": {**m.to_dict(), "participation": participation(m)},
    }


AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def participation(m):
    """{x, y, z, rx, ry, rz: {factor, effective_mass, moved_mass}} of base accelerations: translations along
    the world axes (kg) and rotations about them through the origin (kg·m²), as Nastran and Code_Aster print
    them (:meth:`vibdyn.analysis.modal.Modes.effective_mass`)."""
    out = {}
    for rotation in (False, True):
        unit = "kg_m2" if rotation else "kg"
        for axis, d in AXES.items():
            out[("r" if rotation else "") + axis] = {
                "factor": m.participation(d, rotation).tolist(),
                f"effective_mass_{unit}": m.effective_mass(d, rotation).tolist(),
                f"moved_mass_{unit}": m.moved_mass(d, rotation)}
    return out


MAX_POINT_ROWS = 36  # body points listed by `vibdyn modes` (3 rows a body)


def point_shapes_text(m, per_block=8):
    """The mode shapes as world displacements of the bodies' centres of mass (x, y, z, m per unit modal
    coordinate, each mode scaled so its largest entry is 1): the textbook's absolute coordinates, beside the
    joint coordinates of the shapes table (:meth:`vibdyn.analysis.modal.Modes.point_shapes`)."""
    scene = m.linear.system.scene
    bodies = [b for b in scene.bodies.values() if b.mass > 0][:MAX_POINT_ROWS // 3]
    if not bodies or not m.n:
        return ""
    S = m.point_shapes([(b.name, b.com) for b in bodies])  # (bodies, 3, n)
    S = S / np.maximum(np.abs(S).max(axis=(0, 1)), 1e-300)
    cut = 10 * (m.linear.relative_error + m.n * np.finfo(float).eps)
    rows = [(f"{b.name}", axis, S[i, k]) for i, b in enumerate(bodies) for k, axis in enumerate("xyz")
            if np.abs(S[i, k]).max() > cut]
    lines = ["mode shapes at the centres of mass (world displacements x, y, z; each mode scaled so its largest "
             "entry is 1)"]
    for b0 in range(0, m.n, per_block):
        cols = range(b0, min(b0 + per_block, m.n))
        lines += ["  " + x for x in table(["body", "axis"] + [f"mode {j + 1}" for j in cols],
                                          [[n, a] + [number(v[j], error=cut, digits=4) for j in cols]
                                           for n, a, v in rows], ["<", "<"] + [">"] * len(cols))]
    return "\n".join(lines)


def participation_text(m):
    """Effective modal masses per mode for the base translations that move any mass (kg, and % of the mass
    they move), with their sums: what a modal report lists."""
    rows, cols = [], []
    for axis, d in AXES.items():
        total = m.moved_mass(d)
        if total > 1e-12 * max(m.moved_mass(x) for x in AXES.values()):
            cols.append((axis, m.effective_mass(d), total))
    if not cols or not m.n:
        return ""
    for i in range(m.n):
        rows.append([str(i + 1)] + [f"{number(e[i], digits=6)} ({100 * e[i] / t:.1f} %)" for _, e, t in cols])
    rows.append(["sum"] + [f"{number(e.sum(), digits=6)} ({100 * e.sum() / t:.1f} %)" for _, e, t in cols])
    lines = ["effective modal masses, kg (base translation along x, y, z; % of the mass it moves, "
             f"{', '.join(f'{a}: {number(t, digits=6)} kg' for a, _, t in cols)})"]
    lines += ["  " + x for x in table(["mode"] + [f"along {a}" for a, _, _ in cols], rows)]
    return "\n".join(lines)


def print_modes(system, method="fd", out=None, report=None):
    """Print the operating point, the modes (ascending in ω²) with their shapes, the damped modes, stability
    and error estimates (``report``: a :func:`modal_report` already computed)."""
    out = out or sys.stdout
    op, lin, m, _ = report or modal_report(system, method)
    print(op, file=out)
    print(f"linearisation ({lin.method}): relative error ≈ {lin.relative_error:.1e}, {lin.elapsed * 1e3:.2f} ms, "
          f"{lin.evaluations} evaluations", file=out)
    print("", file=out)
    print(modes_text(lin, m), file=out)
    text = point_shapes_text(m)
    if text:
        print("", file=out)
        print(text, file=out)
    text = participation_text(m)
    if text:
        print("", file=out)
        print(text, file=out)
    if op.regime == "held" and (m.rigid.any() or m.unstable.any()):
        n = int(m.rigid.sum() + m.unstable.sum())
        print(f"note: held by drives with no servo stiffness: only gravity stiffens it, so {n} mode(s) come out "
              "rigid or unstable; give the joints servo stiffness (--servo K,C, or vd.load_robot(name, servo=(K, "
              "C)) or vd.add_servo(scene, K, C) in Python)", file=out)


def modes_text(lin, m, per_block=8):
    """The modes of ``m`` as text: undamped modes in ascending order of signed ω² (unstable directions
    first, then rigid ones, then natural frequencies), their shapes per coordinate (largest entry 1), and
    the damped modes with a note on how they are counted."""
    order = np.argsort(m.omega2, kind="stable")
    lines = ["undamped modes (K_s φ = ω² M φ: ω the undamped natural frequency, f = ω/2π), in ascending order of "
             "ω² (unstable directions, ω² < 0, first; then rigid ones, ω² = 0)"]
    rows = []
    for j in order:
        if m.unstable[j]:
            w, f = "-", "-"
            note = f"UNSTABLE: grows as exp(σt), growth rate σ = {number(m.omega[j], digits=5)} 1/s (not a frequency)"
        else:
            w, f = number(m.omega[j], digits=8), number(m.frequency_hz[j], digits=6)
            note = "rigid" if m.rigid[j] else ""
        rows.append([str(j + 1), number(m.omega2[j], digits=6), w, f, number(m.omega_error[j], digits=1), note])
    lines += ["  " + x for x in table(["mode", "ω² 1/s²", "ω rad/s", "f Hz", "ω error rad/s", "note"], rows,
                                      ["<", ">", ">", ">", ">", "<"])]
    if m.n:
        # a shape is known to about K's relative error (first order): entries below it are noise
        cut = 10 * (lin.relative_error + m.n * np.finfo(float).eps)
        lines.append("")
        lines.append("mode shapes (each scaled so its largest entry is 1; m or rad per coordinate)")
        S = m.shapes / np.abs(m.shapes).max(axis=0, initial=1e-300)
        names, units = m.linear.coordinates, m.linear.units  # what the shapes refer to
        for b in range(0, len(order), per_block):
            cols = order[b:b + per_block]
            rows = [[c, u] + [number(S[i, j], error=cut, digits=4) for j in cols]
                    for i, (c, u) in enumerate(zip(names, units))]
            lines += ["  " + x for x in table(["coordinate", "unit"] + [f"mode {j + 1}" for j in cols], rows,
                                              ["<", "<"] + [">"] * len(cols))]
    if m.eigenvalues.size:
        lines.append("")
        lines.append("damped modes (state form: eigenvalues λ = −ζω_n ± iω_d, 1/s; ω_n = |λ| the natural "
                     "frequency, ω_d = |Im λ| the damped frequency, f_d = ω_d/2π; a real λ is a rate, not a "
                     "frequency)")
        rows = []
        for i, lam in enumerate(m.damped_eigenvalues):
            err = m.eigenvalue_error[i]  # (1/s) a real part below it is round-off, shown as 0
            im = "" if lam.imag == 0 else f" ± {number(abs(lam.imag), digits=8)}i"
            wd = number(m.omega_d[i], digits=8) if lam.imag else "-"
            fd = number(m.omega_d[i] / (2 * np.pi), digits=6) if lam.imag else "-"
            rows.append([str(i + 1), number(lam.real, error=err, digits=8) + im,
                         number(m.zeta[i], error=m.eigenvalue_relative_error[i], digits=6),
                         number(m.omega_n[i], digits=8), wd, fd, number(m.eigenvalue_error[i], digits=1)])
        lines += ["  " + x for x in table(["mode", "λ 1/s", "ζ", "ω_n rad/s", "ω_d rad/s", "f_d Hz", "λ error 1/s"],
                                          rows)]
        lines.append("  " + _damped_note(m))
    lines.append(f"stability {m.stability}; relative error ≈ {m.relative_error:.1e}; {m.elapsed * 1e3:.2f} ms")
    if m.note:
        lines.append(f"note: {m.note}")
    return "\n".join(lines)


def _damped_note(m):
    """Why the damped table's length differs from the undamped one's."""
    lam = m.damped_eigenvalues
    pairs = int(np.sum(lam.imag > 0))
    is_real = lam.imag == 0
    real = lam[is_real]
    zero = int(np.sum(m.damped_zero[is_real]))
    decay = int(np.sum(~m.damped_zero[is_real] & (real.real < 0)))
    grow = len(real) - zero - decay
    kinds = [f"{k} {what}" for k, what in ((zero, "zero (rigid or cyclic)"), (decay, "decaying (overdamped)"),
                                           (grow, "growing (unstable)")) if k]
    text = (f"{m.eigenvalues.size} eigenvalues for {m.n} coordinates: each complex pair λ, λ̄ is one row "
            f"({pairs} pair{'s' * (pairs != 1)}), "
            + (f"each real eigenvalue a row of its own ({len(real)}: {', '.join(kinds)})" if len(real)
               else "none is real"))
    if len(lam) != m.n:
        text += f", hence {len(lam)} rows against {m.n} undamped modes"
    return "note: " + text


def start_offsets(items):
    """{coordinate: offset (m or rad)} from ``NAME=VALUE`` strings (the ``--start`` option)."""
    return name_values(items, "--start", "a coordinate and its offset from neutral (m or rad), e.g. --start "
                                         "pendulum=-1.5")


def servo_pair(text):
    """(stiffness, damping) from ``K,C`` (the ``--servo`` option)."""
    try:
        k, c = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected K,C (two numbers: stiffness and damping), got {text!r}") from None
    return k, c


def with_start(scene, start):
    """``scene`` with its operating point starting from ``start`` ({coordinate: offset}); coordinates not
    named keep the scene's own start."""
    if not start:
        return scene
    op = scene.operating_point or {}
    own = op.get("start")
    if own is not None and not isinstance(own, dict):
        own = dict(zip(scene.build().coordinates, own))
    scene.set_operating_point(op.get("cyclic"), {**(own or {}), **start}, op.get("held", False))
    return scene


def demo(out=None):
    """The main job on the bundled trailer model: the scene, its equilibrium, linear model and modes,
    and its nonlinear dynamics at a displaced state."""
    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    scene = load("trailer")
    system = scene.build()
    describe(scene, system, out)
    p("")
    print_modes(system, out=out)
    ref = scene.references.get("omega")
    if ref is not None:
        m = system.operating_point().linearize().modes()
        p(f"reference omega {vector(ref)} rad/s: largest relative difference "
          f"{np.max(np.abs(m.omega - np.array(ref)) / np.array(ref)):.1e}")
    q = system.integrate(system.neutral(), np.full(system.nv, 0.2))
    v = np.zeros(system.nv)
    times = []
    for _ in range(20):
        t0 = time.perf_counter()
        a = system.accelerations(q, v)
        times.append(time.perf_counter() - t0)
    dt = min(times)
    p("")
    p(f"displaced  q = {vector(q)} (m, rad), v = 0")
    p(f"dv/dt      {vector(a)} (ABA, {dt * 1e6:.0f} µs; RNEA residual "
      f"{np.abs(system.inverse_dynamics(q, v, a)).max():.1e})")
    e = system.energy(q, v)
    p(f"energy     gravity {number(e.gravity, 'J')}, elastic {number(e.elastic, 'J')}")
    r = system.reactions(q, v, a)
    for name, f, mo in zip(r.bodies, r.force, r.moment):
        p(f"link {name:<8} force {vector(f)} N, moment {vector(mo)} N·m (world axes, at the joint)")


def main(argv=None):
    """The ``vibdyn`` command (exit status 0, or 2 with a one-line error); output cut short by its reader
    (``vibdyn info four_bar | head``) ends quietly; a warning (a hint such as "degrees by mistake?") prints as
    one line "vibdyn: warning: ...", not as Python's source line of the console script."""
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.showwarning = lambda message, category, *_: print(f"vibdyn: warning: {message}", file=sys.stderr)
            return _main(argv)
    except BrokenPipeError:  # the reader closed the pipe: no traceback (Python's documented recipe)
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1


SCENE_HELP = "scene file, bundled model name, or robot:NAME"


def _add_info(sub):
    sub.add_parser("info", help="print a scene's bodies, joints, coordinates and elements").add_argument(
        "scene", help=SCENE_HELP)


def _run_info(args):
    scene = load(args.scene)
    describe(scene, scene.build())


def _add_modes(sub):
    modes = sub.add_parser("modes", help="equilibrium, natural frequencies, damping ratios and stability")
    modes.add_argument("scene", help=SCENE_HELP)
    modes.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    modes.add_argument("--method", choices=("fd", "analytic"), default="fd", help="linearisation method")
    modes.add_argument("--start", nargs="+", metavar="NAME=VALUE",
                       help="where the operating point's search starts (or the held configuration): offsets "
                            "from neutral by coordinate, m or rad (others: the scene's start, else 0)")
    modes.add_argument("--png", help="also draw every mode (deformed over undeformed) into this PNG file")
    modes.add_argument("--servo", type=servo_pair, metavar="K,C",
                       help="hold every pivot and slider by a position servo: stiffness K (N·m/rad or N/m) and "
                            "damping C (N·m·s/rad or N·s/m) about the start (a held robot's vibration modes)")


def _run_modes(args):
    scene = with_start(load(args.scene), start_offsets(args.start))
    if args.servo:
        from ..io.robots import add_servo

        add_servo(scene, *args.servo)
    system = scene.build()
    report = modal_report(system, args.method)
    if args.json:
        import json

        print(json.dumps(report[3], indent=1))
    else:
        print_modes(system, args.method, report=report)
    from .nonlinear_command import write_files  # the picture after the table: a failure keeps the table

    write_files(print, [(args.png, lambda: report[2].plot(args.png))], announce=not args.json)


def _add_demo(sub):
    sub.add_parser("demo", help="run the main job on the bundled trailer model")


def _run_demo(args):
    demo()


def _add_frf(sub):
    frf = sub.add_parser("frf", help="frequency response between two channels: peaks, half-power damping, plots")
    frf.add_argument("scene", help=SCENE_HELP)
    frf.add_argument("--input", required=True, help="coordinate name, BODY:X,Y,Z:DX,DY,DZ (point force), or "
                     "support:NAME[:DX,DY,DZ] (base motion: transmissibility)")
    frf.add_argument("--output", required=True, help="coordinate name or BODY:X,Y,Z:DX,DY,DZ (point displacement)")
    frf.add_argument("--from", dest="w0", type=float, help="lowest frequency, rad/s (default 0.1 × lowest ω)")
    frf.add_argument("--to", dest="w1", type=float, help="highest frequency, rad/s (default 2 × highest ω)")
    frf.add_argument("--points", type=int, default=400, help="number of frequencies (log-spaced; default 400)")
    frf.add_argument("--method", choices=("direct", "modal"), default="direct", help="direct solve or modal sum")
    frf.add_argument("--png", help="save a Bode plot (amplitude and phase) to this PNG file")
    frf.add_argument("--nyquist", help="save a Nyquist plot to this PNG file")
    frf.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    frf.add_argument("--start", nargs="+", metavar="NAME=VALUE",
                     help="where the operating point's search starts (offsets from neutral by coordinate)")


def _run_frf(args):
    system = with_start(load(args.scene), start_offsets(args.start)).build()
    from .frf_command import frf_report, print_frf

    frf, peaks, hp, data = frf_report(system, args.input, args.output, args.w0, args.w1, args.points, args.method)
    if args.json:
        import json

        print(json.dumps(data, indent=1))
    else:
        print_frf(frf, peaks, hp, notes=data["notes"])
    from . import plots
    from .nonlinear_command import write_files  # the pictures after the table: a failure keeps the table

    write_files(print, [(args.png, lambda: plots.bode(frf, path=args.png)),
                        (args.nyquist, lambda: plots.nyquist(frf, path=args.nyquist))], announce=not args.json)


def _add_bench(sub):
    sub.add_parser("bench", help="the regression benchmarks (vibdyn bench --help; needs a source checkout)")


def _add_simulate(sub):
    sim = sub.add_parser("simulate", help="nonlinear time simulation: error estimate, energy balance, export")
    sim.add_argument("scene", help=SCENE_HELP)
    sim.add_argument("--t-end", type=float, required=True, help="simulated time, s")
    from ..simulation.integrators import ALIASES, METHODS  # the registry only: no scipy until a method runs

    sim.add_argument("--method", default="dop853", choices=[*METHODS, *ALIASES],
                     help=f"{', '.join(METHODS)} (default dop853)")
    sim.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance (adaptive methods)")
    sim.add_argument("--atol", type=float, help="absolute tolerance (default rtol × 1 rad or the length scale)")
    sim.add_argument("--dt", type=float, help="step of rk4/symplectic, first step of adaptive methods (s)")
    sim.add_argument("--error-method", "--error", dest="error", help="how the error is estimated: local, rerun or "
                     "richardson (default: the method's own; --error: its former name)")
    sim.add_argument("--samples", type=int, help="number of equally spaced outputs (default: every step)")
    sim.add_argument("--offset", type=float, nargs="+",
                     help="initial tangent offsets (m, rad) from neutral (a mechanism with loops: from its declared "
                          "start, if it has one; the start is then put on the loops)")
    sim.add_argument("--v0", type=float, nargs="+", help="initial velocities (m/s, rad/s)")
    sim.add_argument("--out", help="write the trajectory to this .npz or .csv file")
    sim.add_argument("--no-progress", action="store_true", help="no progress bar")


def _run_simulate(args):
    from .simulate_command import command

    command(load(args.scene).build(), args)


def _add_view(sub):
    view = sub.add_parser("view", help="browser viewer of the modes (live, on 127.0.0.1) or an offline HTML page",
                          description="Show the modes (or a trajectory) in the browser: a live meshcat server on "
                          "127.0.0.1 (Ctrl-C stops it), or with --html a self-contained page.")
    view.add_argument("scene", help=SCENE_HELP)
    view.add_argument("--mode", type=int, default=1, help="motion shown first (1-based; default 1)")
    view.add_argument("--amplitude", type=float, help="largest point displacement shown, m (default 10%% of the "
                      "scene's size)")
    view.add_argument("--trajectory", help="replay this .npz or .csv trajectory (vibdyn simulate --out) instead of "
                      "the modes")
    view.add_argument("--speed", type=float, default=1.0, help="replay speed, × real time (default 1)")
    view.add_argument("--html", help="write a self-contained HTML page (every mode) to this file and exit")
    view.add_argument("--no-browser", action="store_true", help="live: print the URL, do not open a browser")
    view.add_argument("--duration", type=float, help="live: stop after this many seconds (default: until Ctrl-C)")


def _run_view(args):
    from .viewer.cli import command as view_command

    view_command(load(args.scene), args)


def _add_campbell(sub):
    cam = sub.add_parser("campbell", help="Campbell diagram: modes against spin speed, whirl, critical speeds")
    cam.add_argument("scene", help=SCENE_HELP)
    cam.add_argument("--spin", required=True, help="the spinning coordinate (held at each speed by its drive)")
    cam.add_argument("--speeds", required=True, help="FROM:TO:N (N equally spaced speeds, rad/s) or a comma list")
    cam.add_argument("--orders", default="1", help="engine orders, comma separated (default 1)")
    cam.add_argument("--method", choices=("fd", "analytic"), default="analytic", help="linearisation method")
    cam.add_argument("--free-spin", action="store_true",
                     help="leave the spin free at each steady motion (default: held by its drive, unless a motor "
                          "law on it depends on its speed)")
    cam.add_argument("--rpm", action="store_true", help="speeds in rpm: --speeds read, the table and the picture")
    cam.add_argument("--png", help="save the diagram to this PNG file")
    cam.add_argument("--json", action="store_true", help="print a JSON object instead of text")


def _run_campbell(args):
    from .campbell_command import command

    command(load(args.scene).build(), args)


def _add_sensitivity(sub):
    from .sensitivity_command import add

    add(sub, SCENE_HELP)


def _run_sensitivity(args):
    from .sensitivity_command import command

    command(load(args.scene), args)


def _add_spectrum(sub):
    from .spectrum_command import add

    add(sub, SCENE_HELP)


def _run_spectrum(args):
    from .spectrum_command import command

    command(load(args.scene), args)


def _add_random(sub):
    from .random_command import add

    add(sub, SCENE_HELP)


def _run_random(args):
    from .random_command import command

    command(load(args.scene), args)


def _run_nonlinear(args):
    from .nonlinear_command import RUNNERS

    RUNNERS[args.command](with_start(load(args.scene), start_offsets(getattr(args, "start", None))), args)


#: the subcommands, in the order ``vibdyn --help`` lists them: name -> (add its parser, run it)
COMMANDS = {"info": (_add_info, _run_info), "modes": (_add_modes, _run_modes), "demo": (_add_demo, _run_demo),
            "frf": (_add_frf, _run_frf), "bench": (_add_bench, None), "simulate": (_add_simulate, _run_simulate),
            "view": (_add_view, _run_view), "campbell": (_add_campbell, _run_campbell),
            "sensitivity": (_add_sensitivity, _run_sensitivity),
            "spectrum": (_add_spectrum, _run_spectrum), "random": (_add_random, _run_random),
            **{name: (add, _run_nonlinear) for name, add in NONLINEAR.items()}}


def _main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["bench"]:  # forwarded whole to the suite's own parser (vibdyn bench --help)
        try:
            return bench(argv[1:])
        except VibdynError as e:
            print(f"vibdyn: error: {e}", file=sys.stderr)
            return 2
    parser = argparse.ArgumentParser(prog="vibdyn", description="Vibration analysis of sets of rigid solids.")
    parser.add_argument("--version", action="version", version=f"vibdyn {_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    for add, _ in COMMANDS.values():
        add(sub)
    args = parser.parse_args(argv)
    try:
        COMMANDS[args.command][1](args)
    except VibdynError as e:
        print(f"vibdyn: error: {e}", file=sys.stderr)
        return 2
    return 0


def _version():
    from importlib import metadata

    try:
        return metadata.version("vibdyn")
    except metadata.PackageNotFoundError:  # pragma: no cover - a source tree on sys.path, never installed
        return "0+unknown"


def _rotation(R):
    """A rotation matrix as its rotation vector (rad)."""
    import pinocchio as pin

    return vector(pin.log3(np.array(R)), "rad (rotation vector)")


def _inertia(I):
    I = np.array(I)
    if not np.any(I - np.diag(np.diag(I))):
        return f"diag{vector(np.diag(I))} kg·m²"
    return "[" + ", ".join(vector(r) for r in I) + "] kg·m²"


def _limits(system, coordinate):
    lim = system.limits.get(coordinate)
    return "" if lim is None else f", limits {number(lim[0])} … {number(lim[1])}"


if __name__ == "__main__":
    sys.exit(main())
