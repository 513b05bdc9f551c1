//! Baseline segmentation (Yu et al., 2024, Fig. 6b): non-maximum suppression along the gradient direction
//! quantised to 0°/45°/90°/135°, the dual threshold (strong/weak edges) and the baseline filter
//! (keep only gradients within a tolerance of horizontal); lag 1 row.
//!
//! Each kept pixel also gets its gradient direction as a binary angle (256 per turn, from an
//! integer octant table) and a sub-pixel offset along x (1/32 px) from a parabola through the
//! magnitudes across the edge — all integer, so the result is the same on every machine.
//!
//! [`segment_pixel`] is the definition, pixel by pixel. The streaming [`Segmenter`] decides the
//! class of a whole row in one branch-free pass over 16-bit lanes (the thresholds, the baseline
//! filter and the direction quantisation as exact integer comparisons, the two neighbours
//! across the edge chosen by selects), and computes the direction and sub-pixel offset only for
//! the few pixels kept; its output is a [`SparseEdgeRow`], the edge pixels in column order.
//!
//! With AVX-512 (F/BW/VL/DQ and VBMI/VBMI2, `crate::simd::vbmi`; `GONIO_SIMD=avx512`) the row is
//! segmented by hand-written intrinsics instead, because the compiler does not produce what
//! the kept pixels need: the classification's comparisons go straight into mask registers (64
//! columns, one word of bits, a step; plain loads inside the row, the border columns by the
//! same zero-padded comparisons through masked loads), the kept columns are listed in a second
//! pass over the words, one `vpcompressb` of their offsets per word, with no loop over bits,
//! and the direction and sub-pixel offset of the listed pixels are computed 16 at a time in
//! vector lanes with the same integer and exact-f32 arithmetic as the scalar path — the
//! per-pixel branches (quadrant, octant, zero denominators) become selects, so the path has no
//! data-dependent branch left; the edge pixels are assembled 16 at a time by byte permutes
//! (`vpermt2b`, indices built at compile time from [`EdgePixel`]'s field offsets) and stored
//! straight into the row (the compiler's loop built them field by field). `tests/simd.rs`
//! compares it with the scalar path on random and extreme gradients at every width up to 70
//! and wider rows.
//!
//! ```
//! use gonio_vision::segment::{angle256, STRONG};
//! assert_eq!(angle256(10, 0), 0);     // gradient to +x
//! assert_eq!(angle256(0, 10), 64);    // +y (down): 90°
//! assert_eq!(angle256(-10, 0), 128);  // 180°
//! assert_eq!(angle256(7, -7), 224);   // −45°
//! assert_eq!(STRONG, 2);
//! ```

use crate::row_types::{EdgePixel, GradRow};
pub use crate::row_types::{EdgeRow, FILLED, NONE, STRONG, SparseEdgeRow, WEAK, axial_deviation};
use crate::rows::{Aligned, RowLag, RowStage, StageObserver};
use tables::{ATAN64, ClassConsts, KeptScratch, TAN22_MUL, TAN22_Q8};

pub(crate) mod tables;

/// The direction of (gx, gy) as a binary angle: 0 = +x, 64 = +y (down), 128 = −x, 192 = −y.
pub fn angle256(gx: i16, gy: i16) -> u8 {
    let (ax, ay) = (gx.unsigned_abs() as u32, gy.unsigned_abs() as u32);
    if ax == 0 && ay == 0 {
        return 0;
    }
    let t = if ax >= ay {
        ATAN64[((ay * 64 + ax / 2) / ax) as usize] as i32
    } else {
        64 - ATAN64[((ax * 64 + ay / 2) / ay) as usize] as i32
    };
    let a = match (gx >= 0, gy >= 0) {
        (true, true) => t,
        (false, true) => 128 - t,
        (false, false) => 128 + t,
        (true, false) => 256 - t,
    };
    (a & 255) as u8
}

