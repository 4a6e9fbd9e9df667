"""Contact with the scene's rigid planes (``[[obstacles]]``): their detector, not a registered
one (the planes come from the scene, not from ``[contact] detection``)."""

from __future__ import annotations

import numpy as np

from ..contact import node_to_plane
from .base import NoParams
from .detector import Detector
from .pairs import DetectedPairs
from .surfaces import ContactSurfaces


class PlaneDetector(Detector):
    """Nodes of every contact surface against the scene's rigid planes (weight 1)."""

    name = "planes"
    pair_weight = 1.0

    def __init__(self, planes, surfaces: ContactSurfaces, search: float):
        super().__init__(NoParams(), surfaces)
        self.planes = list(planes)
        self.search = search

    def detect(self, x) -> DetectedPairs:
        s = self.surfaces
        parts = []
        for plane in self.planes:
            p = node_to_plane(x, s.nodes, plane.point, plane.normal, self.search, s.areas[s.nodes])
            parts.append(DetectedPairs(p, np.ones(len(p)), np.full(len(p), float(np.dot(plane.normal, plane.point))), x))
        return DetectedPairs.concatenate(parts, x)
