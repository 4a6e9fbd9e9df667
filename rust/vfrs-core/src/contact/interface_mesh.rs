//! The paper's detector: a coarse interface tetrahedral mesh that fills the gap between two
//! surfaces, and its oriented-volume inversion test.
//!
//! # Construction
//! For each direction (surface A as slave against the triangles of B, then B against A),
//! every slave node `s` is joined to the master triangle `(x1, x2, x3)` closest to it in the
//! configuration given to [`InterfaceMesh::build`] (found with the [`BvhEngine`] within
//! `search_distance`). The interface tetrahedron is `(x1, x2, x3, s)`. Master normals point
//! out of the master body, towards the slave, so every interface tet has a positive oriented
//! volume `V = |(x2-x1) x (x3-x1)| h / 6` while `s` is in front of the triangle's plane
//! (`h` its signed distance to that plane); `V` turns negative exactly when `s` crosses the
//! plane. A negative tet is a contact pair (slave `s`, that master triangle). Both
//! directions are built, so a collision in which only one fold moves is seen whichever side
//! moves.
//!
//! # Intersection volume
//! Node-to-triangle tets alone do not tile the gap (a tiling between two non-matching
//! surfaces also needs edge-to-edge tets and, in general, extra points). So each tet carries
//! the weight `w = 3 a_s / (2 A_t)` (slave tributary area `a_s`, master triangle area
//! `A_t` at build time), and `w V = a_s h / 2` is the slave's nodal prism, halved because
//! both directions count it. The intersection volume is the sum of `w |V|` over inverted
//! tets: for flat overlapping slabs it is exactly the overlap volume, for curved surfaces it
//! converges with mesh refinement. The plain sum of `|V|` over inverted tets (the paper's
//! literal definition for its gap-filling mesh) is reported as well
//! ([`Inversion::raw_volume`]).
//!
//! # Limits: when to rebuild
//! The pairing is frozen. It stays right while each slave node, projected onto the plane of
//! its master triangle, stays inside (or near) that triangle: the folds may approach, touch
//! and penetrate along the normal without limit, but may slide tangentially by at most about
//! `max_slip` times the local master element size (default 0.5: half an element), and rotate
//! only as far as that keeps the projections in place. [`InterfaceMesh::max_slip`] measures
//! the slip (how far, in barycentric units, the furthest projection lies outside its
//! triangle); [`InterfaceMesh::update`] rebuilds the pairing at the current positions when it
//! exceeds the limit. A rebuild accepts nodes that are already behind a triangle (in
//! contact); nodes further than `search_distance` from the other surface at build time get no
//! tet and are not seen until the next rebuild, so choose `search_distance` larger than the
//! gap plus the expected penetration. Nodes whose closest point is on the boundary edge of
//! the master surface (a boundary edge or vertex) and that lie behind its plane at build time
//! get no tet either (they are beside the other surface, not in front of it); any other node
//! on or behind the surface it faces at the first build is an error.

use super::bvh::BvhEngine;
use super::projection::{plane_coordinates, scaled_normal, v};
use super::record::ContactPairs;
use super::surface::{check_points, check_surface, surface_nodes, tributary_areas};
use super::ContactError;
use rayon::prelude::*;

/// Parameters of the interface mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterfaceMeshParams {
    /// Nodes further than this from the other surface get no interface tet.
    pub search_distance: f64,
    /// Largest tolerated tangential slip, in barycentric units of the master triangle,
    /// before [`InterfaceMesh::update`] rebuilds the pairing.
    pub max_slip: f64,
}

impl Default for InterfaceMeshParams {
    fn default() -> Self {
        Self {
            search_distance: f64::INFINITY,
            max_slip: 0.5,
        }
    }
}

/// Result of the inversion test at one configuration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Inversion {
    /// Number of inverted tets.
    pub n_inverted: usize,
    /// Weighted intersection volume `sum w |V|` over inverted tets (the overlap volume).
    pub intersection_volume: f64,
    /// Plain `sum |V|` over inverted tets.
    pub raw_volume: f64,
}

