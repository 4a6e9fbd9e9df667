"""The converge study's scale-out on dask, measured: the steady main job's study
(examples/m5_steady.toml) over a short window, run once one run after another (``--serial``)
and once on an embedded LocalCluster of 2 workers, against what ``projected_wall`` (longest
run first, each to the worker free first) gives from the runs' own times; then the same
projection from the committed full studies' run times, for 1, 2 and 16 workers.

The window scene is a copy of m5_steady.toml with ``[time] end`` = ``--end`` (10 ms) and
without the limit-cycle keys of ``[output]`` (until, until_cycles, until_cap, errors_from:
``vfrs converge --set`` cannot remove keys, and errors_from is relative to the scene's folder),
written into a temporary folder. Two studies of it by default, each twice, each into a fresh
folder (nothing skipped, no figures): ``meshes`` (``--steps 1``: levels 0, 1, 2 of the
systematic family at the scene's step) and ``steps`` (``--meshes 1``: level 0 at h, h/2, h/4).
A study's wall time is the whole ``vfrs converge`` command's (a subprocess: interpreter start,
plan, the runs, the report); a run's own time is ``wall_time`` of the study's converge.json
(the task's clock, as summary.csv's ``wall_time [s]``). The serial command runs with one
thread (RAYON_NUM_THREADS etc. = 1, ``--serial-threads``), as each dask worker does: the
ratio is the scale-out, not dask against rayon (vfrs.linalg still solves the two bodies'
blocks in two threads: a run uses a little more than one core either way).

    python benchmarks/bench_study_scaleout.py            # both studies, ~4.5 min on 2 idle cores
    python benchmarks/bench_study_scaleout.py --studies steps --end 0.002   # a smoke run, ~30 s
    python benchmarks/bench_study_scaleout.py --from-json benchmarks/results/converged_answer/scale_out.json
                                                         # no run: derive and write the table again

Writes ``benchmarks/results/converged_answer/scale_out.json`` and ``scale_out.md`` (``--out``).
The machine's cores are shared: the load averages before and after each command are recorded,
and the CPU time other jobs took meanwhile (/proc/stat less this command's own).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from vfrs._compat import tomllib
from vfrs.scene.toml_writer import dumps
from vfrs.studies.converge import CONVERGE_FILE, projected_wall
from vfrs.studies.sweep.task import THREAD_VARS

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "m5_steady.toml"
#: The ``[output]`` keys that make the main job run on to a limit cycle and print its errors.
LIMIT_CYCLE_KEYS = ("until", "until_cycles", "until_cap", "errors_from")
#: The measured studies: the ``vfrs converge`` options of each.
STUDIES = {"meshes": ["--steps", "1"], "steps": ["--meshes", "1"]}
#: The committed full studies of the main job (400 ms, to the limit cycle), by axis.
FULL = {"meshes": "examples/converge_results/m5_steady_meshes", "steps": "examples/converge_results/m5_steady_steps"}
WORKERS = (1, 2, 16)


# ------------------------------------------------------------------------------------------
# The window scene
# ------------------------------------------------------------------------------------------

def window_toml(end: float, scene: Path = SCENE) -> str:
    """``scene`` (its own keys, not the resolved scene) ending at ``end`` s, without the
    limit-cycle keys of ``[output]``."""
    with open(scene, "rb") as fh:
        d = tomllib.load(fh)
    d["time"]["end"] = end
    for k in LIMIT_CYCLE_KEYS:
        d["output"].pop(k, None)
    return (f"# {scene.name} over a {end * 1e3:g} ms window, without {', '.join(LIMIT_CYCLE_KEYS)} "
            "(benchmarks/bench_study_scaleout.py)\n" + dumps(d))


def write_window(folder: Path, end: float) -> Path:
    path = Path(folder) / "m5_steady_window.toml"
    path.write_text(window_toml(end))
    return path


# ------------------------------------------------------------------------------------------
# Measure
# ------------------------------------------------------------------------------------------

def loadavg() -> list:
    return [float(x) for x in Path("/proc/loadavg").read_text().split()[:3]]


def cpu_seconds() -> tuple:
    """The machine's busy CPU time (s, all cores, /proc/stat) and that of this process's
    finished children (the command, its dask workers): their difference over a command is
    what other jobs took from the cores meanwhile."""
    import resource

    fields = [int(x) for x in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]
    busy = (sum(fields[:8]) - fields[3] - fields[4]) / os.sysconf("SC_CLK_TCK")  # less idle and iowait
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return busy, ru.ru_utime + ru.ru_stime


def study_runs(folder: Path) -> list:
    """Each run of a study: mesh and step level and label, id, its own wall time (s) and peak
    memory (MB) from converge.json, checked against summary.csv's ``wall_time [s]``."""
    runs = json.loads((Path(folder) / CONVERGE_FILE).read_text())["runs"]
    summary = Path(folder) / "summary.csv"
    if summary.exists():
        with open(summary, newline="") as fh:
            table = {r["id"]: float(r["wall_time [s]"]) for r in csv.DictReader(fh) if r["wall_time [s]"]}
        for r in runs:
            assert math.isclose(table[r["id"]], r["wall_time"], rel_tol=1e-9), (r["id"], table[r["id"]], r["wall_time"])
    keys = ("mesh_level", "step_level", "mesh", "step", "id", "wall_time", "peak_rss_mb")
    return sorted(({k: r.get(k) for k in keys} for r in runs), key=lambda r: (r["mesh_level"], r["step_level"]))


