//! Node-to-triangle projection: closest point, local coordinates, feature, normal, gap.

use super::ContactError;
use parry3d_f64::math::Vector;
use parry3d_f64::query::PointQueryWithLocation;
use parry3d_f64::shape::{Triangle, TrianglePointLocation};

/// Relative area below which a triangle counts as degenerate: |(x2-x1) x (x3-x1)| must exceed
/// this times the square of its longest edge.
pub const DEGENERATE_TOL: f64 = 1e-12;

/// The feature of the master triangle on which the closest point lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Feature {
    /// The interior of the face.
    Face = 0,
    /// One of the three edges.
    Edge = 1,
    /// One of the three vertices.
    Vertex = 2,
}

/// Projection of a slave node onto a master triangle (x1, x2, x3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Closest point of the triangle, `N1 x1 + N2 x2 + N3 x3`.
    pub closest: [f64; 3],
    /// Local coordinate `xi` = N2 of the closest point.
    pub xi: f64,
    /// Local coordinate `zeta` = N3 of the closest point.
    pub zeta: f64,
    /// Unit normal `(x2 - x1) x (x3 - x1) / |...|`, out of the master body.
    pub normal: [f64; 3],
    /// Distance to the closest point, negative when the node is on the side of the
    /// triangle's plane opposite the normal.
    pub gap: f64,
    /// Where the closest point lies.
    pub feature: Feature,
}

#[inline]
pub(crate) fn v(p: [f64; 3]) -> Vector {
    Vector::new(p[0], p[1], p[2])
}

#[inline]
pub(crate) fn a(p: Vector) -> [f64; 3] {
    [p.x, p.y, p.z]
}

/// The scaled normal `(x2 - x1) x (x3 - x1)` of a triangle, or an error if it is degenerate.
/// `index` is the triangle index reported in the error.
#[inline]
pub fn scaled_normal(tri: &[[f64; 3]; 3], index: usize) -> Result<Vector, ContactError> {
    let (x1, x2, x3) = (v(tri[0]), v(tri[1]), v(tri[2]));
    let e1 = x2 - x1;
    let e2 = x3 - x1;
    let ns = e1.cross(e2);
    let len2 = ns.length_squared();
    let longest = e1
        .length_squared()
        .max(e2.length_squared())
        .max((x3 - x2).length_squared());
    if !(len2.is_finite() && longest.is_finite()) {
        for (k, p) in tri.iter().enumerate() {
            for &c in p {
                if !c.is_finite() {
                    return Err(ContactError::NonFinite {
                        what: "triangle vertex",
                        index: 3 * index + k,
                        value: c,
                    });
                }
            }
        }
        return Err(ContactError::NonFinite {
            what: "triangle normal (coordinates too large)",
            index,
            value: len2,
        });
    }
    if len2.sqrt() <= DEGENERATE_TOL * longest || len2 == 0.0 {
        return Err(ContactError::DegenerateTriangle {
            triangle: index,
            area: 0.5 * len2.sqrt(),
        });
    }
    Ok(ns)
}

/// Projects `p` onto the triangle `tri` (closest point, with parry).
///
/// `index` only labels errors. A degenerate triangle or a non-finite coordinate is an error,
/// never a NaN.
///
/// ```
/// use vfrs_core::contact::{project_point_triangle, Feature};
/// let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
/// let pr = project_point_triangle([0.25, 0.25, -0.5], &tri, 0).unwrap();
/// assert_eq!(pr.feature, Feature::Face);
/// assert!((pr.gap + 0.5).abs() < 1e-15 && (pr.xi - 0.25).abs() < 1e-15);
/// assert_eq!(pr.normal, [0.0, 0.0, 1.0]);
/// ```
pub fn project_point_triangle(
    p: [f64; 3],
    tri: &[[f64; 3]; 3],
    index: usize,
) -> Result<Projection, ContactError> {
    for &c in &p {
        if !c.is_finite() {
            return Err(ContactError::NonFinite {
                what: "point",
                index,
                value: c,
            });
        }
    }
    let ns = scaled_normal(tri, index)?;
    let n = ns / ns.length();
    let t = Triangle::new(v(tri[0]), v(tri[1]), v(tri[2]));
    let pv = v(p);
    let (proj, loc) = t.project_local_point_and_get_location(pv, false);
    let (bc, feature) = match loc {
        TrianglePointLocation::OnFace(_, b) => (b, Feature::Face),
        TrianglePointLocation::OnEdge(e, uv) => {
            let mut b = [0.0; 3];
            let (i, j) = match e {
                0 => (0, 1),
                1 => (1, 2),
                _ => (0, 2),
            };
            b[i] = uv[0];
            b[j] = uv[1];
            (b, Feature::Edge)
        }
        TrianglePointLocation::OnVertex(i) => {
            let mut b = [0.0; 3];
            b[(i as usize).min(2)] = 1.0;
            (b, Feature::Vertex)
        }
        // Not produced with solid = false; treat as the plane projection.
        TrianglePointLocation::OnSolid => {
            let (xi, zeta, _) = plane_coordinates(pv, tri, ns);
            ([1.0 - xi - zeta, xi, zeta], Feature::Face)
        }
    };
    let closest = proj.point;
    let dist = (pv - closest).length();
    let side = n.dot(pv - v(tri[0]));
    let gap = if side < 0.0 { -dist } else { dist };
    if !(gap.is_finite() && closest.is_finite() && bc.iter().all(|c| c.is_finite())) {
        return Err(ContactError::NonFinite {
            what: "projection (coordinates too large)",
            index,
            value: gap,
        });
    }
    Ok(Projection {
        closest: a(closest),
        xi: bc[1],
        zeta: bc[2],
        normal: a(n),
        gap,
        feature,
    })
}

