"""Dynamics of a compiled System as free functions over (system, workspace), in the manner of
``pin.aba(model, data, q, v, tau)``: no input checks (the hot paths of linearisation, Newton and time
integration; :class:`vibdyn.System`'s methods are the checked entry points). Every function writes only in
the workspace it is given, so callers with their own workspaces can run at once. SI units: q, v in m and
rad, t in s, forces in N and N·m. Results may share memory with the workspace: copy what you keep.
"""

import functools
from dataclasses import dataclass, field
from itertools import repeat

import numpy as np
import pinocchio as pin

from .._check import call_user, finite_array, finite_result
from ..errors import ModelError
from .fd import tangent_derivative
from .points import Kinematics


def forces(system, ws, q, v, t, shift=None):
    """(Q, fext): the force elements' joint-space forces Q (N or N·m per coordinate, a new array) and, if
    the scene has point elements, the external forces (the workspace's buffer) for ABA/RNEA, else None.
    ``shift`` offsets the supports' displacements and velocities (n_supports × 6, m and m/s)."""
    Q = joint_forces(system, q, v, t)
    if not system.point_groups:
        return Q, None
    return Q, point_forces(system, ws, q, v, t, Q, shift)


def joint_forces(system, q, v, t):
    """The joint-space force elements' generalized forces Q(q, v, t) (N or N·m per coordinate, a new array)."""
    Q = np.zeros(system.nv)
    for g in system.joint_groups:
        g.apply(t, q, v, None, Q, None)
    return Q


def point_forces(system, ws, q, v, t, Q, shift=None):
    """The point elements' external forces for ABA/RNEA (the workspace's buffer, joint frames); what they
    add in joint space goes into Q."""
    kin = kinematics(system, ws, q, v if system.uses_point_velocities else None, t, shift)
    F = np.zeros((system.model.njoints, 6))
    for g in system.point_groups:
        g.apply(t, q, v, kin, Q, F)
    for j in system.point_joints:
        ws.forces[j][:] = F[j]
    return ws.fext


def inverse_dynamics_rows(system, ws, Q, V, a, t, shift=None):
    """(τ, F): RNEA's M a + b (N or N·m) at each row of the configurations Q (B × nq), velocities V and
    accelerations a (B × nv; either may be one row for all, V and a also one nv-vector), with the point
    elements' forces, and the joint-space force elements' generalized forces F (B × nv); the inverse dynamics
    is τ − F. ``t``: a time (s), or one per row; ``shift``: the supports' offsets per row (B × n_supports × 6,
    see :func:`forces`). One pass over the rows: each
    joint-space group, and each point group that can (``rows``), evaluates every row at once; with neither
    velocity nor acceleration, RNEA reduces to the gravity term (nothing at all without gravity)."""
    nv = system.nv
    rows_v, rows_a = V.ndim == 2, getattr(a, "ndim", 0) == 2
    B = max(len(Q), len(V) if rows_v else 1, len(a) if rows_a else 1)
    if len(Q) < B:
        Q = np.broadcast_to(Q, (B, system.nq))
    if rows_v and len(V) < B:
        V = np.broadcast_to(V, (B, nv))
    if rows_a and len(a) < B:
        a = np.broadcast_to(a, (B, nv))
    F = np.zeros((B, nv))
    t_rows = not isinstance(t, float) and np.ndim(t) > 0
    for g in system.joint_groups:
        if t_rows and g.time_dependent:
            for c in range(B):
                g.apply(float(t[c]), Q[c], V[c] if V.ndim == 2 else V, None, F[c], None)
        else:
            g.apply_rows(float(t[0]) if t_rows else t, Q, V, F)
    model, data = system.model, ws.data
    tau = np.empty((B, nv))
    if system.point_groups:
        batched = all(g.rows for g in system.point_groups)
        if batched:
            Vr = (V if rows_v else np.broadcast_to(V, (B, nv))) if system.uses_point_velocities else None
            kin = kinematics_rows(system, ws, Q, Vr, t, shift)
            Fx = np.zeros((B, model.njoints, 6))
            for g in system.point_groups:
                g.apply(t, Q, V, kin, F, Fx)
        for c in range(B):
            v = V[c] if rows_v else V
            tc = float(t[c]) if t_rows else t
            if batched:
                for j in system.point_joints:
                    ws.forces[j][:] = Fx[c, j]
                fext = ws.fext
            else:
                fext = point_forces(system, ws, Q[c], v, tc, F[c], None if shift is None else shift[c])
            tau[c] = pin.rnea(model, data, Q[c], v, a[c] if rows_a else a, fext)
    elif not is_gravity(system, V, a):
        rnea = pin.rnea  # (one list built and copied in at once: cheaper than a row assignment per call)
        tau[:] = [rnea(model, data, q, v, acc) for q, v, acc in zip(Q, V if rows_v else repeat(V),
                                                                      a if rows_a else repeat(a))]
    elif system.has_gravity:
        g = pin.computeGeneralizedGravity
        tau[:] = [g(model, data, q) for q in Q]
    else:
        tau[:] = 0.0
    return tau, F


