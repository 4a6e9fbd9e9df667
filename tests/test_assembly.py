"""Stiffness and mass: against scikit-fem, invariants (rigid modes, symmetry, mass totals),
the patch test, and material frame invariance."""

import numpy as np
import pytest
import scipy.sparse as sp

import vfrs

E, NU, RHO = 10e3, 0.45, 1070.0


@pytest.fixture(scope="module")
def mesh():
    # Perturbed so that no element is a right-angled copy of another.
    return vfrs.meshes.box((0.014, 0.008, 0.01), (5, 4, 3), jitter=0.25, seed=3)


def rigid_modes(points):
    n = len(points)
    modes = []
    for a in range(3):
        t = np.zeros((n, 3))
        t[:, a] = 1.0
        modes.append(t.ravel())
    for axis in np.eye(3):
        modes.append(np.cross(axis, points).ravel())
    return np.array(modes).T


def test_stiffness_equals_scikit_fem(mesh):
    skfem = pytest.importorskip("skfem")
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    sk_mesh = skfem.MeshTet(mesh.points.T.copy(), mesh.tets.T.copy())
    basis = skfem.Basis(sk_mesh, skfem.ElementVector(skfem.ElementTetP1()))
    K_ref = skfem.asm(linear_elasticity(*lame_parameters(E, NU)), basis)
    # scikit-fem numbers DOFs node-major too; map through nodal_dofs to be sure.
    perm = basis.nodal_dofs.T.ravel()
    K_ref = K_ref[perm][:, perm]
    K = vfrs.stiffness(mesh, vfrs.Isotropic(E=E, nu=NU, rho=RHO))
    assert isinstance(K, sp.csr_matrix) and K.shape == (mesh.n_dofs, mesh.n_dofs)
    diff = abs(K - K_ref).max()
    assert diff <= 1e-10 * abs(K_ref).max(), diff


def test_transversely_isotropic_with_equal_parameters_is_isotropic(mesh):
    iso = vfrs.stiffness(mesh, vfrs.Isotropic(E=E, nu=NU))
    ti = vfrs.stiffness(
        mesh, vfrs.TransverselyIsotropic(E_p=E, E_z=E, nu_p=NU, nu_pz=NU, G_pz=E / (2 * (1 + NU)), axis=(1, 2, 3))
    )
    assert abs(iso - ti).max() <= 1e-11 * abs(iso).max()


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_rotated_fibre_axis_equals_rotated_material(mesh):
    """K of the rotated body with the rotated fibre equals Q K Q^T (frame invariance)."""
    R = rotation([1.0, -2.0, 0.5], 0.7)
    mat = dict(E_p=2e3, E_z=40e3, nu_p=0.9, nu_pz=0.0, G_pz=10e3)
    K = vfrs.stiffness(mesh, vfrs.TransverselyIsotropic(**mat, axis=(0, 0, 1))).toarray()
    rotated = vfrs.Mesh(mesh.points @ R.T, mesh.tets)
    K_rot = vfrs.stiffness(rotated, vfrs.TransverselyIsotropic(**mat, axis=tuple(R @ [0, 0, 1]))).toarray()
    Q = np.kron(np.eye(mesh.n_points), R)
    assert np.abs(K_rot - Q @ K @ Q.T).max() <= 1e-10 * np.abs(K).max()
    # And the fibre direction matters: a different axis gives a different K.
    K_x = vfrs.stiffness(mesh, vfrs.TransverselyIsotropic(**mat, axis=(1, 0, 0))).toarray()
    assert np.abs(K_x - K).max() > 1e-2 * np.abs(K).max()


