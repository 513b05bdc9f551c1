//! Streaming 5×5 Gaussian blur (binomial 1-4-6-4-1, σ = 1) with replicated borders; lag 2 rows.
//!
//! Integer arithmetic: the separable sum of weights 256 is rounded, `(Σ + 128) >> 8`. The
//! vertical pass sums five u8 rows into u16 (≤ 16·255), the horizontal one five of those
//! (≤ 256·255 + 128 < 2¹⁶): 16-bit lanes throughout.
//!
//! ```
//! use gonio_vision::gaussian::Gaussian5;
//! use gonio_vision::rows::RowStage;
//! let mut g = Gaussian5::new(6);
//! let mut out = [0u8; 6];
//! let mut rows = Vec::new();
//! for _ in 0..4 { if g.push_row(&[50; 6], &mut out) { rows.push(out); } }
//! while g.flush_row(&mut out) { rows.push(out); }
//! assert_eq!(rows, vec![[50u8; 6]; 4]); // a flat image stays flat
//! ```

use crate::morphology::CHAIN_BATCH;
use crate::rows::{Aligned, RowBlock, RowLag, RowStage, StageObserver, line};

/// Rows in the ring: the five the kernel reads and room for a producer's batch written ahead
/// ([`RowStage::input_block`]; the opening's register chain, [`CHAIN_BATCH`] rows), a multiple
/// of the batch so that batches starting at multiples of it do not wrap (32).
const DEPTH: usize = (5 + CHAIN_BATCH).next_multiple_of(CHAIN_BATCH);

/// The binomial kernel (sums to 16).
pub const KERNEL: [u16; 5] = [1, 4, 6, 4, 1];

/// Streaming 5×5 binomial blur.
#[derive(Debug, Clone)]
pub struct Gaussian5 {
    pub(crate) width: usize,
    /// The last [`DEPTH`] input rows, `stride` apart.
    pub(crate) ring: Aligned<u8>,
    pub(crate) stride: usize,
    /// Vertical sums of the output row: column x at `line + x`, two replicated columns on each
    /// side.
    vsum: Aligned<u16>,
    pub(crate) rows: RowLag,
}

impl Gaussian5 {
    /// A blur for rows of `width` pixels.
    pub fn new(width: usize) -> Self {
        let stride = width.div_ceil(line::<u8>()) * line::<u8>();
        Gaussian5 {
            width,
            ring: Aligned::new(DEPTH * stride, 0),
            stride,
            vsum: Aligned::new(line::<u16>() + width + 2, 0),
            rows: RowLag::with_depth(2, DEPTH),
        }
    }

    /// Offsets in the ring of the rows `output_row − 2 … output_row + 2` (clamped to the rows
    /// received: replicated borders).
    #[inline]
    pub(crate) fn window(&self) -> [usize; 5] {
        self.rows.clamped_run::<5>(-2).map(|s| s * self.stride)
    }

    #[inline(always)]
    pub(crate) fn emit_impl(&mut self, out: &mut [u8]) {
        let w = self.width;
        let [a, b, c, d, e] = self.window().map(|s| &self.ring[s..s + w]);
        let l = line::<u16>();
        let v = &mut self.vsum[l..l + w];
        for (((((o, &a), &b), &c), &d), &e) in v.iter_mut().zip(a).zip(b).zip(c).zip(d).zip(e) {
            *o = a as u16 + 4 * b as u16 + 6 * c as u16 + 4 * d as u16 + e as u16;
        }
        let (first, last) = (self.vsum[l], self.vsum[l + w - 1]);
        self.vsum[l - 2..l].fill(first);
        self.vsum[l + w..l + w + 2].fill(last);
        let v = &self.vsum[l - 2..];
        let (v0, v1, v2, v3, v4) = (&v[..w], &v[1..w + 1], &v[2..w + 2], &v[3..w + 3], &v[4..]);
        for (((((o, &a), &b), &c), &d), &e) in
            out[..w].iter_mut().zip(v0).zip(v1).zip(v2).zip(v3).zip(v4)
        {
            *o = ((a + 4 * b + 6 * c + 4 * d + e + 128) >> 8) as u8;
        }
    }
}

impl RowStage for Gaussian5 {
    type In = [u8];
    type Out = [u8];
    fn rows(&self) -> &RowLag {
        &self.rows
    }
    fn rows_mut(&mut self) -> &mut RowLag {
        &mut self.rows
    }
    fn input(&mut self) -> &mut [u8] {
        let s = self.rows.input_slot() * self.stride;
        &mut self.ring[s..s + self.width]
    }
    fn input_block(&mut self, n: usize) -> Option<RowBlock<'_>> {
        let s = self.rows.block(n)?;
        Some(RowBlock {
            buf: &mut self.ring,
            first: s * self.stride,
            stride: self.stride,
        })
    }
    fn emit<O: StageObserver + ?Sized>(&mut self, out: &mut [u8], obs: &mut O) {
        crate::simd::dispatch(
            #[inline(always)]
            || self.emit_impl(out),
        );
        obs.blurred(out);
    }
}
