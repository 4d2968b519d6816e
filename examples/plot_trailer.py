"""
A trailer carrying a compound pendulum
======================================

A trailer of mass M = 10 kg slides along x, tied to a wall by a spring k = 100 N/m and a damper
c = 5 N·s/m. A uniform rod (m = 2 kg, L = 1 m) hangs from a pivot at the trailer's origin, held by a torsion
spring k_t = 50 N·m/rad with a small damper c_t = 0.1 N·m·s/rad. Gravity g = 9.81 m/s² along −z.

Small motions about the hanging rest, coordinates (x, θ), by Lagrange's equations (the worked problem of
the trailer with a compound pendulum: Rao, *Mechanical Vibrations*, ch. 6, multi-degree-of-freedom equations
of motion; numbers of ``models/trailer.toml``, its ``[reference]`` table):

* M = [[M + m, −m L/2], [−m L/2, m L²/3]] = [[12, −1], [−1, 2/3]] (kg, kg·m, kg·m²),
* K = diag(k, k_t + m g L/2) = diag(100, 59.81) (N/m, N·m/rad), C = diag(c, c_t),
* undamped natural frequencies, the roots of det(K − ω²M) = 0: ω = 2.868701 and 10.189494 rad/s.
"""

# %%
# The scene
# ---------
# The bundled scene file describes it (bodies, joints, springs, dampers); ``vd.load_scene`` reads it.
import numpy as np

import vibdyn as vd

scene = vd.load_scene("trailer")
book = scene.references
system = scene.build()
print(system.coordinates, "nv =", system.nv)

# %%
# Equilibrium and linear model
# ----------------------------
# The static equilibrium (Newton in the tangent space), then M (CRBA), K and C by central differences in the
# tangent space, each with its error estimate (``K_error``, ``C_error``: elementwise, absolute; M from CRBA is
# exact to round-off).
eq = system.equilibrium()
lin = eq.linearize()
print(f"equilibrium {eq.stability}, residual {eq.residual:.1e} N; "
      f"K's relative error estimate {lin.relative_error:.1e}, "
      f"linearised in {lin.elapsed * 1e3:.2f} ms")
for name, value, ref, err in [("M", lin.M, book["mass_matrix"], 1e-12),
                              ("K", lin.K, book["stiffness_matrix"], lin.K_error),
                              ("C", lin.C, book["damping_matrix"], lin.C_error)]:
    print(f"{name} = {np.array2string(value, precision=6)}   book {ref}")
    assert np.all(np.abs(value - np.array(ref)) <= 10 * err + 1e-12 * np.abs(ref).max()), name

# %%
# Modes beside the book's frequencies
# -----------------------------------
# Each ω carries its own error estimate ``omega_error`` (rad/s); the check allows ten times it (the margin
# the test suite uses), the book's values being exact to 16 digits.
modes = lin.modes()
print(" mode   ω vibdyn (rad/s)    f (Hz)      ω book (rad/s)     |Δω|      allowed")
for r, (w, f, e, ref) in enumerate(zip(modes.omega, modes.frequency_hz, modes.omega_error, book["omega"])):
    print(f"  {r + 1}   {w:.12f}   {f:.8f}   {ref:.12f}   {abs(w - ref):.1e}   {10 * e:.1e}")
    assert abs(w - ref) <= 10 * e, f"mode {r + 1}"

# %%
# With its dampers
# ----------------
# The state form gives the damped modes: natural frequency ``ω_n = |λ|``, damped frequency ``ω_d = |Im λ|`` and
# damping ratio ``ζ = −Re λ/|λ|``. Both dampers act on their own coordinate, so the damping is not classical.
for r in range(modes.n):
    print(f"mode {r + 1}: ω_n = {modes.omega_n[r]:.6f} rad/s, ω_d = {modes.omega_d[r]:.6f} rad/s "
          f"(f_d = {modes.damped_frequency_hz[r]:.6f} Hz), ζ = {modes.zeta[r]:.5f}")
print("classical damping:", modes.classical)

# %%
# Pictures and the offline viewer
# -------------------------------
# Each mode drawn over the hanging rest, and the self-contained viewer page animating both.
fig_modes = modes.plot()
vd.export_html(modes, "viewer_trailer.html")
