//! Finite strain (issue 14): hyperelastic laws and the internal force / consistent tangent /
//! strain energy of a P1 or a P2 body on the linear stiffness's CSC pattern (one macro writes
//! both classes' methods). The assembly calls release the GIL.

use crate::convert;
use crate::errors::PyResultExt;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use vfrs_core::hyperelastic::{
    FibreReinforced, FiniteStrainAssembler, HyperelasticMaterial, NeoHookean,
    QuadraticFiniteStrainAssembler, StVenantKirchhoff,
};
use vfrs_core::HyperelasticLaw;

/// A hyperelastic law; built by `neo_hookean`, `neo_hookean_from_young`,
/// `st_venant_kirchhoff` or `fibre_reinforced`.
#[pyclass(
    name = "HyperelasticMaterial",
    module = "vfrs._core.hyperelastic",
    frozen
)]
pub struct PyHyperelasticMaterial {
    inner: HyperelasticMaterial,
}

#[pymethods]
impl PyHyperelasticMaterial {
    /// "neo_hookean", "st_venant_kirchhoff" or "fibre_reinforced".
    #[getter]
    fn kind(&self) -> &'static str {
        match self.inner {
            HyperelasticMaterial::NeoHookean(_) => "neo_hookean",
            HyperelasticMaterial::StVenantKirchhoff(_) => "st_venant_kirchhoff",
            HyperelasticMaterial::FibreReinforced(_) => "fibre_reinforced",
        }
    }
}

fn material(inner: HyperelasticMaterial) -> PyResult<PyHyperelasticMaterial> {
    inner.validate().py()?;
    Ok(PyHyperelasticMaterial { inner })
}

/// Compressible neo-Hookean from the Lame constants mu, lambda (Pa).
#[pyfunction]
#[pyo3(name = "neo_hookean", signature = (mu, lam))]
pub fn neo_hookean(mu: f64, lam: f64) -> PyResult<PyHyperelasticMaterial> {
    material(HyperelasticMaterial::NeoHookean(NeoHookean {
        mu,
        lambda: lam,
    }))
}

/// Compressible neo-Hookean whose small-strain limit is the isotropic material (E, nu).
#[pyfunction]
pub fn neo_hookean_from_young(e: f64, nu: f64) -> PyResult<PyHyperelasticMaterial> {
    material(HyperelasticMaterial::NeoHookean(
        NeoHookean::from_young(e, nu).py()?,
    ))
}

/// St Venant-Kirchhoff with a 6x6 elasticity matrix (e.g. `elasticity_transversely_isotropic`).
#[pyfunction]
pub fn st_venant_kirchhoff(
    elasticity: PyReadonlyArray2<'_, f64>,
) -> PyResult<PyHyperelasticMaterial> {
    let a = elasticity.as_array();
    if a.shape() != [6, 6] {
        return Err(PyValueError::new_err(format!(
            "elasticity must have shape (6, 6), got {:?}",
            a.shape()
        )));
    }
    let mut d = [[0.0; 6]; 6];
    for (i, row) in d.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = a[[i, j]];
        }
    }
    material(HyperelasticMaterial::StVenantKirchhoff(StVenantKirchhoff {
        d,
    }))
}

/// Neo-Hookean matrix (mu, lambda) plus fibres along `axis` resisting stretch only:
/// W_f = k1 / (2 k2) (exp(k2 (I4 - 1)^2) - 1) for I4 > 1 (Holzapfel, Gasser & Ogden 2000).
#[pyfunction]
#[pyo3(signature = (mu, lam, k1, k2, axis))]
pub fn fibre_reinforced(
    mu: f64,
    lam: f64,
    k1: f64,
    k2: f64,
    axis: [f64; 3],
) -> PyResult<PyHyperelasticMaterial> {
    let m = NeoHookean { mu, lambda: lam };
    material(HyperelasticMaterial::FibreReinforced(
        FibreReinforced::new(m, k1, k2, axis).py()?,
    ))
}

/// Internal force, consistent tangent and strain energy of a hyperelastic P1 body (total
/// Lagrangian, reference = the points given here), on the CSC pattern of `Assembler`.
#[pyclass(name = "FiniteStrainAssembler", module = "vfrs._core.hyperelastic")]
pub struct PyFiniteStrainAssembler {
    inner: FiniteStrainAssembler,
}

/// The same for ten-node (P2) tetrahedra (VTK's node order, as `QuadraticAssembler`), on the
/// CSC pattern of `QuadraticAssembler`; the law is evaluated at the 4 points of the degree-2
/// rule of each element. The same calls as `FiniteStrainAssembler`.
#[pyclass(
    name = "QuadraticFiniteStrainAssembler",
    module = "vfrs._core.hyperelastic"
)]
pub struct PyQuadraticFiniteStrainAssembler {
    inner: QuadraticFiniteStrainAssembler,
}

/// u, the laws and the optional per-element material index of a call.
type Inputs = (Vec<f64>, Vec<HyperelasticMaterial>, Option<Vec<usize>>);

fn inputs(
    u: &PyReadonlyArray1<'_, f64>,
    materials: Vec<PyRef<'_, PyHyperelasticMaterial>>,
    material_of: Option<PyReadonlyArray1<'_, i64>>,
) -> PyResult<Inputs> {
    let laws = materials.iter().map(|m| m.inner).collect();
    let mo = material_of
        .map(|m| convert::indices("material_of", &m))
        .transpose()?;
    Ok((convert::floats(u), laws, mo))
}

