//! Surface helpers: input checks, tributary (nodal) areas, contact area.

use super::projection::{scaled_normal, v};
use super::ContactError;

/// Checks that every coordinate is finite.
pub fn check_points(points: &[[f64; 3]]) -> Result<(), ContactError> {
    for (i, p) in points.iter().enumerate() {
        for &c in p {
            if !c.is_finite() {
                return Err(ContactError::NonFinite {
                    what: "points",
                    index: i,
                    value: c,
                });
            }
        }
    }
    Ok(())
}

/// Checks that triangle node indices are `< n_points`.
pub fn check_triangles(
    what: &'static str,
    triangles: &[[usize; 3]],
    n_points: usize,
) -> Result<(), ContactError> {
    for (r, t) in triangles.iter().enumerate() {
        for &i in t {
            if i >= n_points {
                return Err(ContactError::IndexOutOfRange {
                    what,
                    row: r,
                    index: i,
                    len: n_points,
                });
            }
        }
    }
    Ok(())
}

/// Checks triangle indices and that no triangle is degenerate at `points`.
pub fn check_surface(
    what: &'static str,
    points: &[[f64; 3]],
    triangles: &[[usize; 3]],
) -> Result<(), ContactError> {
    check_triangles(what, triangles, points.len())?;
    for (r, t) in triangles.iter().enumerate() {
        scaled_normal(&[points[t[0]], points[t[1]], points[t[2]]], r)?;
    }
    Ok(())
}

/// Tributary area of every node: a third of the area of each surface triangle it belongs
/// to, summed (zero for nodes not on the surface). Length `points.len()`.
pub fn tributary_areas(
    points: &[[f64; 3]],
    triangles: &[[usize; 3]],
) -> Result<Vec<f64>, ContactError> {
    let mut out = vec![0.0; points.len()];
    tributary_areas_into(points, triangles, &mut out)?;
    Ok(out)
}

/// [`tributary_areas`] into a caller's buffer (overwritten; length `points.len()`).
pub fn tributary_areas_into(
    points: &[[f64; 3]],
    triangles: &[[usize; 3]],
    out: &mut [f64],
) -> Result<(), ContactError> {
    check_triangles("triangles", triangles, points.len())?;
    if out.len() != points.len() {
        return Err(ContactError::LengthMismatch {
            what: "tributary area buffer",
            expected: points.len(),
            got: out.len(),
        });
    }
    out.iter_mut().for_each(|x| *x = 0.0);
    for t in triangles {
        let ns = (v(points[t[1]]) - v(points[t[0]])).cross(v(points[t[2]]) - v(points[t[0]]));
        let a3 = ns.length() / 6.0;
        for &i in t {
            out[i] += a3;
        }
    }
    Ok(())
}

/// Contact area as the paper defines it: the summed area of the surface triangles that have
/// at least one loaded vertex (`loaded[node]`).
///
/// ```
/// use vfrs_core::contact::contact_area;
/// let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
/// let t = [[0, 1, 2], [1, 3, 2]];
/// assert_eq!(contact_area(&p, &t, &[true, false, false, false]).unwrap(), 0.5);
/// assert_eq!(contact_area(&p, &t, &[false, true, false, false]).unwrap(), 1.0);
/// ```
pub fn contact_area(
    points: &[[f64; 3]],
    triangles: &[[usize; 3]],
    loaded: &[bool],
) -> Result<f64, ContactError> {
    check_triangles("triangles", triangles, points.len())?;
    if loaded.len() != points.len() {
        return Err(ContactError::LengthMismatch {
            what: "loaded",
            expected: points.len(),
            got: loaded.len(),
        });
    }
    let mut area = 0.0;
    for t in triangles {
        if t.iter().any(|&i| loaded[i]) {
            let ns = (v(points[t[1]]) - v(points[t[0]])).cross(v(points[t[2]]) - v(points[t[0]]));
            area += 0.5 * ns.length();
        }
    }
    Ok(area)
}

/// The distinct nodes of a surface, sorted.
pub fn surface_nodes(triangles: &[[usize; 3]]) -> Vec<usize> {
    let mut n: Vec<usize> = triangles.iter().flatten().copied().collect();
    n.sort_unstable();
    n.dedup();
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tributary_sums_to_area() {
        let p = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [2.0, 2.0, 0.0],
        ];
        let t = [[0, 1, 2], [1, 3, 2]];
        let a = tributary_areas(&p, &t).unwrap();
        assert!((a.iter().sum::<f64>() - 4.0).abs() < 1e-14);
        assert!((a[1] - 4.0 / 3.0).abs() < 1e-14);
        assert!(tributary_areas(&p, &[[0, 1, 9]]).is_err());
        assert!(contact_area(&p, &t, &[true]).is_err());
    }

    #[test]
    fn checks() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [f64::NAN, 0.0, 0.0],
        ];
        assert!(matches!(
            check_surface("s", &p[..3], &[[0, 1, 2]]),
            Err(ContactError::DegenerateTriangle { triangle: 0, .. })
        ));
        assert!(matches!(
            check_points(&p),
            Err(ContactError::NonFinite { index: 3, .. })
        ));
    }
}
