"""Contact pressure as a field (per contact-surface node, Pa) in the history and the VTU
output, and what every run writes at its end: summary.json, the printed summary, run.log,
and `vfrs plot`'s figures."""

import contextlib
import doctest
import io
import json
import os

import meshio
import numpy as np
import pytest
from test_contact_verification import RHO, SIG_G, SIG_H, SIG_N, _signorini_scene

import vfrs
import vfrs.enforcement.record as record
from vfrs.cli import main
from vfrs.contact import tributary_areas


def test_docstring_examples_run():
    result = doctest.testmod(record)
    assert result.failed == 0 and result.attempted > 0


def test_node_normals_and_pressure_are_the_plain_definitions_bit_for_bit():
    """node_normals numbers the triangles' nodes and forms the face normals without
    np.unique's sort and np.cross's set-up: the same numbers as those (the recorded pressure
    of every committed run depends on them), on random surfaces with unused and shared nodes."""
    def normals(x, tri):  # the definition: np.unique's numbering, np.cross's faces
        local, idx = np.unique(tri, return_inverse=True)
        n = np.zeros((len(local), 3))
        if len(tri):
            face = np.cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]])
            for c in range(3):
                n[:, c] = np.bincount(idx.ravel(), np.repeat(face[:, c], 3), minlength=len(local))
        norm = np.linalg.norm(n, axis=1)
        n[norm > 0] /= norm[norm > 0, None]
        full = np.zeros((len(x), 3))
        full[local] = n
        return full

    rng = np.random.default_rng(7)
    for _ in range(100):
        n = int(rng.integers(3, 60))
        x = rng.normal(size=(n, 3))
        tri = rng.integers(0, n, size=(int(rng.integers(0, 80)), 3))
        ref = normals(x, tri)
        assert np.array_equal(record.node_normals(x, tri, n), ref)
        nodes = rng.choice(n, int(rng.integers(0, n)), replace=False)
        assert np.array_equal(record.node_normals(x, tri, n, nodes=nodes), ref[nodes])
        f = np.zeros((n, 3))
        k = rng.choice(n, int(rng.integers(0, n)), replace=False)
        f[k] = rng.normal(size=(len(k), 3))
        areas = rng.random(n)
        areas[rng.choice(n, 3)] = 0.0
        loaded = (areas > 0) & f.any(axis=1)
        expect = np.zeros(n)
        expect[loaded] = np.maximum(-np.einsum("ij,ij->i", f[loaded], ref[loaded]), 0.0) / areas[loaded]
        assert np.array_equal(record.nodal_pressure(f, x, tri, areas), expect)


def test_sensor_reads_the_mean_over_its_face():
    """``sensor_matrix``: a sensor of face area A centred at a node reads the area-weighted
    mean of the nodal pressures within sqrt(A / pi) of it, on the same surface. On a regular
    grid of a flat face (spacing 0.25 mm, 1 mm^2 sensor: radius 0.564 mm, 21 nodes inside
    away from the rim) it reads a uniform pressure exactly, a linear one exactly at interior
    nodes (the stencil is symmetric), and one loaded node p as p a_i / (sum of the areas in
    the disc); the other surface (a second body) is never mixed in."""
    mesh = vfrs.meshes.box((4e-3, 4e-3, 1e-3), (16, 16, 1))
    tri = mesh.surfaces["zmax"]
    areas = tributary_areas(mesh.points, tri)
    x = mesh.points
    other = tri + len(x)  # the same face as a second body's surface
    pts = np.vstack([x, x])
    a2 = np.concatenate([areas, areas])
    S = record.sensor_matrix(pts, [tri, other], a2, 1e-6)
    top = np.unique(tri)
    assert np.allclose(S[top] @ np.ones(len(pts)), 1.0, rtol=0, atol=1e-14)
    assert S[top][:, len(x):].nnz == 0  # the first body's sensors see its own surface only
    p_lin = np.concatenate([1e3 + 2e5 * x[:, 0], np.zeros(len(x))])
    centre = top[np.argmin(np.linalg.norm(x[top, :2] - 2e-3, axis=1))]
    assert (S @ p_lin)[centre] == pytest.approx(p_lin[centre], rel=1e-12)
    assert S[centre].nnz == 21  # i^2 + j^2 <= 5.09 grid points: 1 + 4 + 4 + 4 + 8
    one = np.zeros(len(pts))
    one[centre] = 500.0
    cols = S[centre].indices
    assert (S @ one)[centre] == pytest.approx(500.0 * a2[centre] / a2[cols].sum(), rel=1e-12)


