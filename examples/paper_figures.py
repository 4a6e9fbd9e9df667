"""The paper's Figs. 2-4 as data and plots: contact methods on colliding M5 folds.

Runs ``m5_phonation_isotropic.toml`` (two M5-type folds of the isotropic E = 4 kPa stand-in
tissue its committed results were made with, Bernoulli flow, HHT alpha = -0.3,
h = 50 us) with a ``[contact]`` table per method, interface-mesh detection (the paper's), and
writes to the output folder (default ``out/paper/``):

- ``fig2_node_force.csv`` / ``fig2_node_force.png``: medio-lateral (x) contact force on one
  medial node of the right fold vs time, Ps = 0.8 kPa, for penalty (kappa = 1e7 and 1e8
  Pa/m, see "Units"), Lagrange multipliers (LM) and augmented Lagrange with 4 augmentations
  (A_4), all in the paper's plain HHT scheme, plus LM in vfrs's default scheme (mass
  redistribution, label ``LM (mass redist.)``).
- ``fig3_fig4_summary.csv``: one row per run (Ps, method, kappa, N, scheme): the maximum over the run
  of the right fold's total medio-lateral contact force, of the intersection volume, of the
  contact area, of the penetration, the normalised intersection volume, wall time.
- ``fig3_force_vs_volume.png``: max force vs intersection volume normalised by the detect-
  only run's (same Ps); ``fig4_area_vs_volume.png``: max contact area vs the same abscissa.

Run:  ``python examples/paper_figures.py [--quick] [--out DIR] [--resolution coarse]
[--end 0.045] [--workers N | --serial | --scheduler ADDR] [--runs DIR]``. The runs are one
sweep on dask.distributed (:func:`paper_sweep`, ``vfrs.studies.sweep``; one worker per core by
default, each run's folder in ``OUT/sweep/``, finished runs of the same vfrs build not run
again); the rows and Fig. 2 are measured from the run folders with :func:`measure`, the
function :func:`run_case` (one case in this process) uses too. The full mode (coarse, 45 ms,
51 runs) takes about 70 s on 2 idle cores (``benchmarks/bench_sweep.py``), 10 min when they are
shared with a load average of 10 (``run_info.txt`` records the load); its CSVs and
PNGs are committed in ``examples/paper_results/`` (``tests/test_committed_results.py`` re-runs
a few of their rows with :func:`run_case` and compares). The quick mode (coarse mesh, 15 ms,
Ps = 0.8 kPa only, eight runs, ~15 s) is what ``tests/test_paper_figures.py`` checks.

Schemes (``[contact] scheme``, docs/contact.md, "Dynamic contact schemes"). The paper used
the plain HHT scheme (the usual mass, contact forces at t_{n+1} in the recursion), so the
runs with ``scheme = "plain"`` (written explicitly: it is no longer the default) are the
reproduction, chatter and all. The comparison is vfrs's default, ``scheme =
"mass_redistribution"`` (label suffix `` (mass redist.)``): the contact-surface nodes carry no
mass, so contact never stops a node's inertia within a step and the recorded force has no
impulse spikes (compare LM and LM (mass redist.) in Fig. 2); the full mode repeats every
force method in it as a second panel of Figs. 3-4, the quick mode only LM. The contact-
stabilized predictor (``scheme = "stabilized"``, the default before) is no longer run here:
its recorded peak force is the impulse that stops a contact node's mass over one step, which
grows as 1/h, so its panel compared the methods by a step artefact; the three schemes are
compared where the exact force is known, on two colliding bars (examples/contact_schemes.py).
Detect-only applies no force, so no scheme acts on it (the usual mass).

Definitions (ours, following docs/design.md, "Outputs the paper reports"):

- max force = max over t of ``contact_force.right[:, 0]`` (N): the x component of the sum of
  all nodal contact forces on the right fold (x > 0; contact pushes it towards +x). The paper
  takes the maximum over the collision interval [36, 37] ms of its runs; our folds' collision
  times differ, so we take the maximum over the whole run (``window`` changes that).
- normalised volume = max over t of the run's ``intersection_volume`` (sum of |V_e| of the
  inverted interface tetrahedra) / the same maximum of the ``detect_only`` run (contact forces
  neglected) at the same Ps and resolution. By definition 1 for detect-only.
- contact area = summed area of medial-surface triangles with any vertex loaded (both folds'
  medial surfaces, as the effect records it); max over t.

Units (the paper's numbers have no stated units):

- Penalty. Ours: nodal force = kappa x slave tributary area x penetration, kappa in Pa/m
  (= N/m^3), independent of the mesh. The paper's volume penalty (its eq. 12) is force =
  kappa x V_e, also force per volume, so the two kappas have the same dimension. If the
  paper's kappa = 1e7 is SI (N/m^3) it is our 1e7 Pa/m; if it is CGS (dyn/cm^3 = 10 N/m^3),
  it is our 1e8 Pa/m. Fig. 2 shows both (they bracket the paper's value under either
  reading); Fig. 3 spans several decades around them. A nodal-stiffness reading (N/m per
  node, no area) would correspond to ~1e13 Pa/m on the coarse mesh (tributary area ~1e-6
  m^2): the upper end of the sweep.
- Augmented Lagrange: the paper starts at kappa_0 = 1 (x10 growth when an augmentation cuts
  the volume by less than 75 %). Read as 1 Pa/m (or 10 Pa/m in CGS) that start is 6-7
  decades below the tissue's own stiffness scale (E / element size ~ 1e7 Pa/m), and N <= 8
  augmentations cannot reach a useful force: A_N would be detect-only with extra steps.
  We therefore start A_N at kappa_0 = ``AL_KAPPA0`` = 1e7 Pa/m (the Fig. 2 penalty value),
  so A_1 is exactly that penalty run and A_N (N > 1) adds N - 1 Uzawa updates; the full mode
  also runs A_4 with the literal kappa_0 = 1 Pa/m to show the difference.

The paper's node. The paper gives the initial position (0.024, -0.136, -0.037) cm in its own
frame: x medio-lateral (0.24 mm: on the right fold's medial surface, its half-gap), y
inferior-superior, z anterior-posterior. Our frame differs: the right fold's medial surface
is at x = ``half_gap`` (0.05 mm), the straight medial surface (thickness T = 3 mm, psi = 0)
spans -3 mm <= y <= 0 with y = 0 its superior end, and z runs from 0 to ``length`` (14 mm).
We keep the position relative to the fold, reading the paper's y as measured from the
superior end of the medial surface and its z from mid-length: the target is
(half_gap, -1.36 mm, length / 2 - 0.37 mm), i.e. 45 % down the medial surface, 0.37 mm
anterior of mid-length, and the node is the mesh node nearest to it (on the coarse mesh
(0.05, -1.44, 7.0) mm; the exact node is written in the CSV header and the PNG title).
These readings of the paper's y and z origins are assumptions.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import time
from pathlib import Path

import numpy as np

import vfrs

SCENE = Path(__file__).with_name("m5_phonation_isotropic.toml")

PAPER_NODE_CM = (0.024, -0.136, -0.037)
AL_KAPPA0 = 1e7  # Pa/m, see "Units" in the module docstring
FIG2_PENALTY = (1e7, 1e8)  # the paper's kappa = 1e7 read as SI and as CGS
FULL_KAPPAS = (1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11)
FULL_AUGMENTATIONS = (1, 2, 4, 8)
FULL_PRESSURES = (600.0, 800.0)
QUICK_KAPPAS = (1e6, 1e7, 1e8)
QUICK_AUGMENTATIONS = (1, 4)


def paper_node_position(length=14e-3, half_gap=0.05e-3):
    """Our position (m) for the paper's node: same place relative to the fold (see the
    module docstring): (half_gap, paper y, length / 2 + paper z)."""
    x_cm, y_cm, z_cm = PAPER_NODE_CM
    return (half_gap, y_cm * 1e-2, 0.5 * length + z_cm * 1e-2)


#: The scheme of the paper's runs (the reproduction) and the one they are compared with.
PAPER_SCHEME = "plain"
COMPARISON_SCHEME = "mass_redistribution"
#: A run's label ends with its scheme's suffix (none: the paper's).
SCHEME_SUFFIX = {"plain": "", "mass_redistribution": " (mass redist.)", "stabilized": " (stab.)"}


def case_label(case) -> str:
    m = case["method"]
    suffix = "" if m == "detect_only" else SCHEME_SUFFIX[case.get("scheme", PAPER_SCHEME)]
    if m == "detect_only":
        return "detect-only"
    if m == "lagrange":
        return "LM" + suffix
    if m == "penalty":
        return f"P_{case['kappa']:.0e}".replace("e+0", "e").replace("e+", "e") + suffix
    if m == "augmented_lagrange":
        lab = f"A_{case['augmentations']}"
        if case["kappa"] != AL_KAPPA0:
            lab += f" (kappa0={case['kappa']:g})"
        return lab + suffix
    return m + suffix


def cases(quick=False):
    """The runs: a list of dicts (ps, method, kappa, augmentations, scheme, label).

    Every force method runs with the paper's plain HHT scheme (:data:`PAPER_SCHEME`); the
    full mode repeats them in :data:`COMPARISON_SCHEME` (vfrs's default, mass
    redistribution), the quick mode only LM. Detect-only applies no force: no scheme acts."""
    pressures = (800.0,) if quick else FULL_PRESSURES
    kappas = QUICK_KAPPAS if quick else FULL_KAPPAS
    augs = QUICK_AUGMENTATIONS if quick else FULL_AUGMENTATIONS
    out = []
    schemes = (PAPER_SCHEME,) if quick else (PAPER_SCHEME, COMPARISON_SCHEME)
    for ps in pressures:
        out.append(dict(ps=ps, method="detect_only", kappa=None, augmentations=None, scheme=None))
        for sch in schemes:
            out.append(dict(ps=ps, method="lagrange", kappa=None, augmentations=None, scheme=sch))
            for k in kappas:
                out.append(dict(ps=ps, method="penalty", kappa=k, augmentations=None, scheme=sch))
            for n in augs:
                out.append(dict(ps=ps, method="augmented_lagrange", kappa=AL_KAPPA0, augmentations=n, scheme=sch))
    if quick:
        out.append(dict(ps=800.0, method="lagrange", kappa=None, augmentations=None, scheme=COMPARISON_SCHEME))
    else:
        # The paper's literal augmented-Lagrange start, kappa_0 = 1 (Pa/m here).
        out.append(dict(ps=800.0, method="augmented_lagrange", kappa=1.0, augmentations=4, scheme=PAPER_SCHEME))
    for c in out:
        c["label"] = case_label(c)
    return out


def case_for(ps, label, quick=False):
    """The case of one summary row, by its key columns (``ps_Pa``, ``label``): what a test
    re-runs with :func:`run_case` to check a committed row."""
    for c in cases(quick):
        if c["ps"] == float(ps) and c["label"] == label:
            return c
    raise KeyError(f"no case Ps = {ps} Pa, {label!r} in the {'quick' if quick else 'full'} mode")


def fig2_labels(quick=False):
    """Labels of the runs shown in Fig. 2 (all at Ps = 0.8 kPa): the paper's three methods in
    its plain scheme (penalty at both readings of its kappa) and LM in the comparison scheme
    (mass redistribution)."""
    labs = [case_label(dict(method="penalty", kappa=k)) for k in FIG2_PENALTY]
    return labs + ["LM", "A_4", case_label(dict(method="lagrange", scheme=COMPARISON_SCHEME))]


def scene_for(case, resolution="coarse", end=0.045):
    """The phonation scene with this case's pressure, contact table and the paper's node as
    the probe."""
    d = vfrs.Scene.load(SCENE).to_dict()
    for b in d["bodies"]:
        b["mesh"]["resolution"] = resolution
    mesh = d["bodies"][0]["mesh"]
    d["time"]["end"] = end
    d["flow"]["subglottal_pressure"] = float(case["ps"])
    c = {"method": case["method"], "detection": "interface_mesh"}
    if case["kappa"] is not None:
        c["kappa"] = float(case["kappa"])
    if case["augmentations"] is not None:
        c["max_augmentations"] = int(case["augmentations"])
        # N is the paper's parameter, swept on purpose: a step whose N augmentations end
        # above gap_tol is recorded (history contact_converged = 0), not raised.
        c["strict"] = False
    if c["method"] != "detect_only":
        c["scheme"] = case.get("scheme") or PAPER_SCHEME
    d["contact"] = c
    d["output"]["probes"] = [list(paper_node_position(mesh.get("length", 14e-3), mesh.get("half_gap", 0.05e-3)))]
    return vfrs.Scene.from_dict(d)


def _row_head(case, resolution, end):
    return dict(
        ps_Pa=case["ps"], label=case["label"], method=case["method"], kappa_Pa_per_m=case["kappa"],
        augmentations=case["augmentations"], scheme=case.get("scheme") or "", resolution=resolution,
        end_s=end,
    )


def measure(row, h, probe, window=None):
    """Fills a summary row from a run's history ``h`` (a dict of arrays) and its probe
    (``position``, ``body``); returns the time series Fig. 2 needs. The one measurement of
    both paths: a run in this process (:func:`run_case`) and a finished run of the sweep
    (:func:`run_all`)."""
    t = np.asarray(h["t"], dtype=float)
    keep = np.ones_like(t, dtype=bool) if window is None else (t >= window[0]) & (t <= window[1])
    fx = np.asarray(h["contact_force.right"], dtype=float)[:, 0]
    vol = np.asarray(h["intersection_volume"], dtype=float)
    area = np.asarray(h["contact_area"], dtype=float)
    pen = np.asarray(h["max_penetration"], dtype=float)
    probe_f = np.asarray(h["contact_force_probe.0"], dtype=float)
    i = int(np.argmax(np.where(keep, fx, -np.inf)))
    active = np.asarray(h["active_pairs"]) > 0
    row.update(
        max_force_x_N=float(fx[keep].max()),
        t_max_force_s=float(t[i]),
        max_at_end=int(i == len(t) - 1),  # 1: the run may have cut the largest collision short
        min_force_x_N=float(fx[keep].min()),
        max_intersection_volume_m3=float(vol[keep].max()),
        max_contact_area_m2=float(area[keep].max()),
        max_penetration_m=float(pen[keep].max()),
        max_node_force_x_N=float(probe_f[keep, 0].max()),
        contact_steps=int(np.count_nonzero(active[keep])),
        unsettled_steps=int(np.count_nonzero(np.asarray(h["contact_settled"])[keep] == 0)),
        unconverged_steps=int(np.count_nonzero(np.asarray(h["contact_converged"])[keep] == 0)) if "contact_converged" in h else 0,
        mean_augmentations=float(np.mean(np.asarray(h["augmentations"])[active])) if np.any(active) else 0.0,
        error="",
    )
    node_xyz = tuple(float(v) for v in probe["position"])
    row["node_body"], row["node_xyz_m"] = str(probe["body"]), node_xyz
    return dict(t=t, node_fx=probe_f[:, 0], fx=fx, volume=vol, area=area, node_xyz=node_xyz, body=str(probe["body"]))


def run_case(case, resolution="coarse", end=0.045, window=None):
    """Run one case in this process; return its summary row and the time series Fig. 2 needs
    (what :func:`run_all` gets from the case's task of the sweep: the same scene, the same
    :func:`measure`).

    ``window`` = (t0, t1) in s restricts the maxima to that interval (default: whole run).
    A run that raises (e.g. a :class:`vfrs.ConvergenceError`) is recorded with its error."""
    scene = scene_for(case, resolution, end)
    row = _row_head(case, resolution, end)
    t0 = time.perf_counter()
    try:
        res = vfrs.run(scene, progress=False)
    except vfrs.VfrsError as e:  # report, do not hide
        row.update(wall_s=time.perf_counter() - t0, error=f"{type(e).__name__}: {e}".replace("\n", " ")[:300])
        return row, None
    row["wall_s"] = float(res.timings["total"])
    return row, measure(row, res.history, res.probe(scene.output.probes[0]), window)


def paper_sweep(quick=False, resolution="coarse", end=0.045):
    """The cases as one sweep (:class:`vfrs.studies.sweep.Sweep`), labelled by ``ps_Pa`` and ``label``:
    :func:`scene_for` each, writing no field snapshots but the first and last (the figures
    read the history and the probe)."""
    from vfrs.studies.sweep import Sweep

    runs = []
    for c in cases(quick):
        d = scene_for(c, resolution, end).to_dict()
        d["output"]["every"] = 1_000_000
        runs.append(({"ps_Pa": c["ps"], "label": c["label"]}, d))
    return Sweep.from_runs(f"paper figures ({'quick' if quick else 'full'} mode, {resolution}, {end} s)", runs)


def _case_from_folder(case, folder, resolution, end, window):
    """A summary row and Fig. 2 series from a finished task's run folder (history.npz,
    probes.npz, sweep_run.json)."""
    from vfrs.studies.sweep import own_time, read_run

    row = _row_head(case, resolution, end)
    rec, h = read_run(folder)
    if rec["status"] != "complete":
        row.update(wall_s=rec.get("wall_time"), error=str(rec.get("error") or "failed").replace("\n", " ")[:300])
        return row, None
    with np.load(Path(folder) / "probes.npz", allow_pickle=False) as z:
        probe = {"position": z["probe_0.position"], "body": str(z["probe_0.body"])}
    row["wall_s"] = own_time(rec.get("timings") or {})
    return row, measure(row, h, probe, window)


def normalise(rows):
    """Add ``normalised_volume`` = max volume / the detect-only run's max volume (same Ps)."""
    ref = {r["ps_Pa"]: r.get("max_intersection_volume_m3") for r in rows if r["method"] == "detect_only"}
    for r in rows:
        v, v0 = r.get("max_intersection_volume_m3"), ref.get(r["ps_Pa"])
        r["normalised_volume"] = v / v0 if (v is not None and v0) else float("nan")
    return rows


