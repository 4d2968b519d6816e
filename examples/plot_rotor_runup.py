"""
Run-up of the rotor with a sprung slider: unbalance response and stability
==========================================================================

The bundled rotor of Tătaru's *elastic movements superposed on the motion of the rigid body*
(``models/rotor_slider.toml``, reference case R6): a rotor spinning about the vertical z axis carries a slider
(m = 1 kg) on a radial slide, held by a spring k = 100 N/m (free length 0.5 m) and a damper c = 2 N·s/m. Here
the rotor is run up, its speed Ω held at each step by its drive (the motor law of the scene aside), with an
unbalance U = 1e-3 kg·m on the slider along its slide.

The slider moves in the rotor's frame, where the spring is softened by the centrifugal term. Linearised about
the steady spin, in the slider's travel s (m):

    m s̈ + c ṡ + (k − mΩ²) s = F,

so that in the rotating frame the slider's mode has ω_d = √(k/m − Ω² − (c/2m)²) and ζ = c / (2√(m(k − mΩ²))):
it meets the speed line ω_d = Ω at Ω = √((k/m − (c/2m)²)/2) = 7.0356 rad/s (the Campbell diagram's critical
speed) and loses its stiffness at Ω = √(k/m) = 10 rad/s, beyond which the slider has no steady position. The
unbalance's force U Ω² along the slide turns with the rotor: in the slider's frame it is constant, and the
slider's response is the static s = U Ω² / (k − mΩ²) — which the world sees as a synchronous forward whirl of
that radius. It grows without a peak up to 10 rad/s and does not resonate at 7.04 rad/s.
"""

# %%
# The Campbell diagram: frequencies and damping in the rotating frame
# -------------------------------------------------------------------
import numpy as np

import vibdyn as vd

m, k, c, U = 1.0, 100.0, 2.0, 1e-3
scene = vd.load_scene("rotor_slider")
scene.add_unbalance("slider_unbalance", "slider", U)  # along the slide (angle 0: the slider's x axis)
system = scene.build()

speeds = np.linspace(0.0, 9.9, 34)
diagram = vd.campbell(system, "rotor", speeds, held=True)
print(diagram)
w_d = np.sqrt(k / m - speeds ** 2 - (c / (2 * m)) ** 2)
zeta = c / (2 * np.sqrt(m * (k - m * speeds ** 2)))
oscillating = zeta < 1
gap = np.abs(diagram.omega[oscillating, 0] - w_d[oscillating])
print(f"slider's ω_d against √(k/m − Ω² − (c/2m)²): largest |Δ| {gap.max():.1e} rad/s "
      f"(estimates up to {diagram.error[:, 0].max():.1e})")
assert np.all(gap <= 10 * diagram.error[oscillating, 0] + 1e-12 * w_d[oscillating])
assert np.allclose(diagram.zeta[oscillating, 0], zeta[oscillating], rtol=1e-8)
(critical,) = diagram.critical_speeds(1)
exact = np.sqrt((k / m - (c / (2 * m)) ** 2) / 2)
print(f"critical speed {critical.speed:.10f} rad/s ± {critical.error:.1e}, closed form {exact:.10f}")
assert abs(critical.speed - exact) <= 10 * critical.error + 1e-12 * exact
fig_campbell = diagram.plot()

# %%
# The unbalance response through the run-up
# -----------------------------------------
# Outputs: the slider's coordinate (its steady offset in the rotor's frame, ``static``) and the slider's origin
# in the world (two axes normal to the spin: its synchronous orbit). Amplitudes are 0-peak (``peak_to_peak``
# doubles them) with their error estimates.
run = np.linspace(0.5, 9.8, 32)
response = vd.unbalance_response(system, "rotor", run, outputs=["slider", ("slider", (0.0, 0.0, 0.0))])
print(response)
offset = U * run ** 2 / (k - m * run ** 2)
print(f"slider's static offset against U Ω² / (k − mΩ²): largest relative |Δ| "
      f"{np.max(np.abs(response.static[:, 0] - offset) / offset):.1e}")
assert np.all(np.abs(response.static[:, 0] - offset) <= response.amplitude_error[:, 0] + 1e-12 * offset)
assert np.all(response.amplitude[:, 0] <= 1e-12 * offset)  # the slider's coordinate does not vibrate
orbit = response.orbit(("slider", (0.0, 0.0, 0.0)))
assert np.all(np.abs(orbit.major - offset) <= orbit.error + 1e-12 * offset)
assert np.allclose(orbit.minor, orbit.major, rtol=1e-9) and set(orbit.whirl) == {"forward"}  # a circle
print(f"orbit of the slider at {run[-1]:g} rad/s: radius {orbit.major[-1]:.6e} m (error {orbit.error[-1]:.1e}), "
      f"{orbit.whirl[-1]} whirl; no resonance peak below 10 rad/s: {response.peaks(1)}")
assert response.peaks(1) == [] and set(response.stability) == {"stable"}
fig_bode = response.plot(outputs=[1, 2], units="rpm")
for ax in fig_bode.axes:  # the Campbell diagram's critical speed, which the unbalance does not excite
    ax.axvline(critical.speed_rpm, color="0.5", ls=":", lw=1)
fig_polar = response.polar(output=1)

# %%
# Beyond 10 rad/s
# ---------------
# There the centrifugal force m Ω² |s| outgrows the spring's k (|s| − l₀) at every radius: the slider has no
# steady position, and vibdyn says so rather than give a response.
q_last = system.steady_motion({"rotor": run[-1]}).q  # (the search starts from the last steady position)
try:
    vd.unbalance_response(system, "rotor", [10.5], outputs=["slider"], q0=q_last)
    raise AssertionError("a steady response beyond 10 rad/s")
except vd.ConvergenceError as e:
    print(f"at 10.5 rad/s: {str(e)[:110]}…")

# %%
# The modes at 9 rad/s, in the viewer
# -----------------------------------
modes = system.steady_motion({"rotor": 9.0}).linearize(hold="rotor").modes()
vd.export_html(modes, "viewer_rotor_runup.html")
