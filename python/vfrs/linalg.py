"""Sparse Cholesky (vfrs._core: faer's symbolic analysis, vfrs's numeric factorization and
solves) and Dirichlet elimination."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from concurrent.futures import ThreadPoolExecutor

from . import _core
from .errors import SolverError


def dot(x, y) -> float:
    """``x . y`` by numpy's pairwise sum of the products, not BLAS: OpenBLAS picks its ddot
    kernel (fused multiply-adds or not, the lanes it sums in) by CPU, so a result would
    depend on the machine in its last bits, which contact and Newton's line search amplify."""
    return float(np.multiply(x, y).sum())


def combine_columns(R, c) -> np.ndarray:
    """``R @ c`` for a dense (n, k) ``R`` and k coefficients, as elementwise numpy
    operations over the columns in order (the same bits on every CPU; see :func:`dot`)."""
    R = np.asarray(R, dtype=float)
    out = R[:, 0] * c[0]
    for j in range(1, R.shape[1]):
        out += R[:, j] * c[j]
    return out


def _csc_arrays(A, triangle: str | None = None, check_symmetry: bool = False):
    """(n, indptr, indices, data) of ``A`` in CSC, duplicates summed and indices sorted.

    ``triangle = "lower"`` / ``"upper"``: ``A`` holds one triangle of a symmetric matrix (the
    other is ignored), mirrored here into the full matrix. ``check_symmetry``: a full ``A``
    must be symmetric in structure and values (:func:`check_symmetric`)."""
    if not sp.issparse(A):
        raise SolverError(f"expected a scipy.sparse matrix, got {type(A).__name__}")
    if A.shape[0] != A.shape[1]:
        raise SolverError(f"matrix must be square, got shape {A.shape}")
    if triangle is not None:
        if triangle not in ("lower", "upper"):
            raise SolverError(f"triangle must be 'lower' or 'upper', got {triangle!r}")
        T = sp.tril(A, format="csc") if triangle == "lower" else sp.triu(A, format="csc")
        A = T + sp.triu(T.T, k=1) if triangle == "lower" else T + sp.tril(T.T, k=-1)
    A = sp.csc_matrix(A)
    A.sum_duplicates()  # also sorts indices
    if not np.all(np.isfinite(A.data)):
        k = int(np.flatnonzero(~np.isfinite(A.data))[0])
        col = int(np.searchsorted(A.indptr, k, side="right") - 1)
        raise SolverError(f"matrix entry ({int(A.indices[k])}, {col}) is {A.data[k]}: every entry must be finite")
    if check_symmetry and triangle is None:
        check_symmetric(A)
    return (
        A.shape[0],
        np.ascontiguousarray(A.indptr, dtype=np.int64),
        np.ascontiguousarray(A.indices, dtype=np.int64),
        np.ascontiguousarray(A.data, dtype=np.float64),
    )


def for_products(A) -> sp.csr_matrix:
    """A copy of sparse ``A`` as CSR without its stored zeros, for matrix-vector products.

    The consistent mass of a P1 mesh is assembled in the stiffness pattern, where two thirds
    of its entries are zeros (each node pair couples x with x only): a product with the copy
    reads a third of the entries. The numbers are the same bit for bit for finite vectors: a
    row's sum skips only terms that are exactly zero, and adding a signed zero to a sum that
    started at +0 leaves it as it is. (Factor ``A`` itself: its pattern fixes the ordering.)
    """
    B = sp.csr_matrix(A, copy=True)
    B.eliminate_zeros()
    return B


