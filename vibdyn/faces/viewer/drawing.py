"""What the viewer draws of a system, as plain data: the objects (three.js JSON, in the frames of the nodes
that carry them) and the poses of the animated nodes for a configuration. No meshcat import here.

Nodes: one per body (its frame), one per robot mesh (its placement), one per spring and damper (placed at
end ``a``, its z axis towards end ``b`` and scaled by their distance, so it stretches with the motion).
Shapes come from the bodies' ``shape`` (see :mod:`vibdyn.description.shapes`); a body without one gets a thin rod from
its centre of mass to each point it links (joint, children's joints, anchors) and, at its centre of mass,
the box of equal inertia (a sphere for a point mass). Joints are small markers along their axes. Lengths
are in m, world axes.
"""

import uuid
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ...description.elements import WORLD, Damper, Spring, Support
from ...errors import ModelError

ROOT = "/meshcat/vibdyn"
PALETTE = (0x1f77b4, 0xff7f0e, 0x2ca02c, 0xd62728, 0x9467bd, 0x8c564b, 0xe377c2, 0x17becf, 0xbcbd22, 0x7f7f7f)
ROD_COLOR, JOINT_COLOR, SPRING_COLOR, DAMPER_COLOR, ANCHOR_COLOR = 0x555555, 0x222222, 0xd4a017, 0x6a3d9a, 0x333333


@dataclass
class Item:
    """One drawn object: three.js geometry and material (JSON), its matrix in its node's frame."""

    node: str  # path of the node that carries it, under ROOT
    name: str
    geometry: dict
    material: dict
    matrix: np.ndarray
    kind: str = "Mesh"  # or "Line"


@dataclass
class Drawing:
    """The objects of a system and how to pose them (see the module documentation)."""

    system: object
    items: list = field(default_factory=list)
    bodies: list = field(default_factory=list)  # body names with a node
    links: list = field(default_factory=list)  # (node name, (body, point) a, (body, point) b) springs/dampers
    robot: object = None  # (pin model, data, geometry model, geometry data) of a robot's visual meshes
    probes: list = field(default_factory=list)  # (body, point): points whose displacement sizes the motion
    size: float = 1.0  # m, the scene's size (diagonal of its bounding box)
    center: np.ndarray | None = None
    ground: float = 0.0  # height (z, m) of the ground grid
    _anchors: tuple | None = None  # (joint ids, points in joint frames) of the link ends

    def poses(self, q):
        """{node path under ROOT: 4×4 matrix in world axes} for configuration q (springs scaled along z)."""
        names, mats, ends = self.state(q)
        out = dict(zip(names, mats))
        for (name, _, _), (a, b) in zip(self.links, ends):
            out["links/" + name] = stretch(a, b)
        return out

    def state(self, q):
        """(node names, their 4×4 world matrices (n × 4 × 4), link ends (links × 2 × 3)) at q: the bodies
        and robot meshes, then the spring and damper anchors in world axes (m)."""
        system = self.system
        pin.forwardKinematics(system.model, system.data, q)
        oMi = system.data.oMi
        names, mats = [], []
        for name in self.bodies:
            b = system.body_info(name)
            names.append("bodies/" + name)
            mats.append((oMi[b.joint_id] * b.body_in_joint).homogeneous)
        if self.robot is not None:
            from ...io.robots import to_pin

            model, data, gmodel, gdata = self.robot
            pin.updateGeometryPlacements(model, data, gmodel, gdata, to_pin(system, q))
            for k in range(gmodel.ngeoms):
                names.append(f"robot/{k}")
                mats.append(gdata.oMg[k].homogeneous)
        if self._anchors is None:
            atts = [end for _, a, b in self.links for end in (a, b)]
            self._anchors = system.attachments(atts) if atts else (np.zeros(0, int), np.zeros((0, 3)))
        joints, local = self._anchors
        if joints.size:
            used = np.unique(joints)
            R = np.array([oMi[int(j)].rotation for j in used])
            p = np.array([oMi[int(j)].translation for j in used])
            k = np.searchsorted(used, joints)
            ends = (np.einsum("nij,nj->ni", R[k], local) + p[k]).reshape(-1, 2, 3)
        else:
            ends = np.zeros((0, 2, 3))
        return names, np.array(mats).reshape(-1, 4, 4), ends

    def points(self, q):
        """World positions (m) of the probe points at q, (n × 3)."""
        return np.array([self.system.point_position(b, p, q) for b, p in self.probes]).reshape(-1, 3)

    def frame(self, configurations, samples=60):
        """Grow the size and centre (and lower the ground) to hold the probe points at every one of
        ``configurations`` (a replayed motion: up to ``samples`` of them, evenly spaced, the ends included),
        so that the camera frames the whole motion, not its first pose."""
        qs = np.asarray(configurations, float)
        if not len(qs) or not self.probes:
            return
        pick = np.unique(np.linspace(0, len(qs) - 1, min(samples, len(qs))).round().astype(int))
        pts = np.vstack([self.points(qs[k]) for k in pick])
        half = 0.5 * self.size / np.sqrt(3)  # the current box, as a cube of the same diagonal around the centre
        lo = np.minimum(pts.min(axis=0), self.center - half)
        hi = np.maximum(pts.max(axis=0), self.center + half)
        self.size = max(float(np.linalg.norm(hi - lo)), self.size)
        self.center = 0.5 * (lo + hi)
        self.ground = min(self.ground, float(pts[:, 2].min()) - 0.05 * self.size)


