"""Measures of a P1 pressure field on a triangulated surface that have a limit (issue 45, item 2):
a pressure sensor integrated over its exact disc, and the area where the pressure is positive.

The field is nodal and linear on each triangle (the P1 interpolant of a contact pressure).

:func:`disc_pressure` reads a sensor: a flat disc of ``radius`` centred at ``centre``, facing
along ``normal``. The surface is taken inside the cylinder of that radius about the normal
(each triangle projected on the disc's plane and clipped with the circle, its straight edges
and the circle's arcs, exactly); the linear field is integrated over each clipped piece
exactly (its area and first moments, by Green's theorem, in closed form), and the result
divided by the surface area inside: the mean pressure over the sensor's face. The disc's
edge is not approximated by whole triangles, so a field the mesh represents exactly (linear)
reads exactly on any mesh, and any other converges with the P1 interpolation (second order
where the field is smooth). ``nodes`` counts the surface nodes inside the disc; a reading
from fewer than :data:`MIN_NODES` is resolved by few elements (``warning``).

:func:`pressure_area` integrates the field where it is positive: each triangle is cut at the
zero line of its linear field (exactly), giving the contact area (no one-element rim of
triangles with one loaded vertex), the force ``F`` (the integral of p over it), the mean
pressure ``F / area``, the force-weighted pressure ``p_F`` (the integral of p^2 over F) and
the effective area ``F / p_F = F^2 / (integral of p^2)``: the area a uniform pressure of the
same force and the same p_F would cover. It equals the area for a uniform pressure, is 8/9
of it under a Hertzian one, and, unlike the area, changes little when a rim of tiny pressures
appears or goes (a smooth functional of the field).

>>> import numpy as np
>>> pts = np.array([[-1.0, -1, 0], [0, -1, 0], [1, -1, 0], [-1, 1, 0], [0, 1, 0], [1, 1, 0]])
>>> tri = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]])
>>> r = disc_pressure(pts, tri, 2.0 + pts[:, 0], centre=[0.2, 0.0, 0.0], radius=0.5, normal=[0, 0, 1])
>>> round(r.mean_pressure, 12), round(r.area / np.pi, 12), r.nodes, r.warning is not None
(2.2, 0.25, 0, True)
>>> a = pressure_area(pts, tri, 0.5 - np.abs(pts[:, 0]))   # zero at |x| = 0.5
>>> round(a.area, 12), round(a.force, 12), round(a.effective_area, 12)
(2.0, 0.5, 1.5)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ContactError
from .geometry import node_normals

__all__ = ["MIN_NODES", "SensorReading", "PressureArea", "disc_pressure", "disc_weights", "pressure_area",
           "disc_moments", "SurfaceSensors", "surface_sensors"]

#: A sensor whose disc holds fewer surface nodes than this is resolved by few elements.
MIN_NODES = 10


@dataclass(frozen=True)
class SensorReading:
    """A sensor's reading (:func:`disc_pressure`): ``mean_pressure`` (Pa) = ``force`` (N, the
    integral of the pressure over the surface inside the disc) / ``area`` (m^2, that surface's
    area); ``nodes``: the surface nodes inside the disc."""

    mean_pressure: float
    force: float
    area: float
    nodes: int

    @property
    def warning(self) -> str | None:
        """A sentence when the disc holds fewer than :data:`MIN_NODES` nodes, else None."""
        if self.nodes >= MIN_NODES:
            return None
        return (f"the sensor's disc holds {self.nodes} surface node(s) (fewer than {MIN_NODES}): its reading is "
                "resolved by few elements")


@dataclass(frozen=True)
class PressureArea:
    """Where a P1 pressure field is positive (:func:`pressure_area`)."""

    area: float  #: m^2, where the interpolated pressure is > 0
    force: float  #: N, the integral of the positive pressure
    square: float  #: the integral of the positive pressure squared (Pa^2 m^2)

    @property
    def mean_pressure(self) -> float:
        """force / area (Pa; nan without contact)."""
        return self.force / self.area if self.area > 0 else math.nan

    @property
    def weighted_pressure(self) -> float:
        """The force-weighted mean pressure, integral of p^2 / force (Pa; nan without contact)."""
        return self.square / self.force if self.force > 0 else math.nan

    @property
    def effective_area(self) -> float:
        """force / weighted_pressure = force^2 / integral of p^2 (m^2; 0 without contact)."""
        return self.force**2 / self.square if self.square > 0 else 0.0


def disc_moments(q, radius: float) -> tuple[float, float, float]:
    """The area and first moments (integrals of 1, u, v) of the triangle ``q`` ((3, 2), any
    orientation) intersected with the disc ``u^2 + v^2 <= radius^2``: by Green's theorem over
    its boundary, the triangle's edges inside the disc and the circle's arcs between them.
    Plain floats (a few microseconds a triangle)."""
    q = [(float(u), float(v)) for u, v in q]
    if (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[1][1] - q[0][1]) * (q[2][0] - q[0][0]) < 0:
        q = q[::-1]  # counter-clockwise
    R = float(radius)
    pieces = []  # (start, end, the end leaves the disc)
    for k in range(3):
        (x0, y0), (x1, y1) = q[k], q[(k + 1) % 3]
        dx, dy = x1 - x0, y1 - y0
        a, b, c = dx * dx + dy * dy, 2 * (x0 * dx + y0 * dy), x0 * x0 + y0 * y0 - R * R
        disc = b * b - 4 * a * c
        if a == 0 or disc <= 0:
            continue
        s = math.sqrt(disc)
        t0, t1 = max((-b - s) / (2 * a), 0.0), min((-b + s) / (2 * a), 1.0)
        if t0 < t1:
            pieces.append(((x0 + t0 * dx, y0 + t0 * dy), (x0 + t1 * dx, y0 + t1 * dy), t1 < 1.0))
    if not pieces:  # no edge inside: the disc is inside the triangle, or they do not meet
        inside = all((q[(k + 1) % 3][0] - q[k][0]) * (-q[k][1]) - (q[(k + 1) % 3][1] - q[k][1]) * (-q[k][0]) >= 0
                     for k in range(3))
        return (math.pi * R * R, 0.0, 0.0) if inside else (0.0, 0.0, 0.0)
    area = mu = mv = 0.0
    for i, ((ax, ay), (bx, by), leaves) in enumerate(pieces):
        area += 0.5 * (ax * by - bx * ay)
        mu += (by - ay) * (ax * ax + ax * bx + bx * bx) / 6
        mv -= (bx - ax) * (ay * ay + ay * by + by * by) / 6
        ex, ey = pieces[(i + 1) % len(pieces)][0]
        if leaves and math.hypot(ex - bx, ey - by) > 1e-12 * R:  # along the circle to where it comes back
            t0 = math.atan2(by, bx)
            t1 = t0 + (math.atan2(ey, ex) - t0) % (2 * math.pi)
            s0, s1, c0, c1 = math.sin(t0), math.sin(t1), math.cos(t0), math.cos(t1)
            area += 0.5 * R * R * (t1 - t0)
            mu += 0.5 * R**3 * ((s1 - s1**3 / 3) - (s0 - s0**3 / 3))
            mv += 0.5 * R**3 * ((-c1 + c1**3 / 3) - (-c0 + c0**3 / 3))
    return area, mu, mv


def _frame(normal):
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(n, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1), n


def _disc(X, T, tri_n, centre, R, normal, depth):
    """The disc's integration weights: ``(nodes, w, area, inside)`` with the integral of a P1
    field p over the surface inside the disc ``w @ p[nodes]``, that surface's ``area`` and the
    count of its nodes ``inside`` the disc (see :func:`disc_pressure`)."""
    if normal is None:
        normal = tri_n[np.argmin(np.linalg.norm(X[T].mean(axis=1) - centre, axis=1))]
    e1, e2, n = _frame(normal)
    rel = X - centre
    uv, h = np.column_stack([rel @ e1, rel @ e2]), rel @ n
    norms = np.linalg.norm(tri_n, axis=1)
    facing = tri_n @ n > 1e-9 * norms
    near = np.abs(h[T]).min(axis=1) <= depth
    lo, hi = uv[T].min(axis=1), uv[T].max(axis=1)
    touches = (lo < R).all(axis=1) & (hi > -R).all(axis=1)
    nodes, weights, area = [], [], 0.0
    for t in np.flatnonzero(facing & near & touches):
        q = uv[T[t]]
        a, mu, mv = disc_moments(q, R)
        if a <= 0:
            continue
        stretch = norms[t] / (tri_n[t] @ n)  # true area / projected area
        # p = c0 + c1 u + c2 v = [1 u v] M^-1 p_t over the piece: its integral (a, mu, mv) M^-1 p_t.
        w = np.linalg.solve(np.column_stack([np.ones(3), q]).T, np.array([a, mu, mv]))
        nodes.append(T[t])
        weights.append(stretch * w)
        area += stretch * a
    on = np.unique(T[facing & near])
    inside = int(np.count_nonzero((uv[on] ** 2).sum(axis=1) <= R * R))
    if not nodes:
        return np.zeros(0, dtype=np.int64), np.zeros(0), 0.0, inside
    return np.concatenate(nodes), np.concatenate(weights), float(area), inside


def _checked(points, triangles, radius, depth, who):
    X = np.asarray(points, dtype=float)
    T = np.asarray(triangles, dtype=np.int64)
    R = float(radius)
    if not (R > 0 and math.isfinite(R)):
        raise ContactError(f"{who}: radius must be > 0 (got {radius})")
    tri_n = np.cross(X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]])  # 2 x area x unit normal
    return X, T, R, tri_n, R if depth is None else float(depth)


def disc_pressure(points, triangles, pressure, centre, radius: float, normal=None, depth: float | None = None
                  ) -> SensorReading:
    """The mean of the P1 field ``pressure`` (per point) over the sensor disc of ``radius``
    centred at ``centre`` and facing along ``normal`` (unset: the normal of the triangle
    nearest the centre), on the surface ``triangles`` ((k, 3) indices into ``points``): the
    surface inside the cylinder of the disc, within ``depth`` (unset: ``radius``) of the
    disc's plane and facing the same way (a single sheet there: the triangles are projected
    on the plane), exactly (see the module). Raises :class:`~vfrs.errors.ContactError` when
    no surface lies under the disc."""
    X, T, R, tri_n, depth = _checked(points, triangles, radius, depth, "disc_pressure")
    p = np.asarray(pressure, dtype=float)
    if p.shape != (len(X),):
        raise ContactError(f"disc_pressure: pressure must have one value per point, got shape {p.shape}")
    c = np.asarray(centre, dtype=float)
    nodes, w, area, inside = _disc(X, T, tri_n, c, R, normal, depth)
    if area <= 0:
        raise ContactError(f"disc_pressure: no surface under the disc at {c.tolist()} (radius {R:g})")
    force = float(w @ p[nodes])
    return SensorReading(force / area, force, area, inside)


def disc_weights(points, triangles, centres, radius: float, normals=None, depth: float | None = None):
    """The sensors of :func:`disc_pressure` centred at each of ``centres`` ((m, 3); ``normals``
    (m, 3) or unset) as one sparse matrix ``S`` (m x n points): ``S @ p`` are their mean
    pressures for any P1 field p (a row of zeros for a disc over no surface), and the count
    of surface nodes inside each disc. Built once for a surface, it reads every step's
    pressure with one product."""
    import scipy.sparse as sp

    from scipy.spatial import cKDTree

    X, T, R, tri_n, depth = _checked(points, triangles, radius, depth, "disc_weights")
    C = np.atleast_2d(np.asarray(centres, dtype=float))
    mid = X[T].mean(axis=1)
    reach = math.hypot(R, depth) + float(np.linalg.norm(X[T] - mid[:, None], axis=2).max(initial=0.0))
    near = cKDTree(mid).query_ball_point(C, reach)  # the triangles that can meet each disc
    rows, cols, vals, inside = [], [], [], np.zeros(len(C), dtype=np.int64)
    for k, c in enumerate(C):
        cand = np.asarray(near[k], dtype=np.int64)
        if not cand.size:
            continue
        normal = None if normals is None else normals[k]
        # Only the candidates' own nodes (numbered locally): the same numbers per node, and
        # the disc's work no longer grows with the whole mesh.
        local, T_local = np.unique(T[cand], return_inverse=True)
        nodes, w, area, inside[k] = _disc(X[local], T_local.reshape(-1, 3), tri_n[cand], c, R, normal, depth)
        if area > 0:
            rows.append(np.full(len(nodes), k))
            cols.append(local[nodes])
            vals.append(w / area)
    if not rows:
        return sp.csr_matrix((len(C), len(X))), inside
    S = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(len(C), len(X)))
    return S, inside


def pressure_area(points, triangles, pressure) -> PressureArea:
    """The area of the surface ``triangles`` where the P1 field ``pressure`` (per point) is
    positive, and the integrals of p and p^2 over it: each triangle cut at the zero line of its
    linear field (exact for the interpolant)."""
    X = np.asarray(points, dtype=float)
    T = np.asarray(triangles, dtype=np.int64)
    p = np.asarray(pressure, dtype=float)[T]  # (k, 3)
    A = 0.5 * np.linalg.norm(np.cross(X[T[:, 1]] - X[T[:, 0]], X[T[:, 2]] - X[T[:, 0]]), axis=1)
    p = -np.sort(-p, axis=1)  # descending: p[:, 0] >= p[:, 1] >= p[:, 2]
    positive = (p > 0).sum(axis=1)
    whole_1 = A * p.sum(axis=1) / 3
    whole_2 = A * ((p**2).sum(axis=1) + p[:, 0] * p[:, 1] + p[:, 1] * p[:, 2] + p[:, 0] * p[:, 2]) / 6
    area, f1, f2 = np.zeros(len(T)), np.zeros(len(T)), np.zeros(len(T))
    full = positive == 3
    area[full], f1[full], f2[full] = A[full], whole_1[full], whole_2[full]
    one = positive == 1  # the corner at the positive vertex: (p0, 0, 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = p[:, 0] ** 2 / ((p[:, 0] - p[:, 1]) * (p[:, 0] - p[:, 2]))
        area[one] = A[one] * frac[one]
        f1[one] = area[one] * p[one, 0] / 3
        f2[one] = area[one] * p[one, 0] ** 2 / 6
        two = positive == 2  # all but the corner at the negative vertex: (p2, 0, 0)
        neg = A * p[:, 2] ** 2 / ((p[:, 2] - p[:, 0]) * (p[:, 2] - p[:, 1]))
        area[two] = A[two] - neg[two]
        f1[two] = whole_1[two] - neg[two] * p[two, 2] / 3
        f2[two] = whole_2[two] - neg[two] * p[two, 2] ** 2 / 6
    return PressureArea(float(area.sum()), float(f1.sum()), float(f2.sum()))


@dataclass(frozen=True)
class SurfaceSensors:
    """Sensors of one face area centred at every node of some surfaces (:func:`surface_sensors`):
    ``S @ p`` (one row per sensor) are their readings of a P1 field ``p`` (per point), ``nodes``
    the global node each is centred at, ``inside`` how many surface nodes each disc holds,
    ``surface`` the surface (its name) each lies on."""

    S: object  # scipy.sparse.csr_matrix (m x n points)
    nodes: np.ndarray
    inside: np.ndarray
    surface: tuple

    def sparse(self) -> dict:
        """Per surface, the median count of surface nodes in a disc, where it is below
        :data:`MIN_NODES` (a reading resolved by few elements): ``{name: median}``."""
        out = {}
        for name in dict.fromkeys(self.surface):
            mine = np.array([s == name for s in self.surface])
            median = float(np.median(self.inside[mine])) if mine.any() else 0.0
            if median < MIN_NODES:
                out[name] = median
        return out


def surface_sensors(points, surfaces: dict, area: float) -> SurfaceSensors:
    """A flush-mounted pressure sensor of face ``area`` (m^2: a disc of radius sqrt(area / pi))
    centred at every node of each surface of ``surfaces`` (name -> (k, 3) triangles, global node
    numbers into ``points``, reference positions), facing along the surface's normal at the
    node (:func:`vfrs.contact.geometry.node_normals`: the area-weighted mean of the node's
    triangles' normals), each reading its own surface only
    (:func:`disc_weights`). Built once per run; a step's readings are one sparse product."""
    import scipy.sparse as sp

    X = np.asarray(points, dtype=float)
    R = math.sqrt(float(area) / math.pi)
    blocks, nodes_all, inside_all, names = [], [], [], []
    for name, tri in surfaces.items():
        T = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
        if not len(T):
            continue
        nodes = np.unique(T)
        normals = node_normals(X, T, len(X), nodes=nodes)
        S, inside = disc_weights(X, T, X[nodes], R, normals=normals)
        blocks.append(S)
        nodes_all.append(nodes)
        inside_all.append(inside)
        names += [name] * len(nodes)
    if not blocks:
        return SurfaceSensors(sp.csr_matrix((0, len(X))), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), ())
    return SurfaceSensors(sp.vstack(blocks, format="csr"), np.concatenate(nodes_all), np.concatenate(inside_all),
                          tuple(names))
