//! The P2 tetrahedron against closed forms: the quadrature rules' exactness, the shape
//! functions' interpolation and quadratic completeness, the stiffness's rigid-body null space
//! and rank (no spurious zero-energy modes), constant-strain energy, and the mass's totals,
//! closed form and lumping.

use super::*;

fn factorial(n: u32) -> f64 {
    (1..=n).map(f64::from).product()
}

/// int over the tetrahedron of volume 1 of L0^a L1^b L2^c L3^d = 6 a! b! c! d! / (a+b+c+d+3)!
fn barycentric_integral(p: [u32; 4]) -> f64 {
    6.0 * p.iter().map(|&k| factorial(k)).product::<f64>() / factorial(p.iter().sum::<u32>() + 3)
}

fn monomials(max: u32) -> Vec<[u32; 4]> {
    let mut out = Vec::new();
    for a in 0..=max {
        for b in 0..=max - a {
            for c in 0..=max - a - b {
                for d in 0..=max - a - b - c {
                    out.push([a, b, c, d]);
                }
            }
        }
    }
    out
}

fn rule_error(rule: &Rule, p: [u32; 4]) -> f64 {
    let q: f64 = rule
        .points
        .iter()
        .zip(rule.weights)
        .map(|(l, w)| w * (0..4).map(|k| l[k].powi(p[k] as i32)).product::<f64>())
        .sum();
    let exact = barycentric_integral(p);
    (q - exact).abs() / exact
}

