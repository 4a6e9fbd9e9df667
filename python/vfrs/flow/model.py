"""What a glottal flow model is (``[flow] model``), and their registry.

A flow model turns the gap between the folds (:class:`vfrs.flow.slices.GlottalSlices`: the
width ``x_right - x_left`` on stations along the flow, y, and samples across it, z) and the
pressures around the glottis into the pressure on the stations (a
:class:`~vfrs.flow.slices.FlowState`), which the slices turn into forces on the folds. Each
model is one module of :mod:`vfrs.flow.models` that registers a :class:`FlowModel` subclass
with :func:`register_model`; its ``Params`` are keys of the ``[flow]`` section next to the
shared ones (:class:`vfrs.flow.effect.FlowParams`). The [flow] effect and the time loop never
name a model.

With a vocal tract coupled ([acoustics]), the model hands the tract its losses between the
subglottal pressure and the jet (a :class:`GlottalLoss`), and the tract solves the flow in
its incident waves with them (:meth:`vfrs.acoustics.tract.Tract.glottal_junction`).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..registry import Registry

#: The registered flow models, by ``name`` (``[flow] model``).
FLOW_MODELS = Registry("flow model", packages=("vfrs.flow.models",))


def register_model(cls):
    """Class decorator: registers a :class:`FlowModel` subclass under its ``name``."""
    return FLOW_MODELS.register(cls)


@dataclass(frozen=True)
class GlottalLoss:
    """The pressure a flow ``U`` loses from below the glottis to its jet, besides the jet's own
    ``rho U |U| / (2 A_sep^2)``: ``quadratic`` (kg/m^7, times ``U |U|``: entrance losses) and
    ``linear`` (Pa s/m^3, times ``U``: the viscous resistance). Bernoulli's flow has neither."""

    quadratic: float = 0.0
    linear: float = 0.0


class FlowModel:
    """Base class of a glottal flow model. ``params``: its own keys (``Params``); ``common``:
    the [flow] section's shared keys (``density``, ``separation_ratio``, ...)."""

    #: ``[flow] model`` value.
    name: str = ""
    #: Its own keys of the [flow] section (a dataclass built with :func:`vfrs.params.param`).
    Params: type | None = None
    #: The pressure is proportional to the drive (Bernoulli): the [flow] effect may compute it
    #: for the full subglottal pressure and scale the forces by the pressure ramp after.
    homogeneous: bool = False

    def __init__(self, params, common):
        self.params = params
        self.common = common
        self.separation_ratio = float(common.separation_ratio)
        self.density = float(common.density)

    @classmethod
    def check(cls, params, common, effects: dict, error) -> None:
        """When the scene is read: a model that cannot handle the scene raises ``error(message,
        key)`` (a SceneError naming the key)."""

    def state(self, y, z, width, drive, tract, t) -> object:
        """The :class:`~vfrs.flow.slices.FlowState` for the gap ``width`` (stations ``y`` x
        samples ``z``) driven by ``drive`` (Pa, the subglottal pressure now); ``tract``: see
        :meth:`vfrs.flow.slices.GlottalSlices.state`; ``t``: the time the pressure is for."""
        raise NotImplementedError

    def memory(self) -> dict:
        """What the model carries from one step to the next, for a checkpoint (default: nothing)."""
        return {}

    def recall(self, memory: dict) -> None:
        """Back to a checkpoint's :meth:`memory`."""
