"""Inertia tensors of common solids (kg·m², about the centre of mass, in the body frame).

Every helper returns a 3×3 array that ``Scene.add_body(inertia=...)`` accepts. Tensors given about another
point convert with :func:`to_com` (Huygens): I_G = I_O − m(|c|²·1 − c cᵀ), c the vector from O to G.
"""

import numpy as np

from .._check import finite_array, scalar, unit_axis, vector3
from ..errors import ModelError


def point(mass=None):
    """A point mass: zero tensor (the mass argument is accepted for symmetry and ignored)."""
    return np.zeros((3, 3))


def rod(mass, length, axis=(0, 0, 1)):
    """Thin uniform rod along ``axis``: m L²/12 across, 0 along."""
    m, L = scalar(mass, "rod mass", nonnegative=True), scalar(length, "rod length", nonnegative=True)
    a = unit_axis(axis, "rod axis")
    return m * L**2 / 12.0 * (np.eye(3) - np.outer(a, a))


def box(mass, size):
    """Uniform box of edge lengths ``size`` = (a, b, c) along the body axes: m(b²+c²)/12, ..."""
    m = scalar(mass, "box mass", nonnegative=True)
    a, b, c = vector3(size, "box size")
    if min(a, b, c) < 0:
        raise ModelError(f"box size: edge lengths must not be negative, got {[float(a), float(b), float(c)]}")
    return m / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


def cylinder(mass, radius, length, axis=(0, 0, 1)):
    """Solid uniform cylinder: m r²/2 about ``axis``, m(3r² + L²)/12 across."""
    m = scalar(mass, "cylinder mass", nonnegative=True)
    r = scalar(radius, "cylinder radius", nonnegative=True)
    L = scalar(length, "cylinder length", nonnegative=True)
    return _axisymmetric(m * r * r / 2.0, m * (3 * r * r + L * L) / 12.0, unit_axis(axis, "cylinder axis"))


def disc(mass, radius, axis=(0, 0, 1)):
    """Thin uniform disc: m r²/2 about ``axis``, m r²/4 across (on the triangle inequality)."""
    m, r = scalar(mass, "disc mass", nonnegative=True), scalar(radius, "disc radius", nonnegative=True)
    return _axisymmetric(m * r * r / 2.0, m * r * r / 4.0, unit_axis(axis, "disc axis"))


def sphere(mass, radius, hollow=False):
    """Uniform solid sphere (2/5 m r²) or thin spherical shell if ``hollow`` (2/3 m r²)."""
    m, r = scalar(mass, "sphere mass", nonnegative=True), scalar(radius, "sphere radius", nonnegative=True)
    return (2.0 / 3.0 if hollow else 0.4) * m * r * r * np.eye(3)


def to_com(tensor, mass, com, point=(0, 0, 0)):
    """Huygens: a tensor about ``point`` → the same tensor about the centre of mass ``com`` (body frame)."""
    c = vector3(com, "com") - vector3(point, "point")
    I_o = finite_array(tensor, (3, 3), "inertia")
    return I_o - scalar(mass, "mass") * (c @ c * np.eye(3) - np.outer(c, c))


def to_point(tensor, mass, com, point=(0, 0, 0)):
    """Huygens the other way: a tensor about the centre of mass → the tensor about ``point``."""
    c = vector3(com, "com") - vector3(point, "point")
    I_g = finite_array(tensor, (3, 3), "inertia")
    return I_g + scalar(mass, "mass") * (c @ c * np.eye(3) - np.outer(c, c))


def check(tensor, mass, what="inertia"):
    """A physical inertia about the centre of mass, symmetrised; else ModelError naming ``what``.

    Accepts the limit cases: zero tensor (point mass), one zero moment (thin rod), a principal moment
    equal to the sum of the others (thin disc). A massless body must have a zero tensor.
    """
    I = finite_array(tensor, (3, 3), what)
    scale = np.abs(I).max()
    if scale == 0.0:
        return I  # point mass (or massless body)
    S = I / scale  # checks on the scaled tensor: no overflow near 1e308, no absolute tolerance
    if np.abs(S - S.T).max() > 1e-9:
        raise ModelError(f"{what}: tensor is not symmetric")
    S = 0.5 * (S + S.T)
    if mass == 0.0:
        raise ModelError(f"{what}: a massless body cannot have rotational inertia")
    p = np.linalg.eigvalsh(S)
    tol = 1e-9 * max(p.max(), 0.0)
    if p.min() < -tol:
        raise ModelError(f"{what}: negative principal moment {p.min() * scale:.6g} kg·m² (not physical)")
    a, b, c = np.sort(p)
    if c > a + b + tol:
        raise ModelError(f"{what}: principal moments ({a * scale:.6g}, {b * scale:.6g}, {c * scale:.6g}) break "
                         "the triangle inequality C ≤ A + B")
    I = np.where(I == I.T, I, 0.5 * I + 0.5 * I.T)  # symmetrised; unchanged if it was symmetric
    np.fill_diagonal(I, np.maximum(I.diagonal(), 0.0))  # round-off below zero: Pinocchio refuses it
    return I


def _axisymmetric(axial, transverse, a):
    return transverse * np.eye(3) + (axial - transverse) * np.outer(a, a)
