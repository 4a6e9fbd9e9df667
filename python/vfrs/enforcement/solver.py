"""The contact-solver protocol and its registry (``[contact] solver``).

A contact solver turns a round's constraint matrix G and contact-free gaps g0 into the
:class:`~vfrs.enforcement.reduced.ReducedProblem` a method solves; ``provides`` says which
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

    #: The DOFs whose response to pair forces :meth:`response` gives (None: it cannot; the
    #: effect then applies each detection round's forces with a solve).
    observed = None

    def __init__(self, params, ctx, max_iterations: int, observed, column_bytes: int | None = None, prefetch=None,
                 column_dtype=None):
        self.params = params
        self.force_scale = ctx.force_scale
        self.max_iterations = max_iterations

    @property
    def solves(self) -> int:
        """Right-hand sides solved so far for the reduced space (0 if none)."""
        return 0

    @property
    def nbytes(self) -> int:
        """Memory the solver keeps for the reduced space."""
        return 0

    def response(self, f_full):
        """The displacement change at the ``observed`` DOFs that forces f (all DOFs, at the
        end of the step) cause, without a solve; None if the solver cannot tell."""
        return None

    def apply(self, f_full):
        """The displacement change of every DOF (zero at fixed ones) that forces f (all DOFs,
        at the end of the step) cause, without a solve; None if the solver cannot tell (the
        step then solves)."""
        return None

    def problem(self, G, g0, step):
        """The reduced problem of one round (G: pairs x all DOFs, a
        :class:`~vfrs.contact.geometry.Constraint`: ``G @ x``, ``G.T @ lam``, ``G[rows]``,
        ``G.tocsr()`` for a scipy matrix; g0: gaps without forces)."""
        raise NotImplementedError
