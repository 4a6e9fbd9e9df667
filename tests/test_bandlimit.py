"""vfrs.bandlimit against closed forms (issue 45, item 2): the zero-phase 2nd-order
Butterworth reading of a record (gain 1 / (1 + (f / fc)^4)) passes a slow sinusoid, cuts a
fast one as that gain says, reads a one-step spike as its impulse response says, keeps a
slow half-sine pulse's peak, reads the same on non-uniform steps, and its peak converges at
second order in the step; the closure stages find two humps of known heights and times, and
one."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from vfrs.bandlimit import CUTOFF, HUMP_DIP, band_limited, band_limited_peak, closure_stages, hump_peaks


def gain(f, fc=CUTOFF):
    return 1.0 / (1.0 + (f / fc) ** 4)


def kernel(s, fc=CUTOFF):
    """The filter's impulse response written out: the inverse Fourier transform of gain()."""
    wc = 2 * math.pi * fc
    a = wc / math.sqrt(2)
    return wc / (2 * math.sqrt(2)) * math.exp(-a * abs(s)) * (math.cos(a * s) + math.sin(a * abs(s)))


def fit(t, y, f, a, b):
    """(sine, cosine) amplitudes of y over [a, b] at frequency f, by least squares."""
    keep = (t >= a) & (t <= b)
    w = 2 * np.pi * f * t[keep]
    return np.linalg.lstsq(np.column_stack([np.sin(w), np.cos(w)]), y[keep], rcond=None)[0]


@pytest.mark.parametrize("f", [100.0, 300.0, 1000.0])
def test_a_sinusoid_at_or_below_the_cutoff_passes_with_the_filters_gain(f):
    """sin(2 pi f t) sampled at 10 us reads gain(f) sinc^2(f h) sin(2 pi f t) away from the
    record's ends (sinc^2: the fundamental of the samples' piecewise-linear interpolant):
    0.99990 at 100 Hz, 0.99194 at 300 Hz, 1/2 at the cutoff; to 1e-6, in phase (the cosine's
    share below 1e-6: no delay)."""
    h = 1e-5
    t = np.arange(0.0, 0.04, h)
    y = band_limited(t, np.sin(2 * np.pi * f * t))
    s, c = fit(t, y, f, 0.01, 0.03)
    assert s == pytest.approx(gain(f) * np.sinc(f * h) ** 2, abs=1e-6) and abs(c) < 1e-6


def test_a_sinusoid_well_above_the_cutoff_is_cut_as_the_gain_says():
    """5 kHz at 1 kHz: gain 1/626 = 1.6e-3 (times sinc^2(f h) = 0.9987 at 2.5 us); to 1e-3 of
    it."""
    f, h = 5000.0, 2.5e-6
    t = np.arange(0.0, 0.02, h)
    y = band_limited(t, np.sin(2 * np.pi * f * t))
    s, c = fit(t, y, f, 0.005, 0.015)
    assert s == pytest.approx(gain(f) * np.sinc(f * h) ** 2, rel=1e-3) and abs(c) < 1e-6
    assert s < 2e-3


@pytest.mark.parametrize("h", [1e-5, 25e-6])
def test_a_one_step_spike_reads_its_area_times_the_impulse_response(h):
    """A one-step spike of height H (the samples either side 0: a triangle of area H h) reads
    H h g(0) = H h pi fc / sqrt 2 at its centre: 0.022 H at 10 us, 0.056 H at 25 us (within
    (wc h)^2: g is flat at 0); far less than H."""
    t = np.arange(0.0, 0.02, h)
    x = np.zeros_like(t)
    k = len(t) // 2
    x[k] = 7.0
    y = band_limited(t, x)
    expected = 7.0 * h * math.pi * CUTOFF / math.sqrt(2)
    assert y[k] == pytest.approx(expected, rel=(2 * math.pi * CUTOFF * h) ** 2)
    assert y.max() == y[k] < 0.06 * 7.0
    assert np.sum(y) * h == pytest.approx(7.0 * h, rel=1e-9)  # the filter keeps the area


