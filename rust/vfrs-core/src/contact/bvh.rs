//! The general detector: a BVH broad phase over master triangles and a closest-point
//! narrow phase for slave nodes within a search distance.
//!
//! For surfaces that slide or have no gap mesh (verification problems, other geometries).
//! The detector owns its buffers: the first [`BvhEngine::detect`] builds the tree
//! (parry's binned [`Bvh`]); later calls refit it in place and reuse every buffer, so they
//! do not allocate once the pair buffers have grown to their working size. The narrow phase
//! runs in parallel over slave nodes (rayon).

use super::projection::{project_point_triangle, scaled_normal, v, Feature, Projection};
use super::record::ContactPairs;
use super::surface::check_points;
use super::ContactError;
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::math::Vector;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy, BvhWorkspace};
use parry3d_f64::query::PointProjection;
use rayon::prelude::*;
use std::cell::Cell;

/// The closest master triangle found for one slave node.
#[derive(Debug, Clone, PartialEq)]
enum Slot {
    None,
    Hit { triangle: usize, dist: f64 },
    Error(ContactError),
}

/// BVH broad phase + closest-point narrow phase, holding its buffers between calls.
pub struct BvhEngine {
    triangles: Vec<[usize; 3]>,
    slaves: Vec<usize>,
    areas: Vec<f64>,
    max_index: usize,
    bvh: Option<Bvh>,
    workspace: BvhWorkspace,
    aabbs: Vec<Aabb>,
    slots: Vec<Slot>,
    pairs: ContactPairs,
    best_first: bool,
}

/// The closest master triangle within `r` of slave `s` by a range query of the tree (ties
/// go to the lower triangle index).
fn range_search(
    bvh: &Bvh,
    triangles: &[[usize; 3]],
    points: &[[f64; 3]],
    s: usize,
    r: f64,
) -> Slot {
    let p = points[s];
    let pv = Vector::new(p[0], p[1], p[2]);
    let query = Aabb::new(pv - Vector::splat(r), pv + Vector::splat(r));
    let mut best = Slot::None;
    for leaf in bvh.intersect_aabb(&query) {
        let j = leaf as usize;
        let t = triangles[j];
        if t.contains(&s) {
            continue;
        }
        let tri = [points[t[0]], points[t[1]], points[t[2]]];
        match project_point_triangle(p, &tri, j) {
            Ok(pr) => {
                let d = pr.gap.abs();
                if d > r {
                    continue;
                }
                let better = match &best {
                    Slot::Hit { triangle, dist } => d < *dist || (d == *dist && j < *triangle),
                    _ => true,
                };
                if better {
                    best = Slot::Hit {
                        triangle: j,
                        dist: d,
                    };
                }
            }
            Err(e) => {
                best = Slot::Error(e);
                break;
            }
        }
    }
    best
}

/// The projection of slave `s` on its master triangle `t` (index `triangle`), the contact
/// normal and the gap along it (see [`BvhEngine::detect`]).
fn contact_of(
    points: &[[f64; 3]],
    s: usize,
    t: [usize; 3],
    triangle: usize,
) -> Result<(Projection, Vector, f64), ContactError> {
    let tri = [points[t[0]], points[t[1]], points[t[2]]];
    let pr = project_point_triangle(points[s], &tri, triangle)?;
    let ns = scaled_normal(&tri, triangle)?;
    let n = ns / ns.length();
    let d = Vector::new(
        points[s][0] - pr.closest[0],
        points[s][1] - pr.closest[1],
        points[s][2] - pr.closest[2],
    );
    // On a face, d is along n. On an edge or vertex, the contact direction is d itself
    // (signed by the side of the plane), so that the forces G^T lambda have zero moment; it
    // equals n at the face boundary, so the direction is continuous as the node slides off
    // the face.
    let dist = d.length();
    let size = ns.length().sqrt();
    let normal = if pr.feature == Feature::Face || dist <= 1e-12 * size {
        n
    } else if n.dot(d) < 0.0 {
        -d / dist
    } else {
        d / dist
    };
    let gap = normal.dot(d);
    Ok((pr, normal, gap))
}

