//! What the P1 ([`super::FiniteStrainAssembler`]) and the P2
//! ([`super::QuadraticFiniteStrainAssembler`]) finite-strain assemblers share: the checks of a
//! call's inputs, the evaluation of a law at one point (an element of P1, a quadrature point of
//! P2) and the products of its stress and tangent with shape-function gradients. Both
//! assemblers evaluate and assemble with exactly this arithmetic.

use super::{det3, HyperelasticLaw, Mat3, Tangent, IDENTITY};
use crate::error::{HyperelasticError, MaterialError};

/// Which quantities a pass computes.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum Want {
    /// `J`, `W` and `P`.
    Stress,
    /// `J`, `W`, `P` and `A`.
    Tangent,
}

/// What the last evaluation at a point left in the scratch.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct PointState {
    /// Volume ratio J = det F.
    pub j: f64,
    /// Strain energy density W.
    pub w: f64,
    /// First Piola-Kirchhoff stress.
    pub p: Mat3,
    /// Tangent dP/dF (only when asked).
    pub a: Tangent,
}

impl PointState {
    /// Evaluates `law` at `f`: always `j`; `w`, `p` (and `a`) only where `j` is positive and
    /// finite (the laws are called with `det F > 0` only).
    #[inline]
    pub(super) fn evaluate<L: HyperelasticLaw>(&mut self, law: &L, f: &Mat3, want: Want) {
        let j = det3(f);
        self.j = j;
        if !(j > 0.0 && j.is_finite()) {
            return;
        }
        self.w = law.energy(f);
        self.p = law.stress(f);
        if want == Want::Tangent {
            self.a = law.tangent(f);
        }
    }

    /// The error of this point's last evaluation, naming `element`: inverted (`J <= 0`) first,
    /// then a non-finite energy, stress or (when asked) tangent.
    #[inline]
    pub(super) fn verdict(&self, element: usize, want: Want) -> Result<(), HyperelasticError> {
        if !(self.j > 0.0 && self.j.is_finite()) {
            return Err(HyperelasticError::Inverted { element, j: self.j });
        }
        let finite = self.w.is_finite()
            && self.p.iter().flatten().all(|x| x.is_finite())
            && (want != Want::Tangent || self.a.iter().flatten().all(|x| x.is_finite()));
        if finite {
            Ok(())
        } else {
            Err(HyperelasticError::NonFiniteStress { element, j: self.j })
        }
    }
}

/// `F = I + sum_a u_(nodes[a]) (x) g[a]`: the deformation gradient at a point where the
/// element's shape functions have the reference gradients `g`.
#[inline]
pub(super) fn deformation_gradient<const N: usize>(
    nodes: &[usize; N],
    g: &[[f64; 3]; N],
    u: &[f64],
) -> Mat3 {
    let mut f = IDENTITY;
    for (&node, ga) in nodes.iter().zip(g) {
        for (i, fi) in f.iter_mut().enumerate() {
            let ui = u[3 * node + i];
            for (fij, gaj) in fi.iter_mut().zip(ga) {
                *fij += ui * gaj;
            }
        }
    }
    f
}

/// `P g` (component i: `sum_J P_iJ g_J`): a node's internal force per unit reference volume.
#[inline]
pub(super) fn stress_dot(p: &Mat3, g: &[f64; 3]) -> [f64; 3] {
    [
        p[0][0] * g[0] + p[0][1] * g[1] + p[0][2] * g[2],
        p[1][0] * g[0] + p[1][1] * g[1] + p[1][2] * g[2],
        p[2][0] * g[0] + p[2][1] * g[1] + p[2][2] * g[2],
    ]
}

/// `t[3 i + J][k] = sum_L A_iJkL ga[L]`: the tangent contracted with column node a's gradient.
#[inline]
pub(super) fn tangent_dot(a: &Tangent, ga: &[f64; 3]) -> [[f64; 3]; 9] {
    let mut t = [[0.0; 3]; 9];
    for (tr, ar) in t.iter_mut().zip(a) {
        for (k, tk) in tr.iter_mut().enumerate() {
            *tk = ar[3 * k] * ga[0] + ar[3 * k + 1] * ga[1] + ar[3 * k + 2] * ga[2];
        }
    }
    t
}

/// The 3x3 tangent block of row node b: `v sum_J gb[J] t[3 i + J][k]` with `t` from
/// [`tangent_dot`] and `v` the point's volume (weight).
#[inline]
pub(super) fn tangent_block(t: &[[f64; 3]; 9], gb: &[f64; 3], v: f64) -> [[f64; 3]; 3] {
    let mut blk = [[0.0; 3]; 3];
    for (i, row) in blk.iter_mut().enumerate() {
        for (k, x) in row.iter_mut().enumerate() {
            *x = v * (gb[0] * t[3 * i][k] + gb[1] * t[3 * i + 1][k] + gb[2] * t[3 * i + 2][k]);
        }
    }
    blk
}

/// `Err(BadLength)` unless `got == expected`.
pub(super) fn check_len(
    what: &'static str,
    expected: usize,
    got: usize,
) -> Result<(), HyperelasticError> {
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

/// The checks of a call's inputs, in this order: `u` of length `n_dofs` and finite (the first
/// non-finite DOF is named), at least one law, every law valid, and `material_of` (one per
/// element, each naming a law; without it, exactly one law).
pub(super) fn check_inputs<L: HyperelasticLaw>(
    n_dofs: usize,
    n_elements: usize,
    u: &[f64],
    laws: &[L],
    material_of: Option<&[usize]>,
) -> Result<(), HyperelasticError> {
    check_len("u", n_dofs, u.len())?;
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
            check_len("material_of", n_elements, m.len())?;
            if let Some((element, &index)) = m.iter().enumerate().find(|(_, &k)| k >= laws.len()) {
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
