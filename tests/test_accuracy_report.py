"""The accuracy-cost report: numbers are computed, the Pareto front is right."""

import json

import numpy as np
import pytest

from vfrs.bench import pareto_front, run_accuracy


def test_pareto_front_of_a_hand_made_table():
    #            a     b     c     d     e     f (nan)  g (= b)
    cost = [1.0, 2.0, 3.0, 4.0, 2.5, np.nan, 2.0]
    error = [0.5, 0.1, 0.2, 0.01, 0.1, 0.0, 0.1]
    # a: cheapest; b, g: same point, both optimal; e: same error as b but dearer; c: beaten
    # by b; d: most accurate; f: not finite.
    assert pareto_front(cost, error).tolist() == [True, True, False, True, False, False, True]
    assert pareto_front([], []).tolist() == []


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("accuracy")
    return run_accuracy("quick", problems=["block", "bars"], out=str(out), progress=False), out


def test_every_row_is_measured(report):
    rep, _ = report
    assert len(rep.rows) >= 16
    for r in rep.rows:
        assert not r.failed, r.failed
        assert r.wall > 0 and np.isfinite(r.error), (r.setting, r.level)
        assert r.timings.get("total", 0) > 0


def test_errors_fall_as_resolution_rises_and_with_kappa(report):
    rep, _ = report
    lag = [r for r in rep.table("bars") if r.method == "lagrange"]
    errors = [r.error for r in sorted(lag, key=lambda r: int(r.level))]
    assert errors[-1] < errors[0]
    block = {r.setting: r.error for r in rep.table("block") if r.level == "(2, 2, 2)"}
    assert block["lagrange"] < 1e-9  # exact for uniform stress
    assert block["penalty k=1e+10"] < block["penalty k=1e+06"]
    assert block["AL N=4 k0=1e+06"] < block["AL N=1 k0=1e+06"]


def test_outputs_are_written(report):
    rep, out = report
    for name in ("accuracy.csv", "accuracy.json", "accuracy.md", "pareto_block.png", "pareto_bars.png"):
        assert (out / name).exists(), name
    data = json.loads((out / "accuracy.json").read_text())
    assert len(data["rows"]) == len(rep.rows)
    md = (out / "accuracy.md").read_text()
    assert "Recommendation" in md and "Pareto" in md


def test_cli_writes_the_report(tmp_path, capsys):
    from vfrs.cli import main

    assert main(["bench", "accuracy", "--quick", "--problem", "block", "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "block: for 1% error use" in out
    assert (tmp_path / "accuracy.md").exists() and (tmp_path / "pareto_block.png").exists()
