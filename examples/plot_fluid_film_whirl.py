"""
A rigid rotor on tabulated fluid-film bearing coefficients: the onset of oil whirl
==================================================================================

A disk (m = 2 kg) spins about z on a journal bearing whose eight coefficients come, as a bearing code gives
them, as a table against the spin speed Ω (rad/s). The table here follows the classic "half-frequency" model of
a lubricant film (Crandall; Muszynska; Vance, *Machinery Vibration and Rotordynamics*, ch. 5): the film's mean
flow turns at Ω/2, so its damping c acting in that moving frame gives a cross-coupled stiffness

    k_xy = c Ω / 2,   k_yx = −c Ω / 2,

while the direct stiffness firms up with speed, k(Ω) = k₀ (1 + α Ω / Ω_ref). In the fixed frame the disk's
lateral motion z = x + i y obeys m z̈ + c ż + (k(Ω) − i c Ω/2) z = 0: the forward mode loses its damping where the
cross-coupling's work equals the film's dissipation, c Ω/2 = c ω_n(Ω) with ω_n = √(k(Ω)/m), i.e. at the speed
Ω_th that solves Ω² − (4 k₀ α / (m Ω_ref)) Ω − 4 k₀/m = 0 — twice the natural frequency, the "whirl ratio"
of 1/2. vibdyn reads the table (linear interpolation: exact here, the coefficients being linear in Ω), and its
Campbell diagram, log decrements and onset search find that speed.
"""

# %%
# The rotor and its bearing table
# -------------------------------
import numpy as np

import vibdyn as vd

m, k0, alpha, c, ref = 2.0, 8.0e4, 0.25, 60.0, 600.0
table_speeds = np.linspace(0.0, 600.0, 13)  # rad/s: the bearing code's speeds
k = k0 * (1 + alpha * table_speeds / ref)
q = c * table_speeds / 2
stiffness = np.array([[[kk, qq], [-qq, kk]] for kk, qq in zip(k, q)])  # N/m, [[xx, xy], [yx, yy]] per speed
damping = np.array([c * np.eye(2)] * len(table_speeds))  # N·s/m

scene = vd.Scene("fluid_film_rotor")
scene.add_body("cx", joint=vd.Slider((1, 0, 0)))
scene.add_body("cy", parent="cx", joint=vd.Slider((0, 1, 0)))
scene.add_body("disk", parent="cy", joint=vd.Pivot((0, 0, 1)), mass=m, inertia=np.diag([0.01, 0.01, 0.02]))
scene.add_bearing("journal", "world", "disk", stiffness=stiffness, damping=damping, speeds=table_speeds)
rotor = scene.build()

# %%
# Campbell diagram and log decrements
# -----------------------------------
# The lateral modes at each held speed: their damped frequencies and log decrements δ = −2π Re λ / |Im λ|
# (the sliders' coordinates are fixed in space: the frame of the frequencies is the fixed one).
speeds = np.linspace(10.0, 590.0, 59)  # (at rest the two modes have no whirl: they start at 10 rad/s)
diagram = vd.campbell(rotor, "disk", speeds)
print(diagram)
forward = np.array([list(w).index("forward") for w in diagram.whirl])  # each speed's forward mode
delta = diagram.log_dec[np.arange(len(speeds)), forward]
# the forward mode's exact eigenvalue in the fixed frame: the root of m s² + c s + k(Ω) − i c Ω/2 with Im s > 0
exact = np.array([max(np.roots([m, c, k0 * (1 + alpha * W / ref) - 1j * c * W / 2]), key=lambda s: s.imag)
                  for W in speeds])
exact_delta = -2 * np.pi * exact.real / np.abs(exact.imag)
gap = np.abs(delta - exact_delta)
print(f"forward mode's log decrement against the closed form: largest |Δδ| {gap.max():.1e} "
      f"(estimates up to {diagram.log_dec_error[np.arange(len(speeds)), forward].max():.1e})")
assert np.all(gap <= 10 * diagram.log_dec_error[np.arange(len(speeds)), forward] + 1e-9)

# %%
# The onset of whirl
# ------------------
# Re λ of the forward mode crosses zero between two speeds of the diagram; the crossing is refined by Brent's
# method on the linearised model itself, with its error.
(onset,) = [o for o in diagram.onset() if o.kind == "instability"]
b = 4 * k0 * alpha / (m * ref)
threshold = (b + np.sqrt(b * b + 16 * k0 / m)) / 2
print(f"onset of whirl: Ω = {onset.speed:.8f} ± {onset.speed_error:.1e} rad/s ({onset.whirl} whirl at "
      f"{onset.omega:.4f} rad/s = {onset.omega / onset.speed:.4f} × Ω); closed form {threshold:.8f} rad/s")
assert abs(onset.speed - threshold) <= 10 * onset.speed_error + 1e-9 * threshold
assert onset.whirl == "forward" and abs(onset.omega / onset.speed - 0.5) < 1e-6

# %%
# The picture for a report: speeds in rpm, frequencies in Hz, the unstable stretch marked.
diagram.plot("fluid_film_campbell.png", units="rpm")

# %%
# The two whirling modes at 450 rad/s, past the onset (the forward one growing), in the viewer
modes = rotor.steady_motion({"disk": 450.0}).linearize(hold="disk").modes()
print(modes)
vd.export_html(modes, "viewer_fluid_film_whirl.html")
