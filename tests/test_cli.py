"""The command line: ``vfrs run`` / ``vfrs info``, also as ``python -m vfrs``."""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.cli import main

ROOT = Path(__file__).resolve().parent.parent


def test_python_m_vfrs_runs_a_scene_and_writes_its_outputs(tmp_path):
    out = tmp_path / "out"
    p = subprocess.run(
        [sys.executable, "-m", "vfrs", "run", "examples/cantilever.toml", "-o", str(out), "--set", "time.end=0.01"],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )
    assert p.returncode == 0, p.stderr
    assert "21 steps" in p.stdout and "effects: elasticity, inertia, damping, surface_loads" in p.stdout
    assert p.stderr == ""  # no progress bar when not a terminal
    resolved = vfrs.Scene.load(out / "scene.toml")
    assert resolved.time.end == 0.01
    assert np.load(out / "history.npz")["t"].shape == (21,)
    assert (out / "beam.pvd").exists() and (out / "run.log").exists()


def test_info_lists_bodies_sizes_and_the_effects_that_would_run(capsys):
    assert main(["info", str(ROOT / "examples/sphere_drop.toml")]) == 0
    text = capsys.readouterr().out
    assert "body 'ball': mesh sphere, 729 nodes, 3072 tetrahedra, 2187 DOFs" in text
    assert "effects that would run: elasticity, inertia, damping, gravity" in text
    assert "200 steps" in text


