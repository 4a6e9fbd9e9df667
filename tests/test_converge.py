"""vfrs converge (issue 32): the ladders, a study on a problem of known order run through the
whole command (sweep, tables, errors), oscillatory and divergent numbers said as such, a
study resumed and on dask identical to its serial run, and error bars of a single run."""

import json
import os

import pytest

import vfrs
from vfrs.studies import converge as cv
from vfrs.summary import Quantity, Summary
from vfrs.cli import load_scene, main

TIP = 'last(probes["probe_0.displacement"])[2]'
# The cantilever of tests/test_verification.py: 6 x 2 x 2 cells, the load ramped smoothly over
# 20 ms (a sudden load costs HHT-alpha its order), 40 ms.
CANTILEVER = ["bodies[0].mesh.cells=[6, 2, 2]", "time.end=0.04", "output.every=10",
              "bodies[0].loads=[{ type = 'traction', surface = 'xmax', value = [0.0, 0.0, -50.0], ramp = 0.02 }]"]


def cantilever(step=1e-3):
    return load_scene("examples/cantilever.toml", [*CANTILEVER, f"time.step={step}"])


def test_ladders_of_the_main_job():
    """The M5 folds on the generator's levels (--mesh-ladder levels; the default is the
    systematic family, tests/test_converge_family.py): base medium, in the middle, steps h,
    h/2, h/4 with the fields written at the same times; the most expensive run is submitted
    first."""
    p = cv.plan(vfrs.Scene.load("examples/m5_collision.toml"), mesh_how="levels")
    assert [m.name for m in p.meshes] == ["coarse", "medium", "fine"] and p.base_mesh == 1
    assert [s.h for s in p.steps] == [50e-6, 25e-6, 12.5e-6] and p.base_step == 0
    assert [s.changes.get("output.every", 20) for s in p.steps] == [20, 40, 80]
    assert p.meshes[0].h > p.meshes[1].h > p.meshes[2].h
    assert p.meshes[0].dofs < p.meshes[1].dofs < p.meshes[2].dofs
    assert (p.runs[0]["mesh_level"], p.runs[0]["step_level"]) == (2, 2)
    assert len({cv.scene_key(r["scene"]) for r in p.runs}) == 1  # one scene up to step and mesh


def test_refinement_ladder_halves_the_element_size():
    """A mesh without levels is refined uniformly: each rung splits every tetrahedron into
    eight, so the representative size (V / n)^(1/3) halves exactly."""
    p = cv.plan(cantilever())
    assert [m.changes for m in p.meshes] == [{"bodies[0].mesh.refine": k} for k in range(3)]
    assert p.meshes[0].h / p.meshes[1].h == pytest.approx(2.0, rel=1e-12)
    assert p.meshes[1].h / p.meshes[2].h == pytest.approx(2.0, rel=1e-12)


def test_bad_options():
    with pytest.raises(vfrs.VfrsError, match="--steps 2"):
        cv.plan(cantilever(), steps=2)
    with pytest.raises(vfrs.VfrsError, match="levels"):
        cv.plan(cantilever(), mesh_how="levels")
    static = load_scene("examples/bar_static.toml")
    with pytest.raises(vfrs.VfrsError, match="nothing to study"):
        cv.plan(static, meshes=1)


def test_hht_order_through_converge(tmp_path):
    """HHT-alpha's second order in the step, recovered by the whole command (ladder, sweep,
    derived quantity, study): p within 0.1 of 2 on every mesh, and the extrapolated tip
    deflection of the base mesh within 1e-4 of a run at h/16 (not one of the study's runs)."""
    res = cv.converge(cantilever(), tmp_path / "cv", meshes=1, serial=True, quantities={"tip": TIP},
                      log=lambda m: None, figures=False)
    s = res.study("derived.tip", "step", 0)
    assert s.verification.kind == "monotone"
    assert abs(s.verification.order - 2.0) < 0.1
    ref = vfrs.run(cantilever(1e-3 / 16), progress=False)
    tip = float(ref.displacement("beam")[ref.node((0.02, 0.004, 0.002)), 2])
    assert s.verification.extrapolated == pytest.approx(tip, rel=1e-4)
    assert abs(s.values[-1] - tip) > abs(s.verification.extrapolated - tip)
    e = res.error("derived.tip", 0, 0)  # the base run (h): Roache's coarse-run GCI covers its error
    assert e["bound"] and abs(e["value"] - tip) <= e["relative"] * abs(e["value"])
    for name in ("converge.csv", "converge.parquet", "converge.md", "errors.csv", "converge.json", "converge.txt"):
        assert os.path.exists(tmp_path / "cv" / name)


