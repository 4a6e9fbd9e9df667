//! The P2 finite-strain assembly does not allocate per call either (the per-quadrature-point
//! scratch is built once in `QuadraticFiniteStrainAssembler::new`). Counted with a global
//! allocator, so this lives in its own test binary.

#[path = "common/hyperelastic.rs"]
mod common;
#[path = "common/counting_alloc.rs"]
mod counting_alloc;

use common::grid;
use counting_alloc::ALLOCS;
use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use vfrs_core::fem::tet10::EDGES;
use vfrs_core::{
    FibreReinforced, HyperelasticMaterial, NeoHookean, QuadraticFiniteStrainAssembler,
};

/// Ten-node tetrahedra on the linear ones (mid-edge nodes at the midpoints).
fn elevate(mut p: Vec<[f64; 3]>, tets: &[[usize; 4]]) -> (Vec<[f64; 3]>, Vec<[usize; 10]>) {
    let mut mids = BTreeMap::new();
    let elems = tets
        .iter()
        .map(|t| {
            let mut el = [0usize; 10];
            el[..4].copy_from_slice(t);
            for (k, [a, b]) in EDGES.iter().enumerate() {
                let key = (t[*a].min(t[*b]), t[*a].max(t[*b]));
                el[4 + k] = *mids.entry(key).or_insert_with(|| {
                    p.push(std::array::from_fn(|c| 0.5 * (p[key.0][c] + p[key.1][c])));
                    p.len() - 1
                });
            }
            el
        })
        .collect();
    (p, elems)
}

#[test]
fn p2_force_tangent_and_energy_do_not_allocate_per_call() {
    let (p, t) = grid(3, [3.0, 3.0, 3.0]);
    let (p, t) = elevate(p, &t);
    let nh = NeoHookean::from_young(4e3, 0.45).unwrap();
    let laws = [
        HyperelasticMaterial::NeoHookean(nh),
        HyperelasticMaterial::FibreReinforced(
            FibreReinforced::new(nh, 9.5e3, 2.0, [0.0, 0.0, 1.0]).unwrap(),
        ),
    ];
    let material_of: Vec<usize> = (0..t.len()).map(|e| e % 2).collect();
    let mut fs = QuadraticFiniteStrainAssembler::new(&p, &t).unwrap();
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
        let _ = fs.last_stress(0).unwrap();
        counts.push(ALLOCS.load(Ordering::SeqCst) - before);
    }
    eprintln!("P2: allocations per 4 calls: {counts:?}");
    assert!(
        counts.iter().all(|&c| c == 0),
        "allocations per call: {counts:?}"
    );
}
