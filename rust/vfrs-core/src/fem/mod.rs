//! Linear finite elements on tetrahedra: the mesh and its checks ([`mesh`]), uniform
//! refinement ([`refine`]), materials and their elasticity ([`material`]), the P1 element
//! ([`element`]), the P2 element ([`tet10`]: its kernels and quadrature), the sparsity pattern
//! and its parallel fill ([`pattern`]), assembly of P1 ([`assembly`]) and P2 ([`quadratic`];
//! not yet reachable from Python) tetrahedra, and pressure loads ([`loads`]).

pub mod assembly;
pub mod element;
pub mod error;
pub mod loads;
pub mod material;
pub mod mesh;
pub mod pattern;
pub mod quadratic;
pub mod refine;
#[cfg(test)]
pub(crate) mod test_support;
pub mod tet10;
