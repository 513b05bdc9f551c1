//! The focus sums' kernel of [`crate::focus`] with AVX-512 VNNI (64 columns a step, the tail by
//! a masked load: zero lanes add nothing to any sum).

use crate::simd::Vnni;
use std::arch::x86_64::*;

/// Steps between flushes of the 32-bit lanes: a step adds at most 4 · 255 · 128 < 2^17 to a
/// dot-product lane, so a lane of the combinations of [`RowSums`] (at most 4 of them, 2^19 a
/// step) stays below 2^30 after 2^11 steps.
const FLUSH: usize = 1 << 11;

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

/// What one pass over a row x (w columns) with the row a two above it gives [`crate::focus`]
/// (D = Σx(x − 128), H = Σ_{c < w − 2} x[c + 2](x[c] − 128), V = Σ a(x − 128), S = Σx, each
/// over the whole row unless said): the parts of the squared central differences, each
/// combined in the lanes before the one reduction it takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct RowSums {
    /// Pixels at 255.
    pub saturated: u32,
    /// D + 128 S − 2 V = Σx² − 2 Σax + 256 Σa: this row's share of its vertical pair.
    pub now: i64,
    /// 2 D − 2 H: the row's share of its own horizontal pair (x[c], x[c + 2]).
    pub next: i64,
    /// D − 128 S = Σx² − 256 S: the row's share of the vertical pair it is the upper row of.
    pub after: i64,
    /// Σ_{c < w − 2} |x[c] − x[c + 2]|.
    pub h_abs: u64,
    /// Σ|x − a| over the whole row.
    pub v_abs: u64,
}

/// [`RowSums`] of `row` and the row `above` it (`row` itself without one: the vertical sums
/// are then of no use, and computed anyway, to keep one loop), in one pass over the columns:
/// a step loads x[i …], x[i + 2 …] and a[i …], flips x once into x − 128 and takes the six
/// sums from them (four `vpdpbusd` for S, D, H and V, two `vpsadbw`).
///
/// # Safety
/// The CPU must support AVX-512 F, BW, VNNI and POPCNT.
///
/// # Panics
/// If the rows' lengths differ.
#[target_feature(enable = "avx512f,avx512bw,avx512vnni,popcnt")]
unsafe fn kernel(row: &[u8], above: Option<&[u8]>) -> RowSums {
    let w = row.len();
    let a = above.unwrap_or(row);
    assert_eq!(a.len(), w, "rows of one width");
    // The horizontal pairs (x[c], x[c + 2]) cover c < w − 2.
    let m = w.saturating_sub(2);
    let (pr, pa) = (row.as_ptr(), a.as_ptr());
    let (zero, flip, ones) = (
        _mm512_setzero_si512(),
        _mm512_set1_epi8(i8::MIN),
        _mm512_set1_epi8(1),
    );
    let (mut h_abs, mut v_abs, mut top) = (zero, zero, zero);
    let (mut now, mut next, mut after) = (0i64, 0i64, 0i64);
    let mut i = 0;
    while i < w {
        let end = (i + 64 * FLUSH).min(w);
        let (mut s, mut d, mut h, mut v) = (zero, zero, zero, zero);
        while i < end {
            // SAFETY: plain loads when columns i … i + 65 are inside the rows; masked loads
            // otherwise, each covering only columns inside its row (x and a: i … w − 1;
            // x[c + 2]: c in i … m − 1).
            let (x, xh, x2, ai) = unsafe {
                if i + 64 <= m {
                    let x = _mm512_loadu_si512(pr.add(i).cast());
                    (
                        x,
                        x,
                        _mm512_loadu_si512(pr.add(i + 2).cast()),
                        _mm512_loadu_si512(pa.add(i).cast()),
                    )
                } else {
                    let (kr, kp) = (mask(i, w), mask(i.min(m), m));
                    // (`wrapping_add`: with an empty mask the address may lie past
                    // the row; it is never dereferenced.)
                    let x = _mm512_maskz_loadu_epi8(kr, pr.wrapping_add(i).cast());
                    (
                        x,
                        _mm512_maskz_mov_epi8(kp, x),
                        _mm512_maskz_loadu_epi8(kp, pr.wrapping_add(i + 2).cast()),
                        _mm512_maskz_loadu_epi8(kr, pa.wrapping_add(i).cast()),
                    )
                }
            };
            let xf = _mm512_xor_si512(x, flip);
            top = _mm512_max_epu8(top, x);
            s = _mm512_dpbusd_epi32(s, x, ones);
            d = _mm512_dpbusd_epi32(d, x, xf);
            h = _mm512_dpbusd_epi32(h, x2, xf);
            v = _mm512_dpbusd_epi32(v, ai, xf);
            h_abs = _mm512_add_epi64(h_abs, _mm512_sad_epu8(xh, x2));
            v_abs = _mm512_add_epi64(v_abs, _mm512_sad_epu8(x, ai));
            i += 64;
        }
        let s7 = _mm512_slli_epi32::<7>(s);
        now += lanes_i64(_mm512_sub_epi32(
            _mm512_add_epi32(d, s7),
            _mm512_add_epi32(v, v),
        ));
        next += lanes_i64(_mm512_slli_epi32::<1>(_mm512_sub_epi32(d, h)));
        after += lanes_i64(_mm512_sub_epi32(d, s7));
    }
    RowSums {
        saturated: if _mm512_cmpeq_epi8_mask(top, _mm512_set1_epi8(-1)) == 0 {
            0
        } else {
            saturated(row)
        },
        now,
        next,
        after,
        h_abs: _mm512_reduce_add_epi64(h_abs) as u64,
        v_abs: _mm512_reduce_add_epi64(v_abs) as u64,
    }
}

/// The pixels of `row` at 255 (the rows that have any: [`kernel`] finds them by the row's
/// maximum, one operation a step, and counts only there).
#[inline]
#[target_feature(enable = "avx512f,avx512bw,popcnt")]
fn saturated(row: &[u8]) -> u32 {
    let full = _mm512_set1_epi8(-1);
    let mut n = 0;
    for i in (0..row.len()).step_by(64) {
        // SAFETY: the mask covers columns i … min(i + 64, w) − 1, inside the row.
        let x = unsafe { _mm512_maskz_loadu_epi8(mask(i, row.len()), row.as_ptr().add(i).cast()) };
        n += _mm512_cmpeq_epi8_mask(x, full).count_ones();
    }
    n
}

/// [`kernel`] on a CPU that has the features (`_cpu` proves it): the [`RowSums`] of `row` and
/// the row two above it.
///
/// # Panics
/// If `above` is given and the rows' lengths differ.
#[inline]
pub(crate) fn row_sums(_cpu: Vnni, row: &[u8], above: Option<&[u8]>) -> RowSums {
    // SAFETY: `vnni` is true only when the CPU has AVX-512 F/BW and VNNI
    // (`is_x86_feature_detected!` in `simd::detected` and `simd::vnni`; `_cpu` proves it);
    // `kernel` checks the lengths.
    unsafe { kernel(row, above) }
}