/// ⌊n / d⌋ for n < 2²⁴ and 0 < d through one f32 division, which is exact here: n and d are
/// exact in f32, and the correctly rounded quotient q̃ of q = n/d is off by at most q·2⁻²⁴ < 1/d
/// (as n < 2²⁴), less than the distance from a non-integer q to the next integer, so q̃ never
/// reaches it (an integer q is exact). Faster than the integer divider on the segmentation's
/// per-edge path.
#[inline(always)]
fn div_small(n: u32, d: u32) -> u32 {
    debug_assert!(n < 1 << 24 && d > 0);
    (n as f32 / d as f32) as u32
}

/// [`angle256`] with [`div_small`] (the same value for every input: the dividend is below 2²²).
#[inline(always)]
fn angle256_fast(gx: i16, gy: i16) -> u8 {
    let (ax, ay) = (gx.unsigned_abs() as u32, gy.unsigned_abs() as u32);
    if ax == 0 && ay == 0 {
        return 0;
    }
    let t = if ax >= ay {
        ATAN64[div_small(ay * 64 + ax / 2, ax) as usize] as i32
    } else {
        64 - ATAN64[div_small(ax * 64 + ay / 2, ay) as usize] as i32
    };
    let a = match (gx >= 0, gy >= 0) {
        (true, true) => t,
        (false, true) => 128 - t,
        (false, false) => 128 + t,
        (true, false) => 256 - t,
    };
    (a & 255) as u8
}

/// Rounded integer division (halves away from zero); `d` ≠ 0.
pub fn div_round(n: i32, d: i32) -> i32 {
    if (n < 0) != (d < 0) {
        (n - d / 2) / d
    } else {
        (n + d / 2) / d
    }
}

/// The thresholds of the segmentation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SegmentParams {
    /// Low threshold: |G| below it is no edge.
    pub low: u16,
    /// High threshold: |G| at or above it is a strong edge.
    pub high: u16,
    /// tan(direction tolerance) in Q10: keep |Gy|·1024 ≤ this·|Gx| (below 2048: a tolerance
    /// under 63°; the optics allow at most 45°).
    pub tan_q10: u32,
}

/// The neighbours before (a) and after (b) the centre along the quantised gradient direction,
/// and the x step from a to b (0 for a vertical gradient).
#[inline(always)]
fn across(gx: i16, gy: i16, m: [[u16; 3]; 3]) -> (u16, u16, i32) {
    let (ax, ay) = (gx.unsigned_abs() as u32, gy.unsigned_abs() as u32);
    if ay * 256 <= TAN22_Q8 * ax {
        (m[1][0], m[1][2], 1)
    } else if ax * 256 <= TAN22_Q8 * ay {
        (m[0][1], m[2][1], 0)
    } else if (gx > 0) == (gy > 0) {
        (m[0][0], m[2][2], 1)
    } else {
        (m[2][0], m[0][2], 1)
    }
}

/// [`across`] for an interior column x of a row `cur` between rows `up` and `down`.
#[inline(always)]
fn across_rows(
    gx: i16,
    gy: i16,
    up: &[u16],
    cur: &[u16],
    down: &[u16],
    x: usize,
) -> (u16, u16, i32) {
    let (ax, ay) = (gx.unsigned_abs() as u32, gy.unsigned_abs() as u32);
    if ay * 256 <= TAN22_Q8 * ax {
        (cur[x - 1], cur[x + 1], 1)
    } else if ax * 256 <= TAN22_Q8 * ay {
        (up[x], down[x], 0)
    } else if (gx > 0) == (gy > 0) {
        (up[x - 1], down[x + 1], 1)
    } else {
        (down[x - 1], up[x + 1], 1)
    }
}

