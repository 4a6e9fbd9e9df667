"""What accuracy costs in time: a grid of contact settings x resolutions x time steps, each
run measured for its error (against a closed form or a reference run), its wall time split
by effect, its iterations and its peak memory.

``vfrs bench accuracy [--quick] -o out/accuracy`` writes ``accuracy.csv``, ``accuracy.json``,
``accuracy.md`` (tables, the Pareto-optimal settings and a recommendation per problem) and
``pareto_<problem>.png``.

A problem's reference is never one of the settings it judges: closed forms for the block,
Hertz and the bars; for the M5 folds a Lagrange run on a finer mesh with a smaller step than
every row (``accuracy.json`` records it under ``references``, with its wall time). One row
can be re-run on its own with :func:`run_row` (what ``tests/test_committed_results.py`` does
to keep the committed tables tied to the code).
"""

from __future__ import annotations

import csv
import json
import math
import os
import resource
import time
from dataclasses import dataclass, field

import numpy as np

from .pareto import pareto_front
from .problems import PROBLEMS

_MARKERS = "os^Dxv<>p*"  # one per method, in the grid's order (lagrange, penalty, AL, ...)
EFFECT_KEYS = ("assembly", "factorization", "flow", "contact", "contact_setup", "solve", "step", "record", "output")


def _step_text(step) -> str:
    return "" if step is None else f", h = {step:g}"


def _where(level, step) -> str:
    return f"{level}{_step_text(step)}"


def method_grid(mode: str, problem: str) -> list:
    """Contact settings: (label, [contact] table); the penalty parameters swept and any
    further rows are the problem's (``kappas``, ``extra_settings``)."""
    p = PROBLEMS[problem]
    kappas = list(p.kappas)
    if mode == "quick":
        kappas = kappas[::2]
    grid: list[tuple[str, dict]] = [("lagrange", {"method": "lagrange"})]
    for k in kappas:
        grid.append((f"penalty k={k:.0e}", {"method": "penalty", "kappa": k}))
    if mode == "full":
        grid.append((f"penalty k={kappas[1]:.0e} refactor", {"method": "penalty", "kappa": kappas[1], "solver": "refactor"}))
    # N is swept on purpose: a step whose N augmentations end above gap_tol is recorded
    # (history contact_converged = 0, the row's unconverged_steps), not raised.
    k0 = kappas[0]
    for n in ([1, 4] if mode == "quick" else [1, 2, 4, 8]):
        grid.append((f"AL N={n} k0={k0:.0e}", {"method": "augmented_lagrange", "kappa": k0, "max_augmentations": n,
                                               "strict": False}))
    if mode == "full":
        # The paper's kappa_0 = 1, read in our units (Pa/m): what its start costs.
        grid.append(("AL N=8 k0=1 (paper)", {"method": "augmented_lagrange", "kappa": 1.0, "max_augmentations": 8,
                                             "strict": False}))
    grid += [(label, dict(contact)) for label, contact in getattr(p, "extra_settings", {}).get(mode, [])]
    return grid


@dataclass
class Row:
    problem: str
    setting: str
    method: str
    level: str
    step: float | None
    error: float
    wall: float
    metrics: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    iterations: float = 0.0
    peak_memory_mb: float = float("nan")
    failed: str = ""

    def flat(self) -> dict:
        d = {
            "problem": self.problem, "setting": self.setting, "method": self.method, "level": self.level,
            "step": self.step, "error": self.error, "wall_s": self.wall, "iterations": self.iterations,
            "peak_memory_mb": self.peak_memory_mb, "failed": self.failed,
        }
        d.update({f"t_{k}": self.timings.get(k, 0.0) for k in EFFECT_KEYS})
        d.update({f"m_{k}": v for k, v in self.metrics.items() if k != "error"})
        return d


def _run_one(scene_dict):
    """Runs a scene; returns (result-like summary, wall seconds, peak RSS MB)."""
    import vfrs

    t0 = time.perf_counter()
    res = vfrs.run(vfrs.Scene.from_dict(scene_dict), progress=False)
    wall = time.perf_counter() - t0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return res, wall, rss


def _child_main(conn, fn, args):
    try:
        conn.send(("ok", fn(*args)))
    except BaseException as e:  # report, never hang the parent
        conn.send(("error", f"{type(e).__name__}: {e}"))
    finally:
        conn.close()


_CONTEXT = None


