"""Quasi-steady Bernoulli glottal flow between two folds.

The glottal area A(y) at a station y (flow direction) is the integral along z of the gap
between the right fold's and the left fold's medial surfaces in the current configuration,
with no symmetry assumed. Upstream of flow separation the pressure follows Bernoulli with
the subglottal pressure Ps at rest upstream and zero (supraglottal) pressure at separation:

    p(y) = Ps (1 - (A_sep / A(y))^2),   y <= y_sep;      p = 0 above.

Separation is at the minimum area (``separation_ratio`` = 1), or at the first station
downstream of the minimum where A reaches ``separation_ratio`` x A_min. With the glottis
closed at some station (A = 0), p = Ps below the lowest closure and 0 above it. The
pressure acts as the traction -p n on the medial surfaces and is turned into consistent
nodal forces (exact for pressure linear over a triangle).

The package: :mod:`~vfrs.flow.bernoulli` (the pressure model, :class:`BernoulliFlow`),
:mod:`~vfrs.flow.port` (what it offers a vocal tract: :class:`GlottisPort`, the air's density),
:mod:`~vfrs.flow.effect` (the registered ``[flow]`` effect and its output hooks: the summary's
``phonation`` section), :mod:`~vfrs.flow.figures` (``glottal_area_flow.png``), and
:mod:`~vfrs.flow.viscous` (issue 46, started: the viscous slit flow's equations, Bernoulli with
the Poiseuille loss of a slit whose width varies along z; not yet a ``[flow] model`` a scene can
choose).
"""

from .bernoulli import BernoulliFlow, FlowState, MedialSurface, bernoulli_pressure, consistent_pressure_forces
from .effect import GlottalFlow, phonation_measures
from .port import AIR_DENSITY, GlottisPort

__all__ = ["AIR_DENSITY", "BernoulliFlow", "FlowState", "GlottalFlow", "GlottisPort", "MedialSurface",
           "bernoulli_pressure", "consistent_pressure_forces", "phonation_measures"]
