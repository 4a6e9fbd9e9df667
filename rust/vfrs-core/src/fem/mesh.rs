//! A mesh of linear tetrahedra, validated on construction.

use crate::error::MeshError;

/// Nodes and positively oriented linear tetrahedra.
#[derive(Debug, Clone)]
pub struct TetMesh {
    /// Node coordinates, n x 3.
    pub points: Vec<[f64; 3]>,
    /// Element connectivity, m x 4, positively oriented.
    pub tets: Vec<[usize; 4]>,
}

/// Signed volume det(b-a, c-a, d-a)/6 of a tetrahedron.
#[inline]
pub fn signed_volume(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3], d: &[f64; 3]) -> f64 {
    let u = sub(b, a);
    let v = sub(c, a);
    let w = sub(d, a);
    dot(&u, &cross(&v, &w)) / 6.0
}

#[inline]
pub(crate) fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
pub(crate) fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
pub(crate) fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Checks point and tet indices without looking at volumes (for inversion tests on
/// deformed configurations, where negative volumes are data, not errors).
pub fn check_topology(n_points: usize, tets: &[[i64; 4]]) -> Result<(), MeshError> {
    for (t, tet) in tets.iter().enumerate() {
        for (a, &i) in tet.iter().enumerate() {
            if i < 0 || i as usize >= n_points {
                return Err(MeshError::IndexOutOfRange {
                    tet: t,
                    index: i,
                    n_points,
                });
            }
            if tet[..a].contains(&i) {
                return Err(MeshError::RepeatedVertex {
                    tet: t,
                    index: i as usize,
                });
            }
        }
    }
    Ok(())
}

/// Checks that every coordinate is finite.
pub fn check_points(points: &[[f64; 3]]) -> Result<(), MeshError> {
    for (p, x) in points.iter().enumerate() {
        for (axis, &value) in x.iter().enumerate() {
            if !value.is_finite() {
                return Err(MeshError::NonFinite {
                    point: p,
                    axis,
                    value,
                });
            }
        }
    }
    Ok(())
}

/// Signed volumes of all tetrahedra (indices must be valid: see [`check_topology`]).
pub fn signed_volumes(points: &[[f64; 3]], tets: &[[usize; 4]]) -> Vec<f64> {
    tets.iter()
        .map(|t| signed_volume(&points[t[0]], &points[t[1]], &points[t[2]], &points[t[3]]))
        .collect()
}

impl TetMesh {
    /// Validates and builds a mesh: finite coordinates, indices in range, no repeated vertex
    /// in a tet, every signed volume positive.
    ///
    /// ```
    /// use vfrs_core::TetMesh;
    /// let pts = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    /// let mesh = TetMesh::new(pts.clone(), vec![[0, 1, 2, 3]]).unwrap();
    /// assert!((mesh.volume() - 1.0 / 6.0).abs() < 1e-15);
    /// assert!(TetMesh::new(pts, vec![[0, 2, 1, 3]]).is_err()); // inverted
    /// ```
    pub fn new(points: Vec<[f64; 3]>, tets: Vec<[usize; 4]>) -> Result<Self, MeshError> {
        if tets.is_empty() {
            return Err(MeshError::Empty);
        }
        check_points(&points)?;
        let n = points.len();
        for (t, tet) in tets.iter().enumerate() {
            for (a, &i) in tet.iter().enumerate() {
                if i >= n {
                    return Err(MeshError::IndexOutOfRange {
                        tet: t,
                        index: i as i64,
                        n_points: n,
                    });
                }
                if tet[..a].contains(&i) {
                    return Err(MeshError::RepeatedVertex { tet: t, index: i });
                }
            }
            let v = signed_volume(
                &points[tet[0]],
                &points[tet[1]],
                &points[tet[2]],
                &points[tet[3]],
            );
            // Relative to the element's own size, so that mm and m meshes behave alike.
            let h = edge_scale(&points, tet);
            // Not `v <= ...`: a NaN volume or size must fail too.
            if v.partial_cmp(&(1e-14 * h * h * h)) != Some(std::cmp::Ordering::Greater) {
                return Err(MeshError::NonPositiveVolume { tet: t, volume: v });
            }
        }
        Ok(Self { points, tets })
    }

    /// Number of nodes.
    pub fn n_points(&self) -> usize {
        self.points.len()
    }

    /// Number of tetrahedra.
    pub fn n_tets(&self) -> usize {
        self.tets.len()
    }

    /// Total volume.
    pub fn volume(&self) -> f64 {
        signed_volumes(&self.points, &self.tets).iter().sum()
    }
}

fn edge_scale(points: &[[f64; 3]], tet: &[usize; 4]) -> f64 {
    let mut h: f64 = 0.0;
    for a in 0..4 {
        for b in a + 1..4 {
            let d = sub(&points[tet[a]], &points[tet[b]]);
            h = h.max(dot(&d, &d).sqrt());
        }
    }
    h
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The unit tetrahedron's corners (positively oriented as 0, 1, 2, 3); shared by the
    /// tests of other modules (refine.rs).
    pub(crate) fn unit() -> Vec<[f64; 3]> {
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ]
    }

    #[test]
    fn rejects_each_bad_input_with_its_index() {
        assert_eq!(TetMesh::new(unit(), vec![]).unwrap_err(), MeshError::Empty);
        let e = TetMesh::new(unit(), vec![[0, 1, 2, 3], [0, 1, 2, 7]]).unwrap_err();
        assert_eq!(
            e,
            MeshError::IndexOutOfRange {
                tet: 1,
                index: 7,
                n_points: 4
            }
        );
        let e = TetMesh::new(unit(), vec![[0, 1, 1, 3]]).unwrap_err();
        assert_eq!(e, MeshError::RepeatedVertex { tet: 0, index: 1 });
        assert!(matches!(
            TetMesh::new(unit(), vec![[0, 2, 1, 3]]).unwrap_err(),
            MeshError::NonPositiveVolume { tet: 0, .. }
        ));
        let mut p = unit();
        p[2][1] = f64::NAN;
        assert!(matches!(
            TetMesh::new(p, vec![[0, 1, 2, 3]]).unwrap_err(),
            MeshError::NonFinite {
                point: 2,
                axis: 1,
                ..
            }
        ));
        let mut flat = unit();
        flat[3] = [0.3, 0.3, 0.0];
        assert!(matches!(
            TetMesh::new(flat, vec![[0, 1, 2, 3]]).unwrap_err(),
            MeshError::NonPositiveVolume { .. }
        ));
        assert!(check_topology(4, &[[0, 1, 2, -1]]).is_err());
    }
}