def test_disc_sensor_integrates_over_its_exact_face():
    """``surface_sensors`` (what the record reads each step): a sensor of face area A centred
    at a node reads the P1 pressure integrated over its exact disc (radius sqrt(A / pi)) over
    the disc's area, on its own surface only. On a flat face (0.25 mm grid, 1 mm^2 sensor:
    21 nodes inside away from the rim) it reads a uniform and a linear pressure exactly at
    every interior node, a single loaded node p as p times the integral of that node's hat
    function over the disc over the disc's area, and the second body's identical surface is
    never mixed in."""
    from vfrs.contact.sensor import disc_pressure, surface_sensors

    mesh = vfrs.meshes.box((4e-3, 4e-3, 1e-3), (16, 16, 1))
    tri = mesh.surfaces["zmax"]
    x = mesh.points
    other = tri + len(x)  # the same face as a second body's surface
    pts = np.vstack([x, x])
    sensors = surface_sensors(pts, {"a": tri, "b": other}, 1e-6)
    R = np.sqrt(1e-6 / np.pi)
    top = np.unique(tri)
    rows = {int(n): k for k, n in enumerate(sensors.nodes)}
    interior = [n for n in top if np.all(np.abs(x[n, :2] - 2e-3) <= 2e-3 - R)]
    S = sensors.S
    assert np.allclose((S @ np.ones(len(pts)))[[rows[n] for n in interior]], 1.0, rtol=0, atol=1e-12)
    assert S[[rows[n] for n in top]][:, len(x):].nnz == 0  # the first body's sensors see its own surface only
    p_lin = np.concatenate([1e3 + 2e5 * x[:, 0], np.zeros(len(x))])
    read = S @ p_lin
    assert np.allclose(read[[rows[n] for n in interior]], p_lin[interior], rtol=1e-12)
    centre = top[np.argmin(np.linalg.norm(x[top, :2] - 2e-3, axis=1))]
    assert sensors.inside[rows[centre]] == 21  # i^2 + j^2 <= 5.09 grid points: 1 + 4 + 4 + 4 + 8
    one = np.zeros(len(pts))
    one[centre] = 500.0
    alone = disc_pressure(x, tri, one[:len(x)], x[centre], R, normal=[0, 0, 1])
    assert (S @ one)[rows[centre]] == pytest.approx(alone.mean_pressure, rel=1e-12)
    assert sensors.sparse() == {}  # 21 nodes (median, the rim's fewer) >= MIN_NODES


def test_signorini_block_pressure_is_rho_g_H(tmp_path):
    """A block resting on a frictionless plane under its weight (nu = 0: uniaxial stress)
    carries the pressure rho g H on its base. The area-weighted mean of the nodal pressures
    is exact (it is the total normal force over the base's area: 1e-9); the nodal values
    follow P1's load distribution, documented in test_contact_verification as within 5 % at
    edges and corners (measured 4.0 %), so the peak is rho g H to 5 %, and no node is below
    rho g H by more than that either. The same numbers are in the history (per step) and in
    the last VTU snapshot's ``contact_pressure`` field."""
    scene = _signorini_scene(0.0)
    d = scene.to_dict()
    d["output"]["every"] = 50
    r = vfrs.run(vfrs.Scene.from_dict(d), out=tmp_path, progress=False)
    p_exact = RHO * SIG_G * SIG_H
    h = r.history
    assert h["contact_pressure_mean"][-1] == pytest.approx(p_exact, rel=1e-9)
    p_max = h["contact_pressure_max"][-1]
    print(f"\nSignorini nu=0: peak nodal pressure / rho g H - 1 = {p_max / p_exact - 1:.4f}")
    assert p_exact <= p_max <= 1.05 * p_exact
    node = int(h["contact_pressure_max_node"][-1])
    np.testing.assert_array_equal(h["contact_pressure_max_position"][-1], r.points[node])
    assert r.points[node][2] == 0.0  # on the base

    mesh = r.problem.bodies[0].mesh
    base = np.unique(mesh.surfaces["zmin"])
    areas = tributary_areas(mesh.points, mesh.surfaces["zmin"])
    last = sorted(os.listdir(tmp_path / "fields"))[-1]
    p = meshio.read(tmp_path / "fields" / last).point_data["contact_pressure"]
    assert len(base) == (SIG_N + 1) ** 2 and p.shape == (mesh.n_points,)
    assert np.sum(p[base] * areas[base]) / np.sum(areas[base]) == pytest.approx(p_exact, rel=1e-9)
    assert p.max() == pytest.approx(p_max, rel=1e-12)
    assert np.abs(p[base] / p_exact - 1).max() <= 0.05
    off = np.setdiff1d(np.arange(mesh.n_points), base)
    assert np.all(p[off] == 0.0)  # only the contact surface carries pressure


