"""Periodic measures only from a periodic state (issue 32, item 2): the summary tests whether
the window's last glottal cycles repeat (the spread of the period, of the peak glottal area
and of the peak contact force from cycle to cycle, against vfrs.analysis.PERIODIC_TOLERANCE),
and says so in words and in summary.json (``window.periodic``)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import vfrs
import vfrs.analysis as an

F0 = 150.0
DT = 1.0 / (F0 * 200)  # 200 samples per cycle


def _history(lengths, force_peaks=None, dt=DT):
    """A glottal area of cycles of the given ``lengths`` (s), each one sine period from its
    start, a_min + a0 (1 + sin) / 2, its flow, and (``force_peaks``: N per cycle) a contact
    force pulse in each cycle's trough, as the [flow] and [contact] effects record them; the
    last cycle goes on for a quarter of its length more."""
    starts = np.concatenate([[0.0], np.cumsum(lengths)])
    t = np.arange(0.0, starts[-1] + 0.25 * lengths[-1], dt)  # a quarter cycle more: the last one ends inside
    k = np.minimum(np.searchsorted(starts, t, side="right") - 1, len(lengths) - 1)
    phase = 2 * np.pi * (t - starts[k]) / np.asarray(lengths)[k]
    s = np.sin(phase)
    area = 0.2e-6 + 10e-6 * (1 + s) / 2
    h = {"t": t, "glottal_area": area, "flow_rate": area * math.sqrt(2 * 800.0 / 1.2)}
    if force_peaks is not None:
        trough = np.clip(-s - 0.5, 0.0, None) / 0.5  # 0..1, largest where sin = -1
        fx = np.asarray(force_peaks)[k] * trough
        h.update({"active_pairs": (fx > 0) * 3.0, "contact_force.right": np.column_stack([fx, 0 * fx, 0 * fx]),
                  "contact_force.left": np.column_stack([-fx, 0 * fx, 0 * fx])})
    return h


def test_an_exactly_periodic_history_is_periodic_and_says_so(tmp_path):
    """12 cycles of 1/150 s, each with a 2 mN contact peak: the last 4 of the window repeat to
    round-off in period, peak area and peak force; summary.json keeps the verdict and the
    spreads, and reads back to the same words."""
    h = _history([1.0 / F0] * 12, force_peaks=[2e-3] * 12)
    s = an.summarize(h)
    w = s.window
    assert w["periodic"] is True
    p = w["periodicity"]
    assert p["cycles_tested"] == 4 and p["cycles_needed"] == an.PERIODIC_CYCLES == 4
    assert p["tolerance"] == an.PERIODIC_TOLERANCE == 0.05
    assert set(p["spread"]) == {"period", "peak_area", "peak_force"}
    assert all(v < 1e-9 for v in p["spread"].values()), p["spread"]
    text = s.text()
    assert "cycles: the last 4 glottal cycles repeat within < 0.01 % (period), 0 % (peak glottal area), 0 % (peak " \
           "contact force); tolerance 5 %" in text
    assert "does not repeat" not in text and "not shown to repeat" not in text  # no note
    s.save(tmp_path / "summary.json")
    d = json.loads((tmp_path / "summary.json").read_text())
    assert d["window"]["periodic"] is True and d["window"]["periodicity"]["spread"]["period"] < 1e-9
    assert an.Summary.load(tmp_path / "summary.json").text() == text


def test_a_period_drifting_10_percent_is_not_periodic_with_the_numbers():
    """The period grows from T to 1.1 T over the last 4 cycles of the window (and beyond):
    (max - min) / mean = 0.1 / 1.05 = 9.52 %, twice the tolerance; the peak area stays (0 %).
    The summary says they do not repeat, with that number, and the note says the per-cycle
    means follow this run's trajectory."""
    T = 1.0 / F0
    lengths = [T] * 8 + [T * (1 + 0.1 * i / 3) for i in range(4)]
    s = an.summarize(_history(lengths, dt=T / 2000))
    w = s.window
    assert w["periodic"] is False
    spread = w["periodicity"]["spread"]
    assert spread["period"] == pytest.approx(0.1 / 1.05, rel=1e-3)
    assert spread["peak_area"] < 1e-5
    assert "peak_force" not in spread  # no contact recorded
    assert "cycles: the last 4 glottal cycles do not repeat: 9.5 % (period), < 0.01 % (peak glottal area); tolerance 5 %" \
        in s.text()
    assert any("the oscillation does not repeat, so f0, the per-cycle means" in n for n in s.notes)
    # within the tolerance: 4 % over the last 4 cycles (0.04 / 1.02 = 3.9 %) repeats
    lengths = [T] * 8 + [T * (1 + 0.04 * i / 3) for i in range(4)]
    w = an.summarize(_history(lengths, dt=T / 2000)).window
    assert w["periodic"] is True and w["periodicity"]["spread"]["period"] == pytest.approx(0.04 / 1.02, rel=1e-3)


def test_a_contact_force_that_alternates_is_not_periodic():
    """Period and peak area repeat exactly, the peak contact force alternates 1.0 / 1.1 mN: its
    spread, 0.1 / 1.05, fails the test; the same run without contact would pass it."""
    peaks = [1.0e-3, 1.1e-3] * 6
    w = an.summarize(_history([1.0 / F0] * 12, force_peaks=peaks)).window
    assert w["periodic"] is False
    assert w["periodicity"]["spread"]["peak_force"] == pytest.approx(0.1 / 1.05, rel=1e-9)
    assert w["periodicity"]["spread"]["period"] < 1e-9


def test_too_few_cycles_are_not_shown_to_repeat():
    """7 identical cycles: the window (second half) holds 3 full ones, 4 are needed: not
    periodic, said as such, and the note says the oscillation is not shown to repeat."""
    s = an.summarize(_history([1.0 / F0] * 7))
    assert s.window["periodic"] is False and s.window["periodicity"]["cycles_tested"] == 3
    assert "cycles: only 3 full glottal cycles in the window, 4 needed to tell whether they repeat" in s.text()
    assert any("is not shown to repeat (4 cycles needed)" in n for n in s.notes)


def test_spread_and_periodicity_helpers():
    assert an.relative_spread([1.0, 1.0]) == 0.0
    assert an.relative_spread([0.9, 1.1]) == pytest.approx(0.2)
    assert math.isnan(an.relative_spread([]))
    assert an.relative_spread([-1.0, 1.0]) == math.inf
    p = an.periodicity({"a": ("a", [5.0, 1.0, 1.0, 1.0, 1.02])}, last=4)
    assert p.periodic and p.spreads["a"][1] == pytest.approx(0.02 / 1.005)  # the first value is not compared
    assert not an.periodicity({"a": ("a", [1.0, 1.0, 1.0])}, last=4).periodic
    assert not an.periodicity({}, last=4).periodic
    back = an.Periodicity.from_dict(p.to_dict())
    assert back == p and back.text() == p.text()
