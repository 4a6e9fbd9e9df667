//! Linear finite elements on tetrahedra: the mesh and its checks ([`mesh`]), uniform
//! refinement ([`refine`]), materials and their elasticity ([`material`]), the P1 element
//! ([`element`]), the P2 element ([`tet10`]: its kernels and quadrature, not yet assembled),
//! assembly into a fixed CSC pattern ([`assembly`]) and pressure loads ([`loads`]).

pub mod assembly;
pub mod element;
pub mod error;
pub mod loads;
pub mod material;
pub mod mesh;
pub mod pattern;
pub mod refine;
pub mod tet10;
