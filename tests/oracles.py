"""Independent truths shared by the dynamics tests.

Nothing here calls vibdyn's force machinery: the helpers rebuild what the tests compare against from
Pinocchio primitives (frame Jacobians, log maps), from finite differences of scalar energies, or from
MuJoCo (a second, independent rigid-body engine) through a Scene → MJCF writer.

MuJoCo is imported lazily (only by the functions that need it) so that this module loads without it.
"""

import dataclasses
import os

import numpy as np
import pinocchio as pin

import vibdyn as vd

REPORT = bool(os.environ.get("VIBDYN_REPORT"))


# ---------------------------------------------------------------------------------------------- asserts
def rel_error(actual, expected, scale=None):
    """max |actual − expected| / max(max |expected|, scale)."""
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    ref = float(np.max(np.abs(expected))) if expected.size else 0.0
    if scale is not None:
        ref = max(ref, float(scale))
    err = float(np.max(np.abs(actual - expected))) if expected.size else 0.0
    return err / ref if ref > 0 else err


def assert_close(actual, expected, rel, scale=None, what=""):
    """Relative agreement, the reference being max |expected| (or ``scale`` if larger).

    ``scale`` guards against comparing with a value that happens to be near zero: give a physical
    magnitude of the quantity (e.g. g/l for an angular acceleration).
    """
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    assert np.all(np.isfinite(actual)), f"{what}: not finite: {actual}"
    err = rel_error(actual, expected, scale)
    if REPORT:
        print(f"[err] {what}: {err:.3g}")
    assert err <= rel, f"{what}: relative error {err:.3g} > {rel:g}\nactual   {actual}\nexpected {expected}"
    return err


# ---------------------------------------------------------------------------------------------- scenes

def cli(argv):
    """(exit code, stdout, stderr) of the command line ``vibdyn *argv`` run in this process (its items as strings)."""
    import contextlib
    import io

    from vibdyn.faces.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()

def random_rotation(rng):
    """A uniformly random rotation matrix."""
    from scipy.spatial.transform import Rotation

    return Rotation.random(random_state=rng).as_matrix()


def random_unit(rng):
    a = rng.standard_normal(3)
    return a / np.linalg.norm(a)


def random_inertia(rng, mass, size=0.3):
    """Inertia of a random box of mass ``mass`` turned by a random rotation (physical, full tensor)."""
    a, b, c = size * (0.3 + rng.random(3))
    principal = mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    R = random_rotation(rng)
    return R @ np.diag(principal) @ R.T


def random_chain(rng, n, kinds=("pivot", "slider"), gravity=(0.0, 0.0, -9.81), name="chain", branch=False,
                 first=None, parents=None):
    """A scene of ``n`` bodies with random joints, placements, masses and inertias.

    Joint kinds cycle through ``kinds`` (the root's is ``first`` if given, e.g. "free"); ``branch`` makes a
    tree (each body's parent drawn among the previous ones) instead of a chain; ``parents`` gives the
    parent index of each body explicitly (−1 for the world).
    """
    s = vd.Scene(name, gravity=gravity)
    parent = vd.WORLD
    for i in range(n):
        kind = first if (i == 0 and first) else kinds[i % len(kinds)]
        at = 0.4 * rng.standard_normal(3)
        rot = random_rotation(rng)
        if kind == "pivot":
            joint = vd.Pivot(random_unit(rng), at=at, rotation=rot)
        elif kind == "slider":
            joint = vd.Slider(random_unit(rng), at=at, rotation=rot)
        elif kind == "ball":
            joint = vd.Ball(at=at, rotation=rot)
        elif kind == "free":
            joint = vd.Free(at=at, rotation=rot)
        elif kind == "fixed":
            joint = vd.Fixed(at=at, rotation=rot)
        elif kind == "cylindrical":
            joint = vd.Cylindrical(random_unit(rng), at=at, rotation=rot)
        elif kind == "universal":
            a1 = random_unit(rng)
            a2 = np.cross(a1, random_unit(rng))
            joint = vd.Universal(a1, a2 / np.linalg.norm(a2), at=at, rotation=rot)
        else:
            raise ValueError(kind)
        m = 0.5 + 2.0 * rng.random()
        body = f"b{i}"
        if parents is not None:
            parent = vd.WORLD if parents[i] < 0 else f"b{parents[i]}"
        s.add_body(body, parent, joint, mass=m, com=0.3 * rng.standard_normal(3), inertia=random_inertia(rng, m))
        if branch and i > 0:
            parent = f"b{rng.integers(i + 1)}"
        else:
            parent = body
    return s


