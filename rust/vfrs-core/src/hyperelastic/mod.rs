//! Finite strain: hyperelastic P1 and P2 tetrahedra in the total Lagrangian form (issue 14, the
//! Rust groundwork; the Newton step that uses it lives on the Python side).
//!
//! Kinematics. On the reference configuration X (the mesh as given), an element's
//! deformation gradient is constant: `F = I + grad u = I + sum_a u_a (x) g_a`, with `g_a` the
//! reference shape-function gradients of [`crate::fem::element::gradients`] (the same helper the
//! linear assembly uses). `J = det F` must stay positive.
//!
//! Balance. With the first Piola-Kirchhoff stress `P = dW/dF` and the tangent
//! `A_iJkL = dP_iJ / dF_kL` of a [`HyperelasticLaw`], an element of reference volume `V`
//! contributes
//!
//! ```text
//! f_int[a, i]       = V P_iJ g_a[J]                      (internal force, node a, axis i)
//! K_T[(b, i), (a, k)] = V g_b[J] A_iJkL g_a[L]            (consistent tangent, symmetric)
//! Pi                = sum_e V_e W(F_e)                   (strain energy)
//! ```
//!
//! The residual of a static step is `f_int(u) - f_ext`; `K_T = d f_int / d u`.
//!
//! Assembly. [`FiniteStrainAssembler`] owns an [`Assembler`] built from the same connectivity,
//! so `K_T` is written into exactly the linear stiffness's CSC pattern (`col_ptr`, `row_idx`;
//! symmetric, so also CSR) and a factorization's symbolic analysis can be reused. A call makes
//! two parallel passes, both deterministic (bit-identical for any number of threads):
//! 1. over elements: `F`, `J`, `W`, `P` and (when asked) `A` of each element into a per-element
//!    scratch allocated once in [`FiniteStrainAssembler::new`];
//! 2. over node columns, exactly as [`Assembler`] does for the linear stiffness: each node
//!    column of `K_T` (and each node's 3 entries of `f_int`) is written by one task that visits
//!    the elements around the node in a fixed order.
//!
//! The energy is then summed sequentially over elements. No allocation per call.
//!
//! Errors are typed ([`HyperelasticError`]): an inverted element (the lowest element index
//! with `J <= 0`, and its `J`), a non-finite displacement (its DOF), a non-finite stress
//! (overflow), wrong array lengths and material indices; bad input never panics.
//!
//! Ten-node (P2) tetrahedra: [`QuadraticFiniteStrainAssembler`], the same calls and errors on
//! the linear P2 stiffness's pattern, with `F`, `W`, `P` and `A` at the four points of the
//! degree-2 rule of each element instead of once per element (see its documentation). The input
//! checks, the law's evaluation at a point and the products with the shape-function gradients
//! are shared by the two assemblers (`kernel.rs`).

/// The public calls of a finite-strain assembler (energy, internal force, tangent, both),
/// written once for the P1 and the P2 one: each has `evaluate`, `scatter_force`,
/// `fill_tangent`, `total_energy`, `n_dofs` and `nnz`, and imports `check_len` and `Want`.
macro_rules! entry_points {
    () => {
        /// The total strain energy at displacement `u` (length `3 n`, node-major).
        pub fn energy<L: HyperelasticLaw>(
            &mut self,
            u: &[f64],
            laws: &[L],
            material_of: Option<&[usize]>,
        ) -> Result<f64, HyperelasticError> {
            self.evaluate(u, laws, material_of, Want::Stress)?;
            Ok(self.total_energy())
        }

        /// Writes the internal force `f_int(u)` into `force` (length `3 n`); returns the total
        /// strain energy. One law, or one per material with `material_of[e]` naming each
        /// element's law (as in the linear assembly's `stiffness_into`).
        pub fn internal_force<L: HyperelasticLaw>(
            &mut self,
            u: &[f64],
            laws: &[L],
            material_of: Option<&[usize]>,
            force: &mut [f64],
        ) -> Result<f64, HyperelasticError> {
            check_len("force", self.n_dofs(), force.len())?;
            self.evaluate(u, laws, material_of, Want::Stress)?;
            self.scatter_force(force);
            Ok(self.total_energy())
        }

        /// Writes the consistent tangent `K_T(u) = d f_int / d u` into `values`, in the order
        /// of the pattern (`self.assembler().col_ptr()`, `row_idx()`).
        pub fn tangent_into<L: HyperelasticLaw>(
            &mut self,
            u: &[f64],
            laws: &[L],
            material_of: Option<&[usize]>,
            values: &mut [f64],
        ) -> Result<(), HyperelasticError> {
            check_len("values", self.nnz(), values.len())?;
            self.evaluate(u, laws, material_of, Want::Tangent)?;
            self.fill_tangent(values)
        }

        /// Internal force, tangent and energy in one evaluation (what a Newton iteration needs).
        pub fn force_and_tangent<L: HyperelasticLaw>(
            &mut self,
            u: &[f64],
            laws: &[L],
            material_of: Option<&[usize]>,
            force: &mut [f64],
            values: &mut [f64],
        ) -> Result<f64, HyperelasticError> {
            check_len("force", self.n_dofs(), force.len())?;
            check_len("values", self.nnz(), values.len())?;
            self.evaluate(u, laws, material_of, Want::Tangent)?;
            self.scatter_force(force);
            self.fill_tangent(values)?;
            Ok(self.total_energy())
        }
    };
}

