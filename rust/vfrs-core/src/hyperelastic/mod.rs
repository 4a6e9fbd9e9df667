//! Finite strain: hyperelastic P1 tetrahedra in the total Lagrangian form (issue 14, the Rust
//! groundwork; the Newton step that uses it lives on the Python side).
//!
//! Kinematics. On the reference configuration X (the mesh as given), an element's
//! deformation gradient is constant: `F = I + grad u = I + sum_a u_a (x) g_a`, with `g_a` the
//! reference shape-function gradients of [`crate::element::gradients`] (the same helper the
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

use crate::assembly::Assembler;
use crate::element::gradients;
use crate::error::{HyperelasticError, MaterialError, MeshError};
use crate::material::{Elasticity, Material};
use crate::mesh::TetMesh;
use rayon::prelude::*;

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

/// Compressible neo-Hookean, isotropic:
///
/// ```text
/// W = mu/2 (I1 - 3) - mu ln J + lambda/2 (ln J)^2,   I1 = tr(F^T F)
/// P = mu (F - F^-T) + lambda ln J F^-T
/// A_iJkL = mu d_ik d_JL + (mu - lambda ln J) Finv_Jk Finv_Li + lambda Finv_Ji Finv_Lk
/// ```
///
/// (the compressible neo-Hookean of Bonet & Wood, *Nonlinear Continuum Mechanics for Finite
/// Element Analysis*, 2nd ed., chapter 6; FEBio's "neo-Hookean"). At `F = I` the tangent is the isotropic linear
/// elasticity tensor with Lame constants `lambda` and `mu`: the small-strain limit has
/// `E = mu (3 lambda + 2 mu) / (lambda + mu)` and `nu = lambda / (2 (lambda + mu))`
/// ([`NeoHookean::from_young`] inverts this).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeoHookean {
    /// Shear modulus mu, Pa.
    pub mu: f64,
    /// First Lame constant lambda, Pa.
    pub lambda: f64,
}

impl NeoHookean {
    /// The neo-Hookean law whose small-strain limit is the isotropic material (E, nu).
    pub fn from_young(e: f64, nu: f64) -> Result<Self, MaterialError> {
        Material::Isotropic { e, nu }.validate()?;
        Ok(Self {
            mu: e / (2.0 * (1.0 + nu)),
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        })
    }
}

impl HyperelasticLaw for NeoHookean {
    fn validate(&self) -> Result<(), MaterialError> {
        positive("mu", self.mu)?;
        let bulk = self.lambda + 2.0 * self.mu / 3.0;
        if !(self.lambda.is_finite() && bulk > 0.0) {
            return Err(MaterialError::OutOfRange {
                name: "lambda",
                value: self.lambda,
                reason: "must be finite with a positive bulk modulus lambda + 2 mu / 3".into(),
            });
        }
        Ok(())
    }

    fn energy(&self, f: &Mat3) -> f64 {
        let i1: f64 = f.iter().flatten().map(|x| x * x).sum();
        let lnj = det3(f).ln();
        0.5 * self.mu * (i1 - 3.0) - self.mu * lnj + 0.5 * self.lambda * lnj * lnj
    }

    fn stress(&self, f: &Mat3) -> Mat3 {
        let j = det3(f);
        let fi = inv3(f, j);
        let c = self.lambda * j.ln() - self.mu;
        let mut p = [[0.0; 3]; 3];
        for i in 0..3 {
            for jj in 0..3 {
                p[i][jj] = self.mu * f[i][jj] + c * fi[jj][i];
            }
        }
        p
    }

    fn tangent(&self, f: &Mat3) -> Tangent {
        let j = det3(f);
        let fi = inv3(f, j);
        let c = self.mu - self.lambda * j.ln();
        let mut a = [[0.0; 9]; 9];
        for i in 0..3 {
            for jj in 0..3 {
                for k in 0..3 {
                    for l in 0..3 {
                        let mut v = c * fi[jj][k] * fi[l][i] + self.lambda * fi[jj][i] * fi[l][k];
                        if i == k && jj == l {
                            v += self.mu;
                        }
                        a[3 * i + jj][3 * k + l] = v;
                    }
                }
            }
        }
        a
    }
}

