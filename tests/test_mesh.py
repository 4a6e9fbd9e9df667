"""Mesh validation, volumes, named surfaces, reading and writing."""

import numpy as np
import pytest

import vfrs

UNIT = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])


@pytest.mark.parametrize(
    "points, tets, message",
    [
        (UNIT, [[0, 1, 2, 4]], r"tetrahedron 0 refers to point 4, but there are only 4 points"),
        (UNIT, [[0, 1, 1, 3]], r"tetrahedron 0 uses point 1 twice"),
        (UNIT, [[0, 2, 1, 3]], r"tetrahedron 0 has signed volume -1\.6+\d*e-1 .*swap two vertices"),
        (np.where(np.arange(12).reshape(4, 3) == 7, np.nan, UNIT), [[0, 1, 2, 3]], r"point 2 has a non-finite coordinate"),
        (UNIT, [[0, 1, 2, -1]], r"tetrahedron 0 refers to point -1"),
        (UNIT, np.zeros((0, 4), int), r"no tetrahedra"),
        (UNIT[:, :2], [[0, 1, 2, 3]], r"points must have shape \(n, 3\)"),
        (UNIT, [[0.0, 1, 2, 3]], r"integer node indices"),
    ],
)
def test_bad_meshes_raise_with_the_element_named(points, tets, message):
    with pytest.raises(vfrs.MeshError, match=message):
        vfrs.Mesh(points, np.asarray(tets))


def test_flat_element_in_a_larger_mesh_is_named():
    m = vfrs.meshes.box((1, 1, 1), (2, 2, 2))
    pts = m.points.copy()
    t = 17
    a, b, c, d = m.tets[t]
    pts_bad = pts.copy()
    # Move d onto the plane of a, b, c: element 17 (and maybe neighbours) goes flat.
    pts_bad[d] = (pts[a] + pts[b] + pts[c]) / 3
    with pytest.raises(vfrs.MeshError, match=r"tetrahedron \d+ has signed volume"):
        vfrs.Mesh(pts_bad, m.tets)


def test_signed_volumes_detect_inversion():
    v = vfrs.signed_volumes(UNIT, [[0, 1, 2, 3], [0, 2, 1, 3]])
    assert np.allclose(v, [1 / 6, -1 / 6])
    with pytest.raises(vfrs.MeshError):
        vfrs.signed_volumes(UNIT, [[0, 1, 2, 9]])


def test_box_surfaces_cover_the_boundary_once_and_point_outward():
    m = vfrs.meshes.box((2.0, 1.0, 0.5), (4, 3, 2), jitter=0.2)
    assert m.volume == pytest.approx(1.0, rel=1e-12)
    named = np.concatenate(list(m.surfaces.values()))
    boundary = m.boundary_faces()
    assert sorted(map(tuple, np.sort(named, 1))) == sorted(map(tuple, np.sort(boundary, 1)))
    centre = m.points.mean(axis=0)
    for name, tri in m.surfaces.items():
        x = m.points[tri]
        n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
        assert (np.einsum("ij,ij->i", n, x.mean(axis=1) - centre) > 0).all(), name
    # Divergence theorem: sum of n dA . x / 3 over the closed boundary is the volume.
    x = m.points[boundary]
    n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]) / 2
    assert np.einsum("ij,ij->", n, x.mean(axis=1)) / 3 == pytest.approx(m.volume, rel=1e-12)


def test_gmsh_file_round_trip_keeps_named_surfaces_and_regions(tmp_path):
    meshio = pytest.importorskip("meshio")
    m = vfrs.meshes.box((0.01, 0.01, 0.01), (2, 2, 2))
    tri = np.concatenate([m.surfaces["xmin"], m.surfaces["zmax"]])
    # Flip half of them: the reader orients surface triangles outward.
    tri[::2] = tri[::2][:, [0, 2, 1]]
    tags = np.r_[np.full(len(m.surfaces["xmin"]), 1), np.full(len(m.surfaces["zmax"]), 2)]
    out = meshio.Mesh(
        m.points * 1e3,  # written in mm
        [("triangle", tri), ("tetra", m.tets[:, [0, 2, 1, 3]])],  # and inverted
        cell_data={"gmsh:physical": [tags, np.full(m.n_tets, 3)], "gmsh:geometrical": [tags, np.full(m.n_tets, 3)]},
        field_data={"fixed": np.array([1, 2]), "top": np.array([2, 2]), "tissue": np.array([3, 3])},
    )
    path = tmp_path / "box.msh"
    out.write(path, file_format="gmsh22", binary=False)
    r = vfrs.read_mesh(path, length_unit="mm")
    assert r.volume == pytest.approx(m.volume, rel=1e-12)
    assert set(r.surfaces) == {"fixed", "top"} and set(r.regions) == {"tissue"}
    assert len(r.regions["tissue"]) == m.n_tets
    for name in ("fixed", "top"):
        x = r.points[r.surfaces[name]]
        n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
        assert (np.einsum("ij,ij->i", n, x.mean(axis=1) - 0.005) > 0).all()
    with pytest.raises(vfrs.MeshError, match="does not exist"):
        vfrs.read_mesh(tmp_path / "missing.msh")
    with pytest.raises(vfrs.MeshError, match="has no surface 'lateral'"):
        r.surface("lateral")


def test_vtu_write_opens_again(tmp_path):
    meshio = pytest.importorskip("meshio")
    m = vfrs.meshes.box((1, 1, 1), (2, 2, 2))
    u = np.random.default_rng(0).standard_normal((m.n_points, 3))
    m.write(tmp_path / "u.vtu", point_data={"displacement": u}, cell_data={"volume": m.signed_volumes()})
    back = meshio.read(tmp_path / "u.vtu")
    assert np.allclose(back.point_data["displacement"], u)
