//! Products of the node-blocked sparse matrices of a P1 mesh with vectors.
//!
//! The stiffness of a mesh with three DOFs per node (node-major) is made of full 3 x 3 blocks:
//! the three rows of a node share their columns, which come in the three DOFs of each
//! neighbour node. The consistent mass couples x with x only, with one number per node pair:
//! it is `m (x) I_3`. A CSR product reads a column index per entry (4 bytes beside 8 of value);
//! here the stiffness keeps one index per block (a ninth of them) and the mass one value and
//! one index per node pair (a third of the values). The products are bound by memory, so they
//! read less and run faster.
//!
//! Every entry of a result is summed as a row-by-row CSR product of the same matrix sums it:
//! from 0.0, `a_i0 x_0 + a_i1 x_1 + ...` in the stored (column) order, and a sum of two
//! products as each product's row sum, then their sum. So the numbers are bit for bit those
//! of `A @ x` (and of `r = A @ x; r += B @ y`) in scipy.

use crate::error::SolverError;

/// A node-blocked matrix with `3 n` rows (see the module docs).
#[derive(Debug, Clone)]
pub enum Blocked {
    /// Full 3 x 3 blocks: block row `a` has the block columns `bcols[bptr[a]..bptr[a + 1]]`;
    /// block `k` of the matrix holds its nine values at `data[9 k..9 k + 9]`, row by row (one
    /// stream through memory for the product, which is bound by it).
    Full {
        /// Per block row, where its block columns start in `bcols`.
        bptr: Vec<usize>,
        /// Block column indices.
        bcols: Vec<u32>,
        /// The values, block by block.
        data: Vec<f64>,
        /// Block columns.
        ncols: usize,
    },
    /// `m (x) I_3`: node row `a` has the node columns `cols[ptr[a]..ptr[a + 1]]` with `vals`.
    Kron {
        /// Per node row, where its entries start.
        ptr: Vec<usize>,
        /// Node column indices.
        cols: Vec<u32>,
        /// One value per node pair.
        vals: Vec<f64>,
        /// Node columns.
        ncols: usize,
    },
}

fn bad<T>(reason: String) -> Result<T, SolverError> {
    Err(SolverError::BadRhs { reason })
}

fn bad_matrix<T>(reason: String) -> Result<T, SolverError> {
    Err(SolverError::BadMatrix { reason })
}

/// The CSR row `r`'s column indices and values.
fn row<'a>(
    indptr: &[usize],
    indices: &'a [usize],
    data: &'a [f64],
    r: usize,
) -> (&'a [usize], &'a [f64]) {
    (
        &indices[indptr[r]..indptr[r + 1]],
        &data[indptr[r]..indptr[r + 1]],
    )
}

fn check_csr(
    cols: usize,
    indptr: &[usize],
    indices: &[usize],
    data: &[f64],
) -> Result<usize, SolverError> {
    let rows = indptr.len().saturating_sub(1);
    if indptr.is_empty()
        || indptr[0] != 0
        || indptr[rows] != data.len()
        || indices.len() != data.len()
    {
        return bad_matrix(format!(
            "CSR arrays: indptr of {} entries, {} column indices, {} values",
            indptr.len(),
            indices.len(),
            data.len()
        ));
    }
    if indptr.windows(2).any(|w| w[0] > w[1]) {
        return bad_matrix("CSR indptr decreases".into());
    }
    if indices.iter().any(|&j| j >= cols) {
        return bad_matrix(format!("a column index is not below the {cols} columns"));
    }
    if !rows.is_multiple_of(3) || !cols.is_multiple_of(3) || cols / 3 > u32::MAX as usize {
        return bad_matrix(format!(
            "a {rows} x {cols} matrix is not one of 3 DOFs per node"
        ));
    }
    Ok(rows)
}

