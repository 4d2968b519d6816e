"""Drives compiled (``system.compiled_drives``; bound to the system as ``system.drives``): which tangent
coordinates are prescribed in time (rheonomic joints, :mod:`vibdyn.description.elements.drive`), their values at
t, the free accelerations and the drives' forces.

With drives, the coordinates split into driven ones d (q_d, v_d, a_d: the laws' at t) and free ones f. The
free accelerations solve the free rows of the equations of motion, M_ff a_f = Q_f − g_f − b_f − M_fd a_d,
as h = RNEA(q, v, a⁰) − Q with a⁰ = (a_f = 0, a_d) and M_ff a_f = −h_f (Cholesky of M_ff by CRBA, no
inverse). Each drive exerts along its coordinate τ_d = (M a + b + g − Q)_d (N or N·m): the row d of the
inverse dynamics at the motion's accelerations. ``nq``, ``nv`` and ``coordinates`` stay the tree's.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._check import call_user, finite_result
from ..errors import ModelError
from . import dynamics

PARTS = ("position", "velocity", "acceleration")


class Drives:
    """The drives of a system: ``names``, ``bodies``, ``coordinates`` (driven, in scene order), ``index``
    (their indices in v, and in q: ``q_index``), ``free`` (indices in v of the free coordinates) and
    ``free_coordinates`` (their names); ``units`` ("m" or "rad") of the driven coordinates.

    The table a System compiles (``system.compiled_drives``) refers to no System: its methods that compute take the
    system. ``system.drives`` is that table bound to the system on each access (:meth:`bound`), whose
    :meth:`forces` computes on it."""

    _system: Any  # the System of a bound table (held by the caller only, never by a compiled object), else None

    def __init__(self, system, elements):
        self.elements = tuple(elements)
        self.names = tuple(e.name for e in self.elements)
        self.bodies = tuple(e.body for e in self.elements)
        infos = [system.body_info(e.body) for e in self.elements]
        self.index = np.array([b.idx_v for b in infos], dtype=int)
        self.q_index = np.array([b.idx_q for b in infos], dtype=int)
        self.free = np.setdiff1d(np.arange(system.nv), self.index)
        for a in (self.index, self.q_index, self.free):
            a.flags.writeable = False
        self.coordinates = tuple(system.coordinates[i] for i in self.index)
        self.free_coordinates = tuple(system.coordinates[i] for i in self.free)
        self.units = tuple(system.units[i] for i in self.index)
        self._system = None  # (compiled: bound to no System, :meth:`bound`)

    def bound(self, system: Any) -> Drives:
        """This table bound to ``system`` (what ``system.drives`` is): a copy that :meth:`forces` computes on. Made
        on each access and kept by no compiled object, so nothing refers back to the System (a System is freed by
        its last reference, without the garbage collector) and the System pickles."""
        out = object.__new__(Drives)
        out.__dict__.update(self.__dict__)
        out._system = system
        return out

    def __len__(self):
        return len(self.elements)

    def __repr__(self):
        return f"Drives({', '.join(f'{n} on {c}' for n, c in zip(self.names, self.coordinates))})"

    def values(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_d, v_d, a_d) at time t (s): the driven coordinates' positions (m or rad), velocities and
        accelerations from their laws, each checked finite (a ModelError naming the drive otherwise)."""
        out = np.empty((3, len(self.elements)))
        for k, e in enumerate(self.elements):
            for i, part in enumerate(PARTS):
                x = call_user(getattr(e.motion, part), (t,), f"drive '{e.name}' {part}", t)
                try:
                    out[i, k] = float(x)
                except (TypeError, ValueError):
                    out[i, k] = math.nan
                if not math.isfinite(out[i, k]):
                    unit = self.units[k] + ("", "/s", "/s²")[i]
                    raise ModelError(f"drive '{e.name}': its motion's {part}(t) returned {x!r} at t = {t:.6g} s: "
                                     f"expected a finite number ({unit})")
        return out[0], out[1], out[2]

    def impose(self, q, v, t: float, laws=None) -> tuple[np.ndarray, np.ndarray]:
        """Copies of (q, v) with the driven entries replaced by the laws' values at t (``laws``: their (q_d, v_d,
        a_d) there where the caller has them; None: asked)."""
        qd, vd, _ = self.values(t) if laws is None else laws
        q, v = np.array(q, dtype=float), np.array(v, dtype=float)
        q[self.q_index], v[self.index] = qd, vd
        return q, v

    def accelerations(self, system, ws, q, v, t, ad=None):
        """dv/dt (nv): a_d from the laws at t, a_f from the free rows of the equations of motion at (q, v)
        as given (their driven entries are not replaced: :meth:`impose` does that). Unchecked (the hot path)."""
        return self.accelerations_and_forces(system, ws, q, v, t, ad)[0]

    def accelerations_and_forces(self, system, ws, q, v, t, ad=None):
        """(dv/dt, τ_d): :meth:`accelerations` and the drives' forces there (N or N·m, in the order of
        ``index``). Unchecked (the hot path). ``ad``: the laws' a_d at t where the caller has them (None: asked)."""
        d, f = self.index, self.free
        a = np.zeros(system.nv)
        a[d] = self.values(t)[2] if ad is None else ad
        a, h, M = dynamics.held_accelerations(system, ws, q, v, t, a, f)
        return a, (h[d] if M is None else h[d] + M[np.ix_(d, f)] @ a[f])

    def forces(self, q, v, t: float = 0.0, a=None) -> dict[str, float]:
        """{drive name: τ_d}: the generalized force (N for a slider, N·m for a pivot or helical joint) each
        drive exerts along its coordinate at (q, v) moving with accelerations a (None: the motion's,
        :meth:`accelerations`), τ_d = (M a + b + g − Q)_d. The driven entries of q and v are taken as given."""
        system = self._system
        if system is None:
            raise ModelError("Drives.forces: this table is bound to no System (use system.drives.forces)")
        q, v, t = system.check_configuration(q), system.check_velocity(v), system.check_time(t)
        ws = system.workspace()
        if a is None:
            a = self.accelerations(system, ws, q, v, t)
            if not np.all(np.isfinite(a)):
                system.check_mass_matrix(q, "this configuration")
        a = system.check_velocity(a, "a")
        tau = finite_result(dynamics.inverse_dynamics(system, ws, q, v, a, t), f"drive forces at t = {t}")
        return self.of(tau)

    def of(self, tau) -> dict[str, float]:
        """{drive name: the entry of ``tau`` (nv) at its coordinate}."""
        return {n: float(tau[i]) for n, i in zip(self.names, self.index)}

    def power(self, v, tau) -> float:
        """Σ v_d τ_d (W): the power the drives put in, from the velocities and the inverse dynamics ``tau``."""
        return float(v[self.index] @ tau[self.index])


def compile_drives(system):
    """The :class:`Drives` of a system's scene, None without drives. Drives on a mechanism with closed loops
    are refused (not supported yet)."""
    from ..description.elements import Drive

    elements = system.scene.elements_of(Drive)
    if not elements:
        return None
    if system.scene.loops:
        raise ModelError(f"drive '{elements[0].name}': drives on a mechanism with closed loops are not supported "
                         "yet (drive a tree, or hold the coordinate with a stiff joint spring)")
    return Drives(system, elements)
