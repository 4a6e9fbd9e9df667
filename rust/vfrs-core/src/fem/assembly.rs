//! Assembly of P1 stiffness and mass into a sparse CSC matrix with a fixed pattern
//! ([`crate::fem::pattern::Pattern`]: built once from the connectivity, filled in place in
//! parallel over node columns, no atomics, no per-call allocation; refilling with new
//! coefficients, another material or a deformed configuration, reuses everything).

use crate::error::{Error, MaterialError, MeshError};
use crate::fem::element::{gradients, mass_coefficient, stiffness_column};
use crate::fem::material::Elasticity;
use crate::fem::pattern::Pattern;

/// Fixed sparsity pattern ([`Pattern`]) of P1 tetrahedra and the element kernels to fill it.
#[derive(Debug, Clone)]
pub struct Assembler {
    pattern: Pattern,
    tets: Vec<[usize; 4]>,
}

impl Assembler {
    /// Builds the pattern for `n_nodes` nodes and the given tetrahedra (indices must be valid;
    /// [`crate::TetMesh::new`] checks them).
    pub fn new(n_nodes: usize, tets: &[[usize; 4]]) -> Result<Self, MeshError> {
        Ok(Self {
            pattern: Pattern::new(n_nodes, tets)?,
            tets: tets.to_vec(),
        })
    }

    /// Number of DOFs (3 per node).
    pub fn n_dofs(&self) -> usize {
        3 * self.pattern.n_nodes
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.pattern.n_nodes
    }

    /// The tetrahedra the pattern was built from.
    pub fn tets(&self) -> &[[usize; 4]] {
        &self.tets
    }

    /// The elements around node `j`, each with the node's local index (0..4) in it, in
    /// increasing element order.
    pub(crate) fn elements_around(&self, j: usize) -> &[(usize, u8)] {
        self.pattern.elements_around(j)
    }

    /// Number of stored entries of the pattern.
    pub fn nnz(&self) -> usize {
        self.pattern.nnz()
    }

    /// Column pointers of the CSC pattern (length `n_dofs + 1`).
    pub fn col_ptr(&self) -> &[usize] {
        &self.pattern.col_ptr
    }

    /// Row indices of the CSC pattern, sorted within each column.
    pub fn row_idx(&self) -> &[usize] {
        &self.pattern.row_idx
    }

    /// Shared driver: for every node column, visit the elements around it and add the
    /// 3x3 blocks returned by `block(e, grads, volume, a) -> [4 blocks]`.
    pub(crate) fn fill<F>(
        &self,
        points: &[[f64; 3]],
        values: &mut [f64],
        block: F,
    ) -> Result<(), MeshError>
    where
        F: Fn(usize, &[[f64; 3]; 4], f64, usize) -> [[[f64; 3]; 3]; 4] + Sync,
    {
        let tets = &self.tets;
        self.pattern.fill(tets, values, |e, a| {
            let t = &tets[e];
            let (g, v) = gradients([&points[t[0]], &points[t[1]], &points[t[2]], &points[t[3]]])
                .ok_or(MeshError::NonPositiveVolume {
                    tet: e,
                    volume: 0.0,
                })?;
            let blocks = block(e, &g, v, a);
            // Finite coordinates can still overflow (a sliver with coordinates near 1e300):
            // refuse the element rather than assemble inf or NaN.
            if !blocks.iter().flatten().flatten().all(|x| x.is_finite()) {
                return Err(MeshError::NonFiniteElement { tet: e, volume: v });
            }
            Ok(blocks)
        })
    }

    /// Fills `values` (pattern order) with the stiffness matrix for the given points.
    /// One elasticity matrix, or one per material with `material_of[e]` naming each
    /// element's material.
    pub fn stiffness_into(
        &self,
        points: &[[f64; 3]],
        d: &[Elasticity],
        material_of: Option<&[usize]>,
        values: &mut [f64],
    ) -> Result<(), Error> {
        self.pattern
            .check_inputs(points, d.len(), material_of, values)?;
        self.fill(points, values, |e, g, v, a| {
            let m = material_of.map_or(0, |m| m[e]);
            stiffness_column(g, v, &d[m], a)
        })
        .map_err(Error::from)
    }

