"""Exceptions raised by vfrs. All derive from :class:`VfrsError`, a ``ValueError``."""

from ._core import ContactError, MaterialError, MeshError, SolverError, VfrsError


class SceneError(VfrsError):
    """A scene is invalid: the message names the file, the key path and what was expected."""


class ConvergenceError(VfrsError):
    """An iterative method (active set, augmentation) did not converge.

    The message names the step, the method, the nodes involved and what to try.
    """


class VfrsWarning(UserWarning):
    """Something is allowed but likely not what you want (e.g. near-incompressible P1 tets)."""


class PlausibilityWarning(VfrsWarning):
    """A vocal-fold scene's size, pressure, modulus or density is far outside the physiological
    range, most likely a unit slip (:mod:`vfrs.scene.plausibility`): the message names the file,
    the key, the value with its unit, the range and the slip."""


class PlausibilityError(SceneError):
    """A :class:`PlausibilityWarning` of a scene with ``[checks] strict = true``: the same message."""


__all__ = ["VfrsError", "MeshError", "MaterialError", "SolverError", "ContactError", "SceneError", "ConvergenceError", "VfrsWarning",
           "PlausibilityWarning", "PlausibilityError"]