def test_rigid_body_modes_span_the_null_space(mesh):
    K = vfrs.stiffness(mesh, vfrs.Isotropic(E=E, nu=NU)).toarray()
    assert np.abs(K - K.T).max() <= 1e-14 * np.abs(K).max()
    Z = rigid_modes(mesh.points)
    assert np.abs(K @ Z).max() <= 1e-10 * np.abs(K).max() * np.abs(Z).max()
    w = np.linalg.eigvalsh(K)
    scale = w.max()
    assert w.min() > -1e-12 * scale  # positive semi-definite
    assert np.sum(np.abs(w) < 1e-10 * scale) == 6  # exactly the six rigid motions


@pytest.mark.parametrize("lumped", [False, True])
def test_mass_sums_to_rho_volume_per_direction(mesh, lumped):
    M = vfrs.mass(mesh, RHO, lumped=lumped)
    V = mesh.volume
    for a in range(3):
        e = np.zeros((mesh.n_points, 3))
        e[:, a] = 1.0
        e = e.ravel()
        assert e @ (M @ e) == pytest.approx(RHO * V, rel=1e-12)
    if lumped:
        assert (M - sp.diags(M.diagonal())).nnz == 0
    else:
        # Consistent mass is symmetric positive definite and couples no two directions.
        Md = M.toarray()
        assert np.abs(Md - Md.T).max() == 0
        assert np.linalg.eigvalsh(Md).min() > 0
        assert np.abs(Md[0::3, 1::3]).max() == 0
    # Lumped rows equal consistent row sums.
    if lumped:
        rows = np.asarray(vfrs.mass(mesh, RHO).sum(axis=1)).ravel()
        assert np.allclose(M.diagonal(), rows, rtol=1e-12)


def test_patch_test_linear_field_gives_zero_interior_forces(mesh):
    A = np.array([[1.0, 0.3, -0.2], [0.1, -0.5, 0.4], [0.25, 0.0, 0.7]]) * 1e-3
    u = (mesh.points @ A.T + [1e-4, -2e-4, 3e-4]).ravel()
    K = vfrs.stiffness(mesh, vfrs.TransverselyIsotropic(E_p=2e3, E_z=40e3, nu_p=0.9, nu_pz=0.0, G_pz=10e3))
    f = (K @ u).reshape(-1, 3)
    boundary = np.unique(mesh.boundary_faces())
    interior = np.setdiff1d(np.arange(mesh.n_points), boundary)
    assert len(interior) > 10
    assert np.abs(f[interior]).max() <= 1e-10 * np.abs(f).max()
    # Constant strain: every element's displacement gradient is A.
    x = mesh.points[mesh.tets]
    du = u.reshape(-1, 3)[mesh.tets]
    J = np.transpose(x[:, 1:] - x[:, :1], (0, 2, 1))
    G = np.transpose(du[:, 1:] - du[:, :1], (0, 2, 1)) @ np.linalg.inv(J)
    assert np.abs(G - A).max() <= 1e-12


def test_region_materials_assemble_like_their_sum(mesh):
    """Body-cover layering: K with two regions equals the sum of each region's part."""
    left = np.flatnonzero(mesh.points[mesh.tets].mean(axis=1)[:, 0] < 0.007)
    right = np.setdiff1d(np.arange(mesh.n_tets), left)
    layered = vfrs.Mesh(mesh.points, mesh.tets, regions={"cover": left, "body": right})
    soft, stiff = vfrs.Isotropic(E=2e3, nu=0.4), vfrs.Isotropic(E=20e3, nu=0.4)
    K = vfrs.stiffness(layered, {"cover": soft, "body": stiff})
    K_cover = vfrs.stiffness(vfrs.Mesh(mesh.points, mesh.tets[left]), soft)
    K_body = vfrs.stiffness(vfrs.Mesh(mesh.points, mesh.tets[right]), stiff)
    assert abs(K - K_cover - K_body).max() <= 1e-12 * abs(K).max()
    with pytest.raises(vfrs.MeshError, match="no region 'muscle'"):
        vfrs.stiffness(layered, {"muscle": soft})
    with pytest.raises(vfrs.MaterialError, match="in none of the regions"):
        vfrs.stiffness(layered, {"cover": soft})