def stretch(a, b):
    """4×4 matrix placing a unit segment along z at a, pointing at b, scaled by |b − a| along z."""
    d = np.asarray(b, dtype=float) - a
    L = float(np.linalg.norm(d))
    R = rotation_z_to(d / L if L > 0 else np.array([0.0, 0.0, 1.0]))
    M = np.eye(4)
    M[:3, :3] = R @ np.diag([1.0, 1.0, max(L, 1e-9)])
    M[:3, 3] = a
    return M


def rotation_z_to(u):
    """A rotation matrix taking the z axis to the unit vector u."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(np.dot(z, u))
    if c < -1 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    v = np.cross(z, u)
    K = pin.skew(v)
    return np.eye(3) + K + K @ K / (1 + c)


def link_points(scene):
    """{body: [points in its frame (m)]} where a body meets the rest of the scene besides its own joint
    (its frame's origin): its children's joints, the ends of springs and dampers on it, and its loop
    points — what a drawing joins to its centre of mass, so that a closed loop's links meet."""
    anchors = {name: [] for name in scene.bodies}
    for e in list(scene.elements_of(Spring)) + list(scene.elements_of(Damper)):
        for body, p in (e.a, e.b):
            if body in anchors:
                anchors[body].append(np.asarray(p, dtype=float))
    for b in scene.bodies.values():
        if b.parent in anchors:
            anchors[b.parent].append(np.asarray(b.joint.at, dtype=float))
    for lp in scene.loops.values():
        for body, p in (lp.a, lp.b):
            if body in anchors:
                anchors[body].append(np.asarray(p, dtype=float))
    return anchors


def drawing(system, q0):
    """The :class:`Drawing` of a system, sized and centred at configuration q0."""
    scene = system.scene
    d = Drawing(system)
    robot = getattr(scene, "robot_source", None)
    if robot is not None:
        d.robot = _robot_geometry(robot)
    # points that matter: body origins, centres of mass, anchors, children's joints, loop points
    anchors = link_points(scene)
    pts = []
    for b in scene.bodies.values():
        pts += [system.point_position(b.name, p, q0) for p in [np.zeros(3), np.asarray(b.com)] + anchors[b.name]]
        d.probes += [(b.name, tuple(p)) for p in [np.zeros(3), np.asarray(b.com)] + anchors[b.name]]
    for e in list(scene.elements_of(Spring)) + list(scene.elements_of(Damper)):
        for body, p in (e.a, e.b):
            if body not in scene.bodies:
                pts.append(np.asarray(p, dtype=float))
    if d.robot is not None:
        model, data, gmodel, gdata = d.robot
        from ...io.robots import to_pin

        pin.updateGeometryPlacements(model, data, gmodel, gdata, to_pin(system, q0))
        for k, g in enumerate(gmodel.geometryObjects):
            pts += [gdata.oMg[k].act(c) for c in _corners(g.geometry)]
    pts = np.array(pts, dtype=float).reshape(-1, 3) if pts else np.zeros((1, 3))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    d.size = max(float(np.linalg.norm(hi - lo)), 0.1)
    d.center = 0.5 * (lo + hi)
    d.ground = float(lo[2]) - 0.05 * d.size
    # details (rods, markers, point masses) sized by the scene, and by its links when they are short
    lengths = [np.linalg.norm(p - np.asarray(b.com)) for b in scene.bodies.values()
               for p in [np.zeros(3)] + anchors[b.name]]
    lengths = [x for x in lengths if x > 1e-6 * d.size]
    s = min(d.size, 6 * float(np.median(lengths))) if lengths else d.size
    rod, joint_r = 0.008 * s, 0.02 * s

    for i, b in enumerate(scene.bodies.values()):
        node = "bodies/" + b.name
        d.bodies.append(b.name)
        color = PALETTE[i % len(PALETTE)]
        com = np.asarray(b.com)
        if b.shape:
            for k, sh in enumerate(b.shape):
                d.items += _shape_items(node, f"shape{k}", sh, com, color)
        elif robot is None:
            for k, p in enumerate([np.zeros(3)] + anchors[b.name]):
                if np.linalg.norm(p - com) > 1e-9 * s:
                    d.items.append(Item(node, f"rod{k}", cylinder_geometry(rod, 1.0), phong(ROD_COLOR),
                                        stretch(com, p) @ _translate_z(0.5) @ Y_TO_Z))
            if b.mass > 0:
                d.items.append(_mass_item(node, b, s, color))
        if robot is None and b.joint.nv > 0:
            d.items += _joint_items(node, b.joint, joint_r)
        if b.parent == WORLD and robot is None:
            d.items.append(Item(node, "anchor", box_geometry((2 * joint_r,) * 3), phong(ANCHOR_COLOR),
                                np.eye(4)))
    if d.robot is not None:
        d.items += _robot_items(d.robot)
    sprung = {_ends(e) for e in scene.elements_of(Spring)}
    for e in list(scene.elements_of(Spring)) + list(scene.elements_of(Damper)):
        node = "links/" + e.name
        d.links.append((e.name, e.a, e.b))
        if isinstance(e, Spring):
            d.items.append(Item(node, "coil", coil_geometry(0.025 * s), line_material(SPRING_COLOR), np.eye(4),
                                "Line"))
        else:  # beside a spring on the same ends, as a suspension is drawn (inside it, it would hide the coil)
            beside = _ends(e) in sprung
            d.items.append(Item(node, "body", cylinder_geometry(0.012 * s, 1.0), phong(DAMPER_COLOR, 0.85),
                                _translate((0.06 * s if beside else 0.0, 0.0, 0.5)) @ Y_TO_Z))
        for end in (e.a, e.b):
            if end[0] == WORLD or isinstance(scene.elements.get(end[0]), Support):
                d.items.append(Item("world", f"{e.name}.{end[0]}", box_geometry((1.5 * joint_r,) * 3),
                                    phong(ANCHOR_COLOR), _translate(end[1])))
    return d


# ------------------------------------------------------------------ three.js JSON helpers

Y_TO_Z = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])  # three.js y axis → z


