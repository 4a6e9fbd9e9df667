//! numpy arrays to Rust slices and back, with shape checks that name the argument.

use numpy::ndarray::Dimension;
use numpy::{
    Element, IntoPyArray, PyArray1, PyReadonlyArray, PyReadonlyArray1, PyReadonlyArray2,
    PyReadwriteArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The data of a C-contiguous array, in row-major order. numpy's `as_slice` also hands out
/// the memory of an F-contiguous array, whose entries are then in column-major order: a
/// row-major reader would silently take them for others (an F-ordered (2, 3) store read as
/// rows gave [1, 10, 2] for its row [1, 2, 3]). Those, and non-contiguous arrays, are
/// refused with the argument's name.
pub fn c_slice<'a, T: Element, D: Dimension>(
    name: &str,
    a: &'a PyReadonlyArray<'_, T, D>,
) -> PyResult<&'a [T]> {
    c_order(a).ok_or_else(|| not_c(name, a.shape()))
}

/// [`c_slice`]'s data, or None where the caller copies the array in logical order instead.
pub fn c_order<'a, T: Element, D: Dimension>(a: &'a PyReadonlyArray<'_, T, D>) -> Option<&'a [T]> {
    a.as_slice().ok().filter(|_| a.is_c_contiguous())
}

/// [`c_slice`] for an array written in place.
pub fn c_slice_mut<'a, T: Element, D: Dimension>(
    name: &str,
    a: &'a mut PyReadwriteArray<'_, T, D>,
) -> PyResult<&'a mut [T]> {
    let shape = a.shape().to_vec();
    if !a.is_c_contiguous() {
        return Err(not_c(name, &shape));
    }
    a.as_slice_mut().map_err(|_| not_c(name, &shape))
}

fn not_c(name: &str, shape: &[usize]) -> PyErr {
    PyValueError::new_err(format!(
        "{name} (shape {shape:?}) must be a C-contiguous array: pass np.ascontiguousarray({name})"
    ))
}

/// An (n, 3) float64 array as points.
pub fn points(name: &str, a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<[f64; 3]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (n, 3), got {:?}",
            v.shape()
        )));
    }
    Ok(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

/// An (m, K) int64 array as rows of K indices, rejecting negatives with their position.
pub fn index_rows<const K: usize>(
    name: &str,
    a: &PyReadonlyArray2<'_, i64>,
) -> PyResult<Vec<[usize; K]>> {
    let v = a.as_array();
    if v.ncols() != K {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (m, {K}), got {:?}",
            v.shape()
        )));
    }
    let mut out = Vec::with_capacity(v.nrows());
    for (r, row) in v.rows().into_iter().enumerate() {
        let mut t = [0usize; K];
        for (k, &i) in row.iter().enumerate() {
            if i < 0 {
                return Err(PyValueError::new_err(format!(
                    "{name}[{r}, {k}] = {i} is negative"
                )));
            }
            t[k] = i as usize;
        }
        out.push(t);
    }
    Ok(out)
}

/// A 1-D int64 array as indices.
pub fn indices(name: &str, a: &PyReadonlyArray1<'_, i64>) -> PyResult<Vec<usize>> {
    a.as_array()
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            if i < 0 {
                Err(PyValueError::new_err(format!(
                    "{name}[{k}] = {i} is negative"
                )))
            } else {
                Ok(i as usize)
            }
        })
        .collect()
}

/// A 1-D float64 array as a contiguous Vec.
pub fn floats(a: &PyReadonlyArray1<'_, f64>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

/// (indptr, indices) of an assembler's CSC pattern as int64 arrays (the matrices are
/// symmetric, so these are also the CSR arrays).
pub fn pattern<'py>(
    py: Python<'py>,
    col_ptr: &[usize],
    row_idx: &[usize],
) -> (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>) {
    let cp: Vec<i64> = col_ptr.iter().map(|&x| x as i64).collect();
    let ri: Vec<i64> = row_idx.iter().map(|&x| x as i64).collect();
    (cp.into_pyarray(py), ri.into_pyarray(py))
}
