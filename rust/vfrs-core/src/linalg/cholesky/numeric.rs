//! Numeric supernodal LL^T on faer's symbolic structure, with this crate's kernels only.
//!
//! Why not faer's numeric factorization: its dense products dispatch to AVX-512 kernels on
//! CPUs that have them, so L, and every result downstream (which contact dynamics amplify),
//! would differ in its last bits between an AVX-512 machine and an AVX2 one (its blocking, and
//! so its order of summation, follows the vector width). Here every entry of L is computed by
//! a sequence of lane-wise operations fixed by the symbolic structure alone, with AVX-512F
//! (eight lanes) or AVX2 (four), both with FMA, whichever the CPU has: a lane of either
//! computes the same fused multiply-adds in the same order, so the bits are the same on every
//! x86-64 CPU with AVX2 + FMA (tested against each other where AVX-512 exists); portable scalar
//! code otherwise (within round-off):
//!
//! - left-looking by supernode, in the layout of [`super::symbolic::Supernodes`]: supernode
//!   s starts from the lower triangle of P A P^T scattered into its block, then receives
//!   the update of every descendant d whose rows meet its columns, in increasing d, each a
//!   dense product `L_d[rows ≥ s] L_d[rows in s]^T` subtracted by relative row indices;
//! - wide supernodes are taken in panels of [`NB`] columns: a panel receives the descendant
//!   updates of its columns, then the update of the supernode's earlier columns, then is
//!   factored (dense Cholesky of its diagonal block, then its rows below);
//! - every product entry is one fused multiply-add chain over k in increasing order, from
//!   zero, whatever the tiling, blocking or packing; every factored entry is
//!   `(a - Σ_k l_ik l_jk) / l_jj` with k increasing.
//!
//! Parallelism (rayon) only changes which thread computes what, never an operation: the
//! subtrees of the supernodal elimination tree are factored concurrently, and inside a large
//! supernode (the separators near the root, which hold most of the work of a 3-D mesh and
//! would otherwise run on one thread) the rows of each large update product and of each
//! panel's rows below its diagonal block are split between the threads (a row's entries are
//! computed by the same operations whichever thread computes them, and every target entry
//! still receives its updates in the same order). The bits do not depend on the thread count.
#![allow(clippy::needless_range_loop)]

mod kernels;
mod plan;

#[cfg(target_arch = "x86_64")]
use super::simd::{Avx2, Avx512};
use super::simd::{Scalar, Simd};
use super::symbolic::Supernodes;
use kernels::{factor_diagonal, gemm_lower, rows_below};
use rayon::prelude::*;
use std::sync::Mutex;

/// Columns of a supernode factored at a time (left-looking panels): bounds the update buffer
/// and keeps a panel's rows in cache while it is factored.
const NB: usize = 64;
/// Inner-dimension block of the update products: a packed micro-panel of `KC` columns stays
/// in L1, the packed right operand in L2.
const KC: usize = 256;
/// Columns of the update micro-kernel's tile; its rows are [`MV`] vectors (8 with AVX2, 2 in
/// the portable kernels): 12 accumulators and 3 operands in AVX2's 16 registers (12 x 4
/// measured 1.7x slower on the fine fold block: spills).
const NR: usize = 6;
/// Vectors per micro-kernel tile column.
const MV: usize = 2;
/// The largest micro-kernel row count of any kernel set (buffer sizes): eight lanes.
const MR_MAX: usize = 8 * MV;
/// Multiply-adds from which an update product, or a panel's rows below its diagonal block,
/// is split between threads by rows (below it a hand-off costs more than it saves). Small in
/// tests, so that their small matrices take the split path too.
const PAR_MACS: usize = if cfg!(test) { 2_000 } else { 1 << 21 };
/// Splits into more than one chunk so far (tests: that the split path ran).
#[cfg(test)]
pub(super) static SPLITS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
/// The fewest rows a thread gets of a split product.
const PAR_MIN_ROWS: usize = if cfg!(test) { 8 } else { 64 };

