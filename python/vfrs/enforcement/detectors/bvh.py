"""``detection = "bvh"``: BVH broad phase over the master triangles and closest-point
projection of the slave nodes within ``search_distance`` (see :class:`vfrs.contact.BvhDetector`),
both directions between each pair of bodies."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...contact import BvhEngine
from ...params import param
from ..detector import Detector, register_detector, warn_once
from ..pairs import DetectedPairs


@register_detector
class BvhDetector(Detector):
    name = "bvh"

    @dataclass(frozen=True)
    class Params:
        search_distance: float | None = param(None, doc="how far from the master surface a slave node is looked for "
                                              "(default: half the mean surface edge)", unit="m", positive=True)

    def __init__(self, params, surfaces):
        super().__init__(params, surfaces)
        if params.search_distance is not None:
            self.search = params.search_distance
        self.trees = []
        for a, b in surfaces.body_pairs:
            for s, m in ((a, b), (b, a)):
                nodes = np.unique(surfaces.surface_of[s])
                self.trees.append(BvhEngine(surfaces.surface_of[m], slave_nodes=nodes, slave_areas=surfaces.areas[nodes]))
        self._warned: dict = {}

    def detect(self, x) -> DetectedPairs:
        return DetectedPairs.concatenate([self._pairs(self._beside_patch_removed(t.detect(x, self.search), x), x)
                                          for t in self.trees], x)

    def state(self) -> dict:
        """The warnings already given (the tree is refitted, not rebuilt, and the range search
        breaks ties by triangle index: its pairs do not depend on the tree's history)."""
        return {"warned": dict(self._warned)}

    def restore(self, state: dict) -> None:
        self._warned = dict(state["warned"])

    def after_step(self, x, x_prev, t) -> None:
        nodes = self.surfaces.nodes
        moved = float(np.linalg.norm(x[nodes] - x_prev[nodes], axis=1).max())
        if moved > self.search:
            warn_once(self._warned, "motion", (
                f"t = {t:.6g}: contact-surface nodes moved {moved:.3g} m in one step, more than the BVH search distance "
                f"{self.search:.3g} m: a surface crossed between two steps is not seen. "
                'Use detection = "interface_mesh", a larger search_distance or a smaller time step.'))

    def _beside_patch_removed(self, pairs, x):
        """Drops pairs whose closest point lies on a boundary edge or vertex of an open master
        surface while the node is behind the surface and further outside the rim (in the plane)
        than behind the plane: the node is beside the patch, not through it (it would get a
        negative gap and a sideways normal). A node that went in through the face near the rim
        and spread sideways a little (up to 1 % of an element, or less than its depth) stays.
        Interface meshes leave such nodes out at build time for the same reason."""
        if len(pairs) == 0:
            return pairs
        cand = (pairs.feature > 0) & (pairs.gap < 0) & (pairs.triangle >= 0)
        if not cand.any():
            return pairs
        s = self.surfaces
        drop = np.zeros(len(pairs), dtype=bool)
        N = np.stack([1.0 - pairs.xi - pairs.zeta, pairs.xi, pairs.zeta], axis=1)
        for k in np.flatnonzero(cand):
            on = np.flatnonzero(N[k] > 1e-9)  # master nodes the closest point depends on
            nodes = pairs.master[k][on]
            rim = (len(nodes) == 1 and int(nodes[0]) in s.boundary_nodes) or (
                len(nodes) == 2 and (min(nodes), max(nodes)) in s.boundary_edges)
            if rim:
                xm = x[pairs.master[k]]
                n = np.cross(xm[1] - xm[0], xm[2] - xm[0])
                n /= np.sqrt(np.sum(n * n))
                s_ = x[pairs.slave[k]]
                depth = float(np.sum((xm[0] - s_) * n))  # behind the plane: > 0
                in_plane = s_ + depth * n  # projection onto the plane
                xbar = N[k, 0] * xm[0] + N[k, 1] * xm[1] + N[k, 2] * xm[2]  # closest point (on the rim)
                outside = float(np.sqrt(np.sum((in_plane - xbar) ** 2)))
                # Spreading past the rim by a sliver of an element is not "beside".
                drop[k] = outside > max(depth, 1e-2 * s.h_surface)
        return pairs.select(~drop) if drop.any() else pairs
