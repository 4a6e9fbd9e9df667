//! The contact problem of one detection round as a linear complementarity problem (LCP),
//! solved with a termination guarantee, in plain sequential arithmetic.
//!
//! Every contact method reduces, in the space of its `m` pairs, to
//!
//! ```text
//! find lam >= 0 with  y = A lam + q >= 0,  lam . y = 0
//! ```
//!
//! with `A` symmetric positive definite (`W + eps I` for Lagrange multipliers, `W +
//! diag(1/kappa)` for a penalty; `W` the Delassus operator). [`solve`] does block principal
//! pivoting (Judice & Pires 1994; Kim & Park 2011): guess the loaded set F, solve
//! `A_FF lam_F = -q_F`, exchange every infeasible index at once; when the count of infeasible
//! indices has not fallen for `backup_after` iterations, only the last one changes (Murty's
//! rule), which terminates for any P-matrix.
//!
//! Why here and not in numpy/LAPACK: the systems are small (a median of 17 pairs on the
//! medium M5 mesh, at most about a hundred) and solved several times a step, so the Python
//! overhead was most of their cost; and OpenBLAS picks its kernels by CPU, which made every
//! contact history depend on the machine in its last digits, which contact then amplifies.
//! Here every sum runs in index order without fused multiply-adds: the same bits on every
//! machine for the same input.

use crate::error::SolverError;
use crate::linalg::dense::{cholesky, cholesky_solve, lu_solve, symmetric_eigenvalues};

/// What one solve did.
#[derive(Debug, Clone, PartialEq)]
pub struct LcpInfo {
    /// Linear systems solved (block-pivoting iterations).
    pub iterations: usize,
    /// Single-index exchanges by the backup rule.
    pub pivots: usize,
    /// False when `max_iterations` ran out before the loaded set settled.
    pub converged: bool,
    /// 2-norm condition number of `A` on the final loaded set (1 when it is empty).
    pub condition: f64,
    /// The largest violation of `lam >= 0`, `y >= 0` and `lam y = 0`, in `y`'s units.
    pub residual: f64,
}

/// How the LCPs are solved. [`lagrange`] and [`penalty`] read what applies to them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LcpParams {
    /// Bound on the block-pivoting iterations (running out is reported in
    /// [`LcpInfo::converged`], never hidden).
    pub max_iterations: usize,
    /// Iterations without fewer infeasible indices before Murty's single-index rule.
    pub backup_after: usize,
    /// [`lagrange`] only: `eps = regularization x mean(|diag W|)` is added to W's diagonal.
    pub regularization: f64,
}

impl Default for LcpParams {
    /// 200 iterations, Murty's rule after 3 without progress, regularization 1e-12.
    fn default() -> Self {
        Self {
            max_iterations: 200,
            backup_after: 3,
            regularization: 1e-12,
        }
    }
}

fn bad(reason: String) -> SolverError {
    SolverError::Dense { reason }
}

fn check_system(a: &[f64], q: &[f64], name: &str) -> Result<usize, SolverError> {
    let m = q.len();
    if a.len() != m * m {
        return Err(bad(format!(
            "{name} has {} entries for {m} pairs (expected {m} x {m})",
            a.len()
        )));
    }
    if let Some(k) = a.iter().position(|v| !v.is_finite()) {
        return Err(bad(format!(
            "{name}[{}, {}] = {} is not finite",
            k / m,
            k % m,
            a[k]
        )));
    }
    if let Some(k) = q.iter().position(|v| !v.is_finite()) {
        return Err(bad(format!("gap {k} = {} is not finite", q[k])));
    }
    Ok(m)
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |acc: f64, &x| acc.max(x.abs()))
}

/// `y = A x + q` over the columns `cols` of `A` (the others have `x = 0`), sums in order.
fn residual_on(a: &[f64], m: usize, x: &[f64], cols: &[usize], q: &[f64], y: &mut [f64]) {
    for i in 0..m {
        let row = &a[i * m..(i + 1) * m];
        let mut s = 0.0;
        for &j in cols {
            s += row[j] * x[j];
        }
        y[i] = s + q[i];
    }
}