SUMMARY_COLUMNS = [
    "ps_Pa", "label", "method", "kappa_Pa_per_m", "augmentations", "scheme", "resolution", "end_s",
    "max_force_x_N", "t_max_force_s", "max_at_end", "min_force_x_N", "max_intersection_volume_m3", "normalised_volume",
    "max_contact_area_m2", "max_penetration_m", "max_node_force_x_N", "contact_steps", "unsettled_steps", "unconverged_steps",
    "mean_augmentations", "wall_s", "error",
]


def write_summary(rows, path):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=SUMMARY_COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in SUMMARY_COLUMNS})


def write_fig2(series_by_label, node_xyz, path):
    labels = [k for k, s in series_by_label.items() if s is not None]
    t = series_by_label[labels[0]]["t"]
    with open(path, "w", newline="") as f:
        f.write(f"# Ps = 800 Pa; node nearest the paper's (0.024,-0.136,-0.037) cm, ours at (m) {node_xyz}\n")
        w = csv.writer(f)
        w.writerow(["t_s"] + [f"Fx_N[{lab}]" for lab in labels])
        for j in range(len(t)):
            w.writerow([f"{t[j]:.6g}"] + [f"{series_by_label[lab]['node_fx'][j]:.6e}" for lab in labels])


def read_summary(path):
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            for k, v in r.items():
                if k in ("label", "method", "scheme", "resolution", "error"):
                    continue
                r[k] = float(v) if v not in ("", None) else None
            rows.append(r)
    return rows


