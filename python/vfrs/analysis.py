"""``vfrs.analysis``: what a run measured, as numbers with units.

Two levels, both public:

- **Signals** (a time array ``t`` in s and one sampled signal): :func:`cycle_starts`,
  :func:`fundamental_frequency`, :func:`cycle_amplitudes`, :func:`open_quotients`,
  :func:`max_flow_declination_rate`, :func:`contact_intervals`, :func:`contact_time_per_cycle`,
  :func:`peak`. They know nothing about vocal folds and are tested on signals with known
  answers (``tests/test_analysis.py``).
- **Runs**: :func:`phonation`, :func:`contact` and :func:`summarize` take a :class:`vfrs.Result`,
  an output folder (``vfrs run ... -o OUT``; see :func:`load`) or a history mapping, and return
  :class:`Quantity` values (SI value, unit, what it is, and when / where for peaks). A
  :class:`Summary` prints itself (``vfrs run`` shows it) and is saved as ``summary.json``.

>>> import numpy as np
>>> t = np.arange(0.0, 0.05, 1e-5)
>>> area = np.maximum(np.sin(2 * np.pi * 150 * t), 0.0) * 1e-5         # opens half of each cycle
>>> round(fundamental_frequency(t, area), 3), round(float(np.mean(open_quotients(t, area, 0.0))), 2)
(150.0, 0.5)

Conventions (each a keyword argument):

- The **window** of the periodic measures is the second half of the run (``start``; the
  onset, while the oscillation grows, would bias f0 and the quotients). First contact and the
  contact peaks are over the whole run.
- A **glottal cycle** starts where the glottal area rises through its mean over the window
  (after dipping ``hysteresis`` standard deviations below it, so ripples make no extra cycles,
  and after falling back ``fall``, half, of the previous cycle's own opening, so a sub-pulse is
  no cycle).
- The glottis is **open** while the glottal area exceeds its minimum over the window plus
  ``open_level`` (10 %) of its range. The folds' anterior and posterior ends are clamped, so
  the model's glottis never closes completely (the minimum area is reported too); with a
  complete closure and ``open_level = 0`` this is the usual area > 0.
- **In contact**: a step with any loaded contact pair (``active_pairs > 0``).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from .errors import VfrsError
from .readers import damaged, inside, no_history, read_json, read_npz
from .registry import Registry

# ------------------------------------------------------------------------------------------
# Quantities and summaries
# ------------------------------------------------------------------------------------------

#: How each SI unit is shown in text: (factor, unit).
DISPLAY = {
    "s": (1e3, "ms"),
    "m": (1e3, "mm"),
    "m^2": (1e6, "mm^2"),
    "m^3": (1e9, "mm^3"),
    "m^3/s": (1e6, "mL/s"),
    "m^3/s^2": (1e3, "L/s^2"),
    "N": (1e3, "mN"),
    "N s": (1e6, "uN s"),
    "Pa": (1e-3, "kPa"),
    "Hz": (1.0, "Hz"),
    "1": (1.0, ""),
}


@dataclass(frozen=True)
class Quantity:
    """One measured number: ``value`` in SI ``unit`` (``"1"``: dimensionless), ``what`` it is;
    for peaks also when (``t``, s), on which ``body`` and where (``position``, m, reference
    coordinates), and ``per_cycle`` values when it is a mean over cycles (``per``: what one
    of them is over, ``"cycle"`` unless said). ``over``: ``"window"`` (the analysis window)
    or ``"run"`` (the whole run). ``roundoff``: the size (SI) below which the value is
    round-off of the stated ``scale`` (printed ``0 (below round-off)``; the value itself is
    kept). ``error``: its estimated error when one was asked for (:meth:`Summary.with_errors`:
    ``relative``, None when unknown; ``bound``: False when it is only the band of a study's
    runs; ``source``)."""

    value: float
    unit: str
    what: str
    t: float | None = None
    body: str | None = None
    position: tuple | None = None
    per_cycle: tuple | None = None
    over: str | None = None
    roundoff: float | None = None
    scale: str | None = None
    per: str | None = None
    error: dict | None = None

    def __float__(self) -> float:
        return float(self.value)

    @property
    def below_roundoff(self) -> bool:
        """The value is not zero but smaller than its round-off (``roundoff``): zero to the
        run's precision."""
        return self.roundoff is not None and math.isfinite(self.value) and 0 < abs(self.value) < self.roundoff

    def text(self) -> str:
        """The value in display units, with when / where: ``26.2 mN at t = 12.35 ms``; a mean
        over cycles with its spread and as many digits as the spread supports:
        ``0.79 (per cycle 0.66-1.00, sd 0.19, 3 cycles)``; with an error (:meth:`Summary.with_errors`)
        only the digits the error supports: ``2 kPa (+- 120 %)``, ``180 Hz (+- 27 %, band; per
        cycle 160-220, sd 30, 3 cycles)``; a value below its round-off: ``0 (below round-off)``."""
        if self.below_roundoff:
            return "0 (below round-off)"
        factor, unit = DISPLAY.get(self.unit, (1.0, self.unit))
        u = f" {unit}" if unit and math.isfinite(self.value) else ""
        error, at_most = self._error_text(factor, unit)
        if self.per_cycle is not None:
            value, spread = _with_spread(self.value * factor, [c * factor for c in self.per_cycle], self.per or "cycle",
                                         at_most)
        else:
            value, spread = _rounded(self.value * factor, at_most), ""
        said = "; ".join(p for p in (error, spread) if p)
        s = value + u + (f" ({said})" if said else "")
        extra = []
        if self.body is not None:
            extra.append(f"on {self.body}")
        if self.t is not None:
            extra.append(f"at t = {self.t * 1e3:.2f} ms")
        if self.position is not None:
            extra.append("(x, y, z) = (" + ", ".join(f"{c * 1e3:.2f}" for c in self.position) + ") mm")
        return s + (" " + " ".join(extra) if extra else "")

    def _error_text(self, factor: float, unit: str) -> tuple:
        """(the error as text: ``+- 2.1 %``, ``+- 8 %, band`` when not a bound, ``+- unknown``;
        the decimal the value is rounded to, or None). A 0/1 flag says whether the study's runs
        agree, a position gives its error in its own unit (``+- 0.3 mm``): a percentage of
        either means nothing. Empty and None when no error was asked for."""
        if self.error is None:
            return "", None
        rel, band = self.error.get("relative"), ("" if self.error.get("bound", True) else ", band")
        if self.error.get("as") == "flag":
            return ("error unknown" if rel is None else "the same in every run of the study" if rel == 0 else
                    "not the same in every run of the study"), None
        if rel is None or not math.isfinite(rel):
            return "+- unknown", None
        size = abs(rel * self.value * factor)  # the error in display units
        at_most = _first_digit(size)
        if self.error.get("as") == "position":
            return f"+- {_rounded(size, at_most)}{' ' + unit if unit else ''}{band}", at_most
        pct = 100.0 * rel
        return f"+- {pct:.2g} %{band}" if pct < 10 else f"+- {pct:.0f} %{band}", at_most

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"value": _json_number(self.value), "unit": self.unit, "what": self.what}
        for k in ("t", "body"):
            v = getattr(self, k)
            if v is not None:
                d[k] = _json_number(v) if k == "t" else v
        if self.position is not None:
            d["position"] = [_json_number(c) for c in self.position]
        if self.per_cycle is not None:
            d["per_cycle"] = [_json_number(c) for c in self.per_cycle]
            if self.per is not None:
                d["per"] = self.per
        if self.over is not None:
            d["over"] = self.over
        if self.roundoff is not None:
            d["roundoff"] = _json_number(self.roundoff)
            d["scale"] = self.scale
        if self.error is not None:
            d["error"] = {k: (_json_number(v) if isinstance(v, float) else v) for k, v in self.error.items()}
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "Quantity":
        num = lambda v: float("nan") if v is None else float(v)  # noqa: E731
        return cls(num(d["value"]), d["unit"], d["what"], None if d.get("t") is None else float(d["t"]), d.get("body"),
                   None if d.get("position") is None else tuple(num(c) for c in d["position"]),
                   None if d.get("per_cycle") is None else tuple(num(c) for c in d["per_cycle"]),
                   d.get("over"), None if d.get("roundoff") is None else float(d["roundoff"]), d.get("scale"),
                   d.get("per"), d.get("error"))


