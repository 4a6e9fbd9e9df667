//! Quasi-static Newton on finite-strain problems with the core's Cholesky (symbolic once,
//! numeric refactorization per iteration): rigid rotations leave no stress, and the
//! convergence is quadratic (`cargo test --test hyperelastic_newton -- --nocapture`).

#[path = "common/hyperelastic.rs"]
mod common;

use common::*;
use vfrs_core::{FiniteStrainAssembler, HyperelasticLaw};

/// Quasi-static Newton on the free DOFs with `Cholesky::refactor` on the fixed pattern.
/// `boundary(s)` gives the prescribed displacement of each fixed DOF at load fraction s.
/// Returns the converged u and, per increment, the residual norms.
fn newton_solve<L: HyperelasticLaw>(
    p: &[[f64; 3]],
    t: &[[usize; 4]],
    law: &[L],
    fixed: &[usize],
    boundary: impl Fn(f64) -> Vec<f64>,
    increments: usize,
) -> (Vec<f64>, Vec<Vec<f64>>, FiniteStrainAssembler) {
    use vfrs_core::{Cholesky, CholeskyParams, DofMap};
    let mut fs = FiniteStrainAssembler::new(p, t).unwrap();
    let n = fs.n_dofs();
    let map = DofMap::new(n, fixed).unwrap();
    let (cp, ri, src) = map
        .reduce_pattern(fs.assembler().col_ptr(), fs.assembler().row_idx())
        .unwrap();
    let free = map.free().to_vec();
    let mut u = vec![0.0; n];
    let mut f = vec![0.0; n];
    let mut k = vec![0.0; fs.nnz()];
    let mut kr = vec![0.0; src.len()];
    let mut rhs = vec![0.0; free.len()];
    let mut chol: Option<Cholesky> = None;
    let mut histories = Vec::new();
    for step in 1..=increments {
        let ub = boundary(step as f64 / increments as f64);
        for (&d, &v) in fixed.iter().zip(&ub) {
            u[d] = v;
        }
        let mut history = Vec::new();
        for _ in 0..25 {
            fs.force_and_tangent(&u, law, None, &mut f, &mut k).unwrap();
            let res = free.iter().map(|&d| f[d] * f[d]).sum::<f64>().sqrt();
            history.push(res);
            if res < 1e-10 * E {
                break;
            }
            for (x, &s) in kr.iter_mut().zip(&src) {
                *x = k[s];
            }
            match chol.as_mut() {
                Some(c) => c.refactor(&kr).unwrap(),
                None => {
                    chol = Some(
                        Cholesky::new(free.len(), &cp, &ri, &kr, CholeskyParams::default())
                            .unwrap(),
                    )
                }
            }
            for (r, &d) in rhs.iter_mut().zip(&free) {
                *r = -f[d];
            }
            chol.as_mut().unwrap().solve_in_place(&mut rhs, 1).unwrap();
            for (&d, &x) in free.iter().zip(&rhs) {
                u[d] += x;
            }
        }
        assert!(
            *history.last().unwrap() < 1e-10 * E,
            "increment {step}: Newton did not converge: {history:?}"
        );
        histories.push(history);
    }
    (u, histories, fs)
}

/// The order of convergence estimated from the last three residuals above round-off
/// (the residual's round-off floor here is about 1e-12 E).
fn convergence_order(h: &[f64]) -> f64 {
    let r: Vec<f64> = h.iter().copied().filter(|&x| x > 1e-11 * E).collect();
    if r.len() < 3 {
        return f64::NAN;
    }
    let m = r.len();
    (r[m - 1] / r[m - 2]).ln() / (r[m - 2] / r[m - 3]).ln()
}

