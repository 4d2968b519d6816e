"""
A quarter car on an ISO 8608 road
=================================

The bundled quarter car (m_s = 250 kg on k_s = 16 kN/m and c_s = 1000 N·s/m; m_u = 35 kg on a tyre of
k_t = 160 kN/m) drives over a random road. ISO 8608 classes roads by their vertical displacement PSD in
spatial frequency n (cycles/m):

    G_d(n) = G_d(n0) (n / n0)^-2,   n0 = 0.1 cycle/m,

G_d(n0) = 16, 64, 256, 1024 … ×10⁻⁶ m³ for classes A, B, C, D … At a speed V the wheel meets the frequency
f = n V (Hz), and the same variance spread over V times the band gives the temporal PSD G(f) = G_d(f/V)/V
(m²/Hz), which ``vd.PSD.iso8608(class, speed)`` builds (over n = 0.011 … 2.83 cycles/m). The comfort measure
is the body's RMS acceleration; the suspension's travel is the body's motion relative to the wheel; the
tyre's dynamic load (its spring's force) is the road holding.
"""

# %%
# One road, one speed
# -------------------
import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import quad

import vibdyn as vd

car = vd.load_scene("quarter_car").build().operating_point().linearize()
road = vd.PSD.iso8608("C", speed=20.0)
print(road, f"road RMS {road.rms() * 1e3:.2f} mm")
r = car.random_response(road, support="road", direction=(0, 0, 1), outputs=["body", "wheel"],
                        relative=[("body", "wheel")], springs=["tyre"])
acc, acc_err = r.rms("acceleration"), r.rms_error("acceleration")
travel, travel_err = r.rms("displacement")[2], r.rms_error("displacement")[2]
print(f"body acceleration {acc[0]:.6f} ± {acc_err[0]:.1e} m/s² rms; suspension travel {travel * 1e3:.6f} ± "
      f"{travel_err * 1e3:.1e} mm rms ({r.method}, {r.elapsed * 1e3:.1f} ms)")
tyre = r.rms("displacement")[3]  # a spring's "displacement" output is its force (N)
print(f"tyre load {tyre:.1f} N rms: {tyre / (285.0 * 9.81):.1%} of the static load")

# %%
# An independent check in the road's own variable: the body's acceleration variance
# ∫ \|ω² H_body(ω)\|² G_d(n) dn over the spatial band, ω = 2π n V, with H from the matrices by hand and scipy's
# quad — no temporal PSD in sight, so the conversion G(f) = G_d(n)/V is checked too.
ms, mu, ks, kt, cs = 250.0, 35.0, 16000.0, 160000.0, 1000.0
M = np.diag([mu, ms])
K = np.array([[ks + kt, -ks], [-ks, ks]])
C = np.array([[cs, -cs], [-cs, cs]])
V, gd0 = 20.0, 256e-6


def body_acceleration_density(n):
    w = 2 * np.pi * n * V
    h = np.linalg.solve(K - w * w * M + 1j * w * C, [kt, 0.0])[1]
    return abs(w * w * h) ** 2 * gd0 * (n / 0.1) ** -2


poles = [f / V for f in car.modes().damped_frequency_hz]
var = quad(body_acceleration_density, 0.011, 2.83, points=poles, epsabs=0, epsrel=1e-12, limit=400)[0]
print(f"by hand in spatial frequency: {np.sqrt(var):.9f} m/s² (vibdyn {acc[0]:.9f})")
assert abs(np.sqrt(var) - acc[0]) <= acc_err[0] + 1e-8 * acc[0] + 10 * car.relative_error * acc[0]

# %%
# Classes and speeds
# ------------------
# Comfort worsens with the class (each class doubles the road's RMS, so the response too) and with speed.
speeds = np.array([10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0])
fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
for cls in "ABCD":
    rms = [car.random_response(vd.PSD.iso8608(cls, speed=v), support="road", direction=(0, 0, 1),
                               outputs=["body"]).rms("acceleration")[0] for v in speeds]
    ax.plot(speeds, rms, "o-", label=f"class {cls}")
    print(f"class {cls}: body RMS acceleration (m/s²) at {speeds.tolist()} m/s: {np.round(rms, 4).tolist()}")
ratio = [car.random_response(vd.PSD.iso8608(b, speed=20.0), support="road", direction=(0, 0, 1),
                             outputs=["body"]).rms("acceleration")[0] for b in "AB"]
assert abs(ratio[1] / ratio[0] - 2.0) < 1e-8  # linear: the response scales with the road
ax.set_xlabel("speed V (m/s)")
ax.set_ylabel("body acceleration, RMS (m/s²)")
ax.set_yscale("log")
ax.grid(True, which="both", alpha=0.3)
ax.legend()
ax.set_title("quarter car on ISO 8608 roads (one-sided PSDs in Hz)")

# %%
# The response PSDs (one-sided, per Hz) over the road's, log-log: the body's bounce at 1.2 Hz and the
# wheel hop at 11 Hz.
fig2 = r.plot(None, "acceleration")
vd.export_html(car.modes(), "viewer_random_quarter_car.html")  # the bounce and the wheel hop, offline
plt.show()
