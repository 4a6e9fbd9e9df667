"""The contact problem of one step as a linear complementarity problem, solved with a
termination guarantee.

Every contact method reduces, in the space of the pairs, to

    find lam >= 0 with  y = A lam + q >= 0,  lam . y = 0                        (LCP)

with A symmetric positive definite:

- Lagrange multipliers: A = W + eps I, q = g0. W = G K_eff^-1 G^T (the Delassus operator) is
  only positive *semi*-definite: with two-pass node-to-surface detection on non-matching
  meshes the constraints of the two passes are nearly dependent and W is singular. The gaps
  of the solution are then unique but the multipliers are not. The tiny regularisation
  ``eps = regularization * mean(diag W)`` makes the problem strictly convex, so the solution is
  unique and tends to the least-norm multipliers as eps -> 0 (a Tikhonov-regularised QP);
  the pairs then sit at g = -eps lam, a penetration of ``regularization`` times the contact
  deformation (1e-12 by default). Two steps of iterative refinement on the final active set
  remove most of even that.
- Penalty: lam_i = max(0, shift_i - kappa_i g_i) with g = g0 + W lam is the LCP with
  A = W + diag(1/kappa), q = g0 - shift / kappa (penalty as regularised Lagrange: the
  operator tends to W as kappa grows instead of blowing up with kappa).
- Augmented Lagrange: each augmentation is a shifted penalty problem.

The LCP is the KKT system of the strictly convex QP  min 1/2 lam^T A lam + q^T lam, lam >= 0.
We solve it by block principal pivoting (Judice & Pires 1994, "A block principal pivoting
algorithm for large-scale strictly monotone linear complementarity problems", Comput. Oper.
Res. 21; the same scheme as Kim & Park's NNLS, SIAM J. Sci. Comput. 33, 2011): guess the set
F of loaded pairs, solve A_FF lam_F = -q_F, and exchange every infeasible index (a loaded pair
pulling, lam < 0, or a free pair penetrating, y < 0) at once. While the number of infeasible
indices keeps falling this converges in a few iterations; when it has not fallen for
``backup_after`` iterations, only the infeasible index with the largest number changes (Murty's
rule), which terminates finitely for any P-matrix, and a symmetric positive definite A is one.
So the solver terminates on every input; ``max_iterations`` only bounds the work, and running
out of it is reported, never hidden.

The dense problems (:func:`solve_lcp`, :func:`lagrange`, :func:`penalty`) are solved in Rust
(``rust/vfrs-core/src/lcp.rs``): a round has a few tens of pairs, for which numpy's and
LAPACK's per-call overhead was most of the cost (docs/performance.md), and OpenBLAS chooses
its kernels by CPU, which made every contact history depend on the machine in its last digits
(contact amplifies them). There every sum runs in index order without fused multiply-adds: the same
bits on every machine. :func:`block_pivoting` stays here for solvers whose operator is not a
dense matrix (the refactorization path).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core


@dataclass
class LcpInfo:
    """What one LCP solve did: ``iterations`` (systems solved), ``pivots`` (single-index
    exchanges by the backup rule), ``converged``, ``condition`` (2-norm condition of A on the
    final loaded set), ``residual`` (the largest violation of lam >= 0, y >= 0 and lam y = 0,
    as a length: y in m, lam scaled by A's diagonal), ``message``."""

    iterations: int = 0
    pivots: int = 0
    converged: bool = True
    condition: float = 1.0
    residual: float = 0.0
    message: str = ""


def block_pivoting(m: int, solve_on, start, size, max_iterations: int = 200, backup_after: int = 3,
                   label: str = "LCP", tol: float = 0.0) -> tuple:
    """Block principal pivoting for an LCP given by an oracle.

    ``solve_on(F)`` (F a boolean mask of the loaded set) returns ``(lam, y)``: lam with zeros
    off F, and y = A lam + q with zeros on F. ``size`` (m,) turns lam into the units of y for
    the sign test (A's diagonal, or a lower bound of it). ``tol``: what counts as a violated
    sign, in y's units. Returns (lam, y, F, LcpInfo); lam is clipped at 0.
    """
    info = LcpInfo()
    F = np.asarray(start, dtype=bool).copy()
    best = m + 1
    budget = backup_after
    lam, y = np.zeros(m), np.zeros(m)
    for it in range(1, max_iterations + 1):
        info.iterations = it
        lam, y = solve_on(F)
        # A loaded pair pulls (lam < 0, measured as the gap it would open) or a free pair
        # penetrates (y < 0).
        bad = np.flatnonzero((F & (lam * size < -tol)) | (~F & (y < -tol)))
        if bad.size == 0:
            break
        if bad.size < best:
            best, budget = bad.size, backup_after
            F[bad] = ~F[bad]
        elif budget > 0:
            budget -= 1
            F[bad] = ~F[bad]
        else:  # Murty's rule: finite termination for P-matrices
            info.pivots += 1
            F[bad[-1]] = ~F[bad[-1]]
    else:
        info.converged = False
        info.message = f"{label} active set not settled in {max_iterations} iterations"
    return np.maximum(lam, 0.0), y, F, info


def _result(out: tuple, max_iterations: int, label: str) -> tuple:
    """(lam, LcpInfo) from the Rust LCP's (lam, iterations, pivots, converged, condition, residual)."""
    lam, iterations, pivots, converged, condition, residual = out
    info = LcpInfo(int(iterations), int(pivots), bool(converged), float(condition), float(residual))
    if not info.converged:
        info.message = f"{label} active set not settled in {max_iterations} iterations"
    return lam, info


def _start(start):
    return None if start is None else np.ascontiguousarray(start, dtype=bool)


def solve_lcp(A: np.ndarray, q: np.ndarray, start=None, max_iterations: int = 200, backup_after: int = 3,
              label: str = "LCP") -> tuple:
    """lam >= 0, y = A lam + q >= 0, lam . y = 0 for a symmetric positive definite A.

    ``start``: a boolean guess of the loaded set (default: the pairs with q < 0).
    ``backup_after``: iterations without fewer infeasible indices before the single-index
    rule takes over. Returns (lam, LcpInfo). Solved in Rust (``vfrs_core::lcp``: Cholesky on
    the loaded set, LU if round-off made it indefinite; every sum in index order, so the same
    bits on every CPU); an operator singular on a loaded set or non-finite input is a
    :class:`vfrs.SolverError`.

    >>> A = np.array([[2.0, 1.0], [1.0, 2.0]]); q = np.array([-1.0, 1.0])
    >>> lam, info = solve_lcp(A, q)
    >>> lam.round(12).tolist(), ((A @ lam + q).round(12) + 0.0).tolist(), info.converged
    ([0.5, 0.0], [0.0, 1.5], True)
    """
    out = _core.lcp.lcp_solve(np.asarray(A, dtype=np.float64), np.asarray(q, dtype=np.float64), _start(start),
                          int(max_iterations), int(backup_after))
    return _result(out, max_iterations, label)


def lagrange(W: np.ndarray, g0: np.ndarray, max_iterations: int = 200, regularization: float = 1e-12,
             start=None) -> tuple:
    """Exact contact (Lagrange multipliers): the LCP with W + eps I, eps = ``regularization``
    x mean(diag W), then two steps of iterative refinement towards W itself on the loaded
    set (kept only if they keep every sign). Returns (lam, LcpInfo)."""
    out = _core.lcp.lcp_lagrange(np.asarray(W, dtype=np.float64), np.asarray(g0, dtype=np.float64), _start(start),
                             int(max_iterations), float(regularization))
    return _result(out, max_iterations, "Lagrange")


def penalty(W: np.ndarray, g0: np.ndarray, kappa, shift=None, max_iterations: int = 200, start=None) -> tuple:
    """lam_i = max(0, shift_i - kappa_i g_i), g = g0 + W lam: the LCP with
    A = W + diag(1/kappa), q = g0 - shift/kappa. Returns (lam, LcpInfo)."""
    g0 = np.asarray(g0, dtype=np.float64)
    kappa = np.broadcast_to(np.asarray(kappa, dtype=np.float64), g0.shape)
    shift = None if shift is None else np.broadcast_to(np.asarray(shift, dtype=np.float64), g0.shape)
    out = _core.lcp.lcp_penalty(np.asarray(W, dtype=np.float64), g0, np.ascontiguousarray(kappa),
                            None if shift is None else np.ascontiguousarray(shift), _start(start),
                            int(max_iterations))
    return _result(out, max_iterations, "penalty")
