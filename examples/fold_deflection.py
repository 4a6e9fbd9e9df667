"""One fold's free static deflection on the systematic family's levels 0-2 (docs/convergence.md,
"Steady phonation"): is the main job's tissue locking? The right M5 fold of the main job
(half-gap 50 um, 14 mm long, 8 mm deep), held at its lateral, anterior and posterior walls,
pushed toward the midline by a uniform traction of 300 Pa on its medial surface, static, no
contact and no flow; once with the main job's `vocal_fold` tissue (in-plane Poisson ratio 0.9)
and once with the isotropic nu = 0.45 stand-in of the accuracy report. Measured: the
medio-lateral displacement of the medial surface at mid-height and mid-length (the node
nearest (y, z) = (0, 7 mm)), its largest and its mean.

    python examples/fold_deflection.py        # writes examples/convergence_results/fold_deflection.csv (about 20 s)

``tests/test_mesh_ladders.py`` re-runs levels 0 and 1 and compares.
"""

from __future__ import annotations

import csv
import os
import sys

import numpy as np

import vfrs

HERE = os.path.dirname(os.path.abspath(__file__))
CSV = os.path.join(HERE, "convergence_results", "fold_deflection.csv")
TISSUES = {"vocal_fold": {"model": "vocal_fold"},
           "isotropic nu 0.45": {"model": "isotropic", "E": 4e3, "nu": 0.45, "rho": 1070.0}}
TRACTION = 300.0  # Pa, toward the midline (-x for the right fold)
COLUMNS = ["tissue", "level", "dofs", "u_mid [m]", "u_max [m]", "u_mean [m]"]


def scene(level: int, material: dict) -> dict:
    return {"title": "one M5 fold, uniform medial traction, static",
            "bodies": [{"name": "right",
                        "mesh": {"builtin": "m5", "side": "right", "family": "systematic", "level": level,
                                 "psi": 0.0, "half_gap": 0.05e-3, "length": 14e-3, "depth": 8e-3},
                        "material": dict(material), "fixed": ["lateral", "anterior", "posterior"],
                        "loads": [{"type": "traction", "surface": "medial", "value": [-TRACTION, 0.0, 0.0]}]}],
            "time": {"mode": "static"},
            "output": {"every": 100000, "energy": False}}


def measure(tissue: str, level: int) -> dict:
    """The row of one tissue on one level (displacements toward the midline, m)."""
    res = vfrs.run(vfrs.Scene.from_dict(scene(level, TISSUES[tissue])), progress=False)
    mesh = res.problem.bodies[0].mesh
    nodes = np.unique(mesh.surfaces["medial"])
    ux = -res.displacement("right")[nodes, 0]
    mid = int(np.argmin(np.linalg.norm(mesh.points[nodes][:, 1:] - [0.0, 7e-3], axis=1)))
    return {"tissue": tissue, "level": level, "dofs": int(mesh.n_dofs), "u_mid [m]": float(ux[mid]),
            "u_max [m]": float(ux.max()), "u_mean [m]": float(ux.mean())}


def main(argv=None) -> int:
    rows = [measure(t, k) for t in TISSUES for k in (0, 1, 2)]
    os.makedirs(os.path.dirname(CSV), exist_ok=True)
    with open(CSV, "w", newline="") as fh:
        w = csv.DictWriter(fh, COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: repr(v) if isinstance(v, float) else v for k, v in r.items()})
    for r in rows:
        print(f"{r['tissue']:18s} level {r['level']}: at mid {r['u_mid [m]'] * 1e6:7.2f} um, largest "
              f"{r['u_max [m]'] * 1e6:7.2f} um, mean {r['u_mean [m]'] * 1e6:7.2f} um ({r['dofs']} DOFs)")
    print(f"wrote {os.path.relpath(CSV)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