impl Blocked {
    /// The CSR matrix (`cols` columns) as full 3 x 3 blocks, or None if it is not one.
    pub fn full(
        cols: usize,
        indptr: &[usize],
        indices: &[usize],
        data: &[f64],
    ) -> Result<Option<Self>, SolverError> {
        let rows = check_csr(cols, indptr, indices, data)?;
        let (mut bptr, mut bcols) = (vec![0], Vec::new());
        let mut blocks = Vec::with_capacity(data.len());
        for a in 0..rows / 3 {
            let node = [0, 1, 2].map(|d| row(indptr, indices, data, 3 * a + d));
            let c0 = node[0].0;
            if c0.len() % 3 != 0 || node[1].0 != c0 || node[2].0 != c0 {
                return Ok(None);
            }
            for (k, t) in c0.chunks_exact(3).enumerate() {
                if t[0] % 3 != 0 || t[1] != t[0] + 1 || t[2] != t[0] + 2 {
                    return Ok(None);
                }
                bcols.push((t[0] / 3) as u32);
                for (_, v) in &node {
                    blocks.extend_from_slice(&v[3 * k..3 * k + 3]);
                }
            }
            bptr.push(bcols.len());
        }
        Ok(Some(Blocked::Full {
            bptr,
            bcols,
            data: blocks,
            ncols: cols / 3,
        }))
    }

    /// The CSR matrix (`cols` columns) as `m (x) I_3` (every row's entries in its own
    /// component's columns, the three rows of a node alike bit for bit), or None.
    pub fn kron(
        cols: usize,
        indptr: &[usize],
        indices: &[usize],
        data: &[f64],
    ) -> Result<Option<Self>, SolverError> {
        let rows = check_csr(cols, indptr, indices, data)?;
        let (mut ptr, mut ncol, mut vals) = (vec![0], Vec::new(), Vec::new());
        for a in 0..rows / 3 {
            let (c0, v0) = row(indptr, indices, data, 3 * a);
            for d in 0..3 {
                let (c, v) = row(indptr, indices, data, 3 * a + d);
                if c.len() != c0.len()
                    || c.iter()
                        .zip(c0)
                        .any(|(&j, &j0)| j % 3 != d || j / 3 != j0 / 3)
                    || v.iter().zip(v0).any(|(x, y)| x.to_bits() != y.to_bits())
                {
                    return Ok(None);
                }
            }
            ncol.extend(c0.iter().map(|&j| (j / 3) as u32));
            vals.extend_from_slice(v0);
            ptr.push(ncol.len());
        }
        Ok(Some(Blocked::Kron {
            ptr,
            cols: ncol,
            vals,
            ncols: cols / 3,
        }))
    }

    /// Rows (3 per node).
    pub fn rows(&self) -> usize {
        match self {
            Blocked::Full { bptr, .. } => 3 * (bptr.len() - 1),
            Blocked::Kron { ptr, .. } => 3 * (ptr.len() - 1),
        }
    }

    /// Columns (3 per node).
    pub fn cols(&self) -> usize {
        match self {
            Blocked::Full { ncols, .. } | Blocked::Kron { ncols, .. } => 3 * ncols,
        }
    }

    /// The three row sums of node row `a` against `x`.
    #[inline]
    fn node_row(&self, a: usize, x: &[f64]) -> [f64; 3] {
        let mut s = [0.0f64; 3];
        match self {
            Blocked::Full {
                bptr, bcols, data, ..
            } => {
                let (lo, hi) = (bptr[a], bptr[a + 1]);
                for (&b, w) in bcols[lo..hi]
                    .iter()
                    .zip(data[9 * lo..9 * hi].chunks_exact(9))
                {
                    let j = 3 * b as usize;
                    let xb = &x[j..j + 3];
                    for d in 0..3 {
                        s[0] += w[d] * xb[d];
                        s[1] += w[3 + d] * xb[d];
                        s[2] += w[6 + d] * xb[d];
                    }
                }
            }
            Blocked::Kron {
                ptr, cols, vals, ..
            } => {
                for (&b, &m) in cols[ptr[a]..ptr[a + 1]]
                    .iter()
                    .zip(&vals[ptr[a]..ptr[a + 1]])
                {
                    let j = 3 * b as usize;
                    let xb = &x[j..j + 3];
                    s[0] += m * xb[0];
                    s[1] += m * xb[1];
                    s[2] += m * xb[2];
                }
            }
        }
        s
    }
}