@pytest.fixture(scope="module")
def collision(tmp_path_factory):
    """The main job (examples/m5_collision.toml) on the coarse mesh, 30 ms, through the CLI:
    (output folder, what `vfrs run` printed)."""
    out = tmp_path_factory.mktemp("m5")
    scene = os.path.join(os.path.dirname(__file__), "..", "examples", "m5_collision.toml")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["run", scene, "-o", str(out), "--no-progress", "--set", "bodies[0].mesh.resolution='coarse'",
                   "--set", "bodies[1].mesh.resolution='coarse'", "--set", "time.end=0.03"])
    assert rc == 0
    return out, buf.getvalue()


def test_the_run_prints_and_saves_its_results(collision):
    out, printed = collision
    summary = json.loads((out / "summary.json").read_text())
    for key in ("f0", "open_quotient", "closed_quotient", "max_glottal_area", "peak_flow", "mfdr"):
        assert key in summary["phonation"], key
    for key in ("first_contact", "contact_duration", "peak_force.right", "peak_force.left", "peak_contact_pressure",
                "mean_contact_pressure", "max_intersection_volume"):
        assert key in summary["contact"], key
    assert summary["contact"]["peak_contact_pressure"]["unit"] == "Pa"
    assert summary["contact"]["peak_contact_pressure"]["body"] in ("right", "left")
    assert "fundamental frequency" in printed and "peak contact pressure" in printed and "kPa" in printed
    # Newton's third law on the summary: the peak forces on the two folds are equal
    fr, fl = summary["contact"]["peak_force.right"], summary["contact"]["peak_force.left"]
    assert fr["value"] == pytest.approx(fl["value"], rel=1e-9) and fr["t"] == fl["t"]
    # the summary read back is the one printed
    assert vfrs.load(out).summary.text() in printed
    # whole-run and window quantities under their headings, the per-cycle means with their
    # spread, the Lagrange penetration (round-off) said to be so, and the timings last
    assert printed.index("  over the whole run") < printed.index("  over the window t = 15.0-30.0 ms")
    dur = next(ln for ln in printed.splitlines() if "contact duration per glottal cycle" in ln)
    assert dur.endswith(("(1 cycle)", " cycles)")) and summary["contact"]["contact_duration"]["over"] == "window", dur
    pen = next(ln for ln in printed.splitlines() if "maximum penetration" in ln)
    assert summary["contact"]["max_penetration"]["value"] > 0 and pen.endswith("0 (below round-off)"), pen
    assert printed.index("results:") < printed.index("timings:") < printed.index("output:")


def test_the_main_job_collides_once_per_cycle(collision):
    """The main job with the paper's vocal_fold tissue (coarse mesh, 30 ms, the default contact
    scheme): the folds touch soon after the 2 ms pressure ramp (measured 2.4 ms; coarse runs
    of `vocal_fold` at 0.8 kPa touch at 2.2-2.65 ms with h = 100-25 us), oscillate at a voice
    frequency (measured 120.5 Hz over 15-30 ms, one glottal cycle) and are in contact in every
    glottal cycle (measured 3.6 ms in that cycle; four contacts in 30 ms, one per cycle);
    contact pushes the right fold towards +x only (the smallest x force 0.0); the two folds'
    forces balance (measured 3.3e-16 of the peak); Lagrange multipliers leave no penetration
    beyond round-off (2.2e-19 m); the peak nodal pressure is at least the mean pressure
    (measured 1.30 and 0.51 kPa)."""
    out, _ = collision
    run = vfrs.load(out)
    s = run.summary
    assert 1e-3 <= s["contact"]["first_contact"].value <= 4e-3
    assert 80.0 <= s["phonation"]["f0"].value <= 300.0
    per_cycle = s["contact"]["contact_duration"].per_cycle
    assert len(per_cycle) >= 1 and min(per_cycle) > 0
    F = run.history["contact_force.right"]
    peak = np.abs(F).max()
    assert F[:, 0].min() >= -1e-12 * peak
    assert np.abs(F + run.history["contact_force.left"]).max() <= 1e-12 * peak
    assert s["contact"]["max_penetration"].value <= 1e-12
    assert s["contact"]["peak_contact_pressure"].value >= s["contact"]["mean_contact_pressure"].value > 0


