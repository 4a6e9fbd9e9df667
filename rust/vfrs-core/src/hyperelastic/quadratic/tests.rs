//! The P2 finite-strain assembler on small boxes of ten-node tetrahedra, straight and curved
//! (mid-edge nodes moved off their edges' midpoints): the tangent and the force are the
//! derivatives of the force and the energy, the small-strain limit is the linear P2 stiffness
//! (with RULE_4 and RULE_14), the homogeneous-deformation patch test, rigid rotations, inverted
//! elements and bad input. `cargo test -p vfrs-core quadratic_finite -- --nocapture` prints what
//! each test measured.

use super::*;
use crate::error::MaterialError;
use crate::fem::material::{Elasticity, Material};
use crate::fem::tet10::{EDGES, RULE_14};
use crate::hyperelastic::{FibreReinforced, HyperelasticMaterial, NeoHookean, StVenantKirchhoff};

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

/// A P2 mesh of the box [0, size] cut into n^3 cubes of 6 Kuhn tetrahedra: the interior
/// vertices moved by up to `shake` of a cell (straight edges), then every mid-edge node moved
/// off its edge's midpoint by up to `curve` of a cell (curved elements; 0: straight).
/// Returns (points, ten-node elements).
fn box_mesh(
    n: usize,
    size: [f64; 3],
    shake: f64,
    curve: f64,
    seed: u64,
) -> (Vec<[f64; 3]>, Vec<[usize; 10]>) {
    let m = n + 1;
    let id = |i: usize, j: usize, k: usize| i + m * (j + m * k);
    let mut r = Lcg(seed);
    let h = size.iter().fold(f64::INFINITY, |a, &b| a.min(b)) / n as f64;
    let mut p = Vec::new();
    for k in 0..m {
        for j in 0..m {
            for i in 0..m {
                let inner = [i, j, k].iter().all(|&c| c > 0 && c < n);
                let x: [f64; 3] = std::array::from_fn(|c| {
                    let s = size[c] * [i, j, k][c] as f64 / n as f64;
                    if inner {
                        s + shake * h * r.next()
                    } else {
                        s
                    }
                });
                p.push(x);
            }
        }
    }
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
                for l in [[0, 1, 3, 7], [0, 1, 7, 5], [0, 5, 7, 4]]
                    .into_iter()
                    .chain([[0, 3, 2, 7], [0, 2, 6, 7], [0, 6, 4, 7]])
                {
                    let t = [c[l[0]], c[l[1]], c[l[2]], c[l[3]]];
                    let v = crate::fem::mesh::signed_volume(&p[t[0]], &p[t[1]], &p[t[2]], &p[t[3]]);
                    tets.push(if v > 0.0 { t } else { [t[0], t[2], t[1], t[3]] });
                }
            }
        }
    }
    let n_vertices = p.len();
    let mut mids = std::collections::BTreeMap::new();
    let mut elems = Vec::new();
    for t in &tets {
        let mut el = [0usize; 10];
        el[..4].copy_from_slice(t);
        for (k, [a, b]) in EDGES.iter().enumerate() {
            let key = (t[*a].min(t[*b]), t[*a].max(t[*b]));
            el[4 + k] = *mids.entry(key).or_insert_with(|| {
                p.push(std::array::from_fn(|c| 0.5 * (p[key.0][c] + p[key.1][c])));
                p.len() - 1
            });
        }
        elems.push(el);
    }
    for x in &mut p[n_vertices..] {
        for c in x.iter_mut() {
            *c += curve * h * r.next();
        }
    }
    (p, elems)
}

/// The curved mesh of most tests: one cube of 6 elements, every node moved.
fn curved_cube() -> (Vec<[f64; 3]>, Vec<[usize; 10]>) {
    let (mut p, e) = box_mesh(1, [1.0, 0.8, 1.2], 0.0, 0.04, 3);
    let mut r = Lcg(5);
    for x in &mut p[..8] {
        for c in x.iter_mut() {
            *c += 0.05 * r.next();
        }
    }
    (p, e)
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

fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn apply(r: &Mat3, x: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| r[i][0] * x[0] + r[i][1] * x[1] + r[i][2] * x[2])
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

/// Rotation by `angle` about the axis `n` (Rodrigues).
fn rotation(n: [f64; 3], angle: f64) -> Mat3 {
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let n = n.map(|x| x / l);
    let (s, c) = angle.sin_cos();
    let k = [[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]];
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            (if i == j { c } else { 0.0 }) + s * k[i][j] + (1.0 - c) * n[i] * n[j]
        })
    })
}

