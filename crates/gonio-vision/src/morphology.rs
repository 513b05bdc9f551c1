//! Streaming grey-scale morphology with disks: dilation, erosion, the black top-hat and the
//! opening of the morphology filter (seed Fig. 6a).
//!
//! The algorithm is the product here, so it is hand-written. A disk is a stack of horizontal
//! chords; the dilation of a row set is the maximum over the disk's rows of the row-wise running
//! maximum of that row's chord width. Each input row's running maxima are computed once per
//! distinct chord width: the narrowest from a doubling pyramid (max of 2, 4, 8… pixels; any width
//! is the max of two overlapping power-of-two windows), each wider one from the next narrower
//! (half width h + k = max of the h-row shifted by ±k, for k ≤ h), so the cost is one
//! vectorisable `max` pass per chord width plus two or three pyramid passes per row — never one
//! pass per structuring-element pixel. The vertical combination keeps 256 columns of running
//! extremes in registers while the 2r + 1 class rows stream by. Pixels outside the frame are ignored
//! (padding with the operation's neutral value), above, below and on the sides.
//!
//! ```
//! use gonio_vision::morphology::{Disk, Dilate};
//! let mut dil = Dilate::new(8, Disk::new(1));
//! let rows = [[0u8; 8], [0, 0, 0, 9, 0, 0, 0, 0], [0u8; 8]];
//! let mut out = [0u8; 8];
//! let mut got = Vec::new();
//! for r in &rows {
//!     if dil.push_row(r, &mut out) { got.push(out); }
//! }
//! while dil.flush_row(&mut out) { got.push(out); }
//! // r = 1 is the full 3×3 square (dx² + dy² ≤ 2): every output row sees the 9.
//! assert_eq!(got, vec![[0, 0, 9, 9, 9, 0, 0, 0]; 3]);
//! ```

use crate::rows::RowLag;

/// A discrete disk of radius r: the pixels (dx, dy) with dx² + dy² ≤ r² + r, i.e. within
/// r + ½ of the centre. Diameter 2r + 1 (r = 11: 23×23; r = 2: 5×5 without its corners).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Disk {
    radius: usize,
    /// Half chord width for |dy| = 0 … r.
    half_widths: Vec<usize>,
}

impl Disk {
    /// The disk of the given radius (0 is a single pixel).
    pub fn new(radius: usize) -> Self {
        let lim = radius * radius + radius;
        let half_widths = (0..=radius)
            .map(|dy| {
                let mut w = radius;
                while w * w + dy * dy > lim {
                    w -= 1;
                }
                w
            })
            .collect();
        Disk {
            radius,
            half_widths,
        }
    }

    /// Radius r.
    pub fn radius(&self) -> usize {
        self.radius
    }

    /// Half chord width at vertical offset `dy` (|dy| ≤ r).
    pub fn half_width(&self, dy: isize) -> usize {
        self.half_widths[dy.unsigned_abs()]
    }

    /// True if (dx, dy) belongs to the disk.
    pub fn contains(&self, dx: isize, dy: isize) -> bool {
        dy.unsigned_abs() <= self.radius && dx.unsigned_abs() <= self.half_width(dy)
    }
}

/// How a chord class's row of running extremes is computed.
#[derive(Debug, Clone, Copy)]
enum Source {
    /// From pyramid level k: two overlapping windows of 2^k.
    Pyramid(usize),
    /// From a narrower class's row (its index) shifted by ±k (k ≤ its half width, so the two
    /// windows overlap or touch).
    Chain(usize, usize),
}

/// Columns per block of the vertical combination (four AVX2 registers of running extremes).
const BLOCK: usize = 256;

/// Streaming dilation (`MAX = true`) or erosion (`MAX = false`) by a disk; lag r rows.
#[derive(Debug, Clone)]
pub struct Morph<const MAX: bool> {
    width: usize,
    radius: usize,
    pad: usize,
    /// Distinct half-widths, and for each |dy| the index of its class.
    class_half: Vec<usize>,
    class_of_dy: Vec<usize>,
    /// How each class row is made, narrowest first.
    plan: Vec<(usize, Source)>,
    /// Doubling pyramid; level 0 is the padded row.
    levels: Vec<Vec<u8>>,
    /// (2r + 1) slots × classes × stride.
    ring: Vec<u8>,
    /// Row stride in the ring: width rounded up to whole blocks.
    stride: usize,
    /// Ring offsets of the rows combined for the current output row.
    offs: Vec<usize>,
    rows: RowLag,
}

