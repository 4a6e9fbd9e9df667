//! Sparse Cholesky (LL^T) on faer: symbolic analysis once, numeric refactorization in place,
//! allocation-free solves.

use crate::error::SolverError;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::mat::MatMut;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};

/// Fill-reducing ordering.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Ordering {
    /// Try AMD and nested dissection, keep the one with the smaller factor.
    #[default]
    Auto,
    /// faer's approximate minimum degree.
    Amd,
    /// Nested dissection from the matrix graph ([`crate::ordering`]).
    NestedDissection,
    /// No reordering.
    Identity,
    /// A user permutation: `order[k]` is the original index eliminated k-th.
    Custom(Vec<usize>),
}

/// Parameters of the factorization.
#[derive(Debug, Clone, PartialEq)]
pub struct CholeskyParams {
    /// Fill-reducing ordering.
    pub ordering: Ordering,
    /// Use all rayon threads for the numeric factorization (solves stay sequential: one
    /// substitution is memory-bound and threads do not pay there).
    pub parallel: bool,
    /// Check that the matrix is symmetric (cost O(nnz log)).
    pub check_symmetry: bool,
}

impl Default for CholeskyParams {
    fn default() -> Self {
        Self {
            ordering: Ordering::Auto,
            parallel: true,
            check_symmetry: true,
        }
    }
}

/// A sparse LL^T factorization of a symmetric positive definite matrix (lower triangle read).
pub struct Cholesky {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
    solve_cols: usize,
    par: Par,
    check_symmetry: bool,
    ordering_used: &'static str,
}

impl std::fmt::Debug for Cholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Cholesky")
            .field("n", &self.n)
            .field("nnz_a", &self.row_idx.len())
            .field("nnz_l", &self.l_values.len())
            .field("ordering", &self.ordering_used)
            .finish()
    }
}

fn internal<E: std::fmt::Debug>(e: E) -> SolverError {
    SolverError::Internal {
        reason: format!("{e:?}"),
    }
}

/// Checks that (`col_ptr`, `row_idx`) is a valid n x n CSC pattern with sorted, unique rows.
pub fn check_pattern(n: usize, col_ptr: &[usize], row_idx: &[usize]) -> Result<(), SolverError> {
    let bad = |reason: String| Err(SolverError::BadMatrix { reason });
    if col_ptr.len() != n + 1 {
        return bad(format!(
            "column pointer array has length {}, expected n + 1 = {}",
            col_ptr.len(),
            n + 1
        ));
    }
    if col_ptr[0] != 0 || col_ptr[n] != row_idx.len() {
        return bad(format!(
            "column pointers must run from 0 to nnz = {}",
            row_idx.len()
        ));
    }
    for j in 0..n {
        if col_ptr[j + 1] < col_ptr[j] {
            return bad(format!("column pointers decrease at column {j}"));
        }
        let col = &row_idx[col_ptr[j]..col_ptr[j + 1]];
        for (k, &i) in col.iter().enumerate() {
            if i >= n {
                return bad(format!(
                    "row index {i} in column {j} is out of range (n = {n})"
                ));
            }
            if k > 0 && col[k - 1] >= i {
                return bad(format!(
                    "row indices of column {j} are not sorted and unique"
                ));
            }
        }
    }
    Ok(())
}

fn check_symmetric(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    values: &[f64],
) -> Result<(), SolverError> {
    // Round-off is relative to the size of the diagonal entries an off-diagonal couples
    // (|a_ij| <= sqrt(a_ii a_jj) for an SPD matrix), not to the entry itself: assembly leaves
    // entries that should vanish at 1e-20 with mirrors that differ by as much.
    let diag: Vec<f64> = (0..n)
        .map(|j| {
            let col = &row_idx[col_ptr[j]..col_ptr[j + 1]];
            col.binary_search(&j)
                .map(|p| values[col_ptr[j] + p].abs())
                .unwrap_or(0.0)
        })
        .collect();
    for j in 0..n {
        for k in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[k];
            if i <= j {
                continue;
            }
            let col = &row_idx[col_ptr[i]..col_ptr[i + 1]];
            let mirror = col
                .binary_search(&j)
                .map(|p| values[col_ptr[i] + p])
                .unwrap_or(0.0);
            let v = values[k];
            let scale = v.abs().max(mirror.abs()).max((diag[i] * diag[j]).sqrt());
            if (v - mirror).abs() > 1e-12 * scale {
                return Err(SolverError::NotSymmetric {
                    row: i,
                    col: j,
                    value: v,
                    mirror,
                });
            }
        }
    }
    Ok(())
}

