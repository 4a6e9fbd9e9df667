"""Lagrange multipliers: the exact KKT conditions on the pairs each step
(g >= 0, lam >= 0, lam g = 0), an LCP in the space of the pairs."""

from __future__ import annotations

from ..base import ContactMethod, SolveInfo, register_method


@register_method
class LagrangeMethod(ContactMethod):
    name = "lagrange"
    constraint = True
    uses = frozenset({"lagrange"})

    def solve(self, problem, pairs, scale=1.0, final=True):
        lam, info = problem.lagrange()
        return lam, SolveInfo.of(info)
