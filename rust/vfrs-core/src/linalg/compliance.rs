//! Dense products with stored compliance columns.
//!
//! A compliance keeps the columns `A^-1 e_j` of the DOFs contact has touched, each over the
//! rows of its own block of `A`, one column per row of a row-major store. Forces on a few
//! DOFs then move the whole field by a combination of those columns: no forward/back
//! substitution, and only the loaded DOFs' columns are read.

use crate::error::SolverError;

/// Entries of `out` computed per pass over the loaded columns: the pass's slice of `out`
/// (64 KB with one right-hand side, 128 KB with two) stays in L2 while the columns stream
/// through, four at a time. Measured on the medium M5 fold (10,296 rows, 100 columns, cache
/// flushed): a chunk of 512 entries with one column per pass read 9.7 GB/s (one right-hand
/// side) and 6.6 GB/s (two); four columns per pass, 15 and 12 GB/s; with 8,192-entry chunks,
/// 19-21 and 15-18 GB/s (docs/performance.md, "Outside the solves").
const CHUNK: usize = 8192;

/// The sizes [`combine_rows`] needs: whole rows of `n` in `store`, `slots.len() x m`
/// coefficients, `n x m` outputs, slots in range.
fn check_combine<T>(
    store: &[T],
    n: usize,
    slots: &[usize],
    coeffs: &[f64],
    m: usize,
    out: &[f64],
) -> Result<(), SolverError> {
    let bad = |reason: String| Err(SolverError::BadRhs { reason });
    if n == 0 || !store.len().is_multiple_of(n) {
        return bad(format!(
            "compliance store of {} entries is not a whole number of rows of {n}",
            store.len()
        ));
    }
    let rows = store.len() / n;
    if coeffs.len() != slots.len() * m {
        return bad(format!(
            "{} coefficients for {} columns x {m} right-hand sides",
            coeffs.len(),
            slots.len()
        ));
    }
    if out.len() != n * m {
        return bad(format!(
            "output of {} entries, expected {n} x {m}",
            out.len()
        ));
    }
    if let Some(&s) = slots.iter().find(|&&s| s >= rows) {
        return bad(format!(
            "column slot {s} is out of range (the store holds {rows})"
        ));
    }
    Ok(())
}

/// `out[i, c] = sum_j coeffs[j, c] * store[slots[j], i]` for `i < n`, `c < m`.
///
/// `store`: `f64`, or `f32` columns (half the memory and the bytes read; each entry widened
/// to `f64` before it is multiplied, so the sums are in double precision); row-major, `n` entries per row (a column of the compliance per row); `slots`:
/// the rows to combine; `coeffs`: row-major `(slots.len(), m)`; `out`: row-major `(n, m)`,
/// overwritten. The sum over `j` runs in the order of `slots` for every entry, so the result
/// does not depend on how the work is split. One thread: the product is bound by memory, and
/// the caller's solves run beside it.
pub fn combine_rows<T: Copy + Into<f64>>(
    store: &[T],
    n: usize,
    slots: &[usize],
    coeffs: &[f64],
    m: usize,
    out: &mut [f64],
) -> Result<(), SolverError> {
    check_combine(store, n, slots, coeffs, m, out)?;
    out.fill(0.0);
    let mut start = 0;
    while start < n {
        let end = (start + CHUNK).min(n);
        let o = &mut out[start * m..end * m];
        let col = |j: usize| &store[slots[j] * n + start..slots[j] * n + end];
        let mut j = 0;
        if m <= 2 {
            // Four columns per pass over the chunk: `o` is loaded and stored once for them,
            // and each entry still adds the columns' terms one by one in slot order.
            while j + 4 <= slots.len() {
                let (x0, x1, x2, x3) = (col(j), col(j + 1), col(j + 2), col(j + 3));
                let c = &coeffs[j * m..(j + 4) * m];
                if m == 1 {
                    for (i, oi) in o.iter_mut().enumerate() {
                        let mut v = *oi;
                        v += c[0] * x0[i].into();
                        v += c[1] * x1[i].into();
                        v += c[2] * x2[i].into();
                        v += c[3] * x3[i].into();
                        *oi = v;
                    }
                } else {
                    // The stabilized predictor's two right-hand sides (u~ and v~).
                    for (i, oi) in o.chunks_exact_mut(2).enumerate() {
                        let (mut v0, mut v1) = (oi[0], oi[1]);
                        v0 += c[0] * x0[i].into();
                        v1 += c[1] * x0[i].into();
                        v0 += c[2] * x1[i].into();
                        v1 += c[3] * x1[i].into();
                        v0 += c[4] * x2[i].into();
                        v1 += c[5] * x2[i].into();
                        v0 += c[6] * x3[i].into();
                        v1 += c[7] * x3[i].into();
                        oi[0] = v0;
                        oi[1] = v1;
                    }
                }
                j += 4;
            }
        }
        for j in j..slots.len() {
            let x = col(j);
            let c = &coeffs[j * m..(j + 1) * m];
            for (oi, &xi) in o.chunks_exact_mut(m).zip(x) {
                let xi: f64 = xi.into();
                for (ok, &ck) in oi.iter_mut().zip(c) {
                    *ok += ck * xi;
                }
            }
        }
        start = end;
    }
    Ok(())
}

