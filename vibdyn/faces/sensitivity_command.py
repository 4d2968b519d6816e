"""``vibdyn sensitivity``: how each natural frequency moves with each named parameter (a table: mode ×
parameter, ∂ω/∂p with its error and the normalised (p/ω) ∂ω/∂p), or JSON."""

import sys

import numpy as np

from .._format import json_ready, number, table


def default_params(scene):
    """Every body's mass and every element's stiffness and damping (the parameters designers move first)."""
    from ..description.parameters import parameters

    names = [f"{b.name}.mass" for b in scene.bodies.values() if b.mass > 0]
    for e in scene.elements.values():
        names += [f"{e.name}.{a}" for a in ("stiffness", "damping") if np.any(getattr(e, a, 0.0))]
    return [p.name for p in parameters(scene, names)]


def add(sub, scene_help):
    s = sub.add_parser("sensitivity", help="how each natural frequency moves with each parameter (∂ω/∂p)")
    s.add_argument("scene", help=scene_help)
    s.add_argument("--param", action="append", metavar="NAME",
                   help="a parameter as '<body or element>.<attribute>' (k.stiffness, rod.mass, rod.com.z, "
                        "gravity, rotor.speed); repeat for more (default: every mass, stiffness and damping)")
    s.add_argument("--json", action="store_true", help="print a JSON object instead of text")


def command(scene, args, out=None):
    """Run ``vibdyn sensitivity`` on ``scene`` with the parsed ``args``."""
    from ..analysis.sensitivity import sensitivity

    p = lambda *a: print(*a, file=out or sys.stdout)  # noqa: E731
    params = args.param or default_params(scene)
    system = scene.build()
    s = sensitivity(system, params, unused="raise" if args.param else "drop")
    if args.json:
        import json

        p(json.dumps(json_ready(s.to_dict()), indent=1))
        return s
    p(f"Sensitivities of {system.name}: {s.d_omega.shape[0]} modes × {len(s.params)} parameters "
      f"({s.method}, {s.elapsed:.2f} s)")
    p("∂ω/∂p: undamped natural frequency ω (rad/s) per unit of p, with its absolute error; "
      "(p/ω) ∂ω/∂p: the % change of ω per % change of p")
    rows = []
    for i, w in enumerate(s.omega0):
        for j, name in enumerate(s.params):
            rows.append([str(i + 1), number(w, digits=6), name, number(s.values[j], s.units[j]),
                         f"{s.d_omega[i, j]:.6g}", f"{s.d_omega_error[i, j]:.1e}",
                         f"{s.normalised[i, j]:.4g}"])
    for line in table(["mode", "ω rad/s", "parameter", "value", "∂ω/∂p (rad/s per unit)", "± (abs)",
                       "(p/ω) ∂ω/∂p"], rows):
        p(line)
    if s.d_zeta.size:
        p("damped modes: ∂ζ/∂p (damping ratio per unit of p) and ∂ω_n/∂p (rad/s per unit)")
        rows = [[str(i + 1), name, f"{s.d_zeta[i, j]:.4g}", f"{s.d_zeta_error[i, j]:.1e}", f"{s.d_omega_n[i, j]:.6g}",
                 f"{s.d_omega_n_error[i, j]:.1e}"] for i in range(s.d_zeta.shape[0]) for j, name in enumerate(s.params)]
        for line in table(["mode", "parameter", "∂ζ/∂p", "± (abs)", "∂ω_n/∂p", "± (abs)"], rows):
            p(line)
    if s.note:
        p(f"note: {s.note}")
    return s