def generalized_forces(system, ws, q, v, t):
    """Q(q, v, t) (N or N·m per coordinate, a new array): the generalized force of every force element (not
    gravity); a point element's by Σ Jᵀf, RNEA at rest on the model without gravity."""
    Q, fext = forces(system, ws, q, v, t)
    if fext is not None:
        zero = np.zeros(system.nv)
        Q -= pin.rnea(system.model_without_gravity, ws.data, q, zero, zero, fext)
    return Q

def is_gravity(system, v, a):
    """Whether RNEA at velocities v and accelerations a (any shape) is the gravity term alone: no point
    elements, v = 0 and a = 0."""
    return not (system.point_groups or np.count_nonzero(v) or np.count_nonzero(a))


def kinematics(system, ws, q, v=None, t=0.0, shift=None):
    """Poses (and velocities if ``v`` is given) of the joints point elements attach to, with the supports'
    displacements and velocities at t (:class:`vibdyn.model.forces.Kinematics`)."""
    return Kinematics(system.model, ws, system.point_joints, q, v, supports_motion(system, t, shift))


def kinematics_rows(system, ws, Q, V=None, t=0.0, shift=None):
    """:func:`kinematics` at each row of Q (B × nq), V (B × nv or None), t (a time or B of them, s) and
    ``shift`` (None or B × n_supports × 6): one :meth:`Kinematics.rows`."""
    supports = None
    if system.supports:
        if np.ndim(t) == 0 and shift is None:
            sp, sv = supports_motion(system, t, None)
            supports = (np.broadcast_to(sp, (len(Q),) + sp.shape), np.broadcast_to(sv, (len(Q),) + sv.shape))
        else:
            ts = np.broadcast_to(t, (len(Q),))
            rows = [supports_motion(system, ts[c], None if shift is None else shift[c]) for c in range(len(Q))]
            supports = (np.array([r[0] for r in rows]), np.array([r[1] for r in rows]))
    return Kinematics.rows(system.model, ws, system.point_joints, Q, V, supports)


def supports_motion(system, t, shift=None):
    """(sp, sv): the supports' displacements and velocities at t (m, m/s; one row per support and a last
    zero row), offset by ``shift``; None without supports."""
    if not system.supports:
        return None
    n = len(system.supports)
    sp, sv = np.zeros((n + 1, 3)), np.zeros((n + 1, 3))
    for i, s in enumerate(system.supports):
        for out, part in ((sp, "position"), (sv, "velocity")):
            x = call_user(getattr(s.motion, part), (t,), f"support '{s.name}' {part}", t)
            out[i] = finite_array(x, (3,), f"support '{s.name}': motion is not finite or not 3 numbers "
                                           f"({part} at t = {t})")
    if shift is not None:
        sp[:n] += shift[:, :3]
        sv[:n] += shift[:, 3:]
    if not (np.all(np.isfinite(sp)) and np.all(np.isfinite(sv))):
        bad = next(s.name for i, s in enumerate(system.supports)
                   if not (np.all(np.isfinite(sp[i])) and np.all(np.isfinite(sv[i]))))
        raise ModelError(f"support '{bad}': motion is not finite at t = {t}")
    return sp, sv


