//! The 5×5 Gaussian blur ([`gaussian`](crate::gaussian)) and the Sobel
//! ([`gradient`](crate::gradient)) as one streaming stage; lag 3 rows (2 + 1).
//!
//! The stage holds the blur's ring of five input rows and the Sobel's ring of three rows of
//! horizontal smooths and differences. Each blurred row goes straight from the blur into the
//! Sobel's ring; no `u8` row is handed from one stage to the next through the cascade. The
//! output rows, the blurred rows shown to the observer and their order are those of the two
//! stages chained.
//!
//! With AVX-512 (F/BW, chosen at run time by [`crate::simd`]) one hand-written pass per row
//! does it all, 64 columns a step split into their even and odd columns (32 16-bit lanes each):
//! the blur's vertical 1-4-6-4-1 sums of the five rows, its horizontal taps (a column's
//! neighbours are the other parity's lanes, at most one lane shift away: `vpermt2w` with the
//! neighbouring step's vector, no reloads), the rounding, then the Sobel's horizontal smooth
//! and difference of the blurred row while it is still in registers, the Sobel's vertical pass
//! over its ring and the gradient row interleaved back into column order and written out
//! (details in the kernel's docs). Written by hand because the compiler vectorises the two
//! stages' four row loops one by one (well: 512-bit lanes, the taps as unaligned loads), but
//! with the blur's vertical sums, the blurred row and the Sobel's smooth and difference rows
//! each stored and read back, every row widened by `vpmovzxbw` (a shuffle, on the two pipes
//! the lane shifts need), and the blurred row packed by a masked `vpmovwb` into memory, which
//! Zen 4 runs slowly (≈ 20 % of the blur in `perf annotate`). Here the blurred `u8` row is
//! written only for an observer that looks at it ([`StageObserver::observes`]). The scalar and
//! AVX2 levels run the two stages' loops ([`Gaussian5`], [`Sobel`]), the reference the kernel
//! equals bit for bit (`tests/simd.rs`). The Sobel's ring is in the kernel's split layout at
//! the AVX-512 level and in column order below it, so the stage latches the level at a frame's
//! start ([`RowStage::reset`]): a [`crate::simd::set_level`] (tests and benchmarks) from another
//! thread takes effect at the next frame.
//!
//! ```
//! use gonio_vision::blur_sobel::BlurSobel;
//! use gonio_vision::gradient::GradRow;
//! use gonio_vision::rows::RowStage;
//! let mut s = BlurSobel::new(8);
//! let mut g = GradRow::new(8);
//! let ramp = [0u8, 16, 32, 48, 64, 80, 96, 112];
//! let mut rows = 0;
//! for _ in 0..5 {
//!     rows += s.push_row(&ramp, &mut g) as usize;
//! }
//! while s.flush_row(&mut g) {
//!     rows += 1;
//!     assert_eq!(g.gx[4], 4 * 32); // the blur keeps a linear ramp away from the borders
//!     assert_eq!(g.gy[..], [0; 8]);
//! }
//! assert_eq!(rows, 5);
//! ```

use crate::gaussian::Gaussian5;
use crate::gradient::{GradRow, Sobel};
use crate::rows::{RowBlock, RowLag, RowStage, StageObserver};
use crate::simd::Avx512;

/// The blur and the Sobel in one stage: `u8` rows in, [`GradRow`]s out 3 rows later.
#[derive(Debug, Clone)]
pub struct BlurSobel {
    /// The blur: its ring holds the input rows; its counters, the blurred rows made.
    blur: Gaussian5,
    /// The Sobel: its ring holds the blurred rows' smooths and differences, its input buffer
    /// the last blurred row (for the observer); its counters, the gradient rows emitted.
    sobel: Sobel,
    rows: RowLag,
    /// The fused AVX-512 kernel runs this frame: the SIMD level latched at the frame's start
    /// ([`RowStage::reset`]), since the Sobel's ring layout depends on it.
    avx512: Option<Avx512>,
}

impl BlurSobel {
    /// The stage for rows of `width` pixels (≥ 2).
    pub fn new(width: usize) -> Self {
        BlurSobel {
            blur: Gaussian5::new(width),
            sobel: Sobel::new(width),
            rows: RowLag::new(3),
            avx512: Avx512::get(),
        }
    }

