"""Linearisation + all modes against chain length, beside MuJoCo, and the FD step V-curve.

The scene is bench_linearize's hanging pendulum chain (n pivots about y, links 0.1 m, 0.1 kg, torsion
springs 10 N·m/rad), linearised about its equilibrium, the neutral configuration. Its exact M and K are
closed forms (:func:`exact_chain`), so every path is compared with the exact natural frequencies:

- vibdyn FD and analytic: ``system.linearize(q0, method=...)`` then ``.modes()``, timed together;
- MuJoCo ``mjd_transitionFD`` (centred differences, Euler integrator, step dt) + ``eigvals`` of the discrete
  A: ω = |log λ| / dt (error ≈ (ω dt)²/24 from the discretisation itself);
- MuJoCo ``mjd_inverseFD`` (one-sided) for K, its DfDa for M, + ``eigh(K, M)``.

Error: largest relative error of the natural frequencies over the modes. vibdyn's estimate: ``modes.relative_error``.
"""

import functools
import json
from pathlib import Path

import numpy as np
import scipy.linalg as sla

from . import common as C
from .bench_linearize import pendulum_chain

K_SPRING, L, MASS = 10.0, 0.1, 0.1
MJ_DT = 1e-5  # MuJoCo transition step: its own discretisation error (ω dt)²/24 stays below the FD error


REFERENCE_NOTE = ("The exact M and K eigen-solved in 40-digit arithmetic (benchmarks/chain_reference.py): the "
                  "errors are vibdyn's own (a double-precision reference was itself 2.6e-9 off at n = 100)")


def exact_chain(n, k=K_SPRING, link=L, m=MASS, number=float):
    """Exact M and K (hanging, straight) of :func:`pendulum_chain`: joint i at depth i·L, centre of mass of
    link l at d_l = (l + ½) L, I_yy = m (0.02² + L²)/12. M_ij = Σ_{l ≥ max(i,j)} m (d_l − iL)(d_l − jL) + I_yy;
    K_ij = k δ_ij + g Σ_{l ≥ max(i,j)} m (d_l − max(i,j) L) (the height's Hessian is the lever arm below the
    lower joint). ``number``: float (double precision), or a multiple-precision type such as mpmath's mpf
    (the inputs, floats, taken exactly: object arrays)."""
    i = np.arange(n)
    dtype = float if number is float else object
    k, link, m, g = number(k), number(link), number(m), number(C.G)
    d = np.array([(j + number(0.5)) * link for j in range(n)], dtype=dtype)
    Iyy = m * (number(0.02) ** 2 + link ** 2) / 12
    M, K = np.full((n, n), number(0), dtype=dtype), np.full((n, n), number(0), dtype=dtype)
    K[i, i] = k
    for l_ in range(n):
        r = d[l_] - i[: l_ + 1] * link
        M[: l_ + 1, : l_ + 1] += m * np.outer(r, r) + Iyy
        mx = np.maximum.outer(i[: l_ + 1], i[: l_ + 1])
        K[: l_ + 1, : l_ + 1] += g * m * (d[l_] - mx * link)
    return M, K


REFERENCE = Path(__file__).parent / "data" / "chain_omega.json"  # ω of the chains in 40 digits (chain_reference.py)


@functools.cache
def exact_omega(n):
    """The chain's natural frequencies (rad/s, ascending): those solved in 40-digit arithmetic from the exact
    M and K where :mod:`benchmarks.chain_reference` stored them (n = 10, 30, 100, 300), else eigh in double
    precision (whose own round-off reaches 2.6e-9 at n = 100: of the size of the errors measured)."""
    stored = json.loads(REFERENCE.read_text())["omega"] if REFERENCE.exists() else {}
    if str(n) in stored:
        return np.array([float(w) for w in stored[str(n)]])
    M, K = exact_chain(n)
    return np.sqrt(sla.eigh(K, M, eigvals_only=True))


def omega_error(omega, ref):
    return float(np.max(np.abs(np.sort(omega) - ref) / ref))


def lin_modes(system, q0, method, step=None):
    kw = {"step": step} if step is not None else {}
    lin = system.linearize(q0, method=method, **kw)
    return lin, lin.modes()


def vibdyn_run(system, q0, method, ref, S, step=None, label=None, repeat=None):
    (lin, m), t, peak = C.measure(lambda: lin_modes(system, q0, method, step), repeat or S.repeat)
    return C.run_record(label or f"vibdyn {method}", "vibdyn", omega_error(m.omega, ref), m.relative_error, t,
                        lin.evaluations, peak, method=method, lin_error=lin.relative_error, step=step)


