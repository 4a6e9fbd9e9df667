//! Typed errors of the sparse and dense linear algebra.

use thiserror::Error;

/// What went wrong in a sparse linear algebra operation.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SolverError {
    /// The matrix is not square or the arrays do not describe a CSC matrix.
    #[error("invalid sparse matrix: {reason}")]
    BadMatrix {
        /// Why.
        reason: String,
    },
    /// The matrix is not symmetric.
    #[error(
        "matrix is not symmetric: entry ({row}, {col}) = {value:e} but ({col}, {row}) = {mirror:e}"
    )]
    NotSymmetric {
        /// Row.
        row: usize,
        /// Column.
        col: usize,
        /// Value at (row, col).
        value: f64,
        /// Value at (col, row), 0 if absent.
        mirror: f64,
    },
    /// The Cholesky factorization met a non-positive pivot.
    #[error("matrix is not positive definite (factorization failed near row {row} of the permuted matrix); if this is a stiffness matrix, are all rigid-body motions fixed by Dirichlet conditions?")]
    NotPositiveDefinite {
        /// Approximate failing row (permuted numbering), if known.
        row: usize,
    },
    /// A refactorization was given a matrix of a different sparsity pattern.
    #[error("refactor needs the same sparsity pattern as the first factorization: {reason}")]
    PatternMismatch {
        /// What differs.
        reason: String,
    },
    /// Right-hand side of the wrong size or with non-finite entries.
    #[error("right-hand side: {reason}")]
    BadRhs {
        /// Why.
        reason: String,
    },
    /// Out of memory or an internal failure of the sparse library.
    #[error("sparse library failure: {reason}")]
    Internal {
        /// What faer reported.
        reason: String,
    },
    /// A small dense system of the contact methods (the LCP of a detection round) is
    /// malformed, non-finite or singular.
    #[error("dense contact system: {reason}")]
    Dense {
        /// Why.
        reason: String,
    },
    /// A DOF index is out of range.
    #[error("degree of freedom {dof} is out of range (there are {n_dofs})")]
    DofOutOfRange {
        /// Bad DOF.
        dof: usize,
        /// Number of DOFs.
        n_dofs: usize,
    },
}
