"""System: a scene compiled once into a Pinocchio model plus its force-element groups.

A system computes and keeps no analysis state: M(q) by CRBA, accelerations by ABA with every force element,
inverse dynamics by RNEA, energies, link reactions, and the Lie-group operations on configurations. SI units:
q and v in m and rad (per coordinate), forces in N and N·m, energies in J.
"""

import os
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from . import forces as _forces
from ._check import call_user, count, finite_array, finite_result, scalar, unknown_name, vector3
from .elements import WORLD, Spring, Support
from .errors import ModelError


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
    def v_indices(self):
        return range(self.idx_v, self.idx_v + self.nv)


@dataclass(frozen=True)
class Energy:
    """Energies of a state (J): kinetic, gravity potential, elastic potential (springs)."""

    kinetic: float
    gravity: float
    elastic: float

    @property
    def potential(self):
        return self.gravity + self.elastic

    @property
    def total(self):
        return self.kinetic + self.gravity + self.elastic


@dataclass(frozen=True)
class Reactions:
    """Wrench each joint transmits from the parent to the body it carries (the link unknowns).

    ``force`` (N) and ``moment`` (N·m, about the joint origin) per body with coordinates, in world axes;
    ``force_local``/``moment_local`` in the joint's own axes; ``joint_force[name]`` the part along the
    joint's coordinates (what its springs, dampers and motors carry), the rest being the ideal reaction.
    """

    bodies: tuple
    force: np.ndarray
    moment: np.ndarray
    force_local: np.ndarray
    moment_local: np.ndarray
    joint_force: dict

    def __repr__(self):
        from ._format import summary

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
    """

    def __init__(self, scene):
        self.scene = scene.copy()
        self.name = scene.name
        order = _topological(self.scene)
        leaves = _massless_leaves(order)
        if leaves:
            raise ModelError(f"body '{leaves[0]}' has zero mass and carries no mass: its motion is undefined "
                             "(give it a mass or weld it with Fixed; for a loaded robot: weld_massless=True)")
        self.model, self._bodies = _compile(self.scene, order)
        self.model.gravity.linear = np.array(self.scene.gravity)
        self.data = _create_data(self.model)
        self.nq, self.nv = self.model.nq, self.model.nv
        # unit quaternions (ball, free) and unit (cos, sin) pairs (planar) that q must hold
        self._unit_blocks = tuple((b.name, b.idx_q + b.nq - n, n) for b in self._bodies.values()
                                  if b.joint.kind in ("ball", "free", "planar")
                                  for n in [2 if b.joint.kind == "planar" else 4])
        self.coordinates = tuple(c for b in self._bodies.values() for c in b.coordinates)
        self.units = tuple(u for b in self._bodies.values() for u in b.joint.units)  # "m" or "rad"
        self.bodies = tuple(self._bodies)
        # position limits (m or rad, offsets from neutral) of one-coordinate joints, from a URDF or set_limits
        self.limits = dict(self.scene.limits)
        self._lower, self._upper = np.full(self.nv, -np.inf), np.full(self.nv, np.inf)
        for name, (lo, up) in self.limits.items():
            self._lower[self.coordinate_index(name)], self._upper[self.coordinate_index(name)] = lo, up
        self.has_gravity = bool(np.any(self.scene.gravity))
        self.supports = tuple(self.scene.elements_of(Support))
        self._support_index = {s.name: i for i, s in enumerate(self.supports)}
        self.groups = _forces.compile_groups(self, self.scene, self._free_lengths())
        self._point_groups = [g for g in self.groups if g.uses_points]
        self._point_joints = tuple(sorted({int(j) for g in self._point_groups for j in g.joints} - {0}))
        self._point_velocities = any(g.uses_point_velocities for g in self.groups)
        self.depends_on_velocity = any(g.velocity_dependent for g in self.groups)
        self.depends_on_time = any(g.time_dependent for g in self.groups) or bool(self.supports)
        self._fext = pin.StdVec_Force()
        for _ in range(self.model.njoints):
            self._fext.append(pin.Force.Zero())
        if self.nv:
            self._check_mass_matrix(self.neutral(), "the neutral configuration")
        self.constraints = None  # the loops' equations (vibdyn.loops.Constraints), None for a tree
        if getattr(self.scene, "loops", None):
            from .loops import compile_loops

            self.constraints = compile_loops(self)

    # ------------------------------------------------------------- configuration space
    def neutral(self):
        """Neutral configuration (every joint at its zero; unit quaternions)."""
        return pin.neutral(self.model)

    def integrate(self, q, dv):
        """Configuration reached from q by the tangent displacement dv (exp map; never q + dv)."""
        return pin.integrate(self.model, self._q(q), self._v(dv, "dv"))

    def difference(self, q0, q1):
        """Tangent vector dv such that integrate(q0, dv) = q1 (log map)."""
        return pin.difference(self.model, self._q(q0), self._q(q1, "q1"))

    @property
    def length_scale(self):
        """A characteristic length of the scene (m): the largest distance of a body origin, centre of mass
        or spring end from the world origin at the neutral configuration (at least 1 mm)."""
        if not hasattr(self, "_length_scale"):
            pin.forwardKinematics(self.model, self.data, self.neutral())
            pts = [np.zeros(3)]
            for b in self._bodies.values():
                M = self.data.oMi[b.joint_id] * b.body_in_joint
                pts += [M.translation, M.act(np.array(self.scene.bodies[b.name].com))]
            pts += [np.array(e.a[1]) for e in self.scene.elements_of(Spring)]
            self._length_scale = max(1e-3, float(np.max(np.linalg.norm(pts, axis=1))))
        return self._length_scale

    def configuration(self, offsets):
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

    def limit_bounds(self):
        """(lower, upper): position limits per tangent coordinate (offsets from neutral, m or rad; ±inf
        where a coordinate has none). See :attr:`limits` (coordinate -> (lower, upper))."""
        return self._lower.copy(), self._upper.copy()

    def check_limits(self, q, what="q"):
        """Raise ModelError naming the first coordinate of ``q`` outside its position limits."""
        if not self.limits:
            return
        x = self.difference(self.neutral(), q)
        for i in np.flatnonzero((x < self._lower) | (x > self._upper)):
            side, bound = ("lower", self._lower[i]) if x[i] < self._lower[i] else ("upper", self._upper[i])
            u = self.units[i]
            raise ModelError(f"{what}: coordinate '{self.coordinates[i]}' = {x[i]:.6g} {u} is beyond its {side} "
                             f"limit {bound:.6g} {u}")

    def random_configuration(self, scale=1.0, rng=None):
        """A configuration at a random tangent offset (normal, std ``scale`` m or rad) from neutral."""
        rng = np.random.default_rng(rng)
        return pin.integrate(self.model, self.neutral(), scale * rng.standard_normal(self.nv))

    # ------------------------------------------------------------- closed loops (vibdyn.loops)
    @property
    def has_loops(self):
        return self.constraints is not None

    @property
    def dof(self):
        """Mobility of the mechanism: nv − rank of the loops' Jacobian at the configuration assembled from
        neutral (nv for a tree). See :meth:`mobility` for another configuration."""
        return self.nv if self.constraints is None else self.constraints.dof

    def mobility(self, q):
        """nv − rank of the loops' constraint Jacobian at q (rank by SVD, vibdyn.loops.RANK_RTOL)."""
        return self.nv if self.constraints is None else self.nv - self.constraints.rank(self._q(q))

    def constraint_residual(self, q):
        """Φ(q): the loops' equations at q (m for positions, rad for orientations; empty for a tree)."""
        return np.zeros(0) if self.constraints is None else self.constraints.residual(self._q(q))

    def constraint_jacobian(self, q):
        """Φ_q(q) (equations × nv): the loops' Jacobian in the tangent space (m/m, m/rad, rad/rad, ...)."""
        if self.constraints is None:
            return np.zeros((0, self.nv))
        return self.constraints.jacobian(self._q(q))

    def assemble(self, q0=None):
        """The consistent configuration (loops closed) nearest q0 (neutral if None): Gauss–Newton with
        minimum-norm steps in the tangent space. ConvergenceError if the loops cannot be closed there."""
        q0 = self.neutral() if q0 is None else self._q(q0, "q0")
        return q0.copy() if self.constraints is None else self.constraints.assemble(q0)

    # ------------------------------------------------------------- dynamics
    def mass_matrix(self, q):
        """Mass matrix M(q) (nv × nv, kg, kg·m or kg·m²) by CRBA, symmetric."""
        M = pin.crba(self.model, self.data, self._q(q))
        M = np.triu(M) + np.triu(M, 1).T
        return finite_result(M, "mass matrix")

    def accelerations(self, q, v, t=0.0):
        """dv/dt (m/s², rad/s²) by ABA with gravity and every force element of the scene."""
        q, v, t = self._q(q), self._v(v), self._t(t)
        a = self._accelerations(q, v, t)
        if not np.all(np.isfinite(a)):
            self._check_mass_matrix(q, "this configuration")
            raise ModelError(f"accelerations are not finite at t = {t} (state too large?)")
        return a.copy()

    def _accelerations(self, q, v, t):
        """accelerations without input or output checks (the hot path of time integration). The result may
        share memory with Pinocchio's data: copy it to keep it across dynamics calls."""
        Q, fext = self._forces(q, v, t)
        if self.constraints is not None:  # the loops' constrained accelerations (vibdyn.loops)
            a = pin.aba(self.model, self.data, q, v, Q) if fext is None else pin.aba(self.model, self.data, q, v,
                                                                                       Q, fext)
            return self.constraints.accelerations(q, v, a.copy(), self.mass_matrix(q))
        if fext is None:
            return pin.aba(self.model, self.data, q, v, Q)
        return pin.aba(self.model, self.data, q, v, Q, fext)

    def generalized_forces(self, q, v, t=0.0):
        """Q(q, v, t) (N or N·m per coordinate): the generalized force of every force element (not gravity)."""
        q, v, t = self._q(q), self._v(v), self._t(t)
        Q, fext = self._forces(q, v, t)
        if fext is not None:
            zero = np.zeros(self.nv)
            Q -= pin.rnea(self.model, self.data, q, zero, zero, fext) - self._gravity_forces(q)
        return finite_result(Q, f"generalized forces at t = {t}")

    def gravity_forces(self, q):
        """Generalized gravity force g(q) (N or N·m): the force gravity exerts, −∂V_gravity/∂q."""
        return -self._gravity_forces(self._q(q))

    def inverse_dynamics(self, q, v, a, t=0.0):
        """Generalized force (N or N·m) to add to the scene's own forces to move with acceleration a:
        M a + b(q, v) − Q(q, v, t), by RNEA; zero when a = accelerations(q, v, t)."""
        tau = self._residual(self._q(q), self._v(v), self._v(a, "a"), self._t(t))
        return finite_result(tau, f"inverse dynamics at t = {t}")

    def _residual(self, q, v, a, t, shift=None):
        """inverse_dynamics without input checks (the hot path of linearisation and Newton); ``shift``
        offsets the supports' displacements and velocities (n_supports × 6) for base-excitation inputs."""
        Q, fext = self._forces(q, v, t, shift)
        tau = (pin.rnea(self.model, self.data, q, v, a) if fext is None
               else pin.rnea(self.model, self.data, q, v, a, fext))
        return tau - Q

    def energy(self, q, v, t=0.0):
        """Kinetic, gravity and elastic energies (J) at time t (springs on moving supports depend on it).
        Work of dampers and applied forces is not included."""
        q, v, t = self._q(q), self._v(v), self._t(t)
        kinetic = pin.computeKineticEnergy(self.model, self.data, q, v)
        gravity = pin.computePotentialEnergy(self.model, self.data, q) if self.has_gravity else 0.0
        kin = self._kinematics(q, None, t) if self._point_groups else None
        elastic = sum(g.potential(q, kin) for g in self.groups)
        finite_result([kinetic, gravity, elastic], f"energy at t = {t}")
        return Energy(float(kinetic), float(gravity), float(elastic))

    def reactions(self, q, v, a, t=0.0, loop_forces=None):
        """Link wrenches (:class:`Reactions`) at the state (q, v) moving with accelerations a, by RNEA.
        ``loop_forces``: the loops' multipliers λ (an equilibrium's ``multipliers``), applied to the bodies
        they join (see :mod:`vibdyn.loops`)."""
        q, v, a = self._q(q), self._v(v), self._v(a, "a")
        _, fext = self._forces(q, v, t)
        if loop_forces is not None and self.constraints is not None:
            fext = self.constraints.add_to(q, np.asarray(loop_forces, dtype=float), fext)
        if fext is None:
            pin.rnea(self.model, self.data, q, v, a)
        else:
            pin.rnea(self.model, self.data, q, v, a, fext)
        pin.updateGlobalPlacements(self.model, self.data)  # RNEA leaves oMi as the last call set it
        names, fl, ml, fw, mw, jf = [], [], [], [], [], {}
        for b in self._bodies.values():
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
                         np.array(fl).reshape(-1, 3), np.array(ml).reshape(-1, 3), jf)

    # ------------------------------------------------------------- analyses
    def equilibrium(self, q0=None, t=0.0, tol=1e-10, max_iter=100):
        """Static equilibrium near q0 (see :func:`vibdyn.equilibrium.static_equilibrium`; with loops
        :func:`vibdyn.constrained.equilibrium`, q0 need not be consistent)."""
        if self.constraints is not None:
            from .constrained import equilibrium

            return equilibrium(self, q0, t, tol, max_iter)
        from .equilibrium import static_equilibrium

        return static_equilibrium(self, q0, t, tol, max_iter)

    def equilibria(self, starts, t=0.0, tol=1e-10, max_iter=100):
        """Distinct static equilibria from several starts (see :func:`vibdyn.equilibrium.equilibria`)."""
        from .equilibrium import equilibria

        return equilibria(self, starts, t, tol, max_iter)

    def steady_motion(self, v_cyclic, q0=None, t=0.0, tol=1e-10, max_iter=100, guess=1.0):
        """Steady motion with the coordinates of ``v_cyclic`` turning at constant speed (given, or None
        for found) (see :func:`vibdyn.equilibrium.steady_motion`)."""
        from .equilibrium import steady_motion

        self._no_loops("steady_motion")
        return steady_motion(self, v_cyclic, q0, t, tol, max_iter, guess)

    def held(self, q=None, v=None, t=0.0):
        """The configuration ``q`` (neutral if None), moving at constant velocity ``v`` (0 if None), held by
        drives on every coordinate: an operating point (like :meth:`steady_motion`'s) whose ``drive`` is the
        generalized force (N or N·m per coordinate) that balances gravity, the elastic and the other forces
        there (see :func:`vibdyn.equilibrium.held`). Linearise it with ``.linearize()``."""
        from .equilibrium import held

        self._no_loops("held")
        return held(self, q, v, t)

    def _no_loops(self, what):
        if self.constraints is not None:
            raise ModelError(f"{what}: not available for a mechanism with closed loops (loops: "
                             f"{', '.join(lp.name for lp in self.constraints.loops)}); use equilibrium()")

    def operating_point(self, tol=1e-10, max_iter=100):
        """The scene's declared operating point (:meth:`Scene.set_operating_point`): the configuration held
        by drives (:meth:`held`) if it says so (robots' default), a steady motion if it names cyclic
        coordinates, else the static equilibrium nearest its start (neutral by default)."""
        op = self.scene.operating_point or {}
        q0 = None
        if op.get("start") is not None:
            try:
                q0 = self.configuration(op["start"])
            except ModelError as e:
                raise ModelError(f"operating point start: {e}") from None
        if op.get("held"):
            return self.held(q0)
        if op.get("cyclic"):
            return self.steady_motion(op["cyclic"], q0, tol=tol, max_iter=max_iter)
        return self.equilibrium(q0, tol=tol, max_iter=max_iter)

    def linearize(self, at=None, *, v=None, t=0.0, a=None, method="fd", step=1e-5):
        """Linear model (M, C, K, error estimate) about ``at`` (see :func:`vibdyn.linearize.linearize`; with
        loops :func:`vibdyn.constrained.linearize`, in the mechanism's independent motions)."""
        if self.constraints is not None:
            from .constrained import linearize as constrained_linearize

            return constrained_linearize(self, at, v=v, t=t, a=a, method=method, step=step)
        from .linearize import linearize

        return linearize(self, at, v=v, t=t, a=a, method=method, step=step)

    def simulate(self, t_end, q0=None, v0=None, method="dop853", rtol=1e-8, atol=None, dt=None, t_eval=None,
                 **options):
        """Nonlinear motion from (q0, v0) at t = 0 to ``t_end`` (s): a Trajectory with energies, error
        estimate and elapsed time (see :func:`vibdyn.simulate.simulate`)."""
        from .simulate import simulate

        if self.constraints is not None and str(method).lower() in ("symplectic", "variational"):
            raise ModelError(f"simulate: method '{method}' does not handle closed loops; use dop853, rk4 (projection "
                             "onto the loops after each step), radau or bdf")
        return simulate(self, t_end, q0, v0, method, rtol, atol, dt, t_eval, **options)

    # ------------------------------------------------------------- geometry
    def body_pose(self, body, q):
        """(R, p): rotation (3×3) and origin (m) of a body's frame in world axes."""
        b = self.body_info(body)
        pin.forwardKinematics(self.model, self.data, self._q(q))
        M = self.data.oMi[b.joint_id] * b.body_in_joint
        return M.rotation.copy(), M.translation.copy()

    def point_position(self, body, point, q):
        """World position (m) of a point given in a body's frame."""
        R, p = self.body_pose(body, q)
        return R @ vector3(point, f"point of body '{body}'") + p

    def point_velocity(self, body, point, q, v):
        """World velocity (m/s) of a point given in a body's frame."""
        b = self.body_info(body)
        pin.forwardKinematics(self.model, self.data, self._q(q), self._v(v))
        local = b.body_in_joint.act(vector3(point, f"point of body '{body}'"))
        vj = self.data.v[b.joint_id]
        return self.data.oMi[b.joint_id].rotation @ (vj.linear + np.cross(vj.angular, local))

    # ------------------------------------------------------------- lookups
    def body_info(self, name):
        """Where a body (by its name or its joint's name) lives in the model (:class:`BodyInfo`)."""
        if isinstance(name, str) and name in self._bodies:
            return self._bodies[name]
        return self._bodies[self.scene.body(name).name]

    def body_in_joint(self, name):
        return self.body_info(name).body_in_joint

    def coordinate_index(self, name):
        """Index in v of a tangent coordinate, by name (see :attr:`coordinates`)."""
        try:
            return self.coordinates.index(name)
        except ValueError:
            raise unknown_name(name, self.coordinates, "coordinate") from None

    def attachments(self, atts):
        """(joint ids, points in joint frames) of ``[(body, point), ...]``; world points on joint 0."""
        joints, local = [], []
        for body, point in atts:
            if body == WORLD or body in self._support_index:
                joints.append(0)
                local.append(np.asarray(point, dtype=float))
            else:
                b = self.body_info(body)
                joints.append(b.joint_id)
                local.append(b.body_in_joint.act(np.asarray(point, dtype=float)))
        return np.array(joints, dtype=int), np.array(local, dtype=float).reshape(-1, 3)

    def support_indices(self, atts):
        """Index of the support each attachment of ``[(body, point), ...]`` is on, −1 for none."""
        return np.array([self._support_index.get(body, -1) for body, _ in atts], dtype=int)

    def __repr__(self):
        return f"System({self.name!r}, nq={self.nq}, nv={self.nv}, {len(self.groups)} force groups)"

    # ------------------------------------------------------------- internals
    def _forces(self, q, v, t, shift=None):
        """Joint-space forces Q and, if the scene has point elements, the external forces for ABA/RNEA."""
        Q = np.zeros(self.nv)
        if not self._point_groups:
            for g in self.groups:
                g.apply(t, q, v, None, Q, None)
            return Q, None
        kin = self._kinematics(q, v if self._point_velocities else None, t, shift)
        F = np.zeros((self.model.njoints, 6))
        for g in self.groups:
            g.apply(t, q, v, kin, Q, F)
        for j in self._point_joints:
            self._fext[j] = pin.Force(F[j, :3], F[j, 3:])
        return Q, self._fext

    def _kinematics(self, q, v, t=0.0, shift=None):
        supports = None
        if self.supports:
            n = len(self.supports)
            sp, sv = np.zeros((n + 1, 3)), np.zeros((n + 1, 3))
            for i, s in enumerate(self.supports):
                for out, part in ((sp, "position"), (sv, "velocity")):
                    x = call_user(getattr(s.motion, part), (t,), f"support '{s.name}' {part}", t)
                    out[i] = finite_array(x, (3,), f"support '{s.name}': motion is not finite or not 3 numbers "
                                                   f"({part} at t = {t})")
            if shift is not None:
                sp[:n] += shift[:, :3]
                sv[:n] += shift[:, 3:]
            if not (np.all(np.isfinite(sp)) and np.all(np.isfinite(sv))):
                bad = next(s.name for i, s in enumerate(self.supports)
                           if not (np.all(np.isfinite(sp[i])) and np.all(np.isfinite(sv[i]))))
                raise ModelError(f"support '{bad}': motion is not finite at t = {t}")
            supports = (sp, sv)
        return _forces.Kinematics(self.model, self.data, self._point_joints, q, v, supports)

    def _gravity_forces(self, q):
        if not self.has_gravity:
            return np.zeros(self.nv)
        return pin.computeGeneralizedGravity(self.model, self.data, q).copy()

    def _free_lengths(self):
        """Free length of each spring (m): as given, or the distance at the neutral configuration."""
        springs = self.scene.elements_of(Spring)
        if not springs:
            return []
        q0 = self.neutral()
        out = []
        for s in springs:
            xa, xb = self._anchor(s.a, q0), self._anchor(s.b, q0)
            L = float(np.linalg.norm(xb - xa))
            l0 = L if s.free_length is None else s.free_length
            if s.a[0] == s.b[0] and np.array_equal(np.asarray(s.a[1], float), np.asarray(s.b[1], float)):
                raise ModelError(f"spring '{s.name}': both ends are the same point of '{s.a[0]}' (coincident "
                                 "ends: its direction is undefined)")
            if s.free_length is None and L <= 1e-12:  # the threshold below with l0 = L
                raise ModelError(f"spring '{s.name}': its two ends coincide at the neutral configuration (at "
                                 f"{np.round(xa, 12).tolist()} m) and no free_length is given: attach the ends at "
                                 "distinct points, or give free_length=0 for a zero-length spring (force −k·d)")
            if l0 > 0 and L <= 1e-9 * max(l0, 1e-3):  # the threshold Springs uses at each call
                raise ModelError(f"spring '{s.name}': its two ends coincide at build time (neutral "
                                 "configuration), so its direction is undefined")
            out.append(l0)
        return out

    def _anchor(self, att, q, t=0.0):
        """World position (m) of an attachment (body point, world point or support point) at (q, t)."""
        body, point = att
        if body == WORLD:
            return np.array(point, dtype=float)
        if body in self._support_index:
            return np.array(point, dtype=float) + self.supports[self._support_index[body]].motion.position(t)
        return self.point_position(body, point, q)

    def inertia_scales(self):
        """Per coordinate, the scene's scale of M's diagonal: its total mass (kg, for m) or total mass ×
        length scale² plus the bodies' rotational inertias (kg·m², for rad)."""
        if not hasattr(self, "_inertia_scales"):
            bodies = self.scene.bodies.values()
            mass = sum(b.mass for b in bodies)
            rot = mass * self.length_scale**2 + sum(float(np.trace(np.array(b.inertia))) for b in bodies)
            self._inertia_scales = np.array([mass if u == "m" else rot for u in self.units])
        return self._inertia_scales

    def _check_mass_matrix(self, q, where, M=None):
        """ModelError naming the body and coordinate if M(q) is singular against the scene's scales: an
        eigenvalue of S^-½ M S^-½ (S: :meth:`inertia_scales`) below 1000·nv·ε is round-off, not inertia."""
        M = self.mass_matrix(q) if M is None else M
        s = np.sqrt(self.inertia_scales())
        Ms = M / np.outer(s, s)
        tol = 1e3 * self.nv * np.finfo(float).eps
        if not np.all(np.isfinite(Ms)):
            raise ModelError(f"mass matrix at {where} is not finite")
        w, V = np.linalg.eigh(Ms)
        if w[0] > tol:
            return
        i = int(np.argmax(np.abs(V[:, 0])))
        coord = self.coordinates[i]
        body = next(b.name for b in self._bodies.values() if i in b.v_indices)
        raise ModelError(f"singular mass matrix at {where}: body '{body}' has no inertia along its coordinate "
                         f"'{coord}' (smallest eigenvalue of M {w[0] * s[i] ** 2:.3g}, {w[0]:.2g} of the scene's "
                         "inertia scale); give it mass or inertia")

    def _q(self, q, what="q"):
        q = _state(q, self.nq, what, f"a configuration of {count(self.nq, 'number')}")
        for body, i, n in self._unit_blocks:
            norm = np.linalg.norm(q[i:i + n])
            if abs(norm - 1.0) > 1e-3:
                raise ModelError(f"{what}: the {'quaternion' if n == 4 else '(cos, sin) pair'} of body '{body}'"
                                 f" (q[{i}:{i + n}]) must have unit norm, got {norm:.6g}")
        return q

    def _v(self, v, what="v"):
        return _state(v, self.nv, what, f"{count(self.nv, 'number')} (one per coordinate)")

    def _t(self, t):
        """A finite time (s); None only for a scene that does not depend on time."""
        if t is None and not self.depends_on_time:
            return 0.0
        return scalar(t, "t (time, s)")