def _first_digit(size: float) -> int | None:
    """The decimal of the first significant digit of an error ``size`` (2 for 0.034, -1 for
    49): the last digit of a value that the error supports. None for 0 or not finite."""
    return -math.floor(math.log10(size)) if size > 0 and math.isfinite(size) else None


def _rounded(v: float, decimals: int | None) -> str:
    """``v`` to ``decimals`` decimals (negative: to tens, hundreds, ...), but never past its
    own first significant digit (``0.9 +- 1.6`` stays 0.9) nor to more than :func:`_fmt`'s 4
    significant digits; None: as :func:`_fmt`."""
    if decimals is None or v is None or not math.isfinite(v) or v == 0:
        return _fmt(v)
    lead = math.floor(math.log10(abs(v)))
    decimals = max(decimals, -lead)
    if lead + decimals + 1 > 4 or abs(v) >= 1e4 or abs(v) < 1e-3:
        return _fmt(v)
    return f"{v:.{decimals}f}" if decimals >= 0 else f"{round(v, decimals):.0f}"


def _fmt(v: float) -> str:
    if v is None or not math.isfinite(v):
        return "n/a"
    if v == 0:
        return "0"
    if abs(v) >= 1e4 or abs(v) < 1e-3:
        return f"{v:.3e}"
    return f"{v:.4g}" if abs(v) < 1000 else f"{v:.0f}"


