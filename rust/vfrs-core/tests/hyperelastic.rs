//! Verification of the finite-strain groundwork (issue 14): each test can fail, and prints
//! what it measured (`cargo test --test hyperelastic -- --nocapture`). Newton on the core's
//! Cholesky is in `hyperelastic_newton.rs`.

#[path = "common/hyperelastic.rs"]
mod common;

use common::*;
use vfrs_core::hyperelastic::det3;
use vfrs_core::{
    FibreReinforced, FiniteStrainAssembler, HyperelasticError, HyperelasticLaw,
    HyperelasticMaterial, Material, MaterialError, NeoHookean, StVenantKirchhoff,
};

// (a) ------------------------------------------------------------------------------------

#[test]
fn rigid_rotation_by_90_degrees_has_no_stress_force_or_energy() {
    let (p, t) = distorted_grid(2, 7);
    let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    for axis in [[0.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.3, -1.0, 0.5]] {
        let r = rotation(axis, std::f64::consts::FRAC_PI_2);
        let u = deformation(&p, &r, 0.0, 0);
        for (name, law) in laws() {
            let mut f = vec![0.0; fs.n_dofs()];
            let w = fs.internal_force(&u, &[law], None, &mut f).unwrap();
            let p_max = max_abs(
                (0..fs.n_elements()).flat_map(|e| fs.last_stress(e).unwrap().into_iter().flatten()),
            );
            let f_max = max_abs(f.iter().copied());
            let volume: f64 = 1.0 * 0.8 * 1.2;
            // Relative to the modulus (stress), modulus * area (force), modulus * volume (energy).
            eprintln!(
                "rigid 90 deg about {axis:?}, {name}: max|P|/E = {:.2e}, max|f|/(E h^2) = {:.2e}, W/(E V) = {:.2e}",
                p_max / E,
                f_max / (E * 0.25),
                w / (E * volume)
            );
            assert!(p_max < 1e-12 * E, "{name}: max |P| = {p_max:e}");
            assert!(f_max < 1e-12 * E * 0.25, "{name}: max |f| = {f_max:e}");
            assert!(w.abs() < 1e-14 * E * volume, "{name}: W = {w:e}");
            // A linear body under the same motion: spurious stress of order E.
            let mut k = vec![0.0; fs.nnz()];
            let d = Material::Isotropic { e: E, nu: NU }.elasticity().unwrap();
            fs.assembler()
                .stiffness_into(&p, &[d], None, &mut k)
                .unwrap();
            let kd = dense(fs.assembler(), &k);
            let lin = max_abs(
                kd.iter()
                    .map(|row| row.iter().zip(&u).map(|(a, b)| a * b).sum::<f64>()),
            );
            assert!(
                lin > 1e-2 * E * 0.25,
                "the linear force should not vanish: {lin:e}"
            );
        }
    }
}

// (b) ------------------------------------------------------------------------------------

