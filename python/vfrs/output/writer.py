"""Run output on disk: the resolved scene, history (npz + CSV), VTU series for ParaView, a log.

Layout of ``out/``::

    scene.toml            the scene as run, defaults included (also inside history.npz and
                          the .pvd files)
    history.npz, history.csv
    summary.json          what the run measured (vfrs.summary.summarize: f0, quotients,
                          peak flow, first contact, peak force and contact pressure, ...)
    <body>.pvd            ParaView collection of the field series (open this one)
    fields/<body>_<step>.vtu   displacement, velocity, each effect's force and the fields the
                          effects add (``Effect.output_fields``; with [contact],
                          ``contact_pressure``, Pa, per contact-surface node)
    run.log               sizes, effects that ran, timings, the results summary; where a run
                          stopped on SIGTERM/SIGINT and how to resume it
    probes.npz            the [output] probes: each point, the node it snapped to and its
                          distance, and that node's history (written with the history)
    contact_peak.npz      with [contact] (an effect's ``files``), written when the run completes: the time, history
                          row and force of the step of the largest total contact force, and
                          the nodal contact pressure and positions at that step (``vfrs plot``'s
                          pressure map; vfrs.enforcement.record.ContactRecorder.peak_map)
    checkpoint.npz        the state of the last checkpoint: arrays and a JSON member, no pickle
                          (vfrs.checkpoint), removed when the run completes
    checkpoint_rows/      the checkpoint's append-only lists (history, probes, snapshots so far;
                          only new rows are appended), removed when the run completes
    manifest.json         the files the run wrote, the scene hash, the versions, start/end
                          time and status (running, stopped, failed, complete)

When what is readable (docs/running.md): ``history.csv`` gets the new rows at the first step,
then every second and at each checkpoint (appended; the whole file is rewritten only when its
columns change, on a resume and at the end),
``checkpoint.npz`` is replaced atomically at every checkpoint (``checkpoint_rows/`` appended
to), ``history.npz`` and ``probes.npz`` are written atomically on a stop, a failure and at the
end, the VTU files as they are written. A snapshot's VTU files are written (and
compressed) by one background thread while the run goes on (zlib releases the GIL; at most two
snapshots wait); every manifest, checkpoint and the end of the run wait for them, and an error
in a write is raised at the next snapshot or there.

A folder that holds another run's files is refused unless ``overwrite`` or ``resume``.
``overwrite`` replaces only the files that run's manifest lists (or files of vfrs's own names
when it has none), and only once the new run has completed: until then they wait in
``.vfrs-replaced/``, and a new run that fails gives the folder back as it found it (the old
run's files restored, the new run's removed). A run that fails before its first step leaves no
file behind either (:class:`OutputFolder`). A run holds an exclusive lock on its folder from
before it looks at it until it ends (``flock`` on the folder; the kernel releases it when the
process dies), so two runs into one folder cannot both start: the second is refused at once.
"""

from __future__ import annotations

import csv
import datetime
import glob
import json
import os
import sys
from concurrent.futures import ThreadPoolExecutor
from xml.sax.saxutils import quoteattr

import numpy as np

from ..checkpoint import CHECKPOINT, OLD_CHECKPOINT, ROWS, scene_hash
from ..effects import EFFECTS
from ..errors import OutputFolderError  # defined in errors.py (every error class is), raised here
from .atomic import atomic_json, atomic_npz
from .reader import inside, read_json, running
from .vtu import FieldFileWriter

MANIFEST = "manifest.json"
#: vfrs's own file names (relative, glob patterns): what ``overwrite`` may remove from a folder
#: of a run without a manifest (written before manifests existed).
KNOWN_FILES = ("scene.toml", "run.log", "history.npz", "history.csv", "summary.json", "probes.npz", CHECKPOINT,
               OLD_CHECKPOINT, f"{ROWS}/*.bin", MANIFEST, "*.pvd", "fields/*_[0-9][0-9][0-9][0-9][0-9][0-9].vtu")


def effect_files(names=None) -> tuple:
    """The files the effects write into the output folder (each effect's ``files``: the
    [contact] effect's ``contact_peak.npz``), of the effects ``names`` (default: every
    registered effect)."""
    return tuple(f for name in (EFFECTS if names is None else names) for f in EFFECTS[name].files)