/// 2-norm condition number of the symmetric `a[idx, idx]`: largest over smallest |eigenvalue|
/// (infinite if singular, 1 if `idx` is empty).
fn condition(a: &[f64], m: usize, idx: &[usize]) -> f64 {
    let k = idx.len();
    if k == 0 {
        return 1.0;
    }
    let mut s = vec![0.0; k * k];
    for (r, &i) in idx.iter().enumerate() {
        for (c, &j) in idx.iter().enumerate() {
            s[r * k + c] = a[i * m + j];
        }
    }
    let w = symmetric_eigenvalues(&mut s, k);
    let lo = w.iter().fold(f64::INFINITY, |acc, x| acc.min(x.abs()));
    let hi = w.iter().fold(0.0, |acc: f64, x| acc.max(x.abs()));
    if lo > 0.0 {
        hi / lo
    } else {
        f64::INFINITY
    }
}

/// The sub-matrix `a[idx, idx]` into `out` (row-major `k x k`).
fn gather(a: &[f64], m: usize, idx: &[usize], out: &mut Vec<f64>) {
    let k = idx.len();
    out.clear();
    out.reserve(k * k);
    for &i in idx {
        for &j in idx {
            out.push(a[i * m + j]);
        }
    }
}

/// `lam` with `lam[idx] = A[idx, idx]^-1 (-q[idx])` and zeros elsewhere: Cholesky, LU if
/// round-off made `A[idx, idx]` indefinite. Err if it is singular.
fn solve_on(
    a: &[f64],
    m: usize,
    q: &[f64],
    idx: &[usize],
    sub: &mut Vec<f64>,
    lam: &mut [f64],
) -> Result<(), SolverError> {
    lam.fill(0.0);
    if idx.is_empty() {
        return Ok(());
    }
    let k = idx.len();
    let mut b: Vec<f64> = idx.iter().map(|&i| -q[i]).collect();
    gather(a, m, idx, sub);
    if cholesky(sub, k) {
        cholesky_solve(sub, k, &mut b);
    } else {
        gather(a, m, idx, sub);
        if !lu_solve(sub, k, &mut b) {
            return Err(bad(format!(
                "the contact operator is singular on {k} loaded pairs (pairs {:?}...)",
                &idx[..k.min(8)]
            )));
        }
    }
    for (&i, &v) in idx.iter().zip(&b) {
        lam[i] = v;
    }
    Ok(())
}

/// `lam >= 0, y = A lam + q >= 0, lam . y = 0` for the symmetric positive definite `m x m`
/// row-major `a` (see the module documentation).
///
/// `start`: a guess of the loaded set (default: the pairs with `q < 0`); `params`: the
/// iteration bound and when Murty's rule takes over ([`LcpParams`]).
/// Returns `lam` (clipped at 0) and what the solve did; `Err` for non-finite input or an
/// operator singular on a loaded set.
pub fn solve(
    a: &[f64],
    q: &[f64],
    start: Option<&[bool]>,
    params: &LcpParams,
) -> Result<(Vec<f64>, LcpInfo), SolverError> {
    let m = check_system(a, q, "A")?;
    let mut info = LcpInfo {
        iterations: 0,
        pivots: 0,
        converged: true,
        condition: 1.0,
        residual: 0.0,
    };
    if m == 0 {
        return Ok((Vec::new(), info));
    }
    let mut f = start_set(q, start)?;
    let scale = max_abs(q);
    let tol = 1e-13 * if scale == 0.0 { 1.0 } else { scale };
    let mut best = m + 1;
    let mut budget = params.backup_after;
    let mut lam = vec![0.0; m];
    let mut y = vec![0.0; m];
    let mut sub = Vec::new();
    let mut idx: Vec<usize> = Vec::with_capacity(m);
    let mut bad_idx: Vec<usize> = Vec::with_capacity(m);
    info.converged = false;
    for it in 1..=params.max_iterations {
        info.iterations = it;
        idx.clear();
        idx.extend((0..m).filter(|&i| f[i]));
        solve_on(a, m, q, &idx, &mut sub, &mut lam)?;
        residual_on(a, m, &lam, &idx, q, &mut y);
        for &i in &idx {
            y[i] = 0.0;
        }
        // A loaded pair pulls (lam < 0, measured as the gap it would open: A's diagonal
        // times lam) or a free pair penetrates (y < 0).
        bad_idx.clear();
        bad_idx.extend((0..m).filter(|&i| {
            if f[i] {
                lam[i] * a[i * m + i] < -tol
            } else {
                y[i] < -tol
            }
        }));
        if bad_idx.is_empty() {
            info.converged = true;
            break;
        }
        if bad_idx.len() < best {
            best = bad_idx.len();
            budget = params.backup_after;
            for &i in &bad_idx {
                f[i] = !f[i];
            }
        } else if budget > 0 {
            budget -= 1;
            for &i in &bad_idx {
                f[i] = !f[i];
            }
        } else {
            info.pivots += 1;
            let i = bad_idx[bad_idx.len() - 1];
            f[i] = !f[i];
        }
    }
    finish(a, m, q, &f, &mut lam, &mut info);
    Ok((lam, info))
}

