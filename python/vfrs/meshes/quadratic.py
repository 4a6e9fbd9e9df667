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


def quadratic_mesh(mesh):
    """The linear ``mesh`` as ten-node tetrahedra (a :class:`vfrs.Mesh` of ``order`` 2), its
    surfaces and regions kept. The mid-edge nodes go where the generator that built the mesh
    says (its ``midpoint`` hook: the M5 family's arcs, the sphere's surface) or, for a mesh
    without one (a box, a file), at the edges' midpoints: then ``curved`` is False and a curved
    boundary stays faceted. A ``medial_grid`` (the M5 folds' medial nodes as an (s, z) grid, read
    by the flow) becomes the grid with the mid-edge nodes between its nodes."""
    from ..mesh import Mesh

    if mesh.order == 2:
        return mesh
    midpoint = getattr(mesh, "midpoint", None)
    points, tets10 = elevate(mesh.points, mesh.tets, midpoint)
    out = Mesh(points, tets10, surfaces=dict(mesh.surfaces), regions=dict(mesh.regions), flipped=mesh.flipped,
               merged=mesh.merged)
    setattr(out, "curved", midpoint is not None)
    for key in ("family_info",):
        if hasattr(mesh, key):
            setattr(out, key, getattr(mesh, key))
    grid = getattr(mesh, "medial_grid", None)
    if grid is not None:
        setattr(out, "medial_grid", fine_grid(grid, out.mid_edge_nodes()))
    return out


def fine_grid(grid, lookup) -> np.ndarray:
    """The (2 s + 1, 2 z + 1) grid of a quadratic mesh's nodes on a structured surface whose
    vertices form the (s + 1, z + 1) ``grid``: the mid-edge nodes of its lines between them and,
    in each cell, of the diagonal its two triangles share (``lookup``: (i, j) -> mid-edge node)."""
    S, Z = grid.shape
    out = np.full((2 * S - 1, 2 * Z - 1), -1, dtype=np.int64)
    out[::2, ::2] = grid

    def mid(a, b):
        return lookup.get((min(a, b), max(a, b)), -1)

    for i in range(2 * S - 1):
        for k in range(2 * Z - 1):
            if i % 2 == 0 and k % 2 == 0:
                continue
            a, b = grid[i // 2, k // 2], grid[(i + 1) // 2, (k + 1) // 2]
            m = mid(int(a), int(b))
            if m < 0 and i % 2 and k % 2:  # the cell's other diagonal
                m = mid(int(grid[i // 2 + 1, k // 2]), int(grid[i // 2, k // 2 + 1]))
            if m < 0:
                raise ValueError(f"fine_grid: no mid-edge node between grid nodes at ({i}, {k})")
            out[i, k] = m
    return out


def m5_quadratic(side="right", level=0, **kw) -> tuple:
    """One fold of the systematic M5 family (:func:`vfrs.meshes.m5` with ``family =
    "systematic"``, ``level`` and the profile keywords ``kw``) as ten-node tetrahedra whose
    mid-edge nodes lie on the true geometry: on the medial curve's arcs, not their chords
    (:func:`vfrs.meshes.m5_family.family_grid_midpoints`). Returns (points, tets10, the linear
    mesh): the vertices are the linear mesh's points, in its order."""
    from .m5 import m5

    mesh = m5(side=side, family="systematic", level=level, **kw)
    points, tets10 = elevate(mesh.points, mesh.tets, getattr(mesh, "midpoint"))
    return points, tets10, mesh
