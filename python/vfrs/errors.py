"""Exceptions raised by vfrs. All derive from :class:`VfrsError`, a ``ValueError``; the
warnings from :class:`VfrsWarning`.

Every exception class of the package is defined here (the Rust core's in ``vfrs._core.errors``,
re-exported); the modules that raise them re-export theirs under the old paths
(``vfrs.checkpoint.CheckpointError``, ``vfrs.output.writer.OutputFolderError``). Not an error:
:class:`vfrs.checkpoint.RunStopped`, a run stopped on a signal with its checkpoint written."""

from ._core.errors import ContactError, MaterialError, MeshError, SolverError, VfrsError


class SceneError(VfrsError):
    """A scene is invalid: the message names the file, the key path and what was expected."""


class ConvergenceError(VfrsError):
    """An iterative method (active set, augmentation) did not converge.

    The message names the step, the method, the nodes involved and what to try.
    """


class CheckpointError(VfrsError):
    """A checkpoint cannot be written, read or resumed from (the message says why and what to do)."""


class OutputFolderError(VfrsError):
    """An output folder cannot be used as asked (a file, another run's folder, ...)."""


class VfrsWarning(UserWarning):
    """Something is allowed but likely not what you want (e.g. near-incompressible P1 tets)."""


class PlausibilityWarning(VfrsWarning):
    """A vocal-fold scene's size, pressure, modulus or density is far outside the physiological
    range, most likely a unit slip (:mod:`vfrs.scene.plausibility`): the message names the file,
    the key, the value with its unit, the range and the slip."""


class ResolutionWarning(VfrsWarning):
    """A measure is resolved by too few elements at this mesh (e.g. a pressure sensor's disc
    holding fewer than ten surface nodes): its value is not yet near its limit."""


class PlausibilityError(SceneError):
    """A :class:`PlausibilityWarning` of a scene with ``[checks] strict = true``: the same message."""


__all__ = ["VfrsError", "MeshError", "MaterialError", "SolverError", "ContactError", "SceneError", "ConvergenceError",
           "CheckpointError", "OutputFolderError", "VfrsWarning",
           "PlausibilityWarning", "PlausibilityError", "ResolutionWarning"]