    /// Fills `values` with the consistent mass matrix (density per material).
    pub fn mass_into(
        &self,
        points: &[[f64; 3]],
        rho: &[f64],
        material_of: Option<&[usize]>,
        values: &mut [f64],
    ) -> Result<(), Error> {
        self.pattern
            .check_densities(points, rho, material_of, values)?;
        self.fill(points, values, |e, _g, v, a| {
            let r = rho[material_of.map_or(0, |m| m[e])];
            let mut out = [[[0.0; 3]; 3]; 4];
            for (b, blk) in out.iter_mut().enumerate() {
                let m = mass_coefficient(r, v, a, b);
                for (k, row) in blk.iter_mut().enumerate() {
                    row[k] = m;
                }
            }
            out
        })
        .map_err(Error::from)
    }

    /// Row-sum lumped mass, one value per DOF (length `3 n`).
    pub fn lumped_mass(
        &self,
        points: &[[f64; 3]],
        rho: &[f64],
        material_of: Option<&[usize]>,
    ) -> Result<Vec<f64>, MaterialError> {
        self.pattern.check_body(points, rho.len(), material_of)?;
        let mut out = vec![0.0; self.n_dofs()];
        for (e, t) in self.tets.iter().enumerate() {
            let r = rho[material_of.map_or(0, |m| m[e])];
            if !(r > 0.0 && r.is_finite()) {
                return Err(MaterialError::NotPositive {
                    name: "rho",
                    value: r,
                });
            }
            let v = crate::fem::mesh::signed_volume(
                &points[t[0]],
                &points[t[1]],
                &points[t[2]],
                &points[t[3]],
            );
            for &i in t {
                for c in 0..3 {
                    out[3 * i + c] += r * v / 4.0;
                }
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::material::Material;

    use crate::fem::test_support::cube;

    fn dense(a: &Assembler, v: &[f64]) -> Vec<Vec<f64>> {
        let n = a.n_dofs();
        let mut m = vec![vec![0.0; n]; n];
        for (j, w) in a.col_ptr().windows(2).enumerate() {
            for (&i, &x) in a.row_idx()[w[0]..w[1]].iter().zip(&v[w[0]..w[1]]) {
                m[i][j] += x;
            }
        }
        m
    }

    #[test]
    fn stiffness_is_symmetric_and_kills_rigid_motions() {
        let (p, t) = cube();
        let a = Assembler::new(p.len(), &t).unwrap();
        let d = Material::Isotropic { e: 3.0, nu: 0.3 }
            .elasticity()
            .unwrap();
        let mut v = vec![0.0; a.nnz()];
        a.stiffness_into(&p, &[d], None, &mut v).unwrap();
        let k = dense(&a, &v);
        for (i, row) in k.iter().enumerate() {
            for (j, &kij) in row.iter().enumerate() {
                assert!((kij - k[j][i]).abs() < 1e-13);
            }
        }
        // Rotation about z: u = (-y, x, 0).
        let u: Vec<f64> = p.iter().flat_map(|x| [-x[1], x[0], 0.0]).collect();
        for row in &k {
            let f: f64 = row.iter().zip(&u).map(|(a, b)| a * b).sum();
            assert!(f.abs() < 1e-12);
        }
    }

    #[test]
    fn mass_sums_to_rho_volume() {
        let (p, t) = cube();
        let a = Assembler::new(p.len(), &t).unwrap();
        let mut v = vec![0.0; a.nnz()];
        a.mass_into(&p, &[2.5], None, &mut v).unwrap();
        let total: f64 = v.iter().sum();
        assert!((total - 3.0 * 2.5).abs() < 1e-12);
        let l = a.lumped_mass(&p, &[2.5], None).unwrap();
        assert!((l.iter().sum::<f64>() - 3.0 * 2.5).abs() < 1e-12);
        assert!(a.mass_into(&p, &[-1.0], None, &mut v).is_err());
        assert!(a
            .mass_into(&p, &[1.0, 2.0], Some(&[0, 0, 0, 0, 0, 5]), &mut v)
            .is_err());
    }
}
