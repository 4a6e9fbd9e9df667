//! Uniform refinement of a tetrahedral mesh: every tetrahedron split into eight.
//!
//! Each edge gets one new node at its midpoint, shared by all elements (and surface
//! triangles) around the edge. The new nodes are numbered after the old ones, in the order
//! their edges are first met: tetrahedra in order, and within one the local edges
//! (0,1), (0,2), (0,3), (1,2), (1,3), (2,3). A tetrahedron `(v0, v1, v2, v3)` gives four
//! corner children (the parent halved about each vertex) and the interior octahedron, split
//! into four along its shortest diagonal (ties to the first of m01-m23, m02-m13, m03-m12).
//! Every child keeps the parent's orientation: positive children from a positive parent.
//! The children of tetrahedron `t` are `8 t .. 8 t + 8`; those of surface triangle `k` are
//! `4 k .. 4 k + 4` (the same midpoints, the same outward normal).

use std::collections::HashMap;

use crate::error::MeshError;
use crate::fem::mesh::{check_points, sub};

/// A refined mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Refined {
    /// The old nodes, then one midpoint per edge.
    pub points: Vec<[f64; 3]>,
    /// Eight children per tetrahedron, those of tet `t` at `8 t .. 8 t + 8`.
    pub tets: Vec<[usize; 4]>,
    /// Four children per triangle given, those of triangle `k` at `4 k .. 4 k + 4`.
    pub triangles: Vec<[usize; 3]>,
    /// The end nodes (sorted) of edge `e`, whose midpoint is node `n_old + e`.
    pub edges: Vec<[usize; 2]>,
}

/// Local edges of a tetrahedron, in numbering order.
const TET_EDGES: [[usize; 2]; 6] = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];

/// The octahedron's diagonals as pairs of local edge indices (into [`TET_EDGES`]), each with
/// its four other midpoints in a cycle ordered so that `(a, b, c_i, c_i+1)` is positive.
const DIAGONALS: [([usize; 2], [usize; 4]); 3] = [
    // m01-m23, cycle m02 m03 m13 m12
    ([0, 5], [1, 2, 4, 3]),
    // m02-m13, cycle m01 m12 m23 m03 (the reverse of m01 m03 m23 m12)
    ([1, 4], [0, 3, 5, 2]),
    // m03-m12, cycle m01 m02 m23 m13
    ([2, 3], [0, 1, 5, 4]),
];

fn key(a: usize, b: usize) -> [usize; 2] {
    if a < b {
        [a, b]
    } else {
        [b, a]
    }
}

fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let d = sub(a, b);
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// Checks the tetrahedra's indices (in range, no repeated vertex) and the coordinates.
fn check(points: &[[f64; 3]], tets: &[[usize; 4]]) -> Result<(), MeshError> {
    check_points(points)?;
    let n = points.len();
    for (t, tet) in tets.iter().enumerate() {
        for (a, &i) in tet.iter().enumerate() {
            if i >= n {
                return Err(MeshError::IndexOutOfRange {
                    tet: t,
                    index: i64::try_from(i).unwrap_or(i64::MAX),
                    n_points: n,
                });
            }
            if tet[..a].contains(&i) {
                return Err(MeshError::RepeatedVertex { tet: t, index: i });
            }
        }
    }
    Ok(())
}