/// What the numeric factorization needs beyond faer's symbolic structure, built once in
/// [`Plan::new`]: where A's entries go, which descendants update which supernode, the
/// supernodal elimination tree for the parallel schedule, and the workspaces.
pub(super) struct Plan {
    /// Stored entries of A (lower triangle of the original matrix) scattered into L: for
    /// supernode s, `a_src[a_ptr[s]..a_ptr[s + 1]]` index A's values and `a_dst` (same
    /// range) the positions in L's values.
    a_ptr: Vec<usize>,
    a_src: Vec<usize>,
    a_dst: Vec<usize>,
    /// Descendant updates of supernode s: `upd[upd_ptr[s]..upd_ptr[s + 1]]`, each
    /// `[d, p1, p2]` meaning that the rows `pattern(d)[p1..p2]` are columns of s; increasing d.
    upd_ptr: Vec<usize>,
    upd: Vec<[usize; 3]>,
    /// Supernodal elimination tree: parent (`usize::MAX` for a root), children (CSR), roots.
    parent: Vec<usize>,
    child_ptr: Vec<usize>,
    child: Vec<usize>,
    roots: Vec<usize>,
    /// A postorder of the tree: the subtree of s is `post[first_post[s]..=post_pos[s]]`.
    post: Vec<usize>,
    post_pos: Vec<usize>,
    first_post: Vec<usize>,
    /// Estimated multiply-adds of each subtree (own block and updates it sends).
    subtree_work: Vec<f64>,
    /// Whether every update comes from its target's subtree (true of any structure faer
    /// builds); the parallel schedule needs it (otherwise factor sequentially).
    postordered: bool,
    /// Workspaces, each taken by one task at a time (a run of supernodes, or a row chunk of
    /// a split product) and given back: made in [`Plan::new`] for the pool's threads plus
    /// one, more only if more tasks run at once. Not one per thread: a thread that waits for
    /// a split's chunks may run another task meanwhile (rayon steals), which must not need
    /// the workspace the waiting one holds.
    work: Mutex<Vec<Work>>,
    /// Workspaces made in [`Plan::new`].
    #[cfg_attr(not(test), allow(dead_code))]
    slots: usize,
    n: usize,
    max_nr: usize,
}

/// One thread's scratch: the global-to-local row map of the supernode being factored, the
/// relative row indices of one update, the update product and the packed operands.
struct Work {
    map: Vec<usize>,
    rel: Vec<usize>,
    c: Vec<f64>,
    pa: Vec<f64>,
    pb: Vec<f64>,
}

impl Work {
    fn new(n: usize, max_nr: usize) -> Self {
        Self {
            map: vec![0; n],
            rel: vec![0; max_nr],
            c: vec![0.0; (max_nr + MR_MAX) * (NB + NR)],
            pa: vec![0.0; MR_MAX * KC],
            pb: vec![0.0; (NB + NR) * KC],
        }
    }
}

/// Raw pointer to L's values shared by the threads of a parallel factorization.
#[derive(Clone, Copy)]
struct SharedVals(*mut f64);
// SAFETY: each supernode's block is written by exactly one task (or by the row chunks of
// one of its split products or panels, which write disjoint rows and return before the task
// goes on), and read by other tasks (its ancestors) only after that task has finished
// (rayon's join orders them).
unsafe impl Send for SharedVals {}
// SAFETY: as for Send.
unsafe impl Sync for SharedVals {}

/// One update product of [`apply_update`] (its operand B at `src` with column stride `ld`,
/// the first `nc` of its rows the target's columns, `k` columns; the target block at `ls`
/// with column stride `nr`, and `rel`, the target rows of B's rows), shared by the threads of
/// its row chunks.
#[derive(Clone, Copy)]
struct Operands {
    src: *const f64,
    ld: usize,
    nc: usize,
    k: usize,
    ls: *mut f64,
    nr: usize,
    rel: *const usize,
}
// SAFETY: the chunks of one split write disjoint rows of the target block and read only
// blocks that no chunk writes (see `split_rows`).
unsafe impl Send for Operands {}
// SAFETY: as for Send.
unsafe impl Sync for Operands {}

