//! Triangular solves with a supernodal factor, written for this crate's use: any number of
//! right-hand sides, supernode by supernode, each supernode's block read from memory once per
//! pass for all of them and applied to groups of up to four.
//!
//! faer's own supernodal solve calls its general matmul per supernode: fine for many
//! right-hand sides, but with one or two the per-call overhead and the packing dominate on
//! FEM factors, whose supernodes are mostly narrow; and its kernels depend on the CPU. Here
//! each supernode is swept in panels of 8 columns with fused kernels (AVX2 + FMA when the CPU
//! has them, chosen at run time; plain scalar code otherwise): forward, the panel's small
//! triangle and then `e -= L_panel x_panel` over the rows below it; backward, the dot
//! products `L_panel^T e` and then the small transposed triangle. `e` is the supernode's
//! rows gathered into a dense vector, as in CHOLMOD's supernodal solve.
//!
//! The operations applied to one right-hand side do not depend on how many are solved with
//! it nor on its position among them (panels are 8 columns wide whatever their number; only
//! the register blocking changes): batching never changes a result's bits.
#![allow(clippy::needless_range_loop)]

#[cfg(target_arch = "x86_64")]
use super::simd::Avx2;
use super::simd::{Scalar, Simd};
use super::symbolic::Supernodes;

/// Forward step on the columns c0..c0+Q of a supernode (values at `l`, column stride
/// `nr`) for R right-hand sides, the j-th gathered at `e[j * nr..(j + 1) * nr]`.
///
/// Safety: `l` holds nr * (c0 + Q) values, `e` holds R * nr, c0 + Q <= nr.
#[inline(always)]
unsafe fn fwd_panel<S: Simd, const Q: usize, const R: usize>(
    l: *const f64,
    nr: usize,
    c0: usize,
    e: *mut f64,
) {
    for j in 0..R {
        let e = e.add(j * nr);
        for q in 0..Q {
            let c = c0 + q;
            let col = l.add(c * nr);
            let xc = *e.add(c) / *col.add(c);
            *e.add(c) = xc;
            for r in c + 1..c0 + Q {
                *e.add(r) = S::fnmadd1(*col.add(r), xc, *e.add(r));
            }
        }
    }
    let mut a = [[0.0; R]; Q];
    let mut av = [[S::zero(); R]; Q];
    for q in 0..Q {
        for j in 0..R {
            a[q][j] = *e.add(j * nr + c0 + q);
            av[q][j] = S::splat(a[q][j]);
        }
    }
    let cols = l.add(c0 * nr);
    let mut r = c0 + Q;
    while r + S::W <= nr {
        let mut v = [S::zero(); R];
        for j in 0..R {
            v[j] = S::load(e.add(j * nr + r));
        }
        for q in 0..Q {
            let lv = S::load(cols.add(q * nr + r));
            for j in 0..R {
                v[j] = S::fnmadd(lv, av[q][j], v[j]);
            }
        }
        for j in 0..R {
            S::store(e.add(j * nr + r), v[j]);
        }
        r += S::W;
    }
    while r < nr {
        for j in 0..R {
            let mut v = *e.add(j * nr + r);
            for q in 0..Q {
                v = S::fnmadd1(*cols.add(q * nr + r), a[q][j], v);
            }
            *e.add(j * nr + r) = v;
        }
        r += 1;
    }
}