def run_all(out="out/paper", quick=False, resolution=None, end=None, window=None, log=print, *, workers=None,
            serial=False, scheduler=None, runs=None):
    """Run every case as one sweep on dask.distributed (:func:`paper_sweep`; ``workers``
    default: the cores, ``serial``: in this process, ``scheduler``: an existing cluster), the
    run folders in ``runs`` (default ``out/sweep``; finished runs of the same vfrs build are
    not run again), then write the CSVs from them (and return rows, Fig. 2 series, node
    position, wall)."""
    from vfrs.studies.sweep import run_sweep

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    resolution = resolution or "coarse"
    end = end if end is not None else (0.015 if quick else 0.045)
    t_start = time.perf_counter()
    load_before = _loadavg()
    sweep = paper_sweep(quick, resolution, end)
    runs = Path(runs) if runs is not None else out / "sweep"
    runs.mkdir(parents=True, exist_ok=True)
    (runs / ".gitignore").write_text("*\n")  # run folders: the inputs of the figures, not results
    done = run_sweep(sweep, runs, workers=workers, serial=serial, scheduler=scheduler,
                     log=None if log else (lambda msg: None), progress=None if log else False)
    rows, fig2 = [], {}
    want2 = set(fig2_labels(quick))
    for c, spec in zip(cases(quick), sweep.runs):
        assert spec["params"] == {"ps_Pa": c["ps"], "label": c["label"]}
        row, series = _case_from_folder(c, runs / "runs" / spec["id"], resolution, end, window)
        rows.append(row)
        if c["ps"] == 800.0 and c["label"] in want2:
            fig2[c["label"]] = series
        if log:
            msg = row["error"] or (
                f"max Fx {row['max_force_x_N'] * 1e3:8.3f} mN, max V {row['max_intersection_volume_m3'] * 1e9:9.4f} mm^3, "
                f"max area {row['max_contact_area_m2'] * 1e6:7.3f} mm^2"
            )
            log(f"Ps={c['ps']:.0f} {c['label']:>22s}: {msg}  ({row['wall_s']:.1f} s)")
    normalise(rows)
    write_summary(rows, out / "fig3_fig4_summary.csv")
    node_xyz = next((s["node_xyz"] for s in fig2.values() if s is not None), None)
    if fig2:
        write_fig2({k: fig2.get(k) for k in fig2_labels(quick) if k in fig2}, node_xyz, out / "fig2_node_force.csv")
    wall = time.perf_counter() - t_start
    engine = "serial (one process)" if serial else (scheduler or f"embedded LocalCluster, {workers or 'one per core'} workers")
    schemes = sorted({c["scheme"] for c in cases(quick) if c["scheme"]}, key=lambda s: s != PAPER_SCHEME)
    write_run_info(out / "run_info.txt", quick, resolution, end, wall,
                   f"{len(sweep.runs)} runs, {done.skipped} of them finished before; engine {engine}",
                   schemes=schemes, load=(load_before, _loadavg()))
    return rows, fig2, node_xyz, wall


