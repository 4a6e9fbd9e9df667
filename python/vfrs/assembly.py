"""Stiffness and mass matrices as ``scipy.sparse.csr_matrix`` (DOFs node-major)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .mesh import Mesh


def sparsity_pattern(mesh: Mesh):
    """The mesh's CSC pattern as int32/int64 numpy arrays, converted once and cached (the
    conversion from Rust cost as much as filling the values)."""
    cached = getattr(mesh, "_pattern_arrays", None)
    if cached is None:
        indptr, indices = mesh.assembler().pattern()
        idx = np.int32 if indptr[-1] < np.iinfo(np.int32).max else np.int64
        cached = (indptr.astype(idx), indices.astype(idx))
        mesh._pattern_arrays = cached
    return cached


def _csr(mesh: Mesh, data: np.ndarray) -> sp.csr_matrix:
    indptr, indices = sparsity_pattern(mesh)
    # The pattern is symmetric and so are the values: CSC arrays are the CSR arrays. The
    # pattern is sorted and valid by construction. Each matrix gets its own copy of the index
    # arrays, so that in-place scipy operations on one cannot change another.
    A = sp.csr_matrix((data, indices.copy(), indptr.copy()), shape=(mesh.n_dofs, mesh.n_dofs), copy=False)
    A.has_sorted_indices = True
    return A


def element_materials(mesh: Mesh, material):
    """One material, or a dict ``{region name: material}`` covering every element."""
    if not isinstance(material, dict):
        return [material], None
    names = list(material)
    of = np.full(mesh.n_tets, -1, dtype=np.int64)
    for k, name in enumerate(names):
        if name not in mesh.regions:
            from .errors import MeshError

            raise MeshError(f"no region {name!r} in the mesh; it has {sorted(mesh.regions)}")
        of[mesh.regions[name]] = k
    if (of < 0).any():
        from .errors import MaterialError

        raise MaterialError(f"element {int(np.flatnonzero(of < 0)[0])} is in none of the regions {names}")
    return [material[n] for n in names], of


def stiffness(mesh: Mesh, material, points=None) -> sp.csr_matrix:
    """Linear elastic stiffness K (3n x 3n) of P1 tetrahedra.

    ``material``: one material, or ``{region: material}`` (body-cover layering).
    ``points``: another configuration to assemble on (default: the mesh's).

    >>> import vfrs
    >>> mesh = vfrs.meshes.box((1.0, 1.0, 1.0), (2, 2, 2))
    >>> K = vfrs.stiffness(mesh, vfrs.Isotropic(E=1.0, nu=0.3))
    >>> K.shape, abs(K - K.T).max() < 1e-14
    ((81, 81), True)
    """
    mats, of = element_materials(mesh, material)
    D = np.ascontiguousarray([m.elasticity() for m in mats], dtype=np.float64)
    pts = mesh.points if points is None else _configuration(mesh, points)
    return _csr(mesh, mesh.assembler().stiffness(pts, D, of))


def _configuration(mesh: Mesh, points) -> np.ndarray:
    """``points`` as another configuration of ``mesh``: same shape, finite, and no element
    inverted or flat there (K would not be positive definite: refused, naming the element)."""
    from .errors import MeshError

    pts = np.ascontiguousarray(points, dtype=np.float64)
    if pts.shape != mesh.points.shape:
        raise MeshError(f"points must have the mesh's shape {mesh.points.shape}, got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        k = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise MeshError(f"points: node {k} is at {pts[k].tolist()}; every coordinate must be finite")
    v = mesh.signed_volumes(pts)
    scale = float(np.abs(mesh.signed_volumes()).max()) if mesh.n_tets else 0.0
    bad = ~(v > 1e-12 * scale)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise MeshError(
            f"points: tetrahedron {k} (nodes {mesh.tets[k].tolist()}) has signed volume {v[k]:.6g} in this "
            f"configuration ({int(bad.sum())} of {mesh.n_tets} elements inverted or flat; must be > 0): the "
            "stiffness would not be positive definite. Assemble on a configuration without inverted elements "
            "(e.g. smaller displacements)"
        )
    return pts


def mass(mesh: Mesh, rho, lumped: bool = False) -> sp.csr_matrix:
    """Mass matrix M (3n x 3n): consistent, or row-sum lumped (diagonal).

    ``rho``: a density, a material (its ``rho``), or ``{region: material or density}``.
    """
    if isinstance(rho, dict):
        mats, of = element_materials(mesh, rho)
        values = [getattr(m, "rho", m) for m in mats]
    else:
        values, of = [getattr(rho, "rho", rho)], None
    dens = np.asarray(values, dtype=np.float64)
    a = mesh.assembler()
    if lumped:
        d = a.lumped_mass(mesh.points, dens, of)
        return sp.diags(d, format="csr")
    return _csr(mesh, a.mass(mesh.points, dens, of))