def test_run_log_lists_the_effects_once(collision):
    out, _ = collision
    log = (out / "run.log").read_text()
    assert log.count("effects:") == 1, log
    assert "over the window t = " in log and log.index("results:") < log.index("timings:")


def test_vtu_pressure_balances_the_contact_force(collision):
    """At the snapshot with the largest contact force, the pressure integrated over the right
    fold's medial surface (sum of p_i a_i) is the normal part of its contact force: within
    1 % of |F| (the normals of the contact zone are nearly parallel to the force; measured
    0.03 %: 9.584 against 9.587 mN at 18.00 ms)."""
    out, _ = collision
    run = vfrs.output.load(out)
    mesh, _ = run.meshes["right"]
    tri = mesh.surfaces["medial"]
    areas = tributary_areas(mesh.points, tri)
    F = run.history["contact_force.right"]
    t = run.history["t"]
    best = None
    for ts, path in run.snapshots("right"):
        k = int(np.argmin(np.abs(t - ts)))
        if best is None or np.linalg.norm(F[k]) > np.linalg.norm(F[best[0]]):
            best = (k, path)
    k, path = best
    p = meshio.read(path).point_data["contact_pressure"]
    total = float(np.sum(p * areas))
    print(f"\nright fold at t = {t[k] * 1e3:.2f} ms: sum p a = {total * 1e3:.3f} mN, |F| = {np.linalg.norm(F[k]) * 1e3:.3f} mN")
    assert np.linalg.norm(F[k]) > 1e-3
    assert total == pytest.approx(np.linalg.norm(F[k]), rel=0.01)


def test_vfrs_plot_draws_the_standard_figures(collision, capsys):
    out, _ = collision
    assert main(["plot", str(out)]) == 0
    printed = capsys.readouterr().out
    names = {"glottal_area_flow.png", "contact_force.png", "contact_pressure.png", "pressure_map.png", "probes.png",
             "energy.png", "reactions.png"}
    assert set(os.listdir(out / "plots")) == names
    for n in names:
        assert (out / "plots" / n).stat().st_size > 10_000 and n in printed
    skipped = [line for line in printed.splitlines() if "skipped" in line]
    # the main job has everything but a vocal tract, whose figures need [acoustics]
    assert skipped == ["skipped voice: the run has no [acoustics]"], skipped


def test_the_pressure_map_is_the_state_at_the_peak_force(collision):
    """contact_peak.npz holds the contact state of the step of the largest total contact force,
    recorded at that step: its row and time are the history's argmax of the force, its largest
    nodal pressure that row's contact_pressure_max (the same numbers; the map used to be the
    field snapshot up to half an [output] interval away, 1.45 against 2.2 kPa on the medium
    mesh). Its positions are the folds' at that step: moved from the reference, by less than
    their size."""
    from test_plot import assert_peak_map_is_the_histories

    out, _ = collision
    peak = assert_peak_map_is_the_histories(out, ["right", "left"])
    run = vfrs.output.load(out)
    points = np.concatenate([m.points for m, _ in run.meshes.values()])
    moved = np.linalg.norm(peak["positions"] - points, axis=1)
    assert 1e-6 < moved.max() < 2e-3  # the folds have moved (m), by less than their size


def test_the_folds_forces_are_drawn_as_one_line_labelled_as_both(collision):
    """The two folds' contact forces are equal and opposite to round-off: the force plot
    draws one line for their lengths, labelled "right = left (equal and opposite ...)" (it
    drew two coinciding lines, one hidden)."""
    from vfrs.enforcement.figures import contact_force_figure, equal_and_opposite
    from vfrs.figures import require_matplotlib

    out, _ = collision
    h = vfrs.output.load(out).history
    forces = {b: h[f"contact_force.{b}"] for b in ("right", "left")}
    assert equal_and_opposite(forces) is not None
    plt = require_matplotlib()
    fig = contact_force_figure(plt, h["t"], forces, "M5")
    (line,) = fig.axes[0].get_lines()
    assert line.get_label().startswith("right = left (equal and opposite")
    plt.close(fig)


