//! The segmentation of a row ([`crate::segment`]) with AVX-512 (F/BW/VL/DQ, VBMI for the
//! pixels' byte permutes, VBMI2 for the compress of the kept columns): the classification with compares
//! into mask registers, 64 columns a step, the kept columns compressed into a list
//! (`vpcompressb` per word of bits), then the direction and the sub-pixel offset of the kept
//! pixels in vector lanes, 16 at a time, with no data-dependent branch. Every step is the
//! integer (or exact f32) arithmetic of the scalar path, so the pixels are the same.

use crate::row_types::{EdgePixel, GradRow, STRONG, WEAK};
use crate::segment::tables::{ATAN64, ClassConsts, KeptScratch, TAN22_MUL, TAN22_Q8};
use crate::simd::Vbmi;
use std::arch::x86_64::*;

/// [`ATAN64`]`[0 … 63]` widened to the 32-bit lanes of the direction kernel's table
/// look-ups (entry 64 is handled by a compare), built at compile time.
const ATAN64_I32: [i32; 64] = {
    let mut t = [0i32; 64];
    let mut i = 0;
    while i < 64 {
        t[i] = ATAN64[i] as i32;
        i += 1;
    }
    t
};

/// Classifies row `cur` (between `up` and `down`, zero rows outside the frame; columns
/// outside the row count as zero magnitudes, as in [`crate::segment::segment_pixel`]); writes the
/// kept columns' bits into `bits`, the neighbours across the edge into `s.a`, `s.b` (unless
/// `HORIZ`: then they are the left and right ones) and the kept columns into `s.cols`.
/// Returns the number kept.
///
/// 64 columns (one word of bits) a step, as two halves of 32 16-bit lanes ([`half`]).
/// Inside the row the loads are plain ones (no mask register moved in and out per load);
/// only at the row's two ends do masked loads zero the columns outside it. The kept
/// columns are listed in a second pass over the words: one `vpcompressb` of the byte
/// offsets 0 … 63 per word, widened to 16-bit columns, stored by a 32-byte store (most
/// words keep a few pixels). In one pass, every compress waited at the end of its
/// word's chain of loads, compares and mask moves (`perf` put ≈ 40 % of the kernel on
/// the store after it) and fewer words were in flight.
///
/// # Safety
/// The CPU must support AVX-512 F/BW/VL/DQ and VBMI2; `up`, `down` and `cur`'s rows have
/// the same length, `bits` holds a bit per column.
#[target_feature(
    enable = "avx512f,avx512bw,avx512vl,avx512dq,avx512vbmi2,avx2,bmi1,bmi2,lzcnt,popcnt"
)]
unsafe fn classify_kernel<const HORIZ: bool>(
    cur: &GradRow,
    up: &[u16],
    down: &[u16],
    k: &ClassConsts,
    s: &mut KeptScratch,
    bits: &mut [u64],
) -> usize {
    let w = cur.mag.len();
    assert!(up.len() == w && down.len() == w && cur.gx.len() == w && cur.gy.len() == w);
    assert!(bits.len() * 64 >= w && s.a.len() >= w.div_ceil(32) * 32);
    assert!(s.b.len() == s.a.len() && s.cols.len() >= w + 32 && w <= 1 << 15);
    let rows = Rows {
        gx: cur.gx.as_ptr().cast(),
        gy: cur.gy.as_ptr().cast(),
        c: cur.mag.as_ptr(),
        up: up.as_ptr(),
        down: down.as_ptr(),
    };
    // SAFETY: IOTA8 holds 64 bytes.
    let iota8 = unsafe { _mm512_loadu_si512(IOTA8.as_ptr().cast()) };
    let mut n = 0usize;
    // The 32 lanes from column x inside the row; for the left/right neighbours, the lanes
    // whose neighbour is.
    let masks = |x: usize| -> [__mmask32; 3] {
        let rem = w.saturating_sub(x);
        let mc: __mmask32 = if rem >= 32 { !0 } else { (1u32 << rem) - 1 };
        let ml = if x == 0 { mc & !1 } else { mc };
        let mr = if rem > 32 { !0 } else { mc >> 1 };
        [mc, ml, mr]
    };
    for (j, word) in bits[..w.div_ceil(64)].iter_mut().enumerate() {
        let x0 = 64 * j;
        // SAFETY: columns x0 − 1 … x0 + 64 inside the row for the plain loads; else the
        // masks select columns 0 … w − 1 only (none past the row's end).
        let ((k0, (a0, b0)), (k1, (a1, b1))) = unsafe {
            if x0 > 0 && x0 + 65 <= w {
                (
                    half::<HORIZ, false>(&rows, x0, [!0; 3], k),
                    half::<HORIZ, false>(&rows, x0 + 32, [!0; 3], k),
                )
            } else {
                (
                    half::<HORIZ, true>(&rows, x0, masks(x0), k),
                    half::<HORIZ, true>(&rows, x0 + 32, masks(x0 + 32), k),
                )
            }
        };
        let kk = k0 as u64 | (k1 as u64) << 32;
        *word = kk;
        if !HORIZ {
            // SAFETY: x0 + 32 ≤ the scratch rows' length (w rounded up to 32), and
            // x0 + 64 when the second half has columns.
            unsafe {
                _mm512_storeu_si512(s.a.as_mut_ptr().add(x0).cast(), a0);
                _mm512_storeu_si512(s.b.as_mut_ptr().add(x0).cast(), b0);
                if x0 + 32 < w {
                    _mm512_storeu_si512(s.a.as_mut_ptr().add(x0 + 32).cast(), a1);
                    _mm512_storeu_si512(s.b.as_mut_ptr().add(x0 + 32).cast(), b1);
                }
            }
        }
    }
    // The kept columns, listed from the words (a second pass: the compress no longer
    // waits on the classification's chain of loads, compares and mask moves).
    for (j, &kk) in bits[..w.div_ceil(64)].iter().enumerate() {
        let x0 = 64 * j;
        // The kept columns' offsets in the word (bytes), widened to columns.
        let offs = _mm512_maskz_compress_epi8(kk, iota8);
        let base = _mm512_set1_epi16(x0 as i16);
        let lo = _mm512_add_epi16(_mm512_cvtepu8_epi16(_mm512_castsi512_si256(offs)), base);
        let m = kk.count_ones() as usize;
        // SAFETY: n ≤ the columns before x0 (x0 < w) and `cols` holds w + 32: the 16
        // and 32 columns stored from n fit; beyond 32 only the m − 32 lanes kept are.
        unsafe {
            let p = s.cols.as_mut_ptr().add(n);
            if m <= 16 {
                _mm256_storeu_si256(p.cast(), _mm512_castsi512_si256(lo));
            } else {
                _mm512_storeu_si512(p.cast(), lo);
                if m > 32 {
                    let hi = _mm512_cvtepu8_epi16(_mm512_extracti64x4_epi64::<1>(offs));
                    let hi = _mm512_add_epi16(hi, base);
                    _mm512_mask_storeu_epi16(p.add(32).cast(), !0 >> (64 - m), hi);
                }
            }
        }
        n += m;
    }
    bits[w.div_ceil(64)..].fill(0);
    n
}

