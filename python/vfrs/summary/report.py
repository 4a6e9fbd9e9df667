"""A run's results as one object: :class:`Summary` (sections of :class:`Quantity`, the
analysis window, facts about the run, notes, warnings), printed by ``vfrs run``, saved as
``summary.json`` and read back; :meth:`Summary.with_errors` puts a study's error bars on it."""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass, field

from ..errors import VfrsError
from ..output.reader import damaged, read_json
from ..signals import Periodicity
from .quantity import Quantity


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
        the analysis window (its interval and glottal cycles); each by section. A quantity
        that says its ``kind`` is tagged ``[smooth]`` or ``[extreme]`` before its value."""
        lines = ["results:"]
        w = self.window
        groups: dict[str, dict] = {"run": {}, "window": {}}
        for name, items in self.sections.items():
            for key, q in items.items():
                over = q.over or ("window" if name == "phonation" else "run")  # (summaries from before `over`)
                groups["window" if over == "window" else "run"].setdefault(name, {})[key] = q
        width = max((len(q.what) for items in self.sections.values() for q in items.values()), default=0)
        kinds = max((len(q.kind) + 3 for items in self.sections.values() for q in items.values() if q.kind), default=0)
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
                    tag = f"[{q.kind}]" if q.kind else ""
                    lines.append(f"      {q.what:<{width}}  {tag:<{kinds}}{q.text()}")
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
        """A saved ``summary.json``; a damaged one is a VfrsError naming it (:func:`vfrs.output.reader.damaged`)."""
        fix = (f"remove it (vfrs plot and vfrs.load then compute the summary from history.npz), or run the "
               f"scene again (vfrs run {os.path.join(os.path.dirname(path) or '.', 'scene.toml')} -o "
               f"{os.path.dirname(path) or '.'} --overwrite)")
        data = read_json(path, fix)
        try:
            return cls.from_dict(data)
        except (AttributeError, TypeError, KeyError, ValueError) as exc:
            raise VfrsError(damaged(path, exc, fix)) from None