/// Dense Gaussian elimination with partial pivoting.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for c in 0..n {
        let piv = (c..n)
            .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
            .unwrap();
        a.swap(c, piv);
        b.swap(c, piv);
        for r in c + 1..n {
            let f = a[r][c] / a[c][c];
            if f != 0.0 {
                let (top, bottom) = a.split_at_mut(r);
                for (x, y) in bottom[0][c..].iter_mut().zip(&top[c][c..]) {
                    *x -= f * y;
                }
                b[r] -= f * b[c];
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

/// Uniaxial neo-Hookean stretch in closed form, lateral faces traction free (P22 = P33 =
/// 0): the lateral stretch lt from `mu (lt^2 - 1) + lam ln(stretch lt^2) = 0` (scalar
/// Newton), J = stretch lt^2 and `P11 = mu (stretch - 1/stretch) + lam ln J / stretch`.
fn uniaxial_closed_form(mu: f64, lam: f64, stretch: f64) -> (f64, f64, f64) {
    let mut lt: f64 = 1.0;
    for _ in 0..50 {
        let g = mu * (lt * lt - 1.0) + lam * (stretch * lt * lt).ln();
        let dg = 2.0 * mu * lt + 2.0 * lam / lt;
        lt -= g / dg;
    }
    let j = stretch * lt * lt;
    let p11 = mu * (stretch - 1.0 / stretch) + lam * j.ln() / stretch;
    (lt, j, p11)
}

/// The free DOFs of the unit cube `p` stretched along x, and the starting displacement.
/// x = 0: u_x = 0; x = 1: u_x = stretch - 1; the origin fixed in y, z and (0, 1, 0) in z (no
/// rigid motion, compatible with free lateral contraction). The start is the stretched-only
/// state (no lateral contraction): the first residual is large.
fn uniaxial_start(p: &[[f64; 3]], stretch: f64) -> (Vec<usize>, Vec<f64>) {
    let n = 3 * p.len();
    let mut fixed = vec![false; n];
    let mut u = vec![0.0; n];
    for (i, x) in p.iter().enumerate() {
        if x[0] == 0.0 {
            fixed[3 * i] = true;
        }
        if x[0] == 1.0 {
            fixed[3 * i] = true;
            u[3 * i] = stretch - 1.0;
        }
        if *x == [0.0, 0.0, 0.0] {
            fixed[3 * i + 1] = true;
            fixed[3 * i + 2] = true;
        }
        if *x == [0.0, 1.0, 0.0] {
            fixed[3 * i + 2] = true;
        }
    }
    for (i, x) in p.iter().enumerate() {
        u[3 * i] = (stretch - 1.0) * x[0];
    }
    let free: Vec<usize> = (0..n).filter(|&d| !fixed[d]).collect();
    (free, u)
}

#[test]
fn uniaxial_stretch_to_1_5_matches_the_closed_form_neo_hookean() {
    let nh = NeoHookean::from_young(E, NU).unwrap();
    let stretch = 1.5;
    let (lt, j, p11) = uniaxial_closed_form(nh.mu, nh.lambda, stretch);
    let (p, t) = grid(2, [1.0, 1.0, 1.0]);
    let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    let n = fs.n_dofs();
    let (free, mut u) = uniaxial_start(&p, stretch);
    let law = [nh];
    let mut f = vec![0.0; n];
    let mut k = vec![0.0; fs.nnz()];
    let mut history = Vec::new();
    for _ in 0..20 {
        fs.force_and_tangent(&u, &law, None, &mut f, &mut k)
            .unwrap();
        let res = free.iter().map(|&d| f[d] * f[d]).sum::<f64>().sqrt();
        history.push(res);
        if res < 1e-9 * p11 {
            break;
        }
        let kd = dense(fs.assembler(), &k);
        let a: Vec<Vec<f64>> = free
            .iter()
            .map(|&r| free.iter().map(|&c| kd[r][c]).collect())
            .collect();
        let b: Vec<f64> = free.iter().map(|&d| -f[d]).collect();
        let du = solve(a, b);
        for (&d, x) in free.iter().zip(du) {
            u[d] += x;
        }
    }
    let ratios: Vec<f64> = history
        .windows(2)
        .map(|w| w[1] / (w[0] * w[0]) * p11)
        .collect();
    eprintln!(
        "uniaxial Newton: residual norms {:?}; |r_k+1| / |r_k|^2 * P11 = {:?}",
        history
            .iter()
            .map(|x| format!("{x:.3e}"))
            .collect::<Vec<_>>(),
        ratios
            .iter()
            .map(|x| format!("{x:.3e}"))
            .collect::<Vec<_>>()
    );
    assert!(
        *history.last().unwrap() < 1e-9 * p11,
        "Newton did not converge: {history:?}"
    );
    assert!(
        history.len() <= 8,
        "too many Newton iterations: {history:?}"
    );

    // Reaction on the x = 1 face (area 1) = P11; lateral stretch of every node = lt.
    let reaction: f64 = p
        .iter()
        .enumerate()
        .filter(|(_, x)| x[0] == 1.0)
        .map(|(i, _)| f[3 * i])
        .sum();
    let lt_max_err = max_abs(p.iter().enumerate().flat_map(|(i, x)| {
        [
            u[3 * i + 1] - (lt - 1.0) * x[1],
            u[3 * i + 2] - (lt - 1.0) * x[2],
        ]
    }));
    let p_elem = max_abs((0..fs.n_elements()).map(|e| fs.last_stress(e).unwrap()[0][0] - p11));
    eprintln!(
        "uniaxial 1.5: closed form lt = {lt:.12}, J = {j:.12}, P11 = {p11:.10e} Pa; FE reaction = {reaction:.10e} Pa \
         (rel err {:.2e}); max |u_lat - (lt-1) X| = {lt_max_err:.2e}; max |P11_e - P11| / P11 = {:.2e}",
        (reaction - p11).abs() / p11,
        p_elem / p11
    );
    assert!((reaction - p11).abs() < 1e-9 * p11);
    assert!(lt_max_err < 1e-10);
    assert!(p_elem < 1e-9 * p11);
}

// (c) ------------------------------------------------------------------------------------

#[test]
fn tangent_is_the_central_difference_of_the_internal_force() {
    let (p, t) = distorted_grid(2, 11);
    let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    let n = fs.n_dofs();
    let u = deformation(&p, &MODERATE, 0.02, 3);
    let h = 1e-6;
    for (name, law) in laws() {
        let law = [law];
        let mut k = vec![0.0; fs.nnz()];
        fs.tangent_into(&u, &law, None, &mut k).unwrap();
        let kd = dense(fs.assembler(), &k);
        let scale = max_abs(kd.iter().flatten().copied());
        let mut err: f64 = 0.0;
        let mut grad_err: f64 = 0.0;
        let mut f0 = vec![0.0; n];
        fs.internal_force(&u, &law, None, &mut f0).unwrap();
        let f_scale = max_abs(f0.iter().copied());
        let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
        for d in 0..n {
            let mut up = u.clone();
            let mut um = u.clone();
            up[d] += h;
            um[d] -= h;
            let wp = fs.internal_force(&up, &law, None, &mut fp).unwrap();
            let wm = fs.internal_force(&um, &law, None, &mut fm).unwrap();
            for r in 0..n {
                err = err.max(((fp[r] - fm[r]) / (2.0 * h) - kd[r][d]).abs());
            }
            grad_err = grad_err.max(((wp - wm) / (2.0 * h) - f0[d]).abs());
        }
        let sym =
            max_abs((0..n).flat_map(|r| (0..n).map(|c| kd[r][c] - kd[c][r]).collect::<Vec<_>>()));
        eprintln!(
            "FD check, {name}: max|K_T - dF/du| / max|K_T| = {:.2e}; max|f - dW/du| / max|f| = {:.2e}; asymmetry {:.1e}",
            err / scale,
            grad_err / f_scale,
            sym / scale
        );
        assert!(
            err < 1e-6 * scale,
            "{name}: tangent error {:e}",
            err / scale
        );
        assert!(
            grad_err < 1e-6 * f_scale,
            "{name}: force error {:e}",
            grad_err / f_scale
        );
        assert!(sym < 1e-12 * scale);
    }
}

// (d) ------------------------------------------------------------------------------------

#[test]
fn at_zero_displacement_the_tangent_is_the_linear_stiffness() {
    let (p, t) = distorted_grid(3, 5);
    let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    let u = vec![0.0; fs.n_dofs()];
    let cases = [
        (
            "neo_hookean vs isotropic (E, nu)",
            HyperelasticMaterial::NeoHookean(NeoHookean::from_young(E, NU).unwrap()),
            Material::Isotropic { e: E, nu: NU },
        ),
        (
            "svk vs vocal_fold TI D",
            HyperelasticMaterial::StVenantKirchhoff(
                StVenantKirchhoff::from_material(&vocal_fold()).unwrap(),
            ),
            vocal_fold(),
        ),
        (
            "svk vs skew TI D",
            HyperelasticMaterial::StVenantKirchhoff(
                StVenantKirchhoff::from_material(&Material::TransverselyIsotropic {
                    e_p: 3e3,
                    e_z: 30e3,
                    nu_p: 0.4,
                    nu_pz: 0.1,
                    g_pz: 5e3,
                    axis: [0.3, 1.0, -0.4],
                })
                .unwrap(),
            ),
            Material::TransverselyIsotropic {
                e_p: 3e3,
                e_z: 30e3,
                nu_p: 0.4,
                nu_pz: 0.1,
                g_pz: 5e3,
                axis: [0.3, 1.0, -0.4],
            },
        ),
    ];
    for (name, law, linear) in cases {
        let mut kt = vec![0.0; fs.nnz()];
        let mut f = vec![0.0; fs.n_dofs()];
        fs.force_and_tangent(&u, &[law], None, &mut f, &mut kt)
            .unwrap();
        let mut kl = vec![0.0; fs.nnz()];
        fs.assembler()
            .stiffness_into(&p, &[linear.elasticity().unwrap()], None, &mut kl)
            .unwrap();
        let scale = max_abs(kl.iter().copied());
        let err = max_abs(kt.iter().zip(&kl).map(|(a, b)| a - b));
        eprintln!(
            "small strain, {name}: max|K_T(0) - K_lin| / max|K_lin| = {:.2e}; max|f(0)| = {:.1e}",
            err / scale,
            max_abs(f.iter().copied())
        );
        assert!(err < 1e-10 * scale, "{name}: {:e}", err / scale);
        assert!(f.iter().all(|&x| x == 0.0));
    }
}

#[test]
fn the_internal_force_departs_from_the_linear_one_at_second_order() {
    // O(strain): f_int(eps v) = eps K v + O(eps^2).
    let (p, t) = distorted_grid(3, 5);
    let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    let law = [HyperelasticMaterial::NeoHookean(
        NeoHookean::from_young(E, NU).unwrap(),
    )];
    let mut kl = vec![0.0; fs.nnz()];
    let d = Material::Isotropic { e: E, nu: NU }.elasticity().unwrap();
    fs.assembler()
        .stiffness_into(&p, &[d], None, &mut kl)
        .unwrap();
    let kd = dense(fs.assembler(), &kl);
    let v = deformation(&p, &MODERATE, 0.05, 9);
    let mut prev = f64::NAN;
    for eps in [1e-2, 1e-3, 1e-4] {
        let u: Vec<f64> = v.iter().map(|x| eps * x).collect();
        let mut f = vec![0.0; fs.n_dofs()];
        fs.internal_force(&u, &law, None, &mut f).unwrap();
        let lin: Vec<f64> = kd
            .iter()
            .map(|row| row.iter().zip(&u).map(|(a, b)| a * b).sum())
            .collect();
        let rel = max_abs(f.iter().zip(&lin).map(|(a, b)| a - b)) / max_abs(lin.iter().copied());
        eprintln!("small strain, eps = {eps:.0e}: max|f_int - K u| / max|K u| = {rel:.2e}");
        if prev.is_finite() {
            let ratio = prev / rel;
            assert!(ratio > 8.0 && ratio < 12.0, "not O(strain): ratio {ratio}");
        }
        prev = rel;
    }
}

// (e) ------------------------------------------------------------------------------------

#[test]
fn results_are_identical_for_one_and_two_threads() {
    let (p, t) = distorted_grid(6, 13);
    let u = deformation(&p, &MODERATE, 0.01, 17);
    // Two materials, assigned per element.
    let all = laws();
    let materials = [all[1].1, all[2].1];
    let material_of: Vec<usize> = (0..t.len()).map(|e| (e / 7) % 2).collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
            let mut f = vec![0.0; fs.n_dofs()];
            let mut k = vec![0.0; fs.nnz()];
            let w = fs
                .force_and_tangent(&u, &materials, Some(&material_of), &mut f, &mut k)
                .unwrap();
            (w, f, k)
        })
    };
    let (w1, f1, k1) = run(1);
    let (w2, f2, k2) = run(2);
    let (w4, f4, k4) = run(4);
    eprintln!(
        "threads: {} elements, W = {w1:.17e} (1), {w2:.17e} (2), {w4:.17e} (4); nnz {}",
        t.len(),
        k1.len()
    );
    assert_eq!(w1.to_bits(), w2.to_bits());
    assert_eq!(w1.to_bits(), w4.to_bits());
    assert!(f1.iter().zip(&f2).all(|(a, b)| a.to_bits() == b.to_bits()));
    assert!(k1.iter().zip(&k2).all(|(a, b)| a.to_bits() == b.to_bits()));
    assert!(f1.iter().zip(&f4).all(|(a, b)| a.to_bits() == b.to_bits()));
    assert!(k1.iter().zip(&k4).all(|(a, b)| a.to_bits() == b.to_bits()));
}