/// The interface mesh between two surfaces: tets `(x1, x2, x3, s)`, one per slave node and
/// direction.
#[derive(Debug)]
pub struct InterfaceMesh {
    surfaces: [Vec<[usize; 3]>; 2],
    params: InterfaceMeshParams,
    /// (x1, x2, x3, s) per tet.
    tets: Vec<[usize; 4]>,
    /// Master triangle index within its surface.
    triangle: Vec<usize>,
    /// 0: slave on surface A, master triangle of B; 1: the reverse.
    side: Vec<u8>,
    weight: Vec<f64>,
    area: Vec<f64>,
    slip0: Vec<f64>,
    volumes: Vec<f64>,
    pairs: ContactPairs,
    n_rebuilds: usize,
}

impl InterfaceMesh {
    /// Builds the interface mesh between surfaces `a` and `b` (node triangles into `points`,
    /// normals out of their bodies) at `points`, which must not overlap: a node on or behind
    /// the face of the triangle it faces is [`ContactError::InitialPenetration`].
    pub fn build(
        points: &[[f64; 3]],
        a: Vec<[usize; 3]>,
        b: Vec<[usize; 3]>,
        params: InterfaceMeshParams,
    ) -> Result<Self, ContactError> {
        if params.search_distance.is_nan() || params.search_distance < 0.0 {
            return Err(ContactError::BadParameter {
                name: "search_distance",
                value: params.search_distance,
                reason: "must be >= 0",
            });
        }
        if !(params.max_slip.is_finite() && params.max_slip >= 0.0) {
            return Err(ContactError::BadParameter {
                name: "max_slip",
                value: params.max_slip,
                reason: "must be finite and >= 0",
            });
        }
        let mut m = Self {
            surfaces: [a, b],
            params,
            tets: Vec::new(),
            triangle: Vec::new(),
            side: Vec::new(),
            weight: Vec::new(),
            area: Vec::new(),
            slip0: Vec::new(),
            volumes: Vec::new(),
            pairs: ContactPairs::default(),
            n_rebuilds: 0,
        };
        m.pair_up(points, true)?;
        Ok(m)
    }

    fn pair_up(&mut self, points: &[[f64; 3]], at_rest: bool) -> Result<(), ContactError> {
        check_points(points)?;
        check_surface("surface a", points, &self.surfaces[0])?;
        check_surface("surface b", points, &self.surfaces[1])?;
        self.tets.clear();
        self.triangle.clear();
        self.side.clear();
        self.weight.clear();
        self.area.clear();
        self.slip0.clear();
        // An infinite search distance pairs every node (best-first search in the BVH).
        let r = self.params.search_distance;
        for side in 0..2usize {
            let slave_tris = &self.surfaces[side];
            let master = &self.surfaces[1 - side];
            let nodes = surface_nodes(slave_tris);
            let all_areas = tributary_areas(points, slave_tris)?;
            let areas: Vec<f64> = nodes.iter().map(|&i| all_areas[i]).collect();
            let boundary = boundary_edges(master);
            let mut det = BvhEngine::new(master.clone(), nodes, areas)?;
            let pairs = det.detect(points, r)?;
            for e in 0..pairs.len() {
                let t = pairs.master[e];
                let s = pairs.slave[e];
                let tri = [points[t[0]], points[t[1]], points[t[2]]];
                let ns = scaled_normal(&tri, pairs.triangle[e])?;
                let (xi, zeta, h) = plane_coordinates(v(points[s]), &tri, ns);
                if at_rest && h <= 0.0 {
                    let w = [
                        1.0 - pairs.xi[e] - pairs.zeta[e],
                        pairs.xi[e],
                        pairs.zeta[e],
                    ];
                    let on_boundary = match pairs.feature[e] {
                        0 => false,
                        1 => {
                            let k = (0..3)
                                .min_by(|&i, &j| w[i].abs().total_cmp(&w[j].abs()))
                                .unwrap_or(0);
                            let (x, y) = (t[(k + 1) % 3], t[(k + 2) % 3]);
                            boundary.binary_search(&(x.min(y), x.max(y))).is_ok()
                        }
                        _ => {
                            let k = (0..3).max_by(|&i, &j| w[i].total_cmp(&w[j])).unwrap_or(0);
                            boundary.iter().any(|&(x, y)| x == t[k] || y == t[k])
                        }
                    };
                    if !on_boundary {
                        return Err(ContactError::InitialPenetration {
                            node: s,
                            triangle: pairs.triangle[e],
                            gap: h,
                        });
                    }
                    continue;
                }
                let at = 0.5 * ns.length();
                self.tets.push([t[0], t[1], t[2], s]);
                self.triangle.push(pairs.triangle[e]);
                self.side.push(side as u8);
                self.weight.push(3.0 * pairs.area[e] / (2.0 * at));
                self.area.push(pairs.area[e]);
                self.slip0.push(outside(xi, zeta));
            }
        }
        self.volumes.clear();
        self.volumes.resize(self.tets.len(), 0.0);
        Ok(())
    }

