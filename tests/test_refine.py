"""Uniform refinement (every tetrahedron split into eight, in Rust): volumes, named surfaces and
regions kept to round-off, the box generator's nodes reproduced, a static answer converging,
and the scene key ``mesh = { path = ..., refine = n }``."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs._core import fem
from vfrs.checkpoint import scene_hash
from vfrs.errors import MeshError
from vfrs.mesh import Mesh, read_mesh, refine

DATA = Path(__file__).resolve().parent / "data"


def _area(points, tri):
    a, b, c = (points[tri[:, k]] for k in range(3))
    return np.cross(b - a, c - a) / 2.0  # vector areas, outward


def _region_volume(m, name):
    return m.signed_volumes()[m.regions[name]].sum()


@pytest.mark.parametrize("times", [1, 2])
def test_refinement_keeps_volume_surfaces_and_regions(times):
    """block_a.msh (Gmsh, named surfaces) with two made-up regions: total volume, every named
    surface's area (and its vector area: normals kept outward) and every region's volume equal
    to 1e-12 relative; 8^times tets; every child positive with 1/8^times of its parent."""
    m = read_mesh(DATA / "block_a.msh", length_unit="mm")
    zc = m.points[m.tets].mean(axis=1)[:, 2]
    m.regions = {"low": np.flatnonzero(zc < np.median(zc)), "high": np.flatnonzero(zc >= np.median(zc))}
    assert m.surfaces
    r = m.refined(times)
    assert r.n_tets == 8**times * m.n_tets
    assert set(r.surfaces) == set(m.surfaces) and set(r.regions) == set(m.regions)
    assert abs(r.volume - m.volume) <= 1e-12 * m.volume
    v = r.signed_volumes()
    assert (v > 0).all()
    np.testing.assert_allclose(v.reshape(m.n_tets, -1).sum(axis=1), m.signed_volumes(), rtol=1e-12)
    np.testing.assert_allclose(v.reshape(m.n_tets, -1), np.repeat(m.signed_volumes()[:, None] / 8**times, 8**times, axis=1), rtol=1e-9)
    for name, tri in m.surfaces.items():
        assert len(r.surfaces[name]) == 4**times * len(tri)
        a0, a1 = _area(m.points, tri), _area(r.points, r.surfaces[name])
        s0, s1 = np.linalg.norm(a0, axis=1).sum(), np.linalg.norm(a1, axis=1).sum()
        assert abs(s1 - s0) <= 1e-12 * s0, name
        np.testing.assert_allclose(a1.sum(axis=0), a0.sum(axis=0), atol=1e-12 * s0)
        # each child's normal along its parent's
        par = np.repeat(a0, 4**times, axis=0)
        assert (np.einsum("ij,ij->i", a1, par) > 0).all(), name
    for name in m.regions:
        v0, v1 = _region_volume(m, name), _region_volume(r, name)
        assert abs(v1 - v0) <= 1e-12 * v0, name
    # the refined surfaces are boundary faces of the refined mesh
    bnd = {tuple(sorted(f)) for f in r.boundary_faces()}
    assert all(tuple(sorted(f)) in bnd for tri in r.surfaces.values() for f in tri)


def test_counts_and_shared_midpoints():
    """nodes = old + edges (one midpoint per edge, shared), no two nodes at one position."""
    m = vfrs.meshes.box((1.0, 2.0, 0.5), (3, 2, 2), jitter=0.2)
    edges = np.unique(np.sort(m.tets[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]].reshape(-1, 2), axis=1), axis=0)
    r = m.refined()
    assert r.n_points == m.n_points + len(edges)
    assert len(np.unique(r.points, axis=0)) == r.n_points
    np.testing.assert_array_equal(r.points[: m.n_points], m.points)
    # the same twice (deterministic numbering)
    r2 = refine(m, 1)
    np.testing.assert_array_equal(r2.points, r.points)
    np.testing.assert_array_equal(r2.tets, r.tets)
    assert refine(m, 0) is m


def test_a_refined_box_has_the_nodes_of_the_box_at_doubled_cells():
    """The box generator's cells, refined: the same node set as the generator at 2x (and 4x)
    cells (to round-off), the same surfaces' node sets; the tets differ (octahedra are split
    along a diagonal, not Kuhn's)."""
    size, cells = (0.3, 0.2, 0.1), (3, 2, 2)
    m = vfrs.meshes.box(size, cells)
    for times in (1, 2):
        r = m.refined(times)
        fine = vfrs.meshes.box(size, tuple(c * 2**times for c in cells))
        assert (r.n_points, r.n_tets) == (fine.n_points, fine.n_tets)
        scale = 1e-12 * max(size)
        key = lambda p: {tuple(x) for x in np.round(p / scale).astype(np.int64)}  # noqa: E731
        assert key(r.points) == key(fine.points)
        for name in m.surfaces:
            assert key(r.points[np.unique(r.surfaces[name])]) == key(fine.points[np.unique(fine.surfaces[name])])


