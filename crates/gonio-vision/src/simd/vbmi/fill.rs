//! The row scan of [`crate::fill`]'s edge filling with AVX-512 (F/BW + VBMI2): the candidate
//! test of eight words at once, the shifts across words by `vpshldq`/`vpshrdq`.

use crate::simd::Vbmi;
use std::arch::x86_64::*;

/// Lanes j of eight 64-bit words with 1 ≤ `start` + j ≤ `n` (word `start` + j − 1 inside a
/// row of `n` words).
#[inline(always)]
fn lanes(start: usize, n: usize) -> u8 {
    let below = 1usize.saturating_sub(start) as u32;
    let upto = (n + 1).saturating_sub(start).min(8) as u32;
    (((1u32 << upto) - 1) & !((1u32 << below) - 1)) as u8
}

/// The scan's kernel ([`scan`]).
///
/// # Safety
/// The CPU must support AVX-512 F/BW and VBMI2.
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi2,bmi1")]
unsafe fn kernel(c: &[u64], u: &[u64], d: &[u64], f: &mut impl FnMut(usize)) {
    let n = c.len();
    assert!(u.len() == n && d.len() == n);
    let mut i = 0;
    while i < n {
        // Words i − 1 + j, i + j and i + 1 + j of lane j, zero outside the row.
        let (mp, mc, mn) = (lanes(i, n), lanes(i + 1, n), lanes(i + 2, n));
        macro_rules! ld {
            ($b:expr, $m:expr, $at:expr) => {
                // SAFETY: masked loads read only the lanes of their mask, words 0 … n − 1
                // (lane j of a load at `at` reads word at − 1 + j).
                unsafe {
                    _mm512_maskz_loadu_epi64(
                        $m,
                        $b.as_ptr().wrapping_add($at).wrapping_sub(1).cast(),
                    )
                }
            };
        }
        let (cw, uw, dw) = (ld!(c, mc, i + 1), ld!(u, mc, i + 1), ld!(d, mc, i + 1));
        let (cp, up, dp) = (ld!(c, mp, i), ld!(u, mp, i), ld!(d, mp, i));
        let (cn, un, dn) = (ld!(c, mn, i + 2), ld!(u, mn, i + 2), ld!(d, mn, i + 2));
        // from_left(w, prev) = shld(w, prev, 1); from_right(w, next) = shrd(w, next, 1).
        let we = _mm512_and_si512(
            _mm512_shldi_epi64::<1>(cw, cp),
            _mm512_shrdi_epi64::<1>(cw, cn),
        );
        let ns = _mm512_and_si512(uw, dw);
        let nwse = _mm512_and_si512(
            _mm512_shldi_epi64::<1>(uw, up),
            _mm512_shrdi_epi64::<1>(dw, dn),
        );
        let nesw = _mm512_and_si512(
            _mm512_shrdi_epi64::<1>(uw, un),
            _mm512_shldi_epi64::<1>(dw, dp),
        );
        let any = _mm512_or_si512(_mm512_or_si512(we, ns), _mm512_or_si512(nwse, nesw));
        let mut m = _mm512_mask_test_epi64_mask(mc, _mm512_andnot_si512(cw, any), any);
        while m != 0 {
            f(i + m.trailing_zeros() as usize);
            m &= m - 1;
        }
        i += 8;
    }
}

/// Calls `f(i)` for every word i of the rows' edge bits (`c` the row, `u`, `d` the rows above
/// and below) holding an empty pixel with an opposite pair of edge neighbours, in order, on a
/// CPU with AVX-512 F/BW and VBMI2 (`_cpu` proves it).
#[inline]
pub(crate) fn scan(_cpu: Vbmi, c: &[u64], u: &[u64], d: &[u64], f: &mut impl FnMut(usize)) {
    // SAFETY: `simd::vbmi` is true only on a CPU with AVX-512 F/BW and VBMI2 (`_cpu` proves
    // it).
    unsafe { kernel(c, u, d, f) }
}
