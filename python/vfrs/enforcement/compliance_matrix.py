"""The reduced contact space: a compliance of the contact DOFs, computed as pairs need it.

With a factored free-DOF matrix A (K_eff, or the mass M for the stabilized predictor), the
response of the free DOFs to nodal forces f is du = A^-1 f. A column A^-1 e_j is computed the
first time a pair involves DOF j (one block solve for all new DOFs of a round), as SOFA's
precomputed constraint correction does, and kept at the rows of the *observed* DOFs (every
DOF of the contact surfaces) of its own block (a column is zero on the other blocks' rows,
which are neither stored nor read). Then, for any set of pairs,

- the Delassus operator W = s G_c S G_c^T (S: the computed columns at their own rows) is
  dense work on the contact unknowns: every penalty value, augmentation and LCP iteration
  costs no factorization and no solve;
- the response of every contact-surface node to pair forces (:meth:`Compliance.response`) is
  a dense product, so detection can be repeated at the corrected positions without a solve;
- the response of the whole field to forces on covered DOFs (:meth:`Compliance.solve`, the
  contact correction and the stabilized predictor's shifts) is a product with the columns of
  the loaded DOFs only: every column is kept over all rows of its own block (a body that
  shares no DOF with another is its own block of A; the other blocks' rows are zero and are
  neither solved for nor stored). A step with pairs loads about a hundred DOFs on the medium
  M5 mesh: their columns are a tenth of what a forward/back substitution reads.

Over a run only the contact zone is ever solved for, not the whole candidate surface.

The columns over their blocks grow as columns x block rows (hundreds of MB on the fine M5
mesh: docs/performance.md, "Measurements behind the code's choices"). ``max_bytes`` caps
them (not S and the observed rows): a block whose next columns would not fit keeps the ones
it has and stores no more (their observed rows,
S and the response are kept as always); a product whose loaded DOFs are not all stored is
a solve with the factor instead (:attr:`Compliance.fallback_solves` counts them): the same
numbers to round-off, at the cost of a forward/back substitution.

``dtype`` float32 (``[contact] column_precision = "single"``) stores the columns over their
blocks in single precision: half their memory and half the bytes a product reads, twice the
columns under a cap. They are the solved float64 columns rounded once (relative 6e-8); the
products sum in double precision. S and the observed rows, which the LCP and detection read,
stay float64: the contact problem of a step is the same, only the field's update from its
forces is rounded (docs/performance.md, "A converged answer").

A factor that is refactored (a finite-strain run's tangent, :attr:`vfrs.Cholesky.version`)
makes the columns stale: they are dropped and computed again, as pairs need them, with the
new numbers (:meth:`Compliance.current`). A linear run's factor never changes.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sp

from .. import _core
from ..errors import SolverError, VfrsWarning
from ..checkpoint import Appended, items_of


class Compliance:
    """Columns of A^-1 for the DOFs seen so far, kept at the rows of ``observed``.

    ``factor``: the factor of the free-DOF matrix; ``free``: free DOFs (global numbers);
    ``n_dofs``: all DOFs; ``observed``: DOFs whose response is kept (default: only the
    columns' own DOFs, i.e. S); ``chunk``: right-hand sides per block solve (speed only: no
    result depends on it; the solve's right-hand sides stay in cache); ``max_bytes``:
    the most the columns over their blocks may hold (None: no cap); ``label``: the matrix, for
    the warning given when the cap is reached; ``prefetch``: given DOFs new to the compliance,
    the DOFs to solve for with them (a superset; e.g. the contact surfaces' nodes around them,
    :meth:`ContactSurfaces.nearby`), or None.

    Prefetching: a contact zone grows over a few steps, each step touching a few new surface
    nodes, and every step that did so paid a block solve. With the nodes two surface edges
    around them solved in the same solve, far fewer solves cover what a run needs, for some
    more columns (the counts: docs/performance.md). Prefetched columns are stored like the
    others; once the stored columns reach half of ``max_bytes`` no more are prefetched, so they cannot crowd out
    columns a step needs.
    """

    def __init__(self, factor, free, n_dofs, observed=None, chunk=64, max_bytes=None, label="K_eff",
                 prefetch=None, dtype=np.float64):
        self.factor = factor
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.dtype(np.float64), np.dtype(np.float32)):
            raise SolverError(f"compliance: columns are float64 or float32, not {self.dtype}")
        self._combine = _core.linalg.combine_rows if self.dtype == np.float64 else _core.linalg.combine_rows_single
        self.free = np.asarray(free, dtype=np.int64)
        self.pos_free = np.full(n_dofs, -1, dtype=np.int64)
        self.pos_free[self.free] = np.arange(len(free))
        self.n_free = len(free)
        # The blocks of A (free positions), each solved with its own factor.
        sub = getattr(factor, "factors", None)
        if sub is not None:
            self._blocks = list(zip(factor.blocks, sub))
        else:
            self._blocks = [(slice(0, self.n_free), factor)]
        self.block_of = np.empty(self.n_free, dtype=np.int64)
        for b, (blk, _) in enumerate(self._blocks):
            self.block_of[blk] = b
        # Per-block work runs concurrently when the factor solves its blocks so
        # (vfrs.linalg.BlockCholesky: blocks of concurrent_min DOFs or more), on its pool.
        self._pool = getattr(factor, "_pool", None)
        if sub is None or min(blk.stop - blk.start for blk, _ in self._blocks) < getattr(factor, "concurrent_min", 0):
            self._pool = None
        # Column j over the rows of its block: row slot_of[j] of _F[block].
        self.slot_of = np.full(n_dofs, -1, dtype=np.int64)
        self._F = [np.zeros((0, blk.stop - blk.start), dtype=self.dtype) for blk, _ in self._blocks]
        self._F_count = [0] * len(self._blocks)
        self.max_bytes = None if max_bytes is None else int(max_bytes)
        # A block whose columns reached the cap stores no more (the stored ones are the first
        # _F_count[b] of the block in the order ensure met them; restore relies on it).
        self._closed = [False] * len(self._blocks)
        self.fallback_solves = 0  # products done as a solve (a loaded DOF's column not stored)
        self.label = label
        self.prefetch = prefetch
        self.n_dofs = n_dofs
        self.chunk = chunk
        self.col_of = np.full(n_dofs, -1, dtype=np.int64)
        self.dofs = np.zeros(0, dtype=np.int64)
        self._S = np.zeros((0, 0))
        self.row_of = np.full(n_dofs, -1, dtype=np.int64)
        # The observed rows of the columns, block by block (a column is zero on the other
        # blocks' rows): block b's store _Xb[b] has a row per column of the block (row
        # xslot_of[j] for column j, in the order ensure met them) and a column per observed
        # DOF of the block (column opos[d] for DOF d; _obs_at[b]: their positions among all
        # observed DOFs, where the response puts them).
        self.xslot_of = np.full(n_dofs, -1, dtype=np.int64)
        self.opos = np.full(n_dofs, -1, dtype=np.int64)
        self._Xb: list = []
        self._X_count = [0] * len(self._blocks)
        self._obs_at: list = []
        if observed is None:
            self.observed = None
        else:
            obs = np.unique(np.asarray(observed, dtype=np.int64))
            self.observed = obs[self.pos_free[obs] >= 0]
            self.row_of[self.observed] = np.arange(len(self.observed))
            # Every column a block can ever store is one of its observed DOFs: its stores are
            # allocated once at that size (the columns over the block at most the cap), zero
            # pages the operating system maps when a column is first written, so memory grows
            # with the stored columns and no column is ever copied to a larger store.
            obs_block = self.block_of[self.pos_free[self.observed]]
            for b, (blk, _) in enumerate(self._blocks):
                rows = blk.stop - blk.start
                at = np.flatnonzero(obs_block == b)
                cap = len(at)
                self._obs_at.append(at)
                self.opos[self.observed[at]] = np.arange(cap)
                self._Xb.append(np.zeros((cap, cap)))
                if self.max_bytes is not None:
                    cap = min(cap, self.max_bytes // (self.dtype.itemsize * rows))
                self._F[b] = np.zeros((cap, rows), dtype=self.dtype)
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
        self._drop_columns()

    def _drop_columns(self) -> None:
        self.col_of[self.dofs] = -1
        self.slot_of[self.dofs] = -1
        self.xslot_of[self.dofs] = -1
        self.dofs = np.zeros(0, dtype=np.int64)
        self._F_count = [0] * len(self._blocks)
        self._X_count = [0] * len(self._blocks)
        self._closed = [False] * len(self._blocks)

    @property
    def size(self) -> int:
        return len(self.dofs)

    @property
    def nbytes(self) -> int:
        """Memory held by the columns (S, the observed rows and the columns stored over their
        blocks; a block's store is allocated for all its observed DOFs, but only the pages of
        stored columns are ever touched)."""
        observed_rows = sum(8 * c * X.shape[1] for X, c in zip(self._Xb, self._X_count))
        return int(self._S.nbytes + observed_rows + self._stored_bytes())

    def state(self) -> dict:
        """The columns computed so far, as computed (for a checkpoint): the DOFs they cover in
        order, S, the observed rows, the storage's capacity and the solve count. Computing them
        again after a resume would group the DOFs differently and change the round-off (an
        entry of S between two DOFs added by the same :meth:`ensure` is the mean of their two
        columns' values, between DOFs added by different calls the later column's value)."""
        n = self.size
        return {"dofs": self.dofs.copy(), "capacity": self._S.shape[0], "S": self._S[:n, :n].copy(),
                "Xb": [X[:c].copy() for X, c in zip(self._Xb, self._X_count)], "solves": self.solves,
                "resets": self.resets,
                # The stored rows only gain rows until a reset: a checkpoint appends the new ones.
                "F": [Appended(F[:c], epoch=self.resets) for F, c in zip(self._F, self._F_count)],
                "F_capacity": [F.shape[0] for F in self._F], "fallback_solves": self.fallback_solves}

    def restore(self, state: dict) -> None:
        if "F" not in state:
            # A checkpoint of a version that kept the observed rows only: the columns are
            # computed again as pairs need them (the resumed steps differ in round-off).
            self._drop_columns()
            self.solves = int(state["solves"])
            self.resets = int(state.get("resets", 0)) + 1
            self._version = self._factor_version()
            return
        dofs = np.asarray(state["dofs"], dtype=np.int64)
        n, cap = len(dofs), int(state["capacity"])
        self.dofs = dofs.copy()
        self.col_of[:] = -1
        self.col_of[dofs] = np.arange(n)
        self._S = np.zeros((cap, cap))
        self._S[:n, :n] = state["S"]
        self.solves = int(state["solves"])
        self.resets = int(state.get("resets", 0))
        self.fallback_solves = int(state.get("fallback_solves", 0))
        self.slot_of[:] = -1
        for b, (blk, _) in enumerate(self._blocks):
            F_b = items_of(state["F"][b])
            # The store as allocated here (all observed DOFs of the block), or as large as
            # the checkpoint's when it grows (no observed DOFs).
            cap_b = max(self._F[b].shape[0], len(F_b)) if self.observed is not None else int(state["F_capacity"][b])
            self._F[b] = np.zeros((cap_b, blk.stop - blk.start), dtype=self.dtype)
            self._F[b][: len(F_b)] = F_b
            self._F_count[b] = len(F_b)
        # Slots in each block in the order the DOFs were added (as ensure assigns them).
        blocks = self.block_of[self.pos_free[dofs]]
        self.xslot_of[:] = -1
        for b in range(len(self._blocks)):
            mine = dofs[blocks == b]
            stored = self._F_count[b]
            self.slot_of[mine[:stored]] = np.arange(stored)
            self._closed[b] = len(mine) > stored
            if self.observed is None:
                continue
            self.xslot_of[mine] = np.arange(len(mine))
            self._X_count[b] = len(mine)
            X = self._Xb[b]
            X[:] = 0.0
            if "Xb" in state:
                X[: len(mine)] = state["Xb"][b]
            else:  # a checkpoint that kept the observed rows of all blocks in one array
                full = np.asarray(state["X"])  # (observed, columns in S order)
                X[: len(mine)] = full[np.ix_(self._obs_at[b], self.col_of[mine])].T
        # The columns belong to the factor as restored with them (a finite-strain integrator
        # refactors at the checkpoint's displacement before effects restore).
        self._version = self._factor_version()

    def ensure(self, dofs) -> None:
        """Adds the free DOFs among ``dofs`` that S does not cover yet."""
        self.current()
        new = self._uncovered(dofs)
        if new is None:
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
        new_block = self.block_of[self.pos_free[new]]
        row_block = self.block_of[rows_all]  # S's rows by block (a column is 0 in the others)
        tasks = self._plan_solves(new, new_block)
        self._store_columns(tasks, self._solve_tasks(tasks), n, rows_all, row_block)
        self._symmetrise(old_n, n, new, new_block, row_block)

    def _uncovered(self, dofs) -> np.ndarray | None:
        """The free DOFs among ``dofs`` that S does not cover yet, sorted, with the prefetched
        ones (while the stores are small); None when there are none."""
        dofs = np.asarray(dofs, dtype=np.int64)
        if dofs.size and (self.col_of[dofs] >= 0).all():  # all covered already (the usual case)
            return None
        dofs = np.unique(dofs)
        new = dofs[(self.pos_free[dofs] >= 0) & (self.col_of[dofs] < 0)] if dofs.size else dofs
        if new.size == 0:
            return None
        if self.observed is not None and (self.row_of[new] < 0).any():
            bad = int(new[self.row_of[new] < 0][0])
            raise SolverError(f"compliance: DOF {bad} is not among the observed DOFs (the contact surfaces)")
        if self.prefetch is not None and (self.max_bytes is None or 2 * self._stored_bytes() < self.max_bytes):
            extra = np.asarray(self.prefetch(new), dtype=np.int64)
            extra = extra[(extra >= 0) & (extra < self.n_dofs)]
            extra = extra[(self.pos_free[extra] >= 0) & (self.col_of[extra] < 0)]
            if self.observed is not None:
                extra = extra[self.row_of[extra] >= 0]
            new = np.union1d(new, extra)
        return new

    def _plan_solves(self, new: np.ndarray, new_block: np.ndarray) -> list:
        """The unit right-hand sides, block by block (a column is zero outside its own block),
        ``chunk`` at a time, as tasks (block, its DOFs, first slot or None): each chunk's slots
        in its block's store (None: the block's store is closed), all decided before a view of
        a store is taken (a store without observed DOFs grows)."""
        tasks = []
        for b, (blk, _) in enumerate(self._blocks):
            mine = new[new_block == b]
            for start in range(0, len(mine), self.chunk):
                block = mine[start : start + self.chunk]
                first = self._F_count[b] if self._store(b, len(block)) else None
                if first is not None:
                    self.slot_of[block] = np.arange(first, first + len(block))
                    self._F_count[b] += len(block)
                tasks.append((b, block, first))
        return tasks

    def _solve_tasks(self, tasks: list) -> list:
        """The solved columns X of each task, in the tasks' order. A factor that can solves
        them with its forward pass on their supernodes only. One task per block: a factor is
        never used by two threads at once."""
        chunks: list = [[] for _ in self._blocks]
        for b, block, first in tasks:
            blk, f = self._blocks[b]
            rows = self.pos_free[block] - blk.start
            if hasattr(f, "unit_columns_into"):
                # Straight into the store's rows (a temporary once the block's store is
                # closed, or when the store is single precision): no copy, and no page is
                # touched twice.
                direct = first is not None and self.dtype == np.float64
                out = (self._F[b][first : first + len(block)] if direct
                       else np.empty((len(block), blk.stop - blk.start)))
                chunks[b].append((block, f.unit_columns_into, (rows, out)))
            else:
                # Column-major, as the solve works and returns: X.T is then a store's rows.
                B = np.zeros((blk.stop - blk.start, len(block)), order="F")
                B[rows, np.arange(len(block))] = 1.0
                chunks[b].append((block, f.solve, (B,)))
        busy = [c for c in chunks if c]
        solved = self._concurrently([(_solve_chunks, (c,)) for c in busy])
        return [X for per_block in solved for X in per_block]

    def _store_columns(self, tasks: list, solved: list, n: int, rows_all: np.ndarray, row_block: np.ndarray) -> None:
        """Writes each task's solved columns into its block's store, S's columns and (with
        observed DOFs) the observed rows."""
        for (b, block, first), X in zip(tasks, solved):
            blk = self._blocks[b][0]
            self.solves += len(block)
            if first is not None and not np.may_share_memory(X, self._F[b]):
                self._F[b][first : first + len(block)] = X.T
            cols = self.col_of[block]
            in_b = row_block == b
            S_block = np.zeros((n, len(block)))
            S_block[in_b] = X[rows_all[in_b] - blk.start, :]
            self._S[:n, cols] = S_block
            if self.observed is not None:
                first = self._X_count[b]
                self.xslot_of[block] = np.arange(first, first + len(block))
                self._Xb[b][first : first + len(block)] = X[self.pos_free[self.observed[self._obs_at[b]]] - blk.start, :].T
                self._X_count[b] += len(block)

    def _symmetrise(self, old_n: int, n: int, new: np.ndarray, new_block: np.ndarray, row_block: np.ndarray) -> None:
        """Symmetrise the new rows/columns (the solves are exact up to round-off): the new
        rows at the old columns are the new columns' values there, and each entry between
        two new DOFs is the mean of its two columns' values, whatever chunks solved them."""
        S = self._S[:n, :n]
        S[old_n:, :old_n] = S[:old_n, old_n:].T
        S[:, old_n:] = 0.5 * (S[:, old_n:] + S[old_n:, :].T)
        S[old_n:, :] = S[:, old_n:].T
        if self.observed is not None:
            # The observed rows of the columns' own DOFs are S (symmetric): the new columns'
            # rows at every covered DOF of their block, and the old columns' at the new DOFs.
            for b in range(len(self._blocks)):
                mine = self.dofs[row_block == b]
                fresh = new[new_block == b]
                if fresh.size:
                    X, old = self._Xb[b], mine[: len(mine) - len(fresh)]
                    X[np.ix_(self.xslot_of[fresh], self.opos[mine])] = S[np.ix_(self.col_of[fresh], self.col_of[mine])]
                    X[np.ix_(self.xslot_of[old], self.opos[fresh])] = S[np.ix_(self.col_of[old], self.col_of[fresh])]

    def _concurrently(self, calls) -> list:
        """The results of ``calls`` ((function, arguments), each on one block), on the
        factor's pool beside this thread when its blocks are solved concurrently."""
        if self._pool is None or len(calls) < 2:
            return [fn(*args) for fn, args in calls]
        futures = [self._pool.submit(fn, *args) for fn, args in calls[1:]]
        first = calls[0][0](*calls[0][1])
        return [first] + [f.result() for f in futures]

    def _store(self, b: int, k: int) -> bool:
        """Makes room for ``k`` more columns over block ``b``: False (and the block closed)
        if they would take the stored columns of all blocks past ``max_bytes``."""
        if self._closed[b]:
            return False
        F = self._F[b]
        need = self._F_count[b] + k
        if self.max_bytes is not None and need * F.itemsize * F.shape[1] > self.max_bytes - self._stored_bytes(but=b):
            if not self.capped:
                warnings.warn(
                    f"contact: the compliance columns of {self.label} reached the memory cap "
                    f"([contact] column_memory = {self.max_bytes / 2**20:.6g} MiB) with {self.size} contact DOFs: "
                    "the field updates of steps that load later contact DOFs solve with the factor instead "
                    "(each update the same to round-off, slower; a self-oscillating run's trajectory amplifies "
                    "round-off, docs/performance.md). Raise column_memory to keep them all.",
                    VfrsWarning, stacklevel=2)
            self._closed[b] = True
            return False
        if need > F.shape[0]:  # no observed DOFs given: the store grows
            grown = np.zeros((max(need, 2 * F.shape[0], 64), F.shape[1]), dtype=self.dtype)
            grown[: self._F_count[b]] = F[: self._F_count[b]]
            self._F[b] = grown
        return True

    def _stored_bytes(self, but: int = -1) -> int:
        """Bytes of the columns stored over their blocks (all blocks, or all but ``but``)."""
        return sum(F.itemsize * c * F.shape[1] for i, (F, c) in enumerate(zip(self._F, self._F_count)) if i != but)

    @property
    def capped(self) -> bool:
        """Whether a block's columns reached ``max_bytes`` (its later columns are not stored)."""
        return any(self._closed)

    def solve(self, b) -> np.ndarray:
        """A^-1 b over all free DOFs, for right-hand sides ``b`` (free DOFs, shape (n,) or
        (n, k)) that are zero outside few DOFs (pair forces): a product with those DOFs'
        columns, computed first where missing. Exact up to round-off, as a solve."""
        b = np.asarray(b, dtype=np.float64)
        B = b.reshape(len(b), -1)
        rows = np.flatnonzero(np.any(B != 0.0, axis=1))
        self.ensure(self.free[rows])
        if (self.slot_of[self.free[rows]] < 0).any():  # a column past the memory cap
            self.fallback_solves += 1
            return np.asarray(self.factor.solve(b), dtype=np.float64)
        out = np.zeros(B.shape)
        # One pass over the loaded columns per block (Rust, the sum over them in their order,
        # the GIL released): the blocks concurrently, as the factor's solves.
        jobs = []
        for k, (blk, _) in enumerate(self._blocks):
            sel = rows[self.block_of[rows] == k]
            if sel.size:
                jobs.append((self._F[k], self.slot_of[self.free[sel]], np.ascontiguousarray(B[sel]), out[blk]))
        self._concurrently([(self._combine, job) for job in jobs])
        return out.reshape(b.shape)

    def delassus(self, G, scale: float = 1.0) -> np.ndarray:
        """W = scale G S G^T (dense, pairs x pairs, exactly symmetric), extending S to G's
        DOFs first; G's columns on fixed DOFs (which do not move) are skipped, and only the
        block of S on G's DOFs is read (Rust, ``vfrs_core::compliance::delassus``). ``G``: a
        :class:`~vfrs.contact.geometry.Constraint` or a scipy sparse matrix."""
        if sp.issparse(G):
            G = _csr(G)
        self.ensure(G.indices)
        return _core.linalg.delassus(np.asarray(G.indptr, dtype=np.int64), np.asarray(G.indices, dtype=np.int64),
                              np.asarray(G.data, dtype=np.float64), self.col_of, self._S, self.size, float(scale))

    def response(self, f_full, scale: float = 1.0) -> np.ndarray:
        """scale A^-1 f at the observed DOFs, for nodal forces f (all DOFs) whose free
        support is covered (or is made so): only the loaded DOFs' columns are read."""
        f_full = np.asarray(f_full, dtype=np.float64)
        support = np.flatnonzero(f_full)
        support = support[self.pos_free[support] >= 0]
        if support.size == 0:
            return np.zeros(len(self.observed))
        self.ensure(support)
        out = np.zeros(len(self.observed))
        blocks = self.block_of[self.pos_free[support]]
        for b, at in enumerate(self._obs_at):
            sel = support[blocks == b]
            if sel.size:
                part = np.zeros((len(at), 1))
                _core.linalg.combine_rows(self._Xb[b], self.xslot_of[sel], f_full[sel].reshape(-1, 1), part)
                out[at] = part[:, 0]
        return scale * out


def _solve_chunks(chunks) -> list:
    """The solutions of one block's chunks of right-hand sides, one after the other."""
    return [fn(*args) for _, fn, args in chunks]


def _csr(G) -> sp.csr_matrix:
    """G as CSR, itself when it is one (no new matrix object per call)."""
    return G if sp.issparse(G) and G.format == "csr" else sp.csr_matrix(G)
