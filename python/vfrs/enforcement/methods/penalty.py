"""Penalty from gaps: lam = kappa a_s <-g>_+ (kappa in Pa/m, a_s the slave's tributary
area, so kappa keeps its meaning under mesh refinement)."""

from __future__ import annotations

from dataclasses import dataclass

from ...params import param
from ..base import ContactMethod, SolveInfo, register_method


def weak_kappa_warning(kappa: float, scale: float, what: str) -> str | None:
    """The warning of a kappa far below the contact stiffness scale, or None."""
    if kappa >= 1e-3 * scale:
        return None
    return (f"[contact] kappa = {kappa:g} Pa/m is far below the contact stiffness scale of these surfaces, "
            f"K_ii / a_i ~ E / h = {scale:.3g} Pa/m: {what}. Try kappa of order {scale:.0e}.")


@register_method
class PenaltyMethod(ContactMethod):
    name = "penalty"
    uses = frozenset({"penalty"})

    @dataclass(frozen=True)
    class Params:
        kappa: float = param(doc="penalty stiffness per unit area", unit="Pa/m", positive=True)

    def solve(self, problem, pairs, scale=1.0, final=True):
        lam, info = problem.penalty(scale * self.params.kappa * pairs.tributary)
        return lam, SolveInfo.of(info)

    def stiffness_scale_warning(self, scale):
        return weak_kappa_warning(self.params.kappa, scale, "the penetration will be large")
