//! Tests of the factorization and the solves (bits across kernels, threads and batching;
//! fill of the orderings; errors).

use super::numeric;
use super::symbolic::supernodes;
use super::*;
use faer::sparse::SymbolicSparseColMatRef;
use faer::Side;

/// 3-D Laplacian-like SPD matrix on a k^3 grid (7-point stencil + shift).
fn grid(k: usize) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
    let n = k * k * k;
    let id = |x: usize, y: usize, z: usize| x + k * (y + k * z);
    let mut cp = vec![0];
    let mut ri = vec![];
    let mut v = vec![];
    for z in 0..k {
        for y in 0..k {
            for x in 0..k {
                let mut col = vec![(id(x, y, z), 6.5)];
                if x > 0 {
                    col.push((id(x - 1, y, z), -1.0));
                }
                if x + 1 < k {
                    col.push((id(x + 1, y, z), -1.0));
                }
                if y > 0 {
                    col.push((id(x, y - 1, z), -1.0));
                }
                if y + 1 < k {
                    col.push((id(x, y + 1, z), -1.0));
                }
                if z > 0 {
                    col.push((id(x, y, z - 1), -1.0));
                }
                if z + 1 < k {
                    col.push((id(x, y, z + 1), -1.0));
                }
                col.sort_by_key(|e| e.0);
                for (i, a) in col {
                    ri.push(i);
                    v.push(a);
                }
                cp.push(ri.len());
            }
        }
    }
    (n, cp, ri, v)
}

fn matvec(n: usize, cp: &[usize], ri: &[usize], v: &[f64], x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; n];
    for j in 0..n {
        for k in cp[j]..cp[j + 1] {
            y[ri[k]] += v[k] * x[j];
        }
    }
    y
}

#[test]
fn every_ordering_solves_to_round_off() {
    let (n, cp, ri, v) = grid(16);
    let b: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
    for ordering in [
        Ordering::Amd,
        Ordering::NestedDissection,
        Ordering::Identity,
        Ordering::Auto,
    ] {
        let mut f = Cholesky::new(
            n,
            &cp,
            &ri,
            &v,
            CholeskyParams {
                ordering: ordering.clone(),
                ..Default::default()
            },
        )
        .unwrap();
        let mut x = b.clone();
        f.solve_in_place(&mut x, 1).unwrap();
        let r = matvec(n, &cp, &ri, &v, &x);
        let err: f64 = r
            .iter()
            .zip(&b)
            .map(|(a, c)| (a - c).powi(2))
            .sum::<f64>()
            .sqrt();
        let nb: f64 = b.iter().map(|c| c * c).sum::<f64>().sqrt();
        assert!(err < 1e-12 * nb, "{ordering:?}: residual {err}");
    }
}

/// A 3-D elasticity-like pattern: 3 coupled DOFs per grid node, 27-point stencil, SPD.
fn grid3(k: usize) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
    let nodes = k * k * k;
    let n = 3 * nodes;
    let id = |x: usize, y: usize, z: usize| x + k * (y + k * z);
    let mut cp = vec![0];
    let mut ri = vec![];
    let mut v = vec![];
    for z in 0..k {
        for y in 0..k {
            for x in 0..k {
                let a = id(x, y, z);
                for p in 0..3 {
                    let mut col = vec![];
                    for dz in -1i64..=1 {
                        for dy in -1i64..=1 {
                            for dx in -1i64..=1 {
                                let (x2, y2, z2) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                                if [x2, y2, z2].iter().any(|&c| c < 0 || c >= k as i64) {
                                    continue;
                                }
                                let b = id(x2 as usize, y2 as usize, z2 as usize);
                                for q in 0..3 {
                                    let diag = a == b && p == q;
                                    let val = if diag {
                                        60.0
                                    } else if a == b {
                                        0.5
                                    } else {
                                        -1.0 / (1.0 + ((p + q) % 3) as f64)
                                    };
                                    col.push((3 * b + q, val));
                                }
                            }
                        }
                    }
                    col.sort_by_key(|e| e.0);
                    for (i, a) in col {
                        ri.push(i);
                        v.push(a);
                    }
                    cp.push(ri.len());
                }
            }
        }
    }
    (n, cp, ri, v)
}

fn nd() -> CholeskyParams {
    CholeskyParams {
        ordering: Ordering::NestedDissection,
        ..Default::default()
    }
}

fn rhs(n: usize, k: usize) -> Vec<f64> {
    (0..n * k)
        .map(|i| ((i * 7919) % 23) as f64 - 11.0)
        .collect()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|c| c * c).sum::<f64>().sqrt()
}

