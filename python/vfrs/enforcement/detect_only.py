"""Detection only: pairs, gaps and the intersection volume are recorded, no force is applied
(the paper's reference run "with contact forces neglected")."""

from __future__ import annotations

import numpy as np

from .base import ContactMethod, SolveInfo, register_method


@register_method
class DetectOnly(ContactMethod):
    name = "detect_only"
    applies_forces = False

    def solve(self, W, g0, stiffness, final=True):
        return np.zeros(len(g0)), SolveInfo(condition=1.0)
