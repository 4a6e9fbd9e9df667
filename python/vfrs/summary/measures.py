"""What adds to the summary and how it is put together: :class:`RunView` (what a measure
reads of a run), :class:`Measure` and its registry :data:`MEASURES`, :func:`summarize` (and
its sections :func:`phonation`, :func:`contact`).

A run is a :class:`vfrs.Result`, an output folder (``vfrs run ... -o OUT``; read with
:func:`vfrs.output.load`) or a history mapping. Conventions (each a keyword argument):

- The **window** of the periodic measures is the second half of the run (``start``; the
  onset, while the oscillation grows, would bias f0 and the quotients). First contact and the
  contact peaks are over the whole run.
- A **glottal cycle** starts where the glottal area rises through its mean over the window
  (:func:`vfrs.signals.cycle_starts`: after dipping ``hysteresis`` standard deviations below
  it, and after falling back half of the previous cycle's own opening).
- The glottis is **open** while the glottal area exceeds its minimum over the window plus
  ``open_level`` (10 %) of its range. The folds' anterior and posterior ends are clamped, so
  the model's glottis never closes completely (the minimum area is reported too); with a
  complete closure and ``open_level = 0`` this is the usual area > 0.
- **In contact**: a step with any loaded contact pair (``active_pairs > 0``).
"""

from __future__ import annotations

import os
from typing import Any, Mapping

import numpy as np

from ..output.reader import RunOutput
from ..output.reader import load as read_run
from ..registry import Registry
from ..signals import PERIODIC_CYCLES, PERIODIC_TOLERANCE, Periodicity, cycle_starts, periodicity
from .report import Summary


def _parts(run):
    """(history, scene or None, probe (t, displacement, position) or None, body_of_node or
    None) of a run: a :class:`vfrs.Result` or a :class:`RunOutput` (anything with ``history``,
    ``scene`` and ``body_of_node``; a Result also gives its first probe, ``first_probe()``),
    an output folder or a history mapping."""
    if isinstance(run, (str, os.PathLike)):
        run = read_run(run)
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
        run = read_run(run)
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
                 length_scale: float | None = None, last_cycles: int | None = None,
                 tolerance: float | None = None):
        if isinstance(run, (str, os.PathLike)):
            run = read_run(run)
        self.run = run
        self.history, self.scene, self.probe, self.body_of_node = _parts(run)
        self.t = np.asarray(self.history["t"])
        self.start, self.open_level, self.hysteresis = start, open_level, hysteresis
        self._length_scale = length_scale
        self._cycles: np.ndarray | None = None
        if last_cycles is None:
            last_cycles = getattr(getattr(self.scene, "output", None), "until_cycles", PERIODIC_CYCLES)
        self.last_cycles = int(last_cycles)
        if tolerance is None:  # the scene's [output] until_tolerance (its default: the summary's)
            tolerance = getattr(getattr(self.scene, "output", None), "until_tolerance", PERIODIC_TOLERANCE)
        self.tolerance = float(tolerance)

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

    def periodicity(self, tolerance: float | None = None) -> Periodicity | None:
        """Whether the window's last ``last_cycles`` cycles repeat (:func:`periodicity`) within
        ``tolerance`` (default: the view's, the scene's ``[output] until_tolerance``), over
        every source's per-cycle values (its ``cycle_values(run)``: name -> (what, values));
        None without a cycle signal."""
        if self.cycle_signal is None:
            return None
        series: dict = {}
        for source in measure_sources():
            hook = getattr(source, "cycle_values", None)
            if hook is not None:
                series.update(hook(self))
        return periodicity(series, self.last_cycles, self.tolerance if tolerance is None else tolerance)

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

    @classmethod
    def summary_names(cls, scene) -> dict:
        """{section: [name, ...]}: what :meth:`measures` gives a run of ``scene`` that has what
        each needs (glottal cycles, contact), known without running it (:func:`summary_names`)."""
        return {}


# issue 33: measures to compare with measurements; issue 45: band-limited peaks and closure stages
MEASURES = Registry("measure", modules=("vfrs.summary.fold", "vfrs.summary.closure"))
register_measure = MEASURES.register


def measure_sources() -> list:
    """Who adds to the summary, in order: the registered effects (those of ``EFFECTS``'s own
    modules first, in their order: the [flow] effect's phonation before the [contact] effect's
    contact), then the registered :class:`Measure` classes."""
    from ..effects import EFFECTS

    order = {m: i for i, m in enumerate(EFFECTS.modules)}
    effects = sorted(EFFECTS.values(), key=lambda c: order.get(c.__module__, len(order)))
    return [*effects, *MEASURES.values()]


def summary_names(scene) -> dict:
    """Every name the summary of a run of ``scene`` can hold, by section, known without running
    it (what a sweep's derived columns may read): the ``run`` facts, the ``window`` (its cycles
    and periodicity test when a source has a ``cycle_signal``), then what the scene's effects
    and the registered measures declare (their ``summary_names(scene)``), in
    :func:`measure_sources` order. A name a run does not reach (a contact quotient without two
    glottal cycles) is among them."""
    from ..effects import EFFECTS

    effects = set(EFFECTS.values())
    sources = [s for s in measure_sources() if s not in effects or s.name in scene.effects]
    sections: dict = {}
    for source in sources:
        for section, names in source.summary_names(scene).items():
            have = sections.setdefault(section, [])
            have.extend(n for n in names if n not in have)
    until = getattr(scene.output, "until", "end") != "end"
    out: dict = {"run": ["steps", "t_end", "title", *(["until", "until_end", "until_cap"] if until else [])]}
    if sections:
        cycles = any(getattr(s, "cycle_signal", None) for s in sources)
        out["window"] = ["start", "end", *(["limit_cycle"] if cycles and until else []),
                         *(["cycles", "periodic", "periodicity"] if cycles else [])]
    return {**out, **sections}


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


class SummarizedRun(RunOutput):
    """A run read back from its output folder (:class:`vfrs.output.RunOutput`) with its
    ``summary``: ``summary.json``, or computed (:func:`summarize`) when the folder has none.
    (The reader sits a floor below the summary, which reads runs through it: the summary is
    added here, above both.)"""

    def __init__(self, out):
        super().__init__(out)
        self._summary: Summary | None = None

    @property
    def summary(self) -> Summary:
        if self._summary is None:
            path = os.path.join(self.out, "summary.json")
            self._summary = Summary.load(path) if os.path.exists(path) else summarize(self)
        return self._summary


def load(out) -> SummarizedRun:
    """Reads an output folder of ``vfrs run`` with its summary (``vfrs.load``; see
    :class:`SummarizedRun`)."""
    return SummarizedRun(out)
