//! Mesh checks, materials, assembly.

use crate::convert;
use crate::errors::PyResultExt;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArray3, PyReadwriteArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use vfrs_core::fem::material::{Elasticity, Material};
use vfrs_core::fem::mesh::{check_points, check_topology, signed_volumes as core_signed_volumes};
use vfrs_core::fem::refine::refine;
use vfrs_core::{Assembler, QuadraticAssembler, TetMesh};

/// An (m, 4) int64 array as tetrahedra whose indices all lie in 0..n_points: a wrong shape is
/// a ValueError; a negative or too large index a MeshError naming the element (negative
/// indices are reported like any out-of-range one).
fn checked_tets(n_points: usize, tets: &PyReadonlyArray2<'_, i64>) -> PyResult<Vec<[usize; 4]>> {
    let tv = tets.as_array();
    if tv.ncols() != 4 {
        return Err(PyValueError::new_err(format!(
            "tets must have shape (m, 4), got {:?}",
            tv.shape()
        )));
    }
    let rows: Vec<[i64; 4]> = tv
        .rows()
        .into_iter()
        .map(|r| [r[0], r[1], r[2], r[3]])
        .collect();
    check_topology(n_points, &rows).py()?;
    Ok(rows.iter().map(|r| r.map(|i| i as usize)).collect())
}

/// Signed volumes of tetrahedra (negative = inverted). Checks indices, not orientation.
#[pyfunction]
pub fn signed_volumes<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    tets: PyReadonlyArray2<'py, i64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let p = convert::points("points", &points)?;
    let tu = checked_tets(p.len(), &tets)?;
    check_points(&p).py()?;
    Ok(py.detach(|| core_signed_volumes(&p, &tu)).into_pyarray(py))
}

/// Validates a mesh (finite points, valid indices, positive volumes); raises MeshError.
#[pyfunction]
pub fn validate_mesh(
    points: PyReadonlyArray2<'_, f64>,
    tets: PyReadonlyArray2<'_, i64>,
) -> PyResult<()> {
    let p = convert::points("points", &points)?;
    let t = checked_tets(p.len(), &tets)?;
    TetMesh::new(p, t).py()?;
    Ok(())
}

/// The refined arrays of [`refine_tets`].
type RefinedArrays<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<i64>>,
    Bound<'py, PyArray2<i64>>,
);

/// Uniform refinement: every tet split into eight, every triangle of `triangles` (the named
/// surfaces concatenated) into four, with one shared midpoint per edge. Returns
/// (points, tets, triangles): the old nodes then the midpoints; the children of tet t at
/// 8t..8t+8 and of triangle k at 4k..4k+4, orientation kept. Raises MeshError.
#[pyfunction]
pub fn refine_tets<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    tets: PyReadonlyArray2<'py, i64>,
    triangles: PyReadonlyArray2<'py, i64>,
) -> PyResult<RefinedArrays<'py>> {
    let p = convert::points("points", &points)?;
    let t = checked_tets(p.len(), &tets)?;
    let tri = convert::index_rows::<3>("triangles", &triangles)?;
    let r = py.detach(|| refine(&p, &t, &tri)).py()?;
    let (n, m, k) = (r.points.len(), r.tets.len(), r.triangles.len());
    let flat_p: Vec<f64> = r.points.into_iter().flatten().collect();
    let flat_t: Vec<i64> = r.tets.into_iter().flatten().map(|i| i as i64).collect();
    let flat_s: Vec<i64> = r
        .triangles
        .into_iter()
        .flatten()
        .map(|i| i as i64)
        .collect();
    Ok((
        flat_p.into_pyarray(py).reshape([n, 3])?,
        flat_t.into_pyarray(py).reshape([m, 4])?,
        flat_s.into_pyarray(py).reshape([k, 3])?,
    ))
}

fn to_array<'py>(py: Python<'py>, d: &Elasticity) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let v: Vec<Vec<f64>> = d.iter().map(|r| r.to_vec()).collect();
    PyArray2::from_vec2(py, &v).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// 6x6 elasticity matrix of an isotropic material (Voigt xx, yy, zz, yz, xz, xy).
#[pyfunction]
#[pyo3(name = "elasticity_isotropic")]
pub fn elasticity_isotropic<'py>(
    py: Python<'py>,
    e: f64,
    nu: f64,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    to_array(py, &Material::Isotropic { e, nu }.elasticity().py()?)
}

/// 6x6 elasticity matrix of a transversely isotropic material about `axis`.
#[pyfunction]
#[pyo3(signature = (e_p, e_z, nu_p, nu_pz, g_pz, axis))]
pub fn elasticity_transversely_isotropic<'py>(
    py: Python<'py>,
    e_p: f64,
    e_z: f64,
    nu_p: f64,
    nu_pz: f64,
    g_pz: f64,
    axis: [f64; 3],
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    to_array(
        py,
        &Material::TransverselyIsotropic {
            e_p,
            e_z,
            nu_p,
            nu_pz,
            g_pz,
            axis,
        }
        .elasticity()
        .py()?,
    )
}

/// The fixed CSC pattern of a tet mesh and in-place, parallel filling of its values.
#[pyclass(name = "Assembler", module = "vfrs._core.fem", frozen)]
pub struct PyAssembler {
    inner: Assembler,
}

pub(crate) fn materials(d: &PyReadonlyArray3<'_, f64>) -> PyResult<Vec<Elasticity>> {
    let a = d.as_array();
    if a.shape()[1] != 6 || a.shape()[2] != 6 {
        return Err(PyValueError::new_err(format!(
            "elasticity must have shape (k, 6, 6), got {:?}",
            a.shape()
        )));
    }
    Ok(a.outer_iter()
        .map(|m| {
            let mut out = [[0.0; 6]; 6];
            for i in 0..6 {
                for j in 0..6 {
                    out[i][j] = m[[i, j]];
                }
            }
            out
        })
        .collect())
}

