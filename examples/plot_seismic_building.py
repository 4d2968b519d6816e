"""
A shear building under a design spectrum and under a record
============================================================

The three-storey shear building of ``models/three_storey_building.toml`` (floors of 2000, 1500 and 1000 kg
at 3, 6 and 9 m; storey stiffnesses 6e5, 4e5 and 2e5 N/m) shaken along x by its ground, two ways:

1. **Response-spectrum analysis** (Chopra, *Dynamics of Structures*, ch. 13): each mode peaks at
   Γ_n φ_n S_a(T_n)/ω_n² and the peaks are combined by SRSS or CQC (Der Kiureghian's ρ_ij). The spectrum is
   Eurocode 8's elastic spectrum of type 1 (EN 1998-1, §3.2.2.2) on ground type C: S = 1.15, T_B = 0.2 s,
   T_C = 0.6 s, T_D = 2.0 s, for a design ground acceleration a_g = 0.25 g and 5 % damping (η = 1).
2. **A record**: a synthetic ground acceleration (filtered white noise under an envelope, seeded, scaled to a
   peak of 0.25 g, its baseline corrected so that the ground ends at rest), run through the building in time
   (the exact linear response, integrated through every sample) and turned into its own pseudo-acceleration
   spectrum (exact for the piecewise-linear record: Nigam & Jennings 1969) — the two methods on one building.

The checks: SRSS and CQC against the same sums written out here from numpy's ``eigh`` of the book's M and K;
each mode's peak in the time history against Γ_n S_d(T_n) from the record's spectrum.
"""

# %%
# The design spectrum and the response-spectrum analysis
# ------------------------------------------------------
import matplotlib.pyplot as plt
import numpy as np
import scipy.linalg

import vibdyn as vd

g = 9.80665
a_g, S, T_B, T_C, T_D, eta = 0.25 * g, 1.15, 0.2, 0.6, 2.0, 1.0


def ec8(T):
    """Eurocode 8 elastic spectrum, type 1, ground C (m/s²)."""
    if T <= T_B:
        return a_g * S * (1 + T / T_B * (2.5 * eta - 1))
    if T <= T_C:
        return 2.5 * a_g * S * eta
    if T <= T_D:
        return 2.5 * a_g * S * eta * T_C / T
    return 2.5 * a_g * S * eta * T_C * T_D / T ** 2


spectrum = vd.eurocode8(a_g, ground="C", spectrum_type=1, damping=0.05)  # the same, from vibdyn
print(spectrum.describe())
assert all(abs(spectrum(T) - ec8(T)) <= 1e-14 * ec8(T) for T in np.linspace(0.0, 4.0, 81))
modes = vd.load_scene("three_storey_building").build().operating_point().linearize(method="analytic").modes()
srss = modes.response_spectrum(ec8, (1, 0, 0), "srss", damping=0.05)
cqc = modes.response_spectrum(ec8, (1, 0, 0), "cqc", damping=0.05)
print(cqc)

# the same by hand: the book's M and K, numpy's eigh, the combinations written out
m = np.array([2000.0, 1500.0, 1000.0])
K = np.array([[1e6, -4e5, 0.0], [-4e5, 6e5, -2e5], [0.0, -2e5, 2e5]])
w2, Phi = scipy.linalg.eigh(K, np.diag(m))
w, Gamma = np.sqrt(w2), Phi.T @ m
U = Gamma * np.array([ec8(2 * np.pi / x) for x in w]) / w2 * Phi  # floors × modes
beta = w[None, :] / w[:, None]
rho = 8 * 0.05 ** 2 * (1 + beta) * beta ** 1.5 / ((1 - beta ** 2) ** 2 + 4 * 0.05 ** 2 * beta * (1 + beta) ** 2)
by_hand = {"srss": np.sqrt((U ** 2).sum(axis=1)), "cqc": np.sqrt(np.einsum("ki,ij,kj->k", U, rho, U))}
for r in (srss, cqc):
    ref = by_hand[r.combination]
    print(f"{r.combination.upper()}: floors {np.round(r.displacement * 1e3, 4)} mm (by hand "
          f"{np.round(ref * 1e3, 4)} mm), largest |Δ| {np.abs(r.displacement - ref).max():.1e} m, estimate "
          f"{r.displacement_error.max():.1e} m")
    assert np.all(np.abs(r.displacement - ref) <= r.displacement_error + 1e-12 * ref)
