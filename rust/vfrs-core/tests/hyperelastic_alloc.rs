//! The finite-strain assembly does not allocate per call (issue 14: the scratch is built once
//! in `FiniteStrainAssembler::new`). Counted with a global allocator, so this lives in its
//! own test binary.

#[path = "common/hyperelastic.rs"]
mod common;
#[path = "common/counting_alloc.rs"]
mod counting_alloc;

use common::grid;
use counting_alloc::ALLOCS;
use std::sync::atomic::Ordering;
use vfrs_core::{FibreReinforced, FiniteStrainAssembler, HyperelasticMaterial, NeoHookean};

#[test]
fn force_tangent_and_energy_do_not_allocate_per_call() {
    // A cube of 5 x 5 x 5 unit cubes, 6 tets each.
    let (p, t) = grid(5, [5.0, 5.0, 5.0]);
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
