"""System: a scene compiled once into a Pinocchio model plus its force-element groups.

A system computes and keeps no analysis state: M(q) by CRBA, accelerations by ABA with every force element,
inverse dynamics by RNEA, energies, link reactions, and the Lie-group operations on configurations. SI units:
q and v in m and rad (per coordinate), forces in N and N·m, energies in J.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from .._check import all_finite, count, finite_array, finite_result, scalar, unknown_name, vector3
from ..defaults import EPS, EQUILIBRIUM_TOL, FD_STEP, MAX_ITER, RTOL
from ..description.elements import WORLD, Support
from ..errors import ModelError

if TYPE_CHECKING:  # the analyses' result types, for the entry points' hints only (no import at run time)
    from numpy.typing import ArrayLike

    from ..analysis.equilibrium import OperatingPoint
    from ..analysis.linearize import LinearModel
    from ..simulation.simulate import Trajectory

Vector = np.ndarray  # shape (n,), float
Matrix = np.ndarray  # shape (n, m), float
from . import dynamics
from . import forces as _forces
from .constraints import compile_loops
from .drives import compile_drives
from .workspace import PerThread, Workspace


@dataclass(frozen=True)
class BodyInfo:
    """Where a scene body lives in the Pinocchio model."""

    name: str
    joint: object  # the vibdyn joint
    joint_id: int  # Pinocchio joint that moves it (its parent's for a Fixed body)
    body_in_joint: pin.SE3  # body frame expressed in that joint's frame
    idx_q: int
    idx_v: int
    nq: int
    nv: int
    coordinates: tuple

    @property
    def v_indices(self) -> range:
        return range(self.idx_v, self.idx_v + self.nv)


@dataclass(frozen=True)
class Energy:
    """Energies of a state (J): kinetic, gravity potential, elastic potential (springs)."""

    kinetic: float
    gravity: float
    elastic: float

    @property
    def potential(self) -> float:
        return self.gravity + self.elastic

    @property
    def total(self) -> float:
        return self.kinetic + self.gravity + self.elastic


@dataclass(frozen=True)
class Reactions:
    """Wrench each joint transmits from the parent to the body it carries (the link unknowns).

    ``force`` (N) and ``moment`` (N·m, about the joint origin) per body with coordinates, in world axes;
    ``force_local``/``moment_local`` in the joint's own axes; ``joint_force[name]`` the part along the
    joint's coordinates (what its springs, dampers, motors and drive carry), the rest being the ideal reaction;
    ``drive[name]`` the force (N or N·m) each drive exerts along its coordinate, τ_d = (M a + b + g − Q)_d.
    """

    bodies: tuple
    force: np.ndarray
    moment: np.ndarray
    force_local: np.ndarray
    moment_local: np.ndarray
    joint_force: dict
    drive: dict = field(default_factory=dict)

    def __repr__(self):
        from .._format import summary

        big = np.linalg.norm(self.force, axis=1) if len(self.bodies) else np.zeros(0)
        top = f"largest {np.max(big, initial=0.0):.4g} N at '{self.bodies[int(np.argmax(big))]}'" if big.size else ""
        return summary("Reactions", f"{len(self.bodies)} links", top)

    def __getitem__(self, body):
        i = self.bodies.index(body)
        return self.force[i], self.moment[i]


class System:
    """A compiled scene. Build it with :meth:`vibdyn.Scene.build`.

    ``coordinates`` and ``units`` ("m" or "rad") name the tangent coordinates; ``limits`` maps a
    coordinate to its position limits (lower, upper) in m or rad (from a URDF or ``Scene.set_limits``),
    which equilibrium searches refuse to leave.

    A System is immutable once built (setting an attribute raises) and computes in workspaces
    (:class:`vibdyn.model.workspace.Workspace`: Pinocchio Data and force buffers): its methods use one per
    thread (:meth:`workspace`), so threads may share a System; the free functions of
    :mod:`vibdyn.model.dynamics` take the workspace explicitly. The protocol analyses use: the checked
    inputs :meth:`check_configuration`, :meth:`check_velocity`, :meth:`check_time`,
    :meth:`check_mass_matrix`; the compiled tables ``body_infos`` (name -> :class:`BodyInfo`),
    ``support_index`` (support name -> index in ``supports``), ``force_groups`` (force-element groups),
    ``point_groups``/``point_joints``/``uses_point_velocities`` (what point elements need), ``joint_groups``
    (the others); ``coordinate_scales`` (1 for rad, the length scale for m) and ``inverse_scale_products``
    (1/(s_i s_j), nv × nv), ``additive_coordinates`` and
    ``curved_coordinates`` (which tangent coordinates move by a sum, which by ``integrate``);
    ``model`` and ``model_without_gravity`` (pinocchio.Model, read only); ``drives`` (driven and free
    coordinates, the drives' values and forces: :class:`vibdyn.model.drives.Drives`; None without drives).
    """

    def __setattr__(self, name, value):
        if self.__dict__.get("_built", False):
            raise AttributeError(f"System '{self.name}' is immutable once built: cannot set '{name}' (edit the "
                                 "scene and build it again)")
        object.__setattr__(self, name, value)

    def __getstate__(self):
        """What a pickle keeps (a System goes to a process pool or a Dask worker): everything but the
        workspaces (scratch: a copy makes its own); read-only tables as plain dicts."""
        state = dict(self.__dict__)
        del state["_per_thread"]
        proxies = [key for key, value in state.items() if isinstance(value, MappingProxyType)]
        state.update({key: dict(state[key]) for key in proxies}, _proxies=proxies)
        return state

    def __setstate__(self, state):
        state = dict(state)
        for key in state.pop("_proxies", ()):
            state[key] = MappingProxyType(state[key])
        self.__dict__.update(state, _per_thread=PerThread())

    def workspace(self) -> Workspace:
        """The calling thread's workspace (created on first use): what this System's methods compute in."""
        local = self._per_thread
        ws = local.workspace
        if ws is None:
            ws = local.workspace = Workspace(self.model)
        return ws

    def new_workspace(self) -> Workspace:
        """A fresh workspace of this System, for a caller that wants its own (see :mod:`vibdyn.model.dynamics`)."""
        return Workspace(self.model)

    @property
    def data(self) -> pin.Data:
        """The calling thread's Pinocchio Data (its :meth:`workspace`'s)."""
        return self.workspace().data

    def __init__(self, scene):
        self.scene = scene.copy()
        self.name = scene.name
        order = self.scene.tree_order()
        leaves = self.scene.massless_leaves(order)
        if leaves:
            raise ModelError(f"body '{leaves[0]}' has zero mass and carries no mass: its motion is undefined "
                             "(give it a mass or weld it with Fixed; for a loaded robot: weld_massless=True)")
        self.model, infos = _compile(self.scene, order)
        self.body_infos = MappingProxyType(infos)
        self.model.gravity.linear = np.array(self.scene.gravity)
        # the same model without gravity (read only, like ``model``): RNEA at rest on it is −Σ Jᵀ f of the
        # external forces alone (generalized_forces), with no gravity term to subtract
        self.model_without_gravity = pin.Model(self.model)
        self.model_without_gravity.gravity = pin.Motion.Zero()
        self._per_thread = PerThread()
        self.workspace()  # the first workspace now: a scene too large for memory is refused at build time
        self.nq, self.nv = self.model.nq, self.model.nv
        # unit quaternions (ball, free) and unit (cos, sin) pairs (planar) that q must hold
        self._unit_blocks = tuple((b.name, b.idx_q + b.joint.unit_block[0], b.joint.unit_block[1])
                                  for b in self.body_infos.values() if b.joint.unit_block is not None)
        self.coordinates = tuple(c for b in self.body_infos.values() for c in b.coordinates)
        self.units = tuple(u for b in self.body_infos.values() for u in b.joint.units)  # "m" or "rad"
        self.bodies = tuple(self.body_infos)
        # position limits (m or rad, offsets from neutral) of one-coordinate joints, from a URDF or set_limits
        self.limits = MappingProxyType(dict(self.scene.limits))
        self._lower, self._upper = np.full(self.nv, -np.inf), np.full(self.nv, np.inf)
        for name, (lo, up) in self.limits.items():
            self._lower[self.coordinate_index(name)], self._upper[self.coordinate_index(name)] = lo, up
        self.has_gravity = bool(np.any(self.scene.gravity))
        self.supports = tuple(self.scene.elements_of(Support))
        self.support_index = MappingProxyType({s.name: i for i, s in enumerate(self.supports)})
        self.force_groups = tuple(_forces.compile_groups(self, self.scene))
        self.point_groups = tuple(g for g in self.force_groups if g.uses_points)
        self.joint_groups = tuple(g for g in self.force_groups if not g.uses_points)
        self.point_joints = tuple(sorted({int(j) for g in self.point_groups for j in g.joints} - {0}))
        self.uses_point_velocities = any(g.uses_point_velocities for g in self.force_groups)
        self.depends_on_velocity = any(g.velocity_dependent for g in self.force_groups)
        # drives (vibdyn.model.drives.Drives, None without): prescribed coordinates; the others are free
        self.drives = compile_drives(self)
        self.depends_on_time = any(g.time_dependent for g in self.force_groups) or bool(self.supports or self.drives)
        self._lower.flags.writeable = self._upper.flags.writeable = False
        self.length_scale, extent = self._length_scale()
        # finite-difference scale per tangent coordinate: 1 rad, or the length scale for a length (m)
        self.coordinate_scales = np.array([self.length_scale if u == "m" else 1.0 for u in self.units])
        self.coordinate_scales.flags.writeable = False
        self.inverse_scale_products = 1.0 / np.outer(self.coordinate_scales, self.coordinate_scales)
        self.inverse_scale_products.flags.writeable = False
        # tangent coordinates of vector-space joints (nq = nv: integrate is the sum) with their index in q,
        # and the others (ball, planar, free), which move by integrate (vibdyn.model.fd.Stencil)
        additive = [(b.idx_v + i, b.idx_q + i) for b in self.body_infos.values() if b.nq == b.nv
                    for i in range(b.nv)]
        self.additive_coordinates = tuple(np.array(c, dtype=int) for c in zip(*additive)) if additive else (
            np.zeros(0, int), np.zeros(0, int))
        self.curved_coordinates = tuple(k for b in self.body_infos.values() if b.nq != b.nv for k in b.v_indices)
        # indices in q of the angles whose q is the angle itself (pivots, ...): q and q ± 2π are one pose
        self.periodic_coordinates = np.array([b.idx_q + i for b in self.body_infos.values()
                                              for i, p in enumerate(b.joint.periodic) if p], dtype=int)
        self.periodic_coordinates.flags.writeable = False
        self.inertia_scales = self._inertia_scales(extent)
        self._zero_v = np.zeros(self.nv)
        self._zero_v.flags.writeable = False
        self._mass_weights = 1.0 / np.outer(np.sqrt(self.inertia_scales), np.sqrt(self.inertia_scales))
        if self.nv:
            self._check_inertia()
        # the loops' equations (vibdyn.model.constraints.Constraints), None for a tree
        self.constraints = compile_loops(self) if self.scene.loops else None
        self._built = True

    @property
    def groups(self) -> tuple:
        """The former name of :attr:`force_groups`."""
        return self.force_groups

    # ------------------------------------------------------------- configuration space
    def neutral(self) -> Vector:
        """Neutral configuration (every joint at its zero; unit quaternions)."""
        return pin.neutral(self.model)

    def start_configuration(self) -> tuple[Vector, str]:
        """(q, what): the configuration analyses start from when given none (the scene's declared start,
        :meth:`Scene.set_operating_point`, else neutral: with loops, their closure nearest it) and its name."""
        start = (self.scene.operating_point or {}).get("start")
        if start is None:  # (with loops: vibdyn.model.assembly)
            return (self.neutral(), "the neutral configuration") if self.constraints is None else self.constraints.start()
        try:
            q = self.configuration(start)
        except ModelError as e:
            raise ModelError(f"operating point start: {e}") from None
        if isinstance(start, Mapping):
            text = ", ".join(f"{k} = {float(x):.6g}" for k, x in start.items())
        else:
            text = ", ".join(f"{k} = {float(x):.6g}" for k, x in zip(self.coordinates, np.ravel(start)))
        return q, f"the declared start ({text or 'neutral'})"

    def integrate(self, q: ArrayLike, dv: ArrayLike) -> Vector:
        """Configuration reached from q by the tangent displacement dv (exp map; never q + dv)."""
        return pin.integrate(self.model, self.check_configuration(q), self.check_velocity(dv, "dv"))

    def difference(self, q0: ArrayLike, q1: ArrayLike) -> Vector:
        """Tangent vector dv such that integrate(q0, dv) = q1 (log map)."""
        return pin.difference(self.model, self.check_configuration(q0), self.check_configuration(q1, "q1"))

    def _length_scale(self):
        """A characteristic length of the scene (m): the largest distance of a body origin, centre of mass
        or spring end from the world origin at the neutral configuration, or a spring's free length (at least
        1 mm); ``length_scale``, and the bodies' own extent (without the elements: what sizes their inertia)."""
        data = self.data
        pin.forwardKinematics(self.model, data, self.neutral())
        pts = [np.zeros(3)]
        for b in self.body_infos.values():
            M = data.oMi[b.joint_id] * b.body_in_joint
            pts += [M.translation, M.act(np.array(self.scene.bodies[b.name].com))]
        extent = max(1e-3, float(np.max(np.linalg.norm(pts, axis=1))))
        pts = [np.array(p, dtype=float) for e in self.scene.elements.values() for p in e.reference_points()]
        lengths = [float(x) for e in self.scene.elements.values() for x in e.reference_lengths()]
        return max([extent, *(float(np.linalg.norm(p)) for p in pts), *lengths]), extent

    def configuration(self, offsets: ArrayLike | Mapping[str, float]) -> Vector:
        """Configuration at tangent offsets from neutral (m or rad): one per coordinate, or a dict
        {coordinate: offset} (the others at 0)."""
        dv = np.zeros(self.nv)
        if isinstance(offsets, dict):
            for name, x in offsets.items():
                dv[self.coordinate_index(name)] = x
        else:
            dv = np.asarray(offsets, dtype=float)
            if dv.shape != (self.nv,):
                raise ModelError(f"offsets: expected {count(self.nv, 'number')} (one per coordinate: "
                                 f"{', '.join(self.coordinates)}), got {dv.size}")
        return self.integrate(self.neutral(), dv)

    def limit_bounds(self) -> tuple[Vector, Vector]:
        """(lower, upper): position limits per tangent coordinate (offsets from neutral, m or rad; ±inf
        where a coordinate has none). See :attr:`limits` (coordinate -> (lower, upper))."""
        return self._lower.copy(), self._upper.copy()

    def check_limits(self, q: ArrayLike, what: str = "q") -> None:
        """Raise ModelError naming the first coordinate of ``q`` outside its position limits."""
        if not self.limits:
            return
        x = self.difference(self.neutral(), q)
        for i in np.flatnonzero((x < self._lower) | (x > self._upper)):
            side, bound = ("lower", self._lower[i]) if x[i] < self._lower[i] else ("upper", self._upper[i])
            u = self.units[i]
            raise ModelError(f"{what}: coordinate '{self.coordinates[i]}' = {x[i]:.6g} {u} is beyond its {side} "
                             f"limit {bound:.6g} {u}")

    def random_configuration(self, scale: float = 1.0, rng: Any = None) -> Vector:
        """A configuration at a random tangent offset (normal, std ``scale`` m or rad) from neutral."""
        rng = np.random.default_rng(rng)
        return pin.integrate(self.model, self.neutral(), scale * rng.standard_normal(self.nv))

    # ------------------------------------------------------------- closed loops (vibdyn.description.loops)
    @property
    def has_loops(self) -> bool:
        return self.constraints is not None

    @property
    def dof(self) -> int:
        """Mobility of the mechanism: nv − rank of the loops' Jacobian at the first closed configuration met
        (``constraints.closed``: assembled from the start at build, or by the first analysis; nv for a tree).
        See :meth:`mobility` for another configuration."""
        return self.nv if self.constraints is None else self.constraints.dof

    def mobility(self, q: ArrayLike) -> int:
        """nv − rank of the loops' constraint Jacobian at q (rank by SVD, vibdyn.description.loops.RANK_RTOL)."""
        return self.nv if self.constraints is None else self.nv - self.constraints.rank(self.check_configuration(q))

    def constraint_residual(self, q: ArrayLike) -> Vector:
        """Φ(q): the loops' equations at q (m for positions, rad for orientations; empty for a tree)."""
        return np.zeros(0) if self.constraints is None else self.constraints.phi(self.check_configuration(q))

    def constraint_jacobian(self, q: ArrayLike) -> Matrix:
        """Φ_q(q) (equations × nv): the loops' Jacobian in the tangent space (m/m, m/rad, rad/rad, ...)."""
        if self.constraints is None:
            return np.zeros((0, self.nv))
        return self.constraints.jacobian(self.check_configuration(q))

    def assemble(self, q0: ArrayLike | None = None) -> Vector:
        """The consistent configuration (loops closed) nearest q0 (if None, the start:
        :meth:`start_configuration`): Gauss–Newton with minimum-norm steps in the tangent space, pivot angles
        kept within π of q0's. ConvergenceError naming the loop and the start if the loops cannot be closed."""
        q0, start = self.start_configuration() if q0 is None else (self.check_configuration(q0, "q0"), "q0")
        return q0.copy() if self.constraints is None else self.constraints.assemble(q0, start=start)

    # ------------------------------------------------------------- dynamics
    def mass_matrix(self, q: ArrayLike) -> Matrix:
        """Mass matrix M(q) (nv × nv, kg, kg·m or kg·m²) by CRBA, symmetric."""
        return finite_result(dynamics.mass_matrix(self.model, self.data, self.check_configuration(q)), "mass matrix")

    def accelerations(self, q: ArrayLike, v: ArrayLike, t: float = 0.0) -> Vector:
        """dv/dt (m/s², rad/s²) by ABA with gravity and every force element of the scene; with drives, a_d is
        the laws' at t and the free ones solve the free rows, q and v taken as given (:mod:`vibdyn.model.drives`)."""
        q, v, t = self.check_configuration(q), self.check_velocity(v), self.check_time(t)
        a = dynamics.accelerations(self, self.workspace(), q, v, t)
        if not all_finite(a):
            self.check_mass_matrix(q, "this configuration")
            raise ModelError(f"accelerations are not finite at t = {t} (state too large?)")
        return a.copy()

    def generalized_forces(self, q: ArrayLike, v: ArrayLike, t: float = 0.0) -> Vector:
        """Q(q, v, t) (N or N·m per coordinate): the generalized force of every force element (not gravity)."""
        q, v, t = self.check_configuration(q), self.check_velocity(v), self.check_time(t)
        ws = self.workspace()
        Q, fext = dynamics.forces(self, ws, q, v, t)
        if fext is not None:  # Σ Jᵀf of the point forces: RNEA at rest on the model without gravity
            Q -= pin.rnea(self.model_without_gravity, ws.data, q, self._zero_v, self._zero_v, fext)
        return finite_result(Q, f"generalized forces at t = {t}")

    def gravity_forces(self, q: ArrayLike) -> Vector:
        """Generalized gravity force g(q) (N or N·m): the force gravity exerts, −∂V_gravity/∂q."""
        return -dynamics.gravity_term(self, self.workspace(), self.check_configuration(q))

    def inverse_dynamics(self, q: ArrayLike, v: ArrayLike, a: ArrayLike, t: float = 0.0) -> Vector:
        """Generalized force (N or N·m) to add to the scene's own forces to move with acceleration a:
        M a + b(q, v) − Q(q, v, t), by RNEA; zero when a = accelerations(q, v, t)."""
        tau = dynamics.inverse_dynamics(self, self.workspace(), self.check_configuration(q), self.check_velocity(v), self.check_velocity(a, "a"), self.check_time(t))
        return finite_result(tau, f"inverse dynamics at t = {t}")

    def energy(self, q: ArrayLike, v: ArrayLike, t: float = 0.0) -> Energy:
        """Kinetic, gravity and elastic energies (J) at time t (springs on moving supports depend on it).
        Work of dampers and applied forces is not included."""
        q, v, t = self.check_configuration(q), self.check_velocity(v), self.check_time(t)
        kinetic = pin.computeKineticEnergy(self.model, self.data, q, v)
        gravity = pin.computePotentialEnergy(self.model, self.data, q) if self.has_gravity else 0.0
        kin = dynamics.kinematics(self, self.workspace(), q, None, t) if self.point_groups else None
        elastic = sum(g.potential(q, kin) for g in self.force_groups)
        finite_result([kinetic, gravity, elastic], f"energy at t = {t}")
        return Energy(float(kinetic), float(gravity), float(elastic))

    def reactions(self, q: ArrayLike, v: ArrayLike, a: ArrayLike, t: float = 0.0,
                  loop_forces: ArrayLike | None = None) -> Reactions:
        """Link wrenches (:class:`Reactions`) at the state (q, v) moving with accelerations a, by RNEA.
        ``loop_forces``: the loops' multipliers λ (an equilibrium's ``multipliers``), applied to the bodies
        they join (see :mod:`vibdyn.description.loops`)."""
        q, v, a = self.check_configuration(q), self.check_velocity(v), self.check_velocity(a, "a")
        Q, fext = dynamics.forces(self, self.workspace(), q, v, t)
        if loop_forces is not None and self.constraints is not None:
            fext = self.constraints.add_to(q, np.asarray(loop_forces, dtype=float), fext)
        tau = pin.rnea(self.model, self.data, q, v, a) if fext is None else pin.rnea(self.model, self.data, q, v, a, fext)
        pin.updateGlobalPlacements(self.model, self.data)  # RNEA leaves oMi as the last call set it
        names, fl, ml, fw, mw, jf = [], [], [], [], [], {}
        for b in self.body_infos.values():
            if b.nv == 0:
                continue
            f = self.data.f[b.joint_id]
            R = self.data.oMi[b.joint_id].rotation
            names.append(b.name)
            fl.append(f.linear.copy())
            ml.append(f.angular.copy())
            fw.append(R @ f.linear)
            mw.append(R @ f.angular)
            S = self.data.joints[b.joint_id].S
            jf[b.name] = np.asarray(S).reshape(6, -1).T @ f.vector
        return Reactions(tuple(names), np.array(fw).reshape(-1, 3), np.array(mw).reshape(-1, 3),
                         np.array(fl).reshape(-1, 3), np.array(ml).reshape(-1, 3), jf,
                         {} if self.drives is None else self.drives.of(tau - Q))

    # ------------------------------------------------------------- analyses
    def equilibrium(self, q0: ArrayLike | None = None, t: float = 0.0, tol: float = EQUILIBRIUM_TOL,
                    max_iter: int = MAX_ITER) -> OperatingPoint:
        """Static equilibrium near q0 (see :func:`vibdyn.analysis.equilibrium.static_equilibrium`; with loops
        :func:`vibdyn.analysis.constrained.equilibrium`, q0 need not be consistent)."""
        from ..analysis.equilibrium import static_equilibrium

        return static_equilibrium(self, q0, t, tol, max_iter)

    def equilibria(self, starts: Iterable[ArrayLike], t: float = 0.0, tol: float = EQUILIBRIUM_TOL,
                   max_iter: int = MAX_ITER) -> list[OperatingPoint]:
        """Distinct static equilibria from several starts (see :func:`vibdyn.analysis.equilibrium.equilibria`)."""
        from ..analysis.equilibrium import equilibria

        return equilibria(self, starts, t, tol, max_iter)

    def steady_motion(self, v_cyclic: Mapping[str, float | None], q0: ArrayLike | None = None, t: float = 0.0,
                      tol: float = EQUILIBRIUM_TOL, max_iter: int = MAX_ITER, guess: float = 1.0) -> OperatingPoint:
        """Steady motion with the coordinates of ``v_cyclic`` turning at constant speed (given, or None
        for found) (see :func:`vibdyn.analysis.equilibrium.steady_motion`; with loops
        :func:`vibdyn.analysis.constrained.steady_motion`, speeds given)."""
        from ..analysis.equilibrium import steady_motion

        return steady_motion(self, v_cyclic, q0, t, tol, max_iter, guess)

    def held(self, q: ArrayLike | None = None, v: ArrayLike | None = None, t: float = 0.0) -> OperatingPoint:
        """The configuration ``q`` (neutral if None), moving at constant velocity ``v`` (0 if None), held by
        drives on every coordinate: an operating point (like :meth:`steady_motion`'s) whose ``drive`` is the
        generalized force (N or N·m per coordinate) that balances gravity, the elastic and the other forces
        there (see :func:`vibdyn.analysis.equilibrium.held`). Linearise it with ``.linearize()``."""
        from ..analysis.equilibrium import held

        return held(self, q, v, t)

    def operating_point(self, tol: float = EQUILIBRIUM_TOL, max_iter: int = MAX_ITER) -> OperatingPoint:
        """The scene's declared operating point (:meth:`Scene.set_operating_point`): the configuration held
        by drives (:meth:`held`) if it says so (robots' default), a steady motion if it names cyclic
        coordinates, else the static equilibrium nearest its start (neutral by default)."""
        op = self.scene.operating_point or {}
        # (a mechanism with loops starts from the declared start itself, and names it if it cannot close)
        q0 = self.start_configuration()[0] if op.get("start") is not None and self.constraints is None else None
        if op.get("held"):
            return self.held(q0)
        if op.get("cyclic"):
            return self.steady_motion(op["cyclic"], q0, tol=tol, max_iter=max_iter)
        return self.equilibrium(q0, tol=tol, max_iter=max_iter)

    def linearize(self, at: Any = None, *, v: ArrayLike | None = None, t: float = 0.0, a: ArrayLike | None = None,
                  method: str = "fd", step: float = FD_STEP) -> LinearModel:
        """Linear model (M, C, K, error estimate) about ``at`` (see :func:`vibdyn.analysis.linearize.linearize`; with
        loops :func:`vibdyn.analysis.constrained.linearize`, in the mechanism's independent motions)."""
        from ..analysis.linearize import linearize

        return linearize(self, at, v=v, t=t, a=a, method=method, step=step)

    def simulate(self, t_end: float, q0: ArrayLike | None = None, v0: ArrayLike | None = None,
                 method: str = "dop853", rtol: float = RTOL, atol: float | None = None, dt: float | None = None,
                 t_eval: ArrayLike | None = None, *, t0: float = 0.0, events: Any = None, variational: bool = False,
                 **options: Any) -> Trajectory:
        """Nonlinear motion from (q0, v0) at ``t0`` to the absolute time ``t_end`` (s): a Trajectory with
        energies, error estimate and elapsed time; ``events`` (zero crossings of f(t, q, v)) and
        ``variational`` (the state transition) as :func:`vibdyn.simulation.simulate.simulate` says."""
        from ..simulation.simulate import simulate

        return simulate(self, t_end, q0, v0, method, rtol, atol, dt, t_eval, t0=t0, events=events,
                        variational=variational, **options)

    def momentum_matrix(self, q: ArrayLike, point: ArrayLike = (0.0, 0.0, 0.0)) -> tuple[Matrix, Matrix]:
        """(A_lin, A_ang) (3 × nv each): the linear momentum p = A_lin v (kg·m/s) and the angular momentum
        about ``point`` (m, world) k = A_ang v (kg·m²/s) of every body at q, from Pinocchio's centroidal map.
        Transposed, they are the generalized inertia loads of a unit base acceleration: A_linᵀ d for a
        translation along d, A_angᵀ a for an angular acceleration about a through ``point``."""
        q = self.check_configuration(q)
        data = self.data
        A = np.asarray(pin.computeCentroidalMap(self.model, data, q)).reshape(6, self.nv)  # ((6,) when nv = 1)
        lin, ang = A[:3].copy(), A[3:].copy()
        ang += pin.skew(data.com[0] - vector3(point, "point")) @ lin  # about the point, not the centre of mass
        return lin, ang

    # ------------------------------------------------------------- geometry
    def body_pose(self, body: str, q: ArrayLike) -> tuple[Matrix, Vector]:
        """(R, p): rotation (3×3) and origin (m) of a body's frame in world axes."""
        b = self.body_info(body)
        pin.forwardKinematics(self.model, self.data, self.check_configuration(q))
        M = self.data.oMi[b.joint_id] * b.body_in_joint
        return M.rotation.copy(), M.translation.copy()

    def point_position(self, body: str, point: ArrayLike, q: ArrayLike) -> Vector:
        """World position (m) of a point given in a body's frame."""
        R, p = self.body_pose(body, q)
        return R @ vector3(point, f"point of body '{body}'") + p

    def point_velocity(self, body: str, point: ArrayLike, q: ArrayLike, v: ArrayLike) -> Vector:
        """World velocity (m/s) of a point given in a body's frame."""
        b = self.body_info(body)
        pin.forwardKinematics(self.model, self.data, self.check_configuration(q), self.check_velocity(v))
        local = b.body_in_joint.act(vector3(point, f"point of body '{body}'"))
        vj = self.data.v[b.joint_id]
        return self.data.oMi[b.joint_id].rotation @ (vj.linear + np.cross(vj.angular, local))

    # ------------------------------------------------------------- lookups
    def body_info(self, name: str) -> BodyInfo:
        """Where a body (by its name or its joint's name) lives in the model (:class:`BodyInfo`)."""
        if isinstance(name, str) and name in self.body_infos:
            return self.body_infos[name]
        return self.body_infos[self.scene.body(name).name]

    def body_in_joint(self, name: str) -> pin.SE3:
        return self.body_info(name).body_in_joint

    def coordinate_index(self, name: str) -> int:
        """Index in v of a tangent coordinate, by name (see :attr:`coordinates`)."""
        try:
            return self.coordinates.index(name)
        except ValueError:
            raise unknown_name(name, self.coordinates, "coordinate") from None

    def attachments(self, atts: Sequence[tuple[str, ArrayLike]]) -> tuple[np.ndarray, np.ndarray]:
        """(joint ids, points in joint frames) of ``[(body, point), ...]``; world points on joint 0."""
        joints, local = [], []
        for body, point in atts:
            if body == WORLD or body in self.support_index:
                joints.append(0)
                local.append(np.asarray(point, dtype=float))
            else:
                b = self.body_info(body)
                joints.append(b.joint_id)
                local.append(b.body_in_joint.act(np.asarray(point, dtype=float)))
        return np.array(joints, dtype=int), np.array(local, dtype=float).reshape(-1, 3)

    def support_indices(self, atts: Sequence[tuple[str, ArrayLike]]) -> np.ndarray:
        """Index of the support each attachment of ``[(body, point), ...]`` is on, −1 for none."""
        return np.array([self.support_index.get(body, -1) for body, _ in atts], dtype=int)

    def __repr__(self):
        return f"System({self.name!r}, nq={self.nq}, nv={self.nv}, {len(self.force_groups)} force groups)"

    def _inertia_scales(self, extent):
        """Per coordinate, the scene's scale of M's diagonal: its total mass (kg, for m) or total mass × the
        bodies' extent² plus their rotational inertias (kg·m², for rad; a spring's far end or free length
        does not size a body's inertia); ``inertia_scales``."""
        bodies = self.scene.bodies.values()
        mass = sum(b.mass for b in bodies)
        rot = mass * extent**2 + sum(float(np.trace(np.array(b.inertia))) for b in bodies)
        scales = np.array([mass if u == "m" else rot for u in self.units])
        scales.flags.writeable = False
        return scales

    def _check_inertia(self):
        """At build: a body without inertia along one of its coordinates is refused. The test is made at
        neutral and, only if M is singular there, at a second configuration: a mass matrix singular at
        neutral alone is a singular point of the motion (a slider at the axis of a pivot), refused where
        an analysis meets it, not a fault of the description."""
        try:
            self.check_mass_matrix(self.neutral(), "the neutral configuration")
        except ModelError:
            try:
                self.check_mass_matrix(self.random_configuration(0.5, rng=0), "a random configuration")
            except ModelError:
                pass
            else:
                return
            raise

    def check_mass_matrix(self, q: ArrayLike, where: str, M: Matrix | None = None) -> None:
        """ModelError naming the body and coordinate if M(q) is singular against the scene's scales: an
        eigenvalue of S^-½ M S^-½ (S: :meth:`inertia_scales`) below 1000·nv·ε is round-off, not inertia."""
        M = self.mass_matrix(q) if M is None else M
        Ms = M * self._mass_weights
        tol = 1e3 * self.nv * EPS
        # fast sufficient test: Ms = LLᵀ gives λ_min(Ms) = 1/‖L⁻¹‖₂² ≥ 1/‖L⁻¹‖_F² (at most nv times too
        # cautious; a NaN or inf anywhere fails it); only where that bound is not enough do the eigenvalues
        # decide (LAPACK directly: the wrappers of numpy and scipy cost more than these solves on small models)
        from scipy.linalg import lapack  # (on first use: not at `import vibdyn`)

        L, info = lapack.dpotrf(Ms, lower=1)
        if info == 0:
            Linv, info = lapack.dtrtri(L, lower=1, overwrite_c=1)  # (L's other triangle is zero: so is Linv's)
            x = Linv.ravel(order="K")  # (LAPACK's column order: a view)
            if info == 0 and (x @ x) * tol < 1.0:
                return
        if not all_finite(Ms):
            raise ModelError(f"mass matrix at {where} is not finite")
        w, V, info = lapack.dsyevd(Ms)
        s = np.sqrt(self.inertia_scales)
        if info == 0 and w[0] > tol:
            return
        i = int(np.argmax(np.abs(V[:, 0])))
        coord = self.coordinates[i]
        body = next(b.name for b in self.body_infos.values() if i in b.v_indices)
        raise ModelError(f"singular mass matrix at {where}: body '{body}' has no inertia along its coordinate "
                         f"'{coord}' (smallest eigenvalue of M {w[0] * s[i] ** 2:.3g}, {w[0]:.2g} of the scene's "
                         "inertia scale); give it mass or inertia")

    def check_configuration(self, q: ArrayLike, what: str = "q") -> Vector:
        x = _state(q, self.nq, what, lambda: f"a configuration of {count(self.nq, 'number')}")
        for body, i, n in self._unit_blocks:
            norm = np.linalg.norm(x[i:i + n])
            if abs(norm - 1.0) > 1e-3:
                raise ModelError(f"{what}: the {'quaternion' if n == 4 else '(cos, sin) pair'} of body '{body}'"
                                 f" (q[{i}:{i + n}]) must have unit norm, got {norm:.6g}")
        return x

    def check_velocity(self, v: ArrayLike, what: str = "v") -> Vector:
        return _state(v, self.nv, what, lambda: f"{count(self.nv, 'number')} (one per coordinate)")

    def check_time(self, t: float | None) -> float:
        """A finite time (s); None only for a scene that does not depend on time."""
        if t is None and not self.depends_on_time:
            return 0.0
        return scalar(t, "t (time, s)")


