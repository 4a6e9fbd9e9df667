//! Contact-geometry bindings (projection, detection, constraint matrix).
//!
//! Long calls release the GIL. Points arrays that are C-contiguous float64 are read in place
//! (no copy); detectors keep their Rust buffers between calls.

use crate::convert;
use crate::errors::{ContactError as PyContactError, PyResultExt};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::borrow::Cow;
use vfrs_core::contact::{
    self as core, BvhEngine, ContactPairs, InterfaceMesh, InterfaceMeshParams, RigidPlane, RIGID,
};

/// An (n, 3) float64 array as points, borrowed when C-contiguous.
pub(crate) fn points_view<'a>(
    name: &str,
    a: &'a PyReadonlyArray2<'_, f64>,
) -> PyResult<Cow<'a, [[f64; 3]]>> {
    if a.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (n, 3), got {:?}",
            a.shape()
        )));
    }
    // Borrowed only in C order (an F-ordered array's memory is x of every point, then y,
    // then z: no array of points).
    match convert::c_order(a) {
        Some(s) => {
            // SAFETY: [f64; 3] has the size of three f64 and the alignment of f64; the
            // slice length is a multiple of 3 (n rows of 3).
            let v =
                unsafe { std::slice::from_raw_parts(s.as_ptr() as *const [f64; 3], s.len() / 3) };
            Ok(Cow::Borrowed(v))
        }
        None => Ok(Cow::Owned(convert::points(name, a)?)),
    }
}

/// (k, 3) int64 triangles; a row of three -1 means a rigid master.
fn master_rows(name: &str, a: &PyReadonlyArray2<'_, i64>) -> PyResult<Vec<[usize; 3]>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (k, 3), got {:?}",
            v.shape()
        )));
    }
    let mut out = Vec::with_capacity(v.nrows());
    for (r, row) in v.rows().into_iter().enumerate() {
        if row.iter().all(|&i| i == -1) {
            out.push([RIGID; 3]);
            continue;
        }
        let mut t = [0usize; 3];
        for (k, &i) in row.iter().enumerate() {
            if i < 0 {
                return Err(PyContactError::new_err(format!(
                    "{name}[{r}, {k}] = {i} is negative (only a whole row of -1 marks a rigid master)"
                )));
            }
            t[k] = i as usize;
        }
        out.push(t);
    }
    Ok(out)
}

fn pairs_dict<'py>(py: Python<'py>, p: &ContactPairs) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let idx = |i: usize| if i == RIGID { -1 } else { i as i64 };
    d.set_item(
        "slave",
        p.slave
            .iter()
            .map(|&i| i as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item(
        "triangle",
        p.triangle
            .iter()
            .map(|&i| idx(i))
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    let master: Vec<i64> = p.master.iter().flat_map(|t| t.map(idx)).collect();
    d.set_item("master", master.into_pyarray(py).reshape([p.len(), 3])?)?;
    d.set_item("xi", p.xi.clone().into_pyarray(py))?;
    d.set_item("zeta", p.zeta.clone().into_pyarray(py))?;
    let normal: Vec<f64> = p.normal.iter().flatten().copied().collect();
    d.set_item("normal", normal.into_pyarray(py).reshape([p.len(), 3])?)?;
    d.set_item("gap", p.gap.clone().into_pyarray(py))?;
    d.set_item("area", p.area.clone().into_pyarray(py))?;
    d.set_item("feature", p.feature.clone().into_pyarray(py))?;
    Ok(d)
}

/// Pairwise projection of points (k, 3) onto triangles (k, 3, 3).
///
/// Returns (closest (k, 3), xi (k), zeta (k), normal (k, 3), gap (k), feature (k) uint8).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn project<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    triangles: PyReadonlyArray3<'py, f64>,
) -> PyResult<(
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<u8>>,
)> {
    let p = points_view("points", &points)?;
    let t = triangles.as_array();
    if t.shape()[1] != 3 || t.shape()[2] != 3 {
        return Err(PyValueError::new_err(format!(
            "triangles must have shape (k, 3, 3), got {:?}",
            t.shape()
        )));
    }
    let tris: Vec<[[f64; 3]; 3]> = t
        .outer_iter()
        .map(|m| {
            [
                [m[[0, 0]], m[[0, 1]], m[[0, 2]]],
                [m[[1, 0]], m[[1, 1]], m[[1, 2]]],
                [m[[2, 0]], m[[2, 1]], m[[2, 2]]],
            ]
        })
        .collect();
    let res = py.detach(|| core::project_pairs(&p, &tris)).py()?;
    let k = res.len();
    let closest: Vec<f64> = res.iter().flat_map(|r| r.closest).collect();
    let normal: Vec<f64> = res.iter().flat_map(|r| r.normal).collect();
    Ok((
        closest.into_pyarray(py).reshape([k, 3])?,
        res.iter()
            .map(|r| r.xi)
            .collect::<Vec<_>>()
            .into_pyarray(py),
        res.iter()
            .map(|r| r.zeta)
            .collect::<Vec<_>>()
            .into_pyarray(py),
        normal.into_pyarray(py).reshape([k, 3])?,
        res.iter()
            .map(|r| r.gap)
            .collect::<Vec<_>>()
            .into_pyarray(py),
        res.iter()
            .map(|r| r.feature as u8)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    ))
}

/// Constraint matrix G as CSR arrays (indptr, indices, data, (rows, cols)).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn constraint_matrix<'py>(
    py: Python<'py>,
    slave: PyReadonlyArray1<'py, i64>,
    master: PyReadonlyArray2<'py, i64>,
    xi: PyReadonlyArray1<'py, f64>,
    zeta: PyReadonlyArray1<'py, f64>,
    normal: PyReadonlyArray2<'py, f64>,
    n_nodes: usize,
) -> PyResult<(
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    (usize, usize),
)> {
    let s = convert::indices("slave", &slave)?;
    let m = master_rows("master", &master)?;
    let x = convert::floats(&xi);
    let z = convert::floats(&zeta);
    let n = points_view("normal", &normal)?;
    let g = py
        .detach(|| core::constraint_matrix(&s, &m, &x, &z, &n, n_nodes))
        .py()?;
    let shape = (g.n_rows, g.n_cols);
    Ok((
        g.indptr
            .iter()
            .map(|&i| i as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py),
        g.indices
            .iter()
            .map(|&i| i as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py),
        g.data.into_pyarray(py),
        shape,
    ))
}