def test_bad_input_is_a_mesh_error_not_a_crash():
    pts = np.eye(4, 3, k=-1)
    tets = np.array([[0, 1, 2, 4]], dtype=np.int64)
    none = np.zeros((0, 3), dtype=np.int64)
    with pytest.raises(MeshError, match="refers to point 4"):
        fem.refine_tets(pts, tets, none)
    with pytest.raises(MeshError, match="refers to point -1"):
        fem.refine_tets(pts, np.array([[0, 1, 2, -1]], dtype=np.int64), none)
    with pytest.raises(MeshError, match="surface triangle 0 refers to point 7"):
        fem.refine_tets(pts, np.array([[0, 1, 2, 3]], dtype=np.int64), np.array([[0, 1, 7]], dtype=np.int64))
    with pytest.raises(MeshError, match="times must be an integer >= 0"):
        Mesh(pts, [[0, 1, 2, 3]]).refined(-1)


def _cantilever(mesh_spec):
    """A 40 x 5 x 5 mm tissue beam clamped at x = 0, bending under its weight (static)."""
    return vfrs.Scene.from_dict({
        "bodies": [{"name": "beam", "mesh": mesh_spec,
                    "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
                    "fixed": [{"axis": "x", "at": 0.0}]}],
        "gravity": [0.0, 0.0, -9.81], "time": {"mode": "static"}})


def _tip(res, mesh):
    (n,) = np.flatnonzero(np.all(np.isclose(mesh.points, [0.04, 0.005, 0.005], atol=1e-9), axis=1))
    return res.u[n, 2]


def test_a_static_answer_converges_under_refinement(tmp_path):
    """Tip deflection of a coarse (8 x 1 x 1 cells) beam refined 0, 1, 2 times, against 3
    times: the error falls at each refinement, faster as it nears the asymptotic range (P1 in
    bending: about 4x per refinement there)."""
    path = tmp_path / "beam.vtu"
    vfrs.meshes.box((0.04, 0.005, 0.005), (8, 1, 1)).write(path)
    tips = []
    for level in range(4):
        spec = {"path": str(path), "length_unit": "m", **({"refine": level} if level else {})}
        scene = _cantilever(spec)
        assert ("refine" in scene.bodies[0].mesh) == (level > 0)
        mesh = scene.bodies[0].build_mesh()
        assert mesh.n_tets == 48 * 8**level
        tips.append(_tip(vfrs.run(scene, progress=False), mesh))
    err = [abs(t - tips[-1]) for t in tips[:-1]]
    assert tips[-1] < 0 and err[0] > err[1] > err[2] > 0, (tips, err)
    # measured: ratios 1.67, 2.97 (against a fourth refinement, 37k nodes, 10 s: 1.60, 2.48,
    # 4.03, the P1 rate in the energy norm reached from the one-cell-thick start)
    assert err[1] / err[2] > 2.5, (tips, err)


