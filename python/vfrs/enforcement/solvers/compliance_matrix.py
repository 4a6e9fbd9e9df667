"""The reduced contact space: a compliance of the contact DOFs, computed as pairs need it.

With K_eff factored once, the response of the free DOFs to contact forces is
du = s K_eff^-1 G^T lam (s = 1 + alpha in HHT-alpha, 1 in statics). Only the rows of the
contact DOFs matter for the gaps, so we keep S = P K_eff^-1 P^T for the DOFs that pairs have
touched so far, as SOFA's precomputed constraint correction does. A DOF enters S the first
time a pair involves it: one block solve for all new DOFs of a step, after which W =
s G_c S G_c^T for any set of pairs is dense work on the contact unknowns. Every penalty
value, augmentation and active-set iteration costs no factorization and no solve; applying
the final forces costs one. Over a run only the contact zone is ever solved for, not the
whole candidate surface.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


class Compliance:
    """S = P K^-1 P^T over the DOFs seen so far, for a factored free-DOF system.

    ``factor``: the Cholesky of the free-DOF matrix; ``free``: free DOFs (global numbers);
    ``n_dofs``: all DOFs; ``candidate_dofs``: DOFs to compute at once (optional; others are
    added when a pair first touches them); ``chunk``: right-hand sides per block solve.
    """

    def __init__(self, factor, free, n_dofs, candidate_dofs=(), chunk=256):
        self.factor = factor
        self.pos_free = np.full(n_dofs, -1, dtype=np.int64)
        self.pos_free[np.asarray(free)] = np.arange(len(free))
        self.n_free = len(free)
        self.n_dofs = n_dofs
        self.chunk = chunk
        self.col_of = np.full(n_dofs, -1, dtype=np.int64)
        self.dofs = np.zeros(0, dtype=np.int64)
        self._S = np.zeros((0, 0))
        self.solves = 0  # right-hand sides solved so far (the cost of the compliance)
        self.ensure(candidate_dofs)

    @property
    def size(self) -> int:
        return len(self.dofs)

    @property
    def S(self) -> np.ndarray:
        n = self.size
        return self._S[:n, :n]

    def ensure(self, dofs) -> None:
        """Adds the free DOFs among ``dofs`` that S does not cover yet."""
        dofs = np.unique(np.asarray(dofs, dtype=np.int64))
        new = dofs[(self.pos_free[dofs] >= 0) & (self.col_of[dofs] < 0)] if dofs.size else dofs
        if new.size == 0:
            return
        old_n = self.size
        n = old_n + len(new)
        if n > self._S.shape[0]:
            cap = max(n, 2 * self._S.shape[0], 64)
            grown = np.zeros((cap, cap))
            grown[:old_n, :old_n] = self._S[:old_n, :old_n]
            self._S = grown
        self.col_of[new] = np.arange(old_n, n)
        self.dofs = np.concatenate([self.dofs, new])
        rows_all = self.pos_free[self.dofs]
        for start in range(0, len(new), self.chunk):
            block = new[start : start + self.chunk]
            B = np.zeros((self.n_free, len(block)))
            B[self.pos_free[block], np.arange(len(block))] = 1.0
            X = self.factor.solve(B)
            self.solves += len(block)
            cols = self.col_of[block]
            S_block = X[rows_all, :]  # (n, len(block))
            self._S[:n, cols] = S_block
            self._S[cols, :n] = S_block.T
        # Symmetrise the new rows/columns (the solves are exact up to round-off).
        S = self._S[:n, :n]
        S[:, old_n:] = 0.5 * (S[:, old_n:] + S[old_n:, :].T)
        S[old_n:, :] = S[:, old_n:].T

    def restrict(self, G: sp.spmatrix) -> sp.csr_matrix:
        """Columns of G on the covered DOFs (call :meth:`ensure` first; G's other columns
        must be on fixed DOFs, which do not move)."""
        G = sp.csr_matrix(G)
        cols = self.col_of[G.indices]
        keep = cols >= 0
        rows = np.repeat(np.arange(G.shape[0]), np.diff(G.indptr))
        return sp.csr_matrix((G.data[keep], (rows[keep], cols[keep])), shape=(G.shape[0], self.size))

    def delassus(self, G: sp.spmatrix, scale: float = 1.0) -> np.ndarray:
        """W = scale G_c S G_c^T (dense, pairs x pairs), extending S to G's DOFs first."""
        G = sp.csr_matrix(G)
        self.ensure(G.indices)
        Gc = self.restrict(G)
        GS = Gc @ self.S  # dense (pairs x covered DOFs)
        W = scale * np.asarray(Gc @ GS.T).T
        return 0.5 * (W + W.T)