#[test]
fn rules_integrate_their_degree_exactly_and_not_the_next() {
    for (rule, degree) in [(&RULE_4, 2u32), (&RULE_14, 5u32)] {
        assert!((rule.weights.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!(rule.weights.iter().all(|w| *w > 0.0));
        for p in monomials(degree) {
            assert!(
                rule_error(rule, p) < 1e-14,
                "{p:?}: {}",
                rule_error(rule, p)
            );
        }
        let next = monomials(degree + 1)
            .into_iter()
            .map(|p| rule_error(rule, p))
            .fold(0.0, f64::max);
        assert!(next > 1e-6, "degree {} is exact too", degree + 1);
    }
}

fn vertices() -> [[f64; 3]; 4] {
    [
        [0.1, 0.0, 0.2],
        [1.2, 0.1, 0.0],
        [0.2, 1.3, 0.1],
        [0.0, 0.3, 0.9],
    ]
}

fn volume(v: &[[f64; 3]; 4]) -> f64 {
    let e = |i: usize, r: usize| v[i][r] - v[0][r];
    (e(1, 0) * (e(2, 1) * e(3, 2) - e(2, 2) * e(3, 1))
        - e(1, 1) * (e(2, 0) * e(3, 2) - e(2, 2) * e(3, 0))
        + e(1, 2) * (e(2, 0) * e(3, 1) - e(2, 1) * e(3, 0)))
        / 6.0
}

/// The barycentric coordinates of each node.
fn node_coordinates() -> [[f64; 4]; 10] {
    let mut l = [[0.0; 4]; 10];
    for (i, li) in l.iter_mut().take(4).enumerate() {
        li[i] = 1.0;
    }
    for (e, [i, j]) in EDGES.iter().enumerate() {
        l[4 + e][*i] = 0.5;
        l[4 + e][*j] = 0.5;
    }
    l
}

#[test]
fn shape_functions_interpolate_the_nodes_and_sum_to_one() {
    for (b, l) in node_coordinates().iter().enumerate() {
        let n = shape(l);
        for (a, na) in n.iter().enumerate() {
            assert!((na - if a == b { 1.0 } else { 0.0 }).abs() < 1e-15);
        }
    }
    for l in RULE_14.points {
        assert!((shape(l).iter().sum::<f64>() - 1.0).abs() < 1e-14);
        for k in 0..3 {
            assert!(
                reference_gradients(l)
                    .iter()
                    .map(|g| g[k])
                    .sum::<f64>()
                    .abs()
                    < 1e-13
            );
        }
    }
}

/// A quadratic field and its gradient.
fn quadratic(x: &[f64; 3]) -> (f64, [f64; 3]) {
    let f = 1.0 + 2.0 * x[0] - x[1] + 0.5 * x[2] + 3.0 * x[0] * x[0] - 1.5 * x[0] * x[1]
        + 2.5 * x[1] * x[2]
        - x[2] * x[2];
    let g = [
        2.0 + 6.0 * x[0] - 1.5 * x[1],
        -1.0 - 1.5 * x[0] + 2.5 * x[2],
        0.5 + 2.5 * x[1] - 2.0 * x[2],
    ];
    (f, g)
}

#[test]
fn a_quadratic_field_and_its_gradient_are_reproduced_exactly() {
    let x = straight(&vertices());
    let f: Vec<f64> = x.iter().map(|p| quadratic(p).0).collect();
    for l in RULE_14.points.iter().chain(RULE_4.points) {
        let n = shape(l);
        let p: [f64; 3] = std::array::from_fn(|r| (0..10).map(|a| n[a] * x[a][r]).sum());
        let (exact, grad) = quadratic(&p);
        assert!(((0..10).map(|a| n[a] * f[a]).sum::<f64>() - exact).abs() < 1e-13);
        let (g, _) = gradients_at(&x, l).unwrap();
        for r in 0..3 {
            assert!(((0..10).map(|a| g[a][r] * f[a]).sum::<f64>() - grad[r]).abs() < 1e-12);
        }
    }
}

fn materials() -> Vec<Elasticity> {
    crate::fem::test_support::tissues()
}

/// A curved element: the straight one with every mid-edge node moved off its midpoint.
fn curved() -> [[f64; 3]; 10] {
    let mut x = straight(&vertices());
    for (k, p) in x.iter_mut().skip(4).enumerate() {
        p[0] += 0.03 * (k as f64 - 2.5);
        p[1] -= 0.02 * ((k % 3) as f64);
        p[2] += 0.015;
    }
    x
}

fn rigid_modes(x: &[[f64; 3]; 10]) -> Vec<[f64; 30]> {
    let mut out = Vec::new();
    for c in 0..3 {
        out.push(std::array::from_fn(|i| if i % 3 == c { 1.0 } else { 0.0 }));
    }
    for axis in 0..3 {
        // u = e_axis x x
        out.push(std::array::from_fn(|i| {
            let (a, c) = (i / 3, i % 3);
            let w = [
                (axis == 0) as u8 as f64,
                (axis == 1) as u8 as f64,
                (axis == 2) as u8 as f64,
            ];
            let p = x[a];
            [
                w[1] * p[2] - w[2] * p[1],
                w[2] * p[0] - w[0] * p[2],
                w[0] * p[1] - w[1] * p[0],
            ][c]
        }));
    }
    out
}

/// The rank of a symmetric matrix by Gaussian elimination with complete pivoting, a pivot
/// counting when above `tol` times the largest entry.
fn rank(k: &[[f64; 30]; 30], tol: f64) -> usize {
    let mut a = *k;
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut r = 0;
    let mut rows: Vec<usize> = (0..30).collect();
    let mut cols: Vec<usize> = (0..30).collect();
    while r < 30 {
        let (mut bi, mut bj, mut best) = (r, r, 0.0);
        for i in r..30 {
            for j in r..30 {
                let v = a[rows[i]][cols[j]].abs();
                if v > best {
                    (bi, bj, best) = (i, j, v);
                }
            }
        }
        if best <= tol * scale {
            break;
        }
        rows.swap(r, bi);
        cols.swap(r, bj);
        let (pr, pc) = (rows[r], cols[r]);
        for &i in &rows[r + 1..] {
            let f = a[i][pc] / a[pr][pc];
            for &j in &cols[r..] {
                a[i][j] -= f * a[pr][j];
            }
        }
        r += 1;
    }
    r
}

#[test]
fn the_stiffness_is_symmetric_with_the_six_rigid_modes_as_its_only_zero_energy_modes() {
    for x in [straight(&vertices()), curved()] {
        for d in materials() {
            let k = stiffness(&x, &d).unwrap();
            let scale = k.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            for i in 0..30 {
                for j in 0..30 {
                    assert!((k[i][j] - k[j][i]).abs() < 1e-12 * scale);
                }
            }
            for u in rigid_modes(&x) {
                for row in k.iter() {
                    let f: f64 = row.iter().zip(u.iter()).map(|(a, b)| a * b).sum();
                    assert!(f.abs() < 1e-10 * scale, "rigid mode loads the element: {f}");
                }
            }
            assert_eq!(rank(&k, 1e-10), 24, "30 DOFs less the 6 rigid modes");
        }
    }
}

#[test]
fn a_constant_strain_stores_its_exact_energy() {
    let v = vertices();
    let x = straight(&v);
    let eps = [1e-3, -2e-3, 0.5e-3, 1.5e-3, -0.7e-3, 0.9e-3]; // Voigt, engineering shears
                                                              // u = E x with E symmetric: E = [[e_xx, g_xy/2, g_xz/2], [., e_yy, g_yz/2], [., ., e_zz]]
    let e = [
        [eps[0], eps[5] / 2.0, eps[4] / 2.0],
        [eps[5] / 2.0, eps[1], eps[3] / 2.0],
        [eps[4] / 2.0, eps[3] / 2.0, eps[2]],
    ];
    let u: [f64; 30] = std::array::from_fn(|i| (0..3).map(|c| e[i % 3][c] * x[i / 3][c]).sum());
    for d in materials() {
        let k = stiffness(&x, &d).unwrap();
        let energy: f64 = (0..30)
            .map(|i| u[i] * (0..30).map(|j| k[i][j] * u[j]).sum::<f64>())
            .sum();
        let exact: f64 = volume(&v)
            * (0..6)
                .map(|s| eps[s] * (0..6).map(|t| d[s][t] * eps[t]).sum::<f64>())
                .sum::<f64>();
        assert!(
            (energy - exact).abs() < 1e-12 * exact,
            "{energy} vs {exact}"
        );
    }
}

#[test]
fn the_mass_is_the_closed_form_and_its_lumping_is_positive() {
    let v = vertices();
    let x = straight(&v);
    let (rho, vol) = (1070.0, volume(&v));
    let m = mass(&x, rho).unwrap();
    // int N_a N_b as barycentric monomials: N_i = 2 L_i^2 - L_i, N_ij = 4 L_i L_j
    let poly = |a: usize| -> Vec<(f64, [u32; 4])> {
        let mut p = [0u32; 4];
        if a < 4 {
            let mut q = p;
            p[a] = 2;
            q[a] = 1;
            vec![(2.0, p), (-1.0, q)]
        } else {
            let [i, j] = EDGES[a - 4];
            p[i] = 1;
            p[j] = 1;
            vec![(4.0, p)]
        }
    };
    for (a, row) in m.iter().enumerate() {
        for (b, mab) in row.iter().enumerate() {
            let mut exact = 0.0;
            for (ca, pa) in poly(a) {
                for (cb, pb) in poly(b) {
                    exact += ca * cb * barycentric_integral(std::array::from_fn(|k| pa[k] + pb[k]));
                }
            }
            exact *= rho * vol;
            assert!(
                (mab - exact).abs() < 1e-12 * rho * vol,
                "M[{a}][{b}] = {mab} vs {exact}"
            );
        }
    }
    // row sums: -rho V / 20 at a vertex, rho V / 5 at a mid-edge node; the total rho V
    for (a, row) in m.iter().enumerate() {
        let s: f64 = row.iter().sum();
        let expected = if a < 4 {
            -rho * vol / 20.0
        } else {
            rho * vol / 5.0
        };
        assert!((s - expected).abs() < 1e-12 * rho * vol);
    }
    for x in [x, curved()] {
        let total: f64 = mass(&x, rho).unwrap().iter().flatten().sum();
        let lumped = lumped_mass(&x, rho).unwrap();
        assert!(lumped.iter().all(|m| *m > 0.0));
        assert!((lumped.iter().sum::<f64>() - total).abs() < 1e-12 * total);
    }
}

#[test]
fn an_inverted_element_is_refused_at_its_first_point() {
    let mut v = vertices();
    v.swap(1, 2);
    let x = straight(&v);
    let d = materials()[0];
    assert_eq!(stiffness(&x, &d).unwrap_err(), Inverted { point: 0 });
    assert_eq!(mass(&x, 1.0).unwrap_err(), Inverted { point: 0 });
}

#[test]
fn the_columns_are_the_element_matrices_columns() {
    for x in [straight(&vertices()), curved()] {
        for d in materials() {
            let k = stiffness(&x, &d).unwrap();
            let m = mass(&x, 2.0).unwrap();
            for a in 0..10 {
                let col = stiffness_column(&x, &d, a).unwrap();
                let mc = mass_column(&x, 2.0, a).unwrap();
                for b in 0..10 {
                    for r in 0..3 {
                        for c in 0..3 {
                            let (got, want) = (col[b][r][c], k[3 * b + r][3 * a + c]);
                            assert!(
                                (got - want).abs() <= 1e-12 * want.abs().max(1.0),
                                "{got} vs {want}"
                            );
                        }
                    }
                    assert!((mc[b] - m[b][a]).abs() <= 1e-14 * m[a][a].abs());
                }
            }
        }
    }
}
