"""The sweep file: a base scene, the axes to vary (a grid or a list), fixed changes and derived
columns, read and checked as scenes before anything runs (:func:`load_sweep`, :class:`Sweep`);
a run's id (:func:`run_id_of`)."""

from __future__ import annotations

import copy
import difflib
import itertools
import json
import os
import re
from dataclasses import dataclass, field
from typing import Sequence

from ..._compat import tomllib
from ...errors import SceneError
from ...params import param, param_keys, read_params
from ...params.table import Table
from ...scene import Scene, read_toml
from ...scene.keypath import key_path, set_key
from ..derived import check_expression, references
from .table import summary_columns, summary_names

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

        >>> import vfrs, vfrs.studies.sweep as sw
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
        derived = check_derived(source, derived or {}, keys)
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


def check_derived(source: str, derived, axes: Sequence[str] = ()) -> dict:
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
    derived = check_derived(src, f.derived, [a.key for a in axes])
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
