//! The focus and mean-gradient sums of the raw rows: Σ|a − b| and Σ(a − b)² over two rows of
//! bytes, in exact integer arithmetic.
//!
//! The detector takes them for every row (central differences of the raw image), so the pair of
//! sums runs once per row over twice the width. The portable path sums the differences in 32-bit
//! lanes, 64 columns at a time; with AVX2 (runtime-detected, also used on AVX-512 machines) the
//! absolute differences are summed by `vpsadbw` and the squares by `vpmaddwd`, 32 columns a step.
//! Both are exact integer sums, so they give the same bits (tested over random rows of every
//! length up to a few vectors, and the detector's level test).
//!
//! ```
//! use gonio_vision::focus::abs_diff_sums;
//! assert_eq!(abs_diff_sums(&[10, 0, 255], &[7, 5, 0]), (3 + 5 + 255, 9 + 25 + 255 * 255));
//! ```

#![allow(unsafe_code)]

use crate::simd::{Level, level};

/// Σ|a − b| and Σ(a − b)² over the common length of two rows, with the fastest path the CPU
/// has (the level [`crate::simd::level`] chooses).
#[inline]
pub fn abs_diff_sums(a: &[u8], b: &[u8]) -> (u64, u64) {
    #[cfg(target_arch = "x86_64")]
    if level() >= Level::Avx2 {
        // SAFETY: `level` returns AVX2 or above only when the CPU has AVX2
        // (`is_x86_feature_detected!` in `simd::detected`).
        return unsafe { abs_diff_sums_avx2(a, b) };
    }
    abs_diff_sums_scalar(a, b)
}

/// The portable path: 64 columns at a time, the differences as bytes, their sums and squares in
/// sixteen 32-bit lanes (no overflow: a lane takes at most 4·255² per 64 columns, 512 steps for
/// the widest window of 32768 px).
pub fn abs_diff_sums_scalar(a: &[u8], b: &[u8]) -> (u64, u64) {
    const C: usize = 64;
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let (mut s1, mut s2) = (0u64, 0u64);
    let (ac, bc) = (a.chunks_exact(C), b.chunks_exact(C));
    let (ar, br) = (ac.remainder(), bc.remainder());
    let mut it = ac.zip(bc);
    loop {
        // Blocks of at most 1024 chunks: a 32-bit lane takes ≤ 4·255² < 2^18 a chunk.
        let (mut acc1, mut acc2) = ([0u32; 16], [0u32; 16]);
        let mut steps = 0;
        for (x, y) in it.by_ref().take(1024) {
            steps += 1;
            let mut d = [0u8; C];
            for k in 0..C {
                d[k] = x[k].abs_diff(y[k]);
            }
            for k in 0..16 {
                let q = [d[4 * k], d[4 * k + 1], d[4 * k + 2], d[4 * k + 3]].map(u32::from);
                acc1[k] += q[0] + q[1] + q[2] + q[3];
                acc2[k] += q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
            }
        }
        for k in 0..16 {
            s1 += acc1[k] as u64;
            s2 += acc2[k] as u64;
        }
        if steps < 1024 {
            break;
        }
    }
    for (&x, &y) in ar.iter().zip(br) {
        let d = x.abs_diff(y) as u64;
        s1 += d;
        s2 += d * d;
    }
    (s1, s2)
}

/// The AVX2 path: `vpsadbw` sums eight absolute differences into a 64-bit lane; the differences
/// widened to 16 bits and `vpmaddwd` with themselves give sums of two squares in 32-bit lanes
/// (each lane takes ≤ 4·255² a step: blocks of 4096 steps stay below 2^32).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn abs_diff_sums_avx2(a: &[u8], b: &[u8]) -> (u64, u64) {
    use std::arch::x86_64::*;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every path against the plain definition, on random rows of every length from 0 to 300
    /// (tails of every size after the vectors), and on rows of extreme differences.
    #[test]
    fn every_path_gives_the_exact_sums() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut byte = || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 56) as u8
        };
        for n in 0..300 {
            let a: Vec<u8> = (0..n).map(|_| byte()).collect();
            let b: Vec<u8> = (0..n).map(|_| byte()).collect();
            let want = a.iter().zip(&b).fold((0u64, 0u64), |(s1, s2), (&x, &y)| {
                let d = x.abs_diff(y) as u64;
                (s1 + d, s2 + d * d)
            });
            assert_eq!(abs_diff_sums_scalar(&a, &b), want, "scalar, n = {n}");
            assert_eq!(abs_diff_sums(&a, &b), want, "dispatched, n = {n}");
        }
        // The widest window, every difference 255: the largest sums the lanes must hold.
        let (a, b) = (vec![0u8; 32768], vec![255u8; 32768]);
        let want = (32768 * 255, 32768 * 255 * 255);
        assert_eq!(abs_diff_sums_scalar(&a, &b), want);
        assert_eq!(abs_diff_sums(&b, &a), want);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_path_matches_the_scalar_one() {
        if !std::is_x86_feature_detected!("avx2") {
            return;
        }
        let a: Vec<u8> = (0..5000u32).map(|i| (i * 37 % 251) as u8).collect();
        let b: Vec<u8> = (0..5000u32).map(|i| (i * 91 % 253) as u8).collect();
        for n in [0, 1, 31, 32, 33, 1438, 5000] {
            // SAFETY: AVX2 checked above.
            let v = unsafe { abs_diff_sums_avx2(&a[..n], &b[..n]) };
            assert_eq!(v, abs_diff_sums_scalar(&a[..n], &b[..n]), "n = {n}");
        }
        let (a, b) = (vec![255u8; 200_000], vec![0u8; 200_000]);
        // SAFETY: AVX2 checked above.
        let v = unsafe { abs_diff_sums_avx2(&a, &b) };
        assert_eq!(v, abs_diff_sums_scalar(&a, &b));
    }
}
