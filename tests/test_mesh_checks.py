"""Mesh files checked at load (issue 30, item 2): a repeated tetrahedron, nodes no tetrahedron
uses and unmerged duplicate nodes are MeshErrors naming the file and the elements or nodes
(before, the first changed the answer silently and the others ended in the factorization's
generic 'not positive definite'); negatively oriented tetrahedra are still flipped, and run.log
says how many, unless they overlap their neighbours (issue 43, item 4): a tangled mesh is a
MeshError naming the inverted elements, a consistently reversed one runs as the original."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.errors import MeshError
from vfrs.mesh import read_mesh

meshio = pytest.importorskip("meshio")
DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="module")
def block():
    m = meshio.read(DATA / "block_a.msh")
    return np.asarray(m.points, dtype=float), np.concatenate([c.data for c in m.cells if c.type == "tetra"])


def _write(tmp_path, name, points, tets) -> str:
    path = str(tmp_path / name)
    meshio.write(path, meshio.Mesh(points, [("tetra", np.asarray(tets))]))
    return path


def test_the_clean_file_reads(block, tmp_path):
    points, tets = block
    m = read_mesh(_write(tmp_path, "ok.vtu", points, tets))
    assert m.n_tets == len(tets) and m.flipped == 0


def test_a_repeated_tetrahedron_is_named(block, tmp_path):
    points, tets = block
    path = _write(tmp_path, "dup.vtu", points, np.vstack([tets, tets[7][[1, 0, 2, 3]]]))
    with pytest.raises(MeshError, match=rf"dup.vtu: 1 tetrahedra repeat another one .*elements {len(tets)};"):
        read_mesh(path)


def test_a_node_of_no_tetrahedron_is_named(block, tmp_path):
    points, tets = block
    path = _write(tmp_path, "idle.vtu", np.vstack([points, [[50.0, 50.0, 50.0]]]), tets)
    with pytest.raises(MeshError, match=rf"idle.vtu: 1 nodes belong to no tetrahedron: nodes {len(points)};"):
        read_mesh(path)


def test_unmerged_duplicate_nodes_are_named(block, tmp_path):
    """A tetrahedron moved onto a copy of one of its nodes: two nodes at one position."""
    points, tets = block
    k = int(tets[0, 0])
    t = tets.copy()
    t[0, 0] = len(points)
    path = _write(tmp_path, "twin.vtu", np.vstack([points, points[k]]), t)
    with pytest.raises(MeshError, match=rf"twin.vtu: 2 nodes share their position .*nodes {min(k, len(points))}, "
                                        rf"{max(k, len(points))} at"):
        read_mesh(path)


def test_flipped_tetrahedra_are_counted_in_the_run_log(block, tmp_path):
    points, tets = block
    t = tets.copy()
    t[:5] = t[:5][:, [0, 2, 1, 3]]
    path = _write(tmp_path, "inv.vtu", points, t)
    assert read_mesh(path).flipped == 5
    scene = vfrs.Scene.from_dict({
        "bodies": [{"name": "block", "mesh": {"path": path, "length_unit": "mm"},
                    "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
                    "fixed": [{"axis": "z", "at": 0.0}]}],
        "time": {"mode": "static"}})
    out = tmp_path / "out"
    vfrs.run(scene, out=out, progress=False)
    assert "mesh of body 'block': 5 of 1248 tetrahedra were negatively oriented in the file and were flipped" in (
        out / "run.log").read_text()


@pytest.mark.parametrize("fixed,held", [([], "0 fixed DOFs hold 0 of its 6"),
                                        ([{"surface": "xmin", "components": ["x"]}], "15 fixed DOFs hold 3 of its 6")])
def test_a_static_body_its_supports_do_not_hold_is_named(fixed, held):
    """The factorization's 'not positive definite' of a static scene names the body whose
    rigid-body motions its fixed DOFs leave free, and how many they hold (rollers on x only
    hold translation x and the rotations about y and z)."""
    d = vfrs.Scene.load(Path(__file__).resolve().parent.parent / "examples" / "bar_static.toml").to_dict()
    d["bodies"][0]["fixed"] = fixed
    with pytest.raises(vfrs.SolverError, match=rf"the stiffness is not positive definite: body 'bar' \({held} "
                                               r"rigid-body motions\)\. A static scene must fix"):
        vfrs.run(vfrs.Scene.from_dict(d), progress=False)


def test_merge_nodes_joins_an_unmerged_seam_and_gives_the_clean_answer(tmp_path):
    """block_a.msh cut into its tetrahedra above and below the median height, the nodes they share doubled
    and the upper part's tetrahedra and named triangles moved onto the copies (a seam Gmsh left
    unmerged): refused as read, and with merge_nodes = true the same mesh as the clean file
    (points, tetrahedra, named surfaces) and the same static displacement under gravity, bit
    for bit."""
    m = meshio.read(DATA / "block_a.msh")
    points = np.asarray(m.points, dtype=float)
    (tets,) = [np.asarray(c.data) for c in m.cells if c.type == "tetra"]
    zc = points[tets].mean(axis=1)[:, 2]
    upper = zc > np.median(zc)
    seam = np.intersect1d(tets[upper].ravel(), tets[~upper].ravel())
    assert len(seam) > 4
    copy_of = np.arange(len(points))
    copy_of[seam] = len(points) + np.arange(len(seam))
    faces = {tuple(sorted(f)): bool(up) for t, up in zip(tets, upper)
             for f in (t[[0, 1, 2]], t[[0, 1, 3]], t[[0, 2, 3]], t[[1, 2, 3]])}
    cells = []
    for c in m.cells:
        d = np.asarray(c.data).copy()
        if c.type == "tetra":
            d[upper] = copy_of[d[upper]]
        else:
            hi = np.array([faces[tuple(sorted(f))] for f in d])
            d[hi] = copy_of[d[hi]]
        cells.append((c.type, d))
    seamed = meshio.Mesh(np.vstack([points, points[seam]]), cells, cell_data=m.cell_data, field_data=m.field_data)
    path = str(tmp_path / "seamed.msh")
    meshio.write(path, seamed, file_format="gmsh22", binary=False)
    with pytest.raises(MeshError, match=r"share their position .*merge_nodes = true"):
        read_mesh(path)
    clean, merged = read_mesh(DATA / "block_a.msh"), read_mesh(path, merge_nodes=True)
    assert merged.merged == len(seam)
    np.testing.assert_array_equal(merged.points, clean.points)
    np.testing.assert_array_equal(merged.tets, clean.tets)
    assert set(merged.surfaces) == set(clean.surfaces) and set(merged.surfaces)
    for name in clean.surfaces:
        np.testing.assert_array_equal(merged.surfaces[name], clean.surfaces[name])

    def displacement(mesh_spec, out=None):
        scene = vfrs.Scene.from_dict({
            "bodies": [{"name": "block", "mesh": mesh_spec,
                        "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
                        "fixed": [{"axis": "z", "at": -5e-3}]}],
            "gravity": [0.0, 0.0, -9.81], "time": {"mode": "static"}})
        return vfrs.run(scene, out=out, progress=False).u

    u_clean = displacement({"path": str(DATA / "block_a.msh"), "length_unit": "mm"})
    u_merged = displacement({"path": path, "length_unit": "mm", "merge_nodes": True}, out=tmp_path / "out")
    assert f"mesh of body 'block': {len(seam)} duplicate nodes merged (merge_nodes = true)" in (
        tmp_path / "out" / "run.log").read_text()
    assert np.abs(u_clean).max() > 0
    np.testing.assert_array_equal(u_merged, u_clean)


def _box_file(tmp_path, name, tets, lift=0.0) -> str:
    """vfrs.meshes.box 20 x 4 x 4 mm, 10 x 4 x 4 cells, written with ``tets``; its centre node
    moved up by ``lift`` (m)."""
    m = vfrs.meshes.box((0.02, 0.004, 0.004), (10, 4, 4))
    points = m.points.copy()
    points[int(np.argmin(np.linalg.norm(points - [0.01, 0.002, 0.002], axis=1))), 2] += lift
    return _write(tmp_path, name, points, tets)


def test_a_tangled_mesh_is_refused_naming_its_inverted_elements(tmp_path):
    """The box's centre node moved up 1.2 mm, through the face 1 mm above it: 6 tetrahedra are
    inverted (before, they were flipped and the mesh ran with overlapping elements), 12
    neighbours overlap them. The error names the 6 first; the same mesh written reversed (every
    element negative) names them too, now as the positive ones."""
    tets = vfrs.meshes.box((0.02, 0.004, 0.004), (10, 4, 4)).tets
    inverted = "420, 423, 445, 520, 542, ... (6 in all)"
    with pytest.raises(MeshError, match=rf"tangled.vtu: the mesh is tangled: 6 tetrahedra are oriented negatively in "
                                        rf"the file, .*elements {re.escape(inverted)}, overlapping elements .* \(12 in "
                                        r"all\) .*Untangle the mesh or remesh it"):
        read_mesh(_box_file(tmp_path, "tangled.vtu", tets, lift=1.2e-3))
    with pytest.raises(MeshError, match=rf"6 tetrahedra are oriented positively in the file, .*{re.escape(inverted)}"):
        read_mesh(_box_file(tmp_path, "tangled_reversed.vtu", tets[:, [1, 0, 2, 3]], lift=1.2e-3))
    assert read_mesh(_box_file(tmp_path, "lifted.vtu", tets, lift=0.6e-3)).flipped == 0  # moved, not through


@pytest.mark.parametrize("reversed_part", ["all", "x < 10 mm"])
def test_a_consistently_reversed_mesh_gives_the_original_answer(tmp_path, reversed_part):
    """Every element (or every element of the half x < 10 mm) written negatively oriented: read,
    flipped and run, the clamped box sags under gravity (10.2 mm at the tip, linear) as the
    original does, bit for bit (measured)."""
    box = vfrs.meshes.box((0.02, 0.004, 0.004), (10, 4, 4))
    tets, rev = box.tets, box.tets.copy()
    part = np.ones(len(tets), bool) if reversed_part == "all" else box.points[tets].mean(axis=1)[:, 0] < 0.01
    rev[part] = rev[part][:, [1, 0, 2, 3]]

    def sag(path):
        scene = vfrs.Scene.from_dict({
            "bodies": [{"name": "beam", "mesh": {"path": path},
                        "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
                        "fixed": [{"axis": "x", "at": 0.0}]}],
            "gravity": [0.0, 0.0, -9.81], "time": {"mode": "static"}})
        return vfrs.run(scene, progress=False).u

    original, reversed_ = sag(_box_file(tmp_path, "box.vtu", tets)), sag(_box_file(tmp_path, "rev.vtu", rev))
    assert read_mesh(tmp_path / "rev.vtu").flipped == int(part.sum()) > 0
    assert np.abs(original[:, 2]).max() > 1e-2
    np.testing.assert_array_equal(reversed_, original)