/// Splits every tetrahedron into eight and every triangle of `triangles` (the named
/// surfaces, concatenated) into four, with shared edge midpoints.
///
/// Errors: a non-finite coordinate, a tet index out of range or repeated, a triangle
/// index out of range, or a triangle edge that is no edge of a tetrahedron.
///
/// ```
/// use vfrs_core::fem::refine::refine;
/// let pts = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let r = refine(&pts, &[[0, 1, 2, 3]], &[[1, 2, 3]]).unwrap();
/// assert_eq!((r.points.len(), r.tets.len(), r.triangles.len()), (10, 8, 4));
/// ```
pub fn refine(
    points: &[[f64; 3]],
    tets: &[[usize; 4]],
    triangles: &[[usize; 3]],
) -> Result<Refined, MeshError> {
    check(points, tets)?;
    let n = points.len();
    let mut index: HashMap<[usize; 2], usize> = HashMap::with_capacity(tets.len() * 2);
    let mut edges: Vec<[usize; 2]> = Vec::with_capacity(tets.len() * 2);
    let mut out_points = points.to_vec();
    let mut out_tets = Vec::with_capacity(tets.len() * 8);
    for tet in tets {
        let mut m = [0usize; 6];
        for (e, &[a, b]) in TET_EDGES.iter().enumerate() {
            let k = key(tet[a], tet[b]);
            m[e] = *index.entry(k).or_insert_with(|| {
                edges.push(k);
                let (p, q) = (&points[k[0]], &points[k[1]]);
                // symmetric in p and q: the same midpoint from either end
                out_points.push([
                    (p[0] + q[0]) * 0.5,
                    (p[1] + q[1]) * 0.5,
                    (p[2] + q[2]) * 0.5,
                ]);
                n + edges.len() - 1
            });
        }
        let [v0, v1, v2, v3] = *tet;
        let [m01, m02, m03, m12, m13, m23] = m;
        out_tets.push([v0, m01, m02, m03]);
        out_tets.push([m01, v1, m12, m13]);
        out_tets.push([m02, m12, v2, m23]);
        out_tets.push([m03, m13, m23, v3]);
        // the shortest diagonal; strict `<` keeps the first of equal ones
        let mut best = 0;
        let mut best_len = f64::INFINITY;
        for (d, (ends, _)) in DIAGONALS.iter().enumerate() {
            let l = dist2(&out_points[m[ends[0]]], &out_points[m[ends[1]]]);
            if l < best_len {
                best = d;
                best_len = l;
            }
        }
        let (ends, cycle) = DIAGONALS[best];
        for i in 0..4 {
            out_tets.push([m[ends[0]], m[ends[1]], m[cycle[i]], m[cycle[(i + 1) % 4]]]);
        }
    }
    let out_tris = refine_triangles(triangles, n, &index)?;
    Ok(Refined {
        points: out_points,
        tets: out_tets,
        triangles: out_tris,
        edges,
    })
}

