"""
A first model in five minutes
=============================

A cart of 10 kg slides along x on a spring of 100 N/m; a uniform rod of 2 kg and 1 m hangs from a pivot on
the cart. Describe it, build it, find its equilibrium, linearise there and read its two modes: frequencies
in rad/s and Hz, with their error estimates, the pictures and the offline viewer page.

By hand (Lagrange, small motions about the hanging rest): with x the cart's travel and θ the rod's angle,
M = [[m_c + m_r, m_r a], [m_r a, J_O]] and K = diag(k, m_r g a), a = 0.5 m the pivot-to-centre distance and
J_O = m_r L²/3 the rod's inertia about the pivot.
"""

# %%
# Describe the scene
# ------------------
# Bodies hang from ``"world"`` through joints; springs join points of two bodies. SI units: m, kg, s, N.
import numpy as np
import scipy.linalg

import vibdyn as vd

scene = vd.Scene("trailer", gravity=(0, 0, -9.81))
scene.add_body("cart", joint=vd.Slider(axis=(1, 0, 0)), mass=10.0)
scene.add_body("rod", parent="cart", joint=vd.Pivot(axis=(0, 1, 0)), mass=2.0, com=(0, 0, -0.5),
               inertia=vd.inertia.rod(2.0, 1.0, axis=(0, 0, 1)),
               shape={"type": "capsule", "radius": 0.03, "length": 1.0})
scene.add_spring("k", ("world", (-1, 0, 0)), ("cart", (0, 0, 0)), stiffness=100.0, free_length=1.0)
system = scene.build()
print(system.coordinates, "nv =", system.nv)

# %%
# Equilibrium, linearisation, modes
# ---------------------------------
# The equilibrium is found by Newton's method in the tangent space; K and M come with an error estimate,
# and so does every natural frequency ω (rad/s).
eq = system.equilibrium()
lin = eq.linearize()
modes = lin.modes()
for w, f, e in zip(modes.omega, modes.frequency_hz, modes.omega_error):
    print(f"ω = {w:.6f} rad/s  (f = {f:.6f} Hz), error estimate {e:.1e} rad/s")
print(f"linearised in {lin.elapsed * 1e3:.2f} ms, modes in {modes.elapsed * 1e3:.2f} ms")

# %%
# Check against the hand calculation
# -----------------------------------
# The same two frequencies from the hand-derived M and K, within vibdyn's own error estimate.
m_c, m_r, a, L, k, g = 10.0, 2.0, 0.5, 1.0, 100.0, 9.81
M = np.array([[m_c + m_r, m_r * a], [m_r * a, m_r * L**2 / 3]])
K = np.diag([k, m_r * g * a])
omega_hand = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True))
print("by hand:", omega_hand)
assert np.all(np.abs(modes.omega - omega_hand) <= 10 * modes.omega_error + 1e-12)

# %%
# Pictures and the offline viewer
# -------------------------------
# ``modes.plot()`` draws each mode over the undeformed scene; ``vd.export_html`` writes one self-contained
# page that animates every mode (it opens from disk, no server).
fig = modes.plot()
vd.export_html(modes, "viewer_first_model.html")
