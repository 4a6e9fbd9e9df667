"""The colliding M5 folds at Ps = 0.8 kPa with linear and with finite-strain tissue, side by side.

Two pairs of runs, each pair the same scene but for the material (Lagrange contact on the
interface mesh, HHT-alpha with alpha = -0.3, h = 50 us, 50 ms):

- ``isotropic`` (linear, E = 4 kPa, nu = 0.45: the stand-in of
  ``m5_phonation_isotropic.toml``) and ``neo-Hookean`` (finite strain, the same small-strain
  E and nu): the kinematics alone differ;
- ``vocal_fold`` (linear, the paper's transversely isotropic tissue: ``m5_collision.toml``)
  and ``fibre-reinforced`` (finite strain, the fold law of ``m5_loud.toml`` at 0.8 kPa): the
  fold tissue of each kind (their small-strain shear moduli differ: docs/model.md).

and ``loud``: ``m5_loud.toml`` as it is (fibre-reinforced, Ps = 3 kPa, h = 25 us), where the
linear folds diverge.

Every run uses vfrs's default dynamic contact scheme (``mass_redistribution``: the scenes name
none; ``run_info.txt`` records it). Finite-strain runs use modified Newton. ``python
examples/m5_kinematics.py [--resolution medium] [--end 0.05] [--out
examples/kinematics_results]`` writes ``summary.csv`` (per run: f0 from the glottal area, the
probe's medio-lateral amplitude, peak contact force on the right fold, peak nodal contact
pressure and peak pressure on the 1 mm^2 sensor, first contact, cost per step, Newton
iterations per step) and
``head.csv`` (the first ``HEAD_TIME`` of each run's contact force and probe
displacement: ``tests/test_kinematics_results.py`` re-runs them against the code). The
committed results (medium mesh, 50 ms) are quoted in docs/model.md, "The folds at finite
strain".
"""

from __future__ import annotations

import argparse
import csv
import os
import time
from pathlib import Path

import numpy as np

import vfrs
from vfrs.summary import summarize
from vfrs.studies.sweep import own_time

HERE = Path(__file__).resolve().parent
HEAD_TIME = 2.5e-3  # the first 2.5 ms of each run: through the first contact (1.8-2.3 ms)
FIBRE = {"model": "fibre_reinforced", "E": 2e3, "nu": 0.45, "k1": 9.5e3, "k2": 1.0, "axis": [0.0, 0.0, 1.0],
         "rho": 1070.0}


def scene(case: str, resolution: str = "medium", end: float = 0.05) -> vfrs.Scene:
    """The scene of one case (a label of :data:`CASES`)."""
    if case == "loud":
        d = vfrs.Scene.load(HERE / "m5_loud.toml").to_dict()
    elif case in ("isotropic", "neo-Hookean"):
        d = vfrs.Scene.load(HERE / "m5_phonation_isotropic.toml").to_dict()
        d["contact"] = {"method": "lagrange", "detection": "interface_mesh", "pairs": [["right", "left"]],
                        "surface": "medial"}
        if case == "neo-Hookean":
            for b in d["bodies"]:
                b["material"] = {**b["material"], "model": "neo_hookean"}
    else:
        d = vfrs.Scene.load(HERE / "m5_collision.toml").to_dict()
        if case == "fibre-reinforced":
            for b in d["bodies"]:
                b["material"] = dict(FIBRE)
    if case in ("neo-Hookean", "fibre-reinforced"):
        # 40, not the default 25: under the default contact scheme (mass redistribution) one
        # step of the fibre-reinforced folds (medium mesh, t = 32.9 ms, a hard closure) needs 31
        # modified-Newton iterations, the residual falling linearly (the mean over its first 34 ms: 8.1).
        d["time"]["newton"] = {"method": "modified", "max_iterations": 40}
    for b in d["bodies"]:
        b["mesh"]["resolution"] = resolution
    d["time"]["end"] = end
    if case != "loud":
        d["title"] = f"M5 folds, Ps = 0.8 kPa, Lagrange contact, {case} tissue"
    return vfrs.Scene.from_dict(d)


#: label -> (kinematics, the linear case it is compared with)
CASES = {"isotropic": ("linear", None), "neo-Hookean": ("finite", "isotropic"),
         "vocal_fold": ("linear", None), "fibre-reinforced": ("finite", "vocal_fold"), "loud": ("finite", None)}


def head(res, until: float = HEAD_TIME) -> dict:
    """A run's history up to ``until`` (s, from t = 0): t, the right fold's contact force (x)
    and the probe's medio-lateral displacement."""
    h = res.history
    steps = int(round(until / res.scene.time.step))
    probe = res.probe(res.scene.output.probes[0])
    return {"t": np.asarray(h["t"])[: steps + 1], "force_x": np.asarray(h["contact_force.right"])[: steps + 1, 0],
            "probe_ux": np.asarray(probe["displacement"])[: steps + 1, 0]}


def measure(case: str, res) -> dict:
    s = summarize(res)
    ph, co = s["phonation"], s["contact"]
    steps = len(res.history["t"]) - 1
    wall = own_time(res.timings)  # total less writing output (a run in memory writes none)
    its = res.history.get("newton_iterations")
    return {"case": case, "kinematics": CASES[case][0], "f0_Hz": ph["f0"].value,
            "amplitude_mm": ph["amplitude"].value * 1e3 if "amplitude" in ph else float("nan"),
            "peak_force_mN": co["peak_force.right"].value * 1e3,
            "peak_pressure_kPa": co["peak_contact_pressure"].value * 1e-3,
            "peak_sensor_pressure_kPa": co["peak_sensor_pressure"].value * 1e-3,
            "first_contact_ms": co["first_contact"].value * 1e3, "steps": steps, "wall_s": wall,
            "ms_per_step": wall / steps * 1e3,
            "newton_iterations": float(np.mean(np.asarray(its)[1:])) if its is not None else 0.0}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", default="medium")
    ap.add_argument("--end", type=float, default=0.05)
    ap.add_argument("--out", default=str(HERE / "kinematics_results"))
    ap.add_argument("--cases", nargs="*", default=list(CASES))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, heads, schemes = [], {}, {}
    load_before = _loadavg()
    for case in args.cases:
        t0 = time.perf_counter()
        res = vfrs.run(scene(case, args.resolution, args.end), progress=False)
        rows.append(measure(case, res))
        heads[case] = head(res)
        schemes[case] = res.scene.effects["contact"].scheme
        print(f"{case}: {rows[-1]} ({time.perf_counter() - t0:.0f} s)", flush=True)
    with open(out / "summary.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with open(out / "head.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["case", "t", "force_x", "probe_ux"])
        for case, hd in heads.items():
            for k in range(len(hd["t"])):
                w.writerow([case, repr(float(hd["t"][k])), repr(float(hd["force_x"][k])), repr(float(hd["probe_ux"][k]))])
    from vfrs.studies.accuracy import provenance

    pv = provenance()
    used = sorted(set(schemes.values()))
    (out / "run_info.txt").write_text(
        f"resolution = {args.resolution}\nend = {args.end}\ncommit = {pv['commit']}\ndirty = {pv['dirty']}\n"
        f"scheme = {', '.join(used)}\n"
        f"date = {time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}\n"
        f"load = {load_before} before, {_loadavg()} after (1-minute load average of this machine; "
        f"{os.cpu_count()} cores: the wall times are measured under that load)\n")


def _loadavg() -> str:
    try:
        return Path("/proc/loadavg").read_text().split()[0]
    except OSError:
        return "unknown"


if __name__ == "__main__":
    main()
