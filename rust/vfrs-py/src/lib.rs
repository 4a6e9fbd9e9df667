//! `vfrs._core`: thin pyo3 bindings over `vfrs-core`. Argument conversion and error mapping
//! live here; the numerics live in the core crate. Long calls release the GIL.
//!
//! One submodule per concept of the core crate, each importable as `vfrs._core.<name>`, each
//! in its own file with its own `register()`:
//! `errors` (the exception classes), `fem` (mesh checks, elasticity, assembly, pressure
//! loads), `hyperelastic` (finite-strain materials and assembly), `linalg` (Cholesky, the DOF
//! map, compliance products, node-blocked sparse products), `lcp` (the contact LCPs) and
//! `contact` (projection, constraint matrix, the BVH and interface-mesh engines).

use pyo3::prelude::*;

mod contact;
mod convert;
mod errors;
mod fem;
mod hyperelastic;
mod lcp;
mod linalg;

/// A submodule `vfrs._core.<name>`, filled by `fill`, attached to the parent and entered in
/// `sys.modules` so that `import vfrs._core.<name>` works as well as attribute access.
fn submodule(
    parent: &Bound<'_, PyModule>,
    name: &str,
    fill: impl FnOnce(&Bound<'_, PyModule>) -> PyResult<()>,
) -> PyResult<()> {
    let py = parent.py();
    let m = PyModule::new(py, name)?;
    fill(&m)?;
    parent.add_submodule(&m)?;
    let full = format!("vfrs._core.{name}");
    m.setattr("__name__", &full)?;
    py.import("sys")?.getattr("modules")?.set_item(full, &m)?;
    Ok(())
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    submodule(m, "errors", errors::register)?;
    submodule(m, "fem", fem::register)?;
    submodule(m, "hyperelastic", hyperelastic::register)?;
    submodule(m, "linalg", linalg::register)?;
    submodule(m, "lcp", lcp::register)?;
    submodule(m, "contact", contact::register)?;
    Ok(())
}
