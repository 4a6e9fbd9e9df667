"""Run output on disk: the resolved scene, history (npz + CSV), VTU series for ParaView, a log.

Layout of ``out/``::

    scene.toml            the scene as run, defaults included (also inside history.npz and
                          the .pvd files)
    history.npz, history.csv
    <body>.pvd            ParaView collection of the field series (open this one)
    fields/<body>_<step>.vtu
    run.log               sizes, effects that ran, timings
"""

from __future__ import annotations

import csv
import datetime
import os
from xml.sax.saxutils import quoteattr

import numpy as np


class OutputWriter:
    """Writes one run's files into ``out`` (created if missing)."""

    def __init__(self, out, scene, problem):
        self.out = os.fspath(out)
        self.scene = scene
        self.problem = problem
        os.makedirs(os.path.join(self.out, "fields"), exist_ok=True)
        self.series = {p.name: [] for p in problem.bodies}
        scene.save(os.path.join(self.out, "scene.toml"))
        self._log = open(os.path.join(self.out, "run.log"), "w")
        self.log(f"vfrs run started {datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')}")
        self.log(f"scene: {scene.source}")

    def log(self, line: str) -> None:
        self._log.write(line.rstrip() + "\n")
        self._log.flush()

    def write_fields(self, step: int, t: float, fields: dict) -> None:
        """``fields``: name -> (n_nodes, 3) over all bodies; one VTU per body."""
        for p in self.problem.bodies:
            name = f"{p.name}_{step:06d}.vtu"
            data = {k: np.ascontiguousarray(v[p.nodes]) for k, v in fields.items()}
            p.mesh.write(os.path.join(self.out, "fields", name), point_data=data)
            self.series[p.name].append((t, f"fields/{name}"))
        self._write_pvd()

    def _write_pvd(self) -> None:
        for body, items in self.series.items():
            scene = self.scene.to_toml().replace("--", "- -")
            lines = ['<?xml version="1.0"?>', f"<!-- resolved vfrs scene:\n{scene}-->",
                     '<VTKFile type="Collection" version="0.1">', "<Collection>"]
            lines += [f'<DataSet timestep="{t!r}" part="0" file={quoteattr(f)}/>' for t, f in items]
            lines += ["</Collection>", "</VTKFile>"]
            with open(os.path.join(self.out, f"{body}.pvd"), "w") as fh:
                fh.write("\n".join(lines) + "\n")

    def write_history(self, history: dict) -> None:
        # The resolved scene travels with the numbers (key "scene", a TOML string).
        np.savez(os.path.join(self.out, "history.npz"), scene=np.array(self.scene.to_toml()), **history)
        write_history_csv(os.path.join(self.out, "history.csv"), history)

    def close(self, summary: str = "") -> None:
        if summary:
            self.log(summary)
        self._log.close()


def write_history_csv(path, history: dict) -> None:
    """One row per step; vector entries become ``name_x``, ``name_y``, ``name_z`` columns
    (other shapes: ``name_0``, ``name_1``, ...). Ragged entries stay in ``history.npz`` only."""
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
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        if cols:
            for row in np.column_stack(cols):
                w.writerow([repr(float(x)) for x in row])
