//! The dense kernels of the numeric factorization on one supernode's block: the update
//! products (`gemm_lower` and its micro-kernel) and the panel factorization (diagonal block,
//! rows below). Every entry is one chain of lane-wise operations fixed by the structure.
#![allow(clippy::needless_range_loop)]

use super::{KC, MV, NR};
use crate::linalg::cholesky::simd::Simd;

/// Rows first..first + m of C = A A[..nc]^T, on the tiles of the lower trapezoid (i ≥ j) of
/// the result, A being at least (first + m) x k at `a` with column stride `ld`; C (row i at
/// i - first) column-major with stride `ldc` (a multiple of the tile height). Each entry is
/// one fused multiply-add chain over k in increasing order from zero, whatever the blocking
/// (k blocks continue the chain through C) and whichever rows are computed with it.
///
/// Safety: `a` holds the operand, `c` ldc x ceil(nc / NR) NR values, `pa` MR x KC, `pb` nc
/// rounded up to NR times KC; nc <= NB (the buffers of [`Work`] then suffice).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn gemm_lower<S: Simd>(
    a: *const f64,
    ld: usize,
    first: usize,
    m: usize,
    nc: usize,
    k: usize,
    c: *mut f64,
    ldc: usize,
    pa: *mut f64,
    pb: *mut f64,
) {
    let mr = MV * S::W;
    let ntile = nc.div_ceil(NR);
    let mut k0 = 0;
    while k0 < k {
        let kc = (k - k0).min(KC);
        for t in 0..ntile {
            let dst = pb.add(t * NR * kc);
            for kk in 0..kc {
                let col = a.add((k0 + kk) * ld);
                for jj in 0..NR {
                    let j = t * NR + jj;
                    *dst.add(kk * NR + jj) = if j < nc { *col.add(j) } else { 0.0 };
                }
            }
        }
        let mut i0 = 0;
        while i0 < m {
            let tiles = nc.min(first + i0 + mr).div_ceil(NR);
            let (ap, sa) = if i0 + mr <= m && tiles <= 2 {
                (a.add(first + i0 + k0 * ld), ld)
            } else {
                for kk in 0..kc {
                    let col = a.add(first + i0 + (k0 + kk) * ld);
                    for ii in 0..mr {
                        *pa.add(kk * mr + ii) = if i0 + ii < m { *col.add(ii) } else { 0.0 };
                    }
                }
                (pa as *const f64, mr)
            };
            for t in 0..tiles {
                micro::<S>(
                    ap,
                    sa,
                    pb.add(t * NR * kc),
                    kc,
                    c.add(i0 + t * NR * ldc),
                    ldc,
                    k0 == 0,
                );
            }
            i0 += mr;
        }
        k0 += kc;
    }
}

/// One MV W x NR tile: `c (+)= Σ_kk a[.., kk] b[kk, ..]`, a with stride `sa` between columns,
/// b packed NR per kk; `first`: start from zero instead of c.
#[inline(always)]
unsafe fn micro<S: Simd>(
    a: *const f64,
    sa: usize,
    b: *const f64,
    kc: usize,
    c: *mut f64,
    ldc: usize,
    first: bool,
) {
    let mut acc = [[S::zero(); NR]; MV];
    if !first {
        for q in 0..MV {
            for jj in 0..NR {
                acc[q][jj] = S::load(c.add(jj * ldc + q * S::W));
            }
        }
    }
    for kk in 0..kc {
        let mut av = [S::zero(); MV];
        for q in 0..MV {
            av[q] = S::load(a.add(kk * sa + q * S::W));
        }
        for jj in 0..NR {
            let bv = S::splat(*b.add(kk * NR + jj));
            for q in 0..MV {
                acc[q][jj] = S::fmadd(av[q], bv, acc[q][jj]);
            }
        }
    }
    for q in 0..MV {
        for jj in 0..NR {
            S::store(c.add(jj * ldc + q * S::W), acc[q][jj]);
        }
    }
}