def _with_spread(mean: float, values, per: str = "cycle", at_most: int | None = None) -> tuple:
    """(the mean as text, its spread as text) in the same units: the mean rounded to the
    decimal of the first significant digit of the values' standard deviation plus one (no
    more than :func:`_fmt`'s 4 significant digits, nor than ``at_most`` decimals: an error's),
    with their range, that deviation (n - 1 in the denominator) and how many there are:
    ``("0.79", "per cycle 0.66-1.00, sd 0.19, 3 cycles")``. One value, or equal values: the
    mean as :func:`_fmt` shows it (rounded to ``at_most``)."""
    v = np.asarray([c for c in values if c is not None and math.isfinite(c)], dtype=float)
    n = len(v)
    if n == 0 or not math.isfinite(mean):
        return _rounded(mean, at_most), ""
    if n == 1:
        return _rounded(mean, at_most), f"1 {per}"
    sd = float(v.std(ddof=1))
    if sd == 0.0:
        return _rounded(mean, at_most), f"{n} {per}s, all equal"
    decimals = 1 - math.floor(math.log10(sd))
    if at_most is not None:  # no more digits than the error supports, but the mean's first
        lead = -math.floor(math.log10(abs(mean))) if mean != 0 else at_most
        decimals = min(decimals, max(at_most, lead))
    if mean != 0 and math.floor(math.log10(abs(mean))) + decimals + 1 > 4:  # more than 4 significant digits
        return _fmt(mean), f"per {per} {_fmt(v.min())}-{_fmt(v.max())}, sd {sd:.2g}, {n} {per}s"

    def r(x: float) -> str:
        return f"{x:.{max(decimals, 0)}f}" if decimals >= 0 else f"{round(x, decimals):.0f}"

    sd_text = r(sd) if float(r(sd)) != 0 else f"{sd:.1g}"  # an error's rounding can swallow it
    return r(mean), f"per {per} {r(v.min())}-{r(v.max())}, sd {sd_text}, {n} {per}s"


def _json_number(v):
    v = float(v)
    return v if math.isfinite(v) else None


#: Numbers whose error is no percentage of their value (:meth:`Summary.with_errors`): a 0/1
#: flag (the study's runs agree on it or not) and a position (its error in its own unit: a
#: percentage would depend on where the origin is).
ERROR_AS = {"phonation.onset": "flag", "contact.peak_sensor_pressure_ap": "position",
            "contact.peak_sensor_pressure_below_superior": "position"}
BAND_NOTE = ('"band" (as in "+- 27 %, band"): that number\'s runs in the study go up and down or change more '
             "with each refinement, so the +- is only how far they spread, not a bound on the error")
ERROR_AS_NOTE = ("a 0/1 flag has no percentage error: it says whether the study's runs agree on it; a position "
                 "has its error in its own unit")


