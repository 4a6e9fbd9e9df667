"""Run output on disk: the resolved scene, history (npz + CSV), VTU series for ParaView, a log.

Layout of ``out/``::

    scene.toml            the scene as run, defaults included (also inside history.npz and
                          the .pvd files)
    history.npz, history.csv
    summary.json          what the run measured (vfrs.analysis.summarize: f0, quotients,
                          peak flow, first contact, peak force and contact pressure, ...)
    <body>.pvd            ParaView collection of the field series (open this one)
    fields/<body>_<step>.vtu   displacement, velocity, each effect's force and, with
                          [contact], ``contact_pressure`` (Pa, per contact-surface node)
    run.log               sizes, effects that ran, timings, the results summary
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
        self._pressure = self._pressure_setup(scene, problem)
        scene.save(os.path.join(self.out, "scene.toml"))
        self._log = open(os.path.join(self.out, "run.log"), "w")
        self.log(f"vfrs run started {datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')}")
        self.log(f"scene: {scene.source}")

    def log(self, line: str) -> None:
        self._log.write(line.rstrip() + "\n")
        self._log.flush()

    @staticmethod
    def _pressure_setup(scene, problem):
        """(contact-surface triangles, tributary areas) when the scene has [contact], else None."""
        settings = scene.effects.get("contact")
        if getattr(settings, "common", None) is None:  # no [contact] (or an effect of the user's own)
            return None
        from .enforcement.detection import ContactSurfaces

        surfaces = ContactSurfaces(problem, settings.common.surface, settings.common.pairs)
        return np.concatenate(list(surfaces.surface_of.values())), surfaces.areas

    def write_fields(self, step: int, t: float, fields: dict) -> None:
        """``fields``: name -> (n_nodes, 3) over all bodies; one VTU per body. With [contact],
        adds ``contact_pressure`` (Pa): the compressive normal part of each contact-surface
        node's ``contact_force`` over its tributary area, normals at the displaced positions
        (:func:`vfrs.enforcement.record.nodal_pressure`, as the history's
        ``contact_pressure_max``)."""
        if self._pressure is not None and "contact_force" in fields:
            from .enforcement.record import nodal_pressure

            tri, areas = self._pressure
            x = self.problem.points + fields["displacement"] if "displacement" in fields else self.problem.points
            fields = {**fields, "contact_pressure": nodal_pressure(fields["contact_force"], x, tri, areas)}
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

    def write_summary(self, summary) -> None:
        """``summary.json``: a :class:`vfrs.analysis.Summary` (SI values, units, what each is)."""
        summary.save(os.path.join(self.out, "summary.json"))

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
