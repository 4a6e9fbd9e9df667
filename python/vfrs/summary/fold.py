"""Summary measures for comparing the folds with measurements (issue 33, docs/validation.md):
registered :class:`vfrs.summary.Measure` classes (loaded by ``vfrs.summary.MEASURES`` on
first use), so neither the time loop nor an effect's module changes.

- ``contact.cycle_peak_sensor_pressure`` (Pa): the largest sensor pressure (the history's
  ``contact_pressure_sensor``, a ``[contact] sensor_area`` disc) in each glottal cycle of the
  window; their mean, each cycle's in ``per_cycle`` (a cycle without contact counts 0). The
  run's single largest value (``contact.peak_sensor_pressure``) is one collision's; this is
  the per-cycle number a probe's cycle-by-cycle peaks are averaged into.
- ``contact.peak_sensor_pressure_ap`` (1) and ``contact.peak_sensor_pressure_below_superior``
  (m): where the run's largest sensor pressure was (the same step and node as
  ``contact.peak_sensor_pressure``), as a fraction of the fold's length from its anterior end
  (0.5: mid-length), and as the distance below the superior edge of the medial surface (the
  top of the straight medial surface, where the glottal exit's rounding ``R_O`` begins: y = 0
  for ``psi >= 0``, ``T cos(psi/2)`` for a divergent glottis; reference coordinates). Only for
  bodies on the built-in ``m5`` generator (whose geometry says what "length" and "superior
  edge" are).
- ``phonation.mean_flow`` (m^3/s): the time average of the flow rate over the window's whole
  glottal cycles (from the first cycle start to the last; over the window without two).
- ``phonation.onset`` (1 or 0), with ``phonation.area_growth`` and
  ``phonation.area_oscillation``: whether the folds self-oscillate, by :func:`onset_test`.
"""

from __future__ import annotations

import math

import numpy as np

from ..signals import cycle_amplitudes, cycle_peaks, window
from .measures import Measure, RunView, register_measure
from .quantity import Quantity

#: Least growth factor per glottal cycle of the peak-to-peak glottal area for an oscillation
#: to count as self-sustained: a decay by less than 2 % per cycle. Why: a free oscillation of
#: the folds damped by the tissue's Rayleigh damping alone (the examples' a1 = 1e-5 s: damping
#: ratio pi a1 f0) loses 1 - exp(-2 pi^2 a1 f0) = 2.3-3.5 % of its amplitude per cycle at
#: 120-180 Hz; decaying more slowly than 2 % means the flow returns most of that.
ONSET_GROWTH = 0.98
#: Least peak-to-peak glottal area per cycle, relative to the window's mean glottal area, for
#: the oscillation to count: 10 % (a smaller ripple is not a glottal cycle a video or a flow
#: glottogram would call phonation).
ONSET_SIZE = 0.10
#: Fewest full glottal cycles in the window the test needs (fewer: no onset).
ONSET_CYCLES = 3


def onset_test(t, area, cycles) -> tuple:
    """(onset, growth, size) of a glottal-area record over the window whose cycle starts are
    ``cycles``: ``growth`` is exp of the least-squares slope of ln(peak-to-peak area) against
    the cycle's index (the factor by which the oscillation grows per cycle; 1: sustained, < 1:
    decaying), ``size`` the mean peak-to-peak area over the mean area of the window's whole
    cycles; ``onset`` is True when there are at least :data:`ONSET_CYCLES` cycles, ``growth >=``
    :data:`ONSET_GROWTH` and ``size >=`` :data:`ONSET_SIZE`. NaNs (and False) with fewer than
    two cycles.

    >>> t = np.arange(0.0, 0.05, 1e-5)
    >>> area = 1e-6 * (2.0 + np.exp(-40.0 * t) * np.sin(2 * np.pi * 100 * t))   # decays 33 % per cycle
    >>> on, growth, size = onset_test(t, area, np.arange(0.0, 0.0501, 0.01))
    >>> bool(on), round(growth, 3)
    (False, 0.67)
    """
    cyc = np.asarray(cycles, dtype=float)
    if len(cyc) < 3:
        return False, float("nan"), float("nan")
    p2p = 2.0 * cycle_amplitudes(t, area, cyc[0], cyc[-1], cycles=cyc)
    tw, aw = window(t, area, cyc[0], cyc[-1])
    mean_area = float(aw.mean()) if len(aw) else float("nan")
    size = float(p2p.mean() / mean_area) if mean_area > 0 else float("nan")
    if len(p2p) >= 2 and np.all(p2p > 0):
        slope = float(np.polyfit(np.arange(len(p2p), dtype=float), np.log(p2p), 1)[0])
        growth = math.exp(slope)
    else:
        growth = float("nan")
    on = len(p2p) >= ONSET_CYCLES and growth >= ONSET_GROWTH and size >= ONSET_SIZE
    return bool(on), growth, size