mod assembler;
pub mod error;
mod kernel;
mod laws;
mod quadratic;

pub use assembler::FiniteStrainAssembler;
pub use laws::{FibreReinforced, HyperelasticMaterial, NeoHookean, StVenantKirchhoff};
pub use quadratic::QuadraticFiniteStrainAssembler;

use crate::error::MaterialError;
#[cfg(doc)]
use crate::{error::HyperelasticError, fem::assembly::Assembler};

/// A 3x3 matrix, row-major: `m[i][J]`.
pub type Mat3 = [[f64; 3]; 3];

/// A material tangent `A_iJkL = dP_iJ / dF_kL`, stored as `a[3 i + J][3 k + L]`.
pub type Tangent = [[f64; 9]; 9];

const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Voigt index of the symmetric pair (i, j): order `[xx, yy, zz, yz, xz, xy]`.
const VOIGT: [[usize; 3]; 3] = [[0, 5, 4], [5, 1, 3], [4, 3, 2]];

/// Determinant of a 3x3 matrix.
#[inline]
pub fn det3(m: &Mat3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Inverse of a 3x3 matrix of determinant `det` (non-zero).
#[inline]
fn inv3(m: &Mat3, det: f64) -> Mat3 {
    let d = 1.0 / det;
    [
        [
            (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * d,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * d,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * d,
        ],
        [
            (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * d,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * d,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * d,
        ],
        [
            (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * d,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * d,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * d,
        ],
    ]
}

fn positive(name: &'static str, value: f64) -> Result<(), MaterialError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(MaterialError::NotPositive { name, value })
    }
}

/// A hyperelastic material: a strain energy density `W(F)` per unit reference volume, its
/// first Piola-Kirchhoff stress `P = dW/dF` and the material tangent `A = dP/dF`.
///
/// The functions are called with `det F > 0` only (the assembler checks `J` first).
pub trait HyperelasticLaw: Sync {
    /// Checks the parameters.
    fn validate(&self) -> Result<(), MaterialError>;
    /// Strain energy density W(F), J/m^3.
    fn energy(&self, f: &Mat3) -> f64;
    /// First Piola-Kirchhoff stress P(F), Pa.
    fn stress(&self, f: &Mat3) -> Mat3;
    /// Material tangent `A_iJkL = dP_iJ / dF_kL`, Pa.
    fn tangent(&self, f: &Mat3) -> Tangent;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::material::Material;

    fn laws() -> Vec<HyperelasticMaterial> {
        let nh = NeoHookean::from_young(10e3, 0.3).unwrap();
        vec![
            HyperelasticMaterial::NeoHookean(nh),
            HyperelasticMaterial::StVenantKirchhoff(
                StVenantKirchhoff::from_material(&Material::TransverselyIsotropic {
                    e_p: 2e3,
                    e_z: 40e3,
                    nu_p: 0.9,
                    nu_pz: 0.0,
                    g_pz: 10e3,
                    axis: [0.0, 0.0, 1.0],
                })
                .unwrap(),
            ),
            HyperelasticMaterial::FibreReinforced(
                FibreReinforced::new(nh, 9.5e3, 3.0, [0.2, -0.1, 1.0]).unwrap(),
            ),
        ]
    }

    /// The stress is the derivative of the energy and the tangent that of the stress, at a
    /// pointwise level (central differences), for every law.
    #[test]
    fn stress_and_tangent_are_derivatives_pointwise() {
        let f0 = [[1.1, 0.05, -0.02], [0.03, 0.92, 0.07], [-0.04, 0.06, 1.3]];
        let h = 1e-6;
        for law in laws() {
            let p = law.stress(&f0);
            let a = law.tangent(&f0);
            let scale = a.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
            for k in 0..3 {
                for l in 0..3 {
                    let mut fp = f0;
                    let mut fm = f0;
                    fp[k][l] += h;
                    fm[k][l] -= h;
                    let dw = (law.energy(&fp) - law.energy(&fm)) / (2.0 * h);
                    assert!((dw - p[k][l]).abs() < 1e-6 * scale, "{law:?} P[{k}][{l}]");
                    let (pp, pm) = (law.stress(&fp), law.stress(&fm));
                    for i in 0..3 {
                        for j in 0..3 {
                            let d = (pp[i][j] - pm[i][j]) / (2.0 * h);
                            assert!(
                                (d - a[3 * i + j][3 * k + l]).abs() < 1e-6 * scale,
                                "{law:?} A[{i}{j}][{k}{l}]"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(NeoHookean::from_young(-1.0, 0.3).is_err());
        assert!(NeoHookean {
            mu: 1.0,
            lambda: -1.0
        }
        .validate()
        .is_err());
        let nh = NeoHookean::from_young(1.0, 0.3).unwrap();
        assert!(FibreReinforced::new(nh, 1.0, 0.0, [0.0, 0.0, 1.0]).is_err());
        assert!(FibreReinforced::new(nh, -1.0, 1.0, [0.0, 0.0, 1.0]).is_err());
        assert!(matches!(
            FibreReinforced::new(nh, 1.0, 1.0, [0.0; 3]),
            Err(MaterialError::BadAxis { .. })
        ));
        let mut d = [[0.0; 6]; 6];
        d[0][0] = 1.0;
        assert!(StVenantKirchhoff { d }.validate().is_err());
        d[0][1] = 1.0;
        assert!(StVenantKirchhoff { d }.validate().is_err());
    }
}
