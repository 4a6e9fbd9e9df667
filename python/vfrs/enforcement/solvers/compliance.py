"""The compliance path (default): W from a compliance of the contact DOFs precomputed from
the factor of the effective matrix, so every method is dense work on the pairs."""

from __future__ import annotations

import numpy as np

from ..reduced import DenseProblem
from ..solver import ContactSolver, register_solver
from ..compliance_matrix import Compliance


@register_solver
class ComplianceContactSolver(ContactSolver):
    name = "compliance"
    provides = DenseProblem.provides

    def __init__(self, params, ctx, max_iterations, observed, column_bytes=None, prefetch=None, column_dtype=None):
        super().__init__(params, ctx, max_iterations, observed, column_bytes)
        p = ctx.problem
        # Columns are computed when a pair first touches a DOF: only the contact zone is
        # ever solved for; their rows at every contact-surface DOF are kept, so detection
        # rounds move the surfaces without a solve, and their rows over their blocks, so the
        # final forces move the whole field without one.
        # ``column_bytes`` caps the columns over their blocks ([contact] column_memory).
        # ``prefetch``: the surface DOFs to solve for with new ones (Compliance, "Prefetching").
        # ``column_dtype``: float32 keeps those columns in single precision ([contact] column_precision).
        self.compliance = Compliance(ctx.factor, p.dofmap.free, p.n_dofs, observed=observed, max_bytes=column_bytes,
                                     prefetch=prefetch, dtype=column_dtype or np.float64)
        self.observed = self.compliance.observed

    @property
    def solves(self) -> int:
        return self.compliance.solves

    @property
    def nbytes(self) -> int:
        return self.compliance.nbytes

    def state(self) -> dict:
        return self.compliance.state()

    def restore(self, state: dict) -> None:
        self.compliance.restore(state)

    def response(self, f_full):
        return self.compliance.response(f_full, self.force_scale)

    def apply(self, f_full):
        c = self.compliance
        du = np.zeros(c.n_dofs)
        du[c.free] = self.force_scale * c.solve(np.asarray(f_full, dtype=np.float64)[c.free])
        return du

    def problem(self, G, g0, step):
        W = self.compliance.delassus(G, self.force_scale)
        return DenseProblem(W, g0, self.max_iterations)
