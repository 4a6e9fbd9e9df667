//! Contact-geometry bindings (projection, detection, constraint matrix).

use pyo3::prelude::*;

/// Adds the contact functions and classes to `vfrs._core`.
pub fn register(_m: &Bound<'_, PyModule>) -> PyResult<()> {
    Ok(())
}
