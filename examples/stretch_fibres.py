"""Stretching vocal-fold cover tissue along its fibres: a static check with a closed form.

A 3 x 3 x 14 mm block of transversely isotropic tissue (fibres along z, anterior-posterior)
is held on its posterior face (z = 0, sliding) and pulled by a uniform traction on its
anterior face, as the cricothyroid muscle elongates the folds. The stress is uniform, so
linear tetrahedra must reproduce the exact answer: elongation t L / E_z and lateral strain
-nu_pz t / E_p. Run it to write ``out/stretch_fibres.vtu`` for ParaView:

    python examples/stretch_fibres.py
"""

from pathlib import Path

import numpy as np

import vfrs

L_XY, L_Z = 3e-3, 14e-3
TRACTION = 1e3  # Pa, along +z on the anterior face
tissue = vfrs.TransverselyIsotropic(E_p=2e3, E_z=40e3, nu_p=0.9, nu_pz=0.02, G_pz=10e3, rho=1070)

mesh = vfrs.meshes.box((L_XY, L_XY, L_Z), (3, 3, 10), jitter=0.2, seed=7)
K = vfrs.stiffness(mesh, tissue)

# Minimal supports: u_z = 0 on z = 0; the corner at the origin fixed in x and y; the
# corner at (L, 0, 0) fixed in y (no spin about z). Everything else is free to contract.
back = mesh.surface_nodes("zmin")
origin = int(np.argmin(np.linalg.norm(mesh.points, axis=1)))
corner = int(np.argmin(np.linalg.norm(mesh.points - [L_XY, 0, 0], axis=1)))
fixed = np.r_[3 * back + 2, 3 * origin, 3 * origin + 1, 3 * corner + 1]
dofs = vfrs.DofMap(mesh.n_dofs, fixed)

# Consistent nodal forces of a uniform traction: a third of each triangle's force per vertex.
f = np.zeros(mesh.n_dofs)
tri = mesh.surface("zmax")
x = mesh.points[tri]
area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
np.add.at(f, 3 * tri.ravel() + 2, np.repeat(TRACTION * area / 3, 3))

u = dofs.expand(vfrs.cholesky(dofs.reduce(K)).solve(dofs.restrict(f)))
U = u.reshape(-1, 3)

front = mesh.surface_nodes("zmax")
elongation = U[front, 2].mean()
elongation_exact = TRACTION * L_Z / tissue.E_z
lateral_strain = (U[:, 0] / np.where(mesh.points[:, 0] > 0, mesh.points[:, 0], np.nan))
lateral_strain = np.nanmean(lateral_strain)
lateral_strain_exact = -tissue.nu_pz * TRACTION / tissue.E_p

if __name__ == "__main__":
    out = Path("out")
    out.mkdir(exist_ok=True)
    mesh.write(out / "stretch_fibres.vtu", point_data={"displacement": U})
    print(f"mesh: {mesh.n_points} nodes, {mesh.n_tets} tets")
    print(f"elongation     {elongation * 1e3:.6f} mm   exact {elongation_exact * 1e3:.6f} mm")
    print(f"lateral strain {lateral_strain:.6e}   exact {lateral_strain_exact:.6e}")
    print(f"wrote {out / 'stretch_fibres.vtu'}")
