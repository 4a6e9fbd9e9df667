"""Detection only: pairs, gaps and the intersection volume are recorded, no force is applied
(the paper's reference run "with contact forces neglected")."""

from __future__ import annotations

import numpy as np

from ..base import ContactMethod, SolveInfo, register_method


@register_method
class DetectOnlyMethod(ContactMethod):
    name = "detect_only"
    applies_forces = False

    def solve(self, problem, pairs, scale=1.0, final=True):
        return np.zeros(len(pairs)), SolveInfo(condition=1.0)
