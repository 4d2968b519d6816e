"""The ``vibdyn`` command: ``vibdyn info SCENE``, ``vibdyn modes SCENE [--json]``, ``vibdyn demo``,
``vibdyn bench [--quick] [--smoke] [--check] [--only NAME]`` (the repository's benchmark suite).

SCENE is a TOML scene file, or ``robot:NAME`` for a robot of example-robot-data (e.g. ``robot:ur5``).
"""

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from .errors import ModelError, VibdynError


def models_dir():
    """The bundled ``models/`` folder (override with the VIBDYN_MODELS environment variable)."""
    return Path(os.environ.get("VIBDYN_MODELS", Path(__file__).resolve().parents[1] / "models"))


def benchmarks_dir():
    """The repository's ``benchmarks/`` folder (override with the VIBDYN_BENCHMARKS environment variable).
    It is not part of the installed package: it exists in a source checkout (an editable install)."""
    return Path(os.environ.get("VIBDYN_BENCHMARKS", Path(__file__).resolve().parents[1] / "benchmarks"))


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
    """A Scene from a scene file path, a bundled model name, or ``robot:NAME``."""
    import vibdyn as vd

    if spec.startswith("robot:"):
        return vd.load_robot(spec[len("robot:"):])
    path = Path(spec)
    if not path.exists() and (models_dir() / f"{spec}.toml").exists():
        path = models_dir() / f"{spec}.toml"
    return vd.load_scene(path)


def describe(scene, system, out=None):
    """Print a scene's bodies, joints, coordinates and force elements."""
    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    p(f"scene      {scene.name}")
    if scene.source:
        p(f"source     {scene.source}")
    p(f"gravity    {_vec(scene.gravity)} m/s²")
    p(f"size       {len(scene.bodies)} bodies, nq = {system.nq}, nv = {system.nv}")
    p("")
    p(f"{'body':<22} {'parent':<18} {'joint':<12} {'axis / params':<28} {'mass kg':>9}  coordinates")
    for b in scene.bodies.values():
        params = b.joint.params()
        extra = ", ".join(f"{k}={_vec(v) if isinstance(v, list) else f'{v:g}'}" for k, v in params.items())
        p(f"{b.name:<22} {b.parent:<18} {b.joint.kind:<12} {extra:<28} {b.mass:>9.4g}  "
          f"{' '.join(b.coordinates) or '-'}")
    if scene.elements:
        p("")
        p(f"{'element':<22} {'kind':<13} details")
        for e in scene.elements.values():
            p(f"{e.name:<22} {_kind(e):<13} {_details(e)}")
    if scene.references:
        p("")
        p("reference values: " + ", ".join(sorted(k for k in scene.references if k not in ("source", "note"))))
    if system.nv:
        t0 = time.perf_counter()
        M = system.mass_matrix(system.neutral())
        dt = time.perf_counter() - t0
        w = np.linalg.eigvalsh(M)
        p("")
        p(f"mass matrix at neutral: eigenvalues {w[0]:.4g} … {w[-1]:.4g} (condition {w[-1] / w[0]:.3g}), "
          f"{dt * 1e3:.2f} ms")
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
            "kind": op.kind, "stability": op.stability, "residual": op.residual, "iterations": op.iterations,
            "q": op.q.tolist(), "v": op.v.tolist(),
            "offsets": system.difference(system.neutral(), op.q).tolist(),
            "speeds": op.speeds, "elapsed_s": op.elapsed},
        "linearization": {"method": lin.method, "error_estimate": lin.error, "elapsed_s": lin.elapsed,
                          "evaluations": lin.evaluations, "M": lin.M.tolist(), "C": lin.C.tolist(),
                          "K": lin.K.tolist()},
        "modes": m.to_dict(),
    }


def print_modes(system, method="fd", out=None):
    """Print the operating point, natural frequencies, damping ratios, stability and error estimate."""
    out = out or sys.stdout
    op, lin, m, _ = modal_report(system, method)
    print(op, file=out)
    print(f"linearisation ({lin.method}): error ≈ {lin.error:.1e}, {lin.elapsed * 1e3:.2f} ms, "
          f"{lin.evaluations} evaluations", file=out)
    print(m, file=out)


