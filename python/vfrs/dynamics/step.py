"""What an effect sees during one step: the predictor, the solution, and the factor of K_eff."""

from __future__ import annotations

import numpy as np


class StepContext:
    """The current step, handed to the ``predict`` and ``correct`` hooks of effects.

    Vectors ending in ``_tilde`` and ``u`` are over the free DOFs (``dofmap.free``); forces given
    to :meth:`add_force` / :meth:`response` are over all DOFs (what effects naturally build).

    - ``t_prev``, ``t``: start and end of the step (static: load factors).
    - ``u_tilde``, ``v_tilde``: the HHT/Newmark predictors (``predict`` may change them).
    - ``u``: the solution at ``t`` (after the solve; ``add_force`` updates it).
    - ``force_scale``: how a force at ``t`` enters the right-hand side ((1 + alpha) in HHT-alpha,
      1 in statics), so ``K_eff du = force_scale * f``.
    - ``factor``: the Cholesky factor of K_eff (``factor.solve(b)``, b of shape (n,) or (n, k)).
    - ``iteration``: 0, or in a finite-strain (Newton) step the Newton iteration the ``correct``
      hooks are called in: they are called once per iteration, each time with ``u`` the
      linearised solution without implicit forces and ``factor`` the tangent's (refactored
      in place), and each call adds the implicit forces in full (the step context forgets
      the last iteration's); the last call's forces are the step's.
    """

    def __init__(self, factor, dofmap, force_scale: float, problem=None):
        self.factor = factor
        self.dofmap = dofmap
        self.free = dofmap.free
        self.force_scale = float(force_scale)
        self.problem = problem
        self.t_prev = 0.0
        self.t = 0.0
        self.u_tilde = None
        self.v_tilde = None
        self.u = None
        self.force = None  # free part of the forces at t (explicit + implicit), owned by the loop
        self.implicit_full = None  # all implicit forces added this step (all DOFs), or None
        self.transient_free = None  # the transient part of them (free DOFs), or None
        # Last step's transient forces (free DOFs) that the predictor still holds, and how
        # (1 + alpha) M^-1 of them moves u~ and v~: set by the integrator for predict hooks.
        self.transient_prev = None
        self.transient_shift = (0.0, 0.0)
        self.implicit_by_effect: dict = {}  # effect name -> its implicit forces this step (all DOFs)
        self.current_effect = None  # set by the loop while an effect's hook runs
        self.iteration = 0  # the Newton iteration of a finite-strain step (0 in a linear one)
        # A jump of the velocity at t (free DOFs) that the integrator adds after the step's
        # velocity is formed (an impulse at the end of the step), or None.
        self.velocity_jump = None

    def solve(self, rhs_free) -> np.ndarray:
        """K_eff^-1 rhs on the free DOFs (one or several right-hand sides)."""
        return self.factor.solve(rhs_free)

    def response(self, f_full) -> np.ndarray:
        """The displacement change (all DOFs, zero on fixed ones) that force ``f_full`` at ``t``
        would cause; nothing is applied."""
        du = self.factor.solve(self.force_scale * np.asarray(f_full)[self.free])
        return self.dofmap.expand(du)

    def add_force(self, f_full, du_full=None, transient: bool = False) -> None:
        """Adds a force at ``t`` (all DOFs): updates ``u`` and the step's force balance.

        ``du_full``: the response already computed with :meth:`response` (saves a solve).
        ``transient``: the force acts within this step only. A force normally stays in the
        HHT-alpha recursion: it enters the acceleration at ``t``, and through it the next
        step's predictor, and (weighted by -alpha) the next step's balance, so its momentum
        is spread over this step and the next (``h f`` in all). A transient force (the
        reaction of a contact constraint in the contact-stabilized scheme) is removed from
        both after this step: it changes the momentum by ``gamma (1 + alpha) h f``, all of it
        now, and cannot keep pushing bodies apart while they separate in the next step.
        """
        f_full = np.asarray(f_full, dtype=np.float64)
        f = f_full[self.free]
        du = self.factor.solve(self.force_scale * f) if du_full is None else np.asarray(du_full)[self.free]
        self.u += du
        if transient:
            self.transient_free = f.copy() if self.transient_free is None else self.transient_free + f
        else:
            self.force += f
        if self.implicit_full is None:
            self.implicit_full = f_full.copy()
        else:
            self.implicit_full += f_full
        key = self.current_effect or "implicit"
        if key in self.implicit_by_effect:
            self.implicit_by_effect[key] = self.implicit_by_effect[key] + f_full
        else:
            self.implicit_by_effect[key] = f_full.copy()

    def set_velocity_jump(self, dv_free) -> None:
        """A jump of the velocity at ``t`` (free DOFs; None: none): an impulse at the end of
        the step, added after the step's velocity is formed (a contact scheme's energy
        correction). Each call replaces the last one's."""
        self.velocity_jump = None if dv_free is None else np.asarray(dv_free, dtype=np.float64).copy()

    def begin(self, t_prev, t, force) -> None:
        """Resets the per-step state (called by the loop before each step)."""
        self.t_prev, self.t, self.force = t_prev, t, force
        self.implicit_full = None
        self.transient_free = None
        self.implicit_by_effect = {}
        self.iteration = 0
        self.velocity_jump = None
