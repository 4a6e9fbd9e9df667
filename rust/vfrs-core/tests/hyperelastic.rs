//! Verification of the finite-strain groundwork (issue 14): each test can fail, and prints
//! what it measured (`cargo test --test hyperelastic -- --nocapture`).

use vfrs_core::hyperelastic::{det3, Mat3};
use vfrs_core::{
    Assembler, FibreReinforced, FiniteStrainAssembler, HyperelasticError, HyperelasticLaw,
    HyperelasticMaterial, Material, MaterialError, NeoHookean, StVenantKirchhoff,
};

const E: f64 = 10e3;
const NU: f64 = 0.3;

fn vocal_fold() -> Material {
    Material::TransverselyIsotropic {
        e_p: 2e3,
        e_z: 40e3,
        nu_p: 0.9,
        nu_pz: 0.0,
        g_pz: 10e3,
        axis: [0.0, 0.0, 1.0],
    }
}

/// The three laws: neo-Hookean (E, nu), SVK with the vocal-fold TI constants, fibre-reinforced.
fn laws() -> Vec<(&'static str, HyperelasticMaterial)> {
    let nh = NeoHookean::from_young(E, NU).unwrap();
    vec![
        ("neo_hookean", HyperelasticMaterial::NeoHookean(nh)),
        (
            "svk_ti",
            HyperelasticMaterial::StVenantKirchhoff(
                StVenantKirchhoff::from_material(&vocal_fold()).unwrap(),
            ),
        ),
        (
            "fibre",
            HyperelasticMaterial::FibreReinforced(
                FibreReinforced::new(nh, 9.5e3, 3.0, [0.1, -0.2, 1.0]).unwrap(),
            ),
        ),
    ]
}

/// A box [0, lx] x [0, ly] x [0, lz] of n^3 cubes, 6 Kuhn tets each, positively oriented.
fn grid(n: usize, size: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[usize; 4]>) {
    let m = n + 1;
    let id = |i: usize, j: usize, k: usize| i + m * (j + m * k);
    let mut p = Vec::new();
    for k in 0..m {
        for j in 0..m {
            for i in 0..m {
                p.push([
                    size[0] * i as f64 / n as f64,
                    size[1] * j as f64 / n as f64,
                    size[2] * k as f64 / n as f64,
                ]);
            }
        }
    }
    let local = [
        [0, 1, 3, 7],
        [0, 1, 7, 5],
        [0, 5, 7, 4],
        [0, 3, 2, 7],
        [0, 2, 6, 7],
        [0, 6, 4, 7],
    ];
    let mut tets = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let c = [
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i, j + 1, k),
                    id(i + 1, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i, j + 1, k + 1),
                    id(i + 1, j + 1, k + 1),
                ];
                for l in local {
                    let t = [c[l[0]], c[l[1]], c[l[2]], c[l[3]]];
                    let v = vfrs_core::mesh::signed_volume(&p[t[0]], &p[t[1]], &p[t[2]], &p[t[3]]);
                    tets.push(if v > 0.0 { t } else { [t[0], t[2], t[1], t[3]] });
                }
            }
        }
    }
    (p, tets)
}

/// Deterministic pseudo-random numbers in [-1, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// A slightly distorted grid (interior nodes moved), so that no element is special.
fn distorted_grid(n: usize, seed: u64) -> (Vec<[f64; 3]>, Vec<[usize; 4]>) {
    let (mut p, t) = grid(n, [1.0, 0.8, 1.2]);
    let mut r = Lcg(seed);
    let h = 1.0 / n as f64;
    for x in p.iter_mut() {
        for c in x.iter_mut() {
            *c += 0.15 * h * r.next();
        }
    }
    (p, t)
}

fn dense(asm: &Assembler, v: &[f64]) -> Vec<Vec<f64>> {
    let n = asm.n_dofs();
    let mut m = vec![vec![0.0; n]; n];
    for (j, w) in asm.col_ptr().windows(2).enumerate() {
        for (&i, &x) in asm.row_idx()[w[0]..w[1]].iter().zip(&v[w[0]..w[1]]) {
            m[i][j] += x;
        }
    }
    m
}

fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Rotation by `angle` about the unit vector `n` (Rodrigues).
fn rotation(n: [f64; 3], angle: f64) -> Mat3 {
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let n = [n[0] / l, n[1] / l, n[2] / l];
    let (s, c) = angle.sin_cos();
    let mut r = [[0.0; 3]; 3];
    let k = [[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = if i == j { c } else { 0.0 } + s * k[i][j] + (1.0 - c) * n[i] * n[j];
        }
    }
    r
}

