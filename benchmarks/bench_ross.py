"""vibdyn beside ROSS (ross-rotordynamics): a rigid rotor on two cross-coupled bearings (issue 43, item 5).

ROSS models the rotor as Timoshenko beam elements; made rigid by multiplying steel's moduli by ``STIFFER``
(1e5), its rigid-body lateral modes approach those of vibdyn's rigid solid (the same mass, transverse and polar
inertia: exactly, since the consistent mass matrix reproduces rigid motion) up to the shaft's remaining
flexibility, about (ω_rotor / ω_shaft)² ≈ 1e-5 relative. Compared at each speed: the damped frequencies ω_d,
the log decrements δ = 2πζ/√(1 − ζ²) = −2π Re λ / Im λ of the four lateral modes, and the unbalance response's
peaks (speed and 0-peak amplitude at the disk, each refined by Brent's method). Times: ROSS's and vibdyn's for
each analysis (best of ``--repeat``, ROSS's caches cleared; its first call compiles with numba, left out).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_ross.py [--repeat 3] [--json PATH]

ROSS is no vibdyn dependency: ``pip install ross-rotordynamics`` (2.3.0 here; it needs ``plotly<6``).
"""

from __future__ import annotations

import argparse
import json
import os
import time
import warnings

import numpy as np

import vibdyn as vd

RHO, E, G_S = 7810.0, 211e9, 81.2e9
STIFFER = float(os.environ.get("VIBDYN_ROSS_STIFFER", "1e5"))  # (another factor: the agreement's scaling)
L, D, N_EL = 0.5, 0.05, 4  # shaft length and diameter (m), elements
DISK = dict(m=20.0, Id=0.2, Ip=0.35)  # kg, kg·m² (at the middle node)
BEARINGS = [  # at the two ends: N/m and N·s/m, cross-coupled
    dict(kxx=1.0e6, kyy=1.5e6, kxy=2.0e5, kyx=-3.0e5, cxx=500.0, cyy=600.0, cxy=20.0, cyx=-30.0),
    dict(kxx=1.2e6, kyy=1.3e6, kxy=1.0e5, kyx=-1.0e5, cxx=400.0, cyy=400.0, cxy=0.0, cyx=0.0),
]
UNBALANCE = 1e-4  # kg·m at the disk, phase 0
SPEEDS = (0.0, 300.0, 600.0)  # rad/s, for the modes


def shaft_properties():
    """(mass kg, transverse inertia about the centre kg·m², polar inertia kg·m²) of the solid shaft."""
    r = D / 2
    m = RHO * np.pi * r ** 2 * L
    return m, m * (L ** 2 / 12 + r ** 2 / 4), m * r ** 2 / 2


def vibdyn_rotor():
    """The rigid rotor in vibdyn: sliders x, y and tilts about x, y at the centre of mass, then the spin about z;
    the bearings at z = ∓L/2 from the centre, housings on the world."""
    ms, Its, Ips = shaft_properties()
    m, It, Ip = ms + DISK["m"], Its + DISK["Id"], Ips + DISK["Ip"]
    s = vd.Scene("rigid_rotor_ross")
    s.add_body("x", joint=vd.Slider((1, 0, 0)), mass=0.0)
    s.add_body("y", parent="x", joint=vd.Slider((0, 1, 0)), mass=0.0)
    s.add_body("tilt_x", parent="y", joint=vd.Pivot((1, 0, 0)), mass=0.0)
    s.add_body("tilt_y", parent="tilt_x", joint=vd.Pivot((0, 1, 0)), mass=0.0)
    s.add_body("rotor", parent="tilt_y", joint=vd.Pivot((0, 0, 1)), mass=m, inertia=np.diag([It, It, Ip]))
    for i, (b, z) in enumerate(zip(BEARINGS, (-L / 2, L / 2))):
        s.add_bearing(f"bearing_{i}", ("world", (0.0, 0.0, z)), ("rotor", (0.0, 0.0, z)),
                      stiffness=[[b["kxx"], b["kxy"]], [b["kyx"], b["kyy"]]],
                      damping=[[b["cxx"], b["cxy"]], [b["cyx"], b["cyy"]]])
    s.add_unbalance("disk_unbalance", "rotor", UNBALANCE)
    return s.build()


