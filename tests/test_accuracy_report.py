"""The accuracy-cost report: numbers are computed, the Pareto front is right."""

import json

import numpy as np
import pytest

from vfrs.studies.accuracy import pareto_front, run_accuracy
from vfrs.studies.accuracy import AccuracyReport, Row, grid_cells, recommend, run_row
from vfrs.studies.accuracy.problems import PROBLEMS


def test_pareto_front_of_a_hand_made_table():
    #            a     b     c     d     e     f (nan)  g (= b)
    cost = [1.0, 2.0, 3.0, 4.0, 2.5, np.nan, 2.0]
    error = [0.5, 0.1, 0.2, 0.01, 0.1, 0.0, 0.1]
    # a: cheapest; b, g: same point, both optimal; e: same error as b but dearer; c: beaten
    # by b; d: most accurate; f: not finite.
    assert pareto_front(cost, error).tolist() == [True, True, False, True, False, False, True]
    assert pareto_front([], []).tolist() == []


def _row(setting, level, step, error, wall, failed=""):
    return Row("toy", setting, "penalty", level, step, error, wall, failed=failed)


def test_recommendation_needs_the_next_finer_cells_to_agree():
    # Levels "a" < "b", steps 2 > 1. "noisy" is cheapest under 1 % at (a, 2) but 3 % at the
    # next finer step; "lonely" is under 1 % only in the finest cell, which nothing confirms;
    # "solid" is under 1 % at (a, 2) and at both next finer cells (b, 2) and (a, 1).
    noisy = [_row("noisy", "a", 2.0, 0.005, 1.0), _row("noisy", "a", 1.0, 0.03, 2.0), _row("noisy", "b", 2.0, 0.008, 3.0)]
    lonely = [_row("lonely", "a", 2.0, 0.2, 0.1), _row("lonely", "b", 1.0, 0.001, 0.5)]
    solid = [_row("solid", "a", 2.0, 0.009, 1.5), _row("solid", "a", 1.0, 0.005, 3.0), _row("solid", "b", 2.0, 0.004, 4.0),
             _row("solid", "b", 1.0, 0.02, 8.0)]
    rows = noisy + lonely + solid
    text = recommend("toy", rows, 0.01, levels=["a", "b"])
    assert text.startswith("toy: for 1% error use solid at a, h = 2: error 0.90%"), text
    assert "0.40% on the next finer mesh b" in text and "0.50% at the next finer step h = 1" in text, text
    # The same through the report (levels in order of appearance for an unknown problem).
    assert AccuracyReport(rows, "full", 0.0).recommendation("toy") == text

    text = recommend("toy", noisy + lonely, 0.01, levels=["a", "b"])
    assert text.startswith("toy: no robust recommendation for 1% error:"), text
    assert "noisy at a, h = 2: 0.50%, but 3.00% at the next finer step h = 1" in text, text
    assert "lonely at b, h = 1: 0.10%, but nothing finer in the table confirms it" in text, text
    assert "see the table" in text

    # A failed finer cell confirms nothing either.
    failed = [_row("f", "a", 2.0, 0.001, 1.0), _row("f", "b", 2.0, float("nan"), float("nan"), failed="ConvergenceError")]
    assert "failed (ConvergenceError) on the next finer mesh b" in recommend("toy", failed, 0.01, levels=["a", "b"])

    # Nothing under the target, or a reference that moves more than the target: no recommendation.
    text = recommend("toy", rows, 0.0005)
    assert text.startswith("toy: no robust recommendation for 0.05% error: no setting reached it; the most accurate "
                           "was lonely at b, h = 1 (0.10%, 0.50 s)"), text
    text = recommend("toy", rows, 0.01, levels=["a", "b"], reference_spread=0.05, spread_note="from b to a")
    assert text == ("toy: no robust recommendation for 1% error: the reference itself moves by 5.0% from b to a, "
                    "more than the target, so errors that small are not resolved; see the table.")


