"""The glottal flow models, one module each (``[flow] model``; what a model is:
:mod:`vfrs.flow.model`): :mod:`~vfrs.flow.models.bernoulli` (the quasi-steady Bernoulli jet, no
losses) and :mod:`~vfrs.flow.models.viscous` (Bernoulli with the viscous loss of a slit whose width
varies along the fold, entrance losses, the glottal inertance; no pressure where the folds
touch)."""
