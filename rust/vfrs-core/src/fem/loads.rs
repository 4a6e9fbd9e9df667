//! Surface loads: the consistent nodal forces of a pressure on triangles.
//!
//! The traction `-p n` on a triangle with outward normal `n` and `p` linear over it (vertex
//! values `p_a`) gives vertex `a` the force `f_a = -(2 p_a + p_b + p_c) N / 24`, with
//! `N = (x_2 - x_1) x (x_3 - x_1)` (twice the area along `n`). The flow's pressure load is
//! this, once per step on each fold's wetted surface.
//!
//! The forces are summed as the reference numpy code sums them (vfrs.flow.
//! consistent_pressure_forces): per vertex slot `a` of the triangles, a sum over the
//! triangles in their order from 0 (numpy's `bincount`), then the three slots' sums added in
//! slot order. So the numbers are bit for bit the same; the triangles around each node are
//! listed once at construction, and a call allocates nothing.

use crate::error::MeshError;

/// The pressure load of fixed triangles over `n_points` points.
#[derive(Debug, Clone)]
pub struct PressureLoad {
    triangles: Vec<[usize; 3]>,
    n_points: usize,
    /// For slot `a`, node `i`: the triangles with `i` as vertex `a`, in order, at
    /// `adj[a][ptr[a][i]..ptr[a][i + 1]]`.
    ptr: [Vec<usize>; 3],
    adj: [Vec<usize>; 3],
    /// Per triangle: `N` and `s = p_1 + p_2 + p_3` (work, overwritten by each call).
    normal: Vec<[f64; 3]>,
    psum: Vec<f64>,
}

impl PressureLoad {
    /// Checks the triangles' indices against `n_points`.
    pub fn new(triangles: &[[usize; 3]], n_points: usize) -> Result<Self, MeshError> {
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i >= n_points) {
                return Err(MeshError::SurfaceIndex {
                    triangle: t,
                    index: i,
                    n_points,
                });
            }
        }
        let slot = |a: usize| {
            let mut count = vec![0usize; n_points + 1];
            for tri in triangles {
                count[tri[a] + 1] += 1;
            }
            for i in 0..n_points {
                count[i + 1] += count[i];
            }
            let mut next = count.clone();
            let mut adj = vec![0usize; triangles.len()];
            for (t, tri) in triangles.iter().enumerate() {
                adj[next[tri[a]]] = t;
                next[tri[a]] += 1;
            }
            (count, adj)
        };
        let (s0, s1, s2) = (slot(0), slot(1), slot(2));
        Ok(Self {
            triangles: triangles.to_vec(),
            n_points,
            ptr: [s0.0, s1.0, s2.0],
            adj: [s0.1, s1.1, s2.1],
            normal: vec![[0.0; 3]; triangles.len()],
            psum: vec![0.0; triangles.len()],
        })
    }

    /// The nodal forces into `out` (one row per point, overwritten) for the positions
    /// `points` and the nodal pressures `p`.
    pub fn forces(
        &mut self,
        points: &[[f64; 3]],
        p: &[f64],
        out: &mut [[f64; 3]],
    ) -> Result<(), MeshError> {
        for (what, got) in [
            ("points", points.len()),
            ("pressures", p.len()),
            ("forces", out.len()),
        ] {
            if got != self.n_points {
                return Err(MeshError::BadLength {
                    what,
                    expected: self.n_points,
                    got,
                });
            }
        }
        for (t, tri) in self.triangles.iter().enumerate() {
            let (x0, x1, x2) = (points[tri[0]], points[tri[1]], points[tri[2]]);
            let a = [x1[0] - x0[0], x1[1] - x0[1], x1[2] - x0[2]];
            let b = [x2[0] - x0[0], x2[1] - x0[1], x2[2] - x0[2]];
            // numpy's cross: each component a product less another.
            self.normal[t] = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            self.psum[t] = p[tri[0]] + p[tri[1]] + p[tri[2]];
        }
        for (i, f) in out.iter_mut().enumerate() {
            let mut total = [0.0f64; 3];
            for a in 0..3 {
                let mut part = [0.0f64; 3];
                for &t in &self.adj[a][self.ptr[a][i]..self.ptr[a][i + 1]] {
                    let w = -(p[self.triangles[t][a]] + self.psum[t]) / 24.0;
                    for (pc, &nc) in part.iter_mut().zip(&self.normal[t]) {
                        *pc += w * nc;
                    }
                }
                for (tc, pc) in total.iter_mut().zip(part) {
                    *tc += pc;
                }
            }
            *f = total;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_uniform_pressure_on_a_closed_surface_balances_and_a_flat_one_gives_p_times_area() {
        // A unit square in z = 0 (normal +z) under p = 3: -3 along z in all, nothing in x, y;
        // a tetrahedron's closed surface under a uniform pressure: no net force.
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let mut load = PressureLoad::new(&[[0, 1, 2], [0, 2, 3]], 4).expect("valid");
        let mut f = [[f64::NAN; 3]; 4];
        load.forces(&pts, &[3.0; 4], &mut f).expect("valid");
        let fz: f64 = f.iter().map(|r| r[2]).sum();
        assert!((fz + 3.0).abs() < 1e-15 && f.iter().all(|r| r[0] == 0.0 && r[1] == 0.0));
        let tet = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let mut closed = PressureLoad::new(&faces, 4).expect("valid");
        closed.forces(&tet, &[2.0; 4], &mut f).expect("valid");
        for c in 0..3 {
            assert!(f.iter().map(|r| r[c]).sum::<f64>().abs() < 1e-15);
        }
    }

    #[test]
    fn refuses_bad_indices_and_lengths() {
        assert!(matches!(
            PressureLoad::new(&[[0, 1, 4]], 4),
            Err(MeshError::SurfaceIndex {
                triangle: 0,
                index: 4,
                ..
            })
        ));
        let mut load = PressureLoad::new(&[[0, 1, 2]], 4).expect("valid");
        let mut f = [[0.0; 3]; 4];
        assert!(load.forces(&[[0.0; 3]; 3], &[0.0; 4], &mut f).is_err());
        assert!(load.forces(&[[0.0; 3]; 4], &[0.0; 3], &mut f).is_err());
    }
}