/// The sub-pixel offset (1/32 px) of the parabola through a, c, b.
#[inline(always)]
fn sub_offset(a: u16, c: u16, b: u16, step: i32) -> i8 {
    let den = a as i32 - 2 * c as i32 + b as i32;
    if step == 0 || den == 0 {
        0
    } else {
        div_round(16 * (a as i32 - b as i32), den).clamp(-16, 16) as i8
    }
}

/// [`sub_offset`] with [`div_small`]: `div_round(n, d)` is ±⌊(|n| + ⌊|d|/2⌋) / |d|⌋, negative
/// when the signs of n and d differ (Rust's division truncates toward zero), and the dividend
/// stays below 2²¹ for 16-bit magnitudes.
#[inline(always)]
fn sub_offset_fast(a: u16, c: u16, b: u16, step: i32) -> i8 {
    let den = a as i32 - 2 * c as i32 + b as i32;
    if step == 0 || den == 0 {
        return 0;
    }
    let num = 16 * (a as i32 - b as i32);
    let d = den.unsigned_abs();
    let q = div_small(num.unsigned_abs() + d / 2, d).min(16) as i32;
    (if (num < 0) != (den < 0) { -q } else { q }) as i8
}

/// Segments one pixel given its gradient and the magnitudes of its 3×3 neighbourhood
/// (`m[dy][dx]`, zero outside the frame). Returns (class, dir, sub).
#[inline]
pub fn segment_pixel(gx: i16, gy: i16, m: [[u16; 3]; 3], p: SegmentParams) -> (u8, u8, i8) {
    let c = m[1][1];
    if c < p.low {
        return (NONE, 0, 0);
    }
    let (ax, ay) = (gx.unsigned_abs() as u32, gy.unsigned_abs() as u32);
    // Baseline filter first (cheap, rejects most).
    if ay * 1024 > p.tan_q10 * ax {
        return (NONE, 0, 0);
    }
    let (a, b, step) = across(gx, gy, m);
    if !(c >= a && c > b) {
        return (NONE, 0, 0);
    }
    let class = if c >= p.high { STRONG } else { WEAK };
    (class, angle256(gx, gy), sub_offset(a, c, b, step))
}

/// ⌊x·m / 2¹⁶⌋ in 16 bits (a vector `mulhi`).
#[inline(always)]
fn mulhi(x: u16, m: u16) -> u16 {
    ((x as u32 * m as u32) >> 16) as u16
}

/// The classes of the interior pixels 1 … w − 2 of a row, written to `class[1 .. w − 1]`: the
/// tests of [`segment_pixel`] as branch-free integer comparisons on 16-bit lanes. Every
/// `a·K ≤ b·L` of the definition becomes `a ≤ ⌊b·M / 2¹⁶⌋` with M = 2¹⁶·L/K an integer, exact
/// for integer a; the neighbours across the edge are chosen with masks.
#[inline(always)]
fn classify_interior(g: &GradRow, up: &[u16], down: &[u16], k: &ClassConsts, class: &mut [u8]) {
    let w = g.mag.len();
    if w < 3 {
        return;
    }
    let n = w - 2;
    let (cl, cm, cr) = (&g.mag[..n], &g.mag[1..n + 1], &g.mag[2..]);
    let (ul, um, ur) = (&up[..n], &up[1..n + 1], &up[2..w]);
    let (dl, dm, dr) = (&down[..n], &down[1..n + 1], &down[2..w]);
    let (gxs, gys) = (&g.gx[1..n + 1], &g.gy[1..n + 1]);
    let out = &mut class[1..n + 1];
    let mask = |b: bool| (b as u16).wrapping_neg();
    for i in 0..n {
        let (gx, gy) = (gxs[i], gys[i]);
        let (ax, ay) = (gx.unsigned_abs(), gy.unsigned_abs());
        let c = cm[i];
        let lim = mulhi(ax, k.tan_mul) + (ax & k.tan_all);
        let cand = (c >= k.low) & (ay <= lim);
        let h = mask(ay <= mulhi(ax, TAN22_MUL));
        let v = mask(ax <= mulhi(ay, TAN22_MUL));
        let d = mask((gx > 0) == (gy > 0));
        // Diagonal: up-left/down-right; anti-diagonal: down-left/up-right.
        let da = (ul[i] & d) | (dl[i] & !d);
        let db = (dr[i] & d) | (ur[i] & !d);
        let va = (um[i] & v) | (da & !v);
        let vb = (dm[i] & v) | (db & !v);
        let a = (cl[i] & h) | (va & !h);
        let b = (cr[i] & h) | (vb & !h);
        let keep = cand & (c >= a) & (c > b);
        out[i] = (keep as u8) << ((c >= k.high) as u8);
    }
}