/// The Delassus operator `W = scale G S G^T` (dense, `m x m`, row-major, overwritten) of
/// the `m` rows of the CSR matrix `G` (`indptr`, `indices`: DOFs, `data`).
///
/// `S`: the compliance at its columns' own DOFs, row-major with row stride `stride` (at
/// least `n` rows and columns valid); `col_of[dof]`: the DOF's index in `S`, or negative for
/// a DOF that does not move (fixed: its entries of `G` are skipped). Only the entries of `S`
/// on the DOFs of `G` are read. Entry (a, b), a <= b, is `sum_k G_ak sum_l S[k, l] G_bl`
/// over the stored order of each row, and (b, a) is the same number: `W` is exactly
/// symmetric.
#[allow(clippy::too_many_arguments)]
pub fn delassus(
    indptr: &[usize],
    indices: &[usize],
    data: &[f64],
    col_of: &[i64],
    s: &[f64],
    n: usize,
    stride: usize,
    scale: f64,
    out: &mut [f64],
) -> Result<(), SolverError> {
    let bad = |reason: String| Err(SolverError::BadRhs { reason });
    let m = indptr.len().saturating_sub(1);
    if indptr.is_empty() || indptr[m] != indices.len() || indices.len() != data.len() {
        return bad(format!(
            "constraint matrix: indptr ends at {:?} for {} indices and {} values",
            indptr.last(),
            indices.len(),
            data.len()
        ));
    }
    if indptr.windows(2).any(|w| w[1] < w[0]) {
        return bad("constraint matrix: indptr decreases".into());
    }
    if out.len() != m * m {
        return bad(format!("output of {} entries for {m} x {m}", out.len()));
    }
    if stride < n || s.len() < n.saturating_sub(1) * stride + n {
        return bad(format!(
            "compliance of {} entries with stride {stride} holds no {n} x {n} block",
            s.len()
        ));
    }
    // Each row's (S index, value), fixed DOFs dropped.
    let mut rows: Vec<(usize, f64)> = Vec::with_capacity(indices.len());
    let mut start = Vec::with_capacity(m + 1);
    start.push(0);
    for a in 0..m {
        for k in indptr[a]..indptr[a + 1] {
            let dof = indices[k];
            let c = *col_of.get(dof).ok_or(SolverError::DofOutOfRange {
                dof,
                n_dofs: col_of.len(),
            })?;
            if c >= 0 {
                let c = c as usize;
                if c >= n {
                    return bad(format!(
                        "DOF {dof} has compliance index {c}, beyond the {n} computed"
                    ));
                }
                rows.push((c, data[k]));
            }
        }
        start.push(rows.len());
    }
    for a in 0..m {
        let ra = &rows[start[a]..start[a + 1]];
        for b in a..m {
            let rb = &rows[start[b]..start[b + 1]];
            let mut w = 0.0;
            for &(k, gk) in ra {
                let srow = &s[k * stride..k * stride + n];
                let mut t = 0.0;
                for &(l, gl) in rb {
                    t += srow[l] * gl;
                }
                w += gk * t;
            }
            let w = scale * w;
            out[a * m + b] = w;
            out[b * m + a] = w;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn combines_the_named_rows() {
        // Three stored columns of length 5 (rows of the store), combined two at a time.
        let n = 5;
        let store: Vec<f64> = (0..15).map(|v| v as f64).collect();
        let slots = [2, 0];
        let coeffs = [1.0, 0.5, -2.0, 1.0]; // (2 columns, 2 right-hand sides)
        let mut out = vec![f64::NAN; n * 2];
        combine_rows(&store, n, &slots, &coeffs, 2, &mut out).expect("valid input");
        for i in 0..n {
            let (a, b) = (store[2 * n + i], store[i]);
            assert_eq!(out[2 * i], a - 2.0 * b);
            assert_eq!(out[2 * i + 1], 0.5 * a + b);
        }
    }

    #[test]
    fn every_entry_is_the_sum_in_slot_order() {
        // Rows longer than a chunk, column counts that are and are not multiples of the four
        // combined per pass, one to three right-hand sides: each entry must be the plain
        // sum 0 + c_0 x_0 + c_1 x_1 + ... in the order of the slots, bit for bit (the kernel
        // only reorders which entries and columns it visits, never an entry's additions).
        let n = CHUNK + 37;
        let rows = 11;
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let store: Vec<f64> = (0..rows * n).map(|_| next()).collect();
        // Single-precision columns: the same sums of the widened values, in double precision.
        let single: Vec<f32> = store.iter().map(|&x| x as f32).collect();
        let widened: Vec<f64> = single.iter().map(|&x| f64::from(x)).collect();
        for k in [1, 3, 4, 7, 9] {
            let slots: Vec<usize> = (0..k).map(|j| (7 * j + 3) % rows).collect();
            for m in 1..=3 {
                let coeffs: Vec<f64> = (0..k * m).map(|_| next() * 1e3).collect();
                let mut out = vec![f64::NAN; n * m];
                combine_rows(&store, n, &slots, &coeffs, m, &mut out).expect("valid input");
                let mut out_single = vec![f64::NAN; n * m];
                combine_rows(&single, n, &slots, &coeffs, m, &mut out_single).expect("valid input");
                for i in 0..n {
                    for c in 0..m {
                        let (mut e, mut e_single) = (0.0, 0.0);
                        for (j, &s) in slots.iter().enumerate() {
                            e += coeffs[j * m + c] * store[s * n + i];
                            e_single += coeffs[j * m + c] * widened[s * n + i];
                        }
                        assert_eq!(
                            out[i * m + c].to_bits(),
                            e.to_bits(),
                            "k {k} m {m} entry {i} rhs {c}"
                        );
                        assert_eq!(
                            out_single[i * m + c].to_bits(),
                            e_single.to_bits(),
                            "single: k {k} m {m} entry {i} rhs {c}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn refuses_bad_shapes_and_slots() {
        let store = vec![0.0; 10];
        let mut out = vec![0.0; 5];
        assert!(combine_rows(&store, 5, &[2], &[1.0], 1, &mut out).is_err()); // slot 2 of 2 rows
        assert!(combine_rows(&store, 5, &[0], &[1.0, 2.0], 1, &mut out).is_err());
        assert!(combine_rows(&store, 4, &[0], &[1.0], 1, &mut out).is_err());
        assert!(combine_rows(&store, 5, &[1], &[1.0], 1, &mut out[..4]).is_err());
    }

    #[test]
    fn delassus_is_g_s_gt_and_skips_fixed_dofs() {
        // DOFs 0..4; DOF 2 fixed (col_of -1); S over DOFs 0, 1, 3 (indices 0, 1, 2), stride 4.
        let col_of = [0i64, 1, -1, 2];
        let s = [
            2.0, 0.5, 0.1, 9.0, //
            0.5, 3.0, 0.2, 9.0, //
            0.1, 0.2, 4.0, 9.0,
        ];
        // G rows: [1, 0, 7, -1] and [0, 2, 0, 1] (the 7 on the fixed DOF is ignored).
        let indptr = [0, 3, 5];
        let indices = [0, 2, 3, 1, 3];
        let data = [1.0, 7.0, -1.0, 2.0, 1.0];
        let mut w = vec![0.0; 4];
        delassus(&indptr, &indices, &data, &col_of, &s, 3, 4, 0.5, &mut w).expect("valid");
        let g = [[1.0, 0.0, -1.0], [0.0, 2.0, 1.0]];
        for a in 0..2 {
            for b in 0..2 {
                let mut e = 0.0;
                for k in 0..3 {
                    for l in 0..3 {
                        e += g[a][k] * s[k * 4 + l] * g[b][l];
                    }
                }
                assert!((w[a * 2 + b] - 0.5 * e).abs() < 1e-14, "{a} {b}");
            }
        }
        assert_eq!(w[1], w[2]);
        // A DOF beyond col_of, or a compliance index beyond n: errors.
        assert!(delassus(&[0, 1], &[7], &[1.0], &col_of, &s, 3, 4, 1.0, &mut [0.0]).is_err());
        assert!(delassus(&[0, 1], &[3], &[1.0], &col_of, &s, 2, 4, 1.0, &mut [0.0]).is_err());
    }
}
