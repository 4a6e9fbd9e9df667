//! The quadratic (P2) tetrahedron: ten nodes, isoparametric (issue 47, item 1: the element).
//!
//! Nodes: the vertices 0-3, then the mid-edge nodes in VTK's order (`VTK_QUADRATIC_TETRA`,
//! which meshio uses for Gmsh's `tetra10` too): 4 on edge 0-1, 5 on 1-2, 6 on 0-2, 7 on 0-3,
//! 8 on 1-3, 9 on 2-3 ([`EDGES`]). In barycentric coordinates `L_0..L_3` the shape functions
//! are `L_i (2 L_i - 1)` at a vertex and `4 L_i L_j` on the edge i-j. The reference
//! coordinates are `xi = (L_1, L_2, L_3)`, `L_0 = 1 - xi_1 - xi_2 - xi_3`; the reference
//! tetrahedron's volume is 1/6.
//!
//! Integration: the stiffness with the 4-point rule of degree 2 ([`RULE_4`]: exact for a
//! straight-edged element, whose strains are linear), the consistent mass with the 14-point
//! rule of degree 5 ([`RULE_14`]: exact for a straight-edged element, whose mass integrand is
//! of degree 4). A curved element (mid-edge nodes off their edges' midpoints) is integrated
//! by the same rules, not exactly. Both rules' weights are positive and sum to 1 (a fraction
//! of the element's reference volume).

use crate::fem::element::{b_node, det3, inverse3};
use crate::fem::material::Elasticity;

/// The edge of each mid-edge node 4..9 (its two vertices).
pub const EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]];

/// A quadrature rule on the tetrahedron: barycentric points and weights summing to 1.
#[derive(Debug, Clone, Copy)]
pub struct Rule {
    /// Barycentric coordinates of the points.
    pub points: &'static [[f64; 4]],
    /// Their weights, summing to 1.
    pub weights: &'static [f64],
}

const A4: f64 = 0.585_410_196_624_968_5;
const B4: f64 = 0.138_196_601_125_010_5;

/// Degree 2, four points (the vertices' images at `(5 + 3 sqrt 5) / 20`), equal weights.
pub const RULE_4: Rule = Rule {
    points: &[
        [A4, B4, B4, B4],
        [B4, A4, B4, B4],
        [B4, B4, A4, B4],
        [B4, B4, B4, A4],
    ],
    weights: &[0.25, 0.25, 0.25, 0.25],
};

const P1: f64 = 0.092_735_250_310_891_2;
const Q1: f64 = 1.0 - 3.0 * P1;
const P2: f64 = 0.310_885_919_263_300_6;
const Q2: f64 = 1.0 - 3.0 * P2;
const C3: f64 = 0.454_496_295_874_350_4;
const D3: f64 = 0.045_503_704_125_649_6;
// The weights of the rule as usually tabulated (summing to 5/3), times 3/5.
const W1: f64 = 0.122_488_405_193_936_6 * 0.6;
const W2: f64 = 0.187_813_209_530_026_4 * 0.6;
const W3: f64 = 0.070_910_034_628_469_1 * 0.6;

/// Degree 5, fourteen points (two orbits of four on the medians, one of six on the edges'
/// mid-planes), positive weights.
pub const RULE_14: Rule = Rule {
    points: &[
        [Q1, P1, P1, P1],
        [P1, Q1, P1, P1],
        [P1, P1, Q1, P1],
        [P1, P1, P1, Q1],
        [Q2, P2, P2, P2],
        [P2, Q2, P2, P2],
        [P2, P2, Q2, P2],
        [P2, P2, P2, Q2],
        [C3, C3, D3, D3],
        [C3, D3, C3, D3],
        [C3, D3, D3, C3],
        [D3, C3, C3, D3],
        [D3, C3, D3, C3],
        [D3, D3, C3, C3],
    ],
    weights: &[W1, W1, W1, W1, W2, W2, W2, W2, W3, W3, W3, W3, W3, W3],
};

/// The ten shape functions at the barycentric point `l`.
#[inline]
pub fn shape(l: &[f64; 4]) -> [f64; 10] {
    let mut n = [0.0; 10];
    for i in 0..4 {
        n[i] = l[i] * (2.0 * l[i] - 1.0);
    }
    for (e, [i, j]) in EDGES.iter().enumerate() {
        n[4 + e] = 4.0 * l[*i] * l[*j];
    }
    n
}

