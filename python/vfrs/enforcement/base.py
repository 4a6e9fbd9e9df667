"""The contact-method interface and its registry.

A method solves, in the small space of the detected pairs, for the contact forces lambda
(>= 0, compressive, one per pair) given the gaps ``g0`` the step would have without contact
forces and the Delassus operator ``W`` (how the gaps respond to the pair forces:
``g = g0 + W lambda``). The effect (:mod:`vfrs.enforcement.effect`) does detection, builds
``W`` and applies ``G^T lambda``; a method only decides what lambda is.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

METHODS: dict = {}


def register_method(cls):
    """Class decorator: registers a :class:`ContactMethod` under ``cls.name``."""
    METHODS[cls.name] = cls
    return cls


@dataclass
class SolveInfo:
    """What a method did on one step: iterations of the active set, augmentations, the
    final penalty, and the condition number of the operator it solved with."""

    iterations: int = 0
    augmentations: int = 0
    kappa: float = float("nan")
    condition: float = float("nan")
    converged: bool = True
    cycle: bool = False
    message: str = ""
    extra: dict = field(default_factory=dict)


class ContactMethod:
    """Base class. ``name`` is the scene's ``[contact] method``.

    ``applies_forces``: False for detection only. ``needs_volumes``: the method wants each
    pair's interface-tet weight (penalty from volumes). ``constraint``: the method enforces
    g >= 0 as a constraint (to its tolerance), not as a force law of the overlap; in the
    contact-stabilized scheme its reaction acts within its step only.
    """

    name = ""
    applies_forces = True
    needs_volumes = False
    constraint = False

    def __init__(self, config: dict):
        self.config = config

    def solve(self, W: np.ndarray, g0: np.ndarray, stiffness: np.ndarray, final: bool = True) -> tuple:
        """Returns (lambda, SolveInfo). ``stiffness``: per-pair penalty in N/m (kappa x the
        slave's tributary area, or the volume form's equivalent). ``final``: this solve sets
        the gaps the step ends with (False for the stabilized predictor's projection), so a
        method with a gap tolerance reports missing it as non-convergence."""
        raise NotImplementedError
