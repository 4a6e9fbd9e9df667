"""``vfrs.signals``: cycles, peaks, contact intervals and periodicity of sampled signals.

Each function takes a time array ``t`` (s) and one sampled signal: :func:`cycle_starts`,
:func:`fundamental_frequency`, :func:`cycle_amplitudes`, :func:`open_quotients`,
:func:`max_flow_declination_rate`, :func:`contact_intervals`, :func:`contact_time_per_cycle`,
:func:`peak`, ...; :func:`periodicity` tests whether per-cycle values repeat. They know
nothing about vocal folds, runs or effects (numpy only) and are tested on signals with known
answers (``tests/test_analysis.py``); the summary (:mod:`vfrs.summary`) and the effects'
measures are built on them.

>>> import numpy as np
>>> t = np.arange(0.0, 0.05, 1e-5)
>>> area = np.maximum(np.sin(2 * np.pi * 150 * t), 0.0) * 1e-5         # opens half of each cycle
>>> round(fundamental_frequency(t, area), 3), round(float(np.mean(open_quotients(t, area, 0.0))), 2)
(150.0, 0.5)

Conventions (each a keyword argument):

- ``start``, ``end``: the window a function looks at (s); samples that are not finite are
  left out (:func:`window`).
- A **cycle** starts where the signal rises through its mean over the window (after dipping
  ``hysteresis`` standard deviations below it, so ripples make no extra cycles, and after
  falling back ``fall``, half, of the previous cycle's own opening, so a sub-pulse is no
  cycle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def window(t, x, start=None, end=None):
    """(t, x) as float arrays over the window [``start``, ``end``] (either None: open),
    without the samples whose ``x`` is not finite."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    keep = np.isfinite(x)
    if start is not None:
        keep &= t >= start
    if end is not None:
        keep &= t <= end
    return t[keep], x[keep]


#: What part of its opening a glottal cycle gives back before the next one can start
#: (:func:`cycle_starts`): half. Why: a cycle opens and closes; the coupled voice's area opens
#: to 5.8 mm^2 from 0.27, falls only to 3.8 (gives back 37 %) and opens again, one pulse with a
#: dip, while each of its 12 cycles gives back 99-101 % (examples/voice_results, docs/acoustics.md).
CYCLE_FALL = 0.5


