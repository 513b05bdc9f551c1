//! The focus measure's row kernel of [`crate::focus`] with AVX2: Σ|a − b| and Σ(a − b)² of two
//! rows.

use crate::simd::Avx2;
use std::arch::x86_64::*;

/// The AVX2 path: `vpsadbw` sums eight absolute differences into a 64-bit lane; the differences
/// widened to 16 bits and `vpmaddwd` with themselves give sums of two squares in 32-bit lanes
/// (each lane takes ≤ 4·255² a step: blocks of 4096 steps stay below 2^32).
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
unsafe fn kernel(a: &[u8], b: &[u8]) -> (u64, u64) {
    const V: usize = 32;
    const BLOCK: usize = 4096 * V;
    let n = a.len().min(b.len());
    let (mut s1, mut s2) = (0u64, 0u64);
    let mut i = 0;
    let zero = _mm256_setzero_si256();
    let mut acc1 = zero;
    while i + V <= n {
        let end = (i + BLOCK).min(n);
        let mut acc2 = zero;
        while i + V <= end {
            // SAFETY: i + 32 ≤ n ≤ both lengths: the 32-byte unaligned loads are in bounds.
            let (x, y) = unsafe {
                (
                    _mm256_loadu_si256(a.as_ptr().add(i).cast()),
                    _mm256_loadu_si256(b.as_ptr().add(i).cast()),
                )
            };
            acc1 = _mm256_add_epi64(acc1, _mm256_sad_epu8(x, y));
            let d = _mm256_or_si256(_mm256_subs_epu8(x, y), _mm256_subs_epu8(y, x));
            let (lo, hi) = (_mm256_unpacklo_epi8(d, zero), _mm256_unpackhi_epi8(d, zero));
            let sq = _mm256_add_epi32(_mm256_madd_epi16(lo, lo), _mm256_madd_epi16(hi, hi));
            acc2 = _mm256_add_epi32(acc2, sq);
            i += V;
        }
        let mut t = [0u32; 8];
        // SAFETY: `t` holds 32 bytes.
        unsafe { _mm256_storeu_si256(t.as_mut_ptr().cast(), acc2) };
        s2 += t.iter().map(|&v| v as u64).sum::<u64>();
    }
    let mut t = [0u64; 4];
    // SAFETY: `t` holds 32 bytes.
    unsafe { _mm256_storeu_si256(t.as_mut_ptr().cast(), acc1) };
    s1 += t.iter().sum::<u64>();
    for k in i..n {
        let d = a[k].abs_diff(b[k]) as u64;
        s1 += d;
        s2 += d * d;
    }
    (s1, s2)
}

/// Σ|a − b| and Σ(a − b)² over the common length of two rows ([`kernel`]) on a CPU that has
/// AVX2 (`_cpu` proves it).
#[inline]
pub(crate) fn abs_diff_sums(_cpu: Avx2, a: &[u8], b: &[u8]) -> (u64, u64) {
    // SAFETY: `level` returns AVX2 or above only when the CPU has AVX2
    // (`is_x86_feature_detected!` in `simd::detected`; `_cpu` proves it).
    unsafe { kernel(a, b) }
}
