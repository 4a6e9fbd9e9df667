"""The main job's flow-driven first closure on the systematic M5 family (docs/convergence.md,
"The first closure is a two-stage zipper"): examples/m5_collision.toml on levels 0, 1, 2 of
``m5(family="systematic")``, 0-20 ms at h = 25 us, each step's medio-lateral contact force on
the right fold (+x, lateral), its one-step peak and band-limited (1 kHz) humps, the 1 mm^2 sensor as the
node average (``contact_pressure_sensor``) and over its exact disc (``contact_pressure_disc``),
and the three contact areas.

    python examples/first_closure.py run 0 1 2     # writes examples/convergence_results/first_closure_L<k>.csv
    python examples/first_closure.py figure        # docs/figures/m5_first_closure.png from those files
    python examples/first_closure.py table         # the humps per level (docs/convergence.md)

``tests/test_committed_results.py``-style check: tests/test_mesh_ladders.py re-runs level 0
for 4 ms and compares with its committed rows.
"""

from __future__ import annotations

import csv
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "convergence_results")
FIGURE = os.path.join(HERE, "..", "docs", "figures", "m5_first_closure.png")
END, STEP = 20e-3, 25e-6
COLUMNS = ("t", "force_x", "sensor_nodes_avg", "sensor_disc", "disc_nodes", "area_triangles", "area_nodal",
           "area_effective")


def scene(level: int, end: float = END):
    import vfrs

    d = vfrs.Scene.load(os.path.join(HERE, "m5_collision.toml")).to_dict()
    for b in d["bodies"]:
        mesh = {k: v for k, v in b["mesh"].items() if k not in ("resolution", "cells", "grading")}
        b["mesh"] = {**mesh, "family": "systematic", "level": level}
    d["time"].update(step=STEP, end=end)
    d["output"] = {"every": 100000}
    return vfrs.Scene.from_dict(d)


def history_rows(h) -> list:
    t = np.asarray(h["t"])
    cols = (t, np.asarray(h["contact_force.right"])[:, 0], h["contact_pressure_sensor"], h["contact_pressure_disc"],
            h["contact_pressure_disc_nodes"], np.asarray(h["contact_area"]) / 2, np.asarray(h["contact_area_nodal"]) / 2,
            np.asarray(h["contact_area_effective"]) / 2)
    return [dict(zip(COLUMNS, vals)) for vals in zip(*cols)]


def path_of(level: int) -> str:
    return os.path.join(OUT, f"first_closure_L{level}.csv")


def run(level: int, end: float = END) -> list:
    import vfrs

    res = vfrs.run(scene(level, end), progress=False)
    return history_rows(res.history)


def write(rows, path) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: f"{float(v):.6g}" for k, v in r.items()})


def read(level: int) -> dict:
    with open(path_of(level), encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    return {k: np.array([float(r[k]) for r in rows]) for k in COLUMNS}


def humps(level: int) -> list:
    """The first closure's stages on ``level`` (:func:`vfrs.bandlimit.closure_stages`)."""
    from vfrs.bandlimit import closure_stages

    c = read(level)
    return closure_stages(c["t"], c["force_x"])


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    what, rest = argv[0], argv[1:]
    if what == "run":
        for k in (int(a) for a in rest):
            write(run(k), path_of(k))
            print(f"level {k}: written {path_of(k)}")
    elif what == "table":
        for k in range(3):
            if os.path.exists(path_of(k)):
                for e in humps(k)[:1]:
                    stages = "; ".join(f"{h.t * 1e3:.2f} ms {h.peak * 1e3:.2f} mN (one step {h.peak_step * 1e3:.2f} mN)"
                                       for h in e.humps)
                    print(f"level {k}: contact {e.start * 1e3:.2f}-{e.end * 1e3:.2f} ms, impulse "
                          f"{e.impulse * 1e6:.3f} uN s, humps: {stages}")
    elif what == "figure":
        figure()
    return 0


def figure(path=FIGURE) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vfrs.bandlimit import band_limited

    fig, axes = plt.subplots(1, 2, figsize=(10.0, 3.6))
    for k in range(3):
        if not os.path.exists(path_of(k)):
            continue
        c = read(k)
        ms = c["t"] * 1e3
        axes[0].plot(ms, c["force_x"] * 1e3, lw=0.7, color=f"C{k}", alpha=0.45)
        axes[0].plot(ms, band_limited(c["t"], c["force_x"]) * 1e3, lw=1.6, color=f"C{k}", label=f"level {k}")
        axes[1].plot(ms, c["sensor_nodes_avg"] * 1e-3, lw=0.8, ls="--", color=f"C{k}")
        axes[1].plot(ms, c["sensor_disc"] * 1e-3, lw=1.4, color=f"C{k}", label=f"level {k}")
    axes[0].set_title("contact force on the right fold (thin: each step; thick: 1 kHz)", fontsize=9)
    axes[0].set_ylabel("mN")
    axes[1].set_title("1 mm^2 sensor: exact disc (solid), node average (dashed)", fontsize=9)
    axes[1].set_ylabel("kPa")
    for ax in axes:
        ax.set_xlabel("t (ms)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)


if __name__ == "__main__":
    raise SystemExit(main())