/// Streaming dilation (maximum over a disk).
pub type Dilate = Morph<true>;
/// Streaming erosion (minimum over a disk).
pub type Erode = Morph<false>;

#[inline(always)]
fn ext<const MAX: bool>(a: u8, b: u8) -> u8 {
    if MAX { a.max(b) } else { a.min(b) }
}

impl<const MAX: bool> Morph<MAX> {
    const NEUTRAL: u8 = if MAX { 0 } else { 255 };

    /// A filter for rows of `width` pixels. Allocates all its memory here:
    /// (2r + 1) × (distinct chord widths) rows plus a pyramid of a few rows.
    pub fn new(width: usize, disk: Disk) -> Self {
        let r = disk.radius;
        let mut class_half: Vec<usize> = Vec::new();
        let mut class_of_dy = Vec::with_capacity(r + 1);
        for dy in 0..=r {
            let w = disk.half_widths[dy];
            let c = match class_half.iter().position(|&h| h == w) {
                Some(c) => c,
                None => {
                    class_half.push(w);
                    class_half.len() - 1
                }
            };
            class_of_dy.push(c);
        }
        let pad = r;
        let n = width + 2 * pad;
        // Classes narrowest first; each from the previous one when the step is small enough
        // (one max pass instead of pyramid levels), else from the pyramid.
        let mut order: Vec<usize> = (0..class_half.len()).collect();
        order.sort_by_key(|&c| class_half[c]);
        let mut plan = Vec::with_capacity(order.len());
        let mut top_level = 0;
        for (i, &c) in order.iter().enumerate() {
            let hw = class_half[c];
            let chained = i > 0 && {
                let prev = order[i - 1];
                let k = hw - class_half[prev];
                k <= class_half[prev]
            };
            if chained {
                let prev = order[i - 1];
                plan.push((c, Source::Chain(prev, hw - class_half[prev])));
            } else {
                let span = 2 * hw + 1;
                let k = (usize::BITS - 1 - span.leading_zeros()) as usize;
                top_level = top_level.max(k);
                plan.push((c, Source::Pyramid(k)));
            }
        }
        let nlev = top_level + 1;
        // A ring row holds a class row over −(r − h) … w + (r − h) (the wider classes chained
        // from it need the margin), at `pad` from its start; the vertical combination reads
        // whole blocks from `pad` on (columns past w are ignored).
        let stride = (pad + width.div_ceil(BLOCK) * BLOCK).max(2 * pad + width);
        let stride = stride.div_ceil(64) * 64;
        Morph {
            width,
            radius: r,
            pad,
            plan,
            levels: vec![vec![Self::NEUTRAL; n]; nlev],
            ring: vec![Self::NEUTRAL; (2 * r + 1) * class_half.len() * stride],
            stride,
            class_half,
            class_of_dy,
            offs: Vec::with_capacity(2 * r + 1),
            rows: RowLag::new(r),
        }
    }

    /// Lag in rows between an input row and the output row of the same index.
    pub fn lag(&self) -> usize {
        self.radius
    }

    /// Starts a new frame.
    pub fn reset(&mut self) {
        self.rows.reset();
    }

    #[inline(always)]
    fn slot(&self, row: usize, class: usize) -> std::ops::Range<usize> {
        let nc = self.class_half.len();
        let s = ((row % self.rows.depth()) * nc + class) * self.stride + self.pad;
        s..s + self.width
    }

    /// Pushes one input row (`width` pixels); writes output row `pushed − 1 − r` into `out` and
    /// returns true once enough rows have arrived.
    pub fn push_row(&mut self, row: &[u8], out: &mut [u8]) -> bool {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2() {
            // SAFETY: the CPU has AVX2 (runtime check in `simd::avx2`).
            #[allow(unsafe_code)]
            return unsafe { self.push_row_avx2(row, out) };
        }
        self.push_row_impl(row, out)
    }