def test_the_reference_error_bar_is_the_larger_of_its_two_checks():
    """A problem scored against one reference run (m5_finite): no recommendation for a target
    below how far the reference moves to its coarser mesh or to its larger step (whichever is
    more), one recommendation per target of the problem."""
    rows = [Row("m5_finite", s, "lagrange", lv, h, e, w) for s, lv, h, e, w in [
        ("a", "coarse", 2e-5, 0.04, 1.0), ("a", "coarse", 1e-5, 0.03, 2.0), ("a", "medium", 2e-5, 0.02, 5.0),
        ("a", "medium", 1e-5, 0.01, 9.0)]]
    ref = {"kind": "run", "level": "fine", "step": 5e-6, "metrics": {"impulse": 1.0, "peak_force": 1.0},
           "check": {"level": "medium", "step": 5e-6, "change": 0.02},
           "step_check": {"level": "fine", "step": 1e-5, "change": 0.03}}
    rep = AccuracyReport(rows, "full", 0.0, {"m5_finite": ref})
    assert rep.reference_spread("m5_finite") == (0.03, "from h = 5e-06 to h = 1e-05 on the same mesh")
    assert rep.targets("m5_finite") == PROBLEMS["m5_finite"].targets == (0.01, 0.05)
    one, five = rep.recommendation("m5_finite", 0.01), rep.recommendation("m5_finite", 0.05)
    assert one == ("m5_finite: no robust recommendation for 1% error: the reference itself moves by 3.0% from "
                   "h = 5e-06 to h = 1e-05 on the same mesh, more than the target, so errors that small are not "
                   "resolved; see the table.")
    assert five.startswith("m5_finite: for 5% error use a at coarse, h = 2e-05: error 4.00%"), five
    assert rep.recommendation("m5_finite") == one + " " + five
    ref["check"]["change"] = 0.06  # now the mesh moves it more than 5 %
    assert "moves by 6.0% from the fine to the medium mesh at the same step" in rep.recommendation("m5_finite", 0.05)


def test_an_extrapolated_reference_recovers_the_limit_and_says_how_sure_it_is():
    """The M5 reference is a study (three meshes, three steps): on values with a known limit
    and order (phi = 10 + 3 h^2 on the meshes, + 0.5 dt on the steps) the estimate returns the
    limit the two axes extrapolate (10 + 3 h1^2 - 3 h1^2 + ... : the finest run corrected on
    both axes) with a GCI bound; an oscillatory axis gives a band about the finest run, not a
    bound, and shifts nothing."""
    from vfrs.studies.accuracy.reference import estimate

    hm, hs = [4.0, 2.0, 1.0], [4e-5, 2e-5, 1e-5]
    finest = 10.0 + 3.0 * 1.0 + 0.5 * 1e-5 * 1e5  # the shared finest run: mesh 1, step 1e-5
    mesh = [10.0 + 3.0 * h * h + 0.5 for h in hm]
    step = [10.0 + 3.0 + 0.5 * dt * 1e5 for dt in hs]
    assert mesh[-1] == step[-1] == finest
    e = estimate(mesh, hm, step, hs)
    assert e.mesh.kind == e.step.kind == "monotone" and e.bound
    assert e.mesh.order == pytest.approx(2.0, abs=1e-9) and e.step.order == pytest.approx(1.0, abs=1e-9)
    assert e.value == pytest.approx(10.0, rel=1e-12)  # both errors removed
    # the band: finest +- (GCI_mesh + GCI_step) |finest|; the value's distance to its far edge
    g = 1.25 * 9.0 / (2 ** 2 - 1) + 1.25 * 0.5 / (2 ** 1 - 1)  # Fs |e21| / (r^p - 1), each axis
    assert (e.low, e.high) == (pytest.approx(finest - g), pytest.approx(finest + g))
    assert e.uncertainty == pytest.approx((finest + g - 10.0) / 10.0)
    osc = estimate([12.0, 14.0, 13.5], hm, [13.3, 13.45, 13.5], hs)
    assert osc.mesh.kind == "oscillatory" and not osc.bound
    gs = 1.25 * abs(osc.step.e21) / (2 ** osc.step.order - 1)  # the step axis's GCI band (absolute)
    assert osc.value == pytest.approx(osc.step.extrapolated)  # the mesh axis shifts nothing
    assert (osc.low, osc.high) == (pytest.approx(12.0 - gs), pytest.approx(14.0 + gs))
    # the step ladder on a coarser mesh: its extrapolation shifts the finest mesh's run by as much
    other = estimate(mesh, hm, [v + 1.0 for v in step], hs)
    assert other.value == pytest.approx(e.value) and (other.low, other.high) == (pytest.approx(e.low), pytest.approx(e.high))


