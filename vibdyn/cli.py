"""The ``vibdyn`` command: ``vibdyn info SCENE``, ``vibdyn demo``.

SCENE is a TOML scene file, or ``robot:NAME`` for a robot of example-robot-data (e.g. ``robot:ur5``).
"""

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from .errors import VibdynError


def models_dir():
    """The bundled ``models/`` folder (override with the VIBDYN_MODELS environment variable)."""
    return Path(os.environ.get("VIBDYN_MODELS", Path(__file__).resolve().parents[1] / "models"))


def load(spec):
    """A Scene from a scene file path, a bundled model name, or ``robot:NAME``."""
    import vibdyn as vd

    if spec.startswith("robot:"):
        return vd.load_robot(spec[len("robot:"):])
    path = Path(spec)
    if not path.exists() and (models_dir() / f"{spec}.toml").exists():
        path = models_dir() / f"{spec}.toml"
    return vd.load_scene(path)


def describe(scene, system, out=sys.stdout):
    """Print a scene's bodies, joints, coordinates and force elements."""
    p = lambda *a: print(*a, file=out)  # noqa: E731
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


def demo(out=sys.stdout):
    """The main job on the bundled trailer scene: dynamics at a state, energies, link reactions."""
    p = lambda *a: print(*a, file=out)  # noqa: E731
    scene = load(str(models_dir() / "trailer.toml"))
    system = scene.build()
    describe(scene, system, out)
    q = system.neutral()
    q[system.coordinate_index("rod")] = 0.3
    v = np.zeros(system.nv)
    v[system.coordinate_index("cart")] = 0.2
    t0 = time.perf_counter()
    a = system.accelerations(q, v)
    dt = time.perf_counter() - t0
    residual = np.abs(system.inverse_dynamics(q, v, a)).max()
    p("")
    p(f"state      q = {_vec(q)}, v = {_vec(v)}")
    p(f"M(q)       {np.array2string(system.mass_matrix(q), precision=5)}")
    p(f"Q(q, v)    {_vec(system.generalized_forces(q, v))} (N, N·m)")
    p(f"dv/dt      {_vec(a)} (ABA, {dt * 1e6:.0f} µs; RNEA residual {residual:.1e})")
    e = system.energy(q, v)
    p(f"energy     kinetic {e.kinetic:.6g} J, gravity {e.gravity:.6g} J, elastic {e.elastic:.6g} J")
    r = system.reactions(q, v, a)
    for name, f, m in zip(r.bodies, r.force, r.moment):
        p(f"link {name:<6} force {_vec(f)} N, moment {_vec(m)} N·m (world axes, at the joint)")


def main(argv=None):
    parser = argparse.ArgumentParser(prog="vibdyn", description="Vibration analysis of sets of rigid solids.")
    sub = parser.add_subparsers(dest="command", required=True)
    info = sub.add_parser("info", help="print a scene's bodies, joints, coordinates and elements")
    info.add_argument("scene", help="scene file, bundled model name, or robot:NAME")
    sub.add_parser("demo", help="run the main job on the bundled trailer model")
    args = parser.parse_args(argv)
    try:
        if args.command == "info":
            scene = load(args.scene)
            describe(scene, scene.build())
        elif args.command == "demo":
            demo()
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
    from .elements import BodyForce, Damper, JointDamper, JointForce, JointSpring, Spring

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