def _context():
    """A forkserver context (children forked from a clean server, never from a process
    whose Rust thread pool is running: a plain fork of such a process deadlocks in the
    child's first parallel loop), vfrs preloaded; None where there is none."""
    global _CONTEXT
    if _CONTEXT is None:
        import multiprocessing as mp

        try:
            _CONTEXT = mp.get_context("forkserver")
            _CONTEXT.set_forkserver_preload(["vfrs", "vfrs.bench.accuracy"])
        except ValueError:
            _CONTEXT = False
    return _CONTEXT or None


def _in_child(fn, *args):
    """Runs fn in a child process (so peak memory is the run's own); falls back to
    in-process where there are no child processes."""
    ctx = _context()
    if ctx is None:
        return fn(*args)
    parent, child = ctx.Pipe(duplex=False)
    p = ctx.Process(target=_child_main, args=(child, fn, args))
    p.start()
    child.close()  # the child holds its own end: a child that dies gives EOF, not a hang
    try:
        status, payload = parent.recv()
    except EOFError:
        status, payload = "error", "the run's process died"
    finally:
        p.join()
        parent.close()
    if status == "error":
        raise RuntimeError(payload if p.exitcode == 0 else f"{payload} (exit code {p.exitcode})")
    return payload


def _measured(problem, scene_dict, reference):
    res, wall, rss = _run_one(scene_dict)
    metrics = problem.measure(res, reference)
    h = res.history
    if "contact_converged" in h:
        metrics["unconverged_steps"] = int(np.count_nonzero(np.asarray(h["contact_converged"]) == 0))
    iters = float(np.mean(h["iterations"])) if "iterations" in h else 0.0
    return metrics, wall, rss, dict(res.timings), iters


def grid_cells(mode: str, problem: str) -> list:
    """The rows of a problem's grid in report order: (setting label, contact table, level,
    step)."""
    p = PROBLEMS[problem]
    return [(label, contact, level, step)
            for label, contact in method_grid(mode, problem)
            for level in p.levels[mode]
            for step in p.steps[mode]]


def _grid_cell(mode, problem, setting, level, step):
    """The grid cell a (setting, level, step) key names; level may be given as the table
    prints it (``str(level)``), step as a float or None."""
    for label, contact, lv, h in grid_cells(mode, problem):
        if label != setting or str(lv) != str(level):
            continue
        if (h is None and step is None) or (h is not None and step is not None and math.isclose(h, float(step), rel_tol=1e-9)):
            return contact, lv, h
    raise KeyError(f"{problem} ({mode} mode) has no row {setting!r} at {_where(level, step)}")


def run_row(problem: str, setting: str, level, step, mode="full", reference=None, isolate=False) -> Row:
    """Runs one row of the grid (``setting`` as labelled in the table, ``level`` as an entry
    of the problem's levels or as printed, ``step`` as printed or None) exactly as
    :func:`run_accuracy` does and returns it; ``reference`` is the reference run's metrics
    (``references[problem]["metrics"]`` of ``accuracy.json``) for problems measured against
    one (M5; without it their error is NaN, the other metrics are measured). A failing run is
    a row with ``failed`` set."""
    p = PROBLEMS[problem]()
    contact, level, step = _grid_cell(mode, problem, setting, level, step)
    call = _in_child if isolate else (lambda fn, *a: fn(*a))
    row = Row(problem, setting, contact["method"], str(level), step, float("nan"), float("nan"))
    try:
        metrics, wall, rss, timings, iters = call(_measured, p, p.scene(contact, level, step), reference)
        row.error, row.wall, row.metrics = float(metrics["error"]), wall, metrics
        row.timings, row.iterations, row.peak_memory_mb = timings, iters, rss
    except Exception as e:  # a failing setting is a result, not the end of the report
        row.failed = str(e).splitlines()[0][:200]
    return row