    /// Makes the next blurred row and puts it into the Sobel's ring. With `out` (the blurred
    /// row is then the one below the Sobel's next output row), the fused kernel also writes
    /// that gradient row into `out` and returns true; false when `out` is still to be made.
    fn make_row<O: StageObserver + ?Sized>(
        &mut self,
        out: Option<&mut GradRow>,
        obs: &mut O,
    ) -> bool {
        let window = self.blur.window();
        let sb = &mut self.sobel;
        let c = sb.rows.input_slot() * sb.stride;
        sb.rows.pushed();
        let emitted = match self.kernel(Some(window), c, out, obs.observes()) {
            Some(emitted) => emitted,
            None => {
                crate::simd::dispatch(
                    #[inline(always)]
                    || {
                        self.blur.emit_impl(&mut self.sobel.input);
                        // The slot of the row just counted.
                        self.sobel.accept_at(c);
                    },
                );
                false
            }
        };
        obs.blurred(&self.sobel.input);
        self.blur.rows.advance();
        emitted
    }

    /// The AVX-512 kernel (see [`crate::simd::avx512::blur_sobel`]): the blurred row from
    /// the blur's `window` into the Sobel's ring at `c` (the blurred `u8` row written only if
    /// `blurred`: for an observer), and/or the Sobel's next output row into `out`. Returns
    /// whether `out` was written; `None` below the AVX-512 level (nothing done).
    fn kernel(
        &mut self,
        window: Option<[usize; 5]>,
        c: usize,
        out: Option<&mut GradRow>,
        blurred: bool,
    ) -> Option<bool> {
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = self.avx512 {
            use crate::simd::avx512::blur_sobel::{Emit, blur_sobel};
            let sb = &mut self.sobel;
            let [a, b] = sb.rows.clamped_run::<2>(-1).map(|s| s * sb.stride);
            let emit = out.map(|out| Emit { out, a, b });
            let emitted = emit.is_some();
            blur_sobel(
                cpu,
                window.map(|win| (&self.blur.ring[..], win)),
                (&mut sb.smooth, &mut sb.diff),
                c,
                &mut sb.input,
                blurred,
                emit,
            );
            return Some(emitted);
        }
        let _ = (window, c, out, blurred);
        None
    }
}

impl RowStage for BlurSobel {
    type In = [u8];
    type Out = GradRow;
    fn rows(&self) -> &RowLag {
        &self.rows
    }
    fn rows_mut(&mut self) -> &mut RowLag {
        &mut self.rows
    }
    fn reset(&mut self) {
        self.rows.reset();
        self.blur.rows.reset();
        self.sobel.rows.reset();
        self.avx512 = Avx512::get();
    }
    fn input(&mut self) -> &mut [u8] {
        self.blur.input()
    }
    fn input_block(&mut self, n: usize) -> Option<RowBlock<'_>> {
        self.blur.input_block(n)
    }
    fn accept(&mut self) {
        // Counted only: the blurred rows are made when the Sobel needs them.
        self.blur.rows.pushed();
    }
    fn emit<O: StageObserver + ?Sized>(&mut self, out: &mut GradRow, obs: &mut O) {
        // Gradient row y needs blurred rows up to y + 1 (the last one at the frame's end).
        let y = self.sobel.rows.output_row();
        let need = (y + 1).min(self.blur.rows.received() - 1);
        let mut emitted = false;
        while self.blur.rows.output_row() <= need {
            // The last row needed, below row y, is made and used in the same pass.
            let fuse = self.blur.rows.output_row() == need && need > y;
            emitted = self.make_row(fuse.then_some(&mut *out), obs);
        }
        if !emitted {
            // The frame's last row (nothing below it to make) or the first one of a frame
            // shorter than the lag.
            let c = self.sobel.rows.clamped(1) * self.sobel.stride;
            if self.kernel(None, c, Some(out), false).is_none() {
                crate::simd::dispatch(
                    #[inline(always)]
                    || self.sobel.emit_impl(out),
                );
            }
        }
        self.sobel.rows.advance();
        obs.gradient(out);
    }
}
