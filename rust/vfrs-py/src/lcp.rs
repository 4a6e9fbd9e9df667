//! The contact methods' LCPs (`vfrs_core::contact::lcp`): small dense systems, same bits on every CPU.

use crate::errors::PyResultExt;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use vfrs_core::contact::lcp::{self, LcpInfo, LcpParams};

/// (values, iterations, pivots, converged, condition, residual): what the Python side wraps.
type Solved<'py> = (Bound<'py, PyArray1<f64>>, usize, usize, bool, f64, f64);

fn square(name: &str, a: &PyReadonlyArray2<'_, f64>, m: usize) -> PyResult<Vec<f64>> {
    if a.shape() != [m, m] {
        return Err(PyValueError::new_err(format!(
            "{name} has shape {:?}, expected ({m}, {m}) for {m} pairs",
            a.shape()
        )));
    }
    // Row-major: an array in another order is read in logical order.
    Ok(match crate::convert::c_order(a) {
        Some(s) => s.to_vec(),
        None => a.as_array().iter().copied().collect(),
    })
}

fn vector(a: &PyReadonlyArray1<'_, f64>) -> Vec<f64> {
    match a.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => a.as_array().iter().copied().collect(),
    }
}

fn flags(a: &Option<PyReadonlyArray1<'_, bool>>) -> Option<Vec<bool>> {
    a.as_ref().map(|a| a.as_array().iter().copied().collect())
}

fn out(py: Python<'_>, (lam, info): (Vec<f64>, LcpInfo)) -> Solved<'_> {
    (
        lam.into_pyarray(py),
        info.iterations,
        info.pivots,
        info.converged,
        info.condition,
        info.residual,
    )
}

/// `lam >= 0, y = A lam + q >= 0, lam . y = 0` for a symmetric positive definite `A`.
#[pyfunction]
#[pyo3(signature = (a, q, start=None, max_iterations=200, backup_after=3))]
pub fn lcp_solve<'py>(
    py: Python<'py>,
    a: PyReadonlyArray2<'_, f64>,
    q: PyReadonlyArray1<'_, f64>,
    start: Option<PyReadonlyArray1<'_, bool>>,
    max_iterations: usize,
    backup_after: usize,
) -> PyResult<Solved<'py>> {
    let q = vector(&q);
    let a = square("A", &a, q.len())?;
    let start = flags(&start);
    let params = LcpParams {
        max_iterations,
        backup_after,
        ..LcpParams::default()
    };
    let r = py
        .detach(|| lcp::solve(&a, &q, start.as_deref(), &params))
        .py()?;
    Ok(out(py, r))
}

/// Lagrange multipliers on the Delassus operator `W` and the gaps `g0`.
#[pyfunction]
#[pyo3(signature = (w, g0, start=None, max_iterations=200, regularization=1e-12))]
pub fn lcp_lagrange<'py>(
    py: Python<'py>,
    w: PyReadonlyArray2<'_, f64>,
    g0: PyReadonlyArray1<'_, f64>,
    start: Option<PyReadonlyArray1<'_, bool>>,
    max_iterations: usize,
    regularization: f64,
) -> PyResult<Solved<'py>> {
    let g0 = vector(&g0);
    let w = square("W", &w, g0.len())?;
    let start = flags(&start);
    let params = LcpParams {
        max_iterations,
        regularization,
        ..LcpParams::default()
    };
    let r = py
        .detach(|| lcp::lagrange(&w, &g0, start.as_deref(), &params))
        .py()?;
    Ok(out(py, r))
}

/// Penalty `lam = max(0, shift - kappa g)`, `g = g0 + W lam`.
#[pyfunction]
#[pyo3(signature = (w, g0, kappa, shift=None, start=None, max_iterations=200))]
pub fn lcp_penalty<'py>(
    py: Python<'py>,
    w: PyReadonlyArray2<'_, f64>,
    g0: PyReadonlyArray1<'_, f64>,
    kappa: PyReadonlyArray1<'_, f64>,
    shift: Option<PyReadonlyArray1<'_, f64>>,
    start: Option<PyReadonlyArray1<'_, bool>>,
    max_iterations: usize,
) -> PyResult<Solved<'py>> {
    let g0 = vector(&g0);
    let w = square("W", &w, g0.len())?;
    let kappa = vector(&kappa);
    let shift = shift.as_ref().map(vector);
    let start = flags(&start);
    let params = LcpParams {
        max_iterations,
        ..LcpParams::default()
    };
    let r = py
        .detach(|| lcp::penalty(&w, &g0, &kappa, shift.as_deref(), start.as_deref(), &params))
        .py()?;
    Ok(out(py, r))
}

/// Fills `vfrs._core.lcp`.
pub fn register(c: &Bound<'_, PyModule>) -> PyResult<()> {
    c.add_function(wrap_pyfunction!(lcp_solve, c)?)?;
    c.add_function(wrap_pyfunction!(lcp_lagrange, c)?)?;
    c.add_function(wrap_pyfunction!(lcp_penalty, c)?)?;
    Ok(())
}