/// Factors the diagonal block of the panel of columns c0..c1 of a supernode block (values at
/// `ls`, column stride `nr`) whose updates from other columns are all applied, column by
/// column, each entry `(a_ij - Σ_{c0 ≤ k < j} l_ik l_jk) / l_jj` with k increasing (the same
/// operations in every lane, vector or scalar tail); [`rows_below`] then does the rows below
/// it. Returns the column of a non-positive or non-finite pivot.
///
/// Safety: `ls` holds nr x c1 values, c0 < c1 <= nr.
#[inline(always)]
pub(super) unsafe fn factor_diagonal<S: Simd>(
    ls: *mut f64,
    nr: usize,
    c0: usize,
    c1: usize,
) -> Result<(), usize> {
    let at = |i: usize, j: usize| ls.add(i + j * nr);
    for j in c0..c1 {
        let mut d = *at(j, j);
        for k in c0..j {
            let ljk = *at(j, k);
            d = S::fnmadd1(ljk, ljk, d);
        }
        if !(d > 0.0 && d.is_finite()) {
            return Err(j);
        }
        *at(j, j) = d.sqrt();
        // Rows below the pivot inside the diagonal block.
        let mut r = j + 1;
        while r + 4 * S::W <= c1 {
            col_rows::<S, 4>(ls, nr, r, j, c0);
            r += 4 * S::W;
        }
        while r + S::W <= c1 {
            col_rows::<S, 1>(ls, nr, r, j, c0);
            r += S::W;
        }
        while r < c1 {
            col_rows_scalar::<S>(ls, nr, r, j, c0);
            r += 1;
        }
    }
    Ok(())
}

/// Rows r0..r1 (below the diagonal block, c1 <= r0) of the panel's columns c0..c1, its
/// diagonal block factored: blocks of 8 vectors (independent chains), then 1, then scalar
/// rows; every row by the same operations wherever the range starts.
///
/// Safety: as [`factor_diagonal`], r1 <= nr.
#[inline(always)]
pub(super) unsafe fn rows_below<S: Simd>(
    ls: *mut f64,
    nr: usize,
    c0: usize,
    c1: usize,
    r0: usize,
    r1: usize,
) {
    let mut r = r0;
    while r + 8 * S::W <= r1 {
        for j in c0..c1 {
            col_rows::<S, 8>(ls, nr, r, j, c0);
        }
        r += 8 * S::W;
    }
    while r + S::W <= r1 {
        for j in c0..c1 {
            col_rows::<S, 1>(ls, nr, r, j, c0);
        }
        r += S::W;
    }
    while r < r1 {
        for j in c0..c1 {
            col_rows_scalar::<S>(ls, nr, r, j, c0);
        }
        r += 1;
    }
}

/// Rows r..r + RB W of column j: `l_ij = (a_ij - Σ_{c0 ≤ k < j} l_ik l_jk) / l_jj`, k increasing.
///
/// Safety: as [`factor_diagonal`]; the rows exist and l_jj is computed.
#[inline(always)]
unsafe fn col_rows<S: Simd, const RB: usize>(
    ls: *mut f64,
    nr: usize,
    r: usize,
    j: usize,
    c0: usize,
) {
    let at = |i: usize, j: usize| ls.add(i + j * nr);
    let mut v = [S::zero(); RB];
    for q in 0..RB {
        v[q] = S::load(at(r + q * S::W, j));
    }
    for k in c0..j {
        let b = S::splat(*at(j, k));
        for q in 0..RB {
            v[q] = S::fnmadd(S::load(at(r + q * S::W, k)), b, v[q]);
        }
    }
    let dj = S::splat(*at(j, j));
    for q in 0..RB {
        S::store(at(r + q * S::W, j), S::div(v[q], dj));
    }
}

/// One row of [`col_rows`] in scalar operations (the same ones as a vector lane).
///
/// Safety: as [`col_rows`].
#[inline(always)]
unsafe fn col_rows_scalar<S: Simd>(ls: *mut f64, nr: usize, r: usize, j: usize, c0: usize) {
    let at = |i: usize, j: usize| ls.add(i + j * nr);
    let mut v = *at(r, j);
    for k in c0..j {
        v = S::fnmadd1(*at(r, k), *at(j, k), v);
    }
    *at(r, j) = v / *at(j, j);
}
