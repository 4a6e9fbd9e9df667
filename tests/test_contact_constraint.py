"""Constraint matrix G: G x = gaps; G^T lambda is an equilibrated force system."""

import numpy as np
import pytest
import scipy.sparse as sp

import vfrs
from vfrs.contact import BvhEngine, InterfaceMeshEngine, constraint_matrix, project

from test_contact_interface_mesh import GAP, two_slabs


def _wavy_contact():
    """Two slabs pushed into each other with a wavy, non-uniform right surface."""
    pts, a, b, right = two_slabs(jitter=0.2)
    q = pts.copy()
    q[right, 0] -= GAP + 0.02e-3 + 0.01e-3 * np.sin(3e3 * pts[right, 1]) * np.cos(2e3 * pts[right, 2])
    return pts, q, a, b, right


def _check_equilibrium(G, x, lam, points):
    f = (G.T @ lam).reshape(-1, 3)
    scale = np.abs(lam).max()
    np.testing.assert_allclose(f.sum(axis=0), 0, atol=1e-12 * scale)
    rng = np.random.default_rng(5)
    for c in rng.normal(scale=1e-3, size=(3, 3)):
        m = np.cross(points - c, f).sum(axis=0)
        np.testing.assert_allclose(m, 0, atol=1e-12 * scale)


def test_G_times_positions_gives_gaps_bvh():
    pts, q, a, b, right = _wavy_contact()
    det = BvhEngine(b, slave_triangles=a, points=pts)
    pairs = det.detect(q, search_distance=0.2e-3)
    assert len(pairs) == len(np.unique(a))
    G = pairs.constraint_matrix(len(q))
    assert sp.issparse(G) and G.shape == (len(pairs), 3 * len(q))
    x = q.ravel()
    np.testing.assert_allclose(G @ x, pairs.gap, atol=1e-15)
    # on faces, those gaps are the projection's signed distances
    face = pairs.feature == 0
    assert 0.5 * len(pairs) < face.sum() < len(pairs)  # edges and vertices occur too
    r = project(q[pairs.slave[face]], q[pairs.master[face]])
    np.testing.assert_allclose(pairs.gap[face], r.gap, atol=1e-15)
    # each row: slave part n, master parts -N_i n
    row = G[0].toarray().reshape(-1, 3)
    np.testing.assert_allclose(row[pairs.slave[0]], pairs.normal[0])
    np.testing.assert_allclose(row.sum(axis=0), 0, atol=1e-15)
    # on edges and vertices too, the gap is the signed distance (contact normal along d)
    r = project(q[pairs.slave], q[pairs.master])
    np.testing.assert_allclose(pairs.gap, r.gap, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(pairs.normal, axis=1), 1, atol=1e-14)
    # forces for any lambda: zero resultant and zero moment about any point
    rng = np.random.default_rng(0)
    for _ in range(3):
        _check_equilibrium(G, x, rng.normal(size=G.shape[0]), q)


def test_G_times_positions_gives_gaps_interface_mesh():
    pts, q, a, b, right = _wavy_contact()
    im = InterfaceMeshEngine(pts, a, b, search_distance=0.5e-3)
    pairs = im.detect(q)
    assert len(pairs) > 0 and np.all(pairs.gap < 0)
    G = constraint_matrix(pairs.slave, pairs.master, pairs.xi, pairs.zeta, pairs.normal, len(q))
    np.testing.assert_allclose(G @ q.ravel(), pairs.gap, atol=1e-15)
    # the gaps are 6 V / (2 A_t): the oriented tet volumes
    vol = im.signed_volumes(q)
    inv = vol < 0
    tri = q[im.tets[inv, :3]]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    np.testing.assert_allclose(pairs.gap, 6 * vol[inv] / area2, rtol=1e-10)
    for lam in np.random.default_rng(1).normal(size=(3, len(pairs))):
        _check_equilibrium(G, q.ravel(), lam, q)


def test_rigid_plane_rows():
    pts = np.array([[0.0, 0.0, 0.1], [1.0, 0.0, -0.2], [0.0, 1.0, 3.0]])
    pairs = vfrs.contact.node_to_plane(pts, [0, 1, 2], origin=[0, 0, 0.05], normal=[0, 0, 2], search_distance=1.0)
    assert pairs.slave.tolist() == [0, 1]
    assert np.all(pairs.master == -1)
    G = pairs.constraint_matrix(len(pts))
    # G x = gap + n . origin
    np.testing.assert_allclose(G @ pts.ravel(), pairs.gap + 0.05)
    np.testing.assert_allclose(pairs.gap, [0.05, -0.25])


def test_errors_name_the_pair():
    n = [[0, 0, 1.0]]
    with pytest.raises(vfrs.ContactError, match="pair 0: slave node 0 is a vertex"):
        constraint_matrix([0], [[0, 1, 2]], [0.1], [0.1], n, 4)
    with pytest.raises(vfrs.ContactError, match=r"slave\[0\] = 9 is out of range"):
        constraint_matrix([9], [[0, 1, 2]], [0.1], [0.1], n, 4)
    with pytest.raises(vfrs.ContactError, match=r"master\[0\] = 7"):
        constraint_matrix([3], [[0, 1, 7]], [0.1], [0.1], n, 4)
    with pytest.raises(vfrs.ContactError, match="normal of pair 1"):
        constraint_matrix([3, 3], [[0, 1, 2]] * 2, [0.1] * 2, [0.1] * 2, [[0, 0, 1.0], [0, 0, np.nan]], 4)
    with pytest.raises(vfrs.ContactError, match="xi: expected length 1"):
        constraint_matrix([3], [[0, 1, 2]], [0.1, 0.2], [0.1], n, 4)
    with pytest.raises(vfrs.ContactError, match="negative"):
        constraint_matrix([3], [[0, -1, 2]], [0.1], [0.1], n, 4)


def test_the_constraint_objects_products_are_scipys_bit_for_bit():
    """ContactPairs.constraint (what a contact step uses: Rust products, no scipy matrix)
    gives G x, G^T lam and a row selection's products with the same bits as the scipy matrix
    of constraint_matrix, on surface pairs and a rigid plane's rows (3 entries each)."""
    from vfrs.contact.geometry import ContactPairs

    rng = np.random.default_rng(4)
    n_nodes, m = 40, 25
    slave = rng.integers(0, 10, m)  # slaves 0-9, masters 10-39
    master = np.array([rng.choice(np.arange(10, n_nodes), 3, replace=False) for _ in range(m)])
    master[-5:] = -1  # plane pairs: the slave only
    normal = rng.standard_normal((m, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    z = np.zeros(m)
    pairs = ContactPairs(slave, np.where(master[:, 0] >= 0, 3, -1), master, rng.random(m) * 0.5,
                         rng.random(m) * 0.5, normal, z, z + 1.0, np.zeros(m, np.uint8))
    G, C = pairs.constraint_matrix(n_nodes), pairs.constraint(n_nodes)
    x, lam = rng.standard_normal(3 * n_nodes) * 1e-3, rng.random(m)
    assert C.shape == G.shape and (C @ x).tobytes() == (G @ x).tobytes()
    assert (C.T @ lam).tobytes() == (G.T @ lam).tobytes()
    on = np.flatnonzero(lam > 0.5)
    assert (C[on] @ x).tobytes() == (G[on] @ x).tobytes()
    assert (C[on].T @ lam[on]).tobytes() == (G[on].T @ lam[on]).tobytes()
    assert (C.tocsr() != G).nnz == 0
