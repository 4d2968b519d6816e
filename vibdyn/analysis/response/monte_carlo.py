"""Monte Carlo in time: sample paths of a support's random motion through the nonlinear ``simulate`` and the
linear ``forced_response``, with the statistics' sampling error."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..._check import integer, scalar, unit_axis
from ...description.psd import ORDER, PSD
from ...errors import ModelError
from .random import QUANTITIES


@dataclass(frozen=True, eq=False)
class MonteCarlo:
    """Time-domain statistics of coordinates under ``samples`` sample paths of a random support motion.

    ``variance[model][q]`` (model "linear" or "nonlinear", q = 0, 1, 2: displacement, velocity, acceleration):
    per sample and coordinate, the variance over time after ``settle`` s (about the time mean), shape
    (samples × n_out). :meth:`rms` averages the samples; :meth:`rms_error` is its sampling error (one standard
    deviation of the mean square across samples / √samples, mapped to the RMS), which dwarfs the integrators'.
    """

    outputs: tuple
    units: tuple
    samples: int
    duration: float
    settle: float
    seed: int | None
    variance: dict = field(repr=False)
    integrator_error: dict = field(repr=False)  # largest displacement error estimate per model (m or rad)
    elapsed: float = 0.0

    def __repr__(self):
        from ..._format import duration, summary, values

        rms = (f"{m} displacement RMS {values(self.rms('displacement', m))}" for m in self.variance)
        return summary("MonteCarlo", f"{self.samples} samples of {self.duration:g} s", *rms, duration(self.elapsed))

    def _pick(self, quantity, model):
        if quantity not in QUANTITIES:
            raise ModelError(f"Monte Carlo: unknown quantity {quantity!r} (one of {', '.join(QUANTITIES)})")
        if model not in self.variance:
            raise ModelError(f"Monte Carlo: no {model!r} runs (ran: {', '.join(self.variance)})")
        return self.variance[model][QUANTITIES.index(quantity)]

    def rms(self, quantity: str = "displacement", model: str = "nonlinear") -> np.ndarray:
        """RMS per output over the samples (SI)."""
        return np.sqrt(self._pick(quantity, model).mean(axis=0))

    def rms_error(self, quantity: str = "displacement", model: str = "nonlinear") -> np.ndarray:
        """Sampling error (one standard deviation) of :meth:`rms` per output (SI)."""
        v = self._pick(quantity, model)
        if self.samples < 2:
            raise ModelError("Monte Carlo: the sampling error needs at least 2 samples")
        err_ms = v.std(axis=0, ddof=1) / math.sqrt(self.samples)
        r = np.sqrt(v.mean(axis=0))
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(r > 0, err_ms / (2 * r), np.sqrt(err_ms))

    def difference(self, quantity: str = "displacement") -> tuple:
        """(nonlinear RMS − linear RMS, its sampling error) per output (SI): both models ran on the same sample
        paths, so the error comes from the spread of the paired differences of mean squares (far smaller than
        either RMS's own sampling error)."""
        a, b = self._pick(quantity, "nonlinear"), self._pick(quantity, "linear")
        if self.samples < 2:
            raise ModelError("Monte Carlo: the sampling error needs at least 2 samples")
        ra, rb = np.sqrt(a.mean(axis=0)), np.sqrt(b.mean(axis=0))
        err = (a - b).std(axis=0, ddof=1) / math.sqrt(self.samples) / np.maximum(ra + rb, 1e-300)
        return ra - rb, err

    def ratio(self, quantity: str = "displacement") -> tuple:
        """(mean over the samples of nonlinear RMS / linear RMS, its sampling error) per output: each sample path
        drove both models, so the ratio cancels most of the path-to-path spread of either RMS."""
        a, b = self._pick(quantity, "nonlinear"), self._pick(quantity, "linear")
        if self.samples < 2:
            raise ModelError("Monte Carlo: the sampling error needs at least 2 samples")
        with np.errstate(divide="ignore", invalid="ignore"):
            q = np.sqrt(a / b)
        if not np.all(np.isfinite(q)):
            raise ModelError("Monte Carlo: a linear RMS is zero (an output the input does not reach): no ratio")
        return q.mean(axis=0), q.std(axis=0, ddof=1) / math.sqrt(self.samples)

    def to_dict(self) -> dict:
        out = {"outputs": list(self.outputs), "units": list(self.units), "samples": self.samples,
               "duration_s": self.duration, "settle_s": self.settle, "seed": self.seed, "elapsed_s": self.elapsed}
        for m in self.variance:
            for q in QUANTITIES:
                out[f"{m}_{q}_rms"] = self.rms(q, m).tolist()
                out[f"{m}_{q}_rms_sampling_error"] = self.rms_error(q, m).tolist()
        return out


def monte_carlo(lin: Any, psd: PSD, support: str, direction: Any, outputs: Any = None, *, duration: float,
                samples: int = 8, seed: int | None = 0, settle: float | None = None, dt: float | None = None,
                f_max: float | None = None, models: Any = ("linear", "nonlinear"), rtol: float = 1e-6) -> MonteCarlo:
    """Monte Carlo in time for a support moving along ``direction`` (world axes) with the motion PSD ``psd``
    (:class:`MonteCarlo`): ``samples`` seeded sample paths (:meth:`vibdyn.PSD.sample`, period ``duration`` s,
    up to ``f_max`` Hz), each run from the operating point of ``lin`` for ``settle`` + ``duration`` s
    (``settle`` default: five time constants of the least damped mode) through the nonlinear
    :func:`vibdyn.simulate` (the scene with the support's motion replaced; dop853 at ``rtol``: the sampling
    error dominates) and the linear :func:`forced_response`; statistics over the last ``duration`` s at steps
    ``dt`` (default 1/(20 f_max)). ``outputs``: coordinate names (None: all)."""
    start = time.perf_counter()
    system = lin.system
    if not isinstance(psd, PSD) or ORDER[psd.quantity] is None:
        raise ModelError(f"Monte Carlo: expected a motion PSD (displacement, velocity or acceleration) for support "
                         f"'{support}', got {psd!r}")
    if support not in system.support_index:
        raise ModelError(f"Monte Carlo: '{support}' is not a support of the scene (supports: "
                         f"{', '.join(s.name for s in system.supports) or 'none'})")
    d = unit_axis(direction, f"Monte Carlo: support '{support}' direction")
    n = integer(samples, "Monte Carlo samples", minimum=1)
    T = scalar(duration, "Monte Carlo duration (s)", positive=True)
    bad = [m for m in models if m not in ("linear", "nonlinear")]
    if bad or not models:
        raise ModelError(f"Monte Carlo: models must be among 'linear', 'nonlinear', got {models!r}")
    names = list(lin.coordinates) if outputs is None else [outputs] if isinstance(outputs, str) else list(outputs)
    idx = [lin.coordinate_index(c) for c in names]
    top = psd.band[1] if f_max is None else min(psd.band[1], scalar(f_max, "Monte Carlo f_max (Hz)", positive=True))
    if not math.isfinite(top):
        raise ModelError("Monte Carlo: the PSD's band reaches infinity: give f_max (Hz)")
    if settle is None:
        m = lin.modes()
        rate = np.abs(m.damped_eigenvalues.real)
        rate = rate[rate > 0]
        if not rate.size:
            raise ModelError("Monte Carlo: no damped mode: give settle= (s), the time to discard")
        settle = 5.0 / rate.min()
    settle = scalar(settle, "Monte Carlo settle (s)", nonnegative=True)
    step = 1.0 / (20 * top) if dt is None else scalar(dt, "Monte Carlo dt (s)", positive=True)
    t = np.arange(0.0, settle + T + 0.5 * step, step)
    keep = t >= settle
    seeds = np.random.SeedSequence(seed).spawn(n)
    var = {m: np.zeros((3, n, len(idx))) for m in models}
    err = {m: 0.0 for m in models}
    for i, ss in enumerate(seeds):
        sig = psd.sample(T, seed=int(np.random.default_rng(ss).integers(2 ** 63)), f_max=top)
        pos = lambda s, sig=sig: d * float(sig.displacement(s))  # noqa: E731
        vel = lambda s, sig=sig: d * float(sig.velocity(s))  # noqa: E731
        for model in models:
            if model == "linear":
                r = lin.forced_response(t, support=support, motion=_Motion(pos, vel))
                x, v, a, e = r.x, r.v, r.a, r.error
            else:
                x, v, a, e = _nonlinear(lin, support, pos, vel, t, rtol)
            err[model] = max(err[model], float(np.max(e)) if np.size(e) else 0.0)
            for q, y in enumerate((x, v, a)):
                var[model][q, i] = y[keep][:, idx].var(axis=0)
    return MonteCarlo(tuple(names), tuple(lin.units[j] for j in idx), n, T, settle, seed, var, err,
                      time.perf_counter() - start)


@dataclass(frozen=True)
class _Motion:
    position: object
    velocity: object


def _nonlinear(lin, support, pos, vel, t, rtol):
    """(δq, δv, accelerations, error) of the nonlinear scene with the support moving as (pos, vel) from the
    operating point."""
    from ...description.laws import Motion

    scene = lin.system.scene.copy()
    scene.elements[support] = replace(scene.elements[support], motion=Motion(pos, vel))
    system = scene.build()
    traj = system.simulate(t[-1], q0=lin.q, v0=lin.v, t0=t[0], t_eval=t, rtol=rtol)
    x = np.array([system.difference(lin.q, q) for q in traj.q])
    a = np.array([system.accelerations(q, v, s) for q, v, s in zip(traj.q, traj.v, traj.t)])
    return x, traj.v - lin.v, a, traj.q_error