/// The first loaded set: `start`, or the pairs with `q < 0`.
fn start_set(q: &[f64], start: Option<&[bool]>) -> Result<Vec<bool>, SolverError> {
    let m = q.len();
    Ok(match start {
        Some(s) if s.len() == m => s.to_vec(),
        Some(s) => {
            return Err(bad(format!(
                "start guess has {} entries for {m} pairs",
                s.len()
            )))
        }
        None => q.iter().map(|&v| v < 0.0).collect(),
    })
}

/// The end of [`solve`]: clips `lam` at 0 and reports the condition number of `A` on the
/// final loaded set `f` and the largest violation of the complementarity conditions.
fn finish(a: &[f64], m: usize, q: &[f64], f: &[bool], lam: &mut [f64], info: &mut LcpInfo) {
    for v in lam.iter_mut() {
        *v = v.max(0.0);
    }
    let idx: Vec<usize> = (0..m).filter(|&i| f[i]).collect();
    info.condition = condition(a, m, &idx);
    let all: Vec<usize> = (0..m).collect();
    let mut y = vec![0.0; m];
    residual_on(a, m, lam, &all, q, &mut y);
    let y_min = y.iter().fold(f64::INFINITY, |acc, &v| acc.min(v));
    let lam_max = max_abs(lam);
    let comp = lam
        .iter()
        .zip(&y)
        .fold(0.0, |acc: f64, (&l, &v)| acc.max((l * v).abs()));
    info.residual = 0.0f64
        .max(-y_min)
        .max(comp / if lam_max == 0.0 { 1.0 } else { lam_max });
}

/// Exact contact (Lagrange multipliers) on the Delassus operator `w` (`m x m`, symmetric
/// positive semi-definite) and the gaps `g0`: the LCP with `A = W + eps I`, `eps =
/// regularization x mean(|diag W|)` (a unique solution when `W` is singular, as two-pass
/// detection makes it), then two steps of iterative refinement towards `W` itself on the
/// loaded set, kept only if every sign stays right.
pub fn lagrange(
    w: &[f64],
    g0: &[f64],
    start: Option<&[bool]>,
    params: &LcpParams,
) -> Result<(Vec<f64>, LcpInfo), SolverError> {
    let m = check_system(w, g0, "W")?;
    if m == 0 {
        return solve(w, g0, start, params);
    }
    let mean_diag = (0..m).map(|i| w[i * m + i].abs()).sum::<f64>() / m as f64;
    let eps = params.regularization * if mean_diag == 0.0 { 1.0 } else { mean_diag };
    let mut a = w.to_vec();
    for i in 0..m {
        a[i * m + i] += eps;
    }
    let (mut lam, info) = solve(&a, g0, start, params)?;
    let idx: Vec<usize> = (0..m).filter(|&i| lam[i] > 0.0).collect();
    if info.converged && !idx.is_empty() {
        let k = idx.len();
        let mut l = Vec::new();
        gather(&a, m, &idx, &mut l);
        if cholesky(&mut l, k) {
            let mut trial = lam.clone();
            let mut g = vec![0.0; m];
            let all: Vec<usize> = (0..m).collect();
            for _ in 0..2 {
                residual_on(w, m, &trial, &all, g0, &mut g);
                let mut r: Vec<f64> = idx.iter().map(|&i| g[i]).collect();
                cholesky_solve(&l, k, &mut r);
                for (&i, &d) in idx.iter().zip(&r) {
                    trial[i] -= d;
                }
            }
            residual_on(w, m, &trial, &all, g0, &mut g);
            let tol = 1e-13 * max_abs(g0);
            let loaded_ok = idx.iter().all(|&i| trial[i] >= 0.0);
            let mut is_loaded = vec![false; m];
            for &i in &idx {
                is_loaded[i] = true;
            }
            let free_ok = (0..m).all(|i| is_loaded[i] || g[i] >= -tol);
            if loaded_ok && free_ok {
                lam = trial;
            }
        }
    }
    Ok((lam, info))
}

