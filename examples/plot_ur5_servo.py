"""
A UR5 arm on its position servos
================================

A robot held by its drives under gravity has only gravity's stiffness: most of its modes come out rigid. Its
vibration modes are those of the arm on its servos, each joint a torsion spring k (N·m/rad) about the held
posture with a damper c (N·m·s/rad). Here the UR5 of example-robot-data (its URDF's masses and inertias), at
its SRDF posture, with k = 1000 N·m/rad and c = 10 N·m·s/rad on each of its six joints.

No textbook tabulates this arm; the checks are physical ones that cannot pass by accident:

* the servos add exactly k·I to the stiffness gravity gives the held arm;
* as k grows the frequencies tend to ω² = k · eig(M⁻¹) (gravity's share fades as 1/k);
* the nonlinear motion released along mode 1 (servos, no damper, gravity balanced by the drives' feed-forward)
  swings at ω₁: its half periods, located as zero crossings of the modal velocity, give ω₁ again.
"""

# %%
# The arm on its servos
# ---------------------
import matplotlib.pyplot as plt
import numpy as np
import scipy.linalg

import vibdyn as vd

k, c = 1000.0, 10.0
robot = vd.load_robot("ur5", servo=(k, c)).build()
held = robot.operating_point()  # held by the drives at the SRDF posture
lin = held.linearize()
modes = lin.modes()
print("coordinates:", robot.coordinates)
print("drive torques holding the posture (N·m):", {j: round(t, 6) for j, t in held.drive.items()})
print(" mode   ω_n (rad/s)     f_n (Hz)     ω_d (rad/s)      ζ        λ error estimate (1/s)")
for r in range(modes.omega_n.size):
    print(f"  {r + 1}   {modes.omega_n[r]:12.6f}  {modes.omega_n[r] / (2 * np.pi):10.6f}  {modes.omega_d[r]:12.6f}  "
          f"{modes.zeta[r]:8.5f}   {modes.eigenvalue_error[r]:.1e}")

# %%
# The servos add k·I to gravity's stiffness
# -----------------------------------------
# The same arm held without servos: its K is gravity's alone (none about the vertical pan axis nor, at this
# posture, about the wrists).
bare = vd.load_robot("ur5").build()
lin_bare = bare.operating_point().linearize()
gap = np.abs(lin.K - lin_bare.K - k * np.eye(6))
print(f"gravity's stiffness diag: {np.round(np.diag(lin_bare.K), 6)} N·m/rad; "
      f"|K_servo − K_gravity − k I| ≤ {gap.max():.1e} "
      f"(estimates {lin.K_error.max():.1e} + {lin_bare.K_error.max():.1e})")
assert np.all(gap <= 10 * (lin.K_error + lin_bare.K_error))
assert np.allclose(lin.C, c * np.eye(6), rtol=0, atol=10 * lin.C_error.max() + 1e-12 * c)

# %%
# Stiffer servos: ω² → k · eig(M⁻¹)
# ---------------------------------
# The undamped modes for servos from 1e2 to 1e6 N·m/rad. ω²/k approaches the eigenvalues of M⁻¹, the gap
# shrinking like ‖K_gravity‖/k.
stiffnesses = np.geomspace(1e2, 1e6, 9)
omegas = np.array([vd.load_robot("ur5", servo=(kk, 0.0)).build().operating_point().linearize().modes().omega
                   for kk in stiffnesses])
limit = np.sort(1.0 / scipy.linalg.eigvalsh(lin.M))  # eig(M⁻¹), ascending
scale = np.abs(lin_bare.K).max()
for kk, w in zip(stiffnesses[[0, 4, 8]], omegas[[0, 4, 8]]):
    print(f"k = {kk:8.0e} N·m/rad: ω²/k = {np.round(np.sort(w**2 / kk), 5)}")
print(f"eig(M⁻¹)             = {np.round(limit, 5)}  (1/(kg·m²))")
rel = np.abs(np.sort(omegas[-1] ** 2 / stiffnesses[-1]) - limit) / limit
print(f"at k = 1e6: largest relative gap {rel.max():.1e}, gravity's share |K_g|/k = {scale / stiffnesses[-1]:.1e}")
assert rel.max() <= 10 * scale / stiffnesses[-1] * np.linalg.cond(lin.M)

fig_k, ax = plt.subplots(figsize=(7, 4), layout="constrained")
ax.loglog(stiffnesses, omegas / (2 * np.pi), "o-")
ax.set_xlabel("servo stiffness k (N·m/rad)")
ax.set_ylabel("undamped natural frequency f (Hz)")
ax.set_title("UR5 on position servos: each mode's frequency against k")
ax.grid(True, which="both", alpha=0.3)

# %%
# The nonlinear motion swings at ω₁
# ---------------------------------
# Servos without dampers, the held posture's drive torques applied as constant joint torques (gravity's
# feed-forward), released from rest 1e-3 rad along mode 1. The modal velocity φ₁ᵀM v crosses zero every half
# period: events located on DOP853's interpolant.
scene = vd.load_robot("ur5", servo=(k, 0.0))
for joint, torque in held.drive.items():
    scene.add_joint_force(joint, float(torque))
free = scene.build()
lin0 = free.linearize(held.q)
mode1 = lin0.modes()
phi, M0 = mode1.shapes[:, 0], lin0.M


def modal_velocity(t, q, v):
    return phi @ M0 @ v


q_start = free.integrate(held.q, 1e-3 * phi / np.abs(phi).max())
traj = free.simulate(1.0, q_start, rtol=1e-10, events=[modal_velocity])
half = np.diff(np.r_[0.0, traj.t_events[0]])
omega_sim = np.pi / half.mean()
print(f"ω₁ from the motion {omega_sim:.9f} rad/s (half periods {np.round(half, 9)} s), from the modes "
      f"{mode1.omega[0]:.9f} rad/s; relative gap {abs(omega_sim / mode1.omega[0] - 1):.1e} "
      f"(amplitude effects ~ (1e-3 rad)² and the run's error {traj.error:.1e} rad)")
assert abs(omega_sim / mode1.omega[0] - 1) <= 1e-5

# %%
# The pictures and the viewer
# ---------------------------
# The pictures: the undamped modes on the servos (real shapes, easier to read than the damped ones' two
# phases). The viewer page animates the damped modes with the URDF's meshes (it is large: they are inlined).
fig_modes = mode1.plot()
vd.export_html(modes, "viewer_ur5_servo.html")
