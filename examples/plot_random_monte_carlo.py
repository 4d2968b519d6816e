"""
Random shaking in time: where the linear RMS stops holding
==========================================================

A 1 kg mass slides on a spring (40 N/m) and a damper (1.26 N·s/m) tied to a base that moves at random: a
displacement PSD of 0.025 m²/Hz from 0.3 to 3 Hz (0.26 m RMS). A cubic spring to the ground,
k3 x³ with k3 = 100 N/m³, hardens it (a Duffing oscillator). Linearised about rest it is an oscillator of
1.007 Hz with ζ ≈ 0.10, and ``random_response`` gives its RMS motion exactly: 0.44 m, where the cubic spring
already pulls with k3·x² ≈ 20 N/m, half the linear stiffness.

``vd.monte_carlo`` draws seeded Gaussian sample paths of the base's motion from its PSD and runs each through
the nonlinear ``simulate`` and the linear ``forced_response`` (the same paths for both). The linear runs agree
with ``random_response`` within their sampling error; the nonlinear RMS departs from the linear one by many
times the sampling error of their ratio.
"""

# %%
import matplotlib.pyplot as plt
import numpy as np

import vibdyn as vd

scene = vd.Scene("duffing_on_a_random_base")
scene.add_support("base", vd.laws.HarmonicMotion((0, 0, 0.0), 1.0))  # replaced by each sample path
scene.add_body("mass", joint=vd.Slider((1, 0, 0), at=(1.0, 0, 0)), mass=1.0)
scene.add_spring("k", ("base", (0, 0, 0)), "mass", stiffness=40.0)
scene.add_damper("c", ("base", (0, 0, 0)), "mass", damping=1.26)
scene.add_cubic_joint_spring("mass", 100.0)
lin = scene.build().operating_point().linearize()
m = lin.modes()
print(f"linear: f = {m.frequency_hz[0]:.4f} Hz, ζ = {m.zeta[0]:.4f}")

base = vd.PSD.band_limited(0.025, 0.3, 3.0, unit="m^2/Hz")
theory = lin.random_response(base, support="base", direction=(1, 0, 0))
print(f"random_response: RMS {theory.rms()[0]:.6f} ± {theory.rms_error()[0]:.1e} m")

# %%
# Monte Carlo: 6 sample paths of 20 s each, after the default settling time (five time constants of the
# mode), through both models.
mc = vd.monte_carlo(lin, base, "base", (1, 0, 0), duration=20.0, samples=6, seed=7, dt=0.05)
lin_rms, lin_err = mc.rms("displacement", "linear")[0], mc.rms_error("displacement", "linear")[0]
nl_rms, nl_err = mc.rms("displacement", "nonlinear")[0], mc.rms_error("displacement", "nonlinear")[0]
ratio, ratio_err = (x[0] for x in mc.ratio("displacement"))
print(f"linear Monte Carlo    RMS {lin_rms:.4f} ± {lin_err:.4f} m (sampling error)")
print(f"nonlinear Monte Carlo RMS {nl_rms:.4f} ± {nl_err:.4f} m")
print(f"nonlinear / linear, per sample path: {ratio:.3f} ± {ratio_err:.3f} "
      f"({abs(ratio - 1) / ratio_err:.1f} × its sampling error from 1); {mc.elapsed:.1f} s")
assert abs(lin_rms - theory.rms()[0]) <= 3 * lin_err  # the linear runs: the theory within their error
assert abs(ratio - 1) >= 3 * ratio_err  # the nonlinear RMS departs beyond the sampling error

# %%
# Each sample's RMS, linear against nonlinear: the hardening spring holds the mass back on every path.
lin_s = np.sqrt(mc.variance["linear"][0][:, 0])
nl_s = np.sqrt(mc.variance["nonlinear"][0][:, 0])
fig, ax = plt.subplots(figsize=(5.5, 5), layout="constrained")
ax.plot(lin_s, nl_s, "o", label="one sample path")
lim = [0.9 * min(lin_s.min(), nl_s.min()), 1.1 * max(lin_s.max(), nl_s.max())]
ax.plot(lim, lim, "k--", lw=0.8, label="nonlinear = linear")
ax.axvline(theory.rms()[0], color="C2", lw=0.8, label="random_response (linear, exact)")
ax.set_xlabel("linear RMS per sample (m)")
ax.set_ylabel("nonlinear RMS per sample (m)")
ax.legend()
vd.export_html(m, "viewer_random_monte_carlo.html")  # the linear mode, offline
plt.show()
