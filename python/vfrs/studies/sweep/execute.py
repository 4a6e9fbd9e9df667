"""A sweep's runs executed: on dask.distributed (an embedded LocalCluster or an existing
cluster; ``pip install "vfrs[sweep]"``) or one after another in this process (``--serial``),
finished runs skipped, failed ones retried, the table written (:func:`run_sweep`)."""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
from dataclasses import dataclass, field

from ...errors import VfrsError
from ...output.atomic import atomic_json, atomic_write
from ...output.reader import inside
from ..extra import sweep_extra
from . import task
from .spec import Sweep, load_sweep
from .table import summary_columns, write_table
from .task import THREAD_VARS, collect, failed_row, is_finished, run_task

def check_extra(serial: bool) -> None:
    """What a sweep needs of the ``sweep`` extra, checked before anything runs: pyarrow (its
    table, summary.parquet) and, unless ``serial``, dask.distributed; else a one-line
    VfrsError naming the extra (:func:`vfrs.studies.extra.sweep_extra`)."""
    sweep_extra("pyarrow.parquet", "a sweep's table (summary.parquet)")
    if not serial:
        sweep_extra("distributed", "a sweep on dask (without --serial)")


def check_engine(serial: bool, workers, scheduler, scheduler_file) -> None:
    """The engine options of a sweep's command (vfrs sweep, vfrs converge, vfrs bench
    accuracy): --serial with no cluster options, --workers 1 or more; else VfrsError."""
    if serial and (scheduler or scheduler_file or workers):
        raise VfrsError("--serial runs in this process: give no --scheduler, --scheduler-file or --workers")
    if workers is not None and workers < 1:
        raise VfrsError(f"--workers {workers}: expected 1 or more")


@dataclass
class SweepResult:
    rows: list
    submitted: int
    skipped: int
    failed: int
    out: str
    #: ``(column, run id, error)`` of each derived value a completed run could not compute
    #: (the table's cell is empty, ``derived_errors`` says why): ``vfrs sweep`` exits 1
    derived_failed: list = field(default_factory=list)


def derived_failures(rows: list, derived: dict) -> list:
    """``(column, run id, error)`` of each derived value of a completed run that could not
    be computed (a run's failure leaves its derived cells empty without counting here)."""
    out = []
    for r in rows:
        if r.get("status") != "complete":
            continue
        for name in derived:
            if r.get(name) is None:
                why = [e for e in (r.get("derived_errors") or "").split("; ") if e.startswith(f"{name}: ")]
                out.append((name, r["id"], why[0][len(name) + 2:] if why else "no value"))
    return out


def _failures_text(failures: list, n_rows: int) -> str:
    """``3 derived values could not be computed: ratio in 2 of 4 runs (a1b2..., c3d4...: ZeroDivisionError: ...)``."""
    parts = []
    for name in dict.fromkeys(f[0] for f in failures):
        mine = [f for f in failures if f[0] == name]
        ids = ", ".join(f[1] for f in mine[:3]) + (", ..." if len(mine) > 3 else "")
        parts.append(f"{name} in {len(mine)} of {n_rows} runs ({ids}: {mine[0][2]})")
    n = len(failures)
    return (f"{n} derived value{'' if n == 1 else 's'} could not be computed: " + "; ".join(parts)
            + " - empty cells, the reasons in the derived_errors column")


