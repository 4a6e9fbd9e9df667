"""The committed converge studies of the main job (examples/converge_results/: m5_collision on
the generator's meshes, m5_collision_graded on meshes graded toward the contact zone;
docs/results.md): each study's runs are the main job's, its cheapest run re-run against the
code, and its errors recomputed from its committed table of runs."""

import json
import math
from pathlib import Path

import pytest

import vfrs
from vfrs.studies import converge as cv
from vfrs.cli import load_scene
from vfrs.studies.sweep import flatten_summary, run_id_of

from study_tables import num, recomputed_errors, rows

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "examples" / "converge_results"
GRADED = [f"bodies[{b}].mesh.{kv}" for b in (0, 1)
          for kv in ("contact_zone=3e-3", "contact_zone_z=10e-3", "zone_ratio=1.2", "medial_ratio=1.2")]
STUDIES = {"m5_collision": [], "m5_collision_graded": GRADED}


def _plan(name: str):
    # The committed studies were made on the generator's resolutions (coarse / medium / fine),
    # not on the systematic family that is now the default ladder: their plan is --mesh-ladder levels.
    return cv.plan(load_scene(ROOT / "examples" / "m5_collision.toml", STUDIES[name]), mesh_how="levels")


def _rows(name: str) -> list:
    return rows(RESULTS / name)


@pytest.mark.parametrize("name", list(STUDIES))
def test_the_study_is_of_the_main_job_as_committed(name):
    """Every run of the committed study is a run of today's examples/m5_collision.toml (the
    same ids: the same resolved scenes)."""
    plan = _plan(name)
    committed = {(r["mesh"], r["step"]): r["id"] for r in _rows(name)}
    now = {(r["labels"]["mesh"], r["labels"]["step"]): run_id_of(r["scene"]) for r in plan.runs}
    assert now == committed


@pytest.mark.parametrize("name", list(STUDIES))
def test_cheapest_run_is_reproduced(name):
    """The coarse mesh at the scene's step (about 5 s), re-run: every number of its summary as
    committed (to 1e-9 relative: the same bits on the same kind of CPU, docs/results.md)."""
    plan = _plan(name)
    spec = next(r for r in plan.runs if r["labels"] == {"mesh": "coarse", "step": "h"})
    res = vfrs.run(vfrs.Scene.from_dict(spec["scene"]), progress=False)
    now = flatten_summary(res.results.to_dict())
    row = next(r for r in _rows(name) if r["mesh"] == "coarse" and r["step"] == "h")
    bad = []
    for key, value in now.items():
        if key.startswith("run.") or not isinstance(value, float) or key not in row:
            continue
        was = num(row[key])
        if was is None or not math.isclose(was, value, rel_tol=1e-9, abs_tol=1e-300):
            bad.append((key, was, value))
    assert not bad, bad


@pytest.mark.parametrize("name", list(STUDIES))
def test_studies_follow_from_the_committed_runs(name):
    """converge.json's errors are what vfrs.studies.converge computes from the committed table of runs
    (the analysis of the study, not only its runs, is the code's)."""
    study = json.loads((RESULTS / name / "converge.json").read_text())
    plan = _plan(name)
    errors = recomputed_errors(plan, RESULTS / name, study)
    committed = {(e["quantity"], e["mesh_level"], e["step_level"]): e["relative"] for e in study["errors"]}
    for e in errors:
        was = committed[(e["quantity"], e["mesh_level"], e["step_level"])]
        if was is None or e["relative"] is None:
            assert was is None and e["relative"] is None
        else:
            assert e["relative"] == pytest.approx(was, rel=1e-9), e["quantity"]
