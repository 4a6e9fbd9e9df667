"""Files written whole or not at all: a temporary file in the same folder, flushed, synced and
renamed over the old one, so a run killed at any moment leaves the old file or the new one,
never half of one (the run folder's manifest, history, checkpoint, a sweep's table)."""

from __future__ import annotations

import io
import json
import os

import numpy as np

from ..errors import CheckpointError  # what an array of Python objects is (it would be a pickle)


def atomic_write(path, data) -> None:
    """Writes ``data`` to ``path`` atomically: temp file in the same folder, flush, fsync, rename.
    ``data``: bytes, or a function that writes into the open file."""
    path = os.fspath(path)
    tmp = f"{path}.tmp{os.getpid()}"
    try:
        with open(tmp, "wb") as fh:
            if callable(data):
                data(fh)
            else:
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
    """``arrays`` as an npz file (atomically), without pickles: an array of Python objects is
    a :class:`CheckpointError` (every reader loads with ``allow_pickle=False``)."""
    for k, a in arrays.items():
        if np.asarray(a).dtype.hasobject:
            raise CheckpointError(f"{path}: {k!r} is an array of Python objects, which vfrs does not write (it "
                                  "would be a pickle); store numbers")
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write(path, buf.getvalue())