def _ends(element):
    """The two ends of a spring or damper, in either order."""
    return frozenset({(element.a[0], tuple(element.a[1])), (element.b[0], tuple(element.b[1]))})


def _translate(p):
    M = np.eye(4)
    M[:3, 3] = p
    return M


def _translate_z(z):
    return _translate((0.0, 0.0, z))


def _placement(R, p):
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, p
    return M


def box_geometry(size):
    return {"type": "BoxGeometry", "width": float(size[0]), "height": float(size[1]), "depth": float(size[2])}


def sphere_geometry(r):
    return {"type": "SphereGeometry", "radius": float(r), "widthSegments": 20, "heightSegments": 14}


def cylinder_geometry(r, h):
    """Cylinder of radius r and height h along the y axis (three.js), centred."""
    return {"type": "CylinderGeometry", "radiusTop": float(r), "radiusBottom": float(r), "height": float(h),
            "radialSegments": 20}


def coil_geometry(r, turns=8, n=160):
    """Helix of radius r from z = 0 to z = 1 with straight ends (a spring of unit length)."""
    u = np.linspace(0.0, 1.0, n)
    z = 0.1 + 0.8 * u
    x, y = r * np.cos(2 * np.pi * turns * u), r * np.sin(2 * np.pi * turns * u)
    pts = np.vstack([[0, 0, 0], [x[0], y[0], 0.1], np.column_stack([x, y, z]), [x[-1], y[-1], 0.9], [0, 0, 1]])
    return {"type": "BufferGeometry", "data": {"attributes": {"position": {
        "itemSize": 3, "type": "Float32Array", "normalized": False,
        "array": np.round(pts.ravel(), 6).tolist()}}}}