def _state(x, n, what, expected):
    """A finite float vector of n numbers (the one input layer, :func:`vibdyn._check.finite_array`)."""
    try:
        return finite_array(x, (n,), what)
    except ModelError as e:
        detail = str(e)[len(what) + 2:]
        if detail.startswith("contains"):
            raise
        got = f"shape {detail.split('got ', 1)[1]}" if detail.startswith("expected shape") else repr(x)
        raise ModelError(f"{what}: expected {expected}, got {got}") from None


def _create_data(model):
    """Pinocchio's Data, refused with a clear error where it cannot fit: Pinocchio 4.1 allocates and fills
    four nv×nv×nv tensors in every Data (32·nv³ bytes; upstream issue stack-of-tasks/pinocchio#2949)."""
    need = 2 * 32.0 * model.nv**3  # createData's peak: the tensors are built, then copied into Data
    free = available_memory()
    message = (f"scene '{model.name}' has nv = {model.nv} coordinates: Pinocchio {pin.__version__} allocates "
               f"{need / 2e9:.3g} GB of second-order-derivative tensors in every Data (32·nv³ bytes, "
               f"stack-of-tasks/pinocchio#2949) and peaks at twice that while building it, more than this "
               f"machine or container has free ({free / 1e9:.3g} GB)")
    if need > 0.8 * free:
        raise ModelError(message)
    try:
        return model.createData()
    except MemoryError:
        raise ModelError(message) from None