def invoke(scene: Path, study: str, workers: int | None, serial_threads: int) -> dict:
    """One ``vfrs converge`` of ``study`` into a fresh folder: ``--serial`` (``workers`` None)
    or ``--workers N``; the command's wall time, the load averages, the runs."""
    tmp = Path(tempfile.mkdtemp(prefix=f"vfrs-scaleout-{study}-"))
    engine = ["--serial"] if workers is None else ["--workers", str(workers)]
    cmd = ["vfrs", "converge", str(scene), "-o", str(tmp / "study"), *STUDIES[study], *engine,
           "--no-figures", "--no-progress"]
    env = dict(os.environ)
    if workers is None:
        env.update({v: str(serial_threads) for v in THREAD_VARS})
    try:
        before, (busy0, own0) = loadavg(), cpu_seconds()
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        after, (busy1, own1) = loadavg(), cpu_seconds()
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
        return {"engine": "serial" if workers is None else f"{workers} workers", "workers": workers or 1,
                "command": " ".join(["vfrs", "converge", "WINDOW.toml", "-o", "OUT", *cmd[5:]]),
                "threads_per_run": serial_threads if workers is None else 1, "wall_s": wall,
                "load_before": before, "load_after": after, "cpu_s": own1 - own0,
                "other_cpu_s": max(busy1 - busy0 - (own1 - own0), 0.0), "runs": study_runs(tmp / "study")}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def projections(times: list) -> dict:
    return {str(w): projected_wall(times, w) for w in WORKERS}


def compare(serial: dict, dask: dict) -> dict:
    """The two commands of a study side by side; the projection from the serial runs' times
    (each run alone on a core), and from the dask runs' (side by side: slowed by each other)."""
    ts = [r["wall_time"] for r in serial["runs"]]
    td = [r["wall_time"] for r in dask["runs"]]
    w = dask["workers"]
    proj, proj_dask = projections(ts), projections(td)
    return {"serial_wall_s": serial["wall_s"], "dask_wall_s": dask["wall_s"], "ratio": serial["wall_s"] / dask["wall_s"],
            "sum_s": sum(ts), "longest_s": max(ts), "projected_s": proj, "projected_from_dask_runs_s": proj_dask,
            "serial_overhead_s": serial["wall_s"] - sum(ts),
            "dask_overhead_s": dask["wall_s"] - projected_wall(ts, w),
            "side_by_side_s": projected_wall(td, w) - projected_wall(ts, w),
            "dask_rest_s": dask["wall_s"] - projected_wall(td, w),
            "longest_on_dask_s": max(td), "dask_wall_past_longest_s": dask["wall_s"] - max(td)}


# ------------------------------------------------------------------------------------------
# The committed full studies, and the 3 x 3 grid
# ------------------------------------------------------------------------------------------