@dataclass
class Summary:
    """A run's results: ``sections`` (``"phonation"``, ``"contact"``) of named
    :class:`Quantity`, the analysis ``window`` and facts about the run (``run``: title, steps,
    end time, wall time, ...). ``summary["contact"]["peak_contact_pressure"].value``;
    ``print(summary)``; ``summary.save(path)`` writes ``summary.json``."""

    sections: dict = field(default_factory=dict)
    window: dict = field(default_factory=dict)
    run: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)  # what the numbers do not converge to, in words
    #: the warnings the run showed ("PlausibilityWarning: ..."), one line each: vfrs run repeats
    #: them after the summary, summary.json keeps them (``warnings``; absent in older files)
    warnings: list = field(default_factory=list)

    def __getitem__(self, section: str) -> dict:
        return self.sections[section]

    def __contains__(self, section: str) -> bool:
        return section in self.sections

    def text(self) -> str:
        """Two groups under their own headings: what is over the whole run, then what is over
        the analysis window (its interval and glottal cycles); each by section."""
        lines = ["results:"]
        w = self.window
        groups: dict[str, dict] = {"run": {}, "window": {}}
        for name, items in self.sections.items():
            for key, q in items.items():
                over = q.over or ("window" if name == "phonation" else "run")  # (summaries from before `over`)
                groups["window" if over == "window" else "run"].setdefault(name, {})[key] = q
        width = max((len(q.what) for items in self.sections.values() for q in items.values()), default=0)
        for over, sections in groups.items():
            if not sections:
                continue
            if over == "run":
                steps = self.run.get("steps")
                lines.append("  over the whole run" + (f" ({steps} steps):" if steps else ":"))
            else:
                n = w.get("cycles")
                cycles = "" if n is None else f", {n} glottal cycle{'' if n == 1 else 's'}"
                lines.append(f"  over the window t = {w['start'] * 1e3:.1f}-{w['end'] * 1e3:.1f} ms ({cycles[2:]}{'; ' if cycles else ''}"
                             "per-cycle values: their mean, range, standard deviation and count):")
                test = self.periodicity
                if test is not None:
                    lines.append(f"    cycles: {test.text()}{self._until_text()}")
            for name, items in sections.items():
                lines.append(f"    {name}")
                for q in items.values():
                    lines.append(f"      {q.what:<{width}}  {q.text()}")
        if not self.sections:
            lines.append("  (no flow and no contact: nothing to summarise beyond the history)")
        for note in [*self.notes, *self._quotient_note()]:
            lines.append(f"  note: {note}")
        return "\n".join(lines)

    __str__ = text

    def _quotient_note(self) -> list:
        """Where the closed quotient (of the glottal area) and the contact quotient differ, what
        each is: they answer different questions, and a reader takes one for the other."""
        closed = self.sections.get("phonation", {}).get("closed_quotient")
        touch = self.sections.get("contact", {}).get("contact_quotient")
        if closed is None or touch is None or closed.text().split()[0] == touch.text().split()[0]:
            return []
        return [f"the closed quotient ({closed.text().split()[0]}) is the part of a glottal cycle in which the glottal "
                "area is below the open quotient's level (a narrow glottis, touching or not); the contact quotient "
                f"({touch.text().split()[0]}) the part in which the folds touch (a loaded contact pair): the folds "
                "can touch while the glottis is still open elsewhere, and nearly close without touching"]

    @property
    def periodicity(self) -> Periodicity | None:
        """Whether the window's last cycles repeat (:class:`Periodicity`), or None (no cycles)."""
        p = self.window.get("periodicity")
        return None if p is None else Periodicity.from_dict({**p, "periodic": self.window.get("periodic", False)})

    def _until_text(self) -> str:
        """What a run that went on past its end until the cycles repeated reached."""
        r = self.run
        if r.get("until") != "limit_cycle":
            return ""
        if self.window.get("periodic"):
            if r["t_end"] <= r["until_end"]:
                return f" (until = \"limit_cycle\": so they did by the run's end, {r['until_end'] * 1e3:g} ms)"
            return (f" (the run went on past its end, {r['until_end'] * 1e3:g} ms, until they did: "
                    f"{r['t_end'] * 1e3:.2f} ms)")
        return (f" (the run went on past its end, {r['until_end'] * 1e3:g} ms, to its cap, until_cap = "
                f"{r['until_cap'] * 1e3:g} ms, without reaching a repeating cycle)")

    def to_dict(self) -> dict:
        return {"run": self.run, "window": self.window,
                **{name: {k: q.to_dict() for k, q in items.items()} for name, items in self.sections.items()},
                **({"notes": list(self.notes)} if self.notes else {}), "warnings": list(self.warnings)}

    def save(self, path) -> None:
        with open(path, "w") as fh:
            json.dump(self.to_dict(), fh, indent=2)
            fh.write("\n")

    @classmethod
    def from_dict(cls, d: dict) -> "Summary":
        sections = {k: {n: Quantity.from_dict(q) for n, q in v.items()} for k, v in d.items()
                    if k not in ("run", "window", "notes", "warnings")}
        return cls(sections, d.get("window", {}), d.get("run", {}), list(d.get("notes", [])),
                   list(d.get("warnings", [])))

    def warnings_text(self) -> str:
        """The run's warnings under a heading, one line each (empty when there were none):
        what vfrs run prints after the summary, where they do not scroll away."""
        if not self.warnings:
            return ""
        n = len(self.warnings)
        return "\n".join([f"warnings ({n}; shown above as they came, kept in summary.json):",
                          *(f"  {w}" for w in self.warnings)])

    def with_errors(self, errors: dict | None, source: str, note: str | None = None) -> "Summary":
        """The same summary with each quantity's estimated error: ``errors`` maps
        ``"<section>.<key>"`` to ``{"relative": float or None, "bound": bool, ...}`` (a
        quantity it lacks: unknown); ``source`` says where the errors come from (kept with
        each, and in a note with ``note`` after it)."""
        sections: dict = {}
        for name, items in self.sections.items():
            sections[name] = {}
            for key, q in items.items():
                e = (errors or {}).get(f"{name}.{key}")
                rel = None if e is None else e.get("relative")
                err = {"relative": rel if rel is None else float(rel), "bound": bool(True if e is None else e.get("bound", True)),
                       "source": source}
                if ERROR_AS.get(f"{name}.{key}"):  # a flag or a position: no percentage (Quantity._error_text)
                    err["as"] = ERROR_AS[f"{name}.{key}"]
                if err.get("as") == "flag" and rel is not None:  # kept as such: an infinite error is saved as null
                    err["relative"] = 0.0 if rel == 0 else 1.0
                sections[name][key] = dataclasses.replace(q, error=err)
        line = (f"+- : the estimated error of each number, from {source}" + (f"; {note}" if note else "")
                + "; each value has the digits its error supports")
        said = [q.error for items in sections.values() for q in items.values()]
        band = [BAND_NOTE] if any(not e["bound"] and e.get("as") != "flag" for e in said) else []
        kinds = [ERROR_AS_NOTE] if any(e.get("as") for e in said) else []
        return Summary(sections, dict(self.window), dict(self.run), [*self.notes, line, *band, *kinds],
                       list(self.warnings))

    @classmethod
    def load(cls, path) -> "Summary":
        """A saved ``summary.json``; a damaged one is a VfrsError naming it (:func:`vfrs.readers.damaged`)."""
        fix = (f"remove it (vfrs plot and vfrs.analysis.load then compute the summary from history.npz), or run the "
               f"scene again (vfrs run {os.path.join(os.path.dirname(path) or '.', 'scene.toml')} -o "
               f"{os.path.dirname(path) or '.'} --overwrite)")
        data = read_json(path, fix)
        try:
            return cls.from_dict(data)
        except (AttributeError, TypeError, KeyError, ValueError) as exc:
            raise VfrsError(damaged(path, exc, fix)) from None


