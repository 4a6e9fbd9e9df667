//! [`QuadraticFiniteStrainAssembler`]: the finite-strain (hyperelastic) assembly of ten-node
//! (P2) tetrahedra, on the linear P2 stiffness's pattern (its documentation says how).

use super::kernel::{
    check_inputs, check_len, deformation_gradient, stress_dot, tangent_block, tangent_dot,
    PointState, Want,
};
use super::{HyperelasticLaw, Mat3};
use crate::error::{HyperelasticError, MeshError};
use crate::fem::mesh::check_points;
use crate::fem::quadratic::QuadraticAssembler;
use crate::fem::tet10::{gradients_at, Rule, RULE_4};
use rayon::prelude::*;

/// Internal force, consistent tangent and strain energy of a hyperelastic body of ten-node
/// (P2) tetrahedra ([`crate::fem::tet10`], VTK's node order) in the total Lagrangian form, on
/// the fixed CSC pattern of the linear P2 stiffness ([`QuadraticAssembler`]).
///
/// The same calls, errors and two parallel, deterministic passes as the P1
/// [`super::FiniteStrainAssembler`] (see [`crate::hyperelastic`]), with the per-element
/// quantities replaced by per-quadrature-point ones:
///
/// ```text
/// F_q                 = I + sum_a u_a (x) g_a(q)                     (a = 0..10)
/// f_int[a, i]         = sum_q dV_q P_iJ(F_q) g_a(q)[J]
/// K_T[(b, i), (a, k)] = sum_q dV_q g_b(q)[J] A_iJkL(F_q) g_a(q)[L]
/// Pi                  = sum_e sum_q dV_q W(F_q)
/// ```
///
/// with `g_a(q)` the reference (undeformed) gradients of the shape functions at quadrature
/// point q and `dV_q = w_q det J_q / 6` its share of the element's reference volume, both
/// computed once in [`Self::new`].
///
/// Quadrature: [`RULE_4`] (degree 2, four points: the rule of the linear P2 stiffness). At
/// finite strain the integrand (`P(F)`, `F` linear in the reference coordinates on a straight
/// element) is not a polynomial, so no rule is exact; RULE_4 keeps the cost at four law
/// evaluations per element, makes `K_T(0)` equal the linear P2 stiffness
/// ([`QuadraticAssembler::stiffness_into`]) to round-off for the matching material, and
/// integrates a homogeneous deformation exactly on straight-sided elements (the patch test).
/// On curved elements (mid-edge nodes off the midpoints) it is not exact even for a
/// homogeneous deformation: a patch of curved elements leaves a small force at interior nodes,
/// as the linear P2 stiffness does (5e-4 of the largest nodal force with the mid-edge nodes
/// moved by 4 % of a cell; the degree-5 `RULE_14` passes it to round-off).
/// [`Self::with_rule`] takes another rule (e.g. [`crate::fem::tet10::RULE_14`]); at small
/// strain every rule of degree >= 2 gives the linear stiffness on straight elements.
///
/// An inverted reference element is [`MeshError::InvertedQuadratic`] (element and point); a
/// displacement under which `J <= 0` at some quadrature point is
/// [`HyperelasticError::Inverted`] naming the lowest such element (and that point's `J`), as
/// for P1. The scratch holds one state per quadrature point (`W`, `P`, `A`: ~740 bytes),
/// allocated once; a call allocates nothing.
#[derive(Debug, Clone)]
pub struct QuadraticFiniteStrainAssembler {
    asm: QuadraticAssembler,
    /// The quadrature rule (its points per element: `nq`).
    rule: Rule,
    /// Reference shape-function gradients at each quadrature point, element-major (`nq` per
    /// element).
    grads: Vec<[[f64; 3]; 10]>,
    /// The quadrature points' reference volumes `w_q det J_q / 6`, element-major.
    dv: Vec<f64>,
    /// Per-quadrature-point scratch (allocated once), element-major.
    state: Vec<PointState>,
}

impl QuadraticFiniteStrainAssembler {
    /// [`Self::with_rule`] with [`RULE_4`] (degree 2, the linear P2 stiffness's rule).
    pub fn new(points: &[[f64; 3]], tets: &[[usize; 10]]) -> Result<Self, HyperelasticError> {
        Self::with_rule(points, tets, RULE_4)
    }

    /// Validates the reference mesh (at least one element, finite points, valid indices, no
    /// node twice in an element, the Jacobian positive at every point of `rule`: else
    /// [`MeshError::InvertedQuadratic`] naming the element and the point) and builds the
    /// pattern, the reference gradients and the scratch.
    pub fn with_rule(
        points: &[[f64; 3]],
        tets: &[[usize; 10]],
        rule: Rule,
    ) -> Result<Self, HyperelasticError> {
        if tets.is_empty() {
            return Err(MeshError::Empty.into());
        }
        check_points(points)?;
        let asm = QuadraticAssembler::new(points.len(), tets)?;
        let nq = rule.points.len();
        let mut grads = Vec::with_capacity(nq * tets.len());
        let mut dv = Vec::with_capacity(nq * tets.len());
        for (e, t) in tets.iter().enumerate() {
            if let Some(a) = (1..10).find(|&a| t[..a].contains(&t[a])) {
                return Err(MeshError::RepeatedVertex {
                    tet: e,
                    index: t[a],
                }
                .into());
            }
            let x: [[f64; 3]; 10] = std::array::from_fn(|a| points[t[a]]);
            for (point, (l, w)) in rule.points.iter().zip(rule.weights).enumerate() {
                let (g, det) =
                    gradients_at(&x, l).ok_or(MeshError::InvertedQuadratic { tet: e, point })?;
                grads.push(g);
                dv.push(w * det / 6.0);
            }
        }
        Ok(Self {
            asm,
            rule,
            grads,
            dv,
            state: vec![PointState::default(); nq * tets.len()],
        })
    }

