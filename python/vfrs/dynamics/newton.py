"""Finite strain: Newton with a line search, in load steps (statics) and inside HHT-alpha (issue 14).

A body whose material is finite-strain (``kinematics = "finite"``: ``neo_hookean``,
``st_venant_kirchhoff``, ``fibre_reinforced``) makes ``[time] mode = "static"`` run
:class:`NewtonStaticIntegrator` instead of the linear
:class:`~vfrs.dynamics.integrators.StaticIntegrator`, and ``mode = "dynamic"`` run
:class:`NewtonHHTIntegrator` instead of the linear
:class:`~vfrs.dynamics.integrators.HHTIntegrator` (each linear class selects its Newton
subclass; the march loop does not change). Linear scenes never reach this module. Dynamics:
see :class:`NewtonHHTIntegrator` (the same :func:`newton_solve` on the step's HHT-alpha
balance, :class:`HHTBalance`); what follows describes the statics.

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
dynamics: see ``enforce`` in :func:`newton_solve` and :class:`~vfrs.dynamics.StepContext`
(``iteration``).

Recorded per load step (history): ``newton_iterations``, ``newton_factorizations``,
``newton_residual`` (the final relative residual); the elastic energy is the strain energy
and the reactions are ``f_int - f_ext`` on the fixed DOFs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import scipy.sparse as sp

from .. import _core
from ..assembly import _materials, _pattern, stiffness
from ..errors import ConvergenceError, SolverError
from ..linalg import Cholesky, dot
from ..materials import kinematics_of
from ..params import param
from .hht import correct_predictor, hht_parameters, mass_factor, transient_shift
from .integrators import HHTIntegrator, Integrator, StaticIntegrator

__all__ = ["NewtonParams", "NewtonInfo", "FiniteStrainModel", "newton_solve", "NewtonStaticIntegrator",
           "HHTBalance", "NewtonHHTIntegrator", "has_finite_strain"]

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


def has_finite_strain(problem) -> bool:
    """Whether any body of the problem has a finite-strain material."""
    return any(kinematics_of(b.config.material) == "finite" for b in problem.bodies)


class FiniteStrainModel:
    """Internal force, tangent and strain energy of all bodies of a problem: finite-strain
    bodies by the Rust assembler, linear ones by their K. The tangent of all DOFs lives on
    one fixed block-diagonal CSC pattern (the bodies' P1 patterns), its free-free block on a
    pattern computed once (:meth:`vfrs.DofMap` ``reduce_pattern``), so a tangent is a gather
    and a numeric refactorization."""

    def __init__(self, problem):
        self.problem = problem
        self.free, self.fixed = problem.free, problem.fixed
        self.parts = []
        indptrs, indices = [np.zeros(1, dtype=np.int64)], []
        nnz = 0
        for b in problem.bodies:
            mesh = b.mesh
            if kinematics_of(b.config.material) == "finite":
                mats, of = _materials(mesh, b.config.material)
                asm = _core.FiniteStrainAssembler(mesh.points, mesh.tets)
                self.parts.append((b.dofs, asm, [m.hyperelastic() for m in mats], of, None))
                ip, ix = asm.pattern()
            else:
                K = stiffness(mesh, b.config.material)
                self.parts.append((b.dofs, None, None, None, K))
                ip, ix = _pattern(mesh)
            indptrs.append(np.asarray(ip[1:], dtype=np.int64) + nnz)
            indices.append(np.asarray(ix, dtype=np.int64) + b.dofs.start)
            nnz += int(ip[-1])
        n = problem.n_dofs
        self.indptr, self.indices = np.concatenate(indptrs), np.concatenate(indices)
        self.data = np.zeros(nnz)
        self.n = n
        cp, ri, self._src = problem.dofmap._m.reduce_pattern(self.indptr, self.indices)
        self._free_pattern = (np.asarray(cp), np.asarray(ri))

    def _evaluate(self, u, tangent: bool):
        f = np.zeros(self.n)
        energy = 0.0
        pos = 0
        for dofs, asm, laws, of, K in self.parts:
            ub = np.ascontiguousarray(u[dofs])
            if asm is not None:
                if tangent:
                    fb, kb, w = asm.force_and_tangent(ub, laws, of)
                    self.data[pos:pos + len(kb)] = kb
                    pos += len(kb)
                else:
                    fb, w = asm.internal_force(ub, laws, of)
                f[dofs] = fb
                energy += float(w)
            else:
                fb = K @ ub
                f[dofs] = fb
                energy += 0.5 * dot(ub, fb)
                if tangent:
                    self.data[pos:pos + K.nnz] = K.data
                    pos += K.nnz
        return f, energy

    def force(self, u) -> tuple:
        """``(f_int, energy)`` at the displacement ``u`` (all DOFs)."""
        return self._evaluate(u, tangent=False)

    def force_and_tangent(self, u) -> tuple:
        """``(f_int, energy)``; the tangent's values stay in :meth:`tangent_free` / :meth:`tangent_full`."""
        return self._evaluate(u, tangent=True)

    def tangent_full(self) -> sp.csc_matrix:
        """K_T of all DOFs (from the last :meth:`force_and_tangent`)."""
        return sp.csc_matrix((self.data, self.indices, self.indptr), shape=(self.n, self.n))

    def tangent_free(self) -> sp.csc_matrix:
        """K_T,ff (from the last :meth:`force_and_tangent`), on the fixed free pattern."""
        cp, ri = self._free_pattern
        m = len(self.free)
        return sp.csc_matrix((self.data[self._src], ri, cp), shape=(m, m))


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


def _norm(x) -> float:
    return float(np.sqrt(dot(x, x)))


#: What to try when a step is too large, in statics (load steps) and in dynamics (time step):
#: (the general remedy, the remedy for a tangent that is not positive definite).
LOAD_STEP_HINTS = ("more load steps ([time] load_steps)", NOT_SPD_HINT)
TIME_STEP_HINTS = ("a shorter time step ([time] step)",
                   "a shorter time step ([time] step; K_eff = M/(beta h^2) + ... is positive definite for a short "
                   "enough step)")


def newton_solve(model, u, f_ext, fixed_values, params: NewtonParams = NewtonParams(),
                 where: str = "load step", tangent: _Tangent | None = None, reference: float = 0.0,
                 hints: tuple = LOAD_STEP_HINTS, keep_factor: bool = False, enforce=None,
                 fallback=None, spd_fallback: bool = False) -> NewtonInfo:
    """Solves ``f_int(u) = f_ext`` on the free DOFs with the fixed DOFs at ``fixed_values``.

    ``model``: a :class:`FiniteStrainModel`, or anything with its interface (``free``,
    ``fixed``, ``n``, ``force``, ``force_and_tangent``, ``tangent_free``, ``tangent_full``;
    the HHT-alpha balance of a time step is one, :class:`HHTBalance`).
    ``u`` (all DOFs) is the start (the last converged state) and is updated in place.
    ``where`` names the step in errors, ``hints`` what to try (:data:`LOAD_STEP_HINTS`,
    :data:`TIME_STEP_HINTS`). ``reference``: a force (N) the residual tolerance is relative to
    at least (dynamics: the size of the step's inertia and internal forces). ``keep_factor``:
    modified Newton starts with the factor ``tangent`` holds (made in an earlier step) instead
    of refactoring at the first iteration (it refactors when the residual falls too slowly,
    as within a step). ``fallback``: free DOFs to start from instead when ``u`` inverts an
    element (dynamics: the extrapolated predictor may, the last solution does not).
    ``spd_fallback``: a tangent at an iterate that is not positive definite does not stop
    the iteration; the last SPD factor is made again where it was made (``tangent.at``) and
    kept for the rest of the step (modified-Newton iterations: a descent direction for any
    SPD factor, with the line search). Dynamics: the step's incremental potential can be
    locally non-convex at an iterate (an element buckling under contact) and still have the
    solution the iteration converges to. Counted in ``NewtonInfo.fallbacks``.

    ``enforce(u_lin, iteration) -> (u_new, f_c)``: implicit forces (contact) inside the
    iteration. It gets the linearised solution without them (free DOFs, ``u + du`` with
    ``K_T du = -(g(u) - f_ext)``) and returns the solution with its forces and those forces
    as they enter the balance (free DOFs), decided in full at every iteration from the
    linearisation at the iterate: ``u_new = u_lin + K_T^-1 f_c`` (with the factor in use).
    The iteration then solves ``g(u) = f_ext + f_c``; the line search and the convergence
    test see f_c, and the step is not converged before ``enforce`` ran once. Returns the
    :class:`NewtonInfo`; raises :class:`ConvergenceError` (with the residual history and what
    to try) if the iteration does not converge within ``params.max_iterations`` solves."""
    free, fixed = model.free, model.fixed
    tangent = tangent or _Tangent()
    info = NewtonInfo()
    fe = f_ext[free]
    more_steps, not_spd_hint = hints

    def fail(reason: str, hint: str):
        hist = ", ".join(f"{x:.3g}" for x in info.relative_residuals)
        raise ConvergenceError(
            f"{where}: Newton ({params.method}) {reason}; relative residuals |r|/{info.reference:.3g} N: [{hist}]. "
            f"Try {hint}"
        )

    # 1. The residual of the last converged state under the new loads, and the predictor.
    modified = params.method == "modified"
    fresh = not (keep_factor and modified)  # the model's tangent is at the current u (else its last evaluation was a force only)
    evaluate = model.force_and_tangent if fresh else model.force
    try:
        f, w = evaluate(u)
    except _core.FiniteStrainError as e:
        if fallback is None:
            raise ConvergenceError(f"{where}: the start of the step is not admissible ({e}). Try {more_steps}") from None
        u[free] = fallback  # an extrapolated start that inverts an element: from the last solution
        try:
            f, w = evaluate(u)
        except _core.FiniteStrainError as e:
            raise ConvergenceError(f"{where}: the start of the step is not admissible ({e}). Try {more_steps}") from None
    r = f[free] - fe
    info.residuals.append(_norm(r))
    info.reference = max(info.residuals[0], _norm(fe), reference)
    du_p = np.zeros(model.n)
    du_p[fixed] = fixed_values - u[fixed]
    if np.any(du_p):
        if not fresh:
            model.force_and_tangent(u)
        try:
            tangent.update(model.tangent_free(), u)
        except _NotPositiveDefinite as e:
            fail("cannot start: " + NOT_SPD.format(e), not_spd_hint)
        rhs = r + (model.tangent_full() @ du_p)[free]
        info.reference = max(info.reference, _norm(rhs))  # the force the prescribed motion of the step exerts
        du = -tangent.factor.solve(rhs)  # type: ignore[union-attr]
        u[fixed] = fixed_values
        u_old = u[free].copy()
        u[free] += du
        try:
            f, w = model.force_and_tangent(u)
        except _core.FiniteStrainError:
            u[free] = u_old  # the linearised motion inverts an element: start from the old free DOFs
            try:
                f, w = model.force_and_tangent(u)
            except _core.FiniteStrainError as e:
                fail(f"cannot start: the prescribed displacement of this step inverts an element ({e})", more_steps)
        fresh = True
        info.increments.append(_norm(u[free] - u_old))
        info.steps.append(1.0)
        r = f[free] - fe
        info.residuals.append(_norm(r))
    tol_r = params.residual_tolerance * info.reference
    if info.reference == 0.0 or (info.residuals[-1] <= tol_r and not info.increments):
        # In balance at the start: done, unless implicit forces (contact) act there.
        if enforce is None or not np.any(enforce(u[free].copy(), 0)[1]):
            info.force, info.energy, info.factorizations = f, w, tangent.count
            return info
    fc = np.zeros(len(free))  # the implicit forces of the last enforcement, as in the balance
    enforced = enforce is None
    held = False  # the last SPD factor is kept for the rest of the step (spd_fallback)
    while True:
        rn = info.residuals[-1]
        if enforced and info.increments and rn <= tol_r and info.increments[-1] <= params.increment_tolerance * max(_norm(u), 1e-300):
            break
        if info.iterations >= params.max_iterations:
            rel = info.relative_residuals
            if len(rel) > 4 and rel[-1] < 1e-6 and rel[-1] > 0.5 * rel[-4]:  # no progress in 3 iterations, near balance
                fail(f"did not converge in {params.max_iterations} iterations: the residual stagnates at {rel[-1]:.2g} "
                     "of the step's force, its round-off floor (the stress of a slightly strained hyperelastic "
                     "element loses digits to cancellation)", f"a larger [time.newton] residual_tolerance (> {rel[-1]:.1g})")
            fail(f"did not converge in {params.max_iterations} iterations",
                 f"{more_steps}" + (", method = 'full'" if modified else "") + ", or a larger max_iterations")
        first = 0.0 if keep_factor and modified else 1.0  # the first iteration: reuse the old factor?
        ratio = rn / info.residuals[-2] if len(info.residuals) > 1 and info.residuals[-2] > 0 else first
        if not held and not (modified and tangent.factor is not None and ratio <= params.refactor_ratio):
            if not fresh:  # K_T at the iterate; its force equals the line search's bit for bit
                f, w = model.force_and_tangent(u)
                fresh = True
            try:
                tangent.update(model.tangent_free(), u)
            except _NotPositiveDefinite as e:
                if not (spd_fallback and tangent.at is not None):
                    fail(f"stopped at iteration {info.iterations + 1}: " + NOT_SPD.format(e), not_spd_hint)
                at = tangent.at
                model.force_and_tangent(at)  # the last SPD tangent, where it was made: the same numbers
                try:
                    tangent.update(model.tangent_free(), at)
                except _NotPositiveDefinite:
                    fail(f"stopped at iteration {info.iterations + 1}: " + NOT_SPD.format(e), not_spd_hint)
                fresh, held = False, True
                info.fallbacks += 1
        du = -tangent.factor.solve(r + fc if enforce is not None else r)  # type: ignore[union-attr]
        u0 = u[free].copy()
        if enforce is not None:
            # The implicit forces decided on this linearisation: du = -K_T^-1 (g - f_ext - f_c).
            r = r + fc
            u_new, fc = enforce(u0 + du, info.iterations)
            du = u_new - u0
            r -= fc
            enforced = True
            if _norm(fc) > info.reference:
                info.reference = _norm(fc)
                tol_r = params.residual_tolerance * info.reference
        s, trial = 1.0, None
        g0 = dot(du, r)  # dPi/ds at s = 0: -r K_T^-1 r < 0 (K_T is SPD)
        for _ in range(MAX_BACKTRACKS + 1):
            u[free] = u0 + s * du
            try:
                f_try, w_try = model.force(u)
            except _core.FiniteStrainError:
                f_try = None
            if f_try is None or not np.all(np.isfinite(f_try)):
                if not params.line_search:
                    break
                s *= 0.5  # the trial inverts an element: halve
                continue
            r_try = f_try[free] - fe
            if enforce is not None:
                r_try -= fc
            trial = (s, r_try, f_try, w_try)
            g = dot(du, r_try)
            if not params.line_search or g <= LINE_SEARCH_RATIO * abs(g0):
                break  # |residual along du| reduced enough, or still descending at s
            s *= max(0.1, g0 / (g0 - g))  # the secant root of du . r(s) on [0, s] (g > 0 > g0)
        if trial is None:
            u[free] = u0
            fail("cannot proceed: every trial step inverts an element", more_steps)
        s, r, f, w = trial  # type: ignore[misc]
        rn_new = _norm(r)
        u[free] = u0 + s * du
        info.steps.append(s)
        info.increments.append(s * _norm(du))
        info.residuals.append(rn_new)
        fresh = False
    info.force, info.energy = f, w
    info.factorizations = tangent.count
    return info


def _unloaded_factor(model, problem, what: str) -> tuple:
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


class NewtonStaticIntegrator(StaticIntegrator):
    """``mode = "static"`` with a finite-strain body (chosen by :class:`StaticIntegrator`):
    load step k of N solves the nonlinear balance at lambda = k / N by :func:`newton_solve`."""

    name: ClassVar[str] = "static"  # type: ignore[misc]
    dynamic = False

    def __init__(self, problem, time):
        Integrator.__init__(self, problem, time)
        self.params = getattr(time, "newton", None) or NewtonParams()
        self.model = FiniteStrainModel(problem)
        self.tangent, self.effective_matrix = _unloaded_factor(self.model, problem, "the stiffness")
        self.factor = self.tangent.factor
        self.force_scale = 1.0
        self.last: NewtonInfo | None = None  # the last load step's iteration

    def step(self, state, loads, ctx, hooks) -> None:
        p = self.problem
        lam_prev, lam = state.t, state.t_next
        F = loads[p.free]
        ctx.begin(lam_prev, lam, F.copy())
        ctx.u_tilde = ctx.v_tilde = None
        fixed_values = p.fixed_values(lam, static=True)
        u = state.u.copy()
        count0 = self.tangent.count
        t0 = time.perf_counter()
        enforce = _implicit_forces(ctx, hooks, lambda: ctx.begin(lam_prev, lam, F.copy())) if hooks.correct else None
        info = newton_solve(self.model, u, loads, fixed_values, self.params,
                            f"load step {state.step}/{self.n_steps} (load factor {lam:.4g})", self.tangent,
                            enforce=enforce)
        self.solve_seconds += time.perf_counter() - t0
        self.factor = self.tangent.factor
        info.factorizations = self.tangent.count - count0
        self.last = info
        state.u_free[:] = u[p.free]
        state.sync(fixed_values)
        state.internal_force = info.force
        state.elastic_energy = info.energy
        state.records = {"newton_iterations": info.iterations, "newton_factorizations": info.factorizations,
                         "newton_residual": float(info.relative_residuals[-1])}


def _implicit_forces(ctx, hooks, begin):
    """The ``enforce`` of :func:`newton_solve` for the effects' ``correct`` hooks (contact):
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


# ---- dynamics: HHT-alpha with Newton --------------------------------------------------------
def _on_pattern(A, indptr, indices, n: int) -> np.ndarray:
    """The values of the sparse ``A`` (n x n) on the CSC pattern ``(indptr, indices)``, which
    must hold every entry of A (zeros elsewhere)."""
    A = sp.csc_matrix(A)
    A.sum_duplicates()
    keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr)) * n + indices
    order = np.argsort(keys, kind="stable")
    a_keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr)) * n + A.indices
    at = np.minimum(np.searchsorted(keys[order], a_keys), len(keys) - 1)
    pos = order[at]
    if not np.array_equal(keys[pos], a_keys):
        raise SolverError("the mass or damping matrix has entries outside the stiffness pattern")
    out = np.zeros(len(indices))
    out[pos] = A.data
    return out


class HHTBalance:
    """The HHT-alpha balance of one time step, as a model for :func:`newton_solve`:

        g(u) = M a(u) + (1 + alpha) (f_int(u) + C v(u)),
        a(u) = (u - u~) / (beta h^2),  v(u) = v~ + gamma h a(u)   on the free DOFs

    (``u_tilde``, ``v_tilde``: the Newmark predictors, set per step; on the fixed DOFs a and v
    are the prescribed motion's, ``a_fixed``, ``v_fixed``), so the step solves g(u_n+1) = the
    step's constant forces. Its tangent on the free DOFs is
    ``K_eff = M/(beta h^2) + (1 + alpha)(gamma/(beta h) C + K_T)``, on the fixed pattern of
    K_T (M and C are scattered into it once). ``tangent_full`` is the derivative of g with
    respect to the fixed DOFs (the columns :func:`newton_solve` multiplies it by):
    ``(1 + alpha) K_T``, the prescribed velocity and acceleration not depending on u.
    C is the problem's damping (Rayleigh, C = a0 M + a1 K with K the initial tangent)."""

    def __init__(self, model: FiniteStrainModel, problem, alpha: float, beta: float, gamma: float, h: float):
        self.model = model
        self.free, self.fixed, self.n = model.free, model.fixed, model.n
        self.opa = 1.0 + alpha
        self.c_m = 1.0 / (beta * h * h)
        self.gh = gamma * h
        self.M = sp.csr_matrix(problem.M)
        if not problem.damped:
            self.C = None
        elif problem.C is not None:
            self.C = sp.csr_matrix(problem.C)
        else:
            a0, a1 = problem.rayleigh
            self.C = sp.csr_matrix(a0 * problem.M + a1 * problem.K)
        mc = self.c_m * self.M
        if self.C is not None:
            mc = mc + (self.opa * gamma / (beta * h)) * self.C
        self._mc = _on_pattern(mc, model.indptr, model.indices, model.n)
        nf, nx = len(self.free), len(self.fixed)
        self.u_tilde, self.v_tilde = np.zeros(nf), np.zeros(nf)
        self.a_fixed, self.v_fixed = np.zeros(nx), np.zeros(nx)
        self.a, self.v = np.zeros(self.n), np.zeros(self.n)  # of the last evaluation, all DOFs
        self.last: tuple | None = None  # (u, f_int, strain energy) of the last evaluation

    def motion(self, u) -> None:
        """a(u) and v(u) (all DOFs) into ``self.a``, ``self.v``."""
        a, v, free = self.a, self.v, self.free
        a[free] = self.c_m * (u[free] - self.u_tilde)
        a[self.fixed] = self.a_fixed
        v[free] = self.v_tilde + self.gh * a[free]
        v[self.fixed] = self.v_fixed

    def damping(self, v) -> np.ndarray | None:
        """C v (all DOFs), or None without damping."""
        return None if self.C is None else self.C @ v

    def _balance(self, u, f, w):
        self.last = (u.copy(), f, w)
        self.motion(u)
        g = self.M @ self.a
        g += self.opa * f
        cv = self.damping(self.v)
        if cv is not None:
            g += self.opa * cv
        return g, w

    def force(self, u) -> tuple:
        return self._balance(u, *self.model.force(u))

    def force_and_tangent(self, u) -> tuple:
        return self._balance(u, *self.model.force_and_tangent(u))

    def internal_force(self, u) -> tuple:
        """``(f_int, strain energy)`` at u: from the last evaluation if it was at u."""
        if self.last is not None and np.array_equal(self.last[0], u):
            return self.last[1], self.last[2]
        return self.model.force(u)

    def tangent_free(self) -> sp.csc_matrix:
        cp, ri = self.model._free_pattern
        data = self.opa * self.model.data
        data += self._mc
        return sp.csc_matrix((data[self.model._src], ri, cp), shape=(len(self.free),) * 2)

    def tangent_full(self) -> sp.csc_matrix:
        return self.opa * self.model.tangent_full()


class NewtonHHTIntegrator(HHTIntegrator):
    """``mode = "dynamic"`` with a finite-strain body (chosen by :class:`HHTIntegrator`):
    HHT-alpha in the generalised-alpha form for nonlinear internal forces,

        M a_n+1 + (1+alpha)[f_int(u_n+1) + C v_n+1] - alpha [f_int(u_n) + C v_n]
            = (1+alpha) F_n+1 - alpha F_n,

    with the Newmark updates of :class:`~vfrs.dynamics.hht.HHTAlpha` (beta = (1-alpha)^2/4,
    gamma = 1/2 - alpha), solved for u_n+1 by :func:`newton_solve` on :class:`HHTBalance`
    (K_eff = M/(beta h^2) + (1+alpha)(gamma/(beta h) C + K_T); the same line search,
    convergence tests, modified-Newton option and errors as the statics). Newton starts from
    the constant-acceleration predictor u_n + h v_n + h^2/2 a_n (from u_n where that
    extrapolation inverts an element); its residual tolerance is
    relative to at least the size of the step's inertia, internal forces and momentum rate,
    max(|M a_n|, (1+alpha)|f_int(u_n)|, |M v_n| / h) on the free DOFs.

    ``method = "modified"`` keeps the factor of K_eff across steps (each step starts with the
    last one made, and refactors when the residual falls by less than ``refactor_ratio`` per
    iteration): in a small step K_eff hardly changes.

    Explicit effect forces (``forces`` hooks: loads, the Bernoulli flow) enter F as for a
    linear body. ``predict`` hooks (the contact-stabilized predictor) run once per step on
    the Newmark predictors, and Newton starts from the constant-acceleration predictor moved
    as they moved u~; ``correct`` hooks (contact) run inside every Newton iteration
    (:func:`newton_solve`'s ``enforce``), a force they add stays in F_n+1 (the next step's
    F_n), a transient one acts within the step and is taken out of the next predictor as in
    :class:`~vfrs.dynamics.hht.HHTAlpha`. Carried between steps (checkpoints): F_n,
    f_int(u_n), the last step's transient forces, and with modified Newton the displacement
    the factor was made at (refactored there on restore: the same numbers)."""

    name: ClassVar[str] = "dynamic"  # type: ignore[misc]
    dynamic = True

    def __init__(self, problem, time):
        Integrator.__init__(self, problem, time)
        self.params = getattr(time, "newton", None) or NewtonParams()
        self.alpha, self.h = float(time.alpha), float(time.step)
        self.step_size = self.h
        self.beta, self.gamma = hht_parameters(self.alpha)
        self.model = FiniteStrainModel(problem)
        self.balance = HHTBalance(self.model, problem, self.alpha, self.beta, self.gamma, self.h)
        self.tangent, self.effective_matrix = _unloaded_factor(self.balance, problem, "K_eff")
        self.factor = self.tangent.factor
        self.force_scale = 1.0 + self.alpha
        self.predictor_scale = self.h**2 * (0.5 - self.beta)
        self.transient_weight = self.gamma * (1.0 + self.alpha)
        n = len(problem.free)
        self.F0, self.F1 = np.zeros(n), np.zeros(n)
        self.f0 = np.zeros(problem.n_dofs)  # f_int(u_n), all DOFs
        self.last: NewtonInfo | None = None  # the last step's iteration
        self._mass_factor = None
        self._solve_seconds = 0.0
        self._f_transient: np.ndarray | None = None  # last step's transient forces (free DOFs)
        self.transient_shift = transient_shift(self.alpha, self.beta, self.gamma, self.h)

    @property
    def mass_factor(self):
        if self._mass_factor is None:
            self._mass_factor = mass_factor(self.problem.M_free)
        return self._mass_factor

    @property
    def solve_seconds(self):
        return self._solve_seconds

    def state(self) -> dict:
        # Modified Newton carries its factor across steps: where it was made (refactored there
        # on restore, the same numbers).
        at = self.tangent.at if self.params.method == "modified" else None
        ft = self._f_transient
        return {"F0": self.F0.copy(), "f_int": self.f0.copy(), "factor_at": None if at is None else at.copy(),
                "f_transient": None if ft is None else ft.copy()}

    def restore(self, state: dict) -> None:
        self.F0[:] = state["F0"]
        self.f0[:] = state["f_int"]
        ft = state.get("f_transient")
        self._f_transient = None if ft is None else ft.copy()
        at = state.get("factor_at")
        if at is not None:
            self.balance.force_and_tangent(at)
            self.tangent.update(self.balance.tangent_free(), at)

    def start(self, state, loads) -> None:
        p = self.problem
        v0 = np.concatenate([np.tile(b.config.velocity, b.n_points) for b in p.bodies])
        state.v_free[:] = v0[p.free]
        self.F0[:] = loads[p.free]
        self.accelerate(state)

    def accelerate(self, state) -> None:
        """The initial acceleration from the balance at t = 0 with the state's u and v (free
        DOFs; the fixed ones get the prescribed motion): M a_0 = F_0 - f_int(u_0) - C v_0."""
        p, b = self.problem, self.balance
        a_fixed = p.fixed_values(0.0, 2)
        state.sync(p.fixed_values(0.0), p.fixed_values(0.0, 1), a_fixed)
        f, w = self.model.force(state.u)
        r = -f
        r[p.free] += self.F0
        cv = b.damping(state.v)
        if cv is not None:
            r -= cv
        if np.any(a_fixed):
            a = np.zeros(p.n_dofs)
            a[p.fixed] = a_fixed
            r -= b.M @ a
        state.a_free[:] = self.mass_factor.solve(r[p.free]) if np.any(r[p.free]) else 0.0
        state.sync(p.fixed_values(0.0), p.fixed_values(0.0, 1), a_fixed)
        self.f0[:] = f
        state.internal_force, state.elastic_energy = f.copy(), w
        state.records = {"newton_iterations": 0, "newton_factorizations": 0, "newton_residual": 0.0,
                         "newton_fallbacks": 0}

    def step(self, state, loads, ctx, hooks) -> None:
        p, b = self.problem, self.balance
        free = p.free
        h, beta, gamma, al = self.h, self.beta, self.gamma, self.alpha
        t_prev, t1 = state.t, state.t_next
        self.F1[:] = loads[free]
        ctx.begin(t_prev, t1, self.F1)
        u0, v0, a0 = state.u_free, state.v_free, state.a_free
        b.u_tilde[:] = u0 + h * v0 + (h * h * (0.5 - beta)) * a0
        b.v_tilde[:] = v0 + (h * (1.0 - gamma)) * a0
        # Last step's transient forces (a constraint's reaction in the contact-stabilized
        # scheme) acted in that step only: the predictor must not see them (as in HHTAlpha.step);
        # predict hooks (the stabilized predictor) may take them out themselves.
        shift = np.zeros(len(free))  # how far the predict hooks and the transient forces moved u~
        pending, self._f_transient = self._f_transient, None
        if hooks.predict or pending is not None:
            ut_before = b.u_tilde.copy()
            correct_predictor(b.u_tilde, b.v_tilde, pending, self.transient_shift, self.mass_factor.solve, ctx,
                              hooks.predict)
            shift = b.u_tilde - ut_before
        loads_free = self.F1.copy()

        def begin():  # every Newton iteration decides the implicit forces anew
            self.F1[:] = loads_free
            ctx.begin(t_prev, t1, self.F1)
            ctx.u_tilde, ctx.v_tilde = b.u_tilde, b.v_tilde

        enforce = _implicit_forces(ctx, hooks, begin) if hooks.correct else None
        b.v_fixed[:] = p.fixed_values(t1, 1)
        b.a_fixed[:] = p.fixed_values(t1, 2)
        fixed_u = p.fixed_values(t1)
        # The step's constant forces: (1+alpha) F_n+1 - alpha F_n + alpha (f_int(u_n) + C v_n).
        f_ext = np.zeros(p.n_dofs)
        f_ext[free] = (1.0 + al) * self.F1 - al * self.F0
        if al:
            f_ext += al * self.f0
            cv = b.damping(state.v)
            if cv is not None:
                f_ext += al * cv
        # (|M v_n| / h: a body moving freely has neither inertia nor internal forces, and its
        # residual is round-off; the step's momentum rate is the force its velocity is judged by.)
        reference = max(_norm((b.M @ state.a)[free]), (1.0 + al) * _norm(self.f0[free]),
                        _norm((b.M @ state.v)[free]) / h)
        u = state.u.copy()
        u[free] = u0 + h * v0 + (0.5 * h * h) * a0  # constant acceleration
        u[free] += shift  # the predictor's projection (zero without predict hooks)
        count0 = self.tangent.count
        t0 = time.perf_counter()
        info = newton_solve(b, u, f_ext, fixed_u, self.params, f"step {state.step}/{self.n_steps} (t = {t1:.6g} s)",
                            self.tangent, reference, TIME_STEP_HINTS, keep_factor=True, enforce=enforce,
                        fallback=u0, spd_fallback=True)
        self._solve_seconds += time.perf_counter() - t0
        self.factor = self.tangent.factor
        info.factorizations = self.tangent.count - count0
        self.last = info
        f, w = b.internal_force(u)
        b.motion(u)
        state.u_free[:] = u[free]
        state.a_free[:] = b.a[free]
        state.v_free[:] = b.v[free]
        if ctx.velocity_jump is not None:
            state.v_free += ctx.velocity_jump  # an impulse at t_n+1 (StepContext.set_velocity_jump)
        state.sync(fixed_u, b.v_fixed, b.a_fixed)
        self.f0[:] = f
        state.internal_force, state.elastic_energy = f.copy(), w
        state.records = {"newton_iterations": info.iterations, "newton_factorizations": info.factorizations,
                         "newton_residual": float(info.relative_residuals[-1]),
                         "newton_fallbacks": info.fallbacks}
        if ctx.transient_free is not None:
            self._f_transient = ctx.transient_free.copy()
        self.F0, self.F1 = self.F1, self.F0
