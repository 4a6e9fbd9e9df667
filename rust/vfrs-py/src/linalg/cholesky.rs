//! Sparse Cholesky and the Dirichlet DOF map.

use crate::convert;
use crate::errors::PyResultExt;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods, PyReadonlyArray1,
    PyReadonlyArray2, PyReadonlyArrayDyn, PyReadwriteArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use vfrs_core::{Cholesky, CholeskyParams, DofMap, Ordering};

/// Sparse LL^T factorization (`vfrs_core::Cholesky`). Symbolic analysis once; `refactor`
/// reuses it.
#[pyclass(name = "Cholesky", module = "vfrs._core.linalg")]
pub struct PyCholesky {
    inner: Cholesky,
}

fn parse_ordering(s: &str) -> PyResult<Ordering> {
    Ok(match s {
        "auto" => Ordering::Auto,
        "amd" => Ordering::Amd,
        "nested_dissection" | "nd" => Ordering::NestedDissection,
        "identity" | "natural" => Ordering::Identity,
        other => {
            return Err(PyValueError::new_err(format!(
            "unknown ordering {other:?}: choose 'auto', 'amd', 'nested_dissection' or 'identity'"
        )))
        }
    })
}

impl PyCholesky {
    /// The rows of unit right-hand sides, checked against the matrix size.
    fn unit_rows(&self, rows: &PyReadonlyArray1<'_, i64>) -> PyResult<Vec<usize>> {
        let n = self.inner.n();
        let r = convert::indices("rows", rows)?;
        if let Some(&i) = r.iter().find(|&&i| i >= n) {
            return Err(PyValueError::new_err(format!(
                "row {i} is out of range (the matrix has {n})"
            )));
        }
        Ok(r)
    }

    /// Sets the unit entries of the zeroed column-major `x` (n x rows.len()) and solves in
    /// place, the GIL released.
    fn solve_units(&mut self, py: Python<'_>, x: &mut [f64], rows: &[usize]) -> PyResult<()> {
        let n = self.inner.n();
        for (j, &i) in rows.iter().enumerate() {
            x[j * n + i] = 1.0;
        }
        let inner = &mut self.inner;
        py.detach(|| inner.solve_sparse_rhs_in_place(x, rows.len(), rows))
            .py()
    }
}

