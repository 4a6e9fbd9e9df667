"""Output folders (issue 15): another run's folder is refused unless --overwrite, which removes
that run's files only; a manifest lists what a run wrote; -o naming a file and body names
that are paths are errors; no -o says that nothing is saved; probes are written."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.cli import main
from vfrs.output.writer import OutputFolderError

ROOT = Path(__file__).resolve().parent.parent
BAR = str(ROOT / "examples/bar_static.toml")


def test_a_run_writes_a_manifest_and_the_probes(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", BAR, "-o", str(out), "--no-progress"]) == 0
    m = json.loads((out / "manifest.json").read_text())
    assert m["status"] == "complete" and m["ended"] and m["started"]
    assert len(m["scene_hash"]) == 64 and {"vfrs", "python", "numpy"} <= set(m)
    assert {"scene.toml", "run.log", "history.npz", "history.csv", "probes.npz", "manifest.json"} <= set(m["files"])
    assert all((out / f).is_file() for f in m["files"])
    assert not (out / "checkpoint.npz").exists()  # removed when the run completes
    p = np.load(out / "probes.npz")
    scene = vfrs.Scene.load(BAR)
    node = int(p["probe_0.node"])
    assert np.allclose(p["probe_0.point"], scene.output.probes[0])
    assert p["probe_0.distance"] == pytest.approx(np.linalg.norm(p["probe_0.position"] - p["probe_0.point"]))
    assert p["probe_0.displacement"].shape == (len(p["t"]), 3)
    res = vfrs.run(scene, progress=False)
    assert node == res.node(scene.output.probes[0])
    assert str(p["probe_0.body"]) == res.probe(scene.output.probes[0])["body"] == "bar"
    assert np.array_equal(p["probe_0.displacement"], res.probe(scene.output.probes[0])["displacement"])


def test_another_runs_folder_is_refused_and_overwrite_removes_only_its_files(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", BAR, "-o", str(out), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["run", BAR, "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "holds another run's files" in err and "--overwrite" in err and "--resume" in err and "Traceback" not in err
    (out / "notes.txt").write_text("mine")
    (out / "fields").mkdir(exist_ok=True)
    (out / "fields" / "mine.vtu").write_text("mine")
    stale = out / "fields" / "right_000200.vtu"  # an old run's field file, not in any manifest
    stale.write_text("old")
    assert main(["run", BAR, "-o", str(out), "--no-progress", "--overwrite"]) == 0
    assert (out / "notes.txt").read_text() == "mine" and (out / "fields" / "mine.vtu").read_text() == "mine"
    assert not stale.exists()
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"


def test_a_folder_without_a_run_is_used(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "README").write_text("mine")
    assert main(["run", BAR, "-o", str(out), "--no-progress"]) == 0
    assert (out / "README").read_text() == "mine" and (out / "history.npz").exists()


def test_o_naming_a_file_is_an_error(tmp_path, capsys):
    f = tmp_path / "file.txt"
    f.write_text("x")
    assert main(["run", BAR, "-o", str(f), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "is a file, not a folder" in err and "Traceback" not in err
    with pytest.raises(OutputFolderError):
        vfrs.run(vfrs.Scene.load(BAR), out=f, progress=False)


def test_no_o_says_nothing_is_saved(capsys):
    assert main(["run", BAR, "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert "nothing is saved" in err and "-o OUT" in err


def test_resume_with_a_scene_or_without_anything_is_an_error(tmp_path, capsys):
    assert main(["run", BAR, "--resume", str(tmp_path)]) == 2
    assert "give no scene" in capsys.readouterr().err
    assert main(["run"]) == 2
    assert "give a scene file" in capsys.readouterr().err
    assert main(["run", "--resume", str(tmp_path / "none")]) == 2
    assert "no such folder" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["../x", "a/b", ".", "..", "", "a b", "-x", ".hidden"])
def test_body_names_are_names_not_paths(name):
    d = vfrs.Scene.load(BAR).to_dict()
    d["bodies"][0]["name"] = name
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.name: body 0: name .* is not a valid body name"):
        vfrs.Scene.from_dict(d)


def test_history_csv_grows_by_appends_equal_to_the_whole_file(tmp_path):
    """history.csv while a run goes on: rows appended (what a reader sees is a prefix of the
    final file); new columns rewrite it whole."""
    from vfrs.dynamics import build_problem
    from vfrs.history import as_arrays
    from vfrs.output.writer import OutputWriter, write_history_csv

    class Rec:
        def __init__(self):
            self.history = {"t": [], "f": []}

        @property
        def n_recorded(self):
            return len(self.history["t"])

        def rows(self, start=0):
            return as_arrays({k: v[start:] for k, v in self.history.items()})

    scene = vfrs.Scene.load(BAR)
    w = OutputWriter(tmp_path / "out", scene, build_problem(scene, scene.build_meshes()))
    rec = Rec()
    path = tmp_path / "out" / "history.csv"
    seen = []
    for k in range(7):
        rec.history["t"].append(0.1 * k)
        rec.history["f"].append(np.array([k, 2.0 * k, 1 / 3]))
        if k % 3 == 2:
            w.append_history(rec)
            seen.append(path.read_text())
    w.append_history(rec)
    write_history_csv(tmp_path / "whole.csv", rec.rows())
    final = path.read_text()
    assert final == (tmp_path / "whole.csv").read_text()
    assert all(final.startswith(s) for s in seen) and len(final.splitlines()) == 8
    rec.history["g"] = [1.0] * 8
    rec.history["t"].append(0.7)
    rec.history["f"].append(np.zeros(3))
    w.append_history(rec)  # a new column: the whole file again
    write_history_csv(tmp_path / "whole.csv", rec.rows())
    assert path.read_text() == (tmp_path / "whole.csv").read_text()
    w.close()


def test_overwrite_keeps_the_old_run_when_the_new_scene_is_refused(tmp_path, capsys):
    """Meshes and problem are built before --overwrite clears anything: a probe outside every
    body (an error only the built problem can see) leaves the old run's files in place."""
    out = tmp_path / "out"
    assert main(["run", BAR, "-o", str(out), "--no-progress"]) == 0
    before = sorted(p.name for p in out.iterdir())
    assert main(["run", BAR, "-o", str(out), "--no-progress", "--overwrite",
                 "--set", "output.probes=[[100.0, 0.0, 0.0]]"]) != 0
    err = capsys.readouterr().err
    assert "output.probes[0]" in err and "outside every body" in err and "Traceback" not in err
    assert sorted(p.name for p in out.iterdir()) == before
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"


