"""vfrs converge on the systematic M5 family (issue 45, item 1): the default mesh ladder of the
M5 folds is the family (levels 0-2 for a scene on `resolution`, centred on a family scene's own
level), its rungs' h differ by exactly 1.5, the plan prints each rung's contact-surface edges
(and meshes.csv / converge.json keep them), --mesh-ladder levels / refine / family, and the
committed study made on the legacy ladder still loads and says what it was made on."""

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.cli import load_scene, main
from vfrs.meshes import box, m5
from vfrs.studies import converge as cv
from vfrs.studies.converge.family import LEGACY_SHRINK, contact_surface_size

ROOT = Path(__file__).resolve().parent.parent
MAIN = ROOT / "examples" / "m5_collision.toml"
COMMITTED = ROOT / "examples" / "converge_results" / "m5_collision"


@pytest.fixture(scope="module")
def main_plan():
    return cv.plan(vfrs.Scene.load(MAIN))


def _family(level):
    return {f"bodies[{b}].mesh.{k}": v for b in (0, 1) for k, v in (("family", "systematic"), ("level", level))}


def test_the_default_ladder_of_the_main_job_is_the_family(main_plan):
    """examples/m5_collision.toml (medium, legacy): levels 0, 1, 2 of the family; every run's
    scene is the family's level (resolution dropped) and resolves to itself; h 1.5 per rung
    exactly (the nominal size), the measured (V / n)^(1/3)'s ratio within 1e-5 of it; the base run is
    level 0 (the rung nearest the scene's own mesh in DOFs), and the notes say why."""
    p = main_plan
    assert [m.name for m in p.meshes] == ["level 0", "level 1", "level 2"]
    assert [m.changes for m in p.meshes] == [_family(k) for k in range(3)]
    assert all(m.drops == ("bodies[0].mesh.resolution", "bodies[1].mesh.resolution") for m in p.meshes)
    for coarse, fine in zip(p.meshes, p.meshes[1:]):
        assert coarse.h / fine.h == pytest.approx(1.5, rel=1e-9, abs=0)
        # The measured (V / n)^(1/3) carries the arcs' faceting (the volume changes a little per
        # level): 1.5 - 7.6e-6 and 1.5 - 3.4e-6, hence the nominal size.
        assert 1e-9 < abs(coarse.measured_h / fine.measured_h / 1.5 - 1) < 1e-5
        assert coarse.dofs < fine.dofs
    np.testing.assert_allclose([a.measured_h / b.measured_h - 1.5 for a, b in zip(p.meshes, p.meshes[1:])],
                               [-7.6e-6, -3.4e-6], atol=0.05e-6)
    assert p.meshes[0].h == p.meshes[0].measured_h
    # Two folds, 3 DOFs per node: 4617 / 14365 / 45847 nodes per fold (tests/test_m5_family.py).
    assert [m.dofs for m in p.meshes] == [6 * 4617, 6 * 14365, 6 * 45847]
    assert p.base_mesh == 0 and len({cv.scene_key(r["scene"]) for r in p.runs}) == 1
    for r in p.runs:
        for body in r["scene"]["bodies"]:
            mesh = body["mesh"]
            assert mesh["family"] == "systematic" and mesh["level"] == r["mesh_level"] and "resolution" not in mesh
        assert vfrs.Scene.from_dict(r["scene"]).to_dict()["bodies"] == r["scene"]["bodies"]
    assert "not a refinement" in p.notes[0] and "--mesh-ladder levels keeps them" in p.notes[0]
    assert "resolution medium: 26730 DOFs" in p.notes[1] and "the base run is level 0 (27702 DOFs)" in p.notes[1]


def _medial_edges(m):
    """The lengths of every edge of the m5 mesh's medial surface from its (s, z) grid: along
    s, along z, and the quads' diagonals (corner (i, k) to (i + 1, k + 1))."""
    g = m.points[m.medial_grid]
    return np.concatenate([np.linalg.norm(np.diff(g, axis=0), axis=2).ravel(),
                           np.linalg.norm(np.diff(g, axis=1), axis=2).ravel(),
                           np.linalg.norm(g[1:, 1:] - g[:-1, :-1], axis=2).ravel()])


