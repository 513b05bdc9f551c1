//! Streaming grey-scale morphology with disks: dilation, erosion, the black top-hat and the
//! opening of the morphology filter (Yu et al., 2024, Fig. 6a).
//!
//! The algorithm is the product here, so it is hand-written. A disk is a stack of horizontal
//! chords; the dilation of a row set is the maximum over the disk's rows of the row-wise running
//! maximum of that row's chord width. Each input row's running maxima are computed once per
//! distinct chord width: the narrowest from a doubling pyramid (max of 2, 4, 8… pixels; any width
//! is the max of two overlapping power-of-two windows), each wider one from the next narrower
//! (half width h + k = max of the h-row shifted by ±k, for k ≤ h), so the cost is one
//! vectorisable `max` pass per chord width plus two or three pyramid passes per row — never one
//! pass per structuring-element pixel. The vertical combination keeps 256 columns of running
//! extremes in registers while the 2r + 1 class rows stream by. For radii ≥ 4 (the top-hat's
//! 23×23 disk) the closing makes 4 output rows per vertical pass, one set of running extremes
//! each: the class rows, which come from L2 (the ring is 26 rows × 7 classes × 1.7 kB), are
//! loaded once per batch instead of once per output row (lag 2r + 3 instead of 2r). Pixels
//! outside the frame are ignored (padding with the operation's neutral value), above, below and
//! on the sides.
//!
//! The class rows of the last 2r + b input rows take (2r + b) × (distinct chord widths) rows of
//! memory: with a wide ring that is most of the detector (r = 512 on a 2048-pixel row: 300
//! classes, 0.9 GB each for the closing's two operations). Above [`CLASS_RING_BYTES`] a kernel
//! keeps each input row's doubling pyramid instead (about log₂(2r + 1) rows) and makes every
//! chord's running extreme as it combines, from the two windows of its pyramid level: the
//! same values, in a thirtieth of the memory, for one more load and `max` per chord.
//!
//! Where the CPU has AVX-512 VBMI (`vpermt2b`: any byte shift across two 64-byte vectors; see
//! `crate::simd::vbmi`) the closing and the opening of radius 1 … 12 run a second
//! hand-written kernel, with intrinsics, because no loop the compiler vectorises makes byte
//! shifts across vectors: per 64-column vector the chord classes are made in registers (the
//! pyramid and both windows of each class by `vpermt2b` on the 128 columns around the vector;
//! a class one pixel wider than the next narrower one as that one ∨ the two new columns,
//! loaded from the row), and the vertical union is a chain with 2r vectors of state per column vector, T_j(m) =
//! G_j(m) ∨ T_{j+1}(m − 1) and R_j(m) = G_j(m) ∨ R_{j−1}(m − 1) (G_j the class of |dy| = j,
//! T_r = G_r, R_0 = T_0; the row m − r is R_r(m)): 2r max operations per vector and row, as
//! the direct union, but the state stays in zmm registers while 16 rows stream through one
//! column vector, so there is no class-row ring in L2 at all. Its lag is 2r + 15. It gives the same bits as the other paths (tests: every level
//! against the reference, `tests/simd.rs`).
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

use crate::buffer::{PAD, padded_stride};
use crate::rows::{Aligned, RowBlock, RowLag, RowSink, RowStage, StageObserver};
#[cfg(target_arch = "x86_64")]
use crate::simd::vbmi::morphology as vbmi_kernel;

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

/// Columns per block of the vertical combination.
const BLOCK: usize = 256;

/// Output rows the vertical combination makes at once (per block, one set of running extremes
/// each): a chord-class row loaded once serves every row of the batch that uses it.
const BATCH: usize = 4;

/// Output rows the register chain kernel makes per pass over the column vectors: its 2r state
/// vectors per column vector are loaded and stored once per pass.
pub(crate) const CHAIN_BATCH: usize = 16;

#[inline(always)]
fn ext<const MAX: bool>(a: u8, b: u8) -> u8 {
    if MAX { a.max(b) } else { a.min(b) }
}

/// Most bytes a kernel's ring of chord-class rows may take; above it the kernel keeps each
/// input row's pyramid instead (see the module doc).
pub const CLASS_RING_BYTES: usize = 16 << 20;

/// Bytes per step of a row pass (two AVX2 registers, one AVX-512 register).
const STEP: usize = 64;

/// `dst[i] = ext(a[i], b[i])` for every i, in fixed steps of [`STEP`] bytes with the last step
/// overlapping the one before (it writes the same values again): no scalar remainder loop,
/// which for the morphology's odd pass lengths cost as much as the passes themselves.
#[inline(always)]
fn pass<const MAX: bool>(dst: &mut [u8], a: &[u8], b: &[u8]) {
    let n = dst.len();
    let (a, b) = (&a[..n], &b[..n]);
    if n < STEP {
        for ((d, &x), &y) in dst.iter_mut().zip(a).zip(b) {
            *d = ext::<MAX>(x, y);
        }
        return;
    }
    let step = |dst: &mut [u8], a: &[u8], b: &[u8], i: usize| {
        let d: &mut [u8; STEP] = (&mut dst[i..i + STEP]).try_into().expect("step");
        let x: &[u8; STEP] = a[i..i + STEP].try_into().expect("step");
        let y: &[u8; STEP] = b[i..i + STEP].try_into().expect("step");
        for k in 0..STEP {
            d[k] = ext::<MAX>(x[k], y[k]);
        }
    };
    let mut i = 0;
    while i + STEP <= n {
        step(dst, a, b, i);
        i += STEP;
    }
    if i < n {
        step(dst, a, b, n - STEP);
    }
}

