"""``detection = "interface_mesh"``: the paper's detector (see :class:`vfrs.contact.InterfaceMesh`).

Per pair of bodies, a coarse tetrahedral mesh fills the gap between their surfaces, both
directions; an inverted tet is a contact pair and the weighted sum of |V| over inverted tets
is the intersection volume. The pairing is rebuilt (when the slip demands it) once per step,
at the start-of-step configuration, which contact has kept free of overlap; never mid-step.
"""

from __future__ import annotations

from ...contact import InterfaceMesh
from ..detection import DetectedPairs, Detector, register_detector


@register_detector
class InterfaceMeshDetector(Detector):
    name = "interface_mesh"

    def __init__(self, params, surfaces):
        super().__init__(params, surfaces)
        self.meshes = [InterfaceMesh(surfaces.points, surfaces.surface_of[a], surfaces.surface_of[b], auto_rebuild=False)
                       for a, b in surfaces.body_pairs]

    def begin_step(self, x) -> None:
        for m in self.meshes:
            m.update(x)

    def detect(self, x) -> DetectedPairs:
        return DetectedPairs.concatenate([self._pairs(m.detect(x), x) for m in self.meshes], x)

    def intersection_volume(self, x, found, gap) -> float:
        return float(sum(m.intersection_volume(x) for m in self.meshes))