print(f"ρ_12 = {rho[0, 1]:.4f}, ρ_23 = {rho[1, 2]:.4f}: well-separated modes, so SRSS ≈ CQC "
      f"(roof {srss.displacement[2] * 1e3:.3f} against {cqc.displacement[2] * 1e3:.3f} mm)")
print(f"base shear {cqc.base_shear / 1e3:.3f} kN = storey 1's spring force "
      f"{cqc.spring_forces['storey1'] / 1e3:.3f} kN; "
      f"{cqc.modes_for_90} modes reach 90 % of the {cqc.mass:.0f} kg")

# %%
# One mode and the missing mass
# -----------------------------
# Keeping mode 1 alone misses 18.6 % of the mass; the missing-mass correction adds the rigid response of the
# modes left out (their periods are short: they follow the ground's peak acceleration S_a(0)).
one = modes.response_spectrum(ec8, (1, 0, 0), "srss", n_modes=1)
bare = modes.response_spectrum(ec8, (1, 0, 0), "srss", n_modes=1, missing_mass=False)
print(f"mode 1 alone: base shear {bare.base_shear / 1e3:.3f} kN; with the missing mass "
      f"({one.missing_mass:.1f} kg at {one.zpa:.3f} m/s²) {one.base_shear / 1e3:.3f} kN; all modes "
      f"{srss.base_shear / 1e3:.3f} kN")
fig_ec8 = cqc.plot(None, periods=np.linspace(0.0, 3.0, 301), g_units=True)

# %%
# A ground-motion record
# ----------------------
# Filtered white noise (a Kanai–Tajimi filter at 2.5 Hz, ζ_g = 0.6) under a build-up / strong-motion / decay
# envelope, 20 s at dt = 0.01 s, seeded; baseline corrected and scaled to a peak of 0.25 g.
rng = np.random.default_rng(42)
dt, n = 0.01, 2001
t = dt * np.arange(n)
wg, zg = 2 * np.pi * 2.5, 0.6
noise = rng.standard_normal(n)
x = np.zeros(2)
acc = np.zeros(n)
for k in range(1, n):  # the Kanai–Tajimi ground filter, semi-implicit steps (only the record's shape depends on it)
    x[1] += dt * (-noise[k] / np.sqrt(dt) - 2 * zg * wg * x[1] - wg * wg * x[0])
    x[0] += dt * x[1]
    acc[k] = -(2 * zg * wg * x[1] + wg * wg * x[0])
acc *= np.minimum(1.0, (t / 2.0) ** 2) * np.exp(-np.maximum(t - 8.0, 0.0) / 3.0)
acc -= np.trapezoid(acc, dx=dt) / (dt * (n - 1))  # the ground ends at rest
acc *= 0.25 * g / np.abs(acc).max()
record = vd.laws.Record(acc, dt=dt, direction=(1, 0, 0))
print(record, f"; ground velocity at the end {record.ground(t[-1])[1]:.1e} m/s")

periods = np.union1d(np.linspace(0.0, 3.0, 121), 2 * np.pi / modes.omega)
spec = record.pseudo_acceleration_spectrum(periods, damping=0.05)
print(spec)
by_record = modes.response_spectrum(spec, (1, 0, 0), "cqc", damping=0.05)

