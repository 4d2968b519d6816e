"""
A quarter car: modes, damping, transmissibility
===============================================

The classic two-degree-of-freedom quarter-car model (Rao, *Mechanical Vibrations*, ch. 6; Gillespie,
*Fundamentals of Vehicle Dynamics*, ch. 5): a quarter of the body, m_s = 250 kg, on a suspension spring
k_s = 16 kN/m and a shock absorber c_s = 1000 N·s/m; the wheel, m_u = 35 kg, on its tyre k_t = 160 kN/m; the
road a moving support under the tyre. In the vertical displacements (z_u, z_s),

    M = diag(m_u, m_s),  K = [[k_s + k_t, −k_s], [−k_s, k_s]],  C = [[c_s, −c_s], [−c_s, c_s]],

the undamped frequencies are the roots of (k_s − m_s ω²)(k_s + k_t − m_u ω²) = k_s²: ω = 7.623240 rad/s (the
body's bounce, 1.2133 Hz) and 70.953912 rad/s (the wheel hop, 11.293 Hz). The road moves the tyre's lower end:
the input k_t y on the wheel, and the body's transmissibility T(ω) = ‖z_s/y‖ → 1 as ω → 0.
"""

# %%
# Modes without and with the damper
# ---------------------------------
import matplotlib.pyplot as plt
import numpy as np
import scipy.linalg

import vibdyn as vd

scene = vd.load_scene("quarter_car")
system = scene.build()
lin = system.operating_point().linearize()  # gravity sags the springs to the operating point first
modes = lin.modes()
ms, mu, ks, kt, cs = 250.0, 35.0, 16000.0, 160000.0, 1000.0
a, b, c = ms * mu, -(ms * (ks + kt) + mu * ks), ks * kt  # the frequency equation as a quadratic in ω²
omega_book = np.sqrt(np.sort(np.roots([a, b, c])))
print(" mode   ω vibdyn (rad/s)   f (Hz)     ω by hand (rad/s)   file's book value   |Δω|     allowed")
for r in range(2):
    w, e = modes.omega[r], 10 * modes.omega_error[r]
    ref = scene.references["omega"][r]
    print(f"  {r + 1}   {w:.10f}   {modes.frequency_hz[r]:.6f}   {omega_book[r]:.10f}      {ref}"
          f"        {abs(w - omega_book[r]):.1e}   {e:.1e}")
    assert abs(w - omega_book[r]) <= e and abs(w - ref) <= e + 5e-7  # (the file prints 6 decimals)

# %%
# The damped modes: the state form. The shock absorber acts across the suspension only, so the damping is not
# classical; ζ, ω_n and ω_d come from the state eigenvalues, each with its error estimate. By hand: the
# eigenvalues of [[0, I], [−M⁻¹K, −M⁻¹C]].
M = np.diag([mu, ms])
K = np.array([[ks + kt, -ks], [-ks, ks]])
C = np.array([[cs, -cs], [-cs, cs]])
A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
lam_hand = np.sort_complex(scipy.linalg.eigvals(A))
lam_hand = lam_hand[lam_hand.imag > 0]  # one of each pair, ascending |λ|
lam_hand = lam_hand[np.argsort(np.abs(lam_hand))]
for r in range(2):
    lam = modes.damped_eigenvalues[r]
    tol = 10 * modes.eigenvalue_error[r]
    print(f"mode {r + 1}: λ = {lam.real:.8f} {lam.imag:+.8f}i (by hand {lam_hand[r].real:.8f} "
          f"{lam_hand[r].imag:+.8f}i, |Δ| {abs(lam - lam_hand[r]):.1e} ≤ {tol:.1e}); ω_n = {modes.omega_n[r]:.6f} "
          f"rad/s, ω_d = {modes.omega_d[r]:.6f} rad/s ({modes.damped_frequency_hz[r]:.6f} Hz), ζ = {modes.zeta[r]:.6f}")
    assert abs(lam - lam_hand[r]) <= tol
print("classical damping:", modes.classical)

# %%
# Transmissibility from the road
# ------------------------------
# ``base_response`` gives the body's and the wheel's motion per unit road motion (m/m); by hand:
# (K − ω²M + iωC) Z = [k_t, 0] y.
omega = np.geomspace(1.0, 300.0, 600)
frf = lin.base_response(omega, "road", direction=(0, 0, 1), outputs=["body", "wheel"])
hand = np.array([np.linalg.solve(K - w**2 * M + 1j * w * C, [kt, 0.0]) for w in omega])
T_body, T_wheel = frf.alpha[:, 0, 0], frf.alpha[:, 1, 0]
gap = max(np.abs(T_body - hand[:, 1]).max(), np.abs(T_wheel - hand[:, 0]).max())
print(f"largest |Δ| against the hand solution {gap:.1e} (error estimate {frf.relative_error:.1e} × |T|); "
      f"T_body(1 rad/s) = {abs(T_body[0]):.6f}, peak {np.abs(T_body).max():.4f} at "
      f"{omega[np.argmax(np.abs(T_body))]:.3f} rad/s")
assert np.all(np.abs(T_body - hand[:, 1]) <= 10 * frf.relative_error * np.abs(hand[:, 1]) + 1e-15)
assert np.all(np.abs(T_wheel - hand[:, 0]) <= 10 * frf.relative_error * np.abs(hand[:, 0]) + 1e-15)

fig_t, ax = plt.subplots(figsize=(7, 4), layout="constrained")
ax.loglog(omega, np.abs(T_body), label="body / road")
ax.loglog(omega, np.abs(T_wheel), label="wheel / road")
for w in modes.omega:
    ax.axvline(w, color="0.6", lw=0.8, ls="--")
ax.set_xlabel("ω (rad/s)")
ax.set_ylabel("transmissibility (m/m)")
ax.set_title("quarter car: road to body and wheel (dashed: undamped ω)")
ax.grid(True, which="both", alpha=0.3)
ax.legend()

# %%
# The pictures and the viewer
# ---------------------------
# Bounce (body and wheel in phase) and wheel hop, each with its damping.
fig_modes = modes.plot()
vd.export_html(modes, "viewer_quarter_car.html")
