"""Linear statics K u = F on the free DOFs, with the factor kept for every load step.

>>> import numpy as np, scipy.sparse as sp
>>> s = StaticSolver(sp.csr_matrix([[2.0, -1.0], [-1.0, 2.0]]))
>>> np.round(s.solve(np.array([1.0, 1.0])), 12).tolist()
[1.0, 1.0]
"""

from __future__ import annotations

import numpy as np

from ..linalg import cholesky


class StaticSolver:
    """Solves K u = F (+ implicit forces from effects, through a step context)."""

    force_scale = 1.0

    def __init__(self, K, ordering="auto"):
        self.K = K
        self.factor = cholesky(K, ordering=ordering, blocks=True)

    def solve(self, F, ctx=None, correct_hooks=()) -> np.ndarray:
        u = self.factor.solve(F)
        if ctx is not None:
            ctx.u = u
            for hook in correct_hooks:
                hook(ctx)
            u = ctx.u
        return u
