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
    avx512: bool,
}

/// Whether the current SIMD level runs the fused AVX-512 kernel.
fn avx512_level() -> bool {
    crate::simd::level() == crate::simd::Level::Avx512
}

impl BlurSobel {
    /// The stage for rows of `width` pixels (≥ 2).
    pub fn new(width: usize) -> Self {
        BlurSobel {
            blur: Gaussian5::new(width),
            sobel: Sobel::new(width),
            rows: RowLag::new(3),
            avx512: avx512_level(),
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

    /// The AVX-512 kernel (see [`avx512::blur_sobel`]): the blurred row from the blur's
    /// `window` into the Sobel's ring at `c` (the blurred `u8` row written only if `blurred`:
    /// for an observer), and/or the Sobel's next output row into `out`. Returns whether `out`
    /// was written; `None` below the AVX-512 level (nothing done).
    #[allow(unsafe_code)]
    fn kernel(
        &mut self,
        window: Option<[usize; 5]>,
        c: usize,
        out: Option<&mut GradRow>,
        blurred: bool,
    ) -> Option<bool> {
        #[cfg(target_arch = "x86_64")]
        if self.avx512 {
            let sb = &mut self.sobel;
            let (a, b) = (
                sb.rows.clamped(-1) * sb.stride,
                sb.rows.clamped(0) * sb.stride,
            );
            let emit = out.map(|out| avx512::Emit { out, a, b });
            let emitted = emit.is_some();
            // SAFETY: the AVX-512 level is used only on a CPU with AVX-512 F/BW/VL/DQ (checked
            // in `simd::detected`); the kernel asserts the rows' lengths.
            unsafe {
                avx512::blur_sobel(
                    window.map(|win| (&self.blur.ring[..], win)),
                    (&mut sb.smooth, &mut sb.diff),
                    c,
                    &mut sb.input,
                    blurred,
                    emit,
                )
            };
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
        self.avx512 = avx512_level();
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

/// The fused row kernel with AVX-512 intrinsics (see the module docs).
///
/// 64 columns a step, split into their even and odd columns, 32 16-bit lanes each (`e`, `o`):
/// a 64-byte load of a `u8` row gives both with a mask and a shift, no zero-extending
/// shuffles. The horizontal neighbours of an even column are odd ones and vice versa, so each
/// tap is a lane shift by one (`vpermt2w` with the neighbouring step's vector) of half the
/// vectors, or no shift at all. The Sobel's ring holds its rows in this split layout (even
/// columns, then odd ones, per 64 columns); the gradient rows are interleaved back into column
/// order (`vpermt2w`) before they are stored.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod avx512 {
    use crate::gradient::GradRow;
    use std::arch::x86_64::*;

    /// `vpermt2w` lane indices: lane i takes lane i / `div` + `base` + `odd` · (i mod 2) of
    /// the pair of vectors (0 … 31 the first, 32 … 63 the second).
    const fn table(div: i16, base: i16, odd: i16) -> [i16; 32] {
        let mut t = [0i16; 32];
        let mut i = 0;
        while i < 32 {
            let l = i as i16;
            t[i] = l / div + base + odd * (l % 2);
            i += 1;
        }
        t
    }
    /// Lane m + 1 of (this vector, the next one).
    const NEXT: [i16; 32] = table(1, 1, 0);
    /// Lane m − 1 of (the previous vector, this one).
    const PREV: [i16; 32] = table(1, 31, 0);
    /// Columns 0 … 31 and 32 … 63 of a step from its (even, odd) vectors.
    const LOW: [i16; 32] = table(2, 0, 32);
    const HIGH: [i16; 32] = table(2, 16, 32);

    /// The gradient row the kernel writes: `out`, with the Sobel ring's rows above it (`a`)
    /// and of it (`b`) as offsets.
    pub(super) struct Emit<'a> {
        pub out: &'a mut GradRow,
        pub a: usize,
        pub b: usize,
    }

    #[inline]
    #[target_feature(enable = "avx512f,avx512bw")]
    fn index(t: &[i16; 32]) -> __m512i {
        // SAFETY: 64 bytes read from a 64-byte array.
        unsafe { _mm512_loadu_si512(t.as_ptr().cast()) }
    }

    /// Every lane set to lane `i` of `v`.
    #[inline]
    #[target_feature(enable = "avx512f,avx512bw")]
    fn broadcast(v: __m512i, i: usize) -> __m512i {
        _mm512_permutexvar_epi16(_mm512_set1_epi16(i as i16), v)
    }

    /// The lowest `n` lanes (≤ 32).
    #[inline]
    fn lanes(n: usize) -> __mmask32 {
        if n >= 32 { !0 } else { (1u32 << n) - 1 }
    }

    /// A step's (even, odd) vectors with the columns from `tail` on (the row's end) replaced
    /// by column `tail − 1` (replicated border); returns them and that column broadcast.
    #[inline]
    #[target_feature(enable = "avx512f,avx512bw")]
    fn replicate_after(e: __m512i, o: __m512i, tail: usize) -> (__m512i, __m512i, __m512i) {
        let last = if tail % 2 == 1 {
            broadcast(e, tail / 2)
        } else {
            broadcast(o, tail / 2 - 1)
        };
        let e = _mm512_mask_blend_epi16(lanes(tail.div_ceil(2)), last, e);
        let o = _mm512_mask_blend_epi16(lanes(tail / 2), last, o);
        (e, o, last)
    }

    /// With `blur = Some((ring, window))`: blurs the rows at `window` (offsets into `ring`:
    /// rows y − 2 … y + 2) into row y, its Sobel smooth (1 2 1) and difference (−1 0 1) into
    /// the Sobel's rings `smooth` and `diff` at offset `c` (split layout), its `u8` values into
    /// `out8` if `blurred`. With `emit`: the gradient row above row y, from the rings' rows
    /// `a`, `b` and row y's smooth and difference in registers; or, without `blur`, from the
    /// rings' rows `a`, `b`, `c`.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F/BW/VL/DQ. The lengths are asserted.
    #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq,avx2")]
    pub(super) unsafe fn blur_sobel(
        blur: Option<(&[u8], [usize; 5])>,
        (smooth, diff): (&mut [i16], &mut [i16]),
        c: usize,
        out8: &mut [u8],
        blurred: bool,
        emit: Option<Emit<'_>>,
    ) {
        let w = out8.len();
        assert!(w > 0 && (blur.is_some() || emit.is_some()));
        let n = w.div_ceil(64);
        // Whole vectors are read and written in the rings (their rows are padded to 64
        // columns), masked ones in the output rows.
        if let Some((ring, window)) = blur {
            assert!(window.iter().all(|&o| o + n * 64 <= ring.len()));
        }
        assert!(c + n * 64 <= smooth.len() && c + n * 64 <= diff.len());
        if let Some(e) = &emit {
            assert!(e.a + n * 64 <= smooth.len() && e.b + n * 64 <= diff.len());
            assert!(e.out.gx.len() == w && e.out.gy.len() == w && e.out.mag.len() == w);
        }
        let tail = w - (n - 1) * 64;
        let (next, prev, low, high) = (index(&NEXT), index(&PREV), index(&LOW), index(&HIGH));
        let sp = smooth.as_mut_ptr();
        let dp = diff.as_mut_ptr();
        let emit = emit.map(|e| {
            let o = e.out;
            let p = (o.gx.as_mut_ptr(), o.gy.as_mut_ptr(), o.mag.as_mut_ptr());
            (p, e.a, e.b)
        });

        // The gradients of step j from row y's smooth and difference (split layout).
        let gradients = |j: usize, [sm_e, sm_o, df_e, df_o]: [__m512i; 4]| {
            let Some(((gxp, gyp, magp), a, b)) = emit else {
                return;
            };
            let x = 64 * j;
            // SAFETY: 64 lanes at `a + x`, `b + x` ≤ len − 64 (asserted above); the gradient
            // row's stores are masked to its `w` lanes.
            unsafe {
                let ld = |p: *mut i16, o: usize| _mm512_loadu_si512(p.add(o + x).cast());
                let gx = |d: __m512i, o: usize| {
                    let (da, db) = (ld(dp, a + o), ld(dp, b + o));
                    _mm512_add_epi16(_mm512_add_epi16(da, d), _mm512_add_epi16(db, db))
                };
                let (gx_e, gx_o) = (gx(df_e, 0), gx(df_o, 32));
                let gy_e = _mm512_sub_epi16(sm_e, ld(sp, a));
                let gy_o = _mm512_sub_epi16(sm_o, ld(sp, a + 32));
                let m = if j + 1 == n { tail } else { 64 };
                for (half, idx, mask) in
                    [(0, low, lanes(m)), (32, high, lanes(m.saturating_sub(32)))]
                {
                    let gx = _mm512_permutex2var_epi16(gx_e, idx, gx_o);
                    let gy = _mm512_permutex2var_epi16(gy_e, idx, gy_o);
                    let mag = _mm512_add_epi16(_mm512_abs_epi16(gx), _mm512_abs_epi16(gy));
                    _mm512_mask_storeu_epi16(gxp.add(x + half).cast(), mask, gx);
                    _mm512_mask_storeu_epi16(gyp.add(x + half).cast(), mask, gy);
                    _mm512_mask_storeu_epi16(magp.add(x + half).cast(), mask, mag);
                }
            }
        };

        let Some((ring, window)) = blur else {
            // Only the gradient row, from the ring's row c.
            for j in 0..n {
                // SAFETY: 64 lanes at `c + 64j` ≤ len − 64 (asserted above).
                let ld = |p: *mut i16, o: usize| unsafe {
                    _mm512_loadu_si512(p.add(c + 64 * j + o).cast())
                };
                gradients(j, [ld(sp, 0), ld(sp, 32), ld(dp, 0), ld(dp, 32)]);
            }
            return;
        };

        let rp = ring.as_ptr();
        let bytes = _mm512_set1_epi16(0xff);
        let six = _mm512_set1_epi16(6);
        let half = _mm512_set1_epi16(128);
        // The vertical sums of step k: (even, odd) columns.
        let vsum = |k: usize| {
            let split = |o: usize| {
                // SAFETY: 64 bytes at `o + 64k` ≤ ring.len() − 64 (asserted above).
                let x = unsafe { _mm512_loadu_si512(rp.add(o + 64 * k).cast()) };
                (_mm512_and_si512(x, bytes), _mm512_srli_epi16::<8>(x))
            };
            let [r0, r1, r2, r3, r4] = window.map(split);
            let sum = |a: __m512i, b: __m512i, c: __m512i, d: __m512i, e: __m512i| {
                let bd = _mm512_add_epi16(b, d);
                _mm512_add_epi16(
                    _mm512_add_epi16(a, e),
                    _mm512_add_epi16(_mm512_slli_epi16::<2>(bd), _mm512_mullo_epi16(c, six)),
                )
            };
            (
                sum(r0.0, r1.0, r2.0, r3.0, r4.0),
                sum(r0.1, r1.1, r2.1, r3.1, r4.1),
            )
        };
        // (t[x−2] + t[x+2]) + 4 (t[x−1] + t[x+1]) + 6 t[x], rounded: ≤ 256·255 + 128.
        let blur = |far: __m512i, near: __m512i, centre: __m512i| {
            let s = _mm512_add_epi16(far, _mm512_slli_epi16::<2>(near));
            let s = _mm512_add_epi16(s, _mm512_add_epi16(_mm512_mullo_epi16(centre, six), half));
            _mm512_srli_epi16::<8>(s)
        };
        // The Sobel's smooth and difference of step j from the blurred (even, odd) columns of
        // steps j − 1 (its odd ones), j and j + 1 (its even ones); stored, then the gradients.
        let sobel = |j: usize, o_prev: __m512i, (e, o): (__m512i, __m512i), e_next: __m512i| {
            let op = _mm512_permutex2var_epi16(o_prev, prev, o); // column 2m − 1
            let en = _mm512_permutex2var_epi16(e, next, e_next); // column 2m + 2
            let sm_e = _mm512_add_epi16(_mm512_add_epi16(op, o), _mm512_add_epi16(e, e));
            let sm_o = _mm512_add_epi16(_mm512_add_epi16(e, en), _mm512_add_epi16(o, o));
            let df_e = _mm512_sub_epi16(o, op);
            let df_o = _mm512_sub_epi16(en, e);
            let x = c + 64 * j;
            // SAFETY: 64 lanes at `c + 64j` ≤ len − 64 (asserted above).
            unsafe {
                _mm512_storeu_si512(sp.add(x).cast(), sm_e);
                _mm512_storeu_si512(sp.add(x + 32).cast(), sm_o);
                _mm512_storeu_si512(dp.add(x).cast(), df_e);
                _mm512_storeu_si512(dp.add(x + 32).cast(), df_o);
            }
            gradients(j, [sm_e, sm_o, df_e, df_o]);
        };

        let (mut ve, mut vo) = vsum(0);
        if n == 1 {
            (ve, vo, _) = replicate_after(ve, vo, tail);
        }
        let first = broadcast(ve, 0);
        let (mut ve_prev, mut vo_prev) = (first, first);
        let mut b_prev = (first, first);
        let mut bo_prev2 = first;
        for k in 0..n {
            let (ve_next, vo_next) = if k + 2 < n {
                vsum(k + 1)
            } else if k + 2 == n {
                let (e, o) = vsum(k + 1);
                let (e, o, _) = replicate_after(e, o, tail);
                (e, o)
            } else {
                let (_, _, last) = replicate_after(ve, vo, tail);
                (last, last)
            };
            let ep = _mm512_permutex2var_epi16(ve_prev, prev, ve); // column 2m − 2
            let en = _mm512_permutex2var_epi16(ve, next, ve_next); // column 2m + 2
            let op = _mm512_permutex2var_epi16(vo_prev, prev, vo); // column 2m − 1
            let on = _mm512_permutex2var_epi16(vo, next, vo_next); // column 2m + 3
            let be = blur(_mm512_add_epi16(ep, en), _mm512_add_epi16(op, vo), ve);
            let bo = blur(_mm512_add_epi16(op, on), _mm512_add_epi16(ve, en), vo);
            if blurred {
                let b8 = _mm512_or_si512(be, _mm512_slli_epi16::<8>(bo));
                let mask = crate::simd::first_lanes(if k + 1 == n { tail } else { 64 });
                // SAFETY: masked to the columns inside the row.
                unsafe { _mm512_mask_storeu_epi8(out8.as_mut_ptr().add(64 * k).cast(), mask, b8) };
            }
            let (be, bo) = if k + 1 == n {
                let (e, o, _) = replicate_after(be, bo, tail);
                (e, o)
            } else {
                (be, bo)
            };
            if k == 0 {
                let first = broadcast(be, 0);
                (bo_prev2, b_prev) = (first, (be, bo));
            } else {
                sobel(k - 1, bo_prev2, b_prev, be);
                (bo_prev2, b_prev) = (b_prev.1, (be, bo));
            }
            (ve_prev, vo_prev, ve, vo) = (ve, vo, ve_next, vo_next);
        }
        let (_, _, last) = replicate_after(b_prev.0, b_prev.1, tail);
        sobel(n - 1, bo_prev2, b_prev, last);
    }
}