def cycle_starts(t, x, start=None, end=None, hysteresis: float = 0.25, fall: float = CYCLE_FALL) -> np.ndarray:
    """Times (s) at which ``x`` rises through its mean over the window, linearly interpolated
    between samples; a crossing counts only after ``x`` has been below mean - ``hysteresis``
    standard deviations since the previous one (ripples about the mean make no extra cycles)
    and, after the first, has fallen ``fall`` (:data:`CYCLE_FALL`, half) of the way back from
    its highest value since the previous counted crossing to its lowest value before that
    crossing (the cycle's own range: a sub-pulse, a dip that gives back less than half of the
    opening, is not a new cycle). A clean oscillation falls the whole way: the rule drops none
    of its crossings. ``fall = 0`` leaves the hysteresis alone.

    >>> t = np.arange(0.0, 0.015, 1e-5)                       # 3 cycles at 200 Hz
    >>> (cycle_starts(t, np.sin(2 * np.pi * 200 * t - 1.0)) * 200 * 2 * np.pi).round(6).tolist()
    [1.0, 7.283185, 13.566371]
    >>> x = np.interp(t, [0, 1e-3, 3e-3, 4e-3, 5e-3, 7e-3, 8e-3, 9e-3, 13e-3, 14e-3],
    ...               [0, 10, 10, 6, 10, 10, 0, 10, 10, 0])   # opens, dips to 6 at 4 ms, closes at 8 ms
    >>> (cycle_starts(t, x) * 1e3).round(2).tolist(), (cycle_starts(t, x, fall=0.0) * 1e3).round(2).tolist()
    ([0.77, 8.77], [0.77, 4.43, 8.77])
    """
    t, x = window(t, x, start, end)
    if len(x) < 3:
        return np.zeros(0)
    m, s = float(x.mean()), float(x.std())
    if s == 0.0:
        return np.zeros(0)
    low = m - hysteresis * s
    # A rising crossing between samples i and i + 1 counts when a sample after the previous
    # rising crossing (counted or not: one not counted had no such sample before it), up to i,
    # is below ``low``; vectorized, the same numbers as the step-by-step loop.
    i = np.flatnonzero((x[:-1] < m) & (m <= x[1:]))
    if not i.size:
        return np.zeros(0)
    last_low = np.maximum.accumulate(np.where(x < low, np.arange(len(x)), -1))[i]
    i = _fell_back(x, i[last_low > np.concatenate([[-1], i[:-1]])], fall)
    return t[i] + (m - x[i]) * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def _fell_back(x, crossings, fall: float) -> np.ndarray:
    """The ``crossings`` (sample indices) of :func:`cycle_starts` before which ``x``, since the
    previous one kept, fell ``fall`` of the way from its running highest value back to the
    lowest value before that previous one; the first is kept."""
    if fall <= 0.0 or len(crossings) < 2:
        return crossings
    keep = [int(crossings[0])]
    trough = float(x[: keep[0] + 1].min())
    for j in crossings[1:]:
        seg = x[keep[-1] + 1: j + 1]
        top = np.maximum.accumulate(seg)
        if np.any(seg <= top - fall * (top - trough)):
            keep.append(int(j))
            trough = float(seg.min())
    return np.asarray(keep, dtype=int)


def fundamental_frequency(t, x, start=None, end=None, hysteresis: float = 0.25, fall: float = CYCLE_FALL) -> float:
    """Cycles per second of ``x`` (Hz): full cycles between the first and the last
    :func:`cycle_starts` over their time; NaN without one full cycle."""
    s = cycle_starts(t, x, start, end, hysteresis, fall)
    if len(s) < 2:
        return float("nan")
    return float((len(s) - 1) / (s[-1] - s[0]))


def cycle_amplitudes(t, x, start=None, end=None, hysteresis: float = 0.25, cycles=None) -> np.ndarray:
    """Half the peak-to-peak of ``x`` in each full cycle (same unit as ``x``). ``cycles``:
    cycle start times (default: :func:`cycle_starts` of ``x``)."""
    s = cycle_starts(t, x, start, end, hysteresis) if cycles is None else np.asarray(cycles, dtype=float)
    t, x = window(t, x, start, end)
    out = []
    for a, b in zip(s[:-1], s[1:]):
        seg = x[(t >= a) & (t <= b)]
        if seg.size:
            out.append(0.5 * float(seg.max() - seg.min()))
    return np.asarray(out)


def _time_above(t, x, level, a, b) -> float:
    """Time in [a, b] during which the linear interpolant of (t, x) exceeds ``level``."""
    inner = (t > a) & (t < b)
    ts = np.concatenate([[a], t[inner], [b]])
    xs = np.interp(ts, t, x)
    x0, x1, dt = xs[:-1] - level, xs[1:] - level, np.diff(ts)
    both = (x0 > 0) & (x1 > 0)
    total = float(dt[both].sum())
    cross = (x0 > 0) != (x1 > 0)
    if cross.any():
        frac = x0[cross] / (x0[cross] - x1[cross])  # where the segment crosses the level
        total += float(np.sum(np.where(x0[cross] > 0, frac, 1.0 - frac) * dt[cross]))
    return total


