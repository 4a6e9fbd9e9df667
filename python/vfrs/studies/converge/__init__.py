"""``vfrs converge SCENE -o OUT``: how close a scene's numbers are, and what closer costs.

The scene runs at a ladder of time steps (``h``, ``h/2``, ``h/4``) and of meshes (for the
M5 folds the systematic family's levels, every length 1.5 times smaller per level,
:mod:`vfrs.studies.converge.family`; ``--mesh-ladder levels`` the generator's resolutions;
any other mesh refined uniformly, ``refine = n``, ``n + 1``, ``n + 2``), every combination (a
3 x 3 grid), as one
sweep on the dask engine of :mod:`vfrs.studies.sweep` (resumable: a finished run is not run again).
For every number of the summary, each row and each column of the grid is a three-run study
(:func:`vfrs.studies.verification.verify`: the observed order, the extrapolated value, the GCI, or,
when the runs are not in the asymptotic range, the band of the three values and the words
oscillatory / divergent). Each run's error is its step part (the study along the step at its
mesh) plus its mesh part (along the mesh at its step).

The folder holds ``runs/`` and ``summary.csv`` (the sweep's, one row per run), and:

- ``converge.csv`` / ``converge.parquet``: one row per quantity and study (``axis`` step or
  mesh, ``at`` the fixed level), with the three values, the kind, order, extrapolated value
  and the GCI of each run;
- ``meshes.csv`` / ``meshes.parquet``: one row per mesh rung: its element size, DOFs, the
  mean and largest edge of the scene's contact surface, and each one's ratio to the coarser
  rung's (:func:`mesh_rows`; ``vfrs converge SCENE --plan`` prints them without running);
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
import json
import os
import sys

from ...errors import VfrsError
from .analyse import Quantity, Study, analyse, quantities_of
from .error_bars import (ASSUMED_ORDER, FS_TWO_RUNS, display_path, errors_for, load, step_companion, two_run_errors,
                         why_not, with_step_errors, with_study_errors)
from .plan import (DESIGNS, LEVELS, MESH_LADDERS, STEP_RATIO, Plan, Rung, mesh_ladder, mesh_rows, mesh_sizes, plan,
                   plan_lines, representative_size, scene_key, step_ladder)
from .report import CONVERGE_FILE, TARGETS, ConvergeResult, draw, markdown, projected_wall, recommend, write

__all__ = ["DESIGNS", "LEVELS", "STEP_RATIO", "CONVERGE_FILE", "TARGETS", "FS_TWO_RUNS", "ASSUMED_ORDER", "Rung", "Plan",
           "Quantity", "Study", "ConvergeResult", "mesh_ladder", "step_ladder", "plan", "plan_lines", "mesh_sizes",
           "mesh_rows", "MESH_LADDERS", "representative_size",
           "scene_key", "analyse", "recommend", "projected_wall", "converge", "finish", "write", "markdown", "draw",
           "load", "errors_for", "with_study_errors", "why_not", "display_path", "step_companion", "two_run_errors",
           "with_step_errors", "build_parser", "main"]


# ------------------------------------------------------------------------------------------
# Running a study
# ------------------------------------------------------------------------------------------

def converge(scene, out, *, steps: int = LEVELS, meshes: int = LEVELS, mesh_how: str = "auto",
             design: str = "grid", take_from=(),
             quantities: dict | None = None, workers: int | None = None, scheduler: str | None = None, scheduler_file: str | None = None,
             serial: bool = False, retries: int = 1, figures: bool = True, log=None,
             progress: bool | None = None) -> ConvergeResult:
    """Runs the study of ``scene`` (a Scene, a resolved scene dict or a scene file) into the
    folder ``out`` (finished runs of the same vfrs build are not run again) and writes its
    tables, text and figures. ``design``: every run of the grid or the cross through the base
    run (:data:`~vfrs.studies.converge.plan.DESIGNS`); ``take_from``: folders of other studies
    whose finished runs of this plan are taken, not run (:mod:`vfrs.studies.converge.take`).
    ``quantities``: more numbers to study besides the summary's,
    name = expression in the language of a sweep's derived columns (docs/sweeps.md), e.g.
    ``{"tip_uz": 'last(probes["probe_0.displacement"])[2]'}``. The other options are those of
    :func:`vfrs.studies.sweep.run_sweep`."""
    from ...scene import Scene
    from ..sweep import Sweep, run_sweep, summary_columns, write_table
    from .take import take

    if isinstance(scene, (str, os.PathLike)):
        scene = Scene.load(scene)
    p = plan(scene, steps=steps, meshes=meshes, mesh_how=mesh_how, design=design)
    out = os.fspath(out)
    taken, known, notes = take(p, take_from) if take_from else ({}, [], [])
    p.notes += notes
    todo = [r for r in p.runs if (r["mesh_level"], r["step_level"]) not in taken]
    rows, failed = [], 0
    if todo:
        sweep = Sweep.from_runs(f"converge {p.source}", [(r["labels"], r["scene"]) for r in todo],
                                derived=quantities, title=f"converge {p.source}")
        res = run_sweep(sweep, out, workers=workers, scheduler=scheduler, scheduler_file=scheduler_file,
                        retries=retries, serial=serial, log=log, progress=progress)
        rows, failed = res.rows, res.failed
    if taken:  # the table of every run of the study, taken or run
        os.makedirs(out, exist_ok=True)
        rows = list(taken.values()) + rows
        write_table(rows, out, summary_columns(["mesh", "step"], list(quantities or {})))
    return finish(p, rows, out, figures=figures, failed=failed, derived=quantities, known=known)


def finish(p: Plan, rows: list, out: str | None, *, figures: bool = True, failed: int = 0,
           derived: dict | None = None, known: list | None = None) -> ConvergeResult:
    """The studies of a plan's finished runs (the sweep's rows, in the plan's order) and,
    with ``out``, the files; ``derived``: the quantities given as expressions (their columns);
    ``known``: the quantities, when no run's summary.json is in ``out`` (runs taken from
    other studies)."""
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
                    quantities = quantities_of(json.load(fh))
                break
    quantities = quantities or list(known or [])
    quantities += [Quantity(name, "derived", name, "1", f"{name} = {expr}") for name, expr in (derived or {}).items()]
    studies, errors = analyse(p, grid, quantities)
    res = ConvergeResult(p, grid, quantities, studies, errors, out, failed)
    if out is not None:
        write(res, out, figures=figures)
    return res


# ------------------------------------------------------------------------------------------
# Command line
# ------------------------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="vfrs converge", description="Run a scene at a ladder of time steps (h, h/2, "
                                 "h/4) and meshes, and say for every number of its summary how far it is from the "
                                 "converged value and what a closer answer costs (docs/converge.md).")
    ap.add_argument("scene", help="scene file (.toml)")
    ap.add_argument("-o", "--out", help="output folder: runs/, summary.csv, converge.{csv,parquet,md,"
                    "txt,json}, errors.csv, figures/ (required unless --plan)")
    ap.add_argument("--plan", action="store_true", help="print the ladders (each mesh's element size and its contact "
                    "surface's edges, the steps) and the runs, and run nothing")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a scene value (TOML "
                    "syntax), as vfrs run")
    ap.add_argument("--steps", type=int, default=LEVELS, metavar="N", help=f"{LEVELS}: h, h/2, h/4 (default); 1: the "
                    "scene's step only")
    ap.add_argument("--meshes", type=int, default=LEVELS, metavar="N", help=f"{LEVELS}: three meshes (default); 1: the "
                    "scene's mesh only")
    ap.add_argument("--mesh-ladder", choices=MESH_LADDERS, default="auto",
                    help="family: the systematic M5 family's levels (every length / 1.5 per level); levels: the "
                    "generator's resolutions; refine: every tetrahedron split into eight, once and twice; auto "
                    "(default): the family when every body is the built-in m5 mesh, else levels where the meshes "
                    "have them, else refine")
    ap.add_argument("--design", choices=DESIGNS, default="grid", help="grid (default): every mesh at every step, "
                    "each run with its error; cross: the base mesh at every step and the base step on every mesh (5 "
                    "runs of 9), the base run's error only")
    ap.add_argument("--take", action="append", default=[], metavar="STUDY", help="a folder of another study (or "
                    "sweep) whose finished runs of this plan are taken, not run (matched by run id: the same "
                    "resolved scene); a run two of them hold must have the same numbers in both. E.g. a step study "
                    "(--meshes 1) and a mesh study (--steps 1) make the cross study")
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
    from ...checkpoint import RunStopped
    from ...scene.overrides import load_scene
    from ..sweep import check_engine

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
        if args.plan:
            p = plan(scene, steps=args.steps, meshes=args.meshes, mesh_how=args.mesh_ladder, design=args.design)
            print("\n".join([f"converge {p.source}: {len(p.meshes)} mesh(es) x {len(p.steps)} step(s) = {len(p.runs)} "
                             "runs (--plan: none run)", *plan_lines(p)]))
            return 0
        if not args.out:
            raise VfrsError("-o/--out is required to run the study (or --plan to print it only)")
        res = converge(scene, args.out, steps=args.steps, meshes=args.meshes, mesh_how=args.mesh_ladder,
                       design=args.design, take_from=args.take, quantities=quantities,
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