    /// Rebuilds the pairing at `points` (which may be in contact). Allocates.
    pub fn rebuild(&mut self, points: &[[f64; 3]]) -> Result<(), ContactError> {
        self.pair_up(points, false)?;
        self.n_rebuilds += 1;
        Ok(())
    }

    /// Rebuilds when [`max_slip`](Self::max_slip) exceeds the limit; returns whether it did.
    pub fn update(&mut self, points: &[[f64; 3]]) -> Result<bool, ContactError> {
        if self.max_slip(points)? > self.params.max_slip {
            self.rebuild(points)?;
            Ok(true)
        } else {
            Ok(false)
        }
    }

    /// How many times the pairing was rebuilt since [`build`](Self::build).
    pub fn n_rebuilds(&self) -> usize {
        self.n_rebuilds
    }

    /// Tets `(x1, x2, x3, s)`: master triangle nodes then the slave node.
    pub fn tets(&self) -> &[[usize; 4]] {
        &self.tets
    }

    /// Master triangle index (within its own surface) of each tet.
    pub fn triangles(&self) -> &[usize] {
        &self.triangle
    }

    /// Side of each tet: 0 = slave on surface A, 1 = slave on surface B.
    pub fn sides(&self) -> &[u8] {
        &self.side
    }

    /// Volume weight `3 a_s / (2 A_t)` of each tet.
    pub fn weights(&self) -> &[f64] {
        &self.weight
    }

    /// The pairs found by the last [`detect`](Self::detect).
    pub fn pairs(&self) -> &ContactPairs {
        &self.pairs
    }

    /// The two surfaces.
    pub fn surfaces(&self) -> &[Vec<[usize; 3]>; 2] {
        &self.surfaces
    }

    /// Parameters.
    pub fn params(&self) -> InterfaceMeshParams {
        self.params
    }

    fn check(&self, points: &[[f64; 3]]) -> Result<(), ContactError> {
        for (r, t) in self.tets.iter().enumerate() {
            for &i in t {
                if i >= points.len() {
                    return Err(ContactError::IndexOutOfRange {
                        what: "interface tets",
                        row: r,
                        index: i,
                        len: points.len(),
                    });
                }
            }
        }
        check_points(points)
    }

    /// Oriented volumes of the interface tets at `points` (negative = inverted), computed in
    /// parallel into an internal buffer.
    pub fn signed_volumes(&mut self, points: &[[f64; 3]]) -> Result<&[f64], ContactError> {
        self.check(points)?;
        let tets = &self.tets;
        self.volumes
            .par_iter_mut()
            .zip(tets.par_iter())
            .with_min_len(1024)
            .for_each(|(vol, t)| {
                let x1 = v(points[t[0]]);
                *vol = (v(points[t[1]]) - x1)
                    .cross(v(points[t[2]]) - x1)
                    .dot(v(points[t[3]]) - x1)
                    / 6.0;
            });
        Ok(&self.volumes)
    }

    /// The inversion test: how many tets are inverted and the intersection volume.
    pub fn inversion(&mut self, points: &[[f64; 3]]) -> Result<Inversion, ContactError> {
        self.signed_volumes(points)?;
        let mut out = Inversion::default();
        for (k, &vol) in self.volumes.iter().enumerate() {
            if vol < 0.0 {
                out.n_inverted += 1;
                out.intersection_volume -= self.weight[k] * vol;
                out.raw_volume -= vol;
            }
        }
        Ok(out)
    }

