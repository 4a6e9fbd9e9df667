//! Linear elastic materials: isotropic, and transversely isotropic about a fibre axis.
//!
//! Voigt order `[xx, yy, zz, yz, xz, xy]`, engineering shear strains. The transversely
//! isotropic compliance about z (plane of isotropy x-y, "p"; fibre direction z) is
//!
//! ```text
//! S = [  1/Ep    -nup/Ep  -nupz/Ep   0      0      0
//!       -nup/Ep   1/Ep    -nupz/Ep   0      0      0
//!       -nupz/Ep -nupz/Ep  1/Ez      0      0      0
//!        0        0        0       1/Gpz    0      0
//!        0        0        0        0     1/Gpz    0
//!        0        0        0        0      0    2(1+nup)/Ep ]
//! ```
//!
//! so `nu_pz` is the contraction along z under a stress in the plane (Abaqus' `nu_pt`
//! convention, `nu_zp = nu_pz Ez/Ep`). The elasticity matrix is `D = S^-1`.

use crate::error::MaterialError;

/// A 6x6 elasticity matrix in Voigt notation (row-major).
pub type Elasticity = [[f64; 6]; 6];

/// A linear elastic material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    /// Isotropic: Young's modulus and Poisson's ratio.
    Isotropic {
        /// Young's modulus, Pa.
        e: f64,
        /// Poisson's ratio, in (-1, 0.5).
        nu: f64,
    },
    /// Transversely isotropic about `axis`.
    TransverselyIsotropic {
        /// Young's modulus in the plane of isotropy, Pa.
        e_p: f64,
        /// Young's modulus along the fibre axis, Pa.
        e_z: f64,
        /// Poisson's ratio in the plane.
        nu_p: f64,
        /// Poisson's ratio: contraction along the fibre under in-plane stress.
        nu_pz: f64,
        /// Shear modulus in planes containing the fibre, Pa.
        g_pz: f64,
        /// Fibre direction (need not be unit length).
        axis: [f64; 3],
    },
}

fn positive(name: &'static str, value: f64) -> Result<(), MaterialError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(MaterialError::NotPositive { name, value })
    }
}

impl Material {
    /// Checks the parameters: moduli positive, Poisson ratios admissible, compliance
    /// positive definite.
    pub fn validate(&self) -> Result<(), MaterialError> {
        match *self {
            Material::Isotropic { e, nu } => {
                positive("E", e)?;
                if !(nu > -1.0 && nu < 0.5) {
                    return Err(MaterialError::OutOfRange {
                        name: "nu",
                        value: nu,
                        reason: "an isotropic Poisson's ratio must lie in (-1, 0.5)".into(),
                    });
                }
                Ok(())
            }
            Material::TransverselyIsotropic {
                e_p,
                e_z,
                nu_p,
                nu_pz,
                g_pz,
                axis,
            } => {
                positive("E_p", e_p)?;
                positive("E_z", e_z)?;
                positive("G_pz", g_pz)?;
                if !nu_pz.is_finite() {
                    return Err(MaterialError::OutOfRange {
                        name: "nu_pz",
                        value: nu_pz,
                        reason: "must be finite".into(),
                    });
                }
                if !(nu_p > -1.0 && nu_p < 1.0) {
                    return Err(MaterialError::OutOfRange {
                        name: "nu_p",
                        value: nu_p,
                        reason: "the in-plane Poisson's ratio must lie in (-1, 1)".into(),
                    });
                }
                let nu_zp = nu_pz * e_z / e_p;
                let det = 1.0 - nu_p - 2.0 * nu_pz * nu_zp;
                // Not `det <= 0.0`: a NaN must fail too.
                if det.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    return Err(MaterialError::NotPositiveDefinite {
                        reason: format!(
                            "1 - nu_p - 2 nu_pz^2 E_z/E_p = {det:.4} must be > 0 \
                             (nu_p = {nu_p}, nu_pz = {nu_pz}, E_z/E_p = {:.4}); lower nu_pz or nu_p",
                            e_z / e_p
                        ),
                    });
                }
                let n2 = axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2];
                if !(n2 > 0.0 && n2.is_finite()) {
                    return Err(MaterialError::BadAxis { axis });
                }
                Ok(())
            }
        }
    }

    /// The 6x6 elasticity matrix D (stress = D strain) in global axes.
    ///
    /// ```
    /// use vfrs_core::Material;
    /// let d = Material::Isotropic { e: 1.0, nu: 0.25 }.elasticity().unwrap();
    /// assert!((d[3][3] - 0.4).abs() < 1e-14); // shear modulus E / (2 (1 + nu))
    /// ```
    pub fn elasticity(&self) -> Result<Elasticity, MaterialError> {
        self.validate()?;
        Ok(match *self {
            Material::Isotropic { e, nu } => {
                let lam = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
                let mu = e / (2.0 * (1.0 + nu));
                let mut d = [[0.0; 6]; 6];
                for i in 0..3 {
                    d[i][..3].fill(lam);
                    d[i][i] = lam + 2.0 * mu;
                    d[i + 3][i + 3] = mu;
                }
                d
            }
            Material::TransverselyIsotropic {
                e_p,
                e_z,
                nu_p,
                nu_pz,
                g_pz,
                axis,
            } => {
                let mut s = [[0.0; 6]; 6];
                s[0][0] = 1.0 / e_p;
                s[1][1] = 1.0 / e_p;
                s[2][2] = 1.0 / e_z;
                s[0][1] = -nu_p / e_p;
                s[1][0] = s[0][1];
                s[0][2] = -nu_pz / e_p;
                s[1][2] = s[0][2];
                s[2][0] = s[0][2];
                s[2][1] = s[0][2];
                s[3][3] = 1.0 / g_pz;
                s[4][4] = 1.0 / g_pz;
                s[5][5] = 2.0 * (1.0 + nu_p) / e_p;
                let d = invert6(&s).ok_or_else(|| MaterialError::NotPositiveDefinite {
                    reason: "compliance matrix is singular".into(),
                })?;
                rotate(&d, &rotation_z_to(axis))
            }
        })
    }
}

