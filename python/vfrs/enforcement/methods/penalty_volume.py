"""Penalty from inverted interface volumes (the paper's eq. 12), momentum-balanced.

The paper applies n (-1, 1, 1, 1) kappa V_e / 4 to the slave and the three master nodes of
an inverted interface tet (V_e < 0). Those four forces sum to n kappa V_e / 2, not zero: each
pair pushes the folds with a net force that has no reaction.

For a node-triangle tet, V_e = A_t g / 3 (A_t the master triangle's area, g the slave's
signed distance to its plane), so a penalty on the volume is a penalty on the gap with the
pair stiffness kappa_V A_t / 3 (N/m; kappa_V in N/m^3). We apply it through the gap row
g_e = [n, -N1 n, -N2 n, -N3 n]: the slave gets kappa_V |V_e| n and the master nodes share
-kappa_V |V_e| n in proportion to the shape functions at the projection. The forces sum to
zero and their moments balance. Relation to the printed form (same kappa): the slave force
is 4 times the printed one (kappa |V_e| / 4 there); the master forces point the same way
(-n) but sum to kappa |V_e| (printed: 3/4 of it, so the pair does not balance) and are split
by N1, N2, N3 instead of in equal quarters.

A node against a rigid plane (``[[obstacles]]``) has no master triangle: its overlap volume is
its tributary area times its penetration (the prism it pushes through the plane), so its pair
stiffness is kappa_V a (N/m). (Before this, plane pairs got a stiffness of zero, from the
area of a master triangle they do not have, and a body went through the plane unresisted.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import param
from ..base import ContactMethod, SolveInfo, register_method


@register_method
class PenaltyVolumeMethod(ContactMethod):
    name = "penalty_volume"
    uses = frozenset({"penalty"})
    detections = ("interface_mesh",)  # it penalises inverted interface volumes

    @dataclass(frozen=True)
    class Params:
        kappa: float = param(doc="penalty on the inverted volume", unit="N/m^3", positive=True)

    def solve(self, problem, pairs, scale=1.0, final=True):
        volume_per_gap = np.where(pairs.pairs.triangle >= 0, pairs.master_area() / 3.0, pairs.tributary)
        lam, info = problem.penalty(scale * self.params.kappa * volume_per_gap)
        return lam, SolveInfo.of(info)