/// A moderate deformation with the fibre (about z) stretched by ~25 %.
const MODERATE: Mat3 = [[1.1, 0.08, -0.05], [0.04, 0.93, 0.06], [-0.03, 0.07, 1.25]];

// (a) ------------------------------------------------------------------------------------

#[test]
fn the_tangent_and_the_force_are_central_differences_on_a_curved_mesh() {
    let (p, t) = curved_cube();
    let mut fs = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
    let n = fs.n_dofs();
    let u = deformation(&p, &MODERATE, 0.01, 7);
    let h = 1e-6;
    for (name, law) in laws() {
        let law = [law];
        let mut k = vec![0.0; fs.nnz()];
        fs.tangent_into(&u, &law, None, &mut k).unwrap();
        let kd = dense(fs.assembler(), &k);
        let scale = max_abs(kd.iter().flatten().copied());
        let mut f0 = vec![0.0; n];
        fs.internal_force(&u, &law, None, &mut f0).unwrap();
        let f_scale = max_abs(f0.iter().copied());
        let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
        let (mut err, mut grad_err) = (0.0f64, 0.0f64);
        for d in 0..n {
            let (mut up, mut um) = (u.clone(), u.clone());
            up[d] += h;
            um[d] -= h;
            let wp = fs.internal_force(&up, &law, None, &mut fp).unwrap();
            let wm = fs.internal_force(&um, &law, None, &mut fm).unwrap();
            for r in 0..n {
                err = err.max(((fp[r] - fm[r]) / (2.0 * h) - kd[r][d]).abs());
            }
            grad_err = grad_err.max(((wp - wm) / (2.0 * h) - f0[d]).abs());
        }
        let sym = max_abs(
            (0..n)
                .flat_map(|r| (0..n).map(move |c| (r, c)))
                .map(|(r, c)| kd[r][c] - kd[c][r]),
        );
        eprintln!(
            "P2 FD check, {name}: max|K_T - df/du| / max|K_T| = {:.2e}; max|f - dW/du| / max|f| = {:.2e}; asymmetry {:.1e}",
            err / scale,
            grad_err / f_scale,
            sym / scale
        );
        assert!(err < 1e-6 * scale, "{name}: tangent {:e}", err / scale);
        assert!(
            grad_err < 1e-6 * f_scale,
            "{name}: force {:e}",
            grad_err / f_scale
        );
        assert!(sym < 1e-12 * scale, "{name}: asymmetry {:e}", sym / scale);
    }
}

// (b) ------------------------------------------------------------------------------------

/// (law, the linear material of its small-strain limit) pairs.
fn small_strain_cases() -> Vec<(&'static str, HyperelasticMaterial, Elasticity)> {
    let skew = Material::TransverselyIsotropic {
        e_p: 3e3,
        e_z: 30e3,
        nu_p: 0.4,
        nu_pz: 0.1,
        g_pz: 5e3,
        axis: [0.3, 1.0, -0.4],
    };
    vec![
        (
            "neo_hookean vs isotropic (E, nu)",
            HyperelasticMaterial::NeoHookean(NeoHookean::from_young(E, NU).unwrap()),
            Material::Isotropic { e: E, nu: NU }.elasticity().unwrap(),
        ),
        (
            "svk vs vocal_fold TI",
            HyperelasticMaterial::StVenantKirchhoff(
                StVenantKirchhoff::from_material(&vocal_fold()).unwrap(),
            ),
            vocal_fold().elasticity().unwrap(),
        ),
        (
            "svk vs skew TI",
            HyperelasticMaterial::StVenantKirchhoff(
                StVenantKirchhoff::from_material(&skew).unwrap(),
            ),
            skew.elasticity().unwrap(),
        ),
    ]
}