def _loadavg() -> str:
    """This machine's 1-minute load average (the wall times are measured under it)."""
    try:
        return Path("/proc/loadavg").read_text().split()[0]
    except OSError:
        return "unknown"


def write_run_info(path, quick, resolution, end, wall, engine="", schemes=(), load=None):
    """Provenance: the vfrs commit (and whether the tree had uncommitted changes), settings,
    wall time, the contact schemes run and the machine's load around the sweep. The
    plain-scheme LM and A_N peaks are sensitive to round-off (chatter), so the numbers belong
    to a commit."""
    import subprocess

    def git(*args):
        try:
            return subprocess.run(["git", *args], cwd=Path(__file__).parent, capture_output=True, text=True, timeout=10).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""

    dirty = git("status", "--porcelain", "--", "python", "rust")
    Path(path).write_text(
        f"commit {git('rev-parse', 'HEAD') or 'unknown'}{' + uncommitted changes in python/ or rust/' if dirty else ''}\n"
        f"date {time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}\n"
        f"mode {'quick' if quick else 'full'}; resolution {resolution}; end {end} s; wall {wall:.1f} s\n"
        + (f"sweep {engine}\n" if engine else "")
        + (f"schemes {', '.join(schemes)} (the first is the paper's, of every force method; detect-only has none)\n"
           if schemes else "")
        + (f"load {load[0]} before, {load[1]} after (1-minute load average; {os.cpu_count()} cores: the wall times are "
           "measured under that load)\n" if load else "")
    )


