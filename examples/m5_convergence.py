"""How the main job's numbers move when the step and the mesh are refined (docs/convergence.md).

Runs examples/m5_collision.toml (50 ms, Ps = 0.8 kPa, Lagrange, the default contact scheme)
at the coarse, medium and fine meshes and h = 50, 25, 12.5 us (the fine mesh at 50 and 25 us
only: a run there takes many minutes), each in this process, and writes
``examples/convergence_results/summary.csv``: per run its resolution, step and the summary's
numbers (contact: peak force, contact impulse per cycle, peak nodal and 1 mm^2-sensor
pressure, mean and force-weighted pressure at the peak force, maximum contact area and
effective area summed over both folds (the paper's definition: an interface counts twice),
contact duration and quotient; phonation: f0, amplitude; the share of the flow's work the energy correction took
back), then prints the changes from h = 50 to 25 us and, where three steps exist, the
observed order p = log2(|f(50) - f(25)| / |f(25) - f(12.5)|) (Richardson; given only where
the two differences have the same sign, i.e. the sequence is monotone).

    python examples/m5_convergence.py                 # the whole grid (about an hour here)
    python examples/m5_convergence.py --only coarse   # one resolution

tests/test_committed_results.py re-runs the coarse 50 us row and compares.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

import vfrs

HERE = Path(__file__).resolve().parent
OUT = HERE / "convergence_results"
GRID = [("coarse", 50e-6), ("coarse", 25e-6), ("coarse", 12.5e-6), ("medium", 50e-6), ("medium", 25e-6),
        ("medium", 12.5e-6), ("fine", 50e-6), ("fine", 25e-6)]
#: summary.csv's columns: (column, section, key, unit factor for the printed tables)
COLUMNS = [("peak_force_mN", "contact", "peak_force.right", 1e3),
           ("impulse_per_cycle_uNs", "contact", "contact_impulse.right", 1e6),
           ("peak_nodal_pressure_kPa", "contact", "peak_contact_pressure", 1e-3),
           ("peak_sensor_pressure_kPa", "contact", "peak_sensor_pressure", 1e-3),
           ("mean_pressure_at_peak_force_kPa", "contact", "mean_contact_pressure", 1e-3),
           ("force_weighted_pressure_kPa", "contact", "force_weighted_pressure", 1e-3),
           ("max_contact_area_summed_mm2", "contact", "max_contact_area_summed", 1e6),
           ("max_effective_area_summed_mm2", "contact", "max_effective_area_summed", 1e6),
           ("contact_duration_ms", "contact", "contact_duration", 1e3),
           ("contact_quotient", "contact", "contact_quotient", 1.0),
           ("f0_Hz", "phonation", "f0", 1.0),
           ("amplitude_mm", "phonation", "amplitude", 1e3)]


def scene(resolution: str, step: float) -> vfrs.Scene:
    d = vfrs.Scene.load(HERE / "m5_collision.toml").to_dict()
    for b in d["bodies"]:
        b["mesh"]["resolution"] = resolution
    d["time"]["step"] = step
    d["output"]["every"] = 10**6
    return vfrs.Scene.from_dict(d)


def run_row(resolution: str, step: float) -> dict:
    """One run of the grid: its summary.csv row."""
    t0 = time.perf_counter()
    res = vfrs.run(scene(resolution, step), progress=False)
    s, h = res.results, res.history
    row = {"resolution": resolution, "step_us": step * 1e6}
    for col, section, key, factor in COLUMNS:
        q = s.sections.get(section, {}).get(key)
        row[col] = float(q.value) * factor if q is not None else float("nan")
    flow = float(np.asarray(h["external_work"])[-1])
    row["energy_corrected_of_flow_work"] = float(np.asarray(h["contact_energy_corrected"])[-1]) / flow
    row["notes"] = len(s.notes)
    row["wall_s"] = time.perf_counter() - t0
    return row


def order(a: float, b: float, c: float) -> float:
    """Observed order of a, b, c at steps halving each time (nan unless monotone)."""
    d1, d2 = a - b, b - c
    if d1 == 0 or d2 == 0 or (d1 > 0) != (d2 > 0):
        return float("nan")
    return math.log2(abs(d1) / abs(d2))


def report(rows: list) -> str:
    by = {(r["resolution"], round(float(r["step_us"]), 3)): r for r in rows}
    lines = []
    for res in ("coarse", "medium", "fine"):
        a, b, c = by.get((res, 50.0)), by.get((res, 25.0)), by.get((res, 12.5))
        if a and b:
            ch = ", ".join(f"{col} {100 * (float(b[col]) / float(a[col]) - 1):+.1f} %" for col, *_ in COLUMNS
                           if float(a[col]))
            lines.append(f"{res}, 50 -> 25 us: {ch}")
        if a and b and c:
            p = ", ".join(f"{col} {order(float(a[col]), float(b[col]), float(c[col])):.2f}" for col, *_ in COLUMNS)
            lines.append(f"{res}, observed order in h: {p}")
    return "\n".join(lines)


def write(rows: list) -> None:
    OUT.mkdir(exist_ok=True)
    keys = list(rows[0])
    with open(OUT / "summary.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in r.items()})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", choices=("coarse", "medium", "fine"), help="one resolution")
    args = ap.parse_args(argv)
    rows = []
    for res, step in GRID:
        if args.only and res != args.only:
            continue
        rows.append(run_row(res, step))
        print(", ".join(f"{k} {v:.5g}" if isinstance(v, float) else f"{k} {v}" for k, v in rows[-1].items()),
              flush=True)
        write(rows)
    print(report(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
