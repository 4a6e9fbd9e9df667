//! The fixed sparsity pattern of a mesh's 3-DOF-per-node matrices, for elements of any number
//! of nodes (the P1 tetrahedron's 4, the P2 tetrahedron's 10), and the parallel fill over
//! node columns that [`crate::fem::assembly`] and [`crate::fem::quadratic`] share.
//!
//! The pattern is built once from the connectivity: node adjacency expanded to 3x3 dense
//! blocks, so column `3j + c` holds rows `3i + r` for every neighbour `i` of node `j` (sorted).
//! Values are then filled in place, in parallel over node columns: each node column is
//! written by exactly one task, which visits the elements around that node. No atomics, no
//! per-call allocation.

use crate::error::{MaterialError, MeshError};
use rayon::prelude::*;

/// Fixed sparsity pattern and the maps needed to fill it.
#[derive(Debug, Clone)]
pub struct Pattern {
    pub(crate) n_nodes: usize,
    pub(crate) n_elements: usize,
    /// Node adjacency (CSC over nodes, self included, sorted).
    pub(crate) node_ptr: Vec<usize>,
    pub(crate) node_adj: Vec<usize>,
    /// Elements around each node, with the node's local index in the element.
    pub(crate) elem_ptr: Vec<usize>,
    pub(crate) elem_of_node: Vec<(usize, u8)>,
    /// DOF-level CSC pattern.
    pub(crate) col_ptr: Vec<usize>,
    pub(crate) row_idx: Vec<usize>,
}

/// Shares a mutable buffer between tasks that write disjoint ranges.
#[derive(Clone, Copy)]
struct SyncPtr(*mut f64);
unsafe impl Send for SyncPtr {}
unsafe impl Sync for SyncPtr {}

impl SyncPtr {
    /// The pointer. A method, so that a closure using it captures the whole `SyncPtr` (which
    /// is `Sync`), not its raw-pointer field (which is not).
    fn get(self) -> *mut f64 {
        self.0
    }
}

impl Pattern {
    /// Builds the pattern for `n_nodes` nodes and elements of `N` nodes each (every index
    /// must be below `n_nodes`: the first that is not is an error naming its element).
    pub fn new<const N: usize>(n_nodes: usize, elems: &[[usize; N]]) -> Result<Self, MeshError> {
        for (t, elem) in elems.iter().enumerate() {
            for &i in elem {
                if i >= n_nodes {
                    return Err(MeshError::IndexOutOfRange {
                        tet: t,
                        index: i as i64,
                        n_points: n_nodes,
                    });
                }
            }
        }
        // Elements around each node.
        let mut count = vec![0usize; n_nodes + 1];
        for elem in elems {
            for &i in elem {
                count[i + 1] += 1;
            }
        }
        for i in 0..n_nodes {
            count[i + 1] += count[i];
        }
        let elem_ptr = count.clone();
        let mut fill = count;
        let mut elem_of_node = vec![(0usize, 0u8); elem_ptr[n_nodes]];
        for (e, elem) in elems.iter().enumerate() {
            for (a, &i) in elem.iter().enumerate() {
                elem_of_node[fill[i]] = (e, a as u8);
                fill[i] += 1;
            }
        }
        // Node adjacency: union of the nodes of the elements around each node.
        let adj_lists: Vec<Vec<usize>> = (0..n_nodes)
            .into_par_iter()
            .map(|j| {
                let mut v: Vec<usize> = elem_of_node[elem_ptr[j]..elem_ptr[j + 1]]
                    .iter()
                    .flat_map(|&(e, _)| elems[e])
                    .collect();
                v.push(j);
                v.sort_unstable();
                v.dedup();
                v
            })
            .collect();
        let mut node_ptr = Vec::with_capacity(n_nodes + 1);
        node_ptr.push(0);
        for l in &adj_lists {
            node_ptr.push(node_ptr.last().copied().unwrap_or(0) + l.len());
        }
        let node_adj: Vec<usize> = adj_lists.into_iter().flatten().collect();
        // DOF pattern.
        let mut col_ptr = Vec::with_capacity(3 * n_nodes + 1);
        let mut row_idx = Vec::with_capacity(9 * node_adj.len());
        col_ptr.push(0);
        for j in 0..n_nodes {
            let nb = &node_adj[node_ptr[j]..node_ptr[j + 1]];
            for _c in 0..3 {
                for &i in nb {
                    row_idx.extend_from_slice(&[3 * i, 3 * i + 1, 3 * i + 2]);
                }
                col_ptr.push(row_idx.len());
            }
        }
        Ok(Self {
            n_nodes,
            n_elements: elems.len(),
            node_ptr,
            node_adj,
            elem_ptr,
            elem_of_node,
            col_ptr,
            row_idx,
        })
    }

