"""Integrators: how a run advances from one time (or load factor) to the next.

``[time]`` is a role like ``[contact]``'s methods: ``mode`` names the registered integrators
of one time discretisation (:data:`INTEGRATORS`, keyed by each class's unique ``name``), and
the scene's bodies choose among them by ``kinematics`` (``"linear"``, or ``"finite"`` when a
body is finite-strain: the Newton integrators), :func:`integrator_for`. The chosen class's
``Params`` are the section's keys besides ``mode`` (read by ``resolve(table)``, written back
by ``to_dict(params)``); a new integrator is one class registered with
``@INTEGRATORS.register`` (in this module, or anywhere before the scene is loaded), and the
march loop (:func:`vfrs.run`) does not change. It provides:

- class attributes ``name``, ``mode`` (the ``[time] mode`` it serves; default: ``name``),
  ``kinematics``, ``dynamic`` (the run has inertia), ``Params``; class methods
  ``resolve(table)`` (default: :func:`~vfrs.params.read_params` and ``check``),
  ``to_dict(params)``, ``count_steps(params)``, ``describe(params, n_steps)`` (``vfrs info``),
  ``refuse_keys(table)`` (a key only it reads, in a scene that chose another integrator of
  its mode: a clear error);
- ``n_steps``, ``time(k)``: the steps (times, or load factors in statics), ``step_index(t)``;
- ``start(state, loads)``: the initial state (velocities, prescribed values, acceleration);
- ``step(state, loads, ctx, hooks)``: one step from ``state.t`` to ``state.t_next``, calling
  the effects' ``predict`` and ``correct`` hooks through the step context ``ctx``;
- ``state() -> dict`` / ``restore(dict)``: what a checkpoint keeps of the integrator between
  steps besides the run's :class:`~vfrs.dynamics.State` (default: nothing);
- what effects receive (through :class:`vfrs.effects.SetupContext`, never the integrator
  itself): ``constants`` (:class:`~vfrs.dynamics.hht.HHTConstants`: alpha, the step size h,
  beta, gamma, ``force_scale`` (``effective_matrix du = force_scale f``),
  ``predictor_scale`` (du = predictor_scale M^-1 f), ``transient_weight``, ...; or
  :class:`~vfrs.dynamics.hht.StaticConstants`), ``factor`` (of the effective matrix, for
  solves with it), ``effective_matrix``, and in dynamics ``mass``
  (:class:`~vfrs.dynamics.hht.LazyMassFactor`, M^-1 made on first use).

The Newton integrators (finite strain) iterate inside ``step`` with
:func:`vfrs.dynamics.newton.newton_solve`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..finite_strain import FiniteStrainModel
from ..params import param, params_to_dict, read_params
from ..roles import INTEGRATORS, integrator_for, mode_of, modes  # noqa: F401 (the role lives below the floors it serves)
from .hht import DEFAULT_ALPHA, HHTAlpha, HHTBalance, HHTConstants, LazyMassFactor, StaticConstants, correct_predictor
from .newton import (TIME_STEP_HINTS, NewtonInfo, NewtonOptions, NewtonParams, vector_norm, implicit_forces, newton_solve,
                     unloaded_factor)
from .problem import ramp
from .static import StaticSolver

__all__ = ["INTEGRATORS", "Integrator", "integrator_for", "modes", "MAX_STEPS", "HHTIntegrator", "StaticIntegrator",
           "NewtonHHTIntegrator", "NewtonStaticIntegrator"]


#: The most time or load steps a scene may ask for (a step costs at least a solve).
MAX_STEPS = 10**8


class Integrator:
    """Base class; see the module docstring for the protocol."""

    name = ""
    mode = ""  # the [time] mode it serves (empty: its name)
    kinematics = "linear"
    dynamic = False
    Params: Any = None
    solve_seconds = 0.0  # time in the triangular solves of the steps
    constants: Any = None  # HHTConstants or StaticConstants, set by __init__
    mass: Any = None  # a LazyMassFactor: M^-1 made on first use (dynamics)
    factor: Any = None
    effective_matrix: Any = None

    def __init__(self, problem, time):
        self.problem = problem
        self.n_steps = time.n_steps

    # ---- the scene's [time] keys -----------------------------------------------------------
    @classmethod
    def resolve(cls, table):
        """``Params`` from the ``[time]`` table (the caller reads ``mode`` and calls ``done``)."""
        params = read_params(cls.Params, table)
        cls.check(params, table)
        return params

    @classmethod
    def check(cls, params, table) -> None:
        """Checks across keys (errors through ``table.error``)."""

    @classmethod
    def to_dict(cls, params) -> dict:
        return params_to_dict(params)

    @classmethod
    def count_steps(cls, params) -> int:
        raise NotImplementedError

    @classmethod
    def describe(cls, params, n_steps: int) -> str:
        return f"{cls.name}, {n_steps} steps"

    @classmethod
    def refuse_keys(cls, table) -> None:
        """Called when the scene's bodies chose another integrator of this one's mode: raises
        if ``table`` holds a key only this one reads (default: nothing)."""

    # ---- the march ---------------------------------------------------------------------------
    @property
    def force_scale(self) -> float:
        return self.constants.force_scale

    def time(self, k: int) -> float:
        return self.constants.time(k)

    def step_index(self, t: float) -> int:
        return self.constants.step_index(t)

    def start(self, state, loads) -> None:
        raise NotImplementedError

    def step(self, state, loads, ctx, hooks) -> None:
        raise NotImplementedError

    def state(self) -> dict:
        """What the integrator carries from one step to the next (for checkpoints)."""
        return {}

    def restore(self, state: dict) -> None:
        """Back to a checkpoint's :meth:`state`."""


