"""The equations of motion as a first-order ODE y' = f(t, y) on a vector space, in a local chart if needed.

Ball, free and planar joints make the configuration space a Lie group: q cannot be stepped as q + h v.
Around a centre q_c the chart q = integrate(q_c, ξ), ξ ∈ ℝ^nv, turns the motion into an ODE on a vector
space, smooth while every rotation in ξ stays well below π:

    ξ̇ = dexp⁻¹(ξ) v = dDifference(q_c, q, ARG1) · v,    v̇ = a(q, v, t)    [, ẇ = v · τ(q, v, a)]

(at q = integrate(q_c, ξ) Pinocchio's dDifference is the inverse of dIntegrate(q_c, ξ, ARG1)). Any Runge–
Kutta method applied to this ODE keeps its full order, and configurations built as integrate(q_c, ξ) keep
unit quaternions to round-off. Re-centring (q_c ← integrate(q_c, ξ), ξ ← 0) changes coordinates, not the
motion. A scene whose joints all have nq == nv (pivots, sliders, helical, cylindrical, universal) pays
nothing for this: :class:`VectorODE` integrates y = (q, v) directly, with ξ̇ = v.

The optional last component w integrates the power of every applied force element, v · τ with τ = RNEA(q,
v, a) = M v̇ + C v + g the total generalized force of the force elements (springs included): along the
motion d(T + V_gravity)/dt = v · τ, the energy balance the simulation reports.
"""

import numpy as np
import pinocchio as pin

from ...model import dynamics
from ...model.derivatives import analytic_derivatives_rows, linear_terms, solve_mass
from ...model.points import so3_chart_term, so3_dexp_inv, so3_jacobians, so3_jr_inv

ARG1 = pin.ArgumentPosition.ARG1
def make_ode(system, q0, v0, work=False, variational=False):
    """The ODE of a system (a chart if it has curved joints) and its initial state y0; with
    ``variational``, augmented with the variational equations (:class:`Variational`)."""
    cls = ChartODE if system.nq != system.nv else VectorODE
    if getattr(system, "constraints", None) is not None:  # closed loops: projected after each step
        from .projected import projected_ode

        cls = projected_ode(cls)
    if getattr(system, "drives", None) is not None:  # drives: the free coordinates only
        from .driven import driven_ode

        cls = driven_ode(cls)
    ode = cls(system, work)
    if variational:
        ode = Variational(ode)
    return ode, ode.initial(q0, v0)


