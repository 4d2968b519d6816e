"""
Fit the three-storey building to measured frequencies
=====================================================

A test of the three-storey shear building measured its three natural frequencies with 0.5 % noise. Which
storey stiffnesses make the model match? ``vd.update`` fits them by weighted least squares on the
sensitivities and states each fitted value's standard deviation (from the Jacobian and the measurement
uncertainty σ). Here the "measurements" are synthetic — the book's model with noise — so the fit can be
checked: over 20 noisy draws, the fitted stiffnesses fall within 2σ of the truth about 95 % of the time.
"""

# %%
# One fit
# -------
import matplotlib.pyplot as plt
import numpy as np

import vibdyn as vd
from vibdyn.description.parameters import parameters, with_values

base = vd.load_scene("three_storey_building")
storeys = parameters(base, ["storey1.stiffness", "storey2.stiffness", "storey3.stiffness"])


def building(k1, k2, k3):
    return with_values(base, storeys, [k1, k2, k3])


truth = {"k1": 6e5, "k2": 4e5, "k3": 2e5}
w_true = building(**truth).build().operating_point().linearize(method="analytic").modes().omega
rng = np.random.default_rng(7)
sigma = 0.005 * w_true
measured = w_true + sigma * rng.standard_normal(3)
fit = vd.update(building, {"k1": 5e5, "k2": 5e5, "k3": 3e5}, measured, sigma=sigma)
print(fit)

# %%
# Twenty noisy tests: are the standard deviations honest?
# -------------------------------------------------------
z = []
for _ in range(20):
    measured = w_true + sigma * rng.standard_normal(3)
    f = vd.update(building, {"k1": 5e5, "k2": 5e5, "k3": 3e5}, measured, sigma=sigma)
    z.append([(f.values[k] - truth[k]) / f.std[k] for k in truth])
z = np.array(z)
inside = np.mean(np.abs(z) <= 2)
print(f"{100 * inside:.0f} % of the 60 fitted stiffnesses within 2σ of the truth (expected about 95 %)")
assert inside >= 0.85

fig, ax = plt.subplots(figsize=(6, 3.2))
for j, k in enumerate(truth):
    ax.plot(np.full(20, j) + 0.05 * rng.standard_normal(20), z[:, j], "o", alpha=0.7)
ax.axhspan(-2, 2, color="tab:green", alpha=0.12, label="±2σ")
ax.set_xticks(range(3), [f"{k} (storey {j + 1})" for j, k in enumerate(truth)])
ax.set_ylabel("(fitted − true) / stated σ")
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()

# %%
# The fitted building's modes, in the viewer
# ------------------------------------------
fitted = building(**fit.values).build().operating_point().linearize(method="analytic").modes()
vd.export_html(fitted, "viewer_fit_building.html")