/// The chord kernel of a dilation (`MAX = true`) or an erosion (`MAX = false`) by a disk: the
/// chord-class rows of the last 2r + 1 input rows and their vertical combination.
///
/// Every row (pyramid levels, class rows) has one layout: column x at index `lead + x` of a
/// 64-byte aligned row of `stride` bytes, so every pass stores whole cache lines and the
/// vertical combination loads them (a store straddling two lines costs twice, and the passes
/// are store-bound).
#[derive(Debug, Clone)]
struct MorphCore<const MAX: bool> {
    width: usize,
    radius: usize,
    /// Distinct half-widths, and for each |dy| the index of its class.
    class_half: Vec<usize>,
    class_of_dy: Vec<usize>,
    /// How each class row is made, narrowest first.
    plan: Vec<(usize, Source)>,
    /// Columns before column 0 that the passes compute, a multiple of 64 ≥ r.
    w0: usize,
    /// Index of column 0 in a row (2·w0) and the row length.
    lead: usize,
    stride: usize,
    /// Doubling pyramid, level k at row k (level 0, the row itself, only for radius 0).
    levels: Aligned<u8>,
    /// Ring slots (input rows kept): 2r + the batch size.
    depth: usize,
    /// `depth` slots × classes rows; with `pyramids`, `depth` slots × pyramid levels rows.
    ring: Aligned<u8>,
    /// The class rows combined for the current batch: ring offset of column 0 and the bit set
    /// of the batch's rows that use it.
    offs: Vec<(usize, u8)>,
    /// Pyramid levels kept per input row, when the ring holds pyramids (0: class rows).
    pyramids: usize,
    /// With `pyramids`: each class's pyramid level k (its two windows of 2^k).
    class_level: Vec<usize>,
    /// With `pyramids`: the two windows of each chord combined for the current batch (ring
    /// offsets of column 0) and the bit set of the batch's rows that use it.
    offs2: Vec<(usize, usize, u8)>,
}

impl<const MAX: bool> MorphCore<MAX> {
    const NEUTRAL: u8 = if MAX { 0 } else { 255 };

    /// A kernel for rows of `width` pixels that makes up to `batch` (≤ [`BATCH`]) output rows
    /// at once, its ring of class rows at most [`CLASS_RING_BYTES`] (else pyramids).
    fn new(width: usize, disk: &Disk, batch: usize) -> Self {
        Self::with_ring_limit(width, disk, batch, CLASS_RING_BYTES)
    }

    /// As [`MorphCore::new`], keeping pyramids when the class rows would take more than
    /// `limit` bytes.
    fn with_ring_limit(width: usize, disk: &Disk, batch: usize, limit: usize) -> Self {
        debug_assert!((1..=BATCH).contains(&batch));
        let r = disk.radius;
        let depth = 2 * r + batch;
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
        let w0 = r.max(1).div_ceil(64) * 64;
        let lead = 2 * w0;
        let stride = (lead + width + 2 * w0).max(lead + width.div_ceil(BLOCK) * BLOCK);
        let stride = stride.div_ceil(64) * 64;
        let class_level: Vec<usize> = class_half
            .iter()
            .map(|&hw| (usize::BITS - 1 - (2 * hw + 1).leading_zeros()) as usize)
            .collect();
        let pyramid_levels = class_level.iter().max().map_or(1, |&k| k + 1);
        let class_bytes = depth
            .saturating_mul(class_half.len())
            .saturating_mul(stride);
        let pyramids = if r > 0 && class_bytes > limit {
            pyramid_levels
        } else {
            0
        };
        MorphCore {
            width,
            radius: r,
            w0,
            lead,
            stride,
            plan,
            levels: Aligned::new(
                if pyramids > 0 {
                    0
                } else {
                    (top_level + 1) * stride
                },
                Self::NEUTRAL,
            ),
            depth,
            ring: Aligned::new(
                depth
                    * if pyramids > 0 {
                        pyramids
                    } else {
                        class_half.len()
                    }
                    * stride,
                Self::NEUTRAL,
            ),
            class_half,
            class_of_dy,
            offs: Vec::with_capacity(depth * BATCH),
            pyramids,
            class_level,
            offs2: Vec::new(),
        }
    }