def with_min_inertia(scene, eps=1e-12):
    """A copy of ``scene`` whose bodies all have principal moments ≥ ``eps`` (MuJoCo refuses zero ones).

    Give the same copy to vibdyn and to MuJoCo so that both model exactly the same solids.
    """
    s = scene.copy()
    for name, b in list(s.bodies.items()):
        I = np.array(b.inertia)
        if b.mass > 0 and np.linalg.eigvalsh(I).min() < eps:
            I = I + eps * np.eye(3)
            s.bodies[name] = dataclasses.replace(b, inertia=tuple(tuple(map(float, r)) for r in I))
    return s


# ---------------------------------------------------------------------------------------------- Pinocchio-level oracles
def point_jacobian(system, body, point, q):
    """3 × nv Jacobian of the world position of a body point, from Pinocchio's joint Jacobian.

    Independent of vibdyn's force groups: v_P = v_O + ω × (P − O) with the joint Jacobian in world axes.
    """
    model = system.model
    data = model.createData()
    info = system.body_info(body)
    pin.computeJointJacobians(model, data, q)
    pin.framesForwardKinematics(model, data, q)
    J = pin.getJointJacobian(model, data, info.joint_id, pin.LOCAL_WORLD_ALIGNED).reshape(6, model.nv)
    o = data.oMi[info.joint_id]
    P = o.act(info.body_in_joint.act(np.asarray(point, dtype=float)))
    r = P - o.translation
    return J[:3] - pin.skew(r) @ J[3:], P


def spring_force_q(system, a, b, k, l0, q):
    """Generalized force of a linear spring between points a = (body|"world", p) and b, by Jᵀf."""
    nv = system.nv
    ends = []
    for body, p in (a, b):
        if body == vd.WORLD:
            ends.append((np.zeros((3, nv)), np.asarray(p, dtype=float)))
        else:
            ends.append(point_jacobian(system, body, p, q))
    (Ja, xa), (Jb, xb) = ends
    d = xb - xa
    L = np.linalg.norm(d)
    fb = -k * (L - l0) * d / L
    return Jb.T @ fb - Ja.T @ fb


def bias(system, q, v):
    """b(q, v) = C(q, v) v + g(q) by Pinocchio's RNEA at zero acceleration on a fresh data."""
    model = system.model
    return pin.rnea(model, model.createData(), q, v, np.zeros(model.nv)).copy()


def tangent_gradient(f, system, q, h=1e-4):
    """∂f/∂ξ at ξ = 0 of ξ ↦ f(integrate(q, ξ)) by central differences (4th order, Richardson)."""
    g = np.zeros(system.nv)
    for k in range(system.nv):
        e = np.zeros(system.nv)
        e[k] = 1.0

        def d(step):
            return (f(system.integrate(q, step * e)) - f(system.integrate(q, -step * e))) / (2 * step)

        g[k] = (4 * d(h) - d(2 * h)) / 3
    return g


def rk4_step(system, q, v, h, t=0.0):
    """One classical RK4 step on the Lie group, in the local chart q = integrate(q_n, ξ), ξ(0) = 0.

    ξ̇ = dexp⁻¹(ξ) v via Pinocchio's dIntegrate, v̇ = accelerations: full 4th order on SO(3) too.
    """
    model = system.model

    def f(tt, xi, vv):
        J = pin.dIntegrate(model, q, xi, pin.ARG1)
        return np.linalg.solve(J, vv), system.accelerations(pin.integrate(model, q, xi), vv, tt)

    xi = np.zeros(system.nv)
    k1x, k1v = f(t, xi, v)
    k2x, k2v = f(t + h / 2, xi + h / 2 * k1x, v + h / 2 * k1v)
    k3x, k3v = f(t + h / 2, xi + h / 2 * k2x, v + h / 2 * k2v)
    k4x, k4v = f(t + h, xi + h * k3x, v + h * k3v)
    xi = h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x)
    v = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    return pin.integrate(model, q, xi), v