def phong(color, opacity=1.0):
    m = {"type": "MeshPhongMaterial", "color": int(color), "reflectivity": 0.5, "side": 2}
    if opacity < 1:
        m.update(transparent=True, opacity=float(opacity))
    return m


def line_material(color):
    return {"type": "LineBasicMaterial", "color": int(color), "linewidth": 2}


def rgb(color):
    return int(round(color[0] * 255)) << 16 | int(round(color[1] * 255)) << 8 | int(round(color[2] * 255))


def three_object(item):
    """The three.js JSON object (set_object payload) of an item."""
    g, m = str(uuid.uuid4()), str(uuid.uuid4())
    return {"metadata": {"version": 4.5, "type": "Object"},
            "geometries": [{**item.geometry, "uuid": g}], "materials": [{**item.material, "uuid": m}],
            "object": {"uuid": str(uuid.uuid4()), "type": item.kind, "geometry": g, "material": m,
                       "matrix": [float(x) for x in np.asarray(item.matrix).T.ravel()]}}


# ------------------------------------------------------------------ shapes

def _mass_item(node, body, s, color):
    """Box of equal inertia at the centre of mass (principal axes); a sphere for a point mass."""
    I = np.array(body.inertia)
    w, V = np.linalg.eigh(I)
    sides2 = 6.0 / body.mass * np.array([w[1] + w[2] - w[0], w[0] + w[2] - w[1], w[0] + w[1] - w[2]])
    sides = np.sqrt(np.clip(sides2, 0.0, None))
    if np.linalg.det(V) < 0:
        V[:, 2] *= -1
    if sides.max() < 0.02 * s:  # a point mass
        return Item(node, "mass", sphere_geometry(0.035 * s), phong(color), _translate(body.com))
    sides = np.maximum(sides, 0.02 * s)
    return Item(node, "mass", box_geometry(sides), phong(color), _placement(V, body.com))


def _shape_items(node, name, sh, com, color):
    at = com if sh.at is None else np.asarray(sh.at)
    R = np.eye(3) if sh.rotation is None else np.array(sh.rotation)
    M = _placement(R, at)
    mat = phong(color if sh.color is None else rgb(sh.color))
    if sh.type == "box":
        return [Item(node, name, box_geometry(sh.size), mat, M)]
    if sh.type == "sphere":
        return [Item(node, name, sphere_geometry(sh.size[0]), mat, M)]
    if sh.type == "mesh":
        return [Item(node, name, mesh_geometry(sh.path, f"{node.split('/')[-1]} shape {name}"), mat,
                     M @ np.diag([*sh.size, 1.0]))]
    r, L = sh.size
    A = M @ _placement(rotation_z_to(np.asarray(sh.axis)), np.zeros(3))
    out = [Item(node, name, cylinder_geometry(r, L), mat, A @ Y_TO_Z)] if L > 0 else []
    if sh.type == "capsule":
        out += [Item(node, f"{name}.cap{k}", sphere_geometry(r), mat, A @ _translate_z(z))
                for k, z in enumerate((-L / 2, L / 2))]
    return out


