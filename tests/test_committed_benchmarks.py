"""The committed benchmark results are the code's: the deterministic part of each (never a
wall time) is re-run here and compared with the committed numbers.

- ``benchmarks/results/m5/bench_m5.json`` (``benchmarks/bench_m5.py``): the coarse Lagrange
  row, re-run through the benchmark's own ``one_run``: free DOFs, steps, steps with contact,
  compliance columns solved, nnz of the factor and the peak contact force.
- ``benchmarks/results/solve_m5.json`` (``benchmarks/bench_solve_m5.py``): the medium mesh's
  fold blocks rebuilt as the benchmark builds them: their size, nnz(K_eff) and nnz(L) of the
  integrator's factor (stored and lower triangle); CHOLMOD's nnz(L) when scikit-sparse is
  installed.

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
    row = next(r for r in committed["rows"] if r["level"] == "coarse" and r["method"] == "lagrange")
    now = _load("bench_m5").one_run("coarse", "lagrange", committed["end_s"])
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
        assert f.ordering == row["faer_ordering"]
        assert f.nnz_factor == row["nnz_L_faer_stored"], f"{where}: stored nnz(L) {row['nnz_L_faer_stored']} -> {f.nnz_factor}"
        assert f.nnz_factor_lower == row["nnz_L_faer_lower"], (
            f"{where}: lower nnz(L) {row['nnz_L_faer_lower']} -> {f.nnz_factor_lower}")
        assert f.nnz_factor_lower < f.nnz_factor  # the stored count includes the upper halves
    sksparse = pytest.importorskip("sksparse.cholmod")
    for row, blk in zip(rows, F.blocks):
        nnz = sksparse.cholesky(A[blk, blk]).L().nnz
        assert nnz == row["nnz_L_cholmod"], f"solve_m5.json medium block {row['block']}: CHOLMOD nnz(L) {row['nnz_L_cholmod']} -> {nnz}"
