"""Runs a converge study takes from other studies instead of running them (``vfrs converge
--take STUDY``): the finished rows of their ``summary.csv``, matched to the plan's runs by run
id (the sha256 of the resolved scene, :func:`vfrs.studies.sweep.run_id_of`: the same scene,
step and mesh, up to an explicit ``refine = 0``). A step study (``--meshes 1``) and a mesh study (``--steps 1``) of one scene
make its cross study (``--design cross``) without running anything again; a run that two of
them hold (the base run) must have the same numbers in both, so studies made by two builds
are combined only where the builds agree."""

from __future__ import annotations

import csv
import json
import math
import os

from ...errors import VfrsError
from .analyse import Quantity, finite_number
from .report import CONVERGE_FILE

#: Two studies' copies of one run agree when every studied number is equal to this relative
#: difference (the same scene on the same kind of CPU gives the same bits; a checkpointed
#: resume or another build of the same code may move the last digits).
AGREE = 1e-9


def _value(text: str):
    """A summary.csv cell as the sweep's table held it: a number where it parses, else text."""
    if text == "":
        return None
    try:
        return float(text)
    except ValueError:
        return text


def read_rows(folder) -> list:
    """The rows of a study's (or a sweep's) ``summary.csv``, numbers as floats."""
    path = os.path.join(os.fspath(folder), "summary.csv")
    try:
        with open(path, newline="") as fh:
            return [{k: _value(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    except FileNotFoundError:
        raise VfrsError(f"--take {folder}: no summary.csv there: give the folder of a finished `vfrs converge` "
                        "(or `vfrs sweep`) run") from None


def read_quantities(folder) -> list:
    """The quantities a study studied (its ``converge.json``), or [] when it has none."""
    try:
        with open(os.path.join(os.fspath(folder), CONVERGE_FILE)) as fh:
            return [Quantity(**q) for q in json.load(fh).get("quantities", [])]
    except (FileNotFoundError, ValueError, TypeError):
        return []


#: Columns of a sweep's table that are not the run's numbers (its cost, its bookkeeping).
NOT_NUMBERS = {"id", "mesh", "step", "status", "error", "attempts", "wall_time [s]", "peak_rss [MB]", "skipped",
               "vfrs code", "run.wall_time [s]"}


def _differences(a: dict, b: dict) -> list:
    """The columns in which two copies of one run differ (each studied number and every other
    column of the summary, not the cost)."""
    out = []
    for column in sorted((set(a) | set(b)) - NOT_NUMBERS):
        x, y = a.get(column), b.get(column)
        if finite_number(x) and finite_number(y):
            if not math.isclose(float(x or 0.0), float(y or 0.0), rel_tol=AGREE, abs_tol=0.0):
                out.append(f"{column} {x!r} vs {y!r}")
        elif x != y:
            out.append(f"{column} {x!r} vs {y!r}")
    return out


def _without_zero_refine(scene: dict) -> dict:
    """The scene without a body's ``refine = 0`` (the refinement ladder writes it on its first
    rung; a study with ``--meshes 1`` runs the scene as it is, which is the same run)."""
    import copy

    d = copy.deepcopy(scene)
    for b in d.get("bodies", []):
        if b.get("mesh", {}).get("refine", None) == 0:
            del b["mesh"]["refine"]
    return d


def take(plan, folders) -> tuple:
    """({(mesh level, step level): row} of the plan's runs found finished in ``folders``,
    relabelled with this plan's rungs; the quantities those studies studied; a note per
    folder). VfrsError when two folders hold one run with different numbers."""
    from ..sweep import run_id_of

    cells = {}
    for r in plan.runs:
        ij = (r["mesh_level"], r["step_level"])
        cells[run_id_of(r["scene"])] = cells[run_id_of(_without_zero_refine(r["scene"]))] = ij
    found: dict = {}
    where: dict = {}
    quantities: list = []
    notes = []
    for folder in folders:
        got = 0
        qs = read_quantities(folder)
        quantities += [q for q in qs if q.name not in {x.name for x in quantities}]
        for row in read_rows(folder):
            cell = cells.get(str(row.get("id")))
            if cell is None or row.get("status") != "complete":
                continue
            i, j = cell
            row = {**row, **plan.label(i, j)}
            if cell in found:
                bad = _differences(found[cell], row)
                if bad:
                    raise VfrsError(
                        f"--take: run {row['id']} ({plan.label(i, j)['mesh']}, {plan.label(i, j)['step']}) is in "
                        f"{where[cell]} and {folder} with different numbers (vfrs code {found[cell].get('vfrs code')} "
                        f"and {row.get('vfrs code')}): {'; '.join(bad[:3])}" + (f"; {len(bad) - 3} more" if len(bad) > 3
                                                                                  else "")
                        + ": those studies were made by builds that disagree; run it again in one of them")
                continue
            found[cell], where[cell] = row, folder
            got += 1
        notes.append(f"{got} run(s) taken from the study in {os.fspath(folder)} (matched by run id: the same "
                     "resolved scene), not run again")
    return found, quantities, notes
