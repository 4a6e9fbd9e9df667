"""`vfrs sweep`: a sweep on a 2-worker LocalCluster gives the serial runs' numbers bit for bit,
a finished sweep runs nothing again, a bad axis key fails before anything runs, a failing run
is recorded with its error and retried, and the summary table has a row per combination."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

import vfrs.studies.sweep as sw
from vfrs.errors import SceneError

ROOT = Path(__file__).resolve().parent.parent
MAIN = (ROOT / "examples" / "m5_collision.toml").as_posix()

# The main job, coarse, shortened to 3 ms (the folds touch from about 2 ms on): ~0.7 s a run.
SWEEP = f"""
base = "{MAIN}"
[set]
"bodies[0].mesh.resolution" = "coarse"
"bodies[1].mesh.resolution" = "coarse"
"time.end" = 0.003
[[axes]]
key = "flow.subglottal_pressure"
values = [600.0, 800.0]
[[axes]]
key = "contact.detection"
values = ["interface_mesh", "bvh"]
[derived]
peak_force_mN = "summary.contact.peak_force.right * 1e3"
max_flow_mL_s = "max(history.flow_rate) * 1e6"
last_t_ms = "history.t[-1] * 1e3"
"""


def write(tmp_path, text, name="sweep.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def histories(out):
    runs = Path(out) / "runs"
    return {d.name: dict(np.load(d / "history.npz")) for d in sorted(runs.iterdir()) if d.is_dir()}


def same(a, b):
    return np.array_equal(a, b, equal_nan=a.dtype.kind in "fc")


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("serial")
    path = write(tmp, SWEEP)
    res = sw.run_sweep(path, tmp / "out", serial=True, log=lambda m: None)
    return path, tmp / "out", res


def test_two_dask_workers_give_the_serial_runs_bit_for_bit(serial, tmp_path, capsys):
    path, serial_out, _ = serial
    res = sw.run_sweep(path, tmp_path / "out", workers=2, log=lambda m: None, progress=True)
    assert res.submitted == 4 and res.failed == 0
    # dask's progress bar, drawn on stdout by its own thread while the tasks ran
    assert "100% Completed" in capsys.readouterr().out
    a, b = histories(serial_out), histories(tmp_path / "out")
    assert sorted(a) == sorted(b) and len(a) == 4
    for run_id in a:
        assert sorted(a[run_id]) == sorted(b[run_id])
        for key in a[run_id]:
            assert same(a[run_id][key], b[run_id][key]), (run_id, key)
    # each worker ran with one thread for the Rust core
    rec = json.loads((tmp_path / "out" / "runs" / run_id / sw.RUN_FILE).read_text())
    assert rec["threads"]["RAYON_NUM_THREADS"] == "1"
    assert not [p for p in (tmp_path / "out" / "runs").iterdir() if ".tmp-" in p.name]


def test_the_table_has_a_row_per_combination_with_the_swept_values(serial):
    _, out, res = serial
    table = pq.read_table(out / "summary.parquet").to_pydict()
    assert table["flow.subglottal_pressure"] == [600.0, 600.0, 800.0, 800.0]
    assert table["contact.detection"] == ["interface_mesh", "bvh"] * 2
    assert table["status"] == ["complete"] * 4
    assert all(t > 0 for t in table["wall_time [s]"])
    assert table["last_t_ms"] == pytest.approx([3.0] * 4)
    f = table["contact.peak_force.right [N]"]
    assert table["peak_force_mN"] == pytest.approx([x * 1e3 for x in f]) and min(f) > 0
    assert all(v > 0 for v in table["max_flow_mL_s"])
    for col in ("contact.peak_contact_pressure [Pa]", "contact.max_intersection_volume [m^3]",
                "contact.max_contact_area [m^2]", "contact.first_contact [s]", "contact.peak_force.left [N]"):
        assert len(table[col]) == 4
    # each run folder has vfrs run's layout plus the swept values
    for run_id, pressure in zip(table["id"], table["flow.subglottal_pressure"]):
        folder = out / "runs" / run_id
        for name in ("scene.toml", "history.npz", "summary.json", "manifest.json", "run.log"):
            assert (folder / name).exists()
        assert json.loads((folder / "params.json").read_text())["params"]["flow.subglottal_pressure"] == pressure
    assert (out / "summary.csv").read_text().splitlines()[0].startswith("id,flow.subglottal_pressure,contact.detection")


def test_rerunning_a_finished_sweep_runs_nothing(serial, monkeypatch):
    path, out, _ = serial
    before = {p: p.stat().st_mtime_ns for p in (out / "runs").glob("*/history.npz")}
    monkeypatch.setattr(sw.task, "_run_scene", lambda scene, folder: pytest.fail("a finished run ran again"))
    res = sw.run_sweep(path, out, serial=True, log=lambda m: None)
    assert res.submitted == 0 and res.skipped == 4
    assert [r["skipped"] for r in res.rows] == [True] * 4 and [r["status"] for r in res.rows] == ["complete"] * 4
    assert before == {p: p.stat().st_mtime_ns for p in (out / "runs").glob("*/history.npz")}
    table = pq.read_table(out / "summary.parquet").to_pydict()
    assert len(table["id"]) == 4 and all(v > 0 for v in table["peak_force_mN"])


def test_a_run_finished_by_another_vfrs_build_runs_again(serial, monkeypatch, tmp_path):
    """Skipping goes by the run's scene and the build that made it (sweep_run.json's vfrs.code,
    the table's `vfrs code`): after a code change a sweep runs again, never mixing builds
    silently; each run records its peak memory."""
    path, out, _ = serial
    table = pq.read_table(out / "summary.parquet").to_pydict()
    assert set(table["vfrs code"]) == {sw.code_id()} and all(20 < m < 5000 for m in table["peak_rss [MB]"])
    copy = tmp_path / "copy"
    import shutil

    shutil.copytree(out, copy)
    monkeypatch.setattr(sw.task, "code_id", lambda: "0123456789ab")
    messages: list = []
    res = sw.run_sweep(path, copy, serial=True, log=messages.append)
    assert res.submitted == 4 and res.skipped == 0
    assert "4 of them finished by another vfrs build, run again with this one, 0123456789ab" in messages[0]
    assert set(pq.read_table(copy / "summary.parquet").to_pydict()["vfrs code"]) == {"0123456789ab"}


def test_the_build_a_run_records_is_hashed_before_it_runs(serial, monkeypatch, tmp_path):
    """A package file edited while a run runs does not become the run's recorded build: the
    hash is taken before the run (it was taken after, so a sweep that ran while run.py was being
    edited recorded the edited build for runs the old one made)."""
    path, out, _ = serial
    ran = []
    run_scene = sw.task._run_scene

    def edited_while_running(scene, folder):
        result = run_scene(scene, folder)
        ran.append(True)  # from here on the files on disk are "edited"
        return result

    monkeypatch.setattr(sw.task, "_run_scene", edited_while_running)
    monkeypatch.setattr(sw.task, "code_id", lambda: "after0000000" if ran else "before000000")
    spec = {**sw.load_sweep(path).runs[0], "runs": str(tmp_path / "runs"), "source": "test", "derived": {},
            "attempt": 1, "single_thread": False}
    (tmp_path / "runs").mkdir()
    sw.run_task(spec)
    rec = json.loads((tmp_path / "runs" / spec["id"] / "sweep_run.json").read_text())
    assert rec["status"] == "complete" and rec["vfrs"]["code"] == "before000000"


def test_a_sweep_built_in_python_validates_every_scene_and_names_the_run(tmp_path):
    base = sw.load_sweep(write(tmp_path, SWEEP)).runs[0]["scene"]
    bad = json.loads(json.dumps(base))
    bad["contact"]["kapa"] = 1.0
    with pytest.raises(SceneError, match=r"my study: run 1 \(case = 'b'\): .*contact\.kapa: unknown key"):
        sw.Sweep.from_runs("my study", [({"case": "a"}, base), ({"case": "b"}, bad)])
    with pytest.raises(SceneError, match=r"run 1 \(case = 'b'\): gives the same scene as run 0"):
        sw.Sweep.from_runs("my study", [({"case": "a"}, base), ({"case": "b"}, base)])
    s = sw.Sweep.from_runs("my study", [({"case": "a", "n": 1}, base)])
    assert [a.key for a in s.axes] == ["case", "n"] and s.runs[0]["id"] == sw.run_id_of(base)


@pytest.mark.parametrize("key, named", [("contact.kapa", "contact.kapa"), ("bodies[5].mesh.resolution", "bodies[5]"),
                                         ("time.stepp", "time.stepp")])
def test_a_bad_axis_key_fails_before_anything_runs(tmp_path, key, named):
    path = write(tmp_path, SWEEP + f'[[axes]]\nkey = "{key}"\nvalues = [1.0]\n')
    with pytest.raises(SceneError) as e:
        sw.run_sweep(path, tmp_path / "out", serial=True, log=lambda m: None)
    assert str(path) in str(e.value) and named in str(e.value) and "axes[2]" in str(e.value)
    assert not (tmp_path / "out").exists()
    assert sw.main([str(path), "-o", str(tmp_path / "out"), "--serial"]) == 2
    assert not (tmp_path / "out").exists()
    from vfrs.cli import main as vfrs_main  # `vfrs sweep` is the same command

    assert vfrs_main(["sweep", str(path), "-o", str(tmp_path / "out"), "--serial"]) == 2
    assert not (tmp_path / "out").exists()


def test_a_bad_axis_value_names_the_axis(tmp_path):
    path = write(tmp_path, SWEEP.replace('["interface_mesh", "bvh"]', '["interface_mesh", "bhv"]'))
    with pytest.raises(SceneError, match=r"axes\[1\] \(key = 'contact.detection', value 'bhv'\)"):
        sw.load_sweep(path)


def test_a_failing_run_is_recorded_with_its_error_and_retried(tmp_path, monkeypatch):
    path = write(tmp_path, SWEEP)
    real, calls = sw.task._run_scene, []

    def flaky(scene, folder):
        calls.append(scene.to_dict()["contact"]["detection"])
        if scene.to_dict()["contact"]["detection"] == "bvh":
            raise RuntimeError("the node caught fire")
        real(scene, folder)

    monkeypatch.setattr(sw.task, "_run_scene", flaky)
    res = sw.run_sweep(path, tmp_path / "out", serial=True, retries=2, log=lambda m: None)
    assert calls.count("bvh") == 2 * 3 and calls.count("interface_mesh") == 2  # 1 try + 2 retries each
    assert res.failed == 2 and res.submitted == 2 + 6
    bad = [r for r in res.rows if r["contact.detection"] == "bvh"]
    assert all(r["status"] == "failed" and r["attempts"] == 3 and "the node caught fire" in r["error"] for r in bad)
    folder = tmp_path / "out" / "runs" / bad[0]["id"]
    assert json.loads((folder / sw.RUN_FILE).read_text())["status"] == "failed"
    assert "RuntimeError" in (folder / "error.txt").read_text()
    table = pq.read_table(tmp_path / "out" / "summary.parquet").to_pydict()
    assert table["status"] == ["complete", "failed"] * 2 and table["error"][0] is None

    # once it works, a re-run runs only the failed ones; a run that fails once then works is retried
    tries: dict = {}

    def once(scene, folder):
        d = scene.to_dict()
        run = (d["contact"]["detection"], d["flow"]["subglottal_pressure"])
        tries[run] = tries.get(run, 0) + 1
        if tries[run] == 1:
            raise RuntimeError("transient")
        real(scene, folder)

    monkeypatch.setattr(sw.task, "_run_scene", once)
    res = sw.run_sweep(path, tmp_path / "out", serial=True, log=lambda m: None)
    assert tries == {("bvh", 600.0): 2, ("bvh", 800.0): 2} and res.failed == 0 and res.skipped == 2
    assert sorted(r["attempts"] for r in res.rows if not r["skipped"]) == [2, 2]
    assert sw.main([str(path), "-o", str(tmp_path / "out"), "--serial"]) == 0


@pytest.mark.filterwarnings("ignore:.*kappa = 1 Pa/m is far below")
def test_a_real_run_failure_exits_1(tmp_path):
    """augmented_lagrange at the paper's kappa_0 = 1 Pa/m and N = 4 (given: its defaults now
    converge) does not converge on this job: recorded, exit 1."""
    text = SWEEP.replace('key = "contact.detection"\nvalues = ["interface_mesh", "bvh"]',
                         'key = "contact.method"\nvalues = ["augmented_lagrange"]').replace("[600.0, 800.0]", "[800.0]")
    text = text.replace('"time.end" = 0.003\n', '"time.end" = 0.003\n"contact.kappa" = 1.0\n"contact.max_augmentations" = 4\n')
    assert '"contact.kappa" = 1.0' in text
    path = write(tmp_path, text)
    assert sw.main([str(path), "-o", str(tmp_path / "out"), "--serial", "--retries", "0"]) == 1
    table = pq.read_table(tmp_path / "out" / "summary.parquet").to_pydict()
    assert table["status"] == ["failed"] and "ConvergenceError" in table["error"][0]
    assert table["peak_force_mN"] == [None]


def test_list_mode_zips_and_derived_expressions_are_restricted(tmp_path):
    path = write(tmp_path, 'mode = "list"\n' + SWEEP)
    assert [r["params"] for r in sw.load_sweep(path).runs] == [
        {"flow.subglottal_pressure": 600.0, "contact.detection": "interface_mesh"},
        {"flow.subglottal_pressure": 800.0, "contact.detection": "bvh"}]
    for expr in ("__import__('os').system('true')", "summary.__class__", "(lambda: 1)()", "open('x')",
                 "[x for x in history]"):
        with pytest.raises(SceneError, match="derived.bad"):
            sw.load_sweep(write(tmp_path, SWEEP + f'bad = "{expr}"\n'))
    uneven = 'mode = "list"\n' + SWEEP.replace("[600.0, 800.0]", "[600.0]")
    with pytest.raises(SceneError, match="equal lengths"):
        sw.load_sweep(write(tmp_path, uneven))


# dask moves its dashboard off 8787 when another cluster of the session holds it, and says so.
@pytest.mark.filterwarnings("ignore:Port 8787 is already in use:UserWarning")
def test_a_worker_killed_mid_run_still_completes_the_sweep(tmp_path):
    """SIGKILL the worker process of a run once it has written a checkpoint: dask gives the task
    to another worker (the nanny restarts the killed one), which takes the dead run's folder
    over and resumes it from the checkpoint; every run completes, the resumed one with the
    numbers of an uninterrupted run, bit for bit, and no .tmp- folder is left."""
    import signal
    import threading

    from distributed import Client, LocalCluster

    import vfrs

    path = write(tmp_path, SWEEP.replace('"time.end" = 0.003', '"time.end" = 0.006\n"output.checkpoint_every" = 10'))
    runs = tmp_path / "out" / "runs"
    killed: list = []

    def killer():
        while not killed:
            for p in runs.glob("*.tmp-*/checkpoint.npz") if runs.exists() else []:
                pid = int(p.parent.name.rsplit("-", 1)[1])
                os.kill(pid, signal.SIGKILL)
                killed.append((p.parent.name, pid))
                return
            threading.Event().wait(0.005)

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        pids = set(client.run(os.getpid).values())
        watcher = threading.Thread(target=killer, daemon=True)
        watcher.start()
        res = sw.run_sweep(path, tmp_path / "out", scheduler=cluster.scheduler_address, log=lambda m: None)
        killed.append("stop")
    name, pid = killed[0]
    assert pid in pids  # a worker process, not this one
    assert res.failed == 0 and [r["status"] for r in res.rows] == ["complete"] * 4
    assert not list(runs.glob("*.tmp-*"))
    run_id = name.split(".tmp-")[0]
    rec = json.loads((runs / run_id / sw.RUN_FILE).read_text())
    assert rec["resumed_from"] == name and rec["pid"] != pid
    assert "resumed" in (runs / run_id / "run.log").read_text()
    ref = vfrs.run(vfrs.Scene.load(runs / run_id / "scene.toml"), progress=False).history
    got = dict(np.load(runs / run_id / "history.npz"))
    assert set(ref) <= set(got) and all(same(got[k], np.asarray(ref[k])) for k in ref)


def test_run_ids_ignore_checkpoint_options(tmp_path):
    a = sw.load_sweep(write(tmp_path, SWEEP, "a.toml"))
    b = sw.load_sweep(write(tmp_path, SWEEP.replace('"time.end" = 0.003', '"time.end" = 0.003\n"output.checkpoint_every" = 7'),
                            "b.toml"))
    c = sw.load_sweep(write(tmp_path, SWEEP.replace('"time.end" = 0.003', '"time.end" = 0.004'), "c.toml"))
    assert [r["id"] for r in a.runs] == [r["id"] for r in b.runs]
    assert not {r["id"] for r in a.runs} & {r["id"] for r in c.runs} and len({r["id"] for r in a.runs}) == 4


def test_ctrl_c_in_a_serial_sweep_stops_with_a_checkpoint_and_the_next_sweep_resumes_it(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    path = write(tmp_path, SWEEP.replace('"time.end" = 0.003', '"time.end" = 0.01\n"output.checkpoint_every" = 10'))
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "vfrs.studies.sweep", str(path), "-o", str(out), "--serial"],
                            stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while not list(out.glob("runs/*.tmp-*/checkpoint.npz")) and time.time() < deadline:
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 130, err
    assert "resumes from its checkpoint" in err
    stopped = [p for p in (out / "runs").iterdir() if ".tmp-" in p.name]
    assert len(stopped) == 1 and (stopped[0] / "checkpoint.npz").exists()
    res = sw.run_sweep(path, out, serial=True, log=lambda m: None)
    assert res.failed == 0 and len(res.rows) == 4
    assert [r for r in res.rows if not r["skipped"]]  # the stopped one and those after it ran now
    rec = json.loads((out / "runs" / stopped[0].name.split(".tmp-")[0] / sw.RUN_FILE).read_text())
    assert rec["resumed_from"] == stopped[0].name
    assert not list((out / "runs").glob("*.tmp-*"))


@pytest.mark.parametrize("text, message", [
    ('base = "missing.toml"\n', "base: .*missing.toml: scene file does not exist"),
    (SWEEP.replace("[[axes]]", "[[axis]]", 1), r"axis: unknown key; did you mean 'axes'\?"),
    (SWEEP.replace('key = "contact.detection"', 'key = "contact.detection"\nvalue = 1'), r"axes\[1\]\.value: unknown key"),
    ('mode = "zip"\n' + SWEEP, "mode: 'zip' is not 'grid' or 'list'"),
    # a derived column named like a column the table has: it overwrote that column (status!)
    (SWEEP + 'status = "1.0"\n', r"derived.status: the table has a column 'status' already"),
    (SWEEP + '"contact.detection" = "1.0"\n', r"derived.contact.detection: .*already \(an axis\)"),
    (SWEEP + 'a.b = "1.0"\n', r'derived.a: expected an expression .*a column name with a dot needs quotes: "a.b" = '),
    ('mode = "list"\n' + SWEEP.replace("[600.0, 800.0]", "[600.0]"), r"equal lengths, got \[1, 2\]; give every axis as "
     r"many values, or use mode = 'grid'"),
])
def test_sweep_file_errors_name_the_file_and_the_key(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(SceneError, match=message) as e:
        sw.load_sweep(path)
    assert str(e.value).startswith(str(path))


@pytest.mark.parametrize("section, key, default", sw.ADDED_KEYS)
def test_keys_added_later_keep_earlier_run_ids_at_their_default(section, key, default):
    """A key the resolved scene gained later (``[contact] column_memory``, ``[flow] density``)
    leaves a run's id as it was at its default, and changes it when set otherwise; the default
    it compares with is the key's own (what the scene resolves to when the key is not given)."""
    import vfrs
    from vfrs.scene import read_toml

    assert key not in read_toml(ROOT / "examples" / "m5_collision.toml").get(section, {})
    scene = vfrs.Scene.load(ROOT / "examples" / "m5_collision.toml").to_dict()
    assert scene[section][key] == default
    before = {k: dict(v) if isinstance(v, dict) else v for k, v in scene.items()}
    before[section].pop(key)  # the scene as resolved before the key existed
    assert sw.run_id_of(scene) == sw.run_id_of(before)
    scene[section][key] = default * 1.5
    assert sw.run_id_of(scene) != sw.run_id_of(before)


