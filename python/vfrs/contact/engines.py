"""Detectors: the interface gap mesh (the paper's), the BVH detector, rigid planes."""

from __future__ import annotations

import numpy as np

from .. import _core
from .geometry import ContactPairs, as_indices, as_points, tributary_areas


def _pairs(d: dict) -> ContactPairs:
    return ContactPairs(**d)


class InterfaceMeshEngine:
    """The paper's detector: a coarse tetrahedral mesh filling the gap between two surfaces.

    For each direction (``surface_a`` nodes against ``surface_b`` triangles, then the
    reverse), every slave node ``s`` is joined to the master triangle ``(x1, x2, x3)`` closest
    to it at construction; the tet ``(x1, x2, x3, s)`` has positive oriented volume while
    ``s`` is in front of the triangle's plane and turns negative exactly when it crosses it.
    Inverted tets are contact pairs. Both directions are built, so collision is seen whichever
    fold moves.

    Intersection volume: node-to-triangle tets do not tile the gap by themselves, so each tet
    carries the weight ``3 a_s / (2 A_t)`` (slave tributary area over master triangle area,
    halved for the two directions); the weighted sum of ``|V|`` over inverted tets is the
    overlap volume (exact for flat slabs, convergent for curved ones). The plain sum is
    ``raw_volume`` in :meth:`inversion`.

    Limits: the pairing is frozen. Normal approach and penetration are unlimited, but
    tangential slip must stay below ``max_slip`` (barycentric units, 0.5 = half a master
    element); :meth:`update` rebuilds the pairing when it is exceeded (``detect`` does this
    itself unless ``auto_rebuild=False``). Nodes further than ``search_distance`` from the
    other surface at (re)build get no tet.

    Parameters
    ----------
    points : (n, 3) array
        Positions at which to build (the surfaces must not overlap there).
    surface_a, surface_b : (k, 3) int arrays
        Node triangles into ``points``, normals out of their bodies.
    search_distance : float
        Pairing radius (default: unlimited).
    max_slip : float
        Rebuild threshold, see above.

    Raises
    ------
    vfrs.ContactError
        Overlap at rest (naming node and triangle), degenerate triangles, bad indices.
    """

    name = "interface_mesh"

    def __init__(self, points, surface_a, surface_b, search_distance=np.inf, max_slip=0.5, auto_rebuild=True):
        self._core = _core.contact.InterfaceMesh(
            as_points(points),
            as_indices(surface_a, "surface_a", 2),
            as_indices(surface_b, "surface_b", 2),
            float(search_distance),
            float(max_slip),
        )
        self.auto_rebuild = auto_rebuild

    @property
    def tets(self) -> np.ndarray:
        """(m, 4) interface tets ``(x1, x2, x3, slave)``."""
        return self._core.tets

    @property
    def triangles(self) -> np.ndarray:
        """Master triangle index of each tet, within its own surface."""
        return self._core.triangles

    @property
    def sides(self) -> np.ndarray:
        """0: slave node on surface_a; 1: slave node on surface_b."""
        return self._core.sides

    @property
    def weights(self) -> np.ndarray:
        """Volume weights ``3 a_s / (2 A_t)``."""
        return self._core.weights

    @property
    def n_rebuilds(self) -> int:
        """How many times the pairing was rebuilt."""
        return self._core.n_rebuilds

    def signed_volumes(self, points) -> np.ndarray:
        """Oriented volumes of the interface tets at ``points`` (negative = inverted)."""
        return self._core.signed_volumes(as_points(points))

    def inverted(self, points) -> np.ndarray:
        """Mask of the inverted tets at ``points``."""
        return self.signed_volumes(points) < 0

    def inversion(self, points) -> dict:
        """``{'n_inverted', 'intersection_volume', 'raw_volume'}`` at ``points``."""
        n, vol, raw = self._core.inversion(as_points(points))
        return {"n_inverted": n, "intersection_volume": vol, "raw_volume": raw}

    def intersection_volume(self, points) -> float:
        """Weighted sum of ``|V|`` over inverted tets: the overlap volume."""
        return self._core.inversion(as_points(points))[1]

    def max_slip(self, points) -> float:
        """Largest tangential slip since the last (re)build, in barycentric units."""
        return self._core.max_slip(as_points(points))

    def update(self, points) -> bool:
        """Rebuilds the pairing if the slip exceeds ``max_slip``; returns whether it did."""
        return self._core.update(as_points(points))

    def rebuild(self, points) -> None:
        """Rebuilds the pairing at ``points`` (which may be in contact)."""
        self._core.rebuild(as_points(points))

    def detect(self, points) -> ContactPairs:
        """Contact pairs of the inverted tets (projection onto the master plane, unclamped)."""
        p = as_points(points)
        if self.auto_rebuild:
            self._core.update(p)
        return _pairs(self._core.detect(p))