/// The closest triangle within `r` by best-first BVH traversal (prunes by the best distance
/// found so far; used for an unbounded search).
fn best_first(bvh: &Bvh, triangles: &[[usize; 3]], points: &[[f64; 3]], s: usize, r: f64) -> Slot {
    let p = points[s];
    let pv = Vector::new(p[0], p[1], p[2]);
    let error: Cell<Option<ContactError>> = Cell::new(None);
    // strictly-less comparisons inside parry: widen r by one ulp so that d == r is found
    let max_cost = if r.is_finite() {
        (r * (1.0 + 4.0 * f64::EPSILON)).max(f64::MIN_POSITIVE)
    } else {
        f64::MAX
    };
    let found = bvh.project_point(pv, max_cost, |leaf, _| {
        let j = leaf as usize;
        let t = triangles[j];
        if t.contains(&s) {
            return None;
        }
        let tri = [points[t[0]], points[t[1]], points[t[2]]];
        match project_point_triangle(p, &tri, j) {
            Ok(pr) => Some(PointProjection::new(false, v(pr.closest))),
            Err(e) => {
                error.set(Some(e));
                None
            }
        }
    });
    if let Some(e) = error.take() {
        return Slot::Error(e);
    }
    match found {
        Some((leaf, (dist, _))) if dist <= r => Slot::Hit {
            triangle: leaf as usize,
            dist,
        },
        _ => Slot::None,
    }
}

impl std::fmt::Debug for BvhEngine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BvhEngine")
            .field("n_triangles", &self.triangles.len())
            .field("n_slaves", &self.slaves.len())
            .finish()
    }
}

impl BvhEngine {
    /// A detector of `slaves` (node indices, with their tributary `areas`) against the
    /// master `triangles` (node indices, normals out of the master body).
    pub fn new(
        triangles: Vec<[usize; 3]>,
        slaves: Vec<usize>,
        areas: Vec<f64>,
    ) -> Result<Self, ContactError> {
        if areas.len() != slaves.len() {
            return Err(ContactError::LengthMismatch {
                what: "slave areas",
                expected: slaves.len(),
                got: areas.len(),
            });
        }
        for (i, &a) in areas.iter().enumerate() {
            if !a.is_finite() || a < 0.0 {
                return Err(ContactError::NonFinite {
                    what: "slave areas",
                    index: i,
                    value: a,
                });
            }
        }
        let max_index = triangles
            .iter()
            .flatten()
            .chain(slaves.iter())
            .copied()
            .max()
            .unwrap_or(0);
        let n = slaves.len();
        Ok(Self {
            aabbs: Vec::with_capacity(triangles.len()),
            triangles,
            slaves,
            areas,
            max_index,
            bvh: None,
            workspace: BvhWorkspace::default(),
            slots: vec![Slot::None; n],
            pairs: ContactPairs::default(),
            best_first: false,
        })
    }

    /// Narrow phase by best-first traversal (`true`) instead of testing every triangle
    /// whose box meets the search box (`false`, the default). An infinite search distance
    /// always uses best-first.
    pub fn set_best_first(&mut self, on: bool) {
        self.best_first = on;
    }

    /// Master triangles.
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// Slave nodes.
    pub fn slaves(&self) -> &[usize] {
        &self.slaves
    }

    /// The pairs found by the last [`detect`](Self::detect).
    pub fn pairs(&self) -> &ContactPairs {
        &self.pairs
    }

    fn check_indices(&self, n_points: usize) -> Result<(), ContactError> {
        if self.max_index < n_points || (self.triangles.is_empty() && self.slaves.is_empty()) {
            return Ok(());
        }
        for (r, t) in self.triangles.iter().enumerate() {
            for &i in t {
                if i >= n_points {
                    return Err(ContactError::IndexOutOfRange {
                        what: "master triangles",
                        row: r,
                        index: i,
                        len: n_points,
                    });
                }
            }
        }
        for (r, &i) in self.slaves.iter().enumerate() {
            if i >= n_points {
                return Err(ContactError::IndexOutOfRange {
                    what: "slave nodes",
                    row: r,
                    index: i,
                    len: n_points,
                });
            }
        }
        Ok(())
    }