    /// Keeps input row `n`'s doubling pyramid (levels 0 … `pyramids` − 1, level 0 the row) in
    /// its slot: level k at column x is the extreme of columns x … x + 2^k − 1.
    fn add_pyramid(&mut self, row: &[u8], n: usize) {
        let (w, st, lead, nlev) = (self.width, self.stride, self.lead, self.pyramids);
        let base = (n % self.depth) * nlev * st;
        let slot = &mut self.ring[base..base + nlev * st];
        slot[lead..lead + w].copy_from_slice(row);
        if nlev > 1 {
            let (l0, rest) = slot.split_at_mut(st);
            let l1 = &mut rest[..st];
            if w >= 2 {
                pass::<MAX>(
                    &mut l1[lead..lead + w - 1],
                    &l0[lead..lead + w - 1],
                    &l0[lead + 1..],
                );
            }
            l1[lead - 1] = row[0];
            l1[lead + w - 1] = row[w - 1];
        }
        for k in 2..nlev {
            let s = 1usize << (k - 1);
            let (lo, hi) = slot.split_at_mut(k * st);
            let src = &lo[(k - 1) * st..k * st];
            pass::<MAX>(&mut hi[..st - s], &src[..st - s], &src[s..]);
        }
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
        if self.pyramids > 0 {
            return self.add_pyramid(row, n);
        }
        let (w, r, st, lead, w0) = (self.width, self.radius, self.stride, self.lead, self.w0);
        let nlev = self.levels.len() / st;
        if r == 0 {
            // A single pixel: the class row is the row.
            self.levels[lead..lead + w].copy_from_slice(row);
        } else {
            // Level 1 (max of 2) straight from the row; beside it the neutral padding leaves
            // the edge pixel itself, and further out the neutral value (never written).
            let l1 = &mut self.levels[st..2 * st];
            if w >= 2 {
                pass::<MAX>(&mut l1[lead..lead + w - 1], &row[..w - 1], &row[1..]);
            }
            l1[lead - 1] = row[0];
            l1[lead + w - 1] = row[w - 1];
            // Higher levels over whole rows: exact at every column.
            for k in 2..nlev {
                let s = 1usize << (k - 1);
                let (lo, hi) = self.levels.split_at_mut(k * st);
                let src = &lo[(k - 1) * st..k * st];
                pass::<MAX>(&mut hi[..st - s], &src[..st - s], &src[s..]);
            }
        }
        let row0 = (n % self.depth) * self.class_half.len();
        for &(c, src) in &self.plan {
            let hw = self.class_half[c];
            let margin = r - hw;
            // Columns −w0 … w + margin − 1; the dst starts on a cache line.
            let len = w0 + w + margin;
            let base = (row0 + c) * st + lead - w0;
            match src {
                Source::Pyramid(k) => {
                    let pk = 1usize << k;
                    let lev = &self.levels[k * st..(k + 1) * st];
                    // Column x's window of 2·hw + 1 is the max of two windows of 2^k.
                    let a = &lev[lead - w0 - hw..];
                    let b = &lev[lead - w0 + hw + 1 - pk..];
                    pass::<MAX>(&mut self.ring[base..base + len], a, b);
                }
                Source::Chain(prev, k) => {
                    // The narrower row shifted by ±k.
                    let pbase = (row0 + prev) * st + lead - w0 - k;
                    let (src, dst) = if pbase < base {
                        let (lo, hi) = self.ring.split_at_mut(base);
                        (&lo[pbase..pbase + len + 2 * k], &mut hi[..len])
                    } else {
                        let (lo, hi) = self.ring.split_at_mut(pbase);
                        (&hi[..len + 2 * k], &mut lo[base..base + len])
                    };
                    pass::<MAX>(dst, &src[..len], &src[2 * k..]);
                }
            }
        }
    }

    /// Output rows `y0` … `y0 + nb − 1` (nb ≤ the batch size) from the class rows of input rows
    /// y0 − r … y0 + nb − 1 + r that exist (rows 0 … `n` − 1; the others are outside the frame),
    /// row b into `out[b·ostride ..][.. width]`.
    fn combine(&mut self, y0: usize, nb: usize, n: usize, out: &mut [u8], ostride: usize) {
        if self.pyramids > 0 {
            crate::simd::dispatch(
                #[inline(always)]
                || self.combine_pyramids::<BATCH>(y0, nb, n, out, ostride),
            )
        } else if self.depth == 2 * self.radius + 1 {
            // Single rows: one set of running extremes.
            crate::simd::dispatch(
                #[inline(always)]
                || self.combine_impl::<1>(y0, nb, n, out, ostride),
            )
        } else {
            crate::simd::dispatch(
                #[inline(always)]
                || self.combine_impl::<BATCH>(y0, nb, n, out, ostride),
            )
        }
    }

