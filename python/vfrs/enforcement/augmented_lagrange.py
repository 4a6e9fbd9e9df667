"""Augmented Lagrange by Uzawa iterations (the paper's A_N).

Each augmentation solves the penalty problem shifted by the current multipliers,
lam = max(0, lam_k - kappa g), g = g0 + W lam, then updates lam_{k+1} = max(0, lam_k - kappa g).
A pair stops being augmented once |g| < ``gap_tol``; when an augmentation cuts the
intersection volume by less than ``reduction`` (75 %), kappa is multiplied by ``growth``
(10), up to ``kappa_max``. At most ``max_augmentations`` (N = 4 in the paper's Fig. 2) per
step; lam_0 = 0 each step, as in the paper. The volume used for the growth test is the
overlap implied by the gaps, sum of a_s <-g>_+ (the interface mesh's volume at linear order).

When the augmentations run out with a pair still penetrating by more than ``gap_tol``, the
step has not converged and says so (``SolveInfo.converged = False``, the worst gap in the
message): with ``strict = true`` the run stops with a ConvergenceError, otherwise the history
marks the step (``contact_converged = 0``).
"""

from __future__ import annotations

import numpy as np

from . import active_set
from .base import ContactMethod, SolveInfo, register_method


@register_method
class AugmentedLagrange(ContactMethod):
    name = "augmented_lagrange"
    constraint = True

    def solve(self, W, g0, stiffness, final=True):
        cfg = self.config
        m = len(g0)
        kappa0 = cfg.get("kappa", 1.0)
        # stiffness = kappa x area: keep the areas, scale kappa.
        area = stiffness / kappa0 if kappa0 > 0 else np.ones(m)
        kappa = kappa0
        lam_k = np.zeros(m)
        info = SolveInfo()
        volume_prev = float(np.sum(area * np.maximum(-g0, 0.0)))
        lam = lam_k
        for k in range(1, cfg["max_augmentations"] + 1):
            lam, inner = active_set.penalty(W, g0, kappa * area, shift=lam_k, max_iterations=cfg["max_iterations"])
            info.iterations += inner.iterations
            info.condition = inner.condition
            if not inner.converged:
                info.converged, info.cycle, info.message = False, inner.cycle, inner.message
            g = g0 + W @ lam
            info.augmentations = k
            volume = float(np.sum(area * np.maximum(-g, 0.0)))
            loaded = lam > 0
            if not loaded.any() or np.all(np.abs(g[loaded]) < cfg["gap_tol"]):
                break
            # Pairs already within tolerance keep their multiplier.
            done = np.abs(g) < cfg["gap_tol"]
            lam_next = np.maximum(0.0, lam_k - kappa * area * g)
            lam_k = np.where(done & loaded, lam, lam_next)
            if volume > (1.0 - cfg["reduction"]) * volume_prev:
                kappa = min(kappa * cfg["growth"], cfg["kappa_max"])
            volume_prev = volume
        info.kappa = kappa
        worst = float(np.maximum(-(g0 + W @ lam), 0.0).max()) if m else 0.0
        info.extra["max_gap_violation"] = worst
        if final and info.converged and worst > cfg["gap_tol"]:
            info.converged = False
            info.message = (
                f"after {info.augmentations} augmentations (max_augmentations = {cfg['max_augmentations']}) a pair "
                f"still penetrates by {worst:.3g} m > gap_tol = {cfg['gap_tol']:.3g} m (kappa reached {kappa:.3g} Pa/m)"
            )
        return lam, info
