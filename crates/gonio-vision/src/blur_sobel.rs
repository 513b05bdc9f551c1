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
//! does it all, 32 columns at a time in 16-bit lanes: the blur's vertical 1-4-6-4-1 sum of
//! the five rows, its horizontal sum from lane shifts of the neighbouring vectors (`vpermt2w`,
//! no reloads), the rounding, then the Sobel's horizontal smooth and difference of the blurred
//! row while it is still in registers, and the Sobel's vertical pass over the ring with the
//! gradient row written out. Written by hand because the compiler vectorises the two stages'
//! four row loops one by one (well: 512-bit lanes, the taps as unaligned loads), but with the
//! blur's vertical sums, the blurred row and the Sobel's smooth and difference rows each stored
//! and read back, and the blurred row packed by a masked `vpmovwb` into memory, which Zen 4
//! runs slowly (≈ 20 % of the blur in `perf annotate`). Here the blurred `u8` row is written
//! only for an observer that looks at it ([`StageObserver::observes`]). The scalar and AVX2
//! levels run the two stages' loops ([`Gaussian5`], [`Sobel`]), the reference the kernel
//! equals bit for bit (`tests/simd.rs`).
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
use crate::rows::{RowLag, RowStage, StageObserver};

/// The blur and the Sobel in one stage: `u8` rows in, [`GradRow`]s out 3 rows later.
#[derive(Debug, Clone)]
pub struct BlurSobel {
    /// The blur: its ring holds the input rows; its counters, the blurred rows made.
    blur: Gaussian5,
    /// The Sobel: its ring holds the blurred rows' smooths and differences, its input buffer
    /// the last blurred row (for the observer); its counters, the gradient rows emitted.
    sobel: Sobel,
    rows: RowLag,
}

impl BlurSobel {
    /// The stage for rows of `width` pixels (≥ 2).
    pub fn new(width: usize) -> Self {
        BlurSobel {
            blur: Gaussian5::new(width),
            sobel: Sobel::new(width),
            rows: RowLag::new(3),
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
        let emitted = self.make_row_avx512(out, obs.observes());
        if emitted.is_none() {
            crate::simd::dispatch(
                #[inline(always)]
                || {
                    self.blur.emit_impl(&mut self.sobel.input);
                    self.sobel.accept_impl();
                },
            );
            self.sobel.rows.pushed();
        }
        obs.blurred(&self.sobel.input);
        self.blur.rows.advance();
        emitted == Some(true)
    }

    /// [`BlurSobel::make_row`] by the AVX-512 kernel (the blurred `u8` row written only if
    /// `blurred`: for an observer); `None` below the AVX-512 level.
    #[allow(unsafe_code)]
    fn make_row_avx512(&mut self, out: Option<&mut GradRow>, blurred: bool) -> Option<bool> {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::level() == crate::simd::Level::Avx512 {
            let window = self.blur.window();
            let sb = &mut self.sobel;
            let c = sb.rows.input_slot() * sb.stride;
            sb.rows.pushed();
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
                    &self.blur.ring,
                    window,
                    (&mut sb.smooth, &mut sb.diff),
                    c,
                    &mut sb.input,
                    blurred,
                    emit,
                )
            };
            return Some(emitted);
        }
        let _ = (out, blurred);
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
    }
    fn input(&mut self) -> &mut [u8] {
        self.blur.input()
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
            crate::simd::dispatch(
                #[inline(always)]
                || self.sobel.emit_impl(out),
            );
        }
        self.sobel.rows.advance();
        obs.gradient(out);
    }
}

