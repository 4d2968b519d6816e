"""
Move a resonance out of a band
==============================

The three-storey shear building (``three_storey_building``: floors of 2000, 1500 and 1000 kg, storey
stiffnesses 6e5, 4e5 and 2e5 N/m) has its first natural frequency at ω₁ = 8.384 rad/s. Suppose a machine on
the roof runs between 7.5 and 9 rad/s: which storey should be stiffened, and by how much, to put ω₁ at
9.5 rad/s?

The sensitivities ∂ω₁/∂k_i (rad/s per N/m) answer the first question; normalised as (k/ω) ∂ω/∂k they say
which storey gives the most frequency per percent of stiffness. Newton's method on ω₁(k) with that
derivative answers the second, and a rebuild checks it.
"""

# %%
# Sensitivities of every mode to every storey
# -------------------------------------------
import matplotlib.pyplot as plt
import numpy as np

import vibdyn as vd
from vibdyn.description.parameters import parameters, with_values

base = vd.load_scene("three_storey_building")
names = ["storey1.stiffness", "storey2.stiffness", "storey3.stiffness"]
modes = base.build().operating_point().linearize(method="analytic").modes()
s = modes.sensitivity(names)
print(s)
best = int(np.argmax(s.normalised[0]))
print(f"most effective for mode 1: {names[best]} ((k/ω) ∂ω₁/∂k = {s.normalised[0, best]:.3f})")

# %%
# Newton on ω₁(k): the stiffness that puts ω₁ at 9.5 rad/s
# ---------------------------------------------------------
target = 9.5
p = parameters(base, [names[best]])[0]
k = p.value
for it in range(10):
    m = with_values(base, [p], [k]).build().operating_point().linearize(method="analytic").modes()
    w1 = m.omega[0]
    print(f"iteration {it}: {p.name} = {k:.6e} N/m, ω₁ = {w1:.9f} rad/s")
    if abs(w1 - target) < 1e-9 * target:
        break
    d = m.sensitivity([p.name])
    k += (target - w1) / d.d_omega[0, 0]
assert abs(w1 - target) < 1e-9 * target  # checked by rebuilding: the model with the new stiffness
print(f"{p.name}: {p.value:.4g} → {k:.6g} N/m (+{100 * (k / p.value - 1):.1f} %) puts ω₁ at {w1:.6f} rad/s")

# %%
# ω₁ against the chosen stiffness, with the band
# ----------------------------------------------
ks = np.linspace(p.value, 1.1 * k, 25)
w = [with_values(base, [p], [x]).build().operating_point().linearize(method="analytic").modes().omega[0] for x in ks]
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.axhspan(7.5, 9.0, color="tab:red", alpha=0.15, label="excitation band 7.5–9 rad/s")
ax.plot(ks / 1e5, w, "-", label="ω₁ (undamped, rad/s)")
ax.plot([p.value / 1e5, k / 1e5], [modes.omega[0], w1], "o", label="start, and the Newton result")
ax.plot(ks / 1e5, modes.omega[0] + s.d_omega[0, best] * (ks - p.value), "--", label="first-order: ω₁ + ∂ω₁/∂k Δk")
ax.set_xlabel(f"{p.name} (1e5 N/m)")
ax.set_ylabel("ω₁ (rad/s)")
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()

# %%
# The stiffened building's modes, in the viewer
# ---------------------------------------------
stiffened = with_values(base, [p], [k]).build().operating_point().linearize(method="analytic").modes()
vd.export_html(stiffened, "viewer_move_a_resonance.html")
