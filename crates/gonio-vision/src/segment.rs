//! Baseline segmentation (seed Fig. 6b): non-maximum suppression along the gradient direction
//! quantised to 0°/45°/90°/135°, the dual threshold (strong/weak edges) and the baseline filter
//! (keep only gradients within a tolerance of horizontal); lag 1 row.
//!
//! Each kept pixel also gets its gradient direction as a binary angle (256 per turn, from an
//! integer octant table) and a sub-pixel offset along x (1/32 px) from a parabola through the
//! magnitudes across the edge — all integer, so the result is the same on every machine.
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
use crate::rows::{RowLag, next_set};

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

/// One row of segmented edges.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct EdgeRow {
    /// [`NONE`], [`WEAK`] or [`STRONG`] per pixel.
    pub class: Vec<u8>,
    /// Gradient direction (binary angle) of edge pixels, 0 elsewhere.
    pub dir: Vec<u8>,
    /// Sub-pixel x offset of the edge in 1/32 px (−16 … 16), [`FILLED`] for filled pixels.
    pub sub: Vec<i8>,
    /// Gradient magnitude |Gx| + |Gy| of edge pixels with a position of their own; meaningless
    /// elsewhere (the stages do not clear it: only edge pixels are ever read).
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
    /// Copies another row into this one.
    pub fn copy_from(&mut self, o: &EdgeRow) {
        self.class.copy_from_slice(&o.class);
        self.dir.copy_from_slice(&o.dir);
        self.sub.copy_from_slice(&o.sub);
        self.mag.copy_from_slice(&o.mag);
    }
    /// Clears the row.
    pub fn clear(&mut self) {
        self.clear_marks();
        self.mag.fill(0);
    }
    /// Clears the classes, directions and sub-pixel offsets (not the magnitudes, which are read
    /// only where a class is set).
    pub fn clear_marks(&mut self) {
        self.class.fill(0);
        self.dir.fill(0);
        self.sub.fill(0);
    }
}

/// The thresholds of the segmentation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SegmentParams {
    /// Low threshold: |G| below it is no edge.
    pub low: u16,
    /// High threshold: |G| at or above it is a strong edge.
    pub high: u16,
    /// tan(direction tolerance) in Q10: keep |Gy|·1024 ≤ this·|Gx|.
    pub tan_q10: u32,
}

/// tan(22.5°) in Q8, for the four-way quantisation.
const TAN22_Q8: u32 = 106;

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
    // Neighbours before (a) and after (b) along the quantised direction, and the x step from a
    // to b (for the sub-pixel offset).
    let (a, b, step) = if ay * 256 <= TAN22_Q8 * ax {
        (m[1][0], m[1][2], 1)
    } else if ax * 256 <= TAN22_Q8 * ay {
        (m[0][1], m[2][1], 0)
    } else if (gx > 0) == (gy > 0) {
        (m[0][0], m[2][2], 1)
    } else {
        (m[2][0], m[0][2], 1)
    };
    if !(c >= a && c > b) {
        return (NONE, 0, 0);
    }
    let class = if c >= p.high { STRONG } else { WEAK };
    let den = a as i32 - 2 * c as i32 + b as i32;
    let sub = if step == 0 || den == 0 {
        0
    } else {
        div_round(16 * (a as i32 - b as i32), den).clamp(-16, 16)
    };
    (class, angle256(gx, gy), sub as i8)
}

/// Streaming segmentation of gradient rows.
#[derive(Debug, Clone)]
pub struct Segmenter {
    width: usize,
    params: SegmentParams,
    ring: [GradRow; 3],
    zero: Vec<u16>,
    cand: Vec<u8>,
    rows: RowLag,
}

impl Segmenter {
    /// A segmenter for rows of `width` pixels.
    pub fn new(width: usize, params: SegmentParams) -> Self {
        Segmenter {
            width,
            params,
            ring: [
                GradRow::new(width),
                GradRow::new(width),
                GradRow::new(width),
            ],
            zero: vec![0; width],
            cand: vec![0; width],
            rows: RowLag::new(1),
        }
    }
    /// Lag in rows (1).
    pub fn lag(&self) -> usize {
        self.rows.lag()
    }
    /// Starts a new frame.
    pub fn reset(&mut self) {
        self.rows.reset();
    }
    /// Pushes one gradient row; true when `out` holds the next output row.
    pub fn push_row(&mut self, row: &GradRow, out: &mut EdgeRow) -> bool {
        self.ring[self.rows.input_slot()].copy_from(row);
        let ready = self.rows.pushed();
        self.emit_if(ready, out)
    }
    /// Like [`Segmenter::push_row`] but takes the row by swapping buffers instead of copying it:
    /// `row` is left holding stale data for the caller to overwrite.
    pub fn push_row_swap(&mut self, row: &mut GradRow, out: &mut EdgeRow) -> bool {
        std::mem::swap(&mut self.ring[self.rows.input_slot()], row);
        let ready = self.rows.pushed();
        self.emit_if(ready, out)
    }
    /// After the last row: the next pending output row, false when none is left.
    pub fn flush_row(&mut self, out: &mut EdgeRow) -> bool {
        let ready = self.rows.pending();
        self.emit_if(ready, out)
    }
    fn emit_if(&mut self, ready: bool, out: &mut EdgeRow) -> bool {
        if ready {
            crate::simd::dispatch(|| self.emit_impl(out));
        }
        ready
    }

    #[inline(always)]
    fn emit_impl(&mut self, out: &mut EdgeRow) {
        let w = self.width;
        let cur = &self.ring[self.rows.clamped(0)];
        let up: &[u16] = self
            .rows
            .neighbour(-1)
            .map_or(&self.zero, |s| &self.ring[s].mag);
        let down: &[u16] = self
            .rows
            .neighbour(1)
            .map_or(&self.zero, |s| &self.ring[s].mag);
        out.clear_marks();
        let low = self.params.low;
        let tq = self.params.tan_q10;
        // Candidates (magnitude and baseline filter) for the whole row, vectorised; the
        // neighbourhood is read only where one is found. segment_pixel repeats both tests.
        for (((c, &m), &gx), &gy) in self.cand.iter_mut().zip(&cur.mag).zip(&cur.gx).zip(&cur.gy) {
            let dir_ok = gy.unsigned_abs() as u32 * 1024 <= tq * gx.unsigned_abs() as u32;
            *c = ((m >= low) & dir_ok) as u8;
        }
        let mut x = 0;
        loop {
            x = next_set(&self.cand, x);
            if x >= w {
                break;
            }
            {
                {
                    let at = |r: &[u16], dx: isize| {
                        let xx = x as isize + dx;
                        if xx < 0 || xx >= w as isize {
                            0
                        } else {
                            r[xx as usize]
                        }
                    };
                    let m = [
                        [at(up, -1), at(up, 0), at(up, 1)],
                        [at(&cur.mag, -1), cur.mag[x], at(&cur.mag, 1)],
                        [at(down, -1), at(down, 0), at(down, 1)],
                    ];
                    let (c, d, s) = segment_pixel(cur.gx[x], cur.gy[x], m, self.params);
                    out.class[x] = c;
                    out.dir[x] = d;
                    out.sub[x] = s;
                    out.mag[x] = cur.mag[x];
                }
            }
            x += 1;
        }
        self.rows.advance();
    }
}
