"""Reading a run folder back: :func:`load` (a :class:`RunOutput`: history, scene, field
snapshots; with its summary: :func:`vfrs.load`, the summary package's reader), and its files, which may come from someone else or be cut short by a kill.

- :func:`inside`: a path a folder's own file names (a manifest's file list, a checkpoint's
  lists, a sweep's run ids) as a path inside that folder, or a named error: an absolute path,
  ``..``, or a symbolic link (of the file or of a folder on its way) that leads out is refused,
  so that nothing outside the folder is removed, replaced or read.
- :func:`read_json`, :func:`read_npz`: the content of a file, or one line (:func:`damaged`)
  naming the file and what to do, never a traceback.
"""

from __future__ import annotations

import json
import os

from ..errors import VfrsError


def inside(folder, rel, source: str, error: type = VfrsError) -> str:
    """The path of ``rel`` (relative, as ``source`` names it) in ``folder``, when it stays
    inside: no absolute path, no ``..``, and its real path (every symbolic link followed,
    those of the folders on its way too) inside ``folder``'s. Else ``error``, one line naming
    ``source``, the path and where it leads."""
    folder = os.fspath(folder)
    where = "is not a relative path"
    if isinstance(rel, str) and rel and not os.path.isabs(rel):
        if ".." in rel.replace("\\", "/").split("/"):
            where = "climbs out with '..'"
        else:
            path = os.path.join(folder, rel)
            try:
                root, real = os.path.realpath(folder), os.path.realpath(path)
            except (OSError, ValueError):  # a NUL byte, a loop of links
                root = real = ""
            if real and real != root and os.path.commonpath([root, real]) == root:
                return path
            where = ("is not a path that resolves" if not real else
                     f"leads to {real} through a symbolic link" if real != root else "is the folder itself")
    raise error(f"{source}: names the path {rel!r}, which {where}, outside the folder {folder}: vfrs removes, "
                "replaces and reads only files inside a run's folder, so nothing was touched; this folder's "
                "files were not written by vfrs as they are: remove that path (or the link), or use another folder")


def damaged(path, exc, fix: str | None = None) -> str:
    """The one-line message for an output file that cannot be read: the file, why, and
    ``fix`` (default: run the scene again, or resume the run)."""
    out = os.path.dirname(path) or "."
    why = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    fix = fix or (f"run the scene again (vfrs run {os.path.join(out, 'scene.toml')} -o {out} --overwrite), or, if "
                  f"the run stopped with a checkpoint, vfrs run --resume {out} writes it again")
    return f"{path}: damaged or incomplete, cannot be read ({type(exc).__name__}: {why}); {fix}"


def read_json(path, fix: str | None = None, kind: type = dict):
    """The JSON content of ``path`` (of type ``kind``), or VfrsError (:func:`damaged`, with
    ``fix``): a truncated, empty, non-UTF-8 or missing file is one line."""
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)  # JSONDecodeError and UnicodeDecodeError are ValueErrors
        if not isinstance(data, kind):
            raise ValueError(f"a JSON {type(data).__name__}, not the {kind.__name__} vfrs writes")
    except (OSError, ValueError) as exc:
        raise VfrsError(damaged(path, exc, fix)) from None
    return data


def read_npz(path, fix: str | None = None) -> dict:
    """Every array of the npz file ``path`` (no pickles), or VfrsError (:func:`damaged`)."""
    import zipfile
    import zlib

    import numpy as np

    try:
        with open(path, "rb") as fh:  # our handle: closed on any error
            z = np.load(fh, allow_pickle=False)
            if not isinstance(z, np.lib.npyio.NpzFile):
                raise ValueError("a single array, not an npz archive")
            with z:
                return {k: z[k] for k in z.files}
    except (zipfile.BadZipFile, zlib.error, EOFError, ValueError, KeyError, OSError) as exc:
        raise VfrsError(damaged(path, exc, fix)) from None


def running(out) -> int | None:
    """The process id of a run still writing to ``out`` (its manifest says ``running``, on this
    host, and that process is alive), else None."""
    import socket

    try:
        m = read_json(os.path.join(os.fspath(out), "manifest.json"))
        pid = int(m.get("pid", 0))
    except (ValueError, TypeError):  # none, damaged (a VfrsError), or no number
        return None
    if m.get("status") != "running" or m.get("host") != socket.gethostname() or pid <= 0 or pid == os.getpid():
        return None
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return None
    except OSError:  # alive, another user's
        return pid
    return pid


