//! The contact detectors do not allocate per call once warmed up (their own buffers are
//! reused). Counted with a global allocator, so this lives in its own test binary.

#[path = "common/counting_alloc.rs"]
mod counting_alloc;

use counting_alloc::ALLOCS;
use std::sync::atomic::Ordering;
use vfrs_core::contact::{BvhEngine, InterfaceMesh, InterfaceMeshParams};

fn sheet(p: &mut Vec<[f64; 3]>, n: usize, x0: f64, plus: bool) -> Vec<[usize; 3]> {
    let off = p.len();
    let h = 1.0 / n as f64;
    for j in 0..=n {
        for i in 0..=n {
            p.push([x0, i as f64 * h, j as f64 * h]);
        }
    }
    let id = |i: usize, j: usize| off + j * (n + 1) + i;
    let mut t = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if plus {
                t.extend([[a, b, c], [a, c, d]]);
            } else {
                t.extend([[a, c, b], [a, d, c]]);
            }
        }
    }
    t
}

#[test]
fn detectors_do_not_allocate_per_call() {
    let mut p = Vec::new();
    let left = sheet(&mut p, 60, -0.01, true);
    let nl = p.len();
    let right = sheet(&mut p, 55, 0.01, false);
    let slaves: Vec<usize> = (nl..p.len()).collect();
    let areas = vec![1.0; slaves.len()];
    let mut det = BvhEngine::new(left.clone(), slaves, areas).unwrap();
    let params = InterfaceMeshParams {
        search_distance: 0.05,
        max_slip: 0.5,
    };
    let mut im = InterfaceMesh::build(&p, right, left, params).unwrap();
    let mut q = p.clone();
    // warm up: build the tree, first refit, grow the pair buffers to their working size
    for x in q.iter_mut().skip(nl) {
        x[0] -= 0.03;
    }
    for _ in 0..3 {
        det.detect(&q, 0.05).unwrap();
        im.detect(&q).unwrap();
    }
    let mut counts = Vec::new();
    for step in 0..10 {
        for x in q.iter_mut().skip(nl) {
            x[0] += 1e-4 * (step as f64 - 4.5);
        }
        let before = ALLOCS.load(Ordering::SeqCst);
        let n = det.detect(&q, 0.05).unwrap().len();
        let m = im.detect(&q).unwrap().len();
        im.inversion(&q).unwrap();
        counts.push(ALLOCS.load(Ordering::SeqCst) - before);
        assert!(n > 0 && m > 0);
    }
    // rayon's scheduler may allocate a queue block now and then; our buffers never do
    let total: usize = counts.iter().sum();
    eprintln!("allocations per call: {counts:?}");
    assert!(total <= 10, "allocations per call: {counts:?}");
}