def test_a_study_reference_recommends_per_metric_with_its_uncertainty_and_per_family():
    """Against an extrapolated reference a row's error plus the reference's uncertainty must
    be under the target, in the row and in its next finer cells (the next mesh of its own
    family: coarse graded is confirmed by medium graded, not by medium)."""
    def row(s, lv, h, imp, force, w):
        return Row("m5", s, "lagrange", lv, h, imp, w, metrics={"peak_force_error": force, "pressure_error": 0.5})

    rows = [row("lagrange", "coarse", 2e-5, 0.09, 0.01, 1.0), row("lagrange", "coarse", 1e-5, 0.08, 0.005, 2.0),
            row("lagrange", "medium", 2e-5, 0.02, 0.02, 5.0), row("lagrange", "medium", 1e-5, 0.01, 0.005, 9.0),
            row("lagrange", "coarse graded", 2e-5, 0.03, 0.03, 1.5), row("lagrange", "coarse graded", 1e-5, 0.03, 0.03, 3.0),
            row("lagrange", "medium graded", 2e-5, 0.03, 0.03, 6.0), row("lagrange", "medium graded", 1e-5, 0.03, 0.03, 12.0)]
    ref = {"kind": "study", "method": "lagrange", "quantities": {
        "impulse": {"value": 1.0, "uncertainty": 0.015, "bound": True},
        "peak_force": {"value": 1.0, "uncertainty": 0.04, "bound": True},
        "peak_pressure": {"value": 1.0, "uncertainty": 0.3, "bound": False}}}
    rep = AccuracyReport(rows, "full", 0.0, {"m5": ref})
    ten = rep.recommendation("m5", 0.10)
    assert ("m5: for 10% error on the contact impulse use lagrange at coarse, h = 2e-05: error 9.00% + the "
            "reference's 1.50% (bound) = 10.50%") not in ten  # 9 % + 1.5 % is over 10 %
    assert ("for 10% error on the contact impulse use lagrange at coarse graded, h = 2e-05: error 3.00% + the "
            "reference's 1.50% (bound) = 4.50%, 1.50 s wall (confirmed: 4.50% on the next finer mesh medium graded "
            "and 4.50% at the next finer step h = 1e-05)") in ten, ten
    assert "for 10% error on the peak contact force use lagrange at coarse, h = 2e-05: error 1.00% + the reference's 4.00%" in ten
    assert ("no robust recommendation for 10% error on the peak pressure on a 1 mm^2 sensor: the extrapolated "
            "reference is itself uncertain by 30.0% (band, not a bound)") in ten
    five = rep.recommendation("m5", 0.05)
    # 1 % + 4 % at (coarse, 2e-5), but 6 % on the medium mesh: the step below, confirmed by medium alone
    assert ("for 5% error on the peak contact force use lagrange at coarse, h = 1e-05: error 0.50% + the reference's 4.00% (bound) = 4.50%, 2.00 s wall (confirmed: 4.50% on the next finer mesh medium)") in five, five
    two = rep.recommendation("m5", 0.02)
    assert "no robust recommendation for 2% error on the peak contact force: the extrapolated reference is itself uncertain by 4.0%" in two
    assert "no robust recommendation for 2% error on the contact impulse:" in two  # 0.01 + 0.015 > 0.02
    assert rep.reference_spread("m5") == (None, "")


def test_the_study_is_outside_the_grid_and_the_grid_has_a_graded_axis():
    """The M5 reference study: the medium, fine and finer uniform meshes at half the grid's
    smallest step, three steps on the fine mesh, the graded family as a cross-check; no grid
    cell is one of its runs; the graded rows run three settings, the refactoring path one
    cell; "finer" is fine refined by 1.5 per axis."""
    m5 = PROBLEMS["m5"]()
    study = m5.reference_study("full")
    assert study.meshes == ("medium", "fine", "finer") and study.mesh_step == 6.25e-6
    assert study.steps == (25e-6, 12.5e-6, 6.25e-6) and study.step_level == "fine"
    assert study.cross == ("coarse graded", "medium graded", "fine graded")
    runs = {(lv, h) for lv, h in study.cells()}
    assert len(runs) == 8
    finer = m5.scene({"method": "lagrange"}, "finer", 6.25e-6)["bodies"][0]["mesh"]
    assert finer["cells"] == [72, 18, 30] and "resolution" not in finer
    grid = grid_cells("full", "m5")
    assert not runs & {(str(lv), h) for _, _, lv, h in grid}
    assert all(h > study.mesh_step for _, _, _, h in grid)
    graded = {label for label, _, lv, _ in grid if lv.endswith(" graded")}
    assert graded == set(m5.graded_settings)
    assert [(lv, h) for label, _, lv, h in grid if label.endswith("refactor")] == [("medium", 25e-6)]
    scene = m5.scene({"method": "lagrange"}, "medium graded", 25e-6)
    assert all(b["mesh"]["resolution"] == "medium" and b["mesh"]["contact_zone"] == 3e-3 for b in scene["bodies"])
    assert PROBLEMS["m5_finite"]().reference_study("full") is None


