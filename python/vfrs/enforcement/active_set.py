"""The contact methods' small dense solvers under their older names: penalty (with a shift,
for Uzawa) and Lagrange multipliers, both linear complementarity problems solved by
:mod:`vfrs.enforcement.lcp`, reported as a :class:`~vfrs.enforcement.base.SolveInfo`.

Notation: ``g = g0 + W lam``, ``W`` symmetric positive semi-definite (m x m), ``kappa`` the
per-pair penalty (N/m).
"""

from __future__ import annotations

import numpy as np

from . import lcp
from .base import SolveInfo


def penalty(W, g0, kappa, shift=None, max_iterations=200):
    """lam_i = max(0, shift_i - kappa_i g_i), g = g0 + W lam. Returns (lam, SolveInfo)."""
    lam, info = lcp.penalty(np.asarray(W, dtype=float), np.asarray(g0, dtype=float), kappa, shift=shift,
                            max_iterations=max_iterations)
    return lam, SolveInfo.of(info)


def lagrange(W, g0, max_iterations=200, regularization=1e-12):
    """The LCP lam >= 0, g = g0 + W lam >= 0, lam . g = 0. Returns (lam, SolveInfo)."""
    lam, info = lcp.lagrange(np.asarray(W, dtype=float), np.asarray(g0, dtype=float), max_iterations=max_iterations,
                             regularization=regularization)
    return lam, SolveInfo.of(info)
