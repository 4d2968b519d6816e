"""The reduction of a system's coordinates to its independent ones: the one object every analysis reduces through.

A tree moves in all its nv tangent coordinates. Some are held: a drive prescribes a coordinate in time
(:mod:`vibdyn.model.drives`), or an analysis holds a coordinate at its operating speed (a Campbell diagram's
spin, held by its drive). A mechanism with closed loops moves in the null space of its loop Jacobian,
v = N(q) ż (:mod:`vibdyn.model.constraints`). :class:`Reduction` composes the two: the independent velocities
ż are those of the coordinates that are neither held nor tied by the loops, and

    v = N(q) ż + (the held coordinates' speeds),   N (nv × n): Φ_q N = 0, N = 0 on the held rows,

N's rows at the independent coordinates being the identity. Analyses, the studies and the time layer ask the
reduction (``system.reduction``, or :meth:`Reduction.holding` for an analysis that holds more) to put a state
on it (:meth:`impose`, :meth:`close`, :meth:`project`), for its basis (:meth:`independent`) and moves in it
(:meth:`step`, :meth:`chart`), to reduce forces and their derivatives (:meth:`reduce`, :meth:`derivative`,
:meth:`reduce_model`), for its reference and consistent accelerations, its constraint forces and the curvature
they add to K, and whether it allows an analysis (:meth:`require`); they never ask whether a scene has loops
or drives. The reduction of a tree is the identity (``kind`` "tree", n = nv, N = I).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._deprecation import Renamed
from ..errors import ModelError
from . import dynamics

#: the dimensionless closure a search's iterates are refined to past ASSEMBLY_TOL (16 ε: round-off): near a lock
#: the loops' Jacobian is ill-conditioned, and a closure left at 1e-13 moves the pose by 1e-9 along the mechanism
CLOSE_REFINE = 16 * np.finfo(float).eps

class Reduction:
    """How the nv tangent coordinates of ``system`` reduce to independent ones (see the module docstring).

    ``kind``: "tree", "held", "loops" or "loops, held"; ``held``: indices in v of the held coordinates (drives'
    and those held at a speed), ``free``: the others; ``held_speeds``: {index: speed (rad/s or m/s)} of the
    coordinates held at a constant speed (not by a drive's law)."""

    _pose: np.ndarray | None

    def __init__(self, system: Any, loops: Any = None, drives: Any = None, held_speeds: dict | None = None):
        # what it needs of the system, not the system: the System holds its reduction, and a reference back
        # would be a cycle keeping every System built (and its Pinocchio Data) alive until the garbage collector
        # runs (a 100-body build took twice as long); methods that compute take the system, as Drives' do
        self.nv, self.coordinates, self.model = system.nv, tuple(system.coordinates), system.model
        self._loops, self._drives = loops, drives
        self._pose = None  # q of a configuration held whole (:meth:`holding_all`)
        self._hold(held_speeds or {})

    def _hold(self, held_speeds: dict) -> None:
        """Set the held coordinates: the drives' and ``held_speeds`` ({index in v: speed})."""
        self.held_speeds = {int(i): float(s) for i, s in held_speeds.items()}
        mask = np.zeros(self.nv, dtype=bool)  # (a mask, not set operations: Campbell makes one per speed)
        if self._drives is not None:
            mask[self._drives.index] = True
        mask[list(self.held_speeds)] = True
        self.held, self.free = np.flatnonzero(mask), np.flatnonzero(~mask)
        # N without loops (the identity's columns at ``free``), made when first asked; the laws at the last t
        self._basis: np.ndarray | None = None  # (a tree's N: made once, read-only)
        self._law_memo: tuple | None = None
        for a in (self.held, self.free):
            a.flags.writeable = False
        parts = (["loops"] if self._loops is not None else []) + (["held"] if self.held.size else [])
        self.kind = ", ".join(parts) or "tree"

    # ------------------------------------------------------------------ what it is
    @property
    def is_identity(self) -> bool:
        """True for a tree with nothing held: N = I, nothing to impose or close."""
        return self.kind == "tree"

    @property
    def looped(self) -> bool:
        """True where N depends on q (loops): linear models then carry the constraint forces' curvature."""
        return self._loops is not None

    curved = Renamed("looped")  # ("curved" means nq ≠ nv joints, a Lie group: docs/guide/names.md)

    @property
    def time_laws(self) -> bool:
        """True where held coordinates follow laws of time (drives)."""
        return self._drives is not None

    @property
    def held_names(self) -> tuple[str, ...]:
        return tuple(self.coordinates[i] for i in self.held)

    def describe(self) -> str:
        """What reduces the coordinates, in the user's words (for messages)."""
        out = []
        if self._loops is not None:
            out.append(f"loops {', '.join(lp.name for lp in self._loops.loops)}")
        if self._drives is not None:
            out.append(f"drives {', '.join(self._drives.names)}")
        if self._pose is not None:
            out.append("every coordinate held (a configuration held whole)")
        elif self.held_speeds:
            out.append(f"held speeds of {', '.join(self.coordinates[i] for i in self.held_speeds)}")
        return "; ".join(out) or "nothing (a tree)"

    # ------------------------------------------------------------------ what an analysis may ask of it
    # {analysis: {what the scene has: why the analysis refuses it}}: the analyses name what they do, the
    # reduction answers (the message's "{describe}" is :meth:`describe`)
    REFUSALS = {
        "periodic orbits": {"loops": "not available for a mechanism with closed loops (the simulation gives no "
                                     "variational equations there)"},
        "backbones": {"loops": "not available for a mechanism with closed loops",
                      "drives": "the scene has drives or moving supports: a backbone needs an autonomous scene"},
        "harmonic balance": {"loops": "scenes with closed loops are not handled by harmonic balance yet",
                             "drives": "scenes with drives are not handled by harmonic balance yet"},
        "variational equations": {"loops": "variational equations: not available for a mechanism with closed loops "
                                           "(the projection onto the loops has no variational counterpart here)"},
        "held configurations": {"loops": "not available for a mechanism with closed loops ({describe}); use "
                                         "equilibrium()"},
        # asked with :meth:`allows` (a path an analysis takes where it can, another where it cannot)
        "operating points found from a state": {"drives": "a driven scene's operating point is its declared one (the "
                                                          "drives' motion), not one found again from a state"},
        "steady motions followed from rest": {"loops": "followed in the tree's own coordinates: not with loops",
                                              "drives": "followed in the tree's own coordinates: not with drives"},
        "derivatives on the tree's elements": {part: "the tree's own model only: not with {describe}" for part in
                                               ("loops", "drives", "held speeds", "held configuration")},
    }

    def has(self) -> tuple[str, ...]:
        """What reduces the coordinates, by name: "loops", "drives", "held speeds", "held configuration" (empty
        for a tree)."""
        held = ("held configuration", self._pose) if self._pose is not None else ("held speeds",
                                                                                    self.held_speeds or None)
        return tuple(name for name, x in (("loops", self._loops), ("drives", self._drives), held) if x is not None)

    def require(self, analysis: str, what: str | None = None, **refusals: str) -> None:
        """Nothing, if ``analysis`` (a key of :attr:`REFUSALS`, or any name with its own ``refusals``: {"loops",
        "drives", "held_speeds": message}) handles everything this reduction has; else the ModelError
        "{what}: {why}" naming the first thing it has that the analysis lacks ("{describe}" in a message: what
        reduces the coordinates, "{drives}": the drives' names)."""
        table = {**self.REFUSALS.get(analysis, {}), **{k.replace("_", " "): m for k, m in refusals.items()}}
        for part in self.has():
            if part in table:
                drives = ", ".join(self._drives.names) if self._drives is not None else ""
                raise ModelError(f"{what or analysis}: {table[part].format(describe=self.describe(), drives=drives)}")

    def allows(self, analysis: str) -> bool:
        """True if ``analysis`` (a key of :attr:`REFUSALS`) handles everything this reduction has: where
        :meth:`require` would raise nothing."""
        table = self.REFUSALS.get(analysis, {})
        return not any(part in table for part in self.has())

    def held_at_speed(self) -> tuple[str, ...]:
        """Names of the coordinates held at a speed (``holding``: a Campbell diagram's spin; not the drives')."""
        return tuple(self.coordinates[i] for i in self.held_speeds)

    def holding(self, speeds: dict) -> Reduction:
        """This reduction with the coordinates ``speeds`` ({index in v: speed, rad/s or m/s}) held at those
        speeds as well (a Campbell diagram's spin, held by its drive)."""
        driven = set() if self._drives is None else {int(i) for i in self._drives.index}
        for i in speeds:
            if int(i) in driven:
                raise ModelError(f"coordinate '{self.coordinates[int(i)]}' is driven: its speed is its "
                                 "drive's")
        out = object.__new__(Reduction)
        out.__dict__.update(self.__dict__)
        out._hold({**self.held_speeds, **speeds})
        return out

    def holding_all(self, q, v) -> Reduction:
        """This reduction with every coordinate held: the configuration ``q`` moving at the constant velocity ``v``
        (nv; m/s or rad/s), each coordinate by a holder of its own (a servo-held robot, :meth:`System.held`):
        nothing is left independent, and :meth:`held_forces` are what the holders exert. Only for a reduction
        that holds nothing by loops or drives (:meth:`require` "held configurations" says so first)."""
        out = object.__new__(Reduction)
        out.__dict__.update(self.__dict__)
        out._pose = np.array(q, dtype=float)
        out.held_speeds = dict(enumerate(np.asarray(v, dtype=float).tolist()))
        out.held, out.free = np.arange(self.nv), np.zeros(0, dtype=int)
        out._basis, out._law_memo, out.kind = np.zeros((self.nv, 0)), None, "held"
        for a in (out._pose, out.held, out.free, out._basis):
            a.flags.writeable = False
        return out

    def regime(self, moving: bool) -> str:
        """The regime of an operating point found in this reduction: "held" (every coordinate held,
        :meth:`holding_all`), "steady" (``moving``: coordinates turning at their speeds; or held ones) or
        "static"."""
        if self._pose is not None:
            return "held"
        return "steady" if moving or self.held.size else "static"

    # ------------------------------------------------------------------ states on the reduction
    def impose(self, q, v, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Copies of (q, v) with the held coordinates set: the drives' laws at t (s), the held speeds (and
        configuration)."""
        q = self._pose if self._pose is not None else q
        if self._drives is not None:
            q, v = self._drives.impose(q, v, t, self._laws(t))
        else:
            q, v = np.array(q, dtype=float), np.array(v, dtype=float)
        for i, s in self.held_speeds.items():
            v[i] = s
        return q, v

    def _laws(self, t: float) -> tuple:
        """The drives' (q_d, v_d, a_d) at t, read-only, kept for the last t asked (a search or a linearisation
        asks again and again at one t; the laws are functions of t alone)."""
        memo = self._law_memo  # (one read: another thread may replace it meanwhile)
        if memo is None or memo[0] != t:
            values = tuple(np.array(x, dtype=float) for x in self._drives.values(t))
            for x in values:
                x.flags.writeable = False
            memo = self._law_memo = (t, values)
        return memo[1]

    def law_values(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_d, v_d, a_d) of the driven coordinates at t (empty without drives): see :meth:`Drives.values`."""
        if self._drives is None:
            return np.zeros(0), np.zeros(0), np.zeros(0)
        return self._drives.values(t)

    @property
    def driven(self) -> np.ndarray:
        """Indices in v of the coordinates driven by laws of time (a subset of ``held``)."""
        return np.zeros(0, dtype=int) if self._drives is None else np.asarray(self._drives.index, dtype=int)

    @property
    def driven_q(self) -> np.ndarray:
        """Indices in q of the driven coordinates."""
        return np.zeros(0, dtype=int) if self._drives is None else np.asarray(self._drives.q_index, dtype=int)

    @property
    def driven_names(self) -> tuple[str, ...]:
        """Names of the drives (scene order; empty without drives)."""
        return () if self._drives is None else tuple(self._drives.names)

    @property
    def driven_units(self) -> tuple[str, ...]:
        return () if self._drives is None else tuple(self._drives.units)

    def closure(self, q) -> float:
        """Largest |Φ(q)| of the loops, dimensionless (m / length scale, rad); 0 without loops."""
        if self._loops is None:
            return 0.0
        return float(np.abs(self._loops.scaled_phi(self._loops.phi(q))).max(initial=0.0))

    def close(self, q, start: str = "q0", refine: bool = False) -> np.ndarray:
        """q on the loops (assembled nearest q, a ConvergenceError naming ``start`` if they cannot close; with
        ``refine`` on to round-off where it can be, :data:`CLOSE_REFINE`)."""
        if self._loops is None:
            return np.array(q, dtype=float)
        return self._loops.assemble(q, start=start, refine=CLOSE_REFINE if refine else None)

    def closures(self, qs) -> np.ndarray:
        """Largest |Φ| of the loops (m for positions, rad for orientations) at each configuration of ``qs``;
        zeros without loops."""
        if self._loops is None:
            return np.zeros(len(qs))
        return np.array([np.abs(self._loops.phi(q)).max(initial=0.0) for q in qs])

    def default_start(self, system) -> tuple[np.ndarray, str]:
        """(q, what) a run of ``system`` starts from when given none: neutral ("q0"); with loops the system's start
        (:meth:`System.start_configuration`, closed by :meth:`close`)."""
        return (system.neutral(), "q0") if self._loops is None else system.start_configuration()

    def project(self, q, v, M=None) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) on the loops: q closed, v the M-orthogonal projection on the motions they allow (``M`` the
        mass matrix at q, or a function of q giving it: called only with loops)."""
        if self._loops is None:
            return np.array(q, dtype=float), np.array(v, dtype=float)
        return self._loops.project(q, v, M(q) if callable(M) else M)

    def closure_shift(self, q) -> float:
        """The most (dimensionless: rad, or × the length scale) the loops' closure left at q can move the pose:
        |Φ|₂ / σ_min of the dimensionless Φ_q (|Φ|₂ ≤ √m |Φ|∞), 0 without loops."""
        c = self._loops
        if c is None:
            return 0.0
        phi, J = c.evaluate(q)
        rank, _, s, _ = c.decompose(J)
        return math.sqrt(c.m) * float(np.abs(c.scaled_phi(phi)).max(initial=0.0)) / s[rank - 1] if rank else 0.0

    def conditioning(self, q) -> float:
        """σ_min/σ_max of the loops' dimensionless Jacobian at q (1 without loops)."""
        return 1.0 if self._loops is None else float(self._loops.conditioning(q))

    def opening(self, q, v) -> float:
        """How much the velocity v opens the loops, |Φ_q v| dimensionless per unit of v's largest scaled entry
        (0 without loops)."""
        if self._loops is None or not np.any(v):
            return 0.0
        c = self._loops
        return float(np.abs(c.scaled_phi(c.jacobian(q) @ v)).max(initial=0.0) / np.abs(v / c.col_scale).max())

    # ------------------------------------------------------------------ the basis
    def independent(self, q, keep=None) -> tuple[np.ndarray, np.ndarray]:
        """(ind, N): the independent coordinates (indices in v) and the basis N (nv × len(ind)) at q, N's rows
        at ``ind`` the identity, zero on the held rows. ``keep``: these independent coordinates (a smooth
        basis along a path) instead of choosing them (loops: QR with column pivoting)."""
        nv = self.nv
        if self._loops is None:
            if keep is None or keep is self.free:  # (the same basis at every q: made once, read-only)
                basis = self._basis
                if basis is None:
                    basis = np.eye(nv)[:, self.free]
                    basis.flags.writeable = False
                    self._basis = basis
                return self.free, basis
            ind = np.asarray(keep, dtype=int)
            return ind, np.eye(nv)[:, ind]
        J = self._loops.jacobian(q)
        # (kept or chosen, the held coordinates are independent of the loops, then left out of the basis)
        ind, N = self._loops.partition(J, None if keep is None else np.union1d(keep, self.held))
        tied = [self.coordinates[i] for i in self.held if i not in ind]
        if tied:
            raise ModelError(f"{', '.join(tied)} cannot be held on its own: the loops tie it to the other "
                             "coordinates (hold a coordinate the loops leave free)")
        cols = np.isin(ind, self.held, invert=True)
        return ind[cols], N[:, cols]

    def dependent(self, ind) -> np.ndarray:
        """Indices in v of the coordinates that are neither independent nor held (the loops close them)."""
        return np.setdiff1d(self.free, ind)

    def chart(self, q0, ind, dz) -> np.ndarray:
        """The configuration of the mechanism with independent coordinates moved by dz from q0 (through
        N(q0) dz, then the loops closed by the dependent coordinates alone): its chart in ``ind``."""
        import pinocchio as pin

        _, N0 = self.independent(q0, ind)
        q = pin.integrate(self.model, q0, N0 @ dz)
        return q if self._loops is None else self._loops.close(q, self.dependent(ind))

    def step(self, q, N, dz, start: str = "an iterate", refine: bool = False) -> np.ndarray:
        """q moved by N dz (``N`` the basis at q, dz per independent coordinate), the loops closed again (a
        ConvergenceError naming ``start`` if they cannot): the move of a search in the independent coordinates.
        ``refine``: closed on to round-off where it can be (:data:`CLOSE_REFINE`)."""
        import pinocchio as pin

        if self._loops is None:
            return pin.integrate(self.model, q, N @ dz)
        if not np.any(dz):
            return q
        return self._loops.assemble(pin.integrate(self.model, q, N @ dz), start=start,
                                    refine=CLOSE_REFINE if refine else None)

    def reduce(self, ind, N, r) -> np.ndarray:
        """Nᵀ r: the generalized forces r (nv, or nv × m) on the independent coordinates ``ind`` (basis N)."""
        return r[ind] if self._loops is None else N.T @ r  # (without loops N is the identity's columns: exact)

    def derivative(self, q, ind, N, reduced, tree, h, start: str = "an iterate") -> np.ndarray:
        """∂ρ/∂z at q (n × n, columns: ``ind``) of the reduced forces ρ = N(q)ᵀ r(q) as the independent
        coordinates move: without loops Nᵀ ``tree(q)`` N (N constant: ``tree`` the nv × nv ∂r/∂q); with loops central
        differences of ``reduced`` (q ↦ ρ, N re-evaluated there, same ``ind``) through :meth:`step`, steps
        ``h`` (nv, per tangent coordinate) at ``ind``."""
        if self._loops is None:
            J = tree(q)
            return J if ind.size == self.nv else J[np.ix_(ind, ind)]
        from .fd import vector_derivative

        return vector_derivative(lambda x: reduced(self.step(q, N, x, start)), np.zeros(ind.size), h[ind])

    def require_uniform(self, what: str, t: float, scales) -> None:
        """Nothing if the drives do not accelerate at t (|a_d| ≤ 1e-10 per s² × ``scales``, 1 rad or the length
        scale: at rest or in uniform motion, where the free coordinates may have an equilibrium), else the
        ModelError saying which does."""
        if self._drives is None:
            return
        ad = self._laws(t)[2]
        for k in np.flatnonzero(np.abs(ad) > 1e-10 * np.asarray(scales)[self._drives.index]):
            raise ModelError(f"{what}: drive '{self._drives.names[k]}' accelerates at t = {t:g} s (a = {ad[k]:.6g} "
                             f"{self._drives.units[k]}/s²): the free coordinates have no equilibrium while it does; "
                             "linearise about a state of the motion (system.linearize(q, v=v, t=t)) or simulate it")

    def reference_acceleration(self, ws, q, v, t: float, ind) -> np.ndarray:
        """Accelerations (nv) of the reference motion whose independent coordinates do not accelerate: the
        drives' laws' a_d at t on the driven rows, zero on the other held ones and on ``ind``, and what keeps the
        loops closed (Φ_q a + γ = 0) on the dependent ones."""
        a = np.zeros(self.nv)
        if self._drives is not None:
            a[self._drives.index] = self._laws(t)[2]
        if self._loops is not None and np.any(v):
            c = self._loops
            a += c.dependent_solution(c.jacobian(q), -c.bias(q, v), self.dependent(ind))
        return a

    def accelerations(self, system, ws, q, v, t: float) -> np.ndarray:
        """dv/dt of ``system``'s held motion in its workspace ``ws``: a_d from the laws, the free rows from the
        equations of motion (drives; held speeds are not accelerated); unchecked (:meth:`Drives.accelerations`)."""
        if self._drives is None and not self.held_speeds:
            return dynamics.accelerations(system, ws, q, v, t).copy()
        if self._drives is not None and not self.held_speeds:
            return self._drives.accelerations(system, ws, q, v, t, self._laws(t)[2])
        a = np.zeros(self.nv)
        if self._drives is not None:
            a[self._drives.index] = self._laws(t)[2]
        return dynamics.held_accelerations(system, ws, q, v, t, a, self.free)[0]

    def motion_acceleration(self, system, ws, q, v, t: float, ind, a=None, steady: bool = False) -> np.ndarray:
        """Accelerations (nv) of the motion a linear model is taken about at (q, v, t): ``a`` if given (its driven
        entries must be the laws'), else the reference motion's (:meth:`reference_acceleration`) about an
        operating point (``steady``), or the held motion's (:meth:`accelerations`, checked finite). With loops
        always the reference motion's: the only one they are linearised about (another ``a`` is refused)."""
        if self._loops is not None or (a is None and steady):
            ref = self.reference_acceleration(ws, q, v, t, ind)
            if a is not None and np.any(np.abs(np.asarray(a, dtype=float) - ref) > 1e-10 * system.coordinate_scales):
                self.require("accelerating motions", "linearize", loops=(
                    "a mechanism with loops is linearised about an equilibrium or a steady motion (its independent "
                    "coordinates do not accelerate): give a = None"))
            return ref
        if a is None:
            a0 = self.accelerations(system, ws, q, v, t)
            if not np.all(np.isfinite(a0)):
                system.check_mass_matrix(q, "the operating point")
                raise ModelError(f"linearize: the accelerations are not finite at the operating point (t = {t})")
            return a0
        a0 = system.check_velocity(a, "a")
        d, ad = self.driven, self.law_values(t)[2]
        # (within the tolerance of the equilibria's drives at rest: 1e-10 per s² × 1 rad or the length scale)
        if np.any(np.abs(a0[d] - ad) > 1e-10 * system.coordinate_scales[d]):
            names = [self.coordinates[i] for i in d]
            raise ModelError(f"linearize: a at the driven coordinates ({', '.join(names)}) must be the drives' "
                             f"accelerations at t = {t:g} s, {ad.tolist()}; got {a0[d].tolist()} (give a = None "
                             "for the motion's)")
        return a0

    def linear_model(self, tree, reduced):
        """The linear model in this reduction's coordinates: ``tree()`` where it is the identity (a tree with
        nothing held: the tree's own model, nv × nv), else ``reduced(self)`` (in the independent coordinates)."""
        return tree() if self.is_identity else reduced(self)

    def reduce_model(self, ind, N, tree, moving, moving_terms) -> tuple:
        """(M_r, C_r, K_r, K_error, C_error, K_error_terms) of the tree's linear model ``tree`` (nv × nv) in the
        independent coordinates ``ind`` (basis N): without loops its block at ind (N the identity's columns);
        with loops NᵀAN (errors through |N|; M_r symmetrised), or, about a motion (``moving``) where N depends on
        q, ``moving_terms()`` = (K_r, C_r, K_error, C_error) from the reduced equations themselves (and no
        error terms: None)."""
        if self._loops is None:
            ii = np.ix_(ind, ind)
            terms = None if tree.K_error_terms is None else tuple(T[:, ind] for T in tree.K_error_terms[:2])
            return tree.M[ii], tree.C[ii], tree.K[ii], tree.K_error[ii], tree.C_error[ii], terms
        aN = np.abs(N)
        M_r = N.T @ tree.M @ N
        M_r = 0.5 * (M_r + M_r.T)
        if moving:
            K_r, C_r, K_err, C_err = moving_terms()
        else:
            C_r, K_r = N.T @ tree.C @ N, N.T @ tree.K @ N
            K_err, C_err = aN.T @ tree.K_error @ aN, aN.T @ tree.C_error @ aN
        return M_r, C_r, K_r, K_err, C_err, None

    # ------------------------------------------------------------------ forces of the reduction
    def multipliers(self, q, r) -> np.ndarray:
        """λ: the loop forces (minimum norm, Φ_qᵀλ = r on the loops' rows) balancing the residual r (nv, or a
        function giving it: called only with loops); empty without loops."""
        if self._loops is None:
            return np.zeros(0)
        return self._loops.multipliers(self._loops.jacobian(q), r() if callable(r) else r)

    def constraint_force(self, lam):
        """q ↦ Φ_q(q)ᵀ λ (nv): the loops' generalized forces at fixed λ (None without loops)."""
        if self._loops is None:
            return None
        c = self._loops
        return lambda q: c.jacobian(q).T @ lam

    def split(self, lam) -> dict:
        """{loop name: its part of λ}."""
        return {} if self._loops is None else self._loops.split(lam)

    def held_forces(self, tau) -> dict[str, float]:
        """{drive name, or coordinate held at a speed: the entry of ``tau`` (nv, N or N·m) there}: the force
        each holder exerts along its coordinate, from the inverse dynamics τ = M a + b + g − Q."""
        out = {} if self._drives is None else self._drives.of(tau)
        out.update({self.coordinates[i]: float(tau[i]) for i in self.held_speeds})
        return out

    def refuse(self, name: str, independent) -> ModelError:
        """The error for a coordinate ``name`` that is not one of ``independent`` (names) of a reduced model."""
        if name in self.coordinates:
            i = self.coordinates.index(name)
            if self._drives is not None and i in self._drives.index:
                k = list(self._drives.index).index(i)
                return ModelError(f"coordinate '{name}' is driven (drive '{self._drives.names[k]}' prescribes it): "
                                  f"it is no coordinate of the linear model (free: {', '.join(independent)})")
            if i in self.held_speeds:
                return ModelError(f"coordinate '{name}' is held at its speed: it is no coordinate of the linear model "
                                  f"(free: {', '.join(independent)})")
            return ModelError(f"coordinate '{name}' is not an independent motion of the mechanism (its loops fix "
                              f"it; independent: {', '.join(independent)}): give a body point "
                              "(body, (x, y, z), (dx, dy, dz)) instead")
        return ModelError(f"unknown coordinate '{name}' (independent coordinates: {', '.join(independent)})")


def compile_reduction(system) -> Reduction:
    """The system's own reduction (its drives and loops; nothing held at a speed)."""
    return Reduction(system, system.compiled_loops, system.compiled_drives)  # (the tables: they refer to no System)

