//! [`FiniteStrainAssembler`]: internal force, consistent tangent and strain energy of a
//! hyperelastic P1 body on the linear stiffness's CSC pattern (see the parent module's
//! documentation for the two parallel passes).

use super::kernel::{
    check_inputs, check_len, deformation_gradient, stress_dot, tangent_block, tangent_dot,
    PointState, Want,
};
use super::{HyperelasticLaw, Mat3};
use crate::error::{HyperelasticError, MeshError};
use crate::fem::assembly::Assembler;
use crate::fem::element::gradients;
use crate::fem::mesh::TetMesh;
use rayon::prelude::*;

/// Internal force, consistent tangent and strain energy of a hyperelastic P1 body, on the
/// fixed CSC pattern of the linear stiffness. See the module documentation.
#[derive(Debug, Clone)]
pub struct FiniteStrainAssembler {
    asm: Assembler,
    /// Reference coordinates.
    points: Vec<[f64; 3]>,
    /// Reference shape-function gradients and volume of each element.
    grads: Vec<([[f64; 3]; 4], f64)>,
    /// Per-element scratch (allocated once).
    state: Vec<PointState>,
}

impl FiniteStrainAssembler {
    /// Validates the reference mesh ([`TetMesh::new`]: finite points, valid indices, positive
    /// volumes) and builds the pattern and the scratch.
    pub fn new(points: &[[f64; 3]], tets: &[[usize; 4]]) -> Result<Self, HyperelasticError> {
        TetMesh::new(points.to_vec(), tets.to_vec())?;
        let asm = Assembler::new(points.len(), tets)?;
        let grads = tets
            .iter()
            .enumerate()
            .map(|(e, t)| {
                gradients([&points[t[0]], &points[t[1]], &points[t[2]], &points[t[3]]]).ok_or(
                    MeshError::NonPositiveVolume {
                        tet: e,
                        volume: 0.0,
                    },
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            asm,
            points: points.to_vec(),
            grads,
            state: vec![PointState::default(); tets.len()],
        })
    }

    /// The linear assembler of the same mesh (its pattern is the pattern of `K_T`).
    pub fn assembler(&self) -> &Assembler {
        &self.asm
    }

    /// Number of DOFs (3 per node).
    pub fn n_dofs(&self) -> usize {
        self.asm.n_dofs()
    }

    /// Number of stored entries of the pattern.
    pub fn nnz(&self) -> usize {
        self.asm.nnz()
    }

    /// Number of elements.
    pub fn n_elements(&self) -> usize {
        self.grads.len()
    }

    /// The first Piola-Kirchhoff stress of element `e` at the last successful evaluation.
    pub fn last_stress(&self, e: usize) -> Option<Mat3> {
        self.state.get(e).map(|s| s.p)
    }

    /// The volume ratio J of element `e` at the last evaluation.
    pub fn last_volume_ratio(&self, e: usize) -> Option<f64> {
        self.state.get(e).map(|s| s.j)
    }

    /// Pass 1: per-element F, J, W, P (and A) in parallel; then the first failure in element
    /// order, so that the error does not depend on the thread count.
    fn evaluate<L: HyperelasticLaw>(
        &mut self,
        u: &[f64],
        laws: &[L],
        material_of: Option<&[usize]>,
        want: Want,
    ) -> Result<(), HyperelasticError> {
        check_inputs(self.n_dofs(), self.n_elements(), u, laws, material_of)?;
        let tets = self.asm.tets();
        let grads = &self.grads;
        self.state.par_iter_mut().enumerate().for_each(|(e, s)| {
            let f = deformation_gradient(&tets[e], &grads[e].0, u);
            s.evaluate(&laws[material_of.map_or(0, |m| m[e])], &f, want);
        });
        for (element, s) in self.state.iter().enumerate() {
            s.verdict(element, want)?;
        }
        Ok(())
    }

    /// Total strain energy from the scratch, summed in element order.
    fn total_energy(&self) -> f64 {
        self.state
            .iter()
            .zip(&self.grads)
            .map(|(s, (_, v))| s.w * v)
            .sum()
    }

    /// Pass 2 for the force: each node's 3 entries by one task, elements in fixed order.
    fn scatter_force(&self, f: &mut [f64]) {
        f.par_chunks_mut(3).enumerate().for_each(|(j, fj)| {
            let mut acc = [0.0; 3];
            for &(e, a) in self.asm.elements_around(j) {
                let (g, v) = &self.grads[e];
                let ga = &g[a as usize];
                let pg = stress_dot(&self.state[e].p, ga);
                for (ac, x) in acc.iter_mut().zip(pg) {
                    *ac += v * x;
                }
            }
            fj.copy_from_slice(&acc);
        });
    }

    /// Pass 2 for the tangent, through the linear assembler's node-column driver.
    fn fill_tangent(&self, values: &mut [f64]) -> Result<(), HyperelasticError> {
        let state = &self.state;
        self.asm
            .fill(&self.points, values, |e, g, v, a| {
                let t = tangent_dot(&state[e].a, &g[a]);
                let mut out = [[[0.0; 3]; 3]; 4];
                for (blk, gb) in out.iter_mut().zip(g) {
                    *blk = tangent_block(&t, gb, v);
                }
                out
            })
            .map_err(HyperelasticError::from)
    }

    entry_points!();
}