    /// Largest tangential slip since the last (re)build: over tets, the growth of
    /// `max(0, -min(N1, N2, N3))`, with `N` the local coordinates of the slave's projection
    /// onto the plane of its master triangle (how far, in barycentric units, the projection
    /// has moved out of its triangle; nodes that already projected outside the master
    /// surface at build time, at its boundary, are measured from where they were).
    pub fn max_slip(&self, points: &[[f64; 3]]) -> Result<f64, ContactError> {
        self.check(points)?;
        let mut worst: f64 = 0.0;
        for (k, t) in self.tets.iter().enumerate() {
            let tri = [points[t[0]], points[t[1]], points[t[2]]];
            let ns = scaled_normal(&tri, self.triangle[k])?;
            let (xi, zeta, _) = plane_coordinates(v(points[t[3]]), &tri, ns);
            worst = worst.max(outside(xi, zeta) - self.slip0[k]);
        }
        Ok(worst)
    }

    /// Contact pairs of the inverted tets at `points`, in tet order: slave node, master
    /// triangle, the local coordinates of the slave's projection on the master plane
    /// (unclamped), unit normal, normal gap (negative), tributary area, feature (0 when the
    /// projection is inside the triangle, 1 when one local coordinate is negative, 2 when
    /// two are). Call [`update`](Self::update) first to rebuild when the folds have slid.
    pub fn detect(&mut self, points: &[[f64; 3]]) -> Result<&ContactPairs, ContactError> {
        self.signed_volumes(points)?;
        self.pairs.clear();
        for k in 0..self.tets.len() {
            if self.volumes[k] >= 0.0 {
                continue;
            }
            let t = self.tets[k];
            let tri = [points[t[0]], points[t[1]], points[t[2]]];
            let ns = scaled_normal(&tri, self.triangle[k])?;
            let (xi, zeta, h) = plane_coordinates(v(points[t[3]]), &tri, ns);
            let n = ns / ns.length();
            let neg = [1.0 - xi - zeta, xi, zeta]
                .iter()
                .filter(|&&c| c < 0.0)
                .count()
                .min(2) as u8;
            self.pairs.push(
                t[3],
                self.triangle[k],
                [t[0], t[1], t[2]],
                xi,
                zeta,
                [n.x, n.y, n.z],
                h,
                self.area[k],
                neg,
            );
        }
        Ok(&self.pairs)
    }
}

/// Edges (sorted node pairs, sorted list) used by exactly one triangle.
fn boundary_edges(triangles: &[[usize; 3]]) -> Vec<(usize, usize)> {
    let mut e: Vec<(usize, usize)> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
        .collect();
    e.sort_unstable();
    let mut out = Vec::new();
    let mut i = 0;
    while i < e.len() {
        let mut j = i + 1;
        while j < e.len() && e[j] == e[i] {
            j += 1;
        }
        if j - i == 1 {
            out.push(e[i]);
        }
        i = j;
    }
    out
}

