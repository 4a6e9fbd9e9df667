"""The M5 fold's meshes graded toward the contact zone against today's, at equal cells: what
a graded mesh buys at the contact and what it costs in element shape (issue 32, item 4).

For each cell count (the generator's coarse / medium / fine and one finer) it prints, for the
default mesh and the graded one at the same cells: nodes, tetrahedra, the cell at the
narrowest point of the glottis at mid-length (along the medial curve ``h_s``, along z ``h_z``,
across ``h_r``: the medial layer's thickness), the longest edge of the medial triangles
around that node (``h``: the element size where the folds touch first), the smallest dihedral
angle, its 1st percentile and the largest aspect ratio (:func:`vfrs.mesh.quality`: longest
edge / (2 sqrt(6) inradius), 1 = regular). No simulation runs: the comparison at equal error
(peak contact force and pressure) is the converge command's (docs/converge.md).

    python benchmarks/bench_graded_meshes.py                 # the table, a few seconds
    python benchmarks/bench_graded_meshes.py --set contact_zone=2e-3 --set zone_ratio=1.3
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from vfrs.meshes.m5 import RESOLUTIONS, m5

#: The graded settings docs/model.md recommends (and tests/test_graded_meshes.py holds to its
#: quality floor): the zone is the medial surface's thickness T along the curve, 10 of the 14 mm
#: along z.
GRADED = dict(contact_zone=3e-3, contact_zone_z=10e-3, zone_ratio=1.2, medial_ratio=1.2)
CELLS = {**RESOLUTIONS, "finer": (64, 16, 28)}


def at_contact(mesh, cells) -> dict:
    """The cell and the element size at the narrowest point (minimum x on the medial surface,
    the middle one of ties) at mid-length, in metres."""
    ns, nr, nz = cells
    P = mesh.points.reshape(ns + 1, nr + 1, nz + 1, 3)
    k = nz // 2
    x = P[:, 0, k, 0]
    ties = np.flatnonzero(x <= x.min() + 1e-12)
    i = int(ties[len(ties) // 2])
    node = int(np.arange(len(mesh.points)).reshape(ns + 1, nr + 1, nz + 1)[i, 0, k])
    tri = mesh.surface("medial")
    around = tri[(tri == node).any(axis=1)]
    e = mesh.points[around[:, [1, 2, 0]]] - mesh.points[around]
    h = float(np.sqrt((e * e).sum(axis=2)).max())
    return {"h_s": float(np.linalg.norm(P[i + 1, 0, k] - P[i, 0, k])),
            "h_z": float(np.linalg.norm(P[i, 0, k + 1] - P[i, 0, k])),
            "h_r": float(np.linalg.norm(P[i, 1, k] - P[i, 0, k])), "h": h}


def study(graded: dict) -> list[dict]:
    rows = []
    for name, cells in CELLS.items():
        for kind, kw in (("default", {}), ("graded", graded)):
            t = time.perf_counter()
            mesh = m5("right", cells=cells, **kw)
            q = mesh.quality().percentiles()
            rows.append({"cells": name, "mesh": kind, "nodes": mesh.n_points, "tets": mesh.n_tets,
                         **at_contact(mesh, cells), **q, "seconds": time.perf_counter() - t})
    return rows


def table(rows) -> str:
    head = ("| cells | mesh | nodes | tets | h_s mm | h_z mm | h_r mm | h mm | min dihedral | 1 % below | "
            "max aspect | < 10 deg |")
    lines = [head, "|" + " --- |" * (head.count("|") - 1)]
    for r in rows:
        lines.append(f"| {r['cells']} {CELLS[r['cells']]} | {r['mesh']} | {r['nodes']} | {r['tets']} | "
                     f"{r['h_s'] * 1e3:.3f} | {r['h_z'] * 1e3:.3f} | {r['h_r'] * 1e3:.3f} | {r['h'] * 1e3:.3f} | "
                     f"{r['dihedral_min']:.1f} | {r['dihedral_p1']:.1f} | {r['aspect_max']:.2f} | {r['poor']} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help=f"change a graded setting (default {GRADED})")
    args = ap.parse_args(argv)
    graded = dict(GRADED)
    for item in args.set:
        key, value = item.split("=", 1)
        graded[key.strip()] = None if value.strip() in ("", "none", "None") else float(value)
    print(f"graded: {graded}")
    print(table(study(graded)))


if __name__ == "__main__":
    main()