def ross_rotor():
    import ross as rs

    steel = rs.Material(name="steel_rigid", rho=RHO, E=E * STIFFER, G_s=G_S * STIFFER)
    shaft = [rs.ShaftElement(L / N_EL, idl=0.0, odl=D, material=steel, shear_effects=True, rotary_inertia=True,
                             gyroscopic=True) for _ in range(N_EL)]
    disk = [rs.DiskElement(n=N_EL // 2, **DISK)]
    bearings = [rs.BearingElement(n=n, **b) for n, b in zip((0, N_EL), BEARINGS)]
    return rs.Rotor(shaft, disk, bearings)


def log_dec(lam):
    """δ = −2π Re λ / Im λ (= 2πζ/√(1 − ζ²)), frequencies in the fixed frame."""
    return -2 * np.pi * lam.real / lam.imag


def vibdyn_modes(system, speed):
    """(ω_d, δ) of the four lateral modes at ``speed`` (rad/s), spin held, ascending ω_d; and the error of ω_d."""
    lin = system.steady_motion({"rotor": speed}).linearize(method="analytic", hold="rotor")
    m = lin.modes()
    lam = m.damped_eigenvalues
    keep = lam.imag > 0
    order = np.argsort(lam[keep].imag)
    lam = lam[keep][order]
    return lam.imag, log_dec(lam), (m.eigenvalue_relative_error[keep][order] * np.abs(lam))


def ross_modes(rotor, speed):
    m = rotor.run_modal(speed=speed, num_modes=12, sparse=False)
    lam = np.asarray(m.evalues)
    lam = lam[(lam.imag > 1.0) & (lam.imag < 1e4)]  # the four rigid-rotor modes (the shaft's at 1e6 rad/s; the
    # free torsion and axial motions near 0)
    lam = lam[np.argsort(lam.imag)]
    return lam.imag, log_dec(lam)


def vibdyn_peaks(system, speeds):
    r = vd.unbalance_response(system, "rotor", speeds, outputs=[("rotor", (0.0, 0.0, 0.0))])
    return [(p.speed, p.amplitude, p.speed_error, p.amplitude_error) for p in r.peaks(0) + r.peaks(1)], r


def ross_peaks(rotor, speeds, xtol=1e-10):
    """Peaks of the disk's x and y 0-peak amplitudes in ROSS: each local maximum on the grid refined by Brent's
    method on ROSS's own single-speed responses (vibdyn's refinement, applied to ROSS)."""
    from scipy.optimize import minimize_scalar

    node = N_EL // 2

    def amplitudes(w):
        res = rotor.run_unbalance_response(node, UNBALANCE, 0.0, frequency=np.atleast_1d(w))
        return np.abs(np.asarray(res.forced_resp)[rotor.number_dof * node:rotor.number_dof * node + 2])

    a = amplitudes(speeds)
    out = []
    for dof in (0, 1):
        for i in range(1, len(speeds) - 1):
            if a[dof, i] > a[dof, i - 1] and a[dof, i] >= a[dof, i + 1]:
                res = minimize_scalar(lambda w, dof=dof: -amplitudes(w)[dof, 0], bracket=tuple(speeds[i - 1:i + 2]),
                                      method="brent", tol=xtol)
                out.append((float(res.x), float(-res.fun)))
    return out, a


def best(fun, repeat, rotor=None):
    """(result, best time of ``repeat`` calls); ``rotor``: a ROSS rotor whose cached analyses are cleared before
    each call (ROSS keeps each analysis' result: a repeat would time a lookup)."""
    times, out = [], None
    for _ in range(repeat):
        if rotor is not None:
            for name in ("run_modal", "run_unbalance_response"):
                cached = getattr(rotor, name)
                if hasattr(cached, "cache_clear"):
                    cached.cache_clear()
        t = time.perf_counter()
        out = fun()
        times.append(time.perf_counter() - t)
    return out, min(times)


def run(repeat=3):
    warnings.filterwarnings("ignore")
    system = vibdyn_rotor()
    rotor = ross_rotor()
    ross_modes(rotor, 100.0)  # (numba's compilation, left out of the times)
    report = {"modes": [], "peaks": {}}
    for speed in SPEEDS:
        (w_v, d_v, err), tv = best(lambda speed=speed: vibdyn_modes(system, speed), repeat)
        (w_r, d_r), tr = best(lambda speed=speed: ross_modes(rotor, speed), repeat, rotor)
        report["modes"].append({
            "speed_rad_s": speed, "omega_d_vibdyn_rad_s": w_v.tolist(), "omega_d_ross_rad_s": w_r.tolist(),
            "omega_d_relative_difference": (np.abs(w_v - w_r) / w_r).tolist(),
            "omega_d_vibdyn_error_rad_s": err.tolist(),
            "log_dec_vibdyn": d_v.tolist(), "log_dec_ross": d_r.tolist(),
            "log_dec_difference": np.abs(d_v - d_r).tolist(), "time_vibdyn_s": tv, "time_ross_s": tr})
    # unbalance response: the same grid, each local maximum refined by Brent's method (vibdyn's own; for ROSS,
    # the same method on ROSS's single-speed responses)
    grid = np.linspace(150.0, 450.0, 31)
    (pv, _), tv = best(lambda: vibdyn_peaks(system, grid), max(1, repeat - 1))
    (pr, _), tr = best(lambda: ross_peaks(rotor, grid), max(1, repeat - 1), rotor)
    report["peaks"] = {"vibdyn": [{"speed_rad_s": s, "amplitude_m": a, "speed_error_rad_s": se, "amplitude_error_m": ae}
                                  for s, a, se, ae in pv],
                       "ross": [{"speed_rad_s": s, "amplitude_m": a} for s, a in pr],
                       "time_vibdyn_s": tv, "time_ross_s": tr, "grid_speeds": int(grid.size)}
    return report


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--json", default=None)
    args = p.parse_args()
    rep = run(args.repeat)
    for m in rep["modes"]:
        print(f"Ω = {m['speed_rad_s']:g} rad/s: ω_d vibdyn {np.round(m['omega_d_vibdyn_rad_s'], 6)}")
        print(f"    ω_d ROSS   {np.round(m['omega_d_ross_rad_s'], 6)}; relative difference "
              f"{max(m['omega_d_relative_difference']):.1e}")
        print(f"    δ vibdyn {np.round(m['log_dec_vibdyn'], 6)}, ROSS {np.round(m['log_dec_ross'], 6)}; "
              f"difference {max(m['log_dec_difference']):.1e}")
        print(f"    time: vibdyn {1e3 * m['time_vibdyn_s']:.1f} ms, ROSS {1e3 * m['time_ross_s']:.1f} ms")
    pk = rep["peaks"]
    for v in pk["vibdyn"]:
        print(f"peak vibdyn {v['speed_rad_s']:.6f} ± {v['speed_error_rad_s']:.1e} rad/s, {v['amplitude_m']:.6e} m")
    for r in pk["ross"]:
        print(f"peak ROSS   {r['speed_rad_s']:.6f} rad/s, {r['amplitude_m']:.6e} m")
    print(f"unbalance response, {pk['grid_speeds']} speeds and the peaks refined: vibdyn {pk['time_vibdyn_s']:.2f} s, "
          f"ROSS {pk['time_ross_s']:.2f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rep, f, indent=1)


if __name__ == "__main__":
    main()