def gravity_term(system, ws, q):
    """RNEA's gravity term g(q) (N or N·m): the generalized force that holds the scene against gravity
    (minus the force gravity exerts); zeros without gravity (no work is done)."""
    if not system.has_gravity:
        return np.zeros(system.nv)
    return pin.computeGeneralizedGravity(system.model, ws.data, q).copy()


def inverse_dynamics(system, ws, q, v, a, t, shift=None):
    """M a + b(q, v) − Q(q, v, t) (N or N·m): what must be added to the scene's own forces to move with
    acceleration a, by RNEA. ``shift``: see :func:`forces`."""
    Q, fext = forces(system, ws, q, v, t, shift)
    tau = (pin.rnea(system.model, ws.data, q, v, a) if fext is None
           else pin.rnea(system.model, ws.data, q, v, a, fext))
    return tau - Q


def accelerations(system, ws, q, v, t, applied=None):
    """dv/dt (m/s², rad/s²) by ABA with gravity and every force element (with closed loops, the loops'
    constrained accelerations; with drives, a_d from the laws at t and a_f from the free rows, q and v as
    given: :meth:`vibdyn.model.drives.Drives.accelerations`). May share memory with the workspace.
    ``applied``: the elements' forces at (q, v, t) as :func:`forces` gives them, if already evaluated."""
    if system.compiled_drives is not None:
        return system.compiled_drives.accelerations(system, ws, q, v, t)
    Q, fext = forces(system, ws, q, v, t) if applied is None else applied
    model, data = system.model, ws.data
    a = pin.aba(model, data, q, v, Q) if fext is None else pin.aba(model, data, q, v, Q, fext)
    if system.compiled_loops is not None:
        a = a.copy()
        return system.compiled_loops.accelerations(q, v, a, mass_matrix(model, data, q))
    return a


def held_accelerations(system, ws, q, v, t, a, free):
    """(a, h, M): dv/dt at (q, v, t) with the held coordinates' accelerations given in ``a`` (nv; its ``free``
    entries are filled in place) and the free ones from their rows of the equations of motion,
    M_ff a_f = −h_f with h = RNEA(q, v, a⁰) − Q at a⁰ = (a_f = 0, the held ones) (Cholesky of M_ff by CRBA, no
    inverse; NaN where M_ff is not positive definite: the free coordinates have no inertia there, which the
    callers' checks name). ``h`` and ``M`` (None without free coordinates) give the holders' forces,
    h_held + M_held,f a_f. Unchecked (the hot path of a driven scene)."""
    h = inverse_dynamics(system, ws, q, v, a, t)
    if not free.size:
        return a, h, None
    M = mass_matrix(system.model, ws.data, q)
    from scipy.linalg import lapack  # (on first use: not at `import vibdyn`)

    _, x, info = lapack.dposv(M[np.ix_(free, free)], -h[free])
    a[free] = x if info == 0 else np.nan
    return a, h, M


def accelerations_function(system, ws, keep=None):
    """``accelerations(system, ws, q, v, t)`` as a function of (q, v, t) made once for this scene (the hot path
    of time integration): a scene with neither drives, loops nor point elements runs ABA on its joint-space
    forces alone, and on none without joint-space elements; any other scene, :func:`accelerations` itself.
    ``keep``: a one-item list in which a scene with point elements (and neither drives nor loops) leaves the
    forces of each evaluation, as :func:`forces` gives them (a Jacobian at the same state reuses them)."""
    if system.compiled_drives is not None or system.compiled_loops is not None or (
            system.point_groups and keep is None):
        return lambda q, v, t: accelerations(system, ws, q, v, t)
    if system.point_groups:
        def kept(q, v, t):
            keep[0] = applied = forces(system, ws, q, v, t)
            return accelerations(system, ws, q, v, t, applied)

        return kept
    model, data, aba = system.model, ws.data, pin.aba
    if not system.joint_groups:
        zero = np.zeros(system.nv)
        return lambda q, v, t: aba(model, data, q, v, zero)
    return lambda q, v, t: aba(model, data, q, v, joint_forces(system, q, v, t))