/// St Venant-Kirchhoff with any (anisotropic) elasticity tensor: the linear material's
/// stress-strain law applied to the Green-Lagrange strain `E = (F^T F - I) / 2`:
///
/// ```text
/// S = D : E (Voigt, engineering shear strains),  W = E : D : E / 2,  P = F S
/// A_iJkL = d_ik S_JL + F_iI C_IJLN F_kN
/// ```
///
/// Build it from the project's linear materials with [`StVenantKirchhoff::from_material`]
/// (the transversely isotropic `vocal_fold` tissue keeps its constants and gains exact large
/// rotations). At `F = I` the tangent is `D` exactly. SVK is not polyconvex and softens in
/// strong compression (its stress vanishes as J -> 0): fine for large rotations with
/// moderate strains, not for crushing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StVenantKirchhoff {
    /// The 6x6 elasticity matrix (Voigt `[xx, yy, zz, yz, xz, xy]`), Pa.
    pub d: Elasticity,
}

impl StVenantKirchhoff {
    /// SVK with the elasticity matrix of a linear material (validated).
    pub fn from_material(m: &Material) -> Result<Self, MaterialError> {
        Ok(Self { d: m.elasticity()? })
    }

    /// Green-Lagrange strain in Voigt form with engineering shears, and the 2nd PK stress S.
    #[inline]
    fn strain_stress(&self, f: &Mat3) -> ([f64; 6], Mat3) {
        let mut c = [[0.0; 3]; 3];
        for (i, ci) in c.iter_mut().enumerate() {
            for (j, cij) in ci.iter_mut().enumerate() {
                *cij = (0..3).map(|k| f[k][i] * f[k][j]).sum();
            }
        }
        let e = [
            0.5 * (c[0][0] - 1.0),
            0.5 * (c[1][1] - 1.0),
            0.5 * (c[2][2] - 1.0),
            c[1][2],
            c[0][2],
            c[0][1],
        ];
        let mut s6 = [0.0; 6];
        for (r, s) in s6.iter_mut().enumerate() {
            *s = (0..6).map(|q| self.d[r][q] * e[q]).sum();
        }
        let mut s = [[0.0; 3]; 3];
        for (i, si) in s.iter_mut().enumerate() {
            for (j, sij) in si.iter_mut().enumerate() {
                *sij = s6[VOIGT[i][j]];
            }
        }
        (e, s)
    }
}