# ---------------------------------------------------------------------------------------------- MuJoCo oracle
_MJ_JOINT = {"pivot": "hinge", "slider": "slide", "ball": "ball", "free": "free"}


def _fmt(x):
    return " ".join(repr(float(v)) for v in np.ravel(x))


def scene_to_mjcf(scene, joint_elements=False):
    """MJCF text of a vibdyn scene (no force elements): the same solids, links and gravity.

    ``joint_elements=True`` also converts joint springs and joint dampers on pivots and sliders into the
    MuJoCo joint's ``stiffness``, ``springref`` and ``damping`` (MuJoCo: −k (q − springref) − c q̇, with
    qpos0 = 0 the neutral configuration, as vibdyn's rest offset); any other force element is refused.

    Pivot → hinge, Slider → slide, Ball → ball, Free → free, Fixed → no joint, Cylindrical → slide + hinge
    on the same axis, Universal → two hinges (applied in order, axes in the body frame), Planar → slides
    along the in-plane axes then a hinge about the normal. Joint ``at`` and
    ``rotation`` become the body ``pos``/``quat`` (MuJoCo quaternions are w, x, y, z); the inertia about the
    centre of mass in body axes becomes ``<inertial pos mass fullinertia>``. Contacts are disabled; no
    armature, damping or joint limits. Every MuJoCo joint carries its body's name (plus a suffix when a
    body has two).
    """
    passive = _joint_passive(scene) if joint_elements else {}
    if scene.elements and not joint_elements:
        raise ValueError("scene_to_mjcf: force elements are not converted (compare rigid-body terms only)")
    lines = ['<mujoco model="%s">' % scene.name,
             '  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>',
             f'  <option gravity="{_fmt(scene.gravity)}" integrator="RK4">',
             '    <flag contact="disable"/>', '  </option>', "  <worldbody>"]

    def emit(body, depth):
        J = body.joint
        pad = "  " * depth
        if J.type == "free" and body.parent != vd.WORLD:
            raise ValueError(f"body '{body.name}': MuJoCo only allows free joints on children of the world")
        R = np.eye(3) if J.rotation is None else np.array(J.rotation)
        x, y, z, w = pin.Quaternion(R).coeffs()
        lines.append(f'{pad}<body name="{body.name}" pos="{_fmt(J.at)}" quat="{_fmt([w, x, y, z])}">')
        if J.type in ("pivot", "slider"):
            extra = "".join(f' {k}="{v!r}"' for k, v in passive.get(body.name, {}).items())
            lines.append(f'{pad}  <joint name="{body.name}" type="{_MJ_JOINT[J.type]}" axis="{_fmt(J.axis)}"'
                         f'{extra}/>')
        elif J.type in ("ball", "free"):
            lines.append(f'{pad}  <joint name="{body.name}" type="{_MJ_JOINT[J.type]}"/>')
        elif J.type == "cylindrical":
            lines.append(f'{pad}  <joint name="{body.name}.s" type="slide" axis="{_fmt(J.axis)}"/>')
            lines.append(f'{pad}  <joint name="{body.name}.theta" type="hinge" axis="{_fmt(J.axis)}"/>')
        elif J.type == "planar":  # two slides along the in-plane axes, then the hinge about the normal
            A = J.alignment
            lines.append(f'{pad}  <joint name="{body.name}.x" type="slide" axis="{_fmt(A[:, 0])}"/>')
            lines.append(f'{pad}  <joint name="{body.name}.y" type="slide" axis="{_fmt(A[:, 1])}"/>')
            lines.append(f'{pad}  <joint name="{body.name}.theta" type="hinge" axis="{_fmt(A[:, 2])}"/>')
        elif J.type == "universal":
            lines.append(f'{pad}  <joint name="{body.name}.theta1" type="hinge" axis="{_fmt(J.axis1)}"/>')
            lines.append(f'{pad}  <joint name="{body.name}.theta2" type="hinge" axis="{_fmt(J.axis2)}"/>')
        elif J.type != "fixed":
            raise ValueError(f"body '{body.name}': no MuJoCo equivalent for a {J.type} joint")
        I = np.array(body.inertia)
        if body.mass > 0:
            full = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
            lines.append(f'{pad}  <inertial pos="{_fmt(body.com)}" mass="{float(body.mass)!r}" '
                         f'fullinertia="{_fmt(full)}"/>')
        for child in scene.children(body.name):
            emit(child, depth + 1)
        lines.append(f"{pad}</body>")

    for b in scene.children(vd.WORLD):
        emit(b, 2)
    lines += ["  </worldbody>", "</mujoco>"]
    return "\n".join(lines)