def run_sweep(sweep: Sweep | str, out, *, workers: int | None = None, scheduler: str | None = None,
              scheduler_file: str | None = None, retries: int = 1, serial: bool = False,
              log=None, progress: bool | None = None) -> SweepResult:
    """Runs every combination of ``sweep`` not finished in ``out`` yet; writes the summary table.

    ``serial``: in this process, one after another (no dask). Else on ``scheduler`` /
    ``scheduler_file`` (an existing dask cluster) or an embedded LocalCluster of ``workers``
    processes (default: the cores) with one thread each. ``progress``: dask's progress bar on
    stdout while the tasks run (default: when stdout is a terminal)."""
    if not isinstance(sweep, Sweep):
        sweep = load_sweep(sweep)
    if retries < 0:
        raise VfrsError(f"--retries {retries}: expected 0 or more")
    if scheduler and scheduler_file:
        raise VfrsError("give --scheduler or --scheduler-file, not both")
    check_extra(serial)
    log = log or (lambda msg: print(msg, file=sys.stderr, flush=True))
    out = os.fspath(out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise VfrsError(f"-o {out}: this is a file, not a folder")
    runs_dir = _runs_folder(out, sweep)
    if os.path.isfile(sweep.source):
        if os.path.abspath(sweep.source) != os.path.abspath(os.path.join(out, "sweep.toml")):
            with open(sweep.source, "rb") as fh:  # what this sweep was (replacing a link, never writing through it)
                atomic_write(os.path.join(out, "sweep.toml"), fh.read())
    else:  # built in Python (Sweep.from_runs): its runs' labels and ids
        atomic_json(os.path.join(out, "sweep.json"), {
            "source": sweep.source, "title": sweep.title, "derived": sweep.derived,
            "runs": [{"index": r["index"], "id": r["id"], "params": r["params"]} for r in sweep.runs]})
    rows: dict = {}
    todo = []
    code = task.code_id()  # looked up there: a test standing in for the build stands in for both
    other_build = 0
    for r in sweep.runs:
        folder = os.path.join(runs_dir, r["id"])
        if is_finished(folder, code):
            rows[r["index"]] = {**collect(folder, sweep.derived), "skipped": True}
        else:
            other_build += is_finished(folder)
            todo.append({**r, "runs": runs_dir, "source": f"{sweep.source} run {r['index']}", "derived": sweep.derived,
                         "attempt": 1, "single_thread": not serial})
    skipped = len(rows)
    log(f"sweep {sweep.source}: {len(sweep.runs)} runs, {skipped} finished before (skipped), {len(todo)} to run"
        + (f" ({other_build} of them finished by another vfrs build, run again with this one, {code})"
           if other_build else ""))
    done = [skipped]

    def finished(spec, row):
        ok = row["status"] == "complete"
        done[0] += ok or spec["attempt"] > retries
        params = ", ".join(f"{k} = {v!r}" for k, v in spec["params"].items())
        log(f"[{done[0]}/{len(sweep.runs)}] {spec['id']} {row['status']}"
            + (f" in {row['wall_time [s]']:.1f} s" if row.get("wall_time [s]") is not None else "")
            + f" ({params})" + ("" if ok else f": {row['error']}")
            + ("" if not row.get("derived_errors") else f"; derived {row['derived_errors'].rstrip('; ')}")
            + ("" if ok or spec["attempt"] > retries else f"; retry {spec['attempt']} of {retries}"))
        if not ok and spec["attempt"] <= retries:
            return {**spec, "attempt": spec["attempt"] + 1}
        rows[spec["index"]] = {**row, "skipped": False}
        return None

    try:
        if progress is None:
            progress = sys.stdout.isatty()
        submitted = _execute(todo, serial, workers, scheduler, scheduler_file, finished, log, progress)
    finally:  # also when interrupted: the table of the runs finished so far
        _remove_stale(runs_dir, rows.values())
        table = [rows[i] for i in sorted(rows)]
        write_table(table, out, summary_columns([a.key for a in sweep.axes], list(sweep.derived)))
    failed = sum(r["status"] != "complete" for r in table)
    bad = derived_failures(table, sweep.derived)
    log(f"wrote {os.path.join(out, 'summary.parquet')} and summary.csv: {len(table)} runs, {failed} failed"
        + (f"; {_failures_text(bad, len(table))}" if bad else ""))
    return SweepResult(table, submitted, skipped, failed, out, bad)


def _runs_folder(out: str, sweep: Sweep) -> str:
    """``out/runs``, created if missing; it and every run's folder there that exists must
    stay inside ``out`` (no symbolic link leading out: a sweep removes and replaces run
    folders), else an OutputFolderError before anything is touched."""
    from ...errors import OutputFolderError

    runs_dir = os.path.join(out, "runs")
    for rel in ["runs"] + [f"runs/{r['id']}" for r in sweep.runs]:
        if os.path.lexists(os.path.join(out, rel)):
            inside(out, rel, f"{out} (the sweep's folder)", OutputFolderError)
    os.makedirs(runs_dir, exist_ok=True)
    return runs_dir


def _execute(todo: list, serial: bool, workers, scheduler, scheduler_file, finished, log, progress=False) -> int:
    """Runs the tasks (``finished(spec, row)`` returns the spec of a retry or None); returns
    how many tasks were submitted."""
    submitted = 0
    if todo and serial:
        queue = list(todo)
        while queue:
            spec = queue.pop(0)
            submitted += 1
            again = finished(spec, run_task(spec))
            if again:
                queue.append(again)
    elif todo:
        distributed = sweep_extra("distributed", "a sweep on dask (without --serial)")
        Client, LocalCluster, as_completed = distributed.Client, distributed.LocalCluster, distributed.as_completed

        with contextlib.ExitStack() as stack:
            if scheduler or scheduler_file:
                client = stack.enter_context(Client(scheduler, scheduler_file=scheduler_file))
                if workers:
                    client.wait_for_workers(workers)
            else:
                n = workers or _cores()
                cluster = stack.enter_context(LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                                           env={v: "1" for v in THREAD_VARS}))
                client = stack.enter_context(Client(cluster))
            log(f"dask: {len(client.scheduler_info().get('workers', {}))} workers at {client.scheduler.address}; "
                f"dashboard {client.dashboard_link}" + ("" if _has_bokeh() else " (needs bokeh: pip install bokeh)"))
            specs = {}
            futures = []
            for spec in todo:
                f = client.submit(run_task, spec, key=f"vfrs-run-{spec['id']}-{spec['attempt']}", pure=False)
                specs[f.key] = spec
                futures.append(f)
                submitted += 1
            bar = _progress_bar(futures, client) if progress else None
            pending = as_completed(futures)
            for f in pending:
                spec = specs.pop(f.key)
                if f.status == "finished":
                    row = f.result()
                else:  # the task itself raised, or its workers died (KilledWorker)
                    exc = f.exception()
                    row = failed_row(spec, f"{type(exc).__name__}: {exc}")
                f.release()
                again = finished(spec, row)
                if again:
                    g = client.submit(run_task, again, key=f"vfrs-run-{again['id']}-{again['attempt']}", pure=False)
                    specs[g.key] = again
                    pending.add(g)
                    submitted += 1
            if bar is not None:  # let the bar draw its last state before the cluster closes
                bar.join(timeout=5.0)
    return submitted


def _progress_bar(futures: list, client):
    """Dask's text progress bar of the first attempts, drawn on stdout by a thread of its own
    (the bar's ``listen`` blocks) while the sweep collects the results; retries are in the
    log lines."""
    import threading

    from distributed.diagnostics.progressbar import TextProgressBar

    def show():
        with contextlib.suppress(Exception):  # a bar that cannot draw must not stop the sweep
            TextProgressBar(futures, scheduler=client.scheduler.address, complete=True)

    thread = threading.Thread(target=show, name="vfrs-sweep-progress", daemon=True)
    thread.start()
    return thread


def _remove_stale(runs_dir: str, rows) -> None:
    """Removes the ``<id>.tmp-<pid>`` folders of runs that are finished now (left by a worker
    killed mid-run whose task then completed elsewhere); those of unfinished runs stay."""
    done = {r["id"] for r in rows if r["status"] == "complete"}
    for name in os.listdir(runs_dir):
        run_id, sep, _ = name.partition(".tmp-")
        if sep and run_id in done and is_finished(os.path.join(runs_dir, run_id)):
            shutil.rmtree(os.path.join(runs_dir, name), ignore_errors=True)


def _cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _has_bokeh() -> bool:
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None
