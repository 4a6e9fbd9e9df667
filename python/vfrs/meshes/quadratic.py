"""Quadratic (P2, ten-node) tetrahedra from linear ones (issue 47, started): the mid-edge nodes
and the element connectivity in VTK's order, the order of ``vfrs._core.fem.QuadraticAssembler``
(vertices, then the mid-edge nodes of edges 0-1, 1-2, 0-2, 0-3, 1-3, 2-3).

:func:`elevate` puts each mid-edge node at its edge's midpoint (straight-sided elements, exact
for a body whose boundary is flat, a box), or where a given function says; :func:`m5_quadratic`
puts the M5 family's on the true geometry (the arcs of the medial curve, not their chords).

>>> import numpy as np
>>> p = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
>>> p2, t2 = elevate(p, np.array([[0, 1, 2, 3]]))
>>> p2.shape, t2.tolist()
((10, 3), [[0, 1, 2, 3, 4, 7, 5, 6, 8, 9]])
>>> p2[t2[0, 4]].tolist()                       # the midpoint of edge 0-1
[0.5, 0.0, 0.0]
"""

from __future__ import annotations

import numpy as np

#: The edge of each mid-edge node 4..9 of a ten-node tetrahedron (VTK's ``VTK_QUADRATIC_TETRA``).
EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]])


def elevate(points, tets, midpoint=None) -> tuple:
    """(points with the mid-edge nodes appended, the (m, 10) ten-node tetrahedra) for the
    linear tetrahedra ``tets`` (m, 4) on ``points`` (n, 3); an edge shared by several
    elements gets one node. The new nodes are numbered after the vertices, in the order of
    the sorted edges. ``midpoint(a, b)``: the mid-edge nodes' positions for the edges' vertex
    indices ``a``, ``b`` (arrays), e.g. on a curved boundary; default the edges' midpoints."""
    points = np.asarray(points, dtype=float)
    tets = np.asarray(tets, dtype=np.int64)
    if tets.ndim != 2 or tets.shape[1] != 4:
        raise ValueError(f"elevate: tets must have shape (m, 4), got {tets.shape}")
    edges = np.sort(tets[:, EDGES], axis=2).reshape(-1, 2)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    if midpoint is None:
        mids = 0.5 * (points[unique[:, 0]] + points[unique[:, 1]])
    else:
        mids = np.asarray(midpoint(unique[:, 0], unique[:, 1]), dtype=float)
    return np.vstack([points, mids]), np.hstack([tets, len(points) + inverse.reshape(-1, 6)])


def m5_quadratic(side="right", level=0, **kw) -> tuple:
    """One fold of the systematic M5 family (:func:`vfrs.meshes.m5` with ``family =
    "systematic"``, ``level`` and the profile keywords ``kw``) as ten-node tetrahedra whose
    mid-edge nodes lie on the true geometry: on the medial curve's arcs, not their chords
    (:func:`vfrs.meshes.m5_family.family_grid_midpoints`). Returns (points, tets10, the linear
    mesh): the vertices are the linear mesh's points, in its order."""
    from .m5 import M5Params, m5
    from .m5_family import family_grid_midpoints

    mesh = m5(side=side, family="systematic", level=level, **kw)
    profile = {k: kw.get(k, getattr(M5Params, k)) for k in ("T", "psi", "R_O", "exit_angle", "R_L", "inferior_angle",
                                                             "half_gap", "depth", "inferior_height", "superior_height")}
    fine = family_grid_midpoints(level, kw.get("length", M5Params.length), medial_ratio=kw.get("medial_ratio"),
                                 contact_zone_z=kw.get("contact_zone_z"), zone_ratio=kw.get("zone_ratio"), **profile)
    if side == "left":
        fine = fine * [-1.0, 1.0, 1.0]
    ns, nr, nz = ((n - 1) // 2 for n in fine.shape[:3])

    def grid_index(node):
        return node // ((nr + 1) * (nz + 1)), (node // (nz + 1)) % (nr + 1), node % (nz + 1)

    def midpoint(a, b):
        (ia, ja, ka), (ib, jb, kb) = grid_index(a), grid_index(b)
        return fine[ia + ib, ja + jb, ka + kb]

    points, tets10 = elevate(mesh.points, mesh.tets, midpoint)
    return points, tets10, mesh
