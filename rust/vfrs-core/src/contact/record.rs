//! One record for contact pairs, whatever detected them (interface mesh, BVH, rigid plane).

/// Marks a rigid master (node-to-plane pairs have no master nodes).
pub const RIGID: usize = usize::MAX;

/// Contact pairs as a structure of arrays, one entry per pair.
///
/// For a pair, `g = normal . (x_s - (N1 x1 + N2 x2 + N3 x3))` with `N1 = 1 - xi - zeta`,
/// `N2 = xi`, `N3 = zeta` is the normal gap; it is exactly the row of the constraint matrix
/// applied to the positions (see [`constraint_matrix`](super::constraint_matrix)). For a
/// rigid plane the master nodes are [`RIGID`] and `g = normal . (x_s - origin)`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactPairs {
    /// Slave node.
    pub slave: Vec<usize>,
    /// Master triangle index in the detector's triangle list ([`RIGID`] for a plane).
    pub triangle: Vec<usize>,
    /// Master triangle nodes (x1, x2, x3), [`RIGID`] for a plane.
    pub master: Vec<[usize; 3]>,
    /// Local coordinate xi (= N2).
    pub xi: Vec<f64>,
    /// Local coordinate zeta (= N3).
    pub zeta: Vec<f64>,
    /// Unit master normal, out of the master body.
    pub normal: Vec<[f64; 3]>,
    /// Signed normal gap (negative = penetration).
    pub gap: Vec<f64>,
    /// Tributary area of the slave node on its own surface.
    pub area: Vec<f64>,
    /// Feature of the closest point: 0 face, 1 edge, 2 vertex.
    pub feature: Vec<u8>,
}

impl ContactPairs {
    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.slave.len()
    }

    /// No pairs.
    pub fn is_empty(&self) -> bool {
        self.slave.is_empty()
    }

    /// Empties every array, keeping the capacity (no deallocation).
    pub fn clear(&mut self) {
        self.slave.clear();
        self.triangle.clear();
        self.master.clear();
        self.xi.clear();
        self.zeta.clear();
        self.normal.clear();
        self.gap.clear();
        self.area.clear();
        self.feature.clear();
    }

    /// Appends one pair.
    #[allow(clippy::too_many_arguments)]
    pub fn push(
        &mut self,
        slave: usize,
        triangle: usize,
        master: [usize; 3],
        xi: f64,
        zeta: f64,
        normal: [f64; 3],
        gap: f64,
        area: f64,
        feature: u8,
    ) {
        self.slave.push(slave);
        self.triangle.push(triangle);
        self.master.push(master);
        self.xi.push(xi);
        self.zeta.push(zeta);
        self.normal.push(normal);
        self.gap.push(gap);
        self.area.push(area);
        self.feature.push(feature);
    }

    /// Appends all pairs of `other`.
    pub fn extend_from(&mut self, other: &ContactPairs) {
        self.slave.extend_from_slice(&other.slave);
        self.triangle.extend_from_slice(&other.triangle);
        self.master.extend_from_slice(&other.master);
        self.xi.extend_from_slice(&other.xi);
        self.zeta.extend_from_slice(&other.zeta);
        self.normal.extend_from_slice(&other.normal);
        self.gap.extend_from_slice(&other.gap);
        self.area.extend_from_slice(&other.area);
        self.feature.extend_from_slice(&other.feature);
    }
}