@INTEGRATORS.register
class HHTIntegrator(Integrator):
    """``mode = "dynamic"``: HHT-alpha with K_eff factored once (:class:`HHTAlpha`).

    ``loads`` (all DOFs) are the external and explicit effect forces at the end of the step;
    prescribed displacements enter through their coupling K_fp d, C_fp d, M_fp d (computed
    once) times the ramp and its derivatives.
    """

    name = "dynamic"
    dynamic = True

    @dataclass(frozen=True)
    class Params:
        step: float = param(doc="time step", unit="s", positive=True)
        end: float = param(doc="end time", unit="s", positive=True)
        alpha: float = param(DEFAULT_ALPHA, doc="HHT-alpha", low=-1.0 / 3.0, high=0.0)

    @classmethod
    def check(cls, params, table) -> None:
        step, end = params.step, params.end
        if end < step:
            raise table.error(f"end = {end:g} s is shorter than one step ({step:g} s)", "end")
        if not end / step <= MAX_STEPS:
            raise table.error(f"end = {end:g} s is {end / step:.3g} steps of {step:g} s; at most {MAX_STEPS:.0e} steps "
                              "(shorten end or lengthen step)", "end")

    @classmethod
    def count_steps(cls, params) -> int:
        # Enough steps to reach `end` (the last may pass it by less than a step).
        return max(1, math.ceil(params.end / params.step - 1e-9))

    @classmethod
    def describe(cls, params, n_steps: int) -> str:
        return f"HHT-alpha, alpha = {params.alpha:g}, step {params.step:g} s, end {params.end:g} s, {n_steps} steps"

    def __init__(self, problem, time):
        super().__init__(problem, time)
        self.hht = HHTAlpha(problem.M_free, problem.K_free, time.params.step, time.params.alpha,
                            rayleigh=problem.rayleigh or (0.0, 0.0), C=problem.C_free)
        self.constants = self.hht.constants
        self.mass = self.hht.mass
        self.factor = self.hht.factor
        self.effective_matrix = self.hht.K_eff
        n = len(problem.free)
        # The HHT force vectors at the two ends of the step: loads, plus the implicit forces
        # that stay in the recursion (StepContext.add_force adds those to F1 in place).
        self.F0, self.F1 = np.zeros(n), np.zeros(n)

    @property
    def solve_seconds(self):
        return self.hht.solve_seconds

    def state(self) -> dict:
        # F0: the forces of the step's start, with the implicit forces that stay in the
        # recursion (F1 is refilled every step).
        return {"F0": self.F0.copy(), "hht": self.hht.state()}

    def restore(self, state: dict) -> None:
        self.F0[:] = state["F0"]
        self.hht.restore(state["hht"])

    def start(self, state, loads) -> None:
        p = self.problem
        free = p.free
        v0 = np.concatenate([np.tile(b.config.velocity, b.n_points) for b in p.bodies])
        state.v_free[:] = v0[free]
        self.F0[:] = loads[free]
        rhs0 = self.F0.copy()
        a_fixed = p.fixed_values(0.0, 2)
        for pr in p.prescribed:
            r = ramp(0.0, pr.group.ramp)
            rhs0 -= r[2] * pr.md + r[1] * pr.cd + r[0] * pr.kd
        state.a_free[:] = self.hht.initial_acceleration(state.u_free, state.v_free, rhs0)
        state.sync(p.fixed_values(0.0), p.fixed_values(0.0, 1), a_fixed)

    def _prescribed_rhs(self, t_prev, t1):
        prescribed = self.problem.prescribed
        if not prescribed:
            return None
        al = self.constants.alpha
        r = np.zeros(len(self.problem.free))
        for pr in prescribed:
            r0, r1 = ramp(t_prev, pr.group.ramp), ramp(t1, pr.group.ramp)
            r -= r1[2] * pr.md + (1 + al) * (r1[1] * pr.cd + r1[0] * pr.kd) - al * (r0[1] * pr.cd + r0[0] * pr.kd)
        return r

    def step(self, state, loads, ctx, hooks) -> None:
        p = self.problem
        t_prev, t1 = state.t, state.t_next
        self.F1[:] = loads[p.free]
        extra = self._prescribed_rhs(t_prev, t1)
        ctx.begin(t_prev, t1, self.F1)
        self.hht.step(state.u_free, state.v_free, state.a_free, self.F0, self.F1, extra, ctx, hooks.predict, hooks.correct)
        if p.prescribed:
            state.sync(p.fixed_values(t1), p.fixed_values(t1, 1), p.fixed_values(t1, 2))
        else:
            state.sync(p.fixed_values(t1))
        self.F0, self.F1 = self.F1, self.F0