class Product:
    """A fixed sparse matrix for repeated products ``P @ x`` with vectors.

    A stiffness with three DOFs per node is made of full 3 x 3 blocks and a consistent mass
    (without its stored zeros, :func:`for_products`) is ``m (x) I_3``: such a matrix is kept in
    Rust with one column index per block (stiffness) or one value and index per node pair
    (mass), a third to a half of what a CSR product reads, and its products sum every row in
    the stored order from 0 as scipy's do: ``P @ x`` equals ``A @ x`` bit for bit, and
    :func:`sum_of_products` ``A @ x + B @ y``. Any other matrix, and anything but a contiguous
    float64 vector, goes to scipy.

    >>> import numpy as np, scipy.sparse as sp
    >>> A = sp.kron(sp.random(20, 20, density=0.3, random_state=1), np.ones((3, 3)), format="csr")
    >>> x = np.linspace(0.0, 1.0, 60)
    >>> P = Product(A)
    >>> P.blocked, bool(np.array_equal(P @ x, A @ x))
    (True, True)
    """

    def __init__(self, A):
        self.matrix = sp.csr_matrix(A)
        m = self.matrix
        self.shape = m.shape
        self._rust = None
        if m.shape[0] % 3 == 0 and m.shape[1] % 3 == 0 and m.nnz:
            arrays = (m.shape[1], m.indptr.astype(np.int64), m.indices.astype(np.int64),
                      np.ascontiguousarray(m.data, dtype=np.float64))
            self._rust = _core.linalg.Blocked.from_csr("full", *arrays) or _core.linalg.Blocked.from_csr("kron", *arrays)

    @property
    def blocked(self) -> bool:
        """Whether the products run in Rust (the matrix is node-blocked)."""
        return self._rust is not None

    def __matmul__(self, x):
        return sum_of_products([(self, x)])


def _vector(x, n) -> bool:
    return isinstance(x, np.ndarray) and x.ndim == 1 and x.dtype == np.float64 and x.flags.c_contiguous and len(x) == n


def sum_of_products(terms) -> np.ndarray:
    """``A_0 @ x_0 + A_1 @ x_1 + ...`` for ``terms = [(A_0, x_0), ...]`` (:class:`Product` s or
    sparse matrices, and vectors), the same bits as ``r = A_0 @ x_0; r += A_1 @ x_1; ...``:
    one pass over the rows in Rust when every matrix is a node-blocked :class:`Product`."""
    if all(isinstance(A, Product) and A._rust is not None and _vector(x, A.shape[1]) for A, x in terms):
        out = np.empty(terms[0][0].shape[0])
        _core.linalg.sum_of_products([(A._rust, x) for A, x in terms], out)
        return out
    (A0, x0), *rest = terms
    r = _matrix(A0) @ x0
    for A, x in rest:
        r += _matrix(A) @ x
    return r


def _matrix(A):
    return A.matrix if isinstance(A, Product) else A


def check_symmetric(A, rtol: float = 1e-12) -> None:
    """Raises :class:`SolverError` naming the first entry (by column, then row) where ``A``
    (CSC, sorted, no duplicates) differs from its transpose, in structure or value.

    An entry stored on one side only counts as a zero on the other (so a matrix given by one
    triangle is refused: pass ``lower=True`` or ``upper=True`` to :func:`cholesky`). Values
    agree within ``rtol`` of the larger of the two and of sqrt(|a_ii a_jj|) (round-off of an
    assembly is relative to the diagonal entries the off-diagonal couples). One pass over
    the entries, vectorised: the transpose's CSC arrays are ``A``'s CSR arrays."""
    n = A.shape[0]
    T = A.tocsr()  # the CSC arrays of A^T, sorted
    T.sort_indices()
    d = np.abs(A.diagonal())
    if np.array_equal(A.indptr, T.indptr) and np.array_equal(A.indices, T.indices):
        cols = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr))
        rows = A.indices
        v, m = A.data, T.data
        scale = np.maximum(np.maximum(np.abs(v), np.abs(m)), np.sqrt(d[rows]) * np.sqrt(d[cols]))  # no overflow
        bad = np.abs(v - m) > rtol * scale
        if not bad.any():
            return
        k = int(np.flatnonzero(bad)[0])
        r, c, a, b = int(rows[k]), int(cols[k]), float(v[k]), float(m[k])
    else:
        D = (A - T.T).tocsc()  # A - A^T: the pattern differs, so entries exist on one side only
        D.sum_duplicates()
        cols = np.repeat(np.arange(n, dtype=np.int64), np.diff(D.indptr))
        rows = D.indices
        Acsr = A.tocsr()
        a_all = np.asarray(Acsr[rows, cols]).ravel()
        b_all = np.asarray(Acsr[cols, rows]).ravel()
        scale = np.maximum(np.maximum(np.abs(a_all), np.abs(b_all)), np.sqrt(d[rows]) * np.sqrt(d[cols]))
        bad = np.abs(a_all - b_all) > rtol * scale
        if not bad.any():
            return
        k = int(np.flatnonzero(bad)[0])
        r, c, a, b = int(rows[k]), int(cols[k]), float(a_all[k]), float(b_all[k])
    one_sided = sp.tril(A, k=-1).nnz == 0 or sp.triu(A, k=1).nnz == 0
    raise SolverError(
        f"matrix is not symmetric: entry ({r}, {c}) = {a:.17g} but ({c}, {r}) = {b:.17g}"
        + ("; the matrix seems to hold one triangle only: pass lower=True or upper=True to vfrs.cholesky "
           "to mirror it, or give both triangles" if one_sided else
           "; give a matrix symmetric in structure and values (e.g. (A + A.T) / 2)")
    )


