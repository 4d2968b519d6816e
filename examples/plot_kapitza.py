"""
Kapitza's pendulum: held upside down by shaking
===============================================

A pendulum (a sphere m = 1 kg, radius 2 cm, 0.3 m below its pivot) hangs from a carriage that a drive moves
vertically, z = a sin Ωt with a = 5 cm (the bundled ``shaken_pendulum``). Linearised about hanging (θ = 0) or
inverted (θ = π), in τ = Ωt, the pendulum obeys Mathieu's equation

    θ'' + (±g/(l_eq Ω²) − (a/l_eq) sin τ) θ = 0,   l_eq = I_O/(m l).

Kapitza (1951) found by averaging that the inverted pendulum is held up when a²Ω² > 2 g l_eq; the exact
boundary is Mathieu's characteristic value a₀(q) = −4g/(l_eq Ω²) with q = 2a/l_eq. vibdyn finds the periodic
orbit (here the pendulum at rest relative to the carriage) by shooting over the drive's period and its Floquet
multipliers from the monodromy of the variational equations — no Mathieu equation is written anywhere.
"""

# %%
# Inverted, shaken at Ω = 70 rad/s
# --------------------------------
# An undamped orbit: the multipliers lie on the unit circle within their error (μ₁μ₂ = det Φ = 1); their
# argument is the slow oscillation about the upright position, near Kapitza's averaged frequency.
import math

import matplotlib.pyplot as plt
import numpy as np
from scipy.optimize import brentq
from scipy.special import mathieu_a

import vibdyn as vd
from vibdyn.io.scenefile import scene_from_dict

scene = vd.load_scene("shaken_pendulum")
ref = scene.references
a, leq, g = ref["drive_amplitude"], ref["equivalent_length"], 9.81
UP = [0.0, math.pi]  # carriage (driven), pendulum inverted


def shaken(omega):
    """The bundled scene with the drive at ``omega`` rad/s."""
    d = scene.to_dict()
    d["drive"][0]["motion"]["omega"] = omega
    return scene_from_dict(d).build()


W = ref["drive_omega"]
up = vd.floquet(scene.build(), 2 * math.pi / W, UP)
print(up)
assert up.stability == "neutral within the error"
assert np.all(np.abs(np.abs(up.multipliers) - 1) <= up.multiplier_error)
slow = abs(np.angle(up.multipliers[0])) / up.period
print(f"slow oscillation about θ = π: ω = arg μ / T = {slow:.6f} rad/s ({slow / (2 * math.pi):.6f} Hz); "
      f"Kapitza's averaging (first order in a/l): {ref['omega_slow_inverted']:.6f} rad/s")

# %%
# The stability boundary against Mathieu's characteristic value
# --------------------------------------------------------------
# A 2 × 2 area-preserving monodromy is stable while |tr Φ| < 2: the boundary is the root of tr Φ(Ω) − 2, found by
# Brent's method on vibdyn's monodromies; its uncertainty is the trace's error over the slope there.
def trace(omega):
    orbit = vd.floquet(shaken(omega), 2 * math.pi / omega, UP)
    return float(np.trace(orbit.monodromy)) - 2.0, orbit


lo, hi = 0.8 * ref["omega_kapitza"], 1.2 * ref["omega_kapitza"]
boundary = brentq(lambda w: trace(w)[0], lo, hi, xtol=1e-12)
h = 1e-4 * boundary
slope = (trace(boundary + h)[0] - trace(boundary - h)[0]) / (2 * h)
at = trace(boundary)[1]
err = 2 * at.monodromy_error / abs(slope) + 1e-12 * boundary
q = 2 * a / leq
a0 = mathieu_a(0, q)
series = -q**2 / 2 + 7 * q**4 / 128 - 29 * q**6 / 2304 + 68687 * q**8 / 18874368  # its expansion (A&S 20.2.25)
exact = math.sqrt(-4 * g / (leq * a0))
exact_err = exact / 2 * abs(a0 - series) / abs(a0)  # the scipy value against the 8th-order series, as its error
print(f"held up above Ω = {boundary:.10f} ± {err:.1e} rad/s (vibdyn); Mathieu a₀(q = {q:.6f}) = {a0:.10f}: "
      f"{exact:.10f} ± {exact_err:.1e} rad/s; Kapitza's a²Ω² = 2 g l_eq: {ref['omega_kapitza']:.6f} rad/s "
      f"({100 * (ref['omega_kapitza'] / exact - 1):+.2f} %, first order in a/l)")
assert abs(boundary - exact) <= err + exact_err

# %%
# Multipliers across the threshold, and the motion
# ------------------------------------------------
# Below the boundary one multiplier leaves the unit circle (the pendulum falls, |μ| > 1); above it both stay on
# it. A simulation from 0.1 rad off upright, at rest: held up at 70 rad/s (a slow swing about π with the fast
# jitter of the drive on top), falling at 40 rad/s.
speeds = np.linspace(35.0, 80.0, 10)
largest = np.array([np.abs(trace(w)[1].multipliers).max() for w in speeds])
held = scene.build().simulate(2.0, [0.0, math.pi - 0.1], [0.0, 0.0], t_eval=np.linspace(0, 2.0, 801))
fall = shaken(40.0).simulate(2.0, [0.0, math.pi - 0.1], [0.0, 0.0], t_eval=np.linspace(0, 2.0, 801))
print(f"from θ = π − 0.1 rad: at {W:g} rad/s |θ − π| stays ≤ {np.abs(held.q[:, 1] - math.pi).max():.4f} rad "
      f"(error {held.error:.1e}); at 40 rad/s it reaches {np.abs(fall.q[:, 1] - math.pi).max():.3f} rad")
assert np.abs(held.q[:, 1] - math.pi).max() < math.pi / 4 and np.abs(fall.q[:, 1] - math.pi).max() > 1.0

fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
left.semilogy(speeds, largest - 1 + 1e-16, "o-")
left.axvline(boundary, color="C3", lw=0.8, label=f"boundary {boundary:.4f} rad/s")
left.axvline(ref["omega_kapitza"], color="0.5", ls="--", lw=0.8, label="Kapitza a²Ω² = 2 g l_eq")
left.set_xlabel("drive Ω (rad/s)")
left.set_ylabel("largest |μ| − 1 (inverted)")
left.legend(fontsize="small")
right.plot(held.t, held.q[:, 1], label=f"Ω = {W:g} rad/s: held up")
right.plot(fall.t, fall.q[:, 1], label="Ω = 40 rad/s: falls")
right.axhline(math.pi, color="0.5", lw=0.8)
right.set_xlabel("t (s)")
right.set_ylabel("θ (rad), π = upright")
right.legend(fontsize="small")

# %%
# The viewer replays the held-up motion at a quarter of real time.
vd.export_html(held, "viewer_kapitza.html", speed=0.25)
plt.show()
