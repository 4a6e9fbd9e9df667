"""The summary measures for the comparison with measurements (vfrs.summary.fold, issue 33):
each against a constructed history whose answer is known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

import vfrs
from vfrs import summary
from vfrs.summary import fold as fm
from vfrs.studies.sweep import summary_names

F0 = 200.0
T = np.arange(0.0, 0.06, 1e-5)  # 12 cycles at 200 Hz; the window (second half) holds 6


def _area(t, envelope=None, mean=2e-6, amp=1e-6):
    env = np.ones_like(t) if envelope is None else envelope
    return mean + amp * env * np.sin(2 * np.pi * F0 * t)


def _history(area, **extra):
    return {"t": T, "glottal_area": area, "flow_rate": 0.2 * area, **extra}


def test_cycle_peak_sensor_pressure_is_each_cycles_crest():
    """Cycle k of the window carries a sensor pressure pulse of height 100 (k + 1) Pa: the
    measure's per-cycle values are those heights, their mean the mean."""
    h = _history(_area(T))
    view = summary.RunView(h)
    cyc = view.cycles
    p = np.zeros_like(T)
    heights = []
    for k, (a, b) in enumerate(zip(cyc[:-1], cyc[1:])):
        mid = (T > a + 0.4 * (b - a)) & (T < a + 0.6 * (b - a))
        p[mid] = 100.0 * (k + 1)
        heights.append(100.0 * (k + 1))
    h.update({"contact_pressure_sensor": p, "contact_pressure_sensor_node": np.where(p > 0, 3, -1),
              "contact_pressure_sensor_position": np.zeros((len(T), 3))})
    q = summary.summarize(h)["contact"]["cycle_peak_sensor_pressure"]
    assert list(q.per_cycle) == heights and len(heights) == 4  # rises at 35, 40, ..., 55 ms
    assert q.value == pytest.approx(np.mean(heights), rel=1e-15) and q.unit == "Pa" and q.over == "window"


class _Run:
    """A run as RunView reads one: a history, a scene, and which body a node is on."""

    def __init__(self, history, scene, body):
        self.history, self.scene = history, scene
        self.body_of_node = lambda node: body


@pytest.mark.parametrize("psi", [0.0, -10.0])
def test_place_of_the_peak_sensor_pressure(psi):
    """The largest sensor reading sits at z = 3.5 mm, y = -1.0 mm of a 14 mm fold: a quarter of
    the length from its anterior end, and 1.0 mm below the superior edge (y = 0) for psi >= 0;
    for a divergent glottis the edge is the medial surface's top, T cos(psi/2) above the
    narrowest point, so the distance is T cos(psi/2) + 1.0 mm."""
    d = vfrs.Scene.load("examples/m5_collision.toml").to_dict()
    for b in d["bodies"]:
        b["mesh"]["psi"] = psi
    scene = vfrs.Scene.from_dict(d)
    p = np.zeros_like(T)
    p[1234], p[4000] = 900.0, 500.0
    pos = np.zeros((len(T), 3))
    pos[1234] = (0.05e-3, -1.0e-3, 3.5e-3)
    pos[4000] = (0.05e-3, -0.2e-3, 7.0e-3)
    h = _history(_area(T), contact_pressure_sensor=p, contact_pressure_sensor_node=np.where(p > 0, 7, -1),
                 contact_pressure_sensor_position=pos)
    co = summary.summarize(_Run(h, scene, "right"))["contact"]
    assert co["peak_sensor_pressure_ap"].value == pytest.approx(0.25, rel=1e-12)
    edge = 0.0 if psi >= 0 else 3.0e-3 * math.cos(math.radians(psi) / 2)
    assert co["peak_sensor_pressure_below_superior"].value == pytest.approx(edge + 1.0e-3, rel=1e-12)
    assert co["peak_sensor_pressure_ap"].t == pytest.approx(T[1234]) and co["peak_sensor_pressure_ap"].body == "right"


def test_no_place_without_an_m5_fold_or_a_loaded_node():
    """A history without bodies (no scene) or without a loaded node gives no place."""
    p = np.zeros_like(T)
    h = _history(_area(T), contact_pressure_sensor=p, contact_pressure_sensor_node=np.full(len(T), -1),
                 contact_pressure_sensor_position=np.zeros((len(T), 3)))
    co = summary.summarize(h)["contact"]
    assert "peak_sensor_pressure_ap" not in co and co["cycle_peak_sensor_pressure"].value == 0.0