/// Tributary (nodal) area of every point on a surface: a third of each adjacent triangle.
#[pyfunction]
pub fn tributary_areas<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    triangles: PyReadonlyArray2<'py, i64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let p = points_view("points", &points)?;
    let t = convert::index_rows::<3>("triangles", &triangles)?;
    Ok(core::tributary_areas(&p, &t).py()?.into_pyarray(py))
}

/// Summed area of the triangles with at least one loaded vertex.
#[pyfunction]
pub fn contact_area(
    points: PyReadonlyArray2<'_, f64>,
    triangles: PyReadonlyArray2<'_, i64>,
    loaded: PyReadonlyArray1<'_, bool>,
) -> PyResult<f64> {
    let p = points_view("points", &points)?;
    let t = convert::index_rows::<3>("triangles", &triangles)?;
    let l: Vec<bool> = loaded.as_array().iter().copied().collect();
    core::contact_area(&p, &t, &l).py()
}

/// Node-to-rigid-plane pairs (a dict of arrays, master rows of -1).
#[pyfunction]
pub fn plane_detect<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    nodes: PyReadonlyArray1<'py, i64>,
    areas: PyReadonlyArray1<'py, f64>,
    origin: [f64; 3],
    normal: [f64; 3],
    search_distance: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let p = points_view("points", &points)?;
    let n = convert::indices("nodes", &nodes)?;
    let a = convert::floats(&areas);
    let plane = RigidPlane::new(origin, normal).py()?;
    let mut out = ContactPairs::default();
    plane.detect(&p, &n, &a, search_distance, &mut out).py()?;
    pairs_dict(py, &out)
}

// The core's `BvhEngine`; Python still sees it as `BvhDetector` (the `_core` API is unchanged
// in this pass).
/// BVH broad phase + closest-point narrow phase, holding its buffers between calls.
#[pyclass(name = "BvhDetector", module = "vfrs._core.contact")]
pub struct PyBvhEngine {
    inner: BvhEngine,
}

#[pymethods]
impl PyBvhEngine {
    #[new]
    #[pyo3(signature = (master_triangles, slave_nodes, slave_areas, best_first=false))]
    fn new(
        master_triangles: PyReadonlyArray2<'_, i64>,
        slave_nodes: PyReadonlyArray1<'_, i64>,
        slave_areas: PyReadonlyArray1<'_, f64>,
        best_first: bool,
    ) -> PyResult<Self> {
        let t = convert::index_rows::<3>("master_triangles", &master_triangles)?;
        let s = convert::indices("slave_nodes", &slave_nodes)?;
        let a = convert::floats(&slave_areas);
        let mut inner = BvhEngine::new(t, s, a).py()?;
        inner.set_best_first(best_first);
        Ok(Self { inner })
    }

