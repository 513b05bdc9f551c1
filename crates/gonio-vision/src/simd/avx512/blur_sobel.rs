//! The fused blur and Sobel row kernel of [`crate::blur_sobel`] with AVX-512 intrinsics (see
//! that module's docs).
//!
//! 64 columns a step, split into their even and odd columns, 32 16-bit lanes each (`e`, `o`):
//! a 64-byte load of a `u8` row gives both with a mask and a shift, no zero-extending
//! shuffles. The horizontal neighbours of an even column are odd ones and vice versa, so each
//! tap is a lane shift by one (`vpermt2w` with the neighbouring step's vector) of half the
//! vectors, or no shift at all. The Sobel's ring holds its rows in this split layout (even
//! columns, then odd ones, per 64 columns); the gradient rows are interleaved back into column
//! order (`vpermt2w`) before they are stored.

use crate::row_types::GradRow;
use crate::simd::Avx512;
use std::arch::x86_64::*;

/// `vpermt2w` lane indices: lane i takes lane i / `div` + `base` + `odd` · (i mod 2) of
/// the pair of vectors (0 … 31 the first, 32 … 63 the second).
const fn table(div: i16, base: i16, odd: i16) -> [i16; 32] {
    let mut t = [0i16; 32];
    let mut i = 0;
    while i < 32 {
        let l = i as i16;
        t[i] = l / div + base + odd * (l % 2);
        i += 1;
    }
    t
}
/// Lane m + 1 of (this vector, the next one).
const NEXT: [i16; 32] = table(1, 1, 0);
/// Lane m − 1 of (the previous vector, this one).
const PREV: [i16; 32] = table(1, 31, 0);
/// Columns 0 … 31 and 32 … 63 of a step from its (even, odd) vectors.
const LOW: [i16; 32] = table(2, 0, 32);
const HIGH: [i16; 32] = table(2, 16, 32);

/// The gradient row the kernel writes: `out`, with the Sobel ring's rows above it (`a`)
/// and of it (`b`) as offsets.
pub(crate) struct Emit<'a> {
    pub out: &'a mut GradRow,
    pub a: usize,
    pub b: usize,
}

#[inline]
#[target_feature(enable = "avx512f,avx512bw")]
fn index(t: &[i16; 32]) -> __m512i {
    // SAFETY: 64 bytes read from a 64-byte array.
    unsafe { _mm512_loadu_si512(t.as_ptr().cast()) }
}

/// Every lane set to lane `i` of `v`.
#[inline]
#[target_feature(enable = "avx512f,avx512bw")]
fn broadcast(v: __m512i, i: usize) -> __m512i {
    _mm512_permutexvar_epi16(_mm512_set1_epi16(i as i16), v)
}

/// The lowest `n` lanes (≤ 32).
#[inline]
fn lanes(n: usize) -> __mmask32 {
    if n >= 32 { !0 } else { (1u32 << n) - 1 }
}

/// A step's (even, odd) vectors with the columns from `tail` on (the row's end) replaced
/// by column `tail − 1` (replicated border); returns them and that column broadcast.
#[inline]
#[target_feature(enable = "avx512f,avx512bw")]
fn replicate_after(e: __m512i, o: __m512i, tail: usize) -> (__m512i, __m512i, __m512i) {
    let last = if tail % 2 == 1 {
        broadcast(e, tail / 2)
    } else {
        broadcast(o, tail / 2 - 1)
    };
    let e = _mm512_mask_blend_epi16(lanes(tail.div_ceil(2)), last, e);
    let o = _mm512_mask_blend_epi16(lanes(tail / 2), last, o);
    (e, o, last)
}

