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


__all__ = ["VfrsError", "MeshError", "MaterialError", "SolverError", "ContactError", "SceneError", "ConvergenceError", "VfrsWarning"]
