"""Projection, the contact-pair record, the constraint matrix, areas."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import scipy.sparse as sp

from .. import _core

FEATURES = ("face", "edge", "vertex")


def as_points(a, name="points") -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3), got {a.shape}")
    return a


def as_indices(a, name, ndim) -> np.ndarray:
    a = np.asarray(a)
    if a.size == 0:
        a = a.astype(np.int64)
    if not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name} must hold integer node indices, got dtype {a.dtype}")
    a = np.ascontiguousarray(a, dtype=np.int64)
    if ndim == 2:
        a = a.reshape(-1, 3)
    elif a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
    return a


@dataclass(frozen=True)
class Projection:
    """Pairwise projection of points onto triangles (see :func:`project`)."""

    closest: np.ndarray
    xi: np.ndarray
    zeta: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    feature: np.ndarray


def project(points, triangles) -> Projection:
    """Projects ``points[k]`` onto the triangle ``triangles[k]`` (closest point, with parry).

    Parameters
    ----------
    points : (k, 3) array
        Slave node positions.
    triangles : (k, 3, 3) array
        Master triangle vertex coordinates ``x1, x2, x3``.

    Returns
    -------
    Projection
        ``closest`` (k, 3) = N1 x1 + N2 x2 + N3 x3 with N1 = 1 - xi - zeta, N2 = xi,
        N3 = zeta; ``normal`` (k, 3) = (x2 - x1) x (x3 - x1) normalised; ``gap`` (k) the
        distance to the closest point, negative on the side of the triangle's plane opposite
        the normal; ``feature`` (k) 0 face, 1 edge, 2 vertex.

    Raises
    ------
    vfrs.ContactError
        A degenerate triangle (zero area) or a non-finite coordinate, naming the pair.
    """
    p = as_points(points)
    t = np.ascontiguousarray(triangles, dtype=np.float64)
    if t.ndim != 3 or t.shape[1:] != (3, 3) or len(t) != len(p):
        raise ValueError(f"triangles must have shape ({len(p)}, 3, 3), got {t.shape}")
    return Projection(*_core.contact.project(p, t))


@dataclass
class ContactPairs:
    """Contact pairs, whatever detected them; one entry per pair.

    Attributes
    ----------
    slave : (k,) int
        Slave node.
    triangle : (k,) int
        Master triangle index in the detector's master surface (-1 for a rigid plane).
    master : (k, 3) int
        Master triangle nodes x1, x2, x3 (-1 for a rigid plane).
    xi, zeta : (k,) float
        Local coordinates of the master point ``xbar = (1 - xi - zeta) x1 + xi x2 + zeta x3``.
    normal : (k, 3) float
        Unit contact normal, out of the master body: the master triangle's normal when the
        slave projects inside the face; for the BVH detector on an edge or vertex, the
        direction from ``xbar`` to the slave (on the normal's side), so that ``gap`` is the
        signed distance and ``G.T @ lam`` has zero moment.
    gap : (k,) float
        Normal gap ``normal . (x_s - xbar)``; negative = penetration. ``G x`` reproduces it
        (for a rigid plane, ``G x = gap + normal . origin``).
    area : (k,) float
        Tributary area of the slave node on its own surface (reference configuration):
        nodal force = pressure x area.
    feature : (k,) uint8
        Where xbar lies on the master triangle: 0 face, 1 edge, 2 vertex (for the interface
        mesh: how many local coordinates are negative, i.e. outside the triangle).
    """

    slave: np.ndarray
    triangle: np.ndarray
    master: np.ndarray
    xi: np.ndarray
    zeta: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    area: np.ndarray
    feature: np.ndarray

    def __len__(self) -> int:
        return len(self.slave)

    @classmethod
    def empty(cls) -> "ContactPairs":
        """No pairs."""
        i = np.zeros(0, dtype=np.int64)
        f = np.zeros(0)
        return cls(i, i, np.zeros((0, 3), np.int64), f, f, np.zeros((0, 3)), f, f, np.zeros(0, np.uint8))

    @classmethod
    def concatenate(cls, parts) -> "ContactPairs":
        """Joins several records (e.g. both directions, or a surface pair and a plane)."""
        parts = list(parts)
        if not parts:
            return cls.empty()
        return cls(*(np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(cls)))

    def select(self, mask) -> "ContactPairs":
        """The pairs where ``mask`` (bool or index array) holds, e.g. ``pairs.select(pairs.gap < 0)``."""
        return ContactPairs(*(getattr(self, f.name)[mask] for f in fields(self)))

    @property
    def active(self) -> np.ndarray:
        """Mask of the penetrating pairs (gap < 0)."""
        return self.gap < 0

    def constraint_matrix(self, n_nodes: int) -> sp.csr_matrix:
        """G of these pairs (see :func:`constraint_matrix`)."""
        return constraint_matrix(self.slave, self.master, self.xi, self.zeta, self.normal, n_nodes)

    def constraint(self, n_nodes: int) -> "Constraint":
        """G of these pairs as a :class:`Constraint` (its products in Rust, no scipy matrix)."""
        return Constraint(*_core.contact.constraint_matrix(as_indices(self.slave, "slave", 1), as_indices(self.master, "master", 2),
                                                   np.ascontiguousarray(self.xi, dtype=np.float64).ravel(),
                                                   np.ascontiguousarray(self.zeta, dtype=np.float64).ravel(),
                                                   as_points(self.normal, "normal"), int(n_nodes)))


class Constraint:
    """A constraint matrix G (pairs x DOFs, see :func:`constraint_matrix`) as its CSR arrays,
    with the products a contact step needs done in Rust: ``G @ x`` (the gaps) and
    ``G.T @ lam`` (the pair forces on every DOF), the same bits as scipy's products; ``G[rows]``
    selects rows. A contact step builds several per step, for a few dozen pairs each, where
    constructing a scipy matrix cost more than its products; :meth:`tocsr` gives one."""

    __slots__ = ("indptr", "indices", "data", "shape")

    def __init__(self, indptr, indices, data, shape):
        self.indptr = np.ascontiguousarray(indptr, dtype=np.int64)
        self.indices = np.ascontiguousarray(indices, dtype=np.int64)
        self.data = np.ascontiguousarray(data, dtype=np.float64)
        self.shape = (int(shape[0]), int(shape[1]))

    def __matmul__(self, x) -> np.ndarray:
        return _core.linalg.csr_matvec(self.shape[1], self.indptr, self.indices, self.data,
                                np.ascontiguousarray(x, dtype=np.float64))

    @property
    def T(self) -> "_Transposed":
        return _Transposed(self)

    def __getitem__(self, rows) -> "Constraint":
        rows = np.arange(self.shape[0])[rows]
        start, stop = self.indptr[rows], self.indptr[rows + 1]
        length = stop - start
        indptr = np.zeros(len(rows) + 1, dtype=np.int64)
        np.cumsum(length, out=indptr[1:])
        take = np.repeat(start - indptr[:-1], length) + np.arange(indptr[-1])
        return Constraint(indptr, self.indices[take], self.data[take], (len(rows), self.shape[1]))

    def tocsr(self) -> sp.csr_matrix:
        return sp.csr_matrix((self.data, self.indices, self.indptr), shape=self.shape)


class _Transposed:
    """``G.T`` of a :class:`Constraint`, for ``G.T @ lam``."""

    __slots__ = ("G",)

    def __init__(self, G: Constraint):
        self.G = G

    def __matmul__(self, y) -> np.ndarray:
        G = self.G
        return _core.linalg.csr_rmatvec(G.shape[1], G.indptr, G.indices, G.data, np.ascontiguousarray(y, dtype=np.float64))


def constraint_matrix(slave, master, xi, zeta, normal, n_nodes: int) -> sp.csr_matrix:
    """The sparse constraint matrix G (pairs x 3 n_nodes) of contact pairs.

    Row e is ``g_e = [n, -N1 n, -N2 n, -N3 n]`` on the DOFs (node-major) of the slave node and
    the master nodes x1, x2, x3, with N1 = 1 - xi - zeta, N2 = xi, N3 = zeta. So ``G @ x`` are
    the normal gaps of the stacked positions ``x`` (with xi, zeta, n frozen) and
    ``G.T @ lam`` the contact forces: each slave pushed along +n, its master along -n, with
    zero net force and moment.

    A master row of three -1 marks a rigid master (node-to-plane): that row has only the
    slave's ``n``.

    >>> import numpy as np, vfrs
    >>> G = vfrs.contact.constraint_matrix([3], [[0, 1, 2]], [0.25], [0.25], [[0, 0, 1.0]], 4)
    >>> x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.3, 0.7]]).ravel()
    >>> float((G @ x)[0])
    0.7
    """
    s = as_indices(slave, "slave", 1)
    m = as_indices(master, "master", 2)
    n = as_points(normal, "normal")
    indptr, indices, data, shape = _core.contact.constraint_matrix(
        s,
        m,
        np.ascontiguousarray(xi, dtype=np.float64).ravel(),
        np.ascontiguousarray(zeta, dtype=np.float64).ravel(),
        n,
        int(n_nodes),
    )
    return sp.csr_matrix((data, indices, indptr), shape=shape)


def tributary_areas(points, triangles) -> np.ndarray:
    """Nodal area of every point: a third of each adjacent surface triangle (0 off-surface)."""
    return _core.contact.tributary_areas(as_points(points), as_indices(triangles, "triangles", 2))


def contact_area(points, triangles, loaded) -> float:
    """The paper's contact area: summed area of the ``triangles`` with any loaded vertex.

    ``loaded`` is a bool mask over all points, or an array of loaded node indices.

    >>> import numpy as np, vfrs
    >>> p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    >>> vfrs.contact.contact_area(p, [[0, 1, 2], [1, 3, 2]], [1])
    1.0
    """
    p = as_points(points)
    loaded = np.asarray(loaded)
    if loaded.dtype != bool:
        mask = np.zeros(len(p), dtype=bool)
        mask[as_indices(loaded, "loaded", 1)] = True
        loaded = mask
    return _core.contact.contact_area(p, as_indices(triangles, "triangles", 2), np.ascontiguousarray(loaded))


def stack(*bodies):
    """Stacks bodies ``(points, {name: triangles})`` into one points array.

    Returns ``(points, [offsets], [{name: triangles with global indices}])`` so surfaces of
    several meshes can be handed to one detector.
    """
    pts, offsets, surfaces, off = [], [], [], 0
    for p, surf in bodies:
        p = as_points(p)
        pts.append(p)
        offsets.append(off)
        surfaces.append({k: as_indices(v, k, 2) + off for k, v in surf.items()})
        off += len(p)
    return np.concatenate(pts), offsets, surfaces


def node_normals(x, triangles, n_points: int, nodes=None) -> np.ndarray:
    """Unit normals (n_points, 3) of the surface ``triangles`` at the positions ``x``: at each
    node the area-weighted mean of its triangles' normals (oriented as the triangles: outward
    on the meshes' named surfaces); zero off the surface. ``nodes``: only these nodes' rows,
    (len(nodes), 3) (the triangles' nodes are the only ones computed; the same numbers)."""
    x = np.asarray(x, dtype=float).reshape(-1, 3)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    # The triangles' nodes, numbered 0.. in increasing order (np.unique's numbering, by a
    # mark per node instead of a sort).
    flat = tri.ravel()
    seen = np.zeros(max(len(x), n_points), dtype=bool)
    seen[flat] = True
    local = np.flatnonzero(seen)
    rank = np.cumsum(seen) - 1
    idx = rank[flat]
    n = np.zeros((len(local), 3))
    if len(tri):
        # 2 x area x normal: np.cross's operations, without its per-call set-up
        a, b = x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]]
        face = np.empty((len(tri), 3))
        face[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
        face[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
        face[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        for c in range(3):
            n[:, c] = np.bincount(idx, np.repeat(face[:, c], 3), minlength=len(local))
    norm = np.linalg.norm(n, axis=1)
    ok = norm > 0
    n[ok] /= norm[ok, None]
    if nodes is not None:
        nodes = np.asarray(nodes, dtype=np.int64)
        out = np.zeros((len(nodes), 3))
        on = seen[nodes]
        out[on] = n[rank[nodes[on]]]
        return out
    full = np.zeros((n_points, 3))
    full[local] = n
    return full