/// [`classify_interior`] when every candidate's gradient is near-horizontal (tan_q10 ≤ 424: the
/// tolerance is at most 22.5°, so |Gy|·1024 ≤ tan_q10·|Gx| implies |Gy|·256 ≤ 106·|Gx|, the
/// quantisation's 0° sector): the neighbours across the edge are left and right.
#[inline(always)]
fn classify_horizontal(g: &GradRow, k: &ClassConsts, class: &mut [u8]) {
    let w = g.mag.len();
    if w < 3 {
        return;
    }
    let n = w - 2;
    let (cl, cm, cr) = (&g.mag[..n], &g.mag[1..n + 1], &g.mag[2..]);
    let (gxs, gys) = (&g.gx[1..n + 1], &g.gy[1..n + 1]);
    let out = &mut class[1..n + 1];
    for i in 0..n {
        let (ax, ay) = (gxs[i].unsigned_abs(), gys[i].unsigned_abs());
        let c = cm[i];
        let lim = mulhi(ax, k.tan_mul);
        let keep = (c >= k.low) & (ay <= lim) & (c >= cl[i]) & (c > cr[i]);
        out[i] = (keep as u8) << ((c >= k.high) as u8);
    }
}

/// Eight class bytes (0 or not) as eight bits, byte i → bit i.
#[inline(always)]
fn byte_mask(word: u64) -> u64 {
    let nz = (word | (word >> 1)) & 0x0101_0101_0101_0101;
    nz.wrapping_mul(0x0102_0408_1020_4080) >> 56
}

/// The output row's gradients and the magnitudes of the rows above and below it (`zero`
/// outside the frame).
#[inline(always)]
fn rows_around<'a>(
    rows: &RowLag,
    ring: &'a [GradRow; 3],
    zero: &'a [u16],
) -> (&'a GradRow, &'a [u16], &'a [u16]) {
    let (up, c, down) = rows.around();
    let mag = |s: Option<usize>| s.map_or(zero, |s| &ring[s].mag[..]);
    (&ring[c], mag(up), mag(down))
}

/// Streaming segmentation of gradient rows.
#[derive(Debug, Clone)]
pub struct Segmenter {
    width: usize,
    params: SegmentParams,
    consts: ClassConsts,
    ring: [GradRow; 3],
    zero: Vec<u16>,
    class: Aligned<u8>,
    /// The AVX-512 path's scratch rows.
    kept: KeptScratch,
    rows: RowLag,
}

impl Segmenter {
    /// A segmenter for rows of `width` pixels.
    pub fn new(width: usize, params: SegmentParams) -> Self {
        Segmenter {
            width,
            params,
            consts: ClassConsts::new(params),
            ring: [
                GradRow::new(width),
                GradRow::new(width),
                GradRow::new(width),
            ],
            zero: vec![0; width],
            class: Aligned::new(width.div_ceil(8) * 8, 0),
            kept: KeptScratch::new(width),
            rows: RowLag::new(1),
        }
    }