    #[inline(always)]
    fn combine_impl<const NB: usize>(
        &mut self,
        y0: usize,
        nb: usize,
        n: usize,
        out: &mut [u8],
        ostride: usize,
    ) {
        debug_assert!(nb >= 1 && nb <= NB && nb <= self.depth - 2 * self.radius);
        let (r, y0i) = (self.radius as isize, y0 as isize);
        let lo = (y0i - r).max(0);
        let hi = (y0i + nb as isize - 1 + r).min(n as isize - 1);
        let (st, lead, depth, nc) = (self.stride, self.lead, self.depth, self.class_half.len());
        // Per input row, each class it contributes once, with the batch rows that use it.
        self.offs.clear();
        let mut slot = lo as usize % depth;
        for yy in lo..=hi {
            let first = self.offs.len();
            for b in 0..nb {
                let dy = (yy - y0i - b as isize).unsigned_abs();
                if dy > self.radius {
                    continue;
                }
                let o = (slot * nc + self.class_of_dy[dy]) * st + lead;
                match self.offs[first..].iter_mut().find(|e| e.0 == o) {
                    Some(e) => e.1 |= 1 << b,
                    None => self.offs.push((o, 1 << b)),
                }
            }
            slot = if slot + 1 == depth { 0 } else { slot + 1 };
        }
        // Blocks of BLOCK columns: the running extremes of the batch's rows stay in registers
        // while the class rows stream by.
        const B: usize = BLOCK;
        let (w, src, offs) = (self.width, &self.ring[..], &self.offs[..]);
        let block = |x0: usize| {
            let mut acc = [[Self::NEUTRAL; B]; NB];
            for &(o, m) in offs {
                let s: &[u8; B] = src[o + x0..o + x0 + B].try_into().expect("block");
                for (b, acc) in acc.iter_mut().enumerate() {
                    if NB == 1 || m & (1 << b) != 0 {
                        for i in 0..B {
                            acc[i] = ext::<MAX>(acc[i], s[i]);
                        }
                    }
                }
            }
            acc
        };
        let mut store = |x0: usize, acc: &[[u8; B]; NB], len: usize| {
            for (b, a) in acc.iter().enumerate().take(nb) {
                let o = &mut out[b * ostride + x0..b * ostride + x0 + len];
                if len == B {
                    // Fixed size: vector stores, not a memcpy call per block.
                    let o: &mut [u8; B] = o.try_into().expect("block");
                    *o = *a;
                } else {
                    o.copy_from_slice(&a[..len]);
                }
            }
        };
        let mut x0 = 0;
        while x0 + B <= w {
            store(x0, &block(x0), B);
            x0 += B;
        }
        if x0 < w {
            if w >= B {
                // The last block overlaps the one before: the same values again, whole stores.
                store(w - B, &block(w - B), B);
            } else {
                store(x0, &block(x0), w - x0);
            }
        }
    }
}

impl<const MAX: bool> MorphCore<MAX> {
    /// [`MorphCore::combine`] from the input rows' pyramids: each chord's running extreme is
    /// the extreme of its two windows of 2^k, made as the rows are combined.
    #[inline(always)]
    fn combine_pyramids<const NB: usize>(
        &mut self,
        y0: usize,
        nb: usize,
        n: usize,
        out: &mut [u8],
        ostride: usize,
    ) {
        debug_assert!(nb >= 1 && nb <= NB && nb <= self.depth - 2 * self.radius);
        let (r, y0i) = (self.radius as isize, y0 as isize);
        let lo = (y0i - r).max(0);
        let hi = (y0i + nb as isize - 1 + r).min(n as isize - 1);
        let (st, lead, depth, nlev) = (self.stride, self.lead, self.depth, self.pyramids);
        self.offs2.clear();
        let mut slot = lo as usize % depth;
        for yy in lo..=hi {
            let first = self.offs2.len();
            for b in 0..nb {
                let dy = (yy - y0i - b as isize).unsigned_abs();
                if dy > self.radius {
                    continue;
                }
                let c = self.class_of_dy[dy];
                let (k, hw) = (self.class_level[c], self.class_half[c]);
                let row = (slot * nlev + k) * st + lead;
                let (oa, ob) = (row - hw, row + hw + 1 - (1 << k));
                match self.offs2[first..].iter_mut().find(|e| e.0 == oa) {
                    Some(e) => e.2 |= 1 << b,
                    None => self.offs2.push((oa, ob, 1 << b)),
                }
            }
            slot = if slot + 1 == depth { 0 } else { slot + 1 };
        }
        const B: usize = BLOCK;
        let (w, src, offs) = (self.width, &self.ring[..], &self.offs2[..]);
        let block = |x0: usize| {
            let mut acc = [[Self::NEUTRAL; B]; NB];
            for &(oa, ob, m) in offs {
                let a: &[u8; B] = src[oa + x0..oa + x0 + B].try_into().expect("block");
                let c: &[u8; B] = src[ob + x0..ob + x0 + B].try_into().expect("block");
                let mut chord = [0u8; B];
                for i in 0..B {
                    chord[i] = ext::<MAX>(a[i], c[i]);
                }
                for (b, acc) in acc.iter_mut().enumerate() {
                    if m & (1 << b) != 0 {
                        for i in 0..B {
                            acc[i] = ext::<MAX>(acc[i], chord[i]);
                        }
                    }
                }
            }
            acc
        };
        let mut store = |x0: usize, acc: &[[u8; B]; NB], len: usize| {
            for (b, a) in acc.iter().enumerate().take(nb) {
                out[b * ostride + x0..b * ostride + x0 + len].copy_from_slice(&a[..len]);
            }
        };
        let mut x0 = 0;
        while x0 + B <= w {
            store(x0, &block(x0), B);
            x0 += B;
        }
        if x0 < w {
            if w >= B {
                store(w - B, &block(w - B), B);
            } else {
                store(x0, &block(x0), w - x0);
            }
        }
    }
}

