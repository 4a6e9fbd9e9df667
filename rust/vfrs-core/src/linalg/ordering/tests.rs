//! Tests of the nested-dissection ordering.

use super::*;

fn is_perm(order: &[usize], n: usize) -> bool {
    let mut s = order.to_vec();
    s.sort_unstable();
    s == (0..n).collect::<Vec<_>>()
}

#[test]
fn order_is_a_permutation_with_separator_last() {
    // A path graph 0-1-2-...-999 (tridiagonal pattern, lower triangle only).
    let n = 1000;
    let mut col_ptr = vec![0];
    let mut row_idx = vec![];
    for j in 0..n {
        row_idx.push(j);
        if j + 1 < n {
            row_idx.push(j + 1);
        }
        col_ptr.push(row_idx.len());
    }
    let order = nested_dissection(n, &col_ptr, &row_idx);
    assert!(is_perm(&order, n));
    // The last vertex eliminated separates the path into two long pieces.
    let last = order[n - 1];
    assert!(last > 150 && last < 850, "separator {last}");
}

#[test]
fn disconnected_graph_is_fully_ordered() {
    let n = 500;
    let col_ptr: Vec<usize> = (0..=n).collect();
    let row_idx: Vec<usize> = (0..n).collect(); // diagonal only: no edges
    let order = nested_dissection(n, &col_ptr, &row_idx);
    assert!(is_perm(&order, n));
}

#[test]
fn blocks_of_three_are_compressed_and_kept_together() {
    // A path of 400 nodes with 3 DOFs each (dense 3x3 blocks, both triangles stored).
    let nodes: usize = 400;
    let n = 3 * nodes;
    let mut col_ptr = vec![0];
    let mut row_idx = vec![];
    for j in 0..n {
        let node = j / 3;
        let lo = node.saturating_sub(1) * 3;
        let hi = ((node + 2).min(nodes)) * 3;
        row_idx.extend(lo..hi);
        col_ptr.push(row_idx.len());
    }
    let g = Graph::symmetrise(n, &col_ptr, &row_idx);
    let (c, mptr, _) = g.compress();
    assert_eq!(c.n(), nodes);
    assert!((0..nodes).all(|k| mptr[k + 1] - mptr[k] == 3));
    let order = nested_dissection(n, &col_ptr, &row_idx);
    assert!(is_perm(&order, n));
    for k in (0..n).step_by(3) {
        let node = order[k] / 3;
        assert!(order[k + 1] / 3 == node && order[k + 2] / 3 == node);
    }
}

#[test]
fn factor_nnz_matches_faer_simplicial_symbolic() {
    use faer::perm::PermRef;
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering,
    };
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::Side;
    // A 12 x 12 grid of nodes with 8 neighbours each, 3 DOFs per node, a few DOFs fixed
    // (so weights differ), full symmetric pattern.
    let k = 12;
    let node = |x: usize, y: usize| x + k * y;
    let fixed = |d: usize| d == 0 || d == 4 || d == 5;
    let mut dof = vec![usize::MAX; 3 * k * k];
    let mut nf = 0;
    for (d, slot) in dof.iter_mut().enumerate() {
        if !fixed(d) {
            *slot = nf;
            nf += 1;
        }
    }
    let mut cols: Vec<Vec<usize>> = vec![Vec::new(); nf];
    for y in 0..k {
        for x in 0..k {
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1), (1, -1i64)] {
                let (x2, y2) = (x as i64 + dx, y as i64 + dy);
                if x2 < 0 || y2 < 0 || x2 >= k as i64 || y2 >= k as i64 {
                    continue;
                }
                let (a, b) = (node(x, y), node(x2 as usize, y2 as usize));
                for p in 0..3 {
                    for q in 0..3 {
                        let (i, j) = (dof[3 * a + p], dof[3 * b + q]);
                        if i != usize::MAX && j != usize::MAX {
                            cols[j].push(i);
                            cols[i].push(j);
                        }
                    }
                }
            }
        }
    }
    let mut cp = vec![0];
    let mut ri = vec![];
    for c in &mut cols {
        c.sort_unstable();
        c.dedup();
        ri.extend_from_slice(c);
        cp.push(ri.len());
    }
    let ((nd, nd_nnz), (amd, amd_nnz)) = nested_dissection_and_amd(nf, &cp, &ri);
    for (order, nnz) in [(nd, nd_nnz), (amd, amd_nnz)] {
        assert!(is_perm(&order, nf));
        let mut inv = vec![0; nf];
        for (p, &i) in order.iter().enumerate() {
            inv[i] = p;
        }
        let pat = SymbolicSparseColMatRef::new_checked(nf, nf, &cp, None, &ri);
        let sym = factorize_symbolic_cholesky(
            pat,
            Side::Lower,
            SymmetricOrdering::Custom(PermRef::new_checked(&order, &inv, nf)),
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(matches!(sym.raw(), SymbolicCholeskyRaw::Simplicial(_)));
        assert_eq!(nnz, sym.len_val());
    }
}