#[test]
fn at_zero_displacement_the_tangent_is_the_linear_p2_stiffness() {
    for (mesh, (p, t)) in [
        ("curved 2x2x2", box_mesh(2, [1.0, 0.8, 1.2], 0.1, 0.04, 11)),
        ("curved cube", curved_cube()),
    ] {
        let mut fs = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
        let u = vec![0.0; fs.n_dofs()];
        for (name, law, d) in small_strain_cases() {
            let mut kt = vec![0.0; fs.nnz()];
            let mut f = vec![0.0; fs.n_dofs()];
            fs.force_and_tangent(&u, &[law], None, &mut f, &mut kt)
                .unwrap();
            let mut kl = vec![0.0; fs.nnz()];
            fs.assembler()
                .stiffness_into(&p, &[d], None, &mut kl)
                .unwrap();
            let scale = max_abs(kl.iter().copied());
            let err = max_abs(kt.iter().zip(&kl).map(|(a, b)| a - b));
            eprintln!(
                "P2 small strain, {mesh}, {name}: max|K_T(0) - K_lin| / max|K_lin| = {:.2e}",
                err / scale
            );
            assert!(err < 1e-10 * scale, "{mesh}, {name}: {:e}", err / scale);
            assert!(f.iter().all(|&x| x == 0.0));
        }
    }
}

/// K_T(0) by RULE_4 and by RULE_14 on straight elements: both the linear stiffness (its
/// integrand is of degree 2). On curved elements neither rule is exact and they differ; at a
/// small strain eps the forces of the two rules agree to O(eps) relative on straight elements.
#[test]
fn rule_4_and_rule_14_give_the_same_small_strain_limit() {
    let (name, law, d) = small_strain_cases().swap_remove(0);
    let (p, t) = box_mesh(2, [1.0, 0.8, 1.2], 0.1, 0.0, 13);
    let mut f4 = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
    let mut f14 = QuadraticFiniteStrainAssembler::with_rule(&p, &t, RULE_14).unwrap();
    let u0 = vec![0.0; f4.n_dofs()];
    let (mut k4, mut k14, mut kl) = (
        vec![0.0; f4.nnz()],
        vec![0.0; f4.nnz()],
        vec![0.0; f4.nnz()],
    );
    f4.tangent_into(&u0, &[law], None, &mut k4).unwrap();
    f14.tangent_into(&u0, &[law], None, &mut k14).unwrap();
    f4.assembler()
        .stiffness_into(&p, &[d], None, &mut kl)
        .unwrap();
    let scale = max_abs(kl.iter().copied());
    let e4 = max_abs(k4.iter().zip(&kl).map(|(a, b)| a - b)) / scale;
    let e14 = max_abs(k14.iter().zip(&kl).map(|(a, b)| a - b)) / scale;
    eprintln!("P2 {name}, straight: K_T(0) vs K_lin: RULE_4 {e4:.2e}, RULE_14 {e14:.2e}");
    assert!(e4 < 1e-12 && e14 < 1e-12, "{e4:e} {e14:e}");
    let v = deformation(&p, &MODERATE, 0.05, 9);
    let mut prev = f64::NAN;
    for eps in [1e-2, 1e-3, 1e-4] {
        let u: Vec<f64> = v.iter().map(|x| eps * x).collect();
        let (mut a, mut b) = (vec![0.0; f4.n_dofs()], vec![0.0; f4.n_dofs()]);
        f4.internal_force(&u, &[law], None, &mut a).unwrap();
        f14.internal_force(&u, &[law], None, &mut b).unwrap();
        let rel = max_abs(a.iter().zip(&b).map(|(x, y)| x - y)) / max_abs(a.iter().copied());
        eprintln!("P2 {name}, eps = {eps:.0e}: max|f_4 - f_14| / max|f_4| = {rel:.2e}");
        if prev.is_finite() {
            let ratio = prev / rel;
            assert!(ratio > 8.0 && ratio < 12.0, "not O(eps): ratio {ratio}");
        }
        prev = rel;
    }
    let (pc, tc) = curved_cube();
    let mut c4 = QuadraticFiniteStrainAssembler::new(&pc, &tc).unwrap();
    let mut c14 = QuadraticFiniteStrainAssembler::with_rule(&pc, &tc, RULE_14).unwrap();
    let u0 = vec![0.0; c4.n_dofs()];
    let (mut k4, mut k14) = (vec![0.0; c4.nnz()], vec![0.0; c4.nnz()]);
    c4.tangent_into(&u0, &[law], None, &mut k4).unwrap();
    c14.tangent_into(&u0, &[law], None, &mut k14).unwrap();
    let rel = max_abs(k4.iter().zip(&k14).map(|(a, b)| a - b)) / max_abs(k14.iter().copied());
    eprintln!(
        "P2 {name}, curved cube: max|K_T(0) RULE_4 - RULE_14| / max|K| = {rel:.2e} (neither exact)"
    );
    assert!(rel < 0.05, "{rel:e}");
}

