"""What a converge study says: the base run's numbers with their errors and what the next
refinement buys (:meth:`ConvergeResult.lines`, what ``vfrs converge`` prints), the runs a target
error recommends (:func:`recommend`), and the files: converge.csv/.parquet, errors.csv,
converge.md/.txt/.json and a figure per quantity (:func:`write`)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from ..verification import next_refinement, percent_text
from .analyse import Quantity, Study, finite_number, run_value
from .plan import LEVELS, Plan, mesh_rows, plan_lines, scene_key

CONVERGE_FILE = "converge.json"


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



# ------------------------------------------------------------------------------------------
# Words
# ------------------------------------------------------------------------------------------

def _display(unit: str) -> tuple:
    from ...summary import DISPLAY

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
    return float(v) if isinstance(v, (int, float)) and finite_number(v) else math.nan


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
    if rel == 0.0 and all(x == v for x in (run_value(r, q) for row in res.grid for r in row) if x is not None):
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
        nxt = run_value(res.grid[i + 1][j], q)
        if nxt is not None:
            lim = s.verification.extrapolated if s and s.verification and s.verification.kind == "monotone" else None
            c = next_refinement(v, nxt, _time_of(res.grid[i][j]), _time_of(res.grid[i + 1][j]), "mesh", lim)
            costs.append(c.text())
    if j + 1 < len(p.steps):
        s = res.study(q.name, "step", i)
        nxt = run_value(res.grid[i][j + 1], q)
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
    finer = [run_value(res.grid[a][b], q) for a, b in ((i + 1, j), (i, j + 1))
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
        values = [run_value(r, q) for row in res.grid for r in row]
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
            if not p.planned(i, j):
                continue
            row = res.grid[i][j] or {}
            rss = row.get("peak_rss [MB]")
            lines.append(f"  {m.name:>14} {s.name:>5}  h = {m.h * 1e3:.3g} mm  {m.dofs} DOFs  "
                         f"{_secs(_time_of(row))} s  " + (f"{rss:.0f} MB" if finite_number(rss) else "memory n/a")
                         + ("" if row.get("status") == "complete" else f"  {row.get('status', 'not run')}"))
    times = [_time_of(r) for row in res.grid for r in row]
    if any(math.isfinite(t) for t in times):
        total = sum(t for t in times if math.isfinite(t))
        lines.append(f"cost: {total:.0f} s of run time in all; on 2 / 8 / 32 workers at least "
                     + " / ".join(f"{projected_wall(times, w):.0f}" for w in (2, 8, 32))
                     + " s (longest first; projected from these run times, which include the slowdown of the "
                     "runs sharing this machine's cores)")
    return lines + plan_lines(p)


def write(res: ConvergeResult, out: str, *, figures: bool = True) -> list:
    """converge.csv/.parquet, errors.csv, meshes.csv/.parquet (the mesh rungs: element size,
    contact-surface edges, ratios), converge.md/.txt/.json and the figures; the paths."""
    from ...output.atomic import atomic_json
    from ..sweep import write_table

    p = res.plan
    written = []
    write_table([s.to_row() for s in res.studies], out, ["quantity", "axis", "at", "kind"], name="converge")
    write_table(res.errors, out, ["quantity", "mesh", "step", "value", "relative", "step_part", "mesh_part", "bound"],
                name="errors")
    write_table(mesh_rows(p), out, ["mesh", "index", "base", "h [m]", "h ratio"], name="meshes")
    written += [os.path.join(out, n) for n in ("converge.parquet", "converge.csv", "errors.parquet", "errors.csv",
                                               "meshes.parquet", "meshes.csv")]
    text = res.text()
    with open(os.path.join(out, "converge.txt"), "w") as fh:
        fh.write(text + "\n")
    with open(os.path.join(out, "converge.md"), "w") as fh:
        fh.write(markdown(res))
    atomic_json(os.path.join(out, CONVERGE_FILE), {
        "source": p.source, "scene_key": scene_key(p.runs[0]["scene"] if p.runs else p.scene),
        "meshes": [{"name": r.name, "index": r.index, "changes": r.changes, "drops": list(r.drops), "h": r.h,
                    "measured_h": r.measured_h, "dofs": r.dofs, "contact_surface": r.surface} for r in p.meshes],
        "notes": p.notes,
        "steps": [{"name": r.name, "index": r.index, "changes": r.changes, "h": r.h} for r in p.steps],
        "base": {"mesh": p.base_mesh, "step": p.base_step}, "design": p.design,
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
    from ...plot import require_matplotlib

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
            ax.set_xlabel("time step [us]" if axis == "step" else "element size h [mm] (meshes.csv)")
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