/// Dot products `d[q][j] = Σ_{r ≥ r0} L[r, q0 + q] e_j[r]` for the QB columns from q0 of
/// a backward panel (columns at `cols`, stride `nr`) and R right-hand sides; stored at
/// `d[(q0 + q) * R + j]`. Each product's operations do not depend on QB or R: lane-wise
/// FMA over the vector rows from r0, the fixed horizontal sum, then the scalar rows.
///
/// Safety: as [`bwd_panel`].
#[inline(always)]
unsafe fn bwd_dots<S: Simd, const QB: usize, const R: usize>(
    cols: *const f64,
    nr: usize,
    r0: usize,
    e: *const f64,
    d: &mut [f64; 8 * 4],
    q0: usize,
) {
    let mut acc = [[S::zero(); R]; QB];
    let mut r = r0;
    while r + S::W <= nr {
        let mut ev = [S::zero(); R];
        for j in 0..R {
            ev[j] = S::load(e.add(j * nr + r));
        }
        for q in 0..QB {
            let lv = S::load(cols.add((q0 + q) * nr + r));
            for j in 0..R {
                acc[q][j] = S::fmadd(lv, ev[j], acc[q][j]);
            }
        }
        r += S::W;
    }
    let mut dd = [[0.0; R]; QB];
    for q in 0..QB {
        for j in 0..R {
            dd[q][j] = S::hsum(acc[q][j]);
        }
    }
    while r < nr {
        for q in 0..QB {
            let lq = *cols.add((q0 + q) * nr + r);
            for j in 0..R {
                dd[q][j] = S::fmadd1(lq, *e.add(j * nr + r), dd[q][j]);
            }
        }
        r += 1;
    }
    for q in 0..QB {
        for j in 0..R {
            d[(q0 + q) * R + j] = dd[q][j];
        }
    }
}

/// Backward step on the columns c0..c0+Q (same layout and safety as [`fwd_panel`]). The
/// dot products are computed up to `S::ACC / R` columns at a time (that many accumulators
/// in registers: one pass over the rows for one right-hand side, as before the panel width
/// was fixed); the grouping changes no operation.
#[inline(always)]
unsafe fn bwd_panel<S: Simd, const Q: usize, const R: usize>(
    l: *const f64,
    nr: usize,
    c0: usize,
    e: *mut f64,
) {
    let cols = l.add(c0 * nr);
    let mut d = [0.0; 8 * 4];
    let cap = (S::ACC / R).max(1);
    let mut q0 = 0;
    while q0 < Q {
        let rem = Q - q0;
        let qb = rem.min(cap);
        match qb {
            8 => bwd_dots::<S, 8, R>(cols, nr, c0 + Q, e, &mut d, q0),
            7 => bwd_dots::<S, 7, R>(cols, nr, c0 + Q, e, &mut d, q0),
            6 => bwd_dots::<S, 6, R>(cols, nr, c0 + Q, e, &mut d, q0),
            5 => bwd_dots::<S, 5, R>(cols, nr, c0 + Q, e, &mut d, q0),
            4 => bwd_dots::<S, 4, R>(cols, nr, c0 + Q, e, &mut d, q0),
            3 => bwd_dots::<S, 3, R>(cols, nr, c0 + Q, e, &mut d, q0),
            2 => bwd_dots::<S, 2, R>(cols, nr, c0 + Q, e, &mut d, q0),
            _ => bwd_dots::<S, 1, R>(cols, nr, c0 + Q, e, &mut d, q0),
        }
        q0 += qb;
    }
    for j in 0..R {
        let e = e.add(j * nr);
        for q in (0..Q).rev() {
            let c = c0 + q;
            let col = l.add(c * nr);
            let mut v = *e.add(c) - d[q * R + j];
            for rr in c + 1..c0 + Q {
                v = S::fnmadd1(*col.add(rr), *e.add(rr), v);
            }
            *e.add(c) = v / *col.add(c);
        }
    }
}

/// Forward and backward panels are 8 columns wide for every number of right-hand sides,
/// so that a column's operations do not depend on how many are solved with it.
macro_rules! panel {
    ($f:ident, $S:ty, $R:tt, $q:expr, $($arg:expr),*) => {
        match $q {
            8 => $f::<$S, 8, $R>($($arg),*),
            7 => $f::<$S, 7, $R>($($arg),*),
            6 => $f::<$S, 6, $R>($($arg),*),
            5 => $f::<$S, 5, $R>($($arg),*),
            4 => $f::<$S, 4, $R>($($arg),*),
            3 => $f::<$S, 3, $R>($($arg),*),
            2 => $f::<$S, 2, $R>($($arg),*),
            _ => $f::<$S, 1, $R>($($arg),*),
        }
    };
}