def _joint_passive(scene):
    """Per body: MuJoCo joint attributes (stiffness, springref, damping) of its joint springs and dampers.

    Several springs on one joint add up: k = Σ k_i, springref = Σ k_i r_i / Σ k_i (same force, same K).
    """
    out = {}
    for e in scene.elements.values():
        kind = type(e).__name__
        if kind not in ("JointSpring", "JointDamper"):
            raise ValueError(f"scene_to_mjcf: force element '{e.name}' ({kind}) is not converted; only joint "
                             "springs and dampers are (joint_elements=True)")
        body = scene.body(e.body)
        if body.joint.type not in ("pivot", "slider"):
            raise ValueError(f"scene_to_mjcf: {kind} '{e.name}' on a {body.joint.type} joint is not converted")
        a = out.setdefault(body.name, {"k": 0.0, "kr": 0.0, "c": 0.0})
        if kind == "JointSpring":
            a["k"] += float(e.stiffness[0])
            a["kr"] += float(e.stiffness[0]) * float(e.rest[0])
        else:
            a["c"] += float(e.damping[0])
    attrs = {}
    for name, a in out.items():
        d = {}
        if a["k"]:
            d["stiffness"], d["springref"] = a["k"], a["kr"] / a["k"]
        if a["c"]:
            d["damping"] = a["c"]
        attrs[name] = d
    return attrs


