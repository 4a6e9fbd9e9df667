"""Lagrange multipliers: the exact KKT conditions on the pairs each step
(g >= 0, lam >= 0, lam g = 0), an LCP in the space of the pairs."""

from __future__ import annotations

from . import active_set
from .base import ContactMethod, register_method


@register_method
class Lagrange(ContactMethod):
    name = "lagrange"
    constraint = True

    def solve(self, W, g0, stiffness, final=True):
        return active_set.lagrange(W, g0, max_iterations=self.config["max_iterations"])
