"""Summary measures of what a band-limited sensor reads and of the stages of the first
closure (issue 45): a registered :class:`vfrs.summary.Measure` (loaded by
``vfrs.summary.MEASURES`` on first use), built on :mod:`vfrs.bandlimit`. For runs with
``[contact]``; forces are each body's medio-lateral (x) contact force, |F_x| (N), from the
history's ``contact_force.<body>``.

- ``contact.band_limited_peak_force`` (N): the largest :func:`vfrs.bandlimit.band_limited`
  |F_x| (a sensor of bandwidth :data:`vfrs.bandlimit.CUTOFF`, 1 kHz) of any body, with its body
  and time; over the window's whole glottal cycles when the run has two or more (``over =
  "window"``), else over the whole run (``"run"``), as the contact impulse.
- ``contact.band_limited_peak_sensor_pressure`` (Pa): the same of the history's
  ``contact_pressure_disc`` (the sensor over its exact disc; histories written before it was
  recorded: ``contact_pressure_sensor``; a sample that is not finite reads as 0).
- The **first closure** (:func:`first_closure`: the first contact event,
  :func:`vfrs.bandlimit.closure_stages`, whose impulse is at least :data:`CLOSURE_SHARE` of
  the run's largest; a graze before it is no closure), over the whole run:
  ``first_closure_humps`` (1, how many humps its band-limited force has),
  ``first_closure_hump1_peak`` and ``first_closure_hump2_peak`` (N, the first and the second
  hump's band-limited peak, when; in the flow-driven zipper closure of the M5 folds, issue 45,
  the lower margin's, then the upper margin's), ``first_closure_hump1_peak_step`` and
  ``first_closure_hump2_peak_step`` (N, the largest one-step value within each hump), and
  ``first_closure_impulse`` (N s, the integral of |F_x| over the event). NaN where there is no
  such hump or no contact.

Band-limited peaks, hump peaks and the impulse are ``kind = "smooth"``; one-step peaks
``"extreme"``.
"""

from __future__ import annotations

import math

import numpy as np

from ..bandlimit import CUTOFF, band_limited_peak, closure_stages
from .measures import Measure, RunView, register_measure
from .quantity import Quantity

NAN = float("nan")

#: The least impulse of a contact event, as a share of the run's largest event's, for it to be
#: a closure (:func:`first_closure`): 10 %. Why: the M5 folds graze during the pressure ramp
#: before they first close, on some meshes and not on others (the accuracy report's m5 problem:
#: 0.1-1.0 uN s against about 18 for the closure; the coarse main job at 50 us, 0.08 and 0.56 uN s
#: at 2.4 and 8.7 ms against 19.9 at 16.7 ms), so "the first contact event" would be a graze on
#: one mesh and the closure on the next.
CLOSURE_SHARE = 0.1
#: Two bodies' values equal to this share are a tie, which goes to the first body in the
#: history's order: two folds pushed apart carry equal and opposite forces, and the body named
#: should not flip with round-off from one run to the next.
TIE = 1e-9


def _forces(run: RunView) -> dict:
    """body -> |F_x| (N) per step, of every body with a ``contact_force.<body>`` record."""
    h = run.history
    return {k.split(".", 1)[1]: np.abs(np.asarray(h[k], dtype=float)[:, 0])
            for k in h if k.startswith("contact_force.")}


def _band_limited_peaks(run: RunView, forces: dict) -> dict:
    """``band_limited_peak_force`` and ``band_limited_peak_sensor_pressure`` (module text)."""
    cyc = run.cycles
    a, b, over = (float(cyc[0]), float(cyc[-1]), "window") if len(cyc) >= 2 else (None, None, "run")
    khz = f"{CUTOFF * 1e-3:g} kHz"
    best = (NAN, None, None)
    for body, f in forces.items():
        value, when = band_limited_peak(run.t, f, CUTOFF, a, b)
        if math.isfinite(value) and not value <= best[0] * (1 + TIE):
            best = (value, when, body)
    out = {"band_limited_peak_force": Quantity(
        best[0], "N", f"peak medio-lateral contact force, band-limited ({khz})", t=best[1], body=best[2], over=over,
        kind="smooth")}
    key = "contact_pressure_disc" if "contact_pressure_disc" in run.history else "contact_pressure_sensor"
    if key in run.history:
        p = np.asarray(run.history[key], dtype=float)
        value, when = band_limited_peak(run.t, np.where(np.isfinite(p), p, 0.0), CUTOFF, a, b)
        face = "exact-disc " if key == "contact_pressure_disc" else ""
        out["band_limited_peak_sensor_pressure"] = Quantity(
            value, "Pa", f"peak {face}sensor contact pressure, band-limited ({khz})", t=when, over=over, kind="smooth")
    return out


