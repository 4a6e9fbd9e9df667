"""The committed benchmark results are the code's: the deterministic part of each (never a
wall time) is re-run here and compared with the committed numbers.

- ``benchmarks/results/m5/bench_m5.json`` (``benchmarks/bench_m5.py``): the coarse Lagrange
  row, re-run through the benchmark's own ``one_run``: free DOFs, steps, steps with contact,
  compliance columns solved, nnz of the factor and the peak contact force.
- ``benchmarks/results/solve_m5.json`` (``benchmarks/bench_solve_m5.py``): the medium mesh's
  fold blocks rebuilt as the benchmark builds them: their size, nnz(K_eff) and nnz(L) of the
  integrator's factor (stored and lower triangle). CHOLMOD's nnz(L) in the same rows is not
  re-computed here: it is CHOLMOD's number, not the code's (its ordering depends on the
  SuiteSparse build), and scikit-sparse has no wheel on PyPI (0.5.0 is a source package that
  needs SuiteSparse's headers, libsuitesparse-dev, which the clean CI install does not have),
  so it is not in the ``test`` extra. It is checked where it is made: re-running the benchmark
  (which needs CHOLMOD to run at all, benchmarks/README.md) writes it again. Every test of this
  file runs in CI; none skips.
- ``benchmarks/results/sweep/bench_sweep.json`` (``benchmarks/bench_sweep.py``): the runs are
  the current paper-figure sweep's (same run ids, i.e. the same scenes), every engine ran all of
  them and got the same peak contact force on each, the ratios are those of the recorded wall
  times, and the cheapest run re-run here gives its peak contact force.

When the code changes these on purpose, re-run the benchmark and commit its results.
"""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_bench_m5_coarse_lagrange_row_is_reproduced():
    committed = json.loads((RESULTS / "m5" / "bench_m5.json").read_text())
    row = next(r for r in committed["rows"] if r["level"] == "coarse" and r["method"] == "lagrange"
               and r.get("scheme") == "mass_redistribution")
    now = _load("bench_m5").one_run("coarse", "lagrange", committed["end_s"], "mass_redistribution")
    for key in ("free_dofs", "steps", "steps_with_contact", "compliance_solves", "nnz_factor"):
        assert now[key] == row[key], f"bench_m5.json coarse lagrange: {key} committed {row[key]}, now {now[key]}"
    assert now["peak_force_N"] == pytest.approx(row["peak_force_N"], rel=1e-9), (
        f"bench_m5.json coarse lagrange: peak_force_N committed {row['peak_force_N']}, now {now['peak_force_N']}")


def test_solve_m5_medium_blocks_are_reproduced():
    committed = json.loads((RESULTS / "solve_m5.json").read_text())
    rows = [r for r in committed["results"] if r["resolution"] == "medium" and "block" in r]
    assert len(rows) == 2
    bench = _load("bench_solve_m5")
    integ, _ = bench.build("medium")
    F = integ.factor
    A = integ.effective_matrix.tocsc()
    for row, f, blk in zip(rows, F.factors, F.blocks):
        where = f"solve_m5.json medium block {row['block']}"
        assert f.n == row["n"], f"{where}: n committed {row['n']}, now {f.n}"
        assert A[blk, blk].nnz == row["nnz_A"], f"{where}: nnz(A) committed {row['nnz_A']}, now {A[blk, blk].nnz}"
        assert f.ordering == row["ordering"]
        assert f.nnz_factor == row["nnz_L_vfrs_stored"], f"{where}: stored nnz(L) {row['nnz_L_vfrs_stored']} -> {f.nnz_factor}"
        assert f.nnz_factor_lower == row["nnz_L_vfrs_lower"], (
            f"{where}: lower nnz(L) {row['nnz_L_vfrs_lower']} -> {f.nnz_factor_lower}")
        assert f.nnz_factor_lower < f.nnz_factor  # the stored count includes the upper halves


