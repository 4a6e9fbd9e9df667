"""``vfrs sweep SWEEP.toml -o OUT``: many runs of one scene, each a task on dask.distributed.

A sweep file names a base scene and the axes to vary::

    base = "../m5_collision.toml"        # relative to the sweep file; or an inline [base] table
    mode = "grid"                        # "grid": every combination (default); "list": axes zipped
    [set]                                # optional: fixed changes to the base (--set key paths)
    "time.end" = 0.01
    [[axes]]
    key = "flow.subglottal_pressure"     # any key path `vfrs run --set` accepts
    values = [600.0, 800.0]
    [[axes]]
    key = "contact.method"
    values = ["lagrange", "augmented_lagrange"]
    [derived]                            # optional named columns (a small safe expression language)
    peak_force_mN = "summary.contact.peak_force.right * 1e3"

Every combination is validated as a scene before anything runs (a bad key or value is a
SceneError naming the sweep file, the axis and the key; no folder is created). Each run is
one task writing ``OUT/runs/<id>/`` - the layout of ``vfrs run -o`` plus ``params.json`` (the
swept values) and ``sweep_run.json`` (status, error, attempts, wall time) - into
``OUT/runs/<id>.tmp-<pid>`` first, renamed when it ends. ``<id>`` is a hash of the resolved
scene (:func:`run_id_of`), so a finished run is found again and skipped on a re-run; a
failed run is retried (``--retries``); a run whose worker died is taken over by the task dask
reschedules and resumed from its last checkpoint. ``OUT/summary.parquet`` and ``OUT/summary.csv`` hold
one row per combination: the swept values, status, error, wall time, the derived columns and
every number of the run's ``summary.json`` (units in the column names). ``docs/sweeps.md``.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import csv
import difflib
import itertools
import json
import math
import os
import re
import shutil
import socket
import sys
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ._compat import tomllib
from .output.atomic import atomic_json, atomic_write
from .derived import Namespace, check_expression, evaluate, references
from .errors import SceneError, VfrsError
from .output.reader import inside, read_json, read_npz
from .scene import Scene, read_toml
from .scene.keypath import key_path, set_key
from .params import param, param_keys, read_params
from .params.table import Table, suggest

RUN_FILE = "sweep_run.json"
PARAMS_FILE = "params.json"
#: Threads for the Rust core (rayon), OpenMP and BLAS in each worker process of a sweep: one,
#: the cluster runs one task per core.
THREAD_VARS = ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


# ------------------------------------------------------------------------------------------
# The sweep file
# ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class SweepFile:
    """The keys of a sweep file, read by :func:`~vfrs.params.read_params` (types checked, an
    unknown key named with the closest valid one); what a field's type cannot say (the base a
    file or a table, the mode, the axes and derived columns one by one) :func:`load_sweep` checks."""

    base: str | dict | None = param(None, doc="the base scene: its file (relative to the sweep file) or a [base] table")
    title: str = param("", doc="the sweep's title")
    mode: str = param("grid", doc="grid: every combination of the axes' values; list: the axes zipped")
    set: dict = param({}, doc="fixed changes to the base: key path = value, as `vfrs run --set`")
    axes: list = param([], doc="[[axes]] tables: key and values")
    derived: dict = param({}, doc="named columns: name = expression (docs/sweeps.md)")


@dataclass(frozen=True)
class AxisFile:
    """One ``[[axes]]`` table of a sweep file."""

    key: str = param(doc="a scene key path, as `vfrs run --set` takes it: contact.kappa, bodies[0].mesh.resolution")
    values: list = param(doc="the values, a non-empty array")


#: The keys of a sweep file.
SWEEP_KEYS = tuple(param_keys(SweepFile))
MODES = ("grid", "list")


@dataclass
class Axis:
    key: str
    values: list


@dataclass
class Sweep:
    """A validated sweep: ``runs`` holds, per combination, its swept values (``params``), the
    resolved scene (``scene``, a dict) and the run id."""

    source: str
    base: dict
    base_source: str
    base_dir: str
    axes: list
    mode: str = "grid"
    derived: dict = field(default_factory=dict)
    title: str = ""
    runs: list = field(default_factory=list)

    def combinations(self) -> list[dict]:
        if not self.axes:
            return [{}]
        if self.mode == "list":
            return [{a.key: a.values[i] for a in self.axes} for i in range(len(self.axes[0].values))]
        return [dict(zip([a.key for a in self.axes], vals)) for vals in itertools.product(*[a.values for a in self.axes])]

    def scene(self, params: dict) -> Scene:
        data = copy.deepcopy(self.base)
        for key, value in params.items():
            set_key(data, key, value)
        return Scene.from_dict(data, source=self.base_source, base_dir=self.base_dir)

    @classmethod
    def from_runs(cls, source: str, runs, *, derived: dict | None = None, title: str = "",
                  base_dir: str | None = None) -> "Sweep":
        """A sweep built in Python rather than read from a file: ``runs`` is a list of
        ``(params, scene)`` pairs, ``params`` the run's labels (the table's first columns:
        any names and values, e.g. ``{"problem": "hertz", "setting": "lagrange"}``) and
        ``scene`` a scene as a dict. Every scene is validated here (a SceneError names the
        run's labels); ``source`` names the sweep in messages and ``sweep.json``. What
        ``vfrs bench accuracy`` and ``examples/paper_figures.py`` run.

        >>> import vfrs, vfrs.sweep as sw
        >>> def with_E(E):
        ...     d = vfrs.Scene.load("examples/bar_static.toml").to_dict()
        ...     d["bodies"][0]["material"]["E"] = E
        ...     return d
        >>> s = sw.Sweep.from_runs("example", [({"E": E}, with_E(E)) for E in (1e6, 2e6)])
        >>> [r["params"] for r in s.runs], len({r["id"] for r in s.runs})
        ([{'E': 1000000.0}, {'E': 2000000.0}], 2)
        """
        keys: list = []
        pairs = list(runs)
        for params, _ in pairs:
            keys += [k for k in params if k not in keys]
        derived = _check_derived(source, derived or {}, keys)
        axes = [Axis(k, [params.get(k) for params, _ in pairs]) for k in keys]
        sweep = cls(source, {}, source, base_dir or os.getcwd(), axes, "list", derived, title)
        seen: dict = {}
        scenes: list = []
        for index, (params, scene) in enumerate(pairs):
            where = f"run {index} (" + ", ".join(f"{k} = {v!r}" for k, v in params.items()) + ")"
            try:
                built = Scene.from_dict(copy.deepcopy(scene), source=f"{source} {where}", base_dir=sweep.base_dir)
            except SceneError as e:
                raise _err(source, where, str(e)) from None
            data = built.to_dict()
            run_id = run_id_of(data)
            if run_id in seen:
                raise _err(source, where, f"gives the same scene as run {seen[run_id]}")
            seen[run_id] = index
            sweep.runs.append({"index": index, "id": run_id, "params": dict(params), "scene": data})
            scenes.append(built)
        check_derived_names(sweep, scenes)
        return sweep


def _err(source: str, where: str, message: str) -> SceneError:
    return SceneError(f"{source}: {where}: {message}")


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
    from .summary import MEASURES
    from .summary import summary_names as declared

    key = (scene.to_toml(), tuple(MEASURES))  # what the effects and measures declare reads the whole scene
    if key not in _NAMES:
        names = [f"{section}.{k}" for section, keys in declared(scene).items() for k in keys]
        _NAMES[key] = names + [f"run.{k}" for k in RUN_FACTS if f"run.{k}" not in names]
    return list(_NAMES[key])


def _unknown_name(source: str, column: str, expr: str, ref: str, valid: list, what: str) -> SceneError:
    """The error of a derived column that reads a name its runs will not have: the column,
    the name, the closest valid names and where the valid ones are listed."""
    root = ref.split(".", 1)[0] + "."  # matched without it (a shared "summary." makes any name look close)
    near = [root + v for v in difflib.get_close_matches(ref[len(root):], [v[len(root):] for v in valid], n=3,
                                                        cutoff=0.6)]
    section = ref.rsplit(".", 1)[0] + "."
    same = [v for v in valid if v.startswith(section)] if not near else []
    hint = ("did you mean " + " or ".join(repr(v) for v in near) + "?" if near else
            f"valid names here: {same}" if same else f"valid names: {valid}")
    return _err(source, f"derived.{column}", f"{expr!r} reads {ref!r}, which {what}; {hint}"
                + ("" if hint.endswith("?") else ".") + " Nothing has run.")


def check_derived_names(sweep: "Sweep", scenes: list) -> None:
    """Every ``summary.<name>`` and ``params.<key>`` a derived column reads must be one every
    run will have (:func:`summary_names` of its scene; its swept keys): else a SceneError
    naming the sweep, the column, the name and the closest valid names, before any run.
    ``history.<column>`` and ``probes[...]`` are read at the end of each run (a name no run
    has: an empty cell, a ``derived_errors`` entry and exit 1)."""
    for column, expr in sweep.derived.items():
        for root, key in references(check_expression(expr)):
            if root in ("history", "probes"):
                continue
            for run, scene in zip(sweep.runs, scenes):
                valid = summary_names(scene) if root == "summary" else list(run["params"])
                if key in valid:
                    continue
                ref = f"{root}.{key}"
                others = [f"{root}.{v}" for v in valid]
                if root == "params":
                    what = "is not a swept key" if others else "is not a swept key (this sweep has no axes)"
                elif all(key not in summary_names(s) for s in scenes):
                    what = "is in the summary of no run of this sweep (docs/results.md)"
                else:
                    where = ", ".join(f"{k} = {v!r}" for k, v in run["params"].items())
                    what = f"is not in the summary of run {run['index']} ({where}) (docs/results.md)"
                raise _unknown_name(sweep.source, column, expr, ref, others, what)


def _check_derived(source: str, derived, axes: Sequence[str] = ()) -> dict:
    """The ``[derived]`` columns (name = expression), each expression checked, each name
    one the table does not have already (``axes``: the axis keys); a copy."""
    if not isinstance(derived, dict):
        raise _err(source, "derived", f"expected a table of name = expression, got {derived!r}")
    taken = summary_columns(list(axes), []) + ["derived_errors"]
    for name, expr in derived.items():
        if isinstance(expr, dict):  # `a.b = "..."`: TOML reads a dotted key as a table
            raise _err(source, f"derived.{name}", f"expected an expression (a string), got a table {expr!r}; "
                       f"a column name with a dot needs quotes: \"{name}.{next(iter(expr), '')}\" = ...")
        if not isinstance(expr, str):
            raise _err(source, f"derived.{name}", f"expected an expression (a string), got {expr!r}")
        if name in taken:
            raise _err(source, f"derived.{name}", f"the table has a column {name!r} already "
                       f"({'an axis' if name in axes else 'one of ' + str(taken)}); give the column another name")
        try:
            check_expression(expr)
        except ValueError as e:
            raise _err(source, f"derived.{name}", str(e)) from None
    return dict(derived)


def load_sweep(path) -> Sweep:
    """Reads and validates a sweep file: every combination becomes a valid scene, or a
    SceneError naming the file, the axis and the key says why not (nothing runs)."""
    path = os.fspath(path)
    src = path
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise SceneError(f"{path}: sweep file does not exist") from None
    except (OSError, UnicodeDecodeError) as e:
        raise SceneError(f"{path}: cannot read the sweep file: {e}") from None
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{path}: not valid TOML: {e}") from None
    here = os.path.dirname(os.path.abspath(path))
    table = Table(data, "", src)
    f = read_params(SweepFile, table)
    table.done()
    base = f.base
    if isinstance(base, str):
        base_path = base if os.path.isabs(base) else os.path.join(here, base)
        try:
            base_data = read_toml(base_path)
        except SceneError as e:
            raise _err(src, "base", str(e)) from None
        base_source, base_dir = base_path, os.path.dirname(os.path.abspath(base_path))
    elif isinstance(base, dict):
        base_data, base_source, base_dir = base, f"{src} [base]", here
    else:
        raise _err(src, "base", "missing; expected the base scene's file (relative to the sweep file) or a [base] "
                   "table" if base is None else f"expected a file name or a table, got {base!r}")
    fixed = f.set
    if not isinstance(fixed, dict):
        raise _err(src, "set", f"expected a table of key path = value, got {fixed!r}")
    for k, v in fixed.items():
        try:
            set_key(base_data, k, v)
        except ValueError as e:
            raise _err(src, f"set.{k!r}", f"{e}; the base scene is {base_source}") from None
    if f.mode not in MODES:
        raise _err(src, "mode", f"{f.mode!r} is not 'grid' or 'list'")
    if not isinstance(f.axes, list) or not all(isinstance(a, dict) for a in f.axes):
        raise _err(src, "axes", "expected [[axes]] tables with key and values")
    axes: list[Axis] = []
    for i, a in enumerate(f.axes):
        at = Table(a, f"axes[{i}]", src)
        axis = read_params(AxisFile, at)
        at.done()
        key, values = axis.key, axis.values
        try:
            key_path(key)
        except ValueError as e:
            raise _err(src, f"axes[{i}] (key = {key!r})", str(e)) from None
        if not isinstance(values, list) or not values:
            raise _err(src, f"axes[{i}].values", f"expected a non-empty array, got {values!r}")
        if key in [b.key for b in axes]:
            raise _err(src, f"axes[{i}].key", f"{key!r} is already axis {[b.key for b in axes].index(key)}")
        axes.append(Axis(key, values))
    if f.mode == "list" and len({len(a.values) for a in axes}) > 1:
        raise _err(src, "axes", f"mode = 'list' zips the axes: they need equal lengths, got "
                   f"{[len(a.values) for a in axes]}; give every axis as many values, or use mode = 'grid' "
                   "(every combination)")
    derived = _check_derived(src, f.derived, [a.key for a in axes])
    sweep = Sweep(src, base_data, base_source, base_dir, axes, f.mode, derived, f.title)
    _validate(sweep, fixed=bool(fixed))
    return sweep


def _validate(sweep: Sweep, fixed: bool = False) -> None:
    """Every combination as a scene; fills ``sweep.runs``; the derived columns' names checked
    against what every run will have (:func:`check_derived_names`)."""
    seen: dict = {}
    scenes: list = []
    for index, params in enumerate(sweep.combinations()):
        for i, a in enumerate(sweep.axes):  # a key path that cannot be set at all
            try:
                set_key(copy.deepcopy(sweep.base), a.key, params[a.key])
            except ValueError as e:
                raise _err(sweep.source, f"axes[{i}] (key = {a.key!r})",
                           f"{e}; the base scene is {sweep.base_source}{' with [set]' if fixed else ''}") from None
        try:
            scene = sweep.scene(params)
        except SceneError as e:
            text = str(e)
            named = [i for i, a in enumerate(sweep.axes) if _mentions(text, a.key)]
            where = (f"axes[{named[0]}] (key = {sweep.axes[named[0]].key!r}, value {params[sweep.axes[named[0]].key]!r})"
                     if named else "run " + str(index) + " (" + ", ".join(f"{k} = {v!r}" for k, v in params.items()) + ")")
            raise _err(sweep.source, where, text) from None
        data = scene.to_dict()
        run_id = run_id_of(data)
        if run_id in seen:
            raise _err(sweep.source, "axes", f"combinations {seen[run_id]} and {index} give the same scene "
                       f"({params}); remove the repeated value")
        seen[run_id] = index
        sweep.runs.append({"index": index, "id": run_id, "params": params, "scene": data})
        scenes.append(scene)
    check_derived_names(sweep, scenes)


#: Scene keys that do not change a run's results: left out of its id (changing them does not
#: run a finished sweep again).
RUN_OPTIONS = (("output", "checkpoint_every"), ("output", "checkpoint_seconds"))

#: Keys added to the resolved scene after sweeps were run, with their default: left out of a
#: run's id at that default, so the id of every earlier run stays what it was (a run that sets
#: another value gets another id). ``[contact] column_memory`` caps the compliance columns
#: (a capped run agrees with an uncapped one to round-off, which contact amplifies); ``[flow]
#: density`` is the air's (the flow rate's and the tract's; it was 1.2 fixed).
ADDED_KEYS = (("contact", "column_memory", 1024.0), ("flow", "density", 1.2))


def run_id_of(scene: dict) -> str:
    """The id of a run: the first 12 hex digits of the sha256 of its resolved scene (as a dict)
    without :data:`RUN_OPTIONS`, nor :data:`ADDED_KEYS` at their defaults."""
    import hashlib

    data = copy.deepcopy(scene)
    for section, key in RUN_OPTIONS:
        data.get(section, {}).pop(key, None)
    for section, key, default in ADDED_KEYS:
        table = data.get(section)
        if isinstance(table, dict) and table.get(key) == default:
            del table[key]
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:12]


def _mentions(text: str, key: str) -> bool:
    """Whether a scene error names the key path ``key`` (or a path inside or around it)."""
    paths = re.findall(r"[A-Za-z_][\w\[\]]*(?:\.[\w\[\]]+)+|[A-Za-z_]\w*(?=: )", text)
    return any(p == key or p.startswith(key + ".") or key.startswith(p + ".") for p in paths)


# ------------------------------------------------------------------------------------------
# One run (a task)
# ------------------------------------------------------------------------------------------

def _run_scene(scene: Scene, out: str):
    """The run of one task (a function of its own so tests can make it fail); its Result."""
    from .run import run

    return run(scene, out=out, progress=False)


def _reset_peak_rss() -> bool:
    """Resets this process's peak resident set size (Linux: ``5`` to /proc/self/clear_refs),
    so that the peak read after a run is the run's own, not an earlier task's in the same
    worker. False where that is not possible."""
    import gc

    gc.collect()
    with contextlib.suppress(OSError, AttributeError):  # give freed heap back (glibc), so it is not reused unseen
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def _rss_mb(field: str = "VmHWM") -> float | None:
    """This process's peak resident set size in MB since the last reset (``VmHWM``) or its
    resident set size now (``VmRSS``); None where /proc has neither."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(field + ":"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    return None


def _resume_run(out: str) -> None:
    """Continues the run in ``out`` from its checkpoint (a run taken over from a killed worker)."""
    from .run import resume

    resume(out, progress=False)


def _take_over(folder: str, tmp: str) -> str | None:
    """A ``<id>.tmp-<pid>`` folder of this run holding a checkpoint, left by a worker that died
    mid-run (no live process of this host writes there): renamed to ``tmp`` (atomic, so one
    task takes it), its old name returned; None if there is none."""
    from .checkpoint import CHECKPOINT
    from .output.reader import running

    parent, base = os.path.split(folder)
    for name in sorted(os.listdir(parent)):
        path = os.path.join(parent, name)
        if (not name.startswith(base + ".tmp-") or path == tmp or os.path.islink(path)
                or not os.path.exists(os.path.join(path, CHECKPOINT)) or running(path) is not None):
            continue
        try:
            os.rename(path, tmp)
        except OSError:  # another task took it first
            continue
        return name
    return None


def _flatten_summary(summary: dict) -> dict:
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


def _summary_value(summary: dict, key: str):
    section, _, rest = key.partition(".")
    if section not in summary:
        raise KeyError(f"summary has no section {section!r} (sections: {sorted(summary)})")
    items = summary[section]
    if rest not in items:
        raise KeyError(f"summary.{section} has no {rest!r}{suggest(rest, items)}")
    q = items[rest]
    v = q.get("value") if isinstance(q, dict) else q
    return math.nan if v is None else v


def _npz_lookup(path: str):
    """``key -> array`` of an .npz file, read on the first lookup (a derived column that reads
    nothing of it reads no file; a damaged one: :func:`vfrs.output.reader.read_npz`'s line)."""
    arrays: dict = {}

    def lookup(key):
        if not arrays:
            arrays.update(read_npz(path, _again(os.path.dirname(path))))
        return arrays[key]

    return lookup


def _again(folder: str) -> str:
    """What to do about a damaged file of a sweep's run folder."""
    return f"remove the folder {folder} and run the sweep again (that run then runs again)"


def _record(folder: str) -> dict:
    """A run folder's ``sweep_run.json``: a dict whose ``id`` is the folder's name (a record
    naming another id, e.g. a path, is refused: the id names the folder others read)."""
    path = os.path.join(folder, RUN_FILE)
    rec = read_json(path, _again(folder))
    if rec.get("id") != os.path.basename(os.path.normpath(folder)) or not isinstance(rec.get("params"), dict):
        raise VfrsError(f"{path}: names the run {rec.get('id')!r} (params {rec.get('params')!r}), not this folder's "
                        f"run; {_again(folder)}")
    return rec


def check_engine(serial: bool, workers, scheduler, scheduler_file) -> None:
    """The engine options of a sweep's command (vfrs sweep, vfrs converge, vfrs bench
    accuracy): --serial with no cluster options, --workers 1 or more; else VfrsError."""
    if serial and (scheduler or scheduler_file or workers):
        raise VfrsError("--serial runs in this process: give no --scheduler, --scheduler-file or --workers")
    if workers is not None and workers < 1:
        raise VfrsError(f"--workers {workers}: expected 1 or more")


def collect(folder: str, derived: dict) -> dict:
    """The table row of a finished run folder: its sweep record, summary and derived columns
    (a damaged file of the folder: one line naming it; the record's id must be the folder's)."""
    rec = _record(folder)
    row = {"id": rec["id"], **{k: v for k, v in rec["params"].items()}, "status": rec["status"],
           "error": rec.get("error"), "attempts": rec.get("attempts", 1), "wall_time [s]": rec.get("wall_time"),
           "peak_rss [MB]": rec.get("peak_rss_mb"), "vfrs code": (rec.get("vfrs") or {}).get("code")}
    summary: dict = {}
    path = os.path.join(folder, "summary.json")
    if os.path.exists(path):
        summary = read_json(path, _again(folder))
    history, probe = _npz_lookup(os.path.join(folder, "history.npz")), _npz_lookup(os.path.join(folder, "probes.npz"))
    names = {"summary": Namespace("summary", lambda k: _summary_value(summary, k)),
             "history": Namespace("history", history),
             "params": Namespace("params", lambda k: rec["params"][k]),
             "probes": Namespace("probes", probe)}
    for name, expr in derived.items():
        try:
            row[name] = evaluate(check_expression(expr), names) if rec["status"] == "complete" else None
        except Exception as e:  # a column that cannot be computed for this run: empty, and say why
            row[name] = None
            row.setdefault("derived_errors", "")
            row["derived_errors"] += f"{name}: {type(e).__name__}: {e}; "
    row.update(_flatten_summary(summary))
    return row


_CODE_ID: str | None = None


def code_id() -> str:
    """The vfrs build that runs here: the first 12 hex digits of the sha256 of the package's
    Python files and its compiled core (installed or editable alike). A run folder records
    the build that made it; a sweep skips a finished run only when the build is the same, so a
    table never mixes numbers of two builds without saying so (``vfrs code`` column)."""
    global _CODE_ID
    if _CODE_ID is None:
        import hashlib

        from ._version import __version__

        root = os.path.dirname(os.path.abspath(__file__))  # the package's folder
        h = hashlib.sha256(__version__.encode())
        files = []
        for d, dirs, names in os.walk(root):
            dirs[:] = sorted(x for x in dirs if x != "__pycache__")
            files += [os.path.join(d, n) for n in names if n.endswith((".py", ".so", ".pyd"))]
        for path in sorted(files):
            h.update(os.path.relpath(path, root).encode())
            with open(path, "rb") as fh:
                h.update(fh.read())
        _CODE_ID = h.hexdigest()[:12]
    return _CODE_ID


def read_run(folder: str) -> tuple[dict, dict]:
    """A finished task's folder read back: its ``sweep_run.json`` record (status, error,
    timings, peak memory, ...) and its history (a dict of arrays; empty for a failed run
    that recorded none)."""
    rec = _record(folder)
    path = os.path.join(folder, "history.npz")
    return rec, read_npz(path, _again(folder)) if os.path.exists(path) else {}


def own_time(timings: dict) -> float:
    """A run's own time from its clocks: vfrs's ``total`` less writing its output folder
    (fields, history, checkpoints), which the same run in memory does not do."""
    return float(timings.get("total", math.nan)) - timings.get("output", 0.0) - timings.get("checkpoint", 0.0)


def is_finished(folder: str, code: str | None = None) -> bool:
    """A run folder whose run completed (its manifest and sweep record say so); with
    ``code``, made by that vfrs build (:func:`code_id`)."""
    try:
        with open(os.path.join(folder, "manifest.json")) as fh:
            manifest = json.load(fh)
        rec = _record(folder)
    except (OSError, ValueError, AttributeError):  # missing or damaged (VfrsError): not finished, run again
        return False
    done = manifest.get("status") == "complete" and rec.get("status") == "complete"
    return done and (code is None or (rec.get("vfrs") or {}).get("code") == code)


def run_task(spec: dict) -> dict:
    """One run of a sweep, in a worker (or in this process with ``--serial``): runs the scene
    into ``runs/<id>.tmp-<pid>``, records status and error in ``sweep_run.json``, renames the
    folder to ``runs/<id>`` and returns its table row."""
    if spec.get("single_thread"):
        for var in THREAD_VARS:
            os.environ.setdefault(var, "1")  # read by rayon when its pool starts (the first run here)
    folder = os.path.join(spec["runs"], spec["id"])
    tmp = f"{folder}.tmp-{os.getpid()}"
    # The build is hashed before the run, as near as can be to when this process imported it: hashed
    # after, a file edited during the run would be recorded as the build that made its numbers.
    code = code_id()
    from .checkpoint import CheckpointError, RunStopped
    from .output.writer import OutputFolderError

    if os.path.exists(tmp):  # an earlier attempt in this same process
        shutil.rmtree(tmp)
    t0 = time.perf_counter()
    peak_is_own = _reset_peak_rss()
    rss_start = _rss_mb("VmRSS") if peak_is_own else None
    resumed = _take_over(folder, tmp)
    status, error, result, run_time = "complete", None, None, None
    try:
        if resumed is not None:
            try:
                _resume_run(tmp)  # from the dead worker's last checkpoint, bit-identical (docs/running.md)
            except (CheckpointError, OutputFolderError):  # it cannot be resumed: start again
                shutil.rmtree(tmp)
                resumed = None
        if resumed is None:
            os.makedirs(tmp)
            atomic_json(os.path.join(tmp, PARAMS_FILE), {"id": spec["id"], "index": spec["index"],
                                                         "params": spec["params"]})
            scene = Scene.from_dict(spec["scene"], source=spec["source"])
            t_run = time.perf_counter()
            result = _run_scene(scene, tmp)
            run_time = time.perf_counter() - t_run
    except RunStopped:  # SIGINT/SIGTERM (--serial): the folder keeps its checkpoint; the next sweep resumes it
        raise
    except Exception as exc:
        status, error = "failed", f"{type(exc).__name__}: {exc}"
        os.makedirs(tmp, exist_ok=True)
        with open(os.path.join(tmp, "error.txt"), "w") as fh:
            fh.write(traceback.format_exc())
    rec = {"id": spec["id"], "index": spec["index"], "params": spec["params"], "status": status, "error": error,
           "attempts": spec["attempt"], "wall_time": time.perf_counter() - t0, "host": socket.gethostname(),
           "pid": os.getpid(), "threads": {v: os.environ.get(v) for v in THREAD_VARS}, "resumed_from": resumed,
           # the run itself (vfrs.run, with its output), its clocks by effect and its peak memory:
           # what a cost report compares (None for a resumed run: its clocks are split)
           "run_time": run_time, "timings": dict(getattr(result, "timings", None) or {}) or None,
           "peak_rss_mb": _rss_mb() if peak_is_own else None, "rss_start_mb": rss_start,
           "vfrs": {"version": _version(), "code": code}}
    atomic_json(os.path.join(tmp, RUN_FILE), rec)
    if is_finished(folder, code):  # another attempt of this run finished meanwhile (a worker thought lost)
        shutil.rmtree(tmp)
    else:
        if os.path.exists(folder):  # an earlier failed attempt
            shutil.rmtree(folder)
        os.rename(tmp, folder)
    return collect(folder, spec["derived"])


# ------------------------------------------------------------------------------------------
# The sweep
# ------------------------------------------------------------------------------------------

@dataclass
class SweepResult:
    rows: list
    submitted: int
    skipped: int
    failed: int
    out: str
    #: ``(column, run id, error)`` of each derived value a completed run could not compute
    #: (the table's cell is empty, ``derived_errors`` says why): ``vfrs sweep`` exits 1
    derived_failed: list = field(default_factory=list)


def derived_failures(rows: list, derived: dict) -> list:
    """``(column, run id, error)`` of each derived value of a completed run that could not
    be computed (a run's failure leaves its derived cells empty without counting here)."""
    out = []
    for r in rows:
        if r.get("status") != "complete":
            continue
        for name in derived:
            if r.get(name) is None:
                why = [e for e in (r.get("derived_errors") or "").split("; ") if e.startswith(f"{name}: ")]
                out.append((name, r["id"], why[0][len(name) + 2:] if why else "no value"))
    return out


def _failures_text(failures: list, n_rows: int) -> str:
    """``3 derived values could not be computed: ratio in 2 of 4 runs (a1b2..., c3d4...: ZeroDivisionError: ...)``."""
    parts = []
    for name in dict.fromkeys(f[0] for f in failures):
        mine = [f for f in failures if f[0] == name]
        ids = ", ".join(f[1] for f in mine[:3]) + (", ..." if len(mine) > 3 else "")
        parts.append(f"{name} in {len(mine)} of {n_rows} runs ({ids}: {mine[0][2]})")
    n = len(failures)
    return (f"{n} derived value{'' if n == 1 else 's'} could not be computed: " + "; ".join(parts)
            + " - empty cells, the reasons in the derived_errors column")


def _failed_row(spec: dict, error: str) -> dict:
    return {"id": spec["id"], **spec["params"], "status": "failed", "error": error, "attempts": spec["attempt"],
            "wall_time [s]": None}


def run_sweep(sweep: Sweep | str, out, *, workers: int | None = None, scheduler: str | None = None,
              scheduler_file: str | None = None, retries: int = 1, serial: bool = False,
              log=None, progress: bool | None = None) -> SweepResult:
    """Runs every combination of ``sweep`` not finished in ``out`` yet; writes the summary table.

    ``serial``: in this process, one after another (no dask). Else on ``scheduler`` /
    ``scheduler_file`` (an existing dask cluster) or an embedded LocalCluster of ``workers``
    processes (default: the cores) with one thread each. ``progress``: dask's progress bar on
    stdout while the tasks run (default: when stdout is a terminal)."""
    if not isinstance(sweep, Sweep):
        sweep = load_sweep(sweep)
    if retries < 0:
        raise VfrsError(f"--retries {retries}: expected 0 or more")
    if scheduler and scheduler_file:
        raise VfrsError("give --scheduler or --scheduler-file, not both")
    log = log or (lambda msg: print(msg, file=sys.stderr, flush=True))
    out = os.fspath(out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise VfrsError(f"-o {out}: this is a file, not a folder")
    runs_dir = _runs_folder(out, sweep)
    if os.path.isfile(sweep.source):
        if os.path.abspath(sweep.source) != os.path.abspath(os.path.join(out, "sweep.toml")):
            with open(sweep.source, "rb") as fh:  # what this sweep was (replacing a link, never writing through it)
                atomic_write(os.path.join(out, "sweep.toml"), fh.read())
    else:  # built in Python (Sweep.from_runs): its runs' labels and ids
        atomic_json(os.path.join(out, "sweep.json"), {
            "source": sweep.source, "title": sweep.title, "derived": sweep.derived,
            "runs": [{"index": r["index"], "id": r["id"], "params": r["params"]} for r in sweep.runs]})
    rows: dict = {}
    todo = []
    code = code_id()
    other_build = 0
    for r in sweep.runs:
        folder = os.path.join(runs_dir, r["id"])
        if is_finished(folder, code):
            rows[r["index"]] = {**collect(folder, sweep.derived), "skipped": True}
        else:
            other_build += is_finished(folder)
            todo.append({**r, "runs": runs_dir, "source": f"{sweep.source} run {r['index']}", "derived": sweep.derived,
                         "attempt": 1, "single_thread": not serial})
    skipped = len(rows)
    log(f"sweep {sweep.source}: {len(sweep.runs)} runs, {skipped} finished before (skipped), {len(todo)} to run"
        + (f" ({other_build} of them finished by another vfrs build, run again with this one, {code})"
           if other_build else ""))
    done = [skipped]

    def finished(spec, row):
        ok = row["status"] == "complete"
        done[0] += ok or spec["attempt"] > retries
        params = ", ".join(f"{k} = {v!r}" for k, v in spec["params"].items())
        log(f"[{done[0]}/{len(sweep.runs)}] {spec['id']} {row['status']}"
            + (f" in {row['wall_time [s]']:.1f} s" if row.get("wall_time [s]") is not None else "")
            + f" ({params})" + ("" if ok else f": {row['error']}")
            + ("" if not row.get("derived_errors") else f"; derived {row['derived_errors'].rstrip('; ')}")
            + ("" if ok or spec["attempt"] > retries else f"; retry {spec['attempt']} of {retries}"))
        if not ok and spec["attempt"] <= retries:
            return {**spec, "attempt": spec["attempt"] + 1}
        rows[spec["index"]] = {**row, "skipped": False}
        return None

    try:
        if progress is None:
            progress = sys.stdout.isatty()
        submitted = _execute(todo, serial, workers, scheduler, scheduler_file, finished, log, progress)
    finally:  # also when interrupted: the table of the runs finished so far
        _remove_stale(runs_dir, rows.values())
        table = [rows[i] for i in sorted(rows)]
        write_table(table, out, summary_columns([a.key for a in sweep.axes], list(sweep.derived)))
    failed = sum(r["status"] != "complete" for r in table)
    bad = derived_failures(table, sweep.derived)
    log(f"wrote {os.path.join(out, 'summary.parquet')} and summary.csv: {len(table)} runs, {failed} failed"
        + (f"; {_failures_text(bad, len(table))}" if bad else ""))
    return SweepResult(table, submitted, skipped, failed, out, bad)


def _runs_folder(out: str, sweep: Sweep) -> str:
    """``out/runs``, created if missing; it and every run's folder there that exists must
    stay inside ``out`` (no symbolic link leading out: a sweep removes and replaces run
    folders), else an OutputFolderError before anything is touched."""
    from .errors import OutputFolderError

    runs_dir = os.path.join(out, "runs")
    for rel in ["runs"] + [f"runs/{r['id']}" for r in sweep.runs]:
        if os.path.lexists(os.path.join(out, rel)):
            inside(out, rel, f"{out} (the sweep's folder)", OutputFolderError)
    os.makedirs(runs_dir, exist_ok=True)
    return runs_dir


def _execute(todo: list, serial: bool, workers, scheduler, scheduler_file, finished, log, progress=False) -> int:
    """Runs the tasks (``finished(spec, row)`` returns the spec of a retry or None); returns
    how many tasks were submitted."""
    submitted = 0
    if todo and serial:
        queue = list(todo)
        while queue:
            spec = queue.pop(0)
            submitted += 1
            again = finished(spec, run_task(spec))
            if again:
                queue.append(again)
    elif todo:
        try:
            from distributed import Client, LocalCluster, as_completed
        except ImportError:
            raise VfrsError("vfrs sweep runs on dask.distributed: pip install 'dask[distributed]' (or use --serial)") \
                from None

        with contextlib.ExitStack() as stack:
            if scheduler or scheduler_file:
                client = stack.enter_context(Client(scheduler, scheduler_file=scheduler_file))
                if workers:
                    client.wait_for_workers(workers)
            else:
                n = workers or _cores()
                cluster = stack.enter_context(LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                                           env={v: "1" for v in THREAD_VARS}))
                client = stack.enter_context(Client(cluster))
            log(f"dask: {len(client.scheduler_info().get('workers', {}))} workers at {client.scheduler.address}; "
                f"dashboard {client.dashboard_link}" + ("" if _has_bokeh() else " (needs bokeh: pip install bokeh)"))
            specs = {}
            futures = []
            for spec in todo:
                f = client.submit(run_task, spec, key=f"vfrs-run-{spec['id']}-{spec['attempt']}", pure=False)
                specs[f.key] = spec
                futures.append(f)
                submitted += 1
            bar = _progress_bar(futures, client) if progress else None
            pending = as_completed(futures)
            for f in pending:
                spec = specs.pop(f.key)
                if f.status == "finished":
                    row = f.result()
                else:  # the task itself raised, or its workers died (KilledWorker)
                    exc = f.exception()
                    row = _failed_row(spec, f"{type(exc).__name__}: {exc}")
                f.release()
                again = finished(spec, row)
                if again:
                    g = client.submit(run_task, again, key=f"vfrs-run-{again['id']}-{again['attempt']}", pure=False)
                    specs[g.key] = again
                    pending.add(g)
                    submitted += 1
            if bar is not None:  # let the bar draw its last state before the cluster closes
                bar.join(timeout=5.0)
    return submitted


def _progress_bar(futures: list, client):
    """Dask's text progress bar of the first attempts, drawn on stdout by a thread of its own
    (the bar's ``listen`` blocks) while the sweep collects the results; retries are in the
    log lines."""
    import threading

    from distributed.diagnostics.progressbar import TextProgressBar

    def show():
        with contextlib.suppress(Exception):  # a bar that cannot draw must not stop the sweep
            TextProgressBar(futures, scheduler=client.scheduler.address, complete=True)

    thread = threading.Thread(target=show, name="vfrs-sweep-progress", daemon=True)
    thread.start()
    return thread


def _remove_stale(runs_dir: str, rows) -> None:
    """Removes the ``<id>.tmp-<pid>`` folders of runs that are finished now (left by a worker
    killed mid-run whose task then completed elsewhere); those of unfinished runs stay."""
    done = {r["id"] for r in rows if r["status"] == "complete"}
    for name in os.listdir(runs_dir):
        run_id, sep, _ = name.partition(".tmp-")
        if sep and run_id in done and is_finished(os.path.join(runs_dir, run_id)):
            shutil.rmtree(os.path.join(runs_dir, name), ignore_errors=True)


def _version() -> str:
    from ._version import __version__

    return __version__


def _cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _has_bokeh() -> bool:
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None


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
    import pyarrow as pa
    import pyarrow.parquet as pq

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


# ------------------------------------------------------------------------------------------
# Command line
# ------------------------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="vfrs sweep", description="Run a sweep of scenes (docs/sweeps.md) on "
                                 "dask.distributed: an embedded LocalCluster by default, or an existing cluster.")
    ap.add_argument("sweep", help="sweep file (.toml): base scene, axes, derived columns")
    ap.add_argument("-o", "--out", required=True, help="output folder: runs/<id>/ per run, summary.parquet/.csv")
    ap.add_argument("--workers", type=int, metavar="N", help="worker processes of the embedded cluster (default: the "
                    "cores); with --scheduler: wait for N workers")
    ap.add_argument("--scheduler", metavar="ADDR", help="an existing dask scheduler, e.g. tcp://host:8786")
    ap.add_argument("--scheduler-file", metavar="PATH", help="an existing dask cluster's scheduler file")
    ap.add_argument("--retries", type=int, default=1, metavar="N", help="retry a failed run up to N times (default 1)")
    ap.add_argument("--serial", action="store_true", help="no dask: the same tasks one after another in this process")
    ap.add_argument("--progress", dest="progress", action="store_true", default=None,
                    help="dask's progress bar on stdout (default: when stdout is a terminal)")
    ap.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    return ap