def intersection_volume(points, interface_mesh: InterfaceMeshEngine) -> float:
    """Intersection volume of the two surfaces of ``interface_mesh`` at ``points``."""
    return interface_mesh.intersection_volume(points)


class BvhEngine:
    """General detector: BVH over master triangles, closest-point projection of slave nodes.

    Holds its Rust buffers: the first :meth:`detect` builds the tree, later calls refit it and
    reuse every buffer. For every slave node, the closest master triangle within
    ``search_distance`` is a pair (a slave node that is a vertex of a triangle ignores it).

    Parameters
    ----------
    master_triangles : (k, 3) int array
        Master surface, normals out of the master body.
    slave_nodes : (s,) int array, optional
        Slave nodes; default the nodes of ``slave_triangles``.
    slave_triangles : (k', 3) int array, optional
        Slave surface, used for the tributary areas (and the nodes if not given).
    points : (n, 3) array, optional
        Reference positions for the tributary areas (required with ``slave_triangles``).
    slave_areas : (s,) array, optional
        Tributary areas of the slave nodes, if not computed from ``slave_triangles``.
    best_first : bool
        Narrow phase by best-first traversal (prunes by the best distance so far) instead of
        projecting onto every triangle whose box meets the search box. An unbounded
        ``search_distance`` always uses best-first.
    """

    name = "bvh"

    def __init__(
        self, master_triangles, slave_nodes=None, slave_triangles=None, points=None, slave_areas=None, best_first=False
    ):
        if slave_nodes is None:
            if slave_triangles is None:
                raise ValueError("give slave_nodes or slave_triangles")
            slave_nodes = np.unique(as_indices(slave_triangles, "slave_triangles", 2))
        slave_nodes = as_indices(slave_nodes, "slave_nodes", 1)
        if slave_areas is None:
            if slave_triangles is not None and points is not None:
                slave_areas = tributary_areas(points, slave_triangles)[slave_nodes]
            else:
                slave_areas = np.zeros(len(slave_nodes))
        self._core = _core.contact.BvhDetector(
            as_indices(master_triangles, "master_triangles", 2),
            slave_nodes,
            np.ascontiguousarray(slave_areas, dtype=np.float64),
            bool(best_first),
        )

    def detect(self, points, search_distance: float) -> ContactPairs:
        """Pairs of the slave nodes within ``search_distance`` of the master surface."""
        return _pairs(self._core.detect(as_points(points), float(search_distance)))

    def count(self, points, search_distance: float) -> int:
        """Number of pairs, without building the arrays (for timing)."""
        return self._core.detect_count(as_points(points), float(search_distance))


def node_to_plane(points, nodes, origin, normal, search_distance=np.inf, areas=None) -> ContactPairs:
    """Pairs of ``nodes`` with a rigid plane (through ``origin``, ``normal`` out of the rigid side).

    ``gap = n . (x - origin)``; nodes with gap above ``search_distance`` are left out. Master
    entries are -1. ``areas`` are the nodes' tributary areas (default 0).
    """
    nodes = as_indices(nodes, "nodes", 1)
    areas = np.zeros(len(nodes)) if areas is None else np.ascontiguousarray(areas, dtype=np.float64)
    d = _core.contact.plane_detect(
        as_points(points),
        nodes,
        areas,
        [float(c) for c in origin],
        [float(c) for c in normal],
        float(search_distance),
    )
    return _pairs(d)