def _finite_solution(x: np.ndarray, b) -> np.ndarray:
    if np.isfinite(x).all():  # one pass over the solution: cheap against the solve
        return x
    b = np.asarray(b, dtype=np.float64)
    if not np.isfinite(b).all():
        k = int(np.flatnonzero(~np.isfinite(b).reshape(len(b), -1).all(axis=1))[0])
        raise SolverError(f"right-hand side entry {k} is {b.reshape(len(b), -1)[k].tolist()}: it must be finite")
    k = int(np.flatnonzero(~np.isfinite(x).reshape(len(x), -1).all(axis=1))[0])
    raise SolverError(f"the solution overflows (entry {k} is {x.reshape(len(x), -1)[k].tolist()}): the matrix is "
                      "singular to working precision or badly scaled against the right-hand side; check its units "
                      "and that every body is held against rigid motion")


class Cholesky:
    """LL^T factorization of a sparse symmetric positive definite matrix.

    The symbolic analysis (ordering, elimination tree, supernodes) is done once;
    :meth:`refactor` recomputes only the numbers for a matrix of the same pattern.

    ``ordering``: ``"auto"`` (AMD or nested dissection, whichever fills less),
    ``"amd"``, ``"nested_dissection"``, ``"identity"``. ``A`` holds both triangles
    (``check_symmetry``: the first entry that differs from its mirror is named), or one of
    them with ``lower = True`` / ``upper = True`` (mirrored here).

    >>> import numpy as np, scipy.sparse as sp, vfrs
    >>> A = sp.csr_matrix(np.array([[4.0, 1.0], [1.0, 3.0]]))
    >>> f = vfrs.cholesky(A)
    >>> np.allclose(A @ f.solve(np.array([1.0, 2.0])), [1.0, 2.0])
    True
    """

    def __init__(self, A, ordering: str = "auto", parallel: bool = True, check_symmetry: bool = True,
                 lower: bool = False, upper: bool = False):
        if lower and upper:
            raise SolverError("give lower=True or upper=True (which triangle A holds), not both")
        self._triangle = "lower" if lower else ("upper" if upper else None)
        # Symmetry is checked here (check_symmetric names the entry and says when A holds one
        # triangle), at every (re)factorization; the core's own check would repeat it.
        self._check = check_symmetry
        n, indptr, indices, data = _csc_arrays(A, self._triangle, check_symmetry)
        self._f = _core.linalg.Cholesky(n, indptr, indices, data, ordering, parallel, False)
        self._indptr, self._indices = indptr, indices
        self._keys: np.ndarray | None = None
        #: How many numeric refactorizations this factor has had: what was computed with it
        #: (a compliance's columns) is stale when the number changes.
        self.version = 0

    def solve(self, b) -> np.ndarray:
        """Solves A x = b; ``b`` of shape (n,) or (n, k). A solution that overflows (or a
        right-hand side that is not finite) is a :class:`SolverError`, never inf/NaN."""
        x = self._f.solve(np.asarray(b, dtype=np.float64))
        return _finite_solution(x, b)

    def __call__(self, b):
        return self.solve(b)

    def unit_columns(self, rows) -> np.ndarray:
        """Columns ``A^-1 e_r`` for the indices ``rows``: an (n, len(rows)) array, the values of
        :meth:`solve` on the unit vectors (each column's bits do not depend on which others are
        solved with it), the forward substitution restricted to the supernodes the rows reach."""
        x = self._f.unit_columns(np.ascontiguousarray(rows, dtype=np.int64))
        return _finite_solution(x, np.zeros((len(x), 1)))

    def unit_columns_into(self, rows, out) -> np.ndarray:
        """:meth:`unit_columns` written into ``out``, a C-contiguous (len(rows), n) array whose
        row j becomes column j (a compliance's store: no temporary, no copy); returns
        ``out.T``, the (n, len(rows)) columns."""
        self._f.unit_columns_into(np.ascontiguousarray(rows, dtype=np.int64), out)
        return _finite_solution(out.T, np.zeros((self.n, 1)))

    def refactor(self, A) -> None:
        """Numeric refactorization with the values of ``A`` (same pattern as the first;
        the same triangle if the first was given by one)."""
        n, indptr, indices, data = _csc_arrays(A, self._triangle, self._check)
        if n != self.n:
            raise SolverError(f"refactor needs the same sparsity pattern as the first factorization: size {n} differs from {self.n}")
        if not (np.array_equal(indptr, self._indptr) and np.array_equal(indices, self._indices)):
            # scipy drops explicit zeros in arithmetic: accept any sub-pattern, scattered
            # into the analysed one.
            data = self._scatter(n, indptr, indices, data)
        self._f.refactor(data)
        self.version += 1

    def _scatter(self, n, indptr, indices, data):
        if self._keys is None:
            cols = np.repeat(np.arange(n, dtype=np.int64), np.diff(self._indptr))
            self._keys = cols * n + self._indices
        cols = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr))
        keys = cols * n + indices
        pos = np.minimum(np.searchsorted(self._keys, keys), len(self._keys) - 1)
        missing = self._keys[pos] != keys
        if missing.any():
            k = int(np.flatnonzero(missing)[0])
            raise SolverError(
                f"refactor needs the same sparsity pattern as the first factorization: entry "
                f"({int(indices[k])}, {int(cols[k])}) is not in it; factor the new matrix with vfrs.cholesky"
            )
        out = np.zeros(len(self._keys))
        out[pos] = data
        return out

    @property
    def n(self) -> int:
        return self._f.n

    @property
    def nnz_factor(self) -> int:
        """Stored entries of L (fill); a supernodal factor stores each supernode's diagonal
        block as a full square, so this exceeds :attr:`nnz_factor_lower`."""
        return self._f.nnz_factor

    @property
    def nnz_factor_lower(self) -> int:
        """Entries of L's lower triangle, what CHOLMOD reports as nnz(L)."""
        return self._f.nnz_factor_lower

    @property
    def ordering(self) -> str:
        return self._f.ordering

    def __repr__(self):
        return f"Cholesky(n={self.n}, nnz(L)={self.nnz_factor}, ordering={self.ordering!r})"


