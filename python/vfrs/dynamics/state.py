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
        # Set by a nonlinear integrator after each step (None / empty for linear ones, whose
        # energy and reactions the recorder computes from K): the internal force (all DOFs),
        # the strain energy, and per-step records for the history (e.g. Newton iterations).
        self.internal_force: np.ndarray | None = None
        self.elastic_energy: float | None = None
        self.records: dict = {}
        # The jump the last step added to the velocity after its balance (all DOFs; an impulse
        # at its end, StepContext.set_velocity_jump), or None: the balance saw v - jump.
        self.velocity_jump: np.ndarray | None = None

    def state(self) -> dict:
        """What a checkpoint keeps (copies)."""
        return {"u": self.u.copy(), "v": self.v.copy(), "a": self.a.copy(), "u_free": self.u_free.copy(),
                "v_free": self.v_free.copy(), "a_free": self.a_free.copy(), "t": self.t, "t_next": self.t_next,
                "step": self.step}

    def restore(self, state: dict) -> None:
        """Back to a checkpoint's :meth:`state` (in place: the arrays stay the same objects)."""
        for k in ("u", "v", "a", "u_free", "v_free", "a_free"):
            getattr(self, k)[:] = state[k]
        self.t, self.t_next, self.step = state["t"], state["t_next"], state["step"]

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
