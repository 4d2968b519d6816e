"""Point-to-point linear spring: force k (L − free_length) along the line between two points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._check import MAX_LENGTH, bounded, scalar, value_attachment, value_nonnegative, value_string
from ..._format import number
from ...errors import ModelError
from ...model.groups import TwoPoint
from .base import WORLD, ElementKind, att_list, end_label, file_attachment


class Springs(TwoPoint):
    """Point-to-point linear springs: force on end b = −k (L − l0) u, u from a to b."""

    noun = "spring"
    rows = True

    def __init__(self, system, elements):
        super().__init__(system, elements)
        self.k = np.array([e.stiffness for e in elements])
        self.l0 = np.array(free_lengths(system, elements), dtype=float)
        self.zero_l0 = self.l0 == 0.0  # a zero-free-length spring pulls as −k d: no direction needed
        self.tiny = np.where(self.zero_l0, -1.0, 1e-9 * np.maximum(self.l0, 1e-3))
        # (L − l0)/L is 1 for a zero-free-length spring: L/L, its L kept off zero by the smallest normal float
        # (below it d is zero to double precision); the others are longer than tiny (None: no such spring)
        self.L_floor = np.where(self.zero_l0, np.finfo(float).tiny, 0.0) if self.zero_l0.any() else None
        self.minus_k = -self.k
        self.linear = bool(self.zero_l0.all())
        self.minus_k_column = self.minus_k[:, None]

    def apply(self, t, q, v, kin, Q, F):
        if self.linear:  # (zero free lengths: −k d, no length, nothing singular)
            fb = self.minus_k_column * self.separation(kin)
        else:
            d, L = self.geometry(kin)
            Ls = L if self.L_floor is None else np.maximum(L, self.L_floor)
            fb = (self.minus_k * ((L - self.l0) / Ls))[..., None] * d
        self.ends.add_forces(F, kin, fb)  # fb on every end b, −fb on every end a

    def potential(self, q, kin):
        _, L = self.geometry(kin)
        return 0.5 * float(self.k @ (L - self.l0) ** 2)

    def derivatives(self, d):
        dx, L = self.geometry(d.fkin)
        for i in range(len(self.k)):
            ja, jb = int(self.ja[i]), int(self.jb[i])
            Pb, Pa = d.point(jb, self.pb[i]), d.point(ja, self.pa[i])  # (zeros for an end on the world)
            Jrel = Pb - Pa
            k = self.k[i]
            if self.zero_l0[i]:
                Fb, dF = -k * dx[i], -k * Jrel
            else:
                # −Ks Jrel with Ks = k((1 − l0/L) I + (l0/L) u uᵀ), without forming Ks
                u = dx[i] / L[i]
                ratio = self.l0[i] / L[i]
                Fb = -k * (L[i] - self.l0[i]) * u
                dF = (-k * (1 - ratio)) * Jrel - (k * ratio) * np.outer(u, u @ Jrel)
            # (|Ks| ≤ k, times the ends' own Jacobians, in every axis: their difference Jrel cancels where the spring
            # turns about its own line, and its direction u rounds in every axis, leaving ε k |J| in each)
            size = None if d.dFq_abs is None else np.broadcast_to(
                self.k[i] * (np.abs(Pb).sum(axis=0) + np.abs(Pa).sum(axis=0)), dF.shape)
            d.add_force(jb, self.pb[i], Fb, dF, None, size)
            d.add_force(ja, self.pa[i], -Fb, -dF, None, size)


    def derivatives_rows(self, d):
        dx, L = self.geometry(d.kin)  # B × n × 3, B × n
        n = len(self.k)
        P = d.points(self.j_ends, self.p_ends)  # ends a, then b
        Jrel = P[:, n:] - P[:, :n]
        k = self.k[:, None, None]
        if self.zero_l0.all():
            Fb, dF = -self.k[:, None] * dx, -k * Jrel
        else:  # −Ks Jrel with Ks = k((1 − l0/L) I + (l0/L) u uᵀ)
            Ls = np.where(self.zero_l0, 1.0, L)
            u = np.where(self.zero_l0[:, None], 0.0, dx / Ls[..., None])
            ratio = np.where(self.zero_l0, 0.0, self.l0 / Ls)[..., None, None]
            Fb = np.where(self.zero_l0[:, None], -self.k[:, None] * dx, (-self.k * (L - self.l0))[..., None] * u)
            dF = -k * (1 - ratio) * Jrel - k * ratio * u[..., :, None] * np.einsum("bna,bnaj->bnj", u, Jrel)[
                ..., None, :]
        d.add_forces(self.j_ends, P, np.concatenate([-Fb, Fb], axis=1), np.concatenate([-dF, dF], axis=1))


    def force_rounding(self, d):
        """(U, s): ∂L/∂q of each spring (1 × nv per spring; its force along the line is −k(L − l0)) and the
        rounding of that force, ε·k·(|x_a| + |x_b|) N: L is a difference of world positions, each rounded to
        ε of its size (a spring 10 m out moved by 1e-4 m keeps ~12 digits of its stretch, whatever its force)."""
        dx, L = self.geometry(d.kin)
        u = dx[0] / np.where(L[0] > 0.0, L[0], 1.0)[:, None]
        Jrel = d.points(self.jb, self.pb)[0] - d.points(self.ja, self.pa)[0]
        U = np.einsum("na,naj->nj", u, Jrel)
        sp = d.kin.sp if d.kin.sp.ndim == 2 else d.kin.sp[0]
        xa = np.linalg.norm(d.kin.points(self.ja, self.pa)[0] + sp[self.sa], axis=1)
        xb = np.linalg.norm(d.kin.points(self.jb, self.pb)[0] + sp[self.sb], axis=1)
        return U, np.finfo(float).eps * self.k * (xa + xb)


def free_lengths(system, springs):
    """Free length of each spring (m): as given, or the distance at the neutral configuration."""
    q0 = system.neutral()
    out = []
    for s in springs:
        xa, xb = anchor(system, s.a, q0), anchor(system, s.b, q0)
        L = float(np.linalg.norm(xb - xa))
        l0 = L if s.free_length is None else s.free_length
        if s.a[0] == s.b[0] and np.array_equal(np.asarray(s.a[1], float), np.asarray(s.b[1], float)):
            raise ModelError(f"spring '{s.name}': both ends are the same point of '{s.a[0]}' (coincident "
                             "ends: its direction is undefined)")
        if s.free_length is None and L <= 1e-12:  # the threshold below with l0 = L
            raise ModelError(f"spring '{s.name}': its two ends coincide at the neutral configuration (at "
                             f"{np.round(xa, 12).tolist()} m) and no free_length is given: attach the ends at "
                             "distinct points, or give free_length=0 for a zero-length spring (force −k·d)")
        # (ends that coincide at neutral with a free length given are no fault: neutral need not be a pose
        # any analysis visits; an evaluation where they coincide is refused by the group, naming the spring)
        out.append(l0)
    return out


def anchor(system, att, q, t=0.0):
    """World position (m) of an attachment (body point, world point or support point) at (q, t)."""
    body, point = att
    if body == WORLD:
        return np.array(point, dtype=float)
    if body in system.support_index:
        return np.array(point, dtype=float) + system.supports[system.support_index[body]].motion.position(t)
    return system.point_position(body, point, q)


@dataclass(frozen=True)
class Spring(ElementKind):
    """Linear spring between two points: force k (L − free_length) along the line (N, m).

    ``free_length`` None means the distance at the neutral configuration (unstressed there).
    """

    table = "spring"
    keys = {"name": value_string, "a": value_attachment, "b": value_attachment, "stiffness": value_nonnegative,
            "free_length": value_nonnegative}
    required = ("name", "a", "b", "stiffness")
    group = Springs
    linear_in = ("stiffness",)

    name: str
    a: tuple
    b: tuple
    stiffness: float
    free_length: float | None = None

    @classmethod
    def add(cls, scene, name, a, b, stiffness, free_length=None) -> Spring:
        what = f"spring '{name}'"
        scene.check_new_name(name, "element")
        a, b = scene.resolve_attachment(a, what + " end a"), scene.resolve_attachment(b, what + " end b")
        k = scalar(stiffness, f"{what} stiffness", nonnegative=True)
        l0 = None if free_length is None else bounded(scalar(free_length, f"{what} free_length", nonnegative=True),
                                                      MAX_LENGTH, f"{what} free_length", "m")
        return scene.add_element(cls(name, a, b, k, l0))

    @classmethod
    def from_file(cls, scene, e, error):
        return cls.add(scene, e["name"], file_attachment(e["a"]), file_attachment(e["b"]), e["stiffness"],
                       e.get("free_length"))

    def to_dict(self):
        d = {"name": self.name, "a": att_list(self.a), "b": att_list(self.b), "stiffness": self.stiffness}
        if self.free_length is not None:
            d["free_length"] = self.free_length
        return d

    def describe(self, scene=None):
        l0 = "neutral distance" if self.free_length is None else number(self.free_length, "m")
        return f"{end_label(self.a)} – {end_label(self.b)}, k = {number(self.stiffness, 'N/m')}, free length {l0}"

    def reference_points(self):
        return (self.a[1],)

    def reference_lengths(self):
        return () if self.free_length is None else (self.free_length,)