/// `out = sum_k A_k x_k`, each product summed row by row from 0.0, then the products added in
/// order (`r = A_0 @ x_0; r += A_1 @ x_1; ...` in scipy, bit for bit).
pub fn sum_of_products(terms: &[(&Blocked, &[f64])], out: &mut [f64]) -> Result<(), SolverError> {
    if terms.is_empty() {
        return bad("no product to sum".into());
    }
    for (k, (a, x)) in terms.iter().enumerate() {
        if a.rows() != out.len() || a.cols() != x.len() {
            return bad(format!(
                "term {k}: a {} x {} matrix times a vector of {} into {} rows",
                a.rows(),
                a.cols(),
                x.len(),
                out.len()
            ));
        }
    }
    for (a, o) in out.chunks_exact_mut(3).enumerate() {
        let mut s = terms[0].0.node_row(a, terms[0].1);
        for (m, x) in &terms[1..] {
            let t = m.node_row(a, x);
            for d in 0..3 {
                s[d] += t[d];
            }
        }
        o.copy_from_slice(&s);
    }
    Ok(())
}

/// Checks a general CSR matrix (`cols` columns) and returns its row count.
fn check_general(
    cols: usize,
    indptr: &[usize],
    indices: &[usize],
    data: &[f64],
) -> Result<usize, SolverError> {
    let rows = indptr.len().saturating_sub(1);
    if indptr.is_empty()
        || indptr[0] != 0
        || indptr[rows] != data.len()
        || indices.len() != data.len()
        || indptr.windows(2).any(|w| w[0] > w[1])
    {
        return bad_matrix(format!(
            "CSR arrays: indptr of {} entries, {} column indices, {} values",
            indptr.len(),
            indices.len(),
            data.len()
        ));
    }
    if let Some(&j) = indices.iter().find(|&&j| j >= cols) {
        return bad_matrix(format!("column index {j} is not below the {cols} columns"));
    }
    Ok(rows)
}

/// `out = A x` for a general CSR matrix `A` (`cols` columns): each row summed from 0 in its
/// stored order, as scipy's CSR product sums it (the same bits). Used for the contact
/// constraint matrix G (gaps `G x`), a few hundred rows built every detection round, where
/// a scipy matrix's construction cost more than the product.
pub fn csr_matvec(
    cols: usize,
    indptr: &[usize],
    indices: &[usize],
    data: &[f64],
    x: &[f64],
    out: &mut [f64],
) -> Result<(), SolverError> {
    let rows = check_general(cols, indptr, indices, data)?;
    if x.len() != cols || out.len() != rows {
        return bad(format!(
            "a {rows} x {cols} product with a vector of {} into {}",
            x.len(),
            out.len()
        ));
    }
    for (r, o) in out.iter_mut().enumerate() {
        let (ix, v) = row(indptr, indices, data, r);
        let mut s = 0.0;
        for (&j, &a) in ix.iter().zip(v) {
            s += a * x[j];
        }
        *o = s;
    }
    Ok(())
}