/// Forward substitution on supernode s for the R columns of X at `x` (column stride n,
/// permuted): gather its rows, panels, scatter.
///
/// Safety: `sn` validated for n; `x` holds R * n values; `work` holds R * max_nr.
#[inline(always)]
unsafe fn fwd_node<S: Simd, const R: usize>(
    sn: &Supernodes<'_>,
    s: usize,
    x: *mut f64,
    n: usize,
    work: *mut f64,
) {
    let (f, w) = (sn.begin[s], sn.end[s] - sn.begin[s]);
    let pat = &sn.row_idx[sn.row_ptr[s]..sn.row_ptr[s + 1]];
    let nr = w + pat.len();
    let l = sn.vals.as_ptr().add(sn.val_ptr[s]);
    for j in 0..R {
        let (xj, e) = (x.add(j * n), work.add(j * nr));
        std::ptr::copy_nonoverlapping(xj.add(f), e, w);
        std::ptr::write_bytes(e.add(w), 0, nr - w);
    }
    let mut c0 = 0;
    while c0 < w {
        let q = (w - c0).min(8);
        panel!(fwd_panel, S, R, q, l, nr, c0, work);
        c0 += q;
    }
    for j in 0..R {
        let (xj, e) = (x.add(j * n), work.add(j * nr));
        std::ptr::copy_nonoverlapping(e, xj.add(f), w);
        for (t, &i) in pat.iter().enumerate() {
            *xj.add(i) += *e.add(w + t);
        }
    }
}

/// Backward substitution on supernode s (layout and safety as [`fwd_node`]).
#[inline(always)]
unsafe fn bwd_node<S: Simd, const R: usize>(
    sn: &Supernodes<'_>,
    s: usize,
    x: *mut f64,
    n: usize,
    work: *mut f64,
) {
    let (f, w) = (sn.begin[s], sn.end[s] - sn.begin[s]);
    let pat = &sn.row_idx[sn.row_ptr[s]..sn.row_ptr[s + 1]];
    let nr = w + pat.len();
    let l = sn.vals.as_ptr().add(sn.val_ptr[s]);
    for j in 0..R {
        let (xj, e) = (x.add(j * n), work.add(j * nr));
        std::ptr::copy_nonoverlapping(xj.add(f), e, w);
        for (t, &i) in pat.iter().enumerate() {
            *e.add(w + t) = *xj.add(i);
        }
    }
    let mut c1 = w;
    while c1 > 0 {
        let q = c1.min(8);
        let c0 = c1 - q;
        panel!(bwd_panel, S, R, q, l, nr, c0, work);
        c1 = c0;
    }
    for j in 0..R {
        std::ptr::copy_nonoverlapping(work.add(j * nr), x.add(j * n + f), w);
    }
}

/// Forward substitution on supernode s for all k columns, in groups of up to four.
#[inline(always)]
unsafe fn fwd_groups<S: Simd>(
    sn: &Supernodes<'_>,
    s: usize,
    xp: *mut f64,
    n: usize,
    k: usize,
    wp: *mut f64,
) {
    let mut j = 0;
    while j < k {
        let g = (k - j).min(4);
        let xj = xp.add(j * n);
        match g {
            4 => fwd_node::<S, 4>(sn, s, xj, n, wp),
            3 => fwd_node::<S, 3>(sn, s, xj, n, wp),
            2 => fwd_node::<S, 2>(sn, s, xj, n, wp),
            _ => fwd_node::<S, 1>(sn, s, xj, n, wp),
        }
        j += g;
    }
}

