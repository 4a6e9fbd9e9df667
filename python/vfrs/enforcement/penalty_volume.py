"""Penalty from inverted interface volumes (the paper's eq. 12), momentum-balanced.

The paper applies n (-1, 1, 1, 1) kappa V_e / 4 to the slave and the three master nodes of
an inverted interface tet (V_e < 0). Those four forces sum to n kappa V_e / 2, not zero: the
pair pushes the two folds apart with a net force that has no reaction. For a node-triangle
tet, V_e = A_t g / 3 (A_t the master triangle's area, g the slave's signed distance to its
plane), so a penalty on the volume is a penalty on the gap with stiffness kappa_V A_t / 3.
We apply it through the gap row g_e = [n, -N1 n, -N2 n, -N3 n]: the slave gets
kappa_V |V_e| n and the master nodes share -kappa_V |V_e| n in proportion to the shape
functions at the projection, so forces sum to zero and moments balance. The slave's force
equals the printed one scaled by 4 (the printed slave term is kappa V_e / 4); the masters'
forces differ in sign and split. ``kappa`` here is in Pa/m^2 (force per volume per length)
is not needed: kappa_V is in N/m^3, and the gap stiffness per pair is kappa_V A_t / 3 (N/m).
"""

from __future__ import annotations

from . import active_set
from .base import ContactMethod, register_method


@register_method
class PenaltyVolume(ContactMethod):
    name = "penalty_volume"
    needs_volumes = True

    def solve(self, W, g0, stiffness):
        return active_set.penalty(W, g0, stiffness, max_iterations=self.config["max_iterations"])
