"""``vfrs.bandlimit``: what a sensor of limited bandwidth reads, and the stages of a closure.

A one-step peak of a contact force or pressure is an extreme: it is the largest of the
steps' values, and a contact that chatters from step to step, or a closure with two humps
of similar height, moves it as the time step or the mesh changes. A sensor has a bandwidth
(the pressure arrays of excised larynges are sampled at about 1 kHz, e.g. Scheible et al.
2023): what it reads converges as the step shrinks.

- :func:`band_limited`: the record as a sensor of bandwidth ``cutoff`` (Hz) reads it: a
  zero-phase 2nd-order Butterworth filter (gain 1 / (1 + (f / cutoff)^4): 1/2 at the cutoff)
  applied exactly to the piecewise-linear interpolant of the samples (any steps);
- :func:`band_limited_peak`: its largest value and when;
- :func:`closure_stages`: the contact events of a force record (runs of force > 0), each with
  its humps (:class:`Hump`: band-limited and one-step peak, times) and its impulse.

numpy only; tested against closed forms in ``tests/test_bandlimit.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .signals import contact_intervals, impulse_per_cycle

#: The bandwidth (Hz) of the band-limited readings unless said: the sampling rate of the
#: pressure arrays of excised larynges (about 1 kHz, e.g. Scheible et al. 2023).
CUTOFF = 1000.0

#: How much of the smaller of two neighbouring humps the dip between them must give back
#: for them to be two closure stages (:func:`closure_stages`): 20 %. Why: the flow-driven
#: first closure of the M5 folds is a zipper whose lower- and upper-margin humps are of
#: similar height (issue 45: 9.9 and 13.1 mN on the medium mesh); a dip of a fifth of the
#: smaller is a second stage by any reading, and a 1 kHz band-limit leaves the force's
#: step-to-step chatter (issue 45: a mean |second difference| of 6 % of the mean force on fine
#: meshes, at the steps' own frequency) far below it.
HUMP_DIP = 0.2


def _kernel(cutoff: float) -> tuple:
    """(K, lam): the zero-phase filter's impulse response is g(t) = K Re[(1 - i) exp(-lam |t|)]
    = K exp(-a |t|) (cos a t + sin a |t|), a = wc / sqrt 2, K = wc / (2 sqrt 2), wc = 2 pi
    ``cutoff``: the inverse Fourier transform of 1 / (1 + (w / wc)^4), with unit integral."""
    if not (cutoff > 0 and math.isfinite(cutoff)):
        raise ValueError(f"band_limited: cutoff = {cutoff!r} Hz; give a positive, finite bandwidth in Hz "
                         f"(the default is {CUTOFF:g} Hz)")
    wc = 2.0 * math.pi * float(cutoff)
    a = wc / math.sqrt(2.0)
    return wc / (2.0 * math.sqrt(2.0)), complex(a, -a)


def _one_sided(t, x, w_old, w_new, lam: complex, start: complex) -> np.ndarray:
    """c[k] = exp(-lam (t[k] - t[k-1])) c[k-1] + w_old[k-1] x[k-1] + w_new[k-1] x[k], c[0] =
    ``start``: the exact exponential integral of a piecewise-linear signal, step by step. As
    c[k] Q[k] = c[b] + sum of the steps' additions times Q, Q[k] = exp(lam (t[k] - t[b])),
    over blocks short enough (Re lam (t[k] - t[b]) <= 100) for Q to stay far from overflow:
    vectorized, for any steps."""
    n = len(x)
    out = np.empty(n, dtype=complex)
    out[0] = start
    u = w_old * x[:-1] + w_new * x[1:]  # u[k - 1]: what step k adds
    span = 100.0 / lam.real
    b = 0
    while b < n - 1:
        j = max(int(np.searchsorted(t, t[b] + span, side="right")) - 1, b + 1)  # the block's last sample
        q = np.exp(lam * (t[b + 1:j + 1] - t[b]))
        out[b + 1:j + 1] = (out[b] + np.cumsum(u[b:j] * q)) / q
        b = j
    return out


def band_limited(t, x, cutoff: float = CUTOFF) -> np.ndarray:
    """What a sensor of bandwidth ``cutoff`` (Hz) reads of the record ``x`` sampled at the
    times ``t`` (s; increasing, any steps), at those times, in the unit of ``x``.

    Definition: the convolution of the piecewise-linear interpolant of the samples (held at
    its first and last value before and after the record) with the impulse response of a
    zero-phase 2nd-order Butterworth filter, the forward-backward (filtfilt) pair of the
    analog filter wc^2 / (s^2 + sqrt 2 wc s + wc^2), wc = 2 pi ``cutoff``: gain
    |H(f)| = 1 / (1 + (f / cutoff)^4), 1 at f = 0 (a constant passes unchanged), **1/2 at the
    cutoff** (-6 dB), falling as (cutoff / f)^4 above it; no phase shift (a peak stays at its
    time). Impulse response g(t) = (wc / 2 sqrt 2) exp(-a |t|) (cos a t + sin a |t|),
    a = wc / sqrt 2: a spike of area A (a one-step spike of height H: A = H h) reads
    A wc / (2 sqrt 2) = A pi cutoff / sqrt 2 at its centre.

    The convolution is integrated exactly for the interpolant, step by step, whatever the
    steps (as two one-sided exponential integrals), so the reading converges with the step as the interpolant
    does: at second order for a smooth record. Not-finite samples are an error.

    >>> t = np.arange(0.0, 0.02, 1e-5)
    >>> y = band_limited(t, np.sin(2 * np.pi * 1000.0 * t))        # at the cutoff: half
    >>> round(float(np.abs(y[500:1500]).max()), 3)
    0.5
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if t.ndim != 1 or x.shape != t.shape:
        raise ValueError(f"band_limited: t and x must be 1-D of the same length, got shapes {t.shape} and "
                         f"{x.shape}; pass one component (e.g. F[:, 0]) of a vector record")
    if not np.all(np.isfinite(x)) or not np.all(np.isfinite(t)):
        raise ValueError("band_limited: the record holds a NaN or an infinite value; drop those samples first "
                         "(vfrs.signals.window)")
    if len(t) < 2:
        return x.copy()
    h = np.diff(t)
    if not np.all(h > 0):
        raise ValueError(f"band_limited: the times must increase (step {float(h.min()):g} s at index "
                         f"{int(np.argmin(h))}); sort the record or drop repeated times")
    K, lam = _kernel(cutoff)
    z = lam * h
    e = np.exp(-z)
    one = -np.expm1(-z)  # 1 - e
    w_far = (one - z * e) / z / lam  # weight of the sample at the far end of the step
    w_near = one / lam - w_far  # of the sample at the near end
    causal = _one_sided(t, x, w_far, w_near, lam, x[0] / lam)
    anti = _one_sided(-t[::-1], x[::-1], w_far[::-1], w_near[::-1], lam, x[-1] / lam)[::-1]
    return K * ((1.0 - 1.0j) * (causal + anti)).real