def test_mean_flow_over_whole_cycles():
    """Q = 0.2 (2 + sin) mm^2 x ...: its mean over whole cycles is the constant part, to the
    sampling's error (the cycle starts fall between samples)."""
    h = _history(_area(T))
    q = summary.summarize(h)["phonation"]["mean_flow"]
    assert q.value == pytest.approx(0.2 * 2e-6, rel=2e-3) and q.unit == "m^3/s"
    # a flow whose half cycles differ: over whole cycles the mean is still the constant part
    h2 = _history(_area(T), flow_rate=0.2 * _area(T) + 1e-7 * np.sin(4 * np.pi * F0 * T))
    assert summary.summarize(h2)["phonation"]["mean_flow"].value == pytest.approx(0.2 * 2e-6, rel=2e-3)


@pytest.mark.parametrize("sigma, onset", [(+20.0, True), (0.0, True), (-2.0, True), (-20.0, False), (-200.0, False)])
def test_onset_from_the_growth_per_cycle(sigma, onset):
    """An oscillation exp(sigma t) sin(2 pi 200 t) about a mean: its peak-to-peak grows by
    exp(sigma / 200) per cycle (1.105, 1, 0.990, 0.905, 0.368); self-oscillating when that is
    at least ONSET_GROWTH = 0.98."""
    h = _history(_area(T, np.exp(sigma * T), amp=0.5e-6))
    ph = summary.summarize(h)["phonation"]
    assert ph["area_growth"].value == pytest.approx(math.exp(sigma / F0), rel=2e-3)
    assert (ph["onset"].value == 1.0) is onset


def test_onset_needs_a_visible_oscillation_and_enough_cycles():
    """A sustained ripple of 5 % of the mean area is not phonation (size < 0.10); 20 % is; a
    window with two cycles is not enough to tell."""
    small = summary.summarize(_history(_area(T, amp=0.025 * 2e-6)))["phonation"]
    assert small["area_oscillation"].value == pytest.approx(0.05, rel=2e-3) and small["onset"].value == 0.0
    big = summary.summarize(_history(_area(T, amp=0.1 * 2e-6)))["phonation"]
    assert big["area_oscillation"].value == pytest.approx(0.2, rel=2e-3) and big["onset"].value == 1.0
    short = T[T < 0.025]  # 5 cycles, the window holds 2 full ones
    h = {"t": short, "glottal_area": _area(short, amp=0.5e-6), "flow_rate": 0.2 * _area(short)}
    ph = summary.summarize(h)["phonation"]
    assert ph["onset"].value == 0.0


def test_the_measures_are_in_a_run_scenes_summary_names():
    """A sweep can name them in derived columns (checked before anything runs): each measure
    declares its names (``summary_names(scene)``); the place of the peak only for m5 folds."""
    names = summary_names(vfrs.Scene.load("examples/m5_collision.toml"))
    for key in ("phonation.mean_flow", "phonation.onset", "phonation.area_growth", "phonation.area_oscillation",
                "contact.cycle_peak_sensor_pressure", "contact.peak_sensor_pressure_ap",
                "contact.peak_sensor_pressure_below_superior"):
        assert key in names, key
    d = vfrs.Scene.load("examples/m5_collision.toml").to_dict()
    d.pop("contact")
    assert "contact.peak_sensor_pressure_ap" not in summary_names(vfrs.Scene.from_dict(d))


def test_closed_phase_pressure_is_the_impulse_over_the_time_integrated_effective_area():
    """Contact in the narrow half of each cycle with a force that is 700 Pa times an effective
    area swelling and shrinking within the closed phase (and a y component, which the impulse's
    length counts with it): each cycle's closed-phase pressure is the pressure, 700 Pa, whatever
    the area's shape; the left fold's smaller force makes the right fold the one measured; a
    history without effective areas has none."""
    area = _area(T)
    closed = area < 1.5e-6
    a_eff = np.where(closed, 1e-5 * (1.0 + np.sin(2 * np.pi * 3 * F0 * T) ** 2), 0.0)
    f = 700.0 * a_eff
    h = _history(area, active_pairs=closed * 1.0,
                 **{"contact_force.right": np.column_stack([0.6 * f, 0.8 * f, 0 * f]),
                    "contact_force.left": np.column_stack([-0.5 * f, 0 * f, 0 * f]),
                    "contact_area_effective.right": a_eff, "contact_area_effective.left": a_eff})
    s = summary.summarize(h)
    q = s["contact"]["closed_phase_pressure"]
    assert q.value == pytest.approx(700.0, rel=1e-12)
    assert len(q.per_cycle) == len(s["contact"]["contact_duration"].per_cycle) >= 3  # the window's cycles
    assert all(p == pytest.approx(700.0, rel=1e-12) for p in q.per_cycle)
    assert q.kind == "smooth" and q.unit == "Pa" and "right" in q.what
    del h["contact_area_effective.right"], h["contact_area_effective.left"]
    assert "closed_phase_pressure" not in summary.summarize(h)["contact"]
