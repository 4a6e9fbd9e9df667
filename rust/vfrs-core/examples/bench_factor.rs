//! Numeric factorization and solve times of [`vfrs_core::Cholesky`] against faer's own numeric
//! supernodal LL^T on the same symbolic structure (same ordering, supernodal forced).
//!
//! Matrices: the M5 fold blocks written as binary CSC files (little-endian u64 n, u64 nnz,
//! u64 col_ptr[n + 1], u64 row_idx[nnz], f64 values[nnz]; both triangles stored) in the
//! directory `VFRS_M5_MATS` (default `/work/m5_mats`; missing files are skipped), and a 3-D
//! grid Laplacian (7-point stencil plus a shift), 46^3 = 97,336 DOFs.
//!
//! `cargo run --release --example bench_factor [-- NAME_SUBSTRING...]`. Times are the minimum
//! over repetitions (`BENCH_REPS`, default 5; 3 for the grid), faer and ours interleaved so
//! that load from other processes hits both alike. "1t": faer `Par::Seq` and ours with
//! `parallel: false`; "all": faer `Par::rayon(0)` and ours with `parallel: true`, on the
//! global rayon pool (`RAYON_NUM_THREADS` threads).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Par, Side};
use std::time::Instant;
use vfrs_core::{Cholesky, CholeskyParams, Ordering};

struct Csc {
    name: String,
    n: usize,
    cp: Vec<usize>,
    ri: Vec<usize>,
    v: Vec<f64>,
}

/// n, column pointers, row indices, values.
type Raw = (usize, Vec<usize>, Vec<usize>, Vec<f64>);

fn read_csc(path: &std::path::Path) -> Option<Raw> {
    let b = std::fs::read(path).ok()?;
    let u = |k: usize| -> Option<u64> {
        Some(u64::from_le_bytes(
            b.get(8 * k..8 * k + 8)?.try_into().ok()?,
        ))
    };
    let n = u(0)? as usize;
    let nnz = u(1)? as usize;
    let cp = (0..=n)
        .map(|k| u(2 + k).map(|x| x as usize))
        .collect::<Option<Vec<_>>>()?;
    let ri = (0..nnz)
        .map(|k| u(3 + n + k).map(|x| x as usize))
        .collect::<Option<Vec<_>>>()?;
    let v = (0..nnz)
        .map(|k| u(3 + n + nnz + k).map(f64::from_bits))
        .collect::<Option<Vec<_>>>()?;
    Some((n, cp, ri, v))
}

/// 7-point Laplacian on a k^3 grid plus a shift (6.5 on the diagonal, -1 off it): SPD.
fn grid(k: usize) -> Raw {
    let n = k * k * k;
    let id = |x: usize, y: usize, z: usize| x + k * (y + k * z);
    let (mut cp, mut ri, mut v) = (vec![0], vec![], vec![]);
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

/// The ordering `Ordering::Auto` picks (AMD below 3000 DOFs, else the smaller factor of ND
/// and AMD), as an explicit permutation.
fn auto_order(m: &Csc) -> Vec<usize> {
    if m.n < 3000 {
        let pattern = SymbolicSparseColMatRef::new_checked(m.n, m.n, &m.cp, None, &m.ri);
        let s = factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .expect("symbolic");
        s.perm().expect("amd permutes").arrays().0.to_vec()
    } else {
        let ((nd, nd_nnz), (amd, amd_nnz)) =
            vfrs_core::linalg::ordering::nested_dissection_and_amd(m.n, &m.cp, &m.ri);
        if nd_nnz < amd_nnz {
            nd
        } else {
            amd
        }
    }
}

fn faer_symbolic(m: &Csc, order: &[usize]) -> SymbolicCholesky<usize> {
    let mut inv = vec![0; m.n];
    for (k, &i) in order.iter().enumerate() {
        inv[i] = k;
    }
    let pattern = SymbolicSparseColMatRef::new_checked(m.n, m.n, &m.cp, None, &m.ri);
    factorize_symbolic_cholesky(
        pattern,
        Side::Lower,
        SymmetricOrdering::Custom(PermRef::new_checked(order, &inv, m.n)),
        CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold(f64::NEG_INFINITY),
            ..Default::default()
        },
    )
    .expect("symbolic")
}