    /// [`Segmenter::emit_impl`] with AVX-512 (see `simd::vbmi::segment`); `false` when the
    /// VBMI kernels are off (`crate::simd::vbmi`).
    fn emit_avx512(&mut self, out: &mut SparseEdgeRow) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = crate::simd::Vbmi::get() {
            use crate::simd::vbmi::segment::{classify, directions_and_pixels};
            let y = self.rows.output_row();
            let (cur, up, down) = rows_around(&self.rows, &self.ring, &self.zero);
            let s = &mut self.kept;
            let n = classify(cpu, cur, up, down, &self.consts, s, &mut out.bits);
            // The kept pixels' gradients and neighbours, compact.
            {
                let (gx, gy, mag, a, b) =
                    (&cur.gx[..], &cur.gy[..], &cur.mag[..], &s.a[..], &s.b[..]);
                let kept = s.cols[..n]
                    .iter()
                    .zip(&mut s.gx[..n])
                    .zip(&mut s.gy[..n])
                    .zip(&mut s.c[..n])
                    .zip(s.ka[..n].iter_mut().zip(&mut s.kb[..n]));
                let horizontal = self.consts.horizontal;
                for ((((&x, ogx), ogy), oc), (oa, ob)) in kept {
                    let x = x as usize;
                    *ogx = gx[x];
                    *ogy = gy[x];
                    *oc = mag[x];
                    if horizontal {
                        *oa = if x > 0 { mag[x - 1] } else { 0 };
                        *ob = mag.get(x + 1).copied().unwrap_or(0);
                    } else {
                        *oa = a[x];
                        *ob = b[x];
                    }
                }
            }
            directions_and_pixels(cpu, s, n, y, self.params.high, &mut out.pixels);
            return true;
        }
        let _ = out;
        false
    }

    #[inline(always)]
    fn emit_impl(&mut self, out: &mut SparseEdgeRow) {
        let w = self.width;
        let y = self.rows.output_row();
        let (cur, up, down) = rows_around(&self.rows, &self.ring, &self.zero);
        let p = self.params;
        let at = |r: &[u16], x: usize, dx: isize| {
            let xx = x as isize + dx;
            if xx < 0 || xx >= w as isize {
                0
            } else {
                r[xx as usize]
            }
        };
        let m3 = |x: usize| {
            [
                [at(up, x, -1), at(up, x, 0), at(up, x, 1)],
                [at(&cur.mag, x, -1), cur.mag[x], at(&cur.mag, x, 1)],
                [at(down, x, -1), at(down, x, 0), at(down, x, 1)],
            ]
        };
        if self.consts.horizontal {
            classify_horizontal(cur, &self.consts, &mut self.class);
        } else {
            classify_interior(cur, up, down, &self.consts, &mut self.class);
        }
        // The two border pixels by the definition.
        for x in [0, w - 1] {
            self.class[x] = segment_pixel(cur.gx[x], cur.gy[x], m3(x), p).0;
        }
        out.clear();
        // The kept columns 64 at a time (eight words of class bytes gathered into one mask,
        // branch-free): the loop over them ends once a block, not once every eight columns.
        for (k, block) in self.class.chunks(64).enumerate() {
            let mut bits = 0u64;
            for (j, chunk) in block.chunks_exact(8).enumerate() {
                let word = u64::from_le_bytes(chunk.try_into().unwrap_or([0; 8]));
                bits |= byte_mask(word) << (8 * j);
            }
            while bits != 0 {
                let x = k * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if x >= w {
                    break;
                }
                let (gx, gy) = (cur.gx[x], cur.gy[x]);
                let c = cur.mag[x];
                let (a, b, step) = if x == 0 || x == w - 1 {
                    across(gx, gy, m3(x))
                } else if self.consts.horizontal {
                    (cur.mag[x - 1], cur.mag[x + 1], 1)
                } else {
                    across_rows(gx, gy, up, &cur.mag, down, x)
                };
                out.push(EdgePixel {
                    row: y as u16,
                    col: x as u16,
                    class: self.class[x],
                    dir: angle256_fast(gx, gy),
                    sub: sub_offset_fast(a, c, b, step),
                    mag: c,
                    comp: 0,
                });
            }
        }
    }
}

