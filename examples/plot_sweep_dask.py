"""
A parameter sweep on Dask: modes that cross and modes that veer
===============================================================

Two masses m = 1 kg on parallel sliders, each held to the wall by its own spring (k₁ swept from 80 to 120 N/m,
k₂ = 100 N/m), coupled by a spring k_c (``vibdyn.examples.two_modes``). With M = I and
K = [[k₁ + k_c, −k_c], [−k_c, k₂ + k_c]],

    ω²₁,₂ = (k₁ + k₂ + 2k_c ∓ √((k₁ − k₂)² + 4k_c²)) / 2.

Uncoupled (k_c = 0) the two frequencies cross at k₁ = k₂; coupled (k_c = 2 N/m) they veer: they come no closer
than ω²₂ − ω²₁ = 2k_c, and the modes exchange their shapes as k₁ passes k₂ (the textbook picture of mode
veering; Leissa, "On a curve veering aberration", ZAMP 1974).

The sweep runs on a Dask ``distributed.Client`` (here a local one inside this process, two workers; a
cluster's client works the same way) and gives the same numbers, bit for bit, as the serial run.
"""

# %%
# The sweep on Dask
# -----------------
# ``vd.sweep`` sends the module-level builder and the parameter points to the workers in chunks; each point
# comes back with its outputs, error estimate, time and status.
import matplotlib.pyplot as plt
import numpy as np
from distributed import Client

import vibdyn as vd
from vibdyn import examples

grid = {"k1": np.linspace(80.0, 120.0, 41), "kc": [0.0, 2.0]}
with Client(processes=False, n_workers=2, threads_per_worker=1, dashboard_address=None) as client:
    on_dask = vd.sweep(examples.two_modes, grid, executor=client, progress=False)
serial = vd.sweep(examples.two_modes, grid, progress=False)
print(on_dask)
print(serial)
assert np.array_equal(on_dask.values("omega"), serial.values("omega"))  # bit for bit
print("the Dask sweep's frequencies equal the serial sweep's bit for bit")

# %%
# Every point against the closed form
# -----------------------------------
# Each point carries each ω's absolute error estimate (``omega_error``, rad/s).
worst = 0.0
for point, result in zip(on_dask.parameters, on_dask.results):
    assert result["status"] == "ok", result["status"]
    k1, kc, k2 = point["k1"], point["kc"], 100.0
    root = np.sqrt((k1 - k2) ** 2 + 4 * kc**2)
    exact = np.sqrt([(k1 + k2 + 2 * kc - root) / 2, (k1 + k2 + 2 * kc + root) / 2])
    omega, err = np.array(result["outputs"]["omega"]), np.array(result["outputs"]["omega_error"])
    assert np.all(np.abs(omega - exact) <= 10 * err + 1e-13 * exact), point
    worst = max(worst, np.abs(omega - exact).max())
print(f"{on_dask.n} points, largest |ω − ω_exact| = {worst:.1e} rad/s; {on_dask.elapsed:.2f} s on Dask, "
      f"{serial.elapsed:.2f} s serial (points this small cost less than Dask's scheduling)")

# %%
# Tracking the modes: a crossing and a veering
# --------------------------------------------
# ``tracked`` follows each mode by MAC from one point to the next (not by frequency order) and flags where
# curves cross or veer.
k1 = grid["k1"]
fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True, layout="constrained")
for ax, kc in zip(axes, grid["kc"]):
    part = vd.sweep(examples.two_modes, {"k1": k1, "kc": [kc]}, progress=False)
    tr = part.tracked("omega")
    print(f"k_c = {kc} N/m: crossings {tr.crossings}, veerings {tr.veerings}")
    for j in range(tr.values.shape[1]):
        ax.plot(k1, tr.values[:, j], "o-", ms=3, label=f"tracked mode {j + 1}")
    ax.set_title(f"k_c = {kc} N/m: " + ("the modes cross" if kc == 0 else "the modes veer"))
    ax.set_xlabel("k₁ (N/m)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    if kc == 0:
        assert tr.crossings and not tr.veerings
    else:
        assert tr.veerings and not tr.crossings
        gap = np.min(tr.values[:, 1] ** 2 - tr.values[:, 0] ** 2)
        print(f"  closest approach ω₂² − ω₁² = {gap:.9f} rad²/s² (2k_c = {2 * kc})")
        err = 2 * tr.values.max() * part.values("omega_error").max()  # the error of ω² from ω's
        assert abs(gap - 2 * kc) <= 10 * 2 * err
axes[0].set_ylabel("ω (rad/s)")
