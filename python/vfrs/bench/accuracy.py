"""What accuracy costs in time: a grid of contact settings x resolutions x time steps, each
run measured for its error (against a closed form or a reference run), its wall time split
by effect, its iterations and its peak memory.

``vfrs bench accuracy [--quick] -o out/accuracy`` writes ``accuracy.csv``, ``accuracy.json``,
``accuracy.md`` (tables, the Pareto-optimal settings and a recommendation per problem) and
``pareto_<problem>.png``.

A problem's reference is never one of the settings it judges: closed forms for the block,
Hertz and the bars; for the M5 folds a Lagrange run on a finer mesh with a smaller step than
every row (``accuracy.json`` records it under ``references``, with its wall time and its two
sensitivity checks: one mesh level coarser, ``check``, and twice the step, ``step_check``).
One row
can be re-run on its own with :func:`run_row` (what ``tests/test_committed_results.py`` does
to keep the committed tables tied to the code).
"""

from __future__ import annotations

import csv
import json
import math
import os
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .pareto import pareto_front
from .problems import PROBLEMS

if TYPE_CHECKING:
    from ..sweep import Sweep

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
    if hasattr(p, "settings"):
        return [(label, dict(contact)) for label, contact in p.settings[mode]]
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
    run: str = ""  # the run's id in the report's sweep (its folder: sweep/runs/<run>)

    def flat(self) -> dict:
        d = {
            "problem": self.problem, "setting": self.setting, "method": self.method, "level": self.level,
            "step": self.step, "error": self.error, "wall_s": self.wall, "iterations": self.iterations,
            "peak_memory_mb": self.peak_memory_mb, "failed": self.failed, "run": self.run,
        }
        d.update({f"t_{k}": self.timings.get(k, 0.0) for k in EFFECT_KEYS})
        d.update({f"m_{k}": v for k, v in self.metrics.items() if k != "error"})
        return d


def _run_one(scene_dict):
    """Runs a scene in this process; returns (result, its own time: vfrs's clock ``total``,
    peak resident memory in MB during the run, as in the report's sweep)."""
    from ..run import run
    from ..scene import Scene

    from ..sweep import _reset_peak_rss, _rss_mb

    own = _reset_peak_rss()
    res = run(Scene.from_dict(scene_dict), progress=False)
    rss = _rss_mb() if own else None
    return res, float(res.timings["total"]), float("nan") if rss is None else rss


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
    includes = getattr(p(), "includes", None)
    return [(label, contact, level, step)
            for label, contact in method_grid(mode, problem)
            for level in p.levels[mode]
            for step in p.steps[mode]
            if includes is None or includes(label, level, step)]


def _grid_cell(mode, problem, setting, level, step):
    """The grid cell a (setting, level, step) key names; level may be given as the table
    prints it (``str(level)``), step as a float or None."""
    for label, contact, lv, h in grid_cells(mode, problem):
        if label != setting or str(lv) != str(level):
            continue
        if (h is None and step is None) or (h is not None and step is not None and math.isclose(h, float(step), rel_tol=1e-9)):
            return contact, lv, h
    raise KeyError(f"{problem} ({mode} mode) has no row {setting!r} at {_where(level, step)}")


def run_row(problem: str, setting: str, level, step, mode="full", reference=None) -> Row:
    """Runs one row of the grid (``setting`` as labelled in the table, ``level`` as an entry
    of the problem's levels or as printed, ``step`` as printed or None) exactly as
    :func:`run_accuracy` does (in this process, not as a task of a sweep: the same scene and
    measurement) and returns it; ``reference`` is the reference run's metrics
    (``references[problem]["metrics"]`` of ``accuracy.json``) for problems measured against
    one (M5; without it their error is NaN, the other metrics are measured). A failing run is
    a row with ``failed`` set."""
    p = PROBLEMS[problem]()
    contact, level, step = _grid_cell(mode, problem, setting, level, step)
    row = Row(problem, setting, contact["method"], str(level), step, float("nan"), float("nan"))
    try:
        metrics, wall, rss, timings, iters = _measured(p, p.scene(contact, level, step), reference)
        row.error, row.wall, row.metrics = float(metrics["error"]), wall, metrics
        row.timings, row.iterations, row.peak_memory_mb = timings, iters, rss
    except Exception as e:  # a failing setting is a result, not the end of the report
        row.failed = str(e).splitlines()[0][:200]
    return row