/// Projects `points[k]` onto `triangles[k]` for every k, in parallel. Errors name the pair.
pub fn project_pairs(
    points: &[[f64; 3]],
    triangles: &[[[f64; 3]; 3]],
) -> Result<Vec<Projection>, ContactError> {
    use rayon::prelude::*;
    if points.len() != triangles.len() {
        return Err(ContactError::LengthMismatch {
            what: "triangles",
            expected: points.len(),
            got: triangles.len(),
        });
    }
    points
        .par_iter()
        .zip(triangles.par_iter())
        .enumerate()
        .with_min_len(1024)
        .map(|(k, (p, t))| project_point_triangle(*p, t, k))
        .collect()
}

/// Local coordinates (xi, zeta) of the projection of `p` onto the *plane* of `tri`
/// (unclamped: outside [0, 1] when the projection leaves the triangle) and the signed
/// distance to that plane. `ns` is the triangle's scaled normal.
#[inline]
pub fn plane_coordinates(p: Vector, tri: &[[f64; 3]; 3], ns: Vector) -> (f64, f64, f64) {
    let x1 = v(tri[0]);
    let e1 = v(tri[1]) - x1;
    let e2 = v(tri[2]) - x1;
    let q = p - x1;
    let n2 = ns.length_squared();
    let xi = q.cross(e2).dot(ns) / n2;
    let zeta = e1.cross(q).dot(ns) / n2;
    let h = q.dot(ns) / n2.sqrt();
    (xi, zeta, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: [[f64; 3]; 3] = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]];

    #[test]
    fn face_edge_vertex() {
        let f = project_point_triangle([0.5, 0.5, 1.0], &T, 0).unwrap();
        assert_eq!(f.feature, Feature::Face);
        assert!((f.gap - 1.0).abs() < 1e-14);
        assert!((f.xi - 0.25).abs() < 1e-14 && (f.zeta - 0.25).abs() < 1e-14);
        let e = project_point_triangle([1.0, -1.0, -1.0], &T, 0).unwrap();
        assert_eq!(e.feature, Feature::Edge);
        assert!((e.gap + 2f64.sqrt()).abs() < 1e-14);
        assert!((e.xi - 0.5).abs() < 1e-14 && e.zeta.abs() < 1e-14);
        let vx = project_point_triangle([3.0, -1.0, 0.0], &T, 0).unwrap();
        assert_eq!(vx.feature, Feature::Vertex);
        assert_eq!(vx.closest, [2.0, 0.0, 0.0]);
        assert!((vx.xi - 1.0).abs() < 1e-15);
        // hypotenuse edge BC
        let h = project_point_triangle([2.0, 2.0, 0.5], &T, 0).unwrap();
        assert_eq!(h.feature, Feature::Edge);
        assert!((h.xi - 0.5).abs() < 1e-14 && (h.zeta - 0.5).abs() < 1e-14);
    }

    #[test]
    fn closest_matches_local_coordinates() {
        for p in [
            [0.3, 0.1, 0.2],
            [5.0, 5.0, -1.0],
            [-1.0, 0.5, 0.3],
            [0.1, -3.0, 0.0],
        ] {
            let r = project_point_triangle(p, &T, 0).unwrap();
            let n1 = 1.0 - r.xi - r.zeta;
            for (k, &c) in r.closest.iter().enumerate() {
                let x = n1 * T[0][k] + r.xi * T[1][k] + r.zeta * T[2][k];
                assert!((x - c).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn degenerate_and_non_finite_are_errors() {
        let flat = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert!(matches!(
            project_point_triangle([0.0, 1.0, 0.0], &flat, 7),
            Err(ContactError::DegenerateTriangle { triangle: 7, .. })
        ));
        let same = [[1.0, 1.0, 1.0]; 3];
        assert!(project_point_triangle([0.0; 3], &same, 0).is_err());
        assert!(matches!(
            project_point_triangle([f64::NAN, 0.0, 0.0], &T, 3),
            Err(ContactError::NonFinite { index: 3, .. })
        ));
        let inf = [[0.0, 0.0, 0.0], [f64::INFINITY, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(project_point_triangle([0.0; 3], &inf, 1).is_err());
        let nan = [[0.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(project_point_triangle([0.0; 3], &nan, 1).is_err());
    }

    /// Extreme but finite coordinates: an error or finite results, never a panic or a NaN.
    #[test]
    fn no_panic_no_nan_on_extreme_input() {
        let vals = [0.0, 1.0, -1.0, 1e-310, 1e-160, 1e154, -1e200, 1e308, 3.0];
        let mut state: u64 = 12345;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            vals[(state >> 33) as usize % vals.len()]
        };
        for _ in 0..20000 {
            let p = [next(), next(), next()];
            let t = [
                [next(), next(), next()],
                [next(), next(), next()],
                [next(), next(), next()],
            ];
            if let Ok(r) = project_point_triangle(p, &t, 0) {
                assert!(
                    r.closest
                        .iter()
                        .chain(r.normal.iter())
                        .all(|c| c.is_finite())
                        && r.xi.is_finite()
                        && r.zeta.is_finite()
                        && r.gap.is_finite(),
                    "{p:?} {t:?} -> {r:?}"
                );
            }
        }
    }

    #[test]
    fn plane_coordinates_unclamped() {
        let ns = scaled_normal(&T, 0).unwrap();
        let (xi, zeta, h) = plane_coordinates(Vector::new(3.0, 1.0, -0.5), &T, ns);
        assert!((xi - 1.5).abs() < 1e-14 && (zeta - 0.5).abs() < 1e-14 && (h + 0.5).abs() < 1e-14);
    }
}
