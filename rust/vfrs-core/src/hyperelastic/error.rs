//! Typed errors of the finite-strain evaluation.

use crate::fem::error::{MaterialError, MeshError};
use thiserror::Error;

/// What went wrong in a finite-strain (hyperelastic) evaluation.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum HyperelasticError {
    /// An element is inverted or flat in the deformed configuration.
    #[error("element {element} is inverted or flat in the deformed configuration: J = det F = {j:e} (must be > 0); the displacement is too large for this mesh, try a smaller step or load increment")]
    Inverted {
        /// Element index.
        element: usize,
        /// Its volume ratio J = det F.
        j: f64,
    },
    /// A displacement component is NaN or infinite.
    #[error("displacement u[{dof}] = {value} is not finite")]
    NonFiniteDisplacement {
        /// DOF index (node-major).
        dof: usize,
        /// The offending value.
        value: f64,
    },
    /// The stress or tangent of an element came out non-finite (an overflow of the fibre
    /// exponential, for example).
    #[error("element {element}: the stress or tangent is not finite at J = {j:e}; the deformation is too large for the material parameters")]
    NonFiniteStress {
        /// Element index.
        element: usize,
        /// Its volume ratio.
        j: f64,
    },
    /// A mesh problem (reference configuration).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A material problem (parameters, lengths, material indices).
    #[error(transparent)]
    Material(#[from] MaterialError),
}
