//! Typed errors. Each variant carries the indices a user needs to find the culprit.

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

/// What went wrong in a sparse linear algebra operation.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SolverError {
    /// The matrix is not square or the arrays do not describe a CSC matrix.
    #[error("invalid sparse matrix: {reason}")]
    BadMatrix {
        /// Why.
        reason: String,
    },
    /// The matrix is not symmetric.
    #[error(
        "matrix is not symmetric: entry ({row}, {col}) = {value:e} but ({col}, {row}) = {mirror:e}"
    )]
    NotSymmetric {
        /// Row.
        row: usize,
        /// Column.
        col: usize,
        /// Value at (row, col).
        value: f64,
        /// Value at (col, row), 0 if absent.
        mirror: f64,
    },
    /// The Cholesky factorization met a non-positive pivot.
    #[error("matrix is not positive definite (factorization failed near row {row} of the permuted matrix); if this is a stiffness matrix, are all rigid-body motions fixed by Dirichlet conditions?")]
    NotPositiveDefinite {
        /// Approximate failing row (permuted numbering), if known.
        row: usize,
    },
    /// A refactorization was given a matrix of a different sparsity pattern.
    #[error("refactor needs the same sparsity pattern as the first factorization: {reason}")]
    PatternMismatch {
        /// What differs.
        reason: String,
    },
    /// Right-hand side of the wrong size or with non-finite entries.
    #[error("right-hand side: {reason}")]
    BadRhs {
        /// Why.
        reason: String,
    },
    /// Out of memory or an internal failure of the sparse library.
    #[error("sparse library failure: {reason}")]
    Internal {
        /// What faer reported.
        reason: String,
    },
    /// A small dense system of the contact methods (the LCP of a detection round) is
    /// malformed, non-finite or singular.
    #[error("dense contact system: {reason}")]
    Dense {
        /// Why.
        reason: String,
    },
    /// A DOF index is out of range.
    #[error("degree of freedom {dof} is out of range (there are {n_dofs})")]
    DofOutOfRange {
        /// Bad DOF.
        dof: usize,
        /// Number of DOFs.
        n_dofs: usize,
    },
}

/// What went wrong in a finite-strain (hyperelastic) evaluation.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum HyperelasticError {
    /// An element is inverted or flat in the deformed configuration.
    #[error("element {element} is inverted or flat in the deformed configuration: J = det F = {j:e} (must be > 0); the displacement is too large for this mesh, try a smaller step or load increment")]
    Inverted {
        /// Element index.
        element: usize,
        /// Its volume ratio J = det F.
        j: f64,
    },
    /// A displacement component is NaN or infinite.
    #[error("displacement u[{dof}] = {value} is not finite")]
    NonFiniteDisplacement {
        /// DOF index (node-major).
        dof: usize,
        /// The offending value.
        value: f64,
    },
    /// The stress or tangent of an element came out non-finite (an overflow of the fibre
    /// exponential, for example).
    #[error("element {element}: the stress or tangent is not finite at J = {j:e}; the deformation is too large for the material parameters")]
    NonFiniteStress {
        /// Element index.
        element: usize,
        /// Its volume ratio.
        j: f64,
    },
    /// A mesh problem (reference configuration).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A material problem (parameters, lengths, material indices).
    #[error(transparent)]
    Material(#[from] MaterialError),
}

/// Any error of the core, for operations that can fail in more than one way.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Error {
    /// A mesh problem.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A material problem.
    #[error(transparent)]
    Material(#[from] MaterialError),
    /// A linear-algebra problem.
    #[error(transparent)]
    Solver(#[from] SolverError),
}
