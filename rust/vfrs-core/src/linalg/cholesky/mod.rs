//! Sparse Cholesky (LL^T): faer's symbolic analysis once, then our own numeric supernodal
//! refactorization in place ([`factor`]) and allocation-free solves ([`supernodal`]), both
//! with kernels that give the same bits on every x86-64 CPU with AVX2 + FMA.

mod factor;

use crate::error::SolverError;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::SymbolicSparseColMatRef;
use faer::Side;

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
    /// Factor independent subtrees of the elimination tree on the rayon pool (the bits of L
    /// do not depend on it; solves stay sequential: one substitution is memory-bound and
    /// threads do not pay there).
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
    /// faer's symbolic analysis, always supernodal (forced: our numeric factorization and
    /// solves are supernodal only).
    symbolic: SymbolicCholesky<usize>,
    /// The values of L in faer's supernodal layout ([`supernodal::Supernodes`]).
    l_values: Vec<f64>,
    plan: factor::Plan,
    /// Largest supernode row count (the solves' work size per right-hand side), from
    /// [`supernodal::Supernodes::validate`].
    max_nr: usize,
    parallel: bool,
    /// Tests: the portable kernels (factorization and solves) even where AVX2 + FMA exist.
    portable: bool,
    /// Tests: `false` factors with the AVX2 kernels even where AVX-512 exists, and solves
    /// with AVX2's 16 registers even where AVX-512VL gives 32.
    wide: bool,
    /// Solves: the permuted right-hand sides (n x columns) and the gathered rows of one
    /// supernode for a group of up to four right-hand sides.
    solve_x: Vec<f64>,
    solve_work: Vec<f64>,
    /// Sparse right-hand sides: the supernodes the forward pass visits (capacity: all), and
    /// marks (all false between calls) of rows and supernodes.
    reach: Vec<usize>,
    row_mark: Vec<bool>,
    sn_mark: Vec<bool>,
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
fn analyse(
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
            with_custom(&crate::ordering::nested_dissection(n, col_ptr, row_idx))?,
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
                    crate::ordering::nested_dissection_and_amd(n, col_ptr, row_idx);
                if nd_nnz < amd_nnz {
                    (with_custom(&nd)?, "nested_dissection")
                } else {
                    (with_custom(&amd)?, "amd")
                }
            }
        }
    })
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
        let (symbolic, ordering_used) = analyse(n, col_ptr, row_idx, &params.ordering)?;
        let l_values = vec![0.0; symbolic.len_val()];
        let max_nr = structure(&symbolic, &l_values)?
            .validate(n)
            .ok_or_else(|| internal("inconsistent supernodal structure"))?;
        let inv = symbolic.perm().map(|p| p.arrays().1);
        let n_supernodes = structure(&symbolic, &[])?.begin.len();
        let threads = if params.parallel {
            rayon::current_num_threads()
        } else {
            1
        };
        let plan = factor::Plan::new(
            &structure(&symbolic, &[])?,
            n,
            max_nr,
            col_ptr,
            row_idx,
            inv,
            threads,
        )
        .ok_or_else(|| internal("the matrix does not fit its symbolic factor"))?;
        let mut this = Self {
            n,
            col_ptr: col_ptr.to_vec(),
            row_idx: row_idx.to_vec(),
            symbolic,
            l_values,
            plan,
            max_nr,
            parallel: params.parallel,
            portable: false,
            wide: true,
            solve_x: Vec::new(),
            solve_work: vec![0.0; 4 * max_nr],
            reach: Vec::with_capacity(n_supernodes),
            row_mark: vec![false; n],
            sn_mark: vec![false; n_supernodes],
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
        self.plan
            .factor(
                &structure(&self.symbolic, &[])?,
                &mut self.l_values,
                values,
                self.parallel,
                self.portable,
                self.wide,
            )
            .map_err(|row| SolverError::NotPositiveDefinite { row })
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
    /// `ncols` exceeds every previous call's. The bits of each solution column do not depend
    /// on `ncols` nor on the column's position in `rhs`.
    pub fn solve_in_place(&mut self, rhs: &mut [f64], ncols: usize) -> Result<(), SolverError> {
        self.check_rhs(rhs, ncols)?;
        self.solve_permuted(rhs, ncols, false)
    }

    /// Solves A X = B in place for right-hand sides that are zero outside the rows
    /// `nonzero_rows` (original numbering, any order, repeats allowed), such as unit columns
    /// e_j for columns of A^-1. The forward substitution then visits only the supernodes on
    /// the paths from those rows to the roots of the elimination tree (the others would only
    /// add zeros); the backward one is dense as in [`Self::solve_in_place`].
    ///
    /// Every nonzero of the result has the bits [`Self::solve_in_place`] gives (adding a zero
    /// changes no nonzero value); a zero may come out with the other sign. Errors if a row is
    /// out of range or an entry outside the listed rows is not zero. Allocates only as
    /// [`Self::solve_in_place`] does.
    pub fn solve_sparse_rhs_in_place(
        &mut self,
        rhs: &mut [f64],
        ncols: usize,
        nonzero_rows: &[usize],
    ) -> Result<(), SolverError> {
        self.check_rhs(rhs, ncols)?;
        let n = self.n;
        if let Some(&i) = nonzero_rows.iter().find(|&&i| i >= n) {
            return Err(SolverError::BadRhs {
                reason: format!("nonzero row {i} out of range (n = {n})"),
            });
        }
        for &i in nonzero_rows {
            self.row_mark[i] = true;
        }
        let stray = (0..n * ncols).find(|&t| !self.row_mark[t % n] && rhs[t] != 0.0);
        for &i in nonzero_rows {
            self.row_mark[i] = false;
        }
        if let Some(t) = stray {
            return Err(SolverError::BadRhs {
                reason: format!(
                    "entry {} of column {} is {}, outside the rows listed as nonzero",
                    t % n,
                    t / n,
                    rhs[t]
                ),
            });
        }
        // The supernodes reached from the listed rows, in increasing order.
        let sn = structure(&self.symbolic, &[])?;
        let inv = self.symbolic.perm().map(|p| p.arrays().1);
        let parent = self.plan.parent();
        self.reach.clear();
        for &i in nonzero_rows {
            let c = inv.map_or(i, |p| p[i]);
            let mut s = sn.end.partition_point(|&e| e <= c);
            while s != usize::MAX && !self.sn_mark[s] {
                self.sn_mark[s] = true;
                self.reach.push(s);
                s = parent[s];
            }
        }
        for &s in &self.reach {
            self.sn_mark[s] = false;
        }
        self.reach.sort_unstable();
        self.solve_permuted(rhs, ncols, true)
    }

    fn check_rhs(&self, rhs: &[f64], ncols: usize) -> Result<(), SolverError> {
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
        Ok(())
    }

    /// x = P b, the supernodal solve (forward over `self.reach` if `sparse`), b = P^T x.
    fn solve_permuted(
        &mut self,
        rhs: &mut [f64],
        ncols: usize,
        sparse: bool,
    ) -> Result<(), SolverError> {
        if ncols == 0 || self.n == 0 {
            return Ok(());
        }
        let n = self.n;
        if self.solve_x.len() < n * ncols {
            self.solve_x.resize(n * ncols, 0.0);
        }
        let x = &mut self.solve_x[..n * ncols];
        let perm = self.symbolic.perm().map(|p| p.arrays());
        match perm {
            Some((fwd, _)) => {
                for (xj, bj) in x.chunks_exact_mut(n).zip(rhs.chunks_exact(n)) {
                    for (xi, &p) in xj.iter_mut().zip(fwd) {
                        *xi = bj[p];
                    }
                }
            }
            None => x.copy_from_slice(rhs),
        }
        // SAFETY: `max_nr` is what `validate` returned for this symbolic structure (in `new`;
        // the structure and the length of `l_values` never change).
        unsafe {
            supernodal::solve(
                &structure(&self.symbolic, &self.l_values)?,
                self.max_nr,
                x,
                n,
                ncols,
                &mut self.solve_work,
                self.portable,
                self.wide,
                sparse.then_some(self.reach.as_slice()),
            )
        };
        match perm {
            Some((fwd, _)) => {
                for (xj, bj) in x.chunks_exact(n).zip(rhs.chunks_exact_mut(n)) {
                    for (&xi, &p) in xj.iter().zip(fwd) {
                        bj[p] = xi;
                    }
                }
            }
            None => rhs.copy_from_slice(x),
        }
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

    /// Entries of L in its lower triangle: what CHOLMOD counts as nnz(L). A supernodal
    /// factor stores each supernode's diagonal block as a full square ([`Self::nnz_factor`]);
    /// only its lower half is part of L (zeros from supernode relaxation are counted, as
    /// CHOLMOD counts them).
    pub fn nnz_factor_lower(&self) -> usize {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sn) => sn
                .supernode_begin()
                .iter()
                .zip(sn.supernode_end())
                .zip(sn.col_ptr_for_row_idx().windows(2))
                .map(|((&f, &l), r)| {
                    let w = l - f;
                    w * (w + 1) / 2 + w * (r[1] - r[0])
                })
                .sum(),
            SymbolicCholeskyRaw::Simplicial(_) => self.l_values.len(),
        }
    }

    /// Workspaces of the numeric factorization (tests).
    #[cfg(test)]
    fn plan_slots(&self) -> usize {
        self.plan.slots()
    }

    /// The ordering actually used ("amd", "nested_dissection", ...).
    pub fn ordering(&self) -> &'static str {
        self.ordering_used
    }
}

