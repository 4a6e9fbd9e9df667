"""The compliance columns give A^-1 f without a solve, for forces on few DOFs.

The contact correction and the stabilized predictor move the whole field by products with the
loaded DOFs' columns (kept over the rows of their own block), not by a forward/back
substitution: these products must equal the solve to round-off, block by block, and a
checkpoint must carry them so a resumed run computes the same bits.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

from vfrs.enforcement.compliance_matrix import Compliance
from vfrs.linalg import cholesky


def _block(n, seed):
    """An SPD sparse block (a shifted 1-D Laplacian plus random symmetric couplings)."""
    rng = np.random.default_rng(seed)
    A = sp.diags([-np.ones(n - 1), 2.5 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="lil")
    for _ in range(n):
        i, j = rng.integers(0, n, 2)
        if i != j:
            w = 0.1 * rng.random()
            A[i, j] -= w
            A[j, i] -= w
            A[i, i] += w
            A[j, j] += w
    return sp.csr_matrix(A)


@pytest.mark.parametrize("blocks", [(300,), (300, 200), (5200, 5100)])
def test_products_equal_the_solve(blocks):
    A = sp.block_diag([_block(n, k) for k, n in enumerate(blocks)], format="csr")
    n = A.shape[0]
    factor = cholesky(A, blocks=True)
    assert len(getattr(factor, "factors", [factor])) == len(blocks)
    # Free DOFs: every DOF but the first two (fixed ones are mapped out).
    n_dofs = n + 2
    free = np.arange(2, n_dofs)
    rng = np.random.default_rng(7)
    observed = rng.choice(free, size=min(120, n // 2), replace=False)
    comp = Compliance(factor, free, n_dofs, observed=observed, chunk=16)
    support = rng.choice(np.searchsorted(free, observed), size=25, replace=False)
    B = np.zeros((n, 2))
    B[support] = rng.standard_normal((25, 2))
    X = comp.solve(B)
    ref = factor.solve(B)
    assert np.abs(X - ref).max() <= 1e-12 * np.abs(ref).max()
    # One column alone, with support in the first block only: other blocks exactly zero.
    b = np.zeros(n)
    first = support[support < blocks[0]]
    b[first] = 1.0
    x = comp.solve(b)
    assert np.abs(x - factor.solve(b)).max() <= 1e-12 * np.abs(x).max()
    assert not x[blocks[0]:].any()
    # The observed rows (response) agree with the full columns.
    f_full = np.zeros(n_dofs)
    f_full[free[support]] = B[support, 0]
    r = comp.response(f_full)
    assert np.abs(r - ref[np.searchsorted(free, comp.observed), 0]).max() <= 1e-12 * np.abs(ref).max()
    # A checkpoint carries the columns: the restored compliance gives the same bits.
    again = Compliance(factor, free, n_dofs, observed=observed, chunk=16)
    again.restore(comp.state())
    assert np.array_equal(again.solve(B), X)
    assert again.solves == comp.solves == len(np.unique(support))
    # Only the blocks holding a loaded DOF were solved for: the columns cost k, not k x blocks,
    # and the memory counted is that of the stored columns (each over its own block).
    sizes = [blk.stop - blk.start for blk, _ in comp._blocks]
    stored = np.searchsorted(free, comp.dofs)
    assert sum(comp._F_count) == comp.size == len(np.unique(support))
    assert comp._stored_bytes() == sum(8 * sizes[comp.block_of[r]] for r in stored)
    assert comp.nbytes >= comp._stored_bytes()


def test_refactored_factor_drops_the_columns():
    A = sp.block_diag([_block(200, 1), _block(150, 2)], format="csr")
    factor = cholesky(A, blocks=True)
    comp = Compliance(factor, np.arange(350), 350, observed=np.arange(0, 350, 5))
    b = np.zeros(350)
    b[[0, 5, 200]] = [1.0, -2.0, 0.5]
    comp.solve(b)
    factor.refactor(2.0 * A)
    x = comp.solve(b)
    assert comp.resets == 1
    assert np.abs(x - 0.5 * np.asarray(sp.linalg.spsolve(A.tocsc(), b))).max() <= 1e-12 * np.abs(x).max()


def test_a_checkpoint_without_full_columns_starts_them_again():
    """A checkpoint of the version that kept only the contact-surface rows (no "F") restores
    to an empty compliance that computes its columns again, equal to the solve."""
    A = sp.block_diag([_block(200, 3), _block(150, 4)], format="csr")
    factor = cholesky(A, blocks=True)
    comp = Compliance(factor, np.arange(350), 350, observed=np.arange(0, 350, 5))
    b = np.zeros(350)
    b[[5, 200]] = [1.0, -0.5]
    comp.solve(b)
    old = {k: v for k, v in comp.state().items() if k not in ("F", "F_capacity")}
    again = Compliance(factor, np.arange(350), 350, observed=np.arange(0, 350, 5))
    again.restore(old)
    assert again.size == 0 and again.resets == 1
    x = again.solve(b)
    assert np.abs(x - factor.solve(b)).max() <= 1e-12 * np.abs(x).max()


def test_a_memory_cap_keeps_the_products_exact_and_the_columns_within_it():
    """Past ``max_bytes`` a block stores no more columns and products loading them solve:
    the numbers still equal the solve, the stored columns stay under the cap, a warning says
    so once, and a checkpoint of a capped compliance restores to the same bits."""
    from vfrs.errors import VfrsWarning

    blocks = (300, 200)
    A = sp.block_diag([_block(n, k) for k, n in enumerate(blocks)], format="csr")
    n = A.shape[0]
    factor = cholesky(A, blocks=True)
    free = np.arange(n)
    observed = np.arange(0, n, 2)
    cap = 8 * 300 * 70  # 70 columns of the first block (64 fit the first allocation)
    comp = Compliance(factor, free, n, observed=observed, chunk=16, max_bytes=cap)
    rng = np.random.default_rng(3)
    B = np.zeros((n, 2))
    first = rng.choice(observed[observed < 300], size=60, replace=False)
    B[first] = rng.standard_normal((60, 2))
    X = comp.solve(B)  # 60 columns: stored (a product), under the cap
    assert not comp.capped and comp.fallback_solves == 0
    assert np.abs(X - factor.solve(B)).max() <= 1e-12 * np.abs(X).max()
    more = rng.choice(np.setdiff1d(observed[observed < 300], first), size=30, replace=False)
    B2 = np.zeros((n, 1))
    B2[more, 0] = 1.0
    B2[310, 0] = -0.5  # the second block: its columns still fit
    with pytest.warns(VfrsWarning, match="column_memory"):
        X2 = comp.solve(B2)
    assert comp.capped and comp.fallback_solves == 1
    assert np.abs(X2 - factor.solve(B2)).max() <= 1e-12 * np.abs(X2).max()
    assert comp._stored_bytes() <= cap
    # The capped block keeps its first columns: a product over them needs no solve.
    assert np.abs(comp.solve(B) - X).max() <= 1e-12 * np.abs(X).max() and comp.fallback_solves == 1
    # The surface response (observed rows) covers every column, stored over its block or not.
    f_full = np.zeros(n)
    f_full[more] = 1.0
    assert np.abs(comp.response(f_full) - factor.solve(f_full)[observed]).max() <= 1e-12
    again = Compliance(factor, free, n, observed=observed, chunk=16, max_bytes=cap)
    again.restore(comp.state())
    assert again.capped and again.fallback_solves == 1
    assert np.array_equal(again.solve(B), comp.solve(B))
    assert np.array_equal(again.solve(B2), comp.solve(B2))


def test_prefetched_columns_give_the_same_products_with_fewer_solves():
    """With ``prefetch`` (here: the DOFs within 8 of each new one), a request for new DOFs
    solves for their neighbours too: later requests near them need no solve, the products
    equal the solve to round-off as before, and a prefetch that names unobserved, fixed or
    out-of-range DOFs only gets the observed free ones."""
    A = sp.block_diag([_block(400, 1), _block(300, 2)], format="csr")
    n = A.shape[0]
    factor = cholesky(A, blocks=True)
    n_dofs = n + 2
    free = np.arange(2, n_dofs)
    observed = np.arange(2, n_dofs, 2)  # every other DOF
    asked = []

    def nearby(dofs):
        asked.append(len(dofs))
        return np.concatenate([np.arange(d - 8, d + 9) for d in dofs] + [np.array([-5, 0, 1, n_dofs + 9])])

    plain = Compliance(factor, free, n_dofs, observed=observed)
    ahead = Compliance(factor, free, n_dofs, observed=observed, prefetch=nearby)
    rng = np.random.default_rng(3)
    for start in (100, 104, 108, 112, 500, 504):
        f = np.zeros(n_dofs)
        f[[start, start + 2]] = rng.standard_normal(2)
        for comp in (plain, ahead):
            x = comp.solve(f[free])
            ref = factor.solve(f[free])
            assert np.abs(x - ref).max() <= 1e-12 * np.abs(ref).max()
            assert np.abs(comp.response(f) - ref[np.searchsorted(free, comp.observed)]).max() <= 1e-12 * np.abs(ref).max()
    # Plain: every request solves (12 columns). Prefetched: 100 brings 92-110 (so 104 and 108
    # need nothing), 112 brings more, 500 brings 504: three solves.
    assert plain.solves == 12 and len(asked) == 3 and ahead.solves > plain.solves
    assert set(ahead.dofs.tolist()) <= set(observed.tolist())
    assert ahead.size > plain.size


def test_a_checkpoint_with_all_observed_rows_in_one_array_restores():
    """Checkpoints written before the observed rows were kept block by block hold them as one
    (observed DOFs x columns) array "X": restoring one gives the same responses, bit for bit,
    as the compliance that wrote it."""
    A = sp.block_diag([_block(300, 1), _block(200, 2)], format="csr")
    n = A.shape[0]
    factor = cholesky(A, blocks=True)
    n_dofs = n + 2
    free = np.arange(2, n_dofs)
    observed = np.arange(2, n_dofs, 3)
    comp = Compliance(factor, free, n_dofs, observed=observed)
    comp.ensure(observed[[3, 50, 90, 150]])
    comp.ensure(observed[[4, 120]])
    state = comp.state()
    full = np.zeros((len(comp.observed), comp.size))
    for b, at in enumerate(comp._obs_at):
        mine = comp.dofs[comp.block_of[comp.pos_free[comp.dofs]] == b]
        full[np.ix_(at, comp.col_of[mine])] = state["Xb"][b].T
    legacy = {k: v for k, v in state.items() if k != "Xb"}
    legacy["X"] = full
    again = Compliance(factor, free, n_dofs, observed=observed)
    again.restore(legacy)
    f = np.zeros(n_dofs)
    f[observed[[3, 4, 120]]] = [1.0, -2.0, 0.5]
    assert again.response(f).tobytes() == comp.response(f).tobytes()


def test_more_new_columns_than_a_chunk_in_two_concurrent_blocks():
    """A request with more new DOFs than ``chunk`` in each of two blocks big enough to be
    solved concurrently (a prefetch can ask for hundreds): each block's chunks are solved one
    after the other by one thread (a factor is never used by two at once: pyo3 refused
    that with "Already borrowed"), and the columns equal the solve."""
    A = sp.block_diag([_block(5200, 1), _block(5100, 2)], format="csr")
    n = A.shape[0]
    factor = cholesky(A, blocks=True)
    free = np.arange(n)
    comp = Compliance(factor, free, n, observed=free, chunk=8)
    assert comp._pool is not None
    dofs = np.r_[np.arange(100, 130), np.arange(5300, 5331)]
    comp.ensure(dofs)
    f = np.zeros(n)
    f[dofs] = np.linspace(1.0, 2.0, len(dofs))
    ref = factor.solve(f)
    assert np.abs(comp.solve(f) - ref).max() <= 1e-12 * np.abs(ref).max()


def test_the_chunk_size_changes_no_bit():
    """How many right-hand sides a block solve takes (``chunk``) is a matter of speed only:
    the columns, S (symmetrised across chunks as within one) and the observed rows have the
    same bits for any chunk. Before, an entry of S between two DOFs of different chunks of
    the same request took the later chunk's column instead of the mean of both, and the main
    job's history changed with the chunk."""
    A = sp.block_diag([_block(900, 3), _block(700, 4)], format="csr")
    n = A.shape[0]
    factor = cholesky(A, blocks=True)
    free = np.arange(n)
    rng = np.random.default_rng(11)
    observed = rng.choice(free, size=300, replace=False)
    first, second = observed[:90], observed[90:200]
    comps = []
    for chunk in (4, 7, 64, 1000):
        comp = Compliance(factor, free, n, observed=observed, chunk=chunk)
        comp.ensure(first)
        comp.ensure(second)  # new DOFs beside old ones
        comps.append(comp)
    ref = comps[-1]
    m = ref.size
    assert np.array_equal(ref._S[:m, :m], ref._S[:m, :m].T)
    for comp in comps[:-1]:
        assert np.array_equal(comp.dofs, ref.dofs)
        assert comp._S[:m, :m].tobytes() == ref._S[:m, :m].tobytes(), comp.chunk
        for b in range(2):
            assert comp._F[b][: comp._F_count[b]].tobytes() == ref._F[b][: ref._F_count[b]].tobytes()
            assert comp._Xb[b][: comp._X_count[b]].tobytes() == ref._Xb[b][: ref._X_count[b]].tobytes()