def run_reference(problem: str, mode="full", isolate=False, progress=False, check_only=False) -> dict:
    """The problem's reference: ``{"kind": "exact", "text": ...}`` for a closed form, or for a
    reference run (M5) its setting, metrics, wall time and its sensitivity check (the same
    run one mesh level coarser: ``check["change"]`` = relative change of the measured
    quantity). ``check_only``: only the sensitivity check (``{"kind": "run", "check": ...}``,
    the same code path at a fifth of the cost)."""
    p = PROBLEMS[problem]()
    if not hasattr(p, "reference_setting"):
        return {"kind": "exact", "text": p.reference_text(mode)}
    call = _in_child if isolate else (lambda fn, *a: fn(*a))

    def one(contact, level, step, what):
        if progress:
            print(f"[{problem}] {what}: {contact['method']} at {level}, h={step:g}", flush=True)
        metrics, wall, rss, _, _ = call(_measured, p, p.scene(contact, level, step), None)
        metrics = {k: v for k, v in metrics.items() if k not in ("error", "area_error")}
        if progress:
            print(f"[{problem}] {what}: {wall:.1f} s", flush=True)
        return {"method": contact["method"], "level": str(level), "step": step, "wall_s": wall,
                "peak_memory_mb": rss, "metrics": metrics}

    if check_only:
        contact, level, step = p.reference_check_setting(mode)
        return {"kind": "run", "check": one(contact, level, step, "reference check")}
    contact, level, step = p.reference_setting(mode)
    ref = {"kind": "run", **one(contact, level, step, "reference")}
    if hasattr(p, "reference_check_setting"):
        contact, level, step = p.reference_check_setting(mode)
        chk = one(contact, level, step, "reference check")
        a, b = ref["metrics"]["peak_force"], chk["metrics"]["peak_force"]
        chk["change"] = abs(b - a) / abs(a)
        ref["check"] = chk
    ref["text"] = p.reference_text(mode, ref)
    return ref


def _neighbour_text(kind, n) -> str:
    return f"on the next finer mesh {n.level}" if kind == "mesh" else f"at the next finer step h = {n.step:g}"


def recommend(problem: str, rows, target=0.01, levels=None, reference_spread=None, spread_note="") -> str:
    """A recommendation that rests on more than one cell of the table.

    A row (setting, level, step) *supports* a recommendation when its error is at most
    ``target`` and so is the error of the same setting at the next finer step (same level)
    and at the next finer level (same step), for each of the two the table has; the finest
    cell has nothing to confirm it and is not recommended. Among supported rows the
    cheapest is recommended (among those within 20 % of its wall time, timing noise, the most
    accurate). No recommendation when ``reference_spread`` (the reference's own sensitivity)
    exceeds the target (``spread_note`` says between which runs it was measured), or when no
    row is supported: the text then says why.

    ``levels``: the levels coarse to fine as printed (default: order of appearance); steps
    are ordered by size (None for static problems)."""
    rows = [r for r in rows if r.problem == problem]
    finite = [r for r in rows if not r.failed and math.isfinite(r.error)]
    if not finite:
        return f"{problem}: no runs."
    pct = f"{target * 100:g}%"
    head = f"{problem}: no robust recommendation for {pct} error"
    if reference_spread is not None and reference_spread > target:
        return (f"{head}: the reference itself moves by {reference_spread:.1%}{' ' + spread_note if spread_note else ''}, "
                "more than the target, so errors that small are not resolved; see the table.")
    levels = list(levels) if levels is not None else list(dict.fromkeys(r.level for r in rows))
    steps = sorted({r.step for r in rows if r.step is not None}, reverse=True)
    cell = {(r.setting, r.level, r.step): r for r in rows}

    def finer(r):
        out = []
        i = levels.index(r.level) if r.level in levels else None
        if i is not None and i + 1 < len(levels) and (r.setting, levels[i + 1], r.step) in cell:
            out.append(("mesh", cell[(r.setting, levels[i + 1], r.step)]))
        if r.step is not None:
            j = steps.index(r.step)
            if j + 1 < len(steps) and (r.setting, r.level, steps[j + 1]) in cell:
                out.append(("step", cell[(r.setting, r.level, steps[j + 1])]))
        return out

    ok = [r for r in finite if r.error <= target]
    if not ok:
        best = min(finite, key=lambda r: r.error)
        return (f"{head}: no setting reached it; the most accurate was {best.setting} at "
                f"{_where(best.level, best.step)} ({best.error:.2%}, {best.wall:.2f} s); see the table.")
    supported, unconfirmed = [], []
    for r in ok:
        nb = finer(r)
        bad = [(kind, n) for kind, n in nb if n.failed or not math.isfinite(n.error) or n.error > target]
        if nb and not bad:
            supported.append((r, nb))
        else:
            unconfirmed.append((r, bad))
    if not supported:
        def why(r, bad):
            if not bad:
                return f"{r.setting} at {_where(r.level, r.step)}: {r.error:.2%}, but nothing finer in the table confirms it"
            kind, n = bad[0]
            val = f"failed ({n.failed})" if n.failed else f"{n.error:.2%}"
            return f"{r.setting} at {_where(r.level, r.step)}: {r.error:.2%}, but {val} {_neighbour_text(kind, n)}"

        shown = sorted(unconfirmed, key=lambda rb: rb[0].wall)[:3]
        more = len(unconfirmed) - len(shown)
        return (f"{head}: {len(ok)} cell(s) reached it, none confirmed at the next finer step and mesh ("
                + "; ".join(why(*rb) for rb in shown) + (f"; {more} more" if more > 0 else "") + "); see the table.")
    fastest = min(r.wall for r, _ in supported)
    r, nb = min(((r, nb) for r, nb in supported if r.wall <= 1.2 * fastest), key=lambda rn: rn[0].error)
    confirm = " and ".join(f"{n.error:.2%} {_neighbour_text(kind, n)}" for kind, n in nb)
    return (f"{problem}: for {pct} error use {r.setting} at {_where(r.level, r.step)}: "
            f"error {r.error:.2%}, {r.wall:.2f} s wall (confirmed: {confirm}).")