def test_the_scene_key_is_checked_and_left_out_at_zero(tmp_path):
    path = tmp_path / "beam.vtu"
    vfrs.meshes.box((0.04, 0.005, 0.005), (4, 1, 1)).write(path)
    plain = _cantilever({"path": str(path)})
    zero = _cantilever({"path": str(path), "refine": 0})
    assert zero.bodies[0].mesh == plain.bodies[0].mesh and "refine" not in zero.bodies[0].mesh
    assert scene_hash(zero) == scene_hash(plain)
    one = _cantilever({"path": str(path), "refine": 1})
    assert one.bodies[0].mesh["refine"] == 1 and scene_hash(one) != scene_hash(plain)
    for bad in (-1, 1.5, True):
        with pytest.raises(vfrs.SceneError, match=r"refine"):
            _cantilever({"path": str(path), "refine": bad})


def test_vfrs_run_with_a_refined_mesh(tmp_path):
    path = tmp_path / "beam.vtu"
    vfrs.meshes.box((0.04, 0.005, 0.005), (4, 1, 1)).write(path)
    (tmp_path / "scene.toml").write_text(
        "gravity = [0.0, 0.0, -9.81]\n"
        '[[bodies]]\nname = "beam"\nmesh = { path = "beam.vtu", refine = 1 }\n'
        'material = { model = "isotropic", E = 1e4, nu = 0.3, rho = 1000.0 }\n'
        'fixed = [{ axis = "x", at = 0.0 }]\n'
        '[time]\nmode = "static"\n'
    )
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "vfrs", "run", str(tmp_path / "scene.toml"), "-o", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    log = (out / "run.log").read_text()
    assert "'tetrahedra': 192" in log  # 24 tets refined once
    assert "mesh of body 'beam': refined 1 time(s), every tetrahedron into eight (refine = 1): 192 tetrahedra" in log
    # the resolved scene written with the run keeps the key, and reloads to the same mesh
    again = vfrs.Scene.load(out / "scene.toml")
    assert again.bodies[0].mesh["refine"] == 1
    assert again.bodies[0].build_mesh().n_tets == 24 * 8
    assert scene_hash(again) == scene_hash(vfrs.Scene.load(tmp_path / "scene.toml"))


def test_a_built_in_mesh_refines_too():
    """``mesh = { builtin = "box", ..., refine = 1 }``: the generator's mesh refined, the same
    nodes and named surfaces as the box at doubled cells, the size estimate scaled by 8, and
    refine written into the resolved scene only when > 0 (the scene hash of a run without it
    is unchanged)."""
    def scene(cells, refine=None):
        mesh = {"builtin": "box", "size": [0.01, 0.01, 0.005], "cells": cells}
        if refine is not None:
            mesh["refine"] = refine
        return vfrs.Scene.from_dict({"bodies": [{"name": "b", "mesh": mesh, "fixed": ["zmin"],
                                                 "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0}}],
                                     "time": {"mode": "static"}})

    refined, doubled = scene([2, 2, 1], 1), scene([4, 4, 2])
    a, b = refined.bodies[0].build_mesh(), doubled.bodies[0].build_mesh()
    assert a.n_tets == b.n_tets == 8 * scene([2, 2, 1]).bodies[0].build_mesh().n_tets
    assert sorted(map(tuple, np.round(a.points, 12))) == sorted(map(tuple, np.round(b.points, 12)))
    assert set(a.surfaces) == set(b.surfaces)
    assert refined.to_dict()["bodies"][0]["mesh"]["refine"] == 1
    assert "refine" not in scene([2, 2, 1], 0).to_dict()["bodies"][0]["mesh"]
    assert scene([2, 2, 1], 0).to_toml() == scene([2, 2, 1]).to_toml()
    assert refined.size_estimate()["nodes"] >= 8 * scene([2, 2, 1]).size_estimate()["nodes"] - 1
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.mesh\.refine"):
        scene([2, 2, 1], -1)