@INTEGRATORS.register
class StaticIntegrator(Integrator):
    """``mode = "static"``: linear statics K u = F, with the factor of K kept for every load
    step; load step k of N applies the loads and prescribed displacements times k / N."""

    name = "static"
    dynamic = False

    @dataclass(frozen=True)
    class Params:
        load_steps: int = param(1, doc="load steps", minimum=1)

    @classmethod
    def check(cls, params, table) -> None:
        if params.load_steps > MAX_STEPS:
            raise table.error(f"{params.load_steps} load steps; at most {MAX_STEPS:.0e}", "load_steps")

    @classmethod
    def count_steps(cls, params) -> int:
        return params.load_steps

    @classmethod
    def describe(cls, params, n_steps: int) -> str:
        return f"static, {params.load_steps} load steps"

    def __init__(self, problem, time):
        super().__init__(problem, time)
        self.constants = StaticConstants(self.n_steps)
        self.solver = StaticSolver(problem.K_free)
        self.factor = self.solver.factor
        self.effective_matrix = problem.K_free

    def start(self, state, loads) -> None:
        state.sync(self.problem.fixed_values(0.0, static=True))

    def step(self, state, loads, ctx, hooks) -> None:
        p = self.problem
        lam_prev, lam = state.t, state.t_next
        F = loads[p.free]
        rhs = F.copy()
        for pr in p.prescribed:
            rhs -= lam * pr.kd
        ctx.begin(lam_prev, lam, F.copy())
        ctx.u_tilde = ctx.v_tilde = None
        t0 = time.perf_counter()
        state.u_free[:] = self.solver.solve(rhs, ctx, hooks.correct)
        self.solve_seconds += time.perf_counter() - t0
        state.sync(p.fixed_values(lam, static=True))


