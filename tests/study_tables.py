"""Reading committed converge studies back, for the tests of the committed results: a
study's summary.csv rows, its numbers, and the check that a printed summary's error bars are
the study's (docs/results.md's blocks)."""

from __future__ import annotations

import csv
import re
from pathlib import Path


def rows(folder: Path) -> list:
    """The rows of a study's summary.csv (text, as committed)."""
    with open(folder / "summary.csv", newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def num(text: str):
    """A summary.csv cell as a number, or None."""
    try:
        return float(text)
    except ValueError:
        return None


#: Numbers printed without a percentage (a position, a flag's sense): Quantity.text.
NO_PERCENT = ("phonation.onset", "contact.peak_sensor_pressure_ap", "contact.peak_sensor_pressure_below_superior")


def recomputed_errors(plan, folder: Path, study: dict) -> list:
    """The errors vfrs.studies.converge computes from a committed study's table of runs (its
    summary.csv, read as ``vfrs converge --take`` reads it) and the quantities it studied."""
    from vfrs.studies import converge as cv
    from vfrs.studies.converge.take import read_rows

    quantities = [cv.Quantity(**q) for q in study["quantities"]]
    return cv.finish(plan, read_rows(folder), None, known=quantities).errors


def printed_block(doc: str, after: str) -> str:
    """The first ```text block of ``doc`` after the text ``after``."""
    block = doc[doc.index("```text\n", doc.index(after)):]
    return block[:block.index("```\n", 8)]


def check_printed_errors(block: str, study: dict, errors: dict) -> int:
    """Asserts that every percentage and "band" in a printed summary ``block`` is the study's
    error of that number (``errors``: :func:`vfrs.studies.converge.errors_for` of the run), as
    Quantity.text prints it; returns how many lines it checked."""
    by_what = {q["what"]: f"{q['section']}.{q['key']}" for q in study["quantities"]}
    seen = 0
    for line in block.splitlines():
        what = next((w for w in by_what if line.strip().startswith(w + "  ")), None)
        if what is None or "(below round-off)" in line:
            continue
        e, seen = errors[by_what[what]], seen + 1
        m = re.search(r"\(\+- ([0-9.]+) %(, band)?[;)]", line)
        if by_what[what] in NO_PERCENT:
            assert m is None, line
            continue
        if e["relative"] is None:
            assert "+- unknown" in line, line
            continue
        pct = 100 * e["relative"]
        assert m and m.group(1) == (f"{pct:.2g}" if pct < 10 else f"{pct:.0f}"), line
        assert bool(m.group(2)) == (not e["bound"]), line
    return seen