def _study(p, mode):
    """The problem's reference study (:class:`vfrs.bench.reference.ReferenceStudy`) in this
    mode, or None (a closed form, or one reference run with its checks)."""
    f = getattr(p, "reference_study", None)
    return f(mode) if f is not None else None


def _estimates(p, study, runs: list) -> dict:
    """The reference record of a study from its runs (records with ``level``, ``step`` and
    ``metrics``): per scored metric its :class:`~vfrs.bench.reference.Estimate`, the cross
    family's study, and ``metrics`` = the values the rows are scored against."""
    from .reference import estimate, mesh_size
    from ..studies.verification import verify

    def at(level, step):
        for r in runs:
            if r["level"] == level and math.isclose(r["step"], step):
                return r["metrics"]
        raise KeyError(f"{p.name}: the reference study has no run on {level} at h = {step:g}")

    h = {lv: mesh_size(p.scene(study.contact, lv, study.mesh_step)) for lv in (*study.meshes, *study.cross)}
    quantities, cross, values = {}, {}, {}
    for q in (*p.scored, "max_area"):
        mv = [at(lv, study.mesh_step).get(q) for lv in study.meshes]
        sv = [at(study.step_level, hh).get(q) for hh in study.steps]
        if any(v is None for v in mv + sv):
            continue
        e = estimate(mv, [h[lv] for lv in study.meshes], sv, study.steps)
        quantities[q], values[q] = e.to_dict(), e.value
        if len(study.cross) == 3:
            cv = [at(lv, study.mesh_step).get(q) for lv in study.cross]
            cross[q] = verify(cv[::-1], [h[lv] for lv in study.cross][::-1]).to_dict()
    return {"quantities": quantities, "cross": cross, "metrics": values, "mesh_h": h}


def _reference_checks(p, mode) -> list:
    """The reference's sensitivity checks of problem ``p``: (key in the reference record,
    sweep role, (contact, level, step)); one mesh level coarser (``check``) and twice the
    step (``step_check``), those the problem defines."""
    out = []
    if hasattr(p, "reference_check_setting"):
        out.append(("check", "reference check", p.reference_check_setting(mode)))
    if hasattr(p, "reference_step_check_setting"):
        out.append(("step_check", "reference step check", p.reference_step_check_setting(mode)))
    return out


def _changes(p, ref: dict) -> None:
    """Sets ``change`` (relative change of the problem's scored quantity against the
    reference) on each check of a reference record."""
    q = getattr(p, "quantity", "peak_force")
    for key in ("check", "step_check"):
        chk = ref.get(key)
        if chk and "metrics" in chk and "metrics" in ref:
            a, b = ref["metrics"][q], chk["metrics"][q]
            chk["change"] = abs(b - a) / abs(a)


def run_reference(problem: str, mode="full", progress=False, check_only=False) -> dict:
    """The problem's reference: ``{"kind": "exact", "text": ...}`` for a closed form, or for a
    reference run (M5) its setting, metrics, wall time and its sensitivity checks (the same
    run one mesh level coarser, ``check``, and with twice the step, ``step_check``; each
    with ``change`` = relative change of the scored quantity, ``quantity`` of the problem).
    ``check_only``: only the mesh check (``{"kind": "run", "check": ...}``, the same code
    path at a fraction of the cost)."""
    p = PROBLEMS[problem]()
    if not hasattr(p, "reference_setting"):
        return {"kind": "exact", "text": p.reference_text(mode)}

    def one(contact, level, step, what):
        if progress:
            print(f"[{problem}] {what}: {contact['method']} at {level}, h={step:g}", flush=True)
        metrics, wall, rss, _, _ = _measured(p, p.scene(contact, level, step), None)
        metrics = {k: v for k, v in metrics.items() if k not in _REFERENCE_DROPPED}
        if progress:
            print(f"[{problem}] {what}: {wall:.1f} s", flush=True)
        return {"method": contact["method"], "level": str(level), "step": step, "wall_s": wall,
                "peak_memory_mb": rss, "metrics": metrics}

    study = _study(p, mode)
    if study is not None:
        cells = study.cells()
        if check_only:  # the cheapest run of the study: the coarsest mesh at the reference step
            level, step = cells[0]
            return {"kind": "study", "runs": [one(study.contact, level, step, "reference")]}
        runs = [one(study.contact, level, step, "reference") for level, step in cells]
        ref = {"kind": "study", "method": study.contact["method"], "runs": runs,
               **_estimates(p, study, runs)}
        ref["text"] = p.reference_text(mode, ref)
        return ref
    checks = _reference_checks(p, mode)
    if check_only:
        key, role, (contact, level, step) = checks[0]
        return {"kind": "run", key: one(contact, level, step, role)}
    contact, level, step = p.reference_setting(mode)
    ref = {"kind": "run", **one(contact, level, step, "reference")}
    for key, role, (contact, level, step) in checks:
        ref[key] = one(contact, level, step, role)
    _changes(p, ref)
    ref["text"] = p.reference_text(mode, ref)
    return ref