class MuJoCoOracle:
    """A MuJoCo model of a scene and the maps between vibdyn's and MuJoCo's coordinates.

    vibdyn/Pinocchio: ball q = (x, y, z, w), v = body angular velocity; free q = (p, x, y, z, w) relative
    to the joint placement, v = (body linear, body angular). MuJoCo: ball qpos = (w, x, y, z), qvel = body
    angular velocity; free qpos = world (p, w, x, y, z), qvel = (world linear, body angular). For the free
    joint v_mj = T v_pin with T = diag(R, 1) (R: body → world), so M_pin = Tᵀ M_mj T and
    b_pin = Tᵀ (b_mj + M_mj Ṫ v_pin) with Ṫ v_pin = (R (ω × v_lin), 0). Planar: Pinocchio q = (x, y, cos θ,
    sin θ), v = (in-plane velocity in body axes, θ̇); MuJoCo (x, y, θ) and (ẋ, ẏ, θ̇): T = diag(R2(θ), 1).
    """

    def __init__(self, scene, system, joint_elements=False):
        import mujoco

        self.mujoco = mujoco
        self.scene, self.system = scene, system
        self.xml = scene_to_mjcf(scene, joint_elements=joint_elements)
        self.model = mujoco.MjModel.from_xml_string(self.xml)
        self.data = mujoco.MjData(self.model)
        assert self.model.nv == system.nv, (self.model.nv, system.nv)
        # per vibdyn coordinate: the MuJoCo dof; per body: its MuJoCo joints
        self.dof = np.empty(system.nv, dtype=int)
        self.joints = []
        m = self.model
        for name in system.bodies:
            info = system.body_info(name)
            if info.nv == 0:
                continue
            kind = info.joint.type
            if kind in ("cylindrical", "universal", "planar"):
                mj_names = [name + s for s in info.joint.suffixes]
            else:
                mj_names = [name]
            ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in mj_names]
            assert min(ids) >= 0, mj_names
            dofs = [m.jnt_dofadr[i] + k for i in ids for k in range(_mj_nv(m.jnt_type[i]))]
            self.dof[info.idx_v:info.idx_v + info.nv] = dofs
            self.joints.append((info, ids))

    def set_state(self, q, v):
        """Write the vibdyn state (q, v) into MuJoCo's qpos/qvel; returns T (v_mj = T v_pin) and Ṫ v_pin."""
        m, d, system = self.model, self.data, self.system
        nv = system.nv
        T = np.zeros((m.nv, nv))
        Tdot_v = np.zeros(m.nv)
        T[self.dof, np.arange(nv)] = 1.0
        qvel = np.zeros(m.nv)
        qvel[self.dof] = v
        for info, ids in self.joints:
            qb = q[info.idx_q:info.idx_q + info.nq]
            kind = info.joint.type
            if kind == "ball":
                x, y, z, w = qb
                d.qpos[m.jnt_qposadr[ids[0]]:m.jnt_qposadr[ids[0]] + 4] = [w, x, y, z]
            elif kind == "free":
                P = info.joint.placement  # world → joint placement (free bodies hang from the world)
                Mq = pin.XYZQUATToSE3(qb)
                W = P * Mq
                a = m.jnt_qposadr[ids[0]]
                x, y, z, w = pin.Quaternion(W.rotation).coeffs()
                d.qpos[a:a + 7] = [*W.translation, w, x, y, z]
                R = W.rotation
                i0 = info.idx_v
                dofs = self.dof[i0:i0 + 3]
                T[np.ix_(dofs, range(i0, i0 + 3))] = R
                vl, w_ = v[i0:i0 + 3], v[i0 + 3:i0 + 6]
                qvel[dofs] = R @ vl
                Tdot_v[dofs] = R @ np.cross(w_, vl)
            elif kind == "planar":
                x, y, c, s_ = qb
                th = np.arctan2(s_, c)
                for i, val in zip(ids, (x, y, th)):
                    d.qpos[m.jnt_qposadr[i]] = val
                i0 = info.idx_v
                dofs = self.dof[i0:i0 + 2]
                R2 = np.array([[c, -s_], [s_, c]])
                T[np.ix_(dofs, range(i0, i0 + 2))] = R2
                qvel[dofs] = R2 @ v[i0:i0 + 2]
                Tdot_v[dofs] = v[i0 + 2] * R2 @ np.array([-v[i0 + 1], v[i0]])
            else:
                for j, i in enumerate(ids):
                    d.qpos[m.jnt_qposadr[i]] = qb[j]
        d.qvel[:] = qvel
        d.qacc[:] = 0.0
        return T, Tdot_v

    def dynamics(self, q, v):
        """(M, b) of MuJoCo mapped to vibdyn's coordinates: M_pin and b_pin = rnea(q, v, 0)."""
        mj = self.mujoco
        T, Tdot_v = self.set_state(np.asarray(q, float), np.asarray(v, float))
        mj.mj_forward(self.model, self.data)
        M = np.zeros((self.model.nv, self.model.nv))
        mj.mj_fullM(self.model, self.data, M)
        b = self.data.qfrc_bias.copy()
        return T.T @ M @ T, T.T @ (b + M @ Tdot_v)

    def positions(self):
        """World positions of the bodies' frames after the last state set (for placement checks)."""
        self.mujoco.mj_kinematics(self.model, self.data)
        return {self.model.body(i).name: self.data.xpos[i].copy() for i in range(1, self.model.nbody)}


def _mj_nv(jnt_type):
    return {0: 6, 1: 3, 2: 1, 3: 1}[int(jnt_type)]