/// Solves L L^T X = B for the k columns of X: supernode by supernode, each in groups of
/// four right-hand sides and then the rest (3, 2 or 1) as one group, so that a
/// supernode's block is read from memory once per pass for all columns. `fwd`: the
/// supernodes the forward pass visits (increasing; the others must leave X unchanged,
/// i.e. hold zeros only, with zeros only below them); None: all.
#[inline(always)]
unsafe fn solve_all<S: Simd>(
    sn: &Supernodes<'_>,
    x: &mut [f64],
    n: usize,
    k: usize,
    work: &mut [f64],
    fwd: Option<&[usize]>,
) {
    let (xp, wp) = (x.as_mut_ptr(), work.as_mut_ptr());
    let ns = sn.begin.len();
    // A loop per case, no closure: closures do not inherit `target_feature`, and the
    // kernels would then not inline their AVX2 intrinsics.
    match fwd {
        Some(list) => {
            for &s in list {
                fwd_groups::<S>(sn, s, xp, n, k, wp);
            }
        }
        None => {
            for s in 0..ns {
                fwd_groups::<S>(sn, s, xp, n, k, wp);
            }
        }
    }
    for s in (0..ns).rev() {
        let mut j = 0;
        while j < k {
            let g = (k - j).min(4);
            let xj = xp.add(j * n);
            match g {
                4 => bwd_node::<S, 4>(sn, s, xj, n, wp),
                3 => bwd_node::<S, 3>(sn, s, xj, n, wp),
                2 => bwd_node::<S, 2>(sn, s, xj, n, wp),
                _ => bwd_node::<S, 1>(sn, s, xj, n, wp),
            }
            j += g;
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn solve_avx2(
    sn: &Supernodes<'_>,
    x: &mut [f64],
    n: usize,
    k: usize,
    work: &mut [f64],
    fwd: Option<&[usize]>,
) {
    solve_all::<Avx2>(sn, x, n, k, work, fwd)
}

/// The AVX2 kernels where the CPU also has AVX-512VL: the same 256-bit operations (the
/// same bits), with 32 vector registers for the accumulators instead of 16.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
unsafe fn solve_avx512vl(
    sn: &Supernodes<'_>,
    x: &mut [f64],
    n: usize,
    k: usize,
    work: &mut [f64],
    fwd: Option<&[usize]>,
) {
    solve_all::<Avx2<16>>(sn, x, n, k, work, fwd)
}

/// Solves L L^T X = B in place for the n x k column-major `x` (already permuted);
/// `portable`: the scalar kernels even where AVX2 + FMA exist (tests); `wide`: AVX-512VL's
/// 32 registers for the AVX2 kernels where the CPU has it (the same bits); `fwd`: the
/// supernodes of the forward pass, as in [`solve_all`] (None: all).
/// Panics unless `x.len() == n * k`, `work.len() >= 4 * max_nr` and `fwd` is increasing
/// and in range.
///
/// # Safety
/// `sn.validate(n)` returned `Some(max_nr)` (the kernels index without checks).
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn solve(
    sn: &Supernodes<'_>,
    max_nr: usize,
    x: &mut [f64],
    n: usize,
    k: usize,
    work: &mut [f64],
    portable: bool,
    wide: bool,
    fwd: Option<&[usize]>,
) {
    debug_assert_eq!(sn.validate(n), Some(max_nr));
    assert!(x.len() == n * k && work.len() >= 4 * max_nr);
    if let Some(list) = fwd {
        assert!(
            list.windows(2).all(|p| p[0] < p[1]) && list.last().is_none_or(|&s| s < sn.begin.len()),
            "forward supernodes not increasing or out of range"
        );
    }
    #[cfg(target_arch = "x86_64")]
    if !portable
        && std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma")
    {
        // SAFETY: the CPU has AVX2 and FMA (and AVX-512VL for the second); sizes checked
        // above, structure validated (the caller's contract).
        if wide && std::arch::is_x86_feature_detected!("avx512vl") {
            return solve_avx512vl(sn, x, n, k, work, fwd);
        }
        return solve_avx2(sn, x, n, k, work, fwd);
    }
    solve_all::<Scalar>(sn, x, n, k, work, fwd)
}