@pytest.mark.parametrize("where, key, named", [
    ("set", "bodies[5].mesh.resolution", "set.'bodies[5].mesh.resolution'"),
    ("axis", "bodies[2].material.E", "axes[2] (key = 'bodies[2].material.E')"),
])
def test_an_index_out_of_range_names_the_list_its_length_and_the_valid_indices(tmp_path, where, key, named):
    """Before: "no 5 in the scene", naming neither the list nor how long it is."""
    text = (SWEEP.replace("[set]\n", f'[set]\n"{key}" = "coarse"\n') if where == "set"
            else SWEEP + f'[[axes]]\nkey = "{key}"\nvalues = [1e4]\n')
    path = write(tmp_path, text)
    with pytest.raises(SceneError) as e:
        sw.load_sweep(path)
    msg = str(e.value)
    assert msg.startswith(f"{path}: {named}: ")
    index = key.split("[")[1].split("]")[0]
    assert f"index {index} is out of range: the list bodies has 2 elements (valid indices 0 to 1)" in msg
    assert MAIN in msg  # the base scene, where the list is


def test_set_key_says_why_a_path_cannot_be_followed():
    from vfrs.scene.keypath import set_key

    data = {"bodies": [{"mesh": {}}], "time": {"end": 0.003}, "obstacles": []}
    for path, message in [("bodies[1].mesh", "index 1 is out of range: the list bodies has 1 element (valid indices 0 to 0)"),
                          ("obstacles[0].kind", "index 0 is out of range: the list obstacles has 0 elements (it is empty"),
                          ("bodies.mesh", "bodies is a list (1 element): give an index, e.g. bodies[0].mesh"),
                          ("time[0]", "time is a table, not a list"),
                          ("time.end.x", "time.end is a value (0.003), not a table: it has no key 'x'")]:
        with pytest.raises(ValueError) as e:
            set_key(data, path, 1)
        assert message in str(e.value), (path, str(e.value))


