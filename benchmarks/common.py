"""What every benchmark module shares: run records and their verdicts, timing and memory, MuJoCo models.

A *case* is one problem with one reference (exact, or independent); a *run* is one solver at one setting on
it, one point of the case's work-precision diagram. Every run records its actual error against the
reference, vibdyn's error estimate (None for solvers that give none: MuJoCo, scipy), its best wall time,
the evaluations it made, its peak memory and a verdict.
"""

import math
import os
import platform
import resource
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

import vibdyn as vd

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
G = 9.81

# verdicts
RIGHT, REFUSED, WRONG, UNCHECKED, CRASHED = "right", "refused loudly", "silently wrong", "unchecked", "crashed"
# An error estimate is an estimate: "right" allows the actual error up to ESTIMATE_SLACK × the estimate
# (plus FLOOR, the round-off level of errors measured on quantities of order 1).
ESTIMATE_SLACK = 2.0
FLOOR = 1e-13


def verdict(error, estimate, reference_error=0.0):
    """"right" (finite error within ESTIMATE_SLACK × the estimate, plus FLOOR and the reference's own
    uncertainty ``reference_error``), "silently wrong", or "unchecked" when the solver gives no estimate
    (MuJoCo, scipy)."""
    if estimate is None:
        return UNCHECKED
    if error is None or not math.isfinite(error) or not math.isfinite(estimate):
        return WRONG if error is None or not math.isfinite(error) else RIGHT
    return RIGHT if error <= ESTIMATE_SLACK * estimate + FLOOR + reference_error else WRONG


def run_record(label, solver, error, estimate, time_s, evaluations=None, peak_mb=None, verdict_=None,
               reference_error=0.0, **extra):
    """One run (one point of a work-precision diagram); ``reference_error``: the reference's own uncertainty,
    in the error's unit (an actual error below it says nothing about the estimate)."""
    r = {"label": label, "solver": solver, "error": _num(error), "estimate": _num(estimate), "time_s": time_s,
         "evaluations": None if evaluations is None else int(evaluations), "peak_mb": peak_mb,
         "verdict": verdict_ or verdict(_num(error), _num(estimate), reference_error)}
    r.update(extra)
    return r


def refused(label, solver, exc, time_s, **extra):
    """A run that ended with an exception: a vibdyn error is "refused loudly", anything else "crashed"."""
    loud = isinstance(exc, vd.VibdynError)
    msg = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"[:300]
    return run_record(label, solver, None, None, time_s, verdict_=REFUSED if loud else CRASHED, message=msg, **extra)


def case_record(name, group, reference, runs, unit="", **extra):
    c = {"name": name, "group": group, "reference": reference, "unit": unit, "runs": runs,
         "verdict": case_verdict(runs), "process_peak_mb": process_peak_mb()}
    c.update(extra)
    return c


def case_verdict(runs):
    """The worst verdict of the case's vibdyn runs (MuJoCo and scipy runs are context)."""
    own = [r["verdict"] for r in runs if r["solver"] == "vibdyn"]
    for v in (CRASHED, WRONG, REFUSED, RIGHT):
        if v in own:
            return v
    return UNCHECKED


