"""The state a run carries from step to step."""

from __future__ import annotations

import numpy as np


class State:
    """Displacement, velocity and acceleration at time ``t``: over all DOFs (``u``, ``v``,
    ``a``; what ``forces`` and ``record`` hooks see) and over the free DOFs (``u_free``,
    ``v_free``, ``a_free``; what integrators advance). ``t_next`` and ``step`` name the step
    being taken (``forces`` hooks give the forces at ``t_next`` from the state at ``t``)."""

    def __init__(self, problem):
        self.problem = problem
        n, nf = problem.n_dofs, len(problem.free)
        self.u, self.v, self.a = np.zeros(n), np.zeros(n), np.zeros(n)
        self.u_free, self.v_free, self.a_free = np.zeros(nf), np.zeros(nf), np.zeros(nf)
        self.t = 0.0
        self.t_next = 0.0
        self.step = 0

    @property
    def points(self) -> np.ndarray:
        """Current coordinates (n_nodes, 3)."""
        return self.problem.points + self.u.reshape(-1, 3)

    def sync(self, fixed_u, fixed_v=None, fixed_a=None) -> None:
        """Copies the free DOFs into the full vectors and sets the fixed ones."""
        free, fixed = self.problem.free, self.problem.fixed
        self.u[free], self.v[free], self.a[free] = self.u_free, self.v_free, self.a_free
        self.u[fixed] = fixed_u
        if fixed_v is not None:
            self.v[fixed] = fixed_v
        if fixed_a is not None:
            self.a[fixed] = fixed_a
