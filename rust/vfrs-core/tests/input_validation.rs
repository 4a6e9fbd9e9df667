//! Property tests (issue 15) of the core's input validation: projection, volumes, assembly.
//! Whatever the input (NaN, inf, huge or degenerate coordinates, bad indices), the result is
//! an error or finite numbers that satisfy their invariants; never a panic or a NaN.

use proptest::prelude::*;
use vfrs_core::contact::project_point_triangle;
use vfrs_core::fem::mesh::{check_points, check_topology, signed_volumes};
use vfrs_core::{Assembler, Material, TetMesh};

/// Coordinates: mostly ordinary, sometimes NaN, infinite, huge or tiny.
fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -10.0..10.0f64,
        1 => prop::sample::select(vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300, -1e300, 1e-300, 0.0]),
    ]
}

fn point() -> impl Strategy<Value = [f64; 3]> {
    [coord(), coord(), coord()]
}

fn finite_point() -> impl Strategy<Value = [f64; 3]> {
    [-10.0..10.0f64, -10.0..10.0f64, -10.0..10.0f64]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn projection_is_an_error_or_finite(p in point(), a in point(), b in point(), c in point()) {
        if let Ok(pr) = project_point_triangle(p, &[a, b, c], 0) {
            prop_assert!(pr.gap.is_finite() && pr.xi.is_finite() && pr.zeta.is_finite());
            prop_assert!(pr.closest.iter().chain(pr.normal.iter()).all(|x| x.is_finite()));
            let len = pr.normal.iter().map(|x| x * x).sum::<f64>().sqrt();
            prop_assert!((len - 1.0).abs() < 1e-9, "normal of length {}", len);
            prop_assert!(pr.xi >= -1e-9 && pr.zeta >= -1e-9 && pr.xi + pr.zeta <= 1.0 + 1e-9);
        }
    }

    #[test]
    fn projection_of_a_point_of_an_ordinary_triangle(p in finite_point(), a in finite_point(),
                                                     b in finite_point(), c in finite_point()) {
        // Finite inputs: an error only for a degenerate triangle.
        let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let ac = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2], ab[0] * ac[1] - ab[1] * ac[0]];
        let area2 = n.iter().map(|x| x * x).sum::<f64>().sqrt();
        let h2 = ab.iter().chain(ac.iter()).map(|x| x * x).sum::<f64>();
        let r = project_point_triangle(p, &[a, b, c], 7);
        if area2 > 1e-6 * h2 {
            prop_assert!(r.is_ok(), "{:?}", r.err());
        }
    }

    #[test]
    fn mesh_is_an_error_or_positive_volumes(points in prop::collection::vec(point(), 0..8),
                                             tets in prop::collection::vec([0usize..9, 0usize..9, 0usize..9, 0usize..9], 0..5)) {
        let itets: Vec<[i64; 4]> = tets.iter().map(|t| t.map(|i| i as i64)).collect();
        let topology = check_topology(points.len(), &itets);
        let finite = check_points(&points);
        match TetMesh::new(points.clone(), tets.clone()) {
            Ok(m) => {
                prop_assert!(topology.is_ok() && finite.is_ok());
                let v = signed_volumes(&points, &tets);
                prop_assert!(v.iter().all(|x| x.is_finite() && *x > 0.0));
                prop_assert!(m.volume().is_finite() && m.volume() > 0.0);
            }
            Err(_) => {
                // refused: empty, bad indices or points, or a volume not clearly positive
                // relative to the element's size (TetMesh's rule: v > 1e-14 h^3, h the longest
                // edge; with coordinates near 1e300, h^3 overflows and the tet is refused too)
                if !tets.is_empty() && topology.is_ok() && finite.is_ok() {
                    let v = signed_volumes(&points, &tets);
                    let not_clearly_positive = tets.iter().zip(&v).any(|(t, &vol)| {
                        let mut h2: f64 = 0.0;
                        for a in 0..4 {
                            for b in a + 1..4 {
                                let (p, q) = (points[t[a]], points[t[b]]);
                                h2 = h2.max((0..3).map(|k| (p[k] - q[k]) * (p[k] - q[k])).sum::<f64>());
                            }
                        }
                        let h = h2.sqrt();
                        vol.partial_cmp(&(1e-14 * h * h * h)) != Some(std::cmp::Ordering::Greater)
                    });
                    prop_assert!(not_clearly_positive, "refused although every volume is clearly positive: {:?}", v);
                }
            }
        }
    }

    #[test]
    fn assembly_is_an_error_or_finite(points in prop::collection::vec(finite_point(), 4..9),
                                      tets in prop::collection::vec([0usize..10, 0usize..10, 0usize..10, 0usize..10], 1..5),
                                      e in prop::sample::select(vec![1.0, 1e6, 1e-6]),
                                      nu in prop::sample::select(vec![0.0, 0.3, 0.45])) {
        let asm = match Assembler::new(points.len(), &tets) {
            Ok(a) => a,
            Err(_) => {
                prop_assert!(tets.iter().flatten().any(|&i| i >= points.len()));
                return Ok(());
            }
        };
        let d = Material::Isotropic { e, nu }.elasticity().unwrap();
        let mut values = vec![0.0; asm.nnz()];
        if asm.stiffness_into(&points, &[d], None, &mut values).is_ok() {
            prop_assert!(values.iter().all(|x| x.is_finite()), "non-finite stiffness for finite points");
        }
        // Wrong lengths and materials are errors, not panics.
        let mut short = vec![0.0; asm.nnz().saturating_sub(1)];
        prop_assert!(asm.stiffness_into(&points, &[d], None, &mut short).is_err() || asm.nnz() == 0);
        prop_assert!(asm.stiffness_into(&points[1..], &[d], None, &mut values).is_err());
        prop_assert!(asm.stiffness_into(&points, &[], None, &mut values).is_err());
        let bad_of = vec![5usize; tets.len()];
        prop_assert!(asm.stiffness_into(&points, &[d], Some(&bad_of), &mut values).is_err());
        prop_assert!(asm.mass_into(&points, &[f64::NAN], None, &mut values).is_err());
        prop_assert!(asm.mass_into(&points, &[-1.0], None, &mut values).is_err());
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 500, failure_persistence: None, ..ProptestConfig::default() })]

    /// Non-finite coordinates (a diverged configuration) are refused, not assembled into NaN.
    #[test]
    fn assembly_on_nonfinite_points(points in prop::collection::vec(point(), 4..9)) {
        let tets = vec![[0usize, 1, 2, 3]];
        let asm = Assembler::new(points.len(), &tets).unwrap();
        let d = Material::Isotropic { e: 1.0, nu: 0.3 }.elasticity().unwrap();
        let mut values = vec![0.0; asm.nnz()];
        if asm.stiffness_into(&points, &[d], None, &mut values).is_ok() {
            prop_assert!(values.iter().all(|x| x.is_finite()), "{:?} -> {:?}", &points[..4], values);
        }
    }
}
