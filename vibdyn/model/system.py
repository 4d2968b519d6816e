"""System: a scene compiled once (:mod:`.compile`), and the public face of what is computed on it, each checked
entry point forwarding to where the work lives (:mod:`.configuration`, :mod:`.dynamics`, :mod:`.geometry`,
:mod:`.inertia_check`, :mod:`vibdyn.analysis`, :mod:`vibdyn.simulation`). It keeps no analysis state. SI units:
q and v in m and rad (per coordinate), forces in N and N·m, energies in J.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from .._check import all_finite, count, finite_result, scalar, start_hint, unknown_name, vector3
from .._deprecation import Renamed
from ..defaults import EQUILIBRIUM_TOL, FD_STEP, MAX_ITER, RTOL
from ..errors import ModelError
from . import configuration as config
from . import dynamics, geometry, inertia_check
from .compile import BodyInfo, Compiled, attachments
from .configuration import state as _state
from .constraints import compile_loops
from .drives import compile_drives
from .dynamics import Energy, Reactions
from .reduction import compile_reduction
from .workspace import PerThread, Workspace

if TYPE_CHECKING:  # the analyses' result types, for the entry points' hints only (no import at run time)
    from numpy.typing import ArrayLike

    from ..analysis.equilibrium import OperatingPoint
    from ..analysis.linearize import LinearModel
    from ..simulation.simulate import Trajectory

Vector = np.ndarray  # shape (n,), float
Matrix = np.ndarray  # shape (n, m), float
__all__ = ["BodyInfo", "Energy", "Reactions", "System"]


class System(Compiled):
    """A compiled scene, immutable (setting an attribute raises). Build it with :meth:`vibdyn.Scene.build`.

    ``coordinates`` and ``units`` ("m" or "rad") name the tangent coordinates; ``limits`` maps a coordinate to
    its position limits (lower, upper) in m or rad, which equilibrium searches refuse to leave; the other
    compiled tables are listed by :class:`vibdyn.model.compile.Compiled`; ``drives``
    (:class:`vibdyn.model.drives.Drives`) and ``constraints`` (:class:`vibdyn.model.constraints.Constraints`)
    are None without drives or loops; ``reduction`` (:class:`vibdyn.model.reduction.Reduction`): how the
    coordinates reduce to the independent ones, what analyses use. Its methods compute in the thread's :meth:`workspace`
    (Pinocchio Data and force buffers), so threads may share a System; the free functions of
    :mod:`vibdyn.model.dynamics` and :mod:`vibdyn.model.geometry` take the workspace explicitly, and none reads
    what an earlier call left there. Analyses use the checked inputs (``check_*``) and the tables.
    """

    def __init__(self, scene):
        self._per_thread = PerThread()
        self._per_thread.workspace = self._compile_tree(scene)
        self._compile_elements()
        self.compiled_drives = compile_drives(self)  # (``drives``: bound to this system on access, Compiled.drives)
        self.depends_on_time = any(g.time_dependent for g in self.force_groups) or bool(self.supports or self.drives)
        if self.nv:
            inertia_check.check_inertia(self)
        self.compiled_loops = compile_loops(self) if self.scene.loops else None  # (bound on access: constraints)
        self.reduction = compile_reduction(self)
        self._built = True

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

    groups = Renamed("force_groups")  # (a Lie group is a joint's lie_group)

    # ------------------------------------------------------------- configuration space
    def neutral(self) -> Vector:
        """Neutral configuration (every joint at its zero; unit quaternions)."""
        return pin.neutral(self.model)

    def start_configuration(self) -> tuple[Vector, str]:
        """(q, what): the configuration analyses start from when given none (the scene's declared start,
        :meth:`Scene.set_operating_point`, else neutral: with loops, their closure nearest it) and its name."""
        return config.start_configuration(self)

    def integrate(self, q: ArrayLike, dv: ArrayLike) -> Vector:
        """Configuration reached from q by the tangent displacement dv (exp map; never q + dv)."""
        return pin.integrate(self.model, self.check_configuration(q), self.check_velocity(dv, "dv"))

    def difference(self, q0: ArrayLike, q1: ArrayLike) -> Vector:
        """Tangent vector dv such that integrate(q0, dv) = q1 (log map)."""
        return pin.difference(self.model, self.check_configuration(q0), self.check_configuration(q1, "q1"))

    def configuration(self, offsets: ArrayLike | Mapping[str, float]) -> Vector:
        """Configuration at tangent offsets from neutral (m or rad): one per coordinate, or a dict
        {coordinate: offset} (the others at 0)."""
        return config.configuration(self, offsets)

    def limit_bounds(self) -> tuple[Vector, Vector]:
        """(lower, upper): position limits per tangent coordinate (offsets from neutral, m or rad; ±inf
        where a coordinate has none). See :attr:`limits` (coordinate -> (lower, upper))."""
        return self.lower_limits.copy(), self.upper_limits.copy()

    def check_limits(self, q: ArrayLike, what: str = "q") -> None:
        """Raise ModelError naming the first coordinate of ``q`` outside its position limits."""
        config.check_limits(self, q, what)

    def random_configuration(self, scale: float = 1.0, rng: Any = None) -> Vector:
        """A configuration at a random tangent offset (normal, std ``scale`` m or rad) from neutral."""
        rng = np.random.default_rng(rng)
        return pin.integrate(self.model, self.neutral(), scale * rng.standard_normal(self.nv))

    # ------------------------------------------------------------- closed loops (vibdyn.description.loops)
    @property
    def has_loops(self) -> bool:
        return self.compiled_loops is not None

    @property
    def dof(self) -> int:
        """Mobility: nv − rank of the loops' Jacobian at the first closed configuration met (assembled at build
        or by the first analysis; nv for a tree). See :meth:`mobility` for another configuration."""
        return self.nv if self.constraints is None else self.constraints.dof

    def mobility(self, q: ArrayLike) -> int:
        """nv − rank of the loops' constraint Jacobian at q (rank by SVD, vibdyn.description.loops.RANK_RTOL)."""
        return self.nv if self.constraints is None else self.nv - self.constraints.rank(self.check_configuration(q))

    def constraint_residual(self, q: ArrayLike) -> Vector:
        """Φ(q): the loops' equations at q (m for positions, rad for orientations; empty for a tree)."""
        return np.zeros(0) if self.constraints is None else self.constraints.phi(self.check_configuration(q))

    def constraint_jacobian(self, q: ArrayLike) -> Matrix:
        """Φ_q(q) (equations × nv): the loops' Jacobian in the tangent space (m/m, m/rad, rad/rad, ...)."""
        q = self.check_configuration(q)
        return np.zeros((0, self.nv)) if self.constraints is None else self.constraints.jacobian(q)

    def assemble(self, q0: ArrayLike | None = None) -> Vector:
        """A configuration with the loops closed, reached from q0 (None: :meth:`start_configuration`) by Gauss–Newton
        (not searched for the nearest); ConvergenceError naming the loop and the start if they cannot be closed."""
        q0, start = self.start_configuration() if q0 is None else (self.check_configuration(q0, "q0"), "q0")
        if start == "q0":
            start_hint(self, q0, "assemble: q0")
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
        return finite_result(dynamics.generalized_forces(self, self.workspace(), q, v, t),
                             f"generalized forces at t = {t}")

    def gravity_forces(self, q: ArrayLike) -> Vector:
        """Generalized gravity force g(q) (N or N·m): the force gravity exerts, −∂V_gravity/∂q."""
        return -dynamics.gravity_term(self, self.workspace(), self.check_configuration(q))

    def inverse_dynamics(self, q: ArrayLike, v: ArrayLike, a: ArrayLike, t: float = 0.0) -> Vector:
        """Generalized force (N or N·m) to add to the scene's own forces to move with acceleration a:
        M a + b(q, v) − Q(q, v, t), by RNEA; zero when a = accelerations(q, v, t)."""
        tau = dynamics.inverse_dynamics(self, self.workspace(), self.check_configuration(q), self.check_velocity(v),
                                        self.check_velocity(a, "a"), self.check_time(t))
        return finite_result(tau, f"inverse dynamics at t = {t}")

    def energy(self, q: ArrayLike, v: ArrayLike, t: float = 0.0) -> Energy:
        """Kinetic, gravity and elastic energies (J) at time t (springs on moving supports depend on it).
        Work of dampers and applied forces is not included."""
        q, v, t = self.check_configuration(q), self.check_velocity(v), self.check_time(t)
        return dynamics.energy(self, self.workspace(), q, v, t)

    def reactions(self, q: ArrayLike, v: ArrayLike, a: ArrayLike, t: float = 0.0,
                  loop_forces: ArrayLike | None = None) -> Reactions:
        """Link wrenches (:class:`Reactions`, N and N·m) at (q, v) moving with accelerations a, by RNEA;
        ``loop_forces``: the loops' multipliers λ (an equilibrium's ``multipliers``) on the bodies they join."""
        q, v, a = self.check_configuration(q), self.check_velocity(v), self.check_velocity(a, "a")
        return dynamics.reactions(self, self.workspace(), q, v, a, t, loop_forces)

    def momentum_matrix(self, q: ArrayLike, point: ArrayLike = (0.0, 0.0, 0.0)) -> tuple[Matrix, Matrix]:
        """(A_lin, A_ang) (3 × nv each): linear momentum A_lin v (kg·m/s) and angular momentum about ``point``
        (m, world) A_ang v (kg·m²/s) of every body at q. Transposed, the generalized inertia loads of a unit
        base acceleration: A_linᵀ d for a translation along d, A_angᵀ a for a rotation about a through ``point``."""
        return geometry.momentum_matrix(self, self.workspace(), self.check_configuration(q), vector3(point, "point"))

    # ------------------------------------------------------------- analyses (vibdyn.analysis, vibdyn.simulation)
    def equilibrium(self, q0: ArrayLike | None = None, t: float = 0.0, tol: float = EQUILIBRIUM_TOL,
                    max_iter: int = MAX_ITER) -> OperatingPoint:
        """Static equilibrium near q0 (see :func:`vibdyn.analysis.equilibrium.static_equilibrium`; with loops
        q0 need not be consistent)."""
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
        for found) (see :func:`vibdyn.analysis.equilibrium.steady_motion`)."""
        from ..analysis.equilibrium import steady_motion

        return steady_motion(self, v_cyclic, q0, t, tol, max_iter, guess)

    def held(self, q: ArrayLike | None = None, v: ArrayLike | None = None, t: float = 0.0) -> OperatingPoint:
        """``q`` (neutral if None) moving at constant ``v`` (0 if None), held by drives on every coordinate
        (``drive``, N or N·m: see :func:`vibdyn.analysis.equilibrium.held`)."""
        from ..analysis.equilibrium import held

        return held(self, q, v, t)

    def operating_point(self, tol: float = EQUILIBRIUM_TOL, max_iter: int = MAX_ITER) -> OperatingPoint:
        """The scene's declared operating point (:meth:`Scene.set_operating_point`): held, steady or static
        (see :func:`vibdyn.analysis.equilibrium.operating_point`)."""
        from ..analysis.equilibrium import operating_point

        return operating_point(self, tol, max_iter)

    def linearize(self, at: Any = None, *, v: ArrayLike | None = None, t: float = 0.0, a: ArrayLike | None = None,
                  method: str = "fd", step: float = FD_STEP, hold: Any = ()) -> LinearModel:
        """Linear model (M, C, K, error estimate) about ``at`` (see :func:`vibdyn.analysis.linearize.linearize`)."""
        from ..analysis.linearize import linearize

        return linearize(self, at, v=v, t=t, a=a, method=method, step=step, hold=hold)

    def simulate(self, t_end: float, q0: ArrayLike | None = None, v0: ArrayLike | None = None,
                 method: str = "dop853", rtol: float = RTOL, atol: float | None = None, dt: float | None = None,
                 t_eval: ArrayLike | None = None, *, t0: float = 0.0, events: Any = None, variational: bool = False,
                 **options: Any) -> Trajectory:
        """Nonlinear motion from (q0, v0) at ``t0`` to the time ``t_end`` (s): a Trajectory (see
        :func:`vibdyn.simulation.simulate.simulate`: events, variational equations)."""
        from ..simulation.simulate import simulate

        return simulate(self, t_end, q0, v0, method, rtol, atol, dt, t_eval, t0=t0, events=events,
                        variational=variational, **options)

    # ------------------------------------------------------------- geometry (vibdyn.model.geometry)
    def body_pose(self, body: str, q: ArrayLike) -> tuple[Matrix, Vector]:
        """(R, p): rotation (3×3) and origin (m) of a body's frame in world axes."""
        M = geometry.body_pose(self, self.workspace(), self.body_info(body), self.check_configuration(q))
        return M.rotation.copy(), M.translation.copy()

    def point_position(self, body: str, point: ArrayLike, q: ArrayLike) -> Vector:
        """World position (m) of a point given in a body's frame."""
        R, p = self.body_pose(body, q)
        return R @ vector3(point, f"point of body '{body}'") + p

    def point_velocity(self, body: str, point: ArrayLike, q: ArrayLike, v: ArrayLike) -> Vector:
        """World velocity (m/s) of a point given in a body's frame."""
        b, r, q = self.body_info(body), vector3(point, f"point of body '{body}'"), self.check_configuration(q)
        return geometry.point_velocity(self, self.workspace(), b, r, q, self.check_velocity(v))

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
        return attachments(self, atts)

    def support_indices(self, atts: Sequence[tuple[str, ArrayLike]]) -> np.ndarray:
        """Index of the support each attachment of ``[(body, point), ...]`` is on, −1 for none."""
        return np.array([self.support_index.get(body, -1) for body, _ in atts], dtype=int)

    def __repr__(self):
        return f"System({self.name!r}, nq={self.nq}, nv={self.nv}, {len(self.force_groups)} force groups)"

    # ------------------------------------------------------------- checked inputs
    def check_mass_matrix(self, q: ArrayLike, where: str, M: Matrix | None = None) -> None:
        """ModelError naming the body and coordinate if M(q) is singular against the scene's scales (see
        :func:`vibdyn.model.inertia_check.check_mass_matrix`)."""
        inertia_check.check_mass_matrix(self, q, where, M)

    def check_configuration(self, q: ArrayLike, what: str = "q") -> Vector:
        x = _state(q, self.nq, what, lambda: f"a configuration of {count(self.nq, 'number')}")
        for body, i, n in self.unit_blocks:
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