def full_studies(root: Path = ROOT) -> dict:
    """The projection from each committed full study's run times; the grid of the whole study
    (3 meshes x 3 steps): the mesh study's runs on the scene's step, the step study's on level
    0 (its (0, 0) also the grid's, as the cross study examples/converge_results/m5_steady takes
    it), the four off-diagonal runs never run: estimated t(i, j) = t(i, 0) t(0, j) / t(0, 0)."""
    out: dict = {"studies": {}}
    runs = {}
    for axis, rel in FULL.items():
        runs[axis] = study_runs(root / rel)
        times = [r["wall_time"] for r in runs[axis]]
        out["studies"][axis] = {"source": f"{rel}/{CONVERGE_FILE}", "runs": runs[axis], "sum_s": sum(times),
                                "projected_s": projections(times)}
    mesh_t = {r["mesh_level"]: r["wall_time"] for r in runs["meshes"]}
    step_t = {r["step_level"]: r["wall_time"] for r in runs["steps"]}
    grid = []
    for i in sorted(mesh_t):
        for j in sorted(step_t):
            if j == 0 and i > 0:
                cell = {"wall_time": mesh_t[i], "known": True, "from": FULL["meshes"]}
            elif i == 0:
                cell = {"wall_time": step_t[j], "known": True, "from": FULL["steps"]}
            else:
                cell = {"wall_time": mesh_t[i] * step_t[j] / step_t[0], "known": False,
                        "from": "estimate: t(i, 0) t(0, j) / t(0, 0)"}
            grid.append({"mesh_level": i, "step_level": j, **cell})
    known = [c["wall_time"] for c in grid if c["known"]]
    every = [c["wall_time"] for c in grid]
    factor = step_t[0] / mesh_t[0]  # the estimates with the mesh study's own (0, 0) as the divisor
    out["grid"] = {"cells": grid, "known_runs": len(known), "estimated_runs": len(every) - len(known),
                   "known_sum_s": sum(known), "known_projected_s": projections(known),
                   "sum_s": sum(every), "projected_s": projections(every),
                   "zero_zero_s": {"meshes": mesh_t[0], "steps": step_t[0]},
                   "estimates_with_mesh_study_zero_zero": factor,
                   "projected_with_mesh_study_zero_zero_s": projections(
                       [c["wall_time"] * (1.0 if c["known"] else factor) for c in grid])}
    return out


# ------------------------------------------------------------------------------------------
# Report
# ------------------------------------------------------------------------------------------

def _s(t: float) -> str:
    return f"{t:.1f}" if t < 100 else f"{t:.0f}"


def _h(t: float) -> str:
    return f"{t:.0f} s ({t / 3600:.2f} h)"