fn min_time(reps: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let filters: Vec<String> = std::env::args().skip(1).collect();
    let reps: usize = std::env::var("BENCH_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let mats = load_matrices(&filters);
    println!(
        "threads (all): {}; times in ms, minimum of {reps} runs (3 for the grid)",
        rayon::current_num_threads()
    );
    println!(
        "{:<20} {:>7} {:>11} | {:>9} {:>9} {:>6} | {:>9} {:>9} {:>6} | {:>8}",
        "factor",
        "n",
        "nnz(L)",
        "faer 1t",
        "ours 1t",
        "ratio",
        "faer all",
        "ours all",
        "ratio",
        "rel diff"
    );
    let mut solve_rows = vec![];
    let mut sparse_rows = vec![];
    for m in &mats {
        let (row, sparse) = bench_matrix(m, reps);
        solve_rows.push((m.name.clone(), row));
        if let Some(sparse) = sparse {
            sparse_rows.push((m.name.clone(), sparse));
        }
    }
    println!();
    println!("solve, ms per right-hand side (ours / faer's solve on faer's factor; both 1 thread)");
    for (name, row) in solve_rows {
        let cells: Vec<String> = row
            .iter()
            .map(|(k, o, f)| format!("{k:>2}: {:>7.3} /{:>7.3}", o * 1e3, f * 1e3))
            .collect();
        println!("{name:<20} {}", cells.join(" | "));
    }
    println!();
    println!(
        "unit columns e_j at 64 boundary-like DOFs (fewest stored entries), ms per column: \
         solve_in_place / solve_sparse_rhs_in_place"
    );
    for (name, (one, eight)) in sparse_rows {
        println!(
            "{name:<20} one at a time: {:>7.3} / {:>7.3} ({:.2}) | 8 at a time: {:>7.3} / {:>7.3} ({:.2})",
            one.0 * 1e3,
            one.1 * 1e3,
            one.1 / one.0,
            eight.0 * 1e3,
            eight.1 * 1e3,
            eight.1 / eight.0
        );
    }
}

/// The matrices whose names contain one of `filters` (all if none): the M5 blocks found in
/// `VFRS_M5_MATS` and the grid.
fn load_matrices(filters: &[String]) -> Vec<Csc> {
    let dir = std::env::var("VFRS_M5_MATS").unwrap_or_else(|_| "/work/m5_mats".into());
    let mut mats = vec![];
    for name in [
        "keff_coarse_block0",
        "keff_medium_block0",
        "keff_fine_block0",
        "mass_coarse_block0",
        "mass_medium_block0",
        "mass_fine_block0",
        "grid_46",
    ] {
        if !filters.is_empty() && !filters.iter().any(|f| name.contains(f.as_str())) {
            continue;
        }
        let m = if name == "grid_46" {
            Some(grid(46))
        } else {
            read_csc(&std::path::Path::new(&dir).join(format!("{name}.bin")))
        };
        match m {
            Some((n, cp, ri, v)) => mats.push(Csc {
                name: name.into(),
                n,
                cp,
                ri,
                v,
            }),
            None => eprintln!("skipping {name}: not readable"),
        }
    }
    mats
}

/// Right-hand sides, then seconds per right-hand side: ours, faer's.
type SolveTime = (usize, f64, f64);
/// Seconds per unit column, (dense, sparse) one at a time and (dense, sparse) 8 at a time.
type UnitColumnTimes = ((f64, f64), (f64, f64));

/// Our factorization of `m` in the ordering `order`.
fn ours(m: &Csc, order: &[usize], parallel: bool) -> Cholesky {
    Cholesky::new(
        m.n,
        &m.cp,
        &m.ri,
        &m.v,
        CholeskyParams {
            ordering: Ordering::Custom(order.to_vec()),
            parallel,
            check_symmetry: false,
        },
    )
    .expect("factor")
}

/// One matrix: prints its factorization times and agreement with faer; returns its solve
/// times per right-hand side and, for a `keff` block, the unit-column times.
fn bench_matrix(m: &Csc, reps: usize) -> (Vec<SolveTime>, Option<UnitColumnTimes>) {
    let reps = if m.name.starts_with("grid") {
        3.min(reps)
    } else {
        reps
    };
    let order = auto_order(m);
    let sym = faer_symbolic(m, &order);
    let a = SparseColMatRef::new(
        SymbolicSparseColMatRef::new_checked(m.n, m.n, &m.cp, None, &m.ri),
        &m.v,
    );
    let mut lv = vec![0.0; sym.len_val()];
    let mut faer_time = |par: Par| {
        let mut mem =
            MemBuffer::new(sym.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
        min_time(reps, || {
            sym.factorize_numeric_llt(
                &mut lv,
                a,
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .expect("faer factor");
        })
    };
    let mut c1 = ours(m, &order, false);
    let mut call = ours(m, &order, true);
    let f1 = faer_time(Par::Seq);
    let o1 = min_time(reps, || c1.refactor(&m.v).expect("refactor"));
    let fa = faer_time(Par::rayon(0));
    let oa = min_time(reps, || call.refactor(&m.v).expect("refactor"));
    // Agreement of one solve with faer's factor (faer's solve on faer's L).
    let b: Vec<f64> = (0..m.n).map(|i| ((i * 7919) % 23) as f64 - 11.0).collect();
    let mut x = b.clone();
    c1.solve_in_place(&mut x, 1).expect("solve");
    let mut y = b.clone();
    let llt = faer::sparse::linalg::cholesky::LltRef::new(&sym, &lv);
    let mut smem = MemBuffer::new(sym.solve_in_place_scratch::<f64>(1, Par::Seq));
    llt.solve_in_place_with_conj(
        faer::Conj::No,
        faer::MatMut::from_column_major_slice_mut(&mut y, m.n, 1),
        Par::Seq,
        MemStack::new(&mut smem),
    );
    let nx = x.iter().map(|t| t * t).sum::<f64>().sqrt();
    let d = x
        .iter()
        .zip(&y)
        .map(|(p, q)| (p - q).powi(2))
        .sum::<f64>()
        .sqrt();
    println!(
        "{:<20} {:>7} {:>11} | {:>9.2} {:>9.2} {:>6.2} | {:>9.2} {:>9.2} {:>6.2} | {:>8.1e}",
        m.name,
        m.n,
        c1.nnz_factor_lower(),
        f1 * 1e3,
        o1 * 1e3,
        o1 / f1,
        fa * 1e3,
        oa * 1e3,
        oa / fa,
        d / nx
    );
    let row = solve_times(m, &mut c1, &sym, &llt, reps);
    let sparse = m
        .name
        .starts_with("keff")
        .then(|| sparse_unit_columns(m, &mut c1, reps));
    (row, sparse)
}

/// Solves: time per right-hand side for 1 to 64 of them, ours (`c1`) and faer's solve on
/// faer's factor `llt`.
fn solve_times(
    m: &Csc,
    c1: &mut Cholesky,
    sym: &SymbolicCholesky<usize>,
    llt: &faer::sparse::linalg::cholesky::LltRef<'_, usize, f64>,
    reps: usize,
) -> Vec<SolveTime> {
    let mut row = vec![];
    for k in [1usize, 2, 8, 32, 64] {
        let bk: Vec<f64> = (0..m.n * k)
            .map(|i| ((i * 7919) % 23) as f64 - 11.0)
            .collect();
        let mut xk = bk.clone();
        c1.solve_in_place(&mut xk, k).expect("solve");
        let sreps = (reps * 64 / k).clamp(reps, 40);
        let t_ours = min_time(sreps, || {
            xk.copy_from_slice(&bk);
            c1.solve_in_place(&mut xk, k).expect("solve");
        });
        let mut smem = MemBuffer::new(sym.solve_in_place_scratch::<f64>(k, Par::Seq));
        let t_faer = min_time(sreps, || {
            xk.copy_from_slice(&bk);
            llt.solve_in_place_with_conj(
                faer::Conj::No,
                faer::MatMut::from_column_major_slice_mut(&mut xk, m.n, k),
                Par::Seq,
                MemStack::new(&mut smem),
            );
        });
        row.push((k, t_ours / k as f64, t_faer / k as f64));
    }
    row
}

/// Times per column of unit right-hand sides at 64 DOFs with the fewest stored entries in
/// their column (on a tetrahedral mesh, mostly surface nodes: they have fewer neighbours),
/// solved densely and as sparse right-hand sides, one at a time and 8 at a time. Returns
/// ((dense, sparse) one at a time, (dense, sparse) 8 at a time), seconds per column.
fn sparse_unit_columns(m: &Csc, c: &mut Cholesky, reps: usize) -> UnitColumnTimes {
    let n = m.n;
    let mut by_degree: Vec<usize> = (0..n).collect();
    by_degree.sort_by_key(|&j| (m.cp[j + 1] - m.cp[j], j));
    let mut dofs: Vec<usize> = by_degree[..n / 4].to_vec();
    dofs.sort_unstable();
    let dofs: Vec<usize> = (0..64).map(|t| dofs[t * dofs.len() / 64]).collect();
    let mut x = vec![0.0; 8 * n];
    let mut time = |k: usize, sparse: bool, c: &mut Cholesky| {
        min_time(reps, || {
            for group in dofs.chunks(k) {
                let x = &mut x[..k * n];
                x.fill(0.0);
                for (t, &j) in group.iter().enumerate() {
                    x[t * n + j] = 1.0;
                }
                if sparse {
                    c.solve_sparse_rhs_in_place(x, k, group)
                        .expect("sparse solve");
                } else {
                    c.solve_in_place(x, k).expect("solve");
                }
            }
        }) / dofs.len() as f64
    };
    let d1 = time(1, false, c);
    let s1 = time(1, true, c);
    let d8 = time(8, false, c);
    let s8 = time(8, true, c);
    ((d1, s1), (d8, s8))
}
