"""Small dense solvers for the contact unknowns: penalty (with a shift, for Uzawa) and the
Lagrange-multiplier LCP, both by active-set iteration with a guard against cycling.

Notation: ``g = g0 + W lam``, ``W`` symmetric positive semi-definite (m x m), ``kappa`` the
per-pair penalty (N/m).
"""

from __future__ import annotations

import numpy as np

from .base import SolveInfo, condition


def penalty(W, g0, kappa, shift=None, max_iterations=100):
    """lam_i = max(0, shift_i - kappa_i g_i), g = g0 + W lam.

    On an active set A, lam_A / kappa_A = shift_A / kappa_A - g_A, i.e.
    (W_AA + K_A^-1) lam_A = K_A^-1 shift_A - g0_A  (K = diag kappa):
    penalty as regularised Lagrange. Written this way the operator tends to W_AA as kappa
    grows instead of blowing up with it (kappa K W would), so a stiff penalty keeps the
    conditioning of the Lagrange problem. The set is updated until it repeats; a set seen
    before but not the last one is a cycle. Returns (lam, SolveInfo).
    """
    m = len(g0)
    shift = np.zeros(m) if shift is None else np.asarray(shift, dtype=float)
    kappa = np.asarray(kappa, dtype=float)
    lam = np.zeros(m)
    if m == 0:
        return lam, SolveInfo(condition=1.0)
    active = (shift - kappa * g0) > 0
    seen = set()
    info = SolveInfo()
    for it in range(1, max_iterations + 1):
        key = active.tobytes()
        if key in seen:
            info.converged, info.cycle = False, True
            info.message = f"penalty active set cycles after {it - 1} iterations"
            break
        seen.add(key)
        lam[:] = 0.0
        A = np.flatnonzero(active)
        if A.size:
            inv_k = 1.0 / kappa[A]
            S = W[np.ix_(A, A)] + np.diag(inv_k)
            lam[A] = np.linalg.solve(S, inv_k * shift[A] - g0[A])
        g = g0 + W @ lam
        new = (shift - kappa * g) > 0
        info.iterations = it
        if np.array_equal(new, active):
            break
        active = new
    else:
        info.converged = False
        info.message = f"penalty active set not settled in {max_iterations} iterations"
    A = np.flatnonzero(active)
    info.condition = condition(W[np.ix_(A, A)] + np.diag(1.0 / kappa[A])) if A.size else 1.0
    return np.maximum(lam, 0.0), info


def lagrange(W, g0, max_iterations=200, regularization=1e-12):
    """The LCP lam >= 0, g = g0 + W lam >= 0, lam . g = 0 by an active-set method.

    Start from the penetrating pairs; solve W_AA lam_A = -g0_A; drop pairs with lam < 0
    (pulling), add pairs with g < 0 (penetrating); repeat until nothing changes. Redundant
    constraints (both directions of a node-triangle pair make W singular) are handled by a
    tiny diagonal regularisation relative to W's scale. Returns (lam, SolveInfo).
    """
    m = len(g0)
    lam = np.zeros(m)
    info = SolveInfo()
    if m == 0:
        info.condition = 1.0
        return lam, info
    scale = float(np.abs(np.diag(W)).max()) or 1.0
    eps = regularization * scale
    tol = 1e-12 * max(float(np.abs(g0).max()), 1e-300)
    active = g0 < 0
    seen = set()
    for it in range(1, max_iterations + 1):
        key = active.tobytes()
        if key in seen:
            info.converged, info.cycle = False, True
            info.message = f"Lagrange active set cycles after {it - 1} iterations"
            break
        seen.add(key)
        lam[:] = 0.0
        A = np.flatnonzero(active)
        if A.size:
            WA = W[np.ix_(A, A)] + eps * np.eye(A.size)
            lam[A] = np.linalg.solve(WA, -g0[A])
        g = g0 + W @ lam
        info.iterations = it
        pulling = active & (lam < 0)
        penetrating = ~active & (g < -tol)
        if not pulling.any() and not penetrating.any():
            break
        if pulling.any():
            # Release the most pulling pair first: keeps the method from oscillating.
            active[np.flatnonzero(pulling)[np.argmin(lam[pulling])]] = False
            active |= penetrating
        else:
            active |= penetrating
    else:
        info.converged = False
        info.message = f"Lagrange active set not settled in {max_iterations} iterations"
    A = np.flatnonzero(active)
    info.condition = condition(W[np.ix_(A, A)]) if A.size else 1.0
    return np.maximum(lam, 0.0), info