impl HyperelasticLaw for StVenantKirchhoff {
    fn validate(&self) -> Result<(), MaterialError> {
        let scale = self.d.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        if !scale.is_finite() || scale == 0.0 {
            return Err(MaterialError::NotPositiveDefinite {
                reason: "the elasticity matrix is zero or has a non-finite entry".into(),
            });
        }
        for i in 0..6 {
            for j in 0..i {
                if (self.d[i][j] - self.d[j][i]).abs() > 1e-12 * scale {
                    return Err(MaterialError::NotPositiveDefinite {
                        reason: format!(
                            "the elasticity matrix is not symmetric: D[{i}][{j}] = {:e}, D[{j}][{i}] = {:e}",
                            self.d[i][j], self.d[j][i]
                        ),
                    });
                }
            }
        }
        // Cholesky of the 6x6: positive definite or not.
        let mut l = [[0.0f64; 6]; 6];
        for i in 0..6 {
            for j in 0..=i {
                let s: f64 = self.d[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
                if i == j {
                    if s.partial_cmp(&(1e-14 * scale)) != Some(std::cmp::Ordering::Greater) {
                        return Err(MaterialError::NotPositiveDefinite {
                            reason: format!(
                                "the elasticity matrix is not positive definite (pivot {i})"
                            ),
                        });
                    }
                    l[i][i] = s.sqrt();
                } else {
                    l[i][j] = s / l[j][j];
                }
            }
        }
        Ok(())
    }

    fn energy(&self, f: &Mat3) -> f64 {
        let (e, _) = self.strain_stress(f);
        let mut w = 0.0;
        for r in 0..6 {
            for q in 0..6 {
                w += e[r] * self.d[r][q] * e[q];
            }
        }
        0.5 * w
    }

    fn stress(&self, f: &Mat3) -> Mat3 {
        let (_, s) = self.strain_stress(f);
        let mut p = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                p[i][j] = (0..3).map(|k| f[i][k] * s[k][j]).sum();
            }
        }
        p
    }

    fn tangent(&self, f: &Mat3) -> Tangent {
        let (_, s) = self.strain_stress(f);
        let c = |i: usize, j: usize, k: usize, l: usize| self.d[VOIGT[i][j]][VOIGT[k][l]];
        // G[i][J][L][N] contracted step by step: T_iJLN = F_iI C_IJLN.
        let mut t = [[[[0.0; 3]; 3]; 3]; 3];
        for (i, ti) in t.iter_mut().enumerate() {
            for (jj, tij) in ti.iter_mut().enumerate() {
                for (l, tijl) in tij.iter_mut().enumerate() {
                    for (n, v) in tijl.iter_mut().enumerate() {
                        *v = (0..3).map(|ii| f[i][ii] * c(ii, jj, l, n)).sum();
                    }
                }
            }
        }
        let mut a = [[0.0; 9]; 9];
        for i in 0..3 {
            for jj in 0..3 {
                for k in 0..3 {
                    for l in 0..3 {
                        let mut v: f64 = (0..3).map(|n| t[i][jj][l][n] * f[k][n]).sum();
                        if i == k {
                            v += s[jj][l];
                        }
                        a[3 * i + jj][3 * k + l] = v;
                    }
                }
            }
        }
        a
    }
}

/// Transversely isotropic hyperelastic law: a compressible neo-Hookean matrix plus one family
/// of fibres along the unit reference axis `a0` that resist stretch only:
///
/// ```text
/// W = W_NH(F) + W_f(I4),   I4 = a0 . C a0 = |F a0|^2 (squared fibre stretch)
/// W_f = k1 / (2 k2) (exp(k2 (I4 - 1)^2) - 1)   for I4 > 1,   0 otherwise
/// P_f = 2 W_f' (F a0) (x) a0
/// A_f = 2 W_f' d_ik a0_J a0_L + 4 W_f'' (F a0)_i a0_J (F a0)_k a0_L
/// ```
///
/// The fibre term is the one of Holzapfel, Gasser & Ogden (2000), "A new constitutive
/// framework for arterial wall mechanics and a comparative study of material models",
/// J. Elasticity 61:1-48 (here on the full invariant I4, not its isochoric part,
/// as FEBio's `fiber-exp-pow` with beta = 2, xi = k1, alpha = k2). Fibres in compression
/// (I4 <= 1) carry nothing, so the tangent jumps at I4 = 1 (by 4 k1 along the fibre).
///
/// Vocal folds: the fibres of the lamina propria and the vocalis run anterior-posterior,
/// so `axis = z` in the project's axes. A user sets the matrix (`mu`, `lambda`, or E, nu of
/// the transverse tissue, e.g. the `vocal_fold` tissue's E_p = 2 kPa), `k1` (Pa) and `k2`
/// (dimensionless). For small fibre stretch the fibre adds `4 k1` to the axial modulus, so
/// `k1 ~ (E_z - E_p) / 4` matches the linear tissue's fibre modulus (E_z = 40 kPa:
/// k1 ~ 9.5 kPa); `k2` sets the exponential stiffening and must be fitted to a tensile
/// stress-stretch curve of the layer that is modelled (the lamina propria's tensile response
/// stiffens strongly with stretch: Zhang, Siegmund & Chan 2006, "A constitutive model of the
/// human vocal fold cover for fundamental frequency regulation", JASA 119:1050-1062;
/// anisotropy ratios E_L/E_T of 14-39 in Kelleher et al. 2013, "Empirical measurements of
/// biomechanical anisotropy of the human vocal fold lamina propria", Biomech. Model.
/// Mechanobiol. 12:555-567). No default k2 is adopted here: that is the scene's choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FibreReinforced {
    /// The isotropic matrix.
    pub matrix: NeoHookean,
    /// Fibre stiffness k1, Pa (>= 0).
    pub k1: f64,
    /// Fibre exponential coefficient k2 (> 0, dimensionless).
    pub k2: f64,
    /// Unit fibre axis a0 in the reference configuration.
    axis: [f64; 3],
}