/// How far a point with local coordinates (xi, zeta) lies outside the triangle.
#[inline]
fn outside(xi: f64, zeta: f64) -> f64 {
    0.0f64.max(-(1.0 - xi - zeta)).max(-xi).max(-zeta)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat n x n grid of unit-ish cells in the plane x = x0, normal +x or -x.
    fn sheet(
        p: &mut Vec<[f64; 3]>,
        n: usize,
        h: f64,
        x0: f64,
        normal_plus: bool,
    ) -> Vec<[usize; 3]> {
        let off = p.len();
        for j in 0..=n {
            for i in 0..=n {
                p.push([x0, i as f64 * h, j as f64 * h]);
            }
        }
        let id = |i: usize, j: usize| off + j * (n + 1) + i;
        let mut t = Vec::new();
        for j in 0..n {
            for i in 0..n {
                // (y, z) counter-clockwise seen from +x gives normal +x
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                if normal_plus {
                    t.push([a, b, c]);
                    t.push([a, c, d]);
                } else {
                    t.push([a, c, b]);
                    t.push([a, d, c]);
                }
            }
        }
        t
    }

    #[test]
    fn rest_push_and_overlap() {
        let mut p = Vec::new();
        // left fold surface at x = -0.05 facing +x, right at x = +0.05 facing -x,
        // non-matching (4 vs 5 cells on the same 1 x 1 square).
        let left = sheet(&mut p, 4, 0.25, -0.05, true);
        let n_left = p.len();
        let right = sheet(&mut p, 5, 0.2, 0.05, false);
        let mut im = InterfaceMesh::build(
            &p,
            right.clone(),
            left.clone(),
            InterfaceMeshParams {
                search_distance: 0.5,
                max_slip: 0.5,
            },
        )
        .unwrap();
        assert_eq!(im.tets().len(), 25 + 36);
        let inv = im.inversion(&p).unwrap();
        assert_eq!(inv.n_inverted, 0);
        assert!(im.signed_volumes(&p).unwrap().iter().all(|&v| v > 0.0));
        // push one right node through the left surface
        let s = n_left + 7;
        let mut q = p.clone();
        q[s][0] = -0.1;
        im.signed_volumes(&q).unwrap();
        let pairs = im.detect(&q).unwrap();
        let from_right: Vec<usize> = (0..pairs.len()).filter(|&e| pairs.slave[e] == s).collect();
        assert_eq!(from_right.len(), 1);
        assert!((pairs.gap[from_right[0]] + 0.05).abs() < 1e-14);
        for e in 0..pairs.len() {
            assert!(pairs.slave[e] == s || pairs.master[e].contains(&s));
        }
        // shift the whole right sheet by -0.15: overlap 0.05 over the unit square
        let mut q = p.clone();
        for x in q.iter_mut().skip(n_left) {
            x[0] -= 0.15;
        }
        let inv = im.inversion(&q).unwrap();
        assert_eq!(inv.n_inverted, 61);
        assert!((inv.intersection_volume - 0.05).abs() < 1e-12, "{inv:?}");
        // only the left moves: also seen
        let mut q = p.clone();
        for x in q.iter_mut().take(n_left) {
            x[0] += 0.12;
        }
        let inv = im.inversion(&q).unwrap();
        assert_eq!(inv.n_inverted, 61);
        assert!((inv.intersection_volume - 0.02).abs() < 1e-12);
    }

    #[test]
    fn overlap_at_rest_and_slip() {
        let mut p = Vec::new();
        let left = sheet(&mut p, 2, 0.5, 0.05, true);
        let right = sheet(&mut p, 2, 0.5, -0.05, false);
        assert!(matches!(
            InterfaceMesh::build(&p, right, left, InterfaceMeshParams::default()),
            Err(ContactError::InitialPenetration { .. })
        ));
        let mut p = Vec::new();
        let left = sheet(&mut p, 2, 0.5, -0.05, true);
        let nl = p.len();
        let right = sheet(&mut p, 2, 0.5, 0.05, false);
        let mut im = InterfaceMesh::build(&p, right, left, InterfaceMeshParams::default()).unwrap();
        assert!(im.max_slip(&p).unwrap() < 1e-12);
        assert!(!im.update(&p).unwrap());
        let mut q = p.clone();
        for x in q.iter_mut().skip(nl) {
            x[1] += 0.4;
        }
        assert!(im.max_slip(&q).unwrap() > 0.5);
        assert!(im.update(&q).unwrap());
        assert_eq!(im.n_rebuilds(), 1);
        assert!(im.max_slip(&q).unwrap() < 1e-12);
        let mut bad = q.clone();
        bad[0][2] = f64::INFINITY;
        assert!(im.inversion(&bad).is_err());
        assert!(im.inversion(&q[..3]).is_err());
    }

    #[test]
    fn degenerate_and_non_finite_build_are_errors() {
        let mut p = Vec::new();
        let left = sheet(&mut p, 2, 0.5, -0.05, true);
        let right = sheet(&mut p, 2, 0.5, 0.05, false);
        let mut bad = p.clone();
        bad[4][1] = f64::NAN;
        assert!(matches!(
            InterfaceMesh::build(&bad, right.clone(), left.clone(), Default::default()),
            Err(ContactError::NonFinite { index: 4, .. })
        ));
        let mut flat = p.clone();
        let t = left[3];
        flat[t[1]] = flat[t[0]];
        assert!(matches!(
            InterfaceMesh::build(&flat, right.clone(), left.clone(), Default::default()),
            Err(ContactError::DegenerateTriangle { .. })
        ));
        let params = InterfaceMeshParams {
            search_distance: f64::NAN,
            max_slip: 0.5,
        };
        assert!(InterfaceMesh::build(&p, right.clone(), left.clone(), params).is_err());
        // empty surfaces: an empty mesh, not a panic
        let mut im = InterfaceMesh::build(&p, vec![], left, Default::default()).unwrap();
        assert_eq!(im.inversion(&p).unwrap().n_inverted, 0);
    }
}
