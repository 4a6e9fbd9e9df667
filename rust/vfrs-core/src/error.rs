//! The core's errors: each module has its own kind ([`MeshError`] and [`MaterialError`] in
//! [`crate::fem`], [`SolverError`] in [`crate::linalg`], [`HyperelasticError`] in
//! [`crate::hyperelastic`], [`ContactError`] in [`crate::contact`]), all re-exported here,
//! and [`Error`] is any of them. Each variant carries the indices a user needs to find the
//! culprit.

pub use crate::contact::ContactError;
pub use crate::fem::error::{MaterialError, MeshError};
pub use crate::hyperelastic::error::HyperelasticError;
pub use crate::linalg::error::SolverError;
use thiserror::Error;

/// Any error of the core, one variant per kind, for operations that can fail in more than
/// one way.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Error {
    /// A mesh problem.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A material problem.
    #[error(transparent)]
    Material(#[from] MaterialError),
    /// A linear-algebra problem.
    #[error(transparent)]
    Solver(#[from] SolverError),
    /// A finite-strain evaluation problem.
    #[error(transparent)]
    Hyperelastic(#[from] HyperelasticError),
    /// A contact-geometry problem.
    #[error(transparent)]
    Contact(#[from] ContactError),
}
