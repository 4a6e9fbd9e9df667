//! Helpers shared by the finite-strain test binaries (`hyperelastic`, `hyperelastic_newton`,
//! `hyperelastic_alloc`): meshes, laws, deformations. Each binary uses a part of them.
#![allow(dead_code)]

use vfrs_core::hyperelastic::Mat3;
use vfrs_core::{
    Assembler, FibreReinforced, HyperelasticMaterial, Material, NeoHookean, StVenantKirchhoff,
};

pub const E: f64 = 10e3;
pub const NU: f64 = 0.3;

pub fn vocal_fold() -> Material {
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
pub fn laws() -> Vec<(&'static str, HyperelasticMaterial)> {
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
pub fn grid(n: usize, size: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[usize; 4]>) {
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
                    let v =
                        vfrs_core::fem::mesh::signed_volume(&p[t[0]], &p[t[1]], &p[t[2]], &p[t[3]]);
                    tets.push(if v > 0.0 { t } else { [t[0], t[2], t[1], t[3]] });
                }
            }
        }
    }
    (p, tets)
}

/// Deterministic pseudo-random numbers in [-1, 1).
pub struct Lcg(pub u64);
impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// A slightly distorted grid (interior nodes moved), so that no element is special.
pub fn distorted_grid(n: usize, seed: u64) -> (Vec<[f64; 3]>, Vec<[usize; 4]>) {
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

pub fn dense(asm: &Assembler, v: &[f64]) -> Vec<Vec<f64>> {
    let n = asm.n_dofs();
    let mut m = vec![vec![0.0; n]; n];
    for (j, w) in asm.col_ptr().windows(2).enumerate() {
        for (&i, &x) in asm.row_idx()[w[0]..w[1]].iter().zip(&v[w[0]..w[1]]) {
            m[i][j] += x;
        }
    }
    m
}

pub fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Rotation by `angle` about the unit vector `n` (Rodrigues).
pub fn rotation(n: [f64; 3], angle: f64) -> Mat3 {
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

pub fn apply(r: &Mat3, x: &[f64; 3]) -> [f64; 3] {
    [
        r[0][0] * x[0] + r[0][1] * x[1] + r[0][2] * x[2],
        r[1][0] * x[0] + r[1][1] * x[1] + r[1][2] * x[2],
        r[2][0] * x[0] + r[2][1] * x[1] + r[2][2] * x[2],
    ]
}

/// u = (G - I) X + amp * random.
pub fn deformation(p: &[[f64; 3]], g: &Mat3, amp: f64, seed: u64) -> Vec<f64> {
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
pub const MODERATE: Mat3 = [[1.1, 0.08, -0.05], [0.04, 0.93, 0.06], [-0.03, 0.07, 1.25]];