// (c) ------------------------------------------------------------------------------------

/// Stretch and shear.
const HOMOGENEOUS: Mat3 = [[1.2, 0.15, 0.0], [0.0, 0.9, 0.1], [0.05, 0.0, 1.1]];

fn on_boundary(x: &[f64; 3], size: [f64; 3]) -> bool {
    (0..3).any(|c| x[c] == 0.0 || x[c] == size[c])
}

/// u = (F - I) X on every node of a straight 2x2x2 box with a moved interior vertex: no force
/// at the interior nodes (the vertex and the interior mid-edge nodes), the energy W(F) V, the
/// elements' stress P(F) and volume ratio det F; and Newton from a perturbed interior, the
/// boundary held, returns to the homogeneous field.
#[test]
fn a_homogeneous_deformation_passes_the_patch_test() {
    let size = [1.0, 0.8, 1.2];
    let volume = size[0] * size[1] * size[2];
    let (p, t) = box_mesh(2, size, 0.1, 0.0, 17);
    let mut fs = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
    let n = fs.n_dofs();
    let interior: Vec<usize> = (0..p.len())
        .filter(|&i| !on_boundary(&p[i], size))
        .collect();
    assert!(interior.len() > 10, "{} interior nodes", interior.len());
    let exact = deformation(&p, &HOMOGENEOUS, 0.0, 0);
    let j = super::super::det3(&HOMOGENEOUS);
    for (name, law) in laws() {
        let mut f = vec![0.0; n];
        let w = fs.internal_force(&exact, &[law], None, &mut f).unwrap();
        let scale = max_abs(f.iter().copied());
        let inner = max_abs(interior.iter().flat_map(|&i| f[3 * i..3 * i + 3].to_vec()));
        let w_exact = law.energy(&HOMOGENEOUS) * volume;
        let p_exact = law.stress(&HOMOGENEOUS);
        let p_err = max_abs((0..fs.n_elements()).flat_map(|e| {
            let pe = fs.last_stress(e).unwrap();
            (0..9).map(move |k| pe[k / 3][k % 3] - p_exact[k / 3][k % 3])
        }));
        let j_err = max_abs((0..fs.n_elements()).map(|e| fs.last_volume_ratio(e).unwrap() - j));
        eprintln!(
            "P2 patch, {name}: max|f interior| / max|f| = {:.1e}; |W - W(F) V| / W = {:.1e}; max|P_e - P(F)| / max|P| = {:.1e}; max|J_e - det F| = {j_err:.1e}",
            inner / scale,
            (w - w_exact).abs() / w_exact,
            p_err / max_abs(p_exact.into_iter().flatten())
        );
        assert!(inner < 1e-12 * scale, "{name}: interior force {inner:e}");
        assert!(
            (w - w_exact).abs() < 1e-12 * w_exact,
            "{name}: W {w} vs {w_exact}"
        );
        assert!(p_err < 1e-12 * max_abs(p_exact.into_iter().flatten()));
        assert!(j_err < 1e-13);
    }
    // Newton on the interior DOFs, the boundary held at the homogeneous field.
    let law = [laws()[0].1];
    let free: Vec<usize> = interior.iter().flat_map(|&i| 3 * i..3 * i + 3).collect();
    let mut u = exact.clone();
    let mut r = Lcg(23);
    for &d in &free {
        u[d] += 0.02 * r.next();
    }
    let (mut f, mut k) = (vec![0.0; n], vec![0.0; fs.nnz()]);
    let mut history = Vec::new();
    for _ in 0..8 {
        fs.force_and_tangent(&u, &law, None, &mut f, &mut k)
            .unwrap();
        let res = free.iter().map(|&d| f[d] * f[d]).sum::<f64>().sqrt();
        history.push(res);
        if res < 1e-10 * E {
            break;
        }
        let kd = dense(fs.assembler(), &k);
        let a: Vec<Vec<f64>> = free
            .iter()
            .map(|&r| free.iter().map(|&c| kd[r][c]).collect())
            .collect();
        let b: Vec<f64> = free.iter().map(|&d| -f[d]).collect();
        for (&d, x) in free.iter().zip(solve(a, b)) {
            u[d] += x;
        }
    }
    let err = max_abs(u.iter().zip(&exact).map(|(a, b)| a - b));
    let history_s: Vec<String> = history.iter().map(|x| format!("{x:.2e}")).collect();
    eprintln!(
        "P2 patch, Newton on {} interior nodes: residuals {history_s:?}; max|u - u_exact| = {err:.1e}",
        interior.len()
    );
    assert!(err < 1e-12, "{err:e}");
    assert!(history.len() <= 6, "{history:?}");
}

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
            let (top, bottom) = a.split_at_mut(r);
            for (x, y) in bottom[0][c..].iter_mut().zip(&top[c][c..]) {
                *x -= f * y;
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

// (d) ------------------------------------------------------------------------------------

#[test]
fn a_rigid_rotation_has_no_energy_and_no_force() {
    let (p, t) = curved_cube();
    let mut fs = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
    let volume: f64 = (0..fs.n_elements())
        .map(|e| fs.points_of(e).unwrap().1.iter().sum::<f64>())
        .sum();
    for axis in [[0.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.3, -1.0, 0.5]] {
        let u = deformation(&p, &rotation(axis, std::f64::consts::FRAC_PI_2), 0.0, 0);
        for (name, law) in laws() {
            let mut f = vec![0.0; fs.n_dofs()];
            let w = fs.internal_force(&u, &[law], None, &mut f).unwrap();
            let f_max = max_abs(f.iter().copied());
            let p_max = max_abs(
                (0..fs.n_elements()).flat_map(|e| fs.last_stress(e).unwrap().into_iter().flatten()),
            );
            eprintln!(
                "P2 rigid 90 deg about {axis:?}, {name}: max|P|/E = {:.1e}, max|f|/(E h^2) = {:.1e}, W/(E V) = {:.1e}",
                p_max / E,
                f_max / E,
                w / (E * volume)
            );
            assert!(p_max < 1e-12 * E, "{name}: {p_max:e}");
            assert!(f_max < 1e-12 * E, "{name}: {f_max:e}");
            assert!(w.abs() < 1e-14 * E * volume, "{name}: {w:e}");
        }
    }
}

// (e) ------------------------------------------------------------------------------------

/// The first (element, quadrature point) of RULE_4 where the element on `x` has no positive
/// Jacobian, by the element kernel.
fn first_inverted(x: &[[f64; 3]], t: &[[usize; 10]]) -> Option<(usize, usize)> {
    t.iter().enumerate().find_map(|(e, el)| {
        let xe: [[f64; 3]; 10] = std::array::from_fn(|a| x[el[a]]);
        RULE_4
            .points
            .iter()
            .position(|l| gradients_at(&xe, l).is_none())
            .map(|q| (e, q))
    })
}

#[test]
fn a_mid_edge_node_dragged_across_is_an_error_naming_the_element() {
    let (p, t) = box_mesh(1, [1.0, 1.0, 1.0], 0.0, 0.0, 1);
    // Element 3's mid-edge node on its edge 1-2 (local 5), dragged through the opposite
    // vertex 0 and beyond.
    let (e0, node) = (3, t[3][5]);
    let x0 = p[t[e0][0]];
    let mid = p[node];
    let dragged: [f64; 3] = std::array::from_fn(|c| mid[c] + 1.6 * (x0[c] - mid[c]));
    let mut bad = p.clone();
    bad[node] = dragged;
    let (tet, point) = first_inverted(&bad, &t).unwrap();
    assert!(t[tet].contains(&node));
    match QuadraticFiniteStrainAssembler::new(&bad, &t) {
        Err(HyperelasticError::Mesh(MeshError::InvertedQuadratic { tet: te, point: q })) => {
            eprintln!("P2 reference inverted: element {te}, point {q} (node {node} dragged)");
            assert_eq!((te, q), (tet, point));
        }
        other => panic!("expected InvertedQuadratic, got {other:?}"),
    }
    // The same drag as a displacement of the valid mesh: the P1 assembler's Inverted error,
    // naming the first element whose deformed Jacobian is not positive at a point.
    let mut fs = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
    let mut u = vec![0.0; fs.n_dofs()];
    for c in 0..3 {
        u[3 * node + c] = dragged[c] - mid[c];
    }
    let law = [NeoHookean::from_young(E, NU).unwrap()];
    let mut f = vec![0.0; fs.n_dofs()];
    match fs.internal_force(&u, &law, None, &mut f) {
        Err(HyperelasticError::Inverted { element, j }) => {
            eprintln!("P2 deformed inverted: element {element}, J = {j:.3}");
            assert_eq!(element, tet);
            assert!(j <= 0.0);
        }
        other => panic!("expected Inverted, got {other:?}"),
    }
    let mut k = vec![0.0; fs.nnz()];
    assert!(matches!(
        fs.tangent_into(&u, &law, None, &mut k),
        Err(HyperelasticError::Inverted { .. })
    ));
}

#[test]
fn bad_input_gives_typed_errors_and_a_good_call_still_works() {
    let (p, t) = curved_cube();
    let mut fs = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
    let law = [NeoHookean::from_young(E, NU).unwrap()];
    let n = fs.n_dofs();
    let (mut f, mut k) = (vec![0.0; n], vec![0.0; fs.nnz()]);
    let u0 = vec![0.0; n];
    let bad_len = |r: Result<f64, HyperelasticError>, name: &str| matches!(r, Err(HyperelasticError::Material(MaterialError::BadLength { what, .. })) if what == name);
    assert!(bad_len(
        fs.internal_force(&u0[1..], &law, None, &mut f),
        "u"
    ));
    assert!(bad_len(
        fs.internal_force(&u0, &law, None, &mut f[1..]),
        "force"
    ));
    assert!(matches!(
        fs.tangent_into(&u0, &law, None, &mut k[1..]),
        Err(HyperelasticError::Material(MaterialError::BadLength {
            what: "values",
            ..
        }))
    ));
    let mut un = u0.clone();
    un[7] = f64::NAN;
    assert!(matches!(
        fs.force_and_tangent(&un, &law, None, &mut f, &mut k),
        Err(HyperelasticError::NonFiniteDisplacement { dof: 7, .. })
    ));
    let none: [NeoHookean; 0] = [];
    assert!(fs.energy(&u0, &none, None).is_err());
    assert!(matches!(
        fs.energy(&u0, &law, Some(&[0, 0, 0, 0, 0, 2])),
        Err(HyperelasticError::Material(
            MaterialError::BadMaterialIndex {
                element: 5,
                index: 2,
                ..
            }
        ))
    ));
    assert!(bad_len(fs.energy(&u0, &law, Some(&[0, 0])), "material_of"));
    let nan_law = [NeoHookean {
        mu: f64::NAN,
        lambda: 1.0,
    }];
    assert!(matches!(
        fs.energy(&u0, &nan_law, None),
        Err(HyperelasticError::Material(_))
    ));
    // fibre exponential overflow: a typed error, not inf
    let fib = [FibreReinforced::new(law[0], 1.0, 500.0, [0.0, 0.0, 1.0]).unwrap()];
    let stretch: Vec<f64> = p.iter().flat_map(|x| [0.0, 0.0, 2.0 * x[2]]).collect();
    assert!(matches!(
        fs.internal_force(&stretch, &fib, None, &mut f),
        Err(HyperelasticError::NonFiniteStress { .. })
    ));
    assert!(fs.last_stress(t.len()).is_none() && fs.last_volume_ratio(t.len()).is_none());
    // a good call after the errors
    assert_eq!(fs.internal_force(&u0, &law, None, &mut f).unwrap(), 0.0);
    assert!(f.iter().all(|&x| x == 0.0));
}

#[test]
fn bad_reference_meshes_give_mesh_errors() {
    let (p, t) = curved_cube();
    let mesh_err =
        |p: &[[f64; 3]], t: &[[usize; 10]]| match QuadraticFiniteStrainAssembler::new(p, t) {
            Err(HyperelasticError::Mesh(m)) => m,
            other => panic!("expected a mesh error, got {other:?}"),
        };
    assert_eq!(mesh_err(&p, &[]), MeshError::Empty);
    let mut bad_t = t.clone();
    bad_t[2][9] = p.len();
    assert!(matches!(
        mesh_err(&p, &bad_t),
        MeshError::IndexOutOfRange { tet: 2, .. }
    ));
    bad_t[2][9] = bad_t[2][4];
    assert!(matches!(
        mesh_err(&p, &bad_t),
        MeshError::RepeatedVertex { tet: 2, .. }
    ));
    let mut bad_p = p.clone();
    bad_p[11][1] = f64::INFINITY;
    assert!(matches!(
        mesh_err(&bad_p, &t),
        MeshError::NonFinite {
            point: 11,
            axis: 1,
            ..
        }
    ));
}

#[test]
fn results_are_identical_for_one_and_two_threads() {
    let (p, t) = box_mesh(3, [1.0, 0.8, 1.2], 0.1, 0.04, 29);
    let u = deformation(&p, &MODERATE, 0.01, 31);
    let all = laws();
    let materials = [all[1].1, all[2].1];
    let material_of: Vec<usize> = (0..t.len()).map(|e| (e / 7) % 2).collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut fs = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
            let mut f = vec![0.0; fs.n_dofs()];
            let mut k = vec![0.0; fs.nnz()];
            let w = fs
                .force_and_tangent(&u, &materials, Some(&material_of), &mut f, &mut k)
                .unwrap();
            (w, f, k)
        })
    };
    let one = run(1);
    for threads in [2, 4] {
        let other = run(threads);
        assert_eq!(one.0.to_bits(), other.0.to_bits());
        assert!(one
            .1
            .iter()
            .zip(&other.1)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(one
            .2
            .iter()
            .zip(&other.2)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }
    eprintln!(
        "P2 threads: {} elements, W = {:.17e} for 1, 2 and 4 threads",
        t.len(),
        one.0
    );
}

/// The patch test on curved elements (the interior mid-edge nodes of the box above moved off
/// their midpoints, the boundary straight): the integrand `cof(J) grad_xi N` is of degree 5
/// there, so RULE_14 passes (and integrates the volume exactly) where RULE_4 leaves a small
/// interior force, the same as the linear P2 stiffness (which uses RULE_4 too) does.
#[test]
fn on_curved_elements_rule_14_passes_the_patch_test_and_rule_4_nearly() {
    let size = [1.0, 0.8, 1.2];
    let (mut p, t) = box_mesh(2, size, 0.1, 0.0, 17);
    let (curved, _) = box_mesh(2, size, 0.1, 0.04, 17);
    for (x, c) in p.iter_mut().zip(curved) {
        if !on_boundary(x, size) {
            *x = c;
        }
    }
    let interior: Vec<usize> = (0..p.len())
        .filter(|&i| !on_boundary(&p[i], size))
        .collect();
    let exact = deformation(&p, &HOMOGENEOUS, 0.0, 0);
    let (name, law, d) = small_strain_cases().swap_remove(0);
    let inner = |f: &[f64]| {
        max_abs(interior.iter().flat_map(|&i| f[3 * i..3 * i + 3].to_vec()))
            / max_abs(f.iter().copied())
    };
    let mut measured = Vec::new();
    for (rule_name, rule) in [("RULE_4", RULE_4), ("RULE_14", RULE_14)] {
        let mut fs = QuadraticFiniteStrainAssembler::with_rule(&p, &t, rule).unwrap();
        let mut f = vec![0.0; fs.n_dofs()];
        let w = fs.internal_force(&exact, &[law], None, &mut f).unwrap();
        let w_exact = law.energy(&HOMOGENEOUS) * size.iter().product::<f64>();
        measured.push((inner(&f), (w - w_exact).abs() / w_exact));
        eprintln!(
            "P2 curved patch, {name}, {rule_name}: max|f interior| / max|f| = {:.1e}; |W - W(F) V| / W = {:.1e}",
            measured.last().unwrap().0,
            measured.last().unwrap().1
        );
    }
    let fs = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
    let mut kl = vec![0.0; fs.nnz()];
    fs.assembler()
        .stiffness_into(&p, &[d], None, &mut kl)
        .unwrap();
    let ku: Vec<f64> = dense(fs.assembler(), &kl)
        .iter()
        .map(|row| row.iter().zip(&exact).map(|(a, b)| a * b).sum())
        .collect();
    eprintln!(
        "P2 curved patch, linear P2 stiffness (RULE_4): max|(K u) interior| / max|K u| = {:.1e}",
        inner(&ku)
    );
    assert!(
        measured[1].0 < 1e-12 && measured[1].1 < 1e-12,
        "{measured:?}"
    );
    assert!(measured[0].0 < 1e-2 && measured[0].1 < 1e-4, "{measured:?}");
}