def test_errors_exit_2_with_the_scene_message(capsys, tmp_path):
    assert main(["info", str(ROOT / "examples/cantilever.toml"), "--set", "time.alpha=-0.5"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vfrs: error: ") and "time.alpha: expected a number in [-0.333333, 0]" in err
    assert main(["run", str(tmp_path / "missing.toml")]) == 2
    assert "scene file does not exist" in capsys.readouterr().err


def test_set_reads_toml_values_and_indexed_paths(capsys):
    assert main(["info", str(ROOT / "examples/cantilever.toml"), "--set", "bodies[0].mesh.cells=[4, 1, 1]",
                 "--set", 'title="short"']) == 0
    text = capsys.readouterr().out
    assert "(short)" in text and "20 nodes, 24 tetrahedra" in text


def test_usage_errors_are_argparse_errors():
    with pytest.raises(SystemExit):
        main(["frobnicate"])


def test_bench_problem_help_comes_from_the_problems_registry(capsys):
    from vfrs.studies.accuracy.problems import PROBLEMS

    with pytest.raises(SystemExit):
        main(["bench", "accuracy", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"one of {', '.join(PROBLEMS)}" in text and list(PROBLEMS) == [
        "block", "hertz", "bars", "m5", "m5_finite", "m5_press", "m5_pulse", "m5_pulse_strong"]
    assert main(["bench", "accuracy", "--problem", "nope"]) == 2
    assert f"unknown problem 'nope'; choose from {sorted(PROBLEMS)}" in capsys.readouterr().err


def test_info_lists_what_the_run_lists(tmp_path):
    """``vfrs info`` and the run name the same parts (one list, ``vfrs.run.what_runs``)."""
    from vfrs.cli import info_text

    scene = vfrs.Scene.load(ROOT / "examples/bar_static.toml")
    res = vfrs.run(scene, progress=False)
    assert f"effects that would run: {', '.join(res.effects)}\n" in info_text(scene)
    assert f"{res.problem.sizes()['free_dofs']} free" in info_text(scene)


def test_info_says_an_open_end(capsys):
    """A scene with [output] until = "limit_cycle": vfrs info says the run goes on past its end
    and to which cap."""
    argv = ["info", "examples/m5_collision.toml", "--set", 'output.until="limit_cycle"', "--set", "output.until_cap=0.2"]
    assert main(argv) == 0
    assert "goes on past the end until the last 4 glottal cycles repeat, at most to 200 ms" in capsys.readouterr().out
    assert main(["info", "examples/m5_collision.toml"]) == 0
    assert "goes on past the end" not in capsys.readouterr().out


def _help(argv, capsys) -> str:
    with pytest.raises(SystemExit):
        main(argv + ["--help"])
    return " ".join(capsys.readouterr().out.split())


def test_run_help_says_what_it_does_where_results_go_and_an_example(capsys):
    """Issue 43: `vfrs run --help` had only the options; it says what a run does, where its
    results go and gives an example. `vfrs modes`'s scene argument says what it is."""
    text = _help(["run"], capsys)
    assert "Run a scene: build its bodies" in text and "print the results summary" in text
    assert "With -o OUT the run is kept in OUT: scene.toml" in text and "summary.json" in text
    assert "example: vfrs run examples/m5_collision.toml -o out/m5_collision" in text
    assert "[output] errors_from" in text
    modes = _help(["modes"], capsys)
    assert "scene scene file (.toml): its bodies, materials and fixed conditions" in modes


PHONATION = ['bodies[0].mesh.resolution="coarse"', 'bodies[1].mesh.resolution="coarse"', "time.end=0.002"]


def _study(folder, scene, errors: dict):
    """A converge study's converge.json for ``scene`` whose one rung is any step and mesh, with
    the given relative errors (``{quantity: (relative, bound)}``)."""
    from vfrs.studies.converge import scene_key

    folder.mkdir()
    rung = [{"name": "base", "index": 0, "changes": {}, "h": 5e-5}]
    (folder / "converge.json").write_text(json.dumps({
        "scene_key": scene_key(scene.to_dict()), "meshes": rung, "steps": rung,
        "errors": [{"quantity": q, "mesh_level": 0, "step_level": 0, "relative": rel, "bound": bound}
                   for q, (rel, bound) in errors.items()]}))


def test_errors_are_printed_by_default_from_the_scene_study(tmp_path, capsys):
    """[output] errors_from names a converge study: vfrs run prints each number with its error
    without --errors-from (and no line saying how to get them), rounded to what the error
    supports; summary.json keeps the errors. --errors-from gives the same."""
    from vfrs.cli import load_scene

    study = tmp_path / "study"
    _study(study, load_scene(ROOT / "examples/m5_phonation.toml", PHONATION),
           {"phonation.mean_flow": (0.05, True), "phonation.onset": (0.0, False)})
    sets = [a for s in PHONATION + [f'output.errors_from="{study}"'] for a in ("--set", s)]
    out = tmp_path / "out"
    assert main(["run", str(ROOT / "examples/m5_phonation.toml"), "-o", str(out), "--no-progress", *sets]) == 0
    text = capsys.readouterr().out
    saved = json.loads((out / "summary.json").read_text())["phonation"]
    flow = saved["mean_flow"]["value"] * 1e6  # mL/s; error 5 %: to the decimal of 0.05 x flow's first digit
    digits = -int(np.floor(np.log10(0.05 * flow)))
    mean = re.search(r"^ +mean flow rate +\[smooth\] +(\S+) mL/s \(\+- 5 %\)$", text, re.M)
    assert mean and float(mean.group(1)) == pytest.approx(flow, abs=0.5 * 10.0**-digits)
    assert len(mean.group(1).partition(".")[2]) == max(digits, 0)
    mean = mean.group(0)
    assert "(the same in every run of the study)" in text and "+- unknown" in text  # onset; the others: not in it
    assert f"the converge study in {study}" in text and "error bars: none" not in text
    assert saved["mean_flow"]["error"]["relative"] == 0.05
    again = main(["run", str(ROOT / "examples/m5_phonation.toml"), "--no-progress", "--errors-from", str(study),
                  *[a for s in PHONATION for a in ("--set", s)]])
    assert again == 0 and mean in capsys.readouterr().out


def test_errors_from_is_validated_and_the_main_job_uses_its_committed_study(capsys):
    """A missing study folder, or one without converge.json, is a one-line scene error naming
    the key; examples/m5_collision.toml names its committed study (README: "what those numbers
    are worth is printed with them"), which is not part of its resolved scene (run ids)."""
    argv = ["run", str(ROOT / "examples/m5_phonation.toml"), "--set"]
    assert main(argv + ['output.errors_from="no_such_study"']) == 2
    err = capsys.readouterr().err
    assert err.startswith("vfrs: error: ") and "output.errors_from: the converge study folder" in err
    assert "does not exist" in err and "vfrs converge SCENE -o" in err and len(err.splitlines()) == 1
    assert main(argv + ['output.errors_from="sweeps"']) == 2
    assert "holds no converge study (no converge.json)" in capsys.readouterr().err
    main_job = vfrs.Scene.load(ROOT / "examples/m5_collision.toml")
    assert main_job.output.errors_from == str(ROOT / "examples/converge_results/m5_collision")
    assert "errors_from" not in main_job.to_dict()["output"]


def test_the_scenes_study_that_does_not_apply_is_said_in_one_line(capsys):
    """The main job cut to 5 ms on the coarse folds (--set) is no longer the scene its study
    ran: its numbers print without error bars (not '+- unknown' on every line) and one line
    says why the scene's study does not apply; --errors-from the same study is used as asked
    and says '+- unknown'."""
    argv = ["run", str(ROOT / "examples/m5_collision.toml"), "--no-progress"] + [
        a for s in ['bodies[0].mesh.resolution="coarse"', 'bodies[1].mesh.resolution="coarse"', "time.end=0.005"]
        for a in ("--set", s)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    line = next(ln for ln in text.splitlines() if ln.startswith("error bars: none"))
    assert "the scene's converge study ([output] errors_from = examples/converge_results/m5_collision) does not " \
           "apply to this run: it studies another scene" in line
    assert "+- " not in text.replace(line, "")
    assert main(argv + ["--errors-from", str(ROOT / "examples/converge_results/m5_collision")]) == 0
    text = capsys.readouterr().out
    assert "peak contact force on right" in text and "(+- unknown)" in text and "error bars: none" not in text