def first_closure(run: RunView, forces: dict | None = None, share: float = CLOSURE_SHARE) -> tuple:
    """(body, :class:`vfrs.bandlimit.ClosureEvent`) of the run's first closure: over the bodies'
    medio-lateral forces (``forces``: body -> |F_x|; default: the run's), the earliest contact
    event whose impulse is at least ``share`` of the largest event's of any body (on equal
    starts, the one with the larger impulse; equal to :data:`TIE`, the first body's in the
    history's order); ``share = 0``: the first contact event. (None, None) without contact."""
    forces = _forces(run) if forces is None else forces
    events = {body: closure_stages(run.t, f, CUTOFF) for body, f in forces.items()}
    largest = max((e.impulse for ev in events.values() for e in ev), default=0.0)
    first = None
    for body, ev in events.items():
        closures = [e for e in ev if e.impulse >= share * largest]
        c = closures[0] if closures else None
        if c is not None and (first is None or c.start < first[1].start or (
                c.start == first[1].start and c.impulse > first[1].impulse * (1 + TIE))):
            first = (body, c)
    return (None, None) if first is None else first


def _first_closure_measures(run: RunView, forces: dict) -> dict:
    """The ``first_closure_*`` measures (module text)."""
    body, event = first_closure(run, forces)
    humps = event.humps if event is not None else ()
    out = {"first_closure_humps": Quantity(float(len(humps)) if event is not None else NAN, "1",
                                           "first closure: humps of its band-limited force",
                                           t=event.start if event is not None else None, body=body, over="run")}
    for i, name in ((0, "hump1"), (1, "hump2")):
        hump = humps[i] if len(humps) > i else None
        nth = ("1st", "2nd")[i]
        out[f"first_closure_{name}_peak"] = Quantity(
            hump.peak if hump else NAN, "N", f"first closure: {nth} hump's peak force, band-limited",
            t=hump.t if hump else None, body=body if hump else None, over="run", kind="smooth")
        out[f"first_closure_{name}_peak_step"] = Quantity(
            hump.peak_step if hump else NAN, "N", f"first closure: {nth} hump's peak force, one step",
            t=hump.t_step if hump else None, body=body if hump else None, over="run", kind="extreme")
    out["first_closure_impulse"] = Quantity(
        event.impulse if event is not None else NAN, "N s", "first closure: medio-lateral contact impulse",
        t=event.start if event is not None else None, body=body, over="run", kind="smooth")
    return out


def _dynamic(scene) -> bool:
    """Whether the run's ``t`` is time: a scene whose integrator has inertia (``Time.dynamic``),
    or one not known (a history alone)."""
    time = getattr(scene, "time", None)
    return time is None or bool(getattr(time, "dynamic", True))


@register_measure
class ClosureMeasures(Measure):
    """The band-limited peaks and the first closure's stages (module text)."""

    name = "band_limited_and_closure_stages"

    @classmethod
    def summary_names(cls, scene) -> dict:
        """With contact in a dynamic run: all of them (the sensor's with the history's sensor
        record, which every [contact] run writes). A static run has no time (its ``t`` is the
        load factor), so nothing here."""
        if "contact" not in scene.effects or not _dynamic(scene):
            return {}
        return {"contact": ["band_limited_peak_force", "band_limited_peak_sensor_pressure", "first_closure_humps",
                            "first_closure_hump1_peak", "first_closure_hump1_peak_step", "first_closure_hump2_peak",
                            "first_closure_hump2_peak_step", "first_closure_impulse"]}

    @classmethod
    def measures(cls, run: RunView) -> dict:
        forces = _forces(run)
        if not forces or len(run.t) < 2 or not _dynamic(run.scene):
            return {}
        return {"contact": {**_band_limited_peaks(run, forces), **_first_closure_measures(run, forces)}}

    @classmethod
    def notes(cls, run: RunView, sections: dict) -> list:
        """A first closure cut off by the run's start or end: its impulse and humps are a part's."""
        forces = _forces(run)
        if not forces or "first_closure_humps" not in sections.get("contact", {}):
            return []
        _, event = first_closure(run, forces)
        if event is None or event.complete:
            return []
        return [f"the first closure ({event.start * 1e3:.2f}-{event.end * 1e3:.2f} ms) is cut off by the run's "
                "start or end: its impulse and humps are those of the part recorded (run longer)"]