def main(argv=None) -> int:
    """``vfrs sweep SWEEP.toml -o OUT ...``; 0 when every run completed and gave every derived
    value, 1 when some run failed or a derived value could not be computed, 2 on an error in
    the sweep file or the options."""
    from .checkpoint import RunStopped

    args = build_parser().parse_args(argv)
    try:
        check_engine(args.serial, args.workers, args.scheduler, args.scheduler_file)
        res = run_sweep(args.sweep, args.out, workers=args.workers, scheduler=args.scheduler,
                        scheduler_file=args.scheduler_file, retries=args.retries, serial=args.serial,
                        progress=args.progress)
    except VfrsError as e:
        print(f"vfrs: error: {e}", file=sys.stderr)
        return 2
    except RunStopped as stop:  # --serial: the run in progress stopped with a checkpoint
        print(f"vfrs: {stop}; the finished runs are kept and the stopped one resumes from its checkpoint when the "
              "same command runs again", file=sys.stderr)
        return stop.exit_code
    except KeyboardInterrupt:
        print("vfrs: interrupted (finished runs are kept; run the same command again to continue)", file=sys.stderr)
        return 130
    return 1 if res.failed or res.derived_failed else 0


if __name__ == "__main__":
    # `python -m vfrs.sweep`: run the importable module's main, so that the tasks sent to the
    # workers are vfrs.sweep.run_task (imported there), not this __main__'s copy pickled by value
    from vfrs.sweep import main as _main

    sys.exit(_main())