fn apply(r: &Mat3, x: &[f64; 3]) -> [f64; 3] {
    [
        r[0][0] * x[0] + r[0][1] * x[1] + r[0][2] * x[2],
        r[1][0] * x[0] + r[1][1] * x[1] + r[1][2] * x[2],
        r[2][0] * x[0] + r[2][1] * x[1] + r[2][2] * x[2],
    ]
}

/// u = (G - I) X + amp * random.
fn deformation(p: &[[f64; 3]], g: &Mat3, amp: f64, seed: u64) -> Vec<f64> {
    let mut r = Lcg(seed);
    p.iter()
        .flat_map(|x| {
            let y = apply(g, x);
            [y[0] - x[0], y[1] - x[1], y[2] - x[2]]
        })
        .map(|ui| ui + amp * r.next())
        .collect()
}

/// A moderate deformation with the fibre (about z) stretched by ~25 %.
const MODERATE: Mat3 = [[1.1, 0.08, -0.05], [0.04, 0.93, 0.06], [-0.03, 0.07, 1.25]];

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

#[test]
fn uniaxial_stretch_to_1_5_matches_the_closed_form_neo_hookean() {
    let nh = NeoHookean::from_young(E, NU).unwrap();
    let (mu, lam) = (nh.mu, nh.lambda);
    let stretch = 1.5;
    // Closed form: lateral faces traction free, P22 = P33 = 0:
    //   mu (lt^2 - 1) + lam ln(stretch lt^2) = 0   (scalar Newton for lt)
    //   P11 = mu (stretch - 1/stretch) + lam ln J / stretch,  J = stretch lt^2.
    let mut lt: f64 = 1.0;
    for _ in 0..50 {
        let g = mu * (lt * lt - 1.0) + lam * (stretch * lt * lt).ln();
        let dg = 2.0 * mu * lt + 2.0 * lam / lt;
        lt -= g / dg;
    }
    let j = stretch * lt * lt;
    let p11 = mu * (stretch - 1.0 / stretch) + lam * j.ln() / stretch;

    // The mesh: a unit cube, 2^3 cubes. x = 0: u_x = 0; x = 1: u_x = 0.5; the origin fixed
    // in y, z and (0, 1, 0) in z (no rigid motion, compatible with free lateral contraction).
    let (p, t) = grid(2, [1.0, 1.0, 1.0]);
    let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    let n = fs.n_dofs();
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
    // Start from the stretched-only state (no lateral contraction): the first residual is large.
    for (i, x) in p.iter().enumerate() {
        u[3 * i] = (stretch - 1.0) * x[0];
    }
    let free: Vec<usize> = (0..n).filter(|&d| !fixed[d]).collect();
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
    // O(strain): f_int(eps v) = eps K v + O(eps^2).
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

#[test]
fn bad_input_gives_typed_errors_not_panics() {
    let (p, t) = grid(1, [1.0, 1.0, 1.0]);
    let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    let law = [NeoHookean::from_young(E, NU).unwrap()];
    let n = fs.n_dofs();
    let mut f = vec![0.0; n];
    let mut k = vec![0.0; fs.nnz()];
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
            let v = vfrs_core::mesh::signed_volume(&x[0], &x[1], &x[2], &x[3]);
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

// Newton with the core's Cholesky: symbolic once, numeric refactorization per iteration ----

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

#[test]
fn rigid_90_degree_rotation_prescribed_on_the_boundary_leaves_no_stress_after_newton() {
    // A bar 1 x 1 x 3, both end faces rotated rigidly about the bar's axis-normal x by 90 deg
    // in 6 increments; the interior is solved for and must follow the rotation.
    let (p, t) = grid(3, [1.0, 1.0, 3.0]);
    let fixed: Vec<usize> = p
        .iter()
        .enumerate()
        .filter(|(_, x)| x[2] == 0.0 || x[2] == 3.0)
        .flat_map(|(i, _)| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
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
    let (p, t) = grid(3, [1.0, 1.0, 3.0]);
    let fixed: Vec<usize> = p
        .iter()
        .enumerate()
        .filter(|(_, x)| x[2] == 0.0 || x[2] == 3.0)
        .flat_map(|(i, _)| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
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
