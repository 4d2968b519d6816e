"""
A three-storey shear building
=============================

The textbook model of a building shaken by its ground (Rao, *Mechanical Vibrations*, ch. 6: multistorey
frames as spring–mass chains; Chopra, *Dynamics of Structures*, ch. 9–13 for participation and effective
modal masses). Floors of m = 2000, 1500 and 1000 kg at heights 3, 6 and 9 m drift sideways; the storeys' lateral
stiffnesses are k = 6e5, 4e5 and 2e5 N/m. In the floors' drifts,

    M = diag(2000, 1500, 1000) kg,  K = [[1e6, −4e5, 0], [−4e5, 6e5, −2e5], [0, −2e5, 2e5]] N/m,

and the natural frequencies, the roots of det(K − ω²M) = 0, are ω = 8.38408883, 17.92539591 and
26.61554501 rad/s (``models/three_storey_building.toml``). The effective modal masses for a ground motion
along x sum to the floors' 4500 kg; for a rocking of the base about y, to Σ m h² = 153000 kg·m².

vibdyn builds it as three bodies on sliders joined by point springs, not from M and K.
"""

# %%
# The scene and its modes
# -----------------------
import matplotlib.pyplot as plt
import numpy as np
import scipy.linalg

import vibdyn as vd

scene = vd.load_scene("three_storey_building")
system = scene.build()
# analytic linearisation (RNEA derivatives + the springs' own): the storeys' 10 m springs make the finite
# differences' round-off ε·L/h in each elongation, which their error estimate does not see
modes = system.operating_point().linearize(method="analytic").modes()
m, h = np.array([2000.0, 1500.0, 1000.0]), np.array([3.0, 6.0, 9.0])
K_book = np.array([[1e6, -4e5, 0.0], [-4e5, 6e5, -2e5], [0.0, -2e5, 2e5]])
w2_book, Phi_book = scipy.linalg.eigh(K_book, np.diag(m))
omega_book = np.sqrt(w2_book)
print(" mode   ω vibdyn (rad/s)    f (Hz)       ω book (rad/s)     |Δω|     allowed")
for r in range(modes.n):
    w, e, ref = modes.omega[r], modes.omega_error[r], omega_book[r]
    print(f"  {r + 1}   {w:.12f}   {modes.frequency_hz[r]:.8f}   {ref:.12f}   {abs(w - ref):.1e}   {10 * e:.1e}")
    assert abs(w - ref) <= 10 * e + 1e-13 * ref  # (estimate, or a few ε where it is that small)
    assert abs(ref - scene.references["omega"][r]) <= 5e-9  # the file's values, printed to 1e-8

# %%
# Shapes as floor drifts, participation and effective masses
# ----------------------------------------------------------
# ``point_shapes`` maps the joint-coordinate shapes to the floors' displacements along x (m per unit modal
# coordinate); ``effective_mass`` gives (φᵀL)²/φᵀMφ for a unit ground acceleration along x.
floors = ["floor1", "floor2", "floor3"]
drift = modes.point_shapes(floors, direction=(1, 0, 0))
eff = modes.effective_mass((1, 0, 0))
rocking = modes.effective_mass((0, 1, 0), rotation=True)
gamma_book = Phi_book.T @ m
for r in range(modes.n):
    mac = vd.mac(drift[:, r], Phi_book[:, r])
    print(f"mode {r + 1}: drifts {np.round(drift[:, r] / drift[-1, r], 6)} (roof = 1), MAC with the book's {mac:.12f}; "
          f"Γ = {modes.participation((1, 0, 0))[r]:+.6f} √kg; effective mass {eff[r]:9.3f} kg "
          f"({100 * eff[r] / m.sum():5.2f} %), book {gamma_book[r] ** 2:9.3f} kg")
    assert abs(mac - 1.0) <= 1e-9
print(f"Σ effective masses {eff.sum():.9f} kg (the floors: {m.sum()} kg); rocking {rocking.sum():.6f} kg·m² "
      f"(Σ m h² = {np.sum(m * h**2)} kg·m²)")
assert abs(eff.sum() - m.sum()) <= 1e-9 * m.sum()
assert np.allclose(eff, gamma_book**2, rtol=10 * modes.relative_error + 1e-9)
assert abs(rocking.sum() - np.sum(m * h**2)) <= 1e-9 * np.sum(m * h**2)

# %%
# Pictures and the viewer
# -----------------------
# The drifts of each mode up the building, then vibdyn's pictures of the modes and the viewer page.
fig_drifts, axes = plt.subplots(1, modes.n, figsize=(9, 4), sharey=True, layout="constrained")
for r, ax in enumerate(axes):
    ax.plot(np.r_[0.0, drift[:, r] / np.abs(drift[:, r]).max()], np.r_[0.0, h], "o-")
    ax.axvline(0.0, color="0.6", lw=0.8)
    ax.set_title(f"mode {r + 1}: ω = {modes.omega[r]:.4f} rad/s\n({modes.frequency_hz[r]:.4f} Hz), "
                 f"{100 * eff[r] / m.sum():.1f} % of the mass", fontsize="small")
    ax.set_xlabel("drift (normalised)")
axes[0].set_ylabel("height (m)")
fig_modes = modes.plot()
vd.export_html(modes, "viewer_three_storey_building.html")
