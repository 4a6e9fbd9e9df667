"""The accuracy report's grid: the settings of each problem (method x resolution x step, or a
family of meshes), each cell run and measured on its own (:func:`run_row`), the references
that are runs (:func:`run_reference`), and the cheapest setting within a target error
(:func:`recommend`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .problems import PROBLEMS


MARKERS = "os^Dxv<>p*"  # one per method, in the grid's order (lagrange, penalty, AL, ...)
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
    from ...run import run
    from ...scene import Scene

    from ..sweep.task import reset_peak_rss, rss_mb

    own = reset_peak_rss()
    res = run(Scene.from_dict(scene_dict), progress=False)
    rss = rss_mb() if own else None
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


def grid_cell(mode, problem, setting, level, step):
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
    contact, level, step = grid_cell(mode, problem, setting, level, step)
    row = Row(problem, setting, contact["method"], str(level), step, float("nan"), float("nan"))
    try:
        metrics, wall, rss, timings, iters = _measured(p, p.scene(contact, level, step), reference)
        row.error, row.wall, row.metrics = float(metrics["error"]), wall, metrics
        row.timings, row.iterations, row.peak_memory_mb = timings, iters, rss
    except Exception as e:  # a failing setting is a result, not the end of the report
        row.failed = str(e).splitlines()[0][:200]
    return row


def reference_study_of(p, mode):
    """The problem's reference study (:class:`vfrs.studies.accuracy.reference.ReferenceStudy`) in this
    mode, or None (a closed form, or one reference run with its checks)."""
    f = getattr(p, "reference_study", None)
    return f(mode) if f is not None else None


def estimates(p, study, runs: list) -> dict:
    """The reference record of a study from its runs (records with ``level``, ``step`` and
    ``metrics``): per scored metric its :class:`~vfrs.studies.accuracy.reference.Estimate`, the cross
    family's study, and ``metrics`` = the values the rows are scored against."""
    from .reference import estimate, mesh_size
    from ..verification import verify

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


def reference_checks(p, mode) -> list:
    """The reference's sensitivity checks of problem ``p``: (key in the reference record,
    sweep role, (contact, level, step)); one mesh level coarser (``check``) and twice the
    step (``step_check``), those the problem defines."""
    out = []
    if hasattr(p, "reference_check_setting"):
        out.append(("check", "reference check", p.reference_check_setting(mode)))
    if hasattr(p, "reference_step_check_setting"):
        out.append(("step_check", "reference step check", p.reference_step_check_setting(mode)))
    return out


def check_changes(p, ref: dict) -> None:
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
        metrics = {k: v for k, v in metrics.items() if k not in REFERENCE_DROPPED}
        if progress:
            print(f"[{problem}] {what}: {wall:.1f} s", flush=True)
        return {"method": contact["method"], "level": str(level), "step": step, "wall_s": wall,
                "peak_memory_mb": rss, "metrics": metrics}

    study = reference_study_of(p, mode)
    if study is not None:
        cells = study.cells()
        if check_only:  # the cheapest run of the study: the coarsest mesh at the reference step
            level, step = cells[0]
            return {"kind": "study", "runs": [one(study.contact, level, step, "reference")]}
        runs = [one(study.contact, level, step, "reference") for level, step in cells]
        ref = {"kind": "study", "method": study.contact["method"], "runs": runs,
               **estimates(p, study, runs)}
        ref["text"] = p.reference_text(mode, ref)
        return ref
    checks = reference_checks(p, mode)
    if check_only:
        key, role, (contact, level, step) = checks[0]
        return {"kind": "run", key: one(contact, level, step, role)}
    contact, level, step = p.reference_setting(mode)
    ref = {"kind": "run", **one(contact, level, step, "reference")}
    for key, role, (contact, level, step) in checks:
        ref[key] = one(contact, level, step, role)
    check_changes(p, ref)
    ref["text"] = p.reference_text(mode, ref)
    return ref


# Metrics of a reference run that are errors against a reference (not measured on it).
REFERENCE_DROPPED = ("error", "area_error", "peak_force_error", "pressure_error")


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

    Against an extrapolated reference (:mod:`vfrs.studies.accuracy.reference`): ``error_key`` names the
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
