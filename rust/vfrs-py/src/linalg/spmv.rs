//! Products of node-blocked sparse matrices (`vfrs_core::linalg::spmv`): the same bits as scipy's.

use crate::convert;
use crate::errors::PyResultExt;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadwriteArray1, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use vfrs_core::linalg::spmv::{self, Blocked};

/// A node-blocked CSR matrix kept in Rust for repeated products (copied once).
#[pyclass(name = "Blocked", module = "vfrs._core.linalg", frozen)]
pub struct PyBlocked {
    inner: Blocked,
}

#[pymethods]
impl PyBlocked {
    /// The CSR arrays as a node-blocked matrix (`kind` "full": 3 x 3 blocks, "kron":
    /// m (x) I_3), or None when the matrix is not of that kind.
    #[staticmethod]
    fn from_csr(
        kind: &str,
        cols: usize,
        indptr: PyReadonlyArray1<'_, i64>,
        indices: PyReadonlyArray1<'_, i64>,
        data: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Option<Self>> {
        let ip = convert::indices("indptr", &indptr)?;
        let ix = convert::indices("indices", &indices)?;
        let v = convert::floats(&data);
        let inner = match kind {
            "full" => Blocked::full(cols, &ip, &ix, &v).py()?,
            "kron" => Blocked::kron(cols, &ip, &ix, &v).py()?,
            other => {
                return Err(PyValueError::new_err(format!(
                    "kind {other:?}: choose 'full' or 'kron'"
                )))
            }
        };
        Ok(inner.map(|inner| Self { inner }))
    }

    #[getter]
    fn shape(&self) -> (usize, usize) {
        (self.inner.rows(), self.inner.cols())
    }
}

/// `out = A_0 x_0 + A_1 x_1 + ...` for `terms = [(A_0, x_0), ...]`: scipy's
/// `r = A_0 @ x_0; r += A_1 @ x_1; ...` bit for bit. The GIL is released.
#[pyfunction]
pub fn sum_of_products(
    py: Python<'_>,
    terms: Vec<(Bound<'_, PyBlocked>, PyReadonlyArray1<'_, f64>)>,
    mut out: PyReadwriteArray1<'_, f64>,
) -> PyResult<()> {
    let mut pairs: Vec<(&Blocked, &[f64])> = Vec::with_capacity(terms.len());
    for (k, (a, x)) in terms.iter().enumerate() {
        let x = x.as_slice().map_err(|_| {
            PyValueError::new_err(format!("term {k}: the vector must be contiguous"))
        })?;
        pairs.push((&a.get().inner, x));
    }
    let n = out.len();
    let o = out
        .as_slice_mut()
        .map_err(|_| PyValueError::new_err(format!("out ({n} entries) must be contiguous")))?;
    py.detach(|| spmv::sum_of_products(&pairs, o)).py()
}

/// `A x` for a general CSR matrix (`cols` columns): scipy's CSR product, bit for bit.
#[pyfunction]
pub fn csr_matvec<'py>(
    py: Python<'py>,
    cols: usize,
    indptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    data: PyReadonlyArray1<'_, f64>,
    x: PyReadonlyArray1<'_, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let ip = convert::indices("indptr", &indptr)?;
    let ix = convert::indices("indices", &indices)?;
    let mut out = vec![0.0; ip.len().saturating_sub(1)];
    let (v, x) = (contiguous("data", &data)?, contiguous("x", &x)?);
    spmv::csr_matvec(cols, &ip, &ix, v, x, &mut out).py()?;
    Ok(out.into_pyarray(py))
}

/// `A^T y` (dense, `cols` entries) for a general CSR matrix: scipy's `A.T @ y`, bit for bit.
#[pyfunction]
pub fn csr_rmatvec<'py>(
    py: Python<'py>,
    cols: usize,
    indptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    data: PyReadonlyArray1<'_, f64>,
    y: PyReadonlyArray1<'_, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let ip = convert::indices("indptr", &indptr)?;
    let ix = convert::indices("indices", &indices)?;
    let mut out = vec![0.0; cols];
    let (v, y) = (contiguous("data", &data)?, contiguous("y", &y)?);
    spmv::csr_rmatvec(cols, &ip, &ix, v, y, &mut out).py()?;
    Ok(out.into_pyarray(py))
}

fn contiguous<'a>(name: &str, a: &'a PyReadonlyArray1<'_, f64>) -> PyResult<&'a [f64]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name} must be contiguous")))
}