def _now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


def _listed(out: str) -> list:
    """The files ``out``'s manifest lists, each checked to stay inside ``out``
    (:func:`vfrs.output.reader.inside`: no absolute path, no ``..``, no symbolic link leading out,
    else an :class:`OutputFolderError`); [] without a readable manifest."""
    path = os.path.join(out, MANIFEST)
    try:
        listed = read_json(path).get("files", [])
    except ValueError:  # none, or damaged (a VfrsError): the files of vfrs's names only
        return []
    listed = listed if isinstance(listed, list) else [listed]
    return [f for f in listed if inside(out, f, path, OutputFolderError)]


def _ours(out: str) -> list:
    """Relative paths of the files in ``out`` that a vfrs run wrote: its manifest's list and
    the files matching vfrs's own names. Every one is checked before any is touched: one that
    leads outside ``out`` (its manifest names ``../x`` or ``/x``, or a symbolic link, of the
    file or of a folder on its way, points out) is an :class:`OutputFolderError`."""
    found = {f for f in _listed(out) if os.path.isfile(os.path.join(out, f))}
    for d in ("fields", ROWS):  # the folders a run writes into: never a link leading out
        if os.path.lexists(os.path.join(out, d)):
            inside(out, d, f"{out} (vfrs writes into {d}/)", OutputFolderError)
    for pattern in KNOWN_FILES + effect_files():
        for f in glob.glob(os.path.join(glob.escape(out), pattern)):
            rel = os.path.relpath(f, out)
            if os.path.isfile(inside(out, rel, f"{out} (a file of vfrs's name {pattern})", OutputFolderError)):
                found.add(rel)
    return sorted(found)


REPLACED = ".vfrs-replaced"  # where --overwrite keeps the old run's files until the new one completes


def _holder(out: str) -> str:
    """Who holds ``out``'s lock, from its manifest when that says a run is writing there."""
    import socket

    try:
        with open(os.path.join(out, MANIFEST)) as fh:
            m = json.load(fh)
        if m.get("status") == "running" and m.get("pid"):
            host = m.get("host")
            where = "this machine" if host == socket.gethostname() else (host or "another machine")
            return f"process {int(m['pid'])} on {where}; kill -TERM {int(m['pid'])} ends it with a checkpoint"
    except (OSError, ValueError, TypeError, AttributeError):
        pass
    return "another process, which has not written its manifest yet"