@pytest.mark.parametrize("T, rel", [(10e-3, 1e-4), (3e-3, 1e-3), (1e-3, 0.15)])
def test_a_half_sine_pulse_keeps_its_peak_as_the_convolution_says(T, rel):
    """A half-sine pulse of duration T reads, at its centre, the integral of the filter's
    impulse response against it (by quadrature, independently); for T >> 1/fc that is its
    height: within 1e-4 at T = 10 ms, 1e-3 at 3 ms; at T = 1 ms it is 0.89 (the pulse is no
    longer slow). The reading at h = 5 us matches the quadrature to 3e-5 (measured 2.1e-5 at
    1 ms: the interpolant's second-order error, as in the convergence test below)."""
    h, t0 = 5e-6, 5e-3
    t = np.arange(0.0, 2 * t0 + T, h)
    x = np.where((t > t0) & (t < t0 + T), np.sin(np.pi * (t - t0) / T), 0.0)
    peak, when = band_limited_peak(t, x)
    exact = quad(lambda s: kernel(s) * math.cos(math.pi * s / T), -T / 2, T / 2, limit=200)[0]
    assert peak == pytest.approx(exact, rel=3e-5)
    assert when == pytest.approx(t0 + T / 2, abs=h / 10)
    assert peak == pytest.approx(1.0, rel=rel)


def test_the_band_limited_peak_converges_in_the_step_at_second_order():
    """A 1 ms half-sine pulse (kinks at its ends) sampled at h = 20, 10, 5 us: the
    band-limited peaks differ by 2.2e-4 then 5.5e-5 (observed order 2.00). A contact chatter,
    +-10 % alternating from step to step, raises the one-step peak by 10 %; the band-limited
    peak moves by 2e-7 (measured at 5 us; the chatter sits at the sampling's Nyquist
    frequency)."""
    peaks = []
    for h in (20e-6, 10e-6, 5e-6):
        t = np.arange(0.0, 0.012 + h / 2, h)
        x = np.where((t > 5e-3) & (t < 6e-3), np.sin(np.pi * (t - 5e-3) / 1e-3), 0.0)
        peaks.append(band_limited_peak(t, x)[0])
    d1, d2 = abs(peaks[0] - peaks[1]), abs(peaks[1] - peaks[2])
    assert d1 < 1e-3 and math.log2(d1 / d2) == pytest.approx(2.0, abs=0.3)
    chatter = x * (1 + 0.1 * (-1.0) ** np.arange(len(x)))
    assert band_limited_peak(t, chatter)[0] == pytest.approx(peaks[2], rel=1e-6)
    assert chatter.max() > 1.09


def test_non_uniform_steps_read_the_same():
    """Random steps (0-20 us) read a 200 Hz sine as gain(200) of it, to the interpolant's error
    ((2 pi f h)^2 / 8 = 3e-4 at the largest step)."""
    rng = np.random.default_rng(1)
    t = np.sort(np.concatenate([[0.0, 0.03], rng.uniform(0.0, 0.03, 3000)]))
    y = band_limited(t, np.sin(2 * np.pi * 200 * t))
    keep = (t > 0.008) & (t < 0.022)
    assert np.abs(y[keep] - gain(200.0) * np.sin(2 * np.pi * 200 * t[keep])).max() < 3e-4


