"""The summary's band-limited peaks and first-closure stages (vfrs.summary.closure, issue 45)
on synthetic histories with known answers, and what kind of number each printed quantity is
(``Quantity.kind``: ``[smooth]`` / ``[extreme]`` tags, kept in summary.json)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vfrs import summary
from vfrs.bandlimit import band_limited_peak, closure_stages
from vfrs.summary import MEASURES, Quantity, RunView
from vfrs.summary.closure import CLOSURE_SHARE, first_closure

H = 1e-5


def raised_cosine(t, c, w, A):
    u = (t - c) / w
    return np.where(np.abs(u) < 0.5, A * np.cos(np.pi * u) ** 2, 0.0)


def history(t, fx, sensor=None, **extra):
    """Two folds pushed apart by +-fx (N) along x, with a y force on the right one ten times as
    large (which the medio-lateral measures leave out)."""
    h = {"t": t, "active_pairs": (fx > 0) * 3.0,
         "contact_force.right": np.column_stack([fx, 10 * fx, 0 * fx]),
         "contact_force.left": np.column_stack([-fx, 0 * fx, 0 * fx]), **extra}
    if sensor is not None:
        h["contact_pressure_sensor"] = sensor
    return h


def zipper(t):
    """A two-stage closure (humps of 10 and 14 mN, one-step, at 2 and 5 ms: 9 and 13 mN
    raised cosines 3 ms wide on a 1 mN floor from 0.5 to 6.5 ms, impulse 39 uN s), then a
    single 20 mN closure at 10 ms (1.5 ms wide)."""
    floor = ((t > 0.5e-3 - H / 2) & (t < 6.5e-3 - H / 2)) * 1e-3
    return (raised_cosine(t, 2e-3, 3e-3, 9e-3) + raised_cosine(t, 5e-3, 3e-3, 13e-3) + floor
            + raised_cosine(t, 10e-3, 1.5e-3, 20e-3))


def closure(view) -> dict:
    return MEASURES["band_limited_and_closure_stages"].measures(view)["contact"]


def test_the_first_closure_stages_and_the_band_limited_peaks_without_cycles():
    """Without glottal cycles the band-limited peaks are over the run: the force's is the
    20 mN closure's as vfrs.bandlimit reads |F_x| (the right fold's 10x larger y force left
    out: 18.38 mN, a 1.5 ms pulse loses 8 % in a 1 kHz sensor), the sensor's likewise; the first closure has two humps, their one-step peaks 10 and
    14 mN at 2 and 5 ms, band-limited ones as closure_stages gives them, and the impulse 39 uN s."""
    t = np.arange(0.0, 0.014 + H / 2, H)
    fx = zipper(t)
    co = closure(RunView(history(t, fx, sensor=fx / 1e-5)))
    big, when = band_limited_peak(t, fx)
    q = co["band_limited_peak_force"]
    assert (q.value, q.t, q.over, q.kind, q.unit) == (big, when, "run", "smooth", "N")
    assert 18e-3 < q.value < 19e-3 and q.t == pytest.approx(10e-3, abs=H)  # measured 18.38 mN
    p = co["band_limited_peak_sensor_pressure"]
    assert p.value == pytest.approx(big / 1e-5, rel=1e-12) and p.unit == "Pa" and p.kind == "smooth"
    assert co["first_closure_humps"].value == 2 and co["first_closure_humps"].kind is None
    humps = closure_stages(t, fx)[0].humps
    for name, hump, t_step, top in (("hump1", humps[0], 2e-3, 10e-3), ("hump2", humps[1], 5e-3, 14e-3)):
        band, step = co[f"first_closure_{name}_peak"], co[f"first_closure_{name}_peak_step"]
        assert (band.value, band.t, band.kind) == (hump.peak, hump.t, "smooth")
        assert step.value == pytest.approx(top, rel=1e-12) and step.t == pytest.approx(t_step) and step.kind == "extreme"
    assert co["first_closure_impulse"].value == pytest.approx(39e-6, rel=1e-9)
    assert co["first_closure_impulse"].kind == "smooth" and co["first_closure_impulse"].unit == "N s"


def test_a_graze_before_the_closure_is_no_closure():
    """A 0.5 uN s graze at 1 ms before the zipper (39 uN s, and a 15 uN s closure after it):
    below CLOSURE_SHARE (10 %) of the largest event's impulse, it is not the first closure; the
    zipper is, with its two humps. With share = 0 the graze is."""
    t = np.arange(0.0, 0.016 + H / 2, H)
    fx = zipper(t - 1.5e-3) + raised_cosine(t, 1e-3, 1e-3, 1e-3)  # the zipper from 2 to 8 ms
    view = RunView(history(t, fx))
    assert CLOSURE_SHARE == 0.1
    body, event = first_closure(view)
    assert body == "right" and event.start == pytest.approx(2e-3) and event.impulse == pytest.approx(39e-6, rel=1e-9)
    co = closure(view)
    assert co["first_closure_humps"].value == 2 and co["first_closure_impulse"].value == pytest.approx(39e-6, rel=1e-9)
    _, graze = first_closure(view, share=0.0)
    assert graze.impulse == pytest.approx(0.5e-6, rel=1e-9) and len(graze.humps) == 1


def test_equal_and_opposite_folds_name_the_first_body_whatever_the_round_off():
    """The left fold's force larger by 1e-13 of itself (round-off): still a tie (TIE = 1e-9),
    the band-limited peak and the first closure are the right fold's, the first in the history."""
    t = np.arange(0.0, 0.014 + H / 2, H)
    fx = zipper(t)
    h = history(t, fx)
    h["contact_force.left"] = h["contact_force.left"] * (1 + 1e-13)
    co = closure(RunView(h))
    assert co["band_limited_peak_force"].body == "right" and co["first_closure_humps"].body == "right"
    h["contact_force.left"] = h["contact_force.left"] * 1.01
    co = closure(RunView(h))
    assert co["band_limited_peak_force"].body == "left" and co["first_closure_humps"].body == "left"


