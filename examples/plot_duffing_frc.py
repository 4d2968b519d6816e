"""
The Duffing oscillator's forced response
========================================

NLvib's first example (Krack & Gross, *Harmonic Balance for Nonlinear Vibration Problems*, 2019): a unit mass
on a slider held by a spring k = 1 N/m, a damper c = 0.05 N·s/m and a hardening cubic spring k₃ = 0.1 N/m³,
forced by F cos Ωt with F = 0.1 N:

    m ẍ + c ẋ + k x + k₃ x³ = F cos Ωt.

One harmonic, x = a cos(Ωt − φ), gives the classic closed form [(k − mΩ² + ¾k₃a²)² + (cΩ)²] a² = F²: the
curve leans to the right, with two folds (saddle-nodes) bounding three coexisting responses. vibdyn's harmonic
balance follows the curve through the folds by arclength continuation, adds harmonics until its truncation
estimate is below 1e-8 of the peak, and gives each point's Floquet multipliers by Hill's method.
"""

# %%
# One harmonic: the closed form
# -----------------------------
# With H = 1 the balance solves exactly the closed form's equations: its folds and peak are the reference's
# to the continuation's tolerance.
import math

import matplotlib.pyplot as plt
import numpy as np

import vibdyn as vd

scene = vd.load_scene("duffing")
ref = scene.references
system = scene.build()
F = ref["force"]
one = vd.forced_response_curve(system, ("mass", F), (0.5, 2.0), "mass", harmonics=1)
folds = sorted(one.folds, key=lambda f: f.omega)
for f, w, a in zip(folds, ref["fold_omega"], ref["fold_amplitude"]):
    print(f"fold (H = 1): Ω = {f.omega:.10f} rad/s ({f.frequency_hz:.8f} Hz), a = {f.amplitude:.9f} m; closed form "
          f"Ω = {w:.10f}, a = {a:.9f}")
    assert abs(f.omega - w) < 1e-8 and abs(f.amplitude - a) < 1e-8
print(f"peak (H = 1): a = {one.peak.amplitude:.10f} m at Ω = {one.peak.omega:.10f} rad/s; closed form "
      f"{ref['peak_amplitude']:.10f} m at {ref['peak_omega']:.10f} rad/s")
assert abs(one.peak.amplitude - ref["peak_amplitude"]) < 1e-8 and abs(one.peak.omega - ref["peak_omega"]) < 1e-8

# %%
# Converged in the harmonics
# --------------------------
# The cubic force x³ makes odd harmonics: the single-harmonic answer is itself an approximation, off by about
# its own truncation estimate (one Newton step of the 2H + 1 balance, a first-order estimate).
curve = vd.forced_response_curve(system, ("mass", F), (0.5, 2.0), "mass")
print(curve)
print(f"H = 1 → H = {curve.harmonics}: peak amplitude moved {curve.peak.amplitude - one.peak.amplitude:+.3e} m "
      f"(H = 1's estimate ± {one.peak.error:.1e}); upper fold moved {curve.folds[0].omega - folds[1].omega:+.3e} "
      f"rad/s (± {folds[1].omega_error:.1e})")
assert abs(curve.peak.amplitude - one.peak.amplitude) <= 2 * one.peak.error
assert curve.peak.error <= 1e-8 * curve.peak.amplitude

# %%
# An independent check: shooting on the time simulation
# -----------------------------------------------------
# The same scene with the force as a time law, F sin(Ωt + π/2): the periodic orbit through the balance's state at
# t = 0, converged by shooting on vibdyn's simulation, with its Floquet multipliers from the monodromy. On the
# upper (stable) and the middle (unstable) branch, at the same Ω between the folds.
for branch in ("stable", "unstable"):
    i = next(k for k in range(len(curve.omega)) if curve.stability[k] == branch and 1.09 < curve.omega[k] < 1.11
             and curve.amplitude[k] > 1.0)
    W = float(curve.omega[i])
    forced = scene.copy()
    forced.add_joint_force("mass", vd.laws.Harmonic(F, W, phase=math.pi / 2))
    coef = curve.coefficients[i][:, 0]  # constant, then cos kΩt, sin kΩt
    x0, v0 = coef[0] + coef[1::2].sum(), W * (np.arange(1, curve.harmonics + 1) * coef[2::2]).sum()
    orbit = vd.floquet(forced.build(), 2 * math.pi / W, [x0], [v0])
    dx = abs(orbit.q0[0] - x0)
    mu_hb, mu_sh = abs(curve.multipliers[i, 0]), abs(orbit.multipliers[0])
    print(f"Ω = {W:.8f} rad/s, {branch}: x(0) balance {x0:.10f} m, shooting {orbit.q0[0]:.10f} m "
          f"(|Δ| {dx:.1e} ≤ {curve.error[i] + orbit.error:.1e}); max |μ| Hill {mu_hb:.8f} ± "
          f"{curve.multiplier_error[i]:.0e}, monodromy {mu_sh:.8f} ± {orbit.multiplier_error[0]:.0e} "
          f"({orbit.stability})")
    assert dx <= curve.error[i] + orbit.error
    assert abs(mu_hb - mu_sh) <= curve.multiplier_error[i] + orbit.multiplier_error[0]
    assert (orbit.stability == "unstable") == (branch == "unstable")

# %%
# The curve
# ---------
# Stable solid, unstable dashed (between the folds, the middle branch), folds ×, the peak ▼; the closed form in
# grey.
fig = curve.plot()
ax = fig.axes[0]
a = np.linspace(0.02, 1.85, 600)
k, m, c, k3 = 1.0, 1.0, 0.05, 0.1
# the closed form solved for Ω at each amplitude: m²Ω⁴ − (2m(k + ¾k₃a²) − c²)Ω² + (k + ¾k₃a²)² − F²/a² = 0
s = k + 0.75 * k3 * a**2
disc = (2 * m * s - c * c) ** 2 - 4 * m * m * (s * s - (F / a) ** 2)
ok = disc >= 0
for sign in (-1, 1):
    W2 = (2 * m * s[ok] - c * c + sign * np.sqrt(disc[ok])) / (2 * m * m)
    ax.plot(np.sqrt(np.maximum(W2, 0)), a[ok], color="0.6", lw=0.8, zorder=0,
            label="closed form, H = 1" if sign < 0 else None)
ax.legend(loc="best", fontsize="small")
fig

# %%
# The motion at the peak
# ----------------------
# ``curve.orbit(i)`` rebuilds one period of the balance's motion; the viewer loops it.
peak = int(np.argmax(curve.amplitude))
motion = curve.orbit(peak)
print(motion)
vd.export_html(motion, "viewer_duffing_frc.html")
plt.show()
