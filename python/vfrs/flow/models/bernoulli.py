"""``[flow] model = "bernoulli"``: the quasi-steady Bernoulli jet, no losses (the equations:
:mod:`vfrs.flow`).

The glottal area A(y) is the integral along z of the gap between the folds (its open part,
trapezoid rule over the z samples); upstream of separation
p(y) = p_exit + (p_sub - p_exit) (1 - (A_sep / A(y))^2), p_exit above;
a station with no area closes the glottis (p_sub below the first closed station, p_exit from
it on). The pressure acts on the whole medial surface, the contact patch included."""

from __future__ import annotations

import numpy as np

from ..model import FlowModel, register_model
from ..slices import FlowState, GlottalSlices


def bernoulli_pressure(y, area, subglottal_pressure, separation_ratio=1.0, closed_area=0.0):
    """Pressure at the stations ``y`` (increasing) for glottal areas ``area``.

    >>> import numpy as np
    >>> y = np.linspace(0, 1, 5); A = np.array([4.0, 3.0, 2.0, 1.0, 2.0])
    >>> bernoulli_pressure(y, A, 800.0)[0].round(1).tolist()
    [750.0, 711.1, 600.0, 0.0, 0.0]
    """
    y = np.asarray(y, dtype=float)
    area = np.asarray(area, dtype=float)
    p = np.zeros_like(area)
    shut = np.flatnonzero(area <= closed_area)
    if shut.size:
        below = y < y[shut[0]]
        p[below] = subglottal_pressure
        return p, y[shut[0]], True
    i_min = int(np.argmin(area))
    a_min = area[i_min]
    i_sep = i_min
    if separation_ratio > 1.0:
        after = np.flatnonzero(area[i_min:] >= separation_ratio * a_min)
        i_sep = i_min + int(after[0]) if after.size else len(area) - 1
    a_sep = area[i_sep]
    up = np.arange(len(area)) <= i_sep
    p[up] = subglottal_pressure * (1.0 - (a_sep / area[up]) ** 2)
    return p, y[i_sep], False


@register_model
class BernoulliModel(FlowModel):
    """Bernoulli's jet from rest below the glottis to separation, no losses."""

    name = "bernoulli"
    homogeneous = True

    def state(self, y, z, width, drive, tract, t) -> FlowState:
        gap = np.maximum(width, 0.0)
        trapezoid = getattr(np, "trapezoid", None) or getattr(np, "trapz")  # numpy 2 renamed it
        area = trapezoid(gap, z, axis=1)
        p, y_sep, closed = bernoulli_pressure(y, area, drive, self.separation_ratio)
        drop = None
        if tract is not None:
            pressures = tract(0.0 if closed else float(np.interp(y_sep, y, area)), None)
            if pressures is not None:
                p_sub, p_sup = pressures
                drop = p_sub - p_sup
                p = p_sup + bernoulli_pressure(y, area, drop, self.separation_ratio)[0]
        return FlowState(y, area, p, float(area.min()), float(y_sep), closed, float(width.min()), drop)


class BernoulliFlow(GlottalSlices):
    """The Bernoulli flow between a right fold (x > 0) and a left fold (x < 0), without a scene:
    :class:`~vfrs.flow.slices.GlottalSlices` with :class:`BernoulliModel`."""

    def __init__(self, right, left, subglottal_pressure, separation_ratio=1.0, n_stations=120, n_z=None):
        from ...errors import VfrsError

        if separation_ratio < 1.0:
            raise VfrsError(f"separation_ratio = {separation_ratio} must be >= 1 (1: separation at the minimum area)")
        from ..effect import FlowParams

        common = FlowParams(subglottal_pressure=subglottal_pressure, separation_ratio=separation_ratio)
        super().__init__(right, left, BernoulliModel(None, common), subglottal_pressure,
                         n_stations=n_stations, n_z=n_z)