# %%
# The same record in time: the two methods on one building
# --------------------------------------------------------
# In the ground's frame the floors' drifts u obey M ü + C u̇ + K u = −M r a_g(t), r = 1 (a load on every floor):
# the exact linear response to it, with 5 % damping in every mode (the spectrum's), gives each mode's own
# time history q_n = φ_nᵀ M u(t), which peaks at Γ_n S_d(T_n), and the floors' true peaks, which the
# combination rule only estimates.
lin = modes.linear.with_modal_damping(0.05)
floors = ["floor1", "floor2", "floor3"]
times = np.arange(0.0, t[-1] + 4.0, 0.002)
th = lin.forced_response(times, lambda s: -m * record.ground(s)[2], floors)
um = lin.modes()
q = th.x @ (lin.M @ um.shapes)  # modal coordinates
print(" mode   T (s)    Γ S_d time history (mm)   from the spectrum (mm)   rel. diff.   sampling bound")
for r in range(3):
    peak_th = np.abs(q[:, r]).max() * abs(um.shapes[2, r])
    peak_rs = abs(by_record.modal_displacement[r, 2])
    bound = (um.omega[r] * 0.002) ** 2 / 2 + th.relative_error + spec.relative_error
    print(f"  {r + 1}   {2 * np.pi / um.omega[r]:.4f}   {peak_th * 1e3:12.6f}          {peak_rs * 1e3:12.6f}"
          f"         {abs(peak_th - peak_rs) / peak_rs:.1e}      {bound:.1e}")
    assert abs(peak_th - peak_rs) <= bound * peak_rs
roof_th = np.abs(th.x[:, 2]).max()
print(f"roof: time history {roof_th * 1e3:.3f} mm; CQC of the record's spectrum "
      f"{by_record.displacement[2] * 1e3:.3f} mm "
      f"({100 * (by_record.displacement[2] / roof_th - 1):+.1f} %: the rule's own departure, not an error of vibdyn's)")

# %%
# The record as the motion of a support
# -------------------------------------
# The same building with its first storey on a support that the record moves (``vd.laws.Record`` as a support's
# law: the ground's displacement and velocity are the record's exact integrals). Its absolute floor motions,
# taken relative to the ground, are the drifts above (undamped here, on the first 8 s): the support's spring
# input and the ground frame's inertial load are one physics.
shaken = vd.Scene("shaken_building")
shaken.add_support("ground", record)
for i, (mass, h) in enumerate(zip(m, (3.0, 6.0, 9.0))):
    shaken.add_body(f"floor{i + 1}", joint=vd.Slider((1, 0, 0), at=(0, 0, h)), mass=mass)
for i, (k, below) in enumerate(zip((6e5, 4e5, 2e5), ("ground", "floor1", "floor2"))):
    shaken.add_spring(f"storey{i + 1}", (below, (-10.0, 0.0, 3.0)), f"floor{i + 1}", stiffness=k, free_length=10.0)
moved = shaken.build().linearize(np.zeros(3), method="analytic")
short = times[times <= 8.0]
absolute = moved.forced_response(short, support="ground")
drift = absolute.x - np.array([record.ground(s)[0] for s in short])[:, None]
inertial = modes.linear.forced_response(short, lambda s: -m * record.ground(s)[2], floors)
gap = np.abs(drift - inertial.x).max()
print(f"support-driven against inertial load: largest difference {gap:.1e} m (estimates {absolute.error:.1e} + "
      f"{inertial.error:.1e} m)")
assert gap <= 10 * (absolute.error + inertial.error) + 1e-12

# %%
# Pictures
# --------
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
ax1.plot(t, acc / g)
ax1.set_xlabel("t (s)")
ax1.set_ylabel("ground acceleration (g)")
ax1.set_title("synthetic record (seed 42)")
ax2.plot(times, th.x[:, 2] * 1e3, label="roof, time history")
ax2.axhline(by_record.displacement[2] * 1e3, color="C1", ls="--", label="CQC peak")
ax2.axhline(-by_record.displacement[2] * 1e3, color="C1", ls="--")
ax2.set_xlabel("t (s)")
ax2.set_ylabel("roof drift from the ground (mm)")
ax2.legend(fontsize="small")
from vibdyn.faces.spectrum_plots import plot_response_spectrum  # noqa: E402

fig_spectra = plot_response_spectrum(None, spec, cqc, periods=np.linspace(0, 3, 301),
                                     labels=["record (5 %)", "Eurocode 8, type 1, ground C"], g_units=True)
vd.export_html(modes, "viewer_seismic_building.html")
