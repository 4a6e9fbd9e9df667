"""The contact-solver protocol and its registry (``[contact] solver``).

A contact solver turns a round's constraint matrix G and contact-free gaps g0 into the
:class:`~vfrs.enforcement.problem.ReducedProblem` a method solves; ``provides`` says which
problems it can solve (``"penalty"``, ``"lagrange"``). One module per solver in
``vfrs/enforcement/solvers/``.
"""

from __future__ import annotations

from ..registry import Registry
from .base import NoParams

SOLVERS = Registry("contact solver", packages=("vfrs.enforcement.solvers",))
register_solver = SOLVERS.register


class ContactSolver:
    """Base class: ``name`` is the scene's ``[contact] solver``."""

    name = ""
    Params: type = NoParams
    provides: frozenset = frozenset()

    def __init__(self, params, ctx, max_iterations: int):
        self.params = params
        self.force_scale = ctx.force_scale
        self.max_iterations = max_iterations

    @property
    def solves(self) -> int:
        """Right-hand sides solved so far for the reduced space (0 if none)."""
        return 0

    def problem(self, G, g0, step):
        """The reduced problem of one round (G: pairs x all DOFs, g0: gaps without forces)."""
        raise NotImplementedError
