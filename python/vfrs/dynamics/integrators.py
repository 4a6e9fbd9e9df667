"""Integrators: how a run advances from one time (or load factor) to the next.

The march loop (:func:`vfrs.run`) asks an integrator for its steps and to take them; it does
not know how. An integrator is registered under the scene's ``[time] mode`` and provides:

- ``n_steps``, ``time(k)``: the steps (times, or load factors in statics), ``step_index(t)``;
- ``start(state, loads)``: the initial state (velocities, prescribed values, acceleration);
- ``step(state, loads, ctx, hooks)``: one step from ``state.t`` to ``state.t_next``, calling
  the effects' ``predict`` and ``correct`` hooks through the step context ``ctx``;
- ``state() -> dict`` / ``restore(dict)``: what a checkpoint keeps of the integrator between
  steps besides the run's :class:`~vfrs.dynamics.State` (default: nothing);
- what effects may use (:class:`vfrs.effects.SetupContext` hands it over): ``factor`` (of the
  effective matrix, for solves with it), ``effective_matrix``, ``force_scale`` (how a force at
  the end of the step enters it: ``effective_matrix du = force_scale f``), ``dynamic``, and
  for dynamics ``step_size``, ``mass_factor``, ``predictor_scale`` (how far a force in the
  predictor moves it: du = predictor_scale M^-1 f), ``transient_weight`` (the momentum a
  transient force of the step gives, per h: ``gamma (1 + alpha)``).

A nonlinear (Newton) integrator fits the same protocol: its ``step`` iterates, the loop does
not change.
"""

from __future__ import annotations

import time

import numpy as np

from ..materials import kinematics_of
from ..registry import Registry
from .hht import HHTAlpha
from .problem import ramp
from .static import StaticSolver

INTEGRATORS = Registry("integrator", modules=("vfrs.dynamics.integrators",))


class Integrator:
    """Base class; see the module docstring for the protocol."""

    name = ""
    dynamic = False
    step_size: float | None = None
    solve_seconds = 0.0  # time in the triangular solves of the steps

    def __init__(self, problem, time):
        self.problem = problem
        self.time_spec = time
        self.n_steps = time.n_steps

    def time(self, k: int) -> float:
        raise NotImplementedError

    def step_index(self, t: float) -> int:
        raise NotImplementedError

    def start(self, state, loads) -> None:
        raise NotImplementedError

    def step(self, state, loads, ctx, hooks) -> None:
        raise NotImplementedError

    def state(self) -> dict:
        """What the integrator carries from one step to the next (for checkpoints)."""
        return {}

    def restore(self, state: dict) -> None:
        """Back to a checkpoint's :meth:`state`."""


def _newton_or(cls, base, problem, newton_class: str):
    """A new instance of ``cls``, or, when ``cls`` is the linear ``base`` and a body of the
    problem is finite-strain, of the Newton integrator ``newton_class`` of
    :mod:`vfrs.dynamics.newton` (a subclass of ``base``; imported only then)."""
    if cls is base and any(kinematics_of(b.config.material) == "finite" for b in problem.bodies):
        from . import newton

        return object.__new__(getattr(newton, newton_class))
    return object.__new__(cls)


@INTEGRATORS.register
class HHTIntegrator(Integrator):
    """``mode = "dynamic"``: HHT-alpha with K_eff factored once (:class:`HHTAlpha`).

    ``loads`` (all DOFs) are the external and explicit effect forces at the end of the step;
    prescribed displacements enter through their coupling K_fp d, C_fp d, M_fp d (computed
    once) times the ramp and its derivatives.
    """

    name = "dynamic"
    dynamic = True

    def __new__(cls, problem, time):
        # A finite-strain body: HHT-alpha with Newton (vfrs.dynamics.newton.NewtonHHTIntegrator);
        # linear scenes never import it and run exactly as before.
        return _newton_or(cls, HHTIntegrator, problem, "NewtonHHTIntegrator")

    def __init__(self, problem, time):
        super().__init__(problem, time)
        self.hht = HHTAlpha(problem.M_free, problem.K_free, time.step, time.alpha,
                            rayleigh=problem.rayleigh or (0.0, 0.0), C=problem.C_free)
        self.alpha, self.h = float(time.alpha), float(time.step)
        self.step_size = self.h
        self.factor = self.hht.factor
        self.effective_matrix = self.hht.K_eff
        self.force_scale = 1.0 + self.alpha
        self.predictor_scale = self.h**2 * (0.5 - self.hht.beta)
        self.transient_weight = self.hht.gamma * (1.0 + self.alpha)
        n = len(problem.free)
        # The HHT force vectors at the two ends of the step: loads, plus the implicit forces
        # that stay in the recursion (StepContext.add_force adds those to F1 in place).
        self.F0, self.F1 = np.zeros(n), np.zeros(n)

    @property
    def mass_factor(self):
        return self.hht.mass_factor

    @property
    def solve_seconds(self):
        return self.hht.solve_seconds

    def time(self, k: int) -> float:
        return k * self.h

    def state(self) -> dict:
        # F0: the forces of the step's start, with the implicit forces that stay in the
        # recursion (F1 is refilled every step).
        return {"F0": self.F0.copy(), "hht": self.hht.state()}

    def restore(self, state: dict) -> None:
        self.F0[:] = state["F0"]
        self.hht.restore(state["hht"])

    def step_index(self, t: float) -> int:
        return int(round(t / self.h))

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
        al = self.alpha
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

    def __new__(cls, problem, time):
        # A finite-strain body makes statics nonlinear: the Newton integrator takes the run
        # (vfrs.dynamics.newton); linear scenes never import it and run exactly as before.
        return _newton_or(cls, StaticIntegrator, problem, "NewtonStaticIntegrator")

    def __init__(self, problem, time):
        super().__init__(problem, time)
        self.solver = StaticSolver(problem.K_free)
        self.factor = self.solver.factor
        self.effective_matrix = problem.K_free
        self.force_scale = 1.0

    def time(self, k: int) -> float:
        return k / self.n_steps

    def step_index(self, t: float) -> int:
        return int(round(t * self.n_steps))

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