/// Derivatives of the ten shape functions with respect to the reference coordinates
/// `xi = (L_1, L_2, L_3)` at the barycentric point `l` (`dN/dxi_k = dN/dL_k - dN/dL_0`).
#[inline]
pub fn reference_gradients(l: &[f64; 4]) -> [[f64; 3]; 10] {
    // dN/dL_m for every node, then the chain rule through L_0 = 1 - sum xi.
    let mut dl = [[0.0; 4]; 10];
    for i in 0..4 {
        dl[i][i] = 4.0 * l[i] - 1.0;
    }
    for (e, [i, j]) in EDGES.iter().enumerate() {
        dl[4 + e][*i] = 4.0 * l[*j];
        dl[4 + e][*j] = 4.0 * l[*i];
    }
    let mut out = [[0.0; 3]; 10];
    for (o, d) in out.iter_mut().zip(dl.iter()) {
        for k in 0..3 {
            o[k] = d[k + 1] - d[0];
        }
    }
    out
}

/// The shape functions' gradients in space and `det J` at the barycentric point `l` of the
/// element with nodes `x`; `None` where the Jacobian is not positive and finite (an inverted
/// or degenerate element there).
pub fn gradients_at(x: &[[f64; 3]; 10], l: &[f64; 4]) -> Option<([[f64; 3]; 10], f64)> {
    let dn = reference_gradients(l);
    // J[r][k] = sum_a x_a[r] dN_a/dxi_k
    let mut j = [[0.0; 3]; 3];
    for (xa, da) in x.iter().zip(dn.iter()) {
        for r in 0..3 {
            for k in 0..3 {
                j[r][k] += xa[r] * da[k];
            }
        }
    }
    let det = det3(&j);
    if !(det > 0.0 && det.is_finite()) {
        return None;
    }
    // (J^-1)[k][r]
    let inv = inverse3(&j, det);
    // grad N_a = J^-T dN_a/dxi: component r = sum_k inv[k][r] dN_a/dxi_k
    let mut g = [[0.0; 3]; 10];
    for (ga, da) in g.iter_mut().zip(dn.iter()) {
        for r in 0..3 {
            ga[r] = (0..3).map(|k| inv[k][r] * da[k]).sum();
        }
    }
    Some((g, det))
}

/// Why an element cannot be integrated: the first quadrature point (its index in the rule)
/// where the Jacobian is not positive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inverted {
    /// The quadrature point's index in the rule.
    pub point: usize,
}

/// The element stiffness (30 x 30, row-major, DOF `3 a + c` of node a, direction c) of the
/// element with nodes `x` and the elasticity `d`, by [`RULE_4`].
pub fn stiffness(x: &[[f64; 3]; 10], d: &Elasticity) -> Result<Box<[[f64; 30]; 30]>, Inverted> {
    let mut k = Box::new([[0.0; 30]; 30]);
    for (q, (l, w)) in RULE_4.points.iter().zip(RULE_4.weights).enumerate() {
        let (g, det) = gradients_at(x, l).ok_or(Inverted { point: q })?;
        let dv = w * det / 6.0;
        // B (6 x 30) columns per node: the P1 pattern of each gradient
        let mut b = [[0.0; 30]; 6];
        for (a, ga) in g.iter().enumerate() {
            let c = 3 * a;
            b[0][c] = ga[0];
            b[1][c + 1] = ga[1];
            b[2][c + 2] = ga[2];
            b[3][c + 1] = ga[2];
            b[3][c + 2] = ga[1];
            b[4][c] = ga[2];
            b[4][c + 2] = ga[0];
            b[5][c] = ga[1];
            b[5][c + 1] = ga[0];
        }
        // DB (6 x 30)
        let mut db = [[0.0; 30]; 6];
        for s in 0..6 {
            for col in 0..30 {
                db[s][col] = (0..6).map(|t| d[s][t] * b[t][col]).sum::<f64>() * dv;
            }
        }
        for r in 0..30 {
            for col in 0..30 {
                k[r][col] += (0..6).map(|s| b[s][r] * db[s][col]).sum::<f64>();
            }
        }
    }
    Ok(k)
}

