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
//! use gonio_vision::rows::RowStage;
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

use crate::rows::{RowLag, RowStage, StageObserver};

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

/// The chord kernel of a dilation (`MAX = true`) or an erosion (`MAX = false`) by a disk: the
/// chord-class rows of the last 2r + 1 input rows and their vertical combination.
#[derive(Debug, Clone)]
struct MorphCore<const MAX: bool> {
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
}

#[inline(always)]
fn ext<const MAX: bool>(a: u8, b: u8) -> u8 {
    if MAX { a.max(b) } else { a.min(b) }
}

impl<const MAX: bool> MorphCore<MAX> {
    const NEUTRAL: u8 = if MAX { 0 } else { 255 };

    fn new(width: usize, disk: &Disk) -> Self {
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
        MorphCore {
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
        }
    }

    #[inline(always)]
    fn slot_start(&self, row: usize, class: usize) -> usize {
        let nc = self.class_half.len();
        ((row % (2 * self.radius + 1)) * nc + class) * self.stride + self.pad
    }

    /// Makes the chord-class rows of input row `n` (`width` pixels).
    fn add_row(&mut self, row: &[u8], n: usize) {
        crate::simd::dispatch(
            #[inline(always)]
            || self.add_row_impl(row, n),
        )
    }

    #[inline(always)]
    fn add_row_impl(&mut self, row: &[u8], n: usize) {
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
        let n_pad = w + 2 * p;
        for k in first..self.levels.len() {
            let s = 1usize << (k - 1);
            let len = n_pad + 1 - (1usize << k);
            let (lo, hi) = self.levels.split_at_mut(k);
            let src = &lo[k - 1];
            let dst = &mut hi[0][..len];
            for ((d, &a), &b) in dst.iter_mut().zip(&src[..len]).zip(&src[s..s + len]) {
                *d = ext::<MAX>(a, b);
            }
        }
        let row0 = (n % (2 * self.radius + 1)) * self.class_half.len();
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
    }

    /// Output row `y` from the class rows of input rows y − r … y + r that exist (rows 0 …
    /// `n` − 1; the others are outside the frame).
    fn combine(&mut self, y: usize, n: usize, out: &mut [u8]) {
        crate::simd::dispatch(
            #[inline(always)]
            || self.combine_impl(y, n, out),
        )
    }