_FLOAT = np.dtype(float)


def _state(x, n, what, expected):
    """A finite float vector of n numbers (the one input layer: finite_array), a new array; ``expected()``
    says what it should be in the error."""
    if type(x) is np.ndarray and x.dtype is _FLOAT and x.shape == (n,) and all_finite(x):
        return x.copy()  # the common case, without finite_array's conversions
    try:
        return finite_array(x, (n,), what)
    except ModelError as e:
        detail = str(e)[len(what) + 2:]
        if detail.startswith("contains"):
            raise
        got = f"shape {detail.split('got ', 1)[1]}" if detail.startswith("expected shape") else repr(x)
        raise ModelError(f"{what}: expected {expected()}, got {got}") from None


def _compile(scene, order):
    """The Pinocchio model of a scene (bodies in ``order``) and, per body, where it lives in it."""
    model = pin.Model()
    model.name = scene.name
    infos = {}
    for body in order:
        if body.parent == WORLD:
            parent_jid, parent_B = 0, pin.SE3.Identity()
        else:
            p = infos[body.parent]
            parent_jid, parent_B = p.joint_id, p.body_in_joint
        J = body.joint
        placement = parent_B * J.placement
        if J.nv == 0:
            jid, B = parent_jid, placement
            idx_q = idx_v = model.nq if parent_jid == 0 else model.idx_qs[parent_jid]
        else:
            A = J.alignment
            jid = model.addJoint(parent_jid, J.pin_model(), placement * pin.SE3(A, np.zeros(3)),
                                 J.name or body.name)
            B = pin.SE3(A.T, np.zeros(3))
            idx_q, idx_v = model.idx_qs[jid], model.idx_vs[jid]
        I_body = np.array(body.inertia)
        inertia = pin.Inertia(body.mass, B.act(np.array(body.com)), B.rotation @ I_body @ B.rotation.T)
        _append_body(model, jid, inertia)
        if J.nv:  # (Pinocchio's addFrame searches every frame by name: one per welded body would be quadratic)
            model.addFrame(pin.Frame(body.name, jid, B, pin.FrameType.BODY), False)  # inertia added above
        infos[body.name] = BodyInfo(body.name, J, jid, B, idx_q, idx_v, J.nv and model.nqs[jid], J.nv,
                                    body.coordinates)
    return model, infos


def _append_body(model, jid, inertia):
    """Add a body's inertia to joint ``jid``'s. Summed as dynamic parameters (m, m·c, I about the joint:
    linear, no division): Pinocchio's Inertia addition divides by max(m, ε) and so moves the centre of mass
    of a body lighter than ε ≈ 2e-16 kg to the joint."""
    p = model.inertias[jid].toDynamicParameters() + inertia.toDynamicParameters()
    model.appendBodyToJoint(jid, pin.Inertia.Zero(), pin.SE3.Identity())
    if p[0] > 0:
        model.inertias[jid] = pin.Inertia.FromDynamicParameters(p)
    else:  # massless: the rotational inertia about the joint only
        I = np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]])
        model.inertias[jid] = pin.Inertia(0.0, np.zeros(3), I)
