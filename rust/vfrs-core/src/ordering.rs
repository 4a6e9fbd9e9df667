//! Nested-dissection fill-reducing ordering from the matrix graph alone.
//!
//! faer ships AMD only. On 3-D tetrahedral meshes AMD's factor has several times the fill of
//! nested dissection, so the factorization loses to CHOLMOD+METIS. This is George's automatic
//! nested dissection: from a pseudo-peripheral vertex, a breadth-first level structure; the
//! smallest level near the middle is the separator; the two sides are ordered first,
//! recursively, and the separator last. Small parts are ordered by reverse Cuthill-McKee
//! order of their BFS (a band), which is cheap and good enough at the leaves.

/// Parts at or below this size are not split further.
const LEAF: usize = 96;

/// Returns the elimination order (`order[k]` = the original index eliminated k-th) of the
/// symmetric graph given by a CSC pattern (`col_ptr`, `row_idx`; the diagonal and either
/// or both triangles may be present).
pub fn nested_dissection(n: usize, col_ptr: &[usize], row_idx: &[usize]) -> Vec<usize> {
    // Symmetrise the adjacency (no self loops) so that either triangle works.
    let mut deg = vec![0usize; n + 1];
    for j in 0..n {
        for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
            if i != j {
                deg[i + 1] += 1;
                deg[j + 1] += 1;
            }
        }
    }
    for i in 0..n {
        deg[i + 1] += deg[i];
    }
    let ptr = deg.clone();
    let mut fill = deg;
    let mut adj = vec![0usize; ptr[n]];
    for j in 0..n {
        for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
            if i != j {
                adj[fill[i]] = j;
                fill[i] += 1;
                adj[fill[j]] = i;
                fill[j] += 1;
            }
        }
    }
    // Duplicates (both triangles given) are harmless for BFS.
    let g = Graph { ptr, adj };
    let mut part = vec![0u32; n]; // which part a vertex currently belongs to
    let mut level = vec![u32::MAX; n];
    let mut order = Vec::with_capacity(n);
    let mut next_part = 1u32;
    let mut stack: Vec<(Vec<usize>, u32)> = vec![((0..n).collect(), 0)];
    // Explicit stack of (vertices, part id); separators are emitted after both halves, so
    // we emit in reverse and flip at the end.
    let mut reversed: Vec<usize> = Vec::with_capacity(n);
    let mut queue = Vec::new();
    while let Some((verts, pid)) = stack.pop() {
        if verts.len() <= LEAF {
            let band = g.bfs_order(&verts, pid, &part, &mut level, &mut queue);
            reversed.extend(band.iter().rev());
            continue;
        }
        let n_levels = g.levels(&verts, pid, &part, &mut level, &mut queue);
        if n_levels < 3 {
            let band = g.bfs_order(&verts, pid, &part, &mut level, &mut queue);
            reversed.extend(band.iter().rev());
            continue;
        }
        // Level sizes and the cumulative count; pick the smallest level whose cut leaves
        // each side with at least 30 % of the vertices.
        let mut size = vec![0usize; n_levels];
        for &v in &verts {
            size[levels_of(&level, v, n_levels)] += 1;
        }
        let total = verts.len();
        let mut best = None;
        let mut below = 0usize;
        for (l, &s) in size.iter().enumerate() {
            let above = total - below - s;
            if l > 0 && l + 1 < n_levels && below * 10 >= total * 3 && above * 10 >= total * 3 {
                if best.is_none_or(|(_, bs)| s < bs) {
                    best = Some((l, s));
                }
            }
            below += s;
        }
        let sep_level = match best {
            Some((l, _)) => l,
            None => {
                // Fall back to the median level.
                let mut acc = 0;
                let mut m = 1;
                for (l, &s) in size.iter().enumerate() {
                    acc += s;
                    if acc * 2 >= total {
                        m = l.clamp(1, n_levels - 2);
                        break;
                    }
                }
                m
            }
        };
        let (pa, pb) = (next_part, next_part + 1);
        next_part += 2;
        let mut a = Vec::new();
        let mut b = Vec::new();
        let mut sep = Vec::new();
        for &v in &verts {
            let l = levels_of(&level, v, n_levels);
            if l < sep_level {
                part[v] = pa;
                a.push(v);
            } else if l > sep_level {
                part[v] = pb;
                b.push(v);
            } else {
                part[v] = u32::MAX;
                sep.push(v);
            }
        }
        // Emitted in reverse: the separator goes last in the final order.
        reversed.extend(sep.iter().rev());
        stack.push((a, pa));
        stack.push((b, pb));
    }
    reversed.reverse();
    debug_assert_eq!(reversed.len(), n);
    order.extend(reversed);
    order
}

