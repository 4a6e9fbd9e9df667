"""Checkpoints of a run, resuming from them, and ending a run cleanly on SIGTERM / SIGINT.

A checkpoint (``OUT/checkpoint.pkl``) holds everything the march carries from one step to
the next, so that a resumed run repeats the uninterrupted one bit for bit:

- the loop's own values: the step reached, the loads at its start (``L_prev``), the work of
  the loads so far;
- the :class:`~vfrs.dynamics.State` (u, v, a over all and over the free DOFs, t);
- the integrator's :meth:`state` (HHT-alpha: the force vector of the step's start, the
  transient forces the next predictor must not see);
- every effect's :meth:`~vfrs.effects.Effect.state` (contact: the detectors' pairing and
  previous positions, the compliance columns already computed with the DOFs they cover, the
  recorder's running contact work; flow: nothing carries over);
- the recorder's history, probes and field snapshots so far, the output writer's series.

Every protocol object answers ``state() -> dict`` and ``restore(dict)`` (default: nothing
to keep), so a new effect touches only its own file. The compliance columns are kept as
computed: solved again in other batches they would differ in the last bits (a batch of up
to four right-hand sides takes another kernel than a larger one).

Files are written atomically: a temporary file in the same folder, flushed, fsynced, then
renamed over the old one (:func:`atomic_write`). A run killed at any moment leaves the last
complete checkpoint.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import pickle
import signal
import threading
import time

from .errors import VfrsError

CHECKPOINT = "checkpoint.pkl"
FORMAT = 1
#: Default wall time between checkpoints (seconds) when no step count is given.
DEFAULT_SECONDS = 60.0
#: Wall time between appends to history.csv (seconds).
HISTORY_SECONDS = 5.0


class CheckpointError(VfrsError):
    """A checkpoint cannot be written, read or resumed from (the message says why and what to do)."""


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
    import shlex

    return f"vfrs run --resume {shlex.quote(os.fspath(out))}"


def scene_hash(scene) -> str:
    """sha256 of the resolved scene (its TOML, defaults included)."""
    return hashlib.sha256(scene.to_toml().encode()).hexdigest()


def atomic_write(path, data: bytes) -> None:
    """Writes ``data`` to ``path`` atomically: temp file in the same folder, flush, fsync, rename."""
    path = os.fspath(path)
    tmp = f"{path}.tmp{os.getpid()}"
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    try:  # the rename itself survives a crash once the folder is synced
        fd = os.open(os.path.dirname(os.path.abspath(path)), os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError:
        pass


def atomic_json(path, obj) -> None:
    atomic_write(path, (json.dumps(obj, indent=1) + "\n").encode())


def atomic_npz(path, arrays: dict) -> None:
    import numpy as np

    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write(path, buf.getvalue())


def write_checkpoint(out, data: dict) -> int:
    """Pickles ``data`` into ``out/checkpoint.pkl`` atomically; returns its size in bytes."""
    blob = pickle.dumps({"format": FORMAT, **data}, protocol=pickle.HIGHEST_PROTOCOL)
    path = os.path.join(os.fspath(out), CHECKPOINT)
    try:
        atomic_write(path, blob)
    except OSError as exc:
        raise CheckpointError(f"{path}: the checkpoint ({len(blob) / 1e6:.3g} MB) could not be written: {exc}. The "
                              "previous checkpoint is intact; free space (or fix the folder's permissions) and "
                              f"resume with: {resume_command(out)}") from None
    return len(blob)


def read_checkpoint(out) -> dict:
    """The checkpoint of the run in ``out`` (a :class:`CheckpointError` if there is none).

    The file is a pickle: resume only runs you made (as with any pickle, loading one from an
    untrusted source can run code)."""
    path = os.path.join(os.fspath(out), CHECKPOINT)
    if not os.path.isdir(os.fspath(out)):
        raise CheckpointError(f"--resume {out}: no such folder; give the output folder of a run (vfrs run SCENE -o OUT)")
    if not os.path.exists(path):
        manifest = os.path.join(os.fspath(out), "manifest.json")
        status = ""
        if os.path.exists(manifest):
            try:
                with open(manifest) as fh:
                    status = json.load(fh).get("status", "")
            except (OSError, ValueError):
                status = ""
        if status == "complete":
            raise CheckpointError(f"--resume {out}: the run there is complete (manifest.json); nothing to resume")
        raise CheckpointError(f"--resume {out}: no {CHECKPOINT} there (a run writes one every checkpoint interval, "
                              "and on SIGTERM/SIGINT); start the run again with --overwrite")
    try:
        with open(path, "rb") as fh:
            data = pickle.load(fh)
    except Exception as exc:  # noqa: BLE001 - any unreadable file gets the same answer
        raise CheckpointError(f"{path}: cannot be read ({type(exc).__name__}: {exc}); start the run again with "
                              "--overwrite") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise CheckpointError(f"{path}: not a vfrs checkpoint of format {FORMAT}; start the run again with --overwrite")
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
