//! The vector operations of the kernels of the factorization ([`super::numeric`]) and the
//! solves ([`super::solve`]): portable scalar code, AVX2 + FMA and AVX-512F, each lane of
//! every set computing the same operations in the same order.

/// The vector operations of the kernels.
pub(super) trait Simd {
    type V: Copy;
    const W: usize;
    /// Accumulators the backward dot products keep in registers at once.
    const ACC: usize = 8;
    unsafe fn load(p: *const f64) -> Self::V;
    unsafe fn store(p: *mut f64, v: Self::V);
    unsafe fn splat(x: f64) -> Self::V;
    unsafe fn zero() -> Self::V;
    /// c - a b
    unsafe fn fnmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V;
    /// c + a b
    unsafe fn fmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V;
    unsafe fn hsum(v: Self::V) -> f64;
    /// a / b, correctly rounded lane by lane
    unsafe fn div(a: Self::V, b: Self::V) -> Self::V;
    /// c - a b, one lane (fused, as a vector lane computes it; the portable set overrides)
    #[inline(always)]
    fn fnmadd1(a: f64, b: f64, c: f64) -> f64 {
        (-a).mul_add(b, c)
    }
    /// c + a b, one lane (fused, as a vector lane computes it; the portable set overrides)
    #[inline(always)]
    fn fmadd1(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

pub(super) struct Scalar;
impl Simd for Scalar {
    type V = f64;
    const W: usize = 1;
    #[inline(always)]
    unsafe fn load(p: *const f64) -> f64 {
        *p
    }
    #[inline(always)]
    unsafe fn store(p: *mut f64, v: f64) {
        *p = v
    }
    #[inline(always)]
    unsafe fn splat(x: f64) -> f64 {
        x
    }
    #[inline(always)]
    unsafe fn zero() -> f64 {
        0.0
    }
    #[inline(always)]
    unsafe fn fnmadd(a: f64, b: f64, c: f64) -> f64 {
        c - a * b
    }
    #[inline(always)]
    unsafe fn fmadd(a: f64, b: f64, c: f64) -> f64 {
        c + a * b
    }
    #[inline(always)]
    unsafe fn hsum(v: f64) -> f64 {
        v
    }
    #[inline(always)]
    unsafe fn div(a: f64, b: f64) -> f64 {
        a / b
    }
    #[inline(always)]
    fn fnmadd1(a: f64, b: f64, c: f64) -> f64 {
        c - a * b
    }
    #[inline(always)]
    fn fmadd1(a: f64, b: f64, c: f64) -> f64 {
        c + a * b
    }
}

/// AVX2 with FMA, four lanes; `ACC`: the accumulator registers the backward dot products
/// may use (8 of AVX2's 16 vector registers; 16 of the 32 that AVX-512VL gives the same
/// 256-bit operations).
#[cfg(target_arch = "x86_64")]
pub(super) struct Avx2<const ACC: usize = 8>;
#[cfg(target_arch = "x86_64")]
impl<const A: usize> Simd for Avx2<A> {
    type V = std::arch::x86_64::__m256d;
    const W: usize = 4;
    const ACC: usize = A;
    #[inline(always)]
    unsafe fn load(p: *const f64) -> Self::V {
        std::arch::x86_64::_mm256_loadu_pd(p)
    }
    #[inline(always)]
    unsafe fn store(p: *mut f64, v: Self::V) {
        std::arch::x86_64::_mm256_storeu_pd(p, v)
    }
    #[inline(always)]
    unsafe fn splat(x: f64) -> Self::V {
        std::arch::x86_64::_mm256_set1_pd(x)
    }
    #[inline(always)]
    unsafe fn zero() -> Self::V {
        std::arch::x86_64::_mm256_setzero_pd()
    }
    #[inline(always)]
    unsafe fn fnmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V {
        std::arch::x86_64::_mm256_fnmadd_pd(a, b, c)
    }
    #[inline(always)]
    unsafe fn fmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V {
        std::arch::x86_64::_mm256_fmadd_pd(a, b, c)
    }
    #[inline(always)]
    unsafe fn hsum(v: Self::V) -> f64 {
        use std::arch::x86_64::*;
        let s = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd::<1>(v));
        _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)))
    }
    #[inline(always)]
    unsafe fn div(a: Self::V, b: Self::V) -> Self::V {
        std::arch::x86_64::_mm256_div_pd(a, b)
    }
}

/// AVX-512F with FMA, eight lanes: for the numeric factorization only, whose every entry is
/// a chain of lane-wise operations fixed by the structure (the same bits as the AVX2
/// kernels'). The solves keep AVX2: their horizontal sums depend on the width.
#[cfg(target_arch = "x86_64")]
pub(super) struct Avx512;
#[cfg(target_arch = "x86_64")]
impl Simd for Avx512 {
    type V = std::arch::x86_64::__m512d;
    const W: usize = 8;
    #[inline(always)]
    unsafe fn load(p: *const f64) -> Self::V {
        std::arch::x86_64::_mm512_loadu_pd(p)
    }
    #[inline(always)]
    unsafe fn store(p: *mut f64, v: Self::V) {
        std::arch::x86_64::_mm512_storeu_pd(p, v)
    }
    #[inline(always)]
    unsafe fn splat(x: f64) -> Self::V {
        std::arch::x86_64::_mm512_set1_pd(x)
    }
    #[inline(always)]
    unsafe fn zero() -> Self::V {
        std::arch::x86_64::_mm512_setzero_pd()
    }
    #[inline(always)]
    unsafe fn fnmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V {
        std::arch::x86_64::_mm512_fnmadd_pd(a, b, c)
    }
    #[inline(always)]
    unsafe fn fmadd(a: Self::V, b: Self::V, c: Self::V) -> Self::V {
        std::arch::x86_64::_mm512_fmadd_pd(a, b, c)
    }
    #[inline(always)]
    unsafe fn hsum(v: Self::V) -> f64 {
        std::arch::x86_64::_mm512_reduce_add_pd(v)
    }
    #[inline(always)]
    unsafe fn div(a: Self::V, b: Self::V) -> Self::V {
        std::arch::x86_64::_mm512_div_pd(a, b)
    }
}
