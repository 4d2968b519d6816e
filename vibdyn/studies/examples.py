"""Small scenes built by module-level functions of their parameters: ready for :func:`vibdyn.sweep` (whose
worker processes import ``build`` functions by name) and for examples. SI units."""

from __future__ import annotations

import numpy as np

from ..description import inertia
from ..description.joints import Pivot, Slider
from ..description.scene import Scene


def chain(n: int = 3, k: float = 1000.0, m: float = 1.0, **stiffness) -> Scene:
    """``n`` masses ``m`` (kg) on sliders along x in series, a spring ``k`` (N/m) from the wall to the first
    and between neighbours (fixed–free); ``k1=…, k2=…`` override single springs (k1 is the wall's)."""
    n = int(n)
    s = Scene(f"chain{n}")
    parent = "world"
    for i in range(1, n + 1):
        s.add_body(f"m{i}", parent=parent, joint=Slider(axis=(1, 0, 0), at=(1.0 if i > 1 else 0.0, 0, 0)),
                   mass=float(m), inertia=inertia.point())
        s.add_joint_spring(f"m{i}", float(stiffness.get(f"k{i}", k)))
        parent = f"m{i}"
    return s


def two_modes(k1: float, k2: float = 100.0, kc: float = 0.0, m1: float = 1.0, m2: float = 1.0) -> Scene:
    """Two masses on parallel sliders, each held by its own spring to the wall (k1, k2 N/m) and coupled by a
    spring kc (N/m): with kc = 0 the modes cross as k1 passes k2·m1/m2; with kc > 0 they veer."""
    s = Scene("two_modes")
    s.add_body("a", joint=Slider(axis=(1, 0, 0)), mass=float(m1), inertia=inertia.point())
    s.add_body("b", joint=Slider(axis=(1, 0, 0), at=(1.0, 0, 0)), mass=float(m2), inertia=inertia.point())
    s.add_joint_spring("a", float(k1))
    s.add_joint_spring("b", float(k2))
    if kc:
        s.add_spring("kc", ("a", (0, 0, 0)), ("b", (0, 0, 0)), stiffness=float(kc))
    return s


def gimbal_rotor(It: float = 0.08, Ip: float = 0.12, k: float = 300.0) -> Scene:
    """A disk (transverse inertia It, polar Ip, kg·m²) in a massless gimbal: tilt about x, then y (torsion
    springs k, N·m/rad), spin about z."""
    s = Scene("gimbal_rotor")
    s.add_body("outer", joint=Pivot(axis=(1, 0, 0)), mass=0.0)
    s.add_body("inner", parent="outer", joint=Pivot(axis=(0, 1, 0)), mass=0.0)
    s.add_body("rotor", parent="inner", joint=Pivot(axis=(0, 0, 1)), mass=1.0,
               inertia=np.diag([float(It), float(It), float(Ip)]))
    s.add_joint_spring("outer", float(k))
    s.add_joint_spring("inner", float(k))
    return s
