"""One run of a sweep (a task, :func:`run_task`): its scene run into ``runs/<id>.tmp-<pid>``,
taken over from a worker that died, recorded (``sweep_run.json``: status, attempts, wall
time, peak memory, the build) and read back into a row (:func:`collect`)."""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import socket
import time
import traceback

from ...errors import VfrsError
from ...output.atomic import atomic_json
from ...output.reader import read_json, read_npz
from ...params.table import suggest
from ...scene import Scene
from ..derived import Namespace, check_expression, evaluate
from .table import flatten_summary

RUN_FILE = "sweep_run.json"


PARAMS_FILE = "params.json"


#: Threads for the Rust core (rayon), OpenMP and BLAS in each worker process of a sweep: one,
#: the cluster runs one task per core.
THREAD_VARS = ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _run_scene(scene: Scene, out: str):
    """The run of one task (a function of its own so tests can make it fail); its Result."""
    from ...run import run

    return run(scene, out=out, progress=False)


def reset_peak_rss() -> bool:
    """Resets this process's peak resident set size (Linux: ``5`` to /proc/self/clear_refs),
    so that the peak read after a run is the run's own, not an earlier task's in the same
    worker. False where that is not possible."""
    import gc

    gc.collect()
    with contextlib.suppress(OSError, AttributeError):  # give freed heap back (glibc), so it is not reused unseen
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def rss_mb(field: str = "VmHWM") -> float | None:
    """This process's peak resident set size in MB since the last reset (``VmHWM``) or its
    resident set size now (``VmRSS``); None where /proc has neither."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(field + ":"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    return None


def _resume_run(out: str) -> None:
    """Continues the run in ``out`` from its checkpoint (a run taken over from a killed worker)."""
    from ...run import resume

    resume(out, progress=False)


def _take_over(folder: str, tmp: str) -> str | None:
    """A ``<id>.tmp-<pid>`` folder of this run holding a checkpoint, left by a worker that died
    mid-run (no live process of this host writes there): renamed to ``tmp`` (atomic, so one
    task takes it), its old name returned; None if there is none."""
    from ...checkpoint import CHECKPOINT
    from ...output.reader import running

    parent, base = os.path.split(folder)
    for name in sorted(os.listdir(parent)):
        path = os.path.join(parent, name)
        if (not name.startswith(base + ".tmp-") or path == tmp or os.path.islink(path)
                or not os.path.exists(os.path.join(path, CHECKPOINT)) or running(path) is not None):
            continue
        try:
            os.rename(path, tmp)
        except OSError:  # another task took it first
            continue
        return name
    return None


def _summary_value(summary: dict, key: str):
    section, _, rest = key.partition(".")
    if section not in summary:
        raise KeyError(f"summary has no section {section!r} (sections: {sorted(summary)})")
    items = summary[section]
    if rest not in items:
        raise KeyError(f"summary.{section} has no {rest!r}{suggest(rest, items)}")
    q = items[rest]
    v = q.get("value") if isinstance(q, dict) else q
    return math.nan if v is None else v


def _npz_lookup(path: str):
    """``key -> array`` of an .npz file, read on the first lookup (a derived column that reads
    nothing of it reads no file; a damaged one: :func:`vfrs.output.reader.read_npz`'s line)."""
    arrays: dict = {}

    def lookup(key):
        if not arrays:
            arrays.update(read_npz(path, again_text(os.path.dirname(path))))
        return arrays[key]

    return lookup


def again_text(folder: str) -> str:
    """What to do about a damaged file of a sweep's run folder."""
    return f"remove the folder {folder} and run the sweep again (that run then runs again)"


def read_record(folder: str) -> dict:
    """A run folder's ``sweep_run.json``: a dict whose ``id`` is the folder's name (a record
    naming another id, e.g. a path, is refused: the id names the folder others read)."""
    path = os.path.join(folder, RUN_FILE)
    rec = read_json(path, again_text(folder))
    if rec.get("id") != os.path.basename(os.path.normpath(folder)) or not isinstance(rec.get("params"), dict):
        raise VfrsError(f"{path}: names the run {rec.get('id')!r} (params {rec.get('params')!r}), not this folder's "
                        f"run; {again_text(folder)}")
    return rec


def collect(folder: str, derived: dict) -> dict:
    """The table row of a finished run folder: its sweep record, summary and derived columns
    (a damaged file of the folder: one line naming it; the record's id must be the folder's)."""
    rec = read_record(folder)
    row = {"id": rec["id"], **{k: v for k, v in rec["params"].items()}, "status": rec["status"],
           "error": rec.get("error"), "attempts": rec.get("attempts", 1), "wall_time [s]": rec.get("wall_time"),
           "peak_rss [MB]": rec.get("peak_rss_mb"), "vfrs code": (rec.get("vfrs") or {}).get("code")}
    summary: dict = {}
    path = os.path.join(folder, "summary.json")
    if os.path.exists(path):
        summary = read_json(path, again_text(folder))
    history, probe = _npz_lookup(os.path.join(folder, "history.npz")), _npz_lookup(os.path.join(folder, "probes.npz"))
    names = {"summary": Namespace("summary", lambda k: _summary_value(summary, k)),
             "history": Namespace("history", history),
             "params": Namespace("params", lambda k: rec["params"][k]),
             "probes": Namespace("probes", probe)}
    for name, expr in derived.items():
        try:
            row[name] = evaluate(check_expression(expr), names) if rec["status"] == "complete" else None
        except Exception as e:  # a column that cannot be computed for this run: empty, and say why
            row[name] = None
            row.setdefault("derived_errors", "")
            row["derived_errors"] += f"{name}: {type(e).__name__}: {e}; "
    row.update(flatten_summary(summary))
    return row


_CODE_ID: str | None = None


#: The vfrs package's folder (three levels above this module: vfrs/studies/sweep).
PACKAGE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def code_files() -> list:
    """The files :func:`code_id` hashes: every Python file and the compiled core of the vfrs
    package (:data:`PACKAGE`), sorted."""
    files = []
    for d, dirs, names in os.walk(PACKAGE):
        dirs[:] = sorted(x for x in dirs if x != "__pycache__")
        files += [os.path.join(d, n) for n in names if n.endswith((".py", ".so", ".pyd"))]
    return sorted(files)


def code_id() -> str:
    """The vfrs build that runs here: the first 12 hex digits of the sha256 of the package's
    Python files and its compiled core (installed or editable alike; :func:`code_files`). A run
    folder records the build that made it; a sweep skips a finished run only when the build is
    the same, so a table never mixes numbers of two builds without saying so (``vfrs code``
    column)."""
    global _CODE_ID
    if _CODE_ID is None:
        import hashlib

        from ..._version import __version__

        h = hashlib.sha256(__version__.encode())
        for path in code_files():
            h.update(os.path.relpath(path, PACKAGE).encode())
            with open(path, "rb") as fh:
                h.update(fh.read())
        _CODE_ID = h.hexdigest()[:12]
    return _CODE_ID


def read_run(folder: str) -> tuple[dict, dict]:
    """A finished task's folder read back: its ``sweep_run.json`` record (status, error,
    timings, peak memory, ...) and its history (a dict of arrays; empty for a failed run
    that recorded none)."""
    rec = read_record(folder)
    path = os.path.join(folder, "history.npz")
    return rec, read_npz(path, again_text(folder)) if os.path.exists(path) else {}


def own_time(timings: dict) -> float:
    """A run's own time from its clocks: vfrs's ``total`` less writing its output folder
    (fields, history, checkpoints), which the same run in memory does not do."""
    return float(timings.get("total", math.nan)) - timings.get("output", 0.0) - timings.get("checkpoint", 0.0)


def is_finished(folder: str, code: str | None = None) -> bool:
    """A run folder whose run completed (its manifest and sweep record say so); with
    ``code``, made by that vfrs build (:func:`code_id`)."""
    try:
        with open(os.path.join(folder, "manifest.json")) as fh:
            manifest = json.load(fh)
        rec = read_record(folder)
    except (OSError, ValueError, AttributeError):  # missing or damaged (VfrsError): not finished, run again
        return False
    done = manifest.get("status") == "complete" and rec.get("status") == "complete"
    return done and (code is None or (rec.get("vfrs") or {}).get("code") == code)


def run_task(spec: dict) -> dict:
    """One run of a sweep, in a worker (or in this process with ``--serial``): runs the scene
    into ``runs/<id>.tmp-<pid>``, records status and error in ``sweep_run.json``, renames the
    folder to ``runs/<id>`` and returns its table row."""
    if spec.get("single_thread"):
        for var in THREAD_VARS:
            os.environ.setdefault(var, "1")  # read by rayon when its pool starts (the first run here)
    folder = os.path.join(spec["runs"], spec["id"])
    tmp = f"{folder}.tmp-{os.getpid()}"
    # The build is hashed before the run, as near as can be to when this process imported it: hashed
    # after, a file edited during the run would be recorded as the build that made its numbers.
    code = code_id()
    from ...checkpoint import CheckpointError, RunStopped
    from ...output.writer import OutputFolderError

    if os.path.exists(tmp):  # an earlier attempt in this same process
        shutil.rmtree(tmp)
    t0 = time.perf_counter()
    peak_is_own = reset_peak_rss()
    rss_start = rss_mb("VmRSS") if peak_is_own else None
    resumed = _take_over(folder, tmp)
    status, error, result, run_time = "complete", None, None, None
    try:
        if resumed is not None:
            try:
                _resume_run(tmp)  # from the dead worker's last checkpoint, bit-identical (docs/running.md)
            except (CheckpointError, OutputFolderError):  # it cannot be resumed: start again
                shutil.rmtree(tmp)
                resumed = None
        if resumed is None:
            os.makedirs(tmp)
            atomic_json(os.path.join(tmp, PARAMS_FILE), {"id": spec["id"], "index": spec["index"],
                                                         "params": spec["params"]})
            scene = Scene.from_dict(spec["scene"], source=spec["source"])
            t_run = time.perf_counter()
            result = _run_scene(scene, tmp)
            run_time = time.perf_counter() - t_run
    except RunStopped:  # SIGINT/SIGTERM (--serial): the folder keeps its checkpoint; the next sweep resumes it
        raise
    except Exception as exc:
        status, error = "failed", f"{type(exc).__name__}: {exc}"
        os.makedirs(tmp, exist_ok=True)
        with open(os.path.join(tmp, "error.txt"), "w") as fh:
            fh.write(traceback.format_exc())
    rec = {"id": spec["id"], "index": spec["index"], "params": spec["params"], "status": status, "error": error,
           "attempts": spec["attempt"], "wall_time": time.perf_counter() - t0, "host": socket.gethostname(),
           "pid": os.getpid(), "threads": {v: os.environ.get(v) for v in THREAD_VARS}, "resumed_from": resumed,
           # the run itself (vfrs.run, with its output), its clocks by effect and its peak memory:
           # what a cost report compares (None for a resumed run: its clocks are split)
           "run_time": run_time, "timings": dict(getattr(result, "timings", None) or {}) or None,
           "peak_rss_mb": rss_mb() if peak_is_own else None, "rss_start_mb": rss_start,
           "vfrs": {"version": vfrs_version(), "code": code}}
    atomic_json(os.path.join(tmp, RUN_FILE), rec)
    if is_finished(folder, code):  # another attempt of this run finished meanwhile (a worker thought lost)
        shutil.rmtree(tmp)
    else:
        if os.path.exists(folder):  # an earlier failed attempt
            shutil.rmtree(folder)
        os.rename(tmp, folder)
    return collect(folder, spec["derived"])


def failed_row(spec: dict, error: str) -> dict:
    return {"id": spec["id"], **spec["params"], "status": "failed", "error": error, "attempts": spec["attempt"],
            "wall_time [s]": None}


def vfrs_version() -> str:
    from ..._version import __version__

    return __version__
