"""Small dense solvers for the contact unknowns: penalty (with a shift, for Uzawa) and the
Lagrange-multiplier LCP, both by active-set iteration with a guard against cycling.

Notation: ``g = g0 + W lam``, ``W`` symmetric positive semi-definite (m x m), ``kappa`` the
per-pair penalty (N/m).
"""

from __future__ import annotations

import numpy as np

from .base import SolveInfo, condition


def _iterate(active, solve, update, max_iterations, label):
    """The shared active-set loop: ``solve(active) -> lam``, ``update(active, lam) -> new
    active set`` (the same array object when nothing changes). A set seen before that is not
    the last one is a cycle: it is reported in the returned SolveInfo, not hidden."""
    seen = set()
    info = SolveInfo()
    lam = None
    for it in range(1, max_iterations + 1):
        key = active.tobytes()
        if key in seen:
            info.converged, info.cycle = False, True
            info.message = f"{label} active set cycles after {it - 1} iterations"
            break
        seen.add(key)
        lam = solve(active)
        info.iterations = it
        new = update(active, lam)
        if new is active or np.array_equal(new, active):
            break
        active = new
    else:
        info.converged = False
        info.message = f"{label} active set not settled in {max_iterations} iterations"
    return lam, active, info


def penalty(W, g0, kappa, shift=None, max_iterations=100):
    """lam_i = max(0, shift_i - kappa_i g_i), g = g0 + W lam.

    On an active set A, lam_A / kappa_A = shift_A / kappa_A - g_A, i.e.
    (W_AA + K_A^-1) lam_A = K_A^-1 shift_A - g0_A  (K = diag kappa):
    penalty as regularised Lagrange. Written this way the operator tends to W_AA as kappa
    grows instead of blowing up with it (kappa W would), so a stiff penalty keeps the
    conditioning of the Lagrange problem. Returns (lam, SolveInfo).
    """
    m = len(g0)
    shift = np.zeros(m) if shift is None else np.asarray(shift, dtype=float)
    kappa = np.asarray(kappa, dtype=float)
    if m == 0:
        return np.zeros(0), SolveInfo(condition=1.0)

    def solve(active):
        lam = np.zeros(m)
        A = np.flatnonzero(active)
        if A.size:
            inv_k = 1.0 / kappa[A]
            lam[A] = np.linalg.solve(W[np.ix_(A, A)] + np.diag(inv_k), inv_k * shift[A] - g0[A])
        return lam

    def update(active, lam):
        # Pairs in the set stay while their solved force is positive: lam_A is accurate, while
        # the trial shift - kappa g is kappa x round-off once the penetration is below the
        # round-off of g (kappa >= 1e15 E/h), where it flipped the set and reported a cycle.
        # Pairs outside join when their trial force is positive.
        trial = shift - kappa * (g0 + W @ lam)
        return np.where(active, lam > 0, trial > 0)

    lam, active, info = _iterate((shift - kappa * g0) > 0, solve, update, max_iterations, "penalty")
    A = np.flatnonzero(active)
    info.condition = condition(W[np.ix_(A, A)] + np.diag(1.0 / kappa[A])) if A.size else 1.0
    return np.maximum(lam, 0.0), info


def lagrange(W, g0, max_iterations=200, regularization=1e-12):
    """The LCP lam >= 0, g = g0 + W lam >= 0, lam . g = 0 by an active-set method.

    Start from the penetrating pairs; solve W_AA lam_A = -g0_A; release the most pulling pair
    (lam < 0) or add the penetrating ones (g < 0); repeat until nothing changes. Redundant
    constraints (both directions of a node-triangle pair make W singular) are handled by a
    tiny diagonal regularisation relative to W's scale. Returns (lam, SolveInfo).
    """
    m = len(g0)
    if m == 0:
        return np.zeros(0), SolveInfo(condition=1.0)
    eps = regularization * (float(np.abs(np.diag(W)).max()) or 1.0)
    tol = 1e-12 * max(float(np.abs(g0).max()), 1e-300)

    def solve(active):
        lam = np.zeros(m)
        A = np.flatnonzero(active)
        if A.size:
            lam[A] = np.linalg.solve(W[np.ix_(A, A)] + eps * np.eye(A.size), -g0[A])
        return lam

    def update(active, lam):
        pulling = active & (lam < 0)
        penetrating = ~active & (g0 + W @ lam < -tol)
        if not pulling.any() and not penetrating.any():
            return active
        new = active | penetrating
        if pulling.any():
            # Release the most pulling pair first: keeps the method from oscillating.
            new[np.flatnonzero(pulling)[np.argmin(lam[pulling])]] = False
        return new

    lam, active, info = _iterate(g0 < 0, solve, update, max_iterations, "Lagrange")
    A = np.flatnonzero(active)
    info.condition = condition(W[np.ix_(A, A)]) if A.size else 1.0
    return np.maximum(lam, 0.0), info
