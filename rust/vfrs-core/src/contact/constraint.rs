//! The sparse constraint matrix G of the active pairs (rows `g_e` scattered to global DOFs).

use super::record::RIGID;
use super::ContactError;

/// A compressed-sparse-row matrix (k pairs x 3 n_nodes), columns sorted in each row.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CsrMatrix {
    /// Rows.
    pub n_rows: usize,
    /// Columns.
    pub n_cols: usize,
    /// Row pointers, length `n_rows + 1`.
    pub indptr: Vec<usize>,
    /// Column indices.
    pub indices: Vec<usize>,
    /// Values.
    pub data: Vec<f64>,
}

impl CsrMatrix {
    /// `y = A x`.
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        (0..self.n_rows)
            .map(|r| {
                (self.indptr[r]..self.indptr[r + 1])
                    .map(|k| self.data[k] * x[self.indices[k]])
                    .sum()
            })
            .collect()
    }

    /// `y = A^T x`.
    pub fn tr_mul_vec(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n_cols];
        for (r, &xr) in x.iter().enumerate().take(self.n_rows) {
            for k in self.indptr[r]..self.indptr[r + 1] {
                y[self.indices[k]] += self.data[k] * xr;
            }
        }
        y
    }
}

/// Pair `e`'s master coefficients `-N_j` into `ent[1..4]` after checking its master
/// triangle `m` (slave `s`); returns the entries used: 1 for a rigid master, else 4.
fn master_entries(
    e: usize,
    s: usize,
    m: [usize; 3],
    xi: f64,
    zeta: f64,
    n_nodes: usize,
    ent: &mut [(usize, f64); 4],
) -> Result<usize, ContactError> {
    if m == [RIGID; 3] {
        return Ok(1);
    }
    let w = [1.0 - xi - zeta, xi, zeta];
    for j in 0..3 {
        if m[j] >= n_nodes {
            return Err(ContactError::IndexOutOfRange {
                what: "master",
                row: e,
                index: m[j],
                len: n_nodes,
            });
        }
        if m[j] == s {
            return Err(ContactError::SlaveInMaster { pair: e, node: s });
        }
        if m[(j + 1) % 3] == m[j] {
            return Err(ContactError::DegenerateTriangle {
                triangle: e,
                area: 0.0,
            });
        }
        ent[1 + j] = (m[j], -w[j]);
    }
    Ok(4)
}

