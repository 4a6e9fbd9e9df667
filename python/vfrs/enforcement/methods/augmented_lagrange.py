"""Augmented Lagrange by Uzawa iterations (the paper's A_N).

Each augmentation solves the penalty problem shifted by the current multipliers,
lam = max(0, lam_k - kappa a_s g), g = g0 + W lam, then updates lam_{k+1} = max(0, lam_k - kappa a_s g).
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

from dataclasses import dataclass

import numpy as np

from ...params import param
from ..base import ContactMethod, SolveInfo, register_method
from .penalty import weak_kappa_warning


@register_method
class AugmentedLagrange(ContactMethod):
    name = "augmented_lagrange"
    constraint = True
    uses = frozenset({"penalty"})

    @dataclass(frozen=True)
    class Params:
        kappa: float = param(1.0, doc="starting penalty per unit area (the paper's kappa_0)", unit="Pa/m",
                             positive=True)
        growth: float = param(10.0, doc="kappa grows by this factor when an augmentation cuts the overlap too little",
                              low=1.0, high=1e6)
        reduction: float = param(0.75, doc="the overlap cut an augmentation must reach", low=0.0, high=1.0)
        max_augmentations: int = param(4, doc="augmentations per step (the paper's N)", minimum=1)
        gap_tol: float = param(1e-7, doc="a pair is converged when |g| is below this", unit="m", positive=True)
        kappa_max: float = param(1e16, doc="kappa grows no further", unit="Pa/m", positive=True)

    def solve(self, problem, pairs, scale=1.0, final=True):
        p = self.params
        g0 = problem.g0
        m = len(g0)
        area = pairs.tributary
        kappa = p.kappa
        lam_k = np.zeros(m)
        info = SolveInfo()
        volume_prev = float(np.sum(area * np.maximum(-g0, 0.0)))
        lam = lam_k
        g = g0
        for k in range(1, p.max_augmentations + 1):
            lam, inner = problem.penalty(scale * kappa * area, shift=lam_k)
            info.iterations += inner.iterations
            info.condition = inner.condition
            if not inner.converged:
                info.converged, info.message = False, inner.message
            g = problem.gaps(lam)
            info.augmentations = k
            volume = float(np.sum(area * np.maximum(-g, 0.0)))
            loaded = lam > 0
            if not loaded.any() or np.all(np.abs(g[loaded]) < p.gap_tol):
                break
            # Pairs already within tolerance keep their multiplier.
            done = np.abs(g) < p.gap_tol
            lam_next = np.maximum(0.0, lam_k - scale * kappa * area * g)
            lam_k = np.where(done & loaded, lam, lam_next)
            if volume > (1.0 - p.reduction) * volume_prev:
                kappa = min(kappa * p.growth, p.kappa_max)
            volume_prev = volume
        info.kappa = kappa
        worst = float(np.maximum(-g, 0.0).max()) if m else 0.0
        info.extra["max_gap_violation"] = worst
        if final and info.converged and worst > p.gap_tol:
            info.converged = False
            info.extra["gap_tol_missed"] = True
            info.message = (
                f"after {info.augmentations} augmentations (max_augmentations = {p.max_augmentations}) a pair "
                f"still penetrates by {worst:.3g} m > gap_tol = {p.gap_tol:.3g} m (kappa reached {kappa:.3g} Pa/m)"
            )
        return lam, info

    def stiffness_scale_warning(self, scale):
        p = self.params
        return weak_kappa_warning(p.kappa, scale, (
            f"the augmentations start from almost nothing (kappa grows by a factor {p.growth:g} per augmentation, "
            f"at most {p.max_augmentations} per step)"))

    def hint(self, info, kappa_scale):
        if info.extra.get("gap_tol_missed"):
            e_h = f" (the surfaces' contact stiffness scale E/h is about {kappa_scale:.1e} Pa/m)" if kappa_scale else ""
            return (f"Try more max_augmentations, a larger kappa{e_h}, a larger gap_tol, or strict = false "
                    "to record and continue.")
        return super().hint(info, kappa_scale)
