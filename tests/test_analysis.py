"""vfrs.signals (and the summary of synthetic histories, vfrs.summary) on signals with known answers: sines, clipped sines (a glottis closed for a
known part of the cycle), a triangular flow pulse, contact indicators, and run-level summaries
of synthetic histories."""

import doctest
import json
import math

import numpy as np
import pytest

from vfrs import signals
from vfrs import summary

F0, DT = 137.0, 1e-5
T = np.arange(0.0, 0.1, DT)
W = 2 * np.pi * F0


def test_docstring_examples_run():
    result = doctest.testmod(signals)
    assert result.failed == 0 and result.attempted > 0


def test_sine_frequency_and_amplitude():
    x = 0.2e-3 * np.sin(W * T + 0.4) + 1e-3
    # Crossings are interpolated linearly: each is off by O(dt^2 x''/x'), small where a sine
    # crosses its mean (measured 5e-9 relative); the bound below leaves a margin of 20.
    assert signals.fundamental_frequency(T, x) == pytest.approx(F0, rel=1e-7)
    amp = signals.cycle_amplitudes(T, x)
    assert len(amp) == 12  # 13.7 cycles in 0.1 s: 12 full ones between upward crossings
    np.testing.assert_allclose(amp, 0.2e-3, rtol=(W * DT) ** 2)  # sampling misses the crest by O((w dt)^2)
    # The crossings are the sine's upward zero crossings (it is sampled over whole and part
    # cycles, so its mean is not exactly 1e-3: all shift alike and the period is exact).
    s = signals.cycle_starts(T, x)
    np.testing.assert_allclose(np.diff(s), 1 / F0, rtol=1e-7)


def test_window_drops_the_onset():
    # 30 Hz for the first 50 ms, then 137 Hz: the window sees only the second.
    x = np.where(T < 0.05, np.sin(2 * np.pi * 30 * T), np.sin(W * T))
    assert signals.fundamental_frequency(T, x, start=0.05) == pytest.approx(F0, rel=1e-7)


def test_hysteresis_ignores_ripple_about_the_mean():
    # A ripple steeper than the sine where it crosses its mean, against it, makes three mean
    # crossings per cycle (two upward); the hysteresis (a dip of 0.25 std below the mean
    # re-arms a cycle) counts each cycle once. (The ripple shifts every crossing alike;
    # sampling leaves 3e-6.)
    x = np.sin(W * T) + 0.08 * np.sin(20 * W * T + np.pi)
    assert signals.fundamental_frequency(T, x) == pytest.approx(F0, rel=1e-5)
    assert signals.fundamental_frequency(T, x, hysteresis=0.0, fall=0.0) == pytest.approx(2 * F0, rel=1e-3)
    # The fall rule alone (no hysteresis) also counts each cycle once after the first crossing:
    # a ripple's dip gives back ~5 % of an opening, a cycle 100 % (the window's first crossing,
    # with no opening before it to compare, is the ripple's at t = 0).
    s = signals.cycle_starts(T, x, hysteresis=0.0)
    np.testing.assert_array_equal(s[1:], signals.cycle_starts(T, x))


def _oq_exact(c):
    """Fraction of a cycle in which sin(theta) > c."""
    return (math.pi - 2 * math.asin(c)) / (2 * math.pi)


@pytest.mark.parametrize("c", [0.0, 0.3, -0.4])
def test_clipped_sine_open_quotient(c):
    """A glottal area max(0, sin(wt) - c): open for (pi - 2 asin c) / 2 pi of each cycle."""
    area = np.maximum(np.sin(W * T) - c, 0.0)
    oq = signals.open_quotients(T, area, 0.0)
    assert len(oq) >= 12
    # The interpolant of a clipped signal is positive over the whole sampling interval in
    # which the opening starts: at most one step too much per edge.
    np.testing.assert_allclose(oq, _oq_exact(c), rtol=0, atol=2 * DT * F0)
    # Above the kink the signal is smooth: a level in the open part is met to O((w dt)^2)
    # (measured 1.4e-6 at most).
    oq = signals.open_quotients(T, area, 0.2 * (1 - c))
    np.testing.assert_allclose(oq, _oq_exact(c + 0.2 * (1 - c)), rtol=0, atol=(W * DT) ** 2)


