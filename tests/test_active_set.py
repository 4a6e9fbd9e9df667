"""The small dense contact solvers: KKT conditions, penalty -> Lagrange, bounded conditioning."""

import numpy as np
import pytest

from vfrs.enforcement import active_set


def problem(m=12, seed=0):
    rng = np.random.default_rng(seed)
    B = rng.standard_normal((m, m))
    W = B @ B.T / m * 1e-6 + 1e-9 * np.eye(m)  # compliance-like scale (m/N)
    g0 = rng.uniform(-1e-5, 1e-5, m)  # some penetrating, some open
    return W, g0


@pytest.mark.parametrize("seed", range(5))
def test_lagrange_satisfies_the_kkt_conditions(seed):
    W, g0 = problem(seed=seed)
    lam, info = active_set.lagrange(W, g0)
    g = g0 + W @ lam
    assert info.converged and not info.cycle
    scale = np.abs(g0).max()
    assert (lam >= 0).all()
    assert g.min() > -1e-10 * scale
    assert np.abs(lam * g).max() <= 1e-10 * scale * lam.max()


def test_penalty_tends_to_lagrange_as_one_over_kappa():
    W, g0 = problem(seed=3)
    lam_l, _ = active_set.lagrange(W, g0)
    errors, conds = [], []
    for k in (1e8, 1e10, 1e12, 1e14):  # 1/kappa well below W: the asymptotic range
        lam, info = active_set.penalty(W, g0, np.full(len(g0), k))
        errors.append(np.abs(lam - lam_l).max() / np.abs(lam_l).max())
        conds.append(info.condition)
    slopes = np.diff(np.log10(errors))
    assert np.all(np.abs(slopes + 2) < 0.3), errors  # two decades of kappa, two of error
    assert max(conds) < 2 * conds[-1] < 1e6  # bounded, not growing with kappa


def test_shifted_penalty_is_the_uzawa_step():
    W, g0 = problem(seed=4)
    kappa = np.full(len(g0), 1e7)
    shift = np.abs(np.random.default_rng(1).standard_normal(len(g0)))
    lam, _ = active_set.penalty(W, g0, kappa, shift=shift)
    g = g0 + W @ lam
    assert np.allclose(lam, np.maximum(0.0, shift - kappa * g), rtol=1e-9, atol=1e-12 * shift.max())


def test_not_settling_is_reported():
    W, g0 = problem(m=30, seed=5)
    lam, info = active_set.lagrange(W, g0, max_iterations=1)
    assert not info.converged and "not settled in 1 iterations" in info.message
