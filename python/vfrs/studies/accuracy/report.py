"""The accuracy report read and written: :class:`AccuracyReport` (accuracy.csv/.json/.md, the
Pareto fronts, the recommendation per problem) and its figures (:func:`pareto_figure`)."""

from __future__ import annotations

import csv
import json
import os
from dataclasses import dataclass, field

import numpy as np

from .pareto import pareto_front
from .grid import MARKERS, Row, recommend
from .problems import PROBLEMS



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
                failed=d.get("failed") or "", run=d.get("run") or "",
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

    def reference_spread(self, problem):
        """(relative change, which runs) of the larger of the reference's sensitivity checks
        (one mesh level coarser; twice the step), or (None, "") without a reference run."""
        ref = self.references.get(problem) or {}
        spreads = []
        chk = ref.get("check") or {}
        if "change" in chk:
            spreads.append((chk["change"], f"from the {ref.get('level')} to the {chk.get('level')} mesh at the same step"))
        chk = ref.get("step_check") or {}
        if "change" in chk:
            spreads.append((chk["change"], f"from h = {ref.get('step'):g} to h = {chk.get('step'):g} on the same mesh"))
        return max(spreads, key=lambda s: s[0]) if spreads else (None, "")

    def targets(self, problem) -> tuple:
        """The errors a recommendation is made for (the problem's ``targets``; default 1 %)."""
        return tuple(getattr(PROBLEMS.get(problem), "targets", (0.01,)))

    def _study_recommendations(self, problem, targets, rows, families) -> list:
        """One recommendation per scored metric and target against a study reference."""
        from .reference import UNITS

        p = PROBLEMS[problem]
        ref = self.references.get(problem) or {}
        out = []
        for q, col in p.scored.items():
            est = (ref.get("quantities") or {}).get(q)
            if est is None:
                continue
            for t in targets:
                out.append(recommend(problem, rows, t, error_key=col, margin=est["uncertainty"], bound=est["bound"],
                                     what=UNITS.get(q, ("", 1.0, q))[2], families=families))
        return out

    def families(self, problem) -> list:
        """The problem's mesh families (levels coarse to fine) restricted to the levels its
        table has; one family of every level for a problem without ``families``."""
        fams = getattr(PROBLEMS.get(problem), "families", None)
        if not fams:
            return [self.levels(problem)]
        return [[lv for lv in fam if lv in self.levels(problem)] for fam in fams]

    def family_comparison(self, problem) -> list:
        """Markdown lines: for a problem with more than one mesh family and a study reference,
        each family's recommendation on its own (the settings both families run), per metric
        and target: what each needs for the same error, in time."""
        ref = self.references.get(problem) or {}
        fams = [f for f in self.families(problem) if f]
        if ref.get("kind") != "study" or len(fams) < 2:
            return []
        both = set(getattr(PROBLEMS[problem], "graded_settings", ())) or {r.setting for r in self.table(problem)}
        lines = ["### Mesh families at equal error", "",
                 "Each family's recommendation on its own, for the settings both run ("
                 + ", ".join(sorted(both)) + "): what each needs for the same error, and its time.", ""]
        for fam in fams:
            rows = [r for r in self.table(problem) if r.level in fam and r.setting in both]
            lines += [f"**{' / '.join(fam)}.** " + " ".join(self._study_recommendations(problem, self.targets(problem),
                                                                                     rows, [fam])), ""]
        return lines

    def recommendation(self, problem, target=None) -> str:
        """The recommendation for ``target``, or one per target of the problem, in one text.
        Against an extrapolated reference (a study): one per scored metric and target, each
        with the reference's uncertainty of that metric added to the rows' errors."""
        targets = self.targets(problem) if target is None else (target,)
        ref = self.references.get(problem) or {}
        if ref.get("kind") == "study":
            return " ".join(self._study_recommendations(problem, targets, self.table(problem), self.families(problem)))
        spread, note = self.reference_spread(problem)
        return " ".join(recommend(problem, self.table(problem), t, self.levels(problem), spread, note)
                        for t in targets)

    def convergence(self, problem) -> list:
        """Markdown lines: for a problem scored against a reference run, the scored quantity
        and the peak force of its Lagrange rows and of the reference runs, by mesh and step
        (whether what is scored converges). Empty for other problems."""
        ref = self.references.get(problem) or {}
        if ref.get("kind") == "study":
            return self._study_table(problem, ref)
        if ref.get("kind") != "run" or "metrics" not in ref:
            return []
        q = getattr(PROBLEMS.get(problem), "quantity", "peak_force")
        runs = [(r.level, r.step, r.metrics, "row") for r in self.table(problem)
                if r.setting == "lagrange" and not r.failed and r.step is not None]
        runs.append((ref["level"], ref["step"], ref["metrics"], "reference"))
        for key, what in (("check", "reference check (mesh)"), ("step_check", "reference check (step)")):
            if "metrics" in (ref.get(key) or {}):
                runs.append((ref[key]["level"], ref[key]["step"], ref[key]["metrics"], what))
        order = list(getattr(PROBLEMS.get(problem), "all_levels", ())) or list(dict.fromkeys(r[0] for r in runs))
        runs.sort(key=lambda r: (order.index(r[0]) if r[0] in order else len(order), -r[1]))
        unit, scale = ("uN s", 1e6) if q == "impulse" else ("mN", 1e3)
        lines = ["### Convergence of what is scored", "",
                 f"The Lagrange rows and the reference runs by mesh and step: the scored quantity ({q}) and the "
                 "peak medio-lateral contact force on the right fold. What is scored should settle as both are "
                 "refined; the reference's own error bar is its change to the two checks.", "",
                 f"| level | step (us) | {q} ({unit}) | peak force (mN) | run |", "|---|---|---|---|---|"]
        for level, step, m, what in runs:
            lines.append(f"| {level} | {step * 1e6:g} | {m[q] * scale:.4g} | {m['peak_force'] * 1e3:.4g} | {what} |")
        return lines + [""]

    def _study_table(self, problem, ref) -> list:
        """Markdown lines: a study reference's runs and the Lagrange rows by mesh and step, each
        scored metric's value, and the extrapolated values with their uncertainty."""
        from .reference import UNITS

        p = PROBLEMS[problem]
        qs = [q for q in (*p.scored, "max_area") if q in (ref.get("quantities") or {})]
        runs = [(r["level"], r["step"], r["metrics"], f"reference study, {r.get('wall_s', float('nan')):.0f} s")
                for r in ref.get("runs", [])]
        runs += [(r.level, r.step, r.metrics, f"row, {r.wall:.0f} s") for r in self.table(problem)
                 if r.setting == ref.get("method") and not r.failed and r.step is not None]
        order = [lv for fam in getattr(p, "families", ()) for lv in fam]
        runs.sort(key=lambda r: (order.index(r[0]) if r[0] in order else len(order), -r[1]))
        head = " | ".join(f"{UNITS[q][2]} ({UNITS[q][0]})" for q in qs)
        label, fmt = getattr(p, "step_column", ("step (us)", lambda h: f"{h * 1e6:g}"))  # a static problem's: its own
        lines = ["### Reference study and convergence of what is scored", "",
                 f"The {ref.get('method')} runs of the reference study and the {ref.get('method')} rows, by mesh "
                 "and step; last, the limit each metric is scored against, with its uncertainty (bound: the GCIs of "
                 "monotone studies; band: the range of an oscillatory or divergent one).", "",
                 f"| level | {label} | {head} | run |", "|---|---|" + "---|" * len(qs) + "---|"]
        for level, step, m, what in runs:
            vals = " | ".join(f"{m[q] * UNITS[q][1]:.4g}" if m.get(q) is not None else "" for q in qs)
            lines.append(f"| {level} | {fmt(step)} | {vals} | {what} |")
        est = ref["quantities"]
        vals = " | ".join(f"{est[q]['value'] * UNITS[q][1]:.4g} +- {est[q]['uncertainty']:.1%} "
                          f"({'bound' if est[q]['bound'] else 'band'})" for q in qs)
        lines.append(f"| limit | 0 | {vals} | extrapolated |")
        return lines + [""]

    def markdown(self) -> str:
        lines = [f"# Accuracy vs cost ({self.mode} mode, {self.seconds:.0f} s in all)", ""]
        if self.provenance:
            pv = self.provenance
            lines += [f"vfrs commit {pv.get('commit', 'unknown')}"
                      + (" + uncommitted changes in python/ or rust/" if pv.get("dirty") else "") + ".", ""]
            eng = pv.get("engine")
            if eng:
                how = ("in one process, one run after another" if eng.get("serial") else
                       f"as one sweep on dask.distributed ({eng.get('scheduler')}, "
                       f"{eng.get('workers') or 'its'} worker(s), one thread each)")
                lines += [f"Every run (references and rows) ran {how}. Wall (s) is a run's own time (vfrs's clock, "
                          "less writing its output folder); peak MB its process's peak resident memory during the run. "
                          "Runs side by side on shared cores are slower than alone: compare the wall times of one "
                          "report, not across reports made with different workers.", ""]
        for name in dict.fromkeys(r.problem for r in self.rows):
            rows = self.table(name)
            front = self.front(name)
            doc = " ".join((PROBLEMS[name].__doc__ or "").split())
            lines += [f"## {name}", "", doc, ""]
            ref = self.references.get(name)
            if ref and ref.get("text"):
                lines += ["**Reference.** " + ref["text"], ""]
            more = [col for col in getattr(PROBLEMS[name], "scored", {}).values() if col != "error"] \
                if (ref or {}).get("kind") == "study" else []
            lines += ["Wall (s): the run's own time; contact (s): in the contact effect's hooks; step (s): in the "
                      "integrator's steps (the solves, and the contact hooks they call; for finite strain the "
                      "whole Newton iteration). Iterations: of the contact solver per step.", "",
                      "| setting | level | step | error | " + "".join(f"{c} | " for c in more)
                      + "wall (s) | contact (s) | step (s) | iterations | peak MB | unconverged steps | Pareto |",
                      "|---|---|---|---|" + "---|" * len(more) + "---|---|---|---|---|---|---|"]
            for r, f in sorted(zip(rows, front), key=lambda rf: rf[0].wall):
                step = "static" if r.step is None else f"{r.step:g}"
                pareto = "**yes**" if f else ""
                if r.failed:
                    pareto = f"failed: {r.failed}"
                extra = "".join(f"{r.metrics.get(c, float('nan')):.3e} | " for c in more)
                lines.append(
                    f"| {r.setting} | {r.level} | {step} | {r.error:.3e} | {extra}{r.wall:.3f} | {r.timings.get('contact', 0):.3f} | "
                    f"{r.timings.get('step', 0):.3f} | {r.iterations:.1f} | {r.peak_memory_mb:.0f} | "
                    f"{r.metrics.get('unconverged_steps', 0):.0f} | {pareto} |"
                )
            lines += [""]
            for t in self.targets(name):
                lines += [f"**Recommendation ({t * 100:g} %).** " + self.recommendation(name, t), ""]
            lines += self.family_comparison(name)
            lines += self.convergence(name)
            lines += self.kinematics(name)
        return "\n".join(lines)

    def kinematics(self, problem) -> list:
        """Markdown lines: a finite-strain problem's rows (one with a ``linear`` counterpart)
        beside the linear rows of the same setting, level and step: peak contact force of
        each and their relative difference, the cost of a step (own wall time over the steps)
        and its ratio, Newton iterations per step. Empty for other problems."""
        linear = getattr(PROBLEMS.get(problem), "linear", None)
        if linear is None:
            return []
        lin = {(r.setting, r.level, r.step): r for r in self.table(linear)}
        end = PROBLEMS[problem].end
        lines = ["### Kinematics: linear vs finite strain", "",
                 f"Each {problem} row beside the {linear} row of the same setting, mesh and step (the same "
                 "scene with the linear material): peak medio-lateral contact force on the right fold and its "
                 "contact impulse over the first closure, the finite-strain run's change of each, and the cost "
                 "of a step (the run's own time over its steps).", "",
                 "| setting | level | step | peak force linear (mN) | peak force finite (mN) | change "
                 "| impulse linear (uN s) | impulse finite (uN s) | change | ms/step linear "
                 "| ms/step finite | cost ratio | Newton iterations/step |",
                 "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in self.table(problem):
            other = lin.get((r.setting, r.level, r.step))
            if other is None or r.failed or other.failed or r.step is None:
                continue
            n = round(end / r.step)
            fa, fb = other.metrics["peak_force"], r.metrics["peak_force"]
            ia, ib = other.metrics["impulse"], r.metrics["impulse"]
            ca, cb = other.wall / n * 1e3, r.wall / n * 1e3
            lines.append(f"| {r.setting} | {r.level} | {r.step:g} | {fa * 1e3:.3f} | {fb * 1e3:.3f} | {(fb - fa) / fa:+.1%} "
                         f"| {ia * 1e6:.3f} | {ib * 1e6:.3f} | {(ib - ia) / ia:+.1%} "
                         f"| {ca:.2f} | {cb:.2f} | {cb / ca:.1f} | {r.metrics.get('newton_iterations', float('nan')):.2f} |")
        return lines + [""]

    def write(self, out):
        """``accuracy.csv``, ``accuracy.parquet`` (the same table), ``accuracy.json`` (with the
        references and provenance), ``accuracy.md`` and ``pareto_<problem>.png``, the figures
        drawn from the written table (:func:`pareto_figure`)."""
        os.makedirs(out, exist_ok=True)
        flat = [r.flat() for r in self.rows]
        keys = sorted({k for d in flat for k in d}, key=lambda k: (k not in flat[0], k)) if flat else []
        with open(os.path.join(out, "accuracy.csv"), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=keys)
            w.writeheader()
            w.writerows(flat)
        from ..sweep import write_table

        write_table(flat, out, [], name="accuracy", csv_too=False)
        with open(os.path.join(out, "accuracy.json"), "w") as fh:
            json.dump({"mode": self.mode, "seconds": self.seconds, "provenance": self.provenance,
                       "references": self.references, "rows": flat}, fh, indent=1, default=float)
        with open(os.path.join(out, "accuracy.md"), "w") as fh:
            fh.write(self.markdown())
        table = os.path.join(out, "accuracy.parquet")
        for name in dict.fromkeys(r.problem for r in self.rows):
            pareto_figure(table, name, os.path.join(out, f"pareto_{name}.png"))

    def plot(self, problem, path):
        """The Pareto figure of ``problem`` from this report's rows (:func:`pareto_figure`)."""
        flat = [r.flat() for r in self.rows]
        pareto_figure({k: [d.get(k) for d in flat] for k in ("problem", "method", "setting", "wall_s", "error")},
                      problem, path)


def pareto_figure(table, problem, path):
    """Error vs wall time of one problem's settings, one marker per method, the Pareto front
    joined and labelled: drawn from a summary table (``accuracy.parquet`` of a report, or a
    dict of columns with ``problem``, ``method``, ``setting``, ``wall_s`` and ``error``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not isinstance(table, dict):
        from ..extra import sweep_extra

        pq = sweep_extra("pyarrow.parquet", f"reading {table}")
        table = pq.read_table(table, columns=["problem", "method", "setting", "wall_s", "error"]).to_pydict()
    pick = [i for i, name in enumerate(table["problem"]) if name == problem]
    if not pick:
        raise ValueError(f"no rows of problem {problem!r} in the table (problems: {sorted(set(table['problem']))})")
    method = [table["method"][i] for i in pick]
    setting = [table["setting"][i] for i in pick]
    wall = np.array([np.nan if table["wall_s"][i] is None else table["wall_s"][i] for i in pick], dtype=float)
    error = np.array([np.nan if table["error"][i] is None else table["error"][i] for i in pick], dtype=float)
    front = pareto_front(wall, error)
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for i, m in enumerate(dict.fromkeys(method)):
        sel = [j for j in range(len(pick)) if method[j] == m and np.isfinite(error[j])]
        if not sel:
            continue
        ax.scatter(wall[sel], np.maximum(error[sel], 1e-16), marker=MARKERS[i % len(MARKERS)], label=m,
                   alpha=0.75, s=40)
    pf = sorted(np.flatnonzero(front), key=lambda j: wall[j])
    if pf:
        ax.plot(wall[pf], np.maximum(error[pf], 1e-16), "k--", lw=1, label="Pareto front")
        for j in pf:
            ax.annotate(setting[j], (wall[j], max(error[j], 1e-16)), fontsize=7, xytext=(4, 4), textcoords="offset points")
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
