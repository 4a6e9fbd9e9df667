//! Linear finite elements on tetrahedra: the mesh and its checks ([`mesh`]), uniform
//! refinement ([`refine`]), materials and their elasticity ([`material`]), the P1 element
//! ([`element`]), assembly into a fixed CSC pattern ([`assembly`]) and pressure loads
//! ([`loads`]).

pub mod assembly;
pub mod element;
pub mod error;
pub mod loads;
pub mod material;
pub mod mesh;
pub mod refine;
