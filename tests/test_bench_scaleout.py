"""The committed scale-out of the converge study (``benchmarks/bench_study_scaleout.py``,
``benchmarks/results/converged_answer/scale_out.{json,md}``): what is recomputed without running
is recomputed and compared exactly: the projected walls from the recorded per-run times (with
:func:`vfrs.studies.converge.projected_wall`), the committed full studies' projections and the
3 x 3 grid's estimates from their converge.json; and the window scene the benchmark writes
loads, without the limit-cycle keys. Wall times are never re-measured.

When a committed study changes on purpose, re-run the benchmark and commit its results.
"""

from __future__ import annotations

import json
import runpy
from pathlib import Path
from types import SimpleNamespace

import pytest

import vfrs
from vfrs._compat import tomllib
from vfrs.studies.converge import projected_wall

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "converged_answer"


@pytest.fixture(scope="module")
def bench():
    """The benchmark's functions and constants (its main not run)."""
    return SimpleNamespace(**runpy.run_path(str(ROOT / "benchmarks" / "bench_study_scaleout.py")))


@pytest.fixture(scope="module")
def committed():
    return json.loads((RESULTS / "scale_out.json").read_text())


def _times(runs: list) -> list:
    return [r["wall_time"] for r in runs]


def test_measured_projections_from_the_recorded_run_times(committed):
    assert set(committed["measured"]) == {"meshes", "steps"}
    md = (RESULTS / "scale_out.md").read_text()
    for st in committed["measured"].values():
        serial, dask, c = st["serial"], st["dask"], st["compare"]
        ts, td = _times(serial["runs"]), _times(dask["runs"])
        assert len(ts) == len(td) == 3 and dask["workers"] == 2
        assert [r["id"] for r in serial["runs"]] == [r["id"] for r in dask["runs"]]
        for w in ("1", "2", "16"):
            assert c["projected_s"][w] == projected_wall(ts, int(w))
            assert c["projected_from_dask_runs_s"][w] == projected_wall(td, int(w))
        assert (c["sum_s"], c["longest_s"]) == (sum(ts), max(ts))
        assert c["ratio"] == serial["wall_s"] / dask["wall_s"]
        assert c["dask_overhead_s"] == dask["wall_s"] - projected_wall(ts, 2)
        assert c["side_by_side_s"] + c["dask_rest_s"] == pytest.approx(c["dask_overhead_s"], abs=1e-9)
        assert (c["longest_on_dask_s"], c["dask_wall_past_longest_s"]) == (max(td), dask["wall_s"] - max(td))
        assert f"ratio **{c['ratio']:.2f}**" in md and f"**{c['dask_overhead_s']:.1f} s**" in md


def test_full_studies_projected_from_their_converge_json(bench, committed):
    full = committed["full"]
    runs = {}
    for axis, st in full["studies"].items():
        recorded = json.loads((ROOT / st["source"]).read_text())["runs"]
        runs[axis] = {(r["mesh_level"], r["step_level"]): r["wall_time"] for r in recorded}
        assert sorted(_times(st["runs"])) == sorted(runs[axis].values())
        assert st["projected_s"] == {w: projected_wall(list(runs[axis].values()), int(w)) for w in ("1", "2", "16")}
    mesh, step = runs["meshes"], runs["steps"]
    cells = {(c["mesh_level"], c["step_level"]): c for c in full["grid"]["cells"]}
    assert len(cells) == 9
    for (i, j), c in cells.items():
        if i == 0:
            assert c["known"] and c["wall_time"] == step[0, j]
        elif j == 0:
            assert c["known"] and c["wall_time"] == mesh[i, 0]
        else:
            assert not c["known"] and c["wall_time"] == mesh[i, 0] * step[0, j] / step[0, 0]
    known = [c["wall_time"] for c in cells.values() if c["known"]]
    every = [c["wall_time"] for c in cells.values()]
    g = full["grid"]
    assert g["known_projected_s"] == {w: projected_wall(known, int(w)) for w in ("1", "2", "16")}
    assert g["projected_s"] == {w: projected_wall(every, int(w)) for w in ("1", "2", "16")}
    # the known runs are those of the committed cross study, (0, 0) the step study's as there
    cross = json.loads((ROOT / "examples/converge_results/m5_steady/converge.json").read_text())["runs"]
    assert sorted(known) == sorted(_times(cross))
    # and the benchmark's own code gives the committed block
    assert json.loads(json.dumps(bench.full_studies(ROOT))) == full


def test_window_scene_loads_without_the_limit_cycle_keys(bench, committed, tmp_path):
    end = committed["end"]
    path = bench.write_window(tmp_path, end)
    with open(path, "rb") as fh:
        raw = tomllib.load(fh)
    assert not set(bench.LIMIT_CYCLE_KEYS) & set(raw["output"]) and raw["time"]["end"] == end
    window, main = vfrs.Scene.load(path), vfrs.Scene.load(bench.SCENE)
    assert main.output.until == "limit_cycle" and main.output.errors_from is not None  # there were keys to remove
    assert window.output.until == "end" and window.output.errors_from is None and window.time.end == end
    w, m = window.to_dict(), main.to_dict()
    m["time"]["end"] = end
    m["output"] = {k: v for k, v in m["output"].items() if k not in bench.LIMIT_CYCLE_KEYS}
    assert w == m