    /// The same code compiled with AVX2 (bit-exact: integer max/min only).
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    #[target_feature(enable = "avx2")]
    unsafe fn push_row_avx2(&mut self, row: &[u8], out: &mut [u8]) -> bool {
        self.push_row_impl(row, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    #[target_feature(enable = "avx2")]
    unsafe fn emit_avx2(&mut self, out: &mut [u8]) {
        self.emit(out)
    }

    #[inline(always)]
    fn push_row_impl(&mut self, row: &[u8], out: &mut [u8]) -> bool {
        debug_assert_eq!(row.len(), self.width);
        let (w, p) = (self.width, self.pad);
        // Level 1 (max of 2) straight from the row: no copy into the padded level 0 (a
        // 1.4 kB memcpy per row cost more than the max pass). Level 0 is only read for a chord
        // of width 1 (radius 0).
        let first = if p >= 1 && self.levels.len() > 1 && !self.class_half.contains(&0) {
            let l1 = &mut self.levels[1];
            for ((d, &a), &b) in l1[p..p + w - 1]
                .iter_mut()
                .zip(&row[..w - 1])
                .zip(&row[1..])
            {
                *d = ext::<MAX>(a, b);
            }
            // Beside the row the neutral padding leaves the edge pixel itself.
            l1[p - 1] = row[0];
            l1[p + w - 1] = row[w - 1];
            2
        } else {
            self.levels[0][p..p + w].copy_from_slice(row);
            1
        };
        let n = w + 2 * p;
        for k in first..self.levels.len() {
            let s = 1usize << (k - 1);
            let len = n + 1 - (1usize << k);
            let (lo, hi) = self.levels.split_at_mut(k);
            let src = &lo[k - 1];
            let dst = &mut hi[0][..len];
            for ((d, &a), &b) in dst.iter_mut().zip(&src[..len]).zip(&src[s..s + len]) {
                *d = ext::<MAX>(a, b);
            }
        }
        let row0 = self.rows.input_slot() * self.class_half.len();
        let (r, stride) = (self.radius, self.stride);
        for &(c, src) in &self.plan {
            let hw = self.class_half[c];
            let margin = r - hw;
            let len = w + 2 * margin;
            // Ring index of column −margin of this class row.
            let base = (row0 + c) * stride + p - margin;
            match src {
                Source::Pyramid(k) => {
                    let pk = 1usize << k;
                    let lev = &self.levels[k];
                    // Padded column of −margin is p − margin; its window starts at
                    // p − margin − hw = 0.
                    let a = &lev[p - margin - hw..p - margin - hw + len];
                    let b = &lev[p - margin + hw + 1 - pk..p - margin + hw + 1 - pk + len];
                    let dst = &mut self.ring[base..base + len];
                    for ((d, &x), &y) in dst.iter_mut().zip(a).zip(b) {
                        *d = ext::<MAX>(x, y);
                    }
                }
                Source::Chain(prev, k) => {
                    // The narrower row starts at column −(margin + k).
                    let pbase = (row0 + prev) * stride + p - margin - k;
                    let (src, dst) = if pbase < base {
                        let (lo, hi) = self.ring.split_at_mut(base);
                        (&lo[pbase..pbase + len + 2 * k], &mut hi[..len])
                    } else {
                        let (lo, hi) = self.ring.split_at_mut(pbase);
                        (&hi[..len + 2 * k], &mut lo[base..base + len])
                    };
                    for ((d, &x), &y) in dst.iter_mut().zip(&src[..len]).zip(&src[2 * k..]) {
                        *d = ext::<MAX>(x, y);
                    }
                }
            }
        }
        if self.rows.pushed() {
            self.emit(out);
            true
        } else {
            false
        }
    }

    /// After the frame's last row: writes the next pending output row, false when none is left.
    pub fn flush_row(&mut self, out: &mut [u8]) -> bool {
        if self.rows.pending() {
            #[cfg(target_arch = "x86_64")]
            if crate::simd::avx2() {
                // SAFETY: the CPU has AVX2 (runtime check in `simd::avx2`).
                #[allow(unsafe_code)]
                unsafe {
                    self.emit_avx2(out)
                };
                return true;
            }
            self.emit(out);
            true
        } else {
            false
        }
    }

    #[inline(always)]
    fn emit(&mut self, out: &mut [u8]) {
        let y = self.rows.output_row() as isize;
        let r = self.radius as isize;
        let lo = (y - r).max(0);
        let hi = (y + r).min(self.rows.received() as isize - 1);
        self.offs.clear();
        for yy in lo..=hi {
            let c = self.class_of_dy[(yy - y).unsigned_abs()];
            let start = self.slot(yy as usize, c).start;
            self.offs.push(start);
        }
        // Blocks of BLOCK columns: the running extreme stays in registers while the rows stream
        // by (one load per row and pixel instead of two loads and a store).
        const B: usize = BLOCK;
        let w = self.width;
        let ring = &self.ring;
        let mut x0 = 0;
        while x0 < w {
            let mut acc = [Self::NEUTRAL; B];
            for &o in &self.offs {
                let src: &[u8; B] = ring[o + x0..o + x0 + B].try_into().expect("block");
                for i in 0..B {
                    acc[i] = ext::<MAX>(acc[i], src[i]);
                }
            }
            if x0 + B <= w {
                // Fixed size: vector stores, not a memcpy call per block.
                let o: &mut [u8; B] = (&mut out[x0..x0 + B]).try_into().expect("block");
                *o = acc;
            } else {
                out[x0..w].copy_from_slice(&acc[..w - x0]);
            }
            x0 += B;
        }
        self.rows.advance();
    }
}

/// Streaming morphological closing (dilate, then erode) by a disk.
#[derive(Debug, Clone)]
pub struct Closing {
    dil: Dilate,
    ero: Erode,
    mid: Vec<u8>,
}

/// Streaming morphological opening (erode, then dilate) by a disk.
#[derive(Debug, Clone)]
pub struct Opening {
    ero: Erode,
    dil: Dilate,
    mid: Vec<u8>,
}

macro_rules! two_stage {
    ($t:ident, $a:ident, $b:ident) => {
        impl $t {
            /// A filter for rows of `width` pixels with the given disk.
            pub fn new(width: usize, disk: Disk) -> Self {
                $t {
                    $a: Morph::new(width, disk.clone()),
                    $b: Morph::new(width, disk),
                    mid: vec![0; width],
                }
            }
            /// Lag in rows (2r).
            pub fn lag(&self) -> usize {
                self.$a.lag() + self.$b.lag()
            }
            /// Starts a new frame.
            pub fn reset(&mut self) {
                self.$a.reset();
                self.$b.reset();
            }
            /// Pushes one row; true when `out` holds the next output row.
            pub fn push_row(&mut self, row: &[u8], out: &mut [u8]) -> bool {
                self.$a.push_row(row, &mut self.mid) && self.$b.push_row(&self.mid, out)
            }
            /// After the last row: the next pending output row, false when none is left.
            pub fn flush_row(&mut self, out: &mut [u8]) -> bool {
                while self.$a.flush_row(&mut self.mid) {
                    if self.$b.push_row(&self.mid, out) {
                        return true;
                    }
                }
                self.$b.flush_row(out)
            }
        }
    };
}
two_stage!(Closing, dil, ero);
two_stage!(Opening, ero, dil);

/// Streaming black top-hat: closing(I) − I (keeps dark features narrower than the disk, as
/// bright ones); lag 2r. Holds 2r + 1 input rows to subtract.
#[derive(Debug, Clone)]
pub struct BlackTopHat {
    close: Closing,
    delay: Vec<u8>,
    width: usize,
    slots: usize,
    n_in: usize,
    n_out: usize,
}

impl BlackTopHat {
    /// A filter for rows of `width` pixels with the given closing disk.
    pub fn new(width: usize, disk: Disk) -> Self {
        let slots = 2 * disk.radius() + 1;
        BlackTopHat {
            close: Closing::new(width, disk),
            delay: vec![0; slots * width],
            width,
            slots,
            n_in: 0,
            n_out: 0,
        }
    }
    /// Lag in rows (2r).
    pub fn lag(&self) -> usize {
        self.close.lag()
    }
    /// Starts a new frame.
    pub fn reset(&mut self) {
        self.close.reset();
        self.n_in = 0;
        self.n_out = 0;
    }
    fn subtract(&mut self, out: &mut [u8]) {
        let s = (self.n_out % self.slots) * self.width;
        for (o, &i) in out.iter_mut().zip(&self.delay[s..s + self.width]) {
            *o = o.saturating_sub(i);
        }
        self.n_out += 1;
    }
    /// Pushes one row; true when `out` holds the next output row.
    pub fn push_row(&mut self, row: &[u8], out: &mut [u8]) -> bool {
        let s = (self.n_in % self.slots) * self.width;
        self.delay[s..s + self.width].copy_from_slice(row);
        self.n_in += 1;
        if self.close.push_row(row, out) {
            self.subtract(out);
            true
        } else {
            false
        }
    }
    /// After the last row: the next pending output row, false when none is left.
    pub fn flush_row(&mut self, out: &mut [u8]) -> bool {
        if self.close.flush_row(out) {
            self.subtract(out);
            true
        } else {
            false
        }
    }
}
