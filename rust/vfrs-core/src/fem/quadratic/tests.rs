//! The assembled P2 stiffness and mass on a unit cube of six ten-node tetrahedra: symmetry,
//! rigid modes, the mass's total and lumping, the linear and the quadratic patch tests at the
//! cube's centre (a node interior to all six elements), and bad input.

use super::*;
use crate::fem::tet10::EDGES;

/// The unit cube split into 6 positively oriented tetrahedra (Kuhn), with a node at the
/// midpoint of every edge: (points, ten-node elements, the centre node).
fn cube() -> (Vec<[f64; 3]>, Vec<[usize; 10]>, usize) {
    let (mut p, tets) = crate::fem::test_support::cube();
    let mut mids = std::collections::BTreeMap::new();
    let mut elems = Vec::new();
    for t in &tets {
        let mut el = [0usize; 10];
        el[..4].copy_from_slice(t);
        for (k, [i, j]) in EDGES.iter().enumerate() {
            let key = (t[*i].min(t[*j]), t[*i].max(t[*j]));
            el[4 + k] = *mids.entry(key).or_insert_with(|| {
                p.push(std::array::from_fn(|r| 0.5 * (p[key.0][r] + p[key.1][r])));
                p.len() - 1
            });
        }
        elems.push(el);
    }
    let centre = mids[&(0, 7)];
    (p, elems, centre)
}

fn dense(a: &QuadraticAssembler, v: &[f64]) -> Vec<Vec<f64>> {
    let n = a.n_dofs();
    let mut m = vec![vec![0.0; n]; n];
    for (j, w) in a.col_ptr().windows(2).enumerate() {
        for (&i, &x) in a.row_idx()[w[0]..w[1]].iter().zip(&v[w[0]..w[1]]) {
            m[i][j] += x;
        }
    }
    m
}

fn materials() -> Vec<Elasticity> {
    crate::fem::test_support::tissues()
}

/// The assembled stiffness as a dense matrix, and its largest entry.
fn assembled(a: &QuadraticAssembler, p: &[[f64; 3]], d: Elasticity) -> (Vec<Vec<f64>>, f64) {
    let mut v = vec![0.0; a.nnz()];
    a.stiffness_into(p, &[d], None, &mut v).unwrap();
    (dense(a, &v), v.iter().fold(0.0f64, |m, x| m.max(x.abs())))
}

fn apply(k: &[Vec<f64>], u: &[f64]) -> Vec<f64> {
    k.iter()
        .map(|row| row.iter().zip(u).map(|(a, b)| a * b).sum())
        .collect()
}

#[test]
fn the_stiffness_is_symmetric_and_rigid_motions_load_nothing() {
    let (p, e, _) = cube();
    let a = QuadraticAssembler::new(p.len(), &e).unwrap();
    for d in materials() {
        let (k, scale) = assembled(&a, &p, d);
        for (i, row) in k.iter().enumerate() {
            for (j, kij) in row.iter().enumerate() {
                assert!((kij - k[j][i]).abs() < 1e-12 * scale);
            }
        }
        let rotation: Vec<f64> = p.iter().flat_map(|x| [-x[1], x[0], 0.0]).collect();
        assert!(apply(&k, &rotation).iter().all(|f| f.abs() < 1e-10 * scale));
    }
}

#[test]
fn the_mass_totals_rho_v_and_its_lumping_is_positive() {
    let (p, e, _) = cube();
    let a = QuadraticAssembler::new(p.len(), &e).unwrap();
    let mut v = vec![0.0; a.nnz()];
    a.mass_into(&p, &[2.5], None, &mut v).unwrap();
    assert!((v.iter().sum::<f64>() - 3.0 * 2.5).abs() < 1e-12);
    let l = a.lumped_mass(&p, &[2.5], None).unwrap();
    assert!(l.iter().all(|m| *m > 0.0));
    assert!((l.iter().sum::<f64>() - 3.0 * 2.5).abs() < 1e-12);
}

/// A quadratic displacement field, its strain's derivatives (Voigt, engineering shears) along
/// x, y and z.
fn field(x: &[f64; 3]) -> [f64; 3] {
    [x[0] * x[0], x[0] * x[1], 0.5 * x[1] * x[2] + x[2] * x[2]]
}
const DEPS: [[f64; 6]; 3] = [
    [2.0, 1.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 0.5, 0.0, 0.0, 1.0],
    [0.0, 0.0, 2.0, 0.5, 0.0, 0.0],
];

#[test]
fn patch_tests_at_the_centre_linear_and_quadratic() {
    let (p, e, centre) = cube();
    let a = QuadraticAssembler::new(p.len(), &e).unwrap();
    for d in materials() {
        let (k, scale) = assembled(&a, &p, d);
        // linear: no force at an interior node
        let lin: Vec<f64> = p
            .iter()
            .flat_map(|x| {
                [
                    1e-3 * x[0] + 2e-3 * x[1],
                    -1e-3 * x[2],
                    0.5e-3 * x[0] - 1e-3 * x[1] + 2e-3 * x[2],
                ]
            })
            .collect();
        let f = apply(&k, &lin);
        for c in 0..3 {
            assert!(
                f[3 * centre + c].abs() < 1e-12 * scale,
                "linear: {}",
                f[3 * centre + c]
            );
        }
        // quadratic: the interior node's force is -div(sigma) times int N dV = 1/5 (six
        // elements of volume 1/6 around a mid-edge node, each int N = V / 5)
        let u: Vec<f64> = p.iter().flat_map(field).collect();
        let f = apply(&k, &u);
        let ds: Vec<[f64; 6]> = DEPS
            .iter()
            .map(|de| std::array::from_fn(|s| (0..6).map(|t| d[s][t] * de[t]).sum()))
            .collect();
        let div = [
            ds[0][0] + ds[1][5] + ds[2][4],
            ds[0][5] + ds[1][1] + ds[2][3],
            ds[0][4] + ds[1][3] + ds[2][2],
        ];
        for c in 0..3 {
            let want = -div[c] / 5.0;
            assert!(
                (f[3 * centre + c] - want).abs() < 1e-9 * scale,
                "quadratic, direction {c}: {} vs {want}",
                f[3 * centre + c]
            );
        }
    }
}

#[test]
fn bad_input_is_an_error_naming_the_element() {
    let (mut p, e, centre) = cube();
    assert!(matches!(
        QuadraticAssembler::new(5, &e),
        Err(MeshError::IndexOutOfRange { tet: 0, .. })
    ));
    let a = QuadraticAssembler::new(p.len(), &e).unwrap();
    let d = materials()[0];
    let mut v = vec![0.0; a.nnz()];
    assert!(a.stiffness_into(&p[1..], &[d], None, &mut v).is_err());
    // the centre node pulled far outside the cube: every element around it folds over
    p[centre] = [3.0, 3.0, 3.0];
    match a.stiffness_into(&p, &[d], None, &mut v) {
        Err(Error::Mesh(MeshError::InvertedQuadratic { tet, .. })) => assert!(tet < 6),
        other => panic!("expected an inverted element, got {other:?}"),
    }
    assert!(a.lumped_mass(&p, &[1.0], None).is_err());
}
