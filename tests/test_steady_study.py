"""The main job's committed converge study (issue 45, item 5): examples/converge_results/m5_steady,
the cross study of examples/m5_steady.toml (level 0 at 50 / 25 / 12.5 us, levels 0 / 1 / 2 at
50 us) assembled by `vfrs converge --design cross --take` from its step study
(m5_steady_steps) and its mesh study (m5_steady_meshes). Its runs are today's scene's, its
errors follow from its table, the scene names it, and what the README and docs/results.md
quote is in it. The base run itself is re-run by tests/test_steady_phonation.py."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import vfrs
from vfrs.studies import converge as cv
from vfrs.studies.sweep import run_id_of

from study_tables import check_printed_errors, printed_block, recomputed_errors
from study_tables import num as _num
from study_tables import rows as _rows

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "m5_steady.toml"
RESULTS = ROOT / "examples" / "converge_results"
STUDY = RESULTS / "m5_steady"
PARTS = {"m5_steady_steps": "--meshes 1", "m5_steady_meshes": "--steps 1"}


@pytest.fixture(scope="module")
def plan():
    return cv.plan(vfrs.Scene.load(SCENE), design="cross")


def test_the_study_s_runs_are_today_s_scene_s_cross(plan):
    """The 5 runs of the committed study are the cross plan of today's scene (the same ids: the
    same resolved scenes), and each is the row of the step or the mesh study it was taken from
    (the base run in both, with the same numbers)."""
    committed = {(r["mesh"], r["step"]): r["id"] for r in _rows(STUDY)}
    now = {(r["labels"]["mesh"], r["labels"]["step"]): run_id_of(r["scene"]) for r in plan.runs}
    assert committed == now and len(now) == 5
    parts = {name: {r["id"]: r for r in _rows(RESULTS / name)} for name in PARTS}
    for row in _rows(STUDY):
        copies = [p[row["id"]] for p in parts.values() if row["id"] in p]
        assert copies, row["id"]
        for copy in copies:
            for key, value in row.items():
                if key.startswith(("phonation.", "contact.")) and _num(value) is not None:
                    assert _num(copy[key]) == pytest.approx(_num(value), rel=1e-9), (row["id"], key)
    base = {r["mesh"]: r for r in _rows(STUDY) if r["step"] == "h"}["level 0"]["id"]
    assert all(base in p for p in parts.values())


def test_the_errors_follow_from_the_committed_runs(plan):
    """converge.json's errors are what vfrs.studies.converge computes from the committed table
    (only the base run has them: the cross design)."""
    study = json.loads((STUDY / "converge.json").read_text())
    assert study["design"] == "cross"
    errors = recomputed_errors(plan, STUDY, study)
    committed = {(e["quantity"], e["mesh_level"], e["step_level"]): e["relative"] for e in study["errors"]}
    assert len(errors) == len(committed)
    for e in errors:
        was = committed[(e["quantity"], e["mesh_level"], e["step_level"])]
        if was is None or e["relative"] is None or not math.isfinite(was):
            assert (was is None or not math.isfinite(was)) == (e["relative"] is None or not math.isfinite(e["relative"]))
        else:
            assert e["relative"] == pytest.approx(was, rel=1e-9), e["quantity"]
        if (e["mesh_level"], e["step_level"]) != (0, 0):
            assert e["relative"] is None


def test_the_main_job_names_its_study_and_gets_its_errors():
    scene = vfrs.Scene.load(SCENE)
    assert Path(scene.output.errors_from).resolve() == STUDY.resolve()
    errors = cv.errors_for(scene.to_dict(), cv.load(STUDY))
    assert errors is not None and errors["phonation.f0"]["relative"] is not None


def test_the_main_job_s_printout_in_docs_results_carries_the_study_s_errors():
    """docs/results.md's block of the main job: every percentage and "band" is the committed
    study's error of that number at the base run, as Quantity.text prints it."""
    doc = (ROOT / "docs" / "results.md").read_text()
    block = printed_block(doc, "The main job, `vfrs run examples/m5_steady.toml")
    study = cv.load(STUDY)
    errors = cv.errors_for(vfrs.Scene.load(SCENE).to_dict(), study)
    assert check_printed_errors(block, study, errors) >= 30