/// Streaming dilation (`MAX = true`) or erosion (`MAX = false`) by a disk; lag r rows.
#[derive(Debug, Clone)]
pub struct Morph<const MAX: bool> {
    core: MorphCore<MAX>,
    input: Aligned<u8>,
    rows: RowLag,
}

/// Streaming dilation (maximum over a disk).
pub type Dilate = Morph<true>;
/// Streaming erosion (minimum over a disk).
pub type Erode = Morph<false>;

impl<const MAX: bool> Morph<MAX> {
    /// A filter for rows of `width` pixels. Allocates all its memory here:
    /// (2r + 1) × (distinct chord widths) rows plus a pyramid of a few rows, or for a wide disk
    /// (2r + 1) pyramids of about log₂(2r + 1) rows (see the module doc).
    pub fn new(width: usize, disk: Disk) -> Self {
        Morph {
            core: MorphCore::new(width, &disk, 1),
            input: Aligned::new(width, 0),
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
        let w = out.len();
        self.core
            .combine(self.rows.output_row(), 1, self.rows.received(), out, w);
    }
}

/// Two morphological operations by one disk in a row, optionally minus the input: the closing
/// (dilate, then erode), the black top-hat (the closing minus the input) and the opening
/// (erode, then dilate); lag 2r + b − 1 (b = 16 with the VBMI register
/// chain, see the module doc). Both operations make b rows at a time (the first
/// one's rows as the second one needs them): b = 4 for radii ≥ 4, where each chord-class row
/// loaded serves up to 4 output rows (the top-hat's 23×23 disk: the class rows come from L2),
/// else 1 (the opening's 5×5 disk: its class rows stay in L1 and batching only adds work).
/// The input ring keeps the last 2r + b rows (for the subtraction) and 16 more, so that a
/// producer can write a batch of rows into it ahead ([`RowStage::input_block`]).
///
/// The hand-over with the VBMI register chain: the kernel's second operation makes 16 rows
/// at once, column vector by column vector, so no row is finished before the last vector.
/// In a cascade ([`RowStage::emit_to`]) the batch is written straight into the next stage's
/// input slots when its ring offers them (the opening's ring, the Gaussian's), and the next
/// 16 `emit`s only show the observer the rows already there; the top-hat's subtraction is
/// done in the kernel's store (`vpsubusb` with the input row), so each top-hat row is written
/// once, into the opening's ring. Without such a consumer (a stage pushed on its own) the
/// batch goes into `done` and each `emit` copies a row out.
#[derive(Debug, Clone)]
pub struct MorphPair<const FIRST_MAX: bool, const SECOND_MAX: bool, const SUBTRACT: bool> {
    first: MorphCore<FIRST_MAX>,
    second: MorphCore<SECOND_MAX>,
    /// The last `rdepth` input rows, `rstride` apart (cache-line aligned, padded rows).
    raw: Aligned<u8>,
    rstride: usize,
    /// Rows in `raw`: lag + 1 and room for a producer's batch written ahead
    /// ([`RowStage::input_block`]).
    rdepth: usize,
    /// A batch of the first operation's rows, then of the second one's, `rstride` apart.
    mid: Aligned<u8>,
    done: Aligned<u8>,
    /// Rows of the first operation made so far.
    mid_rows: usize,
    /// Output rows made at once.
    batch: usize,
    /// The second operation's rows in `done`: the first one's index and how many.
    done_from: usize,
    done_rows: usize,
    /// The rows of the current batch went straight into the next stage's input slots.
    direct: bool,
    width: usize,
    radius: usize,
    rows: RowLag,
    /// The register chain kernel's state, where the CPU has AVX-512 VBMI.
    chain: Option<Chain>,
}

/// State of the two operations' register chains ([`crate::simd::vbmi`](mod@crate::simd::vbmi)):
/// rows fed so far, 2r vectors per column vector each, and the first operation's rows of the
/// current batch (padded rows).
#[derive(Debug, Clone)]
struct Chain {
    state1: Aligned<u8>,
    state2: Aligned<u8>,
    fed1: usize,
    fed2: usize,
    /// Padded rows of the first operation (its neutral value around, `rstride` apart); slot 0
    /// holds row `mid_from`.
    mid: Aligned<u8>,
    mid_from: usize,
    /// A padded row of each operation's neutral value (rows below the frame).
    neutral1: Aligned<u8>,
    neutral2: Aligned<u8>,
}

/// Streaming morphological closing (dilate, then erode) by a disk.
pub type Closing = MorphPair<true, false, false>;
/// Streaming black top-hat: closing(I) − I (keeps dark features narrower than the disk, as
/// bright ones); lag 2r + 3 (r ≥ 4; 2r + 15 with the VBMI register chain).
pub type BlackTopHat = MorphPair<true, false, true>;
/// Streaming morphological opening (erode, then dilate) by a disk.
pub type Opening = MorphPair<false, true, false>;

impl<const F: bool, const S: bool, const SUB: bool> MorphPair<F, S, SUB> {
    /// A filter for rows of `width` pixels with the given disk.
    pub fn new(width: usize, disk: Disk) -> Self {
        let r = disk.radius;
        #[cfg(target_arch = "x86_64")]
        let chained = vbmi_kernel::usable(r);
        #[cfg(not(target_arch = "x86_64"))]
        let chained = false;
        let batch = match (chained, r >= 4) {
            (true, _) => CHAIN_BATCH,
            (false, true) => BATCH,
            (false, false) => 1,
        };
        let lag = 2 * r + batch - 1;
        // Padded rows (the register kernel loads 32 columns either side of a vector).
        let rstride = padded_stride(width);
        let (neutral1, neutral2) = (MorphCore::<F>::NEUTRAL, MorphCore::<S>::NEUTRAL);
        #[cfg(target_arch = "x86_64")]
        let chain = chained.then(|| {
            let nstate = width.div_ceil(64) * 2 * r * 64;
            Chain {
                state1: Aligned::new(nstate, neutral1),
                state2: Aligned::new(nstate, neutral2),
                fed1: 0,
                fed2: 0,
                mid: Aligned::new((batch + r) * rstride, neutral2),
                mid_from: 0,
                neutral1: Aligned::new(rstride, neutral1),
                neutral2: Aligned::new(rstride, neutral2),
            }
        });
        #[cfg(not(target_arch = "x86_64"))]
        let chain = None;
        // A multiple of the chain's batch: batches start at multiples of it, so a batch's rows
        // are contiguous in the ring (the top-hat's rows subtracted, a producer's block).
        let rdepth = (lag + 1 + CHAIN_BATCH).next_multiple_of(CHAIN_BATCH);
        MorphPair {
            batch,
            chain,
            first: MorphCore::new(width, &disk, batch.min(BATCH)),
            second: MorphCore::new(width, &disk, batch.min(BATCH)),
            raw: Aligned::new(rdepth * rstride, neutral1),
            rstride,
            rdepth,
            mid: Aligned::new(batch * rstride, 0),
            done: Aligned::new(batch * rstride, 0),
            mid_rows: 0,
            done_from: 0,
            done_rows: 0,
            direct: false,
            width,
            radius: r,
            rows: RowLag::new(lag),
        }
    }