def markdown(data: dict) -> str:
    m = data["machine"]
    lines = ["# The converge study's scale-out on dask: the steady main job", "",
             f"{data['date']}, vfrs {data['commit']}; {m['cpu']}, {m['cores']} cores, Python {m['python']}. "
             f"Window: {data['scene']} to {data['end'] * 1e3:g} ms without the limit-cycle keys "
             f"({', '.join(LIMIT_CYCLE_KEYS)}); each command into a fresh folder, `--no-figures`; the serial one with "
             f"{data['serial_threads']} thread(s) per run (each dask worker: 1). A study's wall time is the whole command's; "
             "a run's is its own (converge.json `wall_time`).", "",
             "## Measured on this machine (2 workers: an embedded LocalCluster)", ""]
    for name, st in data["measured"].items():
        c = st["compare"]
        lines += [f"### {name}: `{st['serial']['command']}`", "",
                  "| command | wall (s) | its CPU (s; cores) | other jobs' CPU meanwhile (s; cores) | load average before "
                  "| after |", "|---|---|---|---|---|---|"]
        for e in (st["serial"], st["dask"]):
            lines.append(f"| {e['engine']} | {e['wall_s']:.1f} | {e['cpu_s']:.1f} ({e['cpu_s'] / e['wall_s']:.2f}) "
                         f"| {e['other_cpu_s']:.1f} "
                         f"({e['other_cpu_s'] / e['wall_s']:.2f}) | {' '.join(f'{x:.2f}' for x in e['load_before'])} "
                         f"| {' '.join(f'{x:.2f}' for x in e['load_after'])} |")
        lines += ["", "| run | serial (s) | on 2 workers (s) | x | peak memory serial / 2 workers (MB) |",
                  "|---|---|---|---|---|"]
        for a, b in zip(st["serial"]["runs"], st["dask"]["runs"]):
            lines.append(f"| {a['mesh']}, {a['step']} | {a['wall_time']:.1f} | {b['wall_time']:.1f} "
                         f"| {b['wall_time'] / a['wall_time']:.2f} "
                         f"| {a['peak_rss_mb']:.0f} / {b['peak_rss_mb']:.0f} |")
        p, q = c["projected_s"], c["projected_from_dask_runs_s"]
        lines += ["", f"- serial {c['serial_wall_s']:.1f} s, 2 workers {c['dask_wall_s']:.1f} s: ratio "
                  f"**{c['ratio']:.2f}**",
                  f"- the serial runs' times: sum {c['sum_s']:.1f} s, longest {c['longest_s']:.1f} s; "
                  f"projected wall on 1 / 2 / 16 workers {p['1']:.1f} / {p['2']:.1f} / {p['16']:.1f} s "
                  f"(from the 2-worker runs' own times: {q['1']:.1f} / {q['2']:.1f} / {q['16']:.1f} s)",
                  f"- overhead of dask: 2-worker wall - projected 2-worker wall = **{c['dask_overhead_s']:.1f} s**: "
                  f"{c['side_by_side_s']:.1f} s the runs slowed by each other (the projection from the 2-worker runs' "
                  f"times minus the serial ones'), {c['dask_rest_s']:.1f} s the rest (cluster start, scheduling, "
                  f"the command's start and report; the serial command's own overhead, wall - sum of runs, "
                  f"is {c['serial_overhead_s']:.1f} s)",
                  f"- the 2-worker wall is its longest run's own time there ({c['longest_on_dask_s']:.1f} s) "
                  f"+ {c['dask_wall_past_longest_s']:.1f} s", ""]
    lines += _reading(data)
    f = data["full"]
    lines += ["## The committed full studies (400 ms to the limit cycle; their run times as recorded)", "",
              "| study | runs (s) | sum (s) | 1 worker (s) | 2 workers (s) | 16 workers (s) |", "|---|---|---|---|---|---|"]
    for axis, st in f["studies"].items():
        p = st["projected_s"]
        lines.append(f"| {st['source']} | {', '.join(_s(r['wall_time']) for r in st['runs'])} | {st['sum_s']:.0f} "
                     f"| {p['1']:.0f} | {p['2']:.0f} | {p['16']:.0f} |")
    g = f["grid"]
    cells = {(c["mesh_level"], c["step_level"]): c for c in g["cells"]}
    lines += ["", "### The whole main-job study: 3 meshes x 3 steps", "",
              f"Known: {g['known_runs']} runs (the mesh study on the scene's step, the step study on level 0; "
              f"(level 0, h) was run by both, {g['zero_zero_s']['meshes']:.1f} s and {g['zero_zero_s']['steps']:.1f} s: "
              "the step study's is used, as examples/converge_results/m5_steady takes it). The "
              f"{g['estimated_runs']} off-diagonal runs were never run: *estimate* t(i, j) = t(i, h) t(0, j) / t(0, h).",
              "", "| mesh \\ step | h | h/2 | h/4 |", "|---|---|---|---|"]
    for i in range(3):
        lines.append(f"| level {i} | " + " | ".join(
            f"{cells[i, j]['wall_time']:.0f}" + ("" if cells[i, j]["known"] else " *estimate*") for j in range(3)) + " |")
    k, p, o = g["known_projected_s"], g["projected_s"], g["projected_with_mesh_study_zero_zero_s"]
    lines += ["", "| runs | sum | 1 worker | 2 workers | 16 workers |", "|---|---|---|---|---|",
              f"| the {g['known_runs']} known (the cross design) | {_h(g['known_sum_s'])} | {_h(k['1'])} | {_h(k['2'])} "
              f"| {_h(k['16'])} |",
              f"| all 9 ({g['estimated_runs']} *estimated*) | {_h(g['sum_s'])} | {_h(p['1'])} | {_h(p['2'])} "
              f"| {_h(p['16'])} |", "",
              f"With the mesh study's (level 0, h) as the divisor the estimates are x{g['estimates_with_mesh_study_zero_zero']:.3f}: "
              f"all 9 on 1 / 2 / 16 workers {o['1']:.0f} / {o['2']:.0f} / {o['16']:.0f} s. The projection leaves out "
              "dask's start-up and the runs slowing each other on shared cores (both measured above), and assumes a "
              "worker per run with the memory it needs (level 2: about 5 GB)."]
    return "\n".join(lines) + "\n"