def band_limited_peak(t, x, cutoff: float = CUTOFF, start=None, end=None) -> tuple:
    """(largest value, its time, s) of :func:`band_limited` ``x`` over the window [``start``,
    ``end``] (the filter runs over the whole record, so the window's edges cut nothing off);
    the largest sample refined by the parabola through it and its neighbours (the reading is
    smooth: this keeps the peak converging with the step). (NaN, None) for an empty window."""
    t = np.asarray(t, dtype=float)
    y = band_limited(t, x, cutoff)
    keep = np.ones(len(t), dtype=bool)
    if start is not None:
        keep &= t >= start
    if end is not None:
        keep &= t <= end
    inside = np.flatnonzero(keep)
    if not inside.size:
        return float("nan"), None
    k = int(inside[np.argmax(y[inside])])
    return _vertex(t, y, k, inside[0], inside[-1])


def _vertex(t, y, k: int, lo: int, hi: int) -> tuple:
    """(value, time) of the parabola through samples k - 1, k, k + 1 at its vertex when k is
    inside [lo, hi] and the vertex between the neighbours; else the sample's."""
    if not lo < k < hi:
        return float(y[k]), float(t[k])
    t0, t1, t2 = t[k - 1] - t[k], 0.0, t[k + 1] - t[k]
    d0, d2 = (y[k - 1] - y[k]) / t0, (y[k + 1] - y[k]) / t2  # slopes of the chords from k
    c = (d2 - d0) / (t2 - t0)  # the parabola's curvature / 2
    if not c < 0:
        return float(y[k]), float(t[k])
    b = d0 - c * t0  # its slope at k
    s = -b / (2.0 * c)
    if not t0 <= s <= t2:
        return float(y[k]), float(t[k])
    return float(y[k] + b * s + c * s * s), float(t[k] + s + t1)


