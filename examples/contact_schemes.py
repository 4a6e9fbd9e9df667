"""Two bars colliding: the recorded contact force of each dynamic contact scheme at three time
steps, against the exact plateau (docs/contact.md, "Dynamic contact schemes").

Two identical bars (L = 0.1 m, 10 x 10 mm, E = 1e4 Pa, nu = 0, rho = 1000 kg/m^3, 40 P1 cells
each, lumped mass; lateral DOFs held as a 1-D bar), bar a at v0 = 0.1 m/s onto bar b at rest,
1e-4 m apart. The exact solution: once the end faces touch (t0 = 1 ms) they press with
F0 = A rho c v0 / 2 for 2 L / c, then bar a stops and bar b leaves at v0. Lagrange multipliers,
BVH detection, HHT alpha = 0 (no numerical dissipation), h = T, T/4 and T/16 with T = L / (40 c)
the time a wave takes to cross one cell.

    python examples/contact_schemes.py              # writes examples/schemes_results/, the figure

Writes ``examples/schemes_results/bars_force.csv`` (scheme, substeps, t (s), F / F0, every
step), ``bars_summary.csv`` (per run: peak / F0, L1 error of the history over F0 2L/c, the
mean force over the middle half of the contact / F0, the largest and the last energy over E0,
the contact duration over 2L/c), ``run_info.txt`` (the commit) and
``docs/figures/bar_schemes.png``.
tests/test_committed_results.py re-runs a subset and compares.
"""

from __future__ import annotations

import csv
import os
import sys
import time

import numpy as np

import vfrs

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "schemes_results")
FIGURE = os.path.join(HERE, "..", "docs", "figures", "bar_schemes.png")
E, RHO, L, S, V0, GAP, N = 1e4, 1000.0, 0.1, 0.01, 0.1, 1e-4, 40
C = float(np.sqrt(E / RHO))
F0 = S * S * RHO * C * V0 / 2
E0 = 0.5 * RHO * L * S * S * V0**2
T0 = GAP / V0  # the end faces touch
SCHEMES = ("mass_redistribution", "stabilized", "plain")
SUBSTEPS = (1, 4, 16)


def scene(scheme: str, substeps: int, method: str = "lagrange") -> dict:
    h = L / C / N / substeps

    def bar(name, x0, v):
        return {"name": name, "mesh": {"builtin": "box", "size": [L, S, S], "cells": [N, 1, 1], "origin": [x0, 0, 0]},
                "material": {"model": "isotropic", "E": E, "nu": 0.0, "rho": RHO}, "mass": "lumped",
                "velocity": [v, 0, 0],
                "fixed": [{"surface": "ymin", "components": ["y"]}, {"surface": "zmin", "components": ["z"]}]}

    return {"title": f"two bars, {scheme}, h = T/{substeps}",
            "bodies": [bar("a", -L - GAP / 2, V0), bar("b", GAP / 2, 0.0)],
            "contact": {"method": method, "detection": "bvh", "surface": {"a": "xmax", "b": "xmin"},
                        "search_distance": 2e-3, "scheme": scheme},
            "time": {"mode": "dynamic", "step": h, "end": T0 + 2.6 * L / C, "alpha": 0.0},
            "output": {"every": 10**6}}


def run_case(scheme: str, substeps: int) -> dict:
    """One run: its force history (t, F / F0) and the summary row."""
    r = vfrs.run(vfrs.Scene.from_dict(scene(scheme, substeps)), progress=False)
    h = r.history
    t = np.asarray(h["t"])
    f = np.asarray(h["contact_force.b"])[:, 0] / F0  # the force on b pushes it along +x
    step = r.scene.time.step
    exact = np.where((t > T0) & (t <= T0 + 2 * L / C), 1.0, 0.0)
    mid = (t > T0 + 0.5 * L / C) & (t < T0 + 1.5 * L / C)
    energy = (np.asarray(h["kinetic_energy"]) + np.asarray(h["elastic_energy"])) / E0
    on = np.flatnonzero(f != 0)
    row = {"scheme": scheme, "substeps": substeps, "step_s": step, "peak_F_over_F0": float(f.max()),
           "L1_error": float(np.sum(np.abs(f - exact)) * step / (2 * L / C)),
           "mean_mid_F_over_F0": float(f[mid].mean()),
           "E_max_over_E0": float(energy.max()), "E_end_over_E0": float(energy[-1]),
           "duration_over_2L_c": float((t[on[-1]] - t[on[0]] + step) / (2 * L / C)) if on.size else 0.0}
    return {"t": t, "f": f, "row": row}


def write(runs: list) -> None:
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "bars_force.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["scheme", "substeps", "t_s", "F_over_F0"])
        for r in runs:
            for t, f in zip(r["t"], r["f"]):
                w.writerow([r["row"]["scheme"], r["row"]["substeps"], repr(float(t)), repr(float(f))])
    with open(os.path.join(OUT, "bars_summary.csv"), "w", newline="") as fh:
        keys = list(runs[0]["row"])
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        for r in runs:
            w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in r["row"].items()})


def figure(runs: list) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(SCHEMES), figsize=(13, 4.0), sharey=True)
    for ax, scheme in zip(axes, SCHEMES):
        for r in (r for r in runs if r["row"]["scheme"] == scheme):
            s = r["row"]["substeps"]
            ax.plot((r["t"] - T0) * C / L, r["f"], lw=1.0, label=f"h = T/{s}: peak {r['row']['peak_F_over_F0']:.2f} F0")
        tt = np.array([-0.2, 0, 0, 2, 2, 2.6])
        ax.plot(tt, [0, 0, 1, 1, 0, 0], "k--", lw=1.0, label="exact")
        ax.set_title({"mass_redistribution": "mass_redistribution (default)", "stabilized": "stabilized",
                      "plain": "plain (the paper's)"}[scheme])
        ax.set_xlabel("(t - t0) c / L")
        ax.legend(fontsize=8, loc="upper right")
    axes[0].set_ylabel("contact force / F0")
    axes[0].set_ylim(-0.2, 4.0)
    fig.suptitle("Two bars colliding: recorded contact force, Lagrange, HHT alpha = 0, T = one cell's wave transit",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=110)


def main(argv=None) -> int:
    runs = [run_case(s, k) for s in SCHEMES for k in SUBSTEPS]
    for r in runs:
        print(", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in r["row"].items()))
    write(runs)
    figure(runs)
    from vfrs.studies.accuracy import provenance

    pv = provenance()
    with open(os.path.join(OUT, "run_info.txt"), "w") as fh:  # the scheme of each run is its row's
        fh.write(f"commit = {pv['commit']}\ndirty = {pv['dirty']}\n"
                 f"date = {time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}\nschemes = {', '.join(SCHEMES)}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