def available_memory():
    """Bytes this process can still allocate: the host's available pages, and the cgroup's limit minus its
    usage where there is one (a container sees the host's free memory, not its own limit)."""
    try:
        free = float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        free = float("inf")
    for limit_file, usage_file in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                                   ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                                    "/sys/fs/cgroup/memory/memory.usage_in_bytes")):
        try:
            with open(limit_file) as f:
                limit = f.read().strip()
            with open(usage_file) as f:
                usage = float(f.read().strip())
        except (OSError, ValueError):
            continue
        if limit.isdigit() and float(limit) < 2**60:
            free = min(free, float(limit) - usage)
        break
    return max(free, 0.0)


def massless_leaves(scene):
    """Names of the bodies with coordinates and zero mass that carry no mass below them."""
    return _massless_leaves(_topological(scene))


def _massless_leaves(order):
    """Bodies with coordinates and zero mass that carry no mass below them (their motion is undefined);
    ``order`` is parents-first."""
    carried = {b.name: b.mass for b in order}
    for b in reversed(order):
        if b.parent in carried:
            carried[b.parent] += carried[b.name]
    return [b.name for b in order if b.joint.nv > 0 and carried[b.name] == 0.0]


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


def _topological(scene):
    """Bodies depth-first from the world (Pinocchio's CRBA needs each subtree's coordinates contiguous);
    a cycle or an unknown parent is a ModelError."""
    rooted = {WORLD}  # bodies known to reach the world
    for b in scene.bodies.values():
        path, on_path, p = [b.name], {b.name}, b.parent
        while p not in rooted:
            if p not in scene.bodies:
                raise scene.unknown_body(p, f"body '{path[-1]}'", noun="parent", extra=(WORLD,))
            if p in on_path:
                raise ModelError(f"body '{b.name}': cycle in the parent links ({' -> '.join(path + [p])})")
            path.append(p)
            on_path.add(p)
            p = scene.bodies[p].parent
        rooted.update(path)
    children = {}
    for b in scene.bodies.values():
        children.setdefault(b.parent, []).append(b)
    order, stack = [], list(reversed(children.get(WORLD, [])))
    while stack:
        b = stack.pop()
        order.append(b)
        stack.extend(reversed(children.get(b.name, [])))
    return order
