"""The Pareto front of (cost, error) points: settings no other setting beats in both."""

from __future__ import annotations

import numpy as np


def pareto_front(cost, error) -> np.ndarray:
    """Mask of the Pareto-optimal points: no other point has cost <= and error <= with one
    of them strictly smaller. Non-finite points are never optimal.

    >>> pareto_front([1, 2, 3, 4], [4, 1, 2, 0.5]).tolist()
    [True, True, False, True]
    """
    cost = np.asarray(cost, dtype=float)
    error = np.asarray(error, dtype=float)
    ok = np.isfinite(cost) & np.isfinite(error)
    front = np.zeros(len(cost), dtype=bool)
    idx = np.flatnonzero(ok)
    # Sweep by cost (ties: smaller error first); a point is optimal if its error is below
    # every error seen at strictly lower or equal cost before it.
    order = idx[np.lexsort((error[idx], cost[idx]))]
    best = np.inf
    for i in order:
        if error[i] < best:
            front[i] = True
            best = error[i]
    # Equal points (same cost and error) are all optimal.
    for i in order:
        if not front[i]:
            same = front & (cost == cost[i]) & (error == error[i])
            front[i] = same.any()
    return front