# ---------------------------------------------------------------------------------------------- IFToMM A05 in MuJoCo
A05_MJCF = """<mujoco model="a05">
  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>
  <option gravity="0 0 -9.81" integrator="RK4" timestep="{dt!r}"><flag contact="disable"/></option>
  <worldbody>
    <body name="shaft">
      <joint name="shaft" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0 0.5" mass="0.3" fullinertia="0.0250025 0.0250025 5e-6 0 0 0"/>
      <body name="sleeve">
        <joint name="sleeve" type="slide" axis="0 0 1"/>
        <inertial pos="0 0 0" mass="3" fullinertia="0.005 0.005 0.005 0 0 0"/>
        <site name="s1" pos="0.05 0 0"/><site name="s2" pos="-0.05 0 0"/>
      </body>
      {rods}
    </body>
  </worldbody>
  <tendon>
    <spatial stiffness="8e5" damping="4e4" springlength="0.5"><site site="s1"/><site site="m1"/></spatial>
    <spatial stiffness="8e5" damping="4e4" springlength="0.5"><site site="s2"/><site site="m2"/></spatial>
  </tendon>
</mujoco>"""
A05_ROD = """<body name="rod{i}" pos="{x} 0 1">
        <joint name="rod{i}" type="hinge" axis="0 {y} 0"/>
        <inertial pos="{c} 0 0" mass="0.3" fullinertia="5e-6 0.0250025 0.0250025 0 0 0"/>
        <site name="m{i}" pos="{c} 0 0"/>
        <body pos="{t} 0 0"><inertial pos="0 0 0" mass="5" diaginertia="1e-12 1e-12 1e-12"/></body>
      </body>"""


def a05_mjcf(dt):
    """IFToMM A05 (models/iftomm_a05.toml) in MuJoCo: the same bodies and joints (qpos = vibdyn's q: shaft,
    sleeve, rod1, rod2), the spring-dampers as spatial tendons, the tip masses with MuJoCo's least inertia."""
    rods = "\n      ".join(A05_ROD.format(i=i, x=x, y=y, c=0.5 * x / 0.05, t=x / 0.05)
                            for i, x, y in ((1, 0.05, 1), (2, -0.05, -1)))
    return A05_MJCF.format(dt=dt, rods=rods)


def a05_mjcf_run(mujoco, t_out, q0, v0, dt):
    """qpos (rows) at the times ``t_out`` of MuJoCo's RK4 run of A05 from (q0, v0) at step ``dt``."""
    model = mujoco.MjModel.from_xml_string(a05_mjcf(dt))
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = q0, v0
    out, t = [], 0.0
    for target in t_out:
        n = int(round((target - t) / dt))
        if n:
            mujoco.mj_step(model, data, nstep=n)
        t += n * dt
        out.append(data.qpos.copy())
    return np.array(out)


# --------------------------------------------------------------------------------------- IFToMM A04 cut elsewhere
def bricard_cut_at_c(a04):
    """IFToMM A04 (the scene of models/iftomm_a04.toml) as another tree: rods 1, 2 from A and rods 5, 4, 3 from
    F, the loop closed at C (P3) instead of F. Same rods, same joints; other coordinates and other loop
    equations: an independent check of a run of the bundled model."""
    rod = dict(a04.bodies)
    s = vd.Scene("a04_cut_at_c", gravity=a04.gravity)
    for name in ("rod1", "rod2"):
        b = rod[name]
        s.add_body(name, parent=b.parent, joint=b.joint, mass=b.mass, com=b.com, inertia=b.inertia)
    s.add_body("rod5", joint=vd.Pivot((1, 0, 0), at=(0, 0, 1)), mass=1.0, com=(0, -0.5, 0), inertia=rod["rod5"].inertia)
    s.add_body("rod4", parent="rod5", joint=vd.Pivot((0, 0, 1), at=(0, -1, 0)), mass=1.0, com=(0.5, 0, 0),
               inertia=rod["rod4"].inertia)
    s.add_body("rod3", parent="rod4", joint=vd.Pivot((0, 1, 0), at=(1, 0, 0)), mass=1.0, com=(0, 0, -0.5),
               inertia=rod["rod3"].inertia)
    s.add_loop("C", ("rod2", (0, -1, 0)), ("rod3", (0, 0, -1)), joint=vd.Pivot((1, 0, 0)))
    return s
