//! `vfrs._core`: thin pyo3 bindings over `vfrs-core`. Argument conversion and error mapping
//! live here; the numerics live in the core crate. Long calls release the GIL.
//!
//! One submodule per concept of the core crate, each importable as `vfrs._core.<name>`:
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
mod solver;
mod spmv;

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
    submodule(m, "fem", |f| {
        f.add_function(wrap_pyfunction!(fem::signed_volumes, f)?)?;
        f.add_function(wrap_pyfunction!(fem::validate_mesh, f)?)?;
        f.add_function(wrap_pyfunction!(fem::refine_tets, f)?)?;
        f.add_function(wrap_pyfunction!(fem::elasticity_isotropic, f)?)?;
        f.add_function(wrap_pyfunction!(fem::elasticity_transversely_isotropic, f)?)?;
        f.add_class::<fem::PyAssembler>()?;
        f.add_class::<fem::PyPressureLoad>()?;
        Ok(())
    })?;
    submodule(m, "hyperelastic", |h| {
        h.add_class::<hyperelastic::PyHyperelasticMaterial>()?;
        h.add_class::<hyperelastic::PyFiniteStrainAssembler>()?;
        h.add_function(wrap_pyfunction!(hyperelastic::neo_hookean, h)?)?;
        h.add_function(wrap_pyfunction!(hyperelastic::neo_hookean_from_young, h)?)?;
        h.add_function(wrap_pyfunction!(hyperelastic::st_venant_kirchhoff, h)?)?;
        h.add_function(wrap_pyfunction!(hyperelastic::fibre_reinforced, h)?)?;
        Ok(())
    })?;
    submodule(m, "linalg", |l| {
        l.add_class::<solver::PyCholesky>()?;
        l.add_class::<solver::PyDofMap>()?;
        l.add_function(wrap_pyfunction!(solver::combine_rows, l)?)?;
        l.add_function(wrap_pyfunction!(solver::delassus, l)?)?;
        l.add_class::<spmv::PyBlocked>()?;
        l.add_function(wrap_pyfunction!(spmv::sum_of_products, l)?)?;
        l.add_function(wrap_pyfunction!(spmv::csr_matvec, l)?)?;
        l.add_function(wrap_pyfunction!(spmv::csr_rmatvec, l)?)?;
        Ok(())
    })?;
    submodule(m, "lcp", |c| {
        c.add_function(wrap_pyfunction!(lcp::lcp_solve, c)?)?;
        c.add_function(wrap_pyfunction!(lcp::lcp_lagrange, c)?)?;
        c.add_function(wrap_pyfunction!(lcp::lcp_penalty, c)?)?;
        Ok(())
    })?;
    submodule(m, "contact", contact::register)?;
    Ok(())
}
