"""The quasi-steady Bernoulli pressure between two folds' medial surfaces (the model:
:mod:`vfrs.flow`): the glottal area along the flow, the pressure, its consistent nodal forces."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _core
from ..errors import VfrsError


@dataclass
class FlowState:
    """What the flow model computed for one configuration."""

    y: np.ndarray  # stations (m)
    area: np.ndarray  # glottal area A(y) (m^2)
    pressure: np.ndarray  # p(y) (Pa)
    min_area: float
    y_separation: float
    closed: bool
    min_gap: float  # smallest x_right - x_left over the (y, z) samples; < 0: the folds overlap
    drop: float | None = None  # p_sub - p_sup from a coupled vocal tract (Pa); None: the flow alone


def bernoulli_pressure(y, area, subglottal_pressure, separation_ratio=1.0, closed_area=0.0):
    """Pressure at the stations ``y`` (increasing) for glottal areas ``area``.

    >>> import numpy as np
    >>> y = np.linspace(0, 1, 5); A = np.array([4.0, 3.0, 2.0, 1.0, 2.0])
    >>> bernoulli_pressure(y, A, 800.0)[0].round(1).tolist()
    [750.0, 711.1, 600.0, 0.0, 0.0]
    """
    y = np.asarray(y, dtype=float)
    area = np.asarray(area, dtype=float)
    p = np.zeros_like(area)
    shut = np.flatnonzero(area <= closed_area)
    if shut.size:
        below = y < y[shut[0]]
        p[below] = subglottal_pressure
        return p, y[shut[0]], True
    i_min = int(np.argmin(area))
    a_min = area[i_min]
    i_sep = i_min
    if separation_ratio > 1.0:
        after = np.flatnonzero(area[i_min:] >= separation_ratio * a_min)
        i_sep = i_min + int(after[0]) if after.size else len(area) - 1
    a_sep = area[i_sep]
    up = np.arange(len(area)) <= i_sep
    p[up] = subglottal_pressure * (1.0 - (a_sep / area[up]) ** 2)
    return p, y[i_sep], False


def _linear_weights(z, zc):
    """Matrix L (len(z) x len(zc)) with L @ f(zc) = np.interp(z, zc, f(zc))."""
    order = np.argsort(zc)
    L = np.zeros((len(z), len(zc)))
    for j in range(len(zc)):
        e = np.zeros(len(zc))
        e[order[j]] = 1.0
        L[:, order[j]] = np.interp(z, zc[order], e[order])
    return L


def _two_point(L) -> tuple:
    """The entries of an interpolation matrix ``L`` with at most two per row, as (first
    column, its weight, second column, its weight) per row (a row with one entry: the same
    column twice, the second weight 0)."""
    L = np.asarray(L, dtype=float)
    if len(L) and np.count_nonzero(L, axis=1).max() > 2:
        raise ValueError("interpolation weights with more than two entries in a row")
    rows = np.arange(len(L))
    j0 = np.argmax(L != 0, axis=1)
    rest = L.copy()
    rest[rows, j0] = 0.0
    j1 = np.where(rest.any(axis=1), np.argmax(rest != 0, axis=1), j0)
    return j0, L[rows, j0], j1, rest[rows, j1]


def _apply_weights(xs, two_point) -> np.ndarray:
    """``xs @ L.T`` for ``two_point = _two_point(L)``, as elementwise numpy operations over
    L's entries in column order: the same bits on every CPU (a BLAS product picks its kernel,
    and with it fused multiply-adds, by CPU)."""
    j0, w0, j1, w1 = two_point
    out = xs[:, j0] * w0
    out += xs[:, j1] * w1
    return out


def consistent_pressure_forces(points, triangles, p_nodes):
    """Nodal forces (n, 3) of the traction -p n on triangles (outward normals), with p
    linear over each triangle given by its vertex values: f_a = -(2 p_a + p_b + p_c) N / 24,
    N = (x2 - x1) x (x3 - x1) = 2 area n."""
    x = points[triangles]
    N = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    pt = p_nodes[triangles]
    s = pt.sum(axis=1)
    n = len(points)
    f = np.zeros((n, 3))
    for a in range(3):
        w = -(pt[:, a] + s) / 24.0
        for c in range(3):  # bincount sums duplicates like np.add.at, several times faster
            f[:, c] += np.bincount(triangles[:, a], weights=w * N[:, c], minlength=n)
    return f


@dataclass
class MedialSurface:
    """One fold's wetted surface as the flow model slices it: ``tri`` (triangles), ``nodes``,
    ``grid`` (the medial nodes as an (s, z) grid, or None), ``sign`` (+1 right, -1 left) and
    ``z_weights`` (linear interpolation from the grid's columns to the z samples)."""

    tri: np.ndarray
    nodes: np.ndarray
    grid: np.ndarray | None
    sign: float
    z_weights: np.ndarray | None = None
    z_columns: tuple | None = None  # z_weights' entries (vfrs.flow._two_point)
    _load: Any = field(default=None, repr=False, compare=False)  # Rust pressure load of ``tri`` (made on first use)

    def pressure_forces(self, points, p_nodes) -> np.ndarray:
        """:func:`consistent_pressure_forces` on ``tri`` (bit for bit), in Rust, the triangles
        around each node listed once."""
        if self._load is None or self._load[1] != len(points):
            self._load = (_core.fem.PressureLoad(np.ascontiguousarray(self.tri, dtype=np.int64), len(points)), len(points))
        out = np.empty((len(points), 3))
        self._load[0].forces(np.ascontiguousarray(points, dtype=np.float64),
                             np.ascontiguousarray(p_nodes, dtype=np.float64), out)
        return out


class BernoulliFlow:
    """Bernoulli glottal flow between a right fold (x > 0) and a left fold (x < 0).

    ``right``, ``left``: meshes with a ``medial`` surface. Built-in M5 folds carry a
    ``medial_grid`` (medial nodes as an (s, z) grid) that makes slicing cheap; other meshes
    are sliced by linear interpolation over their medial nodes' (y, z) positions.
    ``n_stations`` stations in y span the overlap of both medial surfaces; ``n_z`` samples
    along z integrate the gap.
    """

    def __init__(self, right, left, subglottal_pressure, separation_ratio=1.0, n_stations=120, n_z=None):
        if not np.isfinite(subglottal_pressure) or subglottal_pressure < 0:
            raise VfrsError(f"subglottal_pressure = {subglottal_pressure} Pa must be finite and >= 0")
        if separation_ratio < 1.0:
            raise VfrsError(f"separation_ratio = {separation_ratio} must be >= 1 (1: separation at the minimum area)")
        self.ps = float(subglottal_pressure)
        self.separation_ratio = float(separation_ratio)
        self.folds = []
        for mesh, sign in ((right, 1.0), (left, -1.0)):
            tri = mesh.surface("medial")
            nodes = np.unique(tri)
            grid = getattr(mesh, "medial_grid", None)
            self.folds.append(MedialSurface(tri, nodes, grid, sign))
        ys = [right.points[np.unique(right.surface("medial")), 1], left.points[np.unique(left.surface("medial")), 1]]
        zs = [right.points[np.unique(right.surface("medial")), 2], left.points[np.unique(left.surface("medial")), 2]]
        y_lo, y_hi = max(y.min() for y in ys), min(y.max() for y in ys)
        z_lo, z_hi = max(z.min() for z in zs), min(z.max() for z in zs)
        if not (y_hi > y_lo and z_hi > z_lo):
            raise VfrsError("the two medial surfaces do not face each other (no common y-z range)")
        self.y = np.linspace(y_lo, y_hi, int(n_stations))
        if n_z is None:
            grid = self.folds[0].grid
            n_z = grid.shape[1] if grid is not None else 16
        self.z = np.linspace(z_lo, z_hi, int(n_z))
        for fold, mesh in zip(self.folds, (right, left)):
            if fold.grid is not None:
                zc = mesh.points[fold.grid, 2].mean(axis=0)
                fold.z_weights = _linear_weights(self.z, zc)
                fold.z_columns = _two_point(fold.z_weights)

    def _medial_x(self, fold, x):
        """x of the fold's medial surface on the (y stations, z samples) grid."""
        grid = fold.grid
        if grid is not None:
            cols = x[grid]  # (ns + 1, nz + 1, 3): y increases along s
            xs = np.empty((len(self.y), cols.shape[1]))
            for k in range(cols.shape[1]):
                xs[:, k] = np.interp(self.y, cols[:, k, 1], cols[:, k, 0])
            # Along z, linear interpolation between the grid's columns at their rest
            # positions (the flow is one-dimensional in y; z motion is second order).
            return _apply_weights(xs, fold.z_columns)
        from scipy.interpolate import LinearNDInterpolator

        p = x[fold.nodes]
        f = LinearNDInterpolator(p[:, 1:3], p[:, 0])
        Y, Z = np.meshgrid(self.y, self.z, indexing="ij")
        v = f(Y, Z)
        # Outside the hull (rare, at the corners): nearest row value.
        if np.isnan(v).any():
            v = np.where(np.isnan(v), np.nanmean(v, axis=1, keepdims=True), v)
        return v

    def state(self, x_right, x_left, tract=None) -> FlowState:
        """Area and pressure along y for current node positions (n, 3) of each fold.

        ``tract``: called with the area at separation (m^2, 0 closed), returns the pressures
        (p_sub, p_sup) below and above the glottis of a coupled vocal tract (the [acoustics]
        effect), which replace Ps and 0: p = p_sup + (p_sub - p_sup) (1 - (A_sep / A)^2)
        upstream of separation, p_sup above; or None (the flow alone)."""
        xr = self._medial_x(self.folds[0], x_right)
        xl = self._medial_x(self.folds[1], x_left)
        width = xr - xl
        gap = np.maximum(width, 0.0)
        trapezoid = getattr(np, "trapezoid", None) or getattr(np, "trapz")  # numpy 2 renamed it
        area = trapezoid(gap, self.z, axis=1)
        p, y_sep, closed = bernoulli_pressure(self.y, area, self.ps, self.separation_ratio)
        drop = None
        if tract is not None:
            pressures = tract(0.0 if closed else float(np.interp(y_sep, self.y, area)))
            if pressures is not None:
                p_sub, p_sup = pressures
                drop = p_sub - p_sup
                p = p_sup + bernoulli_pressure(self.y, area, drop, self.separation_ratio)[0]
        return FlowState(self.y, area, p, float(area.min()), float(y_sep), closed, float(width.min()), drop)

    def compacted(self) -> tuple:
        """(a copy of this model that takes the positions of the wetted nodes only, and per
        fold the indices of those nodes among the fold's). The copy's :meth:`forces` gives the
        forces at those nodes (the others get none): the same numbers as this model's at
        them, without the work over the folds' other nodes."""
        import copy

        out = copy.copy(self)
        out.folds, kept = [], []
        for fold in self.folds:
            nodes = fold.nodes if fold.grid is None else np.union1d(fold.nodes, fold.grid.ravel())
            where = np.searchsorted(nodes, fold.nodes)
            out.folds.append(MedialSurface(np.searchsorted(nodes, fold.tri), where,
                                           None if fold.grid is None else np.searchsorted(nodes, fold.grid),
                                           fold.sign, fold.z_weights, fold.z_columns))
            kept.append(nodes)
        return out, kept

    def forces(self, x_right, x_left, tract=None):
        """Consistent nodal forces (n, 3) on each fold, and the :class:`FlowState` (``tract``:
        see :meth:`state`)."""
        st = self.state(x_right, x_left, tract)
        out = []
        for fold, x in zip(self.folds, (x_right, x_left)):
            p_nodes = np.zeros(len(x))
            p_nodes[fold.nodes] = np.interp(x[fold.nodes, 1], st.y, st.pressure)
            out.append(fold.pressure_forces(x, p_nodes))
        return out[0], out[1], st