# ------------------------------------------------------------------------------------------
# Signals
# ------------------------------------------------------------------------------------------


def _window(t, x, start=None, end=None):
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
    t, x = _window(t, x, start, end)
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
    t, x = _window(t, x, start, end)
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
    t, x = _window(t, area, start, end)
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
    t, x = _window(t, x, start, end)
    if not len(x):
        return float("nan"), None
    k = int(np.argmax(x))
    return float(x[k]), float(t[k])


def max_flow_declination_rate(t, q, start=None, end=None, within=None) -> tuple:
    """(MFDR, its time): the largest rate of decrease of the flow ``q``, max(-dq/dt)
    (m^3/s^2 for q in m^3/s), by central differences (``np.gradient``) over the window;
    ``within`` (a, b): the largest at a sample in [a, b] only (e.g. whole glottal cycles,
    the rates still from the samples either side, so a rate at a is not one-sided)."""
    t, q = _window(t, q, start, end)
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
#: the effects give (:meth:`RunView.periodicity`: the [flow] effect's period and peak glottal
#: area, the [contact] effect's peak contact force): (max - min) / mean over the last cycles.
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
                "spread": {k: _json_number(s) for k, (_, s) in self.spreads.items()},
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


# ------------------------------------------------------------------------------------------
# Runs: a Result, an output folder, or a history mapping
# ------------------------------------------------------------------------------------------


# damaged, read_npz: in vfrs.readers (with read_json and inside), named here as before