    /// Ring offset of input row `y`.
    fn raw_slot(&self, y: usize) -> usize {
        y % self.rdepth * self.rstride + PAD
    }

    /// Output rows from `y` on that the next batch makes (fewer than a batch at the frame's
    /// end).
    fn batch_rows(&self, y: usize) -> usize {
        self.batch.min(self.rows.received() - y)
    }

    /// Makes the output rows from `y` on (`batch_rows`) with the register chain kernel, into
    /// `into` (the next stage's input slots) or else `done`, the top-hat's already minus its
    /// input rows: the first operation fed the input rows its
    /// rows up to y + nb − 1 + r need (rows below the frame: neutral), then the second one fed
    /// those.
    #[cfg(target_arch = "x86_64")]
    fn chain_batch(&mut self, y: usize, into: Option<RowBlock<'_>>) {
        let (n, r, w, rs) = (self.rows.received(), self.radius, self.width, self.rstride);
        let nb = self.batch_rows(y);
        let rdepth = self.rdepth;
        let Some(c) = self.chain.as_mut() else {
            unreachable!("chain_batch without the chain kernel")
        };
        // The first operation's rows up to `mid_end` (at most the frame's last).
        let mid_end = (y + nb - 1 + r).min(n - 1);
        let (from, to) = (c.fed1, mid_end + r + 1);
        if from < to {
            let (ins, k) = chain_rows(from..to, |m| {
                if m < n {
                    let s = m % rdepth * rs;
                    &self.raw[s..s + rs]
                } else {
                    &c.neutral1[..]
                }
            });
            let ins = &ins[..k];
            let skip = r.saturating_sub(from);
            c.mid_from = from.max(r) - r;
            let out = vbmi_kernel::Out {
                buf: &mut c.mid,
                first: PAD,
                stride: rs,
                minus: &[],
                mfirst: 0,
                mstride: 0,
            };
            vbmi_kernel::feed::<F, false>(r, &mut c.state1, ins, out, skip, w);
            c.fed1 = to;
        }
        // The second operation's rows y … y + nb − 1.
        let (from, to) = (c.fed2, y + nb + r);
        debug_assert_eq!(from.max(r) - r, y);
        let (ins, k) = chain_rows(from..to, |m| {
            if m < n {
                let s = (m - c.mid_from) * rs;
                &c.mid[s..s + rs]
            } else {
                &c.neutral2[..]
            }
        });
        let ins = &ins[..k];
        let skip = r.saturating_sub(from);
        self.direct = into.is_some();
        let (buf, first, stride) = match into {
            Some(b) => (b.buf, b.first, b.stride),
            None => (&mut self.done[..], 0, rs),
        };
        // The top-hat's input rows y … y + nb − 1 (contiguous: y is a multiple of the batch, and
        // so is the ring's depth), subtracted in the kernel's store.
        let mfirst = y % rdepth * rs + PAD;
        assert!(
            y % rdepth + nb <= rdepth,
            "a batch of input rows wraps the ring"
        );
        let out = vbmi_kernel::Out {
            buf,
            first,
            stride,
            minus: &self.raw,
            mfirst,
            mstride: rs,
        };
        if SUB {
            vbmi_kernel::feed::<S, true>(r, &mut c.state2, ins, out, skip, w);
        } else {
            vbmi_kernel::feed::<S, false>(r, &mut c.state2, ins, out, skip, w);
        }
        c.fed2 = to;
        self.done_from = y;
        self.done_rows = nb;
    }