def test_the_plan_prints_the_contact_surface_sizes(main_plan):
    """Each rung's line gives the medial surface's mean and largest edge (both folds, every
    edge once) as the grid gives them, and their ratios to the coarser rung's: 1.485 and 1.490
    for the mean, 1.494 and 1.496 for the largest (the straight inferior and superior surfaces
    are graded: their cells follow the size function to within a few per cent)."""
    lines = cv.plan_lines(main_plan)
    assert lines[0].startswith("meshes (the systematic M5 family; h = the family's nominal size")
    rows = cv.mesh_rows(main_plan)
    for k, row in enumerate(rows):
        edges = _medial_edges(m5("right", family="systematic", level=k))
        assert row["contact_edge_mean [m]"] == pytest.approx(edges.mean(), rel=1e-12)
        assert row["contact_edge_max [m]"] == pytest.approx(edges.max(), rel=1e-12)
        line = next(ln for ln in lines if ln.strip().startswith(f"level {k} "))
        mean = re.search(r"contact surface \(medial\) mean ([\d.]+) um", line)
        assert mean and float(mean.group(1)) == pytest.approx(edges.mean() * 1e6, abs=0.05)
        if k:
            assert "h = " in line and "(x1.5000)" in line
            assert f"(x{row['contact_edge_mean ratio']:.3f})" in line
    np.testing.assert_allclose([r["contact_edge_mean ratio"] for r in rows[1:]], [1.485, 1.490], atol=5e-4)
    np.testing.assert_allclose([r["contact_edge_max ratio"] for r in rows[1:]], [1.494, 1.496], atol=5e-4)
    assert lines[-3] == "steps: h = 50 us, h/2 = 25 us, h/4 = 12.5 us"


def test_the_contact_surface_size_of_a_box_face():
    """A box face of nx x ny cells (two triangles a cell, one diagonal direction): (nx (ny + 1)
    edges of a / nx, (nx + 1) ny of b / ny, nx ny diagonals); the mean in closed form."""
    a, b, nx, ny = 2.0, 1.0, 4, 3
    mesh = box(size=(a, b, 0.5), cells=(nx, ny, 2))
    data = {"bodies": [{"name": "block"}], "contact": {"surface": "zmax"}}
    got = contact_surface_size(data, [mesh])
    hx, hy = a / nx, b / ny
    n = [nx * (ny + 1), (nx + 1) * ny, nx * ny]
    lengths = [hx, hy, np.hypot(hx, hy)]
    assert got["edges"] == sum(n) and got["surfaces"] == {"block": "zmax"}
    assert got["mean"] == pytest.approx(np.dot(n, lengths) / sum(n), rel=1e-12)
    assert got["max"] == pytest.approx(np.hypot(hx, hy), rel=1e-12)
    assert contact_surface_size({"bodies": [{"name": "block"}]}, [mesh]) is None


@pytest.mark.parametrize("level, rungs", [(0, [0, 1, 2]), (1, [0, 1, 2]), (2, [1, 2, 3]), (3, [1, 2, 3])])
def test_a_family_scene_is_centred_on_its_level(level, rungs):
    sets = [f"bodies[{b}].mesh.{kv}" for b in (0, 1) for kv in ("family='systematic'", f"level={level}")]
    data = load_scene(MAIN, sets).to_dict()
    ladder = cv.mesh_ladder(data)
    assert [r.changes for r in ladder] == [_family(k) for k in rungs]
    assert all(r.drops == () for r in ladder)  # the resolved family scene has no `resolution`
    assert [r.name for r in ladder] == [f"level {k}" for k in rungs]


def test_a_family_scene_is_its_own_base_run():
    sets = [f"bodies[{b}].mesh.{kv}" for b in (0, 1) for kv in ("family='systematic'", "level=1")]
    p = cv.plan(load_scene(MAIN, sets), steps=1)
    assert p.base_mesh == 1 and p.notes == []
    assert "level 1  h = " in cv.plan_lines(p)[2] and cv.plan_lines(p)[2].endswith("<- base")