# Metrics of a reference run that are errors against a reference (not measured on it).
_REFERENCE_DROPPED = ("error", "area_error", "peak_force_error", "pressure_error")


def _neighbour_text(kind, n) -> str:
    return f"on the next finer mesh {n.level}" if kind == "mesh" else f"at the next finer step h = {n.step:g}"


def recommend(problem: str, rows, target=0.01, levels=None, reference_spread=None, spread_note="", *,
              error_key: str = "error", margin: float = 0.0, bound: bool = True, what: str = "",
              families=None) -> str:
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
    are ordered by size (None for static problems). ``families``: lists of levels coarse to
    fine instead, a row confirmed on the next finer level of its own family.

    Against an extrapolated reference (:mod:`vfrs.bench.reference`): ``error_key`` names the
    row's error column (``error``, or a metric's ``m_...`` key without the prefix), ``margin``
    is the reference's own uncertainty (relative), added to every error before it is compared
    with the target (error + margin bounds the distance to the limit; ``bound`` False: the
    margin is a band, and the text says so), ``what`` names the metric."""
    rows = [r for r in rows if r.problem == problem]

    def err(r) -> float:
        v = r.error if error_key == "error" else r.metrics.get(error_key, math.nan)
        return float(v) + margin if v is not None else math.nan

    finite = [r for r in rows if not r.failed and math.isfinite(err(r))]
    if not finite:
        return f"{problem}: no runs."
    pct = f"{target * 100:g}%"
    on = f" on the {what}" if what else ""
    head = f"{problem}: no robust recommendation for {pct} error{on}"
    if reference_spread is not None and reference_spread > target:
        return (f"{head}: the reference itself moves by {reference_spread:.1%}{' ' + spread_note if spread_note else ''}, "
                "more than the target, so errors that small are not resolved; see the table.")
    margin_kind = "bound" if bound else "band, not a bound"
    if margin >= target:
        return (f"{head}: the extrapolated reference is itself uncertain by {margin:.1%} ({margin_kind}), "
                "so errors that small are not resolved; see the table.")
    finer = _finer_cells(rows, levels, families)

    plus = f" with the reference's {margin:.1%} ({margin_kind})" if margin else ""
    ok = [r for r in finite if err(r) <= target]
    if not ok:
        best = min(finite, key=err)
        return (f"{head}: no setting reached it{plus}; the most accurate was {best.setting} at "
                f"{_where(best.level, best.step)} ({err(best):.2%}, {best.wall:.2f} s); see the table.")
    supported, unconfirmed = [], []
    for r in ok:
        nb = finer(r)
        bad = [(kind, n) for kind, n in nb if n.failed or not math.isfinite(err(n)) or err(n) > target]
        if nb and not bad:
            supported.append((r, nb))
        else:
            unconfirmed.append((r, bad))
    if not supported:
        return _unconfirmed_text(head, plus, ok, unconfirmed, err)
    fastest = min(r.wall for r, _ in supported)
    r, nb = min(((r, nb) for r, nb in supported if r.wall <= 1.2 * fastest), key=lambda rn: err(rn[0]))
    confirm = " and ".join(f"{err(n):.2%} {_neighbour_text(kind, n)}" for kind, n in nb)
    measured = (f"error {err(r) - margin:.2%} + the reference's {margin:.2%} ({margin_kind}) = {err(r):.2%}" if margin
                else f"error {err(r):.2%}")
    return (f"{problem}: for {pct} error{on} use {r.setting} at {_where(r.level, r.step)}: "
            f"{measured}, {r.wall:.2f} s wall (confirmed: {confirm}).")


def _finer_cells(rows, levels, families):
    """``finer(row)``: the cells that confirm a row of :func:`recommend`'s table, as
    ("mesh" | "step", row) pairs: the same setting on the next finer level of its family (same
    step) and at the next finer step (same level), those the table has."""
    fams = [list(f) for f in families] if families is not None else [
        list(levels) if levels is not None else list(dict.fromkeys(r.level for r in rows))]
    steps = sorted({r.step for r in rows if r.step is not None}, reverse=True)
    cell = {(r.setting, r.level, r.step): r for r in rows}

    def next_level(level):
        for fam in fams:
            if level in fam and fam.index(level) + 1 < len(fam):
                return fam[fam.index(level) + 1]
        return None

    def finer(r):
        out = []
        nxt = next_level(r.level)
        if nxt is not None and (r.setting, nxt, r.step) in cell:
            out.append(("mesh", cell[(r.setting, nxt, r.step)]))
        if r.step is not None:
            j = steps.index(r.step)
            if j + 1 < len(steps) and (r.setting, r.level, steps[j + 1]) in cell:
                out.append(("step", cell[(r.setting, r.level, steps[j + 1])]))
        return out

    return finer


def _unconfirmed_text(head, plus, ok, unconfirmed, err) -> str:
    """:func:`recommend`'s text when cells reached the target but none is confirmed by the
    finer ones: the three cheapest, each with what failed to confirm it."""
    def why(r, bad):
        if not bad:
            return f"{r.setting} at {_where(r.level, r.step)}: {err(r):.2%}, but nothing finer in the table confirms it"
        kind, n = bad[0]
        val = f"failed ({n.failed})" if n.failed else f"{err(n):.2%}"
        return f"{r.setting} at {_where(r.level, r.step)}: {err(r):.2%}, but {val} {_neighbour_text(kind, n)}"

    shown = sorted(unconfirmed, key=lambda rb: rb[0].wall)[:3]
    more = len(unconfirmed) - len(shown)
    return (f"{head}: {len(ok)} cell(s) reached it{plus}, none confirmed at the next finer step and mesh ("
            + "; ".join(why(*rb) for rb in shown) + (f"; {more} more" if more > 0 else "") + "); see the table.")


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
        lines = ["### Reference study and convergence of what is scored", "",
                 f"The {ref.get('method')} runs of the reference study and the {ref.get('method')} rows, by mesh "
                 "and step; last, the limit each metric is scored against, with its uncertainty (bound: the GCIs of "
                 "monotone studies; band: the range of an oscillatory or divergent one).", "",
                 f"| level | step (us) | {head} | run |", "|---|---|" + "---|" * len(qs) + "---|"]
        for level, step, m, what in runs:
            vals = " | ".join(f"{m[q] * UNITS[q][1]:.4g}" if m.get(q) is not None else "" for q in qs)
            lines.append(f"| {level} | {step * 1e6:g} | {vals} | {what} |")
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
        import pyarrow.parquet as pq

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
        ax.scatter(wall[sel], np.maximum(error[sel], 1e-16), marker=_MARKERS[i % len(_MARKERS)], label=m,
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


def accuracy_sweep(mode: str, problems) -> "Sweep":
    """The report's runs as one sweep (:class:`vfrs.sweep.Sweep`): per problem its reference
    runs (``role`` "reference", "reference check" and "reference step check", M5 only) and
    every grid cell (``role`` "row"), labelled by ``problem``, ``role``, ``setting``, ``level``
    (as printed) and ``step``."""
    from ..sweep import Sweep

    runs = []
    for name in problems:
        p = PROBLEMS[name]()
        study = _study(p, mode)
        if study is not None:
            for level, step in study.cells():
                runs.append(({"problem": name, "role": "reference", "setting": study.contact["method"],
                              "level": str(level), "step": step}, p.scene(study.contact, level, step)))
        elif hasattr(p, "reference_setting"):
            contact, level, step = p.reference_setting(mode)
            runs.append(({"problem": name, "role": "reference", "setting": contact["method"], "level": str(level),
                          "step": step}, p.scene(contact, level, step)))
            for _, role, (contact, level, step) in _reference_checks(p, mode):
                runs.append(({"problem": name, "role": role, "setting": contact["method"],
                              "level": str(level), "step": step}, p.scene(contact, level, step)))
        for label, contact, level, step in grid_cells(mode, name):
            runs.append(({"problem": name, "role": "row", "setting": label, "level": str(level), "step": step},
                         p.scene(contact, level, step)))
    return Sweep.from_runs(f"vfrs bench accuracy ({mode} mode)", runs, title=f"accuracy vs cost, {mode} mode")


class _Finished:
    """A finished run of the report's sweep, read back from its folder: what
    :meth:`Problem.measure` reads (``history``) and what the table reports of its cost."""

    def __init__(self, folder):
        from ..sweep import own_time, read_run

        rec, self.history = read_run(folder)
        self.timings = dict(rec.get("timings") or {})
        self.wall = own_time(self.timings)  # as an in-memory run (run_row) would take
        self.peak_memory_mb = float(rec["peak_rss_mb"]) if rec.get("peak_rss_mb") is not None else float("nan")


def _measure_folder(problem, folder, reference):
    run = _Finished(folder)
    metrics = problem.measure(run, reference)
    h = run.history
    if "contact_converged" in h:
        metrics["unconverged_steps"] = int(np.count_nonzero(np.asarray(h["contact_converged"]) == 0))
    iters = float(np.mean(h["iterations"])) if "iterations" in h else 0.0
    return metrics, run.wall, run.peak_memory_mb, run.timings, iters


def run_accuracy(mode="quick", problems=None, out=None, progress=True, *, workers: int | None = 1,
                 scheduler: str | None = None, scheduler_file: str | None = None, serial: bool = False,
                 runs=None, retries: int = 0) -> AccuracyReport:
    """Runs the grid (``mode`` "quick" or "full") for ``problems`` (default: every problem
    whose ``modes`` include ``mode``: in quick mode the block, Hertz and the bars; in full mode
    also the M5 folds) as one sweep on dask.distributed (:func:`vfrs.sweep.run_sweep`) and
    returns the report; with ``out``, writes it there.

    Every run (references and grid cells) is a task of :func:`accuracy_sweep` writing its run
    folder under ``runs`` (default ``out/sweep``, or a temporary folder without ``out``);
    the rows are measured from those folders afterwards. ``workers`` (default 1: the wall
    times are the report's product, and runs side by side slow each other by about 10 % on
    this machine), ``scheduler``/``scheduler_file`` (an existing cluster) and ``serial`` (no
    dask) choose the engine as for ``vfrs sweep``. A finished run is not run again by the
    same vfrs build (an interrupted report continues where it stopped)."""
    import tempfile

    from ..sweep import run_sweep

    if mode not in ("quick", "full"):
        raise ValueError(f"mode must be 'quick' or 'full', got {mode!r}")
    if problems is None:
        problems = [name for name, p in PROBLEMS.items() if mode in p.modes]
    unknown = [p for p in problems if p not in PROBLEMS]
    if unknown:
        raise ValueError(f"unknown problem {unknown[0]!r}; choose from {sorted(PROBLEMS)}")
    t_start = time.perf_counter()
    sweep = accuracy_sweep(mode, problems)
    if runs is None:
        runs = os.path.join(out, "sweep") if out is not None else tempfile.mkdtemp(prefix="vfrs-accuracy-")
    os.makedirs(runs, exist_ok=True)
    with open(os.path.join(runs, ".gitignore"), "w") as fh:  # run folders: inputs of the report, not results
        fh.write("*\n")
    done = run_sweep(sweep, runs, workers=None if serial else workers, scheduler=scheduler,
                     scheduler_file=scheduler_file, retries=retries, serial=serial,
                     log=None if progress else (lambda msg: None), progress=None if progress else False)
    finished = [(spec, row, os.path.join(runs, "runs", spec["id"])) for spec, row in zip(sweep.runs, done.rows)]

    references = _references(problems, mode, finished)
    rows = _rows(finished, mode, references, progress)
    engine = {"workers": 1 if serial else (workers if not (scheduler or scheduler_file) else None),
              "serial": serial, "scheduler": scheduler or scheduler_file or "embedded LocalCluster",
              "runs": os.path.abspath(runs)}
    report = AccuracyReport(rows, mode, time.perf_counter() - t_start, references, {**provenance(), "engine": engine})
    if out is not None:
        report.write(out)
    return report


def _references(problems, mode: str, finished: list) -> dict:
    """Each problem's reference for the report: exact, or measured from its reference runs
    among ``finished`` ((spec, sweep row, folder) per run) with the checks of its changes."""
    references: dict = {}
    for name in problems:
        p = PROBLEMS[name]()
        if not hasattr(p, "reference_setting"):
            references[name] = {"kind": "exact", "text": p.reference_text(mode)}
            continue
        study = _study(p, mode)
        ref: dict = {"kind": "study" if study is not None else "run"}
        runs = []
        for spec, row, folder in finished:
            par = spec["params"]
            if par["problem"] != name or par["role"] == "row":
                continue
            if row["status"] != "complete":
                raise RuntimeError(f"{name}: the {par['role']} run ({par['setting']} at {par['level']}, "
                                   f"h = {par['step']}) failed: {row['error']} (its folder: {folder})")
            metrics, wall, rss, _, _ = _measure_folder(p, folder, None)
            one = {"method": par["setting"], "level": par["level"], "step": par["step"], "wall_s": wall,
                   "peak_memory_mb": rss, "run": spec["id"],
                   "metrics": {k: v for k, v in metrics.items() if k not in _REFERENCE_DROPPED}}
            if study is not None:
                runs.append(one)
            elif par["role"] == "reference":
                ref.update(one)
            else:
                ref[{role: key for key, role, _ in _reference_checks(p, mode)}[par["role"]]] = one
        if study is not None:
            ref.update(method=study.contact["method"], runs=runs, **_estimates(p, study, runs))
        else:
            _changes(p, ref)
        ref["text"] = p.reference_text(mode, ref)
        references[name] = ref
    return references


def _rows(finished: list, mode: str, references: dict, progress: bool) -> list:
    """The report's rows, measured from the grid cells' run folders among ``finished``
    against their problem's reference (a failed run is a row marked failed)."""
    rows = []
    for spec, srow, folder in finished:
        par = spec["params"]
        if par["role"] != "row":
            continue
        p = PROBLEMS[par["problem"]]()
        contact, level, step = _grid_cell(mode, par["problem"], par["setting"], par["level"], par["step"])
        row = Row(par["problem"], par["setting"], contact["method"], str(level), step, float("nan"), float("nan"))
        row.run = spec["id"]
        if srow["status"] != "complete":  # a failing setting is a result, not the end of the report
            row.failed = str(srow.get("error") or "failed").splitlines()[0][:200]
        else:
            metrics, wall, rss, timings, iters = _measure_folder(p, folder, references[par["problem"]].get("metrics"))
            row.error, row.wall, row.metrics = float(metrics["error"]), wall, metrics
            row.timings, row.iterations, row.peak_memory_mb = timings, iters, rss
        rows.append(row)
        if progress:
            print(f"[{row.problem}] {row.setting:28s} {row.level:12s} h={row.step}: error {row.error:.3e}  "
                  f"{row.wall:.2f} s" + (f"  FAILED {row.failed}" if row.failed else ""), flush=True)
    return rows


