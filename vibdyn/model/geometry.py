"""Poses, point velocities and momenta of a compiled system's bodies as free functions over (system,
workspace), in the manner of ``pin.forwardKinematics(model, data, q)``: no input checks (``System.body_pose``,
``point_velocity`` and ``momentum_matrix`` are the checked entry points). Each runs its own forward pass and
returns new arrays: it reads nothing an earlier call left in the workspace, and what it leaves there no other
computation reads (see :mod:`vibdyn.model.workspace`). SI units: m, rad, m/s, kg·m/s, kg·m²/s.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

if TYPE_CHECKING:
    from .compile import BodyInfo
    from .system import System
    from .workspace import Workspace


def body_pose(system: System, ws: Workspace, body: BodyInfo, q: np.ndarray) -> pin.SE3:
    """The pose of a body's frame in the world at q (a new SE3: rotation, origin in m)."""
    pin.forwardKinematics(system.model, ws.data, q)
    return ws.data.oMi[body.joint_id] * body.body_in_joint


def point_velocity(system: System, ws: Workspace, body: BodyInfo, point: np.ndarray, q: np.ndarray,
                   v: np.ndarray) -> np.ndarray:
    """World velocity (m/s) at (q, v) of a point given in a body's frame (m)."""
    pin.forwardKinematics(system.model, ws.data, q, v)
    local = body.body_in_joint.act(point)
    vj = ws.data.v[body.joint_id]
    return ws.data.oMi[body.joint_id].rotation @ (vj.linear + np.cross(vj.angular, local))


def momentum_matrix(system: System, ws: Workspace, q: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A_lin, A_ang) (3 × nv each, new arrays): linear momentum A_lin v (kg·m/s) and angular momentum about
    ``point`` (m, world) A_ang v (kg·m²/s) of every body at q, from Pinocchio's centroidal map."""
    A = np.asarray(pin.computeCentroidalMap(system.model, ws.data, q)).reshape(6, system.nv)  # ((6,) at nv = 1)
    lin, ang = A[:3].copy(), A[3:].copy()
    ang += pin.skew(ws.data.com[0] - point) @ lin  # about the point, not the centre of mass
    return lin, ang
