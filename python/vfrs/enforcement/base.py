"""The contact-method protocol and its registry.

A method decides the pair forces lambda (>= 0, compressive, one per pair) of one detection
round. It gets the round's :class:`~vfrs.enforcement.solvers.ReducedProblem` (the gaps the
step would have without contact forces, ``g0``, and how they respond to pair forces, through
either the Delassus operator W or a refactorization) and the round's
:class:`~vfrs.enforcement.pairs.DetectedPairs` (tributary areas, master triangles, for its
law). It never sees detection, the time scheme or the recording. Once before the first solve it is
told the surfaces' contact stiffness scale K_ii / a_i ~ E / h
(:meth:`ContactMethod.set_stiffness_scale`), from which a method may derive a stiffness the
scene did not give.

A method is one module in ``vfrs/enforcement/methods/`` with one class::

    @register_method
    class MyPenalty(ContactMethod):
        name = "my_penalty"                      # the scene's [contact] method
        uses = frozenset({"penalty"})            # what it asks of the reduced problem

        @dataclass(frozen=True)
        class Params:                            # its keys in [contact]
            kappa: float = param(doc="penalty", unit="Pa/m", positive=True)

        def solve(self, problem, pairs, scale=1.0, final=True):
            return problem.penalty(scale * self.params.kappa * pairs.tributary)
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..registry import Registry

METHODS = Registry("contact method", packages=("vfrs.enforcement.methods",))
register_method = METHODS.register


@dataclass
class SolveInfo:
    """What a method did on one round: iterations of the LCP solver, augmentations, the
    final penalty, and the condition number of the operator it solved with."""

    iterations: int = 0
    augmentations: int = 0
    kappa: float = float("nan")
    condition: float = float("nan")
    converged: bool = True
    cycle: bool = False
    message: str = ""
    extra: dict = field(default_factory=dict)

    @classmethod
    def of(cls, lcp_info) -> "SolveInfo":
        """From an :class:`~vfrs.enforcement.lcp.LcpInfo`."""
        out = cls(iterations=lcp_info.iterations, condition=lcp_info.condition, converged=lcp_info.converged,
                  message=lcp_info.message)
        out.extra["pivots"] = lcp_info.pivots
        out.extra["lcp_residual"] = lcp_info.residual
        return out


@dataclass(frozen=True)
class NoParams:
    """A class without scene keys of its own."""


class ContactMethod:
    """Base class. ``name`` is the scene's ``[contact] method``; ``Params`` its keys.

    ``applies_forces``: False for detection only. ``constraint``: the method enforces g >= 0
    as a constraint (to its tolerance), not as a force law of the overlap; in the
    contact-stabilized scheme its reaction acts within its step only. ``uses``: what it asks of
    the reduced problem (``"penalty"``, ``"lagrange"``); a contact solver that cannot provide
    it is refused at scene load. ``detections``: the detectors it works with (None: any).
    """

    name = ""
    Params: type = NoParams
    applies_forces = True
    constraint = False
    uses: frozenset = frozenset()
    detections: tuple | None = None

    def __init__(self, params):
        self.params = params

    def solve(self, problem, pairs, scale: float = 1.0, final: bool = True) -> tuple:
        """Returns (lambda, SolveInfo) for one round. ``pairs``: the round's
        :class:`~vfrs.enforcement.pairs.DetectedPairs`. ``scale``: multiplies every pair
        stiffness (the stabilized predictor solves in impulse units, h^2 (1/2 - beta) x a
        force). ``final``: this solve sets the gaps the step ends with (False for the
        predictor's projection), so a method with a gap tolerance reports missing it."""
        raise NotImplementedError

    def set_stiffness_scale(self, scale: float | None) -> list:
        """Once, before the first solve (the effect's ``prepare``): the contact surfaces'
        stiffness scale K_ii / a_i ~ E / h (``scale``, Pa/m; None when the surfaces have no
        area). A method whose stiffness the scene may leave out derives it here. Returns lines
        for the run log (what it derived)."""
        return []

    def stiffness_scale_warning(self, scale: float) -> str | None:
        """A warning when the method's stiffness is far below the surfaces' contact stiffness
        scale K_ii / a_i ~ E / h (``scale``, Pa/m), or None."""
        return None

    def hint(self, info: SolveInfo, kappa_scale: float | None) -> str:
        """What to try when a solve did not converge."""
        return "Try a smaller time step or kappa, more max_iterations, or strict = false to record and continue."