/// Every triangle of `triangles` split into four at the edge midpoints `index` (edge ->
/// midpoint) of the refined tetrahedra of a mesh of `n` points.
fn refine_triangles(
    triangles: &[[usize; 3]],
    n: usize,
    index: &HashMap<[usize; 2], usize>,
) -> Result<Vec<[usize; 3]>, MeshError> {
    let mut out_tris = Vec::with_capacity(triangles.len() * 4);
    for (k, tri) in triangles.iter().enumerate() {
        let mut m = [0usize; 3];
        for (e, (a, b)) in [(0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
            for &i in &[tri[a], tri[b]] {
                if i >= n {
                    return Err(MeshError::SurfaceIndex {
                        triangle: k,
                        index: i,
                        n_points: n,
                    });
                }
            }
            m[e] = *index
                .get(&key(tri[a], tri[b]))
                .ok_or(MeshError::SurfaceEdgeNotInMesh {
                    triangle: k,
                    a: tri[a],
                    b: tri[b],
                })?;
        }
        let [a, b, c] = *tri;
        let [mab, mbc, mca] = m;
        out_tris.push([a, mab, mca]);
        out_tris.push([mab, b, mbc]);
        out_tris.push([mca, mbc, c]);
        out_tris.push([mab, mbc, mca]);
    }
    Ok(out_tris)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::mesh::tests::unit;
    use crate::fem::mesh::{cross, signed_volume, signed_volumes};

    /// A cube [0,1]^3 (scaled, shifted) of six positive tetrahedra around the diagonal 0-6,
    /// plus an extra node so that the 2x2x2 corners are not all that is used.
    fn cube(s: f64, shift: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[usize; 4]>) {
        let mut p = Vec::new();
        for &(x, y, z) in &[
            (0., 0., 0.),
            (1., 0., 0.),
            (1., 1., 0.),
            (0., 1., 0.),
            (0., 0., 1.),
            (1., 0., 1.),
            (1., 1., 1.),
            (0., 1., 1.),
        ] {
            p.push([s * x + shift[0], s * y + shift[1], s * z + shift[2]]);
        }
        let mut t = vec![
            [0, 1, 2, 6],
            [0, 2, 3, 6],
            [0, 3, 7, 6],
            [0, 7, 4, 6],
            [0, 4, 5, 6],
            [0, 5, 1, 6],
        ];
        for tet in &mut t {
            if signed_volume(&p[tet[0]], &p[tet[1]], &p[tet[2]], &p[tet[3]]) < 0.0 {
                tet.swap(0, 1);
            }
        }
        (p, t)
    }

    fn n_edges(tets: &[[usize; 4]]) -> usize {
        let mut e: Vec<[usize; 2]> = tets
            .iter()
            .flat_map(|t| TET_EDGES.iter().map(move |&[a, b]| key(t[a], t[b])))
            .collect();
        e.sort_unstable();
        e.dedup();
        e.len()
    }

    #[test]
    fn every_diagonal_gives_positive_children() {
        // stretch the unit tet so that each of the three diagonals is the shortest once
        let base = unit();
        let mut chosen = std::collections::BTreeSet::new();
        for scale in [
            [1.0, 1.0, 1.0],
            [3.0, 1.0, 1.0],
            [1.0, 3.0, 1.0],
            [1.0, 1.0, 3.0],
        ] {
            for shear in [0.0, 0.7, -0.4] {
                let p: Vec<[f64; 3]> = base
                    .iter()
                    .map(|x| {
                        [
                            scale[0] * x[0] + shear * x[1],
                            scale[1] * x[1],
                            scale[2] * x[2] + shear * x[0],
                        ]
                    })
                    .collect();
                let v = signed_volume(&p[0], &p[1], &p[2], &p[3]);
                assert!(v > 0.0);
                let r = refine(&p, &[[0, 1, 2, 3]], &[]).unwrap();
                let vols = signed_volumes(&r.points, &r.tets);
                for c in &vols {
                    assert!((c - v / 8.0).abs() <= 1e-14 * v, "{c} vs {}", v / 8.0);
                }
                // which diagonal: the octahedron's children share their first two nodes
                chosen.insert(key(r.tets[4][0], r.tets[4][1]));
            }
        }
        assert_eq!(chosen.len(), 3, "all three diagonals exercised: {chosen:?}");
    }

    #[test]
    fn volumes_counts_and_shared_midpoints() {
        let (p, t) = cube(1e-3, [0.2, -0.1, 0.05]);
        let r = refine(&p, &t, &[]).unwrap();
        let ne = n_edges(&t);
        assert_eq!(r.tets.len(), 8 * t.len());
        assert_eq!(r.points.len(), p.len() + ne);
        assert_eq!(r.edges.len(), ne);
        let v0: f64 = signed_volumes(&p, &t).iter().sum();
        let vols = signed_volumes(&r.points, &r.tets);
        assert!(vols.iter().all(|&v| v > 0.0));
        let v1: f64 = vols.iter().sum();
        assert!((v1 - v0).abs() <= 1e-14 * v0, "{v1} vs {v0}");
        // per parent too
        let parents = signed_volumes(&p, &t);
        for (i, pv) in parents.iter().enumerate() {
            let s: f64 = vols[8 * i..8 * i + 8].iter().sum();
            assert!((s - pv).abs() <= 1e-14 * pv);
        }
        // no two nodes at one position: midpoints shared, not duplicated
        let mut keys: Vec<[u64; 3]> = r.points.iter().map(|x| x.map(f64::to_bits)).collect();
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), r.points.len());
        // each midpoint is its edge's
        for (e, [a, b]) in r.edges.iter().enumerate() {
            let m = r.points[p.len() + e];
            for k in 0..3 {
                assert_eq!(m[k], (p[*a][k] + p[*b][k]) * 0.5);
            }
        }
        // conforming: every interior face of the refined mesh is used twice, the boundary
        // (12 triangles of the cube, 4 each) once
        let mut faces: HashMap<[usize; 3], usize> = HashMap::new();
        for tet in &r.tets {
            for f in [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]] {
                let mut k = [tet[f[0]], tet[f[1]], tet[f[2]]];
                k.sort_unstable();
                *faces.entry(k).or_default() += 1;
            }
        }
        assert!(faces.values().all(|&c| c == 1 || c == 2));
        assert_eq!(faces.values().filter(|&&c| c == 1).count(), 12 * 4);
    }

    #[test]
    fn twice_and_deterministic() {
        let (p, t) = cube(2.0, [0.0; 3]);
        let r1 = refine(&p, &t, &[]).unwrap();
        let r2 = refine(&r1.points, &r1.tets, &[]).unwrap();
        assert_eq!(r2.tets.len(), 64 * t.len());
        let v: f64 = signed_volumes(&r2.points, &r2.tets).iter().sum();
        assert!((v - 8.0).abs() <= 1e-13);
        assert!(signed_volumes(&r2.points, &r2.tets)
            .iter()
            .all(|&x| x > 0.0));
        assert_eq!(refine(&r1.points, &r1.tets, &[]).unwrap(), r2);
    }

    #[test]
    fn triangles_keep_area_and_normal() {
        let (p, t) = cube(1.0, [0.0; 3]);
        // the z = 0 face, outward normal -z: nodes 0, 1, 2, 3 (counter-clockwise from +z)
        let tris = [[0, 2, 1], [0, 3, 2]];
        let r = refine(&p, &t, &tris).unwrap();
        assert_eq!(r.triangles.len(), 8);
        let mut area = [0.0; 3];
        for tri in &r.triangles {
            let n = cross(
                &sub(&r.points[tri[1]], &r.points[tri[0]]),
                &sub(&r.points[tri[2]], &r.points[tri[0]]),
            );
            assert!(n[2] < 0.0, "outward normal kept: {n:?}");
            for k in 0..3 {
                area[k] += 0.5 * n[k];
            }
        }
        assert!((area[2] + 1.0).abs() < 1e-15);
        // the refined triangles are faces of refined tets
        let mut faces = std::collections::HashSet::new();
        for tet in &r.tets {
            for f in [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]] {
                let mut k = [tet[f[0]], tet[f[1]], tet[f[2]]];
                k.sort_unstable();
                faces.insert(k);
            }
        }
        for tri in &r.triangles {
            let mut k = *tri;
            k.sort_unstable();
            assert!(faces.contains(&k));
        }
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let p = unit();
        assert_eq!(
            refine(&p, &[[0, 1, 2, 4]], &[]),
            Err(MeshError::IndexOutOfRange {
                tet: 0,
                index: 4,
                n_points: 4
            })
        );
        assert_eq!(
            refine(&p, &[[0, 1, 1, 3]], &[]),
            Err(MeshError::RepeatedVertex { tet: 0, index: 1 })
        );
        assert!(matches!(
            refine(&p, &[[0, 1, 2, usize::MAX]], &[]),
            Err(MeshError::IndexOutOfRange { .. })
        ));
        assert_eq!(
            refine(&p, &[[0, 1, 2, 3]], &[[0, 1, 9]]),
            Err(MeshError::SurfaceIndex {
                triangle: 0,
                index: 9,
                n_points: 4
            })
        );
        let (cp, ct) = cube(1.0, [0.0; 3]);
        // 1-3 is a diagonal of the z = 0 face that no tet has (they use 0-2)
        assert_eq!(
            refine(&cp, &ct, &[[1, 3, 0]]),
            Err(MeshError::SurfaceEdgeNotInMesh {
                triangle: 0,
                a: 1,
                b: 3
            })
        );
        let mut bad = unit();
        bad[2][1] = f64::NAN;
        assert!(matches!(
            refine(&bad, &[[0, 1, 2, 3]], &[]),
            Err(MeshError::NonFinite { point: 2, .. })
        ));
        // an empty mesh refines to itself
        let r = refine(&p, &[], &[]).unwrap();
        assert_eq!((r.points.len(), r.tets.len()), (4, 0));
    }
}