def provenance() -> dict:
    """The vfrs commit the numbers come from and whether python/ or rust/ had uncommitted
    changes (then the numbers belong to no commit)."""
    import subprocess
    from pathlib import Path

    def git(*args):
        try:
            return subprocess.run(["git", *args], cwd=Path(__file__).parent, capture_output=True, text=True,
                                  timeout=10).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""

    top = git("rev-parse", "--show-toplevel")
    dirty = bool(top and git("-C", top, "status", "--porcelain", "--", "python", "rust"))
    return {"commit": git("rev-parse", "HEAD") or "unknown", "dirty": dirty}


@dataclass
class AccuracyReport:
    rows: list
    mode: str
    seconds: float
    references: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict)

    @classmethod
    def load(cls, out) -> "AccuracyReport":
        """A written report back from ``out/accuracy.json`` (rows without their timings split)."""
        with open(os.path.join(out, "accuracy.json")) as fh:
            data = json.load(fh)
        rows = []
        for d in data["rows"]:
            step = d["step"]
            rows.append(Row(
                d["problem"], d["setting"], d["method"], d["level"], None if step in (None, "") else float(step),
                float(d["error"]), float(d["wall_s"]),
                metrics={k[2:]: v for k, v in d.items() if k.startswith("m_")},
                timings={k[2:]: v for k, v in d.items() if k.startswith("t_")},
                iterations=d.get("iterations", 0.0), peak_memory_mb=d.get("peak_memory_mb", float("nan")),
                failed=d.get("failed") or "",
            ))
        return cls(rows, data["mode"], data["seconds"], data.get("references", {}), data.get("provenance", {}))

    def table(self, problem):
        return [r for r in self.rows if r.problem == problem]

    def front(self, problem):
        rows = self.table(problem)
        return pareto_front([r.wall for r in rows], [r.error for r in rows])

    def levels(self, problem) -> list:
        """The problem's levels coarse to fine, as printed (its grid's order)."""
        seen = list(dict.fromkeys(r.level for r in self.table(problem)))
        p = PROBLEMS.get(problem)
        order = [str(lv) for lv in p.levels.get(self.mode, [])] if p is not None else []
        return order if set(seen) <= set(order) else seen

    def recommendation(self, problem, target=0.01) -> str:
        ref = self.references.get(problem) or {}
        chk = ref.get("check") or {}
        note = f"from the {ref.get('level')} to the {chk.get('level')} mesh at the same step" if chk else ""
        return recommend(problem, self.table(problem), target, self.levels(problem), chk.get("change"), note)

    def markdown(self) -> str:
        lines = [f"# Accuracy vs cost ({self.mode} mode, {self.seconds:.0f} s in all)", ""]
        if self.provenance:
            pv = self.provenance
            lines += [f"vfrs commit {pv.get('commit', 'unknown')}"
                      + (" + uncommitted changes in python/ or rust/" if pv.get("dirty") else "") + ".", ""]
        for name in dict.fromkeys(r.problem for r in self.rows):
            rows = self.table(name)
            front = self.front(name)
            doc = " ".join((PROBLEMS[name].__doc__ or "").split())
            lines += [f"## {name}", "", doc, ""]
            ref = self.references.get(name)
            if ref and ref.get("text"):
                lines += ["**Reference.** " + ref["text"], ""]
            lines += ["| setting | level | step | error | wall (s) | contact (s) | solve (s) | iterations | peak MB "
                      "| unconverged steps | Pareto |",
                      "|---|---|---|---|---|---|---|---|---|---|---|"]
            for r, f in sorted(zip(rows, front), key=lambda rf: rf[0].wall):
                step = "static" if r.step is None else f"{r.step:g}"
                pareto = "**yes**" if f else ""
                if r.failed:
                    pareto = f"failed: {r.failed}"
                lines.append(
                    f"| {r.setting} | {r.level} | {step} | {r.error:.3e} | {r.wall:.3f} | {r.timings.get('contact', 0):.3f} | "
                    f"{r.timings.get('solve', 0) + r.timings.get('step', 0):.3f} | {r.iterations:.1f} | {r.peak_memory_mb:.0f} | "
                    f"{r.metrics.get('unconverged_steps', 0):.0f} | {pareto} |"
                )
            lines += ["", "**Recommendation.** " + self.recommendation(name), ""]
        return "\n".join(lines)

    def write(self, out):
        os.makedirs(out, exist_ok=True)
        flat = [r.flat() for r in self.rows]
        keys = sorted({k for d in flat for k in d}, key=lambda k: (k not in flat[0], k)) if flat else []
        with open(os.path.join(out, "accuracy.csv"), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=keys)
            w.writeheader()
            w.writerows(flat)
        with open(os.path.join(out, "accuracy.json"), "w") as fh:
            json.dump({"mode": self.mode, "seconds": self.seconds, "provenance": self.provenance,
                       "references": self.references, "rows": flat}, fh, indent=1, default=float)
        with open(os.path.join(out, "accuracy.md"), "w") as fh:
            fh.write(self.markdown())
        for name in dict.fromkeys(r.problem for r in self.rows):
            self.plot(name, os.path.join(out, f"pareto_{name}.png"))

    def plot(self, problem, path):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        rows = self.table(problem)
        front = self.front(problem)
        fig, ax = plt.subplots(figsize=(7.5, 5))
        for i, method in enumerate(dict.fromkeys(r.method for r in rows)):
            sel = [(r, f) for r, f in zip(rows, front) if r.method == method and math.isfinite(r.error)]
            if not sel:
                continue
            ax.scatter([r.wall for r, _ in sel], [max(r.error, 1e-16) for r, _ in sel], marker=_MARKERS[i % len(_MARKERS)],
                       label=method, alpha=0.75, s=40)
        pf = sorted([r for r, f in zip(rows, front) if f], key=lambda r: r.wall)
        if pf:
            ax.plot([r.wall for r in pf], [max(r.error, 1e-16) for r in pf], "k--", lw=1, label="Pareto front")
            for r in pf:
                ax.annotate(r.setting, (r.wall, max(r.error, 1e-16)), fontsize=7, xytext=(4, 4), textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time per run (s)")
        ax.set_ylabel("relative error")
        ax.set_title(f"{problem}: error vs cost")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)


