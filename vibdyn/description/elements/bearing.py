"""Bearing: eight linear coefficients between a housing and a journal, in the world axes x, y normal to the spin
axis, constant or tabulated against the journal's spin speed.

The force on the journal (end ``journal``; the opposite on ``housing``) is

    f = −Eᵀ [K(Ω) E (d − d₀) + C(Ω) E (v_j − v_h)],

E the 2 × 3 rows of the two world axes normal to ``axis`` (z: x then y; x: y then z; y: z then x), d the
world separation journal − housing (m) and d₀ its value at the neutral configuration (the bearing is unloaded
there), v the ends' world velocities (m/s). K (N/m) and C (N·s/m) are 2 × 2, cross-coupled as given
([[k_xx, k_xy], [k_yx, k_yy]]: k_xy is the force along x per displacement along y, with the minus sign above).
Ω (rad/s) is the journal body's angular velocity about ``axis`` in the state (world axes): with ``speeds`` the
coefficients are tables interpolated linearly in Ω (``interpolation="pchip"``: monotone cubic), and a speed
outside the table by more than max(1e-6 × its span, 1e-3 rad/s) is refused, naming the bearing (within that band,
met by the difference steps of a linearisation at a table's end, the end segment is extended).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._check import BadValue, as_list, is_number, shown, value_attachment, value_string
from ..._format import number
from ...errors import ModelError
from ...model.groups import TwoPoint
from .base import WORLD, ElementKind, att_list, end_label, file_attachment

#: the world axes normal to each spin axis, (e1, e2) with e1 × e2 = axis
_PLANES = {(0.0, 0.0, 1.0): ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), (1.0, 0.0, 0.0): ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
           (0.0, 1.0, 0.0): ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0))}
INTERPOLATIONS = ("linear", "pchip")


class Bearings(TwoPoint):
    """Bearings between two points: force on the journal (end b) −Eᵀ[K(Ω) E (d − d₀) + C(Ω) E v_rel]."""

    noun = "bearing"
    uses_point_velocities = True
    needs_velocity_derivatives = True
    velocity_dependent = True

    def __init__(self, system, elements):
        super().__init__(system, elements)
        self.elements = elements
        self.E = np.array([_PLANES[e.axis] for e in elements])  # n × 2 × 3
        self.axis = np.array([e.axis for e in elements])
        q0 = system.neutral()
        self.d0 = np.array([_point(system, e.journal, q0) - _point(system, e.housing, q0) for e in elements])
        self.tables = [e.interpolator() for e in elements]
        self.constant = all(t is None for t in self.tables)
        # Eᵀ K E and Eᵀ C E (n × 3 × 3, world axes): the constant coefficients' force law in one product
        if self.constant:
            self.EKE = np.einsum("naj,nab,nbk->njk", self.E, np.array([e.stiffness for e in elements]), self.E)
            self.ECE = np.einsum("naj,nab,nbk->njk", self.E, np.array([e.damping for e in elements]), self.E)

    def coefficients(self, speeds):
        """(K, C, dK/dΩ, dC/dΩ) of every bearing at the journals' spin speeds Ω (rad/s), n × 2 × 2 each."""
        out = np.zeros((4, len(self.elements), 2, 2))
        for i, (e, table) in enumerate(zip(self.elements, self.tables)):
            if table is None:
                out[0, i], out[1, i] = e.stiffness, e.damping
                continue
            s = float(speeds[i])
            lo, hi = e.speeds[0], e.speeds[-1]
            if not e.covers(s, s):
                raise ModelError(f"bearing '{e.name}': the journal's spin speed {s:.6g} rad/s is outside its table "
                                 f"[{lo:g}, {hi:g}] rad/s: extend the table's speeds to cover the speeds asked")
            out[:, i] = table(s)
        return out

    def spin_speeds(self, kin):
        """Each journal body's angular velocity about its bearing's axis (rad/s), world axes."""
        w = np.einsum("nij,nj->ni", kin.R[self.jb], kin.w[self.jb])
        return np.einsum("ni,ni->n", w, self.axis)

    def apply(self, t, q, v, kin, Q, F):
        if self.constant:
            EKE, ECE = self.EKE, self.ECE
        else:
            K, C, _, _ = self.coefficients(self.spin_speeds(kin))
            EKE = np.einsum("naj,nab,nbk->njk", self.E, K, self.E)
            ECE = np.einsum("naj,nab,nbk->njk", self.E, C, self.E)
        d = self.separation(kin) - self.d0
        va, vb = self.end_velocities(kin)
        f = EKE @ d[:, :, None] + ECE @ (vb - va)[:, :, None]
        self.ends.add_forces(F, kin, -f[:, :, 0])

    def derivatives(self, d):
        kin = d.fkin
        Om = self.spin_speeds(kin)
        K, C, dK, dC = self.coefficients(Om)
        sep = self.separation(kin) - self.d0
        va, vb = self.end_velocities(kin)
        vrel = vb - va
        for i in range(len(self.elements)):
            ja, jb = int(self.ja[i]), int(self.jb[i])
            E = self.E[i]
            Jrel = d.point(jb, self.pb[i]) - d.point(ja, self.pa[i])
            dvrel = d.point_velocity_dq(jb, self.pb[i]) - d.point_velocity_dq(ja, self.pa[i])
            Fb = -E.T @ (K[i] @ E @ sep[i] + C[i] @ E @ vrel[i])
            dF_dq = -E.T @ (K[i] @ E @ Jrel + C[i] @ E @ dvrel)
            dF_dv = -E.T @ (C[i] @ E @ Jrel)
            if self.tables[i] is not None and jb != 0:  # the coefficients' change with the journal's speed
                R, J, w = d.R[jb], d.J[jb], d.u[jb][1]
                dOm_dv = self.axis[i] @ R @ J[3:]
                dOm_dq = self.axis[i] @ R @ (d.dV[jb][3:] - _skew(w) @ J[3:])
                g = -E.T @ (dK[i] @ E @ sep[i] + dC[i] @ E @ vrel[i])
                dF_dq = dF_dq + np.outer(g, dOm_dq)
                dF_dv = dF_dv + np.outer(g, dOm_dv)
            d.add_force(jb, self.pb[i], Fb, dF_dq, dF_dv)
            d.add_force(ja, self.pa[i], -Fb, -dF_dq, -dF_dv)