def demo(out=None):
    """The main job on the bundled trailer model: the scene, its equilibrium, linear model and modes,
    and its nonlinear dynamics at a displaced state."""
    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    scene = load(str(models_dir() / "trailer.toml"))
    system = scene.build()
    describe(scene, system, out)
    p("")
    print_modes(system, out=out)
    ref = scene.references.get("omega")
    if ref is not None:
        m = system.operating_point().linearize().modes()
        p(f"reference omega {_vec(ref)} rad/s: largest relative difference "
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
    p(f"displaced  q = {_vec(q)} (m, rad), v = 0")
    p(f"dv/dt      {_vec(a)} (ABA, {dt * 1e6:.0f} µs; RNEA residual "
      f"{np.abs(system.inverse_dynamics(q, v, a)).max():.1e})")
    e = system.energy(q, v)
    p(f"energy     gravity {e.gravity:.6g} J, elastic {e.elastic:.6g} J")
    r = system.reactions(q, v, a)
    for name, f, mo in zip(r.bodies, r.force, r.moment):
        p(f"link {name:<8} force {_vec(f)} N, moment {_vec(mo)} N·m (world axes, at the joint)")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["bench"]:  # forwarded whole to the suite's own parser (vibdyn bench --help)
        try:
            return bench(argv[1:])
        except VibdynError as e:
            print(f"vibdyn: error: {e}", file=sys.stderr)
            return 2
    parser = argparse.ArgumentParser(prog="vibdyn", description="Vibration analysis of sets of rigid solids.")
    sub = parser.add_subparsers(dest="command", required=True)
    info = sub.add_parser("info", help="print a scene's bodies, joints, coordinates and elements")
    info.add_argument("scene", help="scene file, bundled model name, or robot:NAME")
    modes = sub.add_parser("modes", help="equilibrium, natural frequencies, damping ratios and stability")
    modes.add_argument("scene", help="scene file, bundled model name, or robot:NAME")
    modes.add_argument("--json", action="store_true", help="print a JSON object instead of text")
    modes.add_argument("--method", choices=("fd", "analytic"), default="fd", help="linearisation method")
    sub.add_parser("demo", help="run the main job on the bundled trailer model")
    frf = sub.add_parser("frf", help="frequency response between two channels: peaks, half-power damping, plots")
    frf.add_argument("scene", help="scene file, bundled model name, or robot:NAME")
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
    sub.add_parser("bench", help="the regression benchmarks (vibdyn bench --help; needs a source checkout)")
    sim = sub.add_parser("simulate", help="nonlinear time simulation: error estimate, energy balance, export")
    sim.add_argument("scene", help="scene file, bundled model name, or robot:NAME")
    sim.add_argument("--t-end", type=float, required=True, help="simulated time, s")
    sim.add_argument("--method", default="dop853", help="dop853 (default), rk4, radau, bdf or symplectic")
    sim.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance (adaptive methods)")
    sim.add_argument("--atol", type=float, help="absolute tolerance (default rtol × 1 rad or the length scale)")
    sim.add_argument("--dt", type=float, help="step of rk4/symplectic, first step of adaptive methods (s)")
    sim.add_argument("--error", help="error estimate: local, rerun or richardson (default: the method's own)")
    sim.add_argument("--samples", type=int, help="number of equally spaced outputs (default: every step)")
    sim.add_argument("--offset", type=float, nargs="+", help="initial tangent offsets from neutral (m, rad)")
    sim.add_argument("--v0", type=float, nargs="+", help="initial velocities (m/s, rad/s)")
    sim.add_argument("--out", help="write the trajectory to this .npz or .csv file")
    sim.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    try:
        if args.command == "info":
            scene = load(args.scene)
            describe(scene, scene.build())
        elif args.command == "modes":
            system = load(args.scene).build()
            if args.json:
                import json

                print(json.dumps(modal_report(system, args.method)[3], indent=1))
            else:
                print_modes(system, args.method)
        elif args.command == "demo":
            demo()
        elif args.command == "frf":
            from .response import frf_report, print_frf

            system = load(args.scene).build()
            frf, peaks, hp, data = frf_report(system, args.input, args.output, args.w0, args.w1, args.points,
                                              args.method)
            if args.png or args.nyquist:
                from . import plots

                if args.png:
                    plots.bode(frf, path=args.png)
                if args.nyquist:
                    plots.nyquist(frf, path=args.nyquist)
            if args.json:
                import json

                print(json.dumps(data, indent=1))
            else:
                print_frf(frf, peaks, hp)
                for path in (args.png, args.nyquist):
                    if path:
                        print(f"saved {path}")
        elif args.command == "simulate":
            from .simulate import command

            command(load(args.scene).build(), args)
    except VibdynError as e:
        print(f"vibdyn: error: {e}", file=sys.stderr)
        return 2
    return 0


def _vec(x):
    return "(" + ", ".join(f"{float(v):.6g}" for v in np.ravel(x)) + ")"


def _kind(e):
    import re

    return re.sub(r"(?<!^)([A-Z])", r" \1", type(e).__name__).lower()


def _details(e):
    from .elements import BodyForce, Damper, JointDamper, JointForce, JointSpring, Spring, Support

    if isinstance(e, Support):
        try:
            return f"moving support: {e.motion.to_dict()}"
        except (ModelError, AttributeError):  # callables: no plain-data form
            return f"moving support: {type(e.motion).__name__}"

    if isinstance(e, Spring):
        l0 = "neutral distance" if e.free_length is None else f"{e.free_length:g} m"
        return f"{_end(e.a)} – {_end(e.b)}, k = {e.stiffness:g} N/m, free length {l0}"
    if isinstance(e, Damper):
        return f"{_end(e.a)} – {_end(e.b)}, c = {e.damping:g} N·s/m"
    if isinstance(e, JointSpring):
        return f"on {e.body}, k = {_vec(e.stiffness)}, rest {_vec(e.rest)}"
    if isinstance(e, JointDamper):
        return f"on {e.body}, c = {_vec(e.damping)}"
    if isinstance(e, JointForce):
        value = e.value.to_dict() if hasattr(e.value, "to_dict") else (
            "callable" if callable(e.value) else _vec(e.value))
        return f"on {e.body}: {value}"
    if isinstance(e, BodyForce):
        return f"on {e.body} at {_vec(e.at)}, force {'callable' if callable(e.force) else _vec(e.force)} ({e.frame})"
    return ""


def _end(a):
    return f"{a[0]}{_vec(a[1])}"


if __name__ == "__main__":
    sys.exit(main())