class DiagonalFactor:
    """The "factor" of a diagonal matrix (a lumped mass): solves are a division."""

    def __init__(self, A):
        d = np.asarray(sp.csr_matrix(A).diagonal(), dtype=np.float64)
        if not (np.all(np.isfinite(d)) and np.all(d > 0)):
            k = int(np.flatnonzero(~(np.isfinite(d) & (d > 0)))[0])
            raise SolverError(f"diagonal entry {k} is {d[k]}: the matrix is not positive definite")
        self._inv = 1.0 / d
        self.ordering = "diagonal"

    def solve(self, b) -> np.ndarray:
        b = np.asarray(b, dtype=np.float64)
        return _finite_solution(b * (self._inv if b.ndim == 1 else self._inv[:, None]), b)

    def __call__(self, b):
        return self.solve(b)

    @property
    def n(self) -> int:
        return len(self._inv)

    @property
    def nnz_factor(self) -> int:
        return len(self._inv)


class BlockCholesky:
    """A block-diagonal SPD matrix (bodies that share no DOF) factored block by block, its
    solves run concurrently, one thread per block (the Rust solves release the GIL). ``blocks``
    are contiguous index ranges (slices) covering 0..n in order."""

    _pool: "ThreadPoolExecutor | None" = None

    def __init__(self, A, blocks, ordering: str = "auto", parallel: bool = True):
        A = sp.csr_matrix(A)
        self.blocks = list(blocks)
        self.factors = [Cholesky(A[b, b], ordering=ordering, parallel=parallel) for b in self.blocks]
        self.n = A.shape[0]
        if BlockCholesky._pool is None:
            import os

            BlockCholesky._pool = ThreadPoolExecutor(max_workers=max(2, min(8, os.cpu_count() or 2)),
                                                     thread_name_prefix="vfrs-block-solve")

    #: Blocks smaller than this are solved one after the other: below it a thread hand-off
    #: costs more than the solve saves (docs/performance.md).
    concurrent_min = 5000

    def solve(self, b) -> np.ndarray:
        """Solves A x = b (b of shape (n,) or (n, k)), the blocks concurrently."""
        b = np.asarray(b, dtype=np.float64)
        out = np.empty_like(b)
        if min(blk.stop - blk.start for blk in self.blocks) < self.concurrent_min:
            for f, blk in zip(self.factors, self.blocks):
                out[blk] = f.solve(b[blk])
            return out
        pool = self._pool
        assert pool is not None  # made in __init__
        futures = [pool.submit(f.solve, b[blk]) for f, blk in zip(self.factors[1:], self.blocks[1:])]
        out[self.blocks[0]] = self.factors[0].solve(b[self.blocks[0]])
        for fut, blk in zip(futures, self.blocks[1:]):
            out[blk] = fut.result()
        return out

    def __call__(self, b):
        return self.solve(b)

    def refactor(self, A) -> None:
        A = sp.csr_matrix(A)
        for f, blk in zip(self.factors, self.blocks):
            f.refactor(A[blk, blk])

    @property
    def version(self) -> int:
        """Numeric refactorizations so far (see :attr:`Cholesky.version`)."""
        return sum(f.version for f in self.factors)

    @property
    def nnz_factor(self) -> int:
        return sum(f.nnz_factor for f in self.factors)

    @property
    def ordering(self) -> str:
        return self.factors[0].ordering

    def __repr__(self):
        return f"BlockCholesky(n={self.n}, blocks={[b.stop - b.start for b in self.blocks]}, nnz(L)={self.nnz_factor})"


