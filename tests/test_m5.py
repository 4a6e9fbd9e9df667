"""The built-in M5-type folds: volumes converge to the profile, surfaces cover the boundary
once, left mirrors right, generation is deterministic."""

import numpy as np
import pytest

import vfrs
from vfrs.meshes.m5 import m5, m5_profile

LENGTH = 14e-3


def profile_area_and_medial_length(**kw):
    curve, lateral = m5_profile(n=20000, **kw)
    closed = np.vstack([curve, [lateral, curve[-1, 1]], [lateral, curve[0, 1]]])
    x, y = closed[:, 0], closed[:, 1]
    area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    length = np.linalg.norm(np.diff(curve, axis=0), axis=1).sum()
    return area, length


def tri_area(mesh, name):
    x = mesh.points[mesh.surface(name)]
    return 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).sum()


@pytest.mark.parametrize("psi", [0.0, 10.0, -10.0])
def test_volume_and_medial_area_converge_to_the_profile(psi):
    area, medial_length = profile_area_and_medial_length(psi=psi)
    vol_err, med_err = [], []
    for res in ("coarse", "medium", "fine"):
        m = m5("right", res, psi=psi, length=LENGTH)
        vol_err.append(abs(m.volume - area * LENGTH) / (area * LENGTH))
        med_err.append(abs(tri_area(m, "medial") - medial_length * LENGTH) / (medial_length * LENGTH))
    assert vol_err[0] > vol_err[1] > vol_err[2]
    assert med_err[0] > med_err[1] > med_err[2]
    assert vol_err[2] < 2e-3 and med_err[2] < 2e-3
    # Flat faces are exact.
    m = m5("right", "coarse", psi=psi)
    depth_span = m.points[:, 1].max() - m.points[:, 1].min()
    assert tri_area(m, "lateral") == pytest.approx(depth_span * LENGTH, rel=1e-12)
    assert tri_area(m, "anterior") == pytest.approx(m.volume / LENGTH, rel=1e-12)


def test_named_surfaces_cover_the_boundary_exactly_once_and_point_outward():
    m = m5("right", "coarse", psi=10.0)
    named = np.concatenate(list(m.surfaces.values()))
    key = sorted(map(tuple, np.sort(named, axis=1)))
    assert len(key) == len(set(key))
    assert key == sorted(map(tuple, np.sort(m.boundary_faces(), axis=1)))
    # Outward: the divergence theorem over the named surfaces gives the volume.
    x = m.points[named]
    n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]) / 2
    assert np.einsum("ij,ij->", n, x.mean(axis=1)) / 3 == pytest.approx(m.volume, rel=1e-12)
    # The medial surface faces the glottis (-x for the right fold).
    xm = m.points[m.surface("medial")]
    nm = np.cross(xm[:, 1] - xm[:, 0], xm[:, 2] - xm[:, 0])
    assert (nm[:, 0] < 0).mean() > 0.95


def test_left_fold_is_the_mirror_image_of_the_right():
    r, l = m5("right", "coarse", psi=5.0), m5("left", "coarse", psi=5.0)
    assert np.array_equal(l.points, r.points * [-1, 1, 1])
    assert l.volume == pytest.approx(r.volume, rel=1e-14)
    assert (l.signed_volumes() > 0).all() and (r.signed_volumes() > 0).all()
    assert r.points[r.surface_nodes("medial"), 0].min() == pytest.approx(0.05e-3, rel=1e-6)
    assert l.points[l.surface_nodes("medial"), 0].max() == pytest.approx(-0.05e-3, rel=1e-6)


def test_generation_is_deterministic_and_regions_split_the_fold():
    a, b = m5("right", "coarse"), m5("right", "coarse")
    assert np.array_equal(a.points, b.points) and np.array_equal(a.tets, b.tets)
    cover, body = a.regions["cover"], a.regions["body"]
    assert len(cover) > 0 and len(body) > 0
    assert len(np.intersect1d(cover, body)) == 0 and len(cover) + len(body) == a.n_tets
    # Cover elements are closer to the medial surface than body elements.
    c = a.points[a.tets].mean(axis=1)
    assert c[cover, 0].mean() < c[body, 0].mean()


def test_bad_parameters_are_named():
    with pytest.raises(vfrs.MeshError, match="psi = 60"):
        m5("right", "coarse", psi=60)
    with pytest.raises(vfrs.MeshError, match="unknown resolution 'ultra'"):
        m5("right", "ultra")
    with pytest.raises(vfrs.MeshError, match="side must be"):
        m5("middle")
    with pytest.raises(vfrs.MeshError, match="half_gap"):
        m5("right", "coarse", half_gap=-1e-4)
