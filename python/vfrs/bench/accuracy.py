"""What accuracy costs in time: a grid of contact settings x resolutions x time steps, each
run measured for its error (against a closed form or a reference run), its wall time split
by effect, its iterations and its peak memory.

``vfrs bench accuracy [--quick] -o out/accuracy`` writes ``accuracy.csv``, ``accuracy.json``,
``accuracy.md`` (tables, the Pareto-optimal settings and a recommendation per problem) and
``pareto_<problem>.png``.
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

EFFECT_KEYS = ("assembly", "factorization", "flow", "contact", "contact_setup", "solve", "step", "record", "output")


def _step_text(step) -> str:
    return "" if step is None else f", h = {step:g}"


def method_grid(mode: str, problem: str) -> list:
    """Contact settings: (label, [contact] table)."""
    kappas = {"block": [1e6, 1e8, 1e10], "hertz": [1e7, 1e9, 1e11], "bars": [1e8, 1e10, 1e12], "m5": [1e8, 1e10, 1e12]}[problem]
    if mode == "quick":
        kappas = kappas[::2]
    grid = [("lagrange", {"method": "lagrange"})]
    for k in kappas:
        grid.append((f"penalty k={k:.0e}", {"method": "penalty", "kappa": k}))
    if mode == "full":
        grid.append((f"penalty k={kappas[1]:.0e} refactor", {"method": "penalty", "kappa": kappas[1], "solver": "refactor"}))
    k0 = kappas[0]
    for n in ([1, 4] if mode == "quick" else [1, 2, 4, 8]):
        grid.append((f"AL N={n} k0={k0:.0e}", {"method": "augmented_lagrange", "kappa": k0, "max_augmentations": n}))
    if mode == "full":
        # The paper's kappa_0 = 1, read in our units (Pa/m): what its start costs.
        grid.append(("AL N=8 k0=1 (paper)", {"method": "augmented_lagrange", "kappa": 1.0, "max_augmentations": 8}))
    if problem == "m5" and mode == "full":
        grid.append(("penalty_volume k=1e14", {"method": "penalty_volume", "kappa": 1e14}))
    return grid


@dataclass
class Row:
    problem: str
    setting: str
    method: str
    level: str
    step: float
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


def _in_child(fn, *args):
    """Runs fn in a forked child (so peak memory is the run's own); falls back to in-process."""
    import multiprocessing as mp

    try:
        ctx = mp.get_context("fork")
    except ValueError:
        return fn(*args)
    parent, child = ctx.Pipe(duplex=False)

    def target():
        try:
            child.send(("ok", fn(*args)))
        except BaseException as e:  # report, never hang the parent
            child.send(("error", f"{type(e).__name__}: {e}"))
        finally:
            child.close()

    p = ctx.Process(target=target)
    p.start()
    status, payload = parent.recv()
    p.join()
    if status == "error":
        raise RuntimeError(payload)
    return payload


def _measured(problem, scene_dict, reference):
    res, wall, rss = _run_one(scene_dict)
    metrics = problem.measure(res, reference)
    h = res.history
    iters = float(np.mean(h["iterations"])) if "iterations" in h else 0.0
    return metrics, wall, rss, dict(res.timings), iters


@dataclass
class AccuracyReport:
    rows: list
    mode: str
    seconds: float

    def table(self, problem):
        return [r for r in self.rows if r.problem == problem]

    def front(self, problem):
        rows = self.table(problem)
        return pareto_front([r.wall for r in rows], [r.error for r in rows])

    def recommendation(self, problem, target=0.01) -> str:
        rows = [r for r in self.table(problem) if math.isfinite(r.error)]
        if not rows:
            return f"{problem}: no runs."
        ok = [r for r in rows if r.error <= target]
        if not ok:
            best = min(rows, key=lambda r: r.error)
            return (f"{problem}: no setting reached {target:.0%} error; the most accurate was "
                    f"{best.setting} at {best.level}{_step_text(best.step)} ({best.error:.2%}, {best.wall:.2f} s).")
        # The cheapest, but among settings within 20 % of its time (timing noise) the most
        # accurate.
        fastest = min(r.wall for r in ok)
        r = min((r for r in ok if r.wall <= 1.2 * fastest), key=lambda r: r.error)
        return (f"{problem}: for {target:.0%} error use {r.setting} at {r.level}{_step_text(r.step)}: "
                f"error {r.error:.2%}, {r.wall:.2f} s wall.")

    def markdown(self) -> str:
        lines = [f"# Accuracy vs cost ({self.mode} mode, {self.seconds:.0f} s in all)", ""]
        for name in dict.fromkeys(r.problem for r in self.rows):
            rows = self.table(name)
            front = self.front(name)
            doc = " ".join((PROBLEMS[name].__doc__ or "").split())
            lines += [f"## {name}", "", doc, "",
                      "| setting | level | step | error | wall (s) | contact (s) | solve (s) | iterations | peak MB | Pareto |",
                      "|---|---|---|---|---|---|---|---|---|---|"]
            for r, f in sorted(zip(rows, front), key=lambda rf: rf[0].wall):
                step = "static" if r.step is None else f"{r.step:g}"
                lines.append(
                    f"| {r.setting} | {r.level} | {step} | {r.error:.3e} | {r.wall:.3f} | {r.timings.get('contact', 0):.3f} | "
                    f"{r.timings.get('solve', 0) + r.timings.get('step', 0):.3f} | {r.iterations:.1f} | {r.peak_memory_mb:.0f} | {'**yes**' if f else ''} |"
                    + (f" failed: {r.failed}" if r.failed else "")
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
            json.dump({"mode": self.mode, "seconds": self.seconds, "rows": flat}, fh, indent=1, default=float)
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
        markers = {"lagrange": "o", "penalty": "s", "augmented_lagrange": "^", "penalty_volume": "D", "detect_only": "x"}
        for method in dict.fromkeys(r.method for r in rows):
            sel = [(r, f) for r, f in zip(rows, front) if r.method == method and math.isfinite(r.error)]
            if not sel:
                continue
            ax.scatter([r.wall for r, _ in sel], [max(r.error, 1e-16) for r, _ in sel], marker=markers.get(method, "o"),
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
    """Runs the grid (``mode`` "quick" or "full") for ``problems`` (default: all in quick
    mode the block and the bars; in full mode also the M5 folds) and returns the report;
    with ``out``, writes it there."""
    if mode not in ("quick", "full"):
        raise ValueError(f"mode must be 'quick' or 'full', got {mode!r}")
    if problems is None:
        problems = ["block", "hertz", "bars"] if mode == "quick" else ["block", "hertz", "bars", "m5"]
    unknown = [p for p in problems if p not in PROBLEMS]
    if unknown:
        raise ValueError(f"unknown problem {unknown[0]!r}; choose from {sorted(PROBLEMS)}")
    t_start = time.perf_counter()
    rows = []
    call = _in_child if isolate else (lambda fn, *a: fn(*a))
    for name in problems:
        problem = PROBLEMS[name]()
        reference = None
        if hasattr(problem, "reference_setting"):
            contact, level, step = problem.reference_setting(mode)
            if progress:
                print(f"[{name}] reference: {contact['method']} at {level}, h={step:g}", flush=True)
            reference, *_ = call(_measured, problem, problem.scene(contact, level, step), None)
        for label, contact in method_grid(mode, name):
            for level in problem.levels[mode]:
                for step in problem.steps[mode]:
                    row = Row(name, label, contact["method"], str(level), step, float("nan"), float("nan"))
                    try:
                        metrics, wall, rss, timings, iters = call(_measured, problem, problem.scene(contact, level, step), reference)
                        row.error, row.wall, row.metrics = float(metrics["error"]), wall, metrics
                        row.timings, row.iterations, row.peak_memory_mb = timings, iters, rss
                    except Exception as e:  # a failing setting is a result, not the end of the report
                        row.failed = str(e).splitlines()[0][:200]
                    rows.append(row)
                    if progress:
                        print(f"[{name}] {label:28s} {str(level):12s} h={step}: error {row.error:.3e}  {row.wall:.2f} s"
                              + (f"  FAILED {row.failed}" if row.failed else ""), flush=True)
    report = AccuracyReport(rows, mode, time.perf_counter() - t_start)
    if out is not None:
        report.write(out)
    return report
