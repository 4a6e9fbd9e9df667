//! Typed errors of the mesh and the materials. Each variant carries the indices a user needs
//! to find the culprit.

use thiserror::Error;

/// What is wrong with a tetrahedral mesh.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MeshError {
    /// The points array is not n x 3 or the tets array is not m x 4.
    #[error("{what} must have {expected} columns, got {got}")]
    BadShape {
        /// Which array.
        what: &'static str,
        /// Columns expected.
        expected: usize,
        /// Columns given.
        got: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("point {point} has a non-finite coordinate {value} (axis {axis})")]
    NonFinite {
        /// Point index.
        point: usize,
        /// Axis 0, 1, 2.
        axis: usize,
        /// The offending value.
        value: f64,
    },
    /// A tetrahedron refers to a point that does not exist.
    #[error("tetrahedron {tet} refers to point {index}, but there are only {n_points} points")]
    IndexOutOfRange {
        /// Tet index.
        tet: usize,
        /// The bad point index.
        index: i64,
        /// Number of points.
        n_points: usize,
    },
    /// A tetrahedron uses the same point twice.
    #[error("tetrahedron {tet} uses point {index} twice")]
    RepeatedVertex {
        /// Tet index.
        tet: usize,
        /// The repeated point.
        index: usize,
    },
    /// A tetrahedron has zero or negative signed volume.
    #[error("tetrahedron {tet} has signed volume {volume:e} (must be > 0: swap two vertices to fix the orientation, or remove the flat element)")]
    NonPositiveVolume {
        /// Tet index.
        tet: usize,
        /// Its signed volume.
        volume: f64,
    },
    /// The mesh has no elements.
    #[error("the mesh has no tetrahedra")]
    Empty,
    /// A surface triangle refers to a point that does not exist.
    #[error(
        "surface triangle {triangle} refers to point {index}, but there are only {n_points} points"
    )]
    SurfaceIndex {
        /// Triangle index.
        triangle: usize,
        /// The bad point index.
        index: usize,
        /// Number of points.
        n_points: usize,
    },
    /// A surface triangle's edge is no edge of any tetrahedron (refinement needs the
    /// surfaces to be made of element faces).
    #[error("surface triangle {triangle} has the edge {a}-{b}, which is no edge of any tetrahedron: the surface is not made of element faces")]
    SurfaceEdgeNotInMesh {
        /// Triangle index.
        triangle: usize,
        /// One end of the edge.
        a: usize,
        /// The other end.
        b: usize,
    },
    /// An array over the points (or triangles) has the wrong length.
    #[error("{what}: expected length {expected}, got {got}")]
    BadLength {
        /// Which array.
        what: &'static str,
        /// Length expected.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// An element's matrix overflows: coordinates far from ordinary sizes (e.g. near 1e300)
    /// or an extreme sliver.
    #[error("tetrahedron {tet} (volume {volume:e}) gives a non-finite element matrix: its coordinates are too large or it is too flat to assemble; check the mesh's units and the configuration's displacements")]
    NonFiniteElement {
        /// Tet index.
        tet: usize,
        /// Its volume.
        volume: f64,
    },
    /// A quadratic tetrahedron whose Jacobian is not positive at a quadrature point: a
    /// mid-edge node far from its edge, or an inverted element.
    #[error("quadratic tetrahedron {tet} has a Jacobian that is not positive at quadrature point {point}: a mid-edge node is far from its edge's midpoint, or the element is inverted; move its mid-edge nodes back towards their edges or remesh")]
    InvertedQuadratic {
        /// Tet index.
        tet: usize,
        /// The quadrature point's index in the rule.
        point: usize,
    },
}

/// What is wrong with material parameters.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MaterialError {
    /// A parameter must be positive and finite.
    #[error("material parameter {name} = {value} must be positive and finite")]
    NotPositive {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
    },
    /// A parameter is outside its admissible range.
    #[error("material parameter {name} = {value} is out of range: {reason}")]
    OutOfRange {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
        /// Why.
        reason: String,
    },
    /// The compliance matrix is not positive definite, so the strain energy is not.
    #[error("the compliance matrix is not positive definite: {reason}")]
    NotPositiveDefinite {
        /// Which condition failed.
        reason: String,
    },
    /// The fibre axis is zero or non-finite.
    #[error("fibre axis {axis:?} must be a finite non-zero vector")]
    BadAxis {
        /// The axis given.
        axis: [f64; 3],
    },
    /// Per-element material indices do not match the mesh.
    #[error("element {element} refers to material {index}, but only {n_materials} are given")]
    BadMaterialIndex {
        /// Element.
        element: usize,
        /// Material index.
        index: usize,
        /// Materials available.
        n_materials: usize,
    },
    /// Array length mismatch.
    #[error("{what}: expected length {expected}, got {got}")]
    BadLength {
        /// Which array.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Given length.
        got: usize,
    },
}