    /// Makes the first operation's rows up to the one the second one's rows `y` … `y + nb − 1`
    /// need (y + nb − 1 + r; each of those needs input rows up to r further, all received: the
    /// lag covers both).
    fn make_mid(&mut self, y: usize, nb: usize) {
        let (n, r, rs) = (self.rows.received(), self.radius, self.rstride);
        let need = (y + nb - 1 + r).min(n - 1);
        while self.mid_rows <= need {
            let z = self.mid_rows;
            let k = self.batch.min(need + 1 - z);
            self.first.combine(z, k, n, &mut self.mid, rs);
            for j in 0..k {
                self.second
                    .add_row(&self.mid[j * rs..j * rs + self.width], z + j);
            }
            self.mid_rows += k;
        }
    }

    /// Makes the second operation's rows from `y` on into `done` (a batch, fewer at the frame's
    /// end).
    fn make_batch(&mut self, y: usize) {
        let nb = self.batch_rows(y);
        self.make_mid(y, nb);
        self.second
            .combine(y, nb, self.mid_rows, &mut self.done, self.rstride);
        self.done_from = y;
        self.done_rows = nb;
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
        self.done_from = 0;
        self.done_rows = 0;
        self.direct = false;
        if let Some(c) = self.chain.as_mut() {
            c.state1.fill(MorphCore::<F>::NEUTRAL);
            c.state2.fill(MorphCore::<S>::NEUTRAL);
            c.fed1 = 0;
            c.fed2 = 0;
        }
    }
    fn input(&mut self) -> &mut [u8] {
        let s = self.raw_slot(self.rows.received());
        &mut self.raw[s..s + self.width]
    }
    fn accept(&mut self) {
        if self.chain.is_none() {
            let n = self.rows.received();
            let s = self.raw_slot(n);
            self.first.add_row(&self.raw[s..s + self.width], n);
        }
    }
    fn emit<O: StageObserver + ?Sized>(&mut self, out: &mut [u8], obs: &mut O) {
        let (y, w) = (self.rows.output_row(), self.width);
        let s = self.raw_slot(y);
        if self.batch == 1 && self.chain.is_none() {
            // Single rows: straight into `out`.
            self.make_mid(y, 1);
            self.second.combine(y, 1, self.mid_rows, out, w);
            if SUB {
                for (o, &i) in out.iter_mut().zip(&self.raw[s..s + w]) {
                    *o = o.saturating_sub(i);
                }
            }
        } else {
            if y >= self.done_from + self.done_rows {
                #[cfg(target_arch = "x86_64")]
                if self.chain.is_some() {
                    self.chain_batch(y, None);
                } else {
                    self.make_batch(y);
                }
                #[cfg(not(target_arch = "x86_64"))]
                self.make_batch(y);
            }
            let d = (y - self.done_from) * self.rstride;
            let row = &self.done[d..d + w];
            if SUB && self.chain.is_none() {
                for ((o, &c), &i) in out.iter_mut().zip(row).zip(&self.raw[s..s + w]) {
                    *o = c.saturating_sub(i);
                }
            } else {
                // The register chain's rows are already minus the input.
                out.copy_from_slice(row);
            }
        }
        Self::observe(out, obs);
    }
    fn emit_to<N, O>(&mut self, next: &mut N, obs: &mut O)
    where
        N: RowSink<Row = [u8]> + ?Sized,
        O: StageObserver + ?Sized,
    {
        let y = self.rows.output_row();
        // A new batch of the register chain goes straight into the next stage's input slots
        // when it has room for them (no copy of each row out of `done`).
        #[cfg(target_arch = "x86_64")]
        if self.chain.is_some() && y >= self.done_from + self.done_rows {
            let into = next.input_block(self.batch_rows(y));
            self.chain_batch(y, into);
        }
        if self.direct && y < self.done_from + self.done_rows {
            Self::observe(next.input(), obs);
        } else {
            self.emit(next.input(), obs);
        }
    }
    fn input_block(&mut self, n: usize) -> Option<RowBlock<'_>> {
        // The ring keeps lag + 1 rows and CHAIN_BATCH more: rows written that far ahead never
        // overwrite one still needed; and the block must not wrap.
        let s = self.rows.received() % self.rdepth;
        (n <= CHAIN_BATCH && s + n <= self.rdepth).then(|| RowBlock {
            first: self.raw_slot(self.rows.received()),
            stride: self.rstride,
            buf: &mut self.raw,
        })
    }
}