def _no_run(scene, folder):
    pytest.fail("a run started")


@pytest.mark.parametrize("expr, named, near", [
    ("summary.contact.peak_forse.right * 1e3", "summary.contact.peak_forse.right", "summary.contact.peak_force.right"),
    ("summary.phonaton.f0", "summary.phonaton.f0", "summary.phonation.f0"),
    ("params.flow.subglottal_presure / 1e3", "params.flow.subglottal_presure", "params.flow.subglottal_pressure"),
    ("max(history.flow_rate) / summary.contact.peak_force", "summary.contact.peak_force",
     "summary.contact.peak_force.right"),
])
def test_a_derived_column_reading_a_name_no_run_has_is_refused_before_any_run(tmp_path, monkeypatch, expr, named, near):
    """Before: every run ran, the column was empty, 'N runs, 0 failed' and exit 0."""
    path = write(tmp_path, SWEEP + f'bad = "{expr}"\n')
    monkeypatch.setattr(sw.task, "_run_scene", _no_run)
    with pytest.raises(SceneError) as e:
        sw.run_sweep(path, tmp_path / "out", serial=True, log=lambda m: None)
    msg = str(e.value)
    assert msg.startswith(f"{path}: derived.bad: ") and repr(named) in msg and repr(near) in msg, msg
    assert not (tmp_path / "out").exists()
    assert sw.main([str(path), "-o", str(tmp_path / "out"), "--serial"]) == 2
    assert not (tmp_path / "out").exists()