def rebuild(out, runs=None) -> AccuracyReport:
    """The report of ``out`` measured again from its finished run folders (``runs``, default
    ``out/sweep``) with this code's measurement and text, no run made: how a report's tables,
    references and recommendations are redone after a change to how they are computed or
    written. The mode, problems, total seconds and engine are those ``out/accuracy.json``
    records; ``provenance`` gets this code's commit and keeps the runs' (``runs_commit``). A
    run the grid needs and the folder lacks is an error (run the report instead)."""
    from ..sweep import RUN_FILE

    with open(os.path.join(out, "accuracy.json")) as fh:
        old = json.load(fh)
    mode = old["mode"]
    problems = list(dict.fromkeys(r["problem"] for r in old["rows"]))
    runs = runs or os.path.join(out, "sweep")
    finished = []
    for spec in accuracy_sweep(mode, problems).runs:
        folder = os.path.join(runs, "runs", spec["id"])
        try:
            with open(os.path.join(folder, RUN_FILE)) as fh:
                rec = json.load(fh)
        except OSError:
            raise FileNotFoundError(f"{folder}: no finished run for {spec['params']} (run the report: "
                                    "vfrs bench accuracy)") from None
        finished.append((spec, {"status": rec["status"], "error": rec.get("error")}, folder))
    references = _references(problems, mode, finished)
    rows = _rows(finished, mode, references, progress=False)
    prov = {**provenance(), "engine": (old.get("provenance") or {}).get("engine"),
            "runs_commit": (old.get("provenance") or {}).get("runs_commit") or (old.get("provenance") or {}).get("commit")}
    report = AccuracyReport(rows, mode, float(old["seconds"]), references, prov)
    report.write(out)
    return report
