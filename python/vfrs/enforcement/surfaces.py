"""The contact surfaces of a scene (:class:`ContactSurfaces`), what detectors set up from. The
checks of ``[contact] surface`` / ``pairs`` against the bodies' meshes are the scene's
(:mod:`vfrs.scene.contact_keys`)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..contact import tributary_areas
from ..errors import ContactError
from ..scene.contact_keys import DEFAULT_SURFACE, contact_surface_errors
from .quadratic_surfaces import MidNodeTransform


class ContactSurfaces:
    """The contact surfaces of a scene, in global node numbers: what detectors set up from.

    ``surface_of`` (body name -> (k, 3) triangles), ``body_pairs`` (pairs of body names that
    may touch), ``areas`` (tributary area per global node, 0 off the surfaces), ``nodes`` (all
    surface nodes), ``h_surface`` (mean surface edge), ``boundary_edges`` / ``boundary_nodes``
    (the rims of open surfaces), ``points`` (reference coordinates).
    """

    def __init__(self, problem, surface="medial", pairs=None):
        self.points = problem.points
        errors = contact_surface_errors(surface, pairs, {p.name: list(p.mesh.surfaces) for p in problem.bodies})
        if errors:
            raise ContactError("; ".join(f"[contact] {key}: {msg}" for key, msg in errors))
        self.surface_of = {}
        for p in problem.bodies:
            name = surface if isinstance(surface, str) else surface.get(p.name, DEFAULT_SURFACE)
            tri = p.mesh.surfaces.get(name)
            if tri is None:
                tri = p.mesh.boundary_faces()  # only for the default name (checked above)
            self.surface_of[p.name] = tri + p.node_offset
        if pairs is None:
            names = [p.name for p in problem.bodies]
            pairs = [[a, b] for i, a in enumerate(names) for b in names[i + 1:]]
        self.body_pairs = [tuple(p) for p in pairs]
        all_tri = np.concatenate(list(self.surface_of.values()))
        X = self.points
        self.areas = tributary_areas(X, all_tri)
        edges = np.linalg.norm(X[all_tri] - X[np.roll(all_tri, 1, axis=1)], axis=2)
        self.h_surface = float(edges.mean())
        self.nodes = np.unique(all_tri)
        rims = np.sort(all_tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        uniq, counts = np.unique(rims, axis=0, return_counts=True)
        rim = uniq[counts == 1]
        self.boundary_edges = set(map(tuple, rim.tolist()))
        self.boundary_nodes = set(rim.ravel().tolist())
        self.n_points = problem.n_points
        #: quadratic bodies: their mid-edge contact nodes transformed for detection and constraints
        self.transform = MidNodeTransform(problem.bodies, self.surface_of, problem.n_points)
        #: Every DOF of the contact surfaces (node-major), the rows a compliance keeps.
        self.dofs = (3 * self.nodes[:, None] + np.arange(3)).ravel()
        # Node adjacency along the surfaces' edges (for :meth:`nearby`).
        e = all_tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        n = problem.n_points
        self._adjacency = sp.csr_matrix((np.ones(2 * len(e), dtype=np.int8), (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])),
                                        shape=(n, n))

    def nearby(self, dofs, rings: int = 2) -> np.ndarray:
        """Every DOF (all three components) of the surface nodes within ``rings`` surface edges
        of the nodes of ``dofs``, sorted: where contact spreads to from ``dofs`` next."""
        mark = np.zeros(self.n_points, dtype=bool)
        mark[np.asarray(dofs, dtype=np.int64) // 3] = True
        for _ in range(rings):
            mark |= (self._adjacency @ mark.astype(np.int8)) > 0
        nodes = np.flatnonzero(mark)
        return (3 * nodes[:, None] + np.arange(3)).ravel()