fn max_rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// faer's numeric factorization on the same symbolic structure (the reference).
fn faer_factor(f: &Cholesky, cp: &[usize], ri: &[usize], v: &[f64]) -> Vec<f64> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::sparse::SparseColMatRef;
    use faer::Par;
    let mut lv = vec![0.0; f.l_values.len()];
    let mut mem = MemBuffer::new(
        f.symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
    );
    let a = SparseColMatRef::new(
        SymbolicSparseColMatRef::new_checked(f.n, f.n, cp, None, ri),
        v,
    );
    f.symbolic
        .factorize_numeric_llt(
            &mut lv,
            a,
            Side::Lower,
            Default::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .unwrap();
    lv
}

/// The entries of L that are part of the factor (lower triangles of the diagonal blocks
/// and the rows below), in storage order.
fn lower_entries(f: &Cholesky, lv: &[f64]) -> Vec<f64> {
    let SymbolicCholeskyRaw::Supernodal(sn) = f.symbolic.raw() else {
        unreachable!()
    };
    let sn = supernodes(sn, lv);
    let mut out = vec![];
    for s in 0..sn.begin.len() {
        let w = sn.end[s] - sn.begin[s];
        let nr = w + sn.row_ptr[s + 1] - sn.row_ptr[s];
        for j in 0..w {
            out.extend_from_slice(&lv[sn.val_ptr[s] + j * nr + j..sn.val_ptr[s] + (j + 1) * nr]);
        }
    }
    out
}

/// n, column pointers, row indices, values.
type Csc = (usize, Vec<usize>, Vec<usize>, Vec<f64>);

fn grids() -> Vec<(&'static str, Csc)> {
    vec![("grid 12^3", grid(12)), ("grid3 7^3", grid3(7))]
}

#[test]
fn factor_matches_faer_on_every_ordering() {
    for (name, (n, cp, ri, v)) in grids() {
        let reverse: Vec<usize> = (0..n).rev().collect();
        for ordering in [
            Ordering::Amd,
            Ordering::NestedDissection,
            Ordering::Identity,
            Ordering::Auto,
            Ordering::Custom(reverse),
        ] {
            let params = CholeskyParams {
                ordering: ordering.clone(),
                ..Default::default()
            };
            let f = Cholesky::new(n, &cp, &ri, &v, params).unwrap();
            let reference = faer_factor(&f, &cp, &ri, &v);
            let d = max_rel_diff(
                &lower_entries(&f, &reference),
                &lower_entries(&f, &f.l_values),
            );
            assert!(
                d < 1e-12,
                "{name} {ordering:?}: L differs from faer's by {d}"
            );
        }
    }
}

#[test]
fn solves_to_round_off_for_any_number_of_rhs() {
    for (name, (n, cp, ri, v)) in grids() {
        let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
        assert!(f.nnz_factor_lower() < f.nnz_factor());
        for k in [1, 2, 3, 4, 5, 6, 7, 9, 33] {
            let b = rhs(n, k);
            let mut x = b.clone();
            f.solve_in_place(&mut x, k).unwrap();
            for j in 0..k {
                let (bj, xj) = (&b[j * n..(j + 1) * n], &x[j * n..(j + 1) * n]);
                let r = matvec(n, &cp, &ri, &v, xj);
                let res: Vec<f64> = r.iter().zip(bj).map(|(a, c)| a - c).collect();
                assert!(
                    norm(&res) < 1e-12 * norm(bj),
                    "{name}, k = {k}, column {j}: residual {}",
                    norm(&res)
                );
            }
        }
    }
}

#[test]
fn avx512_and_avx2_factors_have_the_same_bits() {
    #[cfg(target_arch = "x86_64")]
    if !std::arch::is_x86_feature_detected!("avx512f") {
        eprintln!("no AVX-512 on this CPU: only the AVX2 kernels factor here");
        return;
    }
    // Several supernode widths and row counts (tile tails of 8 and 4 lanes, split
    // products and panels on the default pool).
    let forest = block_diagonal(grid3(7), grid(13));
    for (name, (n, cp, ri, v)) in [
        ("grid3 8^3", grid3(8)),
        ("grid 15^3", grid(15)),
        ("forest", forest),
    ] {
        let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
        let wide = f.l_values.clone();
        f.wide = false;
        f.refactor(&v).unwrap();
        assert!(
            f.l_values == wide,
            "{name}: AVX-512 and AVX2 factors differ"
        );
    }
}

