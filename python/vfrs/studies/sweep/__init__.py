"""``vfrs sweep SWEEP.toml -o OUT``: many runs of one scene, each a task on dask.distributed.

A sweep file names a base scene and the axes to vary::

    base = "../m5_collision.toml"        # relative to the sweep file; or an inline [base] table
    mode = "grid"                        # "grid": every combination (default); "list": axes zipped
    [set]                                # optional: fixed changes to the base (--set key paths)
    "time.end" = 0.01
    [[axes]]
    key = "flow.subglottal_pressure"     # any key path `vfrs run --set` accepts
    values = [600.0, 800.0]
    [[axes]]
    key = "contact.method"
    values = ["lagrange", "augmented_lagrange"]
    [derived]                            # optional named columns (a small safe expression language)
    peak_force_mN = "summary.contact.peak_force.right * 1e3"

Every combination is validated as a scene before anything runs (a bad key or value is a
SceneError naming the sweep file, the axis and the key; no folder is created). Each run is
one task writing ``OUT/runs/<id>/`` - the layout of ``vfrs run -o`` plus ``params.json`` (the
swept values) and ``sweep_run.json`` (status, error, attempts, wall time) - into
``OUT/runs/<id>.tmp-<pid>`` first, renamed when it ends. ``<id>`` is a hash of the resolved
scene (:func:`run_id_of`), so a finished run is found again and skipped on a re-run; a
failed run is retried (``--retries``); a run whose worker died is taken over by the task dask
reschedules and resumed from its last checkpoint. ``OUT/summary.parquet`` and ``OUT/summary.csv`` hold
one row per combination: the swept values, status, error, wall time, the derived columns and
every number of the run's ``summary.json`` (units in the column names). ``docs/sweeps.md``.

The package: :mod:`~vfrs.studies.sweep.spec` (the sweep file, read and checked),
:mod:`~vfrs.studies.sweep.task` (one run), :mod:`~vfrs.studies.sweep.execute` (the runs on
dask or in this process) and :mod:`~vfrs.studies.sweep.table` (the results table); this
``__init__`` holds the command and re-exports what users and the other studies call. dask and
pyarrow come with the ``sweep`` extra: ``pip install "vfrs[sweep]"``.
"""

from __future__ import annotations

import argparse
import sys

from ...errors import VfrsError
from .execute import SweepResult, check_engine, check_extra, derived_failures, run_sweep
from .spec import ADDED_KEYS, RUN_OPTIONS, Axis, Sweep, check_derived_names, load_sweep, run_id_of
from .table import RUN_FACTS, flatten_summary, summary_columns, summary_names, write_table
from .task import PARAMS_FILE, RUN_FILE, THREAD_VARS, code_id, collect, is_finished, own_time, read_run, run_task

__all__ = ["Sweep", "Axis", "load_sweep", "run_sweep", "SweepResult", "run_task", "collect", "read_run", "own_time",
           "is_finished", "code_id", "run_id_of", "summary_names", "summary_columns", "write_table", "flatten_summary",
           "check_derived_names", "derived_failures", "check_engine", "check_extra", "build_parser", "main",
           "RUN_FILE", "PARAMS_FILE", "THREAD_VARS", "RUN_FACTS", "RUN_OPTIONS", "ADDED_KEYS"]


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="vfrs sweep", description="Run a sweep of scenes (docs/sweeps.md) on "
                                 "dask.distributed: an embedded LocalCluster by default, or an existing cluster.")
    ap.add_argument("sweep", help="sweep file (.toml): base scene, axes, derived columns")
    ap.add_argument("-o", "--out", required=True, help="output folder: runs/<id>/ per run, summary.parquet/.csv")
    ap.add_argument("--workers", type=int, metavar="N", help="worker processes of the embedded cluster (default: the "
                    "cores); with --scheduler: wait for N workers")
    ap.add_argument("--scheduler", metavar="ADDR", help="an existing dask scheduler, e.g. tcp://host:8786")
    ap.add_argument("--scheduler-file", metavar="PATH", help="an existing dask cluster's scheduler file")
    ap.add_argument("--retries", type=int, default=1, metavar="N", help="retry a failed run up to N times (default 1)")
    ap.add_argument("--serial", action="store_true", help="no dask: the same tasks one after another in this process")
    ap.add_argument("--progress", dest="progress", action="store_true", default=None,
                    help="dask's progress bar on stdout (default: when stdout is a terminal)")
    ap.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    return ap


def main(argv=None) -> int:
    """``vfrs sweep SWEEP.toml -o OUT ...``; 0 when every run completed and gave every derived
    value, 1 when some run failed or a derived value could not be computed, 2 on an error in
    the sweep file or the options."""
    from ...checkpoint import RunStopped

    args = build_parser().parse_args(argv)
    try:
        check_engine(args.serial, args.workers, args.scheduler, args.scheduler_file)
        res = run_sweep(args.sweep, args.out, workers=args.workers, scheduler=args.scheduler,
                        scheduler_file=args.scheduler_file, retries=args.retries, serial=args.serial,
                        progress=args.progress)
    except VfrsError as e:
        print(f"vfrs: error: {e}", file=sys.stderr)
        return 2
    except RunStopped as stop:  # --serial: the run in progress stopped with a checkpoint
        print(f"vfrs: {stop}; the finished runs are kept and the stopped one resumes from its checkpoint when the "
              "same command runs again", file=sys.stderr)
        return stop.exit_code
    except KeyboardInterrupt:
        print("vfrs: interrupted (finished runs are kept; run the same command again to continue)", file=sys.stderr)
        return 130
    return 1 if res.failed or res.derived_failed else 0
