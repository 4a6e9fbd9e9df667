"""``detection = "interface_mesh"``: the paper's detector (see :class:`vfrs.contact.InterfaceMeshEngine`).

Per pair of bodies, a coarse tetrahedral mesh fills the gap between their surfaces, both
directions; an inverted tet is a contact pair and the weighted sum of |V| over inverted tets
is the intersection volume. The pairing is rebuilt (when the slip demands it) once per step,
at the start-of-step configuration, which contact has kept free of overlap; never mid-step.
"""

from __future__ import annotations

import numpy as np

from ...contact import InterfaceMeshEngine
from ..detector import Detector, register_detector
from ..pairs import DetectedPairs


@register_detector
class InterfaceMeshDetector(Detector):
    name = "interface_mesh"

    def __init__(self, params, surfaces):
        super().__init__(params, surfaces)
        self.meshes = [InterfaceMeshEngine(surfaces.points, surfaces.surface_of[a], surfaces.surface_of[b], auto_rebuild=False)
                       for a, b in surfaces.body_pairs]
        # Where each mesh's pairing was last rebuilt (None: as built at rest); the pairing is
        # a function of these positions, which is what a checkpoint keeps.
        self.rebuilt_at: list = [None] * len(self.meshes)

    def begin_step(self, x) -> None:
        for i, m in enumerate(self.meshes):
            if m.update(x):
                self.rebuilt_at[i] = np.array(x, dtype=float, copy=True)

    def state(self) -> dict:
        return {"rebuilt_at": [None if x is None else x.copy() for x in self.rebuilt_at]}

    def restore(self, state: dict) -> None:
        for i, x in enumerate(state["rebuilt_at"]):
            if x is not None:
                self.meshes[i].rebuild(x)
                self.rebuilt_at[i] = x.copy()

    def detect(self, x) -> DetectedPairs:
        parts = [self._pairs(m.detect(x), x) for m in self.meshes]
        return parts[0] if len(parts) == 1 else DetectedPairs.concatenate(parts, x)

    def intersection_volume(self, x, found, gap) -> float:
        return float(sum(m.intersection_volume(x) for m in self.meshes))
