"""The detector role of the ``[contact]`` effect: what a detector is, and its registry.

A detector finds the contact pairs between the bodies' contact surfaces at given positions.
It is one module in ``vfrs/enforcement/detectors/`` (plus its Rust module, if any) with one
class registered under the scene's ``[contact] detection``::

    @register_detector
    class MyDetector(Detector):
        name = "my_detector"
        Params = ...                      # its keys in [contact] (optional)

        def __init__(self, params, surfaces): ...     # setup: the contact surfaces
        def detect(self, x) -> DetectedPairs: ...     # pairs at positions x (n, 3)

and optionally ``begin_step(x)`` (once per step, at the start-of-step positions),
``intersection_volume(x, found, gap)`` and ``after_step(x, x_prev)`` (warnings). Rigid planes
(``[[obstacles]]``) have their own detector, :class:`vfrs.enforcement.planes.PlaneDetector`.
What a detector returns is :class:`vfrs.enforcement.pairs.DetectedPairs`; what it sets up
from, :class:`vfrs.enforcement.surfaces.ContactSurfaces`.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..contact import ContactPairs
from ..errors import VfrsWarning
from ..registry import Registry
from .base import NoParams
from .pairs import DetectedPairs
from .surfaces import ContactSurfaces

DETECTORS = Registry("contact detector", packages=("vfrs.enforcement.detectors",))
register_detector = DETECTORS.register


class Detector:
    """Base class of a detector between bodies (see the module docstring). ``search``: the
    distance within which it looks (rigid planes use it too)."""

    name = ""
    Params: type = NoParams
    #: Two directions between bodies share each contact patch: each pair carries half.
    pair_weight = 0.5

    def __init__(self, params, surfaces: ContactSurfaces):
        self.params = params
        self.surfaces = surfaces
        self.search = 0.5 * surfaces.h_surface

    def begin_step(self, x) -> None:
        """Once per step, at the start-of-step positions (which contact kept free of overlap)."""

    def detect(self, x) -> DetectedPairs:
        raise NotImplementedError

    def intersection_volume(self, x, found: DetectedPairs, gap) -> float:
        """Overlap volume (m^3) of this detector's pairs at ``x``; default: area x <-g>."""
        return float(np.sum(found.tributary * np.maximum(-gap, 0.0))) if len(gap) else 0.0

    def after_step(self, x, x_prev, t: float) -> None:
        """After each step at time ``t`` (e.g. a warning that a crossing may have been missed)."""

    def _pairs(self, pairs: ContactPairs, x) -> DetectedPairs:
        return DetectedPairs(pairs, np.full(len(pairs), self.pair_weight), np.zeros(len(pairs)), x)


def warn_once(flags: dict, key: str, message: str) -> None:
    """A VfrsWarning, the first time only (per run)."""
    if not flags.get(key):
        flags[key] = True
        warnings.warn(message, VfrsWarning, stacklevel=3)
