//! `vfrs-core`: the pure-Rust core of vfrs, a finite-element model of colliding vocal folds.
//!
//! It does what is hot: P1 tetrahedral assembly into sparse CSC matrices, sparse Cholesky
//! factorization with a reusable symbolic analysis, Dirichlet elimination, and (in
//! [`contact`]) the contact geometry. Python drives it through the `vfrs-py` bindings; this
//! crate never links Python, so `cargo test` runs without it.
//!
//! Its modules mirror the Python package: [`fem`] (mesh, materials, the P1 element,
//! assembly, loads), [`linalg`] (sparse Cholesky, ordering, DOF map, compliance products,
//! sparse and small dense kernels), [`hyperelastic`] (finite strain) and [`contact`]
//! (geometry, detection engines, the contact LCPs); [`error::Error`] is any of their errors.
//!
//! Conventions: SI units, node-major degrees of freedom `[u0x, u0y, u0z, u1x, ...]`,
//! positively oriented tetrahedra, Voigt order `[xx, yy, zz, yz, xz, xy]` with engineering
//! shear strains.
#![warn(missing_docs)]

pub mod contact;
pub mod error;
pub mod fem;
pub mod hyperelastic;
pub mod linalg;

pub use error::{ContactError, Error, HyperelasticError, MaterialError, MeshError, SolverError};
pub use fem::assembly::Assembler;
pub use fem::material::{Elasticity, Material};
pub use fem::mesh::TetMesh;
pub use fem::quadratic::QuadraticAssembler;
pub use hyperelastic::{
    FibreReinforced, FiniteStrainAssembler, HyperelasticLaw, HyperelasticMaterial, NeoHookean,
    QuadraticFiniteStrainAssembler, StVenantKirchhoff,
};
pub use linalg::cholesky::{Cholesky, CholeskyParams, Ordering};
pub use linalg::dofmap::DofMap;