def test_triangular_flow_pulse_mfdr_and_peak():
    """A flow pulse rising linearly over 3 ms and falling over 1 ms, then 2.5 ms closed:
    MFDR = peak / 1 ms exactly (central differences are exact on straight pieces)."""
    period, rise, fall, q_peak = 6.5e-3, 3e-3, 1e-3, 400e-6
    ph = np.mod(T, period)
    q = np.where(ph < rise, q_peak * ph / rise, np.where(ph < rise + fall, q_peak * (rise + fall - ph) / fall, 0.0))
    mfdr, when = signals.max_flow_declination_rate(T, q)
    assert mfdr == pytest.approx(q_peak / fall, rel=1e-9)
    assert rise < np.mod(when, period) < rise + fall
    val, when = signals.peak(T, q)
    assert val == pytest.approx(q_peak, rel=1e-9) and np.mod(when, period) == pytest.approx(rise, abs=DT)
    assert signals.fundamental_frequency(T, q) == pytest.approx(1 / period, rel=1e-9)


def test_sine_flow_mfdr():
    q = 300e-6 + 100e-6 * np.sin(W * T)
    mfdr, _ = signals.max_flow_declination_rate(T, q)
    assert mfdr == pytest.approx(100e-6 * W, rel=(W * DT) ** 2)  # central differences: sin(w dt) / (w dt)


def test_contact_intervals_and_first_contact():
    t = np.arange(10) * 0.5
    c = np.array([0, 0, 1, 1, 1, 0, 0, 1, 0, 1], dtype=bool)
    np.testing.assert_array_equal(signals.contact_intervals(t, c), [[1.0, 2.5], [3.5, 4.0], [4.5, 5.0]])
    assert signals.first_contact(t, c) == 1.0
    assert signals.first_contact(t, np.zeros(10, bool)) is None
    assert signals.contact_intervals(t, np.zeros(10, bool)).shape == (0, 2)


@pytest.mark.parametrize("c", [0.0, 0.5])
def test_contact_time_per_cycle_of_a_clipped_sine(c):
    """In contact while sin(wt) < -c: (pi - 2 asin c) / (2 pi w) per cycle, to one step."""
    cycles = signals.cycle_starts(T, np.sin(W * T))
    per = signals.contact_time_per_cycle(T, np.sin(W * T) < -c, cycles)
    assert len(per) == len(cycles) - 1 >= 12
    np.testing.assert_allclose(per, _oq_exact(c) / F0, rtol=0, atol=DT)


def _synthetic_run(c=0.3, level=0.1):
    """A history as the flow and contact effects record it: area A_min + A0 max(0, sin - c)
    (in contact while the area is at its minimum, from 10 ms on), flow area * sqrt(2 Ps / rho), a contact
    force pulse on each body and a pressure history."""
    a_min, a0 = 0.2e-6, 10e-6
    s = np.sin(W * T)
    area = a_min + a0 * np.maximum(s - c, 0.0)
    q = area * math.sqrt(2 * 800.0 / 1.2)
    closed = s <= c
    fx = np.where(closed & (T >= 0.01), 1e-3 * (c - s), 0.0)  # N, peaks where sin = -1: 1e-3 (1 + c)
    p_max = fx / 2e-6
    h = {
        "t": T, "glottal_area": area, "flow_rate": q, "active_pairs": (closed & (T >= 0.01)) * 7.0,
        "contact_force.right": np.column_stack([fx, 0 * fx, 0 * fx]),
        "contact_force.left": np.column_stack([-fx, 0 * fx, 0 * fx]),
        "contact_pressure_max": p_max, "contact_pressure_mean": 0.5 * p_max,
        "contact_pressure_max_node": np.where(fx > 0, 12.0, -1.0),
        "contact_pressure_max_position": np.tile([1e-4, -2e-3, 7e-3], (len(T), 1)),
        "contact_area": (fx > 0) * 3e-5, "intersection_volume": 0 * T, "max_penetration": 0 * T,
        "contact_area.right": (fx > 0) * 1.5e-5, "contact_area.left": (fx > 0) * 1.5e-5,
    }
    return h, a_min, a0