impl RowStage for Segmenter {
    type In = GradRow;
    type Out = SparseEdgeRow;
    fn rows(&self) -> &RowLag {
        &self.rows
    }
    fn rows_mut(&mut self) -> &mut RowLag {
        &mut self.rows
    }
    fn input(&mut self) -> &mut GradRow {
        &mut self.ring[self.rows.input_slot()]
    }
    fn emit<O: StageObserver + ?Sized>(&mut self, out: &mut SparseEdgeRow, obs: &mut O) {
        if !self.emit_avx512(out) {
            crate::simd::dispatch(
                #[inline(always)]
                || self.emit_impl(out),
            );
        }
        obs.edges(out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_mask_gathers_nonzero_bytes() {
        // Every word of class bytes (0, 1 or 2).
        for k in 0..3u32.pow(8) {
            let bytes: [u8; 8] = std::array::from_fn(|i| (k / 3u32.pow(i as u32) % 3) as u8);
            let want = (0..8).fold(0u64, |m, i| m | ((bytes[i] != 0) as u64) << i);
            assert_eq!(byte_mask(u64::from_le_bytes(bytes)), want, "{bytes:?}");
        }
    }

    #[test]
    fn fast_divisions_equal_the_integer_ones() {
        // Every gradient a Sobel of 8-bit rows gives (|Gx|, |Gy| ≤ 1020), and the extremes.
        for gx in -1020i16..=1020 {
            for gy in -1020i16..=1020 {
                assert_eq!(angle256_fast(gx, gy), angle256(gx, gy), "{gx} {gy}");
            }
        }
        for (gx, gy) in [
            (i16::MIN, i16::MAX),
            (i16::MAX, 1),
            (1, i16::MIN),
            (-32767, 32767),
        ] {
            assert_eq!(angle256_fast(gx, gy), angle256(gx, gy));
        }
        // Sub-pixel offsets: NMS keeps c ≥ a and c > b; magnitudes up to 2040 (Sobel L1), all
        // pairs (a, b) for a set of c, and random triples over the whole u16 range.
        for c in [1u16, 2, 3, 7, 40, 255, 1000, 2039, 2040] {
            for a in 0..=c {
                for b in 0..c {
                    for step in [0, 1] {
                        assert_eq!(sub_offset_fast(a, c, b, step), sub_offset(a, c, b, step));
                    }
                }
            }
        }
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..1_000_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let (a, c, b) = (s as u16, (s >> 16) as u16, (s >> 32) as u16);
            assert_eq!(
                sub_offset_fast(a, c, b, 1),
                sub_offset(a, c, b, 1),
                "{a} {c} {b}"
            );
        }
    }

    #[test]
    fn mulhi_comparisons_equal_the_definition() {
        // Every |G| component a Sobel of 8-bit rows can give, and then some.
        for ax in 0u16..=2100 {
            let lim = mulhi(ax, TAN22_MUL);
            for ay in [0, 1, lim.saturating_sub(1), lim, lim + 1, lim + 2, 2100] {
                assert_eq!(
                    ay <= lim,
                    ay as u32 * 256 <= TAN22_Q8 * ax as u32,
                    "{ax} {ay}"
                );
            }
            for tq in [1u32, 106, 339, 700, 1023, 1024, 1500, 2047] {
                let k = ClassConsts::new(SegmentParams {
                    low: 1,
                    high: 2,
                    tan_q10: tq,
                });
                let lim = mulhi(ax, k.tan_mul) + (ax & k.tan_all);
                for ay in [lim.saturating_sub(1), lim, lim + 1] {
                    assert_eq!(ay <= lim, ay as u32 * 1024 <= tq * ax as u32);
                }
            }
        }
    }
}