class OutputFolder:
    """One run's hold on its output folder, from before it is checked until the run ends.

    On entry: the folder is created if missing and locked (``flock``, exclusive, not waiting:
    a folder another run holds is an :class:`OutputFolderError` naming that run's process and
    host); then :func:`prepare_output` checks it and, with ``overwrite``, moves the old run's
    files aside into ``.vfrs-replaced/``. :meth:`complete` (the run ended, or stopped with a
    checkpoint it can resume from) removes what was moved aside; :meth:`failed` with
    ``keep_run = False`` (the run failed before its first step, or an overwriting run failed)
    removes the new run's files and restores the old ones, leaving the folder as it was
    found. The lock is released on exit."""

    def __init__(self, out, mode: str = "new"):
        self.out = os.fspath(out)
        self.mode = mode
        self.created = False
        self.moved: list = []
        self._fd: int | None = None
        self._had_fields = False
        self.files: set = set()  # the new run's files (its writer's set, once it has one)
        self.resolved = False  # complete() or failed() was called

    def __enter__(self) -> "OutputFolder":
        out = self.out
        if os.path.exists(out) and not os.path.isdir(out):
            raise OutputFolderError(f"-o {out}: this is a file, not a folder; give a folder for the run's output "
                                    "(created if missing)")
        if not os.path.isdir(out):
            os.makedirs(out)
            self.created = True
        try:
            import fcntl
        except ImportError:  # no flock (Windows): the manifest's pid check below still applies
            fcntl = None  # type: ignore[assignment]
        if fcntl is not None:
            fd = os.open(out, os.O_RDONLY)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                os.close(fd)
                raise OutputFolderError(f"{out}: a run ({_holder(out)}) is still writing there (it holds the folder's "
                                        "lock); use another folder, or let it end or stop it, then resume or "
                                        "overwrite") from None
            self._fd = fd
        self._had_fields = os.path.isdir(os.path.join(out, "fields"))
        try:
            self.moved = prepare_output(out, self.mode)
        except BaseException:
            self._release()
            raise
        return self

    def complete(self) -> None:
        """The new run owns the folder: what it replaced is removed."""
        import shutil

        shutil.rmtree(os.path.join(self.out, REPLACED), ignore_errors=True)
        self.moved = []
        self.resolved = True

    def failed(self, new_files, keep_run: bool) -> None:
        """The run failed. ``keep_run``: its files stay (a failed run's history, log and
        checkpoint, which may be resumed) and what it replaced is removed; otherwise the
        folder is given back as it was found."""
        if keep_run or self.mode == "resume":  # a resumed run's folder is never taken apart
            self.complete()
            return
        for f in set(new_files) | {MANIFEST, "scene.toml", "run.log"}:
            path = os.path.join(self.out, f)
            if os.path.isfile(path):
                os.remove(path)
        aside = os.path.join(self.out, REPLACED)
        for f in self.moved:
            dest = os.path.join(self.out, f)
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            os.replace(os.path.join(aside, f), dest)
        self.moved = []
        self.complete()
        fields = os.path.join(self.out, "fields")
        if not self._had_fields and os.path.isdir(fields) and not os.listdir(fields):
            os.rmdir(fields)
        rows = os.path.join(self.out, ROWS)
        if os.path.isdir(rows) and not os.listdir(rows):
            os.rmdir(rows)
        if self.created and not os.listdir(self.out):
            os.rmdir(self.out)

    def _release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing the descriptor releases the flock
            self._fd = None

    def __exit__(self, exc_type, *exc) -> None:
        try:
            if not self.resolved:  # the run ended before saying how: a failure gives the folder back
                if exc_type is None:
                    self.complete()
                else:
                    self.failed(self.files, keep_run=False)
        finally:
            self._release()


def prepare_output(out, mode: str = "new") -> list:
    """Checks (and with ``overwrite`` clears) the output folder before a run.

    ``new``: the folder may be missing, empty or hold files that are not a run's; a run's files
    are refused. ``overwrite``: a run's files (those its manifest lists, or of vfrs's own
    names), never other files, are moved into ``.vfrs-replaced/`` (removed when the new run
    completes, put back when it fails: :class:`OutputFolder`); returns their relative paths.
    ``resume``: the folder must hold a run."""
    out = os.fspath(out)
    if os.path.exists(out) and not os.path.isdir(out):
        raise OutputFolderError(f"-o {out}: this is a file, not a folder; give a folder for the run's output "
                                "(created if missing)")
    pid = running(out)
    if pid is not None:
        raise OutputFolderError(f"{out}: a run (process {pid} on this machine) is still writing there; stop it "
                                f"first (kill -TERM {pid} ends it with a checkpoint), then resume or overwrite")
    ours = _ours(out) if os.path.isdir(out) else []  # every path checked (inside the folder) before any is moved
    if mode == "resume":
        if os.path.isdir(out):
            _remove_temporaries(out)
        return []
    if not ours:
        return []
    if mode != "overwrite":
        raise OutputFolderError(
            f"-o {out}: the folder holds another run's files ({', '.join(ours[:4])}{', ...' if len(ours) > 4 else ''}); "
            f"use another folder, --overwrite to replace that run (only its own files are removed), or "
            f"`vfrs run --resume {out}` to continue it")
    import shutil

    aside = os.path.join(out, REPLACED)
    if os.path.islink(aside) or os.path.isfile(aside):  # a link is removed, never followed
        os.remove(aside)
    shutil.rmtree(aside, ignore_errors=True)  # left by a run killed before it could clean up
    for f in ours:
        dest = os.path.join(aside, f)
        os.makedirs(os.path.dirname(dest), exist_ok=True)
        os.replace(os.path.join(out, f), dest)
    return ours