def diagonal_blocks(A) -> list:
    """The contiguous index ranges of the diagonal blocks of ``A``'s pattern: the finest
    split of 0..n into ranges that no stored entry couples (one range when none splits).

    An entry (i, j) ties together every split point k with min(i, j) < k <= max(i, j): the
    ranges are what no entry ties (one pass over the entries; scipy's graph components would
    cost an import on every run). Bodies that share no DOF, numbered one after the other,
    are one range each; bodies whose DOFs interleave are one range together.

    >>> import scipy.sparse as sp
    >>> diagonal_blocks(sp.block_diag([np.ones((2, 2)), np.ones((3, 3))]))
    [slice(0, 2, None), slice(2, 5, None)]
    """
    A = sp.csr_matrix(A)
    n = A.shape[0]
    rows = np.repeat(np.arange(n), np.diff(A.indptr))
    lo, hi = np.minimum(rows, A.indices), np.maximum(rows, A.indices)
    tie = lo < hi
    # Entries tying (lo, hi]: +1 at lo + 1, -1 at hi + 1; a split point k is free where the
    # running count is zero.
    ties = np.cumsum(np.bincount(lo[tie] + 1, minlength=n + 2) - np.bincount(hi[tie] + 1, minlength=n + 2))
    cuts = np.flatnonzero(ties[1:n] == 0) + 1
    bounds = np.r_[0, cuts, n]
    return [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def cholesky(A, ordering: str = "auto", parallel: bool = True, blocks: bool = False,
             lower: bool = False, upper: bool = False):
    """Factorizes ``A`` (see :class:`Cholesky`). ``blocks = True``: a block-diagonal ``A``
    (several bodies that share no DOF) is factored block by block and solved with the blocks
    running concurrently (:class:`BlockCholesky`); a diagonal ``A`` gets a
    :class:`DiagonalFactor`.

    ``A`` must hold both triangles of a symmetric matrix (checked: the first entry that differs
    from its mirror is named in a :class:`~vfrs.errors.SolverError`), unless ``lower = True``
    or ``upper = True`` says it holds one triangle (the other is ignored and mirrored)."""
    if lower and upper:
        raise SolverError("give lower=True or upper=True (which triangle A holds), not both")
    if (lower or upper) and blocks:
        n, indptr, indices, data = _csc_arrays(A, "lower" if lower else "upper")
        A, lower, upper = sp.csc_matrix((data, indices, indptr), shape=(n, n)), False, False
    if blocks:
        A = sp.csr_matrix(A)
        if A.nnz == A.shape[0] and np.array_equal(A.indices, np.arange(A.shape[0])):
            return DiagonalFactor(A)
        parts = diagonal_blocks(A)
        if len(parts) > 1:
            return BlockCholesky(A, parts, ordering=ordering, parallel=parallel)
    return Cholesky(A, ordering=ordering, parallel=parallel, lower=lower, upper=upper)


class DofMap:
    """Dirichlet conditions by elimination: a map from all DOFs to the free ones.

    >>> import numpy as np, vfrs
    >>> d = vfrs.DofMap(6, fixed=[0, 1, 2])
    >>> d.free.tolist()
    [3, 4, 5]
    >>> d.expand(np.ones(3)).tolist()
    [0.0, 0.0, 0.0, 1.0, 1.0, 1.0]
    """

    def __init__(self, n_dofs: int, fixed):
        if isinstance(n_dofs, bool) or not isinstance(n_dofs, (int, np.integer)) or n_dofs < 0:
            raise SolverError(f"n_dofs must be an integer >= 0, got {n_dofs!r}")
        raw = np.asarray(fixed)
        if raw.size and not np.issubdtype(raw.dtype, np.integer):
            raise SolverError(f"fixed DOFs must be integers, got dtype {raw.dtype}")
        fixed = np.unique(raw.astype(np.int64).ravel())
        if fixed.size and (fixed[0] < 0 or fixed[-1] >= n_dofs):
            bad = int(fixed[0]) if fixed[0] < 0 else int(fixed[-1])
            raise SolverError(f"fixed DOF {bad} is out of range 0..{int(n_dofs) - 1} (the DOF map has {int(n_dofs)} DOFs)")
        self._m = _core.linalg.DofMap(int(n_dofs), fixed)
        self.n_dofs = int(n_dofs)
        self.fixed = fixed
        self.free = self._m.free
        self._cache: tuple[tuple[bytes, bytes], tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None

    @property
    def n_free(self) -> int:
        return len(self.free)

    def reduce(self, A) -> sp.csr_matrix:
        """The free-free block A_ff (pattern computed once per source pattern, then a gather)."""
        n, indptr, indices, data = _csc_arrays(A)
        if n != self.n_dofs:
            raise SolverError(f"matrix has {n} rows, the DOF map {self.n_dofs}")
        key = (indptr.tobytes(), indices.tobytes())
        if self._cache is None or self._cache[0] != key:
            self._cache = (key, self._m.reduce_pattern(indptr, indices))
        cp, ri, src = self._cache[1]
        return sp.csc_matrix((data[src], ri, cp), shape=(self.n_free, self.n_free)).tocsr()

    def restrict(self, v) -> np.ndarray:
        """Free entries of a full vector (or rows of a full (n, k) array)."""
        return np.asarray(v)[self.free]

    def expand(self, v_free, fixed_values=None) -> np.ndarray:
        """Full vector from free values; fixed DOFs get ``fixed_values`` (default 0)."""
        v_free = np.asarray(v_free, dtype=np.float64)
        out = np.zeros((self.n_dofs,) + v_free.shape[1:])
        if fixed_values is not None:
            out[self.fixed] = np.asarray(fixed_values, dtype=np.float64)
        out[self.free] = v_free
        return out