/// `out = A^T y` for a general CSR matrix `A` (`cols` columns; `out` has `cols` entries and
/// is overwritten): the rows scattered in order, as scipy's `A.T @ y` adds them (the same
/// bits). The contact forces `G^T lambda`.
pub fn csr_rmatvec(
    cols: usize,
    indptr: &[usize],
    indices: &[usize],
    data: &[f64],
    y: &[f64],
    out: &mut [f64],
) -> Result<(), SolverError> {
    let rows = check_general(cols, indptr, indices, data)?;
    if y.len() != rows || out.len() != cols {
        return bad(format!(
            "a transposed {rows} x {cols} product with a vector of {} into {}",
            y.len(),
            out.len()
        ));
    }
    out.fill(0.0);
    for (r, &yr) in y.iter().enumerate() {
        let (ix, v) = row(indptr, indices, data, r);
        for (&j, &a) in ix.iter().zip(v) {
            out[j] += a * yr;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CSR arrays of a node-blocked matrix on a band of `n` nodes: full 3 x 3 blocks, or
    /// (`kron`) one value per node pair on the diagonal of the block.
    fn banded(n: usize, half: usize, kron: bool) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let (mut indptr, mut indices, mut data) = (vec![0], vec![], vec![]);
        for i in 0..3 * n {
            let a = i / 3;
            for b in a.saturating_sub(half)..(a + half + 1).min(n) {
                for d in 0..3 {
                    if kron && d != i % 3 {
                        continue;
                    }
                    let j = 3 * b + d;
                    indices.push(j);
                    // The mass: one value per node pair (the same in its three rows).
                    let (key, phase) = if kron {
                        (a * 7 + b * 3, b)
                    } else {
                        (i * 7 + j * 3, j)
                    };
                    data.push(1.0 / (1.0 + key as f64) - 0.01 * (phase as f64).sin());
                }
            }
            indptr.push(indices.len());
        }
        (indptr, indices, data)
    }

    fn csr_product(m: &(Vec<usize>, Vec<usize>, Vec<f64>), x: &[f64]) -> Vec<f64> {
        let (ip, ix, d) = m;
        (0..ip.len() - 1)
            .map(|i| {
                let mut s = 0.0;
                for k in ip[i]..ip[i + 1] {
                    s += d[k] * x[ix[k]];
                }
                s
            })
            .collect()
    }

    #[test]
    fn equals_the_row_by_row_csr_product_bit_for_bit() {
        let n = 3000;
        let (k, m) = (banded(n, 5, false), banded(n, 4, true));
        let kb = Blocked::full(3 * n, &k.0, &k.1, &k.2)
            .expect("valid")
            .expect("blocked");
        let mb = Blocked::kron(3 * n, &m.0, &m.1, &m.2)
            .expect("valid")
            .expect("kron");
        let x: Vec<f64> = (0..3 * n).map(|i| ((i as f64) * 0.37).cos()).collect();
        let y: Vec<f64> = (0..3 * n)
            .map(|i| ((i as f64) * 0.11).sin() * 1e3)
            .collect();
        let (kx, my) = (csr_product(&k, &x), csr_product(&m, &y));
        let mut out = vec![f64::NAN; 3 * n];
        sum_of_products(&[(&kb, &x)], &mut out).expect("valid");
        assert!(out.iter().zip(&kx).all(|(o, r)| o.to_bits() == r.to_bits()));
        sum_of_products(&[(&mb, &y), (&kb, &x)], &mut out).expect("valid");
        assert!(out
            .iter()
            .zip(my.iter().zip(&kx))
            .all(|(o, (a, b))| o.to_bits() == (a + b).to_bits()));
    }

    #[test]
    fn other_patterns_are_not_taken_for_blocks() {
        let (ip, ix, d) = banded(10, 2, false);
        // The mass pattern is not full blocks, the stiffness not m (x) I_3.
        let (mi, mx, md) = banded(10, 2, true);
        assert!(Blocked::full(30, &mi, &mx, &md).expect("valid").is_none());
        assert!(Blocked::kron(30, &ip, &ix, &d).expect("valid").is_none());
        // One value of a node's second row changed: no longer m (x) I_3.
        let mut md2 = md.clone();
        md2[mi[1]] += 1e-9;
        assert!(Blocked::kron(30, &mi, &mx, &md2).expect("valid").is_none());
        // Bad arrays and shapes are errors.
        assert!(Blocked::full(29, &ip, &ix, &d).is_err());
        assert!(Blocked::full(30, &ip[..5], &ix, &d).is_err());
        let kb = Blocked::full(30, &ip, &ix, &d)
            .expect("valid")
            .expect("blocked");
        let mut out = vec![0.0; 30];
        assert!(sum_of_products(&[(&kb, &[0.0; 27])], &mut out).is_err());
        assert!(sum_of_products(&[], &mut out).is_err());
    }

    #[test]
    fn general_csr_products_are_row_sums_and_row_scatters() {
        // [[1, 0, 2], [0, 3, 0]] and its transpose.
        let (ip, ix, v) = ([0, 2, 3], [0, 2, 1], [1.0, 2.0, 3.0]);
        let mut y = [0.0; 2];
        csr_matvec(3, &ip, &ix, &v, &[1.0, 10.0, 100.0], &mut y).expect("valid");
        assert_eq!(y, [201.0, 30.0]);
        let mut z = [9.0; 3];
        csr_rmatvec(3, &ip, &ix, &v, &[1.0, 2.0], &mut z).expect("valid");
        assert_eq!(z, [1.0, 6.0, 2.0]);
        assert!(csr_matvec(2, &ip, &ix, &v, &[1.0, 1.0], &mut y).is_err()); // index 2 of 2 columns
        assert!(csr_rmatvec(3, &ip, &ix, &v, &[1.0], &mut z).is_err());
        assert!(csr_matvec(3, &[0, 5], &ix, &v, &[1.0; 3], &mut y[..1]).is_err());
    }
}