impl FibreReinforced {
    /// The law; `axis` need not be unit length (it is normalised).
    pub fn new(
        matrix: NeoHookean,
        k1: f64,
        k2: f64,
        axis: [f64; 3],
    ) -> Result<Self, MaterialError> {
        let n2 = axis.iter().map(|x| x * x).sum::<f64>();
        if !(n2 > 0.0 && n2.is_finite()) {
            return Err(MaterialError::BadAxis { axis });
        }
        let n = n2.sqrt();
        let law = Self {
            matrix,
            k1,
            k2,
            axis: [axis[0] / n, axis[1] / n, axis[2] / n],
        };
        law.validate()?;
        Ok(law)
    }

    /// The unit fibre axis.
    pub fn axis(&self) -> [f64; 3] {
        self.axis
    }

    /// F a0 and I4 = |F a0|^2.
    #[inline]
    fn fibre(&self, f: &Mat3) -> ([f64; 3], f64) {
        let a = &self.axis;
        let fa = [
            f[0][0] * a[0] + f[0][1] * a[1] + f[0][2] * a[2],
            f[1][0] * a[0] + f[1][1] * a[1] + f[1][2] * a[2],
            f[2][0] * a[0] + f[2][1] * a[1] + f[2][2] * a[2],
        ];
        (fa, fa[0] * fa[0] + fa[1] * fa[1] + fa[2] * fa[2])
    }
}

impl HyperelasticLaw for FibreReinforced {
    fn validate(&self) -> Result<(), MaterialError> {
        self.matrix.validate()?;
        if !(self.k1 >= 0.0 && self.k1.is_finite()) {
            return Err(MaterialError::OutOfRange {
                name: "k1",
                value: self.k1,
                reason: "the fibre stiffness must be finite and >= 0".into(),
            });
        }
        positive("k2", self.k2)
    }

    fn energy(&self, f: &Mat3) -> f64 {
        let (_, i4) = self.fibre(f);
        let wf = if i4 > 1.0 {
            let d = i4 - 1.0;
            self.k1 / (2.0 * self.k2) * (self.k2 * d * d).exp_m1()
        } else {
            0.0
        };
        self.matrix.energy(f) + wf
    }

    fn stress(&self, f: &Mat3) -> Mat3 {
        let mut p = self.matrix.stress(f);
        let (fa, i4) = self.fibre(f);
        if i4 > 1.0 {
            let d = i4 - 1.0;
            let w1 = self.k1 * d * (self.k2 * d * d).exp();
            for (pi, fai) in p.iter_mut().zip(fa) {
                for (pij, aj) in pi.iter_mut().zip(self.axis) {
                    *pij += 2.0 * w1 * fai * aj;
                }
            }
        }
        p
    }

    fn tangent(&self, f: &Mat3) -> Tangent {
        let mut a = self.matrix.tangent(f);
        let (fa, i4) = self.fibre(f);
        if i4 > 1.0 {
            let d = i4 - 1.0;
            let ex = (self.k2 * d * d).exp();
            let w1 = self.k1 * d * ex;
            let w2 = self.k1 * (1.0 + 2.0 * self.k2 * d * d) * ex;
            let a0 = &self.axis;
            for i in 0..3 {
                for jj in 0..3 {
                    for k in 0..3 {
                        for l in 0..3 {
                            let mut v = 4.0 * w2 * fa[i] * a0[jj] * fa[k] * a0[l];
                            if i == k {
                                v += 2.0 * w1 * a0[jj] * a0[l];
                            }
                            a[3 * i + jj][3 * k + l] += v;
                        }
                    }
                }
            }
        }
        a
    }
}

