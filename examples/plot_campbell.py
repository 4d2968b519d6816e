"""
A Campbell diagram: a disk rotor in a gimbal
============================================

The classical gyroscopic rotor (Genta, *Dynamics of Rotating Systems*, §3; ``models/gimbal_rotor.toml``): a
disk of transverse inertia I_t = 0.08 kg·m² and polar inertia I_p = 0.12 kg·m² spins about z at Ω inside a
massless gimbal, its two tilts (about x, then y) held by torsion springs k = 300 N·m/rad. The linearised
Lagrange equations couple the tilts through the gyroscopic moment I_p Ω:

    I_t ω² ∓ I_p Ω ω − k = 0,   ω_b,f = (∓I_p Ω + √((I_p Ω)² + 4 I_t k)) / (2 I_t).

At rest both tilts swing at √(k/I_t) = 61.237 rad/s; with speed the backward-whirl mode falls and the forward
one rises. The backward mode meets the speed line ω = Ω at the critical speed Ω_c = √(k/(I_t + I_p)) =
38.729833 rad/s; a disk (I_p > I_t) has no forward critical speed.
"""

# %%
# The diagram
# -----------
# At each speed, held by its drive, vibdyn finds the steady motion, linearises it (gyroscopic C included),
# solves the state eigenvalues and tracks each mode by MAC from one speed to the next.
import numpy as np

import vibdyn as vd

It, Ip, k = 0.08, 0.12, 300.0
rotor = vd.load_scene("gimbal_rotor").build()
speeds = np.linspace(0.0, 150.0, 31)
diagram = vd.campbell(rotor, "rotor", speeds)
print(diagram, f"in {diagram.elapsed:.2f} s")


def closed_form(Omega):
    """(backward, forward) whirl frequencies (rad/s) at spin speed ``Omega`` (rad/s)."""
    root = np.sqrt((Ip * Omega) ** 2 + 4 * It * k)
    return (-Ip * Omega + root) / (2 * It), (Ip * Omega + root) / (2 * It)


# %%
# Each tracked curve against the closed form
# ------------------------------------------
# The columns follow the modes by MAC (mode 1 is column 0: modes are numbered from 1, as in the tables and the
# picture); ``whirl`` says which is which. Each frequency carries its own absolute
# error estimate ``diagram.error`` (rad/s).
backward, forward = closed_form(speeds)
worst = 0.0
for j in range(diagram.omega.shape[1]):
    whirls = set(diagram.whirl[1:, j]) - {""}
    if not whirls:
        continue  # the spin's own (cyclic) mode: frequency 0
    (kind,) = whirls  # one whirl per tracked curve: the tracking never swapped them
    exact = backward if kind == "backward" else forward
    gap = np.abs(diagram.omega[:, j] - exact)
    worst = max(worst, (gap / np.maximum(diagram.error[:, j], 1e-300)).max())
    print(f"mode {j + 1}: {kind} whirl, largest |ω_vibdyn − ω_exact| = {gap.max():.1e} rad/s "
          f"(error estimates up to {diagram.error[:, j].max():.1e})")
    assert np.all(gap <= 10 * diagram.error[:, j] + 1e-12 * exact)
print(f"largest |Δω| / estimate: {worst:.2f}")

# %%
# The critical speed
# ------------------
# Refined on the linearisation itself (continued in the engine order from the grid's bracket), with its error.
critical = diagram.critical_speeds(1)
exact_c = np.sqrt(k / (It + Ip))
for cs in critical:
    print(f"{cs}: {cs.speed:.10f} rad/s ({cs.speed_rpm:.4f} rpm), error estimate {cs.error:.1e}; "
          f"closed form {exact_c:.10f} rad/s, |Δ| {abs(cs.speed - exact_c):.1e} "
          f"(book {rotor.scene.references['backward_critical_speed']:.10f})")
assert len(critical) == 1 and critical[0].whirl == "backward"
assert abs(critical[0].speed - exact_c) <= 10 * critical[0].error + 1e-12 * exact_c

fig_campbell = diagram.plot(units="rpm")  # speeds in rpm, frequencies in Hz (frequency="rad/s" for ω)

# %%
# The modes at 100 rad/s, in the viewer
# -------------------------------------
# The scene file's operating point holds the rotor at 100 rad/s: the two whirling modes animate their complex
# shapes (the disk's axis orbits backwards or forwards), beside the closed form.
modes = rotor.operating_point().linearize().modes()
b100, f100 = closed_form(100.0)
whirling = modes.omega_d > 0
print(f"at Ω = 100 rad/s: ω_d = {np.round(modes.omega_d, 7)} rad/s; closed form {b100:.7f}, {f100:.7f}")
assert np.all(np.abs(modes.omega_d[whirling] - [b100, f100]) <= 10 * modes.eigenvalue_error[whirling])
vd.export_html(modes, "viewer_campbell.html")