def test_one_hump_leaves_the_second_unknown_and_no_contact_leaves_all():
    """A first closure of one hump: the second hump's peaks are NaN (printed n/a) without a
    time; a run without contact: every first-closure number NaN, the band-limited peak 0."""
    t = np.arange(0.0, 0.01 + H / 2, H)
    co = closure(RunView(history(t, raised_cosine(t, 4e-3, 2e-3, 5e-3))))
    assert co["first_closure_humps"].value == 1 and co["first_closure_hump1_peak_step"].value == pytest.approx(5e-3)
    assert np.isnan(co["first_closure_hump2_peak"].value) and co["first_closure_hump2_peak"].t is None
    assert co["first_closure_hump2_peak"].text() == "n/a"
    none = closure(RunView(history(t, 0 * t)))
    assert np.isnan(none["first_closure_humps"].value) and np.isnan(none["first_closure_impulse"].value)
    assert none["band_limited_peak_force"].value == 0.0


def test_with_glottal_cycles_the_band_limited_peaks_are_the_windows():
    """With a glottal area (cycles of 100 Hz from 0 ms) and the window from 20 ms: the
    band-limited peak is over the window's whole cycles (over = "window"): the 10 mN
    closures at 25, 35, 45 ms, not the 30 mN one at 5 ms; the first closure stays the run's."""
    t = np.arange(0.0, 0.06 + H / 2, H)
    area = 1e-6 * (1.2 + np.sin(2 * np.pi * 100 * t))
    fx = raised_cosine(t, 5e-3, 2e-3, 30e-3) + sum(raised_cosine(t, c, 2e-3, 10e-3) for c in (25e-3, 35e-3, 45e-3))
    view = RunView(history(t, fx, glottal_area=area), start=0.02)
    assert len(view.cycles) >= 2
    co = closure(view)
    q = co["band_limited_peak_force"]
    a, b = float(view.cycles[0]), float(view.cycles[-1])
    assert q.over == "window" and (q.value, q.t) == band_limited_peak(t, fx, start=a, end=b)
    assert 9e-3 < q.value < 10e-3  # measured 9.69 mN: the 2 ms pulses lose 3 %
    assert co["first_closure_hump1_peak_step"].value == pytest.approx(30e-3) and co["first_closure_humps"].over == "run"