/// One of the three hyperelastic laws, for callers that choose at run time (scenes, bindings).
// A body holds a handful of these (one per material): 296 bytes each is not worth a Box.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HyperelasticMaterial {
    /// Compressible neo-Hookean.
    NeoHookean(NeoHookean),
    /// St Venant-Kirchhoff with a 6x6 elasticity matrix.
    StVenantKirchhoff(StVenantKirchhoff),
    /// Neo-Hookean matrix with an exponential fibre family.
    FibreReinforced(FibreReinforced),
}

impl HyperelasticLaw for HyperelasticMaterial {
    fn validate(&self) -> Result<(), MaterialError> {
        match self {
            Self::NeoHookean(m) => m.validate(),
            Self::StVenantKirchhoff(m) => m.validate(),
            Self::FibreReinforced(m) => m.validate(),
        }
    }
    fn energy(&self, f: &Mat3) -> f64 {
        match self {
            Self::NeoHookean(m) => m.energy(f),
            Self::StVenantKirchhoff(m) => m.energy(f),
            Self::FibreReinforced(m) => m.energy(f),
        }
    }
    fn stress(&self, f: &Mat3) -> Mat3 {
        match self {
            Self::NeoHookean(m) => m.stress(f),
            Self::StVenantKirchhoff(m) => m.stress(f),
            Self::FibreReinforced(m) => m.stress(f),
        }
    }
    fn tangent(&self, f: &Mat3) -> Tangent {
        match self {
            Self::NeoHookean(m) => m.tangent(f),
            Self::StVenantKirchhoff(m) => m.tangent(f),
            Self::FibreReinforced(m) => m.tangent(f),
        }
    }
}

/// What an element's last evaluation left in the scratch.
#[derive(Debug, Clone, Copy, Default)]
struct ElementState {
    /// Volume ratio J = det F.
    j: f64,
    /// Strain energy density W.
    w: f64,
    /// First Piola-Kirchhoff stress.
    p: Mat3,
    /// Tangent dP/dF (only when asked).
    a: Tangent,
}

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
    state: Vec<ElementState>,
}

/// Which quantities an element pass computes.
#[derive(Clone, Copy, PartialEq)]
enum Want {
    Stress,
    Tangent,
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
            state: vec![ElementState::default(); tets.len()],
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

