//! Building the [`Plan`] once per pattern: where A's entries go in L, which descendants
//! update which supernode, the supernodal elimination tree and its postorder.

use super::{Plan, Work};
use crate::linalg::cholesky::symbolic::Supernodes;
use std::sync::Mutex;

impl Plan {
    /// Builds the plan for the validated supernodal structure `sn` of an n x n matrix whose
    /// CSC pattern is (`col_ptr`, `row_idx`) (both triangles; the lower one is read), with
    /// `inv[i]` the permuted index of original index i (None: identity). Returns None if A
    /// has an entry outside L's structure or an update would leave its target's rows (a
    /// structure faer would not produce; the kernels index without checks on these facts).
    pub(in crate::linalg::cholesky) fn new(
        sn: &Supernodes<'_>,
        n: usize,
        max_nr: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        inv: Option<&[usize]>,
        threads: usize,
    ) -> Option<Self> {
        let ns = sn.begin.len();
        let mut sn_of = vec![0; n];
        for s in 0..ns {
            sn_of[sn.begin[s]..sn.end[s]].fill(s);
        }
        let (a_ptr, a_src, a_dst) = scatter_plan(sn, n, col_ptr, row_idx, inv, &sn_of)?;
        let (parent, upd_ptr, upd) = descendant_updates(sn, &sn_of);
        if !updates_stay_in_targets(sn, n, &upd_ptr, &upd) {
            return None;
        }
        let (child_ptr, child, roots) = children(&parent);
        let (post, post_pos, first_post) = postorder(&child_ptr, &child, &roots);
        let subtree_work = subtree_work(sn, &parent);
        // Every update must come from the target's subtree, factored before it.
        let postordered = post.len() == ns
            && (0..ns).all(|s| {
                upd[upd_ptr[s]..upd_ptr[s + 1]]
                    .iter()
                    .all(|&[d, _, _]| first_post[s] <= post_pos[d] && post_pos[d] < post_pos[s])
            });
        let slots = if threads > 1 && postordered {
            threads + 1
        } else {
            1
        };
        Some(Self {
            a_ptr,
            a_src,
            a_dst,
            upd_ptr,
            upd,
            parent,
            child_ptr,
            child,
            roots,
            post,
            post_pos,
            first_post,
            subtree_work,
            postordered,
            work: Mutex::new((0..slots).map(|_| Work::new(n, max_nr)).collect()),
            slots,
            n,
            max_nr,
        })
    }
}

/// The off-diagonal row indices of supernode s (its pattern below the diagonal block).
fn pattern<'a>(sn: &'a Supernodes<'_>, s: usize) -> &'a [usize] {
    &sn.row_idx[sn.row_ptr[s]..sn.row_ptr[s + 1]]
}

/// Where A's lower triangle goes, by destination supernode (counting sort, stable): for
/// supernode s, `a_src[a_ptr[s]..a_ptr[s + 1]]` index A's values and `a_dst` the positions
/// in L's values. None if an entry falls outside L's structure.
fn scatter_plan(
    sn: &Supernodes<'_>,
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    inv: Option<&[usize]>,
    sn_of: &[usize],
) -> Option<(Vec<usize>, Vec<usize>, Vec<usize>)> {
    let ns = sn.begin.len();
    let mut a_ptr = vec![0; ns + 1];
    let mut entries = Vec::with_capacity(row_idx.len() / 2 + n);
    for j in 0..n {
        for k in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[k];
            if i < j {
                continue;
            }
            let (pi, pj) = match inv {
                Some(p) => (p[i], p[j]),
                None => (i, j),
            };
            let (r, c) = (pi.max(pj), pi.min(pj));
            let s = sn_of[c];
            let (f, l) = (sn.begin[s], sn.end[s]);
            let pat = pattern(sn, s);
            let lr = if r < l {
                r - f
            } else {
                (l - f) + pat.binary_search(&r).ok()?
            };
            let nr = (l - f) + pat.len();
            entries.push((s, k, sn.val_ptr[s] + (c - f) * nr + lr));
            a_ptr[s + 1] += 1;
        }
    }
    for s in 0..ns {
        a_ptr[s + 1] += a_ptr[s];
    }
    let mut next = a_ptr.clone();
    let (mut a_src, mut a_dst) = (vec![0; entries.len()], vec![0; entries.len()]);
    for (s, k, dst) in entries {
        a_src[next[s]] = k;
        a_dst[next[s]] = dst;
        next[s] += 1;
    }
    Some((a_ptr, a_src, a_dst))
}

