"""``scheme = "stabilized"``: the contact-stabilized predictor (Deuflhard, Krause & Ertel 2008;
docs/contact.md, "Dynamic contact schemes"), with the usual mass matrix.

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

from ...linalg import combine_columns, dot
from .. import lcp
from ..detector import warn_once
from ..reduced import DenseProblem
from ..scheme import ContactScheme, register_scheme
from ..compliance_matrix import Compliance


class StabilizedPredictor:
    """``method``: the contact method; ``ctx``: the setup context (the integrator's
    ``mass_factor`` and ``constants``: ``predictor_scale``, h, beta, gamma); ``detect(x)``:
    the effect's detection; ``fail(step, pairs, lam, info)``: how a non-converged solve is reported; ``h_surface``: for the step-size warning;
    ``observed``: the contact-surface DOFs (the mass compliance keeps their rows; the full
    fields' shifts come from its columns over their blocks, no solve with M, unless
    ``column_bytes`` caps them: then with a solve)."""

    def __init__(self, method, ctx, problem, detect, fail, max_iterations, strict, h_surface, observed,
                 column_bytes=None, prefetch=None):
        self.method, self.detect, self.fail = method, detect, fail
        self.mass_factor = ctx.mass_factor
        c = ctx.constants
        self.scale, self.h, self.beta, self.gamma = c.predictor_scale, c.h, c.beta, c.gamma
        self.energy_terms: tuple | None = None  # (dv, M dv, M da) of the last predict (free DOFs)
        self.compliance = Compliance(self.mass_factor, problem.dofmap.free, problem.n_dofs, observed=observed,
                                     max_bytes=column_bytes, label="M", prefetch=prefetch)
        self.problem = problem
        self.max_iterations, self.strict, self.h_surface = max_iterations, strict, h_surface
        self.impulse = np.zeros(problem.n_dofs)  # the velocity projection's impulse this step (N s)
        self._warned: dict = {}

    def state(self) -> dict:
        """For a checkpoint: the mass compliance's columns and the warnings already given
        (``impulse`` is set anew by every :meth:`predict`)."""
        return {"compliance": self.compliance.state(), "warned": dict(self._warned)}

    def restore(self, state: dict) -> None:
        self.compliance.restore(state["compliance"])
        self._warned = dict(state["warned"])

    @property
    def solves(self) -> int:
        return self.compliance.solves

    @property
    def nbytes(self) -> int:
        return self.compliance.nbytes

    def predict(self, step) -> None:
        self.impulse[:] = 0.0
        p = self.problem
        obs = self.compliance.observed
        expand = step.dofmap.expand
        # u~ and v~ over all DOFs (fixed: prescribed values and zero velocity; the velocity
        # projection uses the pairs' free DOFs only).
        u_full = expand(step.u_tilde, p.fixed_values(step.t))
        v_full = None  # made when a constraint's velocity projection needs it
        # Last step's transient forces still in the predictor: their (1 + alpha) M^-1 f moves
        # u~ and v~ by the shifts; at the contact surfaces from the mass compliance, in full
        # with the mass-compliance product below.
        pending = step.transient_prev
        cu, cv = step.transient_shift
        rhs, coef = [], []  # forces moving u~ and v~ (by M^-1), and what each adds to (u~, v~)
        if pending is not None:
            f_prev = expand(pending)
            r_obs = self.compliance.response(f_prev)
            u_full[obs] -= cu * r_obs
            v_full = expand(step.v_tilde)
            v_full[obs] -= cv * r_obs
            rhs.append(pending)
            coef.append((-cu, -cv))
            step.transient_prev = None  # taken out here
        x = p.points + u_full.reshape(-1, 3)
        found = self.detect(x)
        mu = np.zeros(0)
        if len(found):
            G = found.constraint(p.n_points)
            W = self.compliance.delassus(G)
            mu, info = self.method.solve(DenseProblem(W, found.pairs.gap, self.max_iterations), found, self.scale,
                                         final=False)
            if not info.converged and self.strict:
                self.fail(step, found, mu, info)
        if mu.any():
            f_mu = G.T @ mu
            rhs.append(f_mu[step.free])
            coef.append((1.0, 0.0))
            moved = float(np.abs(self.compliance.response(f_mu)).max())
            if moved > 0.5 * self.h_surface:
                warn_once(self._warned, "predictor", (
                    f"t = {step.t:.6g}: the stabilized predictor moved contact nodes by {moved:.3g} m, more "
                    f"than half the surface element size ({self.h_surface:.3g} m): the step is too large for "
                    "this impact speed: the first element layer is crushed in one step (a penalty can then "
                    "return more energy than came in, and every method loses accuracy). Use a smaller time step."))
            if self.method.constraint:
                if v_full is None:
                    v_full = expand(step.v_tilde)
                on = np.flatnonzero(mu > 0)
                G_on = G[on]
                vn = G_on @ v_full
                if on.size and (vn < 0).any():
                    nu, _ = lcp.lagrange(W[np.ix_(on, on)], vn, max_iterations=self.max_iterations)
                    if nu.any():
                        impulse = G_on.T @ nu
                        rhs.append(impulse[step.free])
                        coef.append((0.0, 1.0))
                        self.impulse += impulse
        self.energy_terms = None
        if not rhs:
            return
        # u~ and v~ move by M^-1 of two combinations of these forces, all on contact DOFs:
        # a product with their mass-compliance columns, no solve.
        R = np.column_stack(rhs)
        cu_, cv_ = np.array([c[0] for c in coef]), np.array([c[1] for c in coef])
        cols = [c for c in (cu_, cv_) if c.any()]
        X = self.compliance.solve(np.column_stack([combine_columns(R, c) for c in cols]))
        X = X.reshape(len(X), -1)
        k = 0
        zero = np.zeros(len(step.u_tilde))
        du_t = dv_t = zero
        if cu_.any():
            du_t = X[:, k]
            step.u_tilde += du_t
            k += 1
        if cv_.any():
            dv_t = X[:, k]
            step.v_tilde += dv_t
        self._energy_terms(du_t, dv_t, combine_columns(R, cu_) if cu_.any() else zero,
                           combine_columns(R, cv_) if cv_.any() else zero)

    def _energy_terms(self, du_t, dv_t, M_du_t, M_dv_t) -> None:
        """What the predictor's changes (du_t of u~, dv_t of v~, free DOFs, and M times each)
        do to the energy. They are those of a Newmark step started from the same u_n with
        the velocity v_n + dv and the acceleration a_n + da instead: h dv + h^2 (1/2 - beta)
        da = du_t and dv + h (1 - gamma) da = dv_t. With HHT alpha = 0 that step's energy
        balance is the trapezoidal rule's, so the changes add exactly the jump of the kinetic
        energy, v_n . M dv + dv . M dv / 2, and the work du . M da / 2 along the step's
        displacement du (:meth:`StabilizedScheme.work`)."""
        h, beta, gamma = self.h, self.beta, self.gamma
        c = h * h * (gamma - beta - 0.5)
        da = (du_t - h * dv_t) / c
        M_da = (M_du_t - h * M_dv_t) / c
        dv = dv_t - h * (1.0 - gamma) * da
        M_dv = M_dv_t - h * (1.0 - gamma) * M_da
        self.energy_terms = (dv, M_dv, M_da)


@register_scheme
class StabilizedScheme(ContactScheme):
    """The predictor projected onto the admissible set in the mass norm before each step
    (:class:`StabilizedPredictor`); a constraint method's reaction acts within its step."""

    name = "stabilized"
    transient = True

    def __init__(self, params=None):
        super().__init__(params)
        self.predictor: StabilizedPredictor | None = None

    def setup(self, effect, ctx) -> None:
        c = effect.params.common
        self._free = effect.problem.free
        self._last: tuple | None = None  # (u, v) free DOFs at the last record: the next step's start
        self.transient = effect.method.constraint
        self.predictor = StabilizedPredictor(effect.method, ctx, effect.problem, effect.detect, effect._fail,
                                             c.max_iterations, c.strict, effect.surfaces.h_surface,
                                             effect.surfaces.dofs, column_bytes=int(c.column_memory * 2**20),
                                             prefetch=effect.surfaces.nearby)

    def predict(self, step) -> None:
        if self.predictor is not None and step.u_tilde is not None:
            self.predictor.predict(step)

    def work(self, state, stepped: bool) -> float:
        """The energy the predictor's changes gave the step (exact with HHT alpha = 0, see
        :meth:`StabilizedPredictor._energy_terms`), from the state at the step's start and end."""
        free = self._free
        u, v = state.u[free], state.v[free]
        out = 0.0
        terms = self.predictor.energy_terms if (self.predictor is not None and stepped) else None
        if terms is not None and self._last is not None:
            u0, v0 = self._last
            dv, M_dv, M_da = terms
            out = dot(v0, M_dv) + 0.5 * dot(dv, M_dv) + 0.5 * dot(u - u0, M_da)
        self._last = (u.copy(), v.copy())
        return out

    @property
    def impulse(self):
        return None if self.predictor is None else self.predictor.impulse

    @property
    def solves(self) -> int:
        return 0 if self.predictor is None else self.predictor.solves

    @property
    def nbytes(self) -> int:
        return 0 if self.predictor is None else self.predictor.nbytes

    def state(self) -> dict:
        if self.predictor is None:
            return {}
        return {**self.predictor.state(), "last": self._last,
                "energy_terms": self.predictor.energy_terms}

    def restore(self, state: dict) -> None:
        if self.predictor is not None and state:
            self.predictor.restore(state)
            self._last = state.get("last")
            self.predictor.energy_terms = state.get("energy_terms")
