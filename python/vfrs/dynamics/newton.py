"""The nonlinear solver of finite strain: Newton with a line search (issue 14).

A body whose material is finite-strain (``kinematics = "finite"``: ``neo_hookean``,
``st_venant_kirchhoff``, ``fibre_reinforced``) makes the scene choose the Newton integrators
registered for its ``[time] mode`` (:class:`~vfrs.dynamics.integrators.NewtonStaticIntegrator`,
:class:`~vfrs.dynamics.integrators.NewtonHHTIntegrator`); both solve each step with
:func:`newton_solve`, on the finite-strain model (:class:`vfrs.finite_strain.FiniteStrainModel`)
in statics and on the step's HHT-alpha balance (:class:`vfrs.dynamics.hht.HHTBalance`) in
dynamics. What follows describes the statics.

Load step k of N applies the loads and the prescribed displacements times lambda = k / N and
solves the balance ``r(u) = f_int(u) - lambda f_ext = 0`` on the free DOFs (total Lagrangian;
internal force, consistent tangent ``K_T = d f_int / d u`` and strain energy from the Rust
core, :class:`vfrs._core.FiniteStrainAssembler`; linear bodies of the same scene contribute
``K u`` and ``K``):

1. predictor: the prescribed DOFs move to their new values and the free DOFs follow to first
   order, ``K_T,ff du_f = -(r_f + K_T,fp du_p)`` with the tangent of the last converged state
   (so a prescribed rotation or stretch does not crush the boundary elements);
2. Newton: ``K_T du = -r``, then a backtracking line search on the residual along the Newton
   direction, ``g(s) = du . r(u + s du)`` (the derivative of the potential energy along du):
   the full step is kept when ``g(1) <= 0.9 |g(0)|``, else s shrinks to the secant root of g
   on [0, s] (at least a tenth of s per trial; a trial that inverts an element halves s), at
   most ``max_iterations`` solves in all. (A test on the residual norm, tried first, cut the
   steps of a bending column to a quarter and took 8-12 iterations per load step instead of 5;
   this one keeps the full step there and still carries Newton through a 200 Pa shear in one
   load step where full steps reach a tangent that is not positive definite);
3. converged when ``|r| <= residual_tolerance * max(|r_0|, |lambda f_ext|, |r_p|)`` (r_0:
   the residual at the start of the step, before the predictor; r_p = r_0 + K_T,fp du_p, the
   force of the step's prescribed motion) and the last increment
   ``|du| <= increment_tolerance * |u|`` (norms over the free DOFs; u all DOFs).

``method = "modified"`` keeps the factor of K_T while the residual falls fast enough (refactor
when ``|r_k+1| / |r_k| > refactor_ratio``). The factor is LL^T (:class:`vfrs.Cholesky`,
symbolic analysis once, numeric refactorization per tangent): K_T must be positive definite,
and where it is not (buckling, an element near inversion) the step stops with a
:class:`~vfrs.errors.ConvergenceError` that says so. Every failure names the load step, the
residual history and what to try.

Effects that correct the solution (``[contact]``) run inside the iteration, in statics and
dynamics: see ``enforce`` in :class:`NewtonOptions` and :class:`~vfrs.dynamics.StepContext`
(``iteration``).

Recorded per load step (history): ``newton_iterations``, ``newton_factorizations``,
``newton_residual`` (the final relative residual); the elastic energy is the strain energy
and the reactions are ``f_int - f_ext`` on the fixed DOFs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .. import _core
from ..errors import ConvergenceError, SolverError
from ..linalg import Cholesky, dot
from ..params import param

__all__ = ["NewtonParams", "NewtonInfo", "NewtonOptions", "newton_solve", "LOAD_STEP_HINTS", "TIME_STEP_HINTS",
           "unloaded_factor", "implicit_forces"]

#: Line search: a step length is accepted when the residual projected on the Newton direction
#: has fallen to this fraction of its value at the start, |du . r(u + s du)| <= 0.9 |du . r(u)|
#: (the criterion of Bonet & Wood, with FEBio's default 0.9), or is still negative; at most this many trials.
LINE_SEARCH_RATIO = 0.9
MAX_BACKTRACKS = 10


@dataclass(frozen=True)
class NewtonParams:
    """``[time.newton]``: the Newton options of finite-strain statics and dynamics (defaults when omitted)."""

    method: str = param("full", doc="'full' (a new tangent every iteration) or 'modified' (reuse the factor while the "
                                    "residual falls fast; in dynamics across time steps)", choices=("full", "modified"))
    residual_tolerance: float = param(1e-8, doc="relative residual tolerance", positive=True, high=1.0)
    increment_tolerance: float = param(1e-8, doc="relative increment tolerance", positive=True, high=1.0)
    max_iterations: int = param(25, doc="most Newton solves per load step", minimum=1)
    refactor_ratio: float = param(0.5, doc="modified Newton: refactor when |r_k+1| / |r_k| exceeds it",
                                  positive=True, high=1.0)
    line_search: bool = param(True, doc="backtracking line search on the residual along the Newton direction")


@dataclass
class NewtonInfo:
    """What one load step's Newton iteration did: residual norms (free DOFs, the first at the
    start of the step), increment norms, factorizations, line-search step lengths."""

    residuals: list = field(default_factory=list)
    increments: list = field(default_factory=list)
    steps: list = field(default_factory=list)
    factorizations: int = 0
    fallbacks: int = 0  # tangents that were not SPD, replaced by the last SPD factor (``spd_fallback``)
    reference: float = 0.0
    energy: float = 0.0
    force: np.ndarray | None = None  # f_int at the solution, all DOFs

    @property
    def iterations(self) -> int:
        return len(self.increments)

    @property
    def relative_residuals(self) -> np.ndarray:
        return np.asarray(self.residuals) / (self.reference or 1.0)


class _Tangent:
    """The factor of K_T,ff: symbolic analysis once, then numeric refactorizations."""

    def __init__(self):
        self.factor: Cholesky | None = None
        self.count = 0
        self.at: np.ndarray | None = None  # the displacement (all DOFs) the factored tangent is at

    def update(self, K, at=None) -> None:
        """Factors K, the tangent at the displacement ``at`` (numeric refactorization after the
        first); :class:`_NotPositiveDefinite` if it is not SPD."""
        try:
            if self.factor is None:
                # K_T is symmetric by construction (Rust: each node column written once from
                # A_iJkL = A_kLiJ); the O(nnz) check of every refactorization cost 13 % of a step.
                self.factor = Cholesky(K, check_symmetry=False)
            else:
                self.factor.refactor(K)
        except SolverError as e:
            if "positive definite" not in str(e):
                raise
            raise _NotPositiveDefinite(str(e)) from None
        self.count += 1
        self.at = None if at is None else np.array(at)


class _NotPositiveDefinite(Exception):
    pass


#: What a tangent that is not SPD means, and what to try.
NOT_SPD = ("the tangent stiffness K_T is not positive definite ({}): the iterate is past a limit or bifurcation "
           "point (buckling, snap-through) or an element is close to inversion, and the Cholesky factor (LL^T) "
           "needs an SPD tangent")
NOT_SPD_HINT = ("more load steps ([time] load_steps; a smaller step keeps the iterates near the stable path); a load "
                "past a limit point needs an arc-length method, which vfrs does not have yet")


def vector_norm(x) -> float:
    return float(np.sqrt(dot(x, x)))


#: What to try when a step is too large, in statics (load steps) and in dynamics (time step):
#: (the general remedy, the remedy for a tangent that is not positive definite).
LOAD_STEP_HINTS = ("more load steps ([time] load_steps)", NOT_SPD_HINT)
TIME_STEP_HINTS = ("a shorter time step ([time] step)",
                   "a shorter time step ([time] step; K_eff = M/(beta h^2) + ... is positive definite for a short "
                   "enough step)")


@dataclass(frozen=True)
class NewtonOptions:
    """How :func:`newton_solve` runs one step (defaults: a load step of the statics).

    ``params``: :class:`NewtonParams`. ``where`` names the step in errors, ``hints`` what to
    try (:data:`LOAD_STEP_HINTS`, :data:`TIME_STEP_HINTS`). ``tangent``: the factor holder to
    use and update (a new one if None). ``reference``: a force (N) the residual tolerance is
    relative to at least (dynamics: the size of the step's inertia and internal forces).
    ``keep_factor``: modified Newton starts with the factor ``tangent`` holds (made in an
    earlier step) instead of refactoring at the first iteration (it refactors when the
    residual falls too slowly, as within a step). ``fallback``: free DOFs to start from
    instead when ``u`` inverts an element (dynamics: the extrapolated predictor may, the last
    solution does not). ``spd_fallback``: a tangent at an iterate that is not positive
    definite does not stop the iteration; the last SPD factor is made again where it was
    made (``tangent.at``) and kept for the rest of the step (modified-Newton iterations: a
    descent direction for any SPD factor, with the line search). Dynamics: the step's
    incremental potential can be locally non-convex at an iterate (an element buckling under
    contact) and still have the solution the iteration converges to. Counted in
    ``NewtonInfo.fallbacks``.

    ``enforce(u_lin, iteration) -> (u_new, f_c)``: implicit forces (contact) inside the
    iteration (:func:`implicit_forces` makes it from the effects' ``correct`` hooks). It
    gets the linearised solution without them (free DOFs, ``u + du`` with
    ``K_T du = -(g(u) - f_ext)``) and returns the solution with its forces and those forces
    as they enter the balance (free DOFs), decided in full at every iteration from the
    linearisation at the iterate: ``u_new = u_lin + K_T^-1 f_c`` (with the factor in use).
    The iteration then solves ``g(u) = f_ext + f_c``; the line search and the convergence
    test see f_c, and the step is not converged before ``enforce`` ran once."""

    params: NewtonParams = NewtonParams()
    where: str = "load step"
    tangent: _Tangent | None = None
    reference: float = 0.0
    hints: tuple = LOAD_STEP_HINTS
    keep_factor: bool = False
    enforce: Callable | None = None
    fallback: np.ndarray | None = field(default=None, compare=False)
    spd_fallback: bool = False


def newton_solve(model, u, f_ext, fixed_values, options: NewtonOptions | None = None) -> NewtonInfo:
    """Solves ``f_int(u) = f_ext`` on the free DOFs with the fixed DOFs at ``fixed_values``.

    ``model``: a :class:`~vfrs.finite_strain.FiniteStrainModel`, or anything with its
    interface (``free``, ``fixed``, ``n``, ``force``, ``force_and_tangent``, ``tangent_free``,
    ``tangent_full``; the HHT-alpha balance of a time step is one,
    :class:`~vfrs.dynamics.hht.HHTBalance`). ``u`` (all DOFs) is the start (the last
    converged state) and is updated in place. ``options``: :class:`NewtonOptions`. Returns
    the :class:`NewtonInfo`; raises :class:`ConvergenceError` (with the residual history and
    what to try) if the iteration does not converge within ``params.max_iterations`` solves."""
    return _Iteration(model, u, f_ext, fixed_values, options or NewtonOptions()).run()


class _Iteration:
    """One :func:`newton_solve`: the iterate ``u`` and what the iteration carries between its
    stages (the force ``f``, energy ``w`` and residual ``r`` at ``u``, the implicit forces
    ``fc`` of the last enforcement, whether the tangent is at ``u``)."""

    def __init__(self, model, u, f_ext, fixed_values, options: NewtonOptions):
        self.model, self.u, self.fixed_values, self.o = model, u, fixed_values, options
        self.params = options.params
        self.free, self.fixed = model.free, model.fixed
        self.tangent = options.tangent or _Tangent()
        self.info = NewtonInfo()
        self.fe = f_ext[self.free]
        self.more_steps, self.not_spd_hint = options.hints
        self.modified = self.params.method == "modified"
        # The model's tangent is at the current u (else its last evaluation was a force only).
        self.fresh = not (options.keep_factor and self.modified)
        self.tol_r = 0.0
        self.fc = np.zeros(len(self.free))  # the implicit forces of the last enforcement, as in the balance
        self.enforced = options.enforce is None
        self.held = False  # the last SPD factor is kept for the rest of the step (spd_fallback)

    def fail(self, reason: str, hint: str):
        info = self.info
        hist = ", ".join(f"{x:.3g}" for x in info.relative_residuals)
        raise ConvergenceError(
            f"{self.o.where}: Newton ({self.params.method}) {reason}; relative residuals |r|/{info.reference:.3g} N: "
            f"[{hist}]. Try {hint}"
        )

    def run(self) -> NewtonInfo:
        info, u, free, enforce = self.info, self.u, self.free, self.o.enforce
        self.start()
        self.tol_r = self.params.residual_tolerance * info.reference
        if info.reference == 0.0 or (info.residuals[-1] <= self.tol_r and not info.increments):
            # In balance at the start: done, unless implicit forces (contact) act there.
            if enforce is None or not np.any(enforce(u[free].copy(), 0)[1]):
                info.force, info.energy, info.factorizations = self.f, self.w, self.tangent.count
                return info
        while not self.converged():
            self.check_budget()
            self.update_tangent()
            self.iterate()
        info.force, info.energy = self.f, self.w
        info.factorizations = self.tangent.count
        return info

    # ---- 1. the residual of the last converged state under the new loads, and the predictor
    def start(self) -> None:
        model, u, free, info = self.model, self.u, self.free, self.info
        evaluate = model.force_and_tangent if self.fresh else model.force
        try:
            f, w = evaluate(u)
        except _core.errors.FiniteStrainError as e:
            if self.o.fallback is None:
                raise ConvergenceError(f"{self.o.where}: the start of the step is not admissible ({e}). "
                                       f"Try {self.more_steps}") from None
            u[free] = self.o.fallback  # an extrapolated start that inverts an element: from the last solution
            try:
                f, w = evaluate(u)
            except _core.errors.FiniteStrainError as e:
                raise ConvergenceError(f"{self.o.where}: the start of the step is not admissible ({e}). "
                                       f"Try {self.more_steps}") from None
        self.f, self.w = f, w
        self.r = f[free] - self.fe
        info.residuals.append(vector_norm(self.r))
        info.reference = max(info.residuals[0], vector_norm(self.fe), self.o.reference)
        du_p = np.zeros(model.n)
        du_p[self.fixed] = self.fixed_values - u[self.fixed]
        if np.any(du_p):
            self.follow_prescribed(du_p)

    def follow_prescribed(self, du_p) -> None:
        """The prescribed DOFs move to their values and the free ones follow to first order."""
        model, u, free, info, tangent = self.model, self.u, self.free, self.info, self.tangent
        if not self.fresh:
            model.force_and_tangent(u)
        try:
            tangent.update(model.tangent_free(), u)
        except _NotPositiveDefinite as e:
            self.fail("cannot start: " + NOT_SPD.format(e), self.not_spd_hint)
        rhs = self.r + (model.tangent_full() @ du_p)[free]
        info.reference = max(info.reference, vector_norm(rhs))  # the force the prescribed motion of the step exerts
        du = -tangent.factor.solve(rhs)  # type: ignore[union-attr]
        u[self.fixed] = self.fixed_values
        u_old = u[free].copy()
        u[free] += du
        try:
            f, w = model.force_and_tangent(u)
        except _core.errors.FiniteStrainError:
            u[free] = u_old  # the linearised motion inverts an element: start from the old free DOFs
            try:
                f, w = model.force_and_tangent(u)
            except _core.errors.FiniteStrainError as e:
                self.fail(f"cannot start: the prescribed displacement of this step inverts an element ({e})",
                          self.more_steps)
        self.f, self.w = f, w
        self.fresh = True
        info.increments.append(vector_norm(u[free] - u_old))
        info.steps.append(1.0)
        self.r = f[free] - self.fe
        info.residuals.append(vector_norm(self.r))

    # ---- 2. the iteration
    def converged(self) -> bool:
        info = self.info
        return bool(self.enforced and info.increments and info.residuals[-1] <= self.tol_r
                    and info.increments[-1] <= self.params.increment_tolerance * max(vector_norm(self.u), 1e-300))

    def check_budget(self) -> None:
        params, info = self.params, self.info
        if info.iterations < params.max_iterations:
            return
        rel = info.relative_residuals
        if len(rel) > 4 and rel[-1] < 1e-6 and rel[-1] > 0.5 * rel[-4]:  # no progress in 3 iterations, near balance
            self.fail(f"did not converge in {params.max_iterations} iterations: the residual stagnates at "
                      f"{rel[-1]:.2g} of the step's force, its round-off floor (the stress of a slightly strained "
                      "hyperelastic element loses digits to cancellation)",
                      f"a larger [time.newton] residual_tolerance (> {rel[-1]:.1g})")
        self.fail(f"did not converge in {params.max_iterations} iterations",
                  f"{self.more_steps}" + (", method = 'full'" if self.modified else "") + ", or a larger max_iterations")

    def update_tangent(self) -> None:
        """A new factor of K_T at the iterate, unless modified Newton keeps the last one (the
        residual falls fast enough) or the step holds the last SPD factor."""
        model, u, info, tangent = self.model, self.u, self.info, self.tangent
        first = 0.0 if self.o.keep_factor and self.modified else 1.0  # the first iteration: reuse the old factor?
        rn = info.residuals[-1]
        ratio = rn / info.residuals[-2] if len(info.residuals) > 1 and info.residuals[-2] > 0 else first
        if self.held or (self.modified and tangent.factor is not None and ratio <= self.params.refactor_ratio):
            return
        if not self.fresh:  # K_T at the iterate; its force equals the line search's bit for bit
            self.f, self.w = model.force_and_tangent(u)
            self.fresh = True
        try:
            tangent.update(model.tangent_free(), u)
        except _NotPositiveDefinite as e:
            if not (self.o.spd_fallback and tangent.at is not None):
                self.fail(f"stopped at iteration {info.iterations + 1}: " + NOT_SPD.format(e), self.not_spd_hint)
            at = tangent.at
            model.force_and_tangent(at)  # the last SPD tangent, where it was made: the same numbers
            try:
                tangent.update(model.tangent_free(), at)
            except _NotPositiveDefinite:
                self.fail(f"stopped at iteration {info.iterations + 1}: " + NOT_SPD.format(e), self.not_spd_hint)
            self.fresh, self.held = False, True
            info.fallbacks += 1

    def iterate(self) -> None:
        """The Newton direction (with the implicit forces decided on its linearisation), then
        the line search along it."""
        u, free, info, enforce = self.u, self.free, self.info, self.o.enforce
        du = -self.tangent.factor.solve(self.r + self.fc if enforce is not None else self.r)  # type: ignore[union-attr]
        u0 = u[free].copy()
        if enforce is not None:
            # The implicit forces decided on this linearisation: du = -K_T^-1 (g - f_ext - f_c).
            r = self.r + self.fc
            u_new, self.fc = enforce(u0 + du, info.iterations)
            du = u_new - u0
            r -= self.fc
            self.r = r
            self.enforced = True
            if vector_norm(self.fc) > info.reference:
                info.reference = vector_norm(self.fc)
                self.tol_r = self.params.residual_tolerance * info.reference
        self.line_search(du, u0)

    def line_search(self, du, u0) -> None:
        """Backtracking on the residual along ``du`` from ``u0`` (free DOFs): see the module docstring."""
        u, free, info, model, params = self.u, self.free, self.info, self.model, self.params
        s, trial = 1.0, None
        g0 = dot(du, self.r)  # dPi/ds at s = 0: -r K_T^-1 r < 0 (K_T is SPD)
        for _ in range(MAX_BACKTRACKS + 1):
            u[free] = u0 + s * du
            try:
                f_try, w_try = model.force(u)
            except _core.errors.FiniteStrainError:
                f_try = None
            if f_try is None or not np.all(np.isfinite(f_try)):
                if not params.line_search:
                    break
                s *= 0.5  # the trial inverts an element: halve
                continue
            r_try = f_try[free] - self.fe
            if self.o.enforce is not None:
                r_try -= self.fc
            trial = (s, r_try, f_try, w_try)
            g = dot(du, r_try)
            if not params.line_search or g <= LINE_SEARCH_RATIO * abs(g0):
                break  # |residual along du| reduced enough, or still descending at s
            s *= max(0.1, g0 / (g0 - g))  # the secant root of du . r(s) on [0, s] (g > 0 > g0)
        if trial is None:
            u[free] = u0
            self.fail("cannot proceed: every trial step inverts an element", self.more_steps)
        s, self.r, self.f, self.w = trial  # type: ignore[misc]
        u[free] = u0 + s * du
        info.steps.append(s)
        info.increments.append(s * vector_norm(du))
        info.residuals.append(vector_norm(self.r))
        self.fresh = False


def unloaded_factor(model, problem, what: str) -> tuple:
    """(a :class:`_Tangent` holding the factor of the model's tangent at u = 0, that tangent
    on the free DOFs): what effects see as the integrator's ``factor`` and
    ``effective_matrix`` (its factorization is not counted as a Newton one)."""
    tangent = _Tangent()
    model.force_and_tangent(np.zeros(problem.n_dofs))
    K = model.tangent_free()
    try:
        tangent.update(K, np.zeros(problem.n_dofs))
    except _NotPositiveDefinite as e:
        raise SolverError(f"{problem.scene.source}: {what} of the unloaded state is not positive definite ({e})") from None
    tangent.count = 0
    return tangent, K


def implicit_forces(ctx, hooks, begin):
    """The ``enforce`` of :class:`NewtonOptions` for the effects' ``correct`` hooks (contact):
    each Newton iteration forgets the implicit forces of the last (``begin()`` resets the step
    context and the force vector of the step end), hands the hooks the linearised solution
    without them, and returns the solution with the forces they add and those forces as they
    enter the balance (``force_scale f`` on the free DOFs)."""
    free = ctx.free

    def enforce(u_lin, iteration):
        begin()
        ctx.iteration = iteration
        ctx.u = u_lin
        for hook in hooks.correct:
            hook(ctx)
        f = ctx.implicit_full
        fc = np.zeros(len(free)) if f is None else ctx.force_scale * f[free]
        return ctx.u, fc

    return enforce
