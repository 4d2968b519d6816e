"""Parameter studies: sweeps over a grid or a sample of parameters, run serially, on a local process pool,
on any ``concurrent.futures.Executor`` or on a Dask cluster — the same numbers, bit for bit — with modes
tracked by MAC from point to point, resumable stores and Monte Carlo statistics.

A point is ``build(**parameters)`` (a :class:`Scene` or a :class:`System`) followed by an analysis:
"modes" (static equilibrium or the scene's operating point, linearisation, modes), "equilibrium", or a
callable ``f(system) -> dict`` of numbers. ``build`` and the callable must be importable module-level
functions when the work goes to other processes (they are pickled by reference).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError

ANALYSES = ("modes", "equilibrium", "campbell")


# ------------------------------------------------------------------------------------------ samples
@dataclass(frozen=True, eq=False)
class Samples:
    """A table of parameter samples: ``values[name]`` arrays of equal length ``n`` (from :func:`sample`)."""

    values: dict
    method: str
    seed: Any = None

    @property
    def n(self) -> int:
        return len(next(iter(self.values.values())))

    def points(self) -> list[dict]:
        names = list(self.values)
        return [{k: float(self.values[k][i]) for k in names} for i in range(self.n)]

    def __repr__(self) -> str:
        return f"Samples({self.n} points of {', '.join(self.values)}, {self.method}, seed {self.seed})"


def sample(distributions: dict, n: int, method: str = "lhs", seed: Any = None) -> Samples:
    """``n`` samples of independent parameters, each a ``scipy.stats`` frozen distribution (anything with a
    ``ppf``): ``method`` "lhs" (Latin hypercube), "sobol" (scrambled Sobol' points; n a power of 2 is best)
    or "random" (plain Monte Carlo), all through ``scipy.stats.qmc`` / numpy with ``seed``."""
    from scipy.stats import qmc

    if not isinstance(distributions, dict) or not distributions:
        raise ModelError("sample: distributions must be a non-empty dict {name: scipy.stats distribution}")
    for name, d in distributions.items():
        if not hasattr(d, "ppf"):
            raise ModelError(f"sample: '{name}' is not a distribution (needs a ppf, e.g. scipy.stats.uniform(a, b))")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ModelError(f"sample: n must be a positive integer, got {n!r}")
    d = len(distributions)
    if method == "lhs":
        u = qmc.LatinHypercube(d=d, seed=seed).random(n)
    elif method == "sobol":
        u = qmc.Sobol(d=d, scramble=True, seed=seed).random(n)
    elif method == "random":
        u = np.random.default_rng(seed).random((n, d))
    else:
        raise ModelError(f"sample: method must be 'lhs', 'sobol' or 'random', got {method!r}")
    values = {name: np.asarray(dist.ppf(u[:, k]), dtype=float) for k, (name, dist) in enumerate(distributions.items())}
    for name, v in values.items():
        if not np.all(np.isfinite(v)):
            raise ModelError(f"sample: distribution of '{name}' gave non-finite values (unbounded support?)")
    return Samples(values, method, seed)


# ------------------------------------------------------------------------------------------ one point
def evaluate(build: Callable, point: dict, analysis, options: dict | None = None) -> dict:
    """One point of a sweep: its outputs (numbers and arrays as lists), error estimate, elapsed time (s)
    and status ("ok" or "failed: message"). Never raises for a failing point."""
    start = time.perf_counter()
    try:
        obj = build(**point)
        system = obj.build() if hasattr(obj, "build") and not hasattr(obj, "linearize") else obj
        if not hasattr(system, "linearize"):
            raise ModelError(f"sweep: build(**point) returned {type(obj).__name__}, not a Scene or System")
        out = _analyse(system, analysis, options or {})
        status = "ok"
    except Exception as e:  # noqa: BLE001 — any failure of one point (a user's build too) is that point's record
        out, status = {}, f"failed: {type(e).__name__}: {e}"
    return {"outputs": out, "elapsed": time.perf_counter() - start, "status": status}


def _analyse(system, analysis, options) -> dict:
    if callable(analysis):
        res = analysis(system)
        if not isinstance(res, dict):
            raise ModelError(f"sweep: the analysis returned {type(res).__name__}, not a dict of numbers")
        return {k: _plain(v, k) for k, v in res.items()}
    if analysis == "equilibrium":
        eq = system.operating_point()
        return {"q": eq.q.tolist(), "residual": float(eq.residual), "stability": eq.stability,
                "error": float(np.max(eq.q_error, initial=0.0)) if eq.q_error is not None else float(eq.residual)}
    if analysis == "campbell":
        from ..analysis.campbell_diagram import campbell

        if "spin" not in options or "speeds" not in options:
            raise ModelError("sweep: analysis 'campbell' needs options={'spin': NAME, 'speeds': [...], 'orders': (1,)}")
        c = campbell(system, options["spin"], options["speeds"], options.get("orders", (1,)),
                     method=options.get("method", "analytic"))
        crit = [k for o in c.orders for k in c.critical_speeds(o)]
        return {"critical_speeds": [k.speed for k in crit], "omega": c.omega.ravel().tolist(),
                "error": float(c.error.max(initial=0.0))}
    if analysis == "modes":
        m = system.operating_point().linearize().modes()
        return {"omega": m.omega.tolist(), "zeta": m.zeta.tolist() if m.zeta.size else [0.0] * m.n,
                "rigid": m.rigid.tolist(), "stability": m.stability, "relative_error": m.relative_error,
                "omega_error": m.omega_error.tolist(),
                "shapes": m.shapes.tolist()}
    raise ModelError(f"sweep: analysis must be one of {ANALYSES} or a callable(system) -> dict, got {analysis!r}")


def _plain(v, name):
    a = np.asarray(v)
    if a.dtype.kind not in "biuf":
        raise ModelError(f"sweep: output '{name}' is not numeric ({type(v).__name__})")
    return a.tolist() if a.ndim else a.item()


def _chunk(build, points, analysis, options=None):  # module level: picklable for process pools and Dask
    return [evaluate(build, p, analysis, options) for p in points]


# ------------------------------------------------------------------------------------------ the sweep
@dataclass(frozen=True, eq=False)
class Sweep:
    """Results of :func:`sweep`: ``parameters`` (list of dicts), ``results`` (per point: ``outputs``,
    ``elapsed`` s, ``status``), ``elapsed`` (wall time of the whole sweep, s), ``executor`` (its kind)."""

    parameters: list
    results: list
    analysis: str
    executor: str
    elapsed: float
    names: tuple = field(default=())

    @property
    def n(self) -> int:
        return len(self.parameters)

    @property
    def ok(self) -> np.ndarray:
        return np.array([r["status"] == "ok" for r in self.results])

    def values(self, output: str) -> np.ndarray:
        """One output at every point (NaN-free: failed points are left out; see :attr:`ok`)."""
        rows = [r["outputs"][output] for r in self.results if r["status"] == "ok"]
        if not rows:
            raise ModelError(f"sweep: no point succeeded, so there is no '{output}'")
        if output not in self.results[int(np.argmax(self.ok))]["outputs"]:
            raise ModelError(f"sweep: unknown output '{output}'; outputs: {sorted(self.results[0]['outputs'])}")
        return np.array(rows)

    def rows(self) -> list[dict]:
        """One flat dict per point: parameters, scalar outputs (arrays as name_0, name_1, …), elapsed_s,
        status. Mode shapes are left out (see :meth:`tracked`)."""
        out = []
        for p, r in zip(self.parameters, self.results):
            row = dict(p)
            for k, v in r["outputs"].items():
                if k == "shapes":
                    continue
                if isinstance(v, list):
                    row.update({f"{k}_{i}": x for i, x in enumerate(np.ravel(v))})
                else:
                    row[k] = v
            row["elapsed_s"] = r["elapsed"]
            row["status"] = r["status"]
            out.append(row)
        return out

    def to_pandas(self) -> Any:
        """The table as a pandas DataFrame (needs pandas)."""
        try:
            import pandas as pd
        except ImportError:
            raise ModelError("to_pandas needs pandas: pip install pandas") from None
        return pd.DataFrame(self.rows())

    def to_csv(self, path: str | Path) -> Path:
        import csv

        rows = self.rows()
        keys = list(dict.fromkeys(k for r in rows for k in r))
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=keys)
            w.writeheader()
            w.writerows(rows)
        return Path(path)

    def to_parquet(self, path: str | Path) -> Path:
        """The table as a Parquet file (needs pandas and pyarrow)."""
        self.to_pandas().to_parquet(path)
        return Path(path)

    def tracked(self, output: str = "omega") -> "Tracked":
        """``output`` (one value per mode) with its columns ordered so that each follows one mode from point
        to point, by MAC between neighbouring points' shapes (points in the order of the sweep)."""
        if self.analysis != "modes":
            raise ModelError("tracked: needs a sweep with analysis='modes' (mode shapes)")
        if not self.ok.all():
            raise ModelError(f"tracked: {int((~self.ok).sum())} points failed; tracking needs every point")
        vals = self.values(output)
        shapes = [np.array(r["outputs"]["shapes"]) for r in self.results]
        return track(vals, shapes)

    def quantiles(self, output: str, q: ArrayLike) -> "Statistic":
        """Quantiles of an output over the sample (per component for array outputs), with their Monte Carlo
        standard errors (distribution-free, from the order statistics around each quantile)."""
        x = np.sort(self.values(output), axis=0)
        n = x.shape[0]
        q = np.atleast_1d(np.asarray(q, dtype=float))
        if np.any((q <= 0) | (q >= 1)):
            raise ModelError(f"quantiles: q must lie in (0, 1), got {q}")
        est = np.quantile(x, q, axis=0)
        half = np.sqrt(n * q * (1 - q))
        lo = np.clip(np.floor(n * q - half).astype(int), 0, n - 1)
        hi = np.clip(np.ceil(n * q + half).astype(int), 0, n - 1)
        se = 0.5 * (x[hi] - x[lo])
        return Statistic(est, se, n)

    def probability(self, event: Callable[[dict], bool]) -> "Statistic":
        """Probability of ``event(row)`` (a row of :meth:`rows`, failed points counted as not the event),
        with the Monte Carlo standard error √(p(1−p)/n)."""
        hits = np.array([bool(event(r)) if r["status"] == "ok" else False for r in self.rows()])
        p = hits.mean()
        return Statistic(np.array(p), np.array(math.sqrt(p * (1 - p) / len(hits))), len(hits))

    def __repr__(self) -> str:
        bad = int((~self.ok).sum())
        return (f"Sweep({self.n} points of {', '.join(self.names)}, {self.analysis}, {self.executor}, "
                f"{bad} failed, {self.elapsed:.2f} s)")


@dataclass(frozen=True)
class Statistic:
    """An estimate and its Monte Carlo standard error over ``n`` samples."""

    value: np.ndarray
    standard_error: np.ndarray
    n: int


@dataclass(frozen=True, eq=False)
class Tracked:
    """``values`` (points × modes), columns following one mode each; ``order`` (points × modes): the
    original index of each; ``crossings`` and ``veerings``: (point, mode a, mode b) where two tracked curves
    cross, or approach and exchange their shapes without crossing."""

    values: np.ndarray
    order: np.ndarray
    crossings: list
    veerings: list


def track(values, shapes) -> Tracked:
    """Order each point's modes to follow the previous point's by largest total MAC (Hungarian assignment),
    then flag crossings (tracked curves swap their frequency order) and veerings (neighbouring curves come
    close, then exchange shapes without crossing)."""
    from ..solvers.tracking import mac, match

    values = np.asarray(values, dtype=float)
    n, m = values.shape
    order = np.empty((n, m), dtype=int)
    order[0] = np.arange(m)
    for i in range(1, n):
        order[i] = match(shapes[i - 1][:, order[i - 1]], shapes[i])
    tv = np.take_along_axis(values, order, axis=1)
    ts = [s[:, o] for s, o in zip(shapes, order)]
    crossings, veerings = [], []
    for a in range(m):
        for b in range(a + 1, m):
            d = tv[:, a] - tv[:, b]
            nz = np.flatnonzero(d)  # a point exactly on the crossing has d = 0: look across it
            for i, j in zip(nz[:-1], nz[1:]):
                if d[i] * d[j] < 0:
                    crossings.append((int(i + 1 if j == i + 1 else (i + j) // 2), a, b))
            gap = np.abs(d) / np.maximum(np.abs(tv[:, a]) + np.abs(tv[:, b]), 1e-300)
            for i in range(1, n - 1):
                if not (gap[i] <= gap[i - 1] and gap[i] <= gap[i + 1]) or d[i - 1] * d[i + 1] < 0:
                    continue
                own = float(np.asarray(mac(ts[0][:, a], ts[-1][:, a])))
                swapped = float(np.asarray(mac(ts[0][:, a], ts[-1][:, b])))
                if gap[i] < 0.5 * min(gap[0], gap[-1]) and swapped > own:
                    veerings.append((int(i), a, b))
    return Tracked(tv, order, crossings, veerings)


def _grid(parameters) -> tuple[list[dict], tuple]:
    if isinstance(parameters, Samples):
        return parameters.points(), tuple(parameters.values)
    if not isinstance(parameters, dict) or not parameters:
        raise ModelError("sweep: parameters must be a dict {name: list of values} or vd.sample(...)")
    names = tuple(parameters)
    axes = []
    for k, v in parameters.items():
        a = np.atleast_1d(np.asarray(v, dtype=object))
        if a.size == 0:
            raise ModelError(f"sweep: parameter '{k}' has no values")
        axes.append(list(a.ravel()))
    import itertools

    points = [dict(zip(names, combo)) for combo in itertools.product(*axes)]
    return [{k: (float(v) if isinstance(v, (int, float, np.number)) and not isinstance(v, bool) else v)
             for k, v in p.items()} for p in points], names


def _key(point: dict) -> str:
    return json.dumps(point, sort_keys=True, default=repr)


def sweep(build: Callable, parameters: Any, analysis: Any = "modes", executor: Any = None, progress: bool = True,
          store: str | Path | None = None,
          chunksize: int | None = None, options: dict | None = None) -> Sweep:
    """Run ``analysis`` at every point of ``parameters`` (a dict of value lists: their full grid, in
    row-major order; or :func:`sample`'s table) on ``build(**point)``.

    ``executor``: None (serial, in this process), "processes" (a local process pool, one worker per core),
    any ``concurrent.futures.Executor``, or a Dask ``distributed.Client``: the results are the same, bit
    for bit. ``store``: a JSON-lines file that receives each finished point; a sweep restarted with the same
    store recomputes nothing that finished. A point that fails is recorded with its message; the rest run.
    ``options``: for analysis "campbell", ``{"spin": NAME, "speeds": [...], "orders": (1,)}``.
    """
    start = time.perf_counter()
    if not callable(build):
        raise ModelError("sweep: build must be a callable(**parameters) -> Scene or System")
    if not callable(analysis) and analysis not in ANALYSES:
        raise ModelError(f"sweep: analysis must be one of {ANALYSES} or a callable(system) -> dict, got {analysis!r}")
    if store is not None and not isinstance(store, (str, Path)):
        raise ModelError(f"sweep: store must be a file path (str or pathlib.Path), got {store!r}")
    if store is not None and not Path(store).parent.is_dir():  # found before any work, not after it
        raise ModelError(f"sweep store {store}: no such directory '{Path(store).parent}'")
    if store is not None and Path(store).is_dir():
        raise ModelError(f"sweep store {store}: is a directory; give a file to write the points to (JSON lines)")
    if executor == "processes":
        _check_sendable(build, analysis)
    points, names = _grid(parameters)
    header = {"sweep": {"analysis": analysis if isinstance(analysis, str) else _name(analysis),
                        "build": _name(build), "options": _key(options or {})}}
    done = _load_store(store, header)
    todo = [i for i, p in enumerate(points) if _key(p) not in done]
    results: dict[int, dict] = {i: done[_key(p)] for i, p in enumerate(points) if _key(p) in done}
    kind, run = _runner(executor, options)
    # ~4 chunks per worker, at most 64 points: few tasks (each costs Dask a few ms), and a short wait for
    # the last one
    size = chunksize or max(1, min(64, len(todo) // (4 * _workers(executor)) or 1))
    chunks = [todo[k:k + size] for k in range(0, len(todo), size)]
    bar = _bar(progress, len(points), len(results))
    sink = _open_store(store, header) if store is not None else None
    try:
        for idx, res in run(build, analysis, [[points[i] for i in c] for c in chunks], chunks):
            for i, r in zip(idx, res):
                results[i] = r
                if sink is not None:
                    sink.write(json.dumps({"key": _key(points[i]), "result": r}) + "\n")
            if sink is not None:
                sink.flush()
            if bar is not None:
                bar.update(len(idx))
    finally:
        if sink is not None:
            sink.close()
        if bar is not None:
            bar.close()
    return Sweep(points, [results[i] for i in range(len(points))],
                 analysis if isinstance(analysis, str) else getattr(analysis, "__name__", "callable"),
                 kind, time.perf_counter() - start, names)


def _name(fn) -> str:
    """A callable's module-qualified name: what a store records of the build function and the analysis."""
    return f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', type(fn).__name__)}"


def _check_sendable(build, analysis):
    """A process pool sends the build function (and a callable analysis) to its workers by pickle: refuse,
    naming it, what cannot go (a lambda, a function defined inside another)."""
    import pickle

    for what, fn in (("build", build), ("analysis", analysis)):
        if callable(fn):
            try:
                pickle.dumps(fn)
            except Exception as e:  # noqa: BLE001 — pickling fails in many ways; each means the same here
                raise ModelError(f"sweep: {what} {_name(fn)} cannot be sent to worker processes ({type(e).__name__}): "
                                 "use a function defined at module level (not a lambda or a local function)") \
                    from None


def _load_store(store, header) -> dict:
    """The finished points of a store (key -> result). Its first line says which sweep made it (analysis,
    build function, options): another sweep's store is refused rather than silently reused."""
    if store is None:
        return {}
    path = Path(store)
    if not path.exists():
        return {}
    done = {}
    lines = path.read_text().splitlines()
    for n, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
            if "sweep" in rec:
                if rec != header:
                    raise ModelError(f"sweep store {path}: made by another sweep ({rec['sweep']}, this one is "
                                     f"{header['sweep']}): give another file")
                continue
            result = rec["result"]
            if not isinstance(result, dict) or not isinstance(result.get("status"), str):
                raise TypeError("no result")
            done[rec["key"]] = result
        except (json.JSONDecodeError, KeyError, TypeError):
            if n == len(lines) and not path.read_text().endswith("\n"):  # cut by an interruption: recompute it
                continue
            raise ModelError(f"sweep store {path}: line {n} is not a sweep record") from None
    return done


def _open_store(store, header):
    """The store for appending: a last line cut by an interruption is dropped first (its point is computed
    again), and a new store starts with its header."""
    path = Path(store)
    if path.exists():
        text = path.read_text()
        if text and not text.endswith("\n"):
            path.write_text(text[:text.rfind("\n") + 1])
    new = not path.exists() or path.stat().st_size == 0
    sink = open(path, "a")
    if new:
        sink.write(json.dumps(header) + "\n")
    return sink


def _workers(executor) -> int:
    if executor is None:
        return 1
    if executor == "processes":
        return os.cpu_count() or 1
    if hasattr(executor, "nthreads"):  # a Dask Client: its workers' threads
        try:
            return max(1, sum(executor.nthreads().values()))
        except Exception:  # a client without a live cluster: the sweep's own submit will say so
            return 2
    return getattr(executor, "_max_workers", None) or 2


def _runner(executor, options=None):
    """(kind, run): run(build, analysis, point chunks, index chunks) yields (indices, results) as they end."""
    if executor is None:
        def serial(build, analysis, chunks, idx):
            for c, i in zip(chunks, idx):
                yield i, _chunk(build, c, analysis, options)
        return "serial", serial
    if executor == "processes":
        def pool(build, analysis, chunks, idx):
            import multiprocessing as mp
            import threading

            # fork starts workers without re-importing (fast); with other threads alive it may deadlock: spawn
            method = "fork" if threading.active_count() == 1 and "fork" in mp.get_all_start_methods() else "spawn"
            with mp.get_context(method).Pool(os.cpu_count() or 1) as p:
                try:
                    jobs = [p.apply_async(_chunk, (build, c, analysis, options)) for c in chunks]
                    for j, i in zip(jobs, idx):
                        yield i, j.get()
                except BaseException:
                    p.terminate()  # Ctrl-C or an error: no worker is left behind
                    raise
        return "processes", pool
    if isinstance(executor, Executor):
        def futures(build, analysis, chunks, idx):
            from concurrent.futures import as_completed

            fut = {executor.submit(_chunk, build, c, analysis, options): i for c, i in zip(chunks, idx)}
            try:
                for f in as_completed(fut):
                    yield fut[f], f.result()
            except BaseException:
                for f in fut:
                    f.cancel()
                raise
        return type(executor).__name__, futures
    if type(executor).__name__ == "Client" and hasattr(executor, "submit") and hasattr(executor, "gather"):
        def dask(build, analysis, chunks, idx):
            from distributed import as_completed

            fut = {executor.submit(_chunk, build, c, analysis, options, pure=False): tuple(i)
                   for c, i in zip(chunks, idx)}
            try:
                for f in as_completed(list(fut)):
                    yield list(fut[f]), f.result()
            except BaseException:
                executor.cancel(list(fut))
                raise
        return "dask", dask
    raise ModelError(f"sweep: executor must be None, 'processes', a concurrent.futures.Executor or a Dask "
                     f"distributed.Client, got {executor!r}")


def _bar(progress, total, done):
    if not progress or total < 2 or not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    return tqdm(total=total, initial=done, unit="point", file=sys.stderr)
