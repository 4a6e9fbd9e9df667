"""Statics with finite strain: load steps, Newton with a line search (issue 14, first slice).

A body whose material is finite-strain (``kinematics = "finite"``: ``neo_hookean``,
``st_venant_kirchhoff``) makes ``[time] mode = "static"`` run :class:`NewtonStaticIntegrator`
instead of the linear :class:`~vfrs.dynamics.integrators.StaticIntegrator` (which selects it;
the march loop does not change). Linear scenes never reach this module.

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
from ..errors import ConvergenceError, SceneError, SolverError
from ..linalg import Cholesky
from ..materials import kinematics_of
from ..params import param
from .integrators import Integrator, StaticIntegrator

__all__ = ["NewtonParams", "NewtonInfo", "FiniteStrainModel", "newton_solve", "NewtonStaticIntegrator",
           "has_finite_strain"]

#: Line search: a step length is accepted when the residual projected on the Newton direction
#: has fallen to this fraction of its value at the start, |du . r(u + s du)| <= 0.9 |du . r(u)|
#: (the criterion of Bonet & Wood, with FEBio's default 0.9), or is still negative; at most this many trials.
LINE_SEARCH_RATIO = 0.9
MAX_BACKTRACKS = 10


@dataclass(frozen=True)
class NewtonParams:
    """``[time.newton]``: the Newton options of finite-strain statics (defaults when omitted)."""

    method: str = param("full", doc="'full' (a new tangent every iteration) or 'modified' (reuse the factor while the "
                                    "residual falls fast)", choices=("full", "modified"))
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
                energy += 0.5 * float(ub @ fb)
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

    def update(self, K) -> None:
        """Factors K (numeric refactorization after the first); :class:`_NotPositiveDefinite`
        if it is not SPD."""
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


class _NotPositiveDefinite(Exception):
    pass


#: What a tangent that is not SPD means, and what to try.
NOT_SPD = ("the tangent stiffness K_T is not positive definite ({}): the iterate is past a limit or bifurcation "
           "point (buckling, snap-through) or an element is close to inversion, and the Cholesky factor (LL^T) "
           "needs an SPD tangent")
NOT_SPD_HINT = ("more load steps ([time] load_steps; a smaller step keeps the iterates near the stable path); a load "
                "past a limit point needs an arc-length method, which vfrs does not have yet")


def _norm(x) -> float:
    return float(np.sqrt(np.dot(x, x)))


def newton_solve(model: FiniteStrainModel, u, f_ext, fixed_values, params: NewtonParams = NewtonParams(),
                 where: str = "load step", tangent: _Tangent | None = None) -> NewtonInfo:
    """Solves ``f_int(u) = f_ext`` on the free DOFs with the fixed DOFs at ``fixed_values``.

    ``u`` (all DOFs) is the start (the last converged state) and is updated in place.
    ``where`` names the step in errors. Returns the :class:`NewtonInfo`; raises
    :class:`ConvergenceError` (with the residual history and what to try) if the iteration
    does not converge within ``params.max_iterations`` solves."""
    free, fixed = model.free, model.fixed
    tangent = tangent or _Tangent()
    info = NewtonInfo()
    fe = f_ext[free]
    more_steps = "more load steps ([time] load_steps)"

    def fail(reason: str, hint: str):
        hist = ", ".join(f"{x:.3g}" for x in info.relative_residuals)
        raise ConvergenceError(
            f"{where}: Newton ({params.method}) {reason}; relative residuals |r|/{info.reference:.3g} N: [{hist}]. "
            f"Try {hint}"
        )

    # 1. The residual of the last converged state under the new loads, and the predictor.
    try:
        f, w = model.force_and_tangent(u)
    except _core.FiniteStrainError as e:
        raise ConvergenceError(f"{where}: the start of the step is not admissible ({e}). Try {more_steps}") from None
    r = f[free] - fe
    info.residuals.append(_norm(r))
    info.reference = max(info.residuals[0], _norm(fe))
    du_p = np.zeros(model.n)
    du_p[fixed] = fixed_values - u[fixed]
    if np.any(du_p):
        try:
            tangent.update(model.tangent_free())
        except _NotPositiveDefinite as e:
            fail("cannot start: " + NOT_SPD.format(e), NOT_SPD_HINT)
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
        info.increments.append(_norm(u[free] - u_old))
        info.steps.append(1.0)
        r = f[free] - fe
        info.residuals.append(_norm(r))
    tol_r = params.residual_tolerance * info.reference
    if info.reference == 0.0 or (info.residuals[-1] <= tol_r and not info.increments):
        info.force, info.energy, info.factorizations = f, w, tangent.count
        return info
    modified = params.method == "modified"
    while True:
        rn = info.residuals[-1]
        if info.increments and rn <= tol_r and info.increments[-1] <= params.increment_tolerance * max(_norm(u), 1e-300):
            break
        if info.iterations >= params.max_iterations:
            rel = info.relative_residuals
            if len(rel) > 4 and rel[-1] < 1e-6 and rel[-1] > 0.5 * rel[-4]:  # no progress in 3 iterations, near balance
                fail(f"did not converge in {params.max_iterations} iterations: the residual stagnates at {rel[-1]:.2g} "
                     "of the step's force, its round-off floor (the stress of a slightly strained hyperelastic "
                     "element loses digits to cancellation)", f"a larger [time.newton] residual_tolerance (> {rel[-1]:.1g})")
            fail(f"did not converge in {params.max_iterations} iterations",
                 f"{more_steps}" + (", method = 'full'" if modified else "") + ", or a larger max_iterations")
        ratio = rn / info.residuals[-2] if len(info.residuals) > 1 and info.residuals[-2] > 0 else 1.0
        if not (modified and tangent.factor is not None and ratio <= params.refactor_ratio):
            try:
                tangent.update(model.tangent_free())
            except _NotPositiveDefinite as e:
                fail(f"stopped at iteration {info.iterations + 1}: " + NOT_SPD.format(e), NOT_SPD_HINT)
        du = -tangent.factor.solve(r)  # type: ignore[union-attr]
        u0 = u[free].copy()
        s, trial = 1.0, None
        g0 = float(du @ r)  # dPi/ds at s = 0: -r K_T^-1 r < 0 (K_T is SPD)
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
            trial = (s, r_try, f_try, w_try)
            g = float(du @ r_try)
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
        if not modified or rn_new > params.refactor_ratio * rn:  # the next iteration needs K_T here
            f, w = model.force_and_tangent(u)
    info.force, info.energy = f, w
    info.factorizations = tangent.count
    return info


class NewtonStaticIntegrator(StaticIntegrator):
    """``mode = "static"`` with a finite-strain body (chosen by :class:`StaticIntegrator`):
    load step k of N solves the nonlinear balance at lambda = k / N by :func:`newton_solve`."""

    name: ClassVar[str] = "static"  # type: ignore[misc]
    dynamic = False

    def __init__(self, problem, time):
        Integrator.__init__(self, problem, time)
        self.params = getattr(time, "newton", None) or NewtonParams()
        self.model = FiniteStrainModel(problem)
        self.tangent = _Tangent()
        self.model.force_and_tangent(np.zeros(problem.n_dofs))
        try:
            self.tangent.update(self.model.tangent_free())
        except _NotPositiveDefinite as e:
            raise SolverError(f"{problem.scene.source}: the stiffness of the unloaded state is not positive definite ({e})") from None
        self.tangent.count = 0
        self.factor = self.tangent.factor
        self.effective_matrix = self.model.tangent_free()
        self.force_scale = 1.0
        self.last: NewtonInfo | None = None  # the last load step's iteration

    def step(self, state, loads, ctx, hooks) -> None:
        p = self.problem
        if hooks.predict or hooks.correct:
            raise SceneError(f"{p.scene.source}: effects with implicit forces ({', '.join(hooks.correcting)}) do not "
                             "run inside the Newton iteration of finite-strain statics yet")
        lam_prev, lam = state.t, state.t_next
        ctx.begin(lam_prev, lam, loads[p.free].copy())
        fixed_values = p.fixed_values(lam, static=True)
        u = state.u.copy()
        count0 = self.tangent.count
        t0 = time.perf_counter()
        info = newton_solve(self.model, u, loads, fixed_values, self.params,
                            f"load step {state.step}/{self.n_steps} (load factor {lam:.4g})", self.tangent)
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
