"""The refactoring reference path: each penalty active set refactors
A = K_eff + s G_F^T diag(k_F) G_F and solves with it (symbolic analysis once per pattern,
numeric each time): the plain way, kept as the reference and to show what the compliance
path saves. Methods that solve penalty problems (penalty, penalty_volume, augmented
Lagrange's augmentations) run on it; the exact Lagrange LCP has no such form."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ...linalg import cholesky
from .. import lcp
from ..reduced import ReducedProblem
from ..solver import ContactSolver, register_solver


class RefactorProblem(ReducedProblem):
    """lam_F = shift_F - k_F g_F with g = g0 + G d, (K + s G_F^T k_F G_F) d = s G_F^T (shift_F - k_F g0_F)."""

    provides = frozenset({"penalty"})

    def __init__(self, K, Gf, g0, force_scale, max_iterations=100):
        super().__init__(g0, max_iterations)
        self.K, self.Gf, self.s = K, sp.csr_matrix(Gf), float(force_scale)
        self._last = None

    def penalty(self, stiffness, shift=None):
        m = len(self.g0)
        k = np.asarray(stiffness, dtype=float)
        shift = np.zeros(m) if shift is None else np.asarray(shift, dtype=float)
        g0, Gf, s = self.g0, self.Gf, self.s

        def solve_on(F):
            idx = np.flatnonzero(F)
            d = np.zeros(Gf.shape[1])
            if idx.size:
                GA = Gf[idx]
                A = (self.K + s * (GA.T @ sp.diags(k[idx]) @ GA)).tocsr()
                d = cholesky(A).solve(s * (GA.T @ (shift[idx] - k[idx] * g0[idx])))
            g = g0 + Gf @ d
            lam = np.where(F, shift - k * g, 0.0)
            y = np.where(F, 0.0, g - shift / k)
            return lam, y

        tol = 1e-13 * (float(np.abs(g0).max()) or 1.0) if m else 0.0
        lam, y, F, info = lcp.block_pivoting(m, solve_on, (shift - k * g0) > 0, 1.0 / k, self.max_iterations,
                                             label="penalty (refactor path)", tol=tol)
        info.condition = float("nan")  # not estimated on this path
        self._last = (lam, np.where(F, (shift - lam) / k, y + shift / k))
        return lam, info

    def gaps(self, lam):
        last_lam, g = self._last
        assert last_lam is lam, "the refactor path knows the gaps of its last solution only"
        return g


@register_solver
class RefactorContactSolver(ContactSolver):
    name = "refactor"
    provides = RefactorProblem.provides

    def __init__(self, params, ctx, max_iterations, observed, column_bytes=None, prefetch=None, column_dtype=None):
        super().__init__(params, ctx, max_iterations, observed, column_bytes)
        self.K = ctx.effective_matrix
        self.free = ctx.problem.dofmap.free

    def problem(self, G, g0, step):
        G = G.tocsr() if hasattr(G, "tocsr") else G
        return RefactorProblem(self.K, G[:, self.free], g0, self.force_scale, self.max_iterations)
