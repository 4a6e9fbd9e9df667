//! The linear (P1) tetrahedron: shape-function gradients, stiffness and mass blocks.

use crate::fem::material::Elasticity;

/// The determinant of a 3x3 matrix (rows `j[r]`).
#[inline]
pub(crate) fn det3(j: &[[f64; 3]; 3]) -> f64 {
    j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1])
        - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
        + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0])
}

/// The inverse of the 3x3 matrix `j` whose determinant is `det` (not zero): the adjugate
/// over the determinant.
#[inline]
pub(crate) fn inverse3(j: &[[f64; 3]; 3], det: f64) -> [[f64; 3]; 3] {
    let inv_det = 1.0 / det;
    [
        [
            (j[1][1] * j[2][2] - j[1][2] * j[2][1]) * inv_det,
            (j[0][2] * j[2][1] - j[0][1] * j[2][2]) * inv_det,
            (j[0][1] * j[1][2] - j[0][2] * j[1][1]) * inv_det,
        ],
        [
            (j[1][2] * j[2][0] - j[1][0] * j[2][2]) * inv_det,
            (j[0][0] * j[2][2] - j[0][2] * j[2][0]) * inv_det,
            (j[0][2] * j[1][0] - j[0][0] * j[1][2]) * inv_det,
        ],
        [
            (j[1][0] * j[2][1] - j[1][1] * j[2][0]) * inv_det,
            (j[0][1] * j[2][0] - j[0][0] * j[2][1]) * inv_det,
            (j[0][0] * j[1][1] - j[0][1] * j[1][0]) * inv_det,
        ],
    ]
}

/// Gradients of the four shape functions and the signed volume of a tetrahedron.
/// `None` when the element is degenerate (zero volume).
#[inline]
pub fn gradients(x: [&[f64; 3]; 4]) -> Option<([[f64; 3]; 4], f64)> {
    let j = [
        [x[1][0] - x[0][0], x[2][0] - x[0][0], x[3][0] - x[0][0]],
        [x[1][1] - x[0][1], x[2][1] - x[0][1], x[3][1] - x[0][1]],
        [x[1][2] - x[0][2], x[2][2] - x[0][2], x[3][2] - x[0][2]],
    ];
    let det = det3(&j);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    // Rows of J^-1 are the gradients of N1, N2, N3 (N0 = 1 - N1 - N2 - N3).
    let inv = inverse3(&j, det);
    let g0 = [
        -inv[0][0] - inv[1][0] - inv[2][0],
        -inv[0][1] - inv[1][1] - inv[2][1],
        -inv[0][2] - inv[1][2] - inv[2][2],
    ];
    Some(([g0, inv[0], inv[1], inv[2]], det / 6.0))
}

/// Strain-displacement matrix of one node (6 x 3) from its shape-function gradient.
#[inline]
pub(crate) fn b_node(g: &[f64; 3]) -> [[f64; 3]; 6] {
    [
        [g[0], 0.0, 0.0],
        [0.0, g[1], 0.0],
        [0.0, 0.0, g[2]],
        [0.0, g[2], g[1]],
        [g[2], 0.0, g[0]],
        [g[1], g[0], 0.0],
    ]
}

/// The 3x3 stiffness blocks K_ba (b = 0..4) of column node `a`:
/// `K_ba = V B_b^T D B_a`. Row-major `[b][row][col]`.
#[inline]
pub fn stiffness_column(
    grads: &[[f64; 3]; 4],
    volume: f64,
    d: &Elasticity,
    a: usize,
) -> [[[f64; 3]; 3]; 4] {
    let ba = b_node(&grads[a]);
    let mut dba = [[0.0; 3]; 6];
    for s in 0..6 {
        for c in 0..3 {
            let mut acc = 0.0;
            for t in 0..6 {
                acc += d[s][t] * ba[t][c];
            }
            dba[s][c] = acc * volume;
        }
    }
    let mut out = [[[0.0; 3]; 3]; 4];
    for (b, blk) in out.iter_mut().enumerate() {
        let bb = b_node(&grads[b]);
        for r in 0..3 {
            for c in 0..3 {
                let mut acc = 0.0;
                for s in 0..6 {
                    acc += bb[s][r] * dba[s][c];
                }
                blk[r][c] = acc;
            }
        }
    }
    out
}

/// Consistent mass coefficient between local nodes b and a (per direction):
/// `rho V (1 + delta_ab) / 20`.
#[inline]
pub fn mass_coefficient(rho: f64, volume: f64, a: usize, b: usize) -> f64 {
    rho * volume * if a == b { 2.0 } else { 1.0 } / 20.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::material::Material;

    #[test]
    fn gradients_reproduce_linear_fields() {
        let p = [
            [0.1, 0.0, 0.2],
            [1.0, 0.1, 0.0],
            [0.2, 1.3, 0.1],
            [0.0, 0.3, 0.9],
        ];
        let (g, v) = gradients([&p[0], &p[1], &p[2], &p[3]]).unwrap();
        assert!(v > 0.0);
        // grad of f = 2x - y + 3z is sum f(x_a) g_a
        let f = |x: &[f64; 3]| 2.0 * x[0] - x[1] + 3.0 * x[2];
        for k in 0..3 {
            let s: f64 = (0..4).map(|a| f(&p[a]) * g[a][k]).sum();
            assert!((s - [2.0, -1.0, 3.0][k]).abs() < 1e-12);
        }
    }

    #[test]
    fn rigid_translation_gives_no_force() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let (g, v) = gradients([&p[0], &p[1], &p[2], &p[3]]).unwrap();
        let d = Material::Isotropic { e: 1.0, nu: 0.3 }
            .elasticity()
            .unwrap();
        for a in 0..4 {
            let col = stiffness_column(&g, v, &d, a);
            // The four 3x3 blocks of a column sum to zero (rigid translation).
            let mut sum = [[0.0f64; 3]; 3];
            for blk in &col {
                for (s, b) in sum.iter_mut().flatten().zip(blk.iter().flatten()) {
                    *s += b;
                }
            }
            assert!(sum.iter().flatten().all(|s| s.abs() < 1e-14));
        }
    }
}