def test_a_graded_legacy_scene_keeps_the_family_grading_and_drops_contact_zone():
    """The graded legacy scene (contact_zone, contact_zone_z, zone_ratio, medial_ratio): the
    family refuses contact_zone (it grades along the medial curve itself), so its rungs drop
    it and say so; the growths and contact_zone_z are the family's grading and stay."""
    graded = [f"bodies[{b}].mesh.{kv}" for b in (0, 1)
              for kv in ("contact_zone=3e-3", "contact_zone_z=10e-3", "zone_ratio=1.2", "medial_ratio=1.2")]
    p = cv.plan(load_scene(MAIN, graded), steps=1)
    assert set(p.meshes[0].drops) == {f"bodies[{b}].mesh.{k}" for b in (0, 1) for k in ("resolution", "contact_zone")}
    for r in p.runs:
        mesh = r["scene"]["bodies"][0]["mesh"]
        assert "contact_zone" not in mesh and (mesh["contact_zone_z"], mesh["zone_ratio"], mesh["medial_ratio"]) == (
            10e-3, 1.2, 1.2)
    assert any(n.startswith("left out on the family's rungs: contact_zone") for n in p.notes)
    assert p.meshes[0].h / p.meshes[1].h == pytest.approx(1.5, rel=1e-9, abs=0)


def test_the_other_ladders_and_what_keeps_a_scene_from_the_family():
    data = vfrs.Scene.load(MAIN).to_dict()
    assert [r.name for r in cv.mesh_ladder(data, how="levels")] == ["coarse", "medium", "fine"]
    assert [r.changes for r in cv.mesh_ladder(data, how="refine")][2] == {
        "bodies[0].mesh.refine": 2, "bodies[1].mesh.refine": 2}
    cells = load_scene(MAIN, ["bodies[0].mesh.cells=[20, 5, 8]", "bodies[1].mesh.cells=[20, 5, 8]"]).to_dict()
    assert "refine" in next(iter(cv.mesh_ladder(cells)[1].changes))  # auto: not the family, no levels
    with pytest.raises(vfrs.VfrsError, match=r"--mesh-ladder family: bodies\[0\].mesh.cells is set"):
        cv.mesh_ladder(cells, how="family")
    bar = load_scene(ROOT / "examples" / "cantilever.toml").to_dict()
    with pytest.raises(vfrs.VfrsError, match="not the built-in m5 mesh.*use --mesh-ladder levels or refine"):
        cv.mesh_ladder(bar, how="family")
    with pytest.raises(vfrs.VfrsError, match="choose one of auto, family, levels, refine"):
        cv.mesh_ladder(data, how="uniform")


def test_vfrs_converge_plan_prints_and_runs_nothing(capsys, tmp_path):
    assert main(["converge", str(MAIN), "--plan"]) == 0
    out = capsys.readouterr().out
    assert out.count("contact surface (medial) mean") == 3 and out.count("(x1.5000)") == 2
    assert "note: the mesh ladder is the systematic M5 family" in out and "(--plan: none run)" in out
    assert main(["converge", str(MAIN), "--plan", "--mesh-ladder", "levels", "--steps", "1"]) == 0
    assert "coarse  h = " in capsys.readouterr().out
    assert main(["converge", str(MAIN)]) == 2
    assert "-o/--out is required to run the study (or --plan" in capsys.readouterr().err