    /// Checks a fill's inputs: one point per node, `values` the pattern's length, at least
    /// one material, and `material_of` (one per element) naming existing materials.
    pub(crate) fn check_inputs(
        &self,
        points: &[[f64; 3]],
        n_materials: usize,
        material_of: Option<&[usize]>,
        values: &[f64],
    ) -> Result<(), MaterialError> {
        self.check_points(points)?;
        if values.len() != self.nnz() {
            return Err(MaterialError::BadLength {
                what: "values",
                expected: self.nnz(),
                got: values.len(),
            });
        }
        self.check_materials(n_materials, material_of)
    }

    /// [`Pattern::check_inputs`] without a `values` array (a lumped mass, a vector).
    pub(crate) fn check_body(
        &self,
        points: &[[f64; 3]],
        n_materials: usize,
        material_of: Option<&[usize]>,
    ) -> Result<(), MaterialError> {
        self.check_points(points)?;
        self.check_materials(n_materials, material_of)
    }

    fn check_points(&self, points: &[[f64; 3]]) -> Result<(), MaterialError> {
        if points.len() != self.n_nodes {
            return Err(MaterialError::BadLength {
                what: "points",
                expected: self.n_nodes,
                got: points.len(),
            });
        }
        Ok(())
    }

    fn check_materials(
        &self,
        n_materials: usize,
        material_of: Option<&[usize]>,
    ) -> Result<(), MaterialError> {
        if n_materials == 0 {
            return Err(MaterialError::BadLength {
                what: "materials",
                expected: 1,
                got: 0,
            });
        }
        match material_of {
            Some(m) => {
                if m.len() != self.n_elements {
                    return Err(MaterialError::BadLength {
                        what: "material_of",
                        expected: self.n_elements,
                        got: m.len(),
                    });
                }
                if let Some((element, &index)) =
                    m.iter().enumerate().find(|(_, &k)| k >= n_materials)
                {
                    return Err(MaterialError::BadMaterialIndex {
                        element,
                        index,
                        n_materials,
                    });
                }
            }
            None if n_materials != 1 => {
                return Err(MaterialError::BadLength {
                    what: "materials (no material_of given)",
                    expected: 1,
                    got: n_materials,
                });
            }
            None => {}
        }
        Ok(())
    }

    /// [`Pattern::check_inputs`] for a mass fill, and every density positive and finite.
    pub(crate) fn check_densities(
        &self,
        points: &[[f64; 3]],
        rho: &[f64],
        material_of: Option<&[usize]>,
        values: &[f64],
    ) -> Result<(), MaterialError> {
        self.check_inputs(points, rho.len(), material_of, values)?;
        match rho.iter().find(|r| !(**r > 0.0 && r.is_finite())) {
            Some(&value) => Err(MaterialError::NotPositive { name: "rho", value }),
            None => Ok(()),
        }
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// The elements around node `j`, each with the node's local index in it, in increasing
    /// element order.
    pub(crate) fn elements_around(&self, j: usize) -> &[(usize, u8)] {
        &self.elem_of_node[self.elem_ptr[j]..self.elem_ptr[j + 1]]
    }

    /// For every node column, in parallel: zero it, then add for each element `e` around
    /// node `j` (local index `a`) the 3x3 blocks `block(e, a)` of the element's nodes `elems[e]`.
    pub(crate) fn fill<const N: usize, F>(
        &self,
        elems: &[[usize; N]],
        values: &mut [f64],
        block: F,
    ) -> Result<(), MeshError>
    where
        F: Fn(usize, usize) -> Result<[[[f64; 3]; 3]; N], MeshError> + Sync,
    {
        let ptr = SyncPtr(values.as_mut_ptr());
        (0..self.n_nodes).into_par_iter().try_for_each(|j| {
            let lo = self.node_ptr[j];
            let nb = &self.node_adj[lo..self.node_ptr[j + 1]];
            let deg = nb.len();
            let base = 9 * lo;
            // SAFETY: node column j owns values[9*node_ptr[j] .. 9*node_ptr[j+1]], disjoint
            // from every other node column; the slice lives for the whole call.
            let col: &mut [f64] =
                unsafe { std::slice::from_raw_parts_mut(ptr.get().add(base), 9 * deg) };
            col.fill(0.0);
            for &(e, a) in self.elements_around(j) {
                let t = &elems[e];
                let blocks = block(e, a as usize)?;
                for (b, blk) in blocks.iter().enumerate() {
                    // The neighbour is in the list by construction.
                    let k = nb.binary_search(&t[b]).unwrap_or(0);
                    for c in 0..3 {
                        for r in 0..3 {
                            col[c * 3 * deg + 3 * k + r] += blk[r][c];
                        }
                    }
                }
            }
            Ok(())
        })
    }
}