class MuJoCoLinear:
    """The chain in MuJoCo at its neutral configuration, one MjData per path."""

    def __init__(self, scene, system):
        mj = C.mujoco()
        self.mj = mj
        sim = C.MuJoCoSim(scene, system, "Euler", MJ_DT)
        self.model, self.nv = sim.model, sim.model.nv
        self.d_tr, self.d_inv = mj.MjData(self.model), mj.MjData(self.model)

    def transition(self):
        mj, m, d, nv = self.mj, self.model, self.d_tr, self.nv
        mj.mj_resetData(m, d)
        mj.mj_forward(m, d)
        A = np.zeros((2 * nv, 2 * nv))
        mj.mjd_transitionFD(m, d, 1e-6, True, A, None, None, None)
        lam = np.log(np.linalg.eigvals(A).astype(complex)) / m.opt.timestep
        w = np.abs(lam[lam.imag > 0])
        return np.sort(w)

    def inverse(self):
        mj, m, d, nv = self.mj, self.model, self.d_inv, self.nv
        mj.mj_resetData(m, d)
        mj.mj_forward(m, d)
        d.qacc[:] = 0.0
        DfDq, DfDa = np.zeros((nv, nv)), np.zeros((nv, nv))
        mj.mjd_inverseFD(m, d, 1e-6, False, DfDq, None, DfDa, None, None, None, None)
        K = 0.5 * (DfDq + DfDq.T)
        return np.sqrt(np.abs(sla.eigh(K, 0.5 * (DfDa + DfDa.T), eigvals_only=True)))


def mujoco_runs(scene, system, ref, S, repeat=None):
    if C.mujoco() is None:
        return []
    mjl = MuJoCoLinear(scene, system)
    runs = []
    for label, fn, evals in ((f"mujoco transitionFD (centred, dt={MJ_DT:g}) + eig", mjl.transition, 4 * system.nv + 1),
                             ("mujoco inverseFD + eigh", mjl.inverse, 2 * system.nv + 1)):
        w, t, peak = C.measure(fn, repeat or S.repeat)
        err = omega_error(w, ref) if len(w) == len(ref) else None
        runs.append(C.run_record(label, "mujoco", err, None, t, evals, peak, method=label.split()[1],
                                 **({} if err is not None else {"note": f"{len(w)} of {len(ref)} modes"})))
    return runs


def chain_case(n, S):
    scene = pendulum_chain(n, k=K_SPRING, L=L, m=MASS)
    system = scene.build()
    q0 = system.neutral()
    ref = exact_omega(n)
    runs = [vibdyn_run(system, q0, "fd", ref, S), vibdyn_run(system, q0, "analytic", ref, S)]
    runs += mujoco_runs(scene, system, ref, S)
    case = C.case_record(f"chain n={n}: linearise + all modes", "linearization", "exact M, K (closed form) + eigh",
                         runs, n=n, note=REFERENCE_NOTE)
    mj = next((r for r in runs if r.get("method") == "transitionFD"), None)
    if mj:
        for r in runs:
            if r["solver"] == "vibdyn":
                r["ratio_to_transitionFD"] = r["time_s"] / mj["time_s"]
        case["ratio_to_mujoco"] = runs[0]["time_s"] / mj["time_s"]
        case["ratio_note"] = (f"FD / transitionFD; analytic {runs[1]['ratio_to_transitionFD']:.2f}")
    return case


def vcurve_case(S):
    """FD step sweep: the error of K against the exact K (truncation ∝ h², round-off ∝ 1/h), with vibdyn's
    estimate ``lin.relative_error``; the frequency error is recorded beside (``omega_error``)."""
    n = 100
    system = pendulum_chain(n, k=K_SPRING, L=L, m=MASS).build()
    q0 = system.neutral()
    _, K_exact = exact_chain(n)
    ref = exact_omega(n)
    # smoke: truncation-dominated steps only (round-off-dominated errors vary between machines)
    steps = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9] if not S.smoke else [1e-3, 1e-4, 1e-5]
    runs = []
    for h in steps + [None]:
        method = "fd" if h else "analytic"
        (lin, m), t, peak = C.measure(lambda: lin_modes(system, q0, method, h), 1)
        err = float(np.abs(lin.K - K_exact).max() / np.abs(K_exact).max())
        runs.append(C.run_record(f"vibdyn fd step={h:g}" if h else "vibdyn analytic", "vibdyn", err,
                                 lin.relative_error, t, lin.evaluations, peak, method=method, step=h,
                                 omega_error=omega_error(m.omega, ref), omega_estimate=m.relative_error))
    return C.case_record(f"FD step V-curve (chain n={n})", "linearization", "exact K (closed form)", runs,
                         x="step", unit="relative, K")


def run(S):
    sizes = [10] if S.smoke else [10, 30, 100] if S.quick else [10, 30, 100, 300]
    return [chain_case(n, S) for n in sizes] + [vcurve_case(S)]