class VectorODE:
    """y = (q, v[, w]) for scenes whose configurations form a vector space (nq == nv); counts its evaluations
    in ``nfev``. The chart interface (``configuration``, ``recentre``, ``extent``) is trivial here."""

    curved = False

    def __init__(self, system, work=False):
        self.system = system
        self.ws = system.workspace()  # the calling thread's: one simulation runs in one thread
        self.model, self.data = system.model, self.ws.data
        self.nv = system.nv
        self.n = 2 * system.nv + (1 if work else 0)
        self.work = work
        self.nfev = 0
        self.differenced = False  # a Jacobian so far differenced a user callable (exact to ~1e-10 only)
        # (q, v, t) → dv/dt; the point elements' forces of the last evaluation kept for the Jacobian at that state
        self._applied = [None]
        self.accelerations = dynamics.accelerations_function(system, self.ws, keep=self._applied)
        # J Y by blocks (jacobian_product) where the Jacobian is this class's own (not a subclass's)
        self._blocks = type(self).jacobian in (VectorODE.jacobian, ChartODE.jacobian)
        self._terms: tuple = (None, None)  # ((t, q, v) bytes, (M, K, C)) of the last J Y

    def __call__(self, t, y):
        out = np.empty(self.n)
        self.into(t, y, out)
        return out

    def into(self, t, y, out):
        """f(t, y) written into ``out`` (the hot path of the explicit methods). The power v·τ by vdot: a trial
        step that overflows is rejected by the stepper, and vdot (unlike @) warns of nothing on the way."""
        self.nfev += 1
        nv = self.nv
        q, v = y[:nv], y[nv:2 * nv]
        out[:nv] = v
        out[nv:2 * nv] = self.accelerations(q, v, t)
        if self.work:
            out[-1] = np.vdot(v, pin.rnea(self.model, self.data, q, v, out[nv:2 * nv]))

    def initial(self, q0, v0, w0=0.0):
        y = np.zeros(self.n)
        y[:self.nv], y[self.nv:2 * self.nv] = q0, v0
        if self.work:
            y[-1] = w0
        return y

    def configuration(self, y):
        """The configuration q of a state y (or of an interpolated one, see ``at``)."""
        return y[:self.nv].copy()

    def displacement(self, y0, y1):
        """Tangent displacement from y0 to y1 (both in the current chart)."""
        return y1[:self.nv] - y0[:self.nv]

    def recentre(self, y, f=None, t=None):
        """Centre the chart at y's configuration (nothing to do on a vector space); ``t`` (s) is y's time."""

    def drift(self, y):
        """How far y is off the loops (dimensionless; 0 without loops: see the projected ODE)."""
        return 0.0

    def extent(self, y):
        """Largest rotation (rad) of a curved joint in y's chart: none here."""
        return 0.0

    def frozen(self):
        """A copy of the chart (for dense output after the chart has moved on): nothing to keep here."""
        return self

    # ------------------------------------------------------------------ Jacobian for implicit methods
    def jacobian(self, t, y, a=None):
        """∂f/∂y from the analytic linearisation: ∂v̇/∂q = −M⁻¹K, ∂v̇/∂v = −M⁻¹C (in the tangent space at
        q). The work row is left zero: w feeds nothing back, so the simplified Newton iteration converges.
        ``a``: the accelerations the last :meth:`into` evaluated, at this very (t, y) (rad/s², m/s²; its forces
        are reused too), else None: evaluated here."""
        nv = self.nv
        q, v = self.configuration(y), y[nv:2 * nv].copy()
        MinvK, MinvC = self._minv_kc(q, v, t, a)
        J = np.zeros((self.n, self.n))
        J[:nv, nv:2 * nv] = np.eye(nv)
        J[nv:2 * nv, :nv] = -MinvK
        J[nv:2 * nv, nv:2 * nv] = -MinvC
        return J

    def jacobian_product(self, t, y, Y, a=None):
        """J Y (2nv × k) with J the (ξ, v) block of :meth:`jacobian` (``a`` as there), without forming J: the
        variational equations' right-hand side. (Classes that change the Jacobian, as the driven and projected
        ODEs, take the product of their own :meth:`jacobian`.)"""
        if not self._blocks:
            return self.jacobian(t, y, a)[:2 * self.nv, :2 * self.nv] @ Y
        nv = self.nv
        out = np.empty_like(Y)
        out[:nv] = Y[nv:]
        out[nv:] = self._acceleration_product(y[:nv], y[nv:2 * nv], t, a, Y[:nv], Y[nv:])
        return out

    def jacobians(self, ts, states, accelerations):
        """J (B × 2nv × 2nv: the (ξ, v) block of :meth:`jacobian`) at B states at once — rows of ``states``
        (ξ, v), times ``ts`` (s), the accelerations the ODE evaluated there — the point elements' derivatives in
        one pass (:func:`~vibdyn.model.derivatives.analytic_derivatives_rows`); the last state's (M, K, C) kept as
        :meth:`_acceleration_product` keeps them."""
        nv = self.nv
        Q = self._configurations(states[:, :nv])
        V = states[:, nv:]
        K, C = analytic_derivatives_rows(self.system, Q, V, accelerations, ts)
        M = np.array([dynamics.mass_matrix(self.model, self.data, q) for q in Q])
        X = np.linalg.solve(M, np.concatenate([K, C], axis=2))
        if not np.all(np.isfinite(X)):
            raise np.linalg.LinAlgError("the mass matrix is singular or not finite at this state")
        self._terms = ((float(ts[-1]), Q[-1].tobytes(), V[-1].tobytes()), (M[-1], K[-1], C[-1]))
        J = np.zeros((len(ts), 2 * nv, 2 * nv))
        J[:, nv:, nv:] = -X[:, :, nv:]
        self._chart_blocks(J, states, Q, X[:, :, :nv])
        return J

    def _configurations(self, xi):
        """The configurations of chart coordinates (rows)."""
        return np.array(xi)

    def _chart_blocks(self, J, states, Q, MinvK):
        """J's configuration blocks at each row: ∂ξ̇/∂v = 1, ∂v̇/∂ξ = −M⁻¹K (a vector space)."""
        nv = self.nv
        J[:, :nv, nv:] = np.eye(nv)
        J[:, nv:, :nv] = -MinvK

    def _acceleration_product(self, q, v, t, a, Zq, Yv):
        """−M⁻¹(K Zq + C Yv): the accelerations' rows of J Y (Zq: the configuration rows in the tree's tangent
        space). (M, K, C) of the last state are kept: a chart's re-centring asks for them again at the state the
        step's last stage evaluated (the same q, v and t: the same terms)."""
        key = (t, q.tobytes(), v.tobytes())
        if key == self._terms[0]:
            M, K, C = self._terms[1]
        else:
            flags: dict = {}
            M, K, C = linear_terms(self.system, q, v, t, a, None if a is None else self._applied[0], flags)
            self.differenced = self.differenced or flags["differenced"]
            self._terms = (key, (M, K, C))
        return solve_mass(M, -(K @ Zq + C @ Yv))

    def _minv_kc(self, q, v, t, a=None):
        flags: dict = {}
        M, K, C = linear_terms(self.system, q, v, t, a, None if a is None else self._applied[0], flags)
        self.differenced = self.differenced or flags["differenced"]
        X = solve_mass(M, np.hstack([K, C]))
        return X[:, :self.nv], X[:, self.nv:]


