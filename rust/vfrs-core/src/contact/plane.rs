//! Node-to-rigid-plane contact (symmetric models, verification problems).

use super::record::{ContactPairs, RIGID};
use super::surface::check_points;
use super::ContactError;

/// A rigid plane through `origin` with `normal` pointing out of the rigid body (towards the
/// free side).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidPlane {
    origin: [f64; 3],
    normal: [f64; 3],
}

impl RigidPlane {
    /// A plane; the normal is normalised. Zero or non-finite input is an error.
    pub fn new(origin: [f64; 3], normal: [f64; 3]) -> Result<Self, ContactError> {
        for (k, &c) in origin.iter().enumerate() {
            if !c.is_finite() {
                return Err(ContactError::NonFinite {
                    what: "plane origin",
                    index: k,
                    value: c,
                });
            }
        }
        let len = normal.iter().map(|c| c * c).sum::<f64>().sqrt();
        if !(len.is_finite() && len > 0.0) {
            return Err(ContactError::BadNormal { pair: 0, normal });
        }
        Ok(Self {
            origin,
            normal: normal.map(|c| c / len),
        })
    }

    /// The unit normal.
    pub fn normal(&self) -> [f64; 3] {
        self.normal
    }

    /// The origin.
    pub fn origin(&self) -> [f64; 3] {
        self.origin
    }

    /// Signed gap `n . (x - origin)`.
    #[inline]
    pub fn gap(&self, x: [f64; 3]) -> f64 {
        (0..3)
            .map(|d| self.normal[d] * (x[d] - self.origin[d]))
            .sum()
    }

    /// Appends to `out` a pair for every node of `nodes` (with tributary `areas`) whose
    /// gap is at most `search_distance`; master nodes are [`RIGID`], the triangle index
    /// is [`RIGID`], xi = zeta = 0, feature 0.
    ///
    /// ```
    /// use vfrs_core::contact::{ContactPairs, RigidPlane};
    /// let plane = RigidPlane::new([0.0; 3], [2.0, 0.0, 0.0]).unwrap();
    /// let mut out = ContactPairs::default();
    /// plane.detect(&[[0.1, 0.0, 0.0], [-0.2, 1.0, 0.0], [5.0, 0.0, 0.0]], &[0, 1, 2], &[1.0; 3], 0.5, &mut out).unwrap();
    /// assert_eq!(out.slave, vec![0, 1]);
    /// assert!((out.gap[1] + 0.2).abs() < 1e-15);
    /// ```
    pub fn detect(
        &self,
        points: &[[f64; 3]],
        nodes: &[usize],
        areas: &[f64],
        search_distance: f64,
        out: &mut ContactPairs,
    ) -> Result<(), ContactError> {
        if areas.len() != nodes.len() {
            return Err(ContactError::LengthMismatch {
                what: "areas",
                expected: nodes.len(),
                got: areas.len(),
            });
        }
        if search_distance.is_nan() {
            return Err(ContactError::BadParameter {
                name: "search_distance",
                value: search_distance,
                reason: "must not be NaN",
            });
        }
        for (r, &i) in nodes.iter().enumerate() {
            if i >= points.len() {
                return Err(ContactError::IndexOutOfRange {
                    what: "nodes",
                    row: r,
                    index: i,
                    len: points.len(),
                });
            }
        }
        check_points(points)?;
        for (k, &i) in nodes.iter().enumerate() {
            let g = self.gap(points[i]);
            if g <= search_distance {
                out.push(i, RIGID, [RIGID; 3], 0.0, 0.0, self.normal, g, areas[k], 0);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors() {
        assert!(RigidPlane::new([0.0; 3], [0.0; 3]).is_err());
        assert!(RigidPlane::new([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]).is_err());
        let p = RigidPlane::new([0.0; 3], [0.0, 0.0, 1.0]).unwrap();
        let mut out = ContactPairs::default();
        assert!(p.detect(&[[0.0; 3]], &[1], &[1.0], 1.0, &mut out).is_err());
        assert!(p
            .detect(&[[f64::NAN, 0.0, 0.0]], &[0], &[1.0], 1.0, &mut out)
            .is_err());
    }
}
