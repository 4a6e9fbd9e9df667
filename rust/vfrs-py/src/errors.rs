//! The one place where Rust errors become Python exceptions.
//!
//! Every vfrs exception derives from `vfrs.VfrsError`, itself a `ValueError`, so callers can
//! catch them together or one kind at a time.

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use vfrs_core::error as core;

create_exception!(
    _core,
    VfrsError,
    PyValueError,
    "Base class of vfrs errors (a ValueError)."
);
create_exception!(_core, MeshError, VfrsError, "A mesh is invalid: bad index, repeated vertex, inverted or flat element, non-finite coordinate.");
create_exception!(_core, MaterialError, VfrsError, "Material parameters are inadmissible (non-positive modulus, Poisson ratio out of range, compliance not positive definite).");
create_exception!(_core, SolverError, VfrsError, "A sparse linear-algebra operation failed (not symmetric, not positive definite, pattern mismatch).");
create_exception!(
    _core,
    ContactError,
    VfrsError,
    "A contact-geometry input is invalid (degenerate triangle, bad index, non-finite coordinate)."
);

create_exception!(
    _core,
    FiniteStrainError,
    VfrsError,
    "A finite-strain evaluation failed: an element inverted (J <= 0), a non-finite displacement, or a non-finite stress."
);

/// Converts a core error into the matching Python exception.
pub trait ToPyErr {
    /// The Python exception.
    fn to_py(self) -> PyErr;
}

impl ToPyErr for core::MeshError {
    fn to_py(self) -> PyErr {
        MeshError::new_err(self.to_string())
    }
}
impl ToPyErr for core::MaterialError {
    fn to_py(self) -> PyErr {
        MaterialError::new_err(self.to_string())
    }
}
impl ToPyErr for core::SolverError {
    fn to_py(self) -> PyErr {
        SolverError::new_err(self.to_string())
    }
}
impl ToPyErr for core::ContactError {
    fn to_py(self) -> PyErr {
        ContactError::new_err(self.to_string())
    }
}
impl ToPyErr for core::Error {
    fn to_py(self) -> PyErr {
        match self {
            core::Error::Mesh(e) => e.to_py(),
            core::Error::Material(e) => e.to_py(),
            core::Error::Solver(e) => e.to_py(),
            core::Error::Hyperelastic(e) => e.to_py(),
            core::Error::Contact(e) => e.to_py(),
        }
    }
}

impl ToPyErr for core::HyperelasticError {
    fn to_py(self) -> PyErr {
        match self {
            core::HyperelasticError::Mesh(e) => e.to_py(),
            core::HyperelasticError::Material(e) => e.to_py(),
            e => FiniteStrainError::new_err(e.to_string()),
        }
    }
}

/// `result.py()?` in binding code.
pub trait PyResultExt<T> {
    /// Maps the error to its Python exception.
    fn py(self) -> PyResult<T>;
}
impl<T, E: ToPyErr> PyResultExt<T> for Result<T, E> {
    fn py(self) -> PyResult<T> {
        self.map_err(ToPyErr::to_py)
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("VfrsError", py.get_type::<VfrsError>())?;
    m.add("MeshError", py.get_type::<MeshError>())?;
    m.add("MaterialError", py.get_type::<MaterialError>())?;
    m.add("SolverError", py.get_type::<SolverError>())?;
    m.add("ContactError", py.get_type::<ContactError>())?;
    m.add("FiniteStrainError", py.get_type::<FiniteStrainError>())?;
    Ok(())
}