    fn check<L: HyperelasticLaw>(
        &self,
        u: &[f64],
        laws: &[L],
        material_of: Option<&[usize]>,
    ) -> Result<(), HyperelasticError> {
        if u.len() != self.n_dofs() {
            return Err(MaterialError::BadLength {
                what: "u",
                expected: self.n_dofs(),
                got: u.len(),
            }
            .into());
        }
        if let Some((dof, &value)) = u.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(HyperelasticError::NonFiniteDisplacement { dof, value });
        }
        if laws.is_empty() {
            return Err(MaterialError::BadLength {
                what: "materials",
                expected: 1,
                got: 0,
            }
            .into());
        }
        for law in laws {
            law.validate()?;
        }
        match material_of {
            Some(m) => {
                if m.len() != self.n_elements() {
                    return Err(MaterialError::BadLength {
                        what: "material_of",
                        expected: self.n_elements(),
                        got: m.len(),
                    }
                    .into());
                }
                if let Some((element, &index)) =
                    m.iter().enumerate().find(|(_, &k)| k >= laws.len())
                {
                    return Err(MaterialError::BadMaterialIndex {
                        element,
                        index,
                        n_materials: laws.len(),
                    }
                    .into());
                }
            }
            None if laws.len() != 1 => {
                return Err(MaterialError::BadLength {
                    what: "materials (no material_of given)",
                    expected: 1,
                    got: laws.len(),
                }
                .into());
            }
            None => {}
        }
        Ok(())
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
        self.check(u, laws, material_of)?;
        let tets = self.asm.tets();
        let grads = &self.grads;
        self.state.par_iter_mut().enumerate().for_each(|(e, s)| {
            let t = &tets[e];
            let g = &grads[e].0;
            let mut f = IDENTITY;
            for (a, &node) in t.iter().enumerate() {
                for (i, fi) in f.iter_mut().enumerate() {
                    let ui = u[3 * node + i];
                    for (fij, gaj) in fi.iter_mut().zip(&g[a]) {
                        *fij += ui * gaj;
                    }
                }
            }
            let j = det3(&f);
            s.j = j;
            if !(j > 0.0 && j.is_finite()) {
                return;
            }
            let law = &laws[material_of.map_or(0, |m| m[e])];
            s.w = law.energy(&f);
            s.p = law.stress(&f);
            if want == Want::Tangent {
                s.a = law.tangent(&f);
            }
        });
        for (element, s) in self.state.iter().enumerate() {
            if !(s.j > 0.0 && s.j.is_finite()) {
                return Err(HyperelasticError::Inverted { element, j: s.j });
            }
            let finite = s.w.is_finite()
                && s.p.iter().flatten().all(|x| x.is_finite())
                && (want != Want::Tangent || s.a.iter().flatten().all(|x| x.is_finite()));
            if !finite {
                return Err(HyperelasticError::NonFiniteStress { element, j: s.j });
            }
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
                let p = &self.state[e].p;
                for (ac, pi) in acc.iter_mut().zip(p) {
                    *ac += v * (pi[0] * ga[0] + pi[1] * ga[1] + pi[2] * ga[2]);
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
                let am = &state[e].a;
                let ga = &g[a];
                // t[iJ][k] = sum_L A[iJ][kL] ga[L]
                let mut t = [[0.0; 3]; 9];
                for (tr, ar) in t.iter_mut().zip(am) {
                    for (k, tk) in tr.iter_mut().enumerate() {
                        *tk = ar[3 * k] * ga[0] + ar[3 * k + 1] * ga[1] + ar[3 * k + 2] * ga[2];
                    }
                }
                let mut out = [[[0.0; 3]; 3]; 4];
                for (blk, gb) in out.iter_mut().zip(g) {
                    for (i, row) in blk.iter_mut().enumerate() {
                        for (k, x) in row.iter_mut().enumerate() {
                            *x = v
                                * (gb[0] * t[3 * i][k]
                                    + gb[1] * t[3 * i + 1][k]
                                    + gb[2] * t[3 * i + 2][k]);
                        }
                    }
                }
                out
            })
            .map_err(HyperelasticError::from)
    }

    fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), HyperelasticError> {
        if expected == got {
            Ok(())
        } else {
            Err(MaterialError::BadLength {
                what,
                expected,
                got,
            }
            .into())
        }
    }

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
    /// element's law (as in [`Assembler::stiffness_into`]).
    pub fn internal_force<L: HyperelasticLaw>(
        &mut self,
        u: &[f64],
        laws: &[L],
        material_of: Option<&[usize]>,
        force: &mut [f64],
    ) -> Result<f64, HyperelasticError> {
        Self::check_len("force", self.n_dofs(), force.len())?;
        self.evaluate(u, laws, material_of, Want::Stress)?;
        self.scatter_force(force);
        Ok(self.total_energy())
    }

    /// Writes the consistent tangent `K_T(u) = d f_int / d u` into `values`, in the order of
    /// the pattern (`self.assembler().col_ptr()`, `row_idx()`).
    pub fn tangent_into<L: HyperelasticLaw>(
        &mut self,
        u: &[f64],
        laws: &[L],
        material_of: Option<&[usize]>,
        values: &mut [f64],
    ) -> Result<(), HyperelasticError> {
        Self::check_len("values", self.nnz(), values.len())?;
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
        Self::check_len("force", self.n_dofs(), force.len())?;
        Self::check_len("values", self.nnz(), values.len())?;
        self.evaluate(u, laws, material_of, Want::Tangent)?;
        self.scatter_force(force);
        self.fill_tangent(values)?;
        Ok(self.total_energy())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
