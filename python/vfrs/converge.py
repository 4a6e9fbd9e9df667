"""``vfrs converge SCENE -o OUT``: how close a scene's numbers are, and what closer costs.

The scene runs at a ladder of time steps (``h``, ``h/2``, ``h/4``) and of meshes (the
generator's levels, ``coarse``, ``medium``, ``fine`` for the M5 folds; any other mesh refined
uniformly, ``refine = n``, ``n + 1``, ``n + 2``), every combination (a 3 x 3 grid), as one
sweep on the dask engine of :mod:`vfrs.sweep` (resumable: a finished run is not run again).
For every number of the summary, each row and each column of the grid is a three-run study
(:func:`vfrs.studies.verification.verify`: the observed order, the extrapolated value, the GCI, or,
when the runs are not in the asymptotic range, the band of the three values and the words
oscillatory / divergent). Each run's error is its step part (the study along the step at its
mesh) plus its mesh part (along the mesh at its step).

The folder holds ``runs/`` and ``summary.csv`` (the sweep's, one row per run), and:

- ``converge.csv`` / ``converge.parquet``: one row per quantity and study (``axis`` step or
  mesh, ``at`` the fixed level), with the three values, the kind, order, extrapolated value
  and the GCI of each run;
- ``errors.csv``: per run (mesh, step) and quantity, the value, its relative error (step and
  mesh parts, and whether either is only a band);
- ``converge.md`` and ``converge.txt`` (what ``vfrs converge`` prints): one line per quantity
  for the base run, ``peak contact force on right 24.6 mN +- 0.9 (3.6 %: step 0.2 %, mesh
  3.4 %) ...; the next mesh buys 2.1 % for 4.3x the time; halving the step buys 0.1 % for
  2.0x``, and the runs with their wall time and peak memory;
- ``converge.json``: all of it, read back by :func:`load` and by ``vfrs run --errors-from``;
- ``figures/<quantity>.png``: the value against the step (one line per mesh) and against the
  mesh size (one line per step), with the extrapolated values and their bands.

docs/converge.md explains the procedure, its assumptions and how to read the figures.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import sys
from dataclasses import dataclass, field

from .errors import VfrsError
from .studies.verification import Verification, axis_error, next_refinement, percent_text, verify

#: Levels of each ladder: three runs make a study (Celik et al.; docs/converge.md).
LEVELS = 3
#: What the step is divided by from one rung to the next.
STEP_RATIO = 2
CONVERGE_FILE = "converge.json"


# ------------------------------------------------------------------------------------------
# The ladders
# ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Rung:
    """One level of a ladder: ``name`` (``"medium"``, ``"refine 1"``, ``"h/2"``), its index
    from the coarsest (0), the key paths it sets (``changes``) and its size ``h`` (the step in
    seconds, or the mesh's representative element size in metres, filled in by :func:`plan`)."""

    name: str
    index: int
    changes: dict
    h: float = math.nan
    dofs: int | None = None


def _resolution_levels(data: dict) -> list | None:
    """The generator's levels (coarsest first) shared by every body's built-in mesh that is
    set by ``resolution`` (not by ``cells``), or None."""
    from .meshes import PARAMS

    levels = None
    for b in data["bodies"]:
        mesh = b["mesh"]
        if "builtin" not in mesh or "resolution" not in mesh or mesh.get("refine", 0):
            return None
        cls = PARAMS[mesh["builtin"]]
        meta = cls.__dataclass_fields__["resolution"].metadata
        choices = meta.get("choices")
        choices = list(choices() if callable(choices) else choices or ())
        sizes = [cls.from_dict({**{k: v for k, v in mesh.items() if k != "refine"}, "resolution": c}).estimate()
                 for c in choices]
        ordered = [c for _, c in sorted(zip([s[1] for s in sizes], choices))]  # by tetrahedra, coarsest first
        if levels is None:
            levels = ordered
        elif levels != ordered:
            return None
    return levels


def mesh_ladder(data: dict, levels: int = LEVELS, how: str = "auto") -> list:
    """The mesh rungs of a resolved scene (coarsest first). ``how``: ``"levels"`` (the
    generator's resolutions: every body built in, set by ``resolution``), ``"refine"`` (every
    body's mesh refined uniformly 0, 1, 2 more times than the scene says: 8 and 64 times the
    tetrahedra) or ``"auto"`` (levels where there are at least three, refinement otherwise).
    One level: the scene's own mesh."""
    if levels == 1:
        return [Rung("scene's mesh", 0, {})]
    names = _resolution_levels(data) if how in ("auto", "levels") else None
    if how == "levels" and (names is None or len(names) < levels):
        raise VfrsError("--meshes levels: every body must use a built-in mesh set by `resolution` (with at least "
                        f"{levels} levels); use --meshes refine for uniform refinement")
    n_bodies = len(data["bodies"])
    if names is not None and len(names) >= levels:
        base = data["bodies"][0]["mesh"]["resolution"]
        i = names.index(base)
        first = min(max(i - (levels - 1) // 2, 0), len(names) - levels)  # the base in the middle where it can be
        return [Rung(name, k, {f"bodies[{b}].mesh.resolution": name for b in range(n_bodies)})
                for k, name in enumerate(names[first:first + levels])]
    rungs = []
    for k in range(levels):
        changes = {f"bodies[{b}].mesh.refine": int(data["bodies"][b]["mesh"].get("refine", 0)) + k
                   for b in range(n_bodies)}
        rungs.append(Rung("scene's mesh" if k == 0 else f"refined {k}x", k, changes))
    return rungs


def step_ladder(data: dict, levels: int = LEVELS, ratio: int = STEP_RATIO) -> list:
    """The step rungs (coarsest first): the scene's step divided by 1, ``ratio``,
    ``ratio^2``; ``[output] every`` (and ``checkpoint_every``) multiplied alike, so the fields
    are written at the same times. A static scene, or ``levels = 1``: the scene's step only."""
    time = data.get("time", {})
    if levels == 1 or time.get("mode") != "dynamic":
        return [Rung("scene's step", 0, {})]
    h = float(time["step"])
    out = data.get("output", {})
    rungs = []
    for k in range(levels):
        f = ratio ** k
        changes: dict = {"time.step": h / f}
        if k and "every" in out:
            changes["output.every"] = int(out["every"]) * f
        if k and int(out.get("checkpoint_every", 0) or 0):
            changes["output.checkpoint_every"] = int(out["checkpoint_every"]) * f
        rungs.append(Rung("h" if k == 0 else f"h/{f}", k, changes, h / f))
    return rungs


@dataclass
class Plan:
    """The runs of a study: ``meshes`` and ``steps`` (rungs, coarsest first), the base
    rungs' indices and, per run, its labels and scene (a dict). ``runs`` are in the order
    they are submitted: the most expensive first (the sweep's wall time is the longest run's
    when it starts first)."""

    scene: dict
    source: str
    meshes: list
    steps: list
    base_mesh: int
    base_step: int
    runs: list = field(default_factory=list)

    def label(self, i: int, j: int) -> dict:
        return {"mesh": self.meshes[i].name, "step": self.steps[j].name}


def representative_size(data: dict, source: str) -> tuple:
    """(representative element size ``(V / n_tets)^(1/3)`` over all bodies, DOFs) of a scene."""
    from .scene import Scene

    meshes = Scene.from_dict(copy.deepcopy(data), source=source).build_meshes()
    volume = sum(abs(m.volume) for m in meshes)
    tets = sum(m.n_tets for m in meshes)
    return (volume / tets) ** (1.0 / 3.0), sum(m.n_dofs for m in meshes)


def plan(scene, *, steps: int = LEVELS, meshes: int = LEVELS, mesh_how: str = "auto", source: str | None = None) -> Plan:
    """The ladders and runs of a study of ``scene`` (a :class:`~vfrs.scene.Scene` or a
    resolved scene dict). ``steps`` / ``meshes``: 3 (a study along that axis) or 1 (the
    scene's own step or mesh only)."""
    from .scene import Scene
    from .scene.keypath import set_key

    for what, n in (("--steps", steps), ("--meshes", meshes)):
        if n not in (1, LEVELS):
            raise VfrsError(f"{what} {n}: a study takes {LEVELS} levels (or 1: not along this axis)")
    if isinstance(scene, Scene):
        source = source or scene.source
        data = scene.to_dict()
    else:
        data = copy.deepcopy(scene)
        source = source or "<dict>"
    m_rungs = mesh_ladder(data, meshes, mesh_how)
    s_rungs = step_ladder(data, steps)
    if len(m_rungs) == 1 and len(s_rungs) == 1:
        raise VfrsError(f"{source}: nothing to study: a static scene has no step ladder, and --meshes 1 leaves no "
                        "mesh ladder")
    sized = []
    for r in m_rungs:
        d = copy.deepcopy(data)
        for k, v in r.changes.items():
            set_key(d, k, v)
        h, dofs = representative_size(d, source)
        sized.append(Rung(r.name, r.index, r.changes, h, dofs))
    base_step = 0
    base_mesh = next((r.index for r in sized if all(_get(data, k) == v for k, v in r.changes.items())), 0)
    p = Plan(data, source, sized, s_rungs, base_mesh, base_step)
    order = sorted(((i, j) for i in range(len(sized)) for j in range(len(s_rungs))),
                   key=lambda ij: -(sized[ij[0]].dofs or 0) * STEP_RATIO ** ij[1])
    for i, j in order:
        d = copy.deepcopy(data)
        for k, v in {**sized[i].changes, **s_rungs[j].changes}.items():
            set_key(d, k, v)
        p.runs.append({"mesh_level": i, "step_level": j, "labels": p.label(i, j), "scene": d})
    return p


def _get(data: dict, path: str):
    """The value at a key path of a resolved scene; a mesh's ``refine``, left out at 0, is 0."""
    from .scene.keypath import key_path

    node = data
    for part in key_path(path):
        try:
            node = node[part]
        except (KeyError, IndexError, TypeError):
            return 0 if path.endswith(".mesh.refine") else None
    return node


# ------------------------------------------------------------------------------------------
# The studies
# ------------------------------------------------------------------------------------------

@dataclass
class Quantity:
    """A number of the summary: its column in the sweep's table, section, key, unit, what."""

    column: str
    section: str
    key: str
    unit: str
    what: str
    #: below this size (SI) the value is round-off (the summary's ``roundoff``): taken as 0
    roundoff: float | None = None

    @property
    def name(self) -> str:
        return f"{self.section}.{self.key}"


def _quantities(summary: dict) -> list:
    out = []
    for section, items in summary.items():
        if section in ("run", "window", "notes") or not isinstance(items, dict):
            continue
        for key, q in items.items():
            if isinstance(q, dict) and "value" in q:
                unit = q.get("unit") or "1"
                col = f"{section}.{key}" + (f" [{unit}]" if unit != "1" else "")
                out.append(Quantity(col, section, key, unit, str(q.get("what") or key), q.get("roundoff")))
    return out


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


@dataclass
class Study:
    """One quantity along one axis at a fixed level of the other: ``axis`` ("step" or
    "mesh"), ``at`` (the other axis's rung index), the three ``values`` (coarsest first, None
    where a run has none), ``h`` (coarsest first) and the :class:`Verification` (None when a
    value is missing)."""

    quantity: str
    axis: str
    at: int
    values: list
    h: list
    verification: Verification | None

    def error(self, level: int) -> tuple:
        """(relative error of the run at ``level`` (0: coarsest), is it a bound): the GCI of
        that run when the study is monotone (Celik's GCI21 for the finest, GCI32 for the
        middle one, Roache's coarse-grid form for the coarsest), 0 when converged to
        round-off, else the band of the three values about it (not a bound: False)."""
        v = self.verification
        if v is None:
            return math.nan, False
        value = self.values[level]
        part = axis_error(v, LEVELS - 1 - level)
        if part.gci is not None:
            return float(part.gci), part.bound
        band = max(-part.low, part.high)
        return (band / abs(value) if value else math.inf), part.bound

    def to_row(self) -> dict:
        v = self.verification
        row = {"quantity": self.quantity, "axis": self.axis, "at": self.at,
               **{f"value {k}": x for k, x in enumerate(self.values)}, **{f"h {k}": x for k, x in enumerate(self.h)},
               "kind": "missing" if v is None else v.kind}
        if v is not None:
            row.update(order=v.order, extrapolated=v.extrapolated, gci_finest=v.gci_fine, gci_middle=v.gci_medium,
                       gci_coarsest=v.gci_coarse, asymptotic_ratio=v.asymptotic_ratio, low=v.low, high=v.high,
                       words=v.words)
        return row


def _study(q: Quantity, axis: str, at: int, values: list, h: list) -> Study:
    ver = None
    if all(_finite(x) for x in values) and len(values) == LEVELS:
        ver = verify(list(reversed(values)), list(reversed(h)))
    return Study(q.name, axis, at, values, h, ver)


@dataclass
class ConvergeResult:
    """A study's outcome: the plan, the table of runs (``grid[i][j]``: the row of mesh ``i``,
    step ``j``), the quantities and their studies, each run's errors, the text."""

    plan: Plan
    grid: list
    quantities: list
    studies: list
    errors: list
    out: str | None = None
    failed: int = 0

    def studies_of(self, name: str) -> list:
        return [s for s in self.studies if s.quantity == name]

    def study(self, name: str, axis: str, at: int) -> Study | None:
        return next((s for s in self.studies if s.quantity == name and s.axis == axis and s.at == at), None)

    def error(self, name: str, i: int, j: int) -> dict:
        """The error of quantity ``name`` on the run of mesh ``i`` and step ``j``: ``relative``
        (step part + mesh part), ``step`` and ``mesh`` (each None without that axis),
        ``bound`` (both parts are GCIs, not bands)."""
        return next(e for e in self.errors if e["quantity"] == name and e["mesh_level"] == i and e["step_level"] == j)

    def lines(self) -> list:
        return _lines(self)

    def text(self) -> str:
        return "\n".join(self.lines())


def _run_value(row: dict | None, q: Quantity):
    if row is None or row.get("status") != "complete":
        return None
    v = row.get(q.column)
    if not (isinstance(v, (int, float)) and _finite(v)):
        return None
    return 0.0 if q.roundoff is not None and abs(v) < q.roundoff else float(v)  # round-off: zero


def analyse(p: Plan, grid: list, quantities: list) -> tuple:
    """(studies, errors) of every quantity: each column of the grid along the step, each row
    along the mesh, and per run its step part plus its mesh part."""
    studies, errors = [], []
    nm, ns = len(p.meshes), len(p.steps)
    for q in quantities:
        vals = [[_run_value(grid[i][j], q) for j in range(ns)] for i in range(nm)]
        along_step = {i: _study(q, "step", i, vals[i], [r.h for r in p.steps]) for i in range(nm)} if ns == LEVELS else {}
        along_mesh = ({j: _study(q, "mesh", j, [vals[i][j] for i in range(nm)], [r.h for r in p.meshes])
                       for j in range(ns)} if nm == LEVELS else {})
        studies += list(along_step.values()) + list(along_mesh.values())
        for i in range(nm):
            for j in range(ns):
                e_step, b_step = along_step[i].error(j) if i in along_step else (None, True)
                e_mesh, b_mesh = along_mesh[j].error(i) if j in along_mesh else (None, True)
                parts = [e for e in (e_step, e_mesh) if e is not None]
                errors.append({"quantity": q.name, "mesh_level": i, "step_level": j, "mesh": p.meshes[i].name,
                               "step": p.steps[j].name, "value": vals[i][j],
                               "relative": sum(parts) if parts and vals[i][j] is not None else None,
                               "step_part": e_step, "mesh_part": e_mesh, "bound": bool(b_step and b_mesh)})
    return studies, errors


# ------------------------------------------------------------------------------------------
# Words
# ------------------------------------------------------------------------------------------

def _display(unit: str) -> tuple:
    from .analysis import DISPLAY

    return DISPLAY.get(unit, (1.0, "" if unit == "1" else unit))


def _pct(x) -> str:
    """A relative error (a fraction) in percent, as :mod:`vfrs.studies.verification` prints them."""
    return "n/a" if x is None else percent_text(100 * x)


def _num(v: float, dv: float | None = None) -> str:
    """``v`` to the decimal of ``dv``'s second significant digit (4 significant digits at
    most); without ``dv``, 4 significant digits."""
    if dv is None or not (math.isfinite(dv) and dv > 0 and math.isfinite(v)) or v == 0 or not 1e-3 <= abs(v) < 1e5:
        return f"{v:.4g}"
    decimals = 1 - math.floor(math.log10(dv))
    if decimals + math.floor(math.log10(abs(v))) + 1 > 4:
        return f"{v:.4g}"
    return f"{v:.{max(decimals, 0)}f}" if decimals >= 0 else f"{round(v, decimals):.0f}"


def _err_text(dv: float) -> str:
    """An error to two significant digits."""
    if not math.isfinite(dv):
        return "n/a"
    return f"{dv:.0f}" if 100 <= abs(dv) < 1e5 else f"{dv:.2g}"


def _secs(t: float) -> str:
    return "n/a" if not math.isfinite(t) else f"{t:.2g}" if t < 10 else f"{t:.0f}"


def _time_of(row: dict | None) -> float:
    v = None if row is None else row.get("wall_time [s]")
    return float(v) if isinstance(v, (int, float)) and _finite(v) else math.nan


def _quantity_line(res: ConvergeResult, q: Quantity) -> str:
    p = res.plan
    i, j = p.base_mesh, p.base_step
    e = res.error(q.name, i, j)
    factor, unit = _display(q.unit)
    u = f" {unit}" if unit else ""
    if e["value"] is None:
        return f"{q.what}: no value on the base run"
    v = e["value"]
    rel = e["relative"]
    parts = []
    if e["step_part"] is not None:
        parts.append(f"step {_pct(e['step_part'])} %")
    if e["mesh_part"] is not None:
        parts.append(f"mesh {_pct(e['mesh_part'])} %")
    abs_err = None if rel is None or not math.isfinite(rel) else rel * abs(v) * factor
    kinds = [s.verification.kind for s in (res.study(q.name, "step", i), res.study(q.name, "mesh", j))
             if s is not None and s.verification is not None]
    if rel == 0.0 and all(x == v for x in (_run_value(r, q) for row in res.grid for r in row) if x is not None):
        return f"{q.what} {_num(v * factor)}{u} on every run" + (" (round-off)" if q.roundoff is not None else "")
    if rel == 0.0:
        head = f"{q.what} {_num(v * factor)}{u}: converged to round-off"
    else:
        head = (f"{q.what} {_num(v * factor, abs_err)}{u} +- {_err_text(abs_err) if abs_err is not None else 'n/a'} "
                f"({_pct(rel)} %" + (": " + ", ".join(parts) if len(parts) > 1 else "") + ")")
        if not e["bound"]:
            bad = sorted({k for k in kinds if k in ("oscillatory", "divergent")})
            head += f", the band of the runs, not an error bound ({' and '.join(bad) or 'missing values'})"
    if q.section == "phonation" or q.key.startswith(("contact_duration", "contact_quotient", "contact_impulse")):
        rows = [r for row in res.grid for r in row if r is not None and r.get("status") == "complete"]
        flags = [r.get("window.periodic") for r in rows]
        aperiodic = sum(f is False or f in ("False", "false") for f in flags)
        if aperiodic:
            head += f"; over cycles that do not repeat in {aperiodic} of {len(rows)} runs"
    costs = []
    if i + 1 < len(p.meshes):
        s = res.study(q.name, "mesh", j)
        nxt = _run_value(res.grid[i + 1][j], q)
        if nxt is not None:
            lim = s.verification.extrapolated if s and s.verification and s.verification.kind == "monotone" else None
            c = next_refinement(v, nxt, _time_of(res.grid[i][j]), _time_of(res.grid[i + 1][j]), "mesh", lim)
            costs.append(c.text())
    if j + 1 < len(p.steps):
        s = res.study(q.name, "step", i)
        nxt = _run_value(res.grid[i][j + 1], q)
        if nxt is not None:
            lim = s.verification.extrapolated if s and s.verification and s.verification.kind == "monotone" else None
            c = next_refinement(v, nxt, _time_of(res.grid[i][j]), _time_of(res.grid[i][j + 1]), "step", lim)
            costs.append(c.text())
    return head + ("; " + "; ".join(costs) if costs else "")


#: The errors a study recommends a run for (relative).
TARGETS = (0.10, 0.05, 0.02)


def recommend(res: ConvergeResult, name: str, target: float) -> dict | None:
    """The cheapest run (wall time) of the study whose estimated error of quantity ``name`` is
    a bound (both parts GCIs of monotone studies, or round-off) no larger than ``target``:
    {"mesh_level", "step_level", "error", "time", "confirmed"}, or None. ``confirmed``: the
    runs one level finer in mesh and in step (those the grid has) lie within the recommended
    run's band ``value +- error |value|``; None when it has no finer neighbour."""
    best = None
    for e in res.errors:
        if e["quantity"] != name or e["relative"] is None or not e["bound"] or not math.isfinite(e["relative"]):
            continue
        if e["relative"] > target:
            continue
        t = _time_of(res.grid[e["mesh_level"]][e["step_level"]])
        if best is None or t < best["time"]:
            best = {"mesh_level": e["mesh_level"], "step_level": e["step_level"], "error": e["relative"], "time": t,
                    "value": e["value"]}
    if best is None:
        return None
    i, j = best["mesh_level"], best["step_level"]
    q = next(q for q in res.quantities if q.name == name)
    finer = [_run_value(res.grid[a][b], q) for a, b in ((i + 1, j), (i, j + 1))
             if a < len(res.plan.meshes) and b < len(res.plan.steps)]
    band = best["error"] * abs(best["value"])
    best["confirmed"] = (None if not finer else
                         all(v is not None and abs(v - best["value"]) <= band * (1 + 1e-12) for v in finer))
    return best


def _recommendation_line(res: ConvergeResult, q: Quantity) -> str:
    p = res.plan
    parts = []
    for target in TARGETS:
        r = recommend(res, q.name, target)
        if r is None:
            parts.append(f"{target:.0%}: none of these runs")
            continue
        label = p.label(r["mesh_level"], r["step_level"])
        conf = {True: "confirmed by the finer runs", False: "NOT confirmed by the finer runs",
                None: "the finest run, unconfirmed"}[r["confirmed"]]
        parts.append(f"{target:.0%}: {label['mesh']} {label['step']} ({_pct(r['error'])} %, {_secs(r['time'])} s; {conf})")
    return f"{q.what}: " + "; ".join(parts)


def _recommendation_lines(res: ConvergeResult) -> list:
    """A line per number some run meets a target for; one line naming the others."""
    lines, none = [], []
    for q in res.quantities:
        values = [_run_value(r, q) for row in res.grid for r in row]
        if all(x is not None and x == values[0] for x in values):
            continue  # the same on every run (zero penetration): nothing to recommend
        if recommend(res, q.name, max(TARGETS)) is None:
            none.append(q.what)
        else:
            lines.append("  " + _recommendation_line(res, q))
    if none:
        lines.append(f"  none of these runs is within {max(TARGETS):.0%} by a bound for: " + ", ".join(none))
    return lines


def projected_wall(times: list, workers: int) -> float:
    """The wall time of runs taking ``times`` (s, each on one core) on ``workers`` workers,
    longest first, each to the worker free first (the order :func:`plan` submits them in;
    dask's start-up and the runs slowing each other on shared cores left out)."""
    free = [0.0] * max(int(workers), 1)
    for t in sorted((t for t in times if math.isfinite(t)), reverse=True):
        k = free.index(min(free))
        free[k] += t
    return max(free)


def _lines(res: ConvergeResult) -> list:
    p = res.plan
    base = p.label(p.base_mesh, p.base_step)
    lines = [f"converge {p.source}: {len(p.meshes)} mesh(es) x {len(p.steps)} step(s), base run: mesh "
             f"{base['mesh']}, step {base['step']}"
             + (f" = {p.steps[p.base_step].h * 1e6:.4g} us" if math.isfinite(p.steps[p.base_step].h) else "")]
    lines.append("each number of the base run, +- its estimated error (step part + mesh part; GCI, Fs = 1.25); "
                 "what the next refinement buys (closer to the extrapolated value) and costs (wall time):")
    for q in res.quantities:
        lines.append("  " + _quantity_line(res, q))
    lines.append("the cheapest run whose error is within " + " / ".join(f"{t:.0%}" for t in TARGETS)
                 + " (a bound: GCIs of monotone studies):")
    lines += _recommendation_lines(res)
    lines.append("runs (mesh, step, representative element size, DOFs, wall time, peak memory):")
    for i, m in enumerate(p.meshes):
        for j, s in enumerate(p.steps):
            row = res.grid[i][j] or {}
            rss = row.get("peak_rss [MB]")
            lines.append(f"  {m.name:>14} {s.name:>5}  h = {m.h * 1e3:.3g} mm  {m.dofs} DOFs  "
                         f"{_secs(_time_of(row))} s  " + (f"{rss:.0f} MB" if _finite(rss) else "memory n/a")
                         + ("" if row.get("status") == "complete" else f"  {row.get('status', 'not run')}"))
    times = [_time_of(r) for row in res.grid for r in row]
    if any(math.isfinite(t) for t in times):
        total = sum(t for t in times if math.isfinite(t))
        lines.append(f"cost: {total:.0f} s of run time in all; on 2 / 8 / 32 workers at least "
                     + " / ".join(f"{projected_wall(times, w):.0f}" for w in (2, 8, 32))
                     + " s (longest first; projected from these run times, which include the slowdown of the "
                     "runs sharing this machine's cores)")
    return lines


# ------------------------------------------------------------------------------------------
# Running a study
# ------------------------------------------------------------------------------------------

def converge(scene, out, *, steps: int = LEVELS, meshes: int = LEVELS, mesh_how: str = "auto",
             quantities: dict | None = None, workers: int | None = None, scheduler: str | None = None, scheduler_file: str | None = None,
             serial: bool = False, retries: int = 1, figures: bool = True, log=None,
             progress: bool | None = None) -> ConvergeResult:
    """Runs the study of ``scene`` (a Scene, a resolved scene dict or a scene file) into the
    folder ``out`` (finished runs of the same vfrs build are not run again) and writes its
    tables, text and figures. ``quantities``: more numbers to study besides the summary's,
    name = expression in the language of a sweep's derived columns (docs/sweeps.md), e.g.
    ``{"tip_uz": 'last(probes["probe_0.displacement"])[2]'}``. The other options are those of
    :func:`vfrs.sweep.run_sweep`."""
    from .scene import Scene
    from .sweep import Sweep, run_sweep

    if isinstance(scene, (str, os.PathLike)):
        scene = Scene.load(scene)
    p = plan(scene, steps=steps, meshes=meshes, mesh_how=mesh_how)
    out = os.fspath(out)
    sweep = Sweep.from_runs(f"converge {p.source}", [(r["labels"], r["scene"]) for r in p.runs],
                            derived=quantities, title=f"converge {p.source}")
    res = run_sweep(sweep, out, workers=workers, scheduler=scheduler, scheduler_file=scheduler_file, retries=retries,
                    serial=serial, log=log, progress=progress)
    return finish(p, res.rows, out, figures=figures, failed=res.failed, derived=quantities)


def finish(p: Plan, rows: list, out: str | None, *, figures: bool = True, failed: int = 0,
           derived: dict | None = None) -> ConvergeResult:
    """The studies of a plan's finished runs (the sweep's rows, in the plan's order) and,
    with ``out``, the files; ``derived``: the quantities given as expressions (their columns)."""
    grid: list = [[None] * len(p.steps) for _ in p.meshes]
    by_labels = {(r.get("mesh"), r.get("step")): r for r in rows}
    for r in p.runs:
        grid[r["mesh_level"]][r["step_level"]] = by_labels.get((r["labels"]["mesh"], r["labels"]["step"]))
    quantities = []
    if out is not None:
        for r in p.runs:  # the quantities of the first finished run's summary
            row = grid[r["mesh_level"]][r["step_level"]]
            path = os.path.join(out, "runs", row["id"], "summary.json") if row else None
            if path and row.get("status") == "complete" and os.path.exists(path):
                with open(path) as fh:
                    quantities = _quantities(json.load(fh))
                break
    quantities += [Quantity(name, "derived", name, "1", f"{name} = {expr}") for name, expr in (derived or {}).items()]
    studies, errors = analyse(p, grid, quantities)
    res = ConvergeResult(p, grid, quantities, studies, errors, out, failed)
    if out is not None:
        write(res, out, figures=figures)
    return res


def scene_key(data: dict) -> str:
    """The id of a scene up to its step, its mesh level and its output intervals (what a
    study varies): a run of the same scene at any rung of the study has the same key."""
    from .sweep import run_id_of

    d = copy.deepcopy(data)
    d.get("time", {}).pop("step", None)
    for key in ("every", "checkpoint_every"):
        d.get("output", {}).pop(key, None)
    for b in d.get("bodies", []):
        b.get("mesh", {}).pop("resolution", None)
        b.get("mesh", {}).pop("refine", None)
    return run_id_of(d)


def write(res: ConvergeResult, out: str, *, figures: bool = True) -> list:
    """converge.csv/.parquet, errors.csv, converge.md/.txt/.json and the figures; the paths."""
    from .checkpoint import atomic_json
    from .sweep import write_table

    p = res.plan
    written = []
    write_table([s.to_row() for s in res.studies], out, ["quantity", "axis", "at", "kind"], name="converge")
    write_table(res.errors, out, ["quantity", "mesh", "step", "value", "relative", "step_part", "mesh_part", "bound"],
                name="errors")
    written += [os.path.join(out, n) for n in ("converge.parquet", "converge.csv", "errors.parquet", "errors.csv")]
    text = res.text()
    with open(os.path.join(out, "converge.txt"), "w") as fh:
        fh.write(text + "\n")
    with open(os.path.join(out, "converge.md"), "w") as fh:
        fh.write(markdown(res))
    atomic_json(os.path.join(out, CONVERGE_FILE), {
        "source": p.source, "scene_key": scene_key(p.scene),
        "meshes": [{"name": r.name, "index": r.index, "changes": r.changes, "h": r.h, "dofs": r.dofs} for r in p.meshes],
        "steps": [{"name": r.name, "index": r.index, "changes": r.changes, "h": r.h} for r in p.steps],
        "base": {"mesh": p.base_mesh, "step": p.base_step},
        "runs": [_run_record(r, res.grid[r["mesh_level"]][r["step_level"]]) for r in p.runs],
        "quantities": [q.__dict__ for q in res.quantities],
        "studies": [s.to_row() for s in res.studies],
        "errors": res.errors, "text": res.lines()})
    written += [os.path.join(out, n) for n in ("converge.txt", "converge.md", CONVERGE_FILE)]
    if figures and res.quantities:
        written += draw(res, os.path.join(out, "figures"))
    return written


def _run_record(run: dict, row: dict | None) -> dict:
    """A run of the plan as converge.json lists it: its rungs, labels, id, wall time, memory."""
    return {"mesh_level": run["mesh_level"], "step_level": run["step_level"], **run["labels"],
            "id": (row or {}).get("id"), "wall_time": _time_of(row), "peak_rss_mb": (row or {}).get("peak_rss [MB]")}


def markdown(res: ConvergeResult) -> str:
    """converge.md: the base run's numbers with their errors, the studies, the runs."""
    p = res.plan
    lines = ["# Converge study", "", "```text", *res.lines(), "```", "",
             "| quantity | axis | at | values (coarsest first) | kind | order | extrapolated | GCI finest | GCI coarsest |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    units = {q.name: q.unit for q in res.quantities}
    for s in res.studies:
        factor, unit = _display(units.get(s.quantity, "1"))
        v = s.verification
        at = (p.meshes if s.axis == "step" else p.steps)[s.at].name
        vals = " / ".join("n/a" if x is None else f"{x * factor:.4g}" for x in s.values) + (f" {unit}" if unit else "")
        kind = "missing" if v is None else v.kind
        order = "" if v is None or v.order is None else f"{v.order:.2f}"
        ext = "" if v is None or v.extrapolated is None else f"{v.extrapolated * factor:.4g}"
        g1 = "" if v is None or v.gci_fine is None else f"{_pct(v.gci_fine)} %"
        g3 = "" if v is None or v.gci_coarse is None else f"{_pct(v.gci_coarse)} %"
        lines.append(f"| {s.quantity} | {s.axis} | {at} | {vals} | {kind} | {order} | {ext} | {g1} | {g3} |")
    return "\n".join(lines) + "\n"


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in name)


def draw(res: ConvergeResult, folder: str) -> list:
    """One PNG per quantity: the value against the step (a line per mesh) and against the
    mesh's element size (a line per step), with each monotone study's extrapolated value and
    GCI band at h = 0; the paths."""
    from .plot import require_matplotlib

    plt = require_matplotlib()
    os.makedirs(folder, exist_ok=True)
    p = res.plan
    paths = []
    for q in res.quantities:
        factor, unit = _display(q.unit)
        axes_of = [a for a, n in (("step", len(p.steps)), ("mesh", len(p.meshes))) if n == LEVELS]
        fig, axes = plt.subplots(1, len(axes_of), figsize=(5.2 * len(axes_of), 3.8), squeeze=False)
        for ax, axis in zip(axes[0], axes_of):
            rungs, others = (p.steps, p.meshes) if axis == "step" else (p.meshes, p.steps)
            scale = 1e6 if axis == "step" else 1e3
            for k, other in enumerate(others):
                s = res.study(q.name, axis, k)
                if s is None:
                    continue
                xs = [r.h * scale for r in rungs]
                ys = [math.nan if v is None else v * factor for v in s.values]
                line, = ax.plot(xs, ys, "o-", label=f"{other.name}" + (f" ({s.verification.kind})" if s.verification else ""))
                v = s.verification
                if v is not None and v.kind == "monotone" and v.extrapolated is not None:
                    ax.errorbar([0.0], [v.extrapolated * factor], yerr=[[abs(v.value - v.low) * factor]],
                                fmt="s", color=line.get_color(), capsize=3, alpha=0.8)
                    ax.plot([0.0, xs[-1]], [v.extrapolated * factor, ys[-1]], ":", color=line.get_color())
            ax.set_xlim(left=0)
            ax.set_xlabel("time step [us]" if axis == "step" else "element size (V / n_tets)^(1/3) [mm]")
            ax.set_ylabel(f"{q.what}" + (f" [{unit}]" if unit else ""), fontsize=8)
            ax.set_title(f"along the {axis}" + (" (one line per mesh)" if axis == "step" else " (one line per step)"),
                         fontsize=9)
            ax.legend(fontsize=7)
        fig.suptitle(f"{q.name}: squares at 0 = extrapolated value +- GCI of the finest run", fontsize=9)
        fig.tight_layout()
        path = os.path.join(folder, f"{_slug(q.name)}.png")
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths


# ------------------------------------------------------------------------------------------
# Reading a study back: error bars of a single run
# ------------------------------------------------------------------------------------------

def load(out) -> dict:
    """``converge.json`` of a study folder, or VfrsError saying what is missing."""
    path = os.path.join(os.fspath(out), CONVERGE_FILE)
    try:
        with open(path) as fh:
            return json.load(fh)
    except FileNotFoundError:
        raise VfrsError(f"{out}: no {CONVERGE_FILE} here: run `vfrs converge SCENE -o {out}` first") from None
    except ValueError as e:
        raise VfrsError(f"{path}: cannot be read ({e}); run `vfrs converge` into the folder again") from None


def errors_for(scene_dict: dict, study: dict) -> dict | None:
    """The errors a study (``converge.json`` as read by :func:`load`) gives a run of
    ``scene_dict`` (a resolved scene): {quantity: error row} when the scene is the study's up
    to its step and mesh and sits on one of its rungs, else None."""
    if scene_key(scene_dict) != study.get("scene_key"):
        return None

    def on(rungs):
        for r in rungs:
            if all(_get(scene_dict, k) == v for k, v in r["changes"].items()):
                return r["index"]
        return None

    i, j = on(study["meshes"]), on(study["steps"])
    if i is None or j is None:
        return None
    return {e["quantity"]: e for e in study["errors"] if e["mesh_level"] == i and e["step_level"] == j}


def with_study_errors(summary, scene_dict: dict, folder):
    """``summary`` (a run's :class:`vfrs.analysis.Summary`) with each number's error from the
    converge study in ``folder`` (step part + mesh part at the run's own rungs); every number
    unknown, and a note saying why, when the study is of another scene or the run's step or
    mesh is not one of its rungs."""
    study = load(folder)
    errors = errors_for(scene_dict, study)
    folder = display_path(folder)
    source = f"the converge study in {folder} (step part + mesh part, GCI with Fs = 1.25)"
    if errors is not None:
        return summary.with_errors(errors, source)
    return summary.with_errors({}, folder, f"unknown: {why_not(scene_dict, study)}")


def why_not(scene_dict: dict, study: dict) -> str | None:
    """Why a study (``converge.json`` as read by :func:`load`) gives a run of ``scene_dict`` no
    errors, in words; None when it gives them."""
    if errors_for(scene_dict, study) is not None:
        return None
    if scene_key(scene_dict) != study.get("scene_key"):
        return ("it studies another scene (the scenes differ in more than the step, the mesh level and the output "
                "intervals)")
    return ("this run's step or mesh is not one of its rungs (steps " + ", ".join(
        f"{r['h'] * 1e6:.4g} us" for r in study["steps"] if math.isfinite(r.get("h", math.nan)))
        + "; meshes " + ", ".join(r["name"] for r in study["meshes"]) + ")")


def display_path(folder) -> str:
    """``folder`` as a reader wants it: relative to the working folder when inside it (a
    scene's [output] errors_from is kept absolute)."""
    path = os.fspath(folder)
    rel = os.path.relpath(path) if os.path.isabs(path) else path
    return path if rel.startswith("..") else rel


#: Roache's factor of safety for an estimate from two runs, and the order assumed for it: the
#: contact scheme's (an impact costs HHT-alpha its second order; docs/converge.md).
FS_TWO_RUNS = 3.0
ASSUMED_ORDER = 1.0


def step_companion(scene):
    """The scene with its step halved (``[output] every`` doubled): what ``vfrs run
    --error-bars`` runs beside it."""
    from .scene import Scene

    data = scene.to_dict()
    if data.get("time", {}).get("mode") != "dynamic":
        raise VfrsError(f"{scene.source}: --error-bars halves the time step: a static scene has none (use vfrs "
                        "converge for the mesh part)")
    ladder = step_ladder(data, 2)
    from .scene.keypath import set_key

    for k, v in ladder[1].changes.items():
        set_key(data, k, v)
    return Scene.from_dict(data, source=f"{scene.source} (step halved)")


def two_run_errors(summary, companion, ratio: float = STEP_RATIO, order: float = ASSUMED_ORDER,
                   fs: float = FS_TWO_RUNS) -> dict:
    """{quantity: error} of a run from a companion run at the step divided by ``ratio``:
    Roache's two-run GCI of the coarser run, ``fs |phi_h - phi_h/r| r^p / (r^p - 1) / |phi_h|``
    with the assumed order ``p``."""
    out = {}
    f = ratio ** order
    for name, items in summary.sections.items():
        for key, q in items.items():
            other = companion.sections.get(name, {}).get(key)
            if other is None or not (math.isfinite(q.value) and math.isfinite(other.value)):
                continue
            if q.value == other.value:
                out[f"{name}.{key}"] = {"relative": 0.0, "bound": True, "step_part": 0.0}
            elif q.value != 0:
                rel = fs * abs(q.value - other.value) * f / (f - 1) / abs(q.value)
                out[f"{name}.{key}"] = {"relative": rel, "bound": True, "step_part": rel}
    return out


def with_step_errors(scene, summary, progress: bool = False):
    """``summary`` with the step part of each number's error, from a companion run of
    ``scene`` at half its step (:func:`two_run_errors`); the mesh part stays unknown."""
    from .run import run

    companion = run(step_companion(scene), progress=progress).results
    if companion is None:
        raise VfrsError("--error-bars: the companion run at half the step has no summary")
    return summary.with_errors(two_run_errors(summary, companion), "a companion run at half the step",
                               f"the step part only (two runs: Fs = {FS_TWO_RUNS:g}, order {ASSUMED_ORDER:g} "
                               "assumed); the mesh part is not included: vfrs converge gives both")


# ------------------------------------------------------------------------------------------
# Command line
# ------------------------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="vfrs converge", description="Run a scene at a ladder of time steps (h, h/2, "
                                 "h/4) and meshes, and say for every number of its summary how far it is from the "
                                 "converged value and what a closer answer costs (docs/converge.md).")
    ap.add_argument("scene", help="scene file (.toml)")
    ap.add_argument("-o", "--out", required=True, help="output folder: runs/, summary.csv, converge.{csv,parquet,md,"
                    "txt,json}, errors.csv, figures/")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a scene value (TOML "
                    "syntax), as vfrs run")
    ap.add_argument("--steps", type=int, default=LEVELS, metavar="N", help=f"{LEVELS}: h, h/2, h/4 (default); 1: the "
                    "scene's step only")
    ap.add_argument("--meshes", type=int, default=LEVELS, metavar="N", help=f"{LEVELS}: three meshes (default); 1: the "
                    "scene's mesh only")
    ap.add_argument("--mesh-ladder", choices=("auto", "levels", "refine"), default="auto",
                    help="levels: the generator's resolutions; refine: every tetrahedron split into eight, once and "
                    "twice; auto (default): levels where the meshes have them")
    ap.add_argument("--quantity", action="append", default=[], metavar="NAME=EXPR", help="one more number to "
                    "study, an expression as a sweep's derived column: 'tip=last(probes[\"probe_0.displacement\"])[2]'")
    ap.add_argument("--workers", type=int, metavar="N", help="worker processes (default: the cores); with "
                    "--scheduler: wait for N workers")
    ap.add_argument("--scheduler", metavar="ADDR", help="an existing dask scheduler, e.g. tcp://host:8786")
    ap.add_argument("--scheduler-file", metavar="PATH", help="an existing dask cluster's scheduler file")
    ap.add_argument("--serial", action="store_true", help="no dask: the runs one after another in this process")
    ap.add_argument("--retries", type=int, default=1, metavar="N", help="retry a failed run up to N times (default 1)")
    ap.add_argument("--no-figures", action="store_true", help="no PNGs")
    ap.add_argument("--no-progress", dest="progress", action="store_false", default=None, help="no progress bar")
    return ap


def main(argv=None) -> int:
    """``vfrs converge SCENE -o OUT``: 0 when every run completed, 1 when some failed (the
    studies that need them say "missing"), 2 on an error in the scene or the options."""
    from .checkpoint import RunStopped
    from .scene.overrides import load_scene
    from .sweep import check_engine

    args = build_parser().parse_args(argv)
    try:
        check_engine(args.serial, args.workers, args.scheduler, args.scheduler_file)
        scene = load_scene(args.scene, args.set)
        quantities = {}
        for item in args.quantity:
            name, sep, expr = item.partition("=")
            if not sep or not name.strip() or not expr.strip():
                raise VfrsError(f"--quantity {item!r}: expected NAME=EXPRESSION")
            quantities[name.strip()] = expr.strip()
        res = converge(scene, args.out, steps=args.steps, meshes=args.meshes, mesh_how=args.mesh_ladder,
                       quantities=quantities,
                       workers=args.workers, scheduler=args.scheduler, scheduler_file=args.scheduler_file,
                       serial=args.serial, retries=args.retries, figures=not args.no_figures, progress=args.progress)
    except VfrsError as e:
        print(f"vfrs: error: {e}", file=sys.stderr)
        return 2
    except RunStopped as stop:
        print(f"vfrs: {stop}; the finished runs are kept: run the same command again to continue", file=sys.stderr)
        return stop.exit_code
    except KeyboardInterrupt:
        print("vfrs: interrupted (finished runs are kept; run the same command again to continue)", file=sys.stderr)
        return 130
    print(res.text())
    print(f"wrote {args.out}/converge.md, converge.csv, errors.csv, converge.json" + ("" if args.no_figures else
                                                                                    ", figures/"))
    return 1 if res.failed else 0


if __name__ == "__main__":
    from vfrs.converge import main as _main

    sys.exit(_main())