/// Input rows the register chain is fed at once, at most: a batch and both operations' reach
/// (the first batch of a frame; later ones feed a batch).
#[cfg(target_arch = "x86_64")]
const CHAIN_INS: usize = CHAIN_BATCH + 2 * vbmi_kernel::MAX_RADIUS;

/// The rows `m` of `range` (`row(m)`) for the register chain, in an array on the stack: a batch
/// is fed without an allocation. The count is the second value.
#[cfg(target_arch = "x86_64")]
#[inline]
fn chain_rows<'a>(
    range: std::ops::Range<usize>,
    row: impl Fn(usize) -> &'a [u8],
) -> ([&'a [u8]; CHAIN_INS], usize) {
    let k = range.len();
    assert!(k <= CHAIN_INS, "{k} rows fed to the register chain at once");
    let mut ins: [&[u8]; CHAIN_INS] = [&[]; CHAIN_INS];
    for (slot, m) in ins.iter_mut().zip(range) {
        *slot = row(m);
    }
    (ins, k)
}

impl<const F: bool, const S: bool, const SUB: bool> MorphPair<F, S, SUB> {
    /// Shows `obs` an output row (as the top-hat's or the opening's).
    fn observe<O: StageObserver + ?Sized>(row: &[u8], obs: &mut O) {
        if SUB {
            obs.tophat(row);
        } else if !F {
            obs.opened(row);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::{self, Image};

    /// Every output row of `core` over `img`, each as soon as its last input row is in.
    fn run<const MAX: bool>(core: &mut MorphCore<MAX>, img: &Image<u8>, r: usize) -> Vec<u8> {
        let (w, h) = (img.width, img.height);
        let mut out = vec![0u8; w * h];
        let mut next = 0;
        for y in 0..h {
            core.add_row(&img.data[y * w..(y + 1) * w], y);
            while next + r <= y {
                core.combine(next, 1, y + 1, &mut out[next * w..], w);
                next += 1;
            }
        }
        while next < h {
            core.combine(next, 1, h, &mut out[next * w..], w);
            next += 1;
        }
        out
    }

    #[test]
    fn pyramids_give_the_class_rows_bits_in_far_less_memory() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut byte = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 24) as u8
        };
        for (w, h, r) in [
            (300, 40, 1),
            (300, 90, 5),
            (700, 120, 23),
            (260, 200, 60),
            (40, 30, 9),
        ] {
            let img = Image::from_vec(w, h, (0..w * h).map(|_| byte()).collect());
            let disk = Disk::new(r);
            let mut classes = MorphCore::<true>::with_ring_limit(w, &disk, 1, usize::MAX);
            let mut pyramids = MorphCore::<true>::with_ring_limit(w, &disk, 1, 0);
            assert_eq!((classes.pyramids, pyramids.pyramids > 0), (0, true));
            if r >= 23 {
                // log₂(2r + 1) + 1 rows a slot instead of one a chord width.
                assert!(pyramids.ring.len() * 2 < classes.ring.len());
            }
            let want = reference::dilate(&img, &disk).data;
            assert_eq!(run(&mut classes, &img, r), want, "dilate r = {r}");
            assert_eq!(
                run(&mut pyramids, &img, r),
                want,
                "dilate r = {r}, pyramids"
            );
            let mut pyramids = MorphCore::<false>::with_ring_limit(w, &disk, 1, 0);
            let want = reference::erode(&img, &disk).data;
            assert_eq!(run(&mut pyramids, &img, r), want, "erode r = {r}, pyramids");
        }
    }

    #[test]
    fn a_ring_512_px_wide_on_a_2048_px_row_stays_small() {
        // The closing of a 512-px ring on a 2048 × 2048 window: 0.9 GB of class rows each.
        let core = MorphCore::<true>::new(2048, &Disk::new(512), BATCH);
        assert!(core.pyramids > 0);
        assert!(core.ring.len() < 48 << 20, "{} bytes", core.ring.len());
        // The station's 23 × 23 disk keeps its class rows.
        let station = MorphCore::<true>::new(1440, &Disk::new(11), BATCH);
        assert_eq!(station.pyramids, 0);
    }
}
