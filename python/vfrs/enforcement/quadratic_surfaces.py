"""Contact on quadratic (ten-node) bodies: the transformed surface basis (issue 47).

The consistent forces of a uniform pressure p on a flat six-node face are 0 at its corners and
p A / 3 at its mid-edge nodes. Node-to-surface contact with a force >= 0 per node cannot carry
that distribution between non-matching surfaces (the patch test fails), and against a plane it
cannot carry the negative corner loads at a patch's rim. The remedy of the quadratic mortar
literature is a change of the surface basis (second-hand: the transformation with a parameter
alpha of Popp, Gee and Wall, Int. J. Numer. Meth. Engng 79, 2009, and Wohlmuth, Popp, Gee and
Wall, Comput. Mech. 49, 2012, as recalled, not re-read here): on the contact surface each
mid-edge node m of the edge c1-c2 is replaced, for contact only, by the transformed node

    x~_m = (x_m - alpha (x_c1 + x_c2)) / (1 - 2 alpha),        corners unchanged,

i.e. the surface field is written in the modified basis N~_c = N_c + alpha sum_m N_m,
N~_m = (1 - 2 alpha) N_m. A linear field has the same nodal values in both bases (x~ = x), so
an exact affine solution stays feasible; with alpha = 1/8 the modified basis's integrals over a
flat face are A / 12 at a corner and A / 4 at a mid-edge node: the tributary areas of the four
flat sub-triangles, all positive. Detection, gaps and multipliers then work on the transformed
nodes and the sub-triangles exactly as on a linear surface, and a pair's constraint row on the
physical DOFs is its row on the transformed ones times ``T^-1`` (``G = G~ T^-1``; the forces
``G^T lam``): a uniform pressure gives the corners 0 and the mid-edge nodes p A / 3 again.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..contact.geometry import Constraint

#: The transformation's parameter: the modified basis's integrals are the sub-triangles' tributary areas.
ALPHA = 1.0 / 8.0


class MidNodeTransform:
    """The transformed contact nodes of the quadratic bodies among ``bodies`` (the problem's
    parts) whose contact surfaces are ``surface_of`` (body name -> flat triangles, global
    numbers). Falsy when no contact surface is quadratic."""

    def __init__(self, bodies, surface_of: dict, n_points: int):
        mids, c1, c2 = [], [], []
        for b in bodies:
            tri = surface_of.get(b.name)
            if b.mesh.order != 2 or tri is None or not len(tri):
                continue
            off = b.node_offset
            on = np.zeros(b.mesh.n_points, dtype=bool)
            on[np.asarray(tri) - off] = True
            for (i, j), m in b.mesh.mid_edge_nodes().items():
                if on[m]:
                    mids.append(m + off)
                    c1.append(i + off)
                    c2.append(j + off)
        self.mids, self.c1, self.c2 = (np.asarray(v, dtype=np.int64) for v in (mids, c1, c2))
        self.n_points = int(n_points)
        self._inverse: sp.csr_matrix | None = None

    def __bool__(self) -> bool:
        return bool(len(self.mids))

    def tilde(self, x) -> np.ndarray:
        """The positions (n, 3) with the contact surfaces' mid-edge nodes transformed."""
        x = np.asarray(x, dtype=float).reshape(-1, 3)
        out = x.copy()
        out[self.mids] = (x[self.mids] - ALPHA * (x[self.c1] + x[self.c2])) / (1.0 - 2.0 * ALPHA)
        return out

    def inverse(self) -> sp.csr_matrix:
        """``T^-1`` (3n x 3n, node-major DOFs): x~ = T^-1 x."""
        if self._inverse is None:
            n = self.n_points
            a, b = 1.0 / (1.0 - 2.0 * ALPHA), -ALPHA / (1.0 - 2.0 * ALPHA)
            keep = np.ones(n, dtype=bool)
            keep[self.mids] = False
            ident = np.flatnonzero(keep)
            rows = np.concatenate([ident, self.mids, self.mids, self.mids])
            cols = np.concatenate([ident, self.mids, self.c1, self.c2])
            vals = np.concatenate([np.ones(len(ident)), np.full(len(self.mids), a), np.full(2 * len(self.mids), b)])
            R = np.repeat(3 * rows[:, None] + np.arange(3), 1, axis=0).ravel()
            C = (3 * cols[:, None] + np.arange(3)).ravel()
            self._inverse = sp.csr_matrix((np.repeat(vals, 3), (R, C)), shape=(3 * n, 3 * n))
        return self._inverse

    def apply(self, G: Constraint) -> Constraint:
        """The constraint rows ``G~`` on the transformed DOFs as rows on the physical ones."""
        P = (G.tocsr() @ self.inverse()).tocsr()
        P.sort_indices()
        return Constraint(P.indptr, P.indices, P.data, P.shape)
