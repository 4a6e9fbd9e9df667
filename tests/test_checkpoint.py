"""Nothing lost (issue 15): a run killed with SIGKILL at a random step resumes from its last
checkpoint and ends bit-identical to the uninterrupted run (history, probes, every field of
every VTU); SIGTERM and SIGINT end a run cleanly with a checkpoint and say how to resume."""

from __future__ import annotations

import glob
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.checkpoint import CheckpointError
from vfrs.run import resume

ROOT = Path(__file__).resolve().parent.parent
# The main job, coarse and shortened: the folds touch from about 2 ms on (step 40), so the
# kill falls inside contact (interface mesh, Lagrange, stabilized predictor, flow).
SCENE = ["examples/m5_collision.toml", "--set", "bodies[0].mesh.resolution='coarse'",
         "--set", "bodies[1].mesh.resolution='coarse'", "--set", "time.end=0.008"]
N_STEPS = 160


def vfrs_cmd(*args):
    return [sys.executable, "-m", "vfrs", "run", *args, "--no-progress"]


def start(out, *extra):
    return subprocess.Popen(vfrs_cmd(*SCENE, "-o", str(out), *extra), cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def wait_for_checkpoint(out, proc, timeout=60.0):
    """Until run.log reports a checkpoint (the run is then at least 10 steps in)."""
    t0 = time.monotonic()
    log = Path(out) / "run.log"
    while time.monotonic() - t0 < timeout:
        if log.exists() and "checkpoint after step" in log.read_text():
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)
    raise AssertionError("no checkpoint written")