def superior_edge_y(mesh: dict) -> float:
    """The height (y, m, reference) of the superior edge of an ``m5`` fold's medial surface:
    the top of its straight part (:func:`vfrs.meshes.m5.m5_profile`: at the narrowest point,
    y = 0, for psi >= 0; the medial surface's top, T cos(psi/2), for psi < 0)."""
    psi = float(mesh.get("psi", 0.0))
    return 0.0 if psi >= 0 else float(mesh["T"]) * math.cos(math.radians(psi) / 2)


def _m5_mesh(scene, body: str | None) -> dict | None:
    """The resolved ``mesh`` table of ``body`` when it is a built-in m5 fold, else None."""
    if scene is None or body is None:
        return None
    for b in scene.bodies:
        if b.name == body and isinstance(b.mesh, dict) and b.mesh.get("builtin") == "m5":
            return b.mesh
    return None


@register_measure
class SensorPressureMeasures(Measure):
    """``contact.cycle_peak_sensor_pressure``, ``contact.peak_sensor_pressure_ap`` and
    ``contact.peak_sensor_pressure_below_superior`` (module text)."""

    name = "sensor_pressure_per_cycle_and_place"

    @classmethod
    def summary_names(cls, scene) -> dict:
        """With contact: the peak per glottal cycle (with a glottal area: [flow]); the place,
        between m5 folds (:func:`vfrs.summary.summary_names`)."""
        if "contact" not in scene.effects:
            return {}
        names = ["cycle_peak_sensor_pressure"] if "flow" in scene.effects else []
        if any(_m5_mesh(scene, b.name) for b in scene.bodies):
            names += ["peak_sensor_pressure_ap", "peak_sensor_pressure_below_superior"]
        return {"contact": names} if names else {}

    @classmethod
    def measures(cls, run: RunView) -> dict:
        h = run.history
        if "contact_pressure_sensor" not in h:
            return {}
        p = np.asarray(h["contact_pressure_sensor"], dtype=float)
        out: dict = {}
        cyc = run.cycles
        if len(cyc) >= 2:
            per = cycle_peaks(run.t, p, cyc)
            out["cycle_peak_sensor_pressure"] = Quantity(
                float(per.mean()), "Pa", "peak sensor contact pressure per glottal cycle", per_cycle=tuple(per.tolist()),
                over="window", kind="extreme")
        k = int(np.argmax(p))  # the step of contact.peak_sensor_pressure (the same argmax)
        node = int(np.asarray(h["contact_pressure_sensor_node"])[k])
        if node < 0 or not p[k] > 0 or run.body_of_node is None:
            return {"contact": out} if out else {}
        body = run.body_of_node(node)
        mesh = _m5_mesh(run.scene, body)
        if mesh is not None:
            x, y, z = (float(v) for v in np.asarray(h["contact_pressure_sensor_position"])[k])
            out["peak_sensor_pressure_ap"] = Quantity(
                z / float(mesh["length"]), "1", "peak sensor pressure at (z / fold length)",
                t=float(run.t[k]), body=body, over="run")
            out["peak_sensor_pressure_below_superior"] = Quantity(
                superior_edge_y(mesh) - y, "m", "peak sensor pressure at (below superior edge)",
                t=float(run.t[k]), body=body, over="run")
        return {"contact": out} if out else {}


@register_measure
class OnsetMeasures(Measure):
    """``phonation.mean_flow``, ``phonation.onset``, ``phonation.area_growth`` and
    ``phonation.area_oscillation`` (module text, :func:`onset_test`)."""

    name = "onset_and_mean_flow"

    @classmethod
    def summary_names(cls, scene) -> dict:
        """With a glottal area and flow rate ([flow])."""
        return {"phonation": ["mean_flow", "onset", "area_growth", "area_oscillation"]} if "flow" in scene.effects else {}

    @classmethod
    def measures(cls, run: RunView) -> dict:
        h = run.history
        if "glottal_area" not in h:
            return {}
        t, area = run.t, np.asarray(h["glottal_area"], dtype=float)
        cyc = run.cycles
        out: dict = {}
        if "flow_rate" in h:
            a, b = (float(cyc[0]), float(cyc[-1])) if len(cyc) >= 2 else (run.window_start, float(t[-1]))
            tw, qw = window(t, h["flow_rate"], a, b)
            if len(tw) >= 2:
                trapezoid = getattr(np, "trapezoid", None) or getattr(np, "trapz")  # numpy 2 renamed it
                out["mean_flow"] = Quantity(float(trapezoid(qw, tw) / (tw[-1] - tw[0])), "m^3/s", "mean flow rate",
                                            over="window", kind="smooth")
        on, growth, size = onset_test(t, area, cyc)
        out["onset"] = Quantity(1.0 if on else 0.0, "1",
                                "self-oscillates (1) or not (0)", over="window")
        out["area_growth"] = Quantity(growth, "1", "growth of peak-to-peak glottal area per cycle", over="window")
        out["area_oscillation"] = Quantity(size, "1", "peak-to-peak glottal area / mean area", over="window")
        return {"phonation": out}
