"""The ODE of a scene with drives (rheonomic joints, :mod:`vibdyn.model.drives`): only the free coordinates are
integrated (see :func:`driven_ode`)."""

import numpy as np

from ...model.derivatives import linear_terms, solve_mass


def driven_ode(base):
    """The ODE class ``base`` (:mod:`vibdyn.simulation.integrators.chart`) for a scene with drives. The state
    keeps the tree's layout, but its driven entries are frozen (derivative 0: no error, no step-size control)
    and every evaluation replaces them by the laws' values at t (a drive's joint has one additive coordinate,
    so in a chart ξ_d = q_d(t) − centre_d); the steppers report states with the laws' values (exact to
    round-off). The free accelerations are the drives' (:meth:`vibdyn.model.drives.Drives.accelerations`);
    one more component, before the work w, integrates the drives' power v_d·τ_d (their work W_d, J), and w
    integrates v·RNEA(q, v, a) over every coordinate: the work of the force elements and of the drives. The
    Jacobian (implicit methods, variational equations) has zero driven rows and columns
    and, on the free ones, −M_ff⁻¹K_ff and −M_ff⁻¹C_ff (K and C at the motion's accelerations): the state
    transition is the identity on the driven entries and Φ_ff on the free ones."""

    class Driven(base):
        def __init__(self, system, work=False):
            super().__init__(system, work)
            self.n += 1  # W_d, last but the work w
            drives, ws, kept = system.compiled_drives, self.ws, [None]
            self._drive_forces = kept  # the drives' forces of the last evaluation (their power), this ODE's own

            def accelerations(q, v, t):
                a, kept[0] = drives.accelerations_and_forces(system, ws, q, v, t)
                return a

            self.accelerations = accelerations

        def _impose(self, t, y):
            d, nv = self.system.compiled_drives, self.nv
            qd, vd, _ = d.values(t)
            y = y.copy()
            y[d.index] = qd - self.centre[d.q_index] if self.curved else qd
            y[nv + d.index] = vd
            return y

        def into(self, t, y, out):
            y = self._impose(t, y)
            super().into(t, y, out)
            d = self.system.compiled_drives
            out[self.n - 2 if self.work else self.n - 1] = y[self.nv + d.index] @ self._drive_forces[0]
            out[d.index] = 0.0
            out[self.nv + d.index] = 0.0

        def _minv_kc(self, q, v, t, a=None):  # (``a`` not used: the driven rows of the ODE's are zero)
            f, nv = self.system.compiled_drives.free, self.nv
            MinvK, MinvC = np.zeros((nv, nv)), np.zeros((nv, nv))
            if f.size:
                M, K, C = linear_terms(self.system, q, v, t)
                ff = np.ix_(f, f)
                X = solve_mass(M[ff], np.hstack([K[ff], C[ff]]))
                MinvK[ff], MinvC[ff] = X[:, :f.size], X[:, f.size:]
            return MinvK, MinvC

        def jacobian(self, t, y, a=None):
            J = super().jacobian(t, self._impose(t, y))
            d = self.system.compiled_drives
            rows = np.concatenate([d.index, self.nv + d.index])
            J[rows, :] = 0.0
            J[:, rows] = 0.0
            return J

    Driven.__name__ = f"Driven{base.__name__}"
    return Driven


def free_block(system, transition):
    """The state transition (2nv × 2nv, tangent space) restricted to the free coordinates: 2nf × 2nf,
    ordered (δq_f, δv_f) in the order of ``system.drives.free``; unchanged without drives."""
    if transition is None or system.compiled_drives is None:
        return transition
    f = system.compiled_drives.free
    idx = np.concatenate([f, system.nv + f])
    return transition[np.ix_(idx, idx)]