def test_a_summary_name_only_some_runs_have_names_the_run(tmp_path):
    base = sw.load_sweep(write(tmp_path, SWEEP)).runs[0]["scene"]
    no_flow = json.loads(json.dumps(base))
    del no_flow["flow"]
    with pytest.raises(SceneError, match=r"study: derived.f0: 'summary.phonation.f0' reads 'summary.phonation.f0', "
                       r"which is not in the summary of run 1 \(case = 'dry'\)"):
        sw.Sweep.from_runs("study", [({"case": "wet"}, base), ({"case": "dry"}, no_flow)],
                           derived={"f0": "summary.phonation.f0"})
    # a name every run has passes; history columns are read at the end of each run
    sw.Sweep.from_runs("study", [({"case": "wet"}, base), ({"case": "dry"}, no_flow)],
                       derived={"F": "summary.contact.peak_force.left / len(history.t)", "c": "params.case"})


def test_the_summary_names_known_before_running_hold_every_name_a_run_has(serial):
    """sweep.summary_names predicts summary.json's names from the scene (what the effects and
    measures declare, vfrs.summary.summary_names): if the summary or the history it reads changes, this
    fails rather than letting the sweep refuse a valid column."""
    import vfrs

    _, out, _ = serial
    for folder in sorted(p for p in (out / "runs").iterdir() if p.is_dir()):
        summary = json.loads((folder / "summary.json").read_text())
        have = {f"{section}.{k}" for section, items in summary.items() if isinstance(items, dict) for k in items}
        predicted = set(sw.summary_names(vfrs.Scene.load(folder / "scene.toml")))
        assert have <= predicted, have - predicted
        assert {"phonation.f0", "contact.peak_force.right", "run.steps", "window.start"} <= predicted


