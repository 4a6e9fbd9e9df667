"""Sparse Cholesky (faer) and Dirichlet elimination."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import vfrs


@pytest.fixture(scope="module")
def system():
    mesh = vfrs.meshes.box((0.02, 0.004, 0.004), (12, 3, 3), jitter=0.2, seed=1)
    K = vfrs.stiffness(mesh, vfrs.Isotropic(E=10e3, nu=0.45))
    fixed = (3 * mesh.surface_nodes("xmin")[:, None] + np.arange(3)).ravel()
    dofs = vfrs.DofMap(mesh.n_dofs, fixed)
    return mesh, K, dofs


@pytest.mark.parametrize("ordering", ["auto", "amd", "nested_dissection", "identity"])
def test_solve_residual_is_round_off(system, ordering):
    _, K, dofs = system
    A = dofs.reduce(K)
    f = vfrs.cholesky(A, ordering=ordering)
    rng = np.random.default_rng(0)
    b = rng.standard_normal(A.shape[0])
    x = f.solve(b)
    assert np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b)
    B = rng.standard_normal((A.shape[0], 3))
    X = f.solve(B)
    assert X.shape == B.shape
    assert np.linalg.norm(A @ X - B) <= 1e-10 * np.linalg.norm(B)
    # Same answer as scipy's LU.
    assert np.allclose(x, spla.spsolve(A.tocsc(), b), rtol=1e-8, atol=0)


def test_refactor_equals_a_new_factorization(system):
    _, K, dofs = system
    A = dofs.reduce(K)
    A2 = (A * 2.0 + sp.identity(A.shape[0]) * 1e3).tocsr()
    f = vfrs.cholesky(A)
    f.refactor(A2)
    b = np.arange(A.shape[0], dtype=float)
    # Same pattern: bit-identical to a fresh factorization.
    A2_same = A.copy()
    A2_same.data = A2_same.data * 2.0 + (A2_same.indices == np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))) * 1e3
    f.refactor(A2_same)
    assert np.array_equal(f.solve(b), vfrs.cholesky(A2_same).solve(b))
    # scipy's arithmetic drops explicit zeros: the sub-pattern is scattered, same numbers.
    f.refactor(A2)
    g = vfrs.cholesky(A2)
    assert np.allclose(f.solve(b), g.solve(b), rtol=1e-10, atol=0)
    assert np.linalg.norm(A2 @ f.solve(b) - b) <= 1e-10 * np.linalg.norm(b)


def test_cholesky_errors_are_clear(system):
    _, K, dofs = system
    with pytest.raises(vfrs.SolverError, match="not positive definite.*Dirichlet"):
        vfrs.cholesky(K)  # rigid-body motions free
    A = dofs.reduce(K)
    f = vfrs.cholesky(A)
    with pytest.raises(vfrs.SolverError, match=r"entry \(\d+, \d+\) is not in it"):
        f.refactor(A + sp.csr_matrix(([1.0, 1.0], ([0, A.shape[0] - 1], [A.shape[0] - 1, 0])), shape=A.shape))
    with pytest.raises(vfrs.SolverError, match="size"):
        f.refactor(sp.identity(A.shape[0] + 3, format="csr"))
    # A sub-pattern (here: only the diagonal) is fine.
    f.refactor(sp.diags(A.diagonal()).tocsr())
    assert np.allclose(f.solve(np.ones(A.shape[0])), 1 / A.diagonal())
    with pytest.raises(ValueError, match="rows"):
        f.solve(np.ones(A.shape[0] + 1))
    with pytest.raises(ValueError, match="non-finite"):
        f.solve(np.full(A.shape[0], np.nan))
    nonsym = A.tolil()
    nonsym[0, 1] += 1.0
    with pytest.raises(vfrs.SolverError, match=r"not symmetric: entry \(1, 0\)"):
        vfrs.cholesky(nonsym.tocsr())
    with pytest.raises(vfrs.SolverError, match="square"):
        vfrs.cholesky(sp.csr_matrix((3, 4)))
    with pytest.raises(vfrs.SolverError, match="scipy.sparse"):
        vfrs.cholesky(np.eye(3))
    with pytest.raises(ValueError, match='unknown ordering "metis"' ):
        vfrs.cholesky(A, ordering="metis")


def test_dirichlet_elimination_solves_the_constrained_problem(system):
    """Solving the reduced system with a prescribed displacement equals solving the full
    system with the constraint imposed by a very stiff spring: checks reduce/expand."""
    mesh, K, dofs = system
    n = mesh.n_dofs
    g = np.zeros(n)
    g[dofs.fixed] = 1e-4 * np.sin(np.arange(len(dofs.fixed)))
    f_ext = np.zeros(n)
    f_ext[3 * mesh.surface_nodes("xmax") + 1] = 1e-3
    A = dofs.reduce(K)
    rhs = dofs.restrict(f_ext - K @ g)
    u = dofs.expand(vfrs.cholesky(A).solve(rhs), fixed_values=g[dofs.fixed])
    assert np.allclose(u[dofs.fixed], g[dofs.fixed])
    r = K @ u - f_ext
    assert np.abs(r[dofs.free]).max() <= 1e-9 * np.abs(f_ext).max()
    with pytest.raises(vfrs.SolverError, match="out of range"):
        vfrs.DofMap(6, [6])


def test_round_off_asymmetry_of_tiny_entries_is_accepted():
    """Entries that should vanish come out of assembly at round-off level with mirrors that
    differ by as much; symmetry is judged against the diagonal they couple, not themselves."""
    m = vfrs.meshes.hemisphere(0.01, cells=20)
    K = vfrs.stiffness(m, vfrs.Isotropic(E=1e4, nu=0.3, rho=1000))
    A = (K + sp.identity(K.shape[0]) * 1e-3 * abs(K).max()).tocsr()
    f = vfrs.cholesky(A)
    b = np.ones(A.shape[0])
    assert np.linalg.norm(A @ f.solve(b) - b) <= 1e-9 * np.linalg.norm(b)


def test_unit_columns_are_the_solves_of_unit_vectors_whatever_the_batch():
    """Cholesky.unit_columns (the compliance's columns A^-1 e_r, forward pass only on the
    supernodes the rows reach) gives the dense solve's values, and a column's bits do not
    depend on which other columns are solved with it (so prefetching and batching of the
    contact compliance never change a result)."""
    import vfrs

    rng = np.random.default_rng(2)
    n = 600
    A = sp.random(n, n, density=0.01, random_state=3)
    A = (A + A.T + sp.identity(n) * 5.0).tocsr()
    f = vfrs.cholesky(A)
    rows = rng.choice(n, 13, replace=False)
    X = f.unit_columns(rows)
    E = np.zeros((n, 13))
    E[rows, np.arange(13)] = 1.0
    dense = f.solve(E)
    assert np.array_equal(X, dense)  # == ignores the sign of zeros
    for k in (0, 5, 12):
        assert f.unit_columns(rows[[k]])[:, 0].tobytes() == X[:, k].tobytes()
        assert f.unit_columns(rows[k:])[:, 0].tobytes() == X[:, k].tobytes()
    assert np.abs(A @ X - E).max() < 1e-12
    # Into a store's rows (C-contiguous (k, n), overwritten: the ones must not survive).
    store = np.ones((20, n))
    assert f.unit_columns_into(rows, store[3:16]).tobytes() == X.tobytes()
    assert store[3:16].T.tobytes() == np.asfortranarray(X).tobytes() and (store[:3] == 1).all()
    with pytest.raises(ValueError, match=r"expected \(13, 600\)"):
        f.unit_columns_into(rows, np.zeros((12, n)))
    with pytest.raises(ValueError, match="C-contiguous"):
        f.unit_columns_into(rows, np.zeros((n, 13)).T)
    with pytest.raises(ValueError, match="out of range"):
        f.unit_columns_into(np.array([n]), np.zeros((1, n)))


def test_diagonal_blocks_are_the_ranges_no_entry_couples():
    """Every split of diagonal_blocks is one no stored entry crosses, and no finer split is:
    on bodies numbered one after the other, scipy's connected components (what it replaced)."""
    from scipy.sparse.csgraph import connected_components

    from vfrs.linalg import diagonal_blocks

    rng = np.random.default_rng(3)
    for trial in range(20):
        sizes = rng.integers(1, 9, size=rng.integers(1, 6))
        parts = []
        for m in sizes:  # connected: a path plus random symmetric entries
            B = sp.diags([np.ones(m - 1), 2 * np.ones(m), np.ones(m - 1)], [-1, 0, 1]).tolil()
            for _ in range(m):
                i, j = rng.integers(0, m, size=2)
                B[i, j] = B[j, i] = 1.0
            parts.append(B)
        A = sp.block_diag(parts, format="lil")
        n = A.shape[0]
        if trial % 3 == 1 and len(sizes) > 2:  # couple the first and the last body
            A[0, n - 1] = A[n - 1, 0] = 1.0
        A = A.tocsr()
        blocks = diagonal_blocks(A)
        assert blocks[0].start == 0 and blocks[-1].stop == n
        assert all(a.stop == b.start for a, b in zip(blocks, blocks[1:]))
        label = np.repeat(np.arange(len(blocks)), [b.stop - b.start for b in blocks])
        r, c = A.nonzero()
        assert (label[r] == label[c]).all(), "an entry couples two blocks"
        n_comp, comp = connected_components(A, directed=False)
        if trial % 3 == 1 and len(sizes) > 2:
            assert len(blocks) == 1  # the coupling spans every split point
        else:
            assert len(blocks) == n_comp == len(sizes)
            assert (np.diff(comp) != 0).sum() == len(blocks) - 1
