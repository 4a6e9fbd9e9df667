"""The reduced contact space: a compliance of the contact DOFs, computed as pairs need it.

With a factored free-DOF matrix A (K_eff, or the mass M for the stabilized predictor), the
response of the free DOFs to nodal forces f is du = A^-1 f. A column A^-1 e_j is computed the
first time a pair involves DOF j (one block solve for all new DOFs of a round), as SOFA's
precomputed constraint correction does, and kept at the rows of the *observed* DOFs (every
DOF of the contact surfaces). Then, for any set of pairs,

- the Delassus operator W = s G_c S G_c^T (S: the computed columns at their own rows) is
  dense work on the contact unknowns: every penalty value, augmentation and LCP iteration
  costs no factorization and no solve;
- the response of every contact-surface node to pair forces (:meth:`Compliance.response`) is
  a dense product, so detection can be repeated at the corrected positions without a solve;
  the full field then takes one solve per step.

Over a run only the contact zone is ever solved for, not the whole candidate surface.

A factor that is refactored (a finite-strain run's tangent, :attr:`vfrs.Cholesky.version`)
makes the columns stale: they are dropped and computed again, as pairs need them, with the
new numbers (:meth:`Compliance.current`). A linear run's factor never changes.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ...errors import SolverError


class Compliance:
    """Columns of A^-1 for the DOFs seen so far, kept at the rows of ``observed``.

    ``factor``: the factor of the free-DOF matrix; ``free``: free DOFs (global numbers);
    ``n_dofs``: all DOFs; ``observed``: DOFs whose response is kept (default: only the
    columns' own DOFs, i.e. S); ``chunk``: right-hand sides per block solve.
    """

    def __init__(self, factor, free, n_dofs, observed=None, chunk=256):
        self.factor = factor
        self.pos_free = np.full(n_dofs, -1, dtype=np.int64)
        self.pos_free[np.asarray(free)] = np.arange(len(free))
        self.n_free = len(free)
        self.n_dofs = n_dofs
        self.chunk = chunk
        self.col_of = np.full(n_dofs, -1, dtype=np.int64)
        self.dofs = np.zeros(0, dtype=np.int64)
        self._S = np.zeros((0, 0))
        self._S_contiguous: np.ndarray | None = None  # S's copy for products (see S)
        self.row_of = np.full(n_dofs, -1, dtype=np.int64)
        if observed is None:
            self.observed = None
            self._X = None
        else:
            obs = np.unique(np.asarray(observed, dtype=np.int64))
            self.observed = obs[self.pos_free[obs] >= 0]
            self.row_of[self.observed] = np.arange(len(self.observed))
            self._X = np.zeros((len(self.observed), 0))
        self.solves = 0  # right-hand sides solved so far (the cost of the compliance)
        self._version = self._factor_version()
        self.resets = 0  # times the columns were dropped because the factor changed

    def _factor_version(self) -> int:
        return int(getattr(self.factor, "version", 0))

    def current(self) -> None:
        """Drops the columns if the factor was refactored since they were computed."""
        version = self._factor_version()
        if version == self._version:
            return
        self._version = version
        self.resets += 1
        self.col_of[self.dofs] = -1
        self.dofs = np.zeros(0, dtype=np.int64)
        self._S_contiguous = None

    @property
    def size(self) -> int:
        return len(self.dofs)

    @property
    def S(self) -> np.ndarray:
        """The computed block (read-only), contiguous: scipy's sparse @ dense copies a strided
        operand on every product, so the copy is made once per change of S."""
        n = self.size
        if self._S_contiguous is None or self._S_contiguous.shape[0] != n:
            self._S_contiguous = np.ascontiguousarray(self._S[:n, :n])
            self._S_contiguous.flags.writeable = False
        return self._S_contiguous

    @property
    def nbytes(self) -> int:
        """Memory held by the columns (S and the observed rows)."""
        return int(self._S.nbytes + (0 if self._X is None else self._X.nbytes))

    def state(self) -> dict:
        """The columns computed so far, as computed (for a checkpoint): the DOFs they cover in
        order, S, the observed rows, the storage's capacity and the solve count. Computing them
        again after a resume would batch the right-hand sides differently and change the
        round-off (up to four columns take another kernel than more)."""
        n = self.size
        return {"dofs": self.dofs.copy(), "capacity": self._S.shape[0], "S": self._S[:n, :n].copy(),
                "X": None if self._X is None else self._X[:, :n].copy(), "solves": self.solves,
                "resets": self.resets}

    def restore(self, state: dict) -> None:
        dofs = np.asarray(state["dofs"], dtype=np.int64)
        n, cap = len(dofs), int(state["capacity"])
        self.dofs = dofs.copy()
        self.col_of[:] = -1
        self.col_of[dofs] = np.arange(n)
        self._S = np.zeros((cap, cap))
        self._S[:n, :n] = state["S"]
        self._S_contiguous = None
        if self._X is not None:
            self._X = np.zeros((len(self.observed), cap))
            self._X[:, :n] = state["X"]
        self.solves = int(state["solves"])
        self.resets = int(state.get("resets", 0))
        # The columns belong to the factor as restored with them (a finite-strain integrator
        # refactors at the checkpoint's displacement before effects restore).
        self._version = self._factor_version()

    def ensure(self, dofs) -> None:
        """Adds the free DOFs among ``dofs`` that S does not cover yet."""
        self.current()
        dofs = np.unique(np.asarray(dofs, dtype=np.int64))
        new = dofs[(self.pos_free[dofs] >= 0) & (self.col_of[dofs] < 0)] if dofs.size else dofs
        if new.size == 0:
            return
        if self.observed is not None and (self.row_of[new] < 0).any():
            bad = int(new[self.row_of[new] < 0][0])
            raise SolverError(f"compliance: DOF {bad} is not among the observed DOFs (the contact surfaces)")
        old_n = self.size
        n = old_n + len(new)
        self._S_contiguous = None
        if n > self._S.shape[0]:
            cap = max(n, 2 * self._S.shape[0], 64)
            grown = np.zeros((cap, cap))
            grown[:old_n, :old_n] = self._S[:old_n, :old_n]
            self._S = grown
            if self._X is not None:
                X = np.zeros((len(self.observed), cap))
                X[:, :old_n] = self._X[:, :old_n]
                self._X = X
        self.col_of[new] = np.arange(old_n, n)
        self.dofs = np.concatenate([self.dofs, new])
        rows_all = self.pos_free[self.dofs]
        obs_rows = None if self.observed is None else self.pos_free[self.observed]
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
            if self._X is not None:
                self._X[:, cols] = X[obs_rows, :]
        # Symmetrise the new rows/columns (the solves are exact up to round-off).
        S = self._S[:n, :n]
        S[:, old_n:] = 0.5 * (S[:, old_n:] + S[old_n:, :].T)
        S[old_n:, :] = S[:, old_n:].T
        if self._X is not None:  # the observed rows of the columns' own DOFs are S
            self._X[self.row_of[self.dofs], :n] = S

    def restrict(self, G: sp.spmatrix) -> sp.csr_matrix:
        """Columns of G on the covered DOFs (call :meth:`ensure` first; G's other columns
        must be on fixed DOFs, which do not move)."""
        G = _csr(G)
        cols = self.col_of[G.indices]
        keep = cols >= 0
        m = G.shape[0]
        rows = np.repeat(np.arange(m), np.diff(G.indptr))[keep]
        indptr = np.zeros(m + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows, minlength=m), out=indptr[1:])
        # Built as CSR directly, then made canonical the way scipy's COO -> CSR conversion
        # does (columns sorted in each row): the same arrays as from triplets, without them.
        out = sp.csr_matrix((G.data[keep], cols[keep], indptr), shape=(m, self.size))
        out.sum_duplicates()
        return out

    def delassus(self, G: sp.spmatrix, scale: float = 1.0) -> np.ndarray:
        """W = scale G_c S G_c^T (dense, pairs x pairs), extending S to G's DOFs first."""
        G = _csr(G)
        self.ensure(G.indices)
        Gc = self.restrict(G)
        GS = Gc @ self.S  # dense (pairs x covered DOFs)
        W = scale * np.asarray(Gc @ GS.T).T
        return 0.5 * (W + W.T)

    def response(self, f_full, scale: float = 1.0) -> np.ndarray:
        """scale A^-1 f at the observed DOFs, for nodal forces f (all DOFs) whose free
        support is covered (or is made so)."""
        f_full = np.asarray(f_full, dtype=np.float64)
        support = np.flatnonzero(f_full)
        support = support[self.pos_free[support] >= 0]
        if support.size == 0:
            return np.zeros(len(self.observed))
        self.ensure(support)
        n = self.size
        f_cols = np.zeros(n)
        f_cols[self.col_of[support]] = f_full[support]
        return scale * (self._X[:, :n] @ f_cols)


def _csr(G) -> sp.csr_matrix:
    """G as CSR, itself when it is one (no new matrix object per call)."""
    return G if sp.issparse(G) and G.format == "csr" else sp.csr_matrix(G)