#[test]
fn avx512vl_and_avx2_solves_have_the_same_bits() {
    #[cfg(target_arch = "x86_64")]
    if !std::arch::is_x86_feature_detected!("avx512vl") {
        eprintln!("no AVX-512VL on this CPU: only the AVX2 solve kernels run here");
        return;
    }
    // One to nine right-hand sides (groups of four and the rest; one to eight
    // accumulators per backward pass), dense and sparse, on several supernode widths.
    let forest = block_diagonal(grid3(7), grid(13));
    for (name, (n, cp, ri, v)) in [("grid3 8^3", grid3(8)), ("forest", forest)] {
        let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
        for k in 1..=9 {
            let b = rhs(n, k);
            let rows: Vec<usize> = (0..k).map(|j| (j * 37 + 5) % n).collect();
            let mut unit = vec![0.0; n * k];
            for (j, &r) in rows.iter().enumerate() {
                unit[j * n + r] = 1.0;
            }
            let mut got = Vec::new();
            for wide in [true, false] {
                f.wide = wide;
                let (mut x, mut e) = (b.clone(), unit.clone());
                f.solve_in_place(&mut x, k).unwrap();
                f.solve_sparse_rhs_in_place(&mut e, k, &rows).unwrap();
                let bits = |v: &[f64]| v.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
                got.push((bits(&x), bits(&e)));
            }
            assert!(
                got[0] == got[1],
                "{name}, {k} right-hand sides: the solves differ"
            );
        }
    }
}

#[test]
fn portable_kernels_agree_with_avx2_and_bits_repeat() {
    let (n, cp, ri, v) = grid3(8);
    let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
    let l_fast = f.l_values.clone();
    f.refactor(&v).unwrap();
    assert!(f.l_values == l_fast, "refactor changed bits");
    f.portable = true;
    f.refactor(&v).unwrap();
    let d = max_rel_diff(&lower_entries(&f, &l_fast), &lower_entries(&f, &f.l_values));
    assert!(d < 1e-13, "portable factor differs by {d}");
    let b = rhs(n, 3);
    let mut x_portable = b.clone();
    f.solve_in_place(&mut x_portable, 3).unwrap();
    f.portable = false;
    f.refactor(&v).unwrap();
    assert!(f.l_values == l_fast);
    let mut x = b.clone();
    f.solve_in_place(&mut x, 3).unwrap();
    let d = max_rel_diff(&x, &x_portable);
    assert!(d < 1e-13, "portable solve differs by {d}");
}

/// Two matrices as the diagonal blocks of one (an elimination forest with several roots).
fn block_diagonal(
    a: (usize, Vec<usize>, Vec<usize>, Vec<f64>),
    b: (usize, Vec<usize>, Vec<usize>, Vec<f64>),
) -> (usize, Vec<usize>, Vec<usize>, Vec<f64>) {
    let (na, mut cp, mut ri, mut v) = a;
    let (nb, cpb, rib, vb) = b;
    let nnz = ri.len();
    cp.extend(cpb[1..].iter().map(|&p| p + nnz));
    ri.extend(rib.iter().map(|&i| i + na));
    v.extend(vb);
    (na + nb, cp, ri, v)
}

#[test]
fn factor_bits_do_not_depend_on_threads() {
    // The forest: its subtrees run concurrently while large supernodes split their
    // products, and a thread waiting for a split's chunks may take up another subtree.
    let forest = block_diagonal(grid3(7), block_diagonal(grid(14), grid3(6)));
    for (name, (n, cp, ri, v)) in [
        ("grid 16^3", grid(16)),
        ("grid3 8^3", grid3(8)),
        ("forest", forest),
    ] {
        let mut bits = vec![];
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let splits = numeric::SPLITS.load(std::sync::atomic::Ordering::Relaxed);
            let l = pool.install(|| {
                let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
                assert_eq!(f.plan_slots(), if threads > 1 { threads + 1 } else { 1 });
                f.refactor(&v).unwrap();
                f.l_values.clone()
            });
            // With threads, the large supernodes' products and panels were split by rows.
            if threads > 1 {
                assert!(
                    numeric::SPLITS.load(std::sync::atomic::Ordering::Relaxed) > splits,
                    "{name}"
                );
            }
            bits.push(l);
        }
        let serial = Cholesky::new(
            n,
            &cp,
            &ri,
            &v,
            CholeskyParams {
                parallel: false,
                ..nd()
            },
        )
        .unwrap();
        assert!(bits.iter().all(|l| *l == serial.l_values), "{name}");
    }
}