/// A rotation matrix R (rows = new basis in old coordinates transposed) with R e_z = axis/|axis|.
fn rotation_z_to(axis: [f64; 3]) -> [[f64; 3]; 3] {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let a = [axis[0] / n, axis[1] / n, axis[2] / n];
    // Any unit vector orthogonal to a: the material is isotropic in that plane.
    let helper = if a[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let b = crate::fem::mesh::cross(&a, &helper);
    let nb = crate::fem::mesh::dot(&b, &b).sqrt();
    let b = [b[0] / nb, b[1] / nb, b[2] / nb];
    let c = crate::fem::mesh::cross(&a, &b);
    // Columns of R: images of e_x, e_y, e_z.
    [[b[0], c[0], a[0]], [b[1], c[1], a[1]], [b[2], c[2], a[2]]]
}

const VOIGT: [[usize; 3]; 3] = [[0, 5, 4], [5, 1, 3], [4, 3, 2]];

/// Rotates a Voigt elasticity matrix: C'_ijkl = R_ia R_jb R_kc R_ld C_abcd.
pub fn rotate(d: &Elasticity, r: &[[f64; 3]; 3]) -> Elasticity {
    let c = |i: usize, j: usize, k: usize, l: usize| d[VOIGT[i][j]][VOIGT[k][l]];
    let pairs = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];
    let mut out = [[0.0; 6]; 6];
    for (p, &(i, j)) in pairs.iter().enumerate() {
        for (q, &(k, l)) in pairs.iter().enumerate() {
            let mut s = 0.0;
            for a in 0..3 {
                for b in 0..3 {
                    let rab = r[i][a] * r[j][b];
                    if rab == 0.0 {
                        continue;
                    }
                    for cc in 0..3 {
                        for dd in 0..3 {
                            s += rab * r[k][cc] * r[l][dd] * c(a, b, cc, dd);
                        }
                    }
                }
            }
            out[p][q] = s;
        }
    }
    out
}

/// Inverse of a symmetric positive definite 6x6 matrix by Gauss-Jordan with partial
/// pivoting; `None` if singular.
fn invert6(m: &[[f64; 6]; 6]) -> Option<[[f64; 6]; 6]> {
    let mut a = *m;
    let mut inv = [[0.0; 6]; 6];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for col in 0..6 {
        let piv = (col..6).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
        if a[piv][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, piv);
        inv.swap(col, piv);
        let p = a[col][col];
        for j in 0..6 {
            a[col][j] /= p;
            inv[col][j] /= p;
        }
        for r in 0..6 {
            if r != col {
                let f = a[r][col];
                if f != 0.0 {
                    for j in 0..6 {
                        a[r][j] -= f * a[col][j];
                        inv[r][j] -= f * inv[col][j];
                    }
                }
            }
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Elasticity, b: &Elasticity, tol: f64) -> bool {
        let scale = a.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .all(|(x, y)| (x - y).abs() <= tol * scale)
    }

    #[test]
    fn transversely_isotropic_with_equal_parameters_is_isotropic() {
        let (e, nu) = (10e3, 0.3);
        let iso = Material::Isotropic { e, nu }.elasticity().unwrap();
        let ti = Material::TransverselyIsotropic {
            e_p: e,
            e_z: e,
            nu_p: nu,
            nu_pz: nu,
            g_pz: e / (2.0 * (1.0 + nu)),
            axis: [0.3, -1.0, 2.0],
        }
        .elasticity()
        .unwrap();
        assert!(close(&iso, &ti, 1e-12));
    }

    #[test]
    fn fibre_along_x_swaps_axes() {
        let m = |axis| Material::TransverselyIsotropic {
            e_p: 2e3,
            e_z: 40e3,
            nu_p: 0.9,
            nu_pz: 0.0,
            g_pz: 10e3,
            axis,
        };
        let dz = m([0.0, 0.0, 1.0]).elasticity().unwrap();
        let dx = m([1.0, 0.0, 0.0]).elasticity().unwrap();
        assert!((dx[0][0] - dz[2][2]).abs() < 1e-9 * dz[2][2]);
        assert!((dx[3][3] - dz[5][5]).abs() < 1e-9 * dz[2][2]); // yz is in the plane now
        assert!((dz[2][2] - 40e3).abs() < 1e-8); // nu_pz = 0 decouples the fibre
    }

    #[test]
    fn rejects_inadmissible_parameters() {
        assert!(Material::Isotropic { e: -1.0, nu: 0.3 }.validate().is_err());
        assert!(Material::Isotropic { e: 1.0, nu: 0.5 }.validate().is_err());
        let bad = Material::TransverselyIsotropic {
            e_p: 1.0,
            e_z: 100.0,
            nu_p: 0.3,
            nu_pz: 0.3,
            g_pz: 1.0,
            axis: [0.0, 0.0, 1.0],
        };
        assert!(matches!(
            bad.validate(),
            Err(MaterialError::NotPositiveDefinite { .. })
        ));
        let bad_axis = Material::TransverselyIsotropic {
            e_p: 1.0,
            e_z: 1.0,
            nu_p: 0.3,
            nu_pz: 0.1,
            g_pz: 1.0,
            axis: [0.0; 3],
        };
        assert!(matches!(
            bad_axis.validate(),
            Err(MaterialError::BadAxis { .. })
        ));
    }
}
