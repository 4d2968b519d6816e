"""
A double pendulum and its error estimates
=========================================

Rao, *Mechanical Vibrations*, §6.6 (reference case R3): two point masses m = 1 kg on massless links l = 1 m,
g = 9.81 m/s². About the hanging rest the small oscillations have ω = √((2 ∓ √2) g/l) = 2.397199 and
5.787351 rad/s, with shapes (θ₁, θ₂) ∝ (1, ±√2).

Every number vibdyn computes comes with an estimate of its error. This example puts each estimate beside the
actual error, where the exact answer is known (the closed form) or can be made (a run at far tighter
tolerances): the linearisation's K, the modes' ω, and a simulation's global error along a large swing.
"""

# %%
# The linearisation's error estimate
# ----------------------------------
# K is differenced in the tangent space with steps h and 2h: their difference estimates the truncation
# error, and round-off is added. In the joints' relative angles (θ₂ measured from link 1) the exact matrices
# are M = m l² [[5, 2], [2, 1]] and K = m g l [[3, 1], [1, 1]]; the analytic linearisation (Pinocchio's RNEA
# derivatives) is a second oracle, exact to round-off.
import math

import matplotlib.pyplot as plt
import numpy as np

import vibdyn as vd

scene = vd.load_scene("double_pendulum")
system = scene.build()
eq = system.equilibrium()
fd, exact = eq.linearize(method="fd"), eq.linearize(method="analytic")
print("K (finite differences):\n", fd.K)
print(f"actual |K_fd − K_analytic| ≤ {np.abs(fd.K - exact.K).max():.1e}, estimate K_error ≤ {fd.K_error.max():.1e} "
      f"(N·m/rad); M from CRBA: {fd.M.tolist()}")
K_exact = 9.81 * np.array([[3.0, 1.0], [1.0, 1.0]])
print(f"actual |K_fd − K_exact| ≤ {np.abs(fd.K - K_exact).max():.1e}")
assert np.all(np.abs(fd.K - exact.K) <= 10 * (fd.K_error + exact.K_error))
assert np.all(np.abs(fd.K - K_exact) <= 10 * fd.K_error + 1e-14 * np.abs(K_exact).max())

# %%
# The modes' error estimate
# -------------------------
# ``omega_relative_error`` is each ω's relative error estimate, from the eigen residual and K's error
# (``omega_error`` the same in rad/s).
modes = fd.modes()
omega_exact = np.sqrt((2 - np.array([1, -1]) * math.sqrt(2)) * 9.81 / 1.0)
print(" mode   ω vibdyn (rad/s)     ω exact (rad/s)    actual rel. error   estimate")
for r in range(2):
    actual = abs(modes.omega[r] - omega_exact[r]) / omega_exact[r]
    print(f"  {r + 1}   {modes.omega[r]:.13f}   {omega_exact[r]:.13f}   {actual:.1e}            "
          f"{modes.omega_relative_error[r]:.1e}")
    assert actual <= 10 * modes.omega_relative_error[r]
# The shapes: to first order a perturbation δK turns an eigenvector by about ‖δK‖ / (ω₂² − ω₁²) (M ~ 1 kg·m²).
ratio = modes.shapes[1] / modes.shapes[0]
ratio_exact = np.array([math.sqrt(2) - 1, -math.sqrt(2) - 1])
turn = fd.K_error.max() / (modes.omega2[1] - modes.omega2[0])
print(f"shapes θ₂/θ₁ (relative angles): {ratio}, exact √2 − 1 and −√2 − 1; largest relative gap "
      f"{np.abs(ratio / ratio_exact - 1).max():.1e}, first-order estimate {turn:.1e}")
assert np.all(np.abs(ratio / ratio_exact - 1) <= 10 * 2 * turn)

# %%
# A simulation's global error estimate against its actual error
# -------------------------------------------------------------
# A large swing (θ₁ = 1 rad, θ₂ = 0.5 rad from rest, 5 s: far from linear) with DOP853 at rtol 1e-7. Its
# global error estimate reruns the motion at the tolerances / 100. The actual error is measured against a
# third run at rtol 1e-13.
t = np.linspace(0.0, 5.0, 501)
q0 = system.configuration({"mass1": 1.0, "mass2": 0.5})
traj = system.simulate(5.0, q0, rtol=1e-7, t_eval=t)
ref = system.simulate(5.0, q0, rtol=1e-13, t_eval=t, error_method="local")  # (its own estimate not needed)
actual = np.abs(traj.q - ref.q).max(axis=1)
print(f"rtol 1e-7: {traj.accepted} steps in {traj.elapsed * 1e3:.0f} ms (+ {traj.error_elapsed * 1e3:.0f} ms for the "
      f"estimate); largest error estimate {traj.error:.2e} rad, actual {actual.max():.2e} rad "
      f"(ratio {actual.max() / traj.error:.2f}); energy balance {traj.drift_relative:.1e} relative")
assert actual.max() <= 3 * traj.error  # the estimate follows the actual error within a factor of a few

fig_err, ax = plt.subplots(figsize=(7, 4), layout="constrained")
ax.semilogy(t[1:], traj.q_error[1:], label="vibdyn's global error estimate (rerun at rtol/100)")
ax.semilogy(t[1:], actual[1:], "--", label="actual error (against rtol 1e-13)")
ax.set_xlabel("t (s)")
ax.set_ylabel("largest angle error (rad)")
ax.set_title("double pendulum, θ₁ = 1 rad, θ₂ = 0.5 rad, DOP853 rtol 1e-7")
ax.legend(fontsize="small")
ax.grid(True, which="both", alpha=0.3)

# %%
# The modes and the viewer
# ------------------------
fig_modes = modes.plot()
vd.export_html(modes, "viewer_double_pendulum.html")
