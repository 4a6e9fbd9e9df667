"""Node-to-triangle projection against brute force, ipctk, and the gap-sign property."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import vfrs
from vfrs.contact import project


def _seg(p, a, b):
    d = b - a
    t = np.clip(np.dot(p - a, d) / np.dot(d, d), 0.0, 1.0)
    return a + t * d


def brute_force(p, tri):
    """Closest point by enumerating the face (if the plane projection is inside), edges and
    vertices; returns (closest, distance)."""
    a, b, c = tri
    n = np.cross(b - a, c - a)
    n2 = n @ n
    q = p - a
    xi = np.cross(q, c - a) @ n / n2
    zeta = np.cross(b - a, q) @ n / n2
    cands = [a, b, c, _seg(p, a, b), _seg(p, b, c), _seg(p, a, c)]
    if xi >= 0 and zeta >= 0 and xi + zeta <= 1:
        cands.append(p - (q @ n) / n2 * n)
    d = [np.linalg.norm(p - x) for x in cands]
    k = int(np.argmin(d))
    return cands[k], d[k]


def random_cases(rng, k):
    tris = rng.normal(size=(k, 3, 3))
    # points: a third near the face, a third beyond an edge, a third beyond a vertex
    w = rng.dirichlet([1, 1, 1], size=k)
    inside = np.einsum("ki,kij->kj", w, tris)
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    pts = inside + rng.normal(size=(k, 1)) * n
    third = k // 3
    # beyond edge 0-1: push outwards in the plane, away from vertex 2
    mid = 0.5 * (tris[:third, 0] + tris[:third, 1])
    pts[:third] = mid + 1.5 * (mid - tris[:third, 2]) + rng.normal(size=(third, 1)) * n[:third]
    # beyond vertex 0
    v = tris[third : 2 * third]
    cen = v.mean(axis=1)
    pts[third : 2 * third] = v[:, 0] + 2.0 * (v[:, 0] - cen) + 0.3 * rng.normal(size=(third, 3))
    return pts, tris


def test_matches_brute_force_on_faces_edges_vertices():
    rng = np.random.default_rng(0)
    pts, tris = random_cases(rng, 600)
    r = project(pts, tris)
    # all three features occur
    assert set(np.unique(r.feature)) == {0, 1, 2}
    for k in range(len(pts)):
        c, d = brute_force(pts[k], tris[k])
        np.testing.assert_allclose(r.closest[k], c, atol=1e-12)
        assert abs(abs(r.gap[k]) - d) < 1e-12
    # xi, zeta reconstruct the projected point
    n1 = 1 - r.xi - r.zeta
    rec = n1[:, None] * tris[:, 0] + r.xi[:, None] * tris[:, 1] + r.zeta[:, None] * tris[:, 2]
    np.testing.assert_allclose(rec, r.closest, atol=1e-12)
    assert np.all(r.xi >= -1e-15) and np.all(r.zeta >= -1e-15) and np.all(n1 >= -1e-12)
    # the normal is (x2 - x1) x (x3 - x1) normalised
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    np.testing.assert_allclose(r.normal, n / np.linalg.norm(n, axis=1)[:, None], atol=1e-14)
    # sign: negative exactly on the side opposite the normal
    side = np.einsum("kj,kj->k", pts - tris[:, 0], n)
    assert np.all(np.sign(r.gap) == np.sign(side))
    # on a face, gap is the signed distance along the normal
    f = r.feature == 0
    np.testing.assert_allclose(r.gap[f], np.einsum("kj,kj->k", pts[f] - r.closest[f], r.normal[f]), atol=1e-12)


def test_matches_ipctk():
    ipctk = pytest.importorskip("ipctk")
    rng = np.random.default_rng(1)
    pts, tris = random_cases(rng, 300)
    r = project(pts, tris)
    for k in range(len(pts)):
        d2 = ipctk.point_triangle_distance(pts[k], tris[k, 0], tris[k, 1], tris[k, 2])
        assert abs(r.gap[k] ** 2 - d2) <= 1e-10 * max(1.0, d2)


coord = st.floats(-10, 10, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(
    tri=st.lists(st.tuples(coord, coord, coord), min_size=3, max_size=3),
    w=st.tuples(st.floats(0.01, 1), st.floats(0.01, 1), st.floats(0.01, 1)),
    h=st.floats(-5, 5, allow_nan=False),
)
def test_gap_changes_sign_exactly_when_crossing_plane_inside(tri, w, h):
    tri = np.array(tri, dtype=float)
    n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    area2 = np.linalg.norm(n)
    edges = max(np.linalg.norm(tri[1] - tri[0]), np.linalg.norm(tri[2] - tri[0]), np.linalg.norm(tri[2] - tri[1]))
    if area2 < 1e-3 * edges**2 or edges < 1e-3:
        # too thin: its degenerate limit is covered by the error tests
        return
    n /= area2
    w = np.array(w) / sum(w)
    inside = w @ tri
    # move a node along the normal through the point `inside` of the triangle
    p = inside + h * n
    r = project(p[None], tri[None])
    if abs(h) < 1e-9:
        assert abs(r.gap[0]) < 1e-8
    else:
        assert np.sign(r.gap[0]) == np.sign(h)
        assert r.feature[0] == 0
        assert abs(r.gap[0] - h) < 1e-9 * max(1, abs(h), edges)
        assert abs(r.xi[0] - w[1]) < 1e-8 and abs(r.zeta[0] - w[2]) < 1e-8


def test_degenerate_and_non_finite_raise():
    flat = [[[0, 0, 0], [1, 0, 0], [2, 0, 0]]]
    with pytest.raises(vfrs.ContactError, match="triangle 0 is degenerate"):
        project([[0, 1, 0]], flat)
    good = [[[0, 0, 0], [1, 0, 0], [0, 1, 0]]]
    with pytest.raises(vfrs.ContactError, match=r"point\[1\] is not finite"):
        project([[0, 0, 1], [np.nan, 0, 0]], good * 2)
    with pytest.raises(vfrs.ContactError, match="not finite"):
        project([[0, 0, 1]], [[[0, 0, 0], [np.inf, 0, 0], [0, 1, 0]]])
    with pytest.raises(ValueError, match="shape"):
        project([[0, 0, 1]], good * 2)
