//! Dense products with stored compliance columns.
//!
//! A compliance keeps the columns `A^-1 e_j` of the DOFs contact has touched, each over the
//! rows of its own block of `A`, one column per row of a row-major store. Forces on a few
//! DOFs then move the whole field by a combination of those columns: no forward/back
//! substitution, and only the loaded DOFs' columns are read.

use crate::error::SolverError;

/// Entries of `out` computed per pass over the loaded columns: the pass's slice of `out`
/// stays in L1 while the columns stream through.
const CHUNK: usize = 512;

/// `out[i, c] = sum_j coeffs[j, c] * store[slots[j], i]` for `i < n`, `c < m`.
///
/// `store`: row-major, `n` entries per row (a column of the compliance per row); `slots`:
/// the rows to combine; `coeffs`: row-major `(slots.len(), m)`; `out`: row-major `(n, m)`,
/// overwritten. The sum over `j` runs in the order of `slots` for every entry, so the result
/// does not depend on how the work is split. One thread: the product is bound by memory, and
/// the caller's solves run beside it.
pub fn combine_rows(
    store: &[f64],
    n: usize,
    slots: &[usize],
    coeffs: &[f64],
    m: usize,
    out: &mut [f64],
) -> Result<(), SolverError> {
    let bad = |reason: String| Err(SolverError::BadRhs { reason });
    if n == 0 || store.len() % n != 0 {
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
    out.fill(0.0);
    let mut start = 0;
    while start < n {
        let end = (start + CHUNK).min(n);
        let o = &mut out[start * m..end * m];
        for (j, &s) in slots.iter().enumerate() {
            let col = &store[s * n + start..s * n + end];
            let c = &coeffs[j * m..(j + 1) * m];
            if m == 1 {
                let c0 = c[0];
                for (oi, &x) in o.iter_mut().zip(col) {
                    *oi += c0 * x;
                }
            } else if m == 2 {
                // The stabilized predictor's two right-hand sides (u~ and v~): written out,
                // the loop vectorizes (the generic one runs 6x slower); the same operations.
                let (c0, c1) = (c[0], c[1]);
                for (oi, &x) in o.chunks_exact_mut(2).zip(col) {
                    oi[0] += c0 * x;
                    oi[1] += c1 * x;
                }
            } else {
                for (oi, &x) in o.chunks_exact_mut(m).zip(col) {
                    for (ok, &ck) in oi.iter_mut().zip(c) {
                        *ok += ck * x;
                    }
                }
            }
        }
        start = end;
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
    fn refuses_bad_shapes_and_slots() {
        let store = vec![0.0; 10];
        let mut out = vec![0.0; 5];
        assert!(combine_rows(&store, 5, &[2], &[1.0], 1, &mut out).is_err()); // slot 2 of 2 rows
        assert!(combine_rows(&store, 5, &[0], &[1.0, 2.0], 1, &mut out).is_err());
        assert!(combine_rows(&store, 4, &[0], &[1.0], 1, &mut out).is_err());
        assert!(combine_rows(&store, 5, &[1], &[1.0], 1, &mut out[..4]).is_err());
    }
}