def _joint_items(node, joint, r):
    """The joint's markers (its type says which: :meth:`vibdyn.description.joints.Joint.markers`)."""
    markers = joint.markers()
    items = []
    for k, (shape, axis) in enumerate(markers):
        name = "joint" if len(markers) == 1 else f"joint{k}"
        A = np.eye(4) if axis is None else _placement(rotation_z_to(np.asarray(axis, float)), np.zeros(3))
        if shape == "cylinder":
            width = r if len(markers) == 1 else 0.7 * r
            items.append(Item(node, name, cylinder_geometry(width, 4 * r), phong(JOINT_COLOR), A @ Y_TO_Z))
        elif shape == "box":
            items.append(Item(node, name, box_geometry((0.6 * r, 0.6 * r, 8 * r)), phong(JOINT_COLOR), A))
        else:
            items.append(Item(node, name, sphere_geometry(1.3 * r), phong(JOINT_COLOR), A))
    return items


def mesh_geometry(path, what="mesh"):
    """A mesh file as a meshcat geometry: text for .obj/.dae, bytes for .stl. A file that cannot be read (moved
    or deleted since its body was described) is a ModelError naming ``what`` and the path."""
    fmt = path.rsplit(".", 1)[-1].lower()
    try:
        if fmt == "stl":
            with open(path, "rb") as f:
                data = f.read()
        else:
            with open(path, encoding="utf-8", errors="replace") as f:
                data = f.read()
    except OSError as e:
        raise ModelError(f"{what}: mesh file {path}: cannot read it ({e.strerror or e})") from None
    return {"type": "_meshfile_geometry", "format": fmt, "data": data}


# ------------------------------------------------------------------ robots

def _robot_geometry(src):
    """Pinocchio model, data and visual geometry of a robot file (meshes and primitives)."""
    model = src.pin_model()
    try:
        if src.format == "urdf":
            gmodel = pin.buildGeomFromUrdf(model, src.path, pin.GeometryType.VISUAL,
                                           package_dirs=list(src.package_dirs))
        else:
            gmodel = pin.buildGeomFromMJCF(model, src.path, pin.GeometryType.VISUAL)
    except (RuntimeError, ValueError, AttributeError):  # meshes missing: inertia boxes are drawn instead
        return None
    return model, model.createData(), gmodel, pin.GeometryData(gmodel)


def _corners(geometry):
    """Corners of a collision geometry's local bounding box (its origin when it has none)."""
    try:
        geometry.computeLocalAABB()
        lo, hi = np.asarray(geometry.aabb_local.min_), np.asarray(geometry.aabb_local.max_)
    except (AttributeError, RuntimeError):
        return [np.zeros(3)]
    return [np.where([i & 1, i & 2, i & 4], hi, lo) for i in range(8)]


def _robot_items(robot):
    model, data, gmodel, gdata = robot
    items = []
    for k, g in enumerate(gmodel.geometryObjects):
        c = np.asarray(g.meshColor, dtype=float)
        default = c.size < 3 or not np.any(c[:3] > 0) or np.allclose(c[:3], 0.9)  # Pinocchio's default grey
        color = PALETTE[k % len(PALETTE)] if default else rgb(np.clip(c[:3], 0, 1))
        mat = phong(color)
        path = getattr(g, "meshPath", "") or ""
        scale = np.diag([*np.asarray(g.meshScale, dtype=float), 1.0])
        geom = g.geometry
        gname = type(geom).__name__
        if path.lower().endswith((".stl", ".obj", ".dae")):
            items.append(Item(f"robot/{k}", "mesh", mesh_geometry(path), mat, scale))
        elif gname == "Box":
            items.append(Item(f"robot/{k}", "box", box_geometry(2 * np.asarray(geom.halfSide)), mat, np.eye(4)))
        elif gname == "Sphere":
            items.append(Item(f"robot/{k}", "sphere", sphere_geometry(geom.radius), mat, np.eye(4)))
        elif gname in ("Cylinder", "Capsule"):
            L = 2 * geom.halfLength
            items.append(Item(f"robot/{k}", "cylinder", cylinder_geometry(geom.radius, L), mat, Y_TO_Z))
    return items