/// The bar 1 x 1 x 3 (3^3 boxes of 6 tets) and the DOFs of its end faces (z = 0 and z = 3).
fn bar() -> (Vec<[f64; 3]>, Vec<[usize; 4]>, Vec<usize>) {
    let (p, t) = grid(3, [1.0, 1.0, 3.0]);
    let fixed: Vec<usize> = p
        .iter()
        .enumerate()
        .filter(|(_, x)| x[2] == 0.0 || x[2] == 3.0)
        .flat_map(|(i, _)| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    (p, t, fixed)
}

#[test]
fn rigid_90_degree_rotation_prescribed_on_the_boundary_leaves_no_stress_after_newton() {
    // A bar 1 x 1 x 3, both end faces rotated rigidly about the bar's axis-normal x by 90 deg
    // in 6 increments; the interior is solved for and must follow the rotation.
    let (p, t, fixed) = bar();
    let bnd = |s: f64| -> Vec<f64> {
        let r = rotation([1.0, 0.0, 0.0], s * std::f64::consts::FRAC_PI_2);
        fixed
            .iter()
            .map(|&d| {
                let x = p[d / 3];
                apply(&r, &x)[d % 3] - x[d % 3]
            })
            .collect()
    };
    for (name, law) in laws() {
        let (u, hist, fs) = newton_solve(&p, &t, &[law], &fixed, bnd, 6);
        let r = rotation([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2);
        let err = max_abs(p.iter().enumerate().flat_map(|(i, x)| {
            let y = apply(&r, x);
            [
                u[3 * i] - (y[0] - x[0]),
                u[3 * i + 1] - (y[1] - x[1]),
                u[3 * i + 2] - (y[2] - x[2]),
            ]
        }));
        let p_max = max_abs(
            (0..fs.n_elements()).flat_map(|e| fs.last_stress(e).unwrap().into_iter().flatten()),
        );
        let mut fsc = fs;
        let w = fsc.energy(&u, &[law], None).unwrap();
        let iters: Vec<usize> = hist.iter().map(|h| h.len() - 1).collect();
        eprintln!(
            "Newton rigid 90 deg, {name}, last increment residuals {:?}",
            hist.last()
                .unwrap()
                .iter()
                .map(|x| format!("{x:.2e}"))
                .collect::<Vec<_>>()
        );
        eprintln!(
            "Newton rigid 90 deg, {name}: iterations per increment {iters:?}; max|u - (R-I)X| = {err:.1e}; max|P|/E = {:.1e}; W/(E V) = {:.1e}",
            p_max / E,
            w / (E * 3.0)
        );
        assert!(
            err < 1e-10,
            "{name}: interior does not follow the rotation: {err:e}"
        );
        assert!(p_max < 1e-9 * E, "{name}: stress {p_max:e}");
        assert!(w.abs() < 1e-16 * E * 3.0, "{name}: energy {w:e}");
    }
}

#[test]
fn newton_converges_quadratically_on_a_stretched_twisted_bar() {
    // A bar clamped at z = 0; the top face stretched by 40 % and twisted by 45 deg: large,
    // non-homogeneous strain. Every law, 4 increments; the last iterations of each increment
    // must show order ~2.
    let (p, t, fixed) = bar();
    let bnd = |s: f64| -> Vec<f64> {
        let r = rotation([0.0, 0.0, 1.0], s * std::f64::consts::FRAC_PI_4);
        fixed
            .iter()
            .map(|&d| {
                let x = p[d / 3];
                if x[2] == 0.0 {
                    return 0.0;
                }
                let c = [x[0] - 0.5, x[1] - 0.5, x[2]];
                let y = apply(&r, &c);
                let y = [y[0] + 0.5, y[1] + 0.5, y[2] * (1.0 + 0.4 * s)];
                y[d % 3] - x[d % 3]
            })
            .collect()
    };
    for (name, law) in laws() {
        let (_, hist, _) = newton_solve(&p, &t, &[law], &fixed, bnd, 4);
        let orders: Vec<f64> = hist.iter().map(|h| convergence_order(h)).collect();
        let iters: Vec<usize> = hist.iter().map(|h| h.len() - 1).collect();
        eprintln!("Newton stretch+twist, {name}: iterations per increment {iters:?}; estimated order {orders:.2?}; {:?}", hist.iter().map(|h| h.iter().map(|x| format!("{x:.2e}")).collect::<Vec<_>>()).collect::<Vec<_>>());
        // Plain Newton, no line search, the boundary jumping by a quarter of the load: the
        // exponential fibres (k2 = 3, I4 up to ~2) take up to 11 iterations before the
        // quadratic phase; the isotropic laws 4-5.
        assert!(iters.iter().all(|&k| k <= 12), "{name}: {iters:?}");
        let finite: Vec<f64> = orders.iter().copied().filter(|o| o.is_finite()).collect();
        assert!(
            !finite.is_empty() && finite.iter().all(|&o| o > 1.6),
            "{name}: orders {orders:?}"
        );
    }
}