#[test]
fn batching_never_changes_a_columns_bits() {
    let (n, cp, ri, v) = grid3(7);
    let mut f = Cholesky::new(n, &cp, &ri, &v, nd()).unwrap();
    let b = rhs(n, 9);
    for portable in [false, true] {
        f.portable = portable;
        f.refactor(&v).unwrap();
        let alone: Vec<Vec<f64>> = (0..9)
            .map(|j| {
                let mut x = b[j * n..(j + 1) * n].to_vec();
                f.solve_in_place(&mut x, 1).unwrap();
                x
            })
            .collect();
        for k in 1..=9 {
            // The columns j0, j0 + 1, ... of b, for every start that fits.
            for j0 in 0..=9 - k {
                let mut x = b[j0 * n..(j0 + k) * n].to_vec();
                f.solve_in_place(&mut x, k).unwrap();
                for t in 0..k {
                    assert!(
                        x[t * n..(t + 1) * n] == alone[j0 + t][..],
                        "portable {portable}: column {} at position {t} of {k}",
                        j0 + t
                    );
                }
            }
        }
    }
}

#[test]
fn sparse_rhs_solve_gives_the_dense_values() {
    let (n, cp, ri, v) = grid3(7);
    for ordering in [
        Ordering::NestedDissection,
        Ordering::Amd,
        Ordering::Identity,
    ] {
        let params = CholeskyParams {
            ordering,
            ..Default::default()
        };
        let mut f = Cholesky::new(n, &cp, &ri, &v, params).unwrap();
        for portable in [false, true] {
            f.portable = portable;
            // Unit columns one by one, three at once, and a few-row column pair.
            for rows in [vec![0], vec![n - 1], vec![n / 3], vec![5, 17, 400]] {
                let k = rows.len();
                let mut b = vec![0.0; n * k];
                for (j, &i) in rows.iter().enumerate() {
                    b[j * n + i] = 1.0 + j as f64;
                }
                let mut dense = b.clone();
                f.solve_in_place(&mut dense, k).unwrap();
                let mut sparse = b.clone();
                f.solve_sparse_rhs_in_place(&mut sparse, k, &rows).unwrap();
                // == treats -0.0 and 0.0 as equal: only the signs of zeros may differ.
                assert!(dense == sparse, "rows {rows:?}");
            }
            let mut b = vec![0.0; 2 * n];
            for i in [3, 9, 200] {
                b[i] = i as f64;
                b[n + i] = -(i as f64);
            }
            b[n + 11] = 2.0;
            let mut dense = b.clone();
            f.solve_in_place(&mut dense, 2).unwrap();
            let mut sparse = b.clone();
            f.solve_sparse_rhs_in_place(&mut sparse, 2, &[200, 11, 3, 9, 3])
                .unwrap();
            assert!(dense == sparse);
            // A nonzero outside the listed rows, or a row out of range.
            let mut bad = b.clone();
            assert!(matches!(
                f.solve_sparse_rhs_in_place(&mut bad, 2, &[3, 9, 200]),
                Err(SolverError::BadRhs { .. })
            ));
            assert!(f.solve_sparse_rhs_in_place(&mut bad, 2, &[n]).is_err());
            assert_eq!(bad, b);
        }
    }
}

#[test]
fn not_positive_definite_is_detected_at_the_first_bad_pivot() {
    let (n, cp, ri, v) = grid3(6);
    for parallel in [false, true] {
        let params = CholeskyParams { parallel, ..nd() };
        let mut f = Cholesky::new(n, &cp, &ri, &v, params.clone()).unwrap();
        // An indefinite shift of one diagonal entry: fails at (or after) its column.
        for target in [0, n / 2, n - 1] {
            let mut bad = v.clone();
            let k = (cp[target]..cp[target + 1])
                .find(|&k| ri[k] == target)
                .unwrap();
            bad[k] = -100.0;
            let err = f.refactor(&bad).unwrap_err();
            let SolverError::NotPositiveDefinite { row } = err else {
                panic!("{err:?}")
            };
            let (_, inv) = f.symbolic.perm().unwrap().arrays();
            assert!(row >= inv[target], "row {row} before the bad column");
            assert!(matches!(
                Cholesky::new(n, &cp, &ri, &bad, params.clone()),
                Err(SolverError::NotPositiveDefinite { row: r }) if r == row
            ));
        }
        // Singular: a zero matrix.
        let zero = vec![0.0; v.len()];
        assert!(matches!(
            f.refactor(&zero),
            Err(SolverError::NotPositiveDefinite { row: 0 })
        ));
        // And it recovers.
        f.refactor(&v).unwrap();
        let mut x = rhs(n, 1);
        f.solve_in_place(&mut x, 1).unwrap();
    }
}

