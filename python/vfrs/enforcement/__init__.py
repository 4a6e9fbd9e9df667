"""Contact enforcement: the methods (a registry keyed by the scene's ``[contact] method``)
and the ``[contact]`` effect that runs them inside the time loop.

- ``penalty``: lam = kappa a_s <-g>_+ (kappa in Pa/m);
- ``penalty_volume``: the paper's volume penalty, made momentum-balanced;
- ``lagrange``: exact KKT conditions per step (an LCP on the pairs);
- ``augmented_lagrange``: Uzawa augmentations with the paper's kappa growth rule;
- ``detect_only``: pairs, gaps and intersection volume, no forces.
"""

from . import augmented_lagrange, detect_only, lagrange, penalty, penalty_volume  # noqa: F401 (register)
from .base import METHODS, ContactMethod, SolveInfo
from .compliance import Compliance
from .effect import ContactEffect

__all__ = ["METHODS", "ContactMethod", "SolveInfo", "Compliance", "ContactEffect"]