    /// Closest master triangle of every slave node within `search_distance`.
    fn detect<'py>(
        &mut self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        search_distance: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let p = points_view("points", &points)?;
        let inner = &mut self.inner;
        py.detach(|| inner.detect(&p, search_distance).map(|_| ()))
            .py()?;
        pairs_dict(py, self.inner.pairs())
    }

    /// Number of pairs found by the last call, without building arrays (for timing).
    fn detect_count(
        &mut self,
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        search_distance: f64,
    ) -> PyResult<usize> {
        let p = points_view("points", &points)?;
        let inner = &mut self.inner;
        py.detach(|| inner.detect(&p, search_distance).map(|r| r.len()))
            .py()
    }
}

/// The paper's interface gap mesh between two surfaces.
#[pyclass(name = "InterfaceMesh", module = "vfrs._core.contact")]
pub struct PyInterfaceMesh {
    inner: InterfaceMesh,
}

#[pymethods]
impl PyInterfaceMesh {
    #[new]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        surface_a: PyReadonlyArray2<'_, i64>,
        surface_b: PyReadonlyArray2<'_, i64>,
        search_distance: f64,
        max_slip: f64,
    ) -> PyResult<Self> {
        let p = points_view("points", &points)?;
        let a = convert::index_rows::<3>("surface_a", &surface_a)?;
        let b = convert::index_rows::<3>("surface_b", &surface_b)?;
        let params = InterfaceMeshParams {
            search_distance,
            max_slip,
        };
        let inner = py.detach(|| InterfaceMesh::build(&p, a, b, params)).py()?;
        Ok(Self { inner })
    }

    /// (m, 4) tets (x1, x2, x3, slave).
    #[getter]
    fn tets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let t = self.inner.tets();
        let v: Vec<i64> = t.iter().flatten().map(|&i| i as i64).collect();
        v.into_pyarray(py).reshape([t.len(), 4])
    }

    /// Master triangle index (within its surface) of each tet.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let v: Vec<i64> = self.inner.triangles().iter().map(|&i| i as i64).collect();
        v.into_pyarray(py)
    }

    /// 0: slave on surface a; 1: slave on surface b.
    #[getter]
    fn sides<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u8>> {
        self.inner.sides().to_vec().into_pyarray(py)
    }

    /// Volume weights 3 a_s / (2 A_t).
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.weights().to_vec().into_pyarray(py)
    }

    /// Number of rebuilds since construction.
    #[getter]
    fn n_rebuilds(&self) -> usize {
        self.inner.n_rebuilds()
    }

    /// Oriented volumes of the interface tets.
    fn signed_volumes<'py>(
        &mut self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let p = points_view("points", &points)?;
        let inner = &mut self.inner;
        let v = py
            .detach(|| inner.signed_volumes(&p).map(|v| v.to_vec()))
            .py()?;
        Ok(v.into_pyarray(py))
    }

    /// (n_inverted, intersection_volume, raw_volume).
    fn inversion(
        &mut self,
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<(usize, f64, f64)> {
        let p = points_view("points", &points)?;
        let inner = &mut self.inner;
        let r = py.detach(|| inner.inversion(&p)).py()?;
        Ok((r.n_inverted, r.intersection_volume, r.raw_volume))
    }

    /// Pairs of the inverted tets (dict of arrays).
    fn detect<'py>(
        &mut self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let p = points_view("points", &points)?;
        let inner = &mut self.inner;
        py.detach(|| inner.detect(&p).map(|_| ())).py()?;
        pairs_dict(py, self.inner.pairs())
    }

    /// Largest tangential slip since the last (re)build, in barycentric units.
    fn max_slip(&self, py: Python<'_>, points: PyReadonlyArray2<'_, f64>) -> PyResult<f64> {
        let p = points_view("points", &points)?;
        let inner = &self.inner;
        py.detach(|| inner.max_slip(&p)).py()
    }

    /// Rebuilds when the slip exceeds max_slip; returns whether it did.
    fn update(&mut self, py: Python<'_>, points: PyReadonlyArray2<'_, f64>) -> PyResult<bool> {
        let p = points_view("points", &points)?;
        let inner = &mut self.inner;
        py.detach(|| inner.update(&p)).py()
    }

    /// Rebuilds the pairing at `points`.
    fn rebuild(&mut self, py: Python<'_>, points: PyReadonlyArray2<'_, f64>) -> PyResult<()> {
        let p = points_view("points", &points)?;
        let inner = &mut self.inner;
        py.detach(|| inner.rebuild(&p)).py()
    }
}

/// Adds the contact functions and classes to `vfrs._core`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(project, m)?)?;
    m.add_function(wrap_pyfunction!(constraint_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(tributary_areas, m)?)?;
    m.add_function(wrap_pyfunction!(contact_area, m)?)?;
    m.add_function(wrap_pyfunction!(plane_detect, m)?)?;
    m.add_class::<PyBvhEngine>()?;
    m.add_class::<PyInterfaceMesh>()?;
    Ok(())
}
