"""The small dense contact solvers (vfrs.enforcement.lcp, as the methods call it): KKT conditions, penalty -> Lagrange, bounded conditioning."""

import numpy as np
import pytest

from vfrs.enforcement import lcp
from vfrs.enforcement.base import SolveInfo


def lagrange(W, g0, **options):
    """The LCP lam >= 0, g = g0 + W lam >= 0, lam . g = 0, reported as the methods report it."""
    lam, info = lcp.lagrange(np.asarray(W, dtype=float), np.asarray(g0, dtype=float), **options)
    return lam, SolveInfo.of(info)


def penalty(W, g0, kappa, **options):
    """lam_i = max(0, shift_i - kappa_i g_i), g = g0 + W lam."""
    lam, info = lcp.penalty(np.asarray(W, dtype=float), np.asarray(g0, dtype=float), kappa, **options)
    return lam, SolveInfo.of(info)


def problem(m=12, seed=0):
    rng = np.random.default_rng(seed)
    B = rng.standard_normal((m, m))
    W = B @ B.T / m * 1e-6 + 1e-9 * np.eye(m)  # compliance-like scale (m/N)
    g0 = rng.uniform(-1e-5, 1e-5, m)  # some penetrating, some open
    return W, g0


@pytest.mark.parametrize("seed", range(5))
def test_lagrange_satisfies_the_kkt_conditions(seed):
    W, g0 = problem(seed=seed)
    lam, info = lagrange(W, g0)
    g = g0 + W @ lam
    assert info.converged and not info.cycle
    scale = np.abs(g0).max()
    assert (lam >= 0).all()
    assert g.min() > -1e-10 * scale
    assert np.abs(lam * g).max() <= 1e-10 * scale * lam.max()


def test_penalty_tends_to_lagrange_as_one_over_kappa():
    W, g0 = problem(seed=3)
    lam_l, _ = lagrange(W, g0)
    errors, conds = [], []
    for k in (1e8, 1e10, 1e12, 1e14):  # 1/kappa well below W: the asymptotic range
        lam, info = penalty(W, g0, np.full(len(g0), k))
        errors.append(np.abs(lam - lam_l).max() / np.abs(lam_l).max())
        conds.append(info.condition)
    slopes = np.diff(np.log10(errors))
    assert np.all(np.abs(slopes + 2) < 0.3), errors  # two decades of kappa, two of error
    assert max(conds) < 2 * conds[-1] < 1e6  # bounded, not growing with kappa


def test_shifted_penalty_is_the_uzawa_step():
    W, g0 = problem(seed=4)
    kappa = np.full(len(g0), 1e7)
    shift = np.abs(np.random.default_rng(1).standard_normal(len(g0)))
    lam, _ = penalty(W, g0, kappa, shift=shift)
    g = g0 + W @ lam
    assert np.allclose(lam, np.maximum(0.0, shift - kappa * g), rtol=1e-9, atol=1e-12 * shift.max())


def test_not_settling_is_reported():
    W, g0 = problem(m=30, seed=5)
    lam, info = lagrange(W, g0, max_iterations=1)
    assert not info.converged and "not settled in 1 iterations" in info.message


@pytest.mark.parametrize("seed", range(6))
def test_the_rust_lcp_takes_the_steps_of_the_python_block_pivoting(seed):
    """vfrs.enforcement.lcp.solve_lcp (Rust, sums in index order) against the generic
    block_pivoting driven by a numpy solve of the same system: the same loaded sets at every
    iteration (so the same count of iterations and pivots), the same multipliers to
    round-off, and the 2-norm condition of the final loaded block as numpy's eigvalsh gives."""
    from vfrs.enforcement import lcp

    rng = np.random.default_rng(seed)
    m = 5 + 9 * seed
    B = rng.standard_normal((m, m))
    A = B @ B.T / m + 1e-3 * np.eye(m)
    q = rng.standard_normal(m)
    lam, info = lcp.solve_lcp(A, q)

    def solve_on(F):
        x = np.zeros(m)
        idx = np.flatnonzero(F)
        if idx.size:
            x[idx] = np.linalg.solve(A[np.ix_(idx, idx)], -q[idx])
        y = A @ x + q
        y[idx] = 0.0
        return x, y

    lam_py, _, F, info_py = lcp.block_pivoting(m, solve_on, q < 0, np.diag(A), tol=1e-13 * np.abs(q).max())
    assert (info.iterations, info.pivots, info.converged) == (info_py.iterations, info_py.pivots, True)
    assert np.abs(lam - lam_py).max() <= 1e-10 * np.abs(lam_py).max()
    w = np.linalg.eigvalsh(A[np.ix_(F, F)])
    assert info.condition == pytest.approx(np.abs(w).max() / np.abs(w).min(), rel=1e-8)
    assert info.residual < 1e-12 * np.abs(q).max()


def test_a_singular_operator_on_a_loaded_set_is_a_solver_error():
    from vfrs.enforcement import lcp
    from vfrs.errors import SolverError

    with pytest.raises(SolverError, match="singular on 2 loaded pairs"):
        lcp.solve_lcp(np.zeros((2, 2)), np.array([-1.0, -1.0]))
    with pytest.raises(SolverError, match="not finite"):
        lcp.lagrange(np.array([[np.nan]]), np.array([-1.0]))