def test_derived_values_that_fail_at_the_end_of_a_run_make_the_sweep_exit_1(serial, tmp_path, capsys):
    """A division by zero in one run and a quantity these 3 ms runs do not reach (contact
    quotient: fewer than two glottal cycles) are not sweep-file errors: the runs complete, the
    cells are empty, the last line says how many values failed and where, the exit code is 1.
    Before: '4 runs, 0 failed', exit 0."""
    import shutil

    _, serial_out, _ = serial
    out = tmp_path / "out"
    shutil.copytree(serial_out, out)  # the same four runs: found finished, only the table is made again
    text = SWEEP + 'per_kPa = "1 / (params.flow.subglottal_pressure - 600.0)"\ncq = "summary.contact.contact_quotient"\n'
    path = write(tmp_path, text)
    assert sw.main([str(path), "-o", str(out), "--serial"]) == 1
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert "4 runs, 0 failed; 6 derived values could not be computed: " in last, last
    assert "per_kPa in 2 of 4 runs (" in last and "ZeroDivisionError" in last
    assert "cq in 4 of 4 runs (" in last and "contact_quotient" in last
    res = sw.run_sweep(path, out, serial=True, log=lambda m: None)
    assert res.failed == 0 and res.skipped == 4 and len(res.derived_failed) == 6
    table = pq.read_table(out / "summary.parquet").to_pydict()
    assert table["per_kPa"][:2] == [None, None] and table["per_kPa"][2] == pytest.approx(1 / 200.0)
    assert table["cq"] == [None] * 4 and all("cq: KeyError" in e for e in table["derived_errors"])


def test_the_build_id_hashes_the_whole_package():
    """``code_id`` (what a sweep or a converge study compares before it skips a finished run)
    hashes every Python file of the package and its compiled core, not only the sweep's own
    folder (it did, after the sweep moved to vfrs/studies/sweep: a physics change left finished
    runs in place)."""
    import vfrs
    from vfrs.studies.sweep import task

    root = os.path.dirname(os.path.abspath(vfrs.__file__))
    files = {os.path.relpath(f, root) for f in task.code_files()}
    for must in ("__init__.py", os.path.join("dynamics", "hht.py"), os.path.join("enforcement", "record.py"),
                 os.path.join("studies", "sweep", "task.py")):
        assert must in files, must
    assert any(f.startswith("_core") and f.endswith((".so", ".pyd")) for f in files)