// (f) ------------------------------------------------------------------------------------

#[test]
fn internal_force_is_balanced_and_the_energy_frame_indifferent() {
    let (p, t) = distorted_grid(3, 19);
    let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    let n = fs.n_dofs();
    let u = deformation(&p, &MODERATE, 0.03, 23);
    let q = rotation([0.4, -0.7, 1.0], 1.1);
    // u' = Q (X + u) - X: the same deformation followed by a rigid rotation.
    let uq: Vec<f64> = p
        .iter()
        .enumerate()
        .flat_map(|(i, x)| {
            let y = apply(
                &q,
                &[x[0] + u[3 * i], x[1] + u[3 * i + 1], x[2] + u[3 * i + 2]],
            );
            [y[0] - x[0], y[1] - x[1], y[2] - x[2]]
        })
        .collect();
    for (name, law) in laws() {
        let mut f = vec![0.0; n];
        let w = fs.internal_force(&u, &[law], None, &mut f).unwrap();
        let scale = max_abs(f.iter().copied());
        let mut sum = [0.0; 3];
        let mut moment = [0.0; 3];
        for (i, x) in p.iter().enumerate() {
            let y = [x[0] + u[3 * i], x[1] + u[3 * i + 1], x[2] + u[3 * i + 2]];
            let fi = [f[3 * i], f[3 * i + 1], f[3 * i + 2]];
            for c in 0..3 {
                sum[c] += fi[c];
            }
            moment[0] += y[1] * fi[2] - y[2] * fi[1];
            moment[1] += y[2] * fi[0] - y[0] * fi[2];
            moment[2] += y[0] * fi[1] - y[1] * fi[0];
        }
        let mut fq = vec![0.0; n];
        let wq = fs.internal_force(&uq, &[law], None, &mut fq).unwrap();
        // f(Q x) = Q f(x), node by node.
        let rot_err = max_abs((0..p.len()).flat_map(|i| {
            let r = apply(&q, &[f[3 * i], f[3 * i + 1], f[3 * i + 2]]);
            [fq[3 * i] - r[0], fq[3 * i + 1] - r[1], fq[3 * i + 2] - r[2]]
        }));
        eprintln!(
            "balance, {name}: |sum f| / max|f| = {:.1e}, |sum x x f| / max|f| = {:.1e}; W = {w:.6e}, |W(Qx) - W(x)| / W = {:.1e}, max|f(Qx) - Q f(x)| / max|f| = {:.1e}",
            max_abs(sum) / scale,
            max_abs(moment) / scale,
            (wq - w).abs() / w,
            rot_err / scale
        );
        assert!(w > 0.0);
        assert!(max_abs(sum) < 1e-12 * scale, "{name}: force sum {sum:?}");
        assert!(max_abs(moment) < 1e-12 * scale, "{name}: moment {moment:?}");
        assert!((wq - w).abs() < 1e-12 * w, "{name}: W {w} vs {wq}");
        assert!(rot_err < 1e-12 * scale, "{name}: rotated force {rot_err:e}");
    }
}

