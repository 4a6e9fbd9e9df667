"""The results table of a sweep: a run's ``summary.json`` flattened into its row's columns,
the names a run's summary can have (:func:`summary_names`), and the table written as
Parquet and CSV (:func:`write_table`; Parquet needs pyarrow: ``pip install "vfrs[sweep]"``)."""

from __future__ import annotations

import csv
import json
import os

from ...scene import Scene
from ..extra import sweep_extra

#: Facts :func:`vfrs.run` adds to a summary's ``run`` section after
#: :func:`vfrs.summary.summarize` (``title`` comes from the scene, which a history alone lacks).
RUN_FACTS = ("title", "effects", "wall_time")


_NAMES: dict = {}


def summary_names(scene: Scene) -> list:
    """The names ``summary.<name>`` a run of ``scene`` can read in a derived column (its
    ``summary.json``: ``run.steps``, ``window.start``, ``phonation.f0``,
    ``contact.peak_force.right``, ...), found without running it: the summary
    declares them (:func:`vfrs.summary.summary_names`: the ``run`` facts, the
    ``window``, what the scene's effects and the registered measures declare), and the facts
    :func:`vfrs.run` adds. A quantity the run's own numbers do not give
    (f0 of a run too short for a cycle) is among them: empty in the table for that run.

    >>> import vfrs
    >>> names = summary_names(vfrs.Scene.load("examples/m5_collision.toml"))
    >>> "phonation.f0" in names and "contact.peak_force.left" in names
    True
    """
    from ...summary import MEASURES
    from ...summary import summary_names as declared

    key = (scene.to_toml(), tuple(MEASURES))  # what the effects and measures declare reads the whole scene
    if key not in _NAMES:
        names = [f"{section}.{k}" for section, keys in declared(scene).items() for k in keys]
        _NAMES[key] = names + [f"run.{k}" for k in RUN_FACTS if f"run.{k}" not in names]
    return list(_NAMES[key])


def flatten_summary(summary: dict) -> dict:
    """``summary.json`` as columns: ``contact.peak_force.right [N]`` (value),
    ``contact.peak_force.right.t [s]`` (when), ``run.wall_time [s]``, ..."""
    cols: dict = {}
    units = {"t_end": "s", "wall_time": "s", "start": "s", "end": "s"}
    for section in ("run", "window"):
        for k, v in summary.get(section, {}).items():
            if isinstance(v, (int, float, str)) or v is None:
                u = units.get(k)
                cols[f"{section}.{k}" + (f" [{u}]" if u else "")] = v
    for section, items in summary.items():
        if section in ("run", "window") or not isinstance(items, dict):
            continue
        for k, q in items.items():
            if not isinstance(q, dict):
                continue
            unit = q.get("unit")
            cols[f"{section}.{k}" + (f" [{unit}]" if unit and unit != "1" else "")] = q.get("value")
            if "t" in q:
                cols[f"{section}.{k}.t [s]"] = q["t"]
            if "body" in q:
                cols[f"{section}.{k}.body"] = q["body"]
    return cols


def _column(values: list):
    """One table column with one type: numbers (floats if any is), booleans, or strings."""
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return values
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        if all(isinstance(v, int) for v in present):
            return values
        return [None if v is None else float(v) for v in values]
    return [None if v is None else (v if isinstance(v, str) else json.dumps(v)) for v in values]


def summary_columns(axes: list, derived: list) -> list:
    """The first columns of a sweep's summary table: id, the swept values, status, error,
    attempts, wall time, peak memory, skipped, build, the derived columns."""
    return ["id", *axes, "status", "error", "attempts", "wall_time [s]", "peak_rss [MB]", "skipped", "vfrs code",
            *derived]


def write_table(rows: list, out: str, first: list, *, name: str = "summary", csv_too: bool = True) -> None:
    """``<name>.parquet`` and ``<name>.csv`` (written atomically): one row per run, the columns
    ``first`` (:func:`summary_columns` for a sweep's table), then every other key of the rows
    (a sweep's: the summary's columns). ``csv_too``: False for the Parquet file only."""
    pa = sweep_extra("pyarrow", f"writing {name}.parquet")
    pq = sweep_extra("pyarrow.parquet", f"writing {name}.parquet")

    names = list(first)
    for r in rows:
        names += [k for k in r if k not in names]
    columns = {n: _column([r.get(n) for r in rows]) for n in names}
    tmp = os.path.join(out, f"{name}.parquet.tmp{os.getpid()}")
    pq.write_table(pa.table(columns), tmp)
    os.replace(tmp, os.path.join(out, f"{name}.parquet"))
    if not csv_too:
        return
    tmp = os.path.join(out, f"{name}.csv.tmp{os.getpid()}")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        for i in range(len(rows)):
            w.writerow(["" if columns[n][i] is None else (repr(columns[n][i]) if isinstance(columns[n][i], float)
                                                          else columns[n][i]) for n in names])
    os.replace(tmp, os.path.join(out, f"{name}.csv"))