/// With `blur = Some((ring, window))`: blurs the rows at `window` (offsets into `ring`:
/// rows y − 2 … y + 2) into row y, its Sobel smooth (1 2 1) and difference (−1 0 1) into
/// the Sobel's rings `smooth` and `diff` at offset `c` (split layout), its `u8` values into
/// `out8` if `blurred`. With `emit`: the gradient row above row y, from the rings' rows
/// `a`, `b` and row y's smooth and difference in registers; or, without `blur`, from the
/// rings' rows `a`, `b`, `c`.
///
/// # Safety
/// The CPU must support AVX-512 F/BW/VL/DQ. The lengths are asserted.
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq,avx2")]
unsafe fn kernel(
    blur: Option<(&[u8], [usize; 5])>,
    (smooth, diff): (&mut [i16], &mut [i16]),
    c: usize,
    out8: &mut [u8],
    blurred: bool,
    emit: Option<Emit<'_>>,
) {
    let w = out8.len();
    assert!(w > 0 && (blur.is_some() || emit.is_some()));
    let n = w.div_ceil(64);
    // Whole vectors are read and written in the rings (their rows are padded to 64
    // columns), masked ones in the output rows.
    if let Some((ring, window)) = blur {
        assert!(window.iter().all(|&o| o + n * 64 <= ring.len()));
    }
    assert!(c + n * 64 <= smooth.len() && c + n * 64 <= diff.len());
    if let Some(e) = &emit {
        assert!(e.a + n * 64 <= smooth.len() && e.b + n * 64 <= diff.len());
        assert!(e.out.gx.len() == w && e.out.gy.len() == w && e.out.mag.len() == w);
    }
    let tail = w - (n - 1) * 64;
    let (next, prev, low, high) = (index(&NEXT), index(&PREV), index(&LOW), index(&HIGH));
    let sp = smooth.as_mut_ptr();
    let dp = diff.as_mut_ptr();
    let emit = emit.map(|e| {
        let o = e.out;
        let p = (o.gx.as_mut_ptr(), o.gy.as_mut_ptr(), o.mag.as_mut_ptr());
        (p, e.a, e.b)
    });

    // The gradients of step j from row y's smooth and difference (split layout).
    let gradients = |j: usize, [sm_e, sm_o, df_e, df_o]: [__m512i; 4]| {
        let Some(((gxp, gyp, magp), a, b)) = emit else {
            return;
        };
        let x = 64 * j;
        // SAFETY: 64 lanes at `a + x`, `b + x` ≤ len − 64 (asserted above); the gradient
        // row's stores are masked to its `w` lanes.
        unsafe {
            let ld = |p: *mut i16, o: usize| _mm512_loadu_si512(p.add(o + x).cast());
            let gx = |d: __m512i, o: usize| {
                let (da, db) = (ld(dp, a + o), ld(dp, b + o));
                _mm512_add_epi16(_mm512_add_epi16(da, d), _mm512_add_epi16(db, db))
            };
            let (gx_e, gx_o) = (gx(df_e, 0), gx(df_o, 32));
            let gy_e = _mm512_sub_epi16(sm_e, ld(sp, a));
            let gy_o = _mm512_sub_epi16(sm_o, ld(sp, a + 32));
            let m = if j + 1 == n { tail } else { 64 };
            for (half, idx, mask) in [(0, low, lanes(m)), (32, high, lanes(m.saturating_sub(32)))] {
                let gx = _mm512_permutex2var_epi16(gx_e, idx, gx_o);
                let gy = _mm512_permutex2var_epi16(gy_e, idx, gy_o);
                let mag = _mm512_add_epi16(_mm512_abs_epi16(gx), _mm512_abs_epi16(gy));
                _mm512_mask_storeu_epi16(gxp.add(x + half).cast(), mask, gx);
                _mm512_mask_storeu_epi16(gyp.add(x + half).cast(), mask, gy);
                _mm512_mask_storeu_epi16(magp.add(x + half).cast(), mask, mag);
            }
        }
    };

    let Some((ring, window)) = blur else {
        // Only the gradient row, from the ring's row c.
        for j in 0..n {
            // SAFETY: 64 lanes at `c + 64j` ≤ len − 64 (asserted above).
            let ld =
                |p: *mut i16, o: usize| unsafe { _mm512_loadu_si512(p.add(c + 64 * j + o).cast()) };
            gradients(j, [ld(sp, 0), ld(sp, 32), ld(dp, 0), ld(dp, 32)]);
        }
        return;
    };

    let rp = ring.as_ptr();
    let bytes = _mm512_set1_epi16(0xff);
    let six = _mm512_set1_epi16(6);
    let half = _mm512_set1_epi16(128);
    // The vertical sums of step k: (even, odd) columns.
    let vsum = |k: usize| {
        let split = |o: usize| {
            // SAFETY: 64 bytes at `o + 64k` ≤ ring.len() − 64 (asserted above).
            let x = unsafe { _mm512_loadu_si512(rp.add(o + 64 * k).cast()) };
            (_mm512_and_si512(x, bytes), _mm512_srli_epi16::<8>(x))
        };
        let [r0, r1, r2, r3, r4] = window.map(split);
        let sum = |a: __m512i, b: __m512i, c: __m512i, d: __m512i, e: __m512i| {
            let bd = _mm512_add_epi16(b, d);
            _mm512_add_epi16(
                _mm512_add_epi16(a, e),
                _mm512_add_epi16(_mm512_slli_epi16::<2>(bd), _mm512_mullo_epi16(c, six)),
            )
        };
        (
            sum(r0.0, r1.0, r2.0, r3.0, r4.0),
            sum(r0.1, r1.1, r2.1, r3.1, r4.1),
        )
    };
    // (t[x−2] + t[x+2]) + 4 (t[x−1] + t[x+1]) + 6 t[x], rounded: ≤ 256·255 + 128.
    let blur = |far: __m512i, near: __m512i, centre: __m512i| {
        let s = _mm512_add_epi16(far, _mm512_slli_epi16::<2>(near));
        let s = _mm512_add_epi16(s, _mm512_add_epi16(_mm512_mullo_epi16(centre, six), half));
        _mm512_srli_epi16::<8>(s)
    };
    // The Sobel's smooth and difference of step j from the blurred (even, odd) columns of
    // steps j − 1 (its odd ones), j and j + 1 (its even ones); stored, then the gradients.
    let sobel = |j: usize, o_prev: __m512i, (e, o): (__m512i, __m512i), e_next: __m512i| {
        let op = _mm512_permutex2var_epi16(o_prev, prev, o); // column 2m − 1
        let en = _mm512_permutex2var_epi16(e, next, e_next); // column 2m + 2
        let sm_e = _mm512_add_epi16(_mm512_add_epi16(op, o), _mm512_add_epi16(e, e));
        let sm_o = _mm512_add_epi16(_mm512_add_epi16(e, en), _mm512_add_epi16(o, o));
        let df_e = _mm512_sub_epi16(o, op);
        let df_o = _mm512_sub_epi16(en, e);
        let x = c + 64 * j;
        // SAFETY: 64 lanes at `c + 64j` ≤ len − 64 (asserted above).
        unsafe {
            _mm512_storeu_si512(sp.add(x).cast(), sm_e);
            _mm512_storeu_si512(sp.add(x + 32).cast(), sm_o);
            _mm512_storeu_si512(dp.add(x).cast(), df_e);
            _mm512_storeu_si512(dp.add(x + 32).cast(), df_o);
        }
        gradients(j, [sm_e, sm_o, df_e, df_o]);
    };

    let (mut ve, mut vo) = vsum(0);
    if n == 1 {
        (ve, vo, _) = replicate_after(ve, vo, tail);
    }
    let first = broadcast(ve, 0);
    let (mut ve_prev, mut vo_prev) = (first, first);
    let mut b_prev = (first, first);
    let mut bo_prev2 = first;
    for k in 0..n {
        let (ve_next, vo_next) = if k + 2 < n {
            vsum(k + 1)
        } else if k + 2 == n {
            let (e, o) = vsum(k + 1);
            let (e, o, _) = replicate_after(e, o, tail);
            (e, o)
        } else {
            let (_, _, last) = replicate_after(ve, vo, tail);
            (last, last)
        };
        let ep = _mm512_permutex2var_epi16(ve_prev, prev, ve); // column 2m − 2
        let en = _mm512_permutex2var_epi16(ve, next, ve_next); // column 2m + 2
        let op = _mm512_permutex2var_epi16(vo_prev, prev, vo); // column 2m − 1
        let on = _mm512_permutex2var_epi16(vo, next, vo_next); // column 2m + 3
        let be = blur(_mm512_add_epi16(ep, en), _mm512_add_epi16(op, vo), ve);
        let bo = blur(_mm512_add_epi16(op, on), _mm512_add_epi16(ve, en), vo);
        if blurred {
            let b8 = _mm512_or_si512(be, _mm512_slli_epi16::<8>(bo));
            let mask = crate::simd::first_lanes(if k + 1 == n { tail } else { 64 });
            // SAFETY: masked to the columns inside the row.
            unsafe { _mm512_mask_storeu_epi8(out8.as_mut_ptr().add(64 * k).cast(), mask, b8) };
        }
        let (be, bo) = if k + 1 == n {
            let (e, o, _) = replicate_after(be, bo, tail);
            (e, o)
        } else {
            (be, bo)
        };
        if k == 0 {
            let first = broadcast(be, 0);
            (bo_prev2, b_prev) = (first, (be, bo));
        } else {
            sobel(k - 1, bo_prev2, b_prev, be);
            (bo_prev2, b_prev) = (b_prev.1, (be, bo));
        }
        (ve_prev, vo_prev, ve, vo) = (ve, vo, ve_next, vo_next);
    }
    let (_, _, last) = replicate_after(b_prev.0, b_prev.1, tail);
    sobel(n - 1, bo_prev2, b_prev, last);
}

/// [`kernel`] on a CPU that has the features (`_cpu` proves it): the same arguments.
#[inline]
pub(crate) fn blur_sobel(
    _cpu: Avx512,
    blur: Option<(&[u8], [usize; 5])>,
    (smooth, diff): (&mut [i16], &mut [i16]),
    c: usize,
    out8: &mut [u8],
    blurred: bool,
    emit: Option<Emit<'_>>,
) {
    // SAFETY: the AVX-512 level is used only on a CPU with AVX-512 F/BW/VL/DQ (checked in
    // `simd::detected`; `_cpu` proves it); the kernel asserts the rows' lengths.
    unsafe { kernel(blur, (smooth, diff), c, out8, blurred, emit) }
}
