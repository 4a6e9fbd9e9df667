"""What a run leaves on disk and in the Result: the scene used, history, fields, probes, log."""

import csv
from vfrs._compat import tomllib
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

import vfrs
from vfrs.run.march import progress_bar as _progress_bar


@pytest.fixture(scope="module")
def ran(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    scene = vfrs.Scene.load("examples/cantilever.toml").to_dict()
    scene["time"]["end"] = 0.01
    scene["output"]["every"] = 5
    res = vfrs.run(vfrs.Scene.from_dict(scene), out=out, progress=False)
    return res, out


def test_the_resolved_scene_is_written_with_defaults(ran):
    res, out = ran
    again = vfrs.Scene.load(out / "scene.toml")
    assert again.to_dict() == res.scene.to_dict()
    assert "alpha = -0.1" in (out / "scene.toml").read_text()
    assert "energy = true" in (out / "scene.toml").read_text()  # a default, written out


def test_history_npz_and_csv_hold_every_step(ran):
    res, out = ran
    h = np.load(out / "history.npz")
    assert set(h.files) == set(res.history) | {"scene"}
    assert vfrs.Scene.from_dict(tomllib.loads(str(h["scene"]))).to_dict() == res.scene.to_dict()
    np.testing.assert_array_equal(h["t"], res.t)
    assert len(res.t) == 21 and res.t[-1] == pytest.approx(0.01)
    rows = list(csv.reader(open(out / "history.csv")))
    assert rows[0][:3] == ["t", "kinetic_energy", "elastic_energy"]
    assert "reaction_force.beam.xmin_z" in rows[0]
    assert len(rows) == 22
    assert float(rows[-1][0]) == pytest.approx(0.01)


def test_fields_are_a_paraview_series_of_vtu_files(ran):
    res, out = ran
    pvd = ET.parse(out / "beam.pvd").getroot()
    sets = pvd.findall("./Collection/DataSet")
    assert [float(s.get("timestep")) for s in sets] == pytest.approx(res.fields["t"])
    assert len(sets) == 5  # steps 0, 5, 10, 15, 20
    last = meshio.read(out / sets[-1].get("file"))
    np.testing.assert_allclose(last.point_data["displacement"], res.u, rtol=1e-12, atol=1e-30)
    assert "velocity" in last.point_data


def test_log_names_sizes_effects_and_timings(ran):
    _, out = ran
    log = (out / "run.log").read_text()
    assert "effects: elasticity, inertia, damping, surface_loads" in log
    assert "'free_dofs': 1680" in log and "timings:" in log


def test_result_probe_declared_and_from_snapshots(ran):
    res, _ = ran
    declared = res.probe([0.02, 0.004, 0.002])
    assert declared["displacement"].shape == (21, 3) and declared["body"] == "beam"
    np.testing.assert_allclose(declared["displacement"][-1], res.u[declared["node"]])
    other = res.probe([0.01, 0.0, 0.0])  # not declared: every output.every steps
    assert other["t"].shape == (5,) and other["displacement"].shape == (5, 3)
    np.testing.assert_allclose(other["position"], [0.01, 0.0, 0.0])
    assert res.displacement("beam").shape == (588, 3)


def test_timings_cover_the_parts_that_ran(ran):
    res, _ = ran
    for key in ("mesh", "assembly", "factorization", "step", "solve", "loads", "record", "output", "total"):
        assert res.timings[key] >= 0.0, key
    assert res.timings["solve"] <= res.timings["step"] <= res.timings["total"]


def test_progress_bar_only_on_a_terminal():
    assert _progress_bar(1000, False, "x") is None
    assert _progress_bar(1000, True, "x") is None  # pytest captures stderr: not a terminal


def test_progress_bar_on_a_terminal_for_long_runs(monkeypatch):
    import io
    import sys

    class Tty(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.setattr(sys, "stderr", Tty())
    bar = _progress_bar(1000, True, "x")
    assert bar is not None and bar.total == 1000
    bar.close()
    assert _progress_bar(5, True, "x") is None  # short runs: no bar


def test_ragged_effect_records_are_kept_without_breaking_the_csv(tmp_path):
    from vfrs.effects import Effect

    class Pairs(Effect):
        name = "contact"

        def record(self, state, history):
            history["pairs"].append(list(range(state.step % 3)))  # a different length each step
            history["count"].append(state.step % 3)

    scene = vfrs.Scene.load("examples/bar_static.toml")
    res = vfrs.run(scene, out=tmp_path, progress=False, effects=[Pairs({})])
    assert res.history["pairs"].dtype == object and [len(p) for p in res.history["pairs"]] == [1, 2, 0]
    header = open(tmp_path / "history.csv").readline().strip().split(",")
    assert "count" in header and "pairs" not in header


def test_a_failing_run_leaves_its_history_and_the_reason(tmp_path):
    from vfrs.effects import Effect

    class Fails(Effect):
        name = "contact"

        def forces(self, state):
            if state.step == 7:
                raise vfrs.ConvergenceError("step 7: the active set cycled")
            return None

        def finish(self, result):
            raise AssertionError("finish is not called on a failed run")

    scene = vfrs.Scene.load("examples/cantilever.toml")
    with pytest.raises(vfrs.ConvergenceError, match="cycled"):
        vfrs.run(scene, out=tmp_path, progress=False, effects=[Fails({})])
    assert len(np.load(tmp_path / "history.npz")["t"]) == 7  # t = 0 and steps 1..6
    assert "run failed after 7 recorded steps: ConvergenceError: step 7: the active set cycled" in (tmp_path / "run.log").read_text()


def test_effects_finish_with_the_result():
    from vfrs.effects import Effect

    seen = []

    class Sees(Effect):
        name = "flow"

        def finish(self, result):
            seen.append(result)

    res = vfrs.run(vfrs.Scene.load("examples/bar_static.toml"), progress=False, effects=[Sees({})])
    assert seen == [res] and res.timings["flow"] >= 0 and res.timings["total"] > 0


@pytest.mark.parametrize("compression", ["none", "lzma"])
def test_vtu_compression_is_a_scene_option(ran, tmp_path, compression):
    """[output] compression: the field files hold the same numbers whatever the compression;
    'none' writes larger files (zlib, the default, about 3x smaller on the M5 folds)."""
    res, out = ran
    scene = res.scene.to_dict()
    scene["output"]["compression"] = compression
    vfrs.run(vfrs.Scene.from_dict(scene), out=tmp_path / "o", progress=False)
    for f in sorted((out / "fields").iterdir()):
        a, b = meshio.read(f), meshio.read(tmp_path / "o" / "fields" / f.name)
        for k in a.point_data:
            np.testing.assert_array_equal(a.point_data[k], b.point_data[k])
        if compression == "none":
            assert (tmp_path / "o" / "fields" / f.name).stat().st_size > f.stat().st_size
    assert f'compression = "{compression}"' in (tmp_path / "o" / "scene.toml").read_text()
    with pytest.raises(vfrs.SceneError, match="compression"):
        scene["output"]["compression"] = "gzip"
        vfrs.Scene.from_dict(scene)


@pytest.mark.parametrize("compression", ["zlib", "lzma", "none"])
def test_field_files_hold_what_meshio_writes(tmp_path, compression):
    """vfrs.output.vtu writes the field files itself (points and cells encoded once per body): meshio
    reads back the same points, cells and point data as from meshio's own file of the same
    mesh, with several blocks per array (more than 32 KiB), one-component and integer fields;
    the file is no larger than meshio's."""
    from vfrs.errors import MeshError
    from vfrs.output.vtu import FieldFileWriter

    rng = np.random.default_rng(5)
    points = rng.normal(size=(3000, 3))
    tets = rng.integers(0, 3000, size=(5000, 4))
    data = {"displacement": rng.normal(size=(3000, 3)), "pressure": np.abs(rng.normal(size=3000)),
            "zeros": np.zeros((3000, 3)), "label": np.arange(3000, dtype=np.int64)}
    w = FieldFileWriter(points, tets)
    for k in range(2):  # the second file reuses the encoded points and cells
        w.write(tmp_path / f"ours{k}.vtu", data, compression)
    meshio.vtu.write(tmp_path / "meshio.vtu", meshio.Mesh(points, [("tetra", tets)], point_data=data),
                     binary=True, compression=None if compression == "none" else compression)
    ref = meshio.read(tmp_path / "meshio.vtu")
    for k in range(2):
        got = meshio.read(tmp_path / f"ours{k}.vtu")
        np.testing.assert_array_equal(got.points, ref.points)
        assert [c.type for c in got.cells] == ["tetra"]
        np.testing.assert_array_equal(got.cells[0].data, ref.cells[0].data)
        assert list(got.point_data) == list(data)
        for name in data:
            np.testing.assert_array_equal(got.point_data[name], ref.point_data[name])
            assert got.point_data[name].dtype == data[name].dtype
    ours, theirs = (tmp_path / "ours0.vtu").stat().st_size, (tmp_path / "meshio.vtu").stat().st_size
    # No larger than meshio's (to within the XML framing); smaller uncompressed, where the
    # cell types are one byte each as VTK writes them (meshio: eight).
    assert ours < theirs + 300 + 0.001 * theirs and (compression != "none" or ours < theirs), (ours, theirs)
    # A name with XML's special characters is escaped (meshio's own writer makes such a file
    # unreadable).
    odd = 'a <"quoted"> & name'
    w.write(tmp_path / "odd.vtu", {odd: np.ones(3000)}, compression)
    assert list(meshio.read(tmp_path / "odd.vtu").point_data) == [odd]
    with pytest.raises(MeshError, match="field 'short': \\(10, 3\\) values for 3000 points"):
        w.write(tmp_path / "bad.vtu", {"short": np.zeros((10, 3))}, compression)
    with pytest.raises(MeshError, match="not complex128"):
        w.write(tmp_path / "bad.vtu", {"z": np.zeros(3000, dtype=complex)}, compression)
    with pytest.raises(MeshError, match="choose one of"):
        w.write(tmp_path / "bad.vtu", data, "gzip")