/// The bytes 0 … 63 (the columns' offsets in a word of bits).
const IOTA8: [u8; 64] = {
    let mut t = [0u8; 64];
    let mut i = 0;
    while i < 64 {
        t[i] = i as u8;
        i += 1;
    }
    t
};

/// The rows [`classify`] reads: the gradients and magnitudes of the row, the magnitudes
/// above and below it.
struct Rows {
    gx: *const u16,
    gy: *const u16,
    c: *const u16,
    up: *const u16,
    down: *const u16,
}

/// One 32-column half of [`classify`] at column `x`: the kept columns' mask and the
/// neighbours across the edge (before, after). `masks` = (the columns, those whose left
/// neighbour, those whose right neighbour is inside the row); all-ones inside it.
///
/// # Safety
/// The CPU must support AVX-512 F/BW; the lanes the masks select, at x − 1 … x + 32, are
/// inside the rows.
#[inline]
#[target_feature(enable = "avx512f,avx512bw")]
unsafe fn half<const HORIZ: bool, const MASKED: bool>(
    r: &Rows,
    x: usize,
    [mc, ml, mr]: [__mmask32; 3],
    k: &ClassConsts,
) -> (u32, (__m512i, __m512i)) {
    // SAFETY: masked loads read only the lanes of their mask (the caller's contract); the
    // pointers of masked-off lanes are never dereferenced.
    let ld = |p: *const u16, m: __mmask32, dx: isize| unsafe {
        let p = p.wrapping_offset(x as isize + dx).cast();
        if MASKED {
            _mm512_maskz_loadu_epi16(m, p)
        } else {
            _mm512_loadu_si512(p.cast())
        }
    };
    let (gx, gy, c) = (ld(r.gx, mc, 0), ld(r.gy, mc, 0), ld(r.c, mc, 0));
    let (cl, cr) = (ld(r.c, ml, -1), ld(r.c, mr, 1));
    let ax = _mm512_abs_epi16(gx);
    let ay = _mm512_abs_epi16(gy);
    // tan_all is zero in the horizontal regime (tan_q10 ≤ 424 < 1024).
    // LLVM legalises `_mm512_mulhi_epu16` by a run-time splat as two zero-extended
    // halves (≈ 9 vector operations); one `vpmulhuw` written out is the same result.
    let m = mulhi_epu16(ax, _mm512_set1_epi16(k.tan_mul as i16));
    let lim = if HORIZ {
        m
    } else {
        _mm512_add_epi16(m, _mm512_and_si512(ax, _mm512_set1_epi16(k.tan_all as i16)))
    };
    let cand = _mm512_cmpge_epu16_mask(c, _mm512_set1_epi16(k.low as i16))
        & _mm512_cmple_epu16_mask(ay, lim)
        & mc;
    let (a, b) = if HORIZ {
        (cl, cr)
    } else {
        let t22 = _mm512_set1_epi16(TAN22_MUL as i16);
        let zero = _mm512_setzero_si512();
        let (ul, um, ur) = (ld(r.up, ml, -1), ld(r.up, mc, 0), ld(r.up, mr, 1));
        let (dl, dm, dr) = (ld(r.down, ml, -1), ld(r.down, mc, 0), ld(r.down, mr, 1));
        let h = _mm512_cmple_epu16_mask(ay, _mm512_mulhi_epu16(ax, t22));
        let v = _mm512_cmple_epu16_mask(ax, _mm512_mulhi_epu16(ay, t22));
        let d = !(_mm512_cmpgt_epi16_mask(gx, zero) ^ _mm512_cmpgt_epi16_mask(gy, zero));
        // Diagonal: up-left/down-right; anti-diagonal: down-left/up-right.
        let da = _mm512_mask_blend_epi16(d, dl, ul);
        let db = _mm512_mask_blend_epi16(d, ur, dr);
        let va = _mm512_mask_blend_epi16(v, da, um);
        let vb = _mm512_mask_blend_epi16(v, db, dm);
        (
            _mm512_mask_blend_epi16(h, va, cl),
            _mm512_mask_blend_epi16(h, vb, cr),
        )
    };
    let keep = cand & _mm512_cmpge_epu16_mask(c, a) & _mm512_cmpgt_epu16_mask(c, b);
    (keep, (a, b))
}

