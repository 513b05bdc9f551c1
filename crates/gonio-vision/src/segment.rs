//! Baseline segmentation (seed Fig. 6b): non-maximum suppression along the gradient direction
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
//! With AVX-512 (F/BW/VL/DQ and VBMI/VBMI2, [`crate::simd::vbmi`]; `GONIO_SIMD=avx512`) the row is
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

use crate::gradient::GradRow;
use crate::label::EdgePixel;
use crate::rows::{Aligned, RowBuf, RowLag, RowStage, StageObserver};

/// Class of a non-edge pixel.
pub const NONE: u8 = 0;
/// Class of a weak edge pixel (low ≤ |G| < high, or filled).
pub const WEAK: u8 = 1;
/// Class of a strong edge pixel (|G| ≥ high).
pub const STRONG: u8 = 2;
/// Sub-pixel offset marking a pixel added by edge filling (no position of its own).
pub const FILLED: i8 = i8::MIN;

/// atan(i/64) in binary-angle units (256 per turn), rounded, i = 0 … 64.
const ATAN64: [u8; 65] = [
    0, 1, 1, 2, 3, 3, 4, 4, 5, 6, 6, 7, 8, 8, 9, 9, 10, 11, 11, 12, 12, 13, 13, 14, 15, 15, 16, 16,
    17, 17, 18, 18, 19, 19, 20, 20, 21, 21, 22, 22, 23, 23, 24, 24, 25, 25, 25, 26, 26, 27, 27, 27,
    28, 28, 29, 29, 29, 30, 30, 30, 31, 31, 31, 32, 32,
];

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

/// Signed deviation of a binary angle from the horizontal axis (0° or 180°), in −64 … 63.
pub fn axial_deviation(dir: u8) -> i32 {
    (dir.wrapping_add(64) % 128) as i32 - 64
}

/// Rounded integer division (halves away from zero); `d` ≠ 0.
pub fn div_round(n: i32, d: i32) -> i32 {
    if (n < 0) != (d < 0) {
        (n - d / 2) / d
    } else {
        (n + d / 2) / d
    }
}

/// One row of segmented edges, dense: a value per column.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct EdgeRow {
    /// [`NONE`], [`WEAK`] or [`STRONG`] per pixel.
    pub class: Vec<u8>,
    /// Gradient direction (binary angle) of edge pixels, 0 elsewhere.
    pub dir: Vec<u8>,
    /// Sub-pixel x offset of the edge in 1/32 px (−16 … 16), [`FILLED`] for filled pixels.
    pub sub: Vec<i8>,
    /// Gradient magnitude |Gx| + |Gy| of edge pixels with a position of their own, 0 elsewhere.
    pub mag: Vec<u16>,
}

impl EdgeRow {
    /// An empty row of `width` pixels.
    pub fn new(width: usize) -> Self {
        EdgeRow {
            class: vec![0; width],
            dir: vec![0; width],
            sub: vec![0; width],
            mag: vec![0; width],
        }
    }
    /// Clears the row.
    pub fn clear(&mut self) {
        self.class.fill(0);
        self.dir.fill(0);
        self.sub.fill(0);
        self.mag.fill(0);
    }
    /// The row holding the pixels of `s` (and nothing else).
    pub fn set_from(&mut self, s: &SparseEdgeRow) {
        self.clear();
        for p in &s.pixels {
            let x = p.col as usize;
            self.class[x] = p.class;
            self.dir[x] = p.dir;
            self.sub[x] = p.sub;
            self.mag[x] = if p.sub == FILLED { 0 } else { p.mag };
        }
    }
}

impl RowBuf for EdgeRow {
    fn copy_row(&mut self, o: &EdgeRow) {
        self.class.copy_from_slice(&o.class);
        self.dir.copy_from_slice(&o.dir);
        self.sub.copy_from_slice(&o.sub);
        self.mag.copy_from_slice(&o.mag);
    }
}

/// One row of edge pixels, sparse: the pixels in column order (edges are a few percent of a
/// frame's pixels) and a bit per column marking them.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SparseEdgeRow {
    /// The edge pixels by increasing column (`comp` unused).
    pub pixels: Vec<EdgePixel>,
    /// Bit x % 64 of word x / 64 is set when column x holds an edge pixel.
    pub bits: Vec<u64>,
}

