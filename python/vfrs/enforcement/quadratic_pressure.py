"""The contact pressure of quadratic (ten-node) bodies: the nodal contact forces projected onto
the pressure field of the six-node faces (issue 47).

On a linear body a node's pressure is its normal contact force over its tributary area (a third
of each surface triangle around it). On a quadratic body that rule is wrong: a uniform pressure
p on a flat six-node face loads its corners with 0 and its mid-edge nodes with p A / 3 (the
consistent forces, ``f_a = int N_a p dA``), so force over tributary area (the flat
sub-triangles': A / 12 at a corner, A / 4 at a mid-edge node) would read 0 and 4 p / 3 side by
side. Here the pressure is the field ``p_h = sum_b p_b N_b`` whose consistent forces are the
nodal normal forces: ``M p = f_n`` with the surface's consistent mass ``M_ab = int N_a N_b dA``
(reference configuration, each face integrated over its four sub-triangles by a degree-5 rule),
factorized once per body. A uniform pressure is recovered exactly on any mesh; the result is
clipped at zero (a projection of a patch's edge can undershoot), and the sensors, the effective
area and the maps then read it as they read a linear body's nodal pressure.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..quadratic import SUB_RULES, area_vectors


def face_mass(points, faces6) -> sp.csr_matrix:
    """The consistent surface mass ``int N_a N_b dA`` (n x n) of six-node ``faces6`` (k, 6) at
    ``points`` (n, 3)."""
    x = np.asarray(points, dtype=float)
    faces6 = np.asarray(faces6, dtype=np.int64).reshape(-1, 6)
    rows, cols, vals = [], [], []
    for N, dN, w in SUB_RULES:
        da = np.linalg.norm(area_vectors(x, faces6, dN), axis=2) * w  # (f, q)
        me = np.einsum("qa,qb,fq->fab", N, N, da)  # (f, 6, 6)
        rows.append(np.repeat(faces6, 6, axis=1).ravel())
        cols.append(np.tile(faces6, (1, 6)).ravel())
        vals.append(me.ravel())
    n = len(x)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


class QuadraticPressure:
    """The projection of nodal normal forces onto each quadratic body's contact-surface pressure
    (see the module). ``problem``: the problem (its bodies, node offsets); ``surface_of``: the
    contact surfaces' flat triangles by body name (global node numbers)."""

    def __init__(self, problem, surface_of: dict):
        self.parts = []
        for b in problem.bodies:
            tri = surface_of.get(b.name)
            if b.mesh.order != 2 or tri is None or not len(tri):
                continue
            off = b.node_offset
            faces = b.mesh.quadratic_faces()
            rows, _ = faces.locate(np.asarray(tri) - off)
            faces6 = faces.faces[np.unique(rows)]
            nodes = np.unique(faces6)
            local = np.searchsorted(nodes, faces6)
            M = face_mass(b.mesh.points[nodes], local).tocsc()
            self.parts.append((nodes + off, spla.splu(M)))

    def __bool__(self) -> bool:
        return bool(self.parts)

    def apply(self, pressure: np.ndarray, areas: np.ndarray) -> np.ndarray:
        """``pressure`` (per node, force over tributary ``areas``, as for a linear body) with the
        quadratic bodies' surface nodes replaced by the projected field (a new array)."""
        out = pressure.copy()
        for nodes, lu in self.parts:
            fn = pressure[nodes] * areas[nodes]
            if fn.any():
                out[nodes] = np.maximum(lu.solve(fn), 0.0)
        return out