/// Penalty `lam_i = max(0, shift_i - kappa_i g_i)`, `g = g0 + W lam`: the LCP with `A = W +
/// diag(1/kappa)`, `q = g0 - shift / kappa` (penalty as regularised Lagrange). `shift`:
/// the Uzawa multipliers of an augmentation (zeros: plain penalty).
pub fn penalty(
    w: &[f64],
    g0: &[f64],
    kappa: &[f64],
    shift: Option<&[f64]>,
    start: Option<&[bool]>,
    params: &LcpParams,
) -> Result<(Vec<f64>, LcpInfo), SolverError> {
    let m = check_system(w, g0, "W")?;
    if kappa.len() != m {
        return Err(bad(format!(
            "{} penalty stiffnesses for {m} pairs",
            kappa.len()
        )));
    }
    if let Some(k) = kappa
        .iter()
        .position(|&k| k.is_nan() || k <= 0.0 || !k.is_finite())
    {
        return Err(bad(format!(
            "penalty stiffness {k} = {} must be positive and finite",
            kappa[k]
        )));
    }
    if let Some(s) = shift {
        if s.len() != m {
            return Err(bad(format!("{} shifts for {m} pairs", s.len())));
        }
    }
    let mut a = w.to_vec();
    let mut q = vec![0.0; m];
    for i in 0..m {
        let inv = 1.0 / kappa[i];
        a[i * m + i] += inv;
        let s = shift.map_or(0.0, |s| s[i]);
        q[i] = g0[i] - s * inv;
    }
    solve(&a, &q, start, params)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default parameters with another iteration bound.
    fn iterations(max_iterations: usize) -> LcpParams {
        LcpParams {
            max_iterations,
            ..LcpParams::default()
        }
    }

    /// A symmetric positive definite `m x m` from a fixed pseudo-random sequence.
    fn spd(m: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
        let mut next = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let b: Vec<f64> = (0..m * m).map(|_| next()).collect();
        let mut a = vec![0.0; m * m];
        for i in 0..m {
            for j in 0..m {
                a[i * m + j] = (0..m).map(|k| b[i * m + k] * b[j * m + k]).sum::<f64>() / m as f64;
            }
            a[i * m + i] += 1e-3;
        }
        let q: Vec<f64> = (0..m).map(|_| next()).collect();
        (a, q)
    }

    fn kkt(a: &[f64], q: &[f64], lam: &[f64]) -> (f64, f64) {
        let m = q.len();
        let mut worst_y: f64 = 0.0;
        let mut worst_comp: f64 = 0.0;
        for i in 0..m {
            let y: f64 = (0..m).map(|j| a[i * m + j] * lam[j]).sum::<f64>() + q[i];
            worst_y = worst_y.max(-y);
            worst_comp = worst_comp.max((lam[i] * y).abs());
        }
        (worst_y, worst_comp)
    }

    #[test]
    fn solutions_satisfy_the_complementarity_conditions() {
        for seed in 0..20 {
            let m = 1 + (seed as usize * 7) % 40;
            let (a, q) = spd(m, seed);
            let (lam, info) = solve(&a, &q, None, &iterations(200)).unwrap();
            assert!(info.converged, "seed {seed}");
            assert!(lam.iter().all(|&l| l >= 0.0));
            let (y, comp) = kkt(&a, &q, &lam);
            assert!(y < 1e-12 && comp < 1e-12, "seed {seed}: {y:e} {comp:e}");
            assert!(info.residual < 1e-12);
            assert!(info.condition >= 1.0 && info.condition.is_finite());
        }
    }

    #[test]
    fn two_by_two_closed_form() {
        // The docstring example of vfrs.enforcement.lcp.solve_lcp.
        let (lam, info) =
            solve(&[2.0, 1.0, 1.0, 2.0], &[-1.0, 1.0], None, &iterations(200)).unwrap();
        assert!((lam[0] - 0.5).abs() < 1e-15 && lam[1] == 0.0, "{lam:?}");
        assert_eq!(info.iterations, 1);
        assert_eq!(info.condition, 1.0); // one loaded pair: a 1 x 1 operator
    }

    #[test]
    fn eigenvalues_of_a_known_matrix() {
        // Tridiagonal 2, -1: eigenvalues 2 - 2 cos(k pi / (n + 1)).
        let n = 9;
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            a[i * n + i] = 2.0;
            if i + 1 < n {
                a[i * n + i + 1] = -1.0;
                a[(i + 1) * n + i] = -1.0;
            }
        }
        let mut w = symmetric_eigenvalues(&mut a, n);
        w.sort_by(|x, y| x.partial_cmp(y).unwrap());
        for (k, v) in w.iter().enumerate() {
            let exact = 2.0 - 2.0 * ((k + 1) as f64 * std::f64::consts::PI / (n + 1) as f64).cos();
            assert!((v - exact).abs() < 1e-13, "{k}: {v} vs {exact}");
        }
        // A dense one: sum = trace, product = det (via Cholesky).
        let (mut b, _) = spd(12, 3);
        let trace: f64 = (0..12).map(|i| b[i * 12 + i]).sum();
        let mut l = b.clone();
        assert!(cholesky(&mut l, 12));
        let logdet: f64 = (0..12).map(|i| 2.0 * l[i * 12 + i].ln()).sum();
        let w = symmetric_eigenvalues(&mut b, 12);
        assert!((w.iter().sum::<f64>() - trace).abs() < 1e-12 * trace);
        assert!((w.iter().map(|x| x.ln()).sum::<f64>() - logdet).abs() < 1e-9);
    }

    #[test]
    fn running_out_of_iterations_is_reported() {
        let (a, q) = spd(30, 5);
        let (_, info) = solve(&a, &q, None, &iterations(1)).unwrap();
        assert!(!info.converged);
        assert_eq!(info.iterations, 1);
    }

    #[test]
    fn lagrange_closes_the_gaps_of_loaded_pairs() {
        let (w, g0) = spd(15, 11);
        let g0: Vec<f64> = g0.iter().map(|g| g * 1e-5).collect();
        let (lam, info) = lagrange(&w, &g0, None, &LcpParams::default()).unwrap();
        assert!(info.converged);
        for i in 0..15 {
            let g: f64 = (0..15).map(|j| w[i * 15 + j] * lam[j]).sum::<f64>() + g0[i];
            assert!(g > -1e-17, "{i}: {g:e}");
            if lam[i] > 0.0 {
                assert!(g.abs() < 1e-17, "{i}: {g:e}");
            }
        }
    }

    #[test]
    fn penalty_is_the_force_law() {
        let (w, g0) = spd(10, 2);
        let kappa = vec![50.0; 10];
        let shift: Vec<f64> = (0..10).map(|i| 0.1 * i as f64).collect();
        let (lam, _) = penalty(&w, &g0, &kappa, Some(&shift), None, &iterations(200)).unwrap();
        for i in 0..10 {
            let g: f64 = (0..10).map(|j| w[i * 10 + j] * lam[j]).sum::<f64>() + g0[i];
            let law = (shift[i] - kappa[i] * g).max(0.0);
            assert!((lam[i] - law).abs() < 1e-12, "{i}: {} vs {law}", lam[i]);
        }
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        assert!(solve(&[1.0, 0.0, 0.0], &[1.0, 2.0], None, &iterations(10)).is_err());
        assert!(solve(&[f64::NAN], &[1.0], None, &iterations(10)).is_err());
        assert!(solve(&[1.0], &[f64::INFINITY], None, &iterations(10)).is_err());
        assert!(penalty(&[1.0], &[1.0], &[0.0], None, None, &iterations(10)).is_err());
        assert!(solve(&[1.0], &[-1.0], Some(&[true, false]), &iterations(10)).is_err());
        // Singular on the loaded set: an error naming it.
        let e = solve(&[0.0, 0.0, 0.0, 0.0], &[-1.0, -1.0], None, &iterations(10)).unwrap_err();
        assert!(e.to_string().contains("singular"), "{e}");
    }
}