class RunOutput:
    """A run read back from its output folder (``vfrs run ... -o OUT``): ``history`` (the
    arrays of ``history.npz``), ``scene`` (the resolved :class:`vfrs.Scene`), ``summary``
    (from ``summary.json``, or computed), ``bodies`` (name -> node range, from the scene's
    meshes), ``snapshots(body)`` (times and VTU files of the field series)."""

    def __init__(self, out):
        from .scene import Scene

        self.out = os.fspath(out)
        path = os.path.join(self.out, "history.npz")
        if not os.path.exists(path):  # no run there, or one stopped before it wrote its history: say which
            raise VfrsError(no_history(self.out))
        arrays = read_npz(path)  # no pickles; a damaged file is one VfrsError line saying what to do
        self.history = {k: v for k, v in arrays.items() if k != "scene"}
        toml = str(arrays["scene"]) if "scene" in arrays else None
        if "t" not in self.history:
            raise VfrsError(damaged(path, ValueError("no array 't', the time of each step, which vfrs writes")))
        self.t = self.history["t"]
        scene_path = os.path.join(self.out, "scene.toml")
        if os.path.exists(scene_path) or toml is None:
            try:
                self.scene = Scene.load(scene_path)
            except VfrsError as exc:  # cut short or edited: the copy in history.npz is the scene as run
                raise VfrsError(damaged(scene_path, exc, "the scene as run is also inside history.npz: remove "
                                        "scene.toml and vfrs reads that copy" if toml else None)) from None
        else:  # the copy of the resolved scene that travels inside history.npz
            from ._compat import tomllib

            self.scene = Scene.from_dict(tomllib.loads(toml), source=path, base_dir=self.out)
        self._meshes = None
        self._summary = None

    @property
    def meshes(self) -> dict:
        """Body name -> (mesh, node offset), rebuilt from the scene (deterministic generators)."""
        if self._meshes is None:
            out, off = {}, 0
            for b, m in zip(self.scene.bodies, self.scene.build_meshes()):
                out[b.name] = (m, off)
                off += m.n_points
            self._meshes = out
        return self._meshes

    def body_of_node(self, node: int) -> str | None:
        for name, (m, off) in self.meshes.items():
            if off <= node < off + m.n_points:
                return name
        return None

    @property
    def summary(self) -> Summary:
        if self._summary is None:
            path = os.path.join(self.out, "summary.json")
            self._summary = Summary.load(path) if os.path.exists(path) else summarize(self)
        return self._summary

    def snapshots(self, body: str) -> list:
        """[(t, path to the VTU)] of one body's field series (from ``<body>.pvd``)."""
        import re

        from .errors import OutputFolderError

        path = os.path.join(self.out, f"{body}.pvd")
        try:
            with open(path, encoding="utf-8") as fh:
                text = fh.read()
            items = [(float(t), f) for t, f in re.findall(r'<DataSet timestep="([^"]+)" part="0" file="([^"]+)"/>', text)]
        except (OSError, ValueError) as exc:
            raise VfrsError(damaged(path, exc)) from None
        return [(t, inside(self.out, f, path, OutputFolderError)) for t, f in items]  # never a file outside the run


def load(out) -> RunOutput:
    """Reads an output folder of ``vfrs run`` (see :class:`RunOutput`)."""
    return RunOutput(out)


def _parts(run):
    """(history, scene or None, probe (t, displacement, position) or None, body_of_node or
    None) of a run: a :class:`vfrs.Result` or a :class:`RunOutput` (anything with ``history``,
    ``scene`` and ``body_of_node``; a Result also gives its first probe, ``first_probe()``),
    an output folder or a history mapping."""
    if isinstance(run, (str, os.PathLike)):
        run = load(run)
    if isinstance(run, Mapping):
        return run, None, None, None
    if all(hasattr(run, k) for k in ("history", "scene", "body_of_node")):
        first = getattr(run, "first_probe", None)
        return run.history, run.scene, first() if first is not None else None, run.body_of_node
    raise TypeError(f"expected a vfrs.Result, an output folder or a history mapping, got {type(run).__name__}")


def default_start(t) -> float:
    """The start of the analysis window: the second half of the run."""
    t = np.asarray(t, dtype=float)
    return float(t[0] + 0.5 * (t[-1] - t[0])) if len(t) else 0.0


#: A length, force or impulse smaller than this share of its scale (the mean tetrahedron edge
#: for lengths, its cube for volumes; the largest of the bodies' values for forces and
#: impulses) is round-off: the summary prints it as ``0 (below round-off)``.
ROUNDOFF = 1e-12


def element_size(run) -> float | None:
    """The mean edge length of the run's tetrahedra (m, over all bodies), the length that
    round-off is measured against; None for a bare history (no meshes)."""
    if isinstance(run, (str, os.PathLike)):
        run = load(run)
    if isinstance(run, RunOutput):
        meshes = [m for m, _ in run.meshes.values()]
    elif hasattr(run, "problem") and not isinstance(run, Mapping):  # a vfrs.Result
        meshes = [b.mesh for b in run.problem.bodies]
    else:
        return None
    total, count = 0.0, 0
    for m in meshes:
        x, tets = np.asarray(m.points), np.asarray(m.tets)
        for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)):
            total += float(np.linalg.norm(x[tets[:, i]] - x[tets[:, j]], axis=1).sum())
            count += len(tets)
    return total / count if count else None