def mass_matrix(model, data, q):
    """M(q) by CRBA, both triangles filled (a new array)."""
    M = pin.crba(model, data, q)
    return M if _crba_fills_both() else np.triu(M) + np.triu(M, 1).T


@functools.cache
def _crba_fills_both():
    """Whether this Pinocchio's Python crba returns the full symmetric matrix (4.x does) rather than its upper
    triangle, checked once (at the first mass matrix, not at import) on a sample arm."""
    model = pin.buildSampleModelManipulator()
    M = pin.crba(model, model.createData(), pin.neutral(model))
    return bool(np.any(np.tril(M, -1)) and np.array_equal(M, M.T))


def cancelling_terms(system, ws, q, v, a, t):
    """|RNEA| + |Q| + |g| per coordinate: the size of the terms that cancel in the inverse dynamics (the
    scale of its round-off, N or N·m)."""
    Q, fext = forces(system, ws, q, v, t)
    tau = (pin.rnea(system.model, ws.data, q, v, a) if fext is None
           else pin.rnea(system.model, ws.data, q, v, a, fext))
    return np.abs(tau) + np.abs(Q) + np.abs(gravity_term(system, ws, q))


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


def energy(system, ws, q, v, t):
    """Kinetic, gravity and elastic energies (J, :class:`Energy`) at (q, v, t); ModelError if not finite."""
    model, data = system.model, ws.data
    kinetic = pin.computeKineticEnergy(model, data, q, v)
    gravity = pin.computePotentialEnergy(model, data, q) if system.has_gravity else 0.0
    kin = kinematics(system, ws, q, None, t) if system.point_groups else None
    elastic = sum(g.potential(q, kin) for g in system.force_groups)
    finite_result([kinetic, gravity, elastic], f"energy at t = {t}")
    return Energy(float(kinetic), float(gravity), float(elastic))


def energy_gradient(system, q: np.ndarray, v: np.ndarray, h: np.ndarray, t: float = 0.0,
                    reference: float = 0.0) -> np.ndarray:
    """∂E/∂(δq, δv) at (q, v, t) (J per m or rad, then per m/s or rad/s), δq in the tangent space at q: central
    differences of the energy less ``reference`` (J) with steps h (m or rad, one per tangent coordinate:
    :func:`vibdyn.model.fd.tangent_derivative`) for q, M v for v. The energy rows of shooting and backbones."""
    dq = tangent_derivative(system, lambda qq: system.energy(qq, v, t).total - reference, q, h)[0]
    return np.concatenate([dq, system.mass_matrix(q) @ v])


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


def reactions(system, ws, q, v, a, t, loop_forces=None):
    """Link wrenches (:class:`Reactions`) at (q, v) moving with accelerations a at t, by RNEA; ``loop_forces``
    the loops' multipliers λ, applied to the bodies they join."""
    Q, fext = forces(system, ws, q, v, t)
    if loop_forces is not None and system.compiled_loops is not None:
        fext = system.compiled_loops.add_to(q, np.asarray(loop_forces, dtype=float), fext)
    model, data = system.model, ws.data
    tau = pin.rnea(model, data, q, v, a) if fext is None else pin.rnea(model, data, q, v, a, fext)
    pin.updateGlobalPlacements(model, data)  # RNEA leaves oMi as the last call set it
    names, fl, ml, fw, mw, jf = [], [], [], [], [], {}
    for b in system.body_infos.values():
        if b.nv == 0:
            continue
        f = data.f[b.joint_id]
        R = data.oMi[b.joint_id].rotation
        names.append(b.name)
        fl.append(f.linear.copy())
        ml.append(f.angular.copy())
        fw.append(R @ f.linear)
        mw.append(R @ f.angular)
        S = data.joints[b.joint_id].S
        jf[b.name] = np.asarray(S).reshape(6, -1).T @ f.vector
    return Reactions(tuple(names), np.array(fw).reshape(-1, 3), np.array(mw).reshape(-1, 3),
                     np.array(fl).reshape(-1, 3), np.array(ml).reshape(-1, 3), jf,
                     {} if system.compiled_drives is None else system.compiled_drives.of(tau - Q))