// Errors ---------------------------------------------------------------------------------

/// One cube of 6 tets and its assembler.
fn unit_cube() -> (Vec<[f64; 3]>, Vec<[usize; 4]>, FiniteStrainAssembler) {
    let (p, t) = grid(1, [1.0, 1.0, 1.0]);
    let fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    (p, t, fs)
}

#[test]
fn inverted_elements_and_non_finite_displacements_give_typed_errors() {
    let (p, t, mut fs) = unit_cube();
    let law = [NeoHookean::from_young(E, NU).unwrap()];
    let n = fs.n_dofs();
    let (mut f, mut k) = (vec![0.0; n], vec![0.0; fs.nnz()]);
    // Push node 7 (1, 1, 1) through the cube: some elements invert; the lowest index is named.
    let mut u = vec![0.0; n];
    u[21..24].copy_from_slice(&[-1.5, -1.5, -1.5]);
    let expected = t
        .iter()
        .enumerate()
        .find_map(|(e, tet)| {
            let x: Vec<[f64; 3]> = tet
                .iter()
                .map(|&i| {
                    [
                        p[i][0] + u[3 * i],
                        p[i][1] + u[3 * i + 1],
                        p[i][2] + u[3 * i + 2],
                    ]
                })
                .collect();
            let v = vfrs_core::fem::mesh::signed_volume(&x[0], &x[1], &x[2], &x[3]);
            (v <= 0.0).then_some(e)
        })
        .unwrap();
    match fs.internal_force(&u, &law, None, &mut f) {
        Err(HyperelasticError::Inverted { element, j }) => {
            eprintln!("inverted: element {element}, J = {j:e}");
            assert_eq!(element, expected);
            assert!(j <= 0.0);
        }
        other => panic!("expected Inverted, got {other:?}"),
    }
    assert!(fs.tangent_into(&u, &law, None, &mut k).is_err());
    // Non-finite displacement.
    let mut un = vec![0.0; n];
    un[5] = f64::NAN;
    assert!(matches!(
        fs.internal_force(&un, &law, None, &mut f),
        Err(HyperelasticError::NonFiniteDisplacement { dof: 5, .. })
    ));
    un[5] = f64::INFINITY;
    assert!(fs.energy(&un, &law, None).is_err());
}