def test_the_plan_in_docs_converge_is_what_vfrs_converge_prints(capsys, monkeypatch):
    """docs/converge.md quotes `vfrs converge examples/m5_collision.toml --plan` up to its notes."""
    monkeypatch.chdir(ROOT)
    doc = (ROOT / "docs" / "converge.md").read_text()
    block = doc.split("examples/m5_collision.toml --plan`):", 1)[1].split("```text\n", 1)[1].split("```", 1)[0]
    quoted = [ln[2:] for ln in block.rstrip().splitlines()]
    assert main(["converge", "examples/m5_collision.toml", "--plan"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert quoted == printed[:len(quoted)] and printed[len(quoted)].startswith("note: ")


def test_the_rungs_sizes_are_saved(main_plan, tmp_path):
    """meshes.csv and converge.json keep each rung's element size and contact-surface edges."""
    p = main_plan
    rows = [{"id": f"r{i}{j}", **p.label(i, j), "status": "complete", "wall_time [s]": 1.0, "q": 1.0 + 0.1 / 2**i}
            for i in range(len(p.meshes)) for j in range(len(p.steps))]
    cv.finish(p, rows, str(tmp_path), figures=False, derived={"q": "x"})
    with open(tmp_path / "meshes.csv", newline="") as fh:
        saved = list(csv.DictReader(fh))
    assert [r["mesh"] for r in saved] == ["level 0", "level 1", "level 2"]
    for r, rung in zip(saved, p.meshes):
        assert float(r["contact_edge_mean [m]"]) == pytest.approx(rung.surface["mean"], rel=1e-12)
        assert float(r["h [m]"]) == pytest.approx(rung.h, rel=1e-12)
    assert float(saved[2]["h ratio"]) == pytest.approx(1.5, rel=1e-9)
    study = json.loads((tmp_path / "converge.json").read_text())
    assert study["meshes"][1]["contact_surface"]["max"] == p.meshes[1].surface["max"]
    assert study["meshes"][0]["drops"] == list(p.meshes[0].drops) and study["notes"] == p.notes
    assert "contact surface (medial) mean" in (tmp_path / "converge.txt").read_text()
    # vfrs run --errors-from this study: a run on a family level is a rung, the legacy medium mesh is not.
    level1 = next(r["scene"] for r in p.runs if r["labels"] == {"mesh": "level 1", "step": "h/2"})
    assert cv.errors_for(level1, study)["derived.q"]["mesh_level"] == 1
    assert "not one of its rungs" in cv.why_not(vfrs.Scene.load(MAIN).to_dict(), study)


def test_the_committed_legacy_study_still_loads_and_is_not_the_family(main_plan):
    """examples/converge_results/m5_collision was made on the generator's resolutions: it
    loads, its rungs are coarse / medium / fine (no family key), the main job at its step gets
    its errors, and a run on the family's level 0 is said not to be one of its rungs."""
    study = cv.load(COMMITTED)
    assert [m["name"] for m in study["meshes"]] == ["coarse", "medium", "fine"]
    assert not any(k.endswith((".family", ".level")) for m in study["meshes"] for k in m["changes"])
    assert cv.errors_for(vfrs.Scene.load(MAIN).to_dict(), study)
    level0 = next(r["scene"] for r in main_plan.runs if r["labels"] == {"mesh": "level 0", "step": "h"})
    assert cv.errors_for(level0, study) is None
    assert "not one of its rungs" in cv.why_not(level0, study)


def _first_layer_mid_flat(**kw):
    """The legacy mesh's first layer under the node nearest the middle of the medial flat (z = 0)."""
    m = m5("right", **kw)
    g = m.medial_grid[:, 0]
    ns, nz = m.medial_grid.shape
    P = m.points.reshape(ns, -1, nz, 3)[:, :, 0, :2]
    i = int(np.argmin(np.abs(P[:, 0, 1] + 1.5e-3) + 10 * np.abs(P[:, 0, 0] - 50e-6)))
    assert abs(m.points[g[i], 1] + 1.5e-3) < 0.1e-3
    return float(np.linalg.norm(P[i, 1] - P[i, 0]))


def test_the_legacy_ladder_is_not_a_refinement():
    """What the printed note quotes: the legacy first layer shrinks 2.9x, 3.6x (coarse ->
    medium -> fine) and 6.2x (-> 72 x 18 x 30): 806 / 280 / 79 / 12.7 um."""
    t = [_first_layer_mid_flat(resolution=r) for r in ("coarse", "medium", "fine")]
    t.append(_first_layer_mid_flat(cells=(72, 18, 30)))
    np.testing.assert_allclose(np.array(t) * 1e6, [805.6, 279.9, 78.7, 12.7], atol=0.1)
    assert tuple(round(a / b, 1) for a, b in zip(t, t[1:])) == LEGACY_SHRINK
