"""
A four-bar linkage, described the natural way
=============================================

A planar four-bar: a crank OB (a = 0.1 m, 1 kg), a coupler BC (b = 0.3 m, 0.5 kg) and a rocker DC (c = 0.25 m,
0.8 kg), all slender rods, on ground pivots O (0, 0) and D (d = 0.3 m, 0); a torsion spring of 2 N·m/rad holds the
crank about 1 rad; gravity −y. What is its equilibrium, and at what frequency does it swing about it?

The textbook way to answer (a one-degree-of-freedom system in the crank angle θ): the position analysis in
closed form gives each link's centre and angle as functions of θ, then the potential V(θ) (gravity and the
spring) and the generalized mass m(θ) = Σ m_i ‖dG_i/dθ‖² + J_i (dφ_i/dθ)²; the equilibrium is V'(θₑ) = 0 and
ω² = V''(θₑ) / m(θₑ).

vibdyn is given the mechanism as one would draw it: three bodies joined by pivots, link lengths, and one loop
closure at C; it finds the rest.
"""

# %%
# The description: bodies, pivots, lengths, a loop
# ------------------------------------------------
# The tree is O–crank–coupler and D–rocker; each body's frame sits at its pivot with the link along its x
# axis, so every joint angle is zero when the links lie along x. The loop joins the coupler's end to the
# rocker's end by a pivot about z.
import math

import matplotlib.pyplot as plt
import numpy as np
from scipy.optimize import brentq

import vibdyn as vd

a, b, c, d = 0.1, 0.3, 0.25, 0.3  # crank, coupler, rocker, ground (m)
masses = {"crank": 1.0, "coupler": 0.5, "rocker": 0.8}  # kg
g, k_t, theta_rest = 9.81, 2.0, 1.0  # m/s², N·m/rad, rad


def rod(name, length, parent="world", at=(0.0, 0.0, 0.0)):
    scene.add_body(name, parent=parent, joint=vd.Pivot(axis=(0, 0, 1), at=at), mass=masses[name],
                   com=(length / 2, 0, 0), inertia=vd.inertia.rod(masses[name], length, axis=(1, 0, 0)),
                   shape={"type": "capsule", "radius": 0.008, "length": length, "axis": (1, 0, 0)})


scene = vd.Scene("four_bar", gravity=(0, -g, 0))
rod("crank", a)
rod("coupler", b, parent="crank", at=(a, 0, 0))
rod("rocker", c, at=(d, 0, 0))
scene.add_joint_spring("crank", k_t, rest=theta_rest)
scene.add_loop("C", ("coupler", (b, 0, 0)), ("rocker", (c, 0, 0)), joint=vd.Pivot(axis=(0, 0, 1)))


# %%
# Assembled from the drawing
# --------------------------
# No start is given: the loop is open as drawn (every angle zero), and vibdyn assembles the mechanism at the
# closure nearest that pose (least squares, restarts where the flat drawing leaves it stuck, the nearest
# closure kept; as near below the ground line as above, it takes the larger crank angle and says so).
system = scene.build()
assembly = system.constraints.assembly()
print(assembly)
print(assembly.note)
print("coordinates", system.coordinates, "| loop equations", system.constraint_jacobian(assembly.q).shape[0],
      "| mobility", system.dof)


# %%
# The closed-form position analysis checks it: with the crank at θ, C is where the circles of radius b about B
# and c about D meet (the upper branch).
def position(theta):
    """Each link's (mass, J about its centre, centre (2,), angle) with the crank at ``theta`` (rad)."""
    B, D = a * np.array([math.cos(theta), math.sin(theta)]), np.array([d, 0.0])
    e = D - B
    dist = np.linalg.norm(e)
    x = (dist**2 + b**2 - c**2) / (2 * dist)
    C = B + x * e / dist + math.sqrt(b**2 - x**2) * np.array([-e[1], e[0]]) / dist
    phi_b, phi_c = math.atan2(*(C - B)[::-1]), math.atan2(*(C - D)[::-1])
    return [(masses["crank"], masses["crank"] * a**2 / 12, B / 2, theta),
            (masses["coupler"], masses["coupler"] * b**2 / 12, B + (C - B) / 2, phi_b),
            (masses["rocker"], masses["rocker"] * c**2 / 12, D + (C - D) / 2, phi_c)]


theta_a, coupler_a, rocker_a = system.difference(system.neutral(), assembly.q)
_, link_b, link_c = position(theta_a)
print(f"assembled: θ = {theta_a:.6f} rad, coupler {coupler_a:.6f}, rocker {rocker_a:.6f} rad; closed form "
      f"{link_b[3] - theta_a:.6f}, {link_c[3]:.6f}; closure residual {assembly.constraint_residual:.1e}")
