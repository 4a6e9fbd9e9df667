"""vfrs converge --design cross and --take: the base run's error from 5 runs instead of 9, and
a study assembled from other studies' finished runs (a step study and a mesh study of one
scene make its cross study; what examples/converge_results/m5_steady is)."""

import csv

import pytest

import vfrs
from vfrs.cli import load_scene
from vfrs.studies import converge as cv

TIP = 'last(probes["probe_0.displacement"])[2]'
# tests/test_converge.py's cantilever: 6 x 2 x 2 cells, the load ramped over 20 ms, 40 ms
CANTILEVER = ["bodies[0].mesh.cells=[6, 2, 2]", "time.end=0.04", "output.every=10",
              "bodies[0].loads=[{ type = 'traction', surface = 'xmax', value = [0.0, 0.0, -50.0], ramp = 0.02 }]"]
KW = dict(quantities={"tip": TIP}, serial=True, figures=False, log=lambda m: None)


def cantilever():
    return load_scene("examples/cantilever.toml", CANTILEVER)


def test_the_cross_design_runs_the_base_mesh_at_every_step_and_the_base_step_on_every_mesh():
    p = cv.plan(cantilever(), design="cross")
    cells = sorted((r["mesh_level"], r["step_level"]) for r in p.runs)
    assert cells == [(0, 0), (0, 1), (0, 2), (1, 0), (2, 0)] and (p.base_mesh, p.base_step) == (0, 0)
    assert any(n.startswith("design cross") for n in p.notes)
    with pytest.raises(vfrs.VfrsError, match="--design diagonal"):
        cv.plan(cantilever(), design="diagonal")


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """A step study and a mesh study of the cantilever (5 distinct runs, the base run in both),
    and the grid study that takes their runs and runs the other 4."""
    root = tmp_path_factory.mktemp("cross")
    steps = cv.converge(cantilever(), root / "steps", meshes=1, **KW)
    meshes = cv.converge(cantilever(), root / "meshes", steps=1, **KW)
    said: list = []
    grid = cv.converge(cantilever(), root / "grid", take_from=[root / "steps", root / "meshes"],
                       **{**KW, "log": said.append})
    return root, steps, meshes, grid, said


def test_a_grid_study_takes_the_finished_runs_of_other_studies_and_runs_the_rest(studies):
    root, steps, meshes, grid, said = studies
    assert "0 finished before (skipped), 4 to run" in said[0]
    assert [n for n in grid.plan.notes if "taken from" in n] == [
        f"3 run(s) taken from the study in {root / 'steps'} (matched by run id: the same resolved scene), not run again",
        f"2 run(s) taken from the study in {root / 'meshes'} (matched by run id: the same resolved scene), not run "
        "again"]
    assert grid.study("derived.tip", "step", 0).values == steps.study("derived.tip", "step", 0).values
    assert grid.study("derived.tip", "mesh", 0).values == meshes.study("derived.tip", "mesh", 0).values
    with open(root / "grid" / "summary.csv", newline="") as fh:
        assert len(list(csv.DictReader(fh))) == 9


def test_the_cross_study_gives_the_base_run_the_grid_study_s_error_and_no_other_run_one(studies, tmp_path):
    root, _, _, grid, _ = studies
    cross = cv.converge(cantilever(), tmp_path / "cross", design="cross",
                        take_from=[root / "steps", root / "meshes"], **KW)
    assert not (tmp_path / "cross" / "runs").exists()  # every run taken, none run
    base = cross.error("derived.tip", 0, 0)
    assert base == grid.error("derived.tip", 0, 0) and base["relative"] > 0 and base["bound"]
    assert {(e["mesh_level"], e["step_level"]) for e in cross.errors} == {(0, 0), (0, 1), (0, 2), (1, 0), (2, 0)}
    assert all(e["relative"] is None for e in cross.errors if (e["mesh_level"], e["step_level"]) != (0, 0))
    study = cv.load(tmp_path / "cross")
    assert study["design"] == "cross"
    on_base = cv.plan(cantilever()).runs
    at = {(r["mesh_level"], r["step_level"]): r["scene"] for r in on_base}
    assert cv.errors_for(at[(0, 0)], study)["derived.tip"]["relative"] == base["relative"]
    assert cv.errors_for(at[(1, 0)], study) is None  # a run of the cross, but not its base
    assert "cross study" in cv.why_not(at[(1, 0)], study)
    assert "run(s) taken from" in cross.text()


def test_two_copies_of_a_run_that_disagree_are_refused(studies, tmp_path):
    """The base run is in both studies: when one copy's numbers differ (another build), the
    study is not assembled, and the message names the run, the builds and the numbers."""
    root = studies[0]
    with open(root / "steps" / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    column = "tip"  # the derived quantity's column
    for r in rows:
        if r["step"] == "h":
            r[column] = repr(float(r[column]) * (1 + 1e-6))
    changed = tmp_path / "steps"
    changed.mkdir()
    with open(changed / "summary.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with pytest.raises(vfrs.VfrsError, match=r"with different numbers .*tip "):
        cv.converge(cantilever(), tmp_path / "cross", design="cross", take_from=[changed, root / "meshes"], **KW)
    with pytest.raises(vfrs.VfrsError, match="no summary.csv"):
        cv.converge(cantilever(), tmp_path / "cross", design="cross", take_from=[tmp_path / "nothing"], **KW)
