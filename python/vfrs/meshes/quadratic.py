"""Quadratic (P2, ten-node) tetrahedra from linear ones (issue 47, started): the mid-edge nodes
and the element connectivity in VTK's order, the order of ``vfrs._core.fem.QuadraticAssembler``
(vertices, then the mid-edge nodes of edges 0-1, 1-2, 0-2, 0-3, 1-3, 2-3).

:func:`elevate` puts each mid-edge node at its edge's midpoint: straight-sided elements, exact
for a body whose boundary is flat (a box); a curved boundary (the M5 folds' arcs) needs its
mid-edge nodes moved onto the true surface, which the generators do not do yet.

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


def elevate(points, tets) -> tuple:
    """(points with the mid-edge nodes appended, the (m, 10) ten-node tetrahedra) for the
    linear tetrahedra ``tets`` (m, 4) on ``points`` (n, 3); an edge shared by several
    elements gets one node. The new nodes are numbered after the vertices, in the order of
    the sorted edges."""
    points = np.asarray(points, dtype=float)
    tets = np.asarray(tets, dtype=np.int64)
    if tets.ndim != 2 or tets.shape[1] != 4:
        raise ValueError(f"elevate: tets must have shape (m, 4), got {tets.shape}")
    edges = np.sort(tets[:, EDGES], axis=2).reshape(-1, 2)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mids = 0.5 * (points[unique[:, 0]] + points[unique[:, 1]])
    return np.vstack([points, mids]), np.hstack([tets, len(points) + inverse.reshape(-1, 6)])