def test_m5_scores_the_impulse_of_the_first_closure():
    """The M5 error is that of the medio-lateral contact impulse over the window (the graze of
    the pressure ramp before it is left out); the peak force is still measured."""
    class Res:
        pass

    m5 = PROBLEMS["m5"]()
    h = 1e-4
    t = np.arange(0.0, m5.end + h / 2, h)
    f = np.zeros((t.size, 3))
    f[(t > 2e-3) & (t < 2.5e-3), 0] = -0.05  # a graze before the window: 0.05 N for 0.5 ms
    f[(t > 9.5e-3) & (t < 12.5e-3), 0] = -0.01  # the closure: 0.01 N for 3 ms
    res = Res()
    res.history = {"t": t, "contact_force.right": f, "contact_area": np.ones_like(t), "intersection_volume": 0 * t}
    m = m5.measure(res)
    assert m["impulse"] == pytest.approx(0.01 * 3e-3, rel=0.05) and m["peak_force"] == 0.05
    assert np.isnan(m["error"])
    m = m5.measure(res, {"impulse": 0.5 * m["impulse"], "peak_force": 0.05, "max_area": 1.0})
    assert m["error"] == pytest.approx(1.0) and m["peak_force_error"] == 0.0


@pytest.mark.parametrize("mode", ["quick", "full"])
def test_no_problem_is_scored_against_itself(mode):
    """Closed forms, an extrapolated limit (M5: a study whose runs are no row of the grid), or
    (m5_finite) a reference run on a finer mesh with a smaller step than every row."""
    for name, cls in PROBLEMS.items():
        p = cls()
        assert p.reference_text(mode)
        if not hasattr(p, "reference_setting"):
            assert p.reference_text(mode).startswith("Exact, no run"), name
            continue
        study = p.reference_study(mode)
        if study is not None:
            grid = {(str(lv), h) for _, _, lv, h in grid_cells(mode, name)}
            assert not grid & set(study.cells()) and all(h > study.mesh_step for _, h in grid), (name, mode)
            continue
        contact, level, step = p.reference_setting(mode)
        rank = p.all_levels.index
        for label, _, lv, h in grid_cells(mode, name):
            assert rank(lv) < rank(level) and h > step, (name, mode, label, lv, h, level, step)
        check = p.reference_check_setting(mode)
        assert check[2] == step and rank(check[1]) == rank(level) - 1
        check = p.reference_step_check_setting(mode)  # its other finest cell: twice the step, same mesh
        assert check[1] == level and check[2] == 2 * step
    finite = PROBLEMS["m5_finite"]()
    assert finite.reference_setting("full") == ({"method": "lagrange"}, "medium", 25e-6)


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
    assert md.count("**Reference.** Exact, no run") == 2
    assert set(data["references"]) == {"block", "bars"} and data["provenance"]["commit"]
    back = AccuracyReport.load(out)
    assert [(r.setting, r.level, r.step, r.error) for r in back.rows] == [(r.setting, r.level, r.step, r.error) for r in rep.rows]


def test_one_row_reruns_to_the_same_numbers(report):
    """run_row (in this process) and the report (a task of its sweep, measured from the run's
    folder) share the scene and the measurement: the same numbers, bit for bit."""
    rep, _ = report
    for r in (rep.table("block")[2], rep.table("bars")[-1], rep.table("bars")[3]):
        again = run_row(r.problem, r.setting, r.level, r.step, mode="quick")
        assert again.error == r.error and again.metrics == r.metrics, (r.setting, r.level)
    with pytest.raises(KeyError, match="no row"):
        run_row("block", "penalty k=1e+07", "(2, 2, 2)", None, mode="quick")


