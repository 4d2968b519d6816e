"""Events of a simulation: zero crossings of user functions f(t, q, v), found at the end of each step and
located inside it on the step's own interpolant (to the step's accuracy), as scipy's ``solve_ivp`` does.

An event function may carry the attributes ``direction`` (+1: crossings upwards only, −1: downwards only,
0: both; default 0) and ``terminal`` (True: the run stops at its first crossing; default False).
"""

import math

import numpy as np

from .._check import call_user
from ..errors import ModelError


class Events:
    """The event functions of one run and what they found: ``times[i]``, ``q[i]``, ``v[i]`` lists per
    function; ``stop`` the time of a terminal event (None while none has happened)."""

    def __init__(self, functions):
        functions = [functions] if callable(functions) else list(functions)
        for k, f in enumerate(functions):
            if not callable(f):
                raise ModelError(f"simulate: events[{k}] must be a callable f(t, q, v) → float, got {f!r}")
            d = getattr(f, "direction", 0)
            if d not in (-1, 0, 1):
                raise ModelError(f"simulate: events[{k}].direction must be −1, 0 or 1, got {d!r}")
        self.functions = functions
        self.direction = [getattr(f, "direction", 0) for f in functions]
        self.terminal = [bool(getattr(f, "terminal", False)) for f in functions]
        self.times = [[] for _ in functions]
        self.q = [[] for _ in functions]
        self.v = [[] for _ in functions]
        self.stop = None
        self._last = None

    def _values(self, t, q, v):
        return np.array([self._value(k, t, q, v) for k in range(len(self.functions))])

    def _value(self, k, t, q, v):
        """Event function k at (t, q, v): a finite number, or a ModelError naming it (at a step's end and
        inside the root search alike)."""
        g = call_user(self.functions[k], (t, q, v), f"event function {k}", t)
        try:
            out = float(g)
        except (TypeError, ValueError):
            raise ModelError(f"event function {k}: expected a number, got {g!r} at t = {t:g} s") from None
        if not math.isfinite(out):
            raise ModelError(f"event function {k}: not finite at t = {t:g} s")
        return out

    def start(self, t, q, v):
        self._last = (t, self._values(t, q, v))

    def step(self, t, q, v, state_at):
        """After a step ending at (t, q, v): locate each crossing since the last one inside it, on
        ``state_at(s) → (q, v)`` (the step's interpolant), in time order; a terminal one sets ``stop``."""
        from scipy.optimize import brentq

        t0, g0 = self._last
        g1 = self._values(t, q, v)
        self._last = (t, g1)
        found = []
        for k in range(len(self.functions)):
            up, down = g0[k] < 0 <= g1[k], g0[k] > 0 >= g1[k]
            if not (up or down) or (self.direction[k] == 1 and not up) or (self.direction[k] == -1 and not down):
                continue
            if g1[k] == 0.0:
                s = t
            else:
                def g(x, k=k):
                    return self._value(k, x, *state_at(x))

                ga, gb = g(t0), g(t)
                if ga * gb > 0:  # the interpolant's ends round to one side: the crossing is at the nearer one
                    s = t0 if abs(ga) < abs(gb) else t
                else:
                    s = brentq(g, t0, t, xtol=4 * np.finfo(float).eps * max(abs(t), 1.0),
                               rtol=4 * np.finfo(float).eps)
            found.append((s, k))
        for s, k in sorted(found):
            if self.stop is not None:
                break
            qs, vs = state_at(s)
            self.times[k].append(s)
            self.q[k].append(np.array(qs))
            self.v[k].append(np.array(vs))
            if self.terminal[k]:
                self.stop = s
        return self.stop

    def result(self, nq, nv):
        """(times, q, v): per function, an array of crossing times (s) and the states there."""
        return (tuple(np.array(x, float) for x in self.times),
                tuple(np.array(x, float).reshape(-1, nq) for x in self.q),
                tuple(np.array(x, float).reshape(-1, nv) for x in self.v))


def hermite(system, t0, s0, t1, s1):
    """The state at t in [t0, t1] from both ends' (q, v, a): cubic Hermite of the tangent displacement from
    q0 (slopes v) and of v (slopes a) — for fixed-step methods, which keep no interpolant of their own."""
    q0, v0, a0 = s0
    q1, v1, a1 = s1
    h = t1 - t0
    d = system.difference(q0, q1)

    def at(t):
        x = (t - t0) / h
        h00, h10, h01, h11 = 2 * x**3 - 3 * x**2 + 1, x**3 - 2 * x**2 + x, -2 * x**3 + 3 * x**2, x**3 - x**2
        xi = h01 * d + h * (h10 * v0 + h11 * v1)
        v = h00 * v0 + h01 * v1 + h * (h10 * a0 + h11 * a1)
        return system.integrate(q0, xi), v

    return at
