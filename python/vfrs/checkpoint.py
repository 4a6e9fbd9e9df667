"""Checkpoints of a run, resuming from them, and ending a run cleanly on SIGTERM / SIGINT.

A checkpoint holds everything the march carries from one step to the next, so that a
resumed run repeats the uninterrupted one bit for bit:

- the loop's own values: the step reached, the loads at its start (``L_prev``), the work of
  the loads so far;
- the :class:`~vfrs.dynamics.State` (u, v, a over all and over the free DOFs, t);
- the integrator's :meth:`state` (HHT-alpha: the force vector of the step's start, the
  transient forces the next predictor must not see);
- every effect's :meth:`~vfrs.effects.Effect.state` (contact: the detectors' pairing and
  previous positions, the compliance columns already computed with the DOFs they cover, the
  recorder's running contact work; flow: nothing carries over);
- the recorder's history, probes and field snapshots so far, the output writer's series:
  lists that only grow (:class:`Appended`), kept in append-only files.

Files (no pickle anywhere, nothing read from them can run code):

- ``OUT/checkpoint.npz``: the state. Every array under its path in the state
  (``effects/contact/x_prev``), and the member ``__checkpoint__``, a JSON text: the format,
  the state's skeleton (numbers, strings, bools, None, lists; tagged: ``{"array": path}``,
  ``{"scalar": path}``, ``{"tuple": [...]}``, ``{"dict": [[key, value], ...]}``,
  ``{"rows": path}``) and the append-only files' lengths. Read with
  ``np.load(..., allow_pickle=False)`` and ``json``; replaced atomically.
- ``OUT/checkpoint_rows/<i>.<generation>.bin``: one append-only file per :class:`Appended`
  list (a history key, a probe's record, a snapshot field, the VTU series). A checkpoint
  appends only the items added since the previous one, so its cost does not grow with the
  run; it records how many items and bytes are valid, and a resume cuts off what a stopped
  run appended after its last checkpoint.

:func:`flatten` accepts numpy arrays and scalars (not of dtype object), ``int``, ``float``,
``str``, ``bool``, ``None``, and lists, tuples and dicts (keys ``str`` or ``int``) of those;
anything else is a :class:`CheckpointError` naming its path and type, at the first step of a
run that writes checkpoints (:func:`check_state`). Every protocol object answers
``state() -> dict`` and ``restore(dict)`` (default: nothing to keep), so a new effect touches
only its own file. The compliance columns are kept as computed: solved again in other batches
they would differ in the last bits (a batch of up to four right-hand sides takes another kernel
than a larger one).

Files are written atomically: a temporary file in the same folder, flushed, fsynced, then
renamed over the old one (:func:`vfrs.output.atomic.atomic_write`). A run killed at any moment leaves the last
complete checkpoint.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shlex
import shutil
import signal
import struct
import zlib
import threading
import time

import numpy as np

from .errors import CheckpointError  # defined in errors.py (every error class is), raised here
from .output.atomic import atomic_write
from .output.reader import inside, read_json

CHECKPOINT = "checkpoint.npz"
#: The append-only files of the lists a checkpoint keeps (:class:`Appended`), in ``OUT/``.
ROWS = "checkpoint_rows"
#: The pickled checkpoint of vfrs versions before format 2: refused, never loaded.
OLD_CHECKPOINT = "checkpoint.pkl"
FORMAT = 2
#: The JSON member of checkpoint.npz.
_DOC = "__checkpoint__"
#: Default wall time between checkpoints (seconds) when no step count is given.
DEFAULT_SECONDS = 60.0
#: Wall time between appends to history.csv (seconds; the first rows go at the first step).
HISTORY_SECONDS = 1.0


class RunStopped(Exception):
    """A run ended on SIGTERM or SIGINT after writing its history and a checkpoint.

    ``signum``: the signal; ``step``, ``t``: where it stopped; ``out``: the output folder;
    ``exit_code``: 128 + signum (143 for SIGTERM, 130 for SIGINT), what shells expect."""

    def __init__(self, signum: int, step: int, t: float, out: str):
        self.signum, self.step, self.t, self.out = signum, step, t, out
        self.exit_code = 128 + int(signum)
        name = signal.Signals(signum).name
        super().__init__(f"{name} received: stopped after step {step} (t = {t:.6g}); history and checkpoint written. "
                         f"Resume with: {resume_command(out)}")


def resume_command(out: str) -> str:
    return f"vfrs run --resume {shlex.quote(os.fspath(out))}"


def scene_hash(scene) -> str:
    """sha256 of the resolved scene (its TOML, defaults included)."""
    return hashlib.sha256(scene.to_toml().encode()).hexdigest()


class Appended:
    """A list that only grows during a run (the history of a key, a probe's record, the field
    snapshots), or an array that only gains rows (the compliance columns computed so far): a
    checkpoint appends the items added since the previous one to a file of its own instead of
    writing the whole list again. ``items``: the list or array itself (not copied; its first
    items must be those of the previous checkpoint). Each item is a numpy array or scalar, a
    number, a bool or a string (the same dtype and shape throughout keeps the file plain;
    other lists are stored item by item). ``epoch``: changed when the list is started again
    (its old items dropped): the next checkpoint then writes it whole. Restored as a list, or
    as an array when ``items`` is one."""

    __slots__ = ("items", "epoch")

    def __init__(self, items, epoch: int = 0):
        self.items = items
        self.epoch = int(epoch)


def items_of(x):
    """The list or array of an :class:`Appended` (a state() given straight to restore()), else ``x``."""
    return x.items if isinstance(x, Appended) else x


_KINDS = "biufcUS"  # bool, integers, floats, complex, strings: what np.load reads without pickle


def _unsupported(path: str, obj) -> CheckpointError:
    t = type(obj)
    what = f"an array of dtype {obj.dtype}" if hasattr(obj, "dtype") else f"a {t.__module__}.{t.__qualname__}"
    return CheckpointError(f"checkpoint: {path or '(top)'} is {what}, which a checkpoint does not store: state() may "
                           "return numpy arrays (numbers, bools, strings), numbers, strings, bools, None, and lists, "
                           "tuples and dicts (str or int keys) of those (vfrs.checkpoint.flatten); convert it in the "
                           "state() of the object that returns it")


def flatten(obj, path: str, arrays: dict, journal: "Journal | None" = None):
    """The JSON skeleton of ``obj``; its arrays go into ``arrays`` under their path, its
    :class:`Appended` lists into ``journal`` (None: checked only). Anything not storable
    without pickle is a :class:`CheckpointError` naming its path and type."""
    if obj is None or isinstance(obj, (bool, str)):
        return obj if type(obj) in (bool, str) or obj is None else _scalar(obj, path, arrays)
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind not in _KINDS or obj.dtype.hasobject:
            raise _unsupported(path, obj)
        if path in arrays:
            raise CheckpointError(f"checkpoint: two entries have the path {path!r}")
        arrays[path] = obj
        return {"array": path}
    if isinstance(obj, np.generic):
        return _scalar(obj, path, arrays)
    if type(obj) in (int, float):
        return obj
    if isinstance(obj, tuple) and type(obj) is tuple:
        return {"tuple": [flatten(x, f"{path}/{i}", arrays, journal) for i, x in enumerate(obj)]}
    if type(obj) is list:
        return [flatten(x, f"{path}/{i}", arrays, journal) for i, x in enumerate(obj)]
    if isinstance(obj, dict):
        pairs = []
        for k, v in obj.items():
            if type(k) not in (str, int):
                raise CheckpointError(f"checkpoint: {path or '(top)'} has the key {k!r} of type {type(k).__name__}: "
                                      "dict keys in a state() must be str or int")
            pairs.append([k, flatten(v, f"{path}/{k}" if path else str(k), arrays, journal)])
        return {"dict": pairs}
    if isinstance(obj, Appended):
        if journal is None:  # checked only: each item as the journal would take it
            for i, x in enumerate(obj.items[-2:]):
                _item(x, path, len(obj.items) - 2 + i)
        else:
            journal.append(path, obj.items, obj.epoch)
        return {"rows": path}
    raise _unsupported(path, obj)


def _scalar(obj, path, arrays):
    a = np.asarray(obj)
    if a.dtype.kind not in _KINDS:
        raise _unsupported(path, obj)
    arrays[path] = a
    return {"scalar": path}


def unflatten(node, arrays: dict, rows):
    """The value of a skeleton ``node`` (:func:`flatten`'s inverse); ``rows(path)``: the
    items of an :class:`Appended` list."""
    if node is None or isinstance(node, (bool, int, float, str)):
        return node
    if isinstance(node, list):
        return [unflatten(x, arrays, rows) for x in node]
    if isinstance(node, dict) and len(node) == 1:
        (tag, value), = node.items()
        if tag == "array":
            return arrays[value]
        if tag == "scalar":
            return arrays[value][()]
        if tag == "tuple":
            return tuple(unflatten(x, arrays, rows) for x in value)
        if tag == "dict":
            return {k: unflatten(v, arrays, rows) for k, v in value}
        if tag == "rows":
            return rows(value)
    raise CheckpointError(f"checkpoint: an entry of its skeleton is not one vfrs writes ({str(node)[:80]})")


def _item(x, path: str, i: int) -> np.ndarray:
    a = np.asarray(x)
    if a.dtype.kind not in _KINDS or a.dtype.hasobject:
        what = f"an array of dtype {x.dtype}" if hasattr(x, "dtype") else f"a {type(x).__module__}.{type(x).__qualname__}"
        raise CheckpointError(f"checkpoint: {path}[{i}] is {what}, which a checkpoint does not store: the items of an "
                              "append-only list (vfrs.checkpoint.Appended) must be numpy arrays or scalars (numbers, "
                              "bools, strings), numbers, bools or strings")
    return a


def _ragged(a: np.ndarray) -> bytes:
    head = json.dumps({"dtype": a.dtype.str, "shape": list(a.shape)}).encode()
    return struct.pack("<q", len(head)) + head + np.ascontiguousarray(a).tobytes()


_ROW_FILE = re.compile(r"^[0-9]+\.[0-9]+\.bin$")


class Journal:
    """The append-only files of a run's :class:`Appended` lists (``OUT/checkpoint_rows/``).

    ``meta``: per list (its path in the checkpoint's state) the file, the items and bytes
    written, and either their ``dtype`` and ``shape`` (all alike: the file is the items' bytes
    one after another) or ``ragged`` (each item with a small header: its dtype and shape). A
    list whose items change dtype or shape is written again, once, into a new file (its next
    generation); the old one goes when the checkpoint that no longer needs it is written."""

    def __init__(self, out):
        self.dir = os.path.join(os.fspath(out), ROWS)
        self.meta: dict = {}
        self._obsolete: list = []
        self._next = 0

    def resume(self, meta: dict) -> None:
        """Continue from a checkpoint's lists: each file cut to the length it had then, files
        it does not know removed (what the stopped run wrote after its checkpoint)."""
        self.meta = {p: dict(m) for p, m in meta.items()}
        out = os.path.dirname(self.dir)
        files = [row_file(out, p, m) for p, m in self.meta.items()]  # all checked before any is cut
        self._next = 1 + max((int(m["file"].split(".")[0]) for m in self.meta.values()), default=-1)
        keep = {m["file"] for m in self.meta.values()}
        if os.path.lexists(self.dir) and inside(out, ROWS, os.path.join(out, CHECKPOINT), CheckpointError):
            for f in set(os.listdir(self.dir)) - keep:
                os.remove(os.path.join(self.dir, f))
        for f, m in zip(files, self.meta.values()):
            os.truncate(f, m["bytes"])

    def files(self) -> list:
        """The files in use, relative to the output folder."""
        return [f"{ROWS}/{m['file']}" for m in self.meta.values()]

    def append(self, path: str, items, epoch: int = 0) -> None:
        m = self.meta.get(path)
        n = len(items)
        if m is not None and m.get("epoch", 0) != epoch:  # started again: written whole, into a new file
            self._obsolete.append(m["file"])
            m = self.meta[path] = {"file": f"{self._next}.{int(m['file'].split('.')[1]) + 1}.bin", "count": 0,
                                   "bytes": 0, "epoch": epoch}
            self._next += 1
        if m is not None and n < m["count"]:
            raise CheckpointError(f"checkpoint: the append-only list {path} got shorter ({m['count']} -> {n} items) "
                                  "without a new epoch (vfrs.checkpoint.Appended)")
        start = 0 if m is None else m["count"]
        if m is not None and n == start:
            return
        if isinstance(items, np.ndarray):  # rows of an array: one block, always plain
            if items.ndim < 1 or items.dtype.kind not in _KINDS:
                raise _unsupported(path, items)
            block = np.ascontiguousarray(items[start:])
            if m is None:
                m = self.meta[path] = {"file": f"{self._next}.0.bin", "count": 0, "bytes": 0, "epoch": epoch}
                self._next += 1
            if m["count"] == 0:
                m.update(array=True, dtype=block.dtype.str, shape=list(block.shape[1:]))
            if (block.dtype.str, list(block.shape[1:])) != (m["dtype"], m["shape"]):
                raise CheckpointError(f"checkpoint: the rows of {path} changed dtype or width ({m['dtype']} "
                                      f"{m['shape']} -> {block.dtype.str} {list(block.shape[1:])}) without a new epoch")
            self._write(m, block.tobytes(), len(block))
            return
        if n == start:
            return
        if m is not None and not m.get("ragged"):  # the common case: one conversion of the new items
            fast: np.ndarray | None
            try:
                fast = np.asarray(items[start:])
            except ValueError:  # ragged
                fast = None
            if fast is not None and (fast.dtype.str, list(fast.shape[1:])) == (m["dtype"], m["shape"]):
                self._write(m, fast.tobytes(), n - start)
                return
        new = [_item(x, path, start + i) for i, x in enumerate(items[start:])]
        block = _stacked(new)
        if m is not None and not m.get("ragged") and block is not None and (
                block.dtype.str, list(block.shape[1:])) == (m["dtype"], m["shape"]):
            self._write(m, block.tobytes(), len(new))
            return
        if m is not None and m.get("ragged"):
            self._write(m, b"".join(_ragged(a) for a in new), len(new))
            return
        # A new list, or one whose items changed dtype or shape: all its items into a new file.
        if m is not None:
            self._obsolete.append(m["file"])
            new = [_item(x, path, i) for i, x in enumerate(items)]
            block = _stacked(new)
        m = self.meta[path] = {"file": f"{self._next}.{0 if m is None else int(m['file'].split('.')[1]) + 1}.bin",
                               "count": 0, "bytes": 0, "epoch": epoch}
        self._next += 1
        if block is not None:
            m.update(dtype=block.dtype.str, shape=list(block.shape[1:]))
            self._write(m, block.tobytes(), len(new))
        else:
            m["ragged"] = True
            self._write(m, b"".join(_ragged(a) for a in new), len(new))

    def _write(self, m: dict, data: bytes, count: int) -> None:
        os.makedirs(self.dir, exist_ok=True)
        path = os.path.join(self.dir, m["file"])
        # Not fsynced: a killed process loses nothing the kernel has, and one fsync per list
        # and checkpoint cost more than the rest of the checkpoint (1,100 fsyncs: 0.42 of 0.84 s
        # in the coarse main job); the crc32 tells a file a system crash left incomplete.
        with open(path, "r+b" if os.path.exists(path) else "wb") as fh:
            fh.seek(m["bytes"])  # over anything a stopped run left after the last checkpoint
            fh.write(data)
            fh.truncate()
        m["bytes"] += len(data)
        m["count"] += count
        m["crc32"] = zlib.crc32(data, m.get("crc32", 0))

    def committed(self) -> None:
        """A checkpoint naming the current files is on disk: the files it replaced go."""
        for f in self._obsolete:
            with contextlib.suppress(OSError):
                os.remove(os.path.join(self.dir, f))
        self._obsolete = []

    def remove(self) -> None:
        """The run is complete: the files go."""
        shutil.rmtree(self.dir, ignore_errors=True)


def _stacked(items: list):
    """The items as one array (count, *shape) when they share dtype and shape, else None."""
    first = items[0]
    if any(a.shape != first.shape or a.dtype != first.dtype for a in items):
        return None
    if first.ndim == 0:
        return np.array(items, dtype=first.dtype)
    return np.stack(items)


def row_file(out, path: str, m: dict) -> str:
    """The file of the list ``path`` that the checkpoint's ``m`` names: a name vfrs writes, in
    ``OUT/checkpoint_rows/``, no symbolic link leading out of ``out``; else CheckpointError."""
    name, source = str(m.get("file", "")), os.path.join(os.fspath(out), CHECKPOINT)
    if not _ROW_FILE.match(name):
        raise CheckpointError(f"{source}: the list {path} names the file {name!r}, not one vfrs writes "
                              f"({ROWS}/<n>.<n>.bin); start the run again with --overwrite")
    return inside(out, f"{ROWS}/{name}", f"{source} (the list {path})", CheckpointError)


def read_rows(out, path: str, m: dict) -> list:
    """The items of the append-only list ``path`` as the checkpoint ``m`` describes them (the
    file's first ``m["bytes"]`` bytes; nothing is changed on disk)."""
    where = row_file(out, path, m)
    try:
        with open(where, "rb") as fh:
            buf = fh.read(int(m["bytes"]))
    except OSError as exc:
        raise CheckpointError(f"{where}: cannot be read ({exc}); the checkpoint needs it: start the run again with "
                              "--overwrite") from None
    if len(buf) != int(m["bytes"]):
        raise CheckpointError(f"{where}: {len(buf)} bytes, the checkpoint counts {m['bytes']}: the file was cut or "
                              "replaced; start the run again with --overwrite")
    if zlib.crc32(buf) != int(m.get("crc32", 0)):
        raise CheckpointError(f"{where}: its content is not what the checkpoint recorded (crc32 differs: the file "
                              "was changed, or a system crash left it incomplete); start the run again with --overwrite")
    count = int(m["count"])
    try:
        if not m.get("ragged"):
            dtype = np.dtype(m["dtype"])
            if dtype.kind not in _KINDS:
                raise ValueError(f"dtype {dtype} is not one vfrs writes")
            arr = np.frombuffer(buf, dtype=dtype).reshape((count, *m["shape"])).copy()
            if m.get("array"):
                return arr
            return arr.tolist() if arr.ndim == 1 else list(arr)
        items, pos = [], 0
        for _ in range(count):
            (n,) = struct.unpack_from("<q", buf, pos)
            head = json.loads(buf[pos + 8:pos + 8 + n])
            dtype = np.dtype(head["dtype"])
            if dtype.kind not in _KINDS:
                raise ValueError(f"dtype {dtype} is not one vfrs writes")
            size = dtype.itemsize * int(np.prod(head["shape"], dtype=np.int64))
            start = pos + 8 + n
            items.append(np.frombuffer(buf[start:start + size], dtype=dtype).reshape(head["shape"]).copy())
            pos = start + size
        return items
    except (ValueError, TypeError, KeyError, struct.error) as exc:
        raise CheckpointError(f"{where}: not the list {path} the checkpoint describes ({exc}); start the run again "
                              "with --overwrite") from None


def check_state(data: dict) -> None:
    """Raises the :class:`CheckpointError` that :func:`write_checkpoint` would for ``data``
    (run at a run's first step, so a state() returning something unsupported is told at
    once, not at the first checkpoint); writes nothing."""
    flatten(data, "", {})


def write_checkpoint(out, data: dict, journal: Journal | None = None) -> int:
    """Writes ``data`` as ``out/checkpoint.npz`` (atomically) and its :class:`Appended` lists'
    new items into ``journal``'s files; returns the bytes written."""
    out = os.fspath(out)
    journal = Journal(out) if journal is None else journal
    path = os.path.join(out, CHECKPOINT)
    arrays: dict = {}
    before = sum(m["bytes"] for m in journal.meta.values())
    try:
        skeleton = flatten(data, "", arrays, journal)
        doc = {"format": FORMAT, "state": skeleton, "rows": journal.meta}
        arrays[_DOC] = np.array(json.dumps(doc))
        atomic_write(path, lambda fh: np.savez(fh, allow_pickle=False, **arrays))  # no copy in memory
        size = os.path.getsize(path)
    except OSError as exc:
        raise CheckpointError(f"{path}: the checkpoint could not be written: {exc}. The previous checkpoint is "
                              "intact; free space (or fix the folder's permissions) and resume with: "
                              f"{resume_command(out)}") from None
    journal.committed()
    return size + sum(m["bytes"] for m in journal.meta.values()) - before


def _status(out_s: str) -> str:
    """The manifest's status of the run folder ``out_s`` ("" when it has none or it is damaged)."""
    try:
        return str(read_json(os.path.join(out_s, "manifest.json")).get("status") or "")
    except ValueError:
        return ""


def read_checkpoint(out) -> dict:
    """The checkpoint of the run in ``out`` (a :class:`CheckpointError` if there is none).

    Read with ``np.load(allow_pickle=False)`` and ``json``: nothing in it can run code. A
    pickled ``checkpoint.pkl`` of an earlier version is refused, never loaded. The lists'
    files are only read (:meth:`Journal.resume` cuts them, once the run holds the folder);
    the result's ``"_rows"`` is their description."""
    out_s = os.fspath(out)
    path = os.path.join(out_s, CHECKPOINT)
    if not os.path.isdir(out_s):
        raise CheckpointError(f"--resume {out}: no such folder; give the output folder of a run (vfrs run SCENE -o OUT)")
    if _status(out_s) == "complete":  # a spare checkpoint (killed while removing it) is not resumed
        raise CheckpointError(f"--resume {out}: the run there is complete (manifest.json); nothing to resume")
    if not os.path.exists(path):
        old = os.path.join(out_s, OLD_CHECKPOINT)
        if os.path.exists(old):
            raise CheckpointError(f"{old}: a checkpoint of an earlier vfrs version, a Python pickle, which vfrs no "
                                  "longer loads (loading a pickle can run any code it holds); it cannot be resumed: "
                                  f"start the run again with: vfrs run {os.path.join(out_s, 'scene.toml')} -o {out_s} "
                                  "--overwrite")
        raise CheckpointError(f"--resume {out}: no {CHECKPOINT} there (a run writes one every checkpoint interval, "
                              "and on SIGTERM/SIGINT); start the run again with --overwrite")
    arrays = {}
    try:
        with np.load(path, allow_pickle=False) as z:
            for k in z.files:
                try:
                    arrays[k] = z[k]
                except ValueError as exc:
                    if "allow_pickle" not in str(exc):
                        raise
                    raise CheckpointError(f"{path}: the member {k!r} is an array of Python objects, which a vfrs "
                                          "checkpoint never holds (loading it would unpickle it, which can run code); "
                                          "it was not loaded. This file was not written by vfrs: start the run again "
                                          "with --overwrite") from None
        doc = json.loads(str(arrays.pop(_DOC)[()]))
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise CheckpointError(f"{path}: not a vfrs checkpoint of format {FORMAT}; start the run again with --overwrite")
        meta = doc["rows"]
        [row_file(out_s, p, m) for p, m in meta.items()]  # names vfrs writes, inside the folder (resume cuts them)
        data = unflatten(doc["state"], arrays, lambda p: read_rows(out_s, p, meta[p]) if p in meta else [])
    except CheckpointError:
        raise
    except Exception as exc:  # noqa: BLE001 - any unreadable file gets the same answer
        raise CheckpointError(f"{path}: cannot be read ({type(exc).__name__}: {exc}); start the run again with "
                              "--overwrite") from None
    if not isinstance(data, dict):
        raise CheckpointError(f"{path}: not a vfrs checkpoint of format {FORMAT}; start the run again with --overwrite")
    data["_rows"] = meta
    return data


def state_of(obj) -> dict:
    """``obj.state()`` for objects that keep state across steps, else ``{}``."""
    f = getattr(obj, "state", None)
    return f() if callable(f) else {}


def restore_into(obj, state: dict | None) -> None:
    """``obj.restore(state)`` for objects that keep state across steps."""
    f = getattr(obj, "restore", None)
    if callable(f) and state:
        f(state)


class Checkpointer:
    """When to write checkpoints and history, and the stop requests of SIGTERM / SIGINT.

    ``every``: steps between checkpoints (None: by wall time); ``seconds``: wall time between
    checkpoints when ``every`` is None (0 or None: none but the one on a signal)."""

    def __init__(self, out, every: int | None = None, seconds: float | None = DEFAULT_SECONDS,
                 history_seconds: float = HISTORY_SECONDS):
        if every is not None and (isinstance(every, bool) or not isinstance(every, int) or every < 1):
            raise CheckpointError(f"checkpoint every {every!r} steps: expected a whole number >= 1")
        if seconds is not None and not (isinstance(seconds, (int, float)) and seconds >= 0):
            raise CheckpointError(f"checkpoint every {seconds!r} seconds: expected a number >= 0")
        self.out = os.fspath(out)
        self.every, self.seconds, self.history_seconds = every, seconds, history_seconds
        self.last = self.last_history = time.monotonic()
        self.stop_signal: int | None = None
        self.written = 0
        self._previous: dict = {}
        self.journal = Journal(out)  # the checkpoints' append-only lists

    def due(self, k: int) -> bool:
        if self.every is not None:
            return k % self.every == 0
        return bool(self.seconds) and time.monotonic() - self.last >= float(self.seconds or 0.0)

    def history_due(self) -> bool:
        return time.monotonic() - self.last_history >= self.history_seconds

    def wrote(self) -> None:
        self.last = self.last_history = time.monotonic()
        self.written += 1

    # -- signals -------------------------------------------------------------------------
    def _handler(self, signum, frame):
        if self.stop_signal is not None:  # a second signal: stop now, without a checkpoint
            raise KeyboardInterrupt
        self.stop_signal = signum

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for s in (signal.SIGTERM, signal.SIGINT):
                self._previous[s] = signal.signal(s, self._handler)
        return self

    def __exit__(self, *exc):
        for s, h in self._previous.items():
            signal.signal(s, h)
        self._previous = {}
        return False
