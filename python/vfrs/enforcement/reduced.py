"""The contact problem of one detection round, in the space of its pairs.

With the pairs' geometry frozen, the gaps respond linearly to the pair forces:
g = g0 + W lam. A :class:`ReducedProblem` is what a contact method works with; it hides where
W comes from (a precomputed compliance, or a refactorization):

- ``penalty(stiffness, shift)``: lam_i = max(0, shift_i - stiffness_i g_i);
- ``lagrange()``: lam >= 0, g >= 0, lam . g = 0;
- ``gaps(lam)``: g for the last solution.
"""

from __future__ import annotations

import numpy as np

from . import lcp


class ReducedProblem:
    """Base: ``g0`` (the gaps without contact forces), ``max_iterations`` (of the LCP solver)."""

    provides: frozenset = frozenset()

    def __init__(self, g0, max_iterations: int = 100):
        self.g0 = np.asarray(g0, dtype=float)
        self.max_iterations = max_iterations

    def __len__(self):
        return len(self.g0)

    def penalty(self, stiffness, shift=None) -> tuple:
        raise NotImplementedError

    def lagrange(self) -> tuple:
        raise NotImplementedError

    def gaps(self, lam) -> np.ndarray:
        raise NotImplementedError


class DenseProblem(ReducedProblem):
    """g = g0 + W lam with W given (m x m, symmetric positive semi-definite)."""

    provides = frozenset({"penalty", "lagrange"})

    def __init__(self, W, g0, max_iterations: int = 100):
        super().__init__(g0, max_iterations)
        self.W = W

    def penalty(self, stiffness, shift=None):
        return lcp.penalty(self.W, self.g0, stiffness, shift=shift, max_iterations=self.max_iterations)

    def lagrange(self):
        return lcp.lagrange(self.W, self.g0, max_iterations=self.max_iterations)

    def gaps(self, lam):
        # Row sums of W * lam (numpy's pairwise sums, not BLAS: the same bits on every CPU).
        return self.g0 + (self.W * lam).sum(axis=1)