impl Cholesky {
    /// Analyses and factors the n x n CSC matrix (`col_ptr`, `row_idx`, `values`).
    ///
    /// ```
    /// use vfrs_core::{Cholesky, CholeskyParams};
    /// // [[4, 1], [1, 3]]
    /// let mut f = Cholesky::new(2, &[0, 2, 4], &[0, 1, 0, 1], &[4.0, 1.0, 1.0, 3.0], CholeskyParams::default()).unwrap();
    /// let mut b = [1.0, 2.0];
    /// f.solve_in_place(&mut b, 1).unwrap();
    /// assert!((4.0 * b[0] + b[1] - 1.0).abs() < 1e-14 && (b[0] + 3.0 * b[1] - 2.0).abs() < 1e-14);
    /// ```
    pub fn new(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        values: &[f64],
        params: CholeskyParams,
    ) -> Result<Self, SolverError> {
        check_pattern(n, col_ptr, row_idx)?;
        if values.len() != row_idx.len() {
            return Err(SolverError::BadMatrix {
                reason: format!(
                    "{} values for {} stored entries",
                    values.len(),
                    row_idx.len()
                ),
            });
        }
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, col_ptr, None, row_idx);
        let sym_params = CholeskySymbolicParams::default();
        let analyse = |ord: SymmetricOrdering<'_, usize>| {
            factorize_symbolic_cholesky(pattern, Side::Lower, ord, sym_params).map_err(internal)
        };
        let with_custom = |order: &[usize]| -> Result<SymbolicCholesky<usize>, SolverError> {
            if order.len() != n {
                return Err(SolverError::BadMatrix {
                    reason: format!("custom ordering has length {}, expected {n}", order.len()),
                });
            }
            let mut inv = vec![usize::MAX; n];
            for (k, &i) in order.iter().enumerate() {
                if i >= n || inv[i] != usize::MAX {
                    return Err(SolverError::BadMatrix {
                        reason: format!("custom ordering is not a permutation (entry {k} = {i})"),
                    });
                }
                inv[i] = k;
            }
            analyse(SymmetricOrdering::Custom(PermRef::new_checked(
                order, &inv, n,
            )))
        };
        let (symbolic, ordering_used) = match &params.ordering {
            Ordering::Amd => (analyse(SymmetricOrdering::Amd)?, "amd"),
            // faer's Identity path hands the stored pattern to the numeric kernel unchanged, which
            // is wrong when both triangles are stored; an explicit identity permutation makes
            // it read only the lower triangle, like every other ordering.
            Ordering::Identity => (with_custom(&(0..n).collect::<Vec<_>>())?, "identity"),
            Ordering::NestedDissection => (
                with_custom(&crate::ordering::nested_dissection(n, col_ptr, row_idx))?,
                "nested_dissection",
            ),
            Ordering::Custom(order) => (with_custom(order)?, "custom"),
            Ordering::Auto => {
                // Small matrices: AMD is fine and ND costs more than it saves.
                if n < 3000 {
                    (analyse(SymmetricOrdering::Amd)?, "amd")
                } else {
                    // Both orderings with their exact nnz(L) from one compressed graph; only
                    // the winner gets the (costlier) symbolic analysis.
                    let ((nd, nd_nnz), (amd, amd_nnz)) =
                        crate::ordering::nested_dissection_and_amd(n, col_ptr, row_idx);
                    if nd_nnz < amd_nnz {
                        (with_custom(&nd)?, "nested_dissection")
                    } else {
                        (with_custom(&amd)?, "amd")
                    }
                }
            }
        };
        let par = if params.parallel {
            Par::rayon(0)
        } else {
            Par::Seq
        };
        let factor_req = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let factor_mem = MemBuffer::try_new(factor_req).map_err(internal)?;
        let solve_mem = MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq))
            .map_err(internal)?;
        let l_values = vec![0.0; symbolic.len_val()];
        let mut this = Self {
            n,
            col_ptr: col_ptr.to_vec(),
            row_idx: row_idx.to_vec(),
            symbolic,
            l_values,
            factor_mem,
            solve_mem,
            solve_cols: 1,
            par,
            check_symmetry: params.check_symmetry,
            ordering_used,
        };
        this.refactor(values)?;
        Ok(this)
    }

    /// Numeric refactorization with new values on the same pattern (no allocation).
    pub fn refactor(&mut self, values: &[f64]) -> Result<(), SolverError> {
        if values.len() != self.row_idx.len() {
            return Err(SolverError::PatternMismatch {
                reason: format!(
                    "{} values given, the pattern has {}",
                    values.len(),
                    self.row_idx.len()
                ),
            });
        }
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(SolverError::BadMatrix {
                reason: format!("stored entry {k} is not finite ({})", values[k]),
            });
        }
        if self.check_symmetry {
            check_symmetric(self.n, &self.col_ptr, &self.row_idx, values)?;
        }
        let a = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(
                self.n,
                self.n,
                &self.col_ptr,
                None,
                &self.row_idx,
            ),
            values,
        );
        let stack = MemStack::new(&mut self.factor_mem);
        self.symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                a,
                Side::Lower,
                LltRegularization::default(),
                self.par,
                stack,
                Default::default(),
            )
            .map_err(|e| match e {
                faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                    SolverError::NotPositiveDefinite { row: index }
                }
            })?;
        Ok(())
    }

    /// Refactorization that first checks the pattern is the one analysed.
    pub fn refactor_with_pattern(
        &mut self,
        col_ptr: &[usize],
        row_idx: &[usize],
        values: &[f64],
    ) -> Result<(), SolverError> {
        if col_ptr != self.col_ptr.as_slice() || row_idx != self.row_idx.as_slice() {
            let reason = if col_ptr.len() != self.col_ptr.len() {
                format!(
                    "matrix size {} differs from {}",
                    col_ptr.len().saturating_sub(1),
                    self.n
                )
            } else {
                match (0..self.n).find(|&j| {
                    col_ptr[j + 1] != self.col_ptr[j + 1]
                        || row_idx.get(col_ptr[j]..col_ptr[j + 1])
                            != self.row_idx.get(self.col_ptr[j]..self.col_ptr[j + 1])
                }) {
                    Some(j) => format!("column {j} has other stored rows"),
                    None => "stored entries differ".into(),
                }
            };
            return Err(SolverError::PatternMismatch { reason });
        }
        self.refactor(values)
    }

    /// Solves A X = B in place; `rhs` is column-major n x `ncols`. Allocates only when
    /// `ncols` exceeds every previous call's.
    pub fn solve_in_place(&mut self, rhs: &mut [f64], ncols: usize) -> Result<(), SolverError> {
        if rhs.len() != self.n * ncols {
            return Err(SolverError::BadRhs {
                reason: format!(
                    "{} values for {} x {} right-hand sides",
                    rhs.len(),
                    self.n,
                    ncols
                ),
            });
        }
        if ncols > self.solve_cols {
            let req: StackReq = self.symbolic.solve_in_place_scratch::<f64>(ncols, Par::Seq);
            self.solve_mem = MemBuffer::try_new(req).map_err(internal)?;
            self.solve_cols = ncols;
        }
        if ncols == 0 || self.n == 0 {
            return Ok(());
        }
        let x = MatMut::from_column_major_slice_mut(rhs, self.n, ncols);
        let llt = LltRef::new(&self.symbolic, &self.l_values);
        llt.solve_in_place_with_conj(Conj::No, x, Par::Seq, MemStack::new(&mut self.solve_mem));
        Ok(())
    }

    /// Matrix size.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Stored entries of the factor L.
    pub fn nnz_factor(&self) -> usize {
        self.l_values.len()
    }

    /// The ordering actually used ("amd", "nested_dissection", ...).
    pub fn ordering(&self) -> &'static str {
        self.ordering_used
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 3-D Laplacian-like SPD matrix on a k^3 grid (7-point stencil + shift).
    fn grid(k: usize) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
        let n = k * k * k;
        let id = |x: usize, y: usize, z: usize| x + k * (y + k * z);
        let mut cp = vec![0];
        let mut ri = vec![];
        let mut v = vec![];
        for z in 0..k {
            for y in 0..k {
                for x in 0..k {
                    let mut col = vec![(id(x, y, z), 6.5)];
                    if x > 0 {
                        col.push((id(x - 1, y, z), -1.0));
                    }
                    if x + 1 < k {
                        col.push((id(x + 1, y, z), -1.0));
                    }
                    if y > 0 {
                        col.push((id(x, y - 1, z), -1.0));
                    }
                    if y + 1 < k {
                        col.push((id(x, y + 1, z), -1.0));
                    }
                    if z > 0 {
                        col.push((id(x, y, z - 1), -1.0));
                    }
                    if z + 1 < k {
                        col.push((id(x, y, z + 1), -1.0));
                    }
                    col.sort_by_key(|e| e.0);
                    for (i, a) in col {
                        ri.push(i);
                        v.push(a);
                    }
                    cp.push(ri.len());
                }
            }
        }
        (n, cp, ri, v)
    }

    fn matvec(n: usize, cp: &[usize], ri: &[usize], v: &[f64], x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; n];
        for j in 0..n {
            for k in cp[j]..cp[j + 1] {
                y[ri[k]] += v[k] * x[j];
            }
        }
        y
    }

    #[test]
    fn every_ordering_solves_to_round_off() {
        let (n, cp, ri, v) = grid(16);
        let b: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        for ordering in [
            Ordering::Amd,
            Ordering::NestedDissection,
            Ordering::Identity,
            Ordering::Auto,
        ] {
            let mut f = Cholesky::new(
                n,
                &cp,
                &ri,
                &v,
                CholeskyParams {
                    ordering: ordering.clone(),
                    ..Default::default()
                },
            )
            .unwrap();
            let mut x = b.clone();
            f.solve_in_place(&mut x, 1).unwrap();
            let r = matvec(n, &cp, &ri, &v, &x);
            let err: f64 = r
                .iter()
                .zip(&b)
                .map(|(a, c)| (a - c).powi(2))
                .sum::<f64>()
                .sqrt();
            let nb: f64 = b.iter().map(|c| c * c).sum::<f64>().sqrt();
            assert!(err < 1e-12 * nb, "{ordering:?}: residual {err}");
        }
    }

    #[test]
    fn nested_dissection_has_less_fill_than_amd_on_a_3d_grid() {
        let (n, cp, ri, v) = grid(24);
        let amd = Cholesky::new(
            n,
            &cp,
            &ri,
            &v,
            CholeskyParams {
                ordering: Ordering::Amd,
                ..Default::default()
            },
        )
        .unwrap();
        let nd = Cholesky::new(
            n,
            &cp,
            &ri,
            &v,
            CholeskyParams {
                ordering: Ordering::NestedDissection,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(
            nd.nnz_factor() < amd.nnz_factor(),
            "nd {} amd {}",
            nd.nnz_factor(),
            amd.nnz_factor()
        );
    }

    #[test]
    fn refactor_equals_fresh_factor_and_errors_are_typed() {
        let (n, cp, ri, v) = grid(6);
        let mut f = Cholesky::new(n, &cp, &ri, &v, CholeskyParams::default()).unwrap();
        let v2: Vec<f64> = v.iter().map(|a| 2.0 * a).collect();
        f.refactor(&v2).unwrap();
        let mut g = Cholesky::new(n, &cp, &ri, &v2, CholeskyParams::default()).unwrap();
        let mut x1 = vec![1.0; 2 * n];
        let mut x2 = x1.clone();
        f.solve_in_place(&mut x1, 2).unwrap();
        g.solve_in_place(&mut x2, 2).unwrap();
        assert_eq!(x1, x2);
        // Not positive definite.
        let neg: Vec<f64> = v.iter().map(|a| -a).collect();
        assert!(matches!(
            f.refactor(&neg),
            Err(SolverError::NotPositiveDefinite { .. })
        ));
        // Not symmetric.
        let mut ns = v.clone();
        ns[1] += 0.5;
        assert!(matches!(
            Cholesky::new(n, &cp, &ri, &ns, CholeskyParams::default()),
            Err(SolverError::NotSymmetric { .. })
        ));
        // Wrong rhs size, wrong pattern, bad pattern.
        assert!(f.solve_in_place(&mut [0.0; 3], 1).is_err());
        assert!(f.refactor_with_pattern(&cp[..n], &ri, &v).is_err());
        assert!(Cholesky::new(
            2,
            &[0, 1, 2],
            &[0, 5],
            &[1.0, 1.0],
            CholeskyParams::default()
        )
        .is_err());
        let mut nan = v.clone();
        nan[0] = f64::NAN;
        assert!(f.refactor(&nan).is_err());
    }
}
