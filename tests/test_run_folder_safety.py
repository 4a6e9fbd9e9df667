"""A run folder may come from someone else, or be cut short by a kill (issue 43, items 1-3):
nothing outside it is removed, replaced or read whatever its manifest, checkpoint or sweep
records name; a sweep's derived expression cannot hang the process; a damaged file of a folder
is one line naming it and what to do, never a traceback."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import pytest

import vfrs
import vfrs.studies.sweep as sw
from vfrs.checkpoint import CheckpointError
from vfrs.cli import main
from vfrs.errors import OutputFolderError, SceneError, VfrsError
from vfrs.run import resume

ROOT = Path(__file__).resolve().parent.parent
BAR = str(ROOT / "examples/bar_static.toml")


def _tree(folder: Path) -> dict:
    """Every file under ``folder`` (links not followed) and its bytes."""
    out = {}
    for d, _, names in os.walk(folder):
        for n in names:
            p = Path(d) / n
            out[str(p.relative_to(folder))] = os.readlink(p) if p.is_symlink() else p.read_bytes()
    return out


def _old_run(tmp_path) -> Path:
    out = tmp_path / "out"
    assert main(["run", BAR, "-o", str(out), "--no-progress"]) == 0
    return out


def _list(out: Path, rel: str) -> None:
    """Adds ``rel`` to the files ``out``'s manifest lists (as a doctored folder would)."""
    m = json.loads((out / "manifest.json").read_text())
    m["files"].append(rel)
    (out / "manifest.json").write_text(json.dumps(m))


def _refused(argv, capsys, *words) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("vfrs: error: ") and "Traceback" not in err, err
    for w in words:
        assert w in err, (w, err)
    return err


# -- item 1: --overwrite never deletes outside the folder ------------------------------------

@pytest.mark.parametrize("how", ["link", "dotdot", "absolute"])
def test_overwrite_refuses_a_manifest_naming_a_file_outside_and_removes_nothing(tmp_path, capsys, how):
    """The manifest lists ``lnk/victim.txt`` with ``lnk`` a link to another folder (before: that
    folder's file was deleted, exit 0), ``../victim.txt`` or an absolute path (before: skipped
    silently): an OutputFolderError naming the path, the outside file intact, and not one file
    of the folder moved or removed."""
    out = _old_run(tmp_path)
    other = tmp_path / "other"
    other.mkdir()
    victim = (tmp_path if how == "dotdot" else other) / "victim.txt"
    victim.write_text("not vfrs's")
    if how == "link":
        (out / "lnk").symlink_to(other)
    rel = {"link": "lnk/victim.txt", "dotdot": "../victim.txt", "absolute": str(victim)}[how]
    _list(out, rel)
    before = _tree(out)
    _refused(["run", BAR, "-o", str(out), "--no-progress", "--overwrite"], capsys, repr(rel), "outside the folder",
             "nothing was touched")
    assert victim.read_text() == "not vfrs's"
    assert _tree(out) == before
    with pytest.raises(OutputFolderError, match="outside the folder"):  # the named error, from Python too
        vfrs.run(vfrs.Scene.load(BAR), out=out, progress=False, overwrite=True)
    assert victim.read_text() == "not vfrs's" and _tree(out) == before


def test_a_folder_of_vfrs_names_linked_outside_is_refused(tmp_path, capsys):
    """``fields`` a link to another folder holding files of vfrs's names (``*_000001.vtu``),
    which --overwrite removes from a folder even without a manifest: refused, kept."""
    out = _old_run(tmp_path)
    other = tmp_path / "other"
    other.mkdir()
    victim = other / "bar_000001.vtu"
    victim.write_text("not vfrs's")
    for f in (out / "fields").iterdir():
        f.unlink()
    (out / "fields").rmdir()
    (out / "fields").symlink_to(other)
    _refused(["run", BAR, "-o", str(out), "--no-progress", "--overwrite"], capsys, "fields", "symbolic link")
    assert victim.read_text() == "not vfrs's"