/// Combines two subtrees' outcomes (any failure; the caller then factors sequentially to
/// name the first failing column whatever the schedule).
fn first_err(a: Result<(), usize>, b: Result<(), usize>) -> Result<(), usize> {
    match (a, b) {
        (Err(x), Err(y)) => Err(x.min(y)),
        (Err(x), _) | (_, Err(x)) => Err(x),
        _ => Ok(()),
    }
}

impl Plan {
    /// A workspace of the plan's (a new one if all are taken).
    fn take_work(&self) -> Work {
        let taken = self.work.lock().unwrap_or_else(|e| e.into_inner()).pop();
        taken.unwrap_or_else(|| Work::new(self.n, self.max_nr))
    }

    /// Gives a workspace back.
    fn give_work(&self, w: Work) {
        self.work.lock().unwrap_or_else(|e| e.into_inner()).push(w);
    }

    /// The parent of each supernode in the supernodal elimination tree (`usize::MAX` for a
    /// root).
    pub(super) fn parent(&self) -> &[usize] {
        &self.parent
    }

    /// Number of workspaces (one per thread that may factor at once).
    #[cfg(test)]
    pub(super) fn slots(&self) -> usize {
        self.slots
    }

    /// Factors A (values `a`, in the pattern given to [`Plan::new`]) into `vals`, the values of
    /// L in the layout of `sn`. `parallel`: subtrees on the rayon pool; `portable`: the scalar
    /// kernels even where AVX2 + FMA exist; `wide`: the AVX-512 kernels where the CPU has them
    /// (the same bits as the AVX2 ones: every entry the same lane-wise operations). Returns
    /// the first column (permuted index) with a non-positive or non-finite pivot.
    pub(super) fn factor(
        &self,
        sn: &Supernodes<'_>,
        vals: &mut [f64],
        a: &[f64],
        parallel: bool,
        portable: bool,
        wide: bool,
    ) -> Result<(), usize> {
        let ns = sn.begin.len();
        assert!(
            sn.val_ptr.len() == ns + 1 && vals.len() >= sn.val_ptr[ns],
            "values do not fit the structure"
        );
        assert!(
            self.a_src.iter().all(|&k| k < a.len()),
            "A's values do not fit the plan"
        );
        let kernels = Kernels::detect(portable, wide);
        let threads = rayon::current_num_threads();
        let ctx = Ctx {
            plan: self,
            sn,
            vals: SharedVals(vals.as_mut_ptr()),
            a,
            kernels,
            split: parallel && threads > 1,
        };
        if parallel && threads > 1 && self.postordered && ns > 1 {
            let total: f64 = self.roots.iter().map(|&r| self.subtree_work[r]).sum();
            let cutoff = (total / (8 * threads) as f64).max(2e5);
            let r = self
                .roots
                .par_iter()
                .map(|&r| ctx.subtree(r, cutoff))
                .reduce(|| Ok(()), first_err);
            // Which pivot fails first may depend on the schedule: the sequential order decides.
            r.or_else(|_| ctx.run(0..ns))
        } else {
            ctx.run(0..ns)
        }
    }
}

/// The kernel set a factorization runs: the widest the CPU has (AVX-512F, else AVX2, both
/// with FMA), or the portable scalar one. Every set computes each entry of L by the same
/// lane-wise operations in the same order, so AVX-512 and AVX2 give the same bits (tested);
/// the scalar set differs from them within round-off (its multiply-adds are not fused).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernels {
    Scalar,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Kernels {
    fn detect(portable: bool, wide: bool) -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if !portable && has!("avx2") && has!("fma") {
                return if wide && has!("avx512f") {
                    Kernels::Avx512
                } else {
                    Kernels::Avx2
                };
            }
        }
        let _ = (portable, wide);
        Kernels::Scalar
    }
}

/// One factorization's shared inputs.
struct Ctx<'a> {
    plan: &'a Plan,
    sn: &'a Supernodes<'a>,
    vals: SharedVals,
    a: &'a [f64],
    kernels: Kernels,
    /// Split large products and panels by rows between the pool's threads.
    split: bool,
}