# ------------------------------------------------------------------------------------------
# Measures: what the effects (and measures registered from outside) add to the summary
# ------------------------------------------------------------------------------------------


class RunView:
    """What a measure reads of a run. :func:`summarize` builds one and hands it to the
    ``measures(run)`` and ``notes(run, sections)`` hooks of every effect (:mod:`vfrs.effects`)
    and every registered :class:`Measure`.

    ``history`` (name -> per-step array), ``t``, ``scene`` (None for a bare history),
    ``start`` (the window's start as given; None: :func:`default_start`), ``open_level``,
    ``hysteresis``, ``probe`` ((t, displacement, position) of the first ``[output]`` probe;
    Results only), ``body_of_node`` (node -> body name, or None); computed on first use:
    ``window_start``, ``length_scale`` (:func:`element_size` unless given) and ``cycles``
    (the cycle starts over the window of the history's cycle signal: the first
    ``cycle_signal`` an effect declares that the history has, e.g. the [flow] effect's
    glottal area; none: no cycles)."""

    def __init__(self, run, start=None, open_level: float = 0.1, hysteresis: float = 0.25,
                 length_scale: float | None = None, last_cycles: int | None = None):
        if isinstance(run, (str, os.PathLike)):
            run = load(run)
        self.run = run
        self.history, self.scene, self.probe, self.body_of_node = _parts(run)
        self.t = np.asarray(self.history["t"])
        self.start, self.open_level, self.hysteresis = start, open_level, hysteresis
        self._length_scale = length_scale
        self._cycles: np.ndarray | None = None
        if last_cycles is None:
            last_cycles = getattr(getattr(self.scene, "output", None), "until_cycles", PERIODIC_CYCLES)
        self.last_cycles = int(last_cycles)

    @property
    def window_start(self):
        return default_start(self.t) if self.start is None else self.start

    @property
    def length_scale(self) -> float | None:
        if self._length_scale is None:
            self._length_scale = element_size(self.run)
        return self._length_scale

    @property
    def cycle_signal(self) -> str | None:
        """The history key the cycles are found in (an effect's ``cycle_signal``), or None."""
        for source in measure_sources():
            key = getattr(source, "cycle_signal", None)
            if key is not None and key in self.history:
                return key
        return None

    @property
    def cycles(self) -> np.ndarray:
        if self._cycles is None:
            key = self.cycle_signal
            self._cycles = (np.zeros(0) if key is None else
                            cycle_starts(self.t, self.history[key], self.window_start, hysteresis=self.hysteresis))
        return self._cycles

    def periodicity(self, tolerance: float = PERIODIC_TOLERANCE) -> Periodicity | None:
        """Whether the window's last ``last_cycles`` cycles repeat (:func:`periodicity`), over
        every source's per-cycle values (its ``cycle_values(run)``: name -> (what, values));
        None without a cycle signal."""
        if self.cycle_signal is None:
            return None
        series: dict = {}
        for source in measure_sources():
            hook = getattr(source, "cycle_values", None)
            if hook is not None:
                series.update(hook(self))
        return periodicity(series, self.last_cycles, tolerance)

    def sections(self) -> dict:
        """Every source's sections, in order (:func:`measure_sources`)."""
        out: dict = {}
        for source in measure_sources():
            for name, items in source.measures(self).items():
                if items:
                    out.setdefault(name, {}).update(items)
        return out


class Measure:
    """A summary measure that belongs to no effect, registered from anywhere with
    :func:`register_measure` (effects give theirs through the same two hooks)::

        @register_measure
        class PeakSpeed(Measure):
            name = "peak_speed"
            @classmethod
            def measures(cls, run):             # run: a RunView
                return {"motion": {"peak_speed": Quantity(..., "m/s", "peak speed", over="run")}}

    ``measures(run)`` -> {section: {name: Quantity}} (empty when the history lacks what it
    reads); ``notes(run, sections)`` -> lines the summary adds under ``note:``;
    ``cycle_values(run)`` -> {name: (what, one value per cycle of ``run.cycles``)}, values
    whose repetition :meth:`RunView.periodicity` tests."""

    name: str = ""

    @classmethod
    def measures(cls, run: RunView) -> dict:
        return {}

    @classmethod
    def notes(cls, run: RunView, sections: dict) -> list:
        return []

    @classmethod
    def cycle_values(cls, run: RunView) -> dict:
        return {}


MEASURES = Registry("measure", modules=("vfrs.fold_measures",))  # issue 33: measures to compare with measurements
register_measure = MEASURES.register


