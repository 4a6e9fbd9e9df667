"""Augmented Lagrange by Uzawa iterations (the paper's A_N).

Each augmentation solves the penalty problem shifted by the current multipliers,
lam = max(0, lam_k - kappa a_s g), g = g0 + W lam, then updates lam_{k+1} = max(0, lam_k - kappa a_s g).
A pair stops being augmented once |g| < ``gap_tol``; when an augmentation cuts the
intersection volume by less than ``reduction`` (75 %), kappa is multiplied by ``growth``
(10), up to ``kappa_max``. At most ``max_augmentations`` per step (the paper's Fig. 2 uses
N = 4); lam_0 = 0 each step, as in the paper. The volume used for the growth test is the
overlap implied by the gaps, sum of a_s <-g>_+ (the interface mesh's volume at linear order).

Defaults. When the scene gives no ``kappa``, it starts at :data:`KAPPA_FACTOR` = 100 times the
contact surfaces' stiffness scale S = median K_ii / a_i ~ E / h over the contact nodes (Pa/m;
the effect passes it to :meth:`AugmentedLagrangeMethod.set_stiffness_scale` before any solve, and the
run log says what was derived; the resolved scene leaves ``kappa`` out, so re-running it
derives the same value). In statics a penalty kappa a_s in series with a node's own
stiffness ~ K_ii leaves about 1 / (1 + kappa / S) of the overlap, so at 100 x S the first
augmentation removes ~99 % of it and each Uzawa update contracts the rest about as strongly.
Measured (steps needing the most augmentations): 1 x S up to 8 on the main job and 9 on
blocks colliding at 0.4 element per step; 100 x S at most 3 on the main job (both schemes,
coarse and medium), the Gmsh hemisphere and spheres and nu = 0.499, 5 on those blocks; 1000 x S
meets gap_tol in the first solve on most of the main job's steps (335 of 340, medium,
stabilized; all with mass_redistribution), a stiff penalty with little left to augment. The LCP solver loses nothing as kappa grows (its matrix W + diag(1 / (kappa a_s))
tends to Lagrange's W: docs/stability.md). ``max_augmentations`` defaults to
:data:`MAX_AUGMENTATIONS` = 10, twice the most any measured case needed; a step that reaches
``gap_tol`` stops earlier, so the margin costs nothing. The paper's kappa_0 = 1 stays an
explicit setting (``kappa = 1.0``), with its warning. Measurements: docs/contact.md,
"Augmented Lagrange's defaults".

When the augmentations run out with a pair still penetrating by more than ``gap_tol``, the
step has not converged and says so (``SolveInfo.converged = False``, the worst gap in the
message): with ``strict = true`` the run stops with a ConvergenceError, otherwise the history
marks the step (``contact_converged = 0``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ContactError
from ...params import param
from ..base import ContactMethod, SolveInfo, register_method
from .penalty import weak_kappa_warning


#: kappa when the scene gives none, in units of the contact surfaces' stiffness scale K_ii / a_i.
KAPPA_FACTOR = 100.0
#: max_augmentations when the scene gives none.
MAX_AUGMENTATIONS = 10


@register_method
class AugmentedLagrangeMethod(ContactMethod):
    name = "augmented_lagrange"
    constraint = True
    uses = frozenset({"penalty"})

    @dataclass(frozen=True)
    class Params:
        kappa: float | None = param(None, doc=f"starting penalty per unit area (not given: {KAPPA_FACTOR:g} x the "
                                    "contact surfaces' stiffness scale K_ii / a_i ~ E / h; the paper's kappa_0 is "
                                    "1)", unit="Pa/m", positive=True)
        growth: float = param(10.0, doc="kappa grows by this factor when an augmentation cuts the overlap too little",
                              low=1.0, high=1e6)
        reduction: float = param(0.75, doc="the overlap cut an augmentation must reach", low=0.0, high=1.0)
        max_augmentations: int = param(MAX_AUGMENTATIONS, doc="augmentations per step (the paper's N: 4)",
                                       minimum=1)
        gap_tol: float = param(1e-7, doc="a pair is converged when |g| is below this", unit="m", positive=True)
        kappa_max: float = param(1e16, doc="kappa grows no further", unit="Pa/m", positive=True)

    def __init__(self, params):
        super().__init__(params)
        #: The starting kappa (Pa/m): the scene's, else derived in set_stiffness_scale.
        self.kappa = params.kappa

    def set_stiffness_scale(self, scale):
        if self.params.kappa is not None:
            return []
        if not scale:
            raise ContactError("[contact] kappa: not given, and the contact surfaces have no area to derive it from "
                               "(their stiffness scale K_ii / a_i); give kappa (Pa/m)")
        self.kappa = min(KAPPA_FACTOR * scale, self.params.kappa_max)
        capped = ", capped at kappa_max" if self.kappa < KAPPA_FACTOR * scale else ""
        return [f"augmented_lagrange: kappa not given: {self.kappa:.4g} Pa/m = {KAPPA_FACTOR:g} x the contact "
                f"surfaces' stiffness scale K_ii / a_i ~ E / h = {scale:.4g} Pa/m{capped}"]

    def solve(self, problem, pairs, scale=1.0, final=True):
        p = self.params
        g0 = problem.g0
        m = len(g0)
        area = pairs.tributary
        kappa = self.kappa
        if kappa is None:
            raise ContactError("[contact] kappa: not given, and no contact stiffness scale was set to derive it "
                               "from (AugmentedLagrangeMethod.set_stiffness_scale)")
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
        if p.kappa is None:  # derived from this scale
            return None
        warning = weak_kappa_warning(p.kappa, scale, (
            f"the augmentations start from almost nothing (kappa grows by a factor {p.growth:g} per augmentation, "
            f"at most {p.max_augmentations} per step)"))
        return warning and f"{warning} Left out, kappa starts at {KAPPA_FACTOR:g} x this scale."

    def hint(self, info, kappa_scale):
        if info.extra.get("gap_tol_missed"):
            if self.params.kappa is None:
                e_h = f" (it started at {self.kappa:.1e} Pa/m, {KAPPA_FACTOR:g} x the surfaces' contact stiffness scale)"
            else:
                e_h = f" (the surfaces' contact stiffness scale E/h is about {kappa_scale:.1e} Pa/m)" if kappa_scale else ""
            return (f"Try more max_augmentations, a larger kappa{e_h}, a larger gap_tol, or strict = false "
                    "to record and continue.")
        return super().hint(info, kappa_scale)
