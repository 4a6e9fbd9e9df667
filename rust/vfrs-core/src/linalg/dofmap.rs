//! Dirichlet conditions by elimination: a map from all DOFs to the free ones.

use crate::error::SolverError;

/// A reduced CSC pattern: (col_ptr, row_idx, source), `source[k]` being the index in the full
/// matrix's values of reduced entry k.
pub type ReducedPattern = (Vec<usize>, Vec<usize>, Vec<usize>);

/// Which DOFs are free, and where each lands in the reduced system.
#[derive(Debug, Clone)]
pub struct DofMap {
    n_dofs: usize,
    /// Free DOFs in increasing order.
    free: Vec<usize>,
    /// For each DOF, its index among the free ones, or `usize::MAX` if fixed.
    to_free: Vec<usize>,
}

impl DofMap {
    /// Builds the map from the fixed DOFs (duplicates allowed).
    pub fn new(n_dofs: usize, fixed: &[usize]) -> Result<Self, SolverError> {
        let mut is_fixed = vec![false; n_dofs];
        for &d in fixed {
            if d >= n_dofs {
                return Err(SolverError::DofOutOfRange { dof: d, n_dofs });
            }
            is_fixed[d] = true;
        }
        let mut to_free = vec![usize::MAX; n_dofs];
        let mut free = Vec::with_capacity(n_dofs);
        for d in 0..n_dofs {
            if !is_fixed[d] {
                to_free[d] = free.len();
                free.push(d);
            }
        }
        Ok(Self {
            n_dofs,
            free,
            to_free,
        })
    }

    /// Total number of DOFs.
    pub fn n_dofs(&self) -> usize {
        self.n_dofs
    }

    /// Free DOFs, increasing.
    pub fn free(&self) -> &[usize] {
        &self.free
    }

    /// Index among the free DOFs, or `None` if fixed.
    pub fn to_free(&self, dof: usize) -> Option<usize> {
        self.to_free.get(dof).copied().filter(|&k| k != usize::MAX)
    }

    /// The free-free block of a CSC matrix: its pattern and, for each of its entries, the
    /// index of the entry in the full matrix (so refilling is a gather).
    pub fn reduce_pattern(
        &self,
        col_ptr: &[usize],
        row_idx: &[usize],
    ) -> Result<ReducedPattern, SolverError> {
        crate::linalg::cholesky::check_pattern(self.n_dofs, col_ptr, row_idx)?;
        let mut cp = Vec::with_capacity(self.free.len() + 1);
        let mut ri = Vec::new();
        let mut src = Vec::new();
        cp.push(0);
        for &j in &self.free {
            let (lo, hi) = (col_ptr[j], col_ptr[j + 1]);
            for (k, &r) in (lo..hi).zip(&row_idx[lo..hi]) {
                let i = self.to_free[r];
                if i != usize::MAX {
                    ri.push(i);
                    src.push(k);
                }
            }
            cp.push(ri.len());
        }
        Ok((cp, ri, src))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reduces_to_the_free_block() {
        // 3x3 full matrix, fix DOF 1.
        let cp = [0, 3, 6, 9];
        let ri = [0, 1, 2, 0, 1, 2, 0, 1, 2];
        let m = DofMap::new(3, &[1, 1]).unwrap();
        assert_eq!(m.free(), &[0, 2]);
        assert_eq!(m.to_free(2), Some(1));
        assert_eq!(m.to_free(1), None);
        let (c, r, s) = m.reduce_pattern(&cp, &ri).unwrap();
        assert_eq!(c, vec![0, 2, 4]);
        assert_eq!(r, vec![0, 1, 0, 1]);
        assert_eq!(s, vec![0, 2, 6, 8]);
        assert!(DofMap::new(3, &[3]).is_err());
    }
}