def test_phonation_and_contact_of_a_synthetic_history():
    c, level = 0.3, 0.1
    h, a_min, a0 = _synthetic_run(c, level)
    ph = summary.phonation(h)
    assert ph["f0"].value == pytest.approx(F0, rel=1e-6) and ph["f0"].unit == "Hz"
    # open: area above A_min + 0.1 of its range, i.e. sin > c + 0.1 (1 - c)
    assert ph["open_quotient"].value == pytest.approx(_oq_exact(c + level * (1 - c)), abs=(W * DT) ** 2)
    assert ph["closed_quotient"].value == pytest.approx(1 - ph["open_quotient"].value, abs=1e-15)
    # sampled crests: off by at most a0 (1 - cos(w dt / 2)) < a0 (w dt)^2 / 8
    assert ph["max_glottal_area"].value == pytest.approx(a_min + a0 * (1 - c), rel=(W * DT) ** 2)
    assert ph["min_glottal_area"].value == pytest.approx(a_min, rel=1e-12)
    k = math.sqrt(2 * 800.0 / 1.2)
    assert ph["peak_flow"].value == pytest.approx(k * (a_min + a0 * (1 - c)), rel=(W * DT) ** 2)
    # the steepest fall of k a0 sin(wt) above the clipping: where sin = c on the way down;
    # the steepest sampled central difference lies within two steps of that kink, where the
    # slope is lower by at most 2 w dt tan(asin c) (0.54 %; measured 0.29 %)
    tan = c / math.sqrt(1 - c**2)
    assert ph["mfdr"].value == pytest.approx(k * a0 * W * math.sqrt(1 - c**2), rel=2 * W * DT * tan)
    assert "amplitude" not in ph  # a history has no probes

    co = summary.contact(h)
    # at 10 ms the phase is 2 pi + 2.32 (open); contact starts where sin falls to c after it
    assert co["first_contact"].value == pytest.approx((3 * math.pi - math.asin(c)) / W, abs=DT)
    assert co["contact_duration"].value == pytest.approx((1 - _oq_exact(c)) / F0, abs=DT)
    assert co["contact_quotient"].value == pytest.approx(1 - _oq_exact(c), abs=DT * F0)
    for b in ("right", "left"):
        assert co[f"peak_force.{b}"].value == pytest.approx(1e-3 * (1 + c), rel=(W * DT) ** 2)
        assert co[f"peak_force.{b}"].unit == "N"
    p = co["peak_contact_pressure"]
    assert p.value == pytest.approx(1e-3 * (1 + c) / 2e-6, rel=(W * DT) ** 2) and p.unit == "Pa"
    assert p.position == (1e-4, -2e-3, 7e-3) and p.body is None  # bodies unknown from a bare history
    assert co["mean_contact_pressure"].value == pytest.approx(0.5 * p.value, rel=1e-12)
    assert co["max_contact_area"].value == 1.5e-5 and co["max_contact_area"].body == "right"  # one fold's patch
    assert co["max_contact_area_summed"].value == 3e-5  # both folds' (the paper's)


def test_summary_text_and_json_round_trip(tmp_path):
    h, _, _ = _synthetic_run()
    s = summary.summarize(h)
    assert set(s.sections) == {"phonation", "contact"}
    text = s.text()
    assert "137 Hz" in text and "kPa" in text and "mL/s" in text
    s.save(tmp_path / "summary.json")
    d = json.loads((tmp_path / "summary.json").read_text())
    assert d["phonation"]["f0"]["unit"] == "Hz" and d["window"]["cycles"] >= 6
    back = summary.Summary.load(tmp_path / "summary.json")
    assert back.text() == text


def test_a_run_without_flow_or_contact_has_no_sections():
    s = summary.summarize({"t": T})
    assert s.sections == {} and "nothing to summarise" in s.text()