    #[inline(always)]
    fn combine_impl(&mut self, y: usize, n: usize, out: &mut [u8]) {
        let (y, r) = (y as isize, self.radius as isize);
        let lo = (y - r).max(0);
        let hi = (y + r).min(n as isize - 1);
        self.offs.clear();
        for yy in lo..=hi {
            let c = self.class_of_dy[(yy - y).unsigned_abs()];
            let start = self.slot_start(yy as usize, c);
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
    }
}

/// Streaming dilation (`MAX = true`) or erosion (`MAX = false`) by a disk; lag r rows.
#[derive(Debug, Clone)]
pub struct Morph<const MAX: bool> {
    core: MorphCore<MAX>,
    input: Vec<u8>,
    rows: RowLag,
}

/// Streaming dilation (maximum over a disk).
pub type Dilate = Morph<true>;
/// Streaming erosion (minimum over a disk).
pub type Erode = Morph<false>;

impl<const MAX: bool> Morph<MAX> {
    /// A filter for rows of `width` pixels. Allocates all its memory here:
    /// (2r + 1) × (distinct chord widths) rows plus a pyramid of a few rows.
    pub fn new(width: usize, disk: Disk) -> Self {
        Morph {
            core: MorphCore::new(width, &disk),
            input: vec![0; width],
            rows: RowLag::new(disk.radius),
        }
    }
}

impl<const MAX: bool> RowStage for Morph<MAX> {
    type In = [u8];
    type Out = [u8];
    fn rows(&self) -> &RowLag {
        &self.rows
    }
    fn rows_mut(&mut self) -> &mut RowLag {
        &mut self.rows
    }
    fn input(&mut self) -> &mut [u8] {
        &mut self.input
    }
    fn accept(&mut self) {
        self.core.add_row(&self.input, self.rows.received());
    }
    fn emit<O: StageObserver + ?Sized>(&mut self, out: &mut [u8], _: &mut O) {
        self.core
            .combine(self.rows.output_row(), self.rows.received(), out);
    }
}

/// Two morphological operations by one disk in a row, optionally minus the input: the closing
/// (dilate, then erode), the black top-hat (the closing minus the input) and the opening
/// (erode, then dilate); lag 2r. The first operation's rows are made as the second one needs
/// them; the last 2r + 1 input rows are kept for the subtraction.
#[derive(Debug, Clone)]
pub struct MorphPair<const FIRST_MAX: bool, const SECOND_MAX: bool, const SUBTRACT: bool> {
    first: MorphCore<FIRST_MAX>,
    second: MorphCore<SECOND_MAX>,
    /// The last 2r + 1 input rows.
    raw: Vec<u8>,
    /// One row of the first operation.
    mid: Vec<u8>,
    /// Rows of the first operation made so far.
    mid_rows: usize,
    width: usize,
    radius: usize,
    rows: RowLag,
}

/// Streaming morphological closing (dilate, then erode) by a disk.
pub type Closing = MorphPair<true, false, false>;
/// Streaming black top-hat: closing(I) − I (keeps dark features narrower than the disk, as
/// bright ones); lag 2r.
pub type BlackTopHat = MorphPair<true, false, true>;
/// Streaming morphological opening (erode, then dilate) by a disk.
pub type Opening = MorphPair<false, true, false>;

impl<const F: bool, const S: bool, const SUB: bool> MorphPair<F, S, SUB> {
    /// A filter for rows of `width` pixels with the given disk.
    pub fn new(width: usize, disk: Disk) -> Self {
        let r = disk.radius;
        MorphPair {
            first: MorphCore::new(width, &disk),
            second: MorphCore::new(width, &disk),
            raw: vec![0; (2 * r + 1) * width],
            mid: vec![0; width],
            mid_rows: 0,
            width,
            radius: r,
            rows: RowLag::new(2 * r),
        }
    }
}

impl<const F: bool, const S: bool, const SUB: bool> RowStage for MorphPair<F, S, SUB> {
    type In = [u8];
    type Out = [u8];
    fn rows(&self) -> &RowLag {
        &self.rows
    }
    fn rows_mut(&mut self) -> &mut RowLag {
        &mut self.rows
    }
    fn reset(&mut self) {
        self.rows.reset();
        self.mid_rows = 0;
    }
    fn input(&mut self) -> &mut [u8] {
        let s = self.rows.received() % (2 * self.radius + 1) * self.width;
        &mut self.raw[s..s + self.width]
    }
    fn accept(&mut self) {
        let n = self.rows.received();
        let s = n % (2 * self.radius + 1) * self.width;
        self.first.add_row(&self.raw[s..s + self.width], n);
    }
    fn emit<O: StageObserver + ?Sized>(&mut self, out: &mut [u8], obs: &mut O) {
        let (y, n) = (self.rows.output_row(), self.rows.received());
        // The second operation at row y needs the first one's rows up to y + r.
        let need = (y + self.radius).min(n - 1);
        while self.mid_rows <= need {
            let z = self.mid_rows;
            self.first.combine(z, n, &mut self.mid);
            self.second.add_row(&self.mid, z);
            self.mid_rows += 1;
        }
        self.second.combine(y, self.mid_rows, out);
        if SUB {
            let s = y % (2 * self.radius + 1) * self.width;
            for (o, &i) in out.iter_mut().zip(&self.raw[s..s + self.width]) {
                *o = o.saturating_sub(i);
            }
            obs.tophat(out);
        } else if !F {
            obs.opened(out);
        }
    }
}