/// Points and the optional per-element material index of an assembly call.
pub(crate) type BodyInputs = (Vec<[f64; 3]>, Option<Vec<usize>>);

/// Reads the [`BodyInputs`] of an assembly call.
pub(crate) fn body_inputs(
    points: &PyReadonlyArray2<'_, f64>,
    material_of: Option<PyReadonlyArray1<'_, i64>>,
) -> PyResult<BodyInputs> {
    let p = convert::points("points", points)?;
    let mo = material_of
        .map(|m| convert::indices("material_of", &m))
        .transpose()?;
    Ok((p, mo))
}

/// The Python methods of an assembler class `$class` wrapping `inner: $core` of elements with
/// `$nodes` nodes (the P1 `Assembler` and the P2 `QuadraticAssembler` have the same Rust
/// calls); `$lumped` documents its lumped mass. One definition: the classes cannot drift apart.
macro_rules! assembler_methods {
    ($class:ident, $core:ident, $nodes:literal, $lumped:literal) => {
        #[pymethods]
        impl $class {
            #[new]
            fn new(
                py: Python<'_>,
                n_points: usize,
                tets: PyReadonlyArray2<'_, i64>,
            ) -> PyResult<Self> {
                let t = convert::index_rows::<$nodes>("tets", &tets)?;
                let inner = py.detach(|| $core::new(n_points, &t)).py()?;
                Ok(Self { inner })
            }

            /// Number of stored entries.
            #[getter]
            fn nnz(&self) -> usize {
                self.inner.nnz()
            }

            /// (indptr, indices) of the CSC pattern; the matrices are symmetric, so these are
            /// also the CSR arrays.
            fn pattern<'py>(
                &self,
                py: Python<'py>,
            ) -> (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>) {
                convert::pattern(py, self.inner.col_ptr(), self.inner.row_idx())
            }

            /// Stiffness values in pattern order. `elasticity`: (k, 6, 6); `material_of`: (m,)
            /// or None.
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

            #[doc = $lumped]
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
    };
}

assembler_methods!(
    PyAssembler,
    Assembler,
    4,
    "Row-sum lumped mass per DOF, length 3n."
);

/// The fixed CSC pattern of a mesh of ten-node tetrahedra (VTK's node order: vertices, then the
/// mid-edge nodes of edges 0-1, 1-2, 0-2, 0-3, 1-3, 2-3) and the in-place, parallel filling of
/// its stiffness and mass; the same calls as `Assembler` (issue 47).
#[pyclass(name = "QuadraticAssembler", module = "vfrs._core.fem", frozen)]
pub struct PyQuadraticAssembler {
    inner: QuadraticAssembler,
}

assembler_methods!(
    PyQuadraticAssembler,
    QuadraticAssembler,
    10,
    "HRZ lumped mass per DOF (positive, summing to the mass), length 3n."
);

/// The consistent nodal forces of a linear pressure on fixed surface triangles (the flow's
/// load): bit for bit `vfrs.flow.consistent_pressure_forces`, without allocating per call.
#[pyclass(name = "PressureLoad", module = "vfrs._core.fem")]
pub struct PyPressureLoad {
    inner: vfrs_core::fem::loads::PressureLoad,
}

#[pymethods]
impl PyPressureLoad {
    #[new]
    fn new(triangles: PyReadonlyArray2<'_, i64>, n_points: usize) -> PyResult<Self> {
        let t = convert::index_rows::<3>("triangles", &triangles)?;
        Ok(Self {
            inner: vfrs_core::fem::loads::PressureLoad::new(&t, n_points).py()?,
        })
    }

    /// Writes the forces (n, 3) into `out` for positions `points` (n, 3) and nodal pressures.
    fn forces(
        &mut self,
        points: PyReadonlyArray2<'_, f64>,
        pressure: PyReadonlyArray1<'_, f64>,
        mut out: PyReadwriteArray2<'_, f64>,
    ) -> PyResult<()> {
        let p = crate::contact::points_view("points", &points)?;
        let pr = pressure
            .as_slice()
            .map_err(|_| PyValueError::new_err("pressure must be contiguous"))?;
        if out.shape()[1] != 3 {
            return Err(PyValueError::new_err(format!(
                "out must have shape (n, 3), got {:?}",
                out.shape()
            )));
        }
        let o = convert::c_slice_mut("out", &mut out)?;
        // SAFETY: [f64; 3] has the size of three f64 and the alignment of f64; the slice
        // holds n rows of 3.
        let rows =
            unsafe { std::slice::from_raw_parts_mut(o.as_mut_ptr() as *mut [f64; 3], o.len() / 3) };
        self.inner.forces(&p, pr, rows).py()
    }
}

/// Fills `vfrs._core.fem`.
pub fn register(f: &Bound<'_, PyModule>) -> PyResult<()> {
    f.add_function(wrap_pyfunction!(signed_volumes, f)?)?;
    f.add_function(wrap_pyfunction!(validate_mesh, f)?)?;
    f.add_function(wrap_pyfunction!(refine_tets, f)?)?;
    f.add_function(wrap_pyfunction!(elasticity_isotropic, f)?)?;
    f.add_function(wrap_pyfunction!(elasticity_transversely_isotropic, f)?)?;
    f.add_class::<PyAssembler>()?;
    f.add_class::<PyPressureLoad>()?;
    f.add_class::<PyQuadraticAssembler>()?;
    Ok(())
}