/// Descendant updates, by target (stable in d), and the supernodal elimination tree:
/// (parent, `upd_ptr`, `upd`) as in [`Plan`].
fn descendant_updates(
    sn: &Supernodes<'_>,
    sn_of: &[usize],
) -> (Vec<usize>, Vec<usize>, Vec<[usize; 3]>) {
    let ns = sn.begin.len();
    let mut parent = vec![usize::MAX; ns];
    let mut pairs = vec![];
    let mut upd_ptr = vec![0; ns + 1];
    for d in 0..ns {
        let pat = pattern(sn, d);
        let mut p = 0;
        while p < pat.len() {
            let s = sn_of[pat[p]];
            let mut q = p;
            while q < pat.len() && pat[q] < sn.end[s] {
                q += 1;
            }
            if p == 0 {
                parent[d] = s;
            }
            pairs.push((s, [d, p, q]));
            upd_ptr[s + 1] += 1;
            p = q;
        }
    }
    for s in 0..ns {
        upd_ptr[s + 1] += upd_ptr[s];
    }
    let mut next = upd_ptr.clone();
    let mut upd = vec![[0; 3]; pairs.len()];
    for (s, u) in pairs {
        upd[next[s]] = u;
        next[s] += 1;
    }
    (parent, upd_ptr, upd)
}

/// Whether every row an update brings is a row of its target.
fn updates_stay_in_targets(
    sn: &Supernodes<'_>,
    n: usize,
    upd_ptr: &[usize],
    upd: &[[usize; 3]],
) -> bool {
    let mut mark = vec![usize::MAX; n];
    for s in 0..sn.begin.len() {
        mark[sn.begin[s]..sn.end[s]].fill(s);
        for &r in pattern(sn, s) {
            mark[r] = s;
        }
        for &[d, p1, _] in &upd[upd_ptr[s]..upd_ptr[s + 1]] {
            if pattern(sn, d)[p1..].iter().any(|&r| mark[r] != s) {
                return false;
            }
        }
    }
    true
}

/// The children of each node of the tree `parent` (CSR: `child_ptr`, `child`) and its roots.
fn children(parent: &[usize]) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
    let ns = parent.len();
    let mut child_ptr = vec![0; ns + 1];
    let mut roots = vec![];
    for s in 0..ns {
        match parent[s] {
            usize::MAX => roots.push(s),
            p => child_ptr[p + 1] += 1,
        }
    }
    for s in 0..ns {
        child_ptr[s + 1] += child_ptr[s];
    }
    let mut next = child_ptr.clone();
    let mut child = vec![0; ns - roots.len()];
    for s in 0..ns {
        if parent[s] != usize::MAX {
            child[next[parent[s]]] = s;
            next[parent[s]] += 1;
        }
    }
    (child_ptr, child, roots)
}

/// Postorder (children in increasing order, iteratively: etrees can be deep): (post,
/// `post_pos`, `first_post`); the subtree of s is `post[first_post[s]..=post_pos[s]]`.
fn postorder(
    child_ptr: &[usize],
    child: &[usize],
    roots: &[usize],
) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
    let ns = child_ptr.len() - 1;
    let mut post = Vec::with_capacity(ns);
    let mut post_pos = vec![0; ns];
    let mut first_post = vec![0; ns];
    let mut stack: Vec<(usize, usize)> = roots.iter().rev().map(|&r| (r, 0)).collect();
    while let Some((s, i)) = stack.pop() {
        if i == 0 {
            first_post[s] = post.len();
        }
        let kids = &child[child_ptr[s]..child_ptr[s + 1]];
        if i < kids.len() {
            stack.push((s, i + 1));
            stack.push((kids[i], 0));
        } else {
            post_pos[s] = post.len();
            post.push(s);
        }
    }
    (post, post_pos, first_post)
}

/// Estimated multiply-adds of each subtree (own block and updates it sends).
fn subtree_work(sn: &Supernodes<'_>, parent: &[usize]) -> Vec<f64> {
    let ns = sn.begin.len();
    let mut subtree_work = vec![0.0; ns];
    for s in 0..ns {
        let w = (sn.end[s] - sn.begin[s]) as f64;
        let nr = w + pattern(sn, s).len() as f64;
        subtree_work[s] += w * nr * nr;
        if parent[s] != usize::MAX {
            subtree_work[parent[s]] += subtree_work[s];
        }
    }
    subtree_work
}