def _bench_sweep():
    """The committed bench_sweep.json and the paper sweep of its mode as the code builds it now."""
    committed = json.loads((RESULTS / "sweep" / "bench_sweep.json").read_text())
    quick = committed["mode"] == "quick"
    sweep = _load("bench_sweep").paper_module().paper_sweep(quick=quick, resolution="coarse", end=0.015 if quick else 0.045)
    return committed, sweep


def test_bench_sweep_is_the_current_paper_sweep():
    committed, sweep = _bench_sweep()
    ids = [r["id"] for r in sweep.runs]
    engines = {e["engine"]: e for e in committed["engines"]}
    assert set(engines) == {"serial", "1 worker", "2 workers"}
    for name, e in engines.items():
        assert [r["id"] for r in e["runs"]] == ids, f"bench_sweep.json: the {name} runs are not the current sweep's"
        assert e["failed"] == 0 and all(r["status"] == "complete" for r in e["runs"]), name
        # the same runs on every engine: the same numbers (one thread or two, in a worker or here)
        assert [r["peak_force_N"] for r in e["runs"]] == [r["peak_force_N"] for r in engines["serial"]["runs"]], name
    one = engines["1 worker"]["wall_s"]
    for row in committed["summary"]["rows"]:
        assert row["speedup_vs_1_worker"] == pytest.approx(one / engines[row["engine"]]["wall_s"], rel=1e-12)
        assert row["efficiency"] == pytest.approx(row["speedup_vs_1_worker"] / row["workers"], rel=1e-12)


@pytest.mark.slow
def test_bench_sweep_cheapest_run_is_reproduced():
    import vfrs

    committed, sweep = _bench_sweep()
    runs = {e["engine"]: e for e in committed["engines"]}["1 worker"]["runs"]
    cheapest = min(runs, key=lambda r: r["run_time_s"])
    spec = next(r for r in sweep.runs if r["id"] == cheapest["id"])
    res = vfrs.run(vfrs.Scene.from_dict(spec["scene"]), progress=False)
    now = res.results["contact"]["peak_force.right"].value
    assert now == pytest.approx(cheapest["peak_force_N"], rel=1e-9), (spec["params"], cheapest["peak_force_N"], now)


def test_bench_flow_rows_are_the_benchmark_s_runs():
    """benchmarks/results/flow/bench_flow.json (benchmarks/bench_flow.py): its configurations
    are the benchmark's, each ran the 400 steps of 20 ms at 50 us on level 1, and its summary's
    shares are the rows' (the times themselves are not re-checked: they are the machine's)."""
    mod = _load("bench_flow")
    data = json.loads((RESULTS / "flow" / "bench_flow.json").read_text())
    assert list(data["rows"]) == list(mod.CONFIGS)
    assert (data["end"], data["step"], data["level"]) == (mod.END, mod.STEP, mod.LEVEL)
    for row in data["rows"].values():
        assert row["steps"] == round(mod.END / mod.STEP)
        sec = row["seconds_per_step"]
        assert row["flow_share"] == pytest.approx(sec["flow"] / sec["step"], rel=1e-12)
    rows, summary = data["rows"], data["summary"]
    base, visc = rows["steady, bernoulli"]["seconds_per_step"], rows["steady, viscous"]["seconds_per_step"]
    assert summary["viscous_flow_extra_share"] == pytest.approx((visc["flow"] - base["flow"]) / base["step"], rel=1e-12)


def test_bench_p2_modes_p1_level_0_is_reproduced():
    """benchmarks/results/p2/fold_modes.csv (benchmarks/bench_p2_modes.py): the P1 level-0 row
    re-run gives its three frequencies (to the CSV's 6 digits); the table has P1 and P2 rows."""
    mod = _load("bench_p2_modes")
    import csv

    rows = list(csv.DictReader(open(RESULTS / "p2" / "fold_modes.csv")))
    assert {r["order"] for r in rows} == {"1", "2"}
    row = next(r for r in rows if r["order"] == "1" and r["level"] == "0")
    now = mod.fold_modes(0, 1)
    assert now["free_dofs"] == int(row["free_dofs"])
    for key in ("f1_Hz", "f2_Hz", "f3_Hz"):
        assert now[key] == pytest.approx(float(row[key]), rel=1e-5)