    fn update_tree(&mut self, points: &[[f64; 3]]) {
        self.aabbs.clear();
        for t in &self.triangles {
            let mut mins = Vector::splat(f64::INFINITY);
            let mut maxs = Vector::splat(f64::NEG_INFINITY);
            for &i in t {
                let p = Vector::new(points[i][0], points[i][1], points[i][2]);
                mins = mins.min(p);
                maxs = maxs.max(p);
            }
            self.aabbs.push(Aabb::new(mins, maxs));
        }
        match &mut self.bvh {
            Some(bvh) => {
                for (i, aabb) in self.aabbs.iter().enumerate() {
                    bvh.insert_or_update_partially(*aabb, i as u32, 0.0);
                }
                bvh.refit(&mut self.workspace);
            }
            None => {
                self.bvh = Some(Bvh::from_leaves(BvhBuildStrategy::Binned, &self.aabbs));
            }
        }
    }

    /// Finds, for every slave node, the closest master triangle within `search_distance`
    /// (may be infinite; ties go to the lower triangle index in the default range search) and records the pair: local coordinates of the
    /// closest point `xbar`, the contact normal, the gap `n . (x_s - xbar)`, the slave's
    /// tributary area and the feature. Pairs come in slave order.
    ///
    /// The contact normal is the triangle's unit normal when `xbar` is inside the face;
    /// when it is on an edge or vertex, it is the unit vector from `xbar` to the slave
    /// (flipped to the master normal's side), so the gap is the signed distance in every case
    /// and the forces `G^T lambda` have zero resultant and zero moment.
    ///
    /// A slave node that is a vertex of a candidate triangle ignores that triangle.
    /// Errors (non-finite coordinate, index out of range, degenerate candidate triangle)
    /// name the node or triangle.
    pub fn detect(
        &mut self,
        points: &[[f64; 3]],
        search_distance: f64,
    ) -> Result<&ContactPairs, ContactError> {
        if search_distance.is_nan() || search_distance < 0.0 {
            return Err(ContactError::BadParameter {
                name: "search_distance",
                value: search_distance,
                reason: "must be >= 0 (infinite: the closest triangle, however far)",
            });
        }
        self.check_indices(points.len())?;
        check_points(points)?;
        self.pairs.clear();
        if self.triangles.is_empty() || self.slaves.is_empty() {
            return Ok(&self.pairs);
        }
        self.update_tree(points);
        let bvh = self.bvh.as_ref().expect("built above");
        let triangles = &self.triangles;
        let r = search_distance;
        let use_best_first = r.is_infinite() || self.best_first;
        self.slots
            .par_iter_mut()
            .zip(self.slaves.par_iter())
            .with_min_len(256)
            .for_each(|(slot, &s)| {
                *slot = if use_best_first {
                    best_first(bvh, triangles, points, s, r)
                } else {
                    range_search(bvh, triangles, points, s, r)
                };
            });
        for (k, slot) in self.slots.iter().enumerate() {
            match slot {
                Slot::None => {}
                Slot::Error(e) => return Err(e.clone()),
                &Slot::Hit { triangle, .. } => {
                    let s = self.slaves[k];
                    let t = self.triangles[triangle];
                    let (pr, normal, gap) = contact_of(points, s, t, triangle)?;
                    self.pairs.push(
                        s,
                        triangle,
                        t,
                        pr.xi,
                        pr.zeta,
                        [normal.x, normal.y, normal.z],
                        gap,
                        self.areas[k],
                        pr.feature as u8,
                    );
                }
            }
        }
        Ok(&self.pairs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two facing grids: master z = 0 (normals +z), slaves at z = h.
    fn grid(n: usize, h: f64) -> (Vec<[f64; 3]>, Vec<[usize; 3]>, Vec<usize>) {
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                p.push([i as f64, j as f64, 0.0]);
            }
        }
        let id = |i: usize, j: usize| j * (n + 1) + i;
        let mut t = Vec::new();
        for j in 0..n {
            for i in 0..n {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let off = p.len();
        let mut s = Vec::new();
        for j in 0..n {
            for i in 0..n {
                p.push([i as f64 + 0.3, j as f64 + 0.6, h]);
                s.push(off + j * n + i);
            }
        }
        (p, t, s)
    }

    #[test]
    fn finds_all_within_distance_and_reuses_buffers() {
        let (mut p, t, s) = grid(8, 0.1);
        let a = vec![1.0; s.len()];
        let mut det = BvhEngine::new(t.clone(), s.clone(), a).unwrap();
        let pairs = det.detect(&p, 0.2).unwrap();
        assert_eq!(pairs.len(), s.len());
        for e in 0..pairs.len() {
            assert!((pairs.gap[e] - 0.1).abs() < 1e-14);
            assert_eq!(pairs.feature[e], 0);
        }
        let cap = det.pairs.slave.capacity();
        // move slaves through the master surface: gaps become negative
        for &k in &s {
            p[k][2] = -0.05;
        }
        let pairs = det.detect(&p, 0.2).unwrap();
        assert_eq!(pairs.len(), s.len());
        assert!(pairs.gap.iter().all(|&g| (g + 0.05).abs() < 1e-14));
        assert_eq!(det.pairs.slave.capacity(), cap);
        // far away: nothing
        for &k in &s {
            p[k][2] = 5.0;
        }
        assert!(det.detect(&p, 0.2).unwrap().is_empty());
        // brute force agrees on a shifted configuration
        for &k in &s {
            p[k][2] = 0.3;
            p[k][0] += 0.37;
        }
        let pairs = det.detect(&p, 1.0).unwrap().clone();
        for (e, &k) in pairs.slave.iter().enumerate() {
            let best = t
                .iter()
                .enumerate()
                .map(|(j, tt)| {
                    let tri = [p[tt[0]], p[tt[1]], p[tt[2]]];
                    (project_point_triangle(p[k], &tri, j).unwrap().gap.abs(), j)
                })
                .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a });
            let got = {
                let tt = pairs.master[e];
                let tri = [p[tt[0]], p[tt[1]], p[tt[2]]];
                project_point_triangle(p[k], &tri, 0).unwrap().gap.abs()
            };
            assert!((best.0 - got).abs() < 1e-14);
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let (mut p, t, s) = grid(2, 0.1);
        let a = vec![1.0; s.len()];
        let mut det = BvhEngine::new(t.clone(), s.clone(), a.clone()).unwrap();
        assert!(det.detect(&p, f64::NAN).is_err());
        p[3][1] = f64::NAN;
        assert!(matches!(
            det.detect(&p, 0.2),
            Err(ContactError::NonFinite { index: 3, .. })
        ));
        assert!(matches!(
            det.detect(&p[..5], 0.2),
            Err(ContactError::IndexOutOfRange { .. })
        ));
        let (mut p, t, s) = grid(2, 0.1);
        // collapse triangle 0 onto a line under a slave
        p[t[0][2]] = p[t[0][1]];
        let mut det = BvhEngine::new(t, s, a).unwrap();
        assert!(matches!(
            det.detect(&p, 0.5),
            Err(ContactError::DegenerateTriangle { .. })
        ));
        assert!(BvhEngine::new(vec![], vec![1], vec![]).is_err());
    }

    #[test]
    fn best_first_agrees_with_range_query() {
        let (mut p, t, s) = grid(10, 0.2);
        for (k, &i) in s.iter().enumerate() {
            p[i][2] = 0.05 * ((k % 7) as f64 - 3.0);
            p[i][0] += 0.13 * ((k % 5) as f64) - 0.9;
        }
        let a = vec![1.0; s.len()];
        let mut range = BvhEngine::new(t.clone(), s.clone(), a.clone()).unwrap();
        let mut best = BvhEngine::new(t.clone(), s.clone(), a.clone()).unwrap();
        best.set_best_first(true);
        for r in [0.1, 0.5, f64::INFINITY] {
            let x = range.detect(&p, r).unwrap().clone();
            let y = best.detect(&p, r).unwrap();
            assert_eq!(x.slave, y.slave, "r = {r}");
            for e in 0..x.len() {
                assert!((x.gap[e] - y.gap[e]).abs() < 1e-14);
            }
        }
        // unbounded: every slave gets a pair
        assert_eq!(best.detect(&p, f64::INFINITY).unwrap().len(), s.len());
    }
}