tol = 10 * (assembly.constraint_residual + 1e-16) / system.constraints.conditioning(assembly.q)  # rad, from Φ
assert abs(coupler_a - (link_b[3] - theta_a)) <= tol and abs(rocker_a - link_c[3]) <= tol

# %%
# Equilibrium and frequency
# -------------------------
eq = system.equilibrium()
lin = eq.linearize()
modes = lin.modes()
theta_e = eq.coordinate("crank")
w, w_err = modes.omega[0], modes.omega_error[0]
print(f"vibdyn: θₑ = {theta_e:.12f} rad (error estimate {eq.q_error[0]:.1e}), ω = {w:.10f} rad/s "
      f"({modes.frequency_hz[0]:.10f} Hz), error estimate {w_err:.1e}")
print("pin force at C, coupler on rocker (N, world axes):", eq.loop_forces["C"][:2])


# %%
# The textbook reduction, as an independent check: V and the centres by the position analysis, derivatives
# by five-point central differences; its own error estimate is the change between steps h and 2h.
def V(theta):
    return sum(m * g * G[1] for m, _, G, _ in position(theta)) + 0.5 * k_t * (theta - theta_rest) ** 2


def d1(f, x, h):
    return (8 * (f(x + h) - f(x - h)) - (f(x + 2 * h) - f(x - 2 * h))) / (12 * h)


def d2(f, x, h):
    return (-f(x + 2 * h) + 16 * f(x + h) - 30 * f(x) + 16 * f(x - h) - f(x - 2 * h)) / (12 * h * h)


def reduction(h):
    th = brentq(lambda x: d1(V, x, h), theta_e - 0.05, theta_e + 0.05, xtol=1e-15)
    mass = sum(m * np.sum(d1(lambda x, i=i: position(x)[i][2], th, h) ** 2)
               + J * d1(lambda x, i=i: position(x)[i][3], th, h) ** 2
               for i, (m, J, _, _) in enumerate(position(th)))
    return th, math.sqrt(d2(V, th, 20 * h) / mass)


(th1, w1), (th2, w2) = reduction(1e-4), reduction(2e-4)
red_err = abs(w1 - w2) + 1e-13 * w1
print(f"by hand: θₑ = {th1:.12f} rad, ω = {w1:.10f} rad/s (its error estimate {red_err:.1e}); "
      f"|Δω| = {abs(w - w1):.1e}")
assert abs(theta_e - th1) <= 10 * eq.q_error[0] + abs(th1 - th2) + 1e-12
assert abs(w - w1) <= 10 * (w_err + red_err)
assert np.allclose(system.constraint_jacobian(eq.q) @ modes.shapes, 0, atol=1e-10)  # the mode keeps C closed

# %%
# The potential along the mechanism's one motion
# ----------------------------------------------
# At each crank angle, the closed configuration from the position analysis: vibdyn's loop residual there is
# zero (the description closes where the drawing does) and its potential energy is the textbook's V(θ), up to
# a constant; the equilibrium sits at its minimum.
thetas = np.linspace(0.3, 1.7, 57)
V_vibdyn, closure = [], []
for th in thetas:
    _, cpl, rck = position(th)
    q = system.configuration({"crank": th, "coupler": cpl[3] - th, "rocker": rck[3]})
    closure.append(np.abs(system.constraint_residual(q)).max())
    V_vibdyn.append(system.energy(q, np.zeros(3)).potential)
V_vibdyn = np.array(V_vibdyn)
V_hand = np.array([V(th) for th in thetas])
offset = V_vibdyn[0] - V_hand[0]  # potentials agree up to a constant (their zero level)
print(f"along the motion: loop residual ≤ {max(closure):.1e} m, |V_vibdyn − V_hand − const| ≤ "
      f"{np.abs(V_vibdyn - V_hand - offset).max():.1e} J")
assert max(closure) <= 1e-14 and np.abs(V_vibdyn - V_hand - offset).max() <= 1e-13

fig_v, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
ax.plot(thetas, V_hand, label="by hand V(θ)")
ax.plot(thetas, V_vibdyn - offset, "o", mfc="none", ms=4, label="vibdyn, assembled")
ax.axvline(theta_e, color="0.6", ls="--", lw=0.8, label=f"θₑ = {theta_e:.4f} rad")
ax.set_xlabel("crank angle θ (rad)")
ax.set_ylabel("potential energy (J)")
ax.legend()

# %%
# The mode and the viewer
# -----------------------
fig_mode = modes.plot()
vd.export_html(modes, "viewer_four_bar.html")