/// `_mm512_mulhi_epu16` as the single instruction it names (see its use in [`classify`]);
/// callable only from code compiled for AVX-512 BW.
#[target_feature(enable = "avx512f,avx512bw")]
#[inline]
fn mulhi_epu16(a: __m512i, b: __m512i) -> __m512i {
    let r: __m512i;
    // SAFETY: a register-only vector multiply (no memory, no flags), AVX-512 BW enabled.
    unsafe {
        std::arch::asm!(
            "vpmulhuw {r}, {a}, {b}",
            r = lateout(zmm_reg) r,
            a = in(zmm_reg) a,
            b = in(zmm_reg) b,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    r
}

/// Direction (binary angle, [`crate::segment::angle256`]) and sub-pixel offset
/// (the scalar path's `sub_offset`) of the `n` kept pixels in `s` (their gx, gy, c, a, b), 16 a
/// step, into `s.dir` and `s.sub`.
///
/// # Safety
/// The CPU must support AVX-512 F/BW/VL/DQ; the compact arrays hold n rounded up to 16.
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq,avx2,bmi1,bmi2,lzcnt,popcnt")]
unsafe fn directions_kernel(s: &mut KeptScratch, n: usize) {
    let m = n.div_ceil(16) * 16;
    assert!(s.gx.len() >= m && s.gy.len() >= m && s.c.len() >= m);
    assert!(s.ka.len() >= m && s.kb.len() >= m && s.dir.len() >= m && s.sub.len() >= m);
    // SAFETY: ATAN64_I32 holds 64 i32: four 64-byte loads at 0, 16, 32, 48.
    let (t0, t1, t2, t3) = unsafe {
        let t = ATAN64_I32.as_ptr();
        (
            _mm512_loadu_si512(t.cast()),
            _mm512_loadu_si512(t.add(16).cast()),
            _mm512_loadu_si512(t.add(32).cast()),
            _mm512_loadu_si512(t.add(48).cast()),
        )
    };
    let zero = _mm512_setzero_si512();
    let c16 = _mm512_set1_epi32(16);
    let c32 = _mm512_set1_epi32(32);
    let c64 = _mm512_set1_epi32(64);
    let c128 = _mm512_set1_epi32(128);
    let c256 = _mm512_set1_epi32(256);
    let c255 = _mm512_set1_epi32(255);
    let tan22 = _mm512_set1_epi32(TAN22_Q8 as i32);
    let mut i = 0;
    while i < n {
        // SAFETY: i + 16 ≤ m ≤ every array's length.
        macro_rules! ld16 {
            ($v:expr) => {
                unsafe { _mm256_loadu_si256($v.as_ptr().add(i).cast()) }
            };
        }
        let gx = _mm512_cvtepi16_epi32(ld16!(s.gx));
        let gy = _mm512_cvtepi16_epi32(ld16!(s.gy));
        let c = _mm512_cvtepu16_epi32(ld16!(s.c));
        let a = _mm512_cvtepu16_epi32(ld16!(s.ka));
        let b = _mm512_cvtepu16_epi32(ld16!(s.kb));
        // Direction.
        let ax = _mm512_abs_epi32(gx);
        let ay = _mm512_abs_epi32(gy);
        let big = _mm512_max_epi32(ax, ay);
        let small = _mm512_min_epi32(ax, ay);
        let num = _mm512_add_epi32(_mm512_slli_epi32::<6>(small), _mm512_srli_epi32::<1>(big));
        let q = _mm512_cvttps_epi32(_mm512_div_ps(
            _mm512_cvtepi32_ps(num),
            _mm512_cvtepi32_ps(big),
        ));
        let some = _mm512_cmpgt_epi32_mask(big, zero);
        // ATAN64[q], q = 0 … 64 (garbage lanes where big = 0 are masked at the end).
        let ql = _mm512_permutex2var_epi32(t0, q, t1);
        let qh = _mm512_permutex2var_epi32(t2, q, t3);
        let tq = _mm512_mask_blend_epi32(_mm512_cmpge_epi32_mask(q, c32), ql, qh);
        let tq = _mm512_mask_blend_epi32(_mm512_cmpeq_epi32_mask(q, c64), tq, c32);
        let ge = _mm512_cmpge_epi32_mask(ax, ay);
        let t = _mm512_mask_blend_epi32(ge, _mm512_sub_epi32(c64, tq), tq);
        let xp = _mm512_cmpge_epi32_mask(gx, zero);
        let yp = _mm512_cmpge_epi32_mask(gy, zero);
        let st = _mm512_mask_sub_epi32(t, xp ^ yp, zero, t);
        let base = _mm512_mask_blend_epi32(xp, c128, _mm512_mask_blend_epi32(yp, c256, zero));
        let dir = _mm512_maskz_and_epi32(some, _mm512_add_epi32(base, st), c255);
        // Sub-pixel offset; no offset for the vertical sector (step 0).
        let h = _mm512_cmple_epi32_mask(_mm512_slli_epi32::<8>(ay), _mm512_mullo_epi32(tan22, ax));
        let v = _mm512_cmple_epi32_mask(_mm512_slli_epi32::<8>(ax), _mm512_mullo_epi32(tan22, ay));
        let den = _mm512_add_epi32(_mm512_sub_epi32(a, _mm512_slli_epi32::<1>(c)), b);
        let sn = _mm512_slli_epi32::<4>(_mm512_sub_epi32(a, b));
        let d = _mm512_abs_epi32(den);
        let nn = _mm512_add_epi32(_mm512_abs_epi32(sn), _mm512_srli_epi32::<1>(d));
        let qs = _mm512_cvttps_epi32(_mm512_div_ps(_mm512_cvtepi32_ps(nn), _mm512_cvtepi32_ps(d)));
        let qs = _mm512_min_epi32(qs, c16);
        let neg = _mm512_movepi32_mask(_mm512_xor_si512(sn, den));
        let qs = _mm512_mask_sub_epi32(qs, neg, zero, qs);
        let has = _mm512_cmpneq_epi32_mask(den, zero) & (h | !v);
        let sub = _mm512_maskz_mov_epi32(has, qs);
        // SAFETY: i + 16 ≤ m ≤ the byte arrays' lengths.
        unsafe {
            _mm_storeu_si128(s.dir.as_mut_ptr().add(i).cast(), _mm512_cvtepi32_epi8(dir));
            _mm_storeu_si128(s.sub.as_mut_ptr().add(i).cast(), _mm512_cvtepi32_epi8(sub));
        }
        i += 16;
    }
}

/// Byte index of the zero byte in the second source of [`PIXEL_PERM`].
const ZERO_BYTE: u8 = 64 + 50;

/// `vpermt2b` indices assembling 16 [`EdgePixel`]s (four a register) from two registers:
/// the first holds the 16 columns (bytes 0–31) and magnitudes (32–63), the second the
/// directions (0–15), sub-pixel offsets (16–31), classes (32–47), the row (48–49) and zeros.
/// Built from the struct's field offsets at compile time (any field order the compiler
/// chooses; the size must be 16 bytes).
const PIXEL_PERM: [[u8; 64]; 4] = {
    use std::mem::{offset_of, size_of};
    assert!(size_of::<EdgePixel>() == 16);
    let mut t = [[ZERO_BYTE; 64]; 4];
    let mut p = 0;
    while p < 16 {
        let (r, b) = (p / 4, 16 * (p % 4));
        let q = p as u8;
        t[r][b + offset_of!(EdgePixel, row)] = 64 + 48;
        t[r][b + offset_of!(EdgePixel, row) + 1] = 64 + 49;
        t[r][b + offset_of!(EdgePixel, col)] = 2 * q;
        t[r][b + offset_of!(EdgePixel, col) + 1] = 2 * q + 1;
        t[r][b + offset_of!(EdgePixel, mag)] = 32 + 2 * q;
        t[r][b + offset_of!(EdgePixel, mag) + 1] = 32 + 2 * q + 1;
        t[r][b + offset_of!(EdgePixel, dir)] = 64 + q;
        t[r][b + offset_of!(EdgePixel, sub)] = 64 + 16 + q;
        t[r][b + offset_of!(EdgePixel, class)] = 64 + 32 + q;
        p += 1;
    }
    t
};

/// One row's edge pixels from the `n` kept pixels in `s` (columns, magnitudes, directions,
/// sub-pixel offsets; the class from the magnitude), 16 a step by byte permutes
/// ([`PIXEL_PERM`]) stored straight into `out`.
///
/// # Safety
/// The CPU must support AVX-512 F/BW/VL/DQ and VBMI; the compact arrays hold n rounded
/// up to 16.
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq,avx512vbmi,avx2")]
unsafe fn pixels_kernel(s: &KeptScratch, n: usize, y: usize, high: u16, out: &mut Vec<EdgePixel>) {
    let m = n.div_ceil(16) * 16;
    assert!(s.cols.len() >= m && s.c.len() >= m && s.dir.len() >= m && s.sub.len() >= m);
    // Every one of the n pixels is stored below: only pixels beyond the list's old length
    // get a default first (a `clear` here would write all n twice).
    out.resize(n, EdgePixel::default());
    // SAFETY: PIXEL_PERM holds four rows of 64 bytes.
    let perm: [__m512i; 4] =
        std::array::from_fn(|r| unsafe { _mm512_loadu_si512(PIXEL_PERM[r].as_ptr().cast()) });
    let hv = _mm256_set1_epi16(high as i16);
    let (weak, strong) = (_mm_set1_epi8(WEAK as i8), _mm_set1_epi8(STRONG as i8));
    let rowv = _mm512_maskz_set1_epi16(1 << 24, y as i16);
    let dst = out.as_mut_ptr().cast::<u8>();
    let mut i = 0;
    while i < n {
        // SAFETY: i + 16 ≤ m ≤ every array's length.
        let (cols, c, dir, sub) = unsafe {
            (
                _mm256_loadu_si256(s.cols.as_ptr().add(i).cast()),
                _mm256_loadu_si256(s.c.as_ptr().add(i).cast()),
                _mm_loadu_si128(s.dir.as_ptr().add(i).cast()),
                _mm_loadu_si128(s.sub.as_ptr().add(i).cast()),
            )
        };
        let class = _mm_mask_blend_epi8(_mm256_cmpge_epu16_mask(c, hv), weak, strong);
        let s1 = _mm512_inserti64x4::<1>(_mm512_castsi256_si512(cols), c);
        let s2 = _mm512_inserti32x4::<2>(
            _mm512_inserti32x4::<1>(_mm512_inserti32x4::<0>(rowv, dir), sub),
            class,
        );
        for (r, p) in perm.iter().enumerate() {
            // Pixels i + 4r … of this register that exist: two 64-bit lanes each.
            let have = n.saturating_sub(i + 4 * r).min(4);
            let lanes = ((1u32 << (2 * have)) - 1) as __mmask8;
            // SAFETY: the masked store writes only the lanes of pixels < n, inside `out`
            // (n pixels of 16 bytes, plain integer fields); masked-off lanes never fault.
            unsafe {
                _mm512_mask_storeu_epi64(
                    dst.wrapping_add(16 * (i + 4 * r)).cast(),
                    lanes,
                    _mm512_permutex2var_epi8(s1, *p, s2),
                );
            }
        }
        i += 16;
    }
}

/// Classifies row `cur` ([`classify_kernel`], horizontal when `k.horizontal`: every candidate
/// lies in the 0° sector) on a CPU with the VBMI kernels' features (`_cpu` proves them); returns the number
/// of kept columns.
#[inline]
pub(crate) fn classify(
    _cpu: Vbmi,
    cur: &GradRow,
    up: &[u16],
    down: &[u16],
    k: &ClassConsts,
    s: &mut KeptScratch,
    bits: &mut [u64],
) -> usize {
    // SAFETY: `simd::vbmi` is true only at the AVX-512 level (F/BW/VL/DQ, checked in
    // `simd::detected`) on a CPU with VBMI and VBMI2 (`simd::vbmi_detected`; `_cpu` proves
    // it); the rows and scratch have the lengths the kernels assert.
    unsafe {
        if k.horizontal {
            classify_kernel::<true>(cur, up, down, k, s, bits)
        } else {
            classify_kernel::<false>(cur, up, down, k, s, bits)
        }
    }
}

/// The directions and sub-pixel offsets ([`directions_kernel`]), then the row's edge pixels
/// ([`pixels_kernel`]) of the `n` kept pixels in `s`, on a CPU with the VBMI kernels'
/// features (`_cpu` proves them).
#[inline]
pub(crate) fn directions_and_pixels(
    _cpu: Vbmi,
    s: &mut KeptScratch,
    n: usize,
    y: usize,
    high: u16,
    out: &mut Vec<EdgePixel>,
) {
    // SAFETY: as in `classify` (VBMI for the pixels' byte permutes).
    unsafe {
        directions_kernel(s, n);
        pixels_kernel(s, n, y, high, out);
    }
}
