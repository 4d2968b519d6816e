"""The ODE of a mechanism with closed loops (:mod:`vibdyn.description.loops`): the index-1 equations projected
onto the loops (see :func:`projected_ode`)."""

import numpy as np
import pinocchio as pin

from ...model.fd import vector_derivative

NEAR_SINGULAR = 1e-2  # conditioning of the loops' Jacobian below which stages are projected (projected_ode)


def projected_ode(base):
    """The ODE class ``base`` (:mod:`vibdyn.simulation.integrators.chart`) for a mechanism with loops: accelerations
    from the index-1 equations (Φ_q v̇ = −γ, see :meth:`vibdyn.description.loops.Constraints.accelerations`) and drift
    control by projection: after each accepted step of the explicit methods (dop853, rk4: at ``recentre``)
    the state goes back onto Φ = 0 and Φ_q v = 0 (q assembled, v projected in the kinetic-energy metric) and
    the step's last derivative is re-evaluated. The ODE is left as it is (no Baumgarte parameters to tune,
    nothing added to the dynamics); the projection moves the state by the drift of one step, of the order of
    its local error. The implicit methods (radau, bdf; their Jacobian is differenced here) are projected
    when the drift (:meth:`drift`) passes their relative tolerance, and restarted from the projected state.

    Near a singular position (σ_min/σ_max of the loops' Jacobian below :data:`NEAR_SINGULAR` at the last
    accepted state) the field is evaluated on the loops: each stage's state is projected first. Off the
    loops the index-1 accelerations divide a stage's drift by σ² there, an error that does not shrink like
    the method's order (RK4 at dt = 4 ms through A02's singular positions: 1e-8 m, 16× its Richardson
    estimate, without; 2e-11 with)."""

    class Projected(base):
        _t = 0.0
        near = False  # the last accepted state is near a singular position of the loops

        def into(self, t, y, out):
            self._t = t
            if self.near:  # evaluate the field on the loops: project the stage's state first
                nv, system = self.nv, self.system
                q = self.configuration(y)
                q, v = system.constraints.project(q, y[nv:2 * nv], system.mass_matrix(q))
                y = y.copy()
                y[:nv] = pin.difference(self.model, self.centre, q) if self.curved else q
                y[nv:2 * nv] = v
            super().into(t, y, out)

        def initial(self, q0, v0, w0=0.0):
            c = self.system.constraints
            q, v, cond = c.project(np.asarray(q0, float), np.asarray(v0, float),
                                   self.system.mass_matrix(c.assemble(q0)), conditioning=True)
            self.near = cond < NEAR_SINGULAR
            return super().initial(q, v, w0)

        def recentre(self, y, f=None, t=None):
            nv, system = self.nv, self.system
            q = self.configuration(y)
            q, v, cond = system.constraints.project(q, y[nv:2 * nv], system.mass_matrix(q), conditioning=True)
            self.near = cond < NEAR_SINGULAR
            if self.curved:
                self.centre = q
                y[:nv] = 0.0
            else:
                y[:nv] = q
            y[nv:2 * nv] = v
            if f is not None:
                self.into(self._t if t is None else t, y, f)

        def drift(self, y):
            """Largest dimensionless residual of the loops at y: positions (m / length scale, rad) and
            velocities (Φ_q v relative to the largest dimensionless speed)."""
            c, nv = self.system.constraints, self.nv
            phi, J = c.evaluate(self.configuration(y))
            v = y[nv:2 * nv]
            speed = np.abs(v / c.col_scale).max(initial=0.0)
            dv = np.abs(c.scaled_phi(J @ v)).max(initial=0.0) / speed if speed > 0 else 0.0
            return max(float(np.abs(c.scaled_phi(phi)).max(initial=0.0)), float(dv))

        def jacobian(self, t, y, a=None):
            """∂f/∂y by central differences (steps 1e-6 × (1 rad or the length scale), per unit speed); ``a``
            is not used."""
            unit = self.system.coordinate_scales
            h = 1e-6 * np.concatenate([unit, unit, [1.0] * (self.n - 2 * self.nv)])
            J = vector_derivative(lambda yy: self(t, yy), y, h)
            J[:, -1] = 0.0 if self.work else J[:, -1]
            return J

    Projected.__name__ = f"Projected{base.__name__}"
    return Projected