def _remove_temporaries(out: str) -> None:
    """Removes the temporary files (``manifest.json.tmp<pid>``, ``checkpoint.npz.tmp<pid>``,
    ...) that an atomic write (:func:`vfrs.output.atomic.atomic_write`) interrupted by a kill
    left in ``out``: the run resumed there holds the folder's lock, so no writer is alive."""
    import re

    names = (MANIFEST, CHECKPOINT, "history.npz", "probes.npz", "summary.json") + effect_files()
    stale = re.compile("^(" + "|".join(re.escape(n) for n in names) + r")\.tmp[0-9]+$")
    for name in os.listdir(out):
        path = os.path.join(out, name)
        if stale.match(name) and (os.path.islink(path) or os.path.isfile(path)):
            os.remove(path)  # the entry itself: a link is not followed


def versions() -> dict:
    import platform

    from .._version import __version__

    return {"vfrs": __version__, "python": platform.python_version(), "numpy": np.__version__}


class OutputWriter:
    """Writes one run's files into ``out`` (created if missing; see :func:`prepare_output`).

    ``resume``: continue the run already in ``out`` (run.log is appended to, the manifest
    kept)."""

    def __init__(self, out, scene, problem, resume: bool = False):
        self.out = os.fspath(out)
        self.scene = scene
        self.scene_toml = scene.to_toml()  # the resolved scene, written into every .pvd and history.npz
        self.problem = problem
        os.makedirs(os.path.join(self.out, "fields"), exist_ok=True)
        self.series: dict = {p.name: [] for p in problem.bodies}
        self.files: set = set()
        self._csv_rows, self._csv_names = 0, None
        self._writes: list = []  # snapshot writes in flight (futures of the background thread)
        self._field_files: dict = {}  # body name -> its FieldFileWriter
        self._pool: ThreadPoolExecutor | None = None
        self.manifest = {"status": "running", "started": _now(), "ended": None, "scene": scene.source,
                         "scene_hash": scene_hash(scene), **versions(), "command": sys.argv, "resumed": [],
                         "files": []}
        unread = self._read_manifest() if resume else None
        if resume:
            self.manifest["resumed"] = list(self.manifest.get("resumed", [])) + [_now()]
            self.files.update(self.manifest.get("files", []))
        else:
            scene.save(os.path.join(self.out, "scene.toml"))
        import socket

        self.manifest.update(pid=os.getpid(), host=socket.gethostname())  # who is writing here now
        self.files.update(("scene.toml", "run.log"))
        self._log = open(os.path.join(self.out, "run.log"), "a" if resume else "w")
        if resume:
            self.log(f"vfrs run resumed {_now()}" + (f"; {unread}" if unread else ""))
        else:
            self.log(f"vfrs run started {_now()}")
            self.log(f"scene: {scene.source}")
            for body in problem.bodies:  # element quality (vfrs.mesh.quality), one line per body
                self.log(f"mesh of body {body.name!r}: quality: {body.mesh.quality().line()}")
        self.write_manifest()

    def _read_manifest(self) -> str | None:
        """A resumed run's manifest into :attr:`manifest` (all but its status and end), or
        what the log says when it cannot be read (cut short by a kill: written anew)."""
        try:
            old = read_json(os.path.join(self.out, MANIFEST))
        except ValueError as exc:  # the VfrsError of a missing or damaged file
            return f"{str(exc).split('; ')[0]}; written anew (its start time and earlier resumes are lost)"
        self.manifest.update({k: v for k, v in old.items() if k not in ("status", "ended")})
        return None

    def write_manifest(self, status: str | None = None) -> None:
        """``manifest.json`` (atomically): the files written so far, the scene's hash, versions,
        start/end time and ``status``."""
        # A failed run's manifest is written even if a snapshot write failed too (logged).
        self.flush(raise_errors=status != "failed")
        if status is not None:
            self.manifest["status"] = status
            if status != "running":
                self.manifest["ended"] = _now()
        self.files.add(MANIFEST)
        self.files.update(f for f in effect_files(self.scene.effects) if os.path.exists(os.path.join(self.out, f)))
        self.manifest["files"] = sorted(f for f in self.files if os.path.exists(os.path.join(self.out, f)))
        atomic_json(os.path.join(self.out, MANIFEST), self.manifest)

    def state(self) -> dict:
        """The VTU series so far (times and files, each an append-only list)."""
        from ..checkpoint import Appended

        self.flush()  # a checkpoint lists the snapshots written
        return {"series": {k: {"t": Appended([t for t, _ in v]), "file": Appended([f for _, f in v])}
                           for k, v in self.series.items()}}

    def flush(self, raise_errors: bool = True) -> None:
        """Waits for the snapshot writes in flight; raises the first one's error (or, with
        ``raise_errors = False``, logs it)."""
        writes, self._writes = self._writes, []
        first = None
        for f in writes:
            exc = f.exception()
            if exc is not None and first is None:
                first = exc
        if first is not None:
            if raise_errors:
                raise first
            self.log(f"a field snapshot was not written: {type(first).__name__}: {first}")

    def restore(self, state: dict) -> None:
        from ..checkpoint import items_of

        self.series = {k: [(float(t), str(f)) for t, f in zip(items_of(v["t"]), items_of(v["file"]))]
                       for k, v in state["series"].items()}
        self._write_pvd()  # the stopped run may have listed snapshots after the checkpoint

    @property
    def closed(self) -> bool:
        """Whether run.log is closed (the run is over)."""
        return self._log.closed

    def log(self, line: str) -> None:
        self._log.write(line.rstrip() + "\n")
        self._log.flush()

    def write_fields(self, step: int, t: float, fields: dict) -> None:
        """``fields``: name -> (n_nodes, 3) or (n_nodes,) over all bodies, the effects' own
        included (``Effect.output_fields``: with [contact], ``contact_pressure``); one VTU per
        body."""
        # The previous snapshots' errors surface here; at most two wait for the thread.
        while self._writes and (self._writes[0].done() or len(self._writes) >= 2 * len(self.problem.bodies)):
            self._writes.pop(0).result()
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="vfrs-output")
        for p in self.problem.bodies:
            name = f"{p.name}_{step:06d}.vtu"
            # The arrays are read by the thread later: ``fields`` must not change until
            # flushed (the recorder's snapshots are its own copies, kept unchanged).
            data = {k: np.ascontiguousarray(v[p.nodes]) for k, v in fields.items()}
            files = self._field_files.get(p.name)
            if files is None:  # the body's points and cells, encoded once for all its snapshots
                files = self._field_files[p.name] = FieldFileWriter(p.mesh.points, p.mesh.tets)
            self._writes.append(self._pool.submit(files.write, os.path.join(self.out, "fields", name),
                                                  data, self.scene.output.compression))
            self.series[p.name].append((t, f"fields/{name}"))
            self.files.add(f"fields/{name}")
        self._write_pvd()

    def _write_pvd(self) -> None:
        for body, items in self.series.items():
            scene = self.scene_toml.replace("--", "- -")
            lines = ['<?xml version="1.0"?>', f"<!-- resolved vfrs scene:\n{scene}-->",
                     '<VTKFile type="Collection" version="0.1">', "<Collection>"]
            lines += [f'<DataSet timestep="{t!r}" part="0" file={quoteattr(f)}/>' for t, f in items]
            lines += ["</Collection>", "</VTKFile>"]
            with open(os.path.join(self.out, f"{body}.pvd"), "w") as fh:
                fh.write("\n".join(lines) + "\n")
            self.files.add(f"{body}.pvd")

    def write_history(self, history: dict, csv_too: bool = True) -> None:
        """history.npz (atomically) and (``csv_too``) the whole history.csv."""
        # The resolved scene travels with the numbers (key "scene", a TOML string).
        atomic_npz(os.path.join(self.out, "history.npz"), {"scene": np.array(self.scene_toml), **_unragged(history)})
        self.files.add("history.npz")
        if csv_too:
            names, cols = _csv_columns(history)
            with open(os.path.join(self.out, "history.csv"), "w", newline="") as fh:
                _write_csv(fh, names, cols, header=True)
            self.files.add("history.csv")
            self._csv_rows, self._csv_names = len(history.get("t", ())), names

    def append_history(self, rec) -> None:
        """Appends the rows recorded since the last call to history.csv (rewrites it when the
        columns changed), so the file can be read while the run goes on."""
        n = rec.n_recorded
        if n <= self._csv_rows and self._csv_names is not None:
            return
        rows = rec.rows(self._csv_rows)
        names, cols = _csv_columns(rows)
        path = os.path.join(self.out, "history.csv")
        if names != self._csv_names:
            rows = rec.rows(0)
            names, cols = _csv_columns(rows)
            with open(path, "w", newline="") as fh:
                _write_csv(fh, names, cols, header=True)
        else:
            with open(path, "a", newline="") as fh:
                _write_csv(fh, names, cols, header=False)
        self.files.add("history.csv")
        self._csv_rows, self._csv_names = n, names

    def write_probes(self, rec, history_t) -> None:
        """probes.npz (atomically): ``t``, and per ``[output] probes`` point ``i``:
        ``probe_<i>.point`` (as given), ``.node`` (the node it snapped to), ``.body`` (the name
        of the body it belongs to), ``.distance`` (m, from the point to that node), ``.position``
        (the node's reference coordinates), and the node's ``.displacement``, ``.velocity`` and
        ``.<effect>_force`` per step."""
        points = rec.probe_points()
        if not points:
            return
        arrays: dict = {"t": np.asarray(history_t, dtype=float)}
        for i, p, n, dist in points:
            pre = f"probe_{i}"
            arrays.update({f"{pre}.point": p, f"{pre}.node": np.int64(n), f"{pre}.distance": np.float64(dist),
                           f"{pre}.body": np.array(self.problem.body_of_node(n).name),
                           f"{pre}.position": self.problem.points[n].copy()})
            for k, v in rec.probes.get(n, {}).items():
                arrays[f"{pre}.{k}"] = np.asarray(v)
        atomic_npz(os.path.join(self.out, "probes.npz"), arrays)
        self.files.add("probes.npz")

    def write_summary(self, summary) -> None:
        """``summary.json``: a :class:`vfrs.summary.Summary` (SI values, units, what each is)."""
        summary.save(os.path.join(self.out, "summary.json"))
        self.files.add("summary.json")

    def close(self, summary: str = "") -> None:
        try:
            self.flush()
        finally:
            if self._pool is not None:
                self._pool.shutdown(wait=True)
                self._pool = None
            if summary:
                self.log(summary)
            self._log.close()


