"""
Backbones: nonlinear normal modes
=================================

A linear mode is a family of motions q = a φ cos ωt whose frequency ω does not depend on the amplitude a.
Beyond small amplitudes the family survives, bent: a **nonlinear normal mode** (NNM; Rosenberg, then
Kerschen, Peeters et al., MSSP 2009) is the family of periodic orbits of the undamped scene that grows out of
one linear mode, and its **backbone** is the fundamental frequency ω against the energy (or an amplitude). A
pendulum softens (ω falls as it swings wider), a cubic spring hardens; a forced, lightly damped response peaks
near the backbone. ``vd.backbone(system, mode, amplitudes=… | energies=…)`` follows the family from the linear
mode by pseudo-arclength continuation on the shooting equations and solves every request exactly, each with its
Floquet multipliers (stability) and an error estimate of ω; an internal resonance met on the way (another NNM's
frequency k times this one's: a *tongue*) is reported, never stepped over silently.
"""

# %%
# The pendulum against the elliptic integral
# ------------------------------------------
# A uniform rod of 1 m on a pivot (``rod_pivot``): ω₀ = √(3g/2L). Swinging with amplitude A its exact frequency
# is ω(A) = π ω₀ / (2 K(sin²(A/2))), K the complete elliptic integral of the first kind (ω → 0 at the
# separatrix A = π).
import math

import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import ellipk

import vibdyn as vd

rod = vd.load_scene("rod_pivot")
w0 = rod.references["omega"][0]
pendulum = vd.backbone(rod.build(), 0, amplitudes=[0.5, 1.0, 2.0, 2.5, 3.0])
for A, w, e in zip(pendulum.amplitude, pendulum.omega, pendulum.error):
    exact = math.pi * w0 / (2 * ellipk(math.sin(A / 2) ** 2))
    print(f"A = {A:.1f} rad: ω = {w:.12f} rad/s ({w / (2 * math.pi):.9f} Hz), exact {exact:.12f}, "
          f"error {w - exact:+.1e} (estimate ± {e:.1e})")
    assert abs(w - exact) <= 2 * e + 1e-13  # within the result's own estimate
print(pendulum)
fig = pendulum.plot()
fig

# %%
# Kerschen's two masses with a cubic spring
# -----------------------------------------
# Two unit masses between three unit springs, the first held also by a cubic spring 0.5 x₁³ (``two_mass_cubic``):
#
#     ẍ₁ + (2x₁ − x₂) + 0.5 x₁³ = 0,   ẍ₂ + (2x₂ − x₁) = 0.
#
# Its linear modes are in phase (ω = 1 rad/s) and out of phase (√3 rad/s); the cubic spring hardens both NNMs.
# At high energy the in-phase NNM tends to √2 rad/s (Peeters et al.'s frequency–energy plot): the cubic spring
# all but holds m₁ and m₂ swings alone between two unit springs. On the way it meets a 2:1 internal resonance
# with the out-of-phase mode (a tongue): vibdyn reports it and flags the orbits beyond (here unstable).
# (The bundled scene's springs have zero free length: their forces −k·d stay linear at any amplitude.)
two = vd.load_scene("two_mass_cubic").build()
nnm1 = vd.backbone(two, 0, energies=[0.01, 0.1, 1.0, 10.0, 100.0], coordinate="m1")
nnm2 = vd.backbone(two, 1, energies=[0.01, 0.1, 1.0, 10.0], coordinate="m1")
print(nnm1)
print(nnm2)

# %%
# An independent check: the hand-written equations above, integrated by scipy from each orbit's start over its
# period, come back to the start: the orbits vibdyn found on the Pinocchio model are those of Kerschen's system.


def kerschen(t, y):
    x1, x2, v1, v2 = y
    return [v1, v2, -(2 * x1 - x2 + 0.5 * x1**3), -(2 * x2 - x1)]


for name, bb in (("in phase", nnm1), ("out of phase", nnm2)):
    for E, orbit in zip(bb.energy, bb.orbits):
        y0 = np.concatenate([orbit.q0 - bb.q_eq, orbit.v0])
        end = solve_ivp(kerschen, (0, orbit.period), y0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
        gap = float(np.max(np.abs(end - y0)))
        # vibdyn's estimate: the orbit's closing errors, and its period's error times the state's rate of change
        bound = orbit.error + orbit.velocity_error + orbit.period_error * float(np.max(np.abs(kerschen(0, y0))))
        print(f"{name}, E = {E:.3g} J: ω = {orbit.omega:.10f} rad/s; Kerschen's equations close the orbit to "
              f"{gap:.1e} (vibdyn's estimate {bound:.1e})")
        assert gap <= 2 * bound + 1e-11 * max(1.0, float(np.max(np.abs(y0))))  # + scipy's own (rtol 1e-12)
    assert bb.omega[-1] < (math.sqrt(2) if bb.mode == 0 else math.inf)  # the in-phase NNM stays below √2

# %%
# The frequency–energy plot
# -------------------------
# Both backbones on one plot (``mode`` 0 and 1: the API counts modes from 0, the plot from 1), the energy on a
# log scale; the dotted lines are the linear frequencies. The orbits are neutral (Floquet multipliers on the
# unit circle within their error: an undamped, bounded motion) up to the 2:1 internal resonance, marked; the
# in-phase orbit at 100 J, beyond it, is unstable (dashed).
fig = vd.plots.frequency_energy([nnm1, nnm2])
fig

# %%
# The motion on the out-of-phase NNM
# ----------------------------------
# ``vd.export_html`` of a backbone (or of one of its ``orbits``): the viewer loops one period of the largest-energy
# orbit: the real nonlinear motion, not a linear mode shape.
vd.export_html(nnm2, "viewer_backbones.html")
plt.show()
