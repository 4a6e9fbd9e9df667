"""The registry of the ``[time]`` role, on the ground floor: the scene chooses an integrator by
``mode`` and the bodies' kinematics without importing the integrators (they build on the
assembled problem, which is built from a scene); the registry loads
:mod:`vfrs.dynamics.integrators` on first use. What an integrator is:
:mod:`vfrs.dynamics.integrators`."""

from __future__ import annotations

from .registry import Registry

INTEGRATORS = Registry("integrator", modules=("vfrs.dynamics.integrators",))


def mode_of(cls) -> str:
    return cls.mode or cls.name


def modes() -> list:
    """The ``[time] mode`` values the registered integrators serve."""
    return sorted({mode_of(c) for c in INTEGRATORS.values()})


def integrator_for(mode: str, kinematics: str = "linear"):
    """The registered integrator of ``mode`` for bodies of ``kinematics`` (``"linear"``, or
    ``"finite"`` when any body is finite-strain), or None if the mode has none."""
    for cls in INTEGRATORS.values():
        if mode_of(cls) == mode and cls.kinematics == kinematics:
            return cls
    return None
