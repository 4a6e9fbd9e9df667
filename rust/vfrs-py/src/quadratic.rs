//! `vfrs._core.fem.QuadraticAssembler`: the P2 (ten-node) tetrahedra's assembly (issue 47).

use crate::convert;
use crate::errors::PyResultExt;
use crate::fem::{body_inputs, materials};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use vfrs_core::QuadraticAssembler;

/// The fixed CSC pattern of a mesh of ten-node tetrahedra (VTK's node order: vertices, then the
/// mid-edge nodes of edges 0-1, 1-2, 0-2, 0-3, 1-3, 2-3) and the in-place, parallel filling of
/// its stiffness and mass; the same calls as `Assembler`.
#[pyclass(name = "QuadraticAssembler", module = "vfrs._core.fem", frozen)]
pub struct PyQuadraticAssembler {
    inner: QuadraticAssembler,
}

#[pymethods]
impl PyQuadraticAssembler {
    #[new]
    fn new(py: Python<'_>, n_points: usize, tets: PyReadonlyArray2<'_, i64>) -> PyResult<Self> {
        let t = convert::index_rows::<10>("tets", &tets)?;
        let inner = py.detach(|| QuadraticAssembler::new(n_points, &t)).py()?;
        Ok(Self { inner })
    }

    /// Number of stored entries.
    #[getter]
    fn nnz(&self) -> usize {
        self.inner.nnz()
    }

    /// (indptr, indices) of the CSC pattern (also the CSR arrays: the matrices are symmetric).
    fn pattern<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>) {
        convert::pattern(py, self.inner.col_ptr(), self.inner.row_idx())
    }

    /// Stiffness values in pattern order. `elasticity`: (k, 6, 6); `material_of`: (m,) or None.
    #[pyo3(signature = (points, elasticity, material_of=None))]
    fn stiffness<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        elasticity: PyReadonlyArray3<'py, f64>,
        material_of: Option<PyReadonlyArray1<'py, i64>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (p, mo) = body_inputs(&points, material_of)?;
        let d = materials(&elasticity)?;
        let mut values = vec![0.0; self.inner.nnz()];
        py.detach(|| {
            self.inner
                .stiffness_into(&p, &d, mo.as_deref(), &mut values)
        })
        .py()?;
        Ok(values.into_pyarray(py))
    }

    /// Consistent mass values in pattern order. `rho`: (k,) densities.
    #[pyo3(signature = (points, rho, material_of=None))]
    fn mass<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        rho: PyReadonlyArray1<'py, f64>,
        material_of: Option<PyReadonlyArray1<'py, i64>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (p, mo) = body_inputs(&points, material_of)?;
        let r = convert::floats(&rho);
        let mut values = vec![0.0; self.inner.nnz()];
        py.detach(|| self.inner.mass_into(&p, &r, mo.as_deref(), &mut values))
            .py()?;
        Ok(values.into_pyarray(py))
    }

    /// HRZ lumped mass per DOF (positive, summing to the mass), length 3n.
    #[pyo3(signature = (points, rho, material_of=None))]
    fn lumped_mass<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        rho: PyReadonlyArray1<'py, f64>,
        material_of: Option<PyReadonlyArray1<'py, i64>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (p, mo) = body_inputs(&points, material_of)?;
        let r = convert::floats(&rho);
        let v = self.inner.lumped_mass(&p, &r, mo.as_deref()).py()?;
        Ok(v.into_pyarray(py))
    }
}