def measure_sources() -> list:
    """Who adds to the summary, in order: the registered effects (those of ``EFFECTS``'s own
    modules first, in their order: the [flow] effect's phonation before the [contact] effect's
    contact), then the registered :class:`Measure` classes."""
    from .effects import EFFECTS

    order = {m: i for i, m in enumerate(EFFECTS.modules)}
    effects = sorted(EFFECTS.values(), key=lambda c: order.get(c.__module__, len(order)))
    return [*effects, *MEASURES.values()]


def sample_history(scene) -> dict:
    """A made-up history with the columns a run of ``scene`` records that the summary reads:
    each of the scene's effects gives its own (``sample_history(scene, t)``) over 40 ms,
    oscillating at 200 Hz (``sin(2 pi 200 t)``) so that every measure it can give has a value
    (:func:`vfrs.sweep.summary_names`)."""
    from .effects import EFFECTS

    t = np.linspace(0.0, 0.04, 401)
    h: dict = {"t": t}
    for name in scene.effects:
        h.update(EFFECTS[name].sample_history(scene, t))
    return h


def _section(run, name: str, **options) -> dict:
    return RunView(run, **options).sections().get(name, {})


def phonation(run, start=None, open_level: float = 0.1, hysteresis: float = 0.25) -> dict:
    """The ``phonation`` section of a run with ``[flow]`` (empty dict without), as the [flow]
    effect measures it (:func:`vfrs.flow.phonation_measures`: f0, quotients, glottal area,
    peak flow, MFDR)."""
    return _section(run, "phonation", start=start, open_level=open_level, hysteresis=hysteresis)


def contact(run, start=None, hysteresis: float = 0.25, length_scale: float | None = None) -> dict:
    """The ``contact`` section of a run with ``[contact]`` (empty dict without), as the
    [contact] effect measures it (:func:`vfrs.enforcement.outputs.contact_measures`: first
    contact, durations, peak forces, impulses, pressures, areas, penetration)."""
    return _section(run, "contact", start=start, hysteresis=hysteresis, length_scale=length_scale)


def _limit_cycle_start(view: RunView, test) -> float | None:
    """The window of a run with ``[output] until = "limit_cycle"`` whose last cycles repeat
    (``test.needed`` of them: the scene's ``until_cycles``): from half a cycle before the first
    of them (so that its start, a rise through the mean after a dip, is found again), or None
    for any other run."""
    if not test.periodic or getattr(getattr(view.scene, "output", None), "until", "end") != "limit_cycle":
        return None
    k = test.needed
    cyc = view.cycles
    if len(cyc) < k + 1:
        return None
    first = float(cyc[-(k + 1)])
    return first - 0.5 * (float(cyc[-k]) - first)


def summarize(run, start=None, open_level: float = 0.1, hysteresis: float = 0.25,
              length_scale: float | None = None) -> Summary:
    """What the effects and the registered measures give (:class:`RunView`; the [flow]
    effect's ``phonation``, the [contact] effect's ``contact``), with the analysis window and
    facts about the run, as a :class:`Summary`. ``length_scale``: the length round-off is
    measured against (default: :func:`element_size` of the run, the mean tetrahedron edge)."""
    view = RunView(run, start, open_level, hysteresis, length_scale)
    t = view.t
    sections = view.sections()
    window: dict[str, Any] = {}
    if len(t) and sections:
        s = default_start(t) if start is None else float(start)
        window = {"start": s, "end": float(t[-1])}
        test = view.periodicity()
        if test is not None:  # the history has a cycle signal
            limit = _limit_cycle_start(view, test) if start is None else None
            if limit is not None:  # a run that went on to a limit cycle: its measures over the repeating cycles
                view = RunView(run, limit, open_level, hysteresis, length_scale)
                sections = view.sections()
                window["start"] = limit
                window["limit_cycle"] = True
            window["cycles"] = max(len(view.cycles) - 1, 0)
            window["periodic"] = test.periodic
            window["periodicity"] = {k: v for k, v in test.to_dict().items() if k != "periodic"}
    facts: dict[str, Any] = {"steps": len(t), "t_end": float(t[-1]) if len(t) else 0.0}
    if view.scene is not None:
        facts["title"] = view.scene.title
        out = view.scene.output
        if getattr(out, "until", "end") != "end":  # only then: the summaries of other runs stay as they were
            facts["until"] = out.until
            facts["until_end"] = float(view.scene.time.end)
            facts["until_cap"] = float(out.until_cap)
    notes = [line for source in measure_sources() for line in source.notes(view, sections)] if sections else []
    return Summary(sections, window, facts, notes)