def test_a_growing_store_keeps_every_chunk():
    """Without observed DOFs a block's store grows as columns come; the columns are solved
    straight into it, so every chunk's slots must be taken after the last growth (a view
    of the store before it would receive a chunk's columns and be dropped)."""
    A = sp.block_diag([_block(900, 3), _block(700, 4)], format="csr")
    n = A.shape[0]
    factor = cholesky(A, blocks=True)
    comp = Compliance(factor, np.arange(n), n, chunk=8)
    dofs = np.r_[np.arange(10, 150), np.arange(1000, 1100)]
    comp.ensure(dofs[:30])
    comp.ensure(dofs)  # 210 more columns: both stores grow
    b = np.zeros(n)
    b[dofs] = np.linspace(1.0, 2.0, len(dofs))
    ref = factor.solve(b)
    assert np.abs(comp.solve(b) - ref).max() <= 1e-12 * np.abs(ref).max()


def test_single_precision_columns_round_the_products_once_and_halve_the_memory():
    """``dtype`` float32 ([contact] column_precision = "single"): a product equals the solve to
    the rounding of the columns (relative 6e-8 of the largest entry, bound 2e-7 here); S and the
    observed rows stay float64 and equal the double-precision compliance's bit for bit; the
    columns take half the bytes, so a cap holds twice as many; a checkpoint restores the same
    bits. Anything but float32/float64 is refused."""
    from vfrs.errors import SolverError

    blocks = (300, 200)
    A = sp.block_diag([_block(n, k) for k, n in enumerate(blocks)], format="csr")
    n = A.shape[0]
    factor = cholesky(A, blocks=True)
    free, observed = np.arange(n), np.arange(0, n, 2)
    rng = np.random.default_rng(5)
    B = np.zeros((n, 2))
    loaded = rng.choice(observed, size=60, replace=False)
    B[loaded] = rng.standard_normal((60, 2))
    double = Compliance(factor, free, n, observed=observed, chunk=16)
    single = Compliance(factor, free, n, observed=observed, chunk=16, dtype=np.float32)
    ref, X = double.solve(B), single.solve(B)
    err = np.abs(X - ref).max() / np.abs(ref).max()
    assert 0 < err <= 2e-7
    assert single._stored_bytes() * 2 == double._stored_bytes()
    f_full = np.zeros(n)
    f_full[loaded] = 1.0
    assert np.array_equal(single.response(f_full), double.response(f_full))
    assert np.array_equal(single._S, double._S)
    again = Compliance(factor, free, n, observed=observed, chunk=16, dtype=np.float32)
    again.restore(single.state())
    assert np.array_equal(again.solve(B), X)
    cap = 8 * 300 * 40  # 40 double columns of the first block: 80 single ones
    capped = [Compliance(factor, free, n, observed=observed, chunk=16, max_bytes=cap, dtype=d)
              for d in (np.float64, np.float32)]
    first = observed[observed < 300][:70]
    for comp in capped:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            comp.solve(np.isin(np.arange(n), first).astype(float))
    assert capped[0].capped and not capped[1].capped
    with pytest.raises(SolverError, match="float64 or float32"):
        Compliance(factor, free, n, observed=observed, dtype=np.float16)
