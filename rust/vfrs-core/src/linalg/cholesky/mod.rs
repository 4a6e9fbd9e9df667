//! Sparse Cholesky (LL^T): faer's symbolic analysis once ([`symbolic`]), then our own
//! numeric supernodal refactorization in place ([`numeric`]) and allocation-free solves
//! ([`solve`]), both with kernels ([`simd`]) that give the same bits on every x86-64 CPU with
//! AVX2 + FMA.

mod numeric;
mod simd;
mod solve;
mod symbolic;
#[cfg(test)]
mod tests;

pub use symbolic::check_pattern;

use crate::error::SolverError;
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use symbolic::{analyse, check_symmetric, structure};

/// Fill-reducing ordering.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Ordering {
    /// Try AMD and nested dissection, keep the one with the smaller factor.
    #[default]
    Auto,
    /// faer's approximate minimum degree.
    Amd,
    /// Nested dissection from the matrix graph ([`crate::linalg::ordering`]).
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
    /// The values of L in faer's supernodal layout ([`symbolic::Supernodes`]).
    l_values: Vec<f64>,
    plan: numeric::Plan,
    /// Largest supernode row count (the solves' work size per right-hand side), from
    /// [`symbolic::Supernodes::validate`].
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
        let plan = numeric::Plan::new(
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
            solve::solve(
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
