//! Contact geometry: projection, detection (interface gap mesh, BVH, rigid plane), the
//! contact-pair record, the constraint matrix and the contact area.
//!
//! Two detection engines behind one record ([`ContactPairs`]):
//! - [`InterfaceMesh`], the paper's: node-to-triangle tets filling the gap between two
//!   surfaces, inverted when a node crosses the opposite surface (see its module docs for the
//!   construction and its limits);
//! - [`BvhEngine`], the general one: BVH broad phase and closest-point narrow phase;
//!
//! plus [`RigidPlane`]. From the pairs, [`constraint_matrix`] builds G and
//! [`contact_area`] the paper's contact area.

mod bvh;
mod constraint;
mod error;
mod interface_mesh;
pub mod lcp;
mod plane;
mod projection;
mod record;
mod surface;

pub use bvh::BvhEngine;
pub use constraint::{constraint_matrix, CsrMatrix};
pub use error::ContactError;
pub use interface_mesh::{InterfaceMesh, InterfaceMeshParams, Inversion};
pub use plane::RigidPlane;
pub use projection::{
    plane_coordinates, project_pairs, project_point_triangle, scaled_normal, Feature, Projection,
    DEGENERATE_TOL,
};
pub use record::{ContactPairs, RIGID};
pub use surface::{
    check_points, check_surface, check_triangles, contact_area, surface_nodes, tributary_areas,
    tributary_areas_into,
};