@dataclass(frozen=True)
class Hump:
    """One stage of a closure (:func:`closure_stages`): its band-limited peak ``peak`` (the
    unit of the force record) at ``t`` (s), and the largest one-step sample within its part of
    the event, ``peak_step`` at ``t_step``."""

    t: float
    peak: float
    t_step: float
    peak_step: float


@dataclass(frozen=True)
class ClosureEvent:
    """One contact event of a force record: from ``start`` (s, its first sample with force
    > 0) to ``end`` (s, the first sample after it without; one step after the last sample when
    the record ends in it), its ``impulse`` (the force's integral, each sample times the step
    after it: :func:`vfrs.signals.impulse_per_cycle`), its ``humps`` in time order, and whether
    it is ``complete`` (begins after the record's first sample and ends before its last: else
    its impulse and humps are those of a part)."""

    start: float
    end: float
    impulse: float
    humps: tuple
    complete: bool


def hump_peaks(y, dip: float = HUMP_DIP) -> list:
    """Indices of the humps of ``y`` (a band-limited record over one event): its local maxima,
    then, while two neighbours are separated by a dip that gives back less than ``dip`` of the
    smaller one's height (its lowest value between them above (1 - ``dip``) times the smaller
    peak), the smaller of the pair (of all pairs, the one with the shallowest relative dip
    first) is dropped.

    >>> hump_peaks(np.array([0.0, 5.0, 4.5, 9.0, 1.0, 6.0, 0.0]))   # 5 -> 4.5 gives back 10 %
    [3, 5]
    """
    y = np.asarray(y, dtype=float)
    n = len(y)
    if n == 0:
        return []
    left = np.concatenate([[True], y[1:] > y[:-1]])
    right = np.concatenate([y[:-1] >= y[1:], [True]])
    peaks = [int(k) for k in np.flatnonzero(left & right)]
    while len(peaks) > 1:
        depth = []
        for a, b in zip(peaks[:-1], peaks[1:]):
            low, top = float(y[a:b + 1].min()), min(float(y[a]), float(y[b]))
            depth.append((top - low) / top if top > 0 else 0.0)
        j = int(np.argmin(depth))
        if depth[j] >= dip:
            break
        del peaks[j + 1 if y[peaks[j + 1]] < y[peaks[j]] else j]
    return peaks


def closure_stages(t, force, cutoff: float = CUTOFF, dip: float = HUMP_DIP) -> list:
    """The contact events of a force record (``force``: (n,) or (n, 3), N or any unit; its
    magnitude is used; an event is a run of samples with force > 0), each as a
    :class:`ClosureEvent` with its humps: the local maxima of the :func:`band_limited` force
    (``cutoff``, Hz; the filter runs over the whole record) within the event that
    :func:`hump_peaks` keeps (a dip between two of them gives back at least ``dip``,
    :data:`HUMP_DIP`, of the smaller). Each hump's band-limited peak is refined by the parabola
    through its sample and their neighbours; its one-step peak is the largest sample between the
    lowest band-limited points that separate it from its neighbours (the event's ends outside)."""
    t = np.asarray(t, dtype=float)
    f = np.asarray(force, dtype=float)
    f = np.sqrt((f * f).sum(axis=1)) if f.ndim == 2 else np.abs(f)
    y = band_limited(t, f, cutoff)
    intervals = contact_intervals(t, f > 0)
    out = []
    for start, end in intervals:
        i0 = int(np.searchsorted(t, start))
        i1 = int(np.searchsorted(t, end)) if end <= t[-1] else len(t)  # one past the event's last sample
        peaks = [i0 + k for k in hump_peaks(y[i0:i1], dip)]
        cuts = [i0, *(a + int(np.argmin(y[a:b + 1])) for a, b in zip(peaks[:-1], peaks[1:])), i1]
        humps = []
        for k, lo, hi in zip(peaks, cuts[:-1], cuts[1:]):
            value, when = _vertex(t, y, k, i0, i1 - 1)
            s = lo + int(np.argmax(f[lo:max(hi, lo + 1)]))
            humps.append(Hump(when, value, float(t[s]), float(f[s])))
        impulse = float(impulse_per_cycle(t, f, [start, end])[0])
        out.append(ClosureEvent(float(start), float(end), impulse, tuple(humps), i0 > 0 and i1 < len(t)))
    return out