/// The fused row kernel with AVX-512 intrinsics (see the module docs).
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod avx512 {
    use crate::gradient::GradRow;
    use std::arch::x86_64::*;

    /// Lane indices for `vpermt2w`: lane i of `(a, b)` shifted by one or two lanes, the lanes
    /// shifted in coming from the neighbouring vector.
    const fn shift_index(by: i16) -> [i16; 32] {
        let mut t = [0i16; 32];
        let mut i = 0;
        while i < 32 {
            t[i] = i as i16 + by;
            i += 1;
        }
        t
    }
    /// Column x + 1, x + 2 of (this vector, the next one).
    const NEXT1: [i16; 32] = shift_index(1);
    const NEXT2: [i16; 32] = shift_index(2);
    /// Column x − 1, x − 2 of (the previous vector, this one).
    const PREV1: [i16; 32] = shift_index(31);
    const PREV2: [i16; 32] = shift_index(30);

    /// The gradient row the kernel also writes: `out`, with the Sobel ring's rows above it
    /// (`a`) and of it (`b`) as offsets.
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

    /// Lanes `len …` replaced by lane `len − 1` (replicated border).
    #[inline]
    #[target_feature(enable = "avx512f,avx512bw")]
    fn replicate_after(v: __m512i, len: usize) -> __m512i {
        if len >= 32 {
            return v;
        }
        _mm512_mask_blend_epi16((1u32 << len) - 1, broadcast(v, len - 1), v)
    }

    /// Blurs the rows at `window` (offsets into `ring`: rows y − 2 … y + 2) into row y: its
    /// `u8` values into `out8` (if `blurred`), its Sobel smooth (1 2 1) and difference (−1 0 1)
    /// into the Sobel's rings `smooth` and `diff` at offset `c`. With `emit`, row y is the one
    /// below `emit.out`'s row: its gradients are computed from the rings' rows `a`, `b` and row
    /// y's smooth and difference in registers.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F/BW/VL/DQ. The lengths are asserted.
    #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq,avx2")]
    pub(super) unsafe fn blur_sobel(
        ring: &[u8],
        window: [usize; 5],
        (smooth, diff): (&mut [i16], &mut [i16]),
        c: usize,
        out8: &mut [u8],
        blurred: bool,
        emit: Option<Emit<'_>>,
    ) {
        let w = out8.len();
        assert!(w > 0);
        let n = w.div_ceil(32);
        // Whole vectors are read and written in the rings (their rows are padded to 64
        // bytes), masked ones in the output rows.
        assert!(window.iter().all(|&o| o + n * 32 <= ring.len()));
        assert!(c + n * 32 <= smooth.len() && c + n * 32 <= diff.len());
        if let Some(e) = &emit {
            assert!(e.a + n * 32 <= smooth.len() && e.b + n * 32 <= diff.len());
            assert!(e.out.gx.len() == w && e.out.gy.len() == w && e.out.mag.len() == w);
        }
        let tail = w - (n - 1) * 32;
        let tail_mask: __mmask32 = if tail == 32 { !0 } else { (1 << tail) - 1 };
        let (next1, next2, prev1, prev2) =
            (index(&NEXT1), index(&NEXT2), index(&PREV1), index(&PREV2));
        let six = _mm512_set1_epi16(6);
        let half = _mm512_set1_epi16(128);
        let rp = ring.as_ptr();

        // The vertical sums of chunk k, the lanes beyond the row replicated.
        let vsum = |k: usize| {
            // SAFETY: 32 bytes at `o + 32k` ≤ ring.len() − 32 (asserted above).
            let ld = |o: usize| unsafe {
                _mm512_cvtepu8_epi16(_mm256_loadu_si256(rp.add(o + 32 * k).cast()))
            };
            let [r0, r1, r2, r3, r4] = window.map(ld);
            let v = _mm512_add_epi16(
                _mm512_add_epi16(r0, r4),
                _mm512_add_epi16(
                    _mm512_slli_epi16::<2>(_mm512_add_epi16(r1, r3)),
                    _mm512_mullo_epi16(r2, six),
                ),
            );
            if k + 1 == n {
                replicate_after(v, tail)
            } else {
                v
            }
        };
        let sp = smooth.as_mut_ptr();
        let dp = diff.as_mut_ptr();
        let bp = out8.as_mut_ptr();
        let emit = emit.map(|e| {
            let o = e.out;
            let p = (o.gx.as_mut_ptr(), o.gy.as_mut_ptr(), o.mag.as_mut_ptr());
            (p, e.a, e.b)
        });
        // The Sobel of chunk j from the blurred chunks j − 1, j, j + 1.
        let sobel = |j: usize, prev: __m512i, cur: __m512i, next: __m512i| {
            let l = _mm512_permutex2var_epi16(prev, prev1, cur);
            let r = _mm512_permutex2var_epi16(cur, next1, next);
            let sm = _mm512_add_epi16(_mm512_add_epi16(l, r), _mm512_slli_epi16::<1>(cur));
            let df = _mm512_sub_epi16(r, l);
            let x = 32 * j;
            // SAFETY: 32 lanes at `c + x` ≤ len − 32 (asserted above).
            unsafe {
                _mm512_storeu_si512(sp.add(c + x).cast(), sm);
                _mm512_storeu_si512(dp.add(c + x).cast(), df);
            }
            if let Some(((gxp, gyp, magp), a, b)) = emit {
                // SAFETY: 32 lanes at `a + x`, `b + x` ≤ len − 32 (asserted above); the
                // gradient row's stores are masked to its `w` lanes.
                unsafe {
                    let da = _mm512_loadu_si512(dp.add(a + x).cast());
                    let db = _mm512_loadu_si512(dp.add(b + x).cast());
                    let sa = _mm512_loadu_si512(sp.add(a + x).cast());
                    let gx = _mm512_add_epi16(_mm512_add_epi16(da, df), _mm512_slli_epi16::<1>(db));
                    let gy = _mm512_sub_epi16(sm, sa);
                    let mag = _mm512_add_epi16(_mm512_abs_epi16(gx), _mm512_abs_epi16(gy));
                    let m = if j + 1 == n { tail_mask } else { !0 };
                    _mm512_mask_storeu_epi16(gxp.add(x).cast(), m, gx);
                    _mm512_mask_storeu_epi16(gyp.add(x).cast(), m, gy);
                    _mm512_mask_storeu_epi16(magp.add(x).cast(), m, mag);
                }
            }
        };

        let v0 = vsum(0);
        let (mut vp, mut vc) = (broadcast(v0, 0), v0);
        let (mut bp2, mut bp1) = (_mm512_setzero_si512(), _mm512_setzero_si512());
        for k in 0..n {
            let vn = if k + 1 < n {
                vsum(k + 1)
            } else {
                broadcast(vc, tail - 1)
            };
            // (v[x−2] + v[x+2]) + 4 (v[x−1] + v[x+1]) + 6 v[x], rounded: ≤ 256·255 + 128.
            let s = _mm512_add_epi16(
                _mm512_add_epi16(
                    _mm512_permutex2var_epi16(vp, prev2, vc),
                    _mm512_permutex2var_epi16(vc, next2, vn),
                ),
                _mm512_slli_epi16::<2>(_mm512_add_epi16(
                    _mm512_permutex2var_epi16(vp, prev1, vc),
                    _mm512_permutex2var_epi16(vc, next1, vn),
                )),
            );
            let s = _mm512_add_epi16(s, _mm512_add_epi16(_mm512_mullo_epi16(vc, six), half));
            let b = _mm512_srli_epi16::<8>(s);
            if blurred {
                let b8 = _mm512_cvtepi16_epi8(b);
                let m = if k + 1 == n { tail_mask } else { !0 };
                // SAFETY: masked to the lanes inside the row.
                unsafe { _mm256_mask_storeu_epi8(bp.add(32 * k).cast(), m, b8) };
            }
            let b = if k + 1 == n {
                replicate_after(b, tail)
            } else {
                b
            };
            if k == 0 {
                bp1 = broadcast(b, 0);
            } else {
                sobel(k - 1, bp2, bp1, b);
            }
            (bp2, bp1) = (bp1, b);
            (vp, vc) = (vc, vn);
        }
        sobel(n - 1, bp2, bp1, broadcast(bp1, tail - 1));
    }
}