def test_a_new_run_does_not_write_through_a_folder_linked_outside(tmp_path, capsys):
    """A folder holding no run but ``fields`` a link to another folder (before: the run wrote
    its VTU files there, exit 0): refused, the other folder stays empty."""
    out, other = tmp_path / "out", tmp_path / "other"
    out.mkdir()
    other.mkdir()
    (out / "fields").symlink_to(other)
    _refused(["run", BAR, "-o", str(out), "--no-progress"], capsys, "'fields'", "symbolic link")
    assert list(other.iterdir()) == []


def test_a_linked_aside_folder_is_removed_not_written_through(tmp_path):
    """``.vfrs-replaced`` (where --overwrite keeps the old run's files) a link to another folder
    (before: the old run's scene.toml replaced that folder's scene.toml): the link is removed
    and the other folder untouched."""
    out = _old_run(tmp_path)
    other = tmp_path / "other"
    other.mkdir()
    (other / "scene.toml").write_text("not vfrs's")
    (out / ".vfrs-replaced").symlink_to(other)
    assert main(["run", BAR, "-o", str(out), "--no-progress", "--overwrite"]) == 0
    assert _tree(other) == {"scene.toml": b"not vfrs's"}
    assert not (out / ".vfrs-replaced").exists()


def _stopped(tmp_path) -> Path:
    """A run stopped with a checkpoint (its lists in checkpoint_rows/)."""
    sys.path.insert(0, str(Path(__file__).parent))
    from test_checkpoint import _blocks_scene, _stopped_at

    out = tmp_path / "stopped"
    _stopped_at(_blocks_scene(), out, 12)
    assert (out / "checkpoint_rows").is_dir()
    return out


def test_resume_refuses_checkpoint_lists_linked_outside(tmp_path, capsys):
    """``checkpoint_rows`` a link to another folder (before: --resume removed that folder's
    files the checkpoint does not name, and cut the others), or one list's file a link to a
    file outside (before: cut to the checkpoint's length): a CheckpointError, nothing changed."""
    out = _stopped(tmp_path)
    other = tmp_path / "rows"
    (out / "checkpoint_rows").rename(other)
    (out / "checkpoint_rows").symlink_to(other)
    (other / "victim.txt").write_text("not vfrs's")
    before = _tree(other)
    _refused(["run", "--resume", str(out), "--no-progress"], capsys, "checkpoint_rows", "outside the folder")
    with pytest.raises(CheckpointError, match="symbolic link"):
        resume(out, progress=False)
    assert _tree(other) == before

    (out / "checkpoint_rows").unlink()
    (out / "checkpoint_rows").mkdir()
    names = sorted(p.name for p in other.iterdir() if p.suffix == ".bin")
    for n in names:
        (out / "checkpoint_rows" / n).symlink_to(other / n)
    with open(other / names[0], "ab") as fh:
        fh.write(b"more than the checkpoint counts")
    before = _tree(other)
    _refused(["run", "--resume", str(out), "--no-progress"], capsys, names[0], "outside the folder")
    assert _tree(other) == before


SWEEP = f"""
base = "{Path(BAR).as_posix()}"
[[axes]]
key = "bodies[0].material.E"
values = [20e3, 30e3]
[derived]
tip_mm = "max(history.t) * 1e3"
"""


def _sweep(tmp_path, text=SWEEP) -> Path:
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    return path