#[pymethods]
impl PyCholesky {
    #[new]
    #[pyo3(signature = (n, indptr, indices, data, ordering="auto", parallel=true, check_symmetry=true))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        n: usize,
        indptr: PyReadonlyArray1<'_, i64>,
        indices: PyReadonlyArray1<'_, i64>,
        data: PyReadonlyArray1<'_, f64>,
        ordering: &str,
        parallel: bool,
        check_symmetry: bool,
    ) -> PyResult<Self> {
        let cp = convert::indices("indptr", &indptr)?;
        let ri = convert::indices("indices", &indices)?;
        let v = convert::floats(&data);
        let params = CholeskyParams {
            ordering: parse_ordering(ordering)?,
            parallel,
            check_symmetry,
        };
        let inner = py.detach(|| Cholesky::new(n, &cp, &ri, &v, params)).py()?;
        Ok(Self { inner })
    }

    /// New values, same pattern (values in the order of the first matrix's stored entries).
    fn refactor(&mut self, py: Python<'_>, data: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        let v = convert::floats(&data);
        let inner = &mut self.inner;
        py.detach(|| inner.refactor(&v)).py()
    }

    /// Refactor after checking the pattern is the one analysed.
    fn refactor_with_pattern(
        &mut self,
        py: Python<'_>,
        indptr: PyReadonlyArray1<'_, i64>,
        indices: PyReadonlyArray1<'_, i64>,
        data: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<()> {
        let cp = convert::indices("indptr", &indptr)?;
        let ri = convert::indices("indices", &indices)?;
        let v = convert::floats(&data);
        let inner = &mut self.inner;
        py.detach(|| inner.refactor_with_pattern(&cp, &ri, &v)).py()
    }

    /// Solves A x = b for b of shape (n,) or (n, k); returns a new array of b's shape.
    fn solve<'py>(
        &mut self,
        py: Python<'py>,
        b: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let n = self.inner.n();
        let shape = b.shape().to_vec();
        let (rows, k) = match shape.as_slice() {
            [r] => (*r, 1),
            [r, k] => (*r, *k),
            _ => {
                return Err(PyValueError::new_err(format!(
                    "b must be 1-D or 2-D, got shape {shape:?}"
                )))
            }
        };
        if rows != n {
            return Err(PyValueError::new_err(format!(
                "b has {rows} rows, the matrix has {n}"
            )));
        }
        let a = b.as_array();
        // Column-major copy: the solve works on columns in place. Read in the array's own
        // memory order (a C-ordered (n, k) array row by row, an F-ordered one column by
        // column) rather than through a generic n-d index.
        let mut x = vec![0.0; n * k];
        let at = a.t();
        if let Some(src) = a.as_slice() {
            // C order (logical order in memory).
            if shape.len() == 1 || k <= 1 {
                x.copy_from_slice(src);
            } else {
                for (i, row) in src.chunks_exact(k).enumerate() {
                    for (j, v) in row.iter().enumerate() {
                        x[j * n + i] = *v;
                    }
                }
            }
        } else if let (2, Some(src)) = (shape.len(), at.as_slice()) {
            // F order: already column-major.
            x.copy_from_slice(src);
        } else if shape.len() == 1 {
            for (xi, v) in x.iter_mut().zip(a.iter()) {
                *xi = *v;
            }
        } else {
            for ((i, j), v) in a.indexed_iter().map(|(ix, v)| ((ix[0], ix[1]), v)) {
                x[j * n + i] = *v;
            }
        }
        if let Some(p) = x.iter().position(|v| !v.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "b has a non-finite entry at flat index {p} (column-major)"
            )));
        }
        let inner = &mut self.inner;
        py.detach(|| inner.solve_in_place(&mut x, k)).py()?;
        if shape.len() == 1 {
            x.into_pyarray(py).reshape(vec![n])
        } else {
            // x is column-major n x k: a (k, n) C array, transposed (an F-ordered view).
            x.into_pyarray(py).reshape(vec![k, n])?.transpose()
        }
    }

    /// Columns of A^-1: the solutions for the unit right-hand sides e_r, r in `rows`, as an
    /// (n, len(rows)) F-ordered array. The forward substitution visits only the supernodes
    /// reached from those rows (the values are the dense solve's); the GIL is released.
    fn unit_columns<'py>(
        &mut self,
        py: Python<'py>,
        rows: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let n = self.inner.n();
        let r = self.unit_rows(&rows)?;
        let k = r.len();
        let mut x = vec![0.0; n * k];
        self.solve_units(py, &mut x, &r)?;
        x.into_pyarray(py).reshape(vec![k, n])?.transpose()
    }

    /// [`unit_columns`](Self::unit_columns) written into `out`, a C-contiguous
    /// (len(rows), n) array (column j of A^-1 e_r is row j of `out`): a compliance solves
    /// straight into its store, with no temporary and no copy. `out` is overwritten.
    fn unit_columns_into(
        &mut self,
        py: Python<'_>,
        rows: PyReadonlyArray1<'_, i64>,
        mut out: PyReadwriteArray2<'_, f64>,
    ) -> PyResult<()> {
        let n = self.inner.n();
        let r = self.unit_rows(&rows)?;
        if out.shape() != [r.len(), n] {
            return Err(PyValueError::new_err(format!(
                "out has shape {:?}, expected ({}, {n}): one row per unit column",
                out.shape(),
                r.len()
            )));
        }
        let x = convert::c_slice_mut("out", &mut out)?;
        x.fill(0.0);
        self.solve_units(py, x, &r)
    }

    /// Matrix size.
    #[getter]
    fn n(&self) -> usize {
        self.inner.n()
    }

    /// Stored entries of the factor L.
    #[getter]
    fn nnz_factor(&self) -> usize {
        self.inner.nnz_factor()
    }

    /// Entries of L in its lower triangle (what CHOLMOD reports as nnz(L));
    /// `nnz_factor` also counts the upper halves of the supernodes' stored diagonal blocks.
    #[getter]
    fn nnz_factor_lower(&self) -> usize {
        self.inner.nnz_factor_lower()
    }

    /// Ordering used: "amd", "nested_dissection", "identity" or "custom".
    #[getter]
    fn ordering(&self) -> &'static str {
        self.inner.ordering()
    }
}

/// An int64 index array handed to Python.
type IndexArray<'py> = Bound<'py, PyArray1<i64>>;

/// Dirichlet elimination map.
#[pyclass(name = "DofMap", module = "vfrs._core.linalg", frozen)]
pub struct PyDofMap {
    inner: DofMap,
}

#[pymethods]
impl PyDofMap {
    #[new]
    fn new(n_dofs: usize, fixed: PyReadonlyArray1<'_, i64>) -> PyResult<Self> {
        let f = convert::indices("fixed", &fixed)?;
        Ok(Self {
            inner: DofMap::new(n_dofs, &f).py()?,
        })
    }