# ---- finite strain: the Newton integrators, beside their linear siblings -------------------
def _read_newton(table) -> NewtonParams:
    newton = read_params(NewtonParams, nt := table.table("newton", {}))
    nt.done()
    return newton


def _resolve_with_newton(cls, table):
    """A Newton integrator's ``Params``: its linear sibling's keys and ``[time.newton]``
    (defaults when omitted), read before them when ``newton_first``."""
    newton = _read_newton(table) if cls.newton_first else None
    linear = read_params(cls.Params.__mro__[1], table)
    cls.check(linear, table)
    if newton is None:
        newton = _read_newton(table)
    return cls.Params(**{f.name: getattr(linear, f.name) for f in dataclasses.fields(linear)}, newton=newton)


def _to_dict_with_newton(cls, params) -> dict:
    d = params_to_dict(params)
    d["newton"] = params_to_dict(params.newton)
    return d


def _refuse_newton(cls, table) -> None:
    if table.has("newton"):
        from ..materials import finite_models

        raise table.error(f"Newton options apply to finite-strain bodies only (material model one of "
                          f"{finite_models()}); this scene is linear: remove [time.newton]", "newton")


@INTEGRATORS.register
class NewtonStaticIntegrator(StaticIntegrator):
    """``mode = "static"`` with a finite-strain body: load step k of N solves the nonlinear
    balance at lambda = k / N by :func:`~vfrs.dynamics.newton.newton_solve`."""

    name = "static_newton"
    mode = "static"
    kinematics = "finite"

    @dataclass(frozen=True)
    class Params(StaticIntegrator.Params):
        newton: NewtonParams = NewtonParams()

    newton_first = False
    resolve = classmethod(_resolve_with_newton)
    to_dict = classmethod(_to_dict_with_newton)
    refuse_keys = classmethod(_refuse_newton)

    def __init__(self, problem, time):
        Integrator.__init__(self, problem, time)
        self.constants = StaticConstants(self.n_steps)
        self.params = time.params.newton
        self.model = FiniteStrainModel(problem)
        self.tangent, self.effective_matrix = unloaded_factor(self.model, problem, "the stiffness")
        self.factor = self.tangent.factor
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
        enforce = implicit_forces(ctx, hooks, lambda: ctx.begin(lam_prev, lam, F.copy())) if hooks.correct else None
        where = f"load step {state.step}/{self.n_steps} (load factor {lam:.4g})"
        info = newton_solve(self.model, u, loads, fixed_values,
                            NewtonOptions(self.params, where, self.tangent, enforce=enforce))
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


