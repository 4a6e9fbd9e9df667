"""General detector (BVH + projection), rigid plane, contact area, tributary areas."""

import numpy as np
import pytest

import vfrs
from vfrs.contact import BvhEngine, contact_area, project, tributary_areas

from test_contact_interface_mesh import D, GAP, H, two_slabs


def brute_force_pairs(q, slaves, tris, r):
    """For each slave, the closest triangle within r by projecting onto all triangles."""
    out = {}
    for s in slaves:
        keep = ~np.any(tris == s, axis=1)
        res = project(np.repeat(q[s][None], keep.sum(), 0), q[tris[keep]])
        d = np.abs(res.gap)
        k = np.argmin(d)
        if d[k] <= r:
            out[s] = d[k]
    return out


@pytest.mark.parametrize("shift", [0.0, 1.0, 2.5])
def test_matches_brute_force(shift):
    pts, a, b, right = two_slabs(jitter=0.2)
    q = pts.copy()
    rng = np.random.default_rng(int(shift * 10))
    q[right, 0] -= shift * GAP
    q[right] += rng.normal(scale=0.02e-3, size=(right.sum(), 3))
    r = 0.15e-3
    det = BvhEngine(b, slave_triangles=a, points=pts)
    pairs = det.detect(q, r)
    expected = brute_force_pairs(q, np.unique(a), b, r)
    assert set(pairs.slave.tolist()) == set(expected)
    res = project(q[pairs.slave], q[pairs.master])
    for k, s in enumerate(pairs.slave):
        assert abs(res.gap[k]) == pytest.approx(expected[s], abs=1e-15)
    # the same detector object again after a motion (refit path) agrees too
    q2 = q.copy()
    q2[right, 0] -= 0.5 * GAP
    pairs2 = det.detect(q2, r)
    assert set(pairs2.slave.tolist()) == set(brute_force_pairs(q2, np.unique(a), b, r))


def test_both_directions_and_areas():
    pts, a, b, right = two_slabs()
    q = pts.copy()
    q[right, 0] -= GAP + 0.01e-3
    ab = BvhEngine(b, slave_triangles=a, points=pts).detect(q, 0.1e-3)
    ba = BvhEngine(a, slave_triangles=b, points=pts).detect(q, 0.1e-3)
    assert np.all(ab.gap < 0) and np.all(ba.gap < 0)
    # tributary areas of each side sum to the face area
    assert ab.area.sum() == pytest.approx(H * D, rel=1e-12)
    assert ba.area.sum() == pytest.approx(H * D, rel=1e-12)
    both = vfrs.contact.ContactPairs.concatenate([ab, ba])
    assert len(both) == len(ab) + len(ba)
    assert len(both.select(both.active)) == len(both)


def test_contact_area_counts_triangles_with_a_loaded_vertex():
    pts, a, b, right = two_slabs()
    t = tributary_areas(pts, a)
    assert t.sum() == pytest.approx(H * D, rel=1e-12)
    loaded = np.zeros(len(pts), bool)
    assert contact_area(pts, a, loaded) == 0.0
    loaded[np.unique(a)] = True
    assert contact_area(pts, a, loaded) == pytest.approx(H * D, rel=1e-12)
    # one interior node: the area of its fan of triangles
    s = a[len(a) // 2, 0]
    fan = a[np.any(a == s, axis=1)]
    x = pts[fan]
    expected = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).sum()
    assert contact_area(pts, a, [s]) == pytest.approx(expected, rel=1e-12)


def test_node_to_plane():
    m = vfrs.meshes.box((1.0, 1.0, 1.0), (2, 2, 2), origin=(0, 0, 0.05))
    bottom = m.surfaces["zmin"]
    areas = tributary_areas(m.points, bottom)[np.unique(bottom)]
    q = m.points.copy()
    q[:, 2] -= 0.1
    pairs = vfrs.contact.node_to_plane(q, np.unique(bottom), [0, 0, 0], [0, 0, 1], 0.0, areas=areas)
    assert len(pairs) == 9
    np.testing.assert_allclose(pairs.gap, -0.05)
    assert pairs.area.sum() == pytest.approx(1.0)
    with pytest.raises(vfrs.ContactError, match="normal"):
        vfrs.contact.node_to_plane(q, [0], [0, 0, 0], [0, 0, 0])


def test_bad_input_raises_and_no_panic():
    pts, a, b, right = two_slabs()
    det = BvhEngine(b, slave_triangles=a, points=pts)
    bad = pts.copy()
    bad[7, 2] = np.inf
    with pytest.raises(vfrs.ContactError, match=r"points\[7\] is not finite"):
        det.detect(bad, 1e-3)
    with pytest.raises(vfrs.ContactError, match="search_distance"):
        det.detect(pts, np.nan)
    with pytest.raises(vfrs.ContactError, match="out of range"):
        det.detect(pts[:5], 1e-3)
    flat = pts.copy()
    t0 = b[0]
    flat[t0[2]] = flat[t0[1]]  # collapse a master triangle
    with pytest.raises(vfrs.ContactError, match="degenerate"):
        BvhEngine(b, slave_triangles=a, points=pts).detect(flat, 1.0)
    with pytest.raises(vfrs.ContactError, match="slave areas"):
        BvhEngine(b, slave_nodes=[1, 2], slave_areas=[1.0])