def test_bad_records_say_what_to_fix():
    t = np.arange(5) * 1e-5
    with pytest.raises(ValueError, match="NaN"):
        band_limited(t, [0.0, np.nan, 1.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="increase"):
        band_limited(t[::-1], np.ones(5))
    with pytest.raises(ValueError, match="positive, finite bandwidth"):
        band_limited(t, np.ones(5), cutoff=0.0)


# ------------------------------------------------------------------------------------------
# Closure stages
# ------------------------------------------------------------------------------------------

H = 1e-5


def raised_cosine(t, c, w, A):
    u = (t - c) / w
    return np.where(np.abs(u) < 0.5, A * np.cos(np.pi * u) ** 2, 0.0)


def band_reading(f_of_t, at, a, b):
    """The band-limited reading at ``at`` of a record f(t) on [a, b], by quadrature."""
    return quad(lambda s: kernel(at - s) * f_of_t(s), a, b, limit=400, points=[at])[0]


def test_two_humps_of_known_heights_and_times():
    """A closure with two stages: raised-cosine humps of 9 and 13 mN at 2 and 5 ms (3 ms wide)
    on a 1 mN floor from 0.5 to 6.5 ms, then a second contact of 4 mN at 9 ms. Two events; the
    first has two humps, their one-step peaks 10 and 14 mN at 2 and 5 ms exactly, their
    band-limited peaks those of the convolution by quadrature (to 1e-4), 0.56 and 0.57 % below
    the heights (within 0.6 %), at the humps' times (measured within 0.26 us); the impulse is 9 x 1.5 + 13 x 1.5 + 1 x 6
    = 39 uN s."""
    t = np.arange(0.0, 0.012 + H / 2, H)
    floor = ((t > 0.5e-3 - H / 2) & (t < 6.5e-3 - H / 2)) * 1e-3
    f = raised_cosine(t, 2e-3, 3e-3, 9e-3) + raised_cosine(t, 5e-3, 3e-3, 13e-3) + floor + raised_cosine(
        t, 9e-3, 1.5e-3, 4e-3)
    events = closure_stages(t, f)
    assert len(events) == 2 and all(e.complete for e in events)
    first = events[0]
    assert first.start == pytest.approx(0.5e-3) and first.end == pytest.approx(6.5e-3)
    assert first.impulse == pytest.approx(39e-6, rel=1e-9)
    assert len(first.humps) == 2
    for hump, c, top in zip(first.humps, (2e-3, 5e-3), (10e-3, 14e-3)):
        assert hump.t_step == pytest.approx(c) and hump.peak_step == pytest.approx(top, rel=1e-12)
        exact = band_reading(lambda s: float(np.interp(s, t, f)), hump.t, 0.0, 0.012)
        assert hump.peak == pytest.approx(exact, rel=1e-4)
        assert hump.peak == pytest.approx(top, rel=6e-3) and hump.t == pytest.approx(c, abs=1e-6)
    assert len(events[1].humps) == 1 and events[1].humps[0].peak_step == pytest.approx(4e-3, rel=1e-12)


def test_one_hump_and_a_shallow_dip_make_one_stage():
    """One raised-cosine hump is one stage; two humps whose dip gives back 10 % of the smaller
    (less than HUMP_DIP, 20 %) are one too, its one-step peak the larger's; at 30 % they are
    two."""
    t = np.arange(0.0, 0.012 + H / 2, H)
    one = closure_stages(t, raised_cosine(t, 4e-3, 4e-3, 5e-3))
    assert len(one) == 1 and len(one[0].humps) == 1
    assert one[0].humps[0].peak_step == pytest.approx(5e-3) and one[0].humps[0].t == pytest.approx(4e-3, abs=H)
    assert one[0].impulse == pytest.approx(5e-3 * 2e-3, rel=1e-9)
    assert HUMP_DIP == 0.2
    for give_back, n in ((0.10, 1), (0.30, 2)):
        # two plateaus (10 and 12 mN) joined by a dip to (1 - give_back) x 10 mN, smooth enough
        # (1 ms ramps) that the band-limited dip is the record's to a fraction of a per cent
        knots = np.array([0.5, 1.5, 3.0, 4.0, 5.0, 6.5, 7.5]) * 1e-3
        vals = np.array([0.0, 10.0, 10.0, 10.0 * (1 - give_back), 12.0, 12.0, 0.0]) * 1e-3
        f = np.interp(t, knots, vals)
        ev = closure_stages(t, f)
        assert len(ev) == 1 and len(ev[0].humps) == n, (give_back, ev[0].humps)
        assert max(hm.peak_step for hm in ev[0].humps) == pytest.approx(12e-3)


def test_hump_peaks_drops_the_smaller_of_a_shallow_pair_first():
    assert hump_peaks([0.0, 5.0, 4.5, 9.0, 1.0, 6.0, 0.0]) == [3, 5]
    assert hump_peaks([0.0, 5.0, 3.0, 9.0, 1.0, 6.0, 0.0]) == [1, 3, 5]  # 5 -> 3: gives back 40 %
    assert hump_peaks([]) == [] and hump_peaks([1.0]) == [0]
