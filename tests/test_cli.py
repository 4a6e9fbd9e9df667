"""The command line: ``vfrs run`` / ``vfrs info``, also as ``python -m vfrs``."""

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
    from vfrs.bench.problems import PROBLEMS

    with pytest.raises(SystemExit):
        main(["bench", "accuracy", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"one of {', '.join(PROBLEMS)}" in text and list(PROBLEMS) == ["block", "hertz", "bars", "m5", "m5_finite"]
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