def test_a_sweep_refuses_a_runs_folder_linked_outside(tmp_path, capsys):
    """``OUT/runs`` a link to another folder (before: the runs were written, replaced and
    removed there): exit 2, one line naming it, the other folder untouched."""
    path = _sweep(tmp_path)
    other = tmp_path / "other"
    other.mkdir()
    (other / "victim.txt").write_text("not vfrs's")
    out = tmp_path / "out"
    out.mkdir()
    (out / "runs").symlink_to(other)
    capsys.readouterr()
    assert main(["sweep", str(path), "-o", str(out), "--serial"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'runs'" in err and "outside the folder" in err, err
    assert _tree(other) == {"victim.txt": b"not vfrs's"}


def test_a_sweep_record_naming_another_run_is_not_trusted(tmp_path):
    """A finished run's ``sweep_run.json`` whose id is a path (``../../elsewhere``; the id names
    the folder that vfrs converge and the table read): not taken as finished, the run runs
    again, and the table's id is the folder's."""
    path = _sweep(tmp_path)
    out = tmp_path / "out"
    first = sw.run_sweep(path, out, serial=True, log=lambda m: None)
    run_id = first.rows[0]["id"]
    rec_path = out / "runs" / run_id / sw.RUN_FILE
    rec = json.loads(rec_path.read_text())
    rec["id"] = "../../elsewhere"
    rec_path.write_text(json.dumps(rec))
    with pytest.raises(VfrsError, match="not this folder's run"):
        sw.collect(str(out / "runs" / run_id), {})
    again = sw.run_sweep(path, out, serial=True, log=lambda m: None)
    assert again.submitted == 1 and again.skipped == 1
    assert [r["id"] for r in again.rows] == [r["id"] for r in first.rows]
    assert json.loads(rec_path.read_text())["id"] == run_id


# -- item 2: a derived expression cannot hang the process ------------------------------------

@pytest.mark.parametrize("expr", ["9**9**9", "10**10**10", "2**1000 * 2**1000", "(10**300)**4", "'ab' * 10**9",
                                  "history.t[0] + 7**7**7"])
def test_a_huge_constant_expression_is_refused_when_the_sweep_is_read(tmp_path, expr):
    """Before: ``9**9**9`` never returned (an exact integer of 1.2e9 bits). Now a SceneError
    naming the sweep file and the column, within a second, before anything runs."""
    path = _sweep(tmp_path, SWEEP.replace('tip_mm = "max(history.t) * 1e3"', f'huge = "{expr}"'))
    t0 = time.perf_counter()
    with pytest.raises(SceneError, match=r"sweep\.toml: derived\.huge: .*(bits|arithmetic on str)") as e:
        sw.load_sweep(path)
    assert time.perf_counter() - t0 < 1.0
    assert "\n" not in str(e.value)
    assert not (tmp_path / "out").exists()


def test_a_huge_power_of_run_values_is_an_error_of_its_column(tmp_path):
    """An exponent known only from the run (``len(history.t) ** 10**6``): the run's cell is
    empty, ``derived_errors`` names the column and the part of the expression, promptly."""
    from vfrs.studies.derived import Namespace, check_expression, evaluate

    history = Namespace("history", {"t": [0.0, 1.0, 2.0]}.__getitem__)
    t0 = time.perf_counter()
    with pytest.raises(VfrsError, match=r"len\(history.t\) \*\* 10 \*\* 6: 3 \*\* 1000000 would be an integer of "
                                        r"about 1.58e\+06 bits"):
        evaluate(check_expression("len(history.t) ** 10**6"), {"history": history})
    assert time.perf_counter() - t0 < 1.0
    path = _sweep(tmp_path, SWEEP + 'big = "len(history.t) ** 10**6"\n')
    res = sw.run_sweep(path, tmp_path / "out", serial=True, log=lambda m: None)
    assert res.failed == 0 and all(r["big"] is None for r in res.rows)
    assert all("big: VfrsError: len(history.t) ** 10 ** 6: 3 ** 1000000" in r["derived_errors"] for r in res.rows)
    assert [name for name, _, _ in res.derived_failed] == ["big", "big"]


@pytest.mark.parametrize("expr, value", [("2**10", 1024), ("(-2)**3", -8), ("2**-2", 0.25), ("7 // 2", 3),
                                         ("7 % 4 + 0.5", 3.5), ("-(3 * 4)", -12), ("2**1023", 2**1023),
                                         ("max(history.t) * 1e3", 2000.0), ("history.t[-1] ** 2", 4.0),
                                         ("sum(history.t[1:]) / len(history.t)", 1.0)])
def test_ordinary_expressions_give_the_values_they_gave(expr, value):
    import numpy as np

    from vfrs.studies.derived import Namespace, check_expression, evaluate

    history = Namespace("history", {"t": np.array([0.0, 1.0, 2.0])}.__getitem__)
    got = evaluate(check_expression(expr), {"history": history})
    assert got == value and type(got) is type(value)


# -- item 3: a damaged or missing file of a folder is one line, never a traceback ------------

def _checkpoint_helpers():
    sys.path.insert(0, str(Path(__file__).parent))
    import test_checkpoint

    return test_checkpoint


@pytest.fixture(scope="module")
def blocks_run(tmp_path_factory):
    """A complete run of two blocks in contact (summary.json, contact_peak.npz, two .pvd)."""
    out = tmp_path_factory.mktemp("blocks") / "out"
    vfrs.run(_checkpoint_helpers()._blocks_scene(), out=out, progress=False)
    return out


def _copy(src: Path, dst: Path, name: str, keep: int | None) -> Path:
    """``src`` copied to ``dst`` with the file ``name`` cut to ``keep`` bytes (None: removed)."""
    import shutil

    shutil.copytree(src, dst)
    path = dst / name
    if keep is None:
        path.unlink()
    else:
        with open(path, "r+b") as fh:
            fh.truncate(keep)
    return path


def test_plot_of_a_truncated_summary_json_is_one_line_saying_what_to_do(blocks_run, tmp_path, capsys):
    """Before: a JSONDecodeError traceback. Now exit 2, one line naming the file and what to do;
    doing it (removing the file) lets vfrs plot compute the summary from the history."""
    out = tmp_path / "out"
    path = _copy(blocks_run, out, "summary.json", 100)
    _refused(["plot", str(out)], capsys, f"{path}: damaged or incomplete", "JSONDecodeError", "remove it")
    with pytest.raises(VfrsError, match="summary.json: damaged or incomplete"):
        vfrs.load(out).summary
    path.write_text("[1, 2]")  # JSON, but not a summary
    _refused(["plot", str(out)], capsys, f"{path}: damaged or incomplete", "not the dict vfrs writes")
    path.unlink()
    assert main(["plot", str(out)]) == 0


def test_plot_of_a_truncated_scene_toml_names_it_and_the_copy_in_the_history(blocks_run, tmp_path, capsys):
    out = tmp_path / "out"
    path = _copy(blocks_run, out, "scene.toml", 40)
    _refused(["plot", str(out)], capsys, f"{path}: damaged or incomplete", "inside history.npz")
    path.unlink()
    assert main(["plot", str(out)]) == 0  # the copy inside history.npz


def test_a_missing_or_doctored_pvd_is_one_line(blocks_run, tmp_path):
    """``<body>.pvd`` (the field series vfrs plot reads when a run has no contact_peak.npz):
    missing is a VfrsError naming it (before: FileNotFoundError); a series naming a file outside
    the folder is an OutputFolderError, the file never read."""
    out = tmp_path / "out"
    path = _copy(blocks_run, out, "up.pvd", None)
    with pytest.raises(VfrsError, match=r"up\.pvd: damaged or incomplete, cannot be read \(FileNotFoundError"):
        vfrs.output.load(out).snapshots("up")
    path.write_text((blocks_run / "up.pvd").read_text().replace('file="fields/', 'file="../fields/', 1))
    with pytest.raises(OutputFolderError, match=r"up\.pvd: names the path '\.\./fields/"):
        vfrs.output.load(out).snapshots("up")
    assert [t for t, _ in vfrs.output.load(blocks_run).snapshots("up")]  # the intact one reads


@pytest.fixture(scope="module")
def killed(tmp_path_factory):
    """Runs killed (SIGKILL) before their first history write: at step 4 before any checkpoint,
    at step 13 after the checkpoint of step 10."""
    tc = _checkpoint_helpers()
    tmp = tmp_path_factory.mktemp("killed")
    tc._killed(tmp / "early", 4, "None")
    tc._killed(tmp / "late", 13, 5)
    for out in (tmp / "early", tmp / "late"):
        assert not (out / "history.npz").exists()
    return tmp


def test_plot_of_a_run_stopped_before_its_first_history_says_so_and_how_to_go_on(killed, capsys):
    """Before: "no history.npz; give the output folder of `vfrs run SCENE -o OUT`", as if it
    were no run's folder. Now: the run was stopped, and how to resume it (or, with no
    checkpoint, how to run it again)."""
    late, early = killed / "late", killed / "early"
    _refused(["plot", str(late)], capsys, "no history.npz", "was stopped", f"vfrs run --resume {late}")
    _refused(["plot", str(early)], capsys, "no history.npz", "was stopped", "nothing to resume",
             f"vfrs run {early / 'scene.toml'} -o {early} --overwrite")


def test_resume_removes_stale_temporaries_and_rewrites_a_damaged_manifest(killed, tmp_path, capsys):
    """A ``manifest.json.tmp<pid>`` (and ``checkpoint.npz.tmp<pid>``) left by an atomic write a
    kill interrupted is removed on resume (before: left for good); a manifest cut short is
    written anew and run.log says so (before: silently)."""
    import shutil

    out = tmp_path / "late"
    shutil.copytree(killed / "late", out)
    stale = [out / "manifest.json.tmp4242", out / "checkpoint.npz.tmp4242"]
    for p in stale:
        p.write_bytes(b'{"status": "runn')
    (out / "notes.txt.tmp4242").write_text("not vfrs's")  # not a name of vfrs's: kept
    with open(out / "manifest.json", "r+b") as fh:
        fh.truncate(30)
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert not any(p.exists() for p in stale) and (out / "notes.txt.tmp4242").exists()
    log = (out / "run.log").read_text()
    assert f"vfrs run resumed" in log and "manifest.json: damaged or incomplete" in log and "written anew" in log
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"
    assert main(["plot", str(out)]) == 0


def test_a_sweep_over_a_damaged_run_folder_names_the_file_and_what_to_do(tmp_path, capsys):
    """A finished run's summary.json cut short: `vfrs sweep` again exits 2 with one line naming
    it and what to do (before: a JSONDecodeError traceback); doing it runs that run again. A
    history.npz cut short: its derived cells name the file (before: 'BadZipFile: File is not a
    zip file', no file named)."""
    path = _sweep(tmp_path)
    out = tmp_path / "out"
    first = sw.run_sweep(path, out, serial=True, log=lambda m: None)
    folder = out / "runs" / first.rows[0]["id"]
    with open(folder / "summary.json", "r+b") as fh:
        fh.truncate(50)
    capsys.readouterr()
    assert main(["sweep", str(path), "-o", str(out), "--serial"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[-1].startswith(f"vfrs: error: {folder / 'summary.json'}: damaged or incomplete") and "Traceback" not in err
    assert f"remove the folder {folder} and run the sweep again" in err[-1]
    import shutil

    shutil.rmtree(folder)
    assert main(["sweep", str(path), "-o", str(out), "--serial"]) == 0

    with open(folder / "history.npz", "r+b") as fh:
        fh.truncate(100)
    capsys.readouterr()
    assert main(["sweep", str(path), "-o", str(out), "--serial"]) == 1
    err = capsys.readouterr().err
    assert f"{folder / 'history.npz'}: damaged or incomplete" in err and "Traceback" not in err


def test_a_history_npz_without_its_times_is_one_line(blocks_run, tmp_path, capsys):
    """An npz that reads but lacks ``t`` (not vfrs's history): before, a KeyError traceback."""
    import numpy as np

    out = tmp_path / "out"
    path = _copy(blocks_run, out, "history.npz", None)
    np.savez(path, x=np.zeros(3))
    _refused(["plot", str(out)], capsys, f"{path}: damaged or incomplete", "no array 't'")


def test_resume_with_a_scene_toml_cut_short_says_what_to_do(killed, tmp_path, capsys):
    """Before: `OUT/scene.toml: bodies: missing; expected an array`, which names the file but
    not that the run needs the scene it started with, nor how to go on."""
    import shutil

    out = tmp_path / "late"
    shutil.copytree(killed / "late", out)
    with open(out / "scene.toml", "r+b") as fh:
        fh.truncate(60)
    _refused(["run", "--resume", str(out), "--no-progress"], capsys, f"{out / 'scene.toml'}: damaged or incomplete",
             "the scene the run started with", f"-o {out} --overwrite")


@pytest.mark.parametrize("entry", ["a\x00b", ".", {"file": "x"}])
def test_a_manifest_entry_that_is_no_path_is_refused_not_a_traceback(tmp_path, capsys, entry):
    """A NUL byte (before: skipped, and realpath would raise a bare ValueError), the folder
    itself, or not a string: the named error, nothing moved."""
    out = _old_run(tmp_path)
    _list(out, entry)
    before = _tree(out)
    _refused(["run", BAR, "-o", str(out), "--no-progress", "--overwrite"], capsys, "outside the folder")
    assert _tree(out) == before


@pytest.mark.parametrize("name, keep, words", [
    ("checkpoint.npz", 200, ["checkpoint.npz: cannot be read (BadZipFile", "--overwrite"]),
    ("checkpoint_rows/0.0.bin", 3, ["0.0.bin: 3 bytes, the checkpoint counts", "--overwrite"])])
def test_resume_of_a_cut_checkpoint_is_one_line(killed, tmp_path, capsys, name, keep, words):
    """The checkpoint's own files cut short (these were one line before this issue already:
    kept here so that every file --resume reads has its test)."""
    import shutil

    out = tmp_path / "late"
    shutil.copytree(killed / "late", out)
    with open(out / name, "r+b") as fh:
        fh.truncate(keep)
    _refused(["run", "--resume", str(out), "--no-progress"], capsys, *words)


def test_resume_of_a_checkpoint_without_its_scene_hash_is_one_line(killed, tmp_path, capsys):
    """A checkpoint whose document lacks a key the resume reads (here ``scene_hash``; before:
    a KeyError traceback from vfrs.run.resume) is refused in one line naming the key."""
    import json
    import shutil

    import numpy as np

    from vfrs.checkpoint import _DOC

    out = tmp_path / "late"
    shutil.copytree(killed / "late", out)
    with np.load(out / "checkpoint.npz", allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    doc = json.loads(str(arrays[_DOC][()]))
    doc["state"]["dict"] = [kv for kv in doc["state"]["dict"] if kv[0] != "scene_hash"]  # the skeleton's key list
    arrays[_DOC] = np.array(json.dumps(doc))
    np.savez(out / "checkpoint.npz", allow_pickle=False, **arrays)
    _refused(["run", "--resume", str(out), "--no-progress"], capsys, "checkpoint.npz", "no scene_hash", "--overwrite")


def test_plot_of_a_run_without_contact_peak_and_a_cut_snapshot_is_one_line(blocks_run, tmp_path, capsys):
    """Without contact_peak.npz the pressure map is drawn from the field snapshot nearest the
    peak force; that snapshot cut short was a meshio traceback, now one line naming it."""
    pytest.importorskip("matplotlib")
    out = tmp_path / "out"
    _copy(blocks_run, out, "contact_peak.npz", None)
    for vtu in (out / "fields").rglob("*.vtu"):
        with open(vtu, "r+b") as fh:
            fh.truncate(300)
    _refused(["plot", str(out)], capsys, ".vtu: damaged or incomplete")


def test_a_checkpoint_holds_every_key_a_resume_reads(killed):
    """RESUME_READS (what vfrs.run.resume checks a checkpoint for) is what a run writes: the
    check can neither miss a key nor refuse a checkpoint vfrs wrote."""
    from vfrs.checkpoint import read_checkpoint
    from vfrs.run.march import RESUME_READS

    assert set(read_checkpoint(killed / "late")) - {"_rows"} == set(RESUME_READS)