class ChartODE(VectorODE):
    """y = (ξ, v[, w]) in the chart q = integrate(centre, ξ), for scenes with ball, free or planar joints."""

    curved = True

    def __init__(self, system, work=False):
        super().__init__(system, work)
        # rotational tangent components of the curved joints (where a chart's validity is limited)
        curved = [b for b in system.body_infos.values() if b.joint.chart_rotations]
        self.rotations = np.array([b.idx_v + i for b in curved for i in b.joint.chart_rotations], dtype=int)
        # the chart's own term: ball joints' in closed form (so3_chart_term), the others' (free, planar) by
        # differences of their tangent columns, grouped by their place in their joint (dDifference is block
        # diagonal, one block per joint: the i-th column of every such joint is differenced in one pass), each
        # with the rows of its joint
        self.so3_blocks = [slice(b.idx_v, b.idx_v + 3) for b in curved if b.joint.lie_group == "SO3"]
        differenced = [b for b in curved if b.joint.lie_group != "SO3"]
        width = max((b.nv for b in differenced), default=0)
        self.column_groups = [[(b.idx_v + i, slice(b.idx_v, b.idx_v + b.nv)) for b in differenced if i < b.nv]
                              for i in range(width)]
        self.centre = None
        self._eye = np.eye(self.nv)
        self.so3_starts = [b.start for b in self.so3_blocks]

    def dexp_inv(self, xi, q):
        """dexp⁻¹(ξ) = dDifference(centre, q, ARG1) at q = centre ⊕ ξ (nv × nv): the identity on vector joints,
        balls' blocks in closed form (:func:`so3_jr_inv`: Pinocchio's Jlog3 rounds off to 2e-9 near 1e-3 rad),
        Pinocchio's on free and planar joints."""
        D = pin.dDifference(self.model, self.centre, q, ARG1) if self.column_groups else self._eye.copy()
        for b in self.so3_blocks:
            D[b, b] = so3_jr_inv(xi[b])
        return D

    def into(self, t, y, out):
        self.nfev += 1
        nv, model, c = self.nv, self.model, self.centre
        xi, v = y[:nv], y[nv:2 * nv]
        q = pin.integrate(model, c, xi)
        if self.column_groups:
            out[:nv] = self.dexp_inv(xi, q) @ v
        else:  # (vector joints and balls: ξ̇ = v, and J_r⁻¹(ξ) v on each ball)
            out[:nv] = so3_dexp_inv(xi, v, self.so3_starts)
        out[nv:2 * nv] = self.accelerations(q, v, t)
        if self.work:
            out[-1] = np.vdot(v, pin.rnea(model, self.data, q, v, out[nv:2 * nv]))

    def initial(self, q0, v0, w0=0.0):
        self.centre = np.array(q0, dtype=float)
        return super().initial(np.zeros(self.nv), v0, w0)

    def configuration(self, y):
        return pin.integrate(self.model, self.centre, y[:self.nv])

    def recentre(self, y, f=None, t=None):
        """Move the centre to y's configuration and set ξ = 0 in y (in place); ``f``, the derivative at y
        (in place), becomes the derivative in the new chart: ξ̇ = v there, v̇ and ẇ unchanged."""
        nv = self.nv
        self.centre = self.configuration(y)
        y[:nv] = 0.0
        if f is not None:
            f[:nv] = y[nv:2 * nv]

    def extent(self, y):
        return float(np.abs(y[self.rotations]).max())

    def frozen(self):
        c = object.__new__(ChartODE)
        c.__dict__.update(self.__dict__)
        return c

    def jacobian(self, t, y, a=None):
        """As :meth:`VectorODE.jacobian`, mapped to the chart: ∂v̇/∂ξ = −M⁻¹K dIntegrate(ξ), ∂ξ̇/∂v =
        dexp⁻¹(ξ), and the chart's own term ∂(dexp⁻¹(ξ) v)/∂ξ (:meth:`chart_term`)."""
        nv, model, c = self.nv, self.model, self.centre
        xi, v = y[:nv], y[nv:2 * nv].copy()
        q = self.configuration(y)
        MinvK, MinvC = self._minv_kc(q, v, t, a)
        J = np.zeros((self.n, self.n))
        J[:nv, nv:2 * nv] = self.dexp_inv(xi, q)
        J[nv:2 * nv, :nv] = -MinvK @ pin.dIntegrate(model, c, xi, ARG1)
        J[nv:2 * nv, nv:2 * nv] = -MinvC
        J[:nv, :nv] = self.chart_term(xi, v)
        return J

    def jacobian_product(self, t, y, Y, a=None):
        if not self._blocks:
            return self.jacobian(t, y, a)[:2 * self.nv, :2 * self.nv] @ Y
        nv, model, c = self.nv, self.model, self.centre
        xi, v = y[:nv], y[nv:2 * nv]
        q = pin.integrate(model, c, xi)
        Yq, Yv = Y[:nv], Y[nv:]
        out = np.empty_like(Y)
        out[:nv] = self.dexp_inv(xi, q) @ Yv + self.chart_term(xi, v) @ Yq
        out[nv:] = self._acceleration_product(q, v, t, a, pin.dIntegrate(model, c, xi, ARG1) @ Yq, Yv)
        return out

    def _configurations(self, xi):
        model, c = self.model, self.centre
        return np.array([pin.integrate(model, c, x) for x in xi])

    def _chart_blocks(self, J, states, Q, MinvK):
        """J's configuration blocks at each row in the chart: dexp⁻¹(ξ), the chart's own term, −M⁻¹K dIntegrate(ξ)
        (of vector joints and balls alone: every row at once, in closed form; with free or planar joints, row by
        row)."""
        nv, model, c = self.nv, self.model, self.centre
        if self.column_groups:
            for Jr, y, q, X in zip(J, states, Q, MinvK):
                xi = y[:nv]
                Jr[:nv, nv:] = self.dexp_inv(xi, q)
                Jr[:nv, :nv] = self.chart_term(xi, y[nv:])
                Jr[nv:, :nv] = -X @ pin.dIntegrate(model, c, xi, ARG1)
            return
        B = len(states)
        D = np.broadcast_to(self._eye, (B, nv, nv)).copy()  # dIntegrate(ξ) at each row
        J[:, :nv, nv:] = self._eye
        for b in self.so3_blocks:
            xi, v = states[:, b], states[:, nv + b.start:nv + b.stop]
            D[:, b, b], J[:, b, nv + b.start:nv + b.stop], J[:, b, b] = so3_jacobians(xi, v)
        J[:, nv:, :nv] = -MinvK @ D

    def chart_term(self, xi, v):
        """∂(dexp⁻¹(ξ) v)/∂ξ (nv × nv, 1/s): in closed form for ball joints (:func:`so3_chart_term`), by
        fourth-order differences on the columns of free and planar joints (zero on the others)."""
        nv, model, c = self.nv, self.model, self.centre
        J = np.zeros((nv, nv))
        # fourth-order differences of a step 1e-3 (rad or m): truncation ~1e-14 and round-off ~1e-13 relative (a
        # plain central difference of 1e-7 leaves round-off of 1e-9, which the variational step control sees)
        eps = 1e-3
        for group in self.column_groups:
            e = np.zeros(nv)
            for k, _ in group:
                e[k] = eps
            d = [pin.dDifference(model, c, pin.integrate(model, c, xi + s * e), ARG1) for s in (2, 1, -1, -2)]
            column = (8 * (d[1] - d[2]) - (d[0] - d[3])) @ v / (12 * eps)
            for k, rows in group:
                J[rows, k] = column[rows]
        for b in self.so3_blocks:
            J[b, b] = so3_chart_term(xi[b], v[b])
        return J


