//! The focus sums' kernel of [`crate::focus`] with AVX-512 VNNI (64 columns a step, the tail by
//! a masked load: zero lanes add nothing to any sum).

use crate::simd::Vnni;
use std::arch::x86_64::*;

/// Steps between flushes of the 32-bit dot-product lanes: a step adds at most
/// 4 · 255 · 128 < 2^17 to a lane, so 2^13 steps stay below 2^30.
const FLUSH: usize = 1 << 13;

/// The 64-byte mask of columns i … n − 1 (all 64 when that many remain).
#[inline(always)]
fn mask(i: usize, n: usize) -> __mmask64 {
    crate::simd::first_lanes(n - i)
}

/// The sixteen signed 32-bit lanes of `v`, summed as 64-bit.
#[inline]
#[target_feature(enable = "avx512f")]
fn lanes_i64(v: __m512i) -> i64 {
    let lo = _mm512_cvtepi32_epi64(_mm512_castsi512_si256(v));
    let hi = _mm512_cvtepi32_epi64(_mm512_extracti64x4_epi64::<1>(v));
    _mm512_reduce_add_epi64(_mm512_add_epi64(lo, hi))
}

/// The row's (Σx, Σx²), its count of 255s and, with `prev` = (a, b), added together,
/// Σ|x − y| and Σx(y − 128) of the two pairs (b[0 .. w − 2], b[2 .. w]) and
/// (row[1 .. w − 1], a[1 .. w − 1]) (0 and 0 without `prev`), in one pass over the rows:
/// one loop and one set of reductions a row instead of one per sum.
///
/// # Safety
/// The CPU must support AVX-512 F, BW, VNNI and POPCNT.
///
/// # Panics
/// If `prev` is given and the rows' lengths differ or are below 2.
#[target_feature(enable = "avx512f,avx512bw,avx512vnni,popcnt")]
unsafe fn kernel(row: &[u8], prev: Option<(&[u8], &[u8])>) -> ((i64, i64), u32, u64, i64) {
    let w = row.len();
    // The pairs cover w − 2 columns (b from 0 and 2, row and a from 1), none without
    // `prev` (their loads then read no byte).
    let (a, b, m) = match prev {
        Some((a, b)) => {
            assert!(
                w >= 2 && a.len() == w && b.len() == w,
                "rows of one width ≥ 2"
            );
            (a, b, w - 2)
        }
        None => (row, row, 0),
    };
    let (pr, pa, pb) = (row.as_ptr(), a.as_ptr(), b.as_ptr());
    let (zero, flip, full) = (
        _mm512_setzero_si512(),
        _mm512_set1_epi8(i8::MIN),
        _mm512_set1_epi8(-1),
    );
    let (mut sum, mut sad, mut sat) = (zero, zero, 0u32);
    let (mut sq, mut dot) = (0i64, 0i64);
    let mut i = 0;
    while i < w {
        let end = (i + 64 * FLUSH).min(w);
        let (mut acc, mut dh, mut dv) = (zero, zero, zero);
        while i < end {
            // SAFETY: plain loads when columns i … i + 63 of the row and i … i + 65 of
            // the pairs' reads are inside the rows; masked loads otherwise, each covering
            // only its own slice's columns (the row's i … w − 1; the pairs' i … m − 1).
            let (x, hx, hy, vx, vy) = unsafe {
                if i + 64 <= m {
                    (
                        _mm512_loadu_si512(pr.add(i).cast()),
                        _mm512_loadu_si512(pb.add(i).cast()),
                        _mm512_loadu_si512(pb.add(i + 2).cast()),
                        _mm512_loadu_si512(pr.add(i + 1).cast()),
                        _mm512_loadu_si512(pa.add(i + 1).cast()),
                    )
                } else {
                    let (kr, kp) = (mask(i, w), mask(i.min(m), m));
                    // (`wrapping_add`: with an empty mask the address may lie past
                    // the row; it is never dereferenced.)
                    (
                        _mm512_maskz_loadu_epi8(kr, pr.wrapping_add(i).cast()),
                        _mm512_maskz_loadu_epi8(kp, pb.wrapping_add(i).cast()),
                        _mm512_maskz_loadu_epi8(kp, pb.wrapping_add(i + 2).cast()),
                        _mm512_maskz_loadu_epi8(kp, pr.wrapping_add(i + 1).cast()),
                        _mm512_maskz_loadu_epi8(kp, pa.wrapping_add(i + 1).cast()),
                    )
                }
            };
            sat += _mm512_cmpeq_epi8_mask(x, full).count_ones();
            sum = _mm512_add_epi64(sum, _mm512_sad_epu8(x, zero));
            acc = _mm512_dpbusd_epi32(acc, x, _mm512_xor_si512(x, flip));
            sad = _mm512_add_epi64(
                sad,
                _mm512_add_epi64(_mm512_sad_epu8(hx, hy), _mm512_sad_epu8(vx, vy)),
            );
            dh = _mm512_dpbusd_epi32(dh, hx, _mm512_xor_si512(hy, flip));
            dv = _mm512_dpbusd_epi32(dv, vx, _mm512_xor_si512(vy, flip));
            i += 64;
        }
        sq += lanes_i64(acc);
        dot += lanes_i64(dh) + lanes_i64(dv);
    }
    let sum = _mm512_reduce_add_epi64(sum);
    (
        (sum, sq + 128 * sum),
        sat,
        _mm512_reduce_add_epi64(sad) as u64,
        dot,
    )
}

/// [`kernel`] on a CPU that has the features (`_cpu` proves it): the row's (Σx, Σx²), its count
/// of 255s and, with `prev` = (a, b), the two pairs' Σ|x − y| and Σx(y − 128).
///
/// # Panics
/// If `prev` is given and the rows' lengths differ or are below 2.
#[inline]
pub(crate) fn row_sums(
    _cpu: Vnni,
    row: &[u8],
    prev: Option<(&[u8], &[u8])>,
) -> ((i64, i64), u32, u64, i64) {
    // SAFETY: `vnni` is true only when the CPU has AVX-512 F/BW and VNNI
    // (`is_x86_feature_detected!` in `simd::detected` and `simd::vnni`; `_cpu` proves it);
    // `kernel` checks the lengths.
    unsafe { kernel(row, prev) }
}