def open_quotients(t, area, level: float, start=None, end=None, cycles=None, hysteresis: float = 0.25) -> np.ndarray:
    """Per full cycle, the fraction of the cycle during which ``area`` exceeds ``level`` (the
    open quotient; 1 - it is the closed quotient), from the linear interpolant of the samples
    (exact for piecewise-linear signals). ``cycles``: cycle start times (default:
    :func:`cycle_starts` of ``area``)."""
    s = cycle_starts(t, area, start, end, hysteresis) if cycles is None else np.asarray(cycles, dtype=float)
    t, x = window(t, area, start, end)
    return np.asarray([_time_above(t, x, level, a, b) / (b - a) for a, b in zip(s[:-1], s[1:])])


def force_length(F):
    """|F| of a force (3,) or of each row of (n, 3), by the same operations in both cases (so
    the step of the largest length found per step and from the history are the same step)."""
    F = np.asarray(F, dtype=float)
    return np.sqrt(F[..., 0] * F[..., 0] + F[..., 1] * F[..., 1] + F[..., 2] * F[..., 2])


def peak(t, x, start=None, end=None) -> tuple:
    """(largest value, its time) of ``x`` over the window; for (n, 3) vectors, of their
    length. (NaN, None) for an empty window."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 2:
        x = np.linalg.norm(x, axis=1)
    t, x = window(t, x, start, end)
    if not len(x):
        return float("nan"), None
    k = int(np.argmax(x))
    return float(x[k]), float(t[k])


def max_flow_declination_rate(t, q, start=None, end=None, within=None) -> tuple:
    """(MFDR, its time): the largest rate of decrease of the flow ``q``, max(-dq/dt)
    (m^3/s^2 for q in m^3/s), by central differences (``np.gradient``) over the window;
    ``within`` (a, b): the largest at a sample in [a, b] only (e.g. whole glottal cycles,
    the rates still from the samples either side, so a rate at a is not one-sided)."""
    t, q = window(t, q, start, end)
    if len(q) < 3:
        return float("nan"), None
    d = -np.gradient(q, t)
    inside = np.ones(len(t), bool) if within is None else (t >= within[0]) & (t <= within[1])
    if not inside.any():
        return float("nan"), None
    k = int(np.flatnonzero(inside)[np.argmax(d[inside])])
    return float(d[k]), float(t[k])


def _step_weights(t) -> np.ndarray:
    """The time each sample stands for: the step after it (the last: the one before)."""
    dt = np.diff(t)
    return np.append(dt, dt[-1] if len(dt) else 0.0)


def contact_intervals(t, in_contact) -> np.ndarray:
    """(k, 2) array of [start, end) times of the runs of consecutive samples in contact: start
    at the first sample in contact, end at the first one after it that is not (or one step
    after the last sample). ``end - start`` is the number of steps in contact times the step."""
    t = np.asarray(t, dtype=float)
    c = np.asarray(in_contact, dtype=bool)
    if not c.any():
        return np.zeros((0, 2))
    w = _step_weights(t)
    edges = np.diff(np.concatenate([[0], c.astype(np.int8), [0]]))
    on, off = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    ends = np.where(off < len(t), t[np.minimum(off, len(t) - 1)], t[-1] + w[-1])
    return np.column_stack([t[on], ends])


def contact_time_per_cycle(t, in_contact, cycles) -> np.ndarray:
    """Time in contact (s) within each cycle [cycles[k], cycles[k+1]): the steps in contact
    that start in it, times their step."""
    t = np.asarray(t, dtype=float)
    c = np.asarray(in_contact, dtype=bool)
    w = _step_weights(t) * c
    s = np.asarray(cycles, dtype=float)
    return np.asarray([float(w[(t >= a) & (t < b)].sum()) for a, b in zip(s[:-1], s[1:])])


def impulse_per_cycle(t, force, cycles) -> np.ndarray:
    """The impulse (N s) of a recorded force within each cycle [cycles[k], cycles[k+1]): the
    sum of its magnitude (``force``: (n,) or (n, 3), one value per step: the step's impulse
    over its length) times the step, over the steps that start in it.

    >>> t = np.arange(0.0, 0.02, 1e-4)
    >>> f = np.where((t % 0.01) < 0.002, 0.5, 0.0)                # 0.5 N for 2 ms per 10 ms
    >>> impulse_per_cycle(t, f, [0.0, 0.01, 0.02]).round(6).tolist()
    [0.001, 0.001]
    """
    t = np.asarray(t, dtype=float)
    f = np.asarray(force, dtype=float)
    mag = np.linalg.norm(f, axis=1) if f.ndim == 2 else np.abs(f)
    w = _step_weights(t) * mag
    s = np.asarray(cycles, dtype=float)
    return np.asarray([float(w[(t >= a) & (t < b)].sum()) for a, b in zip(s[:-1], s[1:])])


def first_contact(t, in_contact) -> float | None:
    """The time of the first sample in contact (s), or None."""
    c = np.flatnonzero(np.asarray(in_contact, dtype=bool))
    return float(np.asarray(t)[c[0]]) if c.size else None


def cycle_peaks(t, x, cycles) -> np.ndarray:
    """The largest sample of ``x`` (for (n, 3) vectors, of their length) within each cycle
    [cycles[k], cycles[k+1]): the steps that start in it; 0 for a cycle with no sample.

    >>> t = np.arange(0.0, 0.03, 1e-4)
    >>> x = np.array([1.0, 2.0, 3.0])[np.minimum(t // 0.01, 2).astype(int)] * np.sin(2 * np.pi * 100 * t)
    >>> cycle_peaks(t, x, [0.0, 0.01, 0.02, 0.03]).round(6).tolist()      # each cycle's crest
    [1.0, 2.0, 3.0]
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if x.ndim == 2:
        x = force_length(x)
    k = np.searchsorted(t, np.asarray(cycles, dtype=float), side="left")  # t increases
    return np.asarray([float(x[a:b].max()) if b > a else 0.0 for a, b in zip(k[:-1], k[1:])])


def relative_spread(values) -> float:
    """How far the ``values`` spread about their mean: (max - min) / mean; 0 for equal values,
    infinite when they differ about a mean <= 0, NaN for none.

    >>> relative_spread([9.5, 10.0, 10.5])
    0.1
    """
    v = np.asarray(values, dtype=float)
    if not v.size:
        return float("nan")
    width, mean = float(np.ptp(v)), float(v.mean())
    if width == 0.0:
        return 0.0
    return width / mean if mean > 0 else float("inf")



# ------------------------------------------------------------------------------------------
# Periodicity: whether the window's last cycles repeat
# ------------------------------------------------------------------------------------------

#: The cycles of a periodic state repeat to this share of their mean, in every per-cycle value
#: the effects give (:meth:`vfrs.summary.RunView.periodicity`: the [flow] effect's period and peak glottal
#: area, the [contact] effect's peak contact force and contact impulse): (max - min) / mean over
#: the last cycles.
#: Why 5 %: a repeating cycle measured from the run's own samples meets it with room (the peak
#: of a sampled 150 Hz cycle at a 50 us step is off by at most (w h)^2 / 8 = 0.3 %; the forced,
#: damped block of tests/test_periodicity.py settles to spreads below 0.5 %); an amplitude that
#: still grows or decays by 2 % per cycle (6 % over 4 cycles) does not, nor do the main job's
#: folds (coarse mesh, 0.8 kPa, after 0.5 s: period 1 %, peak glottal area 23 %, peak contact
#: force 13 %); and it is the accuracy asked of the summary's numbers (issue 32: 10, 5 and 2 %).
PERIODIC_TOLERANCE = 0.05
#: How many of the window's last cycles the test compares (the scene's ``[output]
#: until_cycles``, which has this default).
PERIODIC_CYCLES = 4


def _percent(x: float) -> str:
    if not math.isfinite(x):
        return "n/a" if math.isnan(x) else "inf"
    pct = 100.0 * x
    if pct == 0:
        return "0 %"
    if pct < 0.01:
        return "< 0.01 %"
    return f"{pct:.2g} %" if pct < 10 else f"{pct:.0f} %"


@dataclass(frozen=True)
class Periodicity:
    """Whether the window's last ``needed`` cycles repeat: ``spreads`` (name -> (what, the
    :func:`relative_spread` of its per-cycle values over the ``tested`` last cycles)), each
    against ``tolerance``; ``periodic`` only with ``needed`` full cycles in the window and
    every spread within it. :meth:`text` says it in words; :meth:`to_dict` is what
    ``summary.json`` holds under ``window.periodicity``."""

    periodic: bool
    tested: int
    needed: int
    tolerance: float
    spreads: dict = field(default_factory=dict)

    def text(self) -> str:
        """``the last 4 glottal cycles repeat within 1.2 % (period), ...; tolerance 5 %``, or
        ``... do not repeat: ...``, or that there are too few cycles to tell."""
        parts = ", ".join(f"{_percent(s)} ({what})" for what, s in self.spreads.values())
        tol = f"tolerance {_percent(self.tolerance)}"
        n, k = self.tested, self.needed
        if n < 2:
            return (f"{'no' if n == 0 else 'one'} full glottal cycle in the window, {k} needed to tell whether the "
                    f"cycles repeat: no periodic state")
        if n < k and not self.within:
            return f"only {n} full glottal cycles in the window ({k} needed), and they do not repeat: {parts}; {tol}"
        if n < k:
            return (f"only {n} full glottal cycles in the window, {k} needed to tell whether they repeat"
                    + (f" (over these: {parts}; {tol})" if parts else ""))
        if self.periodic:
            return f"the last {n} glottal cycles repeat within {parts}; {tol}"
        return f"the last {n} glottal cycles do not repeat: {parts}; {tol}"

    @property
    def within(self) -> bool:
        """Every spread is within the tolerance (over the cycles there are, however few)."""
        return all(s <= self.tolerance for _, s in self.spreads.values())

    def to_dict(self) -> dict:
        return {"periodic": bool(self.periodic), "cycles_tested": int(self.tested), "cycles_needed": int(self.needed),
                "tolerance": float(self.tolerance),
                "spread": {k: json_number(s) for k, (_, s) in self.spreads.items()},
                "what": {k: what for k, (what, _) in self.spreads.items()}}

    @classmethod
    def from_dict(cls, d: dict) -> "Periodicity":
        what = d.get("what", {})
        spreads = {k: (what.get(k, k), float("nan") if v is None else float(v)) for k, v in d.get("spread", {}).items()}
        return cls(bool(d["periodic"]), int(d["cycles_tested"]), int(d["cycles_needed"]), float(d["tolerance"]),
                   spreads)


def periodicity(series: dict, last: int = PERIODIC_CYCLES, tolerance: float = PERIODIC_TOLERANCE) -> Periodicity:
    """The periodicity test of per-cycle values: ``series`` maps a name to (what it is, its
    value in each of the window's full cycles, oldest first); each is compared over its
    ``last`` values (:func:`relative_spread`), against ``tolerance``. Periodic when the longest
    series has ``last`` values and every spread is within the tolerance.

    >>> periodicity({"period": ("period", [5e-3, 5.05e-3, 5e-3, 5.05e-3, 5e-3])}).text()
    'the last 4 glottal cycles repeat within 1 % (period); tolerance 5 %'
    """
    n = max((len(v) for _, v in series.values()), default=0)
    spreads = {name: (what, relative_spread(np.asarray(v, dtype=float)[-last:]))
               for name, (what, v) in series.items() if len(v)}
    ok = n >= last and bool(spreads) and all(s <= tolerance for _, s in spreads.values())
    return Periodicity(ok, min(n, last), int(last), float(tolerance), spreads)

def json_number(v):
    """``v`` as a float for JSON, None when it is not finite (NaN, infinite)."""
    v = float(v)
    return v if math.isfinite(v) else None