def _skew(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _point(system, att, q):
    body, point = att
    if body == WORLD or body in system.support_index:
        return np.array(point, dtype=float)
    return system.point_position(body, point, q)


def _matrices(value, n, what):
    """``value`` as finite floats of shape 2 × 2 (n None) or n × 2 × 2, else a ModelError naming ``what``."""
    shape = (2, 2) if n is None else (n, 2, 2)
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{what}: expected numbers of shape {shape}, got {shown(value)}") from None
    if a.shape != shape:
        expected = "a 2 × 2 matrix [[xx, xy], [yx, yy]]" if n is None else \
            f"a table of {n} 2 × 2 matrices (one per speed), shape {shape}"
        raise ModelError(f"{what}: expected {expected}, got shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        where = tuple(int(x) for x in np.argwhere(bad)[0])
        raise ModelError(f"{what}: coefficient {where} is {a[where]} (every coefficient must be a finite number)")
    return a


def value_table(x):
    """A scene file's matrix or table of matrices: nested lists of numbers (shapes checked by ``add``)."""
    def walk(v):
        items = as_list(v)
        if items is None:
            if not is_number(v):
                raise BadValue(f"expected nested lists of numbers, got {shown(x)}")
            return float(v)
        return [walk(u) for u in items]
    return walk(x)


def value_speeds(x):
    a = as_list(x)
    if a is None or not a or not all(is_number(v) for v in a):
        raise BadValue(f"expected a list of speeds (rad/s), got {shown(x)}")
    return [float(v) for v in a]


def value_axis(x):
    a = as_list(x)
    if a is None or len(a) != 3 or not all(is_number(v) for v in a):
        raise BadValue(f"expected 3 numbers [x, y, z], got {shown(x)}")
    return tuple(float(v) for v in a)


@dataclass(frozen=True)
class Bearing(ElementKind):
    """A bearing between ``housing`` and ``journal`` (ends as springs take them): stiffness (N/m) and damping
    (N·s/m) 2 × 2 in the world axes normal to ``axis``, or tables (n × 2 × 2) at ``speeds`` (rad/s)."""

    table = "bearing"
    keys = {"name": value_string, "housing": value_attachment, "journal": value_attachment, "stiffness": value_table,
            "damping": value_table, "speeds": value_speeds, "axis": value_axis, "interpolation": value_string}
    required = ("name", "housing", "journal", "stiffness")
    group = Bearings
    linear_in = ()

    name: str
    housing: tuple
    journal: tuple
    stiffness: np.ndarray
    damping: np.ndarray
    speeds: tuple | None = None
    axis: tuple = (0.0, 0.0, 1.0)
    interpolation: str = "linear"

    @classmethod
    def add(cls, scene, name, housing, journal, stiffness, damping=None, speeds=None, *, axis=(0.0, 0.0, 1.0),
            interpolation="linear") -> Bearing:
        what = f"bearing '{name}'"
        scene.check_new_name(name, "element")
        housing = scene.resolve_attachment(housing, what + " housing")
        journal = scene.resolve_attachment(journal, what + " journal")
        if journal[0] == WORLD or journal[0] == housing[0]:
            raise ModelError(f"{what}: the journal must be on a body other than the housing's (got journal "
                             f"'{journal[0]}', housing '{housing[0]}')")
        try:
            key = tuple(float(x) for x in np.asarray(axis, dtype=float).ravel())
        except (TypeError, ValueError):
            key = None
        if key is None or key not in _PLANES:
            raise ModelError(f"{what}: axis must be the world x, y or z axis ((1, 0, 0), (0, 1, 0) or (0, 0, 1)): "
                             f"its x and y are the world axes normal to it; got {axis!r}")
        if interpolation not in INTERPOLATIONS:
            raise ModelError(f"{what}: interpolation must be one of {', '.join(INTERPOLATIONS)}, got "
                             f"{interpolation!r}")
        n = None
        if speeds is not None:
            s = _speeds(speeds, what)
            n = len(s)
            speeds = tuple(float(x) for x in s)
        K = _matrices(stiffness, n, what + " stiffness")
        C = np.zeros_like(K) if damping is None else _matrices(damping, n, what + " damping")
        K.flags.writeable = C.flags.writeable = False
        return scene.add_element(cls(name, housing, journal, K, C, speeds, key, interpolation))

    def covers(self, lowest: float, highest: float) -> bool:
        """Whether the table (if any) covers the spin speeds from ``lowest`` to ``highest`` (rad/s), give or take
        max(1e-6 × its span, 1e-3 rad/s): the difference steps of a linearisation at a table's end, where the end
        segment is extended."""
        if self.speeds is None:
            return True
        band = max(1e-6 * (self.speeds[-1] - self.speeds[0]), 1e-3)
        return self.speeds[0] - band <= lowest and highest <= self.speeds[-1] + band

    def interpolator(self):
        """None (constant coefficients), or Ω ↦ (K, C, dK/dΩ, dC/dΩ) (each 2 × 2) from the tables."""
        if self.speeds is None:
            return None
        s = np.array(self.speeds)
        Y = np.stack([self.stiffness, self.damping]).transpose(1, 0, 2, 3).reshape(len(s), 8)
        if self.interpolation == "pchip":
            from scipy.interpolate import PchipInterpolator

            f = PchipInterpolator(s, Y, axis=0)
            df = f.derivative()
            return lambda x: np.concatenate([f(x), df(x)]).reshape(4, 2, 2)

        def linear(x):
            k = int(np.clip(np.searchsorted(s, x, side="right") - 1, 0, len(s) - 2))
            slope = (Y[k + 1] - Y[k]) / (s[k + 1] - s[k])
            return np.concatenate([Y[k] + (x - s[k]) * slope, slope]).reshape(4, 2, 2)
        return linear

    @classmethod
    def from_file(cls, scene, e, error):
        return cls.add(scene, e["name"], file_attachment(e["housing"]), file_attachment(e["journal"]),
                       e["stiffness"], e.get("damping"), e.get("speeds"), axis=e.get("axis", (0.0, 0.0, 1.0)),
                       interpolation=e.get("interpolation", "linear"))

    def to_dict(self):
        d = {"name": self.name, "housing": att_list(self.housing), "journal": att_list(self.journal),
             "stiffness": self.stiffness.tolist()}
        if np.any(self.damping):
            d["damping"] = self.damping.tolist()
        if self.speeds is not None:
            d["speeds"] = list(self.speeds)
        if self.axis != (0.0, 0.0, 1.0):
            d["axis"] = list(self.axis)
        if self.interpolation != "linear":
            d["interpolation"] = self.interpolation
        return d

    def describe(self, scene=None):
        ends = f"{end_label(self.housing)} – {end_label(self.journal)}"
        if self.speeds is None:
            k = np.array2string(self.stiffness, precision=4, separator=", ").replace("\n", "")
            return f"{ends}, K = {k} N/m" + ("" if not np.any(self.damping) else
                                              f", C = {np.array2string(self.damping, precision=4, separator=', ')}"
                                              " N·s/m").replace("\n", "")
        return (f"{ends}, K and C tabulated at {len(self.speeds)} speeds {number(self.speeds[0], 'rad/s')} … "
                f"{number(self.speeds[-1], 'rad/s')} ({self.interpolation})")

    @property
    def a(self):
        """The housing end (the two-point groups' end a)."""
        return self.housing

    @property
    def b(self):
        """The journal end (end b)."""
        return self.journal

    def reference_points(self):
        return (self.journal[1],)

    def __eq__(self, other):
        return type(other) is type(self) and self.to_dict() == other.to_dict()

    def __hash__(self):
        return hash(self.name)


def _speeds(speeds, what):
    try:
        s = np.array(speeds, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ModelError(f"{what} speeds: expected increasing numbers (rad/s), got {shown(speeds)}") from None
    if s.size < 2 or not np.all(np.isfinite(s)):
        raise ModelError(f"{what} speeds: expected at least two finite speeds (rad/s), got {shown(speeds)}")
    if np.any(np.diff(s) <= 0):
        k = int(np.flatnonzero(np.diff(s) <= 0)[0])
        raise ModelError(f"{what} speeds must be increasing: {s[k]:g} then {s[k + 1]:g} rad/s")
    return s
