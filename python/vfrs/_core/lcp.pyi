"""The contact LCPs: block principal pivoting, penalty and Lagrange (rust/vfrs-py/src/lcp.rs)."""

from collections.abc import Sequence
from typing import Any, final

import numpy as np
from numpy.typing import NDArray

_F64 = NDArray[np.float64]
_I64 = NDArray[np.int64]
_U8 = NDArray[np.uint8]
_Pairs = dict[str, NDArray[Any]]

__all__ = ["lcp_solve", "lcp_lagrange", "lcp_penalty"]

def lcp_solve(
    a: _F64, q: _F64, start: NDArray[np.bool_] | None = None, max_iterations: int = 200, backup_after: int = 3
) -> tuple[_F64, int, int, bool, float, float]: ...

def lcp_lagrange(
    w: _F64, g0: _F64, start: NDArray[np.bool_] | None = None, max_iterations: int = 200, regularization: float = 1e-12
) -> tuple[_F64, int, int, bool, float, float]: ...

def lcp_penalty(
    w: _F64,
    g0: _F64,
    kappa: _F64,
    shift: _F64 | None = None,
    start: NDArray[np.bool_] | None = None,
    max_iterations: int = 200,
) -> tuple[_F64, int, int, bool, float, float]: ...