def run_accuracy(mode="quick", problems=None, out=None, progress=True, isolate=True) -> AccuracyReport:
    """Runs the grid (``mode`` "quick" or "full") for ``problems`` (default: every problem
    whose ``modes`` include ``mode``: in quick mode the block, Hertz and the bars; in full mode
    also the M5 folds) and returns the report; with ``out``, writes it there."""
    if mode not in ("quick", "full"):
        raise ValueError(f"mode must be 'quick' or 'full', got {mode!r}")
    if problems is None:
        problems = [name for name, p in PROBLEMS.items() if mode in p.modes]
    unknown = [p for p in problems if p not in PROBLEMS]
    if unknown:
        raise ValueError(f"unknown problem {unknown[0]!r}; choose from {sorted(PROBLEMS)}")
    t_start = time.perf_counter()
    rows, references = [], {}
    for name in problems:
        ref = run_reference(name, mode, isolate=isolate, progress=progress)
        references[name] = ref
        for label, contact, level, step in grid_cells(mode, name):
            row = run_row(name, label, level, step, mode, ref.get("metrics"), isolate=isolate)
            rows.append(row)
            if progress:
                print(f"[{name}] {label:28s} {str(level):12s} h={step}: error {row.error:.3e}  {row.wall:.2f} s"
                      + (f"  FAILED {row.failed}" if row.failed else ""), flush=True)
    report = AccuracyReport(rows, mode, time.perf_counter() - t_start, references, provenance())
    if out is not None:
        report.write(out)
    return report