def _reading(data: dict) -> list:
    """The measured comparison in one paragraph, its numbers from the records."""
    ms = data["measured"].values()
    x = [b["wall_time"] / a["wall_time"] for st in ms for a, b in zip(st["serial"]["runs"], st["dask"]["runs"])]
    cores = [st["serial"]["cpu_s"] / st["serial"]["wall_s"] for st in ms]
    ratios = " and ".join(f"{st['compare']['ratio']:.2f}" for st in ms)
    best = max(st["compare"]["ratio"] for st in ms)
    gain = "gained nothing" if best < 1.05 else f"were at best x{best:.2f} faster"
    past = " and ".join(f"{st['compare']['dask_wall_past_longest_s']:.1f}" for st in ms)
    return [f"Reading: the 2-worker cluster's wall / the serial one's: {ratios} ({', '.join(data['measured'])}). Each "
            f"study's 2-worker wall is its longest run's own time there + {past} s, but a run beside another took "
            f"x{min(x):.2f} to x{max(x):.2f} its time alone, and the serial runs used {min(cores):.2f} to "
            f"{max(cores):.2f} cores with the thread variables at 1. The projection (each run at its time alone) holds "
            f"for workers that share neither a core nor memory bandwidth; on these 2 cores two workers {gain}.", ""]


def machine() -> dict:
    model = subprocess.run("lscpu | grep 'Model name'", shell=True, capture_output=True, text=True).stdout
    return {"cpu": model.split(":", 1)[-1].strip() or "unknown", "cores": len(os.sched_getaffinity(0)),
            "python": sys.version.split()[0]}


def commit() -> str:
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--", "python", "rust", "examples/m5_steady.toml"],
                           cwd=ROOT, capture_output=True, text=True).stdout.strip()
    return head + (" + changes" if dirty else "")


def measure(a, ap) -> dict:
    """The commands of each study (serial, then on the cluster), recorded."""
    studies = [s.strip() for s in a.studies.split(",") if s.strip()]
    if not studies or any(s not in STUDIES for s in studies):
        ap.error(f"--studies {a.studies}: expected some of {', '.join(STUDIES)}")
    data = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "commit": commit(), "machine": machine(),
            "scene": str(SCENE.relative_to(ROOT)), "end": a.end, "serial_threads": a.serial_threads, "measured": {}}
    with tempfile.TemporaryDirectory(prefix="vfrs-scaleout-") as tmp:
        scene = write_window(Path(tmp), a.end)
        for name in studies:
            st = data["measured"][name] = {}
            for key, workers in (("serial", None), ("dask", a.workers)):
                print(f"{name}, {'serial' if workers is None else f'{workers} workers'} ...", flush=True)
                e = st[key] = invoke(scene, name, workers, a.serial_threads)
                print(f"  {e['wall_s']:.1f} s, load {e['load_before']} -> {e['load_after']}, other jobs' CPU "
                      f"{e['other_cpu_s']:.1f} s", flush=True)
    return data


def derive(data: dict) -> None:
    """What follows from the recorded commands and the committed full studies (no run)."""
    for st in data["measured"].values():
        st["compare"] = compare(st["serial"], st["dask"])
    data["full"] = full_studies()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--studies", default="meshes,steps", help="which studies, of: meshes, steps (default both)")
    ap.add_argument("--end", type=float, default=0.01, help="the window's end (s; default 0.01)")
    ap.add_argument("--workers", type=int, default=2, help="the LocalCluster's workers (default 2)")
    ap.add_argument("--serial-threads", type=int, default=1, help="threads of the serial command's runs (default 1)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "converged_answer"))
    ap.add_argument("--from-json", metavar="PATH", help="run nothing: derive the comparisons, the full studies' "
                    "projections and the table again from the commands recorded in PATH (a scale_out.json)")
    a = ap.parse_args(argv)
    if a.from_json:
        data = json.loads(Path(a.from_json).read_text())
    else:
        data = measure(a, ap)
    derive(data)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    text = markdown(data)
    for name, content in (("scale_out.json", json.dumps(data, indent=1) + "\n"), ("scale_out.md", text)):
        (out / name).write_text(content)
    print(text + f"\nwrote {out / 'scale_out.json'} and scale_out.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
