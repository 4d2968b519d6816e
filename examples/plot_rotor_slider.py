"""
A rotor carrying a sprung slider
================================

Tătaru, *elastic movements superposed on the motion of the rigid body* (reference case R6). A rotor on a pivot
about the vertical z axis (J = 0.1 kg·m² about z) is driven by the motor law τ = 10 − ω² (N·m, ω in rad/s). It
carries a slider (m = 1 kg, J_z = 0.001 kg·m²) on a radial slide through the axis; a spring (k = 100 N/m, free
length 0.5 m) joins the axis point to the slider, with a damper c = 2 N·s/m on the sliding speed.

The book's answers: the steady regime Ω* = √10 = 3.1622777 rad/s, the slider at rest relative to the rotor at
s* = k l₀/(k − mΩ*²) = 0.5555556 m. Linearised about that steady rotation, in (rotor angle, slider travel):

* M = diag(0.4096420, 1), C = [[6.324555, 3.513642], [−3.513642, 2]] (motor damping 2Ω*, gyroscopic
  2 m s* Ω*), K = diag(0, 90);
* state eigenvalues 0, −13.7940275 and −1.8225996 ± 9.8697688i (1/s).

From rest at s = 0.5 m the nonlinear motion converges to (Ω*, s*).
"""

# %%
# The steady motion
# -----------------
# The scene file declares the rotor's speed free: ``operating_point`` searches the speed at which the motor's
# torque balances and the slider's relative rest together.
import matplotlib.pyplot as plt
import numpy as np

import vibdyn as vd

scene = vd.load_scene("rotor_slider")
book = scene.references
system = scene.build()
st = system.operating_point()
Omega, s_rel = st.speeds["rotor"], st.coordinate("slider")
i = system.coordinate_index("slider")
print(f"steady motion ({st.stability}): Ω* = {Omega:.10f} rad/s, book {book['omega_star']:.10f}; "
      f"s* = {0.5 + s_rel:.10f} m (error estimate {st.q_error[i]:.1e}), book {book['s_star']:.10f}")
assert abs(s_rel - book["s_rel_star"]) <= 10 * st.q_error[i] + 1e-15
assert abs(Omega - book["omega_star"]) <= 1e-9 * Omega  # (the speed solves 10 − Ω² = 0: to the search's tolerance)

# %%
# The linear model about the steady rotation
# ------------------------------------------
# With v₀ ≠ 0 the velocity derivatives give C: the motor's damping −∂τ/∂ω = 2Ω* and the gyroscopic coupling
# ±2 m s* Ω*; K holds the spring softened by the centrifugal term, k − mΩ*².
lin = st.linearize()
# The steady speed carries the search's residual torque: δΩ = residual / (∂τ/∂ω) = residual / 2Ω*, which moves
# C by 2δΩ (motor) and 2 m s* δΩ (gyroscopic), and K by 2 m Ω* δΩ: the check allows ten times the
# linearisation's own estimate plus that.
m, s_star = 1.0, 0.5 + s_rel
dOmega = st.residual / (2 * Omega)
shift = {"M": 0.0, "C": np.array([[2, 2 * m * s_star], [2 * m * s_star, 0]]) * dOmega,
         "K": np.array([[0, 0], [0, 2 * m * Omega]]) * dOmega}
print(f"steady speed's error δΩ ≈ {dOmega:.1e} rad/s")
for name, value, ref, err in [("M", lin.M, book["mass_matrix"], 1e-12 * np.abs(lin.M).max()),
                              ("C", lin.C, book["damping_matrix"], lin.C_error),
                              ("K", lin.K, book["stiffness_matrix"], lin.K_error)]:
    diff = np.abs(value - np.array(ref))
    print(f"{name} = {np.array2string(value, precision=7)}\n    book {np.array2string(np.array(ref), precision=7)}"
          f"   largest |Δ| {diff.max():.1e}")
    assert np.all(diff <= 10 * (err + shift[name]) + 1e-12 * np.abs(ref).max()), name

# %%
# Its state eigenvalues
# ---------------------
# Each carries an error estimate ``eigenvalue_error`` (1/s); the zero is the rotor angle's (cyclic).
modes = lin.modes()
lam = np.sort_complex(modes.eigenvalues)
lam_book = np.sort_complex(np.array([complex(*z) for z in book["eigenvalues"]]))
tol = 10 * modes.relative_error * np.abs(lam_book) + 10 * modes.zero_threshold * (lam_book == 0)
for a, b, t in zip(lam, lam_book, tol):
    print(f"λ vibdyn {a.real:+.10f} {a.imag:+.10f}i   book {b.real:+.10f} {b.imag:+.10f}i   "
          f"|Δ| {abs(a - b):.1e} ≤ {t:.1e}")
assert np.all(np.abs(lam - lam_book) <= tol)
k = int(np.argmax(modes.omega_d))
print(f"the slider's mode: ω_n = {modes.omega_n[k]:.6f} rad/s, ω_d = {modes.omega_d[k]:.6f} rad/s "
      f"(f_d = {modes.damped_frequency_hz[k]:.6f} Hz), ζ = {modes.zeta[k]:.6f}; stability: {st.stability}")

# %%
# The nonlinear motion from rest
# ------------------------------
# From rest with the slider at s = 0.5 m (its neutral position), 8 s of the full equations: the speed climbs to
# Ω* while the slider, flung outwards, settles at s* in a damped oscillation at ω_d.
t = np.linspace(0.0, 8.0, 801)
traj = system.simulate(8.0, system.neutral(), np.zeros(system.nv), t_eval=t)
print(f"at 8 s: Ω = {traj.v[-1, 0]:.8f} rad/s, s = {0.5 + traj.q[-1, i]:.8f} m "
      f"(error estimate {traj.error:.1e}; simulated in {traj.elapsed:.2f} s)")
# (what is left is the decaying transient, not an error)
assert abs(traj.v[-1, 0] - book["omega_star"]) < 1e-6 and abs(traj.q[-1, i] - book["s_rel_star"]) < 1e-6

fig_motion, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 5), layout="constrained")
top.plot(t, traj.v[:, 0])
top.axhline(book["omega_star"], color="0.5", ls="--", lw=0.8, label="Ω* = √10 rad/s")
top.set_ylabel("rotor speed (rad/s)")
top.legend()
bottom.plot(t, 0.5 + traj.q[:, i])
bottom.axhline(book["s_star"], color="0.5", ls="--", lw=0.8, label="s* = 0.5556 m")
bottom.set_ylabel("slider s (m)")
bottom.set_xlabel("t (s)")
bottom.legend()

# %%
# Pictures and the viewer
# -----------------------
# The damped modes animate their complex shapes about the steady rotation.
fig_modes = modes.plot()
vd.export_html(modes, "viewer_rotor_slider.html")
