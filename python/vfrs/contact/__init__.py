"""Contact geometry: projection, the detection engines, the contact-pair record, constraint matrix.

Two geometry engines (the detector roles of ``vfrs.enforcement.detectors`` drive them) return
the same record, :class:`ContactPairs`:

- :class:`InterfaceMeshEngine`, the paper's interface mesh: node-to-triangle tetrahedra that fill the gap
  between two surfaces; a tet whose oriented volume turns negative is a contact pair, and
  the intersection volume is summed over the inverted tets;
- :class:`BvhEngine`, the general one: BVH broad phase over master triangles and
  closest-point projection of slave nodes within a search distance;

plus :func:`node_to_plane` for rigid planes. :func:`constraint_matrix` turns pairs into the
sparse matrix G (``G x`` = gaps, ``G.T @ lam`` = contact forces), :func:`contact_area` gives
the paper's contact area.

Surfaces are (k, 3) node triangles into one points array, ordered so that
``(x2 - x1) x (x3 - x1)`` points out of their body (``Mesh.surfaces`` are). For two separate
meshes, stack their points and offset the second mesh's indices (:func:`stack`).

>>> import numpy as np, vfrs
>>> r = vfrs.contact.project([[0.25, 0.25, -0.5]], [[[0, 0, 0], [1, 0, 0], [0, 1, 0]]])
>>> float(r.gap[0]), float(r.xi[0]), r.normal[0].tolist(), int(r.feature[0])
(-0.5, 0.25, [0.0, 0.0, 1.0], 0)
"""

from .geometry import (
    ContactPairs,
    Projection,
    constraint_matrix,
    contact_area,
    project,
    stack,
    tributary_areas,
)
from .engines import BvhEngine, InterfaceMeshEngine, intersection_volume, node_to_plane

__all__ = [
    "project",
    "Projection",
    "ContactPairs",
    "constraint_matrix",
    "contact_area",
    "tributary_areas",
    "stack",
    "InterfaceMeshEngine",
    "BvhEngine",
    "node_to_plane",
    "intersection_volume",

]
