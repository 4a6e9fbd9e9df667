//! Sparse and dense linear algebra: the sparse Cholesky ([`cholesky`]) with its
//! fill-reducing [`ordering`], Dirichlet elimination ([`dofmap`]), products with compliance
//! columns and the Delassus operator ([`compliance`]), node-blocked sparse products
//! ([`spmv`]) and the small dense kernels of the contact problems ([`dense`]).

pub mod cholesky;
pub mod compliance;
pub mod dense;
pub mod dofmap;
pub mod error;
pub mod ordering;
pub mod spmv;