def assert_same_output(a, b):
    """Every array of history.npz and probes.npz, every point field of every VTU and the .pvd
    series are exactly equal."""
    for name in ("history.npz", "probes.npz"):
        A, B = np.load(Path(a) / name, allow_pickle=False), np.load(Path(b) / name, allow_pickle=False)
        assert list(A.keys()) == list(B.keys())
        for k in A.keys():
            x, y = A[k], B[k]
            if x.dtype == object:
                assert len(x) == len(y) and all(np.array_equal(p, q) for p, q in zip(x, y)), (name, k)
            else:
                assert x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), (name, k)
    import meshio

    va = sorted(os.path.relpath(p, a) for p in glob.glob(os.path.join(a, "fields", "*.vtu")))
    vb = sorted(os.path.relpath(p, b) for p in glob.glob(os.path.join(b, "fields", "*.vtu")))
    assert va == vb and len(va) == 2 * (N_STEPS // 20 + 1)
    for f in va:
        A, B = meshio.read(os.path.join(a, f)), meshio.read(os.path.join(b, f))
        assert set(A.point_data) == set(B.point_data)
        for k in A.point_data:
            assert np.array_equal(A.point_data[k], B.point_data[k]), (f, k)
    for p in ("right.pvd", "left.pvd"):
        assert (Path(a) / p).read_text() == (Path(b) / p).read_text()
    assert (Path(a) / "history.csv").read_text() == (Path(b) / "history.csv").read_text()


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "run"
    p = subprocess.run(vfrs_cmd(*SCENE, "-o", str(out)), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    h = np.load(out / "history.npz")
    assert len(h["t"]) == N_STEPS + 1 and h["active_pairs"].max() > 0  # contact happens
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "complete" and not (out / "checkpoint.npz").exists()
    assert not (out / "checkpoint_rows").exists()  # the checkpoint's lists go with it
    return out


def test_kill_9_at_a_random_step_then_resume_is_bit_identical(reference, tmp_path):
    for attempt in range(3):  # on a loaded machine the delay may outlast the run: try again, sooner
        out = tmp_path / f"run{attempt}"
        proc = start(out, "--checkpoint-every", "10")
        wait_for_checkpoint(out, proc)
        time.sleep(random.uniform(0.0, 0.6 / (1 + 2 * attempt)))
        proc.send_signal(signal.SIGKILL)
        proc.communicate()
        done = json.loads((out / "manifest.json").read_text()).get("status") == "complete"
        if proc.returncode == -signal.SIGKILL and not done:  # a kill after the run completed is no test
            break
    assert proc.returncode == -signal.SIGKILL and not done, "the run ended before the kill"
    from vfrs.checkpoint import read_checkpoint

    rows = len((out / "history.csv").read_text().splitlines()) - 1
    # The checkpoint file is renamed into place first, then the history, probes, manifest and
    # the run.log line follow: a kill in between leaves the log one checkpoint behind.
    last = int(read_checkpoint(out)["step"])
    lines = [ln for ln in (out / "run.log").read_text().splitlines() if ln.startswith("checkpoint after step")]
    logged = int(lines[-1].split()[3])
    print(f"killed after the checkpoint of step {last} (logged: {logged}; {rows} rows in history.csv)")
    assert 10 <= last < N_STEPS and logged in (last, last - 10)
    # What was saved is readable as it is: history.csv is appended before each checkpoint is
    # written, so it holds at least the checkpoint's rows (history.npz is written at the end,
    # on a stop or a failure: checkpoints do not rewrite it).
    assert rows >= last + 1
    assert not (out / "history.npz").exists()
    p = subprocess.run(vfrs_cmd("--resume", str(out)), cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert f"resumed from the checkpoint after step {last}" in (out / "run.log").read_text()
    assert_same_output(reference, out)
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"


def test_a_complete_run_with_a_spare_checkpoint_is_not_resumed(reference, tmp_path):
    """A run that completes writes its manifest before it removes its checkpoint (a kill -9
    between the two once left a folder with neither: the kill test above found it); a complete
    folder that still holds a checkpoint is complete to --resume."""
    import shutil

    from vfrs.checkpoint import read_checkpoint
    from vfrs.errors import CheckpointError

    out = tmp_path / "run"
    shutil.copytree(reference, out)
    (out / "checkpoint.npz").write_bytes(b"left behind by a kill")
    with pytest.raises(CheckpointError, match="is complete"):
        read_checkpoint(out)


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_sigterm_and_sigint_stop_cleanly_with_a_checkpoint(reference, tmp_path, sig, code):
    out = tmp_path / "run"
    proc = start(out, "--checkpoint-every", "10")
    wait_for_checkpoint(out, proc)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    assert "Traceback" not in err
    name = signal.Signals(sig).name
    assert f"vfrs: {name} received: stopped after step" in err and f"vfrs run --resume {out}" in err
    log = (out / "run.log").read_text()
    assert f"stopped by {name} after step" in log and f"Resume with: vfrs run --resume {out}" in log
    step = int(log.split(f"stopped by {name} after step ")[1].split()[0])
    assert len(np.load(out / "history.npz")["t"]) == step + 1  # history flushed with the checkpoint
    assert len((out / "history.csv").read_text().splitlines()) == step + 2
    assert json.loads((out / "manifest.json").read_text())["status"] == "stopped"
    res = resume(out, progress=False)
    assert len(res.t) == N_STEPS + 1
    assert_same_output(reference, out)


def test_resume_refuses_a_running_run_a_changed_scene_and_a_complete_run(reference, tmp_path):
    from vfrs.output.writer import OutputFolderError

    out = tmp_path / "run"
    proc = start(out, "--checkpoint-every", "10")
    wait_for_checkpoint(out, proc)
    with pytest.raises(OutputFolderError, match=f"process {proc.pid} on this machine.* is still writing there"):
        resume(out, progress=False)
    with pytest.raises(OutputFolderError, match="still writing there"):
        vfrs.run(vfrs.Scene.load(out / "scene.toml"), out=out, overwrite=True, progress=False)
    proc.send_signal(signal.SIGTERM)
    proc.communicate(timeout=60)
    scene = out / "scene.toml"
    text = scene.read_text()
    scene.write_text(text.replace("subglottal_pressure = 800.0", "subglottal_pressure = 900.0"))
    with pytest.raises(CheckpointError, match="not the scene the run started with"):
        resume(out, progress=False)
    with pytest.raises(CheckpointError, match="complete"):
        resume(reference, progress=False)
    with pytest.raises(CheckpointError, match="no such folder"):
        resume(tmp_path / "nothing", progress=False)


def test_state_protocol_defaults_keep_nothing():
    from vfrs.effects import Effect

    e = Effect({})
    assert e.state() == {}
    e.restore({})  # nothing to do
    assert vfrs.checkpoint.state_of(object()) == {}


class _Terminate:
    """An effect that sends the run SIGTERM from its record hook at one step (in-process)."""

    def __new__(cls, step):
        from vfrs.effects import Effect

        class Terminate(Effect):
            name = "terminate"

            def record(self, state, history):
                if state.step == step:
                    os.kill(os.getpid(), signal.SIGTERM)

        return Terminate({})


@pytest.mark.parametrize("mode", ["static", "dynamic"])
def test_static_and_dynamic_contact_in_process_stop_and_resume(tmp_path, mode):
    """Two blocks pressed together (BVH, augmented Lagrange: penalty solves with
    augmentations), statically in load steps and dynamically: SIGTERM at step 17 from inside
    the run, then resume: the same history as one run."""
    import sys as _sys

    _sys.path.insert(0, str(Path(__file__).parent))
    from test_architecture import blocks

    from vfrs.checkpoint import RunStopped
    from vfrs.effects import EFFECTS

    d = blocks({"method": "augmented_lagrange", "kappa": 1e9, "detection": "bvh"})
    d["time"] = {"mode": "static", "load_steps": 30} if mode == "static" else {"mode": "dynamic", "step": 2e-3,
                                                                               "end": 0.06}
    d["output"] = {"energy": True, "every": 5}
    scene = vfrs.Scene.from_dict(d)
    ref = vfrs.run(scene, out=tmp_path / "ref", progress=False)
    assert ref.history["active_pairs"].max() > 0
    out = tmp_path / "run"
    effects = [EFFECTS[n](p) for n, p in scene.effects.items()] + [_Terminate(17)]
    with pytest.raises(RunStopped) as stop:
        vfrs.run(scene, out=out, progress=False, effects=effects, checkpoint_seconds=None)
    assert stop.value.step == 17 and stop.value.exit_code == 143
    res = resume(out, progress=False)
    assert list(ref.history) == list(res.history)
    for k, v in ref.history.items():
        assert np.array_equal(v, res.history[k], equal_nan=True), k
    for k, v in ref.fields.items():
        assert np.array_equal(v, res.fields[k]), k
    A, B = np.load(tmp_path / "ref" / "history.npz"), np.load(out / "history.npz")
    assert all(np.array_equal(A[k], B[k], equal_nan=A[k].dtype.kind == "f") for k in A.keys())


# -- issue 30, items 3 and 8: checkpoints that hold only the state and cannot run code --------

def _blocks_scene(steps=60, every=5):
    """The two blocks of test_architecture pressed together dynamically (contact, energy)."""
    import sys as _sys

    _sys.path.insert(0, str(Path(__file__).parent))
    from test_architecture import blocks

    d = blocks({"method": "augmented_lagrange", "kappa": 1e9, "detection": "bvh"})
    d["time"] = {"mode": "dynamic", "step": 1e-3, "end": steps * 1e-3}
    d["output"] = {"energy": True, "every": every}
    return vfrs.Scene.from_dict(d)


def _stopped_at(scene, out, step, **kw):
    """Runs ``scene`` into ``out`` and stops it with SIGTERM after ``step`` (a checkpoint there)."""
    from vfrs.checkpoint import RunStopped
    from vfrs.effects import EFFECTS

    effects = [EFFECTS[n](p) for n, p in scene.effects.items()] + [_Terminate(step)]
    with pytest.raises(RunStopped):
        vfrs.run(scene, out=out, progress=False, effects=effects, checkpoint_seconds=None, **kw)


class _Payload:
    """Unpickling it creates the file ``marker`` (what a malicious pickle would do, harmlessly)."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_a_planted_pickle_or_object_array_is_refused_and_never_run(tmp_path):
    """A run folder received from someone else cannot run code on --resume: a checkpoint.pkl
    (the format before) is refused without being unpickled, and a checkpoint.npz holding an
    array of Python objects is refused without loading it. The payload's marker file never
    appears. (Before: checkpoint.pkl was pickle.load-ed, which created the marker.)"""
    import pickle

    out = tmp_path / "run"
    _stopped_at(_blocks_scene(), out, 7)
    good = dict(np.load(out / "checkpoint.npz", allow_pickle=False))
    marker = tmp_path / "marker"
    assert pickle.loads(pickle.dumps(_Payload(tmp_path / "check"))) and (tmp_path / "check").exists()  # it works

    (out / "checkpoint.npz").rename(tmp_path / "saved.npz")
    (out / "checkpoint.pkl").write_bytes(pickle.dumps({"format": 1, "evil": _Payload(marker)}))
    with pytest.raises(CheckpointError, match=r"checkpoint\.pkl: a checkpoint of an earlier vfrs version, a Python "
                                              r"pickle, which vfrs no longer loads.* -o \S+ --overwrite"):
        resume(out, progress=False)
    assert not marker.exists()

    evil = np.empty(1, dtype=object)
    evil[0] = _Payload(marker)
    np.savez(out / "checkpoint.npz", **good, evil=evil)  # numpy pickles an object array
    with pytest.raises(CheckpointError, match=r"checkpoint\.npz: the member 'evil' is an array of Python objects"):
        resume(out, progress=False)
    assert not marker.exists()
    # A file name in the JSON that leaves checkpoint_rows/ is refused, not read or truncated.
    import json as _json

    doc = _json.loads(str(good["__checkpoint__"]))
    path = next(iter(doc["rows"]))
    doc["rows"][path]["file"] = "../scene.toml"
    np.savez(out / "checkpoint.npz", **{**good, "__checkpoint__": np.array(_json.dumps(doc))})
    before = (out / "scene.toml").read_text()
    with pytest.raises(CheckpointError, match=r"names the file '\.\./scene\.toml', not one vfrs writes"):
        resume(out, progress=False)
    assert (out / "scene.toml").read_text() == before


def test_an_unsupported_state_is_a_checkpoint_error_naming_its_key(tmp_path):
    """A new effect whose state() holds an object a checkpoint cannot store (here a set and a
    Fraction) is told at the run's first step, with the key and the type; not at the first
    checkpoint, and never pickled."""
    from fractions import Fraction

    from vfrs.checkpoint import flatten
    from vfrs.effects import EFFECTS, Effect

    class Odd(Effect):
        name = "odd"

        def state(self):
            return {"fine": [np.zeros(2), 1, 2.5, "s", None, True, (np.float64(3), {"k": np.int64(4)})],
                    "bad": {"ratio": Fraction(1, 3)}}

    scene = _blocks_scene(steps=10)
    effects = [EFFECTS[n](p) for n, p in scene.effects.items()] + [Odd({})]
    with pytest.raises(CheckpointError, match=r"effects/odd/bad/ratio is a fractions\.Fraction"):
        vfrs.run(scene, out=tmp_path / "run", progress=False, effects=effects, checkpoint_seconds=None)
    with pytest.raises(CheckpointError, match=r"a/0 is a builtins\.set"):
        flatten({"a": [{1, 2}]}, "", {})
    with pytest.raises(CheckpointError, match=r"x is an array of dtype object"):
        flatten({"x": np.array([None])}, "", {})


def test_checkpoint_size_does_not_grow_with_the_steps(tmp_path):
    """The checkpoint after 4N steps is the size of the one after N (the state only); what
    the history adds goes once into checkpoint_rows/, appended (before: the pickle held the
    whole history and snapshots, and history.npz and probes.npz were rewritten at every
    checkpoint)."""
    scene = _blocks_scene(steps=60)
    sizes, rows = {}, {}
    for n in (10, 40):
        out = tmp_path / f"run{n}"
        _stopped_at(scene, out, n, checkpoint_every=5)
        sizes[n] = (out / "checkpoint.npz").stat().st_size
        rows[n] = sum(f.stat().st_size for f in (out / "checkpoint_rows").iterdir())
        doc = json.loads(str(np.load(out / "checkpoint.npz", allow_pickle=False)["__checkpoint__"]))
        assert doc["rows"]["recorder/history/t"]["count"] == n + 1  # the history is in the appended files
        log = (out / "run.log").read_text()
        written = [float(ln.split(": ")[1].split(" MB")[0]) for ln in log.splitlines()
                   if ln.startswith("checkpoint after step")]
        assert len(written) == n // 5
    print(f"checkpoint.npz: {sizes}; checkpoint_rows/: {rows}; last checkpoint wrote {written[-1]} MB")
    assert abs(sizes[40] - sizes[10]) <= 0.03 * sizes[10]
    assert rows[40] > rows[10]
    # Each checkpoint wrote the state and five steps' rows: the last no more than the second.
    assert written[-1] <= 1.03 * written[1]


_KILLER = """
import os, signal, sys
sys.path.insert(0, {tests!r})
import vfrs
from vfrs.effects import EFFECTS, Effect
from test_checkpoint import _blocks_scene

class Kill(Effect):
    name = "kill"
    def record(self, state, history):
        if state.step == {step}:
            os.kill(os.getpid(), signal.SIGKILL)

scene = _blocks_scene()
effects = [EFFECTS[n](p) for n, p in scene.effects.items()] + [Kill({{}})]
vfrs.run(scene, out={out!r}, progress=False, effects=effects, checkpoint_every={every})
"""


def _killed(out, step, every):
    code = _KILLER.format(tests=str(Path(__file__).parent), step=step, out=str(out), every=every)
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert p.returncode == -signal.SIGKILL, p.stderr


def test_a_run_killed_early_leaves_history_csv_and_resumes_bit_identical(tmp_path):
    """SIGKILL at step 4, long before any checkpoint or the history timer: history.csv holds
    the first steps' rows (before: nothing until 5 s of wall time). Killed at step 13 with a
    checkpoint every 5 steps: --resume cuts off the rows written after step 10 and ends
    bit-identical to an uninterrupted run (history, fields, probes, history.csv)."""
    import csv

    scene = _blocks_scene()
    ref = vfrs.run(scene, out=tmp_path / "ref", progress=False)
    out = tmp_path / "early"
    _killed(out, 4, "None")
    with open(out / "history.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) >= 2 and not (out / "checkpoint.npz").exists()
    for i, row in enumerate(rows):
        assert float(row["t"]) == ref.history["t"][i] and float(row["kinetic_energy"]) == ref.history["kinetic_energy"][i]

    out = tmp_path / "late"
    _killed(out, 13, 5)
    assert vfrs.checkpoint.read_checkpoint(out)["step"] == 10
    res = resume(out, progress=False)
    assert list(ref.history) == list(res.history)
    for k, v in ref.history.items():
        assert np.array_equal(v, res.history[k], equal_nan=True), k
    for k, v in ref.fields.items():
        assert np.array_equal(v, res.fields[k]), k
    assert (out / "history.csv").read_text() == (tmp_path / "ref" / "history.csv").read_text()
    for name in ("up.pvd", "low.pvd"):
        assert (out / name).read_bytes() == (tmp_path / "ref" / name).read_bytes()
    A, B = np.load(tmp_path / "ref" / "history.npz"), np.load(out / "history.npz")
    assert all(np.array_equal(A[k], B[k], equal_nan=A[k].dtype.kind == "f") for k in A.keys())
    assert not (out / "checkpoint_rows").exists()


def test_a_ragged_record_resumes_and_history_npz_holds_no_pickle(tmp_path):
    """An effect recording a different number of values each step (a ragged record: an
    object array in memory) is checkpointed item by item and resumed bit-identical, and
    history.npz stores it as <key>.values and <key>.offsets, readable with allow_pickle=False
    (before: numpy pickled the object array into history.npz)."""
    from vfrs.effects import EFFECTS, Effect

    class Ragged(Effect):
        name = "ragged"

        def record(self, state, history):
            history.setdefault("ragged", []).append(np.arange(state.step % 3, dtype=float) + state.t)

    scene = _blocks_scene(steps=20)

    def effects(*extra):
        return [EFFECTS[n](p) for n, p in scene.effects.items()] + [Ragged({}), *extra]

    ref = vfrs.run(scene, out=tmp_path / "ref", progress=False, effects=effects())
    assert ref.history["ragged"].dtype == object
    out = tmp_path / "run"
    with pytest.raises(vfrs.checkpoint.RunStopped):
        vfrs.run(scene, out=out, progress=False, effects=effects(_Terminate(8)), checkpoint_every=3)
    res = vfrs.run(scene, out=out, progress=False, effects=effects(), _resume=vfrs.checkpoint.read_checkpoint(out))
    assert all(np.array_equal(a, b) for a, b in zip(ref.history["ragged"], res.history["ragged"]))
    with np.load(out / "history.npz", allow_pickle=False) as z:
        values, offsets = z["ragged.values"], z["ragged.offsets"]
        assert not any(z[k].dtype.hasobject for k in z.files)
    assert len(offsets) == len(ref.history["t"]) + 1
    for i, x in enumerate(ref.history["ragged"]):
        assert np.array_equal(values[offsets[i]:offsets[i + 1]], x)


def test_append_only_lists_round_trip_and_restart_on_a_new_epoch(tmp_path):
    """Journal: rows of an array appended checkpoint by checkpoint; a new epoch (the list
    started again, as the compliance columns after a reset) is written whole into a new file
    and the old file goes once the checkpoint is written; lists whose items change dtype or
    shape are kept item by item; a changed file is refused (crc32)."""
    from vfrs.checkpoint import Appended, Journal, read_checkpoint, write_checkpoint

    j = Journal(tmp_path)
    rows = np.arange(12.0).reshape(4, 3)
    items = [1, 2.5]
    write_checkpoint(tmp_path, {"F": Appended(rows[:2]), "h": Appended(items)}, j)
    items += [np.arange(2), "s"]  # other dtypes and shapes: item by item from now on
    write_checkpoint(tmp_path, {"F": Appended(rows[:4]), "h": Appended(items)}, j)
    got = read_checkpoint(tmp_path)
    assert np.array_equal(got["F"], rows) and got["h"][:2] == [1.0, 2.5] and np.array_equal(got["h"][2], [0, 1])
    assert got["h"][3] == "s"
    old = {f.name for f in (tmp_path / "checkpoint_rows").iterdir()}
    write_checkpoint(tmp_path, {"F": Appended(rows[2:3] * 7, epoch=1), "h": Appended(items)}, j)
    got = read_checkpoint(tmp_path)
    assert np.array_equal(got["F"], rows[2:3] * 7)
    assert len({f.name for f in (tmp_path / "checkpoint_rows").iterdir()} - old) == 1
    assert len(old - {f.name for f in (tmp_path / "checkpoint_rows").iterdir()}) == 1
    with pytest.raises(CheckpointError, match="got shorter"):
        write_checkpoint(tmp_path, {"F": Appended(rows[:0], epoch=1), "h": Appended(items)}, j)
    f = tmp_path / "checkpoint_rows" / j.meta["F"]["file"]
    f.write_bytes(f.read_bytes()[:-1] + b"\x01")
    with pytest.raises(CheckpointError, match="crc32 differs"):
        read_checkpoint(tmp_path)
