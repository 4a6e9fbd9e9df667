//! What the unit tests of the element kernels and assemblies share: the unit cube of six
//! tetrahedra and the two tissues (an isotropic nearly incompressible one and the `vocal_fold`
//! transversely isotropic one).

use crate::fem::material::{Elasticity, Material};

/// The unit cube split into 6 tetrahedra (Kuhn), positively oriented.
pub(crate) fn cube() -> (Vec<[f64; 3]>, Vec<[usize; 4]>) {
    let mut p = Vec::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..2 {
                p.push([i as f64, j as f64, k as f64]);
            }
        }
    }
    let tets = vec![
        [0, 1, 3, 7],
        [0, 1, 7, 5],
        [0, 5, 7, 4],
        [0, 3, 2, 7],
        [0, 2, 6, 7],
        [0, 6, 4, 7],
    ];
    let mut t2 = Vec::new();
    for t in tets {
        let v = crate::fem::mesh::signed_volume(&p[t[0]], &p[t[1]], &p[t[2]], &p[t[3]]);
        t2.push(if v > 0.0 { t } else { [t[0], t[2], t[1], t[3]] });
    }
    (p, t2)
}

/// Isotropic E = 30 kPa, nu = 0.45, and the `vocal_fold` tissue (E_p 2 kPa, E_z 40 kPa,
/// nu_p 0.9, G_pz 10 kPa, fibres along z).
pub(crate) fn tissues() -> Vec<Elasticity> {
    vec![
        Material::Isotropic { e: 3.0e4, nu: 0.45 }
            .elasticity()
            .unwrap(),
        Material::TransverselyIsotropic {
            e_p: 2.0e3,
            e_z: 4.0e4,
            nu_p: 0.9,
            nu_pz: 0.0,
            g_pz: 1.0e4,
            axis: [0.0, 0.0, 1.0],
        }
        .elasticity()
        .unwrap(),
    ]
}