def test_vfrs_plot_names_a_folder_that_is_not_an_output(tmp_path, capsys):
    assert main(["plot", str(tmp_path)]) == 2
    assert "no history.npz" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["plot", "."], ["bench", "accuracy", "--quick", "--problem", "block", "-o", "unused"]])
def test_commands_that_plot_say_up_front_when_matplotlib_is_missing(argv, monkeypatch, tmp_path, capsys):
    """matplotlib is a dependency, but an install with --no-deps can miss it: the commands that
    draw say so before computing anything (bench accuracy once ran every case first)."""
    import sys

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    monkeypatch.chdir(tmp_path)
    import time

    t0 = time.perf_counter()
    assert main(argv) == 2
    assert time.perf_counter() - t0 < 5.0
    err = capsys.readouterr().err
    assert "needs matplotlib" in err and "pip install matplotlib" in err
    assert not (tmp_path / "unused").exists()


def test_docs_pressure_table_row_is_reproduced():
    """docs/results.md compares the peak contact pressure with Jiang & Titze (1994) in a table
    of four runs of the main job (peak nodal pressure and where, peak pressure on the 1 mm^2
    sensor and where, mean pressure at the peak force, peak force, first contact, f0); its
    coarse 0.8 kPa row is re-run here (50 ms) and every number compared at the precision
    printed."""
    import re

    text = open(os.path.join(os.path.dirname(__file__), "..", "docs", "results.md"), encoding="utf-8").read()
    row = next(line for line in text.splitlines() if line.startswith("| 0.8 kPa | coarse |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    num = [float(x.replace("−", "-")) for x in re.findall(r"[−-]?\d+(?:\.\d+)?", " ".join(cells[2:]))]
    peak_kpa, x, y, z, sensor_kpa, sx, sy, sz, mean_kpa, force_mn, first_ms, f0 = num
    d = vfrs.Scene.load(os.path.join(os.path.dirname(__file__), "..", "examples", "m5_collision.toml")).to_dict()
    for b in d["bodies"]:
        b["mesh"]["resolution"] = "coarse"
    d["output"] = {"every": 1000}
    s = vfrs.run(vfrs.Scene.from_dict(d), progress=False).results
    c = s["contact"]
    pk = c["peak_contact_pressure"]
    assert round(pk.value / 1e3, 2) == peak_kpa
    assert np.allclose(np.round(np.array(pk.position) * 1e3, 2), [x, y, z], atol=0.011)
    ps = c["peak_sensor_pressure"]
    assert round(ps.value / 1e3, 2) == sensor_kpa
    assert np.allclose(np.round(np.array(ps.position) * 1e3, 2), [sx, sy, sz], atol=0.011)
    assert round(c["mean_contact_pressure"].value / 1e3, 2) == mean_kpa
    assert round(c["peak_force.right"].value * 1e3, 1) == force_mn
    assert round(c["first_contact"].value * 1e3, 2) == first_ms
    assert round(s["phonation"]["f0"].value) == f0


def test_resolution_warning_names_the_sparse_sensor(tmp_path):
    """A contact run whose 1 mm^2 sensor disc holds fewer than ten surface nodes says so when
    it starts (a ResolutionWarning naming the body, the count and how to fix it), and a run
    whose contact surface is fine enough does not."""
    import warnings

    from vfrs.contact.sensor import surface_sensors
    from vfrs.enforcement.record import warn_sparse_sensors

    coarse = vfrs.meshes.box((4e-3, 4e-3, 1e-3), (4, 4, 1))    # 1 mm grid: a 0.56 mm disc holds 1 node
    fine = vfrs.meshes.box((4e-3, 4e-3, 1e-3), (16, 16, 1))    # 0.25 mm grid: 21 nodes
    with pytest.warns(vfrs.ResolutionWarning, match=r"body 'left' holds 1 surface nodes .*higher `level`"):
        warn_sparse_sensors(surface_sensors(coarse.points, {"left": coarse.surfaces["zmax"]}, 1e-6), 1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_sparse_sensors(surface_sensors(fine.points, {"left": fine.surfaces["zmax"]}, 1e-6), 1e-6)