def no_history(out) -> str:
    """Why the folder ``out`` has no ``history.npz`` and what to do, from its manifest: a run
    still writing there; a run stopped (killed) before it wrote its history: resume it from its
    checkpoint, or, without one, run it again; or no run at all."""
    import shlex

    out = os.fspath(out)
    q = shlex.quote(out)
    try:
        status = read_json(os.path.join(out, "manifest.json")).get("status")
    except VfrsError:
        return f"{out}: no history.npz; give the output folder of `vfrs run SCENE -o {out}`"
    pid = running(out)
    if pid is not None:
        return (f"{out}: no history.npz yet: a run (process {pid}) is still writing there; it writes its history "
                f"when it ends, or when stopped with a checkpoint (kill -TERM {pid}), then run this again")
    again = f"vfrs run {shlex.quote(os.path.join(out, 'scene.toml'))} -o {q} --overwrite"
    if status == "complete":
        return f"{out}: no history.npz, though the run completed (manifest.json): it was removed; run it again: {again}"
    if os.path.exists(os.path.join(out, "checkpoint.npz")):
        return (f"{out}: no history.npz: the run there was stopped (killed, manifest status {status!r}) before it "
                f"wrote its history; resume it from its checkpoint with `vfrs run --resume {q}`, then plot it")
    return (f"{out}: no history.npz: the run there was stopped (killed, manifest status {status!r}) before its "
            f"first history write and checkpoint; nothing to resume: run it again with `{again}`")


class RunOutput:
    """A run read back from its output folder (``vfrs run ... -o OUT``): ``history`` (the
    arrays of ``history.npz``), ``scene`` (the resolved :class:`vfrs.Scene`), ``bodies`` (name -> node range, from the scene's
    meshes), ``snapshots(body)`` (times and VTU files of the field series)."""

    def __init__(self, out):
        from ..scene import Scene

        self.out = os.fspath(out)
        path = os.path.join(self.out, "history.npz")
        if not os.path.exists(path):  # no run there, or one stopped before it wrote its history: say which
            raise VfrsError(no_history(self.out))
        arrays = read_npz(path)  # no pickles; a damaged file is one VfrsError line saying what to do
        self.history = {k: v for k, v in arrays.items() if k != "scene"}
        toml = str(arrays["scene"]) if "scene" in arrays else None
        if "t" not in self.history:
            raise VfrsError(damaged(path, ValueError("no array 't', the time of each step, which vfrs writes")))
        self.t = self.history["t"]
        scene_path = os.path.join(self.out, "scene.toml")
        if os.path.exists(scene_path) or toml is None:
            try:
                self.scene = Scene.load(scene_path)
            except VfrsError as exc:  # cut short or edited: the copy in history.npz is the scene as run
                raise VfrsError(damaged(scene_path, exc, "the scene as run is also inside history.npz: remove "
                                        "scene.toml and vfrs reads that copy" if toml else None)) from None
        else:  # the copy of the resolved scene that travels inside history.npz
            from .._compat import tomllib

            self.scene = Scene.from_dict(tomllib.loads(toml), source=path, base_dir=self.out)
        self._meshes = None

    @property
    def meshes(self) -> dict:
        """Body name -> (mesh, node offset), rebuilt from the scene (deterministic generators)."""
        if self._meshes is None:
            out, off = {}, 0
            for b, m in zip(self.scene.bodies, self.scene.build_meshes()):
                out[b.name] = (m, off)
                off += m.n_points
            self._meshes = out
        return self._meshes

    def body_of_node(self, node: int) -> str | None:
        for name, (m, off) in self.meshes.items():
            if off <= node < off + m.n_points:
                return name
        return None

    def snapshots(self, body: str) -> list:
        """[(t, path to the VTU)] of one body's field series (from ``<body>.pvd``)."""
        import re

        from ..errors import OutputFolderError

        path = os.path.join(self.out, f"{body}.pvd")
        try:
            with open(path, encoding="utf-8") as fh:
                text = fh.read()
            items = [(float(t), f) for t, f in re.findall(r'<DataSet timestep="([^"]+)" part="0" file="([^"]+)"/>', text)]
        except (OSError, ValueError) as exc:
            raise VfrsError(damaged(path, exc)) from None
        return [(t, inside(self.out, f, path, OutputFolderError)) for t, f in items]  # never a file outside the run


def load(out) -> RunOutput:
    """Reads an output folder of ``vfrs run`` (see :class:`RunOutput`)."""
    return RunOutput(out)
