"""Contact enforcement: the ``[contact]`` effect and its three roles, each a registry keyed by
its scene name:

- :data:`METHODS` (``[contact] method``): the pair law, one module each in ``methods/``:
  ``penalty`` (lam = kappa a_s <-g>_+, kappa in Pa/m), ``penalty_volume`` (the paper's volume
  penalty, momentum-balanced), ``lagrange`` (exact KKT conditions per step, an LCP),
  ``augmented_lagrange`` (Uzawa augmentations with the paper's kappa growth rule),
  ``detect_only`` (pairs, gaps and intersection volume, no forces);
- :data:`DETECTORS` (``[contact] detection``), one module each in ``detectors/``:
  ``interface_mesh`` (the paper's) and ``bvh``;
- :data:`SOLVERS` (``[contact] solver``), one module each in ``solvers/``: ``compliance``
  (W from precomputed compliance columns) and ``refactor`` (the reference path).

:mod:`~vfrs.enforcement.lcp` solves every method's LCP with a termination guarantee; the
effect (:mod:`~vfrs.enforcement.effect`) wires the roles into the step and records.
"""

from .base import METHODS, ContactMethod, SolveInfo, register_method
from .detector import DETECTORS, Detector, register_detector
from .pairs import DetectedPairs
from .solver import SOLVERS, ContactSolver, register_solver
from .compliance_matrix import Compliance

__all__ = ["METHODS", "ContactMethod", "SolveInfo", "register_method", "DETECTORS", "Detector", "DetectedPairs",
           "register_detector", "SOLVERS", "ContactSolver", "register_solver", "Compliance"]
