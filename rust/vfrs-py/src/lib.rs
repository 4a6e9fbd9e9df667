//! `vfrs._core`: thin pyo3 bindings over `vfrs-core`. Argument conversion and error mapping
//! live here; the numerics live in the core crate. Long calls release the GIL.

use pyo3::prelude::*;

mod contact;
mod convert;
mod errors;
mod fem;
mod hyperelastic;
mod lcp;
mod solver;
mod spmv;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_function(wrap_pyfunction!(fem::signed_volumes, m)?)?;
    m.add_function(wrap_pyfunction!(fem::validate_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(fem::elasticity_isotropic, m)?)?;
    m.add_function(wrap_pyfunction!(fem::elasticity_transversely_isotropic, m)?)?;
    m.add_class::<fem::PyAssembler>()?;
    m.add_class::<fem::PyPressureLoad>()?;
    m.add_class::<hyperelastic::PyHyperelasticMaterial>()?;
    m.add_class::<hyperelastic::PyFiniteStrainAssembler>()?;
    m.add_function(wrap_pyfunction!(hyperelastic::neo_hookean, m)?)?;
    m.add_function(wrap_pyfunction!(hyperelastic::neo_hookean_from_young, m)?)?;
    m.add_function(wrap_pyfunction!(hyperelastic::st_venant_kirchhoff, m)?)?;
    m.add_function(wrap_pyfunction!(hyperelastic::fibre_reinforced, m)?)?;
    m.add_class::<solver::PyCholesky>()?;
    m.add_class::<solver::PyDofMap>()?;
    m.add_function(wrap_pyfunction!(solver::combine_rows, m)?)?;
    m.add_function(wrap_pyfunction!(solver::delassus, m)?)?;
    m.add_class::<spmv::PyBlocked>()?;
    m.add_function(wrap_pyfunction!(spmv::sum_of_products, m)?)?;
    m.add_function(wrap_pyfunction!(spmv::csr_matvec, m)?)?;
    m.add_function(wrap_pyfunction!(spmv::csr_rmatvec, m)?)?;
    m.add_function(wrap_pyfunction!(lcp::lcp_solve, m)?)?;
    m.add_function(wrap_pyfunction!(lcp::lcp_lagrange, m)?)?;
    m.add_function(wrap_pyfunction!(lcp::lcp_penalty, m)?)?;
    contact::register(m)?;
    Ok(())
}