#[test]
fn tiny_matrices_factor() {
    // 0 x 0, 1 x 1, a diagonal 2 x 2 and a 3 x 3 arrow.
    let mut f = Cholesky::new(0, &[0], &[], &[], CholeskyParams::default()).unwrap();
    f.solve_in_place(&mut [], 1).unwrap();
    let mut f = Cholesky::new(
        2,
        &[0, 1, 2],
        &[0, 1],
        &[4.0, 2.0],
        CholeskyParams::default(),
    )
    .unwrap();
    let mut b = [2.0, 1.0];
    f.solve_in_place(&mut b, 1).unwrap();
    assert!((b[0] - 0.5).abs() + (b[1] - 0.5).abs() < 1e-15, "{b:?}");
    let mut f = Cholesky::new(1, &[0, 1], &[0], &[4.0], CholeskyParams::default()).unwrap();
    let mut b = [2.0];
    f.solve_in_place(&mut b, 1).unwrap();
    assert_eq!(b, [0.5]);
    let (cp, ri) = ([0, 3, 5, 7], [0, 1, 2, 0, 1, 0, 2]);
    let v = [4.0, 1.0, 1.0, 1.0, 3.0, 1.0, 5.0];
    let mut f = Cholesky::new(3, &cp, &ri, &v, CholeskyParams::default()).unwrap();
    let mut x = [1.0, 2.0, 3.0];
    f.solve_in_place(&mut x, 1).unwrap();
    let r = matvec(3, &cp, &ri, &v, &x);
    assert!((r[0] - 1.0).abs() + (r[1] - 2.0).abs() + (r[2] - 3.0).abs() < 1e-14);
}

#[test]
fn nested_dissection_has_less_fill_than_amd_on_a_3d_grid() {
    let (n, cp, ri, v) = grid(24);
    let amd = Cholesky::new(
        n,
        &cp,
        &ri,
        &v,
        CholeskyParams {
            ordering: Ordering::Amd,
            ..Default::default()
        },
    )
    .unwrap();
    let nd = Cholesky::new(
        n,
        &cp,
        &ri,
        &v,
        CholeskyParams {
            ordering: Ordering::NestedDissection,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        nd.nnz_factor() < amd.nnz_factor(),
        "nd {} amd {}",
        nd.nnz_factor(),
        amd.nnz_factor()
    );
}

#[test]
fn refactor_equals_fresh_factor_and_errors_are_typed() {
    let (n, cp, ri, v) = grid(6);
    let mut f = Cholesky::new(n, &cp, &ri, &v, CholeskyParams::default()).unwrap();
    let v2: Vec<f64> = v.iter().map(|a| 2.0 * a).collect();
    f.refactor(&v2).unwrap();
    let mut g = Cholesky::new(n, &cp, &ri, &v2, CholeskyParams::default()).unwrap();
    assert!(
        f.l_values == g.l_values,
        "refactor differs from a fresh factor"
    );
    let mut x1 = vec![1.0; 2 * n];
    let mut x2 = x1.clone();
    f.solve_in_place(&mut x1, 2).unwrap();
    g.solve_in_place(&mut x2, 2).unwrap();
    assert_eq!(x1, x2);
    // Not positive definite.
    let neg: Vec<f64> = v.iter().map(|a| -a).collect();
    assert!(matches!(
        f.refactor(&neg),
        Err(SolverError::NotPositiveDefinite { .. })
    ));
    // Not symmetric.
    let mut ns = v.clone();
    ns[1] += 0.5;
    assert!(matches!(
        Cholesky::new(n, &cp, &ri, &ns, CholeskyParams::default()),
        Err(SolverError::NotSymmetric { .. })
    ));
    // Only the upper triangle stored: not symmetric (the lower entries' mirrors are zero).
    let (mut ucp, mut uri, mut uv) = (vec![0], vec![], vec![]);
    for j in 0..n {
        for k in cp[j]..cp[j + 1] {
            if ri[k] <= j {
                uri.push(ri[k]);
                uv.push(v[k]);
            }
        }
        ucp.push(uri.len());
    }
    assert!(uri.len() < ri.len());
    assert!(matches!(
        Cholesky::new(n, &ucp, &uri, &uv, CholeskyParams::default()),
        Err(SolverError::NotSymmetric { .. })
    ));
    // Wrong rhs size, wrong pattern, bad pattern.
    assert!(f.solve_in_place(&mut [0.0; 3], 1).is_err());
    assert!(f.refactor_with_pattern(&cp[..n], &ri, &v).is_err());
    assert!(Cholesky::new(
        2,
        &[0, 1, 2],
        &[0, 5],
        &[1.0, 1.0],
        CholeskyParams::default()
    )
    .is_err());
    let mut nan = v.clone();
    nan[0] = f64::NAN;
    assert!(f.refactor(&nan).is_err());
}
