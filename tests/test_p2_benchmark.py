"""The committed P1-vs-P2 comparison (issue 47, item 4; ``benchmarks/bench_p2.py``,
``benchmarks/results/p2/p1_vs_p2.{csv,json}``) is the code's: two of its cheapest rows are re-run
(the P2 level-0 fold deflection, about 7 s, and the P2 four-cell Hertz block, under 1 s) and
compared with the CSV, and the JSON's limits, errors and costs are recomputed from the CSV's
rows (never a wall time re-measured). docs/performance.md and docs/accuracy.md quote the JSON.

When the code changes these numbers on purpose, re-run the benchmark and commit its results.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "p2"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_p2", ROOT / "benchmarks" / "bench_p2.py")
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def committed(bench):
    rows = bench.read_csv(RESULTS / "p1_vs_p2.csv")
    data = json.loads((RESULTS / "p1_vs_p2.json").read_text())
    return rows, data


def _row(rows, problem, order, size):
    return next(r for r in rows if (r["problem"], r["order"], r["size"]) == (problem, order, size))


@pytest.mark.parametrize("problem,order,size", [("deflection", 2, 0), ("hertz", 2, 4), ("hertz", 1, 8)])
def test_row_is_reproduced(bench, committed, problem, order, size):
    rows, _ = committed
    row = _row(rows, problem, order, size)
    now = bench.measure(problem, order, size)
    assert now["dofs"] == row["dofs"] and now["free_dofs"] == row["free_dofs"]
    for q in bench.QUANTITIES[problem]:
        assert now[q] == pytest.approx(row[q], rel=1e-6), f"p1_vs_p2.csv {problem} P{order} {size}: {q}"


def test_every_case_has_a_row_from_one_commit(bench, committed):
    rows, data = committed
    keys = {(r["problem"], r["order"], r["size"]) for r in rows}
    assert keys == {(p, o, s) for p, cases in bench.CASES.items() for o, s in cases}
    assert {r["commit"] for r in rows} == {data["commit"]} and len(data["commit"]) == 40
    for r in rows:
        if r["status"] == "ok":
            assert r["wall_s"] > 0 and r["peak_rss_mb"] > r["base_rss_mb"] > 0
            assert all(r[q] is not None for q in bench.QUANTITIES[r["problem"]])
        else:  # not run, with its reason
            assert r["status"].startswith(("not run:", "stopped at", "failed")), r["status"]
    assert sorted((x["problem"], x["order"], x["size"]) for x in data["not_run"]) == sorted(
        (r["problem"], r["order"], r["size"]) for r in rows if r["status"] != "ok")


def test_json_is_recomputed_from_the_csv(bench, committed):
    """The JSON's analysis is the CSV's, and each row's error is its distance to the OTHER
    order's stored limit (never a limit made from its own order)."""
    rows, data = committed
    assert json.loads(json.dumps(bench.analyse(rows))) == data["problems"]
    for problem, p in data["problems"].items():
        for q, qd in p["quantities"].items():
            for order in (1, 2):
                ref = qd["limits"][f"P{3 - order}"]["value"]
                for e in qd["errors"][f"P{order}"]:
                    value = _row(rows, problem, order, e["size"])[q]
                    assert e["value"] == value
                    assert e["error"] == pytest.approx(abs(value - ref) / abs(ref), rel=1e-12)
            for t in data["targets"]:
                ratio = qd["costs"][f"P2/P1 wall at {t:.0%}"]["interpolated"]
                w1, w2 = (qd["costs"][o][f"{t:.0%}"]["wall_s"] for o in ("P1", "P2"))
                assert ratio is None or ratio == pytest.approx(w2 / w1, rel=1e-12)


def test_limits_use_the_three_finest_runs(bench, committed):
    """An order with three or more runs is extrapolated from its three finest (Celik et al.'s
    procedure, vfrs.studies.verification.verify), the Hertz limits also stated against the
    half-space formula."""
    from vfrs.studies.verification import verify

    rows, data = committed
    for problem, p in data["problems"].items():
        for q, qd in p["quantities"].items():
            for order in (1, 2):
                runs = sorted((r for r in rows if r["problem"] == problem and r["order"] == order and r["status"] == "ok"),
                              key=lambda r: -bench.mesh_size(problem, r["size"]))
                lim = qd["limits"][f"P{order}"]
                if len(runs) < 3:
                    assert not lim["extrapolated"] and lim["value"] == runs[-1][q]
                    continue
                v = verify([r[q] for r in runs[:-4:-1]], [bench.mesh_size(problem, r["size"]) for r in runs[:-4:-1]])
                assert lim["kind"] == v.kind
                assert lim["value"] == (v.extrapolated if v.kind == "monotone" else v.value)
    F = data["problems"]["hertz"]["quantities"]["F_N"]
    for k in ("P1", "P2"):
        assert F["limits_vs_half_space"][k] == pytest.approx(F["limits"][k]["value"] / data["hertz_half_space"]["F_N"] - 1)


def test_docs_quote_the_committed_comparison(committed):
    """docs/performance.md and docs/accuracy.md name the benchmark, its figure and the JSON's
    headline numbers."""
    _, data = committed
    perf = " ".join((ROOT / "docs" / "performance.md").read_text().split())
    acc = " ".join((ROOT / "docs" / "accuracy.md").read_text().split())
    for page in (perf, acc):
        assert "benchmarks/bench_p2.py" in page and "p1_vs_p2.json" in page
    assert "error_vs_cost.png" in perf
    assert data["commit"][:7] in perf and data["commit"][:7] in acc
    F = data["problems"]["hertz"]["quantities"]["F_N"]["limits_vs_half_space"]
    for k in ("P1", "P2"):
        assert f"{100 * F[k]:+.1f} %" in acc, f"docs/accuracy.md: the Hertz {k} limit {100 * F[k]:+.1f} %"
    for problem in ("deflection", "press", "modes"):
        qd = data["problems"][problem]["quantities"][data["problems"][problem]["principal"]]
        for o in ("P1", "P2"):
            for e in qd["errors"][o]:
                if e["error"] is not None and math.isfinite(e["error"]):
                    assert f"{100 * e['error']:.1f} %" in acc or f"{100 * e['error']:.2f} %" in acc, (
                        f"docs/accuracy.md: {problem} {o} size {e['size']}: {100 * e['error']:.2f} %")