def _fake_rows(p, values):
    return [{"id": f"r{i}{j}", **p.label(i, j), "status": "complete", "wall_time [s]": 1.0 + i + j,
             "q": values[i][j]} for i in range(len(p.meshes)) for j in range(len(p.steps))]


@pytest.mark.parametrize("kind, along_mesh", [("oscillatory", [1.0, 1.2, 0.9]), ("divergent", [1.0, 1.1, 1.4]),
                                              ("monotone", [1.0, 1.2, 1.25])])
def test_kind_said_in_words(kind, along_mesh):
    """A number that goes up and down, or whose change grows, as the mesh is refined is not
    extrapolated: the line says its band is not an error bound and why."""
    p = cv.plan(cantilever())
    values = [[v * (1 + 1e-3 / 4**j) for j in range(3)] for v in along_mesh]
    res = cv.finish(p, _fake_rows(p, values), None, derived={"q": "x"})
    assert res.study("derived.q", "mesh", 0).verification.kind == kind
    line = res.lines()[2]
    if kind == "monotone":
        assert "not an error bound" not in line and res.error("derived.q", 0, 0)["bound"]
    else:
        assert f"not an error bound ({kind})" in line and not res.error("derived.q", 0, 0)["bound"]
    assert "the next mesh buys" in line and "halving the step buys" in line


def test_resumed_and_on_dask_identical_to_serial(tmp_path):
    """The study on two dask workers gives the serial study's numbers bit for bit; run again
    into the same folder, every run is found finished and nothing runs."""
    kw = dict(quantities={"tip": TIP}, figures=False, log=lambda m: None)
    a = cv.converge(cantilever(), tmp_path / "serial", serial=True, **kw)
    b = cv.converge(cantilever(), tmp_path / "dask", workers=2, progress=False, **kw)
    assert [s.values for s in a.studies] == [s.values for s in b.studies]
    assert [e["relative"] for e in a.errors] == [e["relative"] for e in b.errors]
    lines = []
    again = cv.converge(cantilever(), tmp_path / "serial", serial=True, quantities={"tip": TIP}, figures=False,
                        log=lines.append)
    assert "9 finished before (skipped), 0 to run" in lines[0]
    assert [s.values for s in again.studies] == [s.values for s in a.studies]


def test_error_bars_from_a_study(tmp_path, capsys):
    """A run of the study's scene at one of its rungs gets each number's error; another
    scene gets 'unknown' and the reason."""
    res = cv.converge(cantilever(), tmp_path / "cv", meshes=1, serial=True, quantities={"tip": TIP},
                      log=lambda m: None, figures=False)
    study = cv.load(tmp_path / "cv")
    scene = cantilever(5e-4).to_dict()
    scene["output"]["every"] = 20
    errs = cv.errors_for(scene, study)
    assert errs["derived.tip"]["relative"] == res.error("derived.tip", 0, 1)["relative"]
    other = cantilever().to_dict()
    other["bodies"][0]["material"]["E"] = 20e3
    assert cv.errors_for(other, study) is None
    summary = Summary({"motion": {"tip": Quantity(1.0, "m", "tip deflection")}}, {}, {})
    said = cv.with_study_errors(summary, other, tmp_path / "cv")
    assert "+- unknown" in said.text() and "another scene" in said.text()
    with pytest.raises(vfrs.VfrsError, match="no converge.json"):
        cv.load(tmp_path)


