"""The reduced contact space: a precomputed compliance of the candidate contact DOFs.

With K_eff factored once, the response of the free DOFs to contact forces is
du = s K_eff^-1 G^T lam (s = 1 + alpha in HHT-alpha, 1 in statics). Only the rows of the
contact DOFs matter for the gaps, so we precompute S = P K_eff^-1 P^T for the candidate DOFs
(every free DOF of a contact-surface node), as SOFA's precomputed constraint correction
does, once per run. Then W = s G_c S G_c^T for any set of pairs is dense work on the
contact unknowns: every penalty value, every augmentation and every active-set iteration
costs no factorization and no solve; applying the final forces costs one solve.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


class Compliance:
    """S = P K^-1 P^T for ``candidate_dofs`` (global DOF numbers) of a factored free system.

    ``factor``: the Cholesky of the free-DOF matrix; ``free``: free DOFs (global numbers,
    increasing); ``chunk``: right-hand sides per block solve (bounds the memory to
    n_free x chunk).
    """

    def __init__(self, factor, free, n_dofs, candidate_dofs, chunk=256):
        free = np.asarray(free)
        pos_free = np.full(n_dofs, -1, dtype=np.int64)
        pos_free[free] = np.arange(len(free))
        cand = np.unique(np.asarray(candidate_dofs, dtype=np.int64))
        cand = cand[pos_free[cand] >= 0]  # fixed DOFs do not move
        self.dofs = cand
        self.col_of = np.full(n_dofs, -1, dtype=np.int64)
        self.col_of[cand] = np.arange(len(cand))
        rows = pos_free[cand]
        c = len(cand)
        S = np.empty((c, c))
        for start in range(0, c, chunk):
            stop = min(start + chunk, c)
            B = np.zeros((len(free), stop - start))
            B[rows[start:stop], np.arange(stop - start)] = 1.0
            X = factor.solve(B)
            S[:, start:stop] = X[rows, :]
        self.S = 0.5 * (S + S.T)
        self.n_dofs = n_dofs

    @property
    def size(self) -> int:
        return len(self.dofs)

    def restrict(self, G: sp.spmatrix) -> sp.csr_matrix:
        """Columns of G on the candidate DOFs (G's other columns must be on fixed DOFs)."""
        G = sp.csr_matrix(G)
        cols = self.col_of[G.indices]
        keep = cols >= 0
        rows = np.repeat(np.arange(G.shape[0]), np.diff(G.indptr))
        return sp.csr_matrix((G.data[keep], (rows[keep], cols[keep])), shape=(G.shape[0], self.size))

    def delassus(self, G: sp.spmatrix, scale: float = 1.0) -> np.ndarray:
        """W = scale G_c S G_c^T (dense, pairs x pairs)."""
        Gc = self.restrict(G)
        GS = Gc @ self.S  # dense (pairs x candidates)
        W = scale * np.asarray(Gc @ GS.T).T
        return 0.5 * (W + W.T)
