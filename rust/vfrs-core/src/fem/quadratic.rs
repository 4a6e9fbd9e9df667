//! Assembly of P2 (ten-node) tetrahedra's stiffness and mass into a sparse CSC matrix with a
//! fixed pattern ([`crate::fem::pattern::Pattern`]), the element kernels of
//! [`crate::fem::tet10`] (issue 47). Nodes per element in VTK's order (vertices, then the
//! mid-edge nodes of edges 0-1, 1-2, 0-2, 0-3, 1-3, 2-3).

use crate::error::{Error, MaterialError, MeshError};
use crate::fem::material::Elasticity;
use crate::fem::pattern::Pattern;
use crate::fem::tet10::{lumped_mass, mass_column, stiffness_column, Inverted};

/// Fixed sparsity pattern of P2 tetrahedra and the kernels to fill it.
#[derive(Debug, Clone)]
pub struct QuadraticAssembler {
    pattern: Pattern,
    elems: Vec<[usize; 10]>,
}

impl QuadraticAssembler {
    /// Builds the pattern for `n_nodes` nodes (vertices and mid-edge nodes) and the given
    /// ten-node tetrahedra.
    pub fn new(n_nodes: usize, elems: &[[usize; 10]]) -> Result<Self, MeshError> {
        Ok(Self {
            pattern: Pattern::new(n_nodes, elems)?,
            elems: elems.to_vec(),
        })
    }

    /// Number of DOFs (3 per node).
    pub fn n_dofs(&self) -> usize {
        3 * self.pattern.n_nodes
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

    /// The ten-node tetrahedra the pattern was built from.
    pub fn tets(&self) -> &[[usize; 10]] {
        &self.elems
    }

    /// The pattern and its node-column fill (shared with the P2 finite-strain assembly).
    pub(crate) fn pattern(&self) -> &Pattern {
        &self.pattern
    }

    /// The element's ten node positions.
    fn coordinates(&self, points: &[[f64; 3]], e: usize) -> [[f64; 3]; 10] {
        let t = &self.elems[e];
        std::array::from_fn(|a| points[t[a]])
    }

    fn inverted(e: usize) -> impl Fn(Inverted) -> MeshError {
        move |i| MeshError::InvertedQuadratic {
            tet: e,
            point: i.point,
        }
    }

    /// Fills `values` (pattern order) with the stiffness matrix for the given points: one
    /// elasticity matrix, or one per material with `material_of[e]` naming each element's.
    pub fn stiffness_into(
        &self,
        points: &[[f64; 3]],
        d: &[Elasticity],
        material_of: Option<&[usize]>,
        values: &mut [f64],
    ) -> Result<(), Error> {
        self.pattern
            .check_inputs(points, d.len(), material_of, values)?;
        self.pattern
            .fill(&self.elems, values, |e, a| {
                let m = material_of.map_or(0, |m| m[e]);
                stiffness_column(&self.coordinates(points, e), &d[m], a).map_err(Self::inverted(e))
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
        self.pattern
            .fill(&self.elems, values, |e, a| {
                let r = rho[material_of.map_or(0, |m| m[e])];
                let col =
                    mass_column(&self.coordinates(points, e), r, a).map_err(Self::inverted(e))?;
                let mut out = [[[0.0; 3]; 3]; 10];
                for (blk, m) in out.iter_mut().zip(col) {
                    for (k, row) in blk.iter_mut().enumerate() {
                        row[k] = m;
                    }
                }
                Ok(out)
            })
            .map_err(Error::from)
    }

    /// The HRZ lumped mass ([`crate::fem::tet10::lumped_mass`]), one value per DOF (length
    /// `3 n`): positive, summing to the mass.
    pub fn lumped_mass(
        &self,
        points: &[[f64; 3]],
        rho: &[f64],
        material_of: Option<&[usize]>,
    ) -> Result<Vec<f64>, Error> {
        self.pattern.check_body(points, rho.len(), material_of)?;
        let mut out = vec![0.0; self.n_dofs()];
        for e in 0..self.elems.len() {
            let r = rho[material_of.map_or(0, |m| m[e])];
            if !(r > 0.0 && r.is_finite()) {
                return Err(MaterialError::NotPositive {
                    name: "rho",
                    value: r,
                }
                .into());
            }
            let m = lumped_mass(&self.coordinates(points, e), r).map_err(Self::inverted(e))?;
            for (&i, mi) in self.elems[e].iter().zip(m) {
                for c in 0..3 {
                    out[3 * i + c] += mi;
                }
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests;
