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

/// Streaming segmentation of gradient rows.
#[derive(Debug, Clone)]
pub struct Segmenter {
    width: usize,
    params: SegmentParams,
    consts: ClassConsts,
    ring: [GradRow; 3],
    zero: Vec<u16>,
    class: Aligned<u8>,
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
            rows: RowLag::new(1),
        }
    }

    #[inline(always)]
    fn emit_impl(&mut self, out: &mut SparseEdgeRow) {
        let w = self.width;
        let y = self.rows.output_row();
        let cur = &self.ring[self.rows.clamped(0)];
        let up: &[u16] = self
            .rows
            .neighbour(-1)
            .map_or(&self.zero, |s| &self.ring[s].mag);
        let down: &[u16] = self
            .rows
            .neighbour(1)
            .map_or(&self.zero, |s| &self.ring[s].mag);
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
        crate::simd::dispatch(
            #[inline(always)]
            || self.emit_impl(out),
        );
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