def test_checkpoint_interval_is_a_scene_option(tmp_path):
    """[output] checkpoint_every sets the interval (the command line's --checkpoint-every
    overrides it); negative values are refused at load."""
    out = tmp_path / "out"
    assert main(["run", BAR, "-o", str(out), "--no-progress", "--set", "output.checkpoint_every=1"]) == 0
    assert "checkpoints: every 1 steps" in (out / "run.log").read_text()
    out2 = tmp_path / "out2"
    assert main(["run", BAR, "-o", str(out2), "--no-progress", "--set", "output.checkpoint_every=1",
                 "--checkpoint-every", "3"]) == 0
    assert "checkpoints: every 3 steps" in (out2 / "run.log").read_text()
    out3 = tmp_path / "out3"
    assert main(["run", BAR, "-o", str(out3), "--no-progress", "--set", "output.checkpoint_seconds=0"]) == 0
    assert "checkpoints: on SIGTERM/SIGINT only" in (out3 / "run.log").read_text()
    with pytest.raises(vfrs.SceneError, match="checkpoint_every"):
        d = vfrs.Scene.load(BAR).to_dict()
        d["output"]["checkpoint_every"] = -1
        vfrs.Scene.from_dict(d)


# -- the folder is the run's: a lock for the whole run, --overwrite replaces only on success ------


