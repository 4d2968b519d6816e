"""
The trammel: a closed loop
==========================

Vénizélos, *Vibrations des systèmes mécaniques*, Ex. 2.4.1 (reference case R9). A plane problem, y vertical
upwards, gravity −y. A homogeneous disk (centre G, radius R = 0.1 m, mass M = 2 kg) is welded to massless rods;
A, G, B are aligned with AB = 2ℓ = 1 m, G the midpoint. Axis A (a point mass m = 0.5 kg) slides without
friction along x, axis B (m = 0.5 kg) along y. A spring O–A, free length 2ℓ₀ = 0.6 m, stiffness k. With γ the
angle of AB from the y axis, OA = 2ℓ sin γ, OB = 2ℓ cos γ, and

    [C + (M + 2m)ℓ²] γ̈ = (M + 2m) g ℓ sin γ − 4kℓ(ℓ sin γ − ℓ₀) cos γ,  C = I(G, z) = MR²/2 + 2mℓ².

The book's answers: γₑ = π/4 is an equilibrium for k = 137.386259 N/m; there ω = 6.885411 rad/s; the groove
reactions are X = 2k(ℓ√2/2 − ℓ₀) = 14.715 N on B and Y = (M + 2m) g = 29.43 N on A.

vibdyn solves it from the three-dimensional multibody model: A on a slider, the disk on a pivot on A, B on a
slider, and a ball loop joining the disk's end to B (``models/trammel.toml``).
"""

# %%
# The scene: a tree closed by a loop
# ----------------------------------
import math

import numpy as np
from scipy.optimize import brentq

import vibdyn as vd

scene = vd.load_scene("trammel")
book = scene.references
system = scene.build()
print(system.coordinates, "tree coordinates; mobility", system.dof)

# %%
# Equilibrium and groove reactions
# --------------------------------
# The equilibrium is searched on the loop (Newton on the reduced force, each iterate re-assembled). The
# coordinate ``disk`` is the book's γ. The file's k is the book's, rounded to 1e-6 N/m, which moves the
# equilibrium 2.8e-10 rad off π/4: γ is compared with the book's balance solved at that k, within the
# search's own error estimate ``q_error``.
eq = system.equilibrium()
i = system.coordinate_index("disk")
gamma, gamma_err = eq.coordinate("disk"), eq.q_error[i]
M, m, ell, ell0, R, g, k = 2.0, 0.5, 0.5, 0.3, 0.1, 9.81, 137.386259
balance = brentq(lambda c: (M + 2 * m) * g * ell * math.sin(c)
                 - 4 * k * ell * (ell * math.sin(c) - ell0) * math.cos(c), 0.6, 1.0, xtol=1e-16)
print(f"γ vibdyn {gamma:.13f} rad (error estimate {gamma_err:.1e}); book's balance {balance:.13f} "
      f"(|Δ| {abs(gamma - balance):.1e}); π/4 = {math.pi / 4:.13f}")
assert abs(gamma - balance) <= 10 * gamma_err + 1e-15
assert abs(gamma - book["gamma"]) <= 1e-9  # the book's π/4, with its k rounded to 1e-6 N/m

# The reactions of the grooves: what each slider's link transmits across its axis (world axes, N).
reactions = eq.reactions()
X = reactions["B"][0][0]  # the y groove pushes B along x
Y = reactions["A"][0][1]  # the x groove carries the weight at A
print(f"X on B: vibdyn {X:.6f} N, book {book['X']} N;  Y on A: vibdyn {Y:.6f} N, book {book['Y']} N")
assert abs(X - book["X"]) <= 5e-4 and abs(Y - book["Y"]) <= 5e-4  # the book prints them to 1e-3 N

# %%
# The frequency
# -------------
# Linearised on the loop (M_r = NᵀMN, K_r with the constraint forces' curvature), one independent motion.
# The book prints ω to 1e-6 rad/s: the check allows its rounding plus ten times vibdyn's estimate.
lin = eq.linearize()
modes = lin.modes()
w, e = modes.omega[0], modes.omega_error[0]
# the book's equation linearised at γ: [C + (M + 2m)ℓ²] δγ̈ + K δγ = 0
inertia = M * R**2 / 2 + 2 * m * ell**2 + (M + 2 * m) * ell**2
stiffness = (-(M + 2 * m) * g * ell * math.cos(gamma)
             + 4 * k * ell * (ell * math.cos(gamma) ** 2 - (ell * math.sin(gamma) - ell0) * math.sin(gamma)))
hand = math.sqrt(stiffness / inertia)
print(f"ω vibdyn {w:.10f} rad/s ({w / (2 * np.pi):.10f} Hz), error estimate {e:.1e}; book {book['omega'][0]}; "
      f"the book's equation linearised: {hand:.10f} (|Δ| {abs(w - hand):.1e})")
assert abs(w - book["omega"][0]) <= 10 * e + 5e-7
assert abs(w - hand) <= 10 * e + 1e-12 * w

# %%
# The mode and the viewer
# -----------------------
# The shape is in the tree's coordinates (A, disk, B) and keeps the loop closed: Φ_q φ = 0.
print("shape (A m, γ rad, B m):", modes.shapes[:, 0], " Φ_q φ =", system.constraint_jacobian(eq.q) @ modes.shapes[:, 0])
fig_mode = modes.plot()
vd.export_html(modes, "viewer_trammel.html")
