//! `vfrs._core.linalg`: the sparse Cholesky and the Dirichlet DOF map ([`cholesky`]),
//! products with compliance columns and the Delassus operator, node-blocked sparse products
//! ([`spmv`]).

use pyo3::prelude::*;

mod cholesky;
mod spmv;

/// Fills `vfrs._core.linalg`.
pub fn register(l: &Bound<'_, PyModule>) -> PyResult<()> {
    l.add_class::<cholesky::PyCholesky>()?;
    l.add_class::<cholesky::PyDofMap>()?;
    l.add_function(wrap_pyfunction!(cholesky::combine_rows, l)?)?;
    l.add_function(wrap_pyfunction!(cholesky::combine_rows_single, l)?)?;
    l.add_function(wrap_pyfunction!(cholesky::delassus, l)?)?;
    l.add_class::<spmv::PyBlocked>()?;
    l.add_function(wrap_pyfunction!(spmv::sum_of_products, l)?)?;
    l.add_function(wrap_pyfunction!(spmv::csr_matvec, l)?)?;
    l.add_function(wrap_pyfunction!(spmv::csr_rmatvec, l)?)?;
    Ok(())
}
