"""The M5 mesh ladders compared (docs/convergence.md, "Why the folds' numbers moved"): the
legacy resolutions (coarse, medium, fine) and the systematic family's levels 0-3, each
measured from the mesh itself: the first element layer under the middle of the medial flat,
the cells along the flat, the largest faceting error of the two arcs beside it (the largest
distance between an arc and the mesh's chords), the mean edge of the medial surface's
triangles, and the worst dihedral angle and aspect ratio.

    python examples/mesh_ladders.py            # writes examples/convergence_results/ladders.csv
    python examples/mesh_ladders.py --figure   # and docs/figures/m5_ladders.png

``tests/test_committed_results.py`` re-measures the coarse and level-0 rows and compares.
"""

from __future__ import annotations

import csv
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
CSV = os.path.join(HERE, "convergence_results", "ladders.csv")
FIGURE = os.path.join(HERE, "..", "docs", "figures", "m5_ladders.png")
LEGACY = ("coarse", "medium", "fine")
LEVELS = (0, 1, 2, 3)
COLUMNS = ("ladder", "rung", "cells", "tets", "first_layer_um", "flat_cell_um", "facet_error_um",
           "medial_edge_um", "worst_dihedral_deg", "worst_aspect")


def _pieces():
    """The exact medial curve of the default folds (vfrs.meshes.m5_family.profile_pieces)."""
    from vfrs.meshes.m5 import M5Params
    from vfrs.meshes.m5_family import profile_pieces

    p = M5Params()
    keys = ("T", "psi", "R_O", "exit_angle", "R_L", "inferior_angle", "half_gap", "depth", "inferior_height",
            "superior_height")
    return profile_pieces(**{k: getattr(p, k) for k in keys})[0]


def facet_error(curve, pieces, samples: int = 2000) -> float:
    """The largest distance (m) from a point of an arc of ``pieces`` to the polyline ``curve``
    ((n, 2), the mesh's medial curve): each arc sampled at ``samples`` points, each point's
    distance to the nearest chord. On a mesh whose nodes lie on the arc this is the chords'
    sagitta R (1 - cos(angle / 2n)); the legacy meshes resample the curve, and the coarse one
    cuts an arc with a single chord."""
    a, b = curve[:-1], curve[1:]
    d = b - a
    dd = np.maximum((d * d).sum(axis=1), 1e-300)
    worst = 0.0
    for arc in (p for p in pieces if p.centre is not None):
        pts = arc.at(np.linspace(0.0, 1.0, samples))
        t = np.clip(((pts[:, None, :] - a[None]) * d[None]).sum(axis=2) / dd[None], 0.0, 1.0)
        near = a[None] + t[..., None] * d[None]
        worst = max(worst, float(np.linalg.norm(near - pts[:, None, :], axis=2).min(axis=1).max()))
    return worst


def measure(mesh, cells) -> dict:
    """The row of one mesh (``cells``: its (ns, nr, nz), the structured grid's shape)."""
    ns, nr, nz = cells
    P = mesh.points.reshape(ns + 1, nr + 1, nz + 1, 3)
    curve = P[:, 0, 0, :2]
    flat = np.flatnonzero(np.abs(curve[:, 0] - curve[:, 0].min()) <= 1e-9)  # the nodes on the medial flat
    mid = flat[len(flat) // 2]
    tri = np.asarray(mesh.surfaces["medial"])
    X = mesh.points
    edges = np.concatenate([np.linalg.norm(X[tri[:, a]] - X[tri[:, b]], axis=1) for a, b in ((0, 1), (1, 2), (2, 0))])
    q = mesh.quality()
    return {"cells": f"{ns} x {nr} x {nz}", "tets": mesh.n_tets,
            "first_layer_um": float(np.linalg.norm(P[mid, 1, nz // 2] - P[mid, 0, nz // 2])) * 1e6,
            "flat_cell_um": float(np.ptp(curve[flat, 1]) / max(len(flat) - 1, 1)) * 1e6,
            "facet_error_um": facet_error(curve, _pieces()) * 1e6, "medial_edge_um": float(edges.mean()) * 1e6,
            "worst_dihedral_deg": q.worst_dihedral, "worst_aspect": q.worst_aspect}


def rows(legacy=LEGACY, levels=LEVELS) -> list:
    """Every rung's row, the legacy resolutions first."""
    from vfrs.meshes import m5
    from vfrs.meshes.m5 import RESOLUTIONS

    out = []
    for r in legacy:
        out.append({"ladder": "legacy", "rung": r, **measure(m5("right", r), RESOLUTIONS[r])})
    for k in levels:
        mesh = m5("right", family="systematic", level=k)
        out.append({"ladder": "systematic", "rung": f"level {k}", **measure(mesh, getattr(mesh, "family_info")["cells"])})
    return out


def write(table, path=CSV) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS, lineterminator="\n")
        w.writeheader()
        for r in table:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})


def figure(table, path=FIGURE) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.6))
    for ladder, marker in (("legacy", "s"), ("systematic", "o")):
        mine = [r for r in table if r["ladder"] == ladder]
        x = np.arange(len(mine))
        for ax, key, label in ((axes[0], "first_layer_um", "first layer under the medial flat"),
                               (axes[1], "facet_error_um", "arcs' faceting error")):
            ax.semilogy(x, [r[key] for r in mine], marker=marker, label=f"{ladder} ({', '.join(r['rung'] for r in mine)})")
            ax.set_title(label, fontsize=10)
            ax.set_xlabel("rung (coarsest = 0)")
            ax.set_xticks(range(4))
            ax.set_ylabel("um")
    axes[1].axhline(50.0, color="0.5", ls="--", lw=1)
    axes[1].text(0.05, 55.0, "half-gap 50 um", color="0.4", fontsize=8)
    k = np.arange(4)
    first0 = [r for r in table if r["ladder"] == "systematic"][0]["first_layer_um"]
    axes[0].semilogy(k, first0 / 1.5**k, color="0.5", ls=":", lw=1, label="ratio 1.5 per rung")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=130)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    table = rows()
    write(table)
    for r in table:
        print(", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in r.items()))
    if "--figure" in argv:
        figure(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