    /// Free DOFs, increasing.
    #[getter]
    fn free<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        self.inner
            .free()
            .iter()
            .map(|&d| d as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py)
    }

    /// Total DOFs.
    #[getter]
    fn n_dofs(&self) -> usize {
        self.inner.n_dofs()
    }

    /// (indptr, indices, source) of the free-free block of a CSC pattern; `source[k]` is the
    /// index in the full matrix's data of reduced entry k.
    fn reduce_pattern<'py>(
        &self,
        py: Python<'py>,
        indptr: PyReadonlyArray1<'py, i64>,
        indices: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<(IndexArray<'py>, IndexArray<'py>, IndexArray<'py>)> {
        let cp = convert::indices("indptr", &indptr)?;
        let ri = convert::indices("indices", &indices)?;
        let (c, r, s) = self.inner.reduce_pattern(&cp, &ri).py()?;
        let conv = |v: Vec<usize>| {
            v.into_iter()
                .map(|x| x as i64)
                .collect::<Vec<_>>()
                .into_pyarray(py)
        };
        Ok((conv(c), conv(r), conv(s)))
    }
}

/// `out[i, c] = sum_j coeffs[j, c] * store[slots[j], i]`: forces on a few DOFs combined
/// from their stored compliance columns (one per row of `store`), written into `out`
/// (C-contiguous, shape (n, m), n the store's row length). The GIL is released.
#[pyfunction]
pub fn combine_rows(
    py: Python<'_>,
    store: PyReadonlyArray2<'_, f64>,
    slots: PyReadonlyArray1<'_, i64>,
    coeffs: PyReadonlyArray2<'_, f64>,
    out: PyReadwriteArray2<'_, f64>,
) -> PyResult<()> {
    combine(py, store, slots, coeffs, out)
}

/// [`combine_rows`] with single-precision columns (`store` float32; the sums in double
/// precision).
#[pyfunction]
pub fn combine_rows_single(
    py: Python<'_>,
    store: PyReadonlyArray2<'_, f32>,
    slots: PyReadonlyArray1<'_, i64>,
    coeffs: PyReadonlyArray2<'_, f64>,
    out: PyReadwriteArray2<'_, f64>,
) -> PyResult<()> {
    combine(py, store, slots, coeffs, out)
}

fn combine<T: numpy::Element + Copy + Into<f64> + Sync>(
    py: Python<'_>,
    store: PyReadonlyArray2<'_, T>,
    slots: PyReadonlyArray1<'_, i64>,
    coeffs: PyReadonlyArray2<'_, f64>,
    mut out: PyReadwriteArray2<'_, f64>,
) -> PyResult<()> {
    let n = store.shape()[1];
    let m = coeffs.shape()[1];
    if coeffs.shape()[0] != slots.len() {
        return Err(PyValueError::new_err(format!(
            "coeffs has {} rows for {} slots",
            coeffs.shape()[0],
            slots.len()
        )));
    }
    if out.shape() != [n, m] {
        return Err(PyValueError::new_err(format!(
            "out has shape {:?}, expected ({n}, {m})",
            out.shape()
        )));
    }
    let s = convert::indices("slots", &slots)?;
    let store = convert::c_slice("store", &store)?;
    let c = coeffs.as_array().iter().copied().collect::<Vec<f64>>();
    let o = convert::c_slice_mut("out", &mut out)?;
    py.detach(|| vfrs_core::linalg::compliance::combine_rows(store, n, &s, &c, m, o))
        .py()
}

/// `W = scale G S G^T` (dense, pairs x pairs, exactly symmetric) for the CSR constraint
/// matrix `G` (`indptr`, `indices`, `data`), the compliance `S` (its leading `n x n` block
/// valid) and `col_of` (each DOF's index in `S`, negative for fixed DOFs, whose entries of
/// `G` are skipped). Only the entries of `S` on `G`'s DOFs are read.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn delassus<'py>(
    py: Python<'py>,
    indptr: PyReadonlyArray1<'_, i64>,
    indices: PyReadonlyArray1<'_, i64>,
    data: PyReadonlyArray1<'_, f64>,
    col_of: PyReadonlyArray1<'_, i64>,
    s: PyReadonlyArray2<'_, f64>,
    n: usize,
    scale: f64,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let ip = convert::indices("indptr", &indptr)?;
    let ix = convert::indices("indices", &indices)?;
    let d = data
        .as_slice()
        .map_err(|_| PyValueError::new_err("data must be contiguous"))?;
    let c = col_of
        .as_slice()
        .map_err(|_| PyValueError::new_err("col_of must be contiguous"))?;
    let shape = s.shape();
    if n > shape[0] || n > shape[1] {
        return Err(PyValueError::new_err(format!(
            "S has shape {shape:?}: no {n} x {n} block"
        )));
    }
    let stride = shape[1];
    let sv = convert::c_slice("S", &s)?;
    let m = ip.len().saturating_sub(1);
    let mut out = vec![0.0; m * m];
    py.detach(|| {
        vfrs_core::linalg::compliance::delassus(&ip, &ix, d, c, sv, n, stride, scale, &mut out)
    })
    .py()?;
    PyArray1::from_vec(py, out).reshape([m, m])
}