impl SparseEdgeRow {
    /// An empty row of `width` pixels.
    pub fn new(width: usize) -> Self {
        SparseEdgeRow {
            pixels: Vec::with_capacity(width / 4),
            bits: vec![0; width.div_ceil(64)],
        }
    }
    /// Removes every pixel.
    pub fn clear(&mut self) {
        self.pixels.clear();
        self.bits.fill(0);
    }
    /// Appends a pixel right of all those already in the row.
    #[inline]
    pub fn push(&mut self, p: EdgePixel) {
        let x = p.col as usize;
        debug_assert!(self.pixels.last().is_none_or(|q| q.col < p.col));
        self.bits[x / 64] |= 1 << (x % 64);
        self.pixels.push(p);
    }
    /// The edge pixels of a dense row `e` in row `y`.
    pub fn set_from(&mut self, e: &EdgeRow, y: usize) {
        self.clear();
        let mut x = 0;
        loop {
            x = crate::rows::next_set(&e.class, x);
            if x >= e.class.len() {
                break;
            }
            self.push(EdgePixel {
                row: y as u16,
                col: x as u16,
                class: e.class[x],
                dir: e.dir[x],
                sub: e.sub[x],
                mag: e.mag[x],
                comp: 0,
            });
            x += 1;
        }
    }
    /// True when column `x` holds an edge pixel.
    #[inline]
    pub fn has(&self, x: usize) -> bool {
        self.bits[x / 64] >> (x % 64) & 1 != 0
    }
}