/// The 3x3 stiffness blocks `K_ba` (b = 0..10) of column node `a`: the column of
/// [`stiffness`] that an assembly over node columns needs, by [`RULE_4`], without the rest
/// of the element matrix. Row-major `[b][row][col]`.
pub fn stiffness_column(
    x: &[[f64; 3]; 10],
    d: &Elasticity,
    a: usize,
) -> Result<[[[f64; 3]; 3]; 10], Inverted> {
    let mut out = [[[0.0; 3]; 3]; 10];
    for (q, (l, w)) in RULE_4.points.iter().zip(RULE_4.weights).enumerate() {
        let (g, det) = gradients_at(x, l).ok_or(Inverted { point: q })?;
        let dv = w * det / 6.0;
        let ba = b_node(&g[a]);
        let mut dba = [[0.0; 3]; 6];
        for s in 0..6 {
            for c in 0..3 {
                dba[s][c] = (0..6).map(|t| d[s][t] * ba[t][c]).sum::<f64>() * dv;
            }
        }
        for (blk, gb) in out.iter_mut().zip(g.iter()) {
            let bb = b_node(gb);
            for r in 0..3 {
                for c in 0..3 {
                    blk[r][c] += (0..6).map(|s| bb[s][r] * dba[s][c]).sum::<f64>();
                }
            }
        }
    }
    Ok(out)
}

/// The consistent mass coefficients `M_ba` (b = 0..10) of column node `a`, by [`RULE_14`].
pub fn mass_column(x: &[[f64; 3]; 10], rho: f64, a: usize) -> Result<[f64; 10], Inverted> {
    let mut out = [0.0; 10];
    for (q, (l, w)) in RULE_14.points.iter().zip(RULE_14.weights).enumerate() {
        let (_, det) = gradients_at(x, l).ok_or(Inverted { point: q })?;
        let n = shape(l);
        let dv = rho * w * det / 6.0 * n[a];
        for (o, nb) in out.iter_mut().zip(n.iter()) {
            *o += nb * dv;
        }
    }
    Ok(out)
}

/// The consistent mass coefficients `M_ab = int rho N_a N_b dV` (10 x 10, per direction) by
/// [`RULE_14`].
pub fn mass(x: &[[f64; 3]; 10], rho: f64) -> Result<[[f64; 10]; 10], Inverted> {
    let mut m = [[0.0; 10]; 10];
    for (q, (l, w)) in RULE_14.points.iter().zip(RULE_14.weights).enumerate() {
        let (_, det) = gradients_at(x, l).ok_or(Inverted { point: q })?;
        let n = shape(l);
        let dv = rho * w * det / 6.0;
        for a in 0..10 {
            for b in 0..10 {
                m[a][b] += n[a] * n[b] * dv;
            }
        }
    }
    Ok(m)
}

/// The lumped mass per node (per direction) by the HRZ rule (Hinton, Rock & Zienkiewicz):
/// the consistent mass's diagonal, scaled so that it sums to the element's mass. Every entry
/// is positive (the row sums of a straight element's consistent mass are not: -rho V / 20 at
/// a vertex, rho V / 5 at a mid-edge node).
pub fn lumped_mass(x: &[[f64; 3]; 10], rho: f64) -> Result<[f64; 10], Inverted> {
    let m = mass(x, rho)?;
    let total: f64 = m.iter().flatten().sum();
    let diag: f64 = (0..10).map(|a| m[a][a]).sum();
    let mut out = [0.0; 10];
    for (a, o) in out.iter_mut().enumerate() {
        *o = m[a][a] * total / diag;
    }
    Ok(out)
}

/// The ten nodes of the straight-edged element on the four vertices `v` (mid-edge nodes at
/// the edges' midpoints).
pub fn straight(v: &[[f64; 3]; 4]) -> [[f64; 3]; 10] {
    let mut x = [[0.0; 3]; 10];
    x[..4].copy_from_slice(v);
    for (e, [i, j]) in EDGES.iter().enumerate() {
        for r in 0..3 {
            x[4 + e][r] = 0.5 * (v[*i][r] + v[*j][r]);
        }
    }
    x
}

#[cfg(test)]
mod tests;
