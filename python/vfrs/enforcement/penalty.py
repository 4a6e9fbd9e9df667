"""Penalty from gaps: lam = kappa a_s <-g>_+ (kappa in Pa/m, a_s the slave's tributary
area, so kappa keeps its meaning under mesh refinement)."""

from __future__ import annotations

from . import active_set
from .base import ContactMethod, register_method


@register_method
class Penalty(ContactMethod):
    name = "penalty"

    def solve(self, W, g0, stiffness, final=True):
        return active_set.penalty(W, g0, stiffness, max_iterations=self.config["max_iterations"])