impl RowBuf for SparseEdgeRow {
    fn copy_row(&mut self, o: &SparseEdgeRow) {
        self.pixels.clone_from(&o.pixels);
        self.bits.copy_from_slice(&o.bits);
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

/// tan(22.5°) in Q8, for the four-way quantisation.
const TAN22_Q8: u32 = 106;

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

/// tan(22.5°) as a 16-bit multiplier: ay·256 ≤ 106·ax ⇔ ay ≤ ⌊ax·106·256 / 2¹⁶⌋ (ay an integer).
const TAN22_MUL: u16 = (TAN22_Q8 * 256) as u16;

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

/// The segmentation's thresholds as the row pass uses them.
#[derive(Debug, Clone, Copy)]
struct ClassConsts {
    low: u16,
    high: u16,
    /// (tan_q10 mod 1024)·64: ⌊tan_q10·ax / 1024⌋ = mulhi(ax, this) + (ax if tan_q10 ≥ 1024).
    tan_mul: u16,
    /// All ones when tan_q10 ≥ 1024.
    tan_all: u16,
    /// tan_q10 ≤ 424: every candidate lies in the 0° sector.
    horizontal: bool,
}

impl ClassConsts {
    fn new(p: SegmentParams) -> Self {
        assert!(p.tan_q10 < 2048, "direction tolerance of 63° or more");
        ClassConsts {
            low: p.low,
            high: p.high,
            tan_mul: ((p.tan_q10 % 1024) * 64) as u16,
            tan_all: if p.tan_q10 >= 1024 { u16::MAX } else { 0 },
            horizontal: p.tan_q10 * 256 <= TAN22_Q8 * 1024,
        }
    }
}

/// Eight class bytes (0 or not) as eight bits, byte i → bit i.
#[inline(always)]
fn byte_mask(word: u64) -> u64 {
    let nz = (word | (word >> 1)) & 0x0101_0101_0101_0101;
    nz.wrapping_mul(0x0102_0408_1020_4080) >> 56
}

/// Scratch rows of the AVX-512 path: the neighbours across the edge per column, and the kept
/// pixels of one row, compact (each with 16 elements of slack for the last vector).
#[derive(Debug, Clone)]
struct KeptScratch {
    /// The neighbour before (a) and after (b) the centre across the edge, per column.
    a: Aligned<u16>,
    b: Aligned<u16>,
    /// The kept columns, in order.
    cols: Vec<u16>,
    gx: Vec<i16>,
    gy: Vec<i16>,
    c: Vec<u16>,
    ka: Vec<u16>,
    kb: Vec<u16>,
    dir: Vec<u8>,
    sub: Vec<i8>,
}

impl KeptScratch {
    fn new(width: usize) -> Self {
        let row = width.div_ceil(32) * 32;
        let n = width + 32;
        KeptScratch {
            a: Aligned::new(row, 0),
            b: Aligned::new(row, 0),
            cols: vec![0; n],
            gx: vec![0; n],
            gy: vec![0; n],
            c: vec![0; n],
            ka: vec![0; n],
            kb: vec![0; n],
            dir: vec![0; n],
            sub: vec![0; n],
        }
    }
}

/// The AVX-512 segmentation of a row (AVX-512 F/BW/VL/DQ): the classification with compares
/// into mask registers, 64 columns a step, the kept columns compressed into a list
/// (`vpcompressb` per word of bits), then the direction and the sub-pixel offset of the kept
/// pixels in vector lanes, 16 at a time, with no data-dependent branch. Every step is the
/// integer (or exact f32) arithmetic of the scalar path, so the pixels are the same.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod avx512 {
    use super::{ATAN64, ClassConsts, KeptScratch, STRONG, TAN22_MUL, TAN22_Q8, WEAK};
    use crate::gradient::GradRow;
    use crate::label::EdgePixel;
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
    /// outside the row count as zero magnitudes, as in [`super::segment_pixel`]); writes the
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
    pub(super) unsafe fn classify<const HORIZ: bool>(
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

    /// Direction (binary angle, [`super::angle256`]) and sub-pixel offset
    /// ([`super::sub_offset`]) of the `n` kept pixels in `s` (their gx, gy, c, a, b), 16 a
    /// step, into `s.dir` and `s.sub`.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F/BW/VL/DQ; the compact arrays hold n rounded up to 16.
    #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq,avx2,bmi1,bmi2,lzcnt,popcnt")]
    pub(super) unsafe fn directions(s: &mut KeptScratch, n: usize) {
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
            let h =
                _mm512_cmple_epi32_mask(_mm512_slli_epi32::<8>(ay), _mm512_mullo_epi32(tan22, ax));
            let v =
                _mm512_cmple_epi32_mask(_mm512_slli_epi32::<8>(ax), _mm512_mullo_epi32(tan22, ay));
            let den = _mm512_add_epi32(_mm512_sub_epi32(a, _mm512_slli_epi32::<1>(c)), b);
            let sn = _mm512_slli_epi32::<4>(_mm512_sub_epi32(a, b));
            let d = _mm512_abs_epi32(den);
            let nn = _mm512_add_epi32(_mm512_abs_epi32(sn), _mm512_srli_epi32::<1>(d));
            let qs =
                _mm512_cvttps_epi32(_mm512_div_ps(_mm512_cvtepi32_ps(nn), _mm512_cvtepi32_ps(d)));
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
    pub(super) unsafe fn pixels(
        s: &KeptScratch,
        n: usize,
        y: usize,
        high: u16,
        out: &mut Vec<EdgePixel>,
    ) {
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
}

/// The output row's gradients and the magnitudes of the rows above and below it (`zero`
/// outside the frame).
#[inline(always)]
fn rows_around<'a>(
    rows: &RowLag,
    ring: &'a [GradRow; 3],
    zero: &'a [u16],
) -> (&'a GradRow, &'a [u16], &'a [u16]) {
    let around = |dy| rows.neighbour(dy).map_or(zero, |s| &ring[s].mag[..]);
    (&ring[rows.clamped(0)], around(-1), around(1))
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

    /// [`Segmenter::emit_impl`] with AVX-512 (see the `avx512` module); `false` when the
    /// VBMI kernels are off ([`crate::simd::vbmi`]).
    #[allow(unsafe_code)]
    fn emit_avx512(&mut self, out: &mut SparseEdgeRow) -> bool {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::vbmi() {
            let y = self.rows.output_row();
            let (cur, up, down) = rows_around(&self.rows, &self.ring, &self.zero);
            let s = &mut self.kept;
            // SAFETY: `simd::vbmi` is true only at the AVX-512 level (F/BW/VL/DQ, checked in
            // `simd::detected`) on a CPU with VBMI and VBMI2 (`simd::vbmi_detected`); the rows
            // and scratch have the lengths the kernels assert.
            let n = unsafe {
                if self.consts.horizontal {
                    avx512::classify::<true>(cur, up, down, &self.consts, s, &mut out.bits)
                } else {
                    avx512::classify::<false>(cur, up, down, &self.consts, s, &mut out.bits)
                }
            };
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
            // SAFETY: as above (VBMI for the pixels' byte permutes).
            unsafe {
                avx512::directions(s, n);
                avx512::pixels(s, n, y, self.params.high, &mut out.pixels);
            }
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