def read_run_info(path):
    """The settings ``write_run_info`` recorded: dict with commit, dirty (bool), date, quick
    (bool), resolution, end (s), wall (s)."""
    lines = Path(path).read_text().splitlines()
    info = {"commit": lines[0].split()[1], "dirty": "uncommitted" in lines[0], "date": lines[1].split()[1]}
    for part in lines[2].split(";"):
        key, value = part.split()[:2]
        info[key] = value
    info["quick"] = info.pop("mode") == "quick"
    info["end"], info["wall"] = float(info["end"]), float(info["wall"])
    return info


# -- plots --------------------------------------------------------------------------------
STYLE = {"LM": dict(color="k", ls="-", lw=1.4), "LM (mass redist.)": dict(color="tab:orange", ls="-", lw=1.2),
         "A_4": dict(color="tab:red", ls="--", lw=1.4)}


def plot_fig2(fig2, node_xyz, path, zoom=2.5e-3):
    """Top: the whole run; bottom: ``zoom`` s around the largest LM force on the node."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(8.5, 7))
    ref = fig2.get("LM") or next(s for s in fig2.values() if s is not None)
    i = int(np.argmax(ref["node_fx"]))
    t_c = ref["t"][i]
    for ax, lim in zip(axes, (None, (t_c - 0.4 * zoom, t_c + 0.6 * zoom))):
        dotted = iter([dict(color="tab:blue", ls=":", lw=1.8), dict(color="tab:green", ls=":", lw=1.8)])
        for lab, s in fig2.items():
            if s is None:
                continue
            st = STYLE.get(lab) or next(dotted)
            name = {"LM": "Lagrange (LM)", "A_4": "augmented Lagrange, N = 4 (kappa0 = 1e7 Pa/m)",
                    "LM (mass redist.)": "LM, mass redistribution (vfrs's default scheme)"}.get(lab, lab)
            if lab.startswith("P_"):
                name = f"penalty, kappa = {lab[2:]} Pa/m"
            keep = slice(None) if lim is None else (s["t"] >= lim[0]) & (s["t"] <= lim[1])
            ax.plot(s["t"][keep] * 1e3, s["node_fx"][keep] * 1e3, label=name, marker="." if lim else None, ms=3, **st)
        ax.set_ylabel("node contact force, x (mN)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="upper left")
    axes[0].axvspan((t_c - 0.4 * zoom) * 1e3, (t_c + 0.6 * zoom) * 1e3, color="0.9", zorder=0)
    axes[1].set_xlabel("t (ms)")
    axes[1].set_title("zoom (shaded above); dots: time steps (h = 50 us)", fontsize=9)
    x, y, z = (v * 1e3 for v in node_xyz)
    axes[0].set_title(f"Fig. 2: Ps = 0.8 kPa, right-fold node at ({x:.2f}, {y:.2f}, {z:.2f}) mm; plain HHT unless noted",
                      fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _marker(method):
    return {"lagrange": "o", "penalty": "s", "augmented_lagrange": "^", "detect_only": "x"}[method]


NAMES = {"lagrange": "LM", "penalty": "P_kappa", "augmented_lagrange": "A_N", "detect_only": "detect-only"}
XFLOOR = 1e-6  # normalised volumes below this are drawn at it (log axis)


def _panel(ax, rows, key, scale):
    seen = set()
    for r in rows:
        v = r.get(key)
        if v is None or not math.isfinite(v) or r.get("error"):
            continue
        filled = r["ps_Pa"] == 800.0
        m = _marker(r["method"])
        name = NAMES[r["method"]]
        legend = f"{name}, Ps = {r['ps_Pa'] / 1e3:.1f} kPa" if (name, filled) not in seen else None
        seen.add((name, filled))
        kw = dict(marker=m, s=45, label=legend, zorder=3)
        if m == "x":
            kw.update(color="k" if filled else "0.5")
        else:
            kw.update(facecolor="k" if filled else "white", edgecolor="k")
        x = max(r["normalised_volume"], XFLOOR)
        ax.scatter(x, v * scale, **kw)
        lab = r["label"]
        for suffix in SCHEME_SUFFIX.values():
            lab = lab.replace(suffix, "") if suffix else lab
        lab = lab.replace(" (kappa0=1)", " k0=1")
        if r["method"] != "detect_only":
            left = r["method"] == "augmented_lagrange"  # A_1 coincides with P_1e7 by construction
            ax.annotate(lab, (x, v * scale), textcoords="offset points", xytext=(-5 if left else 5, 3 if filled else -9),
                        ha="right" if left else "left", fontsize=6.5, color="k" if filled else "0.45")
    ax.set_xscale("log")
    ax.set_xlabel(f"max intersection volume / max without contact forces (values < {XFLOOR:g} drawn at it)", fontsize=8)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="best")


def plot_vs_volume(rows, key, scale, ylabel, title, path):
    """One panel per scheme present (plain HHT = the paper's; then the comparison's)."""
    import matplotlib.pyplot as plt

    ref = [r for r in rows if r["method"] == "detect_only"]
    names = {PAPER_SCHEME: "paper's scheme (plain HHT)", "mass_redistribution": "mass redistribution (vfrs default)",
             "stabilized": "contact-stabilized predictor"}
    groups = []
    for sch in dict.fromkeys([PAPER_SCHEME] + [r.get("scheme") for r in rows if r["method"] != "detect_only"]):
        rs = [r for r in rows if r["method"] != "detect_only" and r.get("scheme") == sch]
        if rs or sch == PAPER_SCHEME:
            groups.append((names.get(sch, sch), rs))
    fig, axes = plt.subplots(1, len(groups), figsize=(6.5 * len(groups), 5), sharey=True, squeeze=False)
    for ax, (name, rs) in zip(axes[0], groups):
        _panel(ax, rs + ref, key, scale)
        ax.set_title(name, fontsize=9)
    axes[0][0].set_ylabel(ylabel)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def plot_all(rows, fig2, node_xyz, out):
    out = Path(out)
    if fig2:
        plot_fig2(fig2, node_xyz, out / "fig2_node_force.png")
    plot_vs_volume(rows, "max_force_x_N", 1e3, "max total contact force on the right fold, x component (mN)",
                   "Fig. 3: max medio-lateral contact force vs normalised intersection volume", out / "fig3_force_vs_volume.png")
    plot_vs_volume([r for r in rows if r["method"] != "detect_only"], "max_contact_area_m2", 1e6, "max contact area (mm$^2$)",
                   "Fig. 4: max contact area vs normalised intersection volume (detect-only: no loaded node, area 0, not drawn)", out / "fig4_area_vs_volume.png")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarse, 15 ms, Ps = 0.8 kPa, 8 runs")
    ap.add_argument("--out", default="out/paper")
    ap.add_argument("--resolution", default=None, help="coarse (default), medium, fine")
    ap.add_argument("--end", type=float, default=None, help="simulated time (s); 0.015 quick, 0.045 full")
    ap.add_argument("--workers", type=int, default=None, help="dask workers (default: one per core)")
    ap.add_argument("--serial", action="store_true", help="no dask: every run in this process")
    ap.add_argument("--scheduler", default=None, help="an existing dask scheduler, tcp://host:8786")
    ap.add_argument("--runs", default=None, help="the run folders (default OUT/sweep)")
    a = ap.parse_args(argv)
    rows, fig2, node_xyz, wall = run_all(a.out, a.quick, a.resolution, a.end, workers=a.workers, serial=a.serial,
                                         scheduler=a.scheduler, runs=a.runs)
    plot_all(rows, fig2, node_xyz, a.out)
    print(f"wall time {wall:.1f} s; node {tuple(round(v * 1e3, 3) for v in node_xyz)} mm; wrote {a.out}/")
    for r in rows:
        if not r.get("error"):
            print(f"  Ps={r['ps_Pa']:.0f} {r['label']:>22s}: Fmax = {r['max_force_x_N'] * 1e3:8.3f} mN, "
                  f"V/V0 = {r['normalised_volume']:.4f}, Amax = {r['max_contact_area_m2'] * 1e6:7.3f} mm^2")
    return rows


if __name__ == "__main__":
    main()
