//! The hyperelastic laws: compressible neo-Hookean, St Venant-Kirchhoff (any linear
//! elasticity, so also the transversely isotropic vocal-fold tissue) and an exponential
//! fibre reinforcement on a neo-Hookean matrix; [`HyperelasticMaterial`] holds any of them.

use super::{det3, inv3, positive, HyperelasticLaw, Mat3, Tangent, VOIGT};
use crate::error::MaterialError;
use crate::fem::material::{Elasticity, Material};

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
