"""What the ``[contact]`` effect records per step (history keys, one value per step).

``contact_pairs``, ``active_pairs``, ``iterations`` (LCP iterations of the step's last
detection round), ``augmentations``, ``detections``, ``contact_settled``,
``contact_converged``, ``contact_work`` (J), ``max_penetration`` (m), ``intersection_volume``
(m^3), ``condition``, ``contact_force.<body>`` (N: impulse / h, see docs/contact.md),
``contact_area`` (m^2: summed area of contact-surface triangles with any loaded vertex, the
paper's definition), ``compliance_solves``, ``contact_force_probe.<k>``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..contact import contact_area
from .detection import DetectedPairs


@dataclass
class ContactStep:
    """The outcome of one step's contact correction."""

    found: DetectedPairs  # the last round's pairs
    lam: np.ndarray
    info: Any  # SolveInfo of the last round, or None
    detections: int
    settled: bool
    converged: bool
    G: Any = None  # the last round's constraint matrix, if it built one


class ContactRecorder:
    """Appends the contact diagnostics of a step to the history."""

    def __init__(self, problem, surfaces, detectors, probe_nodes):
        self.problem, self.surfaces, self.detectors = problem, surfaces, detectors
        self.probe_nodes = probe_nodes
        self._work_state = None
        self._contact_work = 0.0

    def record(self, h: dict, outcome: ContactStep, force: np.ndarray, solves: int) -> None:
        p = self.problem
        found, lam, info = outcome.found, outcome.lam, outcome.info
        x = found.x
        # Gaps at the final positions, with the pairs' frozen geometry.
        if len(found):
            G = outcome.G if outcome.G is not None else found.pairs.constraint_matrix(p.n_points)
            gap = G @ x.ravel() - found.offset
        else:
            gap = np.zeros(0)
        h.setdefault("contact_pairs", []).append(len(found))
        h.setdefault("active_pairs", []).append(int((lam > 0).sum()))
        h.setdefault("iterations", []).append(info.iterations if info else 0)
        h.setdefault("augmentations", []).append(info.augmentations if info else 0)
        h.setdefault("detections", []).append(outcome.detections)
        h.setdefault("contact_settled", []).append(int(outcome.settled))
        h.setdefault("contact_converged", []).append(int(outcome.converged))
        # Work of the recorded contact forces on the bodies (trapezoidal in time): lets an
        # energy balance separate contact from the loads.
        if self._work_state is not None:
            x_old, f_old = self._work_state
            self._contact_work += 0.5 * float(np.sum((f_old + force) * (x.ravel() - x_old)))
        self._work_state = (x.ravel().copy(), force.copy())
        h.setdefault("contact_work", []).append(self._contact_work)
        h.setdefault("max_penetration", []).append(float(np.maximum(-gap, 0.0).max()) if len(gap) else 0.0)
        volume = 0.0
        for i, d in enumerate(self.detectors):
            mine = found.source == i
            volume += d.intersection_volume(x, found.select(mine), gap[mine])
        h.setdefault("intersection_volume", []).append(volume)
        h.setdefault("condition", []).append(info.condition if info else 1.0)
        f = force.reshape(-1, 3)
        for part in p.bodies:
            h.setdefault(f"contact_force.{part.name}", []).append(f[part.nodes].sum(axis=0))
        loaded_nodes = np.flatnonzero(np.abs(f).sum(axis=1) > 0)
        area = 0.0
        if loaded_nodes.size:
            for tri in self.surfaces.surface_of.values():
                area += contact_area(x, tri, loaded_nodes)
        h.setdefault("contact_area", []).append(area)
        # Cumulative right-hand sides solved for the compliance columns (the reduced space's
        # cost: one solve per contact DOF the first time a pair touches it).
        h.setdefault("compliance_solves", []).append(solves)
        for i, n in enumerate(self.probe_nodes):
            h.setdefault(f"contact_force_probe.{i}", []).append(f[n].copy())
