"""
Base excitation: the transmissibility
=====================================

The course's problem of a machine on a moving floor (the single-degree-of-freedom system under harmonic
motion of its base: Rao, *Mechanical Vibrations*, §3.6). A mass m = 2 kg slides vertically on a spring
k = 800 N/m and a damper c = 8 N·s/m whose lower ends move with the support as y(t) = Y sin ωt, Y = 1 cm,
ω = 15 rad/s. The support acts through them as k y + c ẏ. With ω_n = √(k/m) = 20 rad/s, ζ = c/(2√(km)) = 0.1
and r = ω/ω_n, the amplitude of the mass is X = T(r, ζ) Y with the displacement transmissibility

    T(r, ζ) = √((1 + (2ζr)²) / ((1 − r²)² + (2ζr)²)),

equal to 1 at r = √2 whatever the damping; above it the mass moves less than its support (isolation).
"""

# %%
# The scene: a support that moves
# --------------------------------
# ``add_support`` declares a frame of the world moving in time; springs and dampers attach to it.
import matplotlib.pyplot as plt
import numpy as np

import vibdyn as vd

m, k, c, Y, w = 2.0, 800.0, 8.0, 0.01, 15.0
scene = vd.Scene("machine_on_a_floor", gravity=(0, 0, -9.81))
scene.add_support("floor", vd.laws.HarmonicMotion((0, 0, Y), w))
scene.add_body("mass", joint=vd.Slider((0, 0, 1), at=(0, 0, 1.0)), mass=m)
scene.add_spring("k", ("floor", (0, 0, 0)), "mass", stiffness=k)
scene.add_damper("c", ("floor", (0, 0, 0)), "mass", damping=c)
system = scene.build()
omega_n, zeta = np.sqrt(k / m), c / (2 * np.sqrt(k * m))
print(f"ω_n = {omega_n:.6f} rad/s ({omega_n / (2 * np.pi):.6f} Hz), ζ = {zeta:.3f}")

# %%
# Transmissibility from the linear model
# --------------------------------------
# Linearised at its equilibrium (gravity sags the spring), ``base_response`` gives the absolute motion of the
# mass per unit motion of the support, with its error estimate (condition number × backward residual).
lin = system.equilibrium().linearize()
r = np.array([0.25, 0.75, 1.0, np.sqrt(2), 2.0, 4.0])
frf = lin.base_response(r * omega_n, "floor", direction=(0, 0, 1))
T = np.abs(frf.alpha[:, 0, 0])
T_book = vd.transmissibility(r, zeta)
print("    r      T vibdyn          T closed form      |Δ|")
for ri, a, b in zip(r, T, T_book):
    print(f"  {ri:5.3f}   {a:.14f}   {b:.14f}   {abs(a - b):.1e}")
print(f"error estimate of the response: {frf.relative_error:.1e} (relative)")
assert np.all(np.abs(T - T_book) <= 10 * frf.relative_error * T_book)
assert abs(T[3] - 1.0) <= 10 * frf.relative_error  # r = √2: T = 1 for any ζ

# %%
# The same from the nonlinear equations in time
# ---------------------------------------------
# Simulate 10 s from rest at the equilibrium with the floor moving (DOP853 with its global error estimate),
# then read the steady amplitude of the mass over the last 2 s by least squares on sin ωt and cos ωt. The
# free transient has decayed there by e^(−ζω_n·8 s) ≈ 1e-7 of its start (at most 2Y).
eq = system.equilibrium()
t = np.linspace(0.0, 10.0, 2001)
traj = system.simulate(10.0, eq.q, t_eval=t)
late = t >= 8.0
x = traj.q[late, 0] - eq.q[0]
basis = np.column_stack([np.sin(w * t[late]), np.cos(w * t[late]), np.ones(late.sum())])
coef = np.linalg.lstsq(basis, x, rcond=None)[0]
X = np.hypot(coef[0], coef[1])
X_book = vd.transmissibility(w / omega_n, zeta) * Y
tol = 10 * traj.error + 2 * Y * np.exp(-zeta * omega_n * 8.0)
print(f"steady amplitude at ω = {w} rad/s: simulated {X * 1e3:.9f} mm, T·Y {X_book * 1e3:.9f} mm "
      f"(|Δ| {abs(X - X_book):.1e} m ≤ {tol:.1e} m: the run's error estimate {traj.error:.1e} m + the transient)")
print(f"simulated in {traj.elapsed:.2f} s (+ {traj.error_elapsed:.2f} s for its error estimate)")
assert abs(X - X_book) <= tol

# %%
# Pictures
# --------
# Left: the transmissibility for several damping ratios (closed form), the curves all passing through 1 at
# r = √2, with vibdyn's points for ζ = 0.1. Right: the mass following the floor at r = 0.75 (amplified).
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
rr = np.linspace(0.01, 4.0, 400)
for z in (0.05, 0.1, 0.2, 0.5, 1.0):
    left.semilogy(rr, vd.transmissibility(rr, z), label=f"ζ = {z}")
left.semilogy(r, T, "ko", mfc="none", label="vibdyn, ζ = 0.1")
left.axvline(np.sqrt(2), color="0.6", lw=0.8, ls="--")
left.set_xlabel("r = ω/ω_n")
left.set_ylabel("T = X/Y")
left.legend(fontsize="small")
left.grid(True, which="both", alpha=0.3)
right.plot(t, Y * np.sin(w * t) * 1e3, color="0.6", label="floor y(t)")
right.plot(t, (traj.q[:, 0] - eq.q[0]) * 1e3, label="mass x(t)")
right.set_xlabel("t (s)")
right.set_ylabel("displacement (mm)")
right.legend(fontsize="small")
right.set_title(f"r = {w / omega_n:.2f}: X/Y → T = {X_book / Y:.4f}")
