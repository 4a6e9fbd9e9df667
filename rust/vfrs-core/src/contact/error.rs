//! Typed errors of the contact geometry. Each variant carries the indices a user needs to
//! find the culprit (node, triangle, pair).

use thiserror::Error;

/// What is wrong with a contact-geometry input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ContactError {
    /// A triangle has (numerically) zero area, so it has no normal.
    #[error(
        "triangle {triangle} is degenerate (area {area:e}): it has no normal; remove or repair it"
    )]
    DegenerateTriangle {
        /// Triangle index (pair index for pairwise projection).
        triangle: usize,
        /// Its area.
        area: f64,
    },
    /// A coordinate or value is NaN or infinite.
    #[error("{what}[{index}] is not finite ({value})")]
    NonFinite {
        /// Which array.
        what: &'static str,
        /// Row index.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// An index refers to a node or triangle that does not exist.
    #[error("{what}[{row}] = {index} is out of range (there are {len})")]
    IndexOutOfRange {
        /// Which array.
        what: &'static str,
        /// Row holding the bad index.
        row: usize,
        /// The bad index.
        index: usize,
        /// Number of valid entries.
        len: usize,
    },
    /// Arrays that must have the same length do not.
    #[error("{what}: expected length {expected}, got {got}")]
    LengthMismatch {
        /// Which array.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// A contact pair whose slave node is a vertex of its own master triangle.
    #[error("pair {pair}: slave node {node} is a vertex of its master triangle")]
    SlaveInMaster {
        /// Pair index.
        pair: usize,
        /// The node.
        node: usize,
    },
    /// A normal vector is zero or not finite.
    #[error("normal of pair {pair} is not a finite non-zero vector: {normal:?}")]
    BadNormal {
        /// Pair index.
        pair: usize,
        /// The normal given.
        normal: [f64; 3],
    },
    /// A parameter is out of its admissible range.
    #[error("parameter {name} = {value} is invalid: {reason}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
        /// Why.
        reason: &'static str,
    },
    /// At construction of the interface mesh, a node already lies on or behind the
    /// triangle it faces: the surfaces overlap at rest, or a surface is oriented inwards.
    #[error("interface mesh: node {node} is on or behind triangle {triangle} at rest (gap {gap:e}); the surfaces overlap or a surface's triangles point into its body")]
    InitialPenetration {
        /// Slave node.
        node: usize,
        /// Master triangle index.
        triangle: usize,
        /// Its signed gap at rest.
        gap: f64,
    },
}
