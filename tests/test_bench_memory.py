"""The committed memory benchmark (``benchmarks/results/converged_answer/memory.json``, made by
``benchmarks/bench_memory.py``) is the code's: its shortest level-0 run with the scene's cap is
run again here as the benchmark runs it (its child process) and its deterministic numbers compared
(never a wall time or an RSS): the factor's size, the compliance columns (how many, which were
stored, their bytes as the store counts them, S's capacity) and the columns the products read.
When the code changes them on purpose, re-run ``python benchmarks/bench_memory.py --levels 0
--end 0.005 --caps none`` and commit its results.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "converged_answer" / "memory.json"


def test_shortest_level0_run_is_reproduced():
    runs = json.loads(RESULTS.read_text())["runs"]
    row = min((r for r in runs if r["level"] == 0 and r["default_cap"]), key=lambda r: r["end_s"])
    assert row["end_s"] <= 0.01, "the committed JSON has no short level-0 run: run the benchmark with --end 0.005"
    # In a fresh process, as the benchmark runs it (one thread, as the committed run).
    env = {**os.environ, "RAYON_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    cmd = [sys.executable, str(ROOT / "benchmarks" / "bench_memory.py"), "--child", "0", str(row["end_s"]), "default", "none"]
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True)
    now = json.loads(done.stdout.strip().splitlines()[-1])
    for key in ("free_dofs", "steps", "steps_with_contact", "column_memory_mib", "loaded_columns", "stored_and_loaded"):
        assert now[key] == row[key], f"memory.json level 0, {row['end_s']} s: {key} committed {row[key]}, now {now[key]}"
    for key in ("nnz_factor", "nnz_factor_lower"):
        assert now["census"]["factor"][key] == row["census"]["factor"][key], key
    was, comp = row["census"]["compliance"], now["census"]["compliance"]
    for key in ("contact_dofs", "observed_dofs", "stored_columns", "stored_per_block", "block_rows", "cap_columns",
                "capped", "fallback_solves", "column_solves", "S_capacity"):
        assert comp[key] == was[key], f"memory.json level 0 compliance: {key} committed {was[key]}, now {comp[key]}"
    for key in ("stored_mb", "observed_rows_mb", "S_mb", "nbytes_mb"):
        assert comp[key] == pytest.approx(was[key], rel=1e-12), key
