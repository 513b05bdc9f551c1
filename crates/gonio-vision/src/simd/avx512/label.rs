//! The labeller's ([`crate::label`]) writes of a row's kept edge pixels with AVX-512, four pixels a step (written by hand: no loop the compiler
//! vectorises compresses): the four pixels' 64 bytes loaded without their padding, the row
//! and the labels blended in, the kept ones packed to the front by `vpcompressq` and all 64
//! bytes stored (the unkept tail is overwritten by the next step, as the scalar loop
//! overwrites a filled pixel). The same fields as the scalar `write_kept`; padding bytes are zero.
//!
//! And [`run`]: a closure compiled with the AVX-512 level's features (the labeller's row pass).

use crate::row_types::{EdgePixel, FILLED};
use crate::simd::Avx512;
use std::arch::x86_64::*;

/// As [`crate::label`]'s scalar `write_kept` for the whole steps of four pixels: returns how many
/// of `px` it wrote (a multiple of four; the rest is the scalar loop's) and the new `n`.
///
/// # Safety
/// The CPU must support AVX-512 F, BW, VL and DQ.
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq")]
unsafe fn kernel(
    px: &[EdgePixel],
    lab: &[u32],
    row: u16,
    out: &mut [EdgePixel],
    mut n: usize,
) -> (usize, usize) {
    const _: () = assert!(std::mem::size_of::<EdgePixel>() == 16);
    assert!(lab.len() >= px.len() && out.len() >= n + px.len());
    // Per pixel: bytes 0–6 (row, col, class, dir, sub), 8–9 (mag), 12–15 (comp).
    const FIELDS: u64 = 0xF37F_F37F_F37F_F37F;
    let rows = _mm512_set1_epi16(row as i16);
    // Dword 3 of pixel j takes label j.
    let to_comp = _mm512_set_epi32(3, 0, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0);
    // `sub` is byte 6 of a pixel's first quadword: kept unless it is FILLED.
    let sub = _mm512_set_epi64(0, 0xFF << 48, 0, 0xFF << 48, 0, 0xFF << 48, 0, 0xFF << 48);
    let filled = _mm512_set1_epi64(((FILLED as u8 as u64) << 48) as i64);
    let mut k = 0;
    while k + 4 <= px.len() {
        // SAFETY: pixels k … k + 3 and labels k … k + 3 are in their slices (the masked
        // load reads no padding byte); the store covers out[n .. n + 4], inside `out`
        // because n ≤ n₀ + k and out.len() ≥ n₀ + px.len() ≥ n₀ + k + 4.
        unsafe {
            let v = _mm512_maskz_loadu_epi8(FIELDS, px.as_ptr().add(k).cast());
            let l = _mm512_castsi128_si512(_mm_loadu_si128(lab.as_ptr().add(k).cast()));
            let v = _mm512_mask_permutexvar_epi32(v, 0x8888, to_comp, l);
            let v = _mm512_mask_mov_epi16(v, 0x0101_0101, rows);
            let kept = _mm512_test_epi64_mask(_mm512_xor_si512(v, filled), sub);
            let packed = _mm512_maskz_compress_epi64(kept | (kept << 1), v);
            _mm512_storeu_si512(out.as_mut_ptr().add(n).cast(), packed);
            n += kept.count_ones() as usize;
        }
        k += 4;
    }
    (k, n)
}

/// [`kernel`] on a CPU that has the features (`_cpu` proves it): the pixels written (whole
/// steps of four) and the new `n`.
#[inline]
pub(crate) fn write_kept(
    _cpu: Avx512,
    px: &[EdgePixel],
    lab: &[u32],
    row: u16,
    out: &mut [EdgePixel],
    n: usize,
) -> (usize, usize) {
    // SAFETY: the CPU has AVX-512 F/BW/VL/DQ (`simd::level` returns `Avx512` only when
    // `is_x86_feature_detected!` found them; `_cpu` proves it); `kernel` asserts the lengths.
    unsafe { kernel(px, lab, row, out, n) }
}

/// Runs `f` compiled with the AVX-512 level's features (F/BW/VL/DQ, AVX2, BMI1/2, LZCNT,
/// POPCNT) on a CPU that has them (`_cpu` proves it): the same code, with vector additions
/// for the sums' arrays of four and BMI2 shifts.
#[inline(always)]
pub(crate) fn run<R>(_cpu: Avx512, f: impl FnOnce() -> R) -> R {
    // SAFETY: the CPU has AVX-512 F/BW/VL/DQ (`simd::level` returns `Avx512` only when
    // `is_x86_feature_detected!` found them, and AVX2/BMI with them; `_cpu` proves it).
    unsafe { crate::simd::with_avx512(f) }
}
