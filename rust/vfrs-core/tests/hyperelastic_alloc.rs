//! The finite-strain assembly does not allocate per call (issue 14: the scratch is built once
//! in `FiniteStrainAssembler::new`). Counted with a global allocator, so this lives in its
//! own test binary.

#[path = "common/counting_alloc.rs"]
mod counting_alloc;

use counting_alloc::ALLOCS;
use std::sync::atomic::Ordering;
use vfrs_core::{FibreReinforced, FiniteStrainAssembler, HyperelasticMaterial, NeoHookean};

#[test]
fn force_tangent_and_energy_do_not_allocate_per_call() {
    // A column of 5 x 5 x 5 cubes, 6 tets each.
    let n = 5;
    let m = n + 1;
    let id = |i: usize, j: usize, k: usize| i + m * (j + m * k);
    let mut p = Vec::new();
    for k in 0..m {
        for j in 0..m {
            for i in 0..m {
                p.push([i as f64, j as f64, k as f64]);
            }
        }
    }
    let mut t = Vec::new();
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
                for l in [
                    [0, 1, 3, 7],
                    [0, 1, 7, 5],
                    [0, 5, 7, 4],
                    [0, 3, 2, 7],
                    [0, 2, 6, 7],
                    [0, 6, 4, 7],
                ] {
                    let tet = [c[l[0]], c[l[1]], c[l[2]], c[l[3]]];
                    let v = vfrs_core::mesh::signed_volume(
                        &p[tet[0]], &p[tet[1]], &p[tet[2]], &p[tet[3]],
                    );
                    t.push(if v > 0.0 {
                        tet
                    } else {
                        [tet[0], tet[2], tet[1], tet[3]]
                    });
                }
            }
        }
    }
    let nh = NeoHookean::from_young(4e3, 0.45).unwrap();
    let laws = [
        HyperelasticMaterial::NeoHookean(nh),
        HyperelasticMaterial::FibreReinforced(
            FibreReinforced::new(nh, 9.5e3, 2.0, [0.0, 0.0, 1.0]).unwrap(),
        ),
    ];
    let material_of: Vec<usize> = (0..t.len()).map(|e| e % 2).collect();
    let mut fs = FiniteStrainAssembler::new(&p, &t).unwrap();
    let mut u: Vec<f64> = p
        .iter()
        .flat_map(|x| [0.02 * x[1], -0.01 * x[0], 0.1 * x[2]])
        .collect();
    let mut f = vec![0.0; fs.n_dofs()];
    let mut k = vec![0.0; fs.nnz()];
    // Warm up (the global thread pool starts here).
    fs.force_and_tangent(&u, &laws, Some(&material_of), &mut f, &mut k)
        .unwrap();
    let mut counts = Vec::new();
    for step in 0..5 {
        u.iter_mut().for_each(|x| *x *= 1.0 + 0.01 * step as f64);
        let before = ALLOCS.load(Ordering::SeqCst);
        fs.force_and_tangent(&u, &laws, Some(&material_of), &mut f, &mut k)
            .unwrap();
        fs.internal_force(&u, &laws, Some(&material_of), &mut f)
            .unwrap();
        fs.tangent_into(&u, &laws, Some(&material_of), &mut k)
            .unwrap();
        fs.energy(&u, &laws, Some(&material_of)).unwrap();
        counts.push(ALLOCS.load(Ordering::SeqCst) - before);
    }
    eprintln!("allocations per 4 calls: {counts:?}");
    assert!(
        counts.iter().all(|&c| c == 0),
        "allocations per call: {counts:?}"
    );
}