#[test]
fn bad_sizes_parameters_and_meshes_give_typed_errors() {
    let (p, t, mut fs) = unit_cube();
    let law = [NeoHookean::from_young(E, NU).unwrap()];
    let n = fs.n_dofs();
    let (mut f, mut k) = (vec![0.0; n], vec![0.0; fs.nnz()]);
    // Wrong sizes.
    let u0 = vec![0.0; n];
    assert!(matches!(
        fs.internal_force(&u0[1..], &law, None, &mut f),
        Err(HyperelasticError::Material(MaterialError::BadLength {
            what: "u",
            ..
        }))
    ));
    assert!(matches!(
        fs.internal_force(&u0, &law, None, &mut f[1..]),
        Err(HyperelasticError::Material(MaterialError::BadLength {
            what: "force",
            ..
        }))
    ));
    assert!(matches!(
        fs.tangent_into(&u0, &law, None, &mut k[1..]),
        Err(HyperelasticError::Material(MaterialError::BadLength {
            what: "values",
            ..
        }))
    ));
    let none: [NeoHookean; 0] = [];
    assert!(fs.energy(&u0, &none, None).is_err());
    assert!(matches!(
        fs.energy(&u0, &law, Some(&[0, 0, 0, 0, 0, 3])),
        Err(HyperelasticError::Material(
            MaterialError::BadMaterialIndex {
                element: 5,
                index: 3,
                ..
            }
        ))
    ));
    assert!(fs.energy(&u0, &law, Some(&[0, 0])).is_err());
    // Bad parameters are caught per call.
    let bad = [NeoHookean {
        mu: f64::NAN,
        lambda: 1.0,
    }];
    assert!(matches!(
        fs.energy(&u0, &bad, None),
        Err(HyperelasticError::Material(_))
    ));
    // Fibre exponential overflow: a typed error, not inf.
    let fib = [FibreReinforced::new(law[0], 1.0, 500.0, [0.0, 0.0, 1.0]).unwrap()];
    let ustretch: Vec<f64> = p.iter().flat_map(|x| [0.0, 0.0, 2.0 * x[2]]).collect();
    assert!(matches!(
        fs.internal_force(&ustretch, &fib, None, &mut f),
        Err(HyperelasticError::NonFiniteStress { .. })
    ));
    // A bad reference mesh.
    let mut flat = p.clone();
    flat[7] = [0.5, 0.5, 0.0];
    assert!(FiniteStrainAssembler::new(&flat, &t).is_err());
    assert!(FiniteStrainAssembler::new(&p, &[[0, 1, 2, 99]]).is_err());
    // And a good call still works after the errors.
    let w = fs.internal_force(&u0, &law, None, &mut f).unwrap();
    assert_eq!(w, 0.0);
    let _ = det3(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
}

/// The laws are usable through the trait object too (a scene may hold `dyn` laws).
#[test]
fn trait_objects_work() {
    let nh = NeoHookean::from_young(E, NU).unwrap();
    let law: &dyn HyperelasticLaw = &nh;
    let f = [[1.2, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    assert!(law.energy(&f) > 0.0);
}
