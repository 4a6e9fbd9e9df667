"""The paper-figure sweep (examples/paper_figures.py, full mode: 53 runs of the coarse M5
folds, 45 ms each) on dask.distributed with 1 and 2 workers, against the same runs one after
another in this process (``--serial``, no dask): the peer measured in the same invocation.

Each engine gets a fresh folder (nothing skipped) and runs the same sweep; the wall time is
from submitting the sweep to its table written (cluster start included). Reported: wall time,
speed-up over 1 worker and over serial, efficiency (speed-up / workers), each run's own time
(``run_time`` of its ``sweep_run.json``), the sum of those, and what a 1,000-run study of such
runs costs on N workers by extrapolation from the measured per-run times.

    python benchmarks/bench_sweep.py                     # full mode, ~10 min on 2 cores
    python benchmarks/bench_sweep.py --quick             # 8 runs of 15 ms, ~1 min (smoke run)

Writes ``benchmarks/results/sweep/bench_sweep.json`` and ``bench_sweep.md`` (``--out``).
Run it on an otherwise idle machine: the workers share its cores with whatever else runs.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def paper_module():
    spec = importlib.util.spec_from_file_location("paper_figures", ROOT / "examples" / "paper_figures.py")
    assert spec and spec.loader
    pf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(pf)
    return pf


def load():
    with open("/proc/loadavg") as fh:
        return float(fh.read().split()[0])


def one_engine(sweep, engine: str, workers: int | None) -> dict:
    """Runs ``sweep`` into a fresh folder with one engine; wall time and each run's time."""
    from vfrs.studies.sweep import RUN_FILE, run_sweep

    tmp = Path(tempfile.mkdtemp(prefix=f"vfrs-bench-sweep-{engine}-"))
    try:
        load_before = load()
        t0 = time.perf_counter()
        res = run_sweep(sweep, tmp, serial=engine == "serial", workers=workers, log=lambda m: None, progress=False)
        wall = time.perf_counter() - t0
        runs = []
        for spec, row in zip(sweep.runs, res.rows):
            rec = json.loads((tmp / "runs" / spec["id"] / RUN_FILE).read_text())
            runs.append({"id": spec["id"], **spec["params"], "status": row["status"], "run_time_s": rec["run_time"],
                         "task_time_s": rec["wall_time"], "peak_rss_mb": rec["peak_rss_mb"], "pid": rec["pid"],
                         "peak_force_N": (row.get("contact.peak_force.right [N]"))})
        return {"engine": engine, "workers": workers if engine != "serial" else 1, "wall_s": wall,
                "failed": res.failed, "load_before": load_before, "load_after": load(), "runs": runs}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def summarise(results: list[dict], n_study: int = 1000) -> dict:
    by = {r["engine"]: r for r in results}
    one = by["1 worker"]["wall_s"]
    rows = []
    for r in results:
        times = [x["run_time_s"] for x in r["runs"] if x["run_time_s"] is not None]
        rows.append({"engine": r["engine"], "workers": r["workers"], "wall_s": r["wall_s"],
                     "speedup_vs_1_worker": one / r["wall_s"], "speedup_vs_serial": by["serial"]["wall_s"] / r["wall_s"],
                     "efficiency": one / r["wall_s"] / r["workers"], "sum_run_s": sum(times),
                     "mean_run_s": statistics.mean(times), "max_run_s": max(times),
                     "overhead_s": r["wall_s"] - sum(times) / r["workers"]})
    alone = statistics.mean(x["run_time_s"] for x in by["1 worker"]["runs"])
    side = statistics.mean(x["run_time_s"] for x in by["2 workers"]["runs"])
    slow = side / alone
    study = {"runs": n_study, "mean_run_alone_s": alone, "mean_run_side_by_side_s": side, "side_by_side_factor": slow,
             "hours_on": {str(n): n_study * alone * (1 if n == 1 else slow) / n / 3600 for n in (1, 2, 8, 32, 128)}}
    return {"rows": rows, "study": study}


def markdown(data: dict) -> str:
    s = data["summary"]
    lines = [f"# The paper-figure sweep on dask ({data['mode']} mode: {data['n_runs']} runs)", "",
             f"{data['date']}, vfrs {data['commit']}, {data['machine']}; load average before/after each engine in "
             "bench_sweep.json.", "",
             "| engine | wall (s) | speed-up vs 1 worker | vs serial | efficiency | sum of run times (s) | mean run (s) "
             "| longest run (s) | overhead (s) |", "|---|---|---|---|---|---|---|---|---|"]
    for r in s["rows"]:
        lines.append(f"| {r['engine']} | {r['wall_s']:.1f} | {r['speedup_vs_1_worker']:.2f} | {r['speedup_vs_serial']:.2f} "
                     f"| {r['efficiency']:.0%} | {r['sum_run_s']:.1f} | {r['mean_run_s']:.2f} | {r['max_run_s']:.2f} "
                     f"| {r['overhead_s']:.1f} |")
    st = s["study"]
    lines += ["", "Overhead = wall - (sum of run times) / workers: cluster start, imports, scheduling, the uneven "
              "end of the queue, writing the run folders.", "",
              f"**A {st['runs']:,}-run study** of such runs (mean run {st['mean_run_alone_s']:.2f} s alone, "
              f"{st['mean_run_side_by_side_s']:.2f} s side by side on 2 workers: x{st['side_by_side_factor']:.2f}), "
              "extrapolated as runs x mean run x that factor / N workers (assumes the factor of 2 workers holds for "
              "N, i.e. each worker has a core and its share of memory bandwidth, and the file system keeps up):", "",
              "| workers | hours |", "|---|---|"]
    lines += [f"| {n} | {h:.2f} |" for n, h in st["hours_on"].items()]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the quick mode's 8 runs (15 ms): a smoke run")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "sweep"))
    a = ap.parse_args(argv)
    import subprocess

    import vfrs

    pf = paper_module()
    sweep = pf.paper_sweep(quick=a.quick, resolution="coarse", end=0.015 if a.quick else 0.045)
    results = []
    for engine, workers in (("serial", None), ("1 worker", 1), ("2 workers", 2)):
        print(f"{engine}: {len(sweep.runs)} runs ...", flush=True)
        r = one_engine(sweep, engine, workers)
        print(f"{engine}: {r['wall_s']:.1f} s, {r['failed']} failed", flush=True)
        results.append(r)
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    dirty = bool(subprocess.run(["git", "status", "--porcelain", "--", "python", "rust", "examples", "benchmarks"],
                                cwd=ROOT, capture_output=True, text=True).stdout.strip())
    data = {"mode": "quick" if a.quick else "full", "n_runs": len(sweep.runs), "commit": commit + (" + changes" if dirty else ""),
            "vfrs": vfrs.__version__, "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "machine": f"{platform.processor() or platform.machine()}, {len(os.sched_getaffinity(0))} cores, "
                       f"Python {sys.version.split()[0]}",
            "engines": results, "summary": summarise(results)}
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench_sweep.json").write_text(json.dumps(data, indent=1) + "\n")
    (out / "bench_sweep.md").write_text(markdown(data))
    print(markdown(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
