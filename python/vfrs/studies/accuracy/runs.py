"""The accuracy report as one sweep of run folders (:func:`accuracy_sweep`, run by
:func:`run_accuracy`), measured afterwards from the folders; :func:`rebuild` measures an
existing sweep folder again."""

from __future__ import annotations

import json
import os
import time
from typing import TYPE_CHECKING

import numpy as np

from .grid import (REFERENCE_DROPPED, Row, check_changes, estimates, grid_cell, grid_cells, provenance, reference_checks,
                   reference_study_of)
from .problems import PROBLEMS
from .report import AccuracyReport

if TYPE_CHECKING:
    from ..sweep import Sweep


def accuracy_sweep(mode: str, problems) -> "Sweep":
    """The report's runs as one sweep (:class:`vfrs.studies.sweep.Sweep`): per problem its reference
    runs (``role`` "reference", "reference check" and "reference step check", M5 only) and
    every grid cell (``role`` "row"), labelled by ``problem``, ``role``, ``setting``, ``level``
    (as printed) and ``step``."""
    from ..sweep import Sweep

    runs = []
    for name in problems:
        p = PROBLEMS[name]()
        study = reference_study_of(p, mode)
        if study is not None:
            for level, step in study.cells():
                runs.append(({"problem": name, "role": "reference", "setting": study.contact["method"],
                              "level": str(level), "step": step}, p.scene(study.contact, level, step)))
        elif hasattr(p, "reference_setting"):
            contact, level, step = p.reference_setting(mode)
            runs.append(({"problem": name, "role": "reference", "setting": contact["method"], "level": str(level),
                          "step": step}, p.scene(contact, level, step)))
            for _, role, (contact, level, step) in reference_checks(p, mode):
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
    also the M5 folds) as one sweep on dask.distributed (:func:`vfrs.studies.sweep.run_sweep`) and
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
        study = reference_study_of(p, mode)
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
                   "metrics": {k: v for k, v in metrics.items() if k not in REFERENCE_DROPPED}}
            if study is not None:
                runs.append(one)
            elif par["role"] == "reference":
                ref.update(one)
            else:
                ref[{role: key for key, role, _ in reference_checks(p, mode)}[par["role"]]] = one
        if study is not None:
            ref.update(method=study.contact["method"], runs=runs, **estimates(p, study, runs))
        else:
            check_changes(p, ref)
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
        contact, level, step = grid_cell(mode, par["problem"], par["setting"], par["level"], par["step"])
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