def test_two_run_error_formula():
    """--error-bars: Roache's two-run GCI of the coarser run with Fs = 3 and order 1 assumed:
    3 |phi_h - phi_h/2| 2 / (2 - 1) / |phi_h|."""
    a = Summary({"contact": {"f": Quantity(10.0, "N", "force"), "z": Quantity(0.0, "m", "gap")}}, {}, {})
    b = Summary({"contact": {"f": Quantity(10.1, "N", "force"), "z": Quantity(0.0, "m", "gap")}}, {}, {})
    errs = cv.two_run_errors(a, b)
    assert errs["contact.f"]["relative"] == pytest.approx(3 * 0.1 * 2 / 10.0)
    assert errs["contact.z"]["relative"] == 0.0
    text = a.with_errors(errs, "test").text()
    assert "+- 6 %" in text and "+- 0 %" in text


def test_cli_converge(tmp_path, capsys):
    out = tmp_path / "cli"
    args = ["converge", "examples/cantilever.toml", "-o", str(out), "--serial", "--meshes", "1", "--no-figures",
            "--quantity", f"tip={TIP}"] + [a for s in CANTILEVER + ["time.step=1e-3"] for a in ("--set", s)]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "tip = " in text and "halving the step buys" in text
    assert json.loads((out / "converge.json").read_text())["base"] == {"mesh": 0, "step": 0}
    assert main(["converge", "examples/cantilever.toml", "-o", str(out), "--steps", "2"]) == 2
    assert main(["converge", "examples/cantilever.toml", "-o", str(out), "--quantity", "nonsense"]) == 2


def test_projected_wall_time():
    """Longest first to the worker free first: 9 runs on 2 workers, 8 and 32."""
    times = [220.0, 110.0, 55.0, 48.0, 24.0, 12.0, 28.0, 14.0, 7.0]
    assert cv.projected_wall(times, 1) == sum(times)
    assert cv.projected_wall(times, 2) == 262.0  # 220 + 24 + 12 = 256 / 110 + 55 + 48 + 28 + 14 + 7 = 262
    assert cv.projected_wall(times, 8) == cv.projected_wall(times, 32) == 220.0


def test_recommendation_is_the_cheapest_bounded_run():
    """A number converging as 1 + h_mesh (first order) + h_step^2 / 10: the cheapest run within
    10 % is recommended and confirmed by its finer neighbours; 2 % is met by none."""
    p = cv.plan(cantilever())
    hm = [m.h / p.meshes[0].h for m in p.meshes]  # 1, 1/2, 1/4
    hs = [s.h / p.steps[0].h for s in p.steps]
    values = [[1.0 + 0.1 * a + 0.01 * b**2 for b in hs] for a in hm]
    res = cv.finish(p, _fake_rows(p, values), None, derived={"q": "x"})
    r10 = cv.recommend(res, "derived.q", 0.10)
    assert r10 is not None and r10["error"] <= 0.10 and r10["confirmed"]
    cheaper = [e for e in res.errors if e["quantity"] == "derived.q" and e["relative"] <= 0.10]
    assert r10["time"] == min(1.0 + e["mesh_level"] + e["step_level"] for e in cheaper)
    assert cv.recommend(res, "derived.q", 1e-6) is None
    assert "none of these runs" in res.text()