def _num(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else (None if math.isnan(x) else x)


# ------------------------------------------------------------------------------------------- measuring
class Settings:
    """What a mode ("smoke", "quick", "full") asks of every module: timing repeats and extent."""

    def __init__(self, mode):
        self.mode = mode
        self.smoke, self.quick, self.full = mode == "smoke", mode == "quick", mode == "full"
        self.repeat = {"smoke": 1, "quick": 3, "full": 7}[mode]


def measure(fn, repeat=1, memory=True):
    """Best wall time of ``repeat`` calls of ``fn`` after a first, warm-up call (runs longer than
    REPEAT_MAX_S are not repeated: their first call is the time), then, for runs shorter than
    MEMORY_MAX_S, one more call under tracemalloc for the peak Python/numpy allocation (MB; Pinocchio's C++
    allocations are not seen; tracemalloc slows Python-heavy code several times, so that call is never
    timed).
    Returns (result of the last call, best time in s, peak MB or None). Exceptions propagate."""
    t = time.perf_counter()
    out = fn()
    best = first = time.perf_counter() - t
    if first < REPEAT_MAX_S:  # the first call was a warm-up (imports, caches): time fresh ones
        best = math.inf
        for _ in range(repeat):
            t = time.perf_counter()
            out = fn()
            best = min(best, time.perf_counter() - t)
    peak = None
    if memory and best < MEMORY_MAX_S:
        tracemalloc.start()
        try:
            fn()
            peak = tracemalloc.get_traced_memory()[1] / 2**20
        finally:
            tracemalloc.stop()
    return out, best, peak


REPEAT_MAX_S = 0.5
MEMORY_MAX_S = 1.0


def process_peak_mb():
    """Peak resident memory of this process so far (MB, ru_maxrss)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def machine():
    import scipy

    info = {"platform": platform.platform(), "processor": platform.processor(), "cpus": os.cpu_count(),
            "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
            "pinocchio": __import__("pinocchio").__version__, "vibdyn": vd.__version__,
            "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
            "loadavg": list(os.getloadavg()) if hasattr(os, "getloadavg") else None}
    try:
        import mujoco

        info["mujoco"] = mujoco.__version__
    except ImportError:
        info["mujoco"] = None
    return info


def time_at_error(runs, error, key="time_s"):
    """Wall time (``key``: "time_s", or "solution_time_s" without vibdyn's error estimate) a solver's runs
    would need to reach ``error``: log-log interpolation along its work-precision curve (runs sorted by
    error); None outside the measured range."""
    pts = sorted((r["error"], r.get(key) or r["time_s"]) for r in runs
                 if r.get("error") and r["error"] > 0 and r.get("time_s"))
    if len(pts) < 2 or not pts[0][0] <= error <= pts[-1][0]:
        exact = [t for e, t in pts if e == error]
        return exact[0] if exact else None
    le = np.log([p[0] for p in pts])
    lt = np.log([p[1] for p in pts])
    # keep the Pareto front (time falls as error grows) so that the interpolation is monotone
    keep = [0]
    for i in range(1, len(pts)):
        if lt[i] < lt[keep[-1]]:
            keep.append(i)
    if len(keep) < 2:
        return float(np.exp(lt[keep[0]]))
    return float(np.exp(np.interp(np.log(error), le[keep], lt[keep])))


# ------------------------------------------------------------------------------------------- MuJoCo
def mujoco():
    """The mujoco module, or None (the MuJoCo runs are then skipped, and said so)."""
    try:
        import mujoco as mj

        return mj
    except ImportError:
        return None


def _oracles():
    """tests/oracles.py: the Scene → MJCF writer and coordinate maps shared with the MuJoCo tests."""
    tests = str(ROOT / "tests")
    if tests not in sys.path:
        sys.path.insert(0, tests)
    import oracles

    return oracles


def with_min_inertia(scene, eps=1e-12):
    return _oracles().with_min_inertia(scene, eps)


class MuJoCoSim:
    """The same scene in MuJoCo (joint springs and dampers included) with a given integrator and step, its
    own MjData, and the maps of (q, v) both ways (pivots, sliders and ball joints)."""

    def __init__(self, scene, system, integrator="RK4", dt=1e-3):
        mj = mujoco()
        oracle = _oracles().MuJoCoOracle(scene, system, joint_elements=True)
        xml = oracle.xml.replace('integrator="RK4"', f'integrator="{integrator}" timestep="{dt!r}"')
        self.mj, self.system, self.oracle = mj, system, oracle
        self.model = mj.MjModel.from_xml_string(xml)
        oracle.model, oracle.data = self.model, mj.MjData(self.model)
        self.data = oracle.data

    def run(self, q0, v0, n):
        """n steps from (q0, v0); returns vibdyn's q, v at the end."""
        mj = self.mj
        mj.mj_resetData(self.model, self.data)
        self.oracle.set_state(q0, v0)
        mj.mj_step(self.model, self.data, nstep=n)
        return self.state()

    def state(self):
        m, d, system = self.model, self.data, self.system
        q = system.neutral().copy()
        for info, ids in self.oracle.joints:
            a = m.jnt_qposadr[ids[0]]
            if info.joint.type == "ball":
                w, x, y, z = d.qpos[a:a + 4]
                q[info.idx_q:info.idx_q + 4] = np.array([x, y, z, w]) / math.sqrt(w * w + x * x + y * y + z * z)
            elif info.joint.type in ("pivot", "slider"):
                q[info.idx_q] = d.qpos[a]
            else:
                raise ValueError(f"MuJoCoSim: {info.joint.type} joints are not mapped back")
        v = np.asarray(d.qvel)[self.oracle.dof].copy()
        return q, v