def test_cli_writes_the_report(tmp_path, capsys):
    from vfrs.cli import main

    assert main(["bench", "accuracy", "--quick", "--problem", "block", "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "block: for 1% error use" in out
    assert (tmp_path / "accuracy.md").exists() and (tmp_path / "pareto_block.png").exists()


def test_the_report_is_a_sweep_of_run_folders(report, monkeypatch, tmp_path):
    """Every row is a task of one sweep: its run folder (history, clocks, peak memory) under
    out/sweep, ignored by git; running the report again runs nothing and gives the same table;
    another vfrs build runs everything again (no stale runs in a regenerated report)."""
    import pyarrow.parquet as pq

    import vfrs.studies.sweep as sw

    rep, out = report
    table = pq.read_table(out / "sweep" / "summary.parquet").to_pydict()
    assert len(table["id"]) == len(rep.rows) and set(table["status"]) == {"complete"}
    assert set(table["role"]) == {"row"} and set(table["problem"]) == {"block", "bars"}  # exact references: no run
    assert (out / "sweep" / ".gitignore").read_text() == "*\n"
    for r in rep.rows:
        rec = json.loads((out / "sweep" / "runs" / r.run / sw.RUN_FILE).read_text())
        assert rec["params"]["setting"] == r.setting and rec["params"]["level"] == r.level
        assert r.peak_memory_mb == rec["peak_rss_mb"] > 20  # MB: at least Python and numpy
        own = rec["timings"]["total"] - rec["timings"]["output"] - rec["timings"].get("checkpoint", 0.0)
        assert r.wall == pytest.approx(own, rel=1e-12)  # the run's own time: no file writing
        assert rec["vfrs"]["code"] == sw.code_id()
    assert json.loads((out / "accuracy.json").read_text())["provenance"]["engine"]["workers"] == 1

    again = run_accuracy("quick", problems=["block", "bars"], out=str(tmp_path / "again"), progress=False, serial=True,
                         runs=str(out / "sweep"))
    assert [(r.setting, r.level, r.error, r.wall) for r in again.rows] == [(r.setting, r.level, r.error, r.wall)
                                                                          for r in rep.rows]
    assert all(pq.read_table(out / "sweep" / "summary.parquet").to_pydict()["skipped"])

    ran = []
    real = sw.task._run_scene
    monkeypatch.setattr(sw.task, "code_id", lambda: "another-build")
    monkeypatch.setattr(sw.task, "_run_scene", lambda scene, folder: ran.append(1) or real(scene, folder))
    other = run_accuracy("quick", problems=["block"], out=str(tmp_path / "other"), progress=False, serial=True,
                         runs=str(out / "sweep"))
    assert len(ran) == len(other.rows) == len(rep.table("block"))
    assert [r.error for r in other.rows] == [r.error for r in rep.table("block")]


def test_pareto_figure_is_drawn_from_the_table(report, tmp_path):
    """The figure the report writes comes from accuracy.parquet: drawn again from the table
    it is the same image as from the rows in memory, and a table with other numbers gives
    another image."""
    import pyarrow.parquet as pq

    from vfrs.studies.accuracy import pareto_figure

    rep, out = report
    rep.plot("bars", tmp_path / "from_rows.png")
    assert (out / "pareto_bars.png").read_bytes() == (tmp_path / "from_rows.png").read_bytes()
    table = pq.read_table(out / "accuracy.parquet").to_pydict()
    table["error"] = [e * 10 for e in table["error"]]
    pareto_figure(table, "bars", tmp_path / "changed.png")
    assert (tmp_path / "changed.png").read_bytes() != (out / "pareto_bars.png").read_bytes()
    with pytest.raises(ValueError, match="no rows of problem 'hertz'.*'bars', 'block'"):
        pareto_figure(table, "hertz", tmp_path / "none.png")


def test_cli_refuses_contradictory_engine_options(tmp_path, capsys):
    from vfrs.cli import main

    assert main(["bench", "accuracy", "--quick", "--problem", "block", "--serial", "--workers", "2",
                 "-o", str(tmp_path)]) == 2
    assert "--serial runs in this process" in capsys.readouterr().err
    assert main(["bench", "accuracy", "--quick", "--problem", "block", "--workers", "0", "-o", str(tmp_path)]) == 2
    assert "--workers 0: expected 1 or more" in capsys.readouterr().err
    assert not (tmp_path / "accuracy.md").exists()
