"""Glottal flow between two folds: a flow model's pressure on their medial surfaces.

The glottal area A(y) at a station y (flow direction) is the integral along z of the gap
between the right fold's and the left fold's medial surfaces in the current configuration,
with no symmetry assumed. Two models (``[flow] model``, :mod:`vfrs.flow.models`):

- ``bernoulli`` (the default): upstream of flow separation the pressure follows Bernoulli with
  the subglottal pressure Ps at rest upstream and zero (supraglottal) pressure at separation,
  ``p(y) = Ps (1 - (A_sep / A(y))^2)`` for ``y <= y_sep``, ``p = 0`` above; no losses.
- ``viscous``: the same jet with the viscous loss of a slit whose width varies along z
  (``12 mu U int dy / int g^3 dz``), an entrance loss, optionally the glottal inertance; the
  pressure acts only where the gap is open (:mod:`vfrs.flow.models.viscous`).

Separation is at the minimum area (``separation_ratio`` = 1), or at the first station
downstream of the minimum where A reaches ``separation_ratio`` x A_min. With the glottis
closed at some station (A = 0), p = Ps below the lowest closure and 0 above it. The
pressure acts as the traction -p n on the medial surfaces and is turned into consistent
nodal forces (exact for pressure linear over a triangle).

The package: :mod:`~vfrs.flow.slices` (the glottis as the models see it: the gap on stations,
the forces), :mod:`~vfrs.flow.model` (what a model is, their registry, the losses a model hands
a vocal tract), :mod:`~vfrs.flow.models` (one module per model), :mod:`~vfrs.flow.port` (what the
flow offers a vocal tract: :class:`GlottisPort`, the air's density), :mod:`~vfrs.flow.effect`
(the registered ``[flow]`` effect and its output hooks: the summary's ``phonation`` section),
:mod:`~vfrs.flow.figures` (``glottal_area_flow.png``).
"""

from .effect import GlottalFlow, phonation_measures
from .model import FLOW_MODELS, FlowModel, GlottalLoss, register_model
from .models.bernoulli import BernoulliFlow, BernoulliModel, bernoulli_pressure
from .models.viscous import ViscousModel, slit_integrals, viscous_flow
from .port import AIR_DENSITY, GlottisPort
from .slices import FlowState, GlottalSlices, MedialSurface, consistent_pressure_forces

__all__ = ["AIR_DENSITY", "BernoulliFlow", "BernoulliModel", "FLOW_MODELS", "FlowModel", "FlowState", "GlottalFlow",
           "GlottalLoss", "GlottalSlices", "GlottisPort", "MedialSurface", "ViscousModel", "bernoulli_pressure",
           "consistent_pressure_forces", "phonation_measures", "register_model", "slit_integrals", "viscous_flow"]