    /// The linear P2 assembler of the same mesh (its pattern is the pattern of `K_T`).
    pub fn assembler(&self) -> &QuadraticAssembler {
        &self.asm
    }

    /// The quadrature rule.
    pub fn rule(&self) -> Rule {
        self.rule
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
        self.asm.tets().len()
    }

    /// Quadrature points per element.
    fn nq(&self) -> usize {
        self.rule.points.len()
    }

    /// The element's quadrature points' states and reference volumes.
    fn points_of(&self, e: usize) -> Option<(&[PointState], &[f64])> {
        let nq = self.nq();
        let r = nq * e..nq * (e + 1);
        Some((self.state.get(r.clone())?, self.dv.get(r)?))
    }

    /// The first Piola-Kirchhoff stress of element `e` at the last successful evaluation:
    /// its mean over the element, `sum_q dV_q P_q / sum_q dV_q` (the rule's integral over the
    /// reference element over its volume; exact for a homogeneous deformation).
    pub fn last_stress(&self, e: usize) -> Option<Mat3> {
        let (s, dv) = self.points_of(e)?;
        let v: f64 = dv.iter().sum();
        let mut p = [[0.0; 3]; 3];
        for (sq, w) in s.iter().zip(dv) {
            for (pi, qi) in p.iter_mut().zip(&sq.p) {
                for (x, y) in pi.iter_mut().zip(qi) {
                    *x += w / v * y;
                }
            }
        }
        Some(p)
    }

    /// The volume ratio of element `e` at the last evaluation: the mean of `J` over the element,
    /// `sum_q dV_q J_q / sum_q dV_q` (its deformed volume over its reference volume, as the
    /// rule integrates them).
    pub fn last_volume_ratio(&self, e: usize) -> Option<f64> {
        let (s, dv) = self.points_of(e)?;
        let v: f64 = dv.iter().sum();
        Some(s.iter().zip(dv).map(|(sq, w)| w * sq.j).sum::<f64>() / v)
    }

    /// Pass 1: `F`, `J`, `W`, `P` (and `A`) at every quadrature point, in parallel over
    /// elements; then the first failure in element order (and point order within an element),
    /// so that the error does not depend on the thread count.
    fn evaluate<L: HyperelasticLaw>(
        &mut self,
        u: &[f64],
        laws: &[L],
        material_of: Option<&[usize]>,
        want: Want,
    ) -> Result<(), HyperelasticError> {
        check_inputs(self.n_dofs(), self.n_elements(), u, laws, material_of)?;
        let nq = self.nq();
        let tets = self.asm.tets();
        let grads = &self.grads;
        self.state
            .par_chunks_mut(nq)
            .enumerate()
            .for_each(|(e, states)| {
                let law = &laws[material_of.map_or(0, |m| m[e])];
                for (s, g) in states.iter_mut().zip(&grads[nq * e..nq * (e + 1)]) {
                    let f = deformation_gradient(&tets[e], g, u);
                    s.evaluate(law, &f, want);
                }
            });
        for (k, s) in self.state.iter().enumerate() {
            s.verdict(k / nq, want)?;
        }
        Ok(())
    }

    /// Total strain energy from the scratch, summed in element and point order.
    fn total_energy(&self) -> f64 {
        self.state.iter().zip(&self.dv).map(|(s, v)| s.w * v).sum()
    }

    /// Pass 2 for the force: each node's 3 entries by one task, elements in fixed order.
    fn scatter_force(&self, f: &mut [f64]) {
        let nq = self.nq();
        let pattern = self.asm.pattern();
        f.par_chunks_mut(3).enumerate().for_each(|(j, fj)| {
            let mut acc = [0.0; 3];
            for &(e, a) in pattern.elements_around(j) {
                let r = nq * e..nq * (e + 1);
                for ((s, g), v) in self.state[r.clone()]
                    .iter()
                    .zip(&self.grads[r.clone()])
                    .zip(&self.dv[r])
                {
                    let pg = stress_dot(&s.p, &g[a as usize]);
                    for (ac, x) in acc.iter_mut().zip(pg) {
                        *ac += v * x;
                    }
                }
            }
            fj.copy_from_slice(&acc);
        });
    }

    /// Pass 2 for the tangent, through the pattern's node-column driver: node column a of
    /// element e is `sum_q` of the point's blocks. A block that overflows is
    /// [`MeshError::NonFiniteElement`] (as in the P1 fill).
    fn fill_tangent(&self, values: &mut [f64]) -> Result<(), HyperelasticError> {
        let nq = self.nq();
        let tets = self.asm.tets();
        self.asm
            .pattern()
            .fill(tets, values, |e, a| {
                let r = nq * e..nq * (e + 1);
                let mut out = [[[0.0; 3]; 3]; 10];
                for ((s, g), &v) in self.state[r.clone()]
                    .iter()
                    .zip(&self.grads[r.clone()])
                    .zip(&self.dv[r.clone()])
                {
                    let t = tangent_dot(&s.a, &g[a]);
                    for (blk, gb) in out.iter_mut().zip(g) {
                        let add = tangent_block(&t, gb, v);
                        for (row, add_row) in blk.iter_mut().zip(add) {
                            for (x, y) in row.iter_mut().zip(add_row) {
                                *x += y;
                            }
                        }
                    }
                }
                if out.iter().flatten().flatten().all(|x| x.is_finite()) {
                    Ok(out)
                } else {
                    Err(MeshError::NonFiniteElement {
                        tet: e,
                        volume: self.dv[r].iter().sum(),
                    })
                }
            })
            .map_err(HyperelasticError::from)
    }

    entry_points!();
}

#[cfg(test)]
mod tests;