#[inline]
fn levels_of(level: &[u32], v: usize, n_levels: usize) -> usize {
    // Vertices in other components than the BFS root's were given the last level + 1;
    // they join the far side.
    (level[v] as usize).min(n_levels - 1)
}

struct Graph {
    ptr: Vec<usize>,
    adj: Vec<usize>,
}

impl Graph {
    /// BFS from `root` inside part `pid`; writes levels; returns the vertices reached in
    /// order and the number of levels.
    fn bfs(
        &self,
        root: usize,
        pid: u32,
        part: &[u32],
        level: &mut [u32],
        queue: &mut Vec<usize>,
    ) -> usize {
        queue.clear();
        queue.push(root);
        level[root] = 0;
        let mut head = 0;
        let mut max_level = 0;
        while head < queue.len() {
            let v = queue[head];
            head += 1;
            let lv = level[v];
            for &w in &self.adj[self.ptr[v]..self.ptr[v + 1]] {
                if part[w] == pid && level[w] == u32::MAX {
                    level[w] = lv + 1;
                    max_level = max_level.max(lv + 1);
                    queue.push(w);
                }
            }
        }
        max_level as usize + 1
    }

    fn reset(verts: &[usize], level: &mut [u32]) {
        for &v in verts {
            level[v] = u32::MAX;
        }
    }

    /// Level structure rooted at a pseudo-peripheral vertex (two sweeps). Vertices not
    /// reached (other components) get the level after the last.
    fn levels(
        &self,
        verts: &[usize],
        pid: u32,
        part: &[u32],
        level: &mut [u32],
        queue: &mut Vec<usize>,
    ) -> usize {
        Self::reset(verts, level);
        // Start from the vertex of minimum degree, then go to the farthest vertex twice.
        let mut root = verts[0];
        let mut n_levels = self.bfs(root, pid, part, level, queue);
        for _ in 0..2 {
            let far = *queue.last().unwrap_or(&root);
            if far == root {
                break;
            }
            Self::reset(verts, level);
            let nl = self.bfs(far, pid, part, level, queue);
            root = far;
            n_levels = nl;
        }
        for &v in verts {
            if level[v] == u32::MAX {
                level[v] = n_levels as u32;
            }
        }
        let reached_all = queue.len() == verts.len();
        if reached_all {
            n_levels
        } else {
            n_levels + 1
        }
    }

    /// Reverse Cuthill-McKee-like order of a small part: BFS order from a far vertex, every
    /// component included.
    fn bfs_order(
        &self,
        verts: &[usize],
        pid: u32,
        part: &[u32],
        level: &mut [u32],
        queue: &mut Vec<usize>,
    ) -> Vec<usize> {
        Self::reset(verts, level);
        let mut out = Vec::with_capacity(verts.len());
        for &v in verts {
            if level[v] == u32::MAX {
                self.bfs(v, pid, part, level, queue);
                out.extend_from_slice(queue);
            }
        }
        out.reverse();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let mut seen = vec![false; n];
        for &v in &order {
            assert!(!seen[v]);
            seen[v] = true;
        }
        assert!(seen.iter().all(|&s| s));
        // The last vertex eliminated separates the path into two long pieces.
        let last = order[n - 1];
        assert!(last > 200 && last < 800, "separator {last}");
    }

    #[test]
    fn disconnected_graph_is_fully_ordered() {
        let n = 500;
        let col_ptr: Vec<usize> = (0..=n).collect();
        let row_idx: Vec<usize> = (0..n).collect(); // diagonal only: no edges
        let order = nested_dissection(n, &col_ptr, &row_idx);
        let mut s = order.clone();
        s.sort_unstable();
        assert_eq!(s, (0..n).collect::<Vec<_>>());
    }
}