def _files(folder: Path) -> dict:
    """Every file under ``folder`` (relative path -> bytes), hidden ones included."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


UNFIXED = ["--set", "bodies[0].fixed=[]"]  # no supports: the factorization fails (rigid-body motions)


def test_overwrite_that_fails_gives_the_old_run_back(tmp_path, capsys):
    """--overwrite with a scene that fails in the factorization (no supports) leaves the old
    run's files as they were, byte for byte, and no file of the failed run."""
    out = tmp_path / "out"
    assert main(["run", BAR, "-o", str(out), "--no-progress"]) == 0
    (out / "notes.txt").write_text("mine")
    before = _files(out)
    assert main(["run", BAR, "-o", str(out), "--no-progress", "--overwrite", *UNFIXED]) != 0
    assert "positive definite" in capsys.readouterr().err
    assert _files(out) == before
    assert not (out / ".vfrs-replaced").exists()
    # and an overwrite that completes replaces the run and keeps nothing aside
    assert main(["run", BAR, "-o", str(out), "--no-progress", "--overwrite", "--set", "time.load_steps=2"]) == 0
    assert not (out / ".vfrs-replaced").exists() and (out / "notes.txt").read_text() == "mine"
    assert "load_steps = 2" in (out / "scene.toml").read_text()


def test_a_run_that_fails_before_its_first_step_leaves_the_folder_as_found(tmp_path, capsys):
    """A new folder is not left behind; an existing one keeps only what it held (no manifest,
    log or scene.toml that would make the next run ask for --resume)."""
    out = tmp_path / "new"
    assert main(["run", BAR, "-o", str(out), "--no-progress", *UNFIXED]) != 0
    assert not out.exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "README").write_text("mine")
    assert main(["run", BAR, "-o", str(mine), "--no-progress", *UNFIXED]) != 0
    assert _files(mine) == {"README": b"mine"}
    capsys.readouterr()
    assert main(["run", BAR, "-o", str(mine), "--no-progress"]) == 0  # and the next run just runs


def test_a_folder_another_run_holds_is_refused_at_once(tmp_path):
    """The race of two runs into one folder, made deterministic: the first has checked the
    folder but written nothing yet (the window in which, before the lock, a second run's check
    also passed: both ran in 1 of 6 trials, the second's scene.toml beside the first's
    results). Now the second is refused before it touches anything (this fails without the
    lock). Two runs started together 12 times did not hit that window here even without the
    lock, so no such repeated test is kept. The lock of a process that died is the kernel's to
    release, so the folder is free again."""
    import subprocess
    import sys

    from vfrs.output.writer import OutputFolder

    out = tmp_path / "out"
    with OutputFolder(out):
        with pytest.raises(OutputFolderError, match="still writing there .*lock"):
            vfrs.run(vfrs.Scene.load(BAR), out=out, progress=False)
        assert _files(out) == {}
    # a process that takes the lock and dies without releasing it
    code = ("import os, fcntl, sys; fd = os.open(sys.argv[1], os.O_RDONLY); "
            "fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB); os._exit(0)")
    subprocess.run([sys.executable, "-c", code, str(out)], check=True)
    assert vfrs.run(vfrs.Scene.load(BAR), out=out, progress=False).history["t"][-1] == pytest.approx(1.0)


def test_a_warning_shown_during_a_run_is_a_line_of_its_run_log(tmp_path, monkeypatch):
    """A warning the run shows (here one the recorder is made to give at its first step) is
    written to run.log as well as shown: a sweep's workers print warnings to a stderr that no
    run folder keeps, so without this a run's table row could not say that it warned."""
    import warnings

    from vfrs.errors import VfrsWarning
    from vfrs.history import Recorder

    record = Recorder.record

    def warning_record(self, *args, **kwargs):
        if not getattr(self, "_warned_once", False):
            self._warned_once = True
            warnings.warn("contact made 1e-3 J of energy in one step (a test's warning)", VfrsWarning)
        return record(self, *args, **kwargs)

    monkeypatch.setattr(Recorder, "record", warning_record)
    out = tmp_path / "out"
    with pytest.warns(VfrsWarning, match="a test's warning"):
        vfrs.run(BAR, out=out, progress=False)
    log = (out / "run.log").read_text()
    assert "warning: VfrsWarning: contact made 1e-3 J of energy in one step (a test's warning)" in log
    # the hook is gone after the run: a warning outside a run is not written to its log
    with pytest.warns(VfrsWarning):
        warnings.warn("after the run", VfrsWarning)
    assert "after the run" not in (out / "run.log").read_text()