def test_a_first_closure_cut_off_by_the_run_is_said_so():
    t = np.arange(0.0, 0.005 + H / 2, H)
    h = history(t, raised_cosine(t, 5e-3, 4e-3, 5e-3))  # still rising at the run's end
    s = summary.summarize(h)
    assert any("first closure" in n and "cut off" in n for n in s.notes), s.notes


def test_kind_is_kept_in_summary_json_and_printed_as_a_tag():
    """``kind`` survives summary.json; the printed line carries ``[smooth]`` / ``[extreme]``
    in a column of its own before the value, nothing for a quantity without a kind; a kind
    that is neither is an error naming the quantity."""
    sec = {"contact": {"a": Quantity(1e-3, "N", "peak force", t=0.01, kind="extreme"),
                       "b": Quantity(2e-6, "N s", "impulse", kind="smooth"),
                       "c": Quantity(1e-3, "s", "first contact")}}
    s = summary.Summary(sec)
    back = summary.Summary.from_dict(json.loads(json.dumps(s.to_dict())))
    assert [q.kind for q in back["contact"].values()] == ["extreme", "smooth", None]
    assert "kind" not in s.to_dict()["contact"]["c"]
    lines = {ln.split()[0]: ln for ln in s.text().splitlines() if ln.startswith("      ")}
    assert lines["peak"].endswith("[extreme] 1 mN at t = 10.00 ms")
    assert lines["impulse"].endswith("[smooth]  2 uN s")
    assert lines["first"].endswith("contact            1 ms")
    with pytest.raises(ValueError, match="'peak force'.*smooth, extreme"):
        Quantity(1.0, "N", "peak force", kind="peak")


def test_a_static_run_in_load_steps_keeps_its_summary():
    """A static contact run's ``t`` is the load factor (0.25 ... 1 in four load steps), not a
    time: the band-limited and closure measures are not taken (they were, and a 1 kHz filter
    over "times" 0.25 s apart overflowed, losing the run's whole summary), and the rest of the
    contact summary is there (the patch test: two blocks pressed together, uniform pressure)."""
    import vfrs

    def block(name, z0, fixed):
        return {"name": name, "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": [2, 2, 2],
                                        "origin": [0, 0, z0]},
                "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
                "fixed": fixed + [{"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]}]}

    scene = vfrs.Scene.from_dict({
        "bodies": [block("lower", 0.0, [{"surface": "zmin", "components": ["z"]}]),
                   block("upper", 0.01, [{"surface": "zmax", "components": ["z"], "displacement": [0, 0, -1e-4]}])],
        "contact": {"method": "lagrange", "detection": "bvh", "surface": {"lower": "zmax", "upper": "zmin"}},
        "time": {"mode": "static", "load_steps": 4}, "output": {"energy": False}})
    r = vfrs.run(scene, progress=False)
    co = r.results["contact"]
    assert np.allclose(r.history["t"], [0.25, 0.5, 0.75, 1.0])
    assert co["peak_force.upper"].value == pytest.approx(1e4 * 1e-4 / 0.02 * 1e-4, rel=1e-9)  # E d / 2H x A
    assert not any(k.startswith(("band_limited", "first_closure")) for k in co)
    assert not any(k.startswith(("band_limited", "first_closure")) for k in summary.summary_names(scene)["contact"])