@INTEGRATORS.register
class NewtonHHTIntegrator(HHTIntegrator):
    """``mode = "dynamic"`` with a finite-strain body:
    HHT-alpha in the generalised-alpha form for nonlinear internal forces,

        M a_n+1 + (1+alpha)[f_int(u_n+1) + C v_n+1] - alpha [f_int(u_n) + C v_n]
            = (1+alpha) F_n+1 - alpha F_n,

    with the Newmark updates of :class:`~vfrs.dynamics.hht.HHTAlpha` (beta = (1-alpha)^2/4,
    gamma = 1/2 - alpha), solved for u_n+1 by :func:`~vfrs.dynamics.newton.newton_solve` on
    :class:`~vfrs.dynamics.hht.HHTBalance`
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
(``NewtonOptions.enforce``), a force they add stays in F_n+1 (the next step's
    F_n), a transient one acts within the step and is taken out of the next predictor as in
    :class:`~vfrs.dynamics.hht.HHTAlpha`. Carried between steps (checkpoints): F_n,
    f_int(u_n), the last step's transient forces, and with modified Newton the displacement
    the factor was made at (refactored there on restore: the same numbers)."""

    name = "dynamic_newton"
    mode = "dynamic"
    kinematics = "finite"

    @dataclass(frozen=True)
    class Params(HHTIntegrator.Params):
        newton: NewtonParams = NewtonParams()

    newton_first = True  # [time.newton] is read before step, end, alpha
    resolve = classmethod(_resolve_with_newton)
    to_dict = classmethod(_to_dict_with_newton)
    refuse_keys = classmethod(_refuse_newton)

    def __init__(self, problem, time):
        Integrator.__init__(self, problem, time)
        self.params = time.params.newton
        self.constants = HHTConstants(time.params.alpha, time.params.step)
        self.model = FiniteStrainModel(problem)
        self.balance = HHTBalance(self.model, problem, self.constants)
        self.tangent, self.effective_matrix = unloaded_factor(self.balance, problem, "K_eff")
        self.factor = self.tangent.factor
        n = len(problem.free)
        self.F0, self.F1 = np.zeros(n), np.zeros(n)
        self.f0 = np.zeros(problem.n_dofs)  # f_int(u_n), all DOFs
        self.last: NewtonInfo | None = None  # the last step's iteration
        self.mass = LazyMassFactor(problem.M_free)
        self._solve_seconds = 0.0
        self._f_transient: np.ndarray | None = None  # last step's transient forces (free DOFs)

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
        state.a_free[:] = self.mass.solve(r[p.free]) if np.any(r[p.free]) else 0.0
        state.sync(p.fixed_values(0.0), p.fixed_values(0.0, 1), a_fixed)
        self.f0[:] = f
        state.internal_force, state.elastic_energy = f.copy(), w
        state.records = {"newton_iterations": 0, "newton_factorizations": 0, "newton_residual": 0.0,
                         "newton_fallbacks": 0}

    def step(self, state, loads, ctx, hooks) -> None:
        p, b = self.problem, self.balance
        free = p.free
        c = self.constants
        h, al = c.h, c.alpha
        t_prev, t1 = state.t, state.t_next
        self.F1[:] = loads[free]
        ctx.begin(t_prev, t1, self.F1)
        u0, v0, a0 = state.u_free, state.v_free, state.a_free
        b.u_tilde[:] = u0 + h * v0 + c.u_predictor * a0
        b.v_tilde[:] = v0 + c.v_predictor * a0
        # Last step's transient forces (a constraint's reaction in the contact-stabilized
        # scheme) acted in that step only: the predictor must not see them (as in HHTAlpha.step);
        # predict hooks (the stabilized predictor) may take them out themselves.
        shift = np.zeros(len(free))  # how far the predict hooks and the transient forces moved u~
        pending, self._f_transient = self._f_transient, None
        if hooks.predict or pending is not None:
            ut_before = b.u_tilde.copy()
            correct_predictor(b.u_tilde, b.v_tilde, pending, c.transient_shift, self.mass.solve, ctx, hooks.predict)
            shift = b.u_tilde - ut_before
        loads_free = self.F1.copy()

        def begin():  # every Newton iteration decides the implicit forces anew
            self.F1[:] = loads_free
            ctx.begin(t_prev, t1, self.F1)
            ctx.u_tilde, ctx.v_tilde = b.u_tilde, b.v_tilde

        enforce = implicit_forces(ctx, hooks, begin) if hooks.correct else None
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
        reference = max(vector_norm((b.M @ state.a)[free]), (1.0 + al) * vector_norm(self.f0[free]),
                        vector_norm((b.M @ state.v)[free]) / h)
        u = state.u.copy()
        u[free] = u0 + h * v0 + (0.5 * h * h) * a0  # constant acceleration
        u[free] += shift  # the predictor's projection (zero without predict hooks)
        count0 = self.tangent.count
        t0 = time.perf_counter()
        where = f"step {state.step}/{self.n_steps} (t = {t1:.6g} s)"
        info = newton_solve(b, u, f_ext, fixed_u, NewtonOptions(self.params, where, self.tangent, reference, TIME_STEP_HINTS,
                                                                keep_factor=True, enforce=enforce, fallback=u0,
                                                                spd_fallback=True))
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
