//! Streaming Sobel gradient with replicated borders; lag 1 row.
//!
//! Gx = [−1 0 1; −2 0 2; −1 0 1] ∗ I, Gy = [−1 −2 −1; 0 0 0; 1 2 1] ∗ I (y grows downward), and
//! the magnitude |G| = |Gx| + |Gy| (the L1 norm: integer, and what FPGA pipelines use).
//!
//! ```
//! use gonio_vision::gradient::{GradRow, Sobel};
//! use gonio_vision::rows::RowStage;
//! let mut s = Sobel::new(4);
//! let mut g = GradRow::new(4);
//! let ramp = [0u8, 10, 20, 30];
//! assert!(!s.push_row(&ramp, &mut g));
//! assert!(s.push_row(&ramp, &mut g));
//! assert_eq!(g.gx[..], [40, 80, 80, 40]); // 4·(I(x+1) − I(x−1)), replicated at the ends
//! assert_eq!(g.gy[..], [0; 4]);
//! ```

pub use crate::row_types::GradRow;
use crate::rows::{Aligned, RowLag, RowStage, StageObserver};

/// Streaming Sobel operator.
#[derive(Debug, Clone)]
pub struct Sobel {
    width: usize,
    pub(crate) input: Aligned<u8>,
    /// Per input row: horizontal smooth (1 2 1) and difference (−1 0 1), 3 slots each,
    /// `stride` apart.
    pub(crate) smooth: Aligned<i16>,
    pub(crate) diff: Aligned<i16>,
    pub(crate) stride: usize,
    pub(crate) rows: RowLag,
}

impl Sobel {
    /// A gradient for rows of `width` pixels (≥ 2).
    pub fn new(width: usize) -> Self {
        // Rows padded to 64 columns, whole cache lines (the fused stage's AVX-512 kernel steps
        // 64 columns at a time).
        let stride = width.div_ceil(64) * 64;
        Sobel {
            width,
            input: Aligned::new(width, 0),
            smooth: Aligned::new(3 * stride, 0),
            diff: Aligned::new(3 * stride, 0),
            stride,
            rows: RowLag::new(1),
        }
    }

    #[inline(always)]
    fn accept_impl(&mut self) {
        self.accept_at(self.rows.input_slot() * self.stride);
    }

    /// The smooth and difference of the input row into the ring at offset `s`.
    #[inline(always)]
    pub(crate) fn accept_at(&mut self, s: usize) {
        let w = self.width;
        let row = &self.input;
        let sm = &mut self.smooth[s..s + w];
        let df = &mut self.diff[s..s + w];
        sm[0] = 3 * row[0] as i16 + row[1] as i16;
        df[0] = row[1] as i16 - row[0] as i16;
        let (l, c, r) = (&row[..w - 2], &row[1..w - 1], &row[2..w]);
        for ((((s, d), &l), &c), &r) in sm[1..w - 1]
            .iter_mut()
            .zip(df[1..w - 1].iter_mut())
            .zip(l)
            .zip(c)
            .zip(r)
        {
            *s = l as i16 + 2 * c as i16 + r as i16;
            *d = r as i16 - l as i16;
        }
        sm[w - 1] = row[w - 2] as i16 + 3 * row[w - 1] as i16;
        df[w - 1] = row[w - 1] as i16 - row[w - 2] as i16;
    }

    #[inline(always)]
    pub(crate) fn emit_impl(&mut self, out: &mut GradRow) {
        let w = self.width;
        let slot = |dy: isize| self.rows.clamped(dy) * self.stride;
        let (a, b, c) = (slot(-1), slot(0), slot(1));
        let (sa, sc) = (&self.smooth[a..a + w], &self.smooth[c..c + w]);
        let (da, db, dc) = (
            &self.diff[a..a + w],
            &self.diff[b..b + w],
            &self.diff[c..c + w],
        );
        let (ogx, ogy, omag) = (&mut out.gx[..w], &mut out.gy[..w], &mut out.mag[..w]);
        for ((((((ox, oy), om), &da), &db), &dc), (&sa, &sc)) in ogx
            .iter_mut()
            .zip(ogy.iter_mut())
            .zip(omag.iter_mut())
            .zip(da)
            .zip(db)
            .zip(dc)
            .zip(sa.iter().zip(sc))
        {
            let gx = da + 2 * db + dc;
            let gy = sc - sa;
            *ox = gx;
            *oy = gy;
            *om = gx.unsigned_abs() + gy.unsigned_abs();
        }
    }
}

impl RowStage for Sobel {
    type In = [u8];
    type Out = GradRow;
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
        crate::simd::dispatch(
            #[inline(always)]
            || self.accept_impl(),
        );
    }
    fn emit<O: StageObserver + ?Sized>(&mut self, out: &mut GradRow, obs: &mut O) {
        crate::simd::dispatch(
            #[inline(always)]
            || self.emit_impl(out),
        );
        obs.gradient(out);
    }
}
