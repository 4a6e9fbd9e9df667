"""What the [flow] effect offers a vocal tract (the ``[acoustics]`` effect) in the setup context.

With an ``[acoustics]`` section coupled two ways, the vocal tract (:mod:`vfrs.acoustics`) gives
the pressures below and above the glottis in the same step, which replace Ps and 0 above:
p = p_sup + (p_sub - p_sup) (1 - (A_sep / A)^2) upstream of separation, p_sup downstream (the
tract connected to the :class:`GlottisPort` the [flow] effect offers in the setup
context); without it, or with
``coupling = "none"``, the flow is computed exactly as without a tract.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


#: kg/m^3: the default of ``[flow] density``, the air's (the reported flow rate's, and a coupled
#: vocal tract's).
AIR_DENSITY = 1.2


@dataclass
class GlottisPort:
    """The typed link the [flow] effect offers a vocal tract in the setup context
    (:meth:`vfrs.effects.SetupContext.offer`): the air's ``density`` (kg/m^3, ``[flow]
    density``: the glottal jet's and the tract's, one for both), its ``viscosity``, and the
    tract's ``glottis(t, A_sep, P_lung, loss) -> (p_sub, p_jet) or None``, which the tract connects (:meth:`connect`) and
    the flow calls once per step, at its load's time (None: no tract, the flow alone)."""

    density: float = AIR_DENSITY
    tract: Callable[..., tuple | None] | None = None
    #: The air's dynamic viscosity (Pa s) of a flow model that has one (the tract's boundary
    #: layers take it too); None: the tract's own default.
    viscosity: float | None = None

    def connect(self, glottis) -> None:
        """The tract's ``glottis(t, A_sep, P_lung)`` (:meth:`vfrs.acoustics.Acoustics.glottis`)."""
        self.tract = glottis