impl Ctx<'_> {
    /// Whether a piece of `macs` multiply-adds over `rows` rows is split between the threads.
    fn splits(&self, rows: usize, macs: usize) -> bool {
        self.split && macs >= PAR_MACS && rows >= 2 * PAR_MIN_ROWS
    }

    /// Factors the supernodes `list` in order with a workspace of the plan's.
    fn run(&self, mut list: impl Iterator<Item = usize>) -> Result<(), usize> {
        let mut work = self.plan.take_work();
        // SAFETY: the plan was built for this structure (`Plan::new` checked what the kernels
        // rely on); the supernodes that update s precede it (sequential order) or lie in its
        // subtree, factored before (parallel order); s's block is written by this call only.
        let done = list.try_for_each(|s| unsafe { self.node(s, &mut work) });
        self.plan.give_work(work);
        done
    }

    /// Factors the subtree rooted at s: light subtrees sequentially, heavy ones by factoring
    /// the children's subtrees in parallel first.
    fn subtree(&self, s: usize, cutoff: f64) -> Result<(), usize> {
        let p = self.plan;
        if p.subtree_work[s] <= cutoff {
            return self.run(p.post[p.first_post[s]..=p.post_pos[s]].iter().copied());
        }
        // Down a chain of single heavy children without recursing (deep etrees).
        let mut bottom = s;
        loop {
            let kids = &p.child[p.child_ptr[bottom]..p.child_ptr[bottom + 1]];
            if kids.len() == 1 && p.subtree_work[kids[0]] > cutoff {
                bottom = kids[0];
            } else {
                break;
            }
        }
        let kids = &p.child[p.child_ptr[bottom]..p.child_ptr[bottom + 1]];
        kids.par_iter()
            .map(|&c| self.subtree(c, cutoff))
            .reduce(|| Ok(()), first_err)?;
        let mut x = bottom;
        loop {
            self.run(std::iter::once(x))?;
            if x == s {
                return Ok(());
            }
            x = p.parent[x];
        }
    }

    /// Factors supernode s.
    ///
    /// Safety: as stated in [`Ctx::range`].
    unsafe fn node(&self, s: usize, work: &mut Work) -> Result<(), usize> {
        match self.kernels {
            #[cfg(target_arch = "x86_64")]
            Kernels::Avx512 => node_avx512(self, s, work),
            #[cfg(target_arch = "x86_64")]
            Kernels::Avx2 => node_avx2(self, s, work),
            Kernels::Scalar => node_generic::<Scalar>(self, s, work),
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn node_avx2(ctx: &Ctx<'_>, s: usize, work: &mut Work) -> Result<(), usize> {
    node_generic::<Avx2>(ctx, s, work)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn node_avx512(ctx: &Ctx<'_>, s: usize, work: &mut Work) -> Result<(), usize> {
    node_generic::<Avx512>(ctx, s, work)
}

/// Factors supernode s: scatter of A, descendant updates, panels. Returns the failing column.
#[inline(always)]
unsafe fn node_generic<S: Simd>(ctx: &Ctx<'_>, s: usize, ws: &mut Work) -> Result<(), usize> {
    let (plan, sn, vals) = (ctx.plan, ctx.sn, ctx.vals.0);
    let (f, l) = (sn.begin[s], sn.end[s]);
    let w = l - f;
    let pat = &sn.row_idx[sn.row_ptr[s]..sn.row_ptr[s + 1]];
    let nr = w + pat.len();
    let ls = vals.add(sn.val_ptr[s]);
    std::ptr::write_bytes(ls, 0, nr * w);
    for k in plan.a_ptr[s]..plan.a_ptr[s + 1] {
        *vals.add(plan.a_dst[k]) = ctx.a[plan.a_src[k]];
    }
    for t in 0..w {
        ws.map[f + t] = t;
    }
    for (t, &r) in pat.iter().enumerate() {
        ws.map[r] = w + t;
    }
    let upd = &plan.upd[plan.upd_ptr[s]..plan.upd_ptr[s + 1]];
    let mut c0 = 0;
    while c0 < w {
        let c1 = (c0 + NB).min(w);
        for &[d, p1, p2] in upd {
            let pd = &sn.row_idx[sn.row_ptr[d]..sn.row_ptr[d + 1]];
            let (q1, q2) = if c0 == 0 && c1 == w {
                (p1, p2)
            } else {
                let seg = &pd[p1..p2];
                (
                    p1 + seg.partition_point(|&r| r < f + c0),
                    p1 + seg.partition_point(|&r| r < f + c1),
                )
            };
            if q1 == q2 {
                continue;
            }
            let wd = sn.end[d] - sn.begin[d];
            for (i, &r) in pd[q1..].iter().enumerate() {
                *ws.rel.get_unchecked_mut(i) = *ws.map.get_unchecked(r);
            }
            apply_update::<S>(
                ctx,
                vals.add(sn.val_ptr[d] + wd + q1),
                wd + pd.len(),
                pd.len() - q1,
                q2 - q1,
                wd,
                ws,
                ls,
                nr,
            );
        }
        if c0 > 0 {
            for (i, r) in ws.rel[..nr - c0].iter_mut().enumerate() {
                *r = c0 + i;
            }
            apply_update::<S>(ctx, ls.add(c0), nr, nr - c0, c1 - c0, c0, ws, ls, nr);
        }
        factor_diagonal::<S>(ls, nr, c0, c1).map_err(|j| f + j)?;
        let (below, width) = (nr - c1, c1 - c0);
        if ctx.splits(below, below * width * width / 2) {
            let (ls_shared, kernels) = (SharedVals(ls), ctx.kernels);
            split_rows(plan, below, |a, b, _| {
                // SAFETY: rows c1 + a..c1 + b of the panel's columns, one chunk each; they
                // read the factored diagonal block (rows < c1), which no chunk writes.
                unsafe { rows_below_any(kernels, { ls_shared }.0, nr, c0, c1, c1 + a, c1 + b) }
            });
        } else {
            rows_below::<S>(ls, nr, c0, c1, c1, nr);
        }
        c0 = c1;
    }
    Ok(())
}

/// Subtracts the product `B B[..nc]^T` (lower trapezoid) from the target block: B is the
/// m x k matrix at `src` (column stride `ld`), its first nc rows the target's columns; row i
/// of the product goes to row `rel[i]` of the target (values at `ls`, column stride `nr`),
/// column j to column `rel[j]`. A large product is split by rows between the threads
/// ([`split_rows`]) when the factorization is parallel.
///
/// Safety: the operands are within their blocks; `rel[..m]` are rows of the target (ascending,
/// the first nc of them < the target's width); B does not overlap the target's columns
/// `rel[..nc]`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn apply_update<S: Simd>(
    ctx: &Ctx<'_>,
    src: *const f64,
    ld: usize,
    m: usize,
    nc: usize,
    k: usize,
    ws: &mut Work,
    ls: *mut f64,
    nr: usize,
) {
    let op = Operands {
        src,
        ld,
        nc,
        k,
        ls,
        nr,
        rel: ws.rel.as_ptr(),
    };
    if ctx.splits(m, m * nc * k) {
        let kernels = ctx.kernels;
        split_rows(ctx.plan, m, |a, b, w| {
            // SAFETY: rows a..b of the product, one chunk each: they write the target rows
            // rel[a..b] (distinct, rel ascending) and read B and rel, which no chunk writes.
            unsafe { update_rows_any(kernels, op, a, b, w) }
        });
    } else {
        update_rows::<S>(
            op,
            0,
            m,
            ws.c.as_mut_ptr(),
            ws.pa.as_mut_ptr(),
            ws.pb.as_mut_ptr(),
        );
    }
}

/// Runs `f(a, b, work)` on row ranges a..b covering 0..m, one per thread of the pool (at
/// least [`PAR_MIN_ROWS`] rows each, bounds on multiples of 8), each with a workspace of
/// the plan's; returns when all are done.
fn split_rows(plan: &Plan, m: usize, f: impl Fn(usize, usize, &mut Work) + Sync) {
    let parts = rayon::current_num_threads().min(m / PAR_MIN_ROWS).max(1);
    #[cfg(test)]
    SPLITS.fetch_add(usize::from(parts > 1), std::sync::atomic::Ordering::Relaxed);
    let bound = |t: usize| if t == parts { m } else { (m * t / parts) & !7 };
    let run = |t: usize| {
        let mut w = plan.take_work();
        f(bound(t), bound(t + 1), &mut w);
        plan.give_work(w);
    };
    rayon::scope(|sc| {
        for t in 1..parts {
            let run = &run;
            sc.spawn(move |_| run(t));
        }
        run(0);
    });
}

/// [`update_rows`] with the kernel set `kernels` (as [`Ctx::kernels`]), into the workspace
/// `w`.
///
/// Safety: as [`update_rows`].
unsafe fn update_rows_any(kernels: Kernels, op: Operands, a: usize, b: usize, w: &mut Work) {
    let (c, pa, pb) = (w.c.as_mut_ptr(), w.pa.as_mut_ptr(), w.pb.as_mut_ptr());
    match kernels {
        #[cfg(target_arch = "x86_64")]
        Kernels::Avx512 => update_rows_avx512(op, a, b, c, pa, pb),
        #[cfg(target_arch = "x86_64")]
        Kernels::Avx2 => update_rows_avx2(op, a, b, c, pa, pb),
        Kernels::Scalar => update_rows::<Scalar>(op, a, b, c, pa, pb),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn update_rows_avx512(
    op: Operands,
    a: usize,
    b: usize,
    c: *mut f64,
    pa: *mut f64,
    pb: *mut f64,
) {
    update_rows::<Avx512>(op, a, b, c, pa, pb);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn update_rows_avx2(
    op: Operands,
    a: usize,
    b: usize,
    c: *mut f64,
    pa: *mut f64,
    pb: *mut f64,
) {
    update_rows::<Avx2>(op, a, b, c, pa, pb);
}

/// Rows a..b of [`apply_update`]'s product, computed into `c` (packing buffers `pa`, `pb`)
/// and subtracted from the target: each entry the same fused multiply-add chain whatever
/// the rows computed with it.
///
/// Safety: as [`apply_update`]; `c` holds (b - a) rounded up to the tile height times nc
/// rounded up to NR values.
#[inline(always)]
unsafe fn update_rows<S: Simd>(
    op: Operands,
    a: usize,
    b: usize,
    c: *mut f64,
    pa: *mut f64,
    pb: *mut f64,
) {
    let Operands {
        src,
        ld,
        nc,
        k,
        ls,
        nr,
        rel,
    } = op;
    let mr = MV * S::W;
    let m = b - a;
    let ldc = m.div_ceil(mr) * mr;
    gemm_lower::<S>(src, ld, a, m, nc, k, c, ldc, pa, pb);
    for j in 0..nc {
        let col = ls.add(*rel.add(j) * nr);
        let cc = c.add(j * ldc);
        for i in j.max(a)..b {
            *col.add(*rel.add(i)) -= *cc.add(i - a);
        }
    }
}

/// [`rows_below`] with the kernel set `kernels` (as [`Ctx::kernels`]).
///
/// Safety: as [`rows_below`].
unsafe fn rows_below_any(
    kernels: Kernels,
    ls: *mut f64,
    nr: usize,
    c0: usize,
    c1: usize,
    r0: usize,
    r1: usize,
) {
    match kernels {
        #[cfg(target_arch = "x86_64")]
        Kernels::Avx512 => rows_below_avx512(ls, nr, c0, c1, r0, r1),
        #[cfg(target_arch = "x86_64")]
        Kernels::Avx2 => rows_below_avx2(ls, nr, c0, c1, r0, r1),
        Kernels::Scalar => rows_below::<Scalar>(ls, nr, c0, c1, r0, r1),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn rows_below_avx512(ls: *mut f64, nr: usize, c0: usize, c1: usize, r0: usize, r1: usize) {
    rows_below::<Avx512>(ls, nr, c0, c1, r0, r1)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn rows_below_avx2(ls: *mut f64, nr: usize, c0: usize, c1: usize, r0: usize, r1: usize) {
    rows_below::<Avx2>(ls, nr, c0, c1, r0, r1)
}