def _unragged(history: dict) -> dict:
    """``history`` without arrays of Python objects (which an npz holds only as a pickle, and
    every reader loads with ``allow_pickle=False``): a ragged per-step record ``key`` (an
    object array of arrays) becomes ``key.values``, its entries one step after another, and
    ``key.offsets``, where each step's entries start (n + 1 of them)."""
    out = {}
    for k, v in history.items():
        v = np.asarray(v)
        if v.dtype != object:
            out[k] = v
            continue
        items = [np.ravel(np.asarray(x, dtype=float)) for x in v]
        out[f"{k}.values"] = np.concatenate(items) if items else np.zeros(0)
        out[f"{k}.offsets"] = np.concatenate([[0], np.cumsum([len(x) for x in items])]).astype(np.int64)
    return out


def write_history_csv(path, history: dict) -> None:
    """One row per step; vector entries become ``name_x``, ``name_y``, ``name_z`` columns
    (other shapes: ``name_0``, ``name_1``, ...). Ragged entries stay in ``history.npz`` only."""
    names, cols = _csv_columns(history)
    with open(path, "w", newline="") as fh:
        _write_csv(fh, names, cols, header=True)


def _write_csv(fh, names, cols, header: bool) -> None:
    w = csv.writer(fh)
    if header:
        w.writerow(names)
    if cols:
        for row in np.column_stack(cols):
            w.writerow([repr(float(x)) for x in row])


def _csv_columns(history: dict) -> tuple:
    """(column names, columns) of the CSV of ``history``."""
    cols, names = [], []
    n = len(history["t"]) if "t" in history else None
    for k, v in history.items():
        v = np.asarray(v)
        if v.dtype == object or (n is not None and len(v) != n):
            continue  # ragged, or not one row per step: kept in history.npz only
        if v.ndim == 1:
            cols.append(v)
            names.append(k)
        else:
            flat = v.reshape(len(v), -1)
            labels = "xyz" if flat.shape[1] == 3 else [str(i) for i in range(flat.shape[1])]
            for j in range(flat.shape[1]):
                cols.append(flat[:, j])
                names.append(f"{k}_{labels[j]}")
    return names, cols