fn supernodes<'a>(
    sn: &'a faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
    vals: &'a [f64],
) -> supernodal::Supernodes<'a> {
    supernodal::Supernodes {
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
fn structure<'a>(
    symbolic: &'a SymbolicCholesky<usize>,
    vals: &'a [f64],
) -> Result<supernodal::Supernodes<'a>, SolverError> {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(sn) => Ok(supernodes(sn, vals)),
        SymbolicCholeskyRaw::Simplicial(_) if symbolic.nrows() == 0 => Ok(supernodal::Supernodes {
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

/// Triangular solves with a supernodal factor, written for this crate's use: any number of
/// right-hand sides, supernode by supernode, each supernode's block read from memory once per
/// pass for all of them and applied to groups of up to four.
///
/// faer's own supernodal solve calls its general matmul per supernode: fine for many
/// right-hand sides, but with one or two the per-call overhead and the packing dominate on
/// FEM factors, whose supernodes are mostly narrow; and its kernels depend on the CPU. Here
/// each supernode is swept in panels of 8 columns with fused kernels (AVX2 + FMA when the CPU
/// has them, chosen at run time; plain scalar code otherwise): forward, the panel's small
/// triangle and then `e -= L_panel x_panel` over the rows below it; backward, the dot
/// products `L_panel^T e` and then the small transposed triangle. `e` is the supernode's
/// rows gathered into a dense vector, as in CHOLMOD's supernodal solve.
///
/// The operations applied to one right-hand side do not depend on how many are solved with
/// it nor on its position among them (panels are 8 columns wide whatever their number; only
/// the register blocking changes): batching never changes a result's bits.
mod supernodal {
    #![allow(clippy::needless_range_loop)]

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
            if self.end.len() != ns || self.row_ptr.len() != ns + 1 || self.val_ptr.len() != ns + 1
            {
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

    /// The vector operations of the kernels (also those of [`super::factor`]).
    pub(super) trait Simd {
        type V: Copy;
        const W: usize;
        /// Accumulators the backward dot products keep in registers at once.
        const ACC: usize = 8;
        unsafe fn load(p: *const f64) -> Self::V;
        unsafe fn store(p: *mut f64, v: Self::V);
        unsafe fn splat(x: f64) -> Self::V;
        unsafe fn zero() -> Self::V;
        /// c - a b
        unsafe fn fnmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V;
        /// c + a b
        unsafe fn fmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V;
        unsafe fn hsum(v: Self::V) -> f64;
        /// a / b, correctly rounded lane by lane
        unsafe fn div(a: Self::V, b: Self::V) -> Self::V;
        /// c - a b, one lane (fused, as a vector lane computes it; the portable set overrides)
        #[inline(always)]
        fn fnmadd1(a: f64, b: f64, c: f64) -> f64 {
            (-a).mul_add(b, c)
        }
        /// c + a b, one lane (fused, as a vector lane computes it; the portable set overrides)
        #[inline(always)]
        fn fmadd1(a: f64, b: f64, c: f64) -> f64 {
            a.mul_add(b, c)
        }
    }

    pub(super) struct Scalar;
    impl Simd for Scalar {
        type V = f64;
        const W: usize = 1;
        #[inline(always)]
        unsafe fn load(p: *const f64) -> f64 {
            *p
        }
        #[inline(always)]
        unsafe fn store(p: *mut f64, v: f64) {
            *p = v
        }
        #[inline(always)]
        unsafe fn splat(x: f64) -> f64 {
            x
        }
        #[inline(always)]
        unsafe fn zero() -> f64 {
            0.0
        }
        #[inline(always)]
        unsafe fn fnmadd(a: f64, b: f64, c: f64) -> f64 {
            c - a * b
        }
        #[inline(always)]
        unsafe fn fmadd(a: f64, b: f64, c: f64) -> f64 {
            c + a * b
        }
        #[inline(always)]
        unsafe fn hsum(v: f64) -> f64 {
            v
        }
        #[inline(always)]
        unsafe fn div(a: f64, b: f64) -> f64 {
            a / b
        }
        #[inline(always)]
        fn fnmadd1(a: f64, b: f64, c: f64) -> f64 {
            c - a * b
        }
        #[inline(always)]
        fn fmadd1(a: f64, b: f64, c: f64) -> f64 {
            c + a * b
        }
    }

    /// AVX2 with FMA, four lanes; `ACC`: the accumulator registers the backward dot products
    /// may use (8 of AVX2's 16 vector registers; 16 of the 32 that AVX-512VL gives the same
    /// 256-bit operations).
    #[cfg(target_arch = "x86_64")]
    pub(super) struct Avx2<const ACC: usize = 8>;
    #[cfg(target_arch = "x86_64")]
    impl<const A: usize> Simd for Avx2<A> {
        type V = std::arch::x86_64::__m256d;
        const W: usize = 4;
        const ACC: usize = A;
        #[inline(always)]
        unsafe fn load(p: *const f64) -> Self::V {
            std::arch::x86_64::_mm256_loadu_pd(p)
        }
        #[inline(always)]
        unsafe fn store(p: *mut f64, v: Self::V) {
            std::arch::x86_64::_mm256_storeu_pd(p, v)
        }
        #[inline(always)]
        unsafe fn splat(x: f64) -> Self::V {
            std::arch::x86_64::_mm256_set1_pd(x)
        }
        #[inline(always)]
        unsafe fn zero() -> Self::V {
            std::arch::x86_64::_mm256_setzero_pd()
        }
        #[inline(always)]
        unsafe fn fnmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V {
            std::arch::x86_64::_mm256_fnmadd_pd(a, b, c)
        }
        #[inline(always)]
        unsafe fn fmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V {
            std::arch::x86_64::_mm256_fmadd_pd(a, b, c)
        }
        #[inline(always)]
        unsafe fn hsum(v: Self::V) -> f64 {
            use std::arch::x86_64::*;
            let s = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd::<1>(v));
            _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)))
        }
        #[inline(always)]
        unsafe fn div(a: Self::V, b: Self::V) -> Self::V {
            std::arch::x86_64::_mm256_div_pd(a, b)
        }
    }

    /// AVX-512F with FMA, eight lanes: for the numeric factorization only, whose every entry is
    /// a chain of lane-wise operations fixed by the structure (the same bits as the AVX2
    /// kernels'). The solves keep AVX2: their horizontal sums depend on the width.
    #[cfg(target_arch = "x86_64")]
    pub(super) struct Avx512;
    #[cfg(target_arch = "x86_64")]
    impl Simd for Avx512 {
        type V = std::arch::x86_64::__m512d;
        const W: usize = 8;
        #[inline(always)]
        unsafe fn load(p: *const f64) -> Self::V {
            std::arch::x86_64::_mm512_loadu_pd(p)
        }
        #[inline(always)]
        unsafe fn store(p: *mut f64, v: Self::V) {
            std::arch::x86_64::_mm512_storeu_pd(p, v)
        }
        #[inline(always)]
        unsafe fn splat(x: f64) -> Self::V {
            std::arch::x86_64::_mm512_set1_pd(x)
        }
        #[inline(always)]
        unsafe fn zero() -> Self::V {
            std::arch::x86_64::_mm512_setzero_pd()
        }
        #[inline(always)]
        unsafe fn fnmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V {
            std::arch::x86_64::_mm512_fnmadd_pd(a, b, c)
        }
        #[inline(always)]
        unsafe fn fmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V {
            std::arch::x86_64::_mm512_fmadd_pd(a, b, c)
        }
        #[inline(always)]
        unsafe fn hsum(v: Self::V) -> f64 {
            std::arch::x86_64::_mm512_reduce_add_pd(v)
        }
        #[inline(always)]
        unsafe fn div(a: Self::V, b: Self::V) -> Self::V {
            std::arch::x86_64::_mm512_div_pd(a, b)
        }
    }

    /// Forward step on the columns c0..c0+Q of a supernode (values at `l`, column stride
    /// `nr`) for R right-hand sides, the j-th gathered at `e[j * nr..(j + 1) * nr]`.
    ///
    /// Safety: `l` holds nr * (c0 + Q) values, `e` holds R * nr, c0 + Q <= nr.
    #[inline(always)]
    unsafe fn fwd_panel<S: Simd, const Q: usize, const R: usize>(
        l: *const f64,
        nr: usize,
        c0: usize,
        e: *mut f64,
    ) {
        for j in 0..R {
            let e = e.add(j * nr);
            for q in 0..Q {
                let c = c0 + q;
                let col = l.add(c * nr);
                let xc = *e.add(c) / *col.add(c);
                *e.add(c) = xc;
                for r in c + 1..c0 + Q {
                    *e.add(r) = S::fnmadd1(*col.add(r), xc, *e.add(r));
                }
            }
        }
        let mut a = [[0.0; R]; Q];
        let mut av = [[S::zero(); R]; Q];
        for q in 0..Q {
            for j in 0..R {
                a[q][j] = *e.add(j * nr + c0 + q);
                av[q][j] = S::splat(a[q][j]);
            }
        }
        let cols = l.add(c0 * nr);
        let mut r = c0 + Q;
        while r + S::W <= nr {
            let mut v = [S::zero(); R];
            for j in 0..R {
                v[j] = S::load(e.add(j * nr + r));
            }
            for q in 0..Q {
                let lv = S::load(cols.add(q * nr + r));
                for j in 0..R {
                    v[j] = S::fnmadd(lv, av[q][j], v[j]);
                }
            }
            for j in 0..R {
                S::store(e.add(j * nr + r), v[j]);
            }
            r += S::W;
        }
        while r < nr {
            for j in 0..R {
                let mut v = *e.add(j * nr + r);
                for q in 0..Q {
                    v = S::fnmadd1(*cols.add(q * nr + r), a[q][j], v);
                }
                *e.add(j * nr + r) = v;
            }
            r += 1;
        }
    }

    /// Dot products `d[q][j] = Σ_{r ≥ r0} L[r, q0 + q] e_j[r]` for the QB columns from q0 of
    /// a backward panel (columns at `cols`, stride `nr`) and R right-hand sides; stored at
    /// `d[(q0 + q) * R + j]`. Each product's operations do not depend on QB or R: lane-wise
    /// FMA over the vector rows from r0, the fixed horizontal sum, then the scalar rows.
    ///
    /// Safety: as [`bwd_panel`].
    #[inline(always)]
    unsafe fn bwd_dots<S: Simd, const QB: usize, const R: usize>(
        cols: *const f64,
        nr: usize,
        r0: usize,
        e: *const f64,
        d: &mut [f64; 8 * 4],
        q0: usize,
    ) {
        let mut acc = [[S::zero(); R]; QB];
        let mut r = r0;
        while r + S::W <= nr {
            let mut ev = [S::zero(); R];
            for j in 0..R {
                ev[j] = S::load(e.add(j * nr + r));
            }
            for q in 0..QB {
                let lv = S::load(cols.add((q0 + q) * nr + r));
                for j in 0..R {
                    acc[q][j] = S::fmadd(lv, ev[j], acc[q][j]);
                }
            }
            r += S::W;
        }
        let mut dd = [[0.0; R]; QB];
        for q in 0..QB {
            for j in 0..R {
                dd[q][j] = S::hsum(acc[q][j]);
            }
        }
        while r < nr {
            for q in 0..QB {
                let lq = *cols.add((q0 + q) * nr + r);
                for j in 0..R {
                    dd[q][j] = S::fmadd1(lq, *e.add(j * nr + r), dd[q][j]);
                }
            }
            r += 1;
        }
        for q in 0..QB {
            for j in 0..R {
                d[(q0 + q) * R + j] = dd[q][j];
            }
        }
    }

    /// Backward step on the columns c0..c0+Q (same layout and safety as [`fwd_panel`]). The
    /// dot products are computed up to `S::ACC / R` columns at a time (that many accumulators
    /// in registers: one pass over the rows for one right-hand side, as before the panel width
    /// was fixed); the grouping changes no operation.
    #[inline(always)]
    unsafe fn bwd_panel<S: Simd, const Q: usize, const R: usize>(
        l: *const f64,
        nr: usize,
        c0: usize,
        e: *mut f64,
    ) {
        let cols = l.add(c0 * nr);
        let mut d = [0.0; 8 * 4];
        let cap = (S::ACC / R).max(1);
        let mut q0 = 0;
        while q0 < Q {
            let rem = Q - q0;
            let qb = rem.min(cap);
            match qb {
                8 => bwd_dots::<S, 8, R>(cols, nr, c0 + Q, e, &mut d, q0),
                7 => bwd_dots::<S, 7, R>(cols, nr, c0 + Q, e, &mut d, q0),
                6 => bwd_dots::<S, 6, R>(cols, nr, c0 + Q, e, &mut d, q0),
                5 => bwd_dots::<S, 5, R>(cols, nr, c0 + Q, e, &mut d, q0),
                4 => bwd_dots::<S, 4, R>(cols, nr, c0 + Q, e, &mut d, q0),
                3 => bwd_dots::<S, 3, R>(cols, nr, c0 + Q, e, &mut d, q0),
                2 => bwd_dots::<S, 2, R>(cols, nr, c0 + Q, e, &mut d, q0),
                _ => bwd_dots::<S, 1, R>(cols, nr, c0 + Q, e, &mut d, q0),
            }
            q0 += qb;
        }
        for j in 0..R {
            let e = e.add(j * nr);
            for q in (0..Q).rev() {
                let c = c0 + q;
                let col = l.add(c * nr);
                let mut v = *e.add(c) - d[q * R + j];
                for rr in c + 1..c0 + Q {
                    v = S::fnmadd1(*col.add(rr), *e.add(rr), v);
                }
                *e.add(c) = v / *col.add(c);
            }
        }
    }

    /// Forward and backward panels are 8 columns wide for every number of right-hand sides,
    /// so that a column's operations do not depend on how many are solved with it.
    macro_rules! panel {
        ($f:ident, $S:ty, $R:tt, $q:expr, $($arg:expr),*) => {
            match $q {
                8 => $f::<$S, 8, $R>($($arg),*),
                7 => $f::<$S, 7, $R>($($arg),*),
                6 => $f::<$S, 6, $R>($($arg),*),
                5 => $f::<$S, 5, $R>($($arg),*),
                4 => $f::<$S, 4, $R>($($arg),*),
                3 => $f::<$S, 3, $R>($($arg),*),
                2 => $f::<$S, 2, $R>($($arg),*),
                _ => $f::<$S, 1, $R>($($arg),*),
            }
        };
    }

    /// Forward substitution on supernode s for the R columns of X at `x` (column stride n,
    /// permuted): gather its rows, panels, scatter.
    ///
    /// Safety: `sn` validated for n; `x` holds R * n values; `work` holds R * max_nr.
    #[inline(always)]
    unsafe fn fwd_node<S: Simd, const R: usize>(
        sn: &Supernodes<'_>,
        s: usize,
        x: *mut f64,
        n: usize,
        work: *mut f64,
    ) {
        let (f, w) = (sn.begin[s], sn.end[s] - sn.begin[s]);
        let pat = &sn.row_idx[sn.row_ptr[s]..sn.row_ptr[s + 1]];
        let nr = w + pat.len();
        let l = sn.vals.as_ptr().add(sn.val_ptr[s]);
        for j in 0..R {
            let (xj, e) = (x.add(j * n), work.add(j * nr));
            std::ptr::copy_nonoverlapping(xj.add(f), e, w);
            std::ptr::write_bytes(e.add(w), 0, nr - w);
        }
        let mut c0 = 0;
        while c0 < w {
            let q = (w - c0).min(8);
            panel!(fwd_panel, S, R, q, l, nr, c0, work);
            c0 += q;
        }
        for j in 0..R {
            let (xj, e) = (x.add(j * n), work.add(j * nr));
            std::ptr::copy_nonoverlapping(e, xj.add(f), w);
            for (t, &i) in pat.iter().enumerate() {
                *xj.add(i) += *e.add(w + t);
            }
        }
    }

    /// Backward substitution on supernode s (layout and safety as [`fwd_node`]).
    #[inline(always)]
    unsafe fn bwd_node<S: Simd, const R: usize>(
        sn: &Supernodes<'_>,
        s: usize,
        x: *mut f64,
        n: usize,
        work: *mut f64,
    ) {
        let (f, w) = (sn.begin[s], sn.end[s] - sn.begin[s]);
        let pat = &sn.row_idx[sn.row_ptr[s]..sn.row_ptr[s + 1]];
        let nr = w + pat.len();
        let l = sn.vals.as_ptr().add(sn.val_ptr[s]);
        for j in 0..R {
            let (xj, e) = (x.add(j * n), work.add(j * nr));
            std::ptr::copy_nonoverlapping(xj.add(f), e, w);
            for (t, &i) in pat.iter().enumerate() {
                *e.add(w + t) = *xj.add(i);
            }
        }
        let mut c1 = w;
        while c1 > 0 {
            let q = c1.min(8);
            let c0 = c1 - q;
            panel!(bwd_panel, S, R, q, l, nr, c0, work);
            c1 = c0;
        }
        for j in 0..R {
            std::ptr::copy_nonoverlapping(work.add(j * nr), x.add(j * n + f), w);
        }
    }

    /// Forward substitution on supernode s for all k columns, in groups of up to four.
    #[inline(always)]
    unsafe fn fwd_groups<S: Simd>(
        sn: &Supernodes<'_>,
        s: usize,
        xp: *mut f64,
        n: usize,
        k: usize,
        wp: *mut f64,
    ) {
        let mut j = 0;
        while j < k {
            let g = (k - j).min(4);
            let xj = xp.add(j * n);
            match g {
                4 => fwd_node::<S, 4>(sn, s, xj, n, wp),
                3 => fwd_node::<S, 3>(sn, s, xj, n, wp),
                2 => fwd_node::<S, 2>(sn, s, xj, n, wp),
                _ => fwd_node::<S, 1>(sn, s, xj, n, wp),
            }
            j += g;
        }
    }

    /// Solves L L^T X = B for the k columns of X: supernode by supernode, each in groups of
    /// four right-hand sides and then the rest (3, 2 or 1) as one group, so that a
    /// supernode's block is read from memory once per pass for all columns. `fwd`: the
    /// supernodes the forward pass visits (increasing; the others must leave X unchanged,
    /// i.e. hold zeros only, with zeros only below them); None: all.
    #[inline(always)]
    unsafe fn solve_all<S: Simd>(
        sn: &Supernodes<'_>,
        x: &mut [f64],
        n: usize,
        k: usize,
        work: &mut [f64],
        fwd: Option<&[usize]>,
    ) {
        let (xp, wp) = (x.as_mut_ptr(), work.as_mut_ptr());
        let ns = sn.begin.len();
        // A loop per case, no closure: closures do not inherit `target_feature`, and the
        // kernels would then not inline their AVX2 intrinsics.
        match fwd {
            Some(list) => {
                for &s in list {
                    fwd_groups::<S>(sn, s, xp, n, k, wp);
                }
            }
            None => {
                for s in 0..ns {
                    fwd_groups::<S>(sn, s, xp, n, k, wp);
                }
            }
        }
        for s in (0..ns).rev() {
            let mut j = 0;
            while j < k {
                let g = (k - j).min(4);
                let xj = xp.add(j * n);
                match g {
                    4 => bwd_node::<S, 4>(sn, s, xj, n, wp),
                    3 => bwd_node::<S, 3>(sn, s, xj, n, wp),
                    2 => bwd_node::<S, 2>(sn, s, xj, n, wp),
                    _ => bwd_node::<S, 1>(sn, s, xj, n, wp),
                }
                j += g;
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn solve_avx2(
        sn: &Supernodes<'_>,
        x: &mut [f64],
        n: usize,
        k: usize,
        work: &mut [f64],
        fwd: Option<&[usize]>,
    ) {
        solve_all::<Avx2>(sn, x, n, k, work, fwd)
    }

    /// The AVX2 kernels where the CPU also has AVX-512VL: the same 256-bit operations (the
    /// same bits), with 32 vector registers for the accumulators instead of 16.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
    unsafe fn solve_avx512vl(
        sn: &Supernodes<'_>,
        x: &mut [f64],
        n: usize,
        k: usize,
        work: &mut [f64],
        fwd: Option<&[usize]>,
    ) {
        solve_all::<Avx2<16>>(sn, x, n, k, work, fwd)
    }

    /// Solves L L^T X = B in place for the n x k column-major `x` (already permuted);
    /// `portable`: the scalar kernels even where AVX2 + FMA exist (tests); `wide`: AVX-512VL's
    /// 32 registers for the AVX2 kernels where the CPU has it (the same bits); `fwd`: the
    /// supernodes of the forward pass, as in [`solve_all`] (None: all).
    /// Panics unless `x.len() == n * k`, `work.len() >= 4 * max_nr` and `fwd` is increasing
    /// and in range.
    ///
    /// # Safety
    /// `sn.validate(n)` returned `Some(max_nr)` (the kernels index without checks).
    #[allow(clippy::too_many_arguments)]
    pub(super) unsafe fn solve(
        sn: &Supernodes<'_>,
        max_nr: usize,
        x: &mut [f64],
        n: usize,
        k: usize,
        work: &mut [f64],
        portable: bool,
        wide: bool,
        fwd: Option<&[usize]>,
    ) {
        debug_assert_eq!(sn.validate(n), Some(max_nr));
        assert!(x.len() == n * k && work.len() >= 4 * max_nr);
        if let Some(list) = fwd {
            assert!(
                list.windows(2).all(|p| p[0] < p[1])
                    && list.last().is_none_or(|&s| s < sn.begin.len()),
                "forward supernodes not increasing or out of range"
            );
        }
        #[cfg(target_arch = "x86_64")]
        if !portable
            && std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has AVX2 and FMA (and AVX-512VL for the second); sizes checked
            // above, structure validated (the caller's contract).
            if wide && std::arch::is_x86_feature_detected!("avx512vl") {
                return solve_avx512vl(sn, x, n, k, work, fwd);
            }
            return solve_avx2(sn, x, n, k, work, fwd);
        }
        solve_all::<Scalar>(sn, x, n, k, work, fwd)
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

    /// A 3-D elasticity-like pattern: 3 coupled DOFs per grid node, 27-point stencil, SPD.
    fn grid3(k: usize) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
        let nodes = k * k * k;
        let n = 3 * nodes;
        let id = |x: usize, y: usize, z: usize| x + k * (y + k * z);
        let mut cp = vec![0];
        let mut ri = vec![];
        let mut v = vec![];
        for z in 0..k {
            for y in 0..k {
                for x in 0..k {
                    let a = id(x, y, z);
                    for p in 0..3 {
                        let mut col = vec![];
                        for dz in -1i64..=1 {
                            for dy in -1i64..=1 {
                                for dx in -1i64..=1 {
                                    let (x2, y2, z2) =
                                        (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                                    if [x2, y2, z2].iter().any(|&c| c < 0 || c >= k as i64) {
                                        continue;
                                    }
                                    let b = id(x2 as usize, y2 as usize, z2 as usize);
                                    for q in 0..3 {
                                        let diag = a == b && p == q;
                                        let val = if diag {
                                            60.0
                                        } else if a == b {
                                            0.5
                                        } else {
                                            -1.0 / (1.0 + ((p + q) % 3) as f64)
                                        };
                                        col.push((3 * b + q, val));
                                    }
                                }
                            }
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
        }
        (n, cp, ri, v)
    }

    fn nd() -> CholeskyParams {
        CholeskyParams {
            ordering: Ordering::NestedDissection,
            ..Default::default()
        }
    }

    fn rhs(n: usize, k: usize) -> Vec<f64> {
        (0..n * k)
            .map(|i| ((i * 7919) % 23) as f64 - 11.0)
            .collect()
    }

    fn norm(v: &[f64]) -> f64 {
        v.iter().map(|c| c * c).sum::<f64>().sqrt()
    }

    fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
        let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
            / scale
    }

    /// faer's numeric factorization on the same symbolic structure (the reference).
    fn faer_factor(f: &Cholesky, cp: &[usize], ri: &[usize], v: &[f64]) -> Vec<f64> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::sparse::SparseColMatRef;
        use faer::Par;
        let mut lv = vec![0.0; f.l_values.len()];
        let mut mem = MemBuffer::new(
            f.symbolic
                .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        );
        let a = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(f.n, f.n, cp, None, ri),
            v,
        );
        f.symbolic
            .factorize_numeric_llt(
                &mut lv,
                a,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .unwrap();
        lv
    }

    /// The entries of L that are part of the factor (lower triangles of the diagonal blocks
    /// and the rows below), in storage order.
    fn lower_entries(f: &Cholesky, lv: &[f64]) -> Vec<f64> {
        let SymbolicCholeskyRaw::Supernodal(sn) = f.symbolic.raw() else {
            unreachable!()
        };
        let sn = supernodes(sn, lv);
        let mut out = vec![];
        for s in 0..sn.begin.len() {
            let w = sn.end[s] - sn.begin[s];
            let nr = w + sn.row_ptr[s + 1] - sn.row_ptr[s];
            for j in 0..w {
                out.extend_from_slice(
                    &lv[sn.val_ptr[s] + j * nr + j..sn.val_ptr[s] + (j + 1) * nr],
                );
            }
        }
        out
    }

    /// n, column pointers, row indices, values.
    type Csc = (usize, Vec<usize>, Vec<usize>, Vec<f64>);

    fn grids() -> Vec<(&'static str, Csc)> {
        vec![("grid 12^3", grid(12)), ("grid3 7^3", grid3(7))]
    }

    #[test]
    fn factor_matches_faer_on_every_ordering() {
        for (name, (n, cp, ri, v)) in grids() {
            let reverse: Vec<usize> = (0..n).rev().collect();
            for ordering in [
                Ordering::Amd,
                Ordering::NestedDissection,
                Ordering::Identity,
                Ordering::Auto,
                Ordering::Custom(reverse),
            ] {
                let params = CholeskyParams {
                    ordering: ordering.clone(),
                    ..Default::default()
                };
                let f = Cholesky::new(n, &cp, &ri, &v, params).unwrap();
                let reference = faer_factor(&f, &cp, &ri, &v);
                let d = max_rel_diff(
                    &lower_entries(&f, &reference),
                    &lower_entries(&f, &f.l_values),
                );
                assert!(
                    d < 1e-12,
                    "{name} {ordering:?}: L differs from faer's by {d}"
                );
            }
        }
    }

    #[test]
    fn solves_to_round_off_for_any_number_of_rhs() {
        for (name, (n, cp, ri, v)) in grids() {
            let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
            assert!(f.nnz_factor_lower() < f.nnz_factor());
            for k in [1, 2, 3, 4, 5, 6, 7, 9, 33] {
                let b = rhs(n, k);
                let mut x = b.clone();
                f.solve_in_place(&mut x, k).unwrap();
                for j in 0..k {
                    let (bj, xj) = (&b[j * n..(j + 1) * n], &x[j * n..(j + 1) * n]);
                    let r = matvec(n, &cp, &ri, &v, xj);
                    let res: Vec<f64> = r.iter().zip(bj).map(|(a, c)| a - c).collect();
                    assert!(
                        norm(&res) < 1e-12 * norm(bj),
                        "{name}, k = {k}, column {j}: residual {}",
                        norm(&res)
                    );
                }
            }
        }
    }

    #[test]
    fn avx512_and_avx2_factors_have_the_same_bits() {
        #[cfg(target_arch = "x86_64")]
        if !std::arch::is_x86_feature_detected!("avx512f") {
            eprintln!("no AVX-512 on this CPU: only the AVX2 kernels factor here");
            return;
        }
        // Several supernode widths and row counts (tile tails of 8 and 4 lanes, split
        // products and panels on the default pool).
        let forest = block_diagonal(grid3(7), grid(13));
        for (name, (n, cp, ri, v)) in [
            ("grid3 8^3", grid3(8)),
            ("grid 15^3", grid(15)),
            ("forest", forest),
        ] {
            let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
            let wide = f.l_values.clone();
            f.wide = false;
            f.refactor(&v).unwrap();
            assert!(
                f.l_values == wide,
                "{name}: AVX-512 and AVX2 factors differ"
            );
        }
    }

    #[test]
    fn avx512vl_and_avx2_solves_have_the_same_bits() {
        #[cfg(target_arch = "x86_64")]
        if !std::arch::is_x86_feature_detected!("avx512vl") {
            eprintln!("no AVX-512VL on this CPU: only the AVX2 solve kernels run here");
            return;
        }
        // One to nine right-hand sides (groups of four and the rest; one to eight
        // accumulators per backward pass), dense and sparse, on several supernode widths.
        let forest = block_diagonal(grid3(7), grid(13));
        for (name, (n, cp, ri, v)) in [("grid3 8^3", grid3(8)), ("forest", forest)] {
            let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
            for k in 1..=9 {
                let b = rhs(n, k);
                let rows: Vec<usize> = (0..k).map(|j| (j * 37 + 5) % n).collect();
                let mut unit = vec![0.0; n * k];
                for (j, &r) in rows.iter().enumerate() {
                    unit[j * n + r] = 1.0;
                }
                let mut got = Vec::new();
                for wide in [true, false] {
                    f.wide = wide;
                    let (mut x, mut e) = (b.clone(), unit.clone());
                    f.solve_in_place(&mut x, k).unwrap();
                    f.solve_sparse_rhs_in_place(&mut e, k, &rows).unwrap();
                    let bits = |v: &[f64]| v.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
                    got.push((bits(&x), bits(&e)));
                }
                assert!(
                    got[0] == got[1],
                    "{name}, {k} right-hand sides: the solves differ"
                );
            }
        }
    }

    #[test]
    fn portable_kernels_agree_with_avx2_and_bits_repeat() {
        let (n, cp, ri, v) = grid3(8);
        let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
        let l_fast = f.l_values.clone();
        f.refactor(&v).unwrap();
        assert!(f.l_values == l_fast, "refactor changed bits");
        f.portable = true;
        f.refactor(&v).unwrap();
        let d = max_rel_diff(&lower_entries(&f, &l_fast), &lower_entries(&f, &f.l_values));
        assert!(d < 1e-13, "portable factor differs by {d}");
        let b = rhs(n, 3);
        let mut x_portable = b.clone();
        f.solve_in_place(&mut x_portable, 3).unwrap();
        f.portable = false;
        f.refactor(&v).unwrap();
        assert!(f.l_values == l_fast);
        let mut x = b.clone();
        f.solve_in_place(&mut x, 3).unwrap();
        let d = max_rel_diff(&x, &x_portable);
        assert!(d < 1e-13, "portable solve differs by {d}");
    }

    /// Two matrices as the diagonal blocks of one (an elimination forest with several roots).
    fn block_diagonal(
        a: (usize, Vec<usize>, Vec<usize>, Vec<f64>),
        b: (usize, Vec<usize>, Vec<usize>, Vec<f64>),
    ) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
        let (na, mut cp, mut ri, mut v) = a;
        let (nb, cpb, rib, vb) = b;
        let nnz = ri.len();
        cp.extend(cpb[1..].iter().map(|&p| p + nnz));
        ri.extend(rib.iter().map(|&i| i + na));
        v.extend(vb);
        (na + nb, cp, ri, v)
    }

    #[test]
    fn factor_bits_do_not_depend_on_threads() {
        // The forest: its subtrees run concurrently while large supernodes split their
        // products, and a thread waiting for a split's chunks may take up another subtree.
        let forest = block_diagonal(grid3(7), block_diagonal(grid(14), grid3(6)));
        for (name, (n, cp, ri, v)) in [
            ("grid 16^3", grid(16)),
            ("grid3 8^3", grid3(8)),
            ("forest", forest),
        ] {
            let mut bits = vec![];
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let splits = factor::SPLITS.load(std::sync::atomic::Ordering::Relaxed);
                let l = pool.install(|| {
                    let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
                    assert_eq!(f.plan_slots(), if threads > 1 { threads + 1 } else { 1 });
                    f.refactor(&v).unwrap();
                    f.l_values.clone()
                });
                // With threads, the large supernodes' products and panels were split by rows.
                if threads > 1 {
                    assert!(
                        factor::SPLITS.load(std::sync::atomic::Ordering::Relaxed) > splits,
                        "{name}"
                    );
                }
                bits.push(l);
            }
            let serial = Cholesky::new(
                n,
                &cp,
                &ri,
                &v,
                CholeskyParams {
                    parallel: false,
                    ..nd()
                },
            )
            .unwrap();
            assert!(bits.iter().all(|l| *l == serial.l_values), "{name}");
        }
    }

    #[test]
    fn batching_never_changes_a_columns_bits() {
        let (n, cp, ri, v) = grid3(7);
        let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
        let b = rhs(n, 9);
        for portable in [false, true] {
            f.portable = portable;
            f.refactor(&v).unwrap();
            let alone: Vec<Vec<f64>> = (0..9)
                .map(|j| {
                    let mut x = b[j * n..(j + 1) * n].to_vec();
                    f.solve_in_place(&mut x, 1).unwrap();
                    x
                })
                .collect();
            for k in 1..=9 {
                // The columns j0, j0 + 1, ... of b, for every start that fits.
                for j0 in 0..=9 - k {
                    let mut x = b[j0 * n..(j0 + k) * n].to_vec();
                    f.solve_in_place(&mut x, k).unwrap();
                    for t in 0..k {
                        assert!(
                            x[t * n..(t + 1) * n] == alone[j0 + t][..],
                            "portable {portable}: column {} at position {t} of {k}",
                            j0 + t
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn sparse_rhs_solve_gives_the_dense_values() {
        let (n, cp, ri, v) = grid3(7);
        for ordering in [
            Ordering::NestedDissection,
            Ordering::Amd,
            Ordering::Identity,
        ] {
            let params = CholeskyParams {
                ordering,
                ..Default::default()
            };
            let mut f = Cholesky::new(n, &cp, &ri, &v, params).unwrap();
            for portable in [false, true] {
                f.portable = portable;
                // Unit columns one by one, three at once, and a few-row column pair.
                for rows in [vec![0], vec![n - 1], vec![n / 3], vec![5, 17, 400]] {
                    let k = rows.len();
                    let mut b = vec![0.0; n * k];
                    for (j, &i) in rows.iter().enumerate() {
                        b[j * n + i] = 1.0 + j as f64;
                    }
                    let mut dense = b.clone();
                    f.solve_in_place(&mut dense, k).unwrap();
                    let mut sparse = b.clone();
                    f.solve_sparse_rhs_in_place(&mut sparse, k, &rows).unwrap();
                    // == treats -0.0 and 0.0 as equal: only the signs of zeros may differ.
                    assert!(dense == sparse, "rows {rows:?}");
                }
                let mut b = vec![0.0; 2 * n];
                for i in [3, 9, 200] {
                    b[i] = i as f64;
                    b[n + i] = -(i as f64);
                }
                b[n + 11] = 2.0;
                let mut dense = b.clone();
                f.solve_in_place(&mut dense, 2).unwrap();
                let mut sparse = b.clone();
                f.solve_sparse_rhs_in_place(&mut sparse, 2, &[200, 11, 3, 9, 3])
                    .unwrap();
                assert!(dense == sparse);
                // A nonzero outside the listed rows, or a row out of range.
                let mut bad = b.clone();
                assert!(matches!(
                    f.solve_sparse_rhs_in_place(&mut bad, 2, &[3, 9, 200]),
                    Err(SolverError::BadRhs { .. })
                ));
                assert!(f.solve_sparse_rhs_in_place(&mut bad, 2, &[n]).is_err());
                assert_eq!(bad, b);
            }
        }
    }

    #[test]
    fn not_positive_definite_is_detected_at_the_first_bad_pivot() {
        let (n, cp, ri, v) = grid3(6);
        for parallel in [false, true] {
            let params = CholeskyParams { parallel, ..nd() };
            let mut f = Cholesky::new(n, &cp, &ri, &v, params.clone()).unwrap();
            // An indefinite shift of one diagonal entry: fails at (or after) its column.
            for target in [0, n / 2, n - 1] {
                let mut bad = v.clone();
                let k = (cp[target]..cp[target + 1])
                    .find(|&k| ri[k] == target)
                    .unwrap();
                bad[k] = -100.0;
                let err = f.refactor(&bad).unwrap_err();
                let SolverError::NotPositiveDefinite { row } = err else {
                    panic!("{err:?}")
                };
                let (_, inv) = f.symbolic.perm().unwrap().arrays();
                assert!(row >= inv[target], "row {row} before the bad column");
                assert!(matches!(
                    Cholesky::new(n, &cp, &ri, &bad, params.clone()),
                    Err(SolverError::NotPositiveDefinite { row: r }) if r == row
                ));
            }
            // Singular: a zero matrix.
            let zero = vec![0.0; v.len()];
            assert!(matches!(
                f.refactor(&zero),
                Err(SolverError::NotPositiveDefinite { row: 0 })
            ));
            // And it recovers.
            f.refactor(&v).unwrap();
            let mut x = rhs(n, 1);
            f.solve_in_place(&mut x, 1).unwrap();
        }
    }

    #[test]
    fn tiny_matrices_factor() {
        // 0 x 0, 1 x 1, a diagonal 2 x 2 and a 3 x 3 arrow.
        let mut f = Cholesky::new(0, &[0], &[], &[], CholeskyParams::default()).unwrap();
        f.solve_in_place(&mut [], 1).unwrap();
        let mut f = Cholesky::new(
            2,
            &[0, 1, 2],
            &[0, 1],
            &[4.0, 2.0],
            CholeskyParams::default(),
        )
        .unwrap();
        let mut b = [2.0, 1.0];
        f.solve_in_place(&mut b, 1).unwrap();
        assert!((b[0] - 0.5).abs() + (b[1] - 0.5).abs() < 1e-15, "{b:?}");
        let mut f = Cholesky::new(1, &[0, 1], &[0], &[4.0], CholeskyParams::default()).unwrap();
        let mut b = [2.0];
        f.solve_in_place(&mut b, 1).unwrap();
        assert_eq!(b, [0.5]);
        let (cp, ri) = ([0, 3, 5, 7], [0, 1, 2, 0, 1, 0, 2]);
        let v = [4.0, 1.0, 1.0, 1.0, 3.0, 1.0, 5.0];
        let mut f = Cholesky::new(3, &cp, &ri, &v, CholeskyParams::default()).unwrap();
        let mut x = [1.0, 2.0, 3.0];
        f.solve_in_place(&mut x, 1).unwrap();
        let r = matvec(3, &cp, &ri, &v, &x);
        assert!((r[0] - 1.0).abs() + (r[1] - 2.0).abs() + (r[2] - 3.0).abs() < 1e-14);
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
        assert!(
            f.l_values == g.l_values,
            "refactor differs from a fresh factor"
        );
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
        // Only the upper triangle stored: not symmetric (the lower entries' mirrors are zero).
        let (mut ucp, mut uri, mut uv) = (vec![0], vec![], vec![]);
        for j in 0..n {
            for k in cp[j]..cp[j + 1] {
                if ri[k] <= j {
                    uri.push(ri[k]);
                    uv.push(v[k]);
                }
            }
            ucp.push(uri.len());
        }
        assert!(uri.len() < ri.len());
        assert!(matches!(
            Cholesky::new(n, &ucp, &uri, &uv, CholeskyParams::default()),
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