def test_manufactured_static_solution_order_and_limit(tmp_path):
    """A bar hanging under its own weight (nu = 0: u_x = g rho / E (L x - x^2 / 2) solves 3-D
    elasticity exactly): the strain energy rho^2 g^2 A L^3 / (6 E) is approached at order 2
    under uniform refinement (the energy error of linear elements is O(h^2)); the study
    recovers p within 0.1 and the exact energy within 1e-3 relative (the coarsest run is 2.7 %
    off)."""
    scene = load_scene("tests/data/bar_gravity.toml")
    res = cv.converge(scene, tmp_path / "bar", serial=True, quantities={"energy": "last(history.elastic_energy)"},
                      log=lambda m: None, figures=False)
    assert [m.name for m in res.plan.meshes] == ["scene's mesh", "refined 1x", "refined 2x"] and len(res.plan.steps) == 1
    v = res.study("derived.energy", "mesh", 0).verification
    E, rho, g, L, A = 1e4, 1000.0, 9.81, 0.1, 1e-4
    exact = rho**2 * g**2 * A * L**3 / (6 * E)
    assert v.kind == "monotone" and abs(v.order - 2.0) < 0.1
    assert v.extrapolated == pytest.approx(exact, rel=1e-3)
    assert abs(v.value - exact) / exact > 1e-3  # the finest run alone is not that close
    assert v.low < exact < v.high


def test_signorini_block_is_said_converged(tmp_path):
    """The block pressed onto a rigid plane with Lagrange multipliers (vfrs bench accuracy's
    'block'): P1 elements reproduce its uniform stress, so the force E A d / H is the same on
    every mesh; the study says "converged to round-off" (no order, no extrapolation) and the
    value is the closed form to 1e-9."""
    from vfrs.studies.accuracy.problems import Block

    b = Block()
    scene = b.scene({"method": "lagrange"}, (2, 2, 2), None)
    res = cv.converge(scene, tmp_path / "block", serial=True, log=lambda m: None, figures=False,
                      quantities={"force": 'last(history["contact_force.block"])[2]'})
    v = res.study("derived.force", "mesh", 0).verification
    assert v.kind == "converged" and v.order is None and v.extrapolated is None
    assert v.value == pytest.approx(b.E * b.W * b.W * b.d / b.H, rel=1e-9)
    assert res.error("derived.force", 0, 0)["relative"] == 0.0


def test_cli_error_bars_from_a_companion_run(tmp_path, capsys):
    """vfrs run --error-bars: the main job's first 5 ms on the coarse folds, and beside it the
    same at half the step; summary.json's error of the peak contact force is Roache's two-run
    GCI, 6 |F_h - F_h/2| / F_h, with the companion computed here independently."""
    sets = ['bodies[0].mesh.resolution="coarse"', 'bodies[1].mesh.resolution="coarse"', "time.end=0.005"]
    out = tmp_path / "run"
    argv = ["run", "examples/m5_collision.toml", "-o", str(out), "--error-bars", "--no-progress"]
    assert main(argv + [a for s in sets for a in ("--set", s)]) == 0
    text = capsys.readouterr().out
    assert "the step part only" in text and " +- " in text
    summary = json.loads((out / "summary.json").read_text())
    force = summary["contact"]["peak_force.right"]
    half = vfrs.run(load_scene("examples/m5_collision.toml", sets + ["time.step=2.5e-5", "output.every=40"]),
                    progress=False).results["contact"]["peak_force.right"].value
    assert force["error"]["relative"] == pytest.approx(6 * abs(force["value"] - half) / force["value"], rel=1e-12)
    with pytest.raises(vfrs.VfrsError, match="static"):
        cv.step_companion(load_scene("examples/bar_static.toml"))


def test_the_collision_jobs_printed_error_bars_are_its_committed_studys():
    """docs/results.md's block of the collision job with its error bars (the scene's [output]
    errors_from): every percentage and "band" is the committed study's error of that number at
    the collision job's rungs (medium mesh, 50 us), as Quantity.text prints it; a flag and the
    positions print none."""
    from study_tables import check_printed_errors, printed_block

    root = os.path.join(os.path.dirname(__file__), "..")
    study = json.load(open(os.path.join(root, "examples/converge_results/m5_collision/converge.json")))
    doc = open(os.path.join(root, "docs/results.md")).read()
    block = printed_block(doc, "## How close are these numbers")
    scene = vfrs.Scene.load(os.path.join(root, "examples/m5_collision.toml"))
    assert check_printed_errors(block, study, cv.errors_for(scene.to_dict(), study)) >= 30