/// The Python methods of a finite-strain class `$class` wrapping `inner: $core` (the P1 and
/// the P2 assemblers have the same Rust calls), its elements of `$nodes` nodes: one
/// definition, so the two classes cannot drift apart.
macro_rules! finite_strain_methods {
    ($class:ident, $core:ident, $nodes:literal) => {
        #[pymethods]
        impl $class {
            #[new]
            fn new(
                py: Python<'_>,
                points: PyReadonlyArray2<'_, f64>,
                tets: PyReadonlyArray2<'_, i64>,
            ) -> PyResult<Self> {
                let p = convert::points("points", &points)?;
                let t = convert::index_rows::<$nodes>("tets", &tets)?;
                let inner = py.detach(|| $core::new(&p, &t)).py()?;
                Ok(Self { inner })
            }

            /// Number of stored entries.
            #[getter]
            fn nnz(&self) -> usize {
                self.inner.nnz()
            }

            /// (indptr, indices) of the CSC pattern (the same as the linear assembler's
            /// `pattern()` on the same tets).
            fn pattern<'py>(
                &self,
                py: Python<'py>,
            ) -> (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>) {
                let a = self.inner.assembler();
                convert::pattern(py, a.col_ptr(), a.row_idx())
            }

            /// (f_int, energy) at the displacement `u` (length 3n, node-major).
            #[pyo3(signature = (u, materials, material_of=None))]
            fn internal_force<'py>(
                &mut self,
                py: Python<'py>,
                u: PyReadonlyArray1<'py, f64>,
                materials: Vec<PyRef<'py, PyHyperelasticMaterial>>,
                material_of: Option<PyReadonlyArray1<'py, i64>>,
            ) -> PyResult<(Bound<'py, PyArray1<f64>>, f64)> {
                let (u, laws, mo) = inputs(&u, materials, material_of)?;
                let mut f = vec![0.0; self.inner.n_dofs()];
                let inner = &mut self.inner;
                let w = py
                    .detach(|| inner.internal_force(&u, &laws, mo.as_deref(), &mut f))
                    .py()?;
                Ok((f.into_pyarray(py), w))
            }

            /// Consistent tangent values in pattern order.
            #[pyo3(signature = (u, materials, material_of=None))]
            fn tangent<'py>(
                &mut self,
                py: Python<'py>,
                u: PyReadonlyArray1<'py, f64>,
                materials: Vec<PyRef<'py, PyHyperelasticMaterial>>,
                material_of: Option<PyReadonlyArray1<'py, i64>>,
            ) -> PyResult<Bound<'py, PyArray1<f64>>> {
                let (u, laws, mo) = inputs(&u, materials, material_of)?;
                let mut k = vec![0.0; self.inner.nnz()];
                let inner = &mut self.inner;
                py.detach(|| inner.tangent_into(&u, &laws, mo.as_deref(), &mut k))
                    .py()?;
                Ok(k.into_pyarray(py))
            }

            /// (f_int, tangent values, energy) from one evaluation.
            #[pyo3(signature = (u, materials, material_of=None))]
            #[allow(clippy::type_complexity)]
            fn force_and_tangent<'py>(
                &mut self,
                py: Python<'py>,
                u: PyReadonlyArray1<'py, f64>,
                materials: Vec<PyRef<'py, PyHyperelasticMaterial>>,
                material_of: Option<PyReadonlyArray1<'py, i64>>,
            ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, f64)> {
                let (u, laws, mo) = inputs(&u, materials, material_of)?;
                let mut f = vec![0.0; self.inner.n_dofs()];
                let mut k = vec![0.0; self.inner.nnz()];
                let inner = &mut self.inner;
                let w = py
                    .detach(|| inner.force_and_tangent(&u, &laws, mo.as_deref(), &mut f, &mut k))
                    .py()?;
                Ok((f.into_pyarray(py), k.into_pyarray(py), w))
            }

            /// Total strain energy at `u`.
            #[pyo3(signature = (u, materials, material_of=None))]
            fn energy<'py>(
                &mut self,
                py: Python<'py>,
                u: PyReadonlyArray1<'py, f64>,
                materials: Vec<PyRef<'py, PyHyperelasticMaterial>>,
                material_of: Option<PyReadonlyArray1<'py, i64>>,
            ) -> PyResult<f64> {
                let (u, laws, mo) = inputs(&u, materials, material_of)?;
                let inner = &mut self.inner;
                py.detach(|| inner.energy(&u, &laws, mo.as_deref())).py()
            }
        }
    };
}

finite_strain_methods!(PyFiniteStrainAssembler, FiniteStrainAssembler, 4);
finite_strain_methods!(
    PyQuadraticFiniteStrainAssembler,
    QuadraticFiniteStrainAssembler,
    10
);

/// Fills `vfrs._core.hyperelastic`.
pub fn register(h: &Bound<'_, PyModule>) -> PyResult<()> {
    h.add_class::<PyHyperelasticMaterial>()?;
    h.add_class::<PyFiniteStrainAssembler>()?;
    h.add_class::<PyQuadraticFiniteStrainAssembler>()?;
    h.add_function(wrap_pyfunction!(neo_hookean, h)?)?;
    h.add_function(wrap_pyfunction!(neo_hookean_from_young, h)?)?;
    h.add_function(wrap_pyfunction!(st_venant_kirchhoff, h)?)?;
    h.add_function(wrap_pyfunction!(fibre_reinforced, h)?)?;
    Ok(())
}
