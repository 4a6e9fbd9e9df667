//! What is done once per pattern: the checks of the CSC input, faer's symbolic analysis
//! (forced supernodal) in the fill-reducing ordering, and the supernodal structure
//! ([`Supernodes`]) that the numeric factorization and the solves work on.

use super::{internal, Ordering};
use crate::error::SolverError;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::SymbolicSparseColMatRef;
use faer::Side;

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

/// Checks that the matrix is symmetric to round-off (both triangles stored).
pub(super) fn check_symmetric(
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
    // Every off-diagonal entry against its mirror, both triangles: a matrix stored by one
    // triangle only (or with an entry missing on one side) is not symmetric either.
    for j in 0..n {
        for k in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[k];
            if i == j {
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

/// faer's symbolic analysis (forced supernodal) of the n x n pattern (`col_ptr`, `row_idx`)
/// with the fill-reducing `ordering`, and the name of the ordering used.
pub(super) fn analyse(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    ordering: &Ordering,
) -> Result<(SymbolicCholesky<usize>, &'static str), SolverError> {
    let pattern = SymbolicSparseColMatRef::new_checked(n, n, col_ptr, None, row_idx);
    let sym_params = CholeskySymbolicParams {
        // FORCE_SUPERNODAL (0) still gives a simplicial structure when no column has an
        // off-diagonal entry (0 flops > 0 fails); any ratio exceeds -inf.
        supernodal_flop_ratio_threshold: SupernodalThreshold(f64::NEG_INFINITY),
        ..Default::default()
    };
    let factorize = |ord: SymmetricOrdering<'_, usize>| {
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
        factorize(SymmetricOrdering::Custom(PermRef::new_checked(
            order, &inv, n,
        )))
    };
    Ok(match ordering {
        Ordering::Amd => (factorize(SymmetricOrdering::Amd)?, "amd"),
        // faer's Identity path hands the stored pattern to the numeric kernel unchanged, which
        // is wrong when both triangles are stored; an explicit identity permutation makes
        // it read only the lower triangle, like every other ordering.
        Ordering::Identity => (with_custom(&(0..n).collect::<Vec<_>>())?, "identity"),
        Ordering::NestedDissection => (
            with_custom(&crate::linalg::ordering::nested_dissection(
                n, col_ptr, row_idx,
            ))?,
            "nested_dissection",
        ),
        Ordering::Custom(order) => (with_custom(order)?, "custom"),
        Ordering::Auto => {
            // Small matrices: AMD is fine and ND costs more than it saves.
            if n < 3000 {
                (factorize(SymmetricOrdering::Amd)?, "amd")
            } else {
                // Both orderings with their exact nnz(L) from one compressed graph; only
                // the winner gets the (costlier) symbolic analysis.
                let ((nd, nd_nnz), (amd, amd_nnz)) =
                    crate::linalg::ordering::nested_dissection_and_amd(n, col_ptr, row_idx);
                if nd_nnz < amd_nnz {
                    (with_custom(&nd)?, "nested_dissection")
                } else {
                    (with_custom(&amd)?, "amd")
                }
            }
        }
    })
}

/// faer's supernodal structure `sn` with the values `vals`.
pub(super) fn supernodes<'a>(
    sn: &'a faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
    vals: &'a [f64],
) -> Supernodes<'a> {
    Supernodes {
        begin: sn.supernode_begin(),
        end: sn.supernode_end(),
        row_ptr: sn.col_ptr_for_row_idx(),
        row_idx: sn.row_idx(),
        val_ptr: sn.col_ptr_for_val(),
        vals,
    }
}

/// The supernodal structure of `symbolic`: faer's, or none at all for a 0 x 0 matrix (for
/// which faer's analysis is simplicial whatever the threshold).
pub(super) fn structure<'a>(
    symbolic: &'a SymbolicCholesky<usize>,
    vals: &'a [f64],
) -> Result<Supernodes<'a>, SolverError> {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(sn) => Ok(supernodes(sn, vals)),
        SymbolicCholeskyRaw::Simplicial(_) if symbolic.nrows() == 0 => Ok(Supernodes {
            begin: &[],
            end: &[],
            row_ptr: &[0],
            row_idx: &[],
            val_ptr: &[0],
            vals,
        }),
        SymbolicCholeskyRaw::Simplicial(_) => Err(internal("faer returned a simplicial structure")),
    }
}

/// The supernodal structure of L (faer's layout): supernode s has the columns
/// `begin[s]..end[s]`, the off-diagonal row indices `row_idx[row_ptr[s]..row_ptr[s + 1]]`
/// and its values column-major (the full square diagonal block on top) at
/// `vals[val_ptr[s]..val_ptr[s + 1]]`.
pub(super) struct Supernodes<'a> {
    pub begin: &'a [usize],
    pub end: &'a [usize],
    pub row_ptr: &'a [usize],
    pub row_idx: &'a [usize],
    pub val_ptr: &'a [usize],
    pub vals: &'a [f64],
}

impl Supernodes<'_> {
    /// Checks what the unchecked kernels rely on; returns the largest supernode row
    /// count (the work size per right-hand side), or None if the structure is not a
    /// consistent partition of 0..n with sorted row patterns below each supernode.
    pub(super) fn validate(&self, n: usize) -> Option<usize> {
        let ns = self.begin.len();
        if self.end.len() != ns || self.row_ptr.len() != ns + 1 || self.val_ptr.len() != ns + 1 {
            return None;
        }
        let mut next = 0;
        let mut max_nr = 0;
        for s in 0..ns {
            let (f, l) = (self.begin[s], self.end[s]);
            let (r0, r1) = (self.row_ptr[s], self.row_ptr[s + 1]);
            let (v0, v1) = (self.val_ptr[s], self.val_ptr[s + 1]);
            if f != next || l <= f || r1 < r0 || r1 > self.row_idx.len() || v1 < v0 {
                return None;
            }
            let nr = (l - f) + (r1 - r0);
            if v1 - v0 != nr * (l - f) || v1 > self.vals.len() {
                return None;
            }
            let pat = &self.row_idx[r0..r1];
            if pat.iter().any(|&i| i < l || i >= n) || pat.windows(2).any(|p| p[0] >= p[1]) {
                return None;
            }
            max_nr = max_nr.max(nr);
            next = l;
        }
        (next == n).then_some(max_nr)
    }
}
