"""The contact-stabilized predictor (Deuflhard, Krause & Ertel 2008; docs/design.md, "Energy in
dynamic contact").

Before each dynamic step the HHT predictor u~ is projected onto the admissible set in the
mass norm: u~ + M^-1 G^T mu with mu >= 0, g(u~) + G M^-1 G^T mu >= 0, complementary. Without
it, enforcing the gap at t_n+1 inside Newmark/HHT makes contact chatter and the energy grow.

Every method keeps its own law here (Lagrange: the exact projection; penalty and Uzawa:
their penalty, augmentations included), or the projection would enforce the gap exactly and
kappa would no longer control the overlap. Over the predictor's h^2 (1/2 - beta), a pair
force f moves u~ by M^-1 G^T f times that, so the method solves with its stiffness scaled by
it (the integrator's ``predictor_scale``).

For constraint methods the pairs the projection closed must not keep approaching: their
predicted normal velocity is projected too (same mass norm, on those pairs only). Otherwise
a node resting in contact keeps the velocity -(1 - gamma) h a of the start-of-step
acceleration forever, and damping acts on it. That projection is an impulse G^T nu: it
changes momentum, and :attr:`StabilizedPredictor.impulse` keeps it for the record.
"""

from __future__ import annotations

import numpy as np

from . import lcp
from .detection import warn_once
from .problem import DenseProblem
from .solvers.compliance_matrix import Compliance


class StabilizedPredictor:
    """``method``: the contact method; ``integrator``: its ``mass_factor`` and
    ``predictor_scale``; ``detect(x)``: the effect's detection; ``fail(step, pairs, lam,
    info)``: how a non-converged solve is reported; ``h_surface``: for the step-size warning."""

    def __init__(self, method, integrator, problem, detect, fail, max_iterations, strict, h_surface):
        self.method, self.detect, self.fail = method, detect, fail
        self.mass_factor = integrator.mass_factor
        self.scale = integrator.predictor_scale
        self.compliance = Compliance(self.mass_factor, problem.dofmap.free, problem.n_dofs)
        self.problem = problem
        self.max_iterations, self.strict, self.h_surface = max_iterations, strict, h_surface
        self.impulse = np.zeros(problem.n_dofs)  # the velocity projection's impulse this step (N s)
        self._warned: dict = {}
        self._full = np.zeros(problem.n_dofs)

    @property
    def solves(self) -> int:
        return self.compliance.solves

    def predict(self, step) -> None:
        self.impulse[:] = 0.0
        p = self.problem
        full = self._full
        full[:] = 0.0
        full[p.fixed] = p.fixed_values(step.t)
        full[step.free] = step.u_tilde
        x = p.points + full.reshape(-1, 3)
        found = self.detect(x)
        if len(found) == 0:
            return
        G = found.pairs.constraint_matrix(p.n_points)
        W = self.compliance.delassus(G)
        mu, info = self.method.solve(DenseProblem(W, found.pairs.gap, self.max_iterations), found, self.scale, final=False)
        if not info.converged and self.strict:
            self.fail(step, found, mu, info)
        if not mu.any():
            return
        du = self.mass_factor.solve((G.T @ mu)[step.free])
        step.u_tilde += du
        moved = float(np.abs(du).max())
        if moved > 0.5 * self.h_surface:
            warn_once(self._warned, "predictor", (
                f"t = {step.t:.6g}: the stabilized predictor moved contact nodes by {moved:.3g} m, more "
                f"than half the surface element size ({self.h_surface:.3g} m): the step is too large for "
                "this impact speed: the first element layer is crushed in one step (a penalty can then "
                "return more energy than came in, and every method loses accuracy). Use a smaller time step."))
        if not self.method.constraint:
            return
        on = np.flatnonzero(mu > 0)
        full[:] = 0.0
        full[step.free] = step.v_tilde
        vn = G[on] @ full
        if on.size and (vn < 0).any():
            nu, _ = lcp.lagrange(W[np.ix_(on, on)], vn, max_iterations=self.max_iterations)
            if nu.any():
                impulse = G[on].T @ nu
                step.v_tilde += self.mass_factor.solve(impulse[step.free])
                self.impulse += impulse