/// The constraint matrix G: row e is `g_e = [n, -N1 n, -N2 n, -N3 n]` on the DOFs of
/// (slave, x1, x2, x3), with `N1 = 1 - xi - zeta`, `N2 = xi`, `N3 = zeta`. So `G x` gives
/// the normal gaps of the stacked positions `x` (node-major), and `G^T lambda` are contact
/// forces that push each slave along `+n` and its master along `-n`, summing to zero.
///
/// A pair whose master nodes are all [`RIGID`] (node-to-plane) has only the slave part
/// `n`: then `G x = gap + n . origin`.
///
/// ```
/// use vfrs_core::contact::constraint_matrix;
/// let g = constraint_matrix(&[3], &[[0, 1, 2]], &[0.25], &[0.25], &[[0.0, 0.0, 1.0]], 4).unwrap();
/// let x = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.2, 0.3, 0.7];
/// assert!((g.mul_vec(&x)[0] - 0.7).abs() < 1e-15);
/// ```
pub fn constraint_matrix(
    slave: &[usize],
    master: &[[usize; 3]],
    xi: &[f64],
    zeta: &[f64],
    normal: &[[f64; 3]],
    n_nodes: usize,
) -> Result<CsrMatrix, ContactError> {
    let k = slave.len();
    for (what, got) in [
        ("master", master.len()),
        ("xi", xi.len()),
        ("zeta", zeta.len()),
        ("normal", normal.len()),
    ] {
        if got != k {
            return Err(ContactError::LengthMismatch {
                what,
                expected: k,
                got,
            });
        }
    }
    let mut indptr = Vec::with_capacity(k + 1);
    let mut indices = Vec::with_capacity(12 * k);
    let mut data = Vec::with_capacity(12 * k);
    indptr.push(0);
    for e in 0..k {
        let s = slave[e];
        if s >= n_nodes {
            return Err(ContactError::IndexOutOfRange {
                what: "slave",
                row: e,
                index: s,
                len: n_nodes,
            });
        }
        let n = normal[e];
        if !n.iter().all(|c| c.is_finite()) || n == [0.0; 3] {
            return Err(ContactError::BadNormal { pair: e, normal: n });
        }
        for (what, val) in [("xi", xi[e]), ("zeta", zeta[e])] {
            if !val.is_finite() {
                return Err(ContactError::NonFinite {
                    what,
                    index: e,
                    value: val,
                });
            }
        }
        let mut ent: [(usize, f64); 4] = [(s, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)];
        let len = master_entries(e, s, master[e], xi[e], zeta[e], n_nodes, &mut ent)?;
        let ent = &mut ent[..len];
        ent.sort_unstable_by_key(|t| t.0);
        for &(node, c) in ent.iter() {
            for (d, nd) in n.iter().enumerate() {
                indices.push(3 * node + d);
                data.push(c * nd);
            }
        }
        indptr.push(indices.len());
    }
    Ok(CsrMatrix {
        n_rows: k,
        n_cols: 3 * n_nodes,
        indptr,
        indices,
        data,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    #[test]
    fn gaps_and_zero_net_force_and_moment() {
        // master triangle in z = 0 (normal +z); slaves placed at xbar + g n.
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let (xi, zeta, gap) = ([0.2, 0.5], [0.3, 0.1], [0.4, -0.25]);
        let mut pts = tri.to_vec();
        for e in 0..2 {
            let w = [1.0 - xi[e] - zeta[e], xi[e], zeta[e]];
            let mut p = [0.0; 3];
            for d in 0..3 {
                p[d] = w[0] * tri[0][d] + w[1] * tri[1][d] + w[2] * tri[2][d];
            }
            p[2] += gap[e];
            pts.push(p);
        }
        let n = [[0.0, 0.0, 1.0]; 2];
        let g = constraint_matrix(&[3, 4], &[[0, 1, 2], [0, 1, 2]], &xi, &zeta, &n, 5).unwrap();
        let x: Vec<f64> = pts.iter().flatten().copied().collect();
        let gx = g.mul_vec(&x);
        for e in 0..2 {
            assert!((gx[e] - gap[e]).abs() < 1e-15);
        }
        let f = g.tr_mul_vec(&[1.7, -0.4]);
        let c = [0.3, -2.0, 5.0];
        let mut sum = [0.0; 3];
        let mut mom = [0.0; 3];
        for (i, p) in pts.iter().enumerate() {
            let fi = [f[3 * i], f[3 * i + 1], f[3 * i + 2]];
            let m = cross([p[0] - c[0], p[1] - c[1], p[2] - c[2]], fi);
            for d in 0..3 {
                sum[d] += fi[d];
                mom[d] += m[d];
            }
        }
        for d in 0..3 {
            assert!(
                sum[d].abs() < 1e-14 && mom[d].abs() < 1e-13,
                "{sum:?} {mom:?}"
            );
        }
    }

    #[test]
    fn errors() {
        let n = [[0.0, 0.0, 1.0]];
        assert!(matches!(
            constraint_matrix(&[0], &[[0, 1, 2]], &[0.1], &[0.1], &n, 4),
            Err(ContactError::SlaveInMaster { pair: 0, node: 0 })
        ));
        assert!(constraint_matrix(&[9], &[[0, 1, 2]], &[0.1], &[0.1], &n, 4).is_err());
        assert!(constraint_matrix(&[3], &[[0, 1, 7]], &[0.1], &[0.1], &n, 4).is_err());
        assert!(constraint_matrix(&[3], &[[0, 1, 2]], &[f64::NAN], &[0.1], &n, 4).is_err());
        assert!(constraint_matrix(&[3], &[[0, 1, 2]], &[0.1], &[0.1], &[[0.0; 3]], 4).is_err());
        assert!(constraint_matrix(&[3], &[[0, 1, 2]], &[0.1], &[], &n, 4).is_err());
        let r = constraint_matrix(&[3], &[[RIGID; 3]], &[0.0], &[0.0], &n, 4).unwrap();
        assert_eq!(r.indices, vec![9, 10, 11]);
    }
}
