"""The glottis between two folds' medial surfaces as a flow model sees it: the gap between the
folds sampled on stations along the flow (y) and samples across it (z), and the pressure a flow
model (:mod:`vfrs.flow.model`) computes there turned into consistent nodal forces on the folds."""

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
    flow: float | None = None  # the volume flow (m^3/s) if the model computes it (None: A_sep sqrt(2 drop / rho))
    wet: np.ndarray | None = None  # (stations, z samples): 1 where the pressure acts, 0 where the folds touch (None: everywhere)
    z: np.ndarray | None = None  # the z samples of ``wet``


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
    quadratic: Any = None  # of an order-2 mesh: its six-node faces' load on ``tri`` (vfrs.quadratic.FaceLoad)

    def pressure_forces(self, points, p_nodes) -> np.ndarray:
        """:func:`consistent_pressure_forces` on ``tri`` (bit for bit), in Rust, the triangles
        around each node listed once; on a quadratic mesh the forces consistent with its curved
        six-node faces (:class:`vfrs.quadratic.FaceLoad`, the pressure interpolated quadratically)."""
        if self.quadratic is not None:
            return self.quadratic.forces(points, pressure=p_nodes)
        if self._load is None or self._load[1] != len(points):
            self._load = (_core.fem.PressureLoad(np.ascontiguousarray(self.tri, dtype=np.int64), len(points)), len(points))
        out = np.empty((len(points), 3))
        self._load[0].forces(np.ascontiguousarray(points, dtype=np.float64),
                             np.ascontiguousarray(p_nodes, dtype=np.float64), out)
        return out


class GlottalSlices:
    """The glottis between a right fold (x > 0) and a left fold (x < 0), and the pressure a
    flow model (``law``, a :class:`vfrs.flow.model.FlowModel`) puts on them.

    ``right``, ``left``: meshes with a ``medial`` surface. Built-in M5 folds carry a
    ``medial_grid`` (medial nodes as an (s, z) grid) that makes slicing cheap; other meshes
    are sliced by linear interpolation over their medial nodes' (y, z) positions.
    ``n_stations`` stations in y span the overlap of both medial surfaces; ``n_z`` samples
    along z give the gap across the glottis (``x_right - x_left``, no symmetry assumed).
    ``subglottal_pressure``: the drive below the glottis.
    """

    def __init__(self, right, left, law, subglottal_pressure, n_stations=120, n_z=None):
        if not np.isfinite(subglottal_pressure) or subglottal_pressure < 0:
            raise VfrsError(f"subglottal_pressure = {subglottal_pressure} Pa must be finite and >= 0")
        self.law = law
        self.ps = float(subglottal_pressure)
        self.folds = []
        for mesh, sign in ((right, 1.0), (left, -1.0)):
            tri = mesh.surface("medial")
            nodes = np.unique(tri)
            grid = getattr(mesh, "medial_grid", None)
            self.folds.append(MedialSurface(tri, nodes, grid, sign))
            if mesh.order == 2:
                self.folds[-1].quadratic = mesh.quadratic_faces().load(tri)
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

    @property
    def separation_ratio(self) -> float:
        return self.law.separation_ratio

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

    def width(self, x_right, x_left) -> np.ndarray:
        """x_right - x_left on the (stations, z samples) grid for node positions (n, 3) of each
        fold: the gap across the glottis, negative where the folds overlap."""
        return self._medial_x(self.folds[0], x_right) - self._medial_x(self.folds[1], x_left)

    def state(self, x_right, x_left, tract=None, drive=None, t=None) -> FlowState:
        """The flow model's :class:`FlowState` for current node positions (n, 3) of each fold.

        ``tract``: called with the area at separation (m^2, 0 closed) and the model's
        :class:`vfrs.flow.model.GlottalLoss`, returns the pressures (p_sub, p_exit) below the
        glottis and in the jet at its exit of a coupled vocal tract (the [acoustics] effect),
        which replace Ps and 0; or None (the flow alone). ``drive``: the subglottal pressure
        now (default: ``subglottal_pressure``); ``t``: the time the pressure is for (a model
        with memory, the glottal inertance, needs it)."""
        return self.law.state(self.y, self.z, self.width(x_right, x_left), self.ps if drive is None else drive,
                              tract, t)

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

    def forces(self, x_right, x_left, tract=None, drive=None, t=None):
        """Consistent nodal forces (n, 3) on each fold, and the :class:`FlowState` (``tract``,
        ``drive``, ``t``: see :meth:`state`). A node's pressure is its station's (linear in y);
        a model that says where the folds touch (``FlowState.wet``) puts none there (the
        fraction of the node's (y, z) cell that is open, bilinear)."""
        st = self.state(x_right, x_left, tract, drive, t)
        out = []
        for fold, x in zip(self.folds, (x_right, x_left)):
            p_nodes = np.zeros(len(x))
            at = x[fold.nodes]
            p_nodes[fold.nodes] = np.interp(at[:, 1], st.y, st.pressure)
            if st.wet is not None:
                p_nodes[fold.nodes] *= bilinear(st.y, st.z, st.wet, at[:, 1], at[:, 2])
            out.append(fold.pressure_forces(x, p_nodes))
        return out[0], out[1], st


def bilinear(y, z, values, yq, zq) -> np.ndarray:
    """``values`` (len(y), len(z)) on the grid of increasing ``y`` and ``z``, interpolated
    bilinearly at the points (``yq``, ``zq``) (clamped to the grid's edges).

    >>> bilinear(np.array([0.0, 1.0]), np.array([0.0, 2.0]), np.array([[0.0, 2.0], [1.0, 3.0]]),
    ...          np.array([0.5, 9.0]), np.array([1.0, -1.0])).tolist()
    [1.5, 1.0]
    """
    def cell(grid, q):
        q = np.clip(q, grid[0], grid[-1])
        i = np.clip(np.searchsorted(grid, q, side="right") - 1, 0, len(grid) - 2)
        return i, (q - grid[i]) / (grid[i + 1] - grid[i])

    i, s = cell(y, np.asarray(yq, dtype=float))
    j, r = cell(z, np.asarray(zq, dtype=float))
    v = values
    return ((1 - s) * ((1 - r) * v[i, j] + r * v[i, j + 1]) + s * ((1 - r) * v[i + 1, j] + r * v[i + 1, j + 1]))