class Variational:
    """An ODE augmented with its variational equations: y = (ξ, v, Y, [w]) with Y (2nv × 2nv, row-major) the
    derivative of (ξ, v) with respect to their initial values, Ẏ = J(t, ξ, v) Y, J the ODE's Jacobian
    (:meth:`VectorODE.jacobian`: the analytic −M⁻¹K and −M⁻¹C, mapped to the chart). The chart re-centres
    carry Y with them (δξ_new = dIntegrate(ξ) δξ_old), so :meth:`transition` is the state transition in the
    tangent spaces at q(t) and q0. The steppers control Y's error with the state's (DOP853: see
    :mod:`.explicit`). Not for mechanisms with loops (their projection has no
    variational counterpart here)."""

    def __init__(self, base):
        if getattr(base.system, "constraints", None) is not None:
            from ...errors import ModelError

            raise ModelError("variational equations: not available for a mechanism with closed loops (the "
                             "projection onto the loops has no variational counterpart here)")
        self.base, self.nv, self.work, self.system = base, base.nv, base.work, base.system
        self.m = 2 * base.nv
        self.n = base.n + self.m * self.m
        self.curved = base.curved
        self._t = 0.0

    def __getattr__(self, name):  # nfev, model, centre, rotations ...: the base ODE's
        return getattr(self.base, name)

    def _split(self, y):
        """(the base ODE's state, Y as an m × m view): y = (ξ, v, Y, the base's other components: [W_d], [w])."""
        m = self.m
        base = y[:m] if self.base.n == m else np.concatenate([y[:m], y[m + m * m:]])  # (w and the like last)
        return base, y[m:m + m * m].reshape(m, m)

    def __call__(self, t, y):
        out = np.empty(self.n)
        self.into(t, y, out)
        return out

    def into(self, t, y, out):
        self._t = t
        m = self.m
        base, Y = self._split(y)
        f = np.empty(self.base.n)
        self.base.into(t, base, f)
        out[:m] = f[:m]
        out[m + m * m:] = f[m:]
        # (the base's accelerations just evaluated at this state: the Jacobian need not evaluate them again)
        out[m:m + m * m] = self.base.jacobian_product(t, base, Y, f[self.nv:m]).ravel()

    def initial(self, q0, v0, w0=0.0):
        b = self.base.initial(q0, v0, w0)
        y = np.zeros(self.n)
        y[:self.m] = b[:self.m]
        y[self.m:self.m + self.m * self.m] = np.eye(self.m).ravel()
        y[self.m + self.m * self.m:] = b[self.m:]
        return y

    def configuration(self, y):
        return self.base.configuration(y[:self.nv] if not self.curved else y)

    def displacement(self, y0, y1):
        return self.base.displacement(y0, y1)

    def drift(self, y):
        return 0.0

    def extent(self, y):
        return self.base.extent(y)

    def recentre(self, y, f=None, t=None):
        """Re-centre the base chart; Y's configuration rows follow it (δξ_new = dIntegrate(ξ_old) δξ_old at
        the new centre), and its derivative in ``f`` is evaluated again there, at y's time ``t`` (s; None: the
        last evaluation's, which a dense output's extra stages move: steppers give it)."""
        m, nv = self.m, self.nv
        base, Y = self._split(y)
        if self.curved:
            Y[:nv] = pin.dIntegrate(self.base.model, self.base.centre, y[:nv], ARG1) @ Y[:nv]
        self.base.recentre(y, None if f is None else f, t)
        # (a vector space's trivial re-centring changes neither y nor Y: f's Y part, J Y at y, stands)
        if f is not None and (self.curved or type(self.base).recentre is not VectorODE.recentre):
            base, Y = self._split(y)
            f[m:m + m * m] = self.base.jacobian_product(self._t if t is None else t, base, Y).ravel()

    def frozen(self):
        c = object.__new__(Variational)
        c.__dict__.update(self.__dict__)
        c.base = self.base.frozen()
        return c

    def transition(self, y):
        """The state transition (2nv × 2nv) in the tangent spaces at q(t) and q0."""
        Y = self._split(y)[1].copy()
        if self.curved:
            nv = self.nv
            Y[:nv] = pin.dIntegrate(self.base.model, self.base.centre, y[:nv], ARG1) @ Y[:nv]
        return Y