def test_notes_say_what_does_not_converge():
    """The summary says in words when its window's glottal cycles do not repeat (lengths
    spread by more than 10 % of their mean, or fewer than three), and that the peak nodal
    pressure is one node's; a periodic signal gets no cycle note."""
    h, _, _ = _synthetic_run()
    s = summary.summarize(h)
    assert not any("glottal cycle" in n for n in s.notes)
    assert any("peak nodal contact pressure is one node's" in n for n in s.notes)
    # cycles of 6 and 8 ms alternating; a cycle starts where the area rises through its mean,
    # a quarter into each: 3/4 of one plus 1/4 of the next, 6.5 and 7.5 ms (a 14 % spread)
    edges = np.cumsum([0.0] + [6e-3, 8e-3] * 6)
    tt = np.arange(0.0, edges[-1], 1e-5)
    k = np.searchsorted(edges, tt, side="right") - 1
    phase = (tt - edges[k]) / np.diff(edges)[k]
    irregular = {"t": tt, "glottal_area": 1e-6 * (1.0 - np.cos(2 * np.pi * phase)), "flow_rate": 0 * tt}
    s = summary.summarize(irregular)
    note = [n for n in s.notes if "glottal cycle" in n]
    assert len(note) == 1 and "6.50-7.50 ms" in note[0], s.notes
    assert "note: the" in s.text()
    back = summary.Summary.from_dict(json.loads(json.dumps(s.to_dict())))
    assert back.notes == s.notes


def test_extremes_are_taken_over_whole_cycles_not_a_cut_closing():
    """The last part cycle of the window (after its last cycle start) opens twice as wide and
    closes twice as fast, cut off by the window's end mid-closure: the summary's MFDR, peak flow
    and largest area are the whole cycles' (the regular clipped sine's, as in the test above),
    at times between the first and the last cycle start; over the window they were twice
    that, at the cut closing."""
    c = 0.3
    h, a_min, a0 = _synthetic_run(c)
    last = 13 / F0  # the clipped sine's area is a_min here: the switch is continuous
    scale = np.where(T >= last, 2.0, 1.0)
    k = math.sqrt(2 * 800.0 / 1.2)
    h["glottal_area"] = a_min + a0 * scale * np.maximum(np.sin(W * T) - c, 0.0)
    h["flow_rate"] = k * h["glottal_area"]
    cycles = signals.cycle_starts(T, h["glottal_area"], summary.default_start(T))
    assert last < cycles[-1] < T[-1]  # the last cycle start is in the wide part cycle
    old, _ = signals.max_flow_declination_rate(T, h["flow_rate"], summary.default_start(T))
    ph = summary.phonation(h)
    regular = k * a0 * W * math.sqrt(1 - c**2)
    assert old == pytest.approx(2 * regular, rel=0.01)  # the window's: the cut closing
    assert ph["mfdr"].value == pytest.approx(regular, rel=2 * W * DT * c / math.sqrt(1 - c**2))
    assert ph["peak_flow"].value == pytest.approx(k * (a_min + a0 * (1 - c)), rel=(W * DT) ** 2)
    assert ph["max_glottal_area"].value == pytest.approx(a_min + a0 * (1 - c), rel=(W * DT) ** 2)
    for key in ("mfdr", "peak_flow", "max_glottal_area", "min_glottal_area"):
        assert cycles[0] <= ph[key].t <= cycles[-1], key
    assert not any("bound" in n for n in summary.summarize(h).notes)


def test_mfdr_within_whole_cycles_uses_central_differences():
    """``within`` picks the largest rate among the samples in [a, b], each still a central
    difference of its neighbours (the window's last sample, one-sided, is out)."""
    q = np.cos(W * T) * (1.0 + 10.0 * T)  # grows: the window's steepest fall is at its end
    whole, when = signals.max_flow_declination_rate(T, q, within=(0.0, 13 / F0))
    everything, at = signals.max_flow_declination_rate(T, q)
    assert at > 13 / F0 and everything > whole
    d = -np.gradient(q, T)
    inside = T <= 13 / F0
    assert whole == d[inside].max() and when == T[inside][np.argmax(d[inside])]


def test_an_extreme_at_the_window_s_edge_without_whole_cycles_is_called_a_bound():
    """Under two cycle starts in the window the extremes are the window's: the MFDR of a closing
    cut off by the run's end, at its last sample, is said to be a bound."""
    t = np.arange(0.0, 0.012, 1e-5)
    area = 1e-6 * (1.0 + np.sin(2 * np.pi * 40 * t))  # the window 6-12 ms: a quarter cycle, falling ever faster
    s = summary.summarize({"t": t, "glottal_area": area, "flow_rate": 0.5 * area})
    assert s["phonation"]["mfdr"].t == pytest.approx(t[-1])
    note = [n for n in s.notes if "bound" in n]
    assert len(note) == 1 and "maximum flow declination rate" in note[0], s.notes
    assert "minimum glottal area" in note[0] and "maximum glottal area" not in note[0]  # its crest is at 6.25 ms
