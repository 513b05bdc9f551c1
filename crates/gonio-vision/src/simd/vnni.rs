//! The focus sums' kernels of [`crate::focus`] with AVX-512 VNNI (64 columns a step, the tail by
//! a masked load: zero lanes add nothing to any sum): a row's sums reduced per row
//! ([`row_sums`]), and a frame's rows into lanes kept across rows and reduced once a frame
//! ([`frame_row_sums`], [`frame_end_sums`]).

use crate::simd::Vnni;
use std::arch::x86_64::*;

/// Steps between reductions of the lanes: a step adds less than 2^19 to a lane of each sum
/// [`RowSums`] reduces (a `vpdpbusd` adds at most 4 · 255 · 128 < 2^17, and `now`, the largest
/// combination, less than 4 such terms), so the 16 lanes of 2^7 steps total less than 2^30 and
/// are reduced in 32-bit lanes (a row of 1440 columns is one block of 23 steps).
const FLUSH: usize = 1 << 7;

/// The 64-byte mask of columns i … n − 1 (all 64 when that many remain).
#[inline(always)]
fn mask(i: usize, n: usize) -> __mmask64 {
    crate::simd::first_lanes(n - i)
}

/// Per 128-bit lane: [a0 + a2, b0 + b2, a1 + a3, b1 + b3] of lanes [a0 … a3] and [b0 … b3].
#[inline]
#[target_feature(enable = "avx512f")]
fn pairs(a: __m512i, b: __m512i) -> __m512i {
    _mm512_add_epi32(_mm512_unpacklo_epi32(a, b), _mm512_unpackhi_epi32(a, b))
}

/// Per 128-bit lane: the sums of the four vectors [`pairs`] made `x` (of a and b) and `y` (of
/// c and d), as [a, b, c, d].
#[inline]
#[target_feature(enable = "avx512f")]
fn quads(x: __m512i, y: __m512i) -> __m512i {
    _mm512_add_epi32(_mm512_unpacklo_epi64(x, y), _mm512_unpackhi_epi64(x, y))
}

/// The totals of the sixteen 32-bit lanes of each of `v` (each total and each partial sum of
/// its lanes within `i32`), in one transposing reduction: 21 vector operations for the
/// eight, where one reduction each takes about ten.
#[inline]
#[target_feature(enable = "avx512f")]
fn totals(v: [__m512i; 8]) -> [i32; 8] {
    let abcd = quads(pairs(v[0], v[1]), pairs(v[2], v[3]));
    let efgh = quads(pairs(v[4], v[5]), pairs(v[6], v[7]));
    // [abcd 0 + 1, abcd 2 + 3, efgh 0 + 1, efgh 2 + 3], then each half's total in its lanes.
    let x = _mm512_add_epi32(
        _mm512_shuffle_i32x4::<0b10_00_10_00>(abcd, efgh),
        _mm512_shuffle_i32x4::<0b11_01_11_01>(abcd, efgh),
    );
    let y = _mm512_add_epi32(x, _mm512_shuffle_i32x4::<0b10_11_00_01>(x, x));
    let (lo, hi) = (_mm512_castsi512_si128(y), _mm512_extracti32x4_epi32::<2>(y));
    [
        _mm_cvtsi128_si32(lo),
        _mm_extract_epi32::<1>(lo),
        _mm_extract_epi32::<2>(lo),
        _mm_extract_epi32::<3>(lo),
        _mm_cvtsi128_si32(hi),
        _mm_extract_epi32::<1>(hi),
        _mm_extract_epi32::<2>(hi),
        _mm_extract_epi32::<3>(hi),
    ]
}

/// One step's loads [x, x, x two columns on, a] at column i (the second x is the one the
/// horizontal pair's Σ|x − y| takes, masked at its end in the tail).
///
/// # Safety
/// Columns i … i + 65 of `pr` and i … i + 63 of `pa` must be inside their rows.
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn plain(pr: *const u8, pa: *const u8, i: usize) -> [__m512i; 4] {
    // SAFETY: the caller keeps the columns inside the rows.
    unsafe {
        let x = _mm512_loadu_si512(pr.add(i).cast());
        [
            x,
            x,
            _mm512_loadu_si512(pr.add(i + 2).cast()),
            _mm512_loadu_si512(pa.add(i).cast()),
        ]
    }
}

/// One step's loads at column i of rows `w` wide whose horizontal pairs cover columns
/// c < m (= w − 2): [`plain`] when columns i … i + 65 lie inside the rows, otherwise masked
/// loads covering only columns inside them (x and a: i … w − 1; x[c + 2]: c in i … m − 1;
/// zero lanes add nothing to any sum).
///
/// # Safety
/// i < w, and `pr`, `pa` must point at rows of w bytes.
#[inline]
#[target_feature(enable = "avx512f,avx512bw")]
unsafe fn step_loads(pr: *const u8, pa: *const u8, i: usize, m: usize, w: usize) -> [__m512i; 4] {
    // SAFETY: the caller keeps i inside the rows; each load stays inside them (see above).
    unsafe {
        if i + 64 <= m {
            plain(pr, pa, i)
        } else {
            let (kr, kp) = (mask(i, w), mask(i.min(m), m));
            // (`wrapping_add`: with an empty mask the address may lie past the row; it is
            // never dereferenced.)
            let x = _mm512_maskz_loadu_epi8(kr, pr.wrapping_add(i).cast());
            [
                x,
                _mm512_maskz_mov_epi8(kp, x),
                _mm512_maskz_loadu_epi8(kp, pr.wrapping_add(i + 2).cast()),
                _mm512_maskz_loadu_epi8(kr, pa.wrapping_add(i).cast()),
            ]
        }
    }
}

/// The lanes of one set of sums over a block of steps: S, D, H, V (`vpdpbusd`, 32-bit
/// lanes) and both Σ|x − y| (`vpsadbw`, each lane's total in its low 32 bits).
#[derive(Clone, Copy)]
struct Sums([__m512i; 6]);

impl Sums {
    /// All lanes 0.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn new() -> Sums {
        Sums([_mm512_setzero_si512(); 6])
    }

    /// Adds one step's loads [`plain`] gives (x, x for the horizontal Σ|x − y|, x two
    /// columns on, a), and x to the row's maximum `top`.
    #[inline]
    #[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
    fn step(&mut self, top: &mut __m512i, [x, xh, x2, a]: [__m512i; 4]) {
        let [s, d, h, v, sh, sv] = &mut self.0;
        let xf = _mm512_xor_si512(x, _mm512_set1_epi8(i8::MIN));
        *top = _mm512_max_epu8(*top, x);
        *s = _mm512_dpbusd_epi32(*s, x, _mm512_set1_epi8(1));
        *d = _mm512_dpbusd_epi32(*d, x, xf);
        *h = _mm512_dpbusd_epi32(*h, x2, xf);
        *v = _mm512_dpbusd_epi32(*v, a, xf);
        *sh = _mm512_add_epi32(*sh, _mm512_sad_epu8(xh, x2));
        *sv = _mm512_add_epi32(*sv, _mm512_sad_epu8(x, a));
    }

    /// Both sets' lanes added.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn plus(self, other: Sums) -> Sums {
        Sums(std::array::from_fn(|k| {
            _mm512_add_epi32(self.0[k], other.0[k])
        }))
    }

    /// The block's `now`, `next`, `after` and both Σ|x − y| of [`RowSums`] (then three 0s).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn totals(self) -> [i32; 8] {
        let [s, d, h, v, sh, sv] = self.0;
        let (s7, zero) = (_mm512_slli_epi32::<7>(s), _mm512_setzero_si512());
        totals([
            _mm512_sub_epi32(_mm512_add_epi32(d, s7), _mm512_add_epi32(v, v)),
            _mm512_slli_epi32::<1>(_mm512_sub_epi32(d, h)),
            _mm512_sub_epi32(d, s7),
            sh,
            sv,
            zero,
            zero,
            zero,
        ])
    }
}

/// What one pass over a row x (w columns) with the row a two above it gives [`crate::focus`]
/// (D = Σx(x − 128), H = `Σ_{c < w − 2} x[c + 2](x[c] − 128)`, V = Σ a(x − 128), S = Σx, each
/// over the whole row unless said): the parts of the squared central differences, each
/// combined in the lanes before the one reduction it takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct RowSums {
    /// Pixels at 255.
    pub saturated: u32,
    /// D + 128 S − 2 V = Σx² − 2 Σax + 256 Σa: this row's share of its vertical pair.
    pub now: i64,
    /// 2 D − 2 H: the row's share of its own horizontal pair (`x[c]`, `x[c + 2]`).
    pub next: i64,
    /// D − 128 S = Σx² − 256 S: the row's share of the vertical pair it is the upper row of.
    pub after: i64,
    /// `Σ_{c < w − 2} |x[c] − x[c + 2]|`.
    pub h_abs: u64,
    /// Σ|x − a| over the whole row.
    pub v_abs: u64,
}

/// [`RowSums`] of `row` and the row `above` it (`row` itself without one: the vertical sums
/// are then of no use, and computed anyway, to keep one loop), in one pass over the columns:
/// a step loads x[i …], x[i + 2 …] and a[i …], flips x once into x − 128 and takes the six
/// sums from them (four `vpdpbusd` for S, D, H and V, two `vpsadbw`).
///
/// # Safety
/// The CPU must support AVX-512 F, BW, VNNI and POPCNT.
///
/// # Panics
/// If the rows' lengths differ.
#[target_feature(enable = "avx512f,avx512bw,avx512vnni,popcnt")]
unsafe fn kernel(row: &[u8], above: Option<&[u8]>) -> RowSums {
    let w = row.len();
    let a = above.unwrap_or(row);
    assert_eq!(a.len(), w, "rows of one width");
    // The horizontal pairs (x[c], x[c + 2]) cover c < w − 2.
    let m = w.saturating_sub(2);
    let (pr, pa) = (row.as_ptr(), a.as_ptr());
    let mut top = _mm512_setzero_si512();
    let (mut now, mut next, mut after, mut h_abs, mut v_abs) = (0i64, 0i64, 0i64, 0u64, 0u64);
    let mut i = 0;
    while i < w {
        let end = (i + 64 * FLUSH).min(w);
        // Two sets of sums, for steps two at a time: each `vpdpbusd` accumulator takes
        // every other step, not a chain of one step's latency after the other.
        let (mut p, mut q) = (Sums::new(), Sums::new());
        // SAFETY (both loops): plain loads when columns i … i + 129 are inside the rows,
        // `step_loads` (i < w) otherwise.
        while i + 128 <= end.min(m) {
            let (l0, l1) = unsafe { (plain(pr, pa, i), plain(pr, pa, i + 64)) };
            p.step(&mut top, l0);
            q.step(&mut top, l1);
            i += 128;
        }
        while i < end {
            p.step(&mut top, unsafe { step_loads(pr, pa, i, m, w) });
            i += 64;
        }
        let t = p.plus(q).totals();
        now += i64::from(t[0]);
        next += i64::from(t[1]);
        after += i64::from(t[2]);
        h_abs += t[3] as u64;
        v_abs += t[4] as u64;
    }
    RowSums {
        saturated: if _mm512_cmpeq_epi8_mask(top, _mm512_set1_epi8(-1)) == 0 {
            0
        } else {
            saturated(row)
        },
        now,
        next,
        after,
        h_abs,
        v_abs,
    }
}

/// The pixels of `row` at 255 (the rows that have any: [`kernel`] finds them by the row's
/// maximum, one operation a step, and counts only there).
#[inline]
#[target_feature(enable = "avx512f,avx512bw,popcnt")]
fn saturated(row: &[u8]) -> u32 {
    let full = _mm512_set1_epi8(-1);
    let mut n = 0;
    for i in (0..row.len()).step_by(64) {
        // SAFETY: the mask covers columns i … min(i + 64, w) − 1, inside the row.
        let x = unsafe { _mm512_maskz_loadu_epi8(mask(i, row.len()), row.as_ptr().add(i).cast()) };
        n += _mm512_cmpeq_epi8_mask(x, full).count_ones();
    }
    n
}

/// [`kernel`] on a CPU that has the features (`_cpu` proves it): the [`RowSums`] of `row` and
/// the row two above it.
///
/// # Panics
/// If `above` is given and the rows' lengths differ.
#[inline]
pub(crate) fn row_sums(_cpu: Vnni, row: &[u8], above: Option<&[u8]>) -> RowSums {
    // SAFETY: `vnni` is true only when the CPU has AVX-512 F/BW and VNNI
    // (`is_x86_feature_detected!` in `simd::detected` and `simd::vnni`; `_cpu` proves it);
    // `kernel` checks the lengths.
    unsafe { kernel(row, above) }
}

/// Steps of the frame kernel's 32-bit lanes between their widening to 64 bits: a step adds
/// less than 2^17 to a lane of D, H and V (see [`FLUSH`]), so 2^13 steps keep each lane
/// below 2^30 (a frame of 1440 × 540 takes two blocks).
const FRAME_FLUSH: usize = 1 << 13;

/// The lanes the frame kernel keeps across rows: D, H and V (32-bit lanes) and the sum of
/// both Σ|x − y| (64-bit lanes, `vpsadbw`'s).
#[derive(Clone, Copy)]
struct Lanes([__m512i; 4]);

impl Lanes {
    /// Adds one step's loads [`plain`] gives (as [`Sums::step`], without S).
    #[inline]
    #[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
    fn step(&mut self, top: &mut __m512i, [x, xh, x2, a]: [__m512i; 4]) {
        let [d, h, v, g] = &mut self.0;
        let xf = _mm512_xor_si512(x, _mm512_set1_epi8(i8::MIN));
        *top = _mm512_max_epu8(*top, x);
        *d = _mm512_dpbusd_epi32(*d, x, xf);
        *h = _mm512_dpbusd_epi32(*h, x2, xf);
        *v = _mm512_dpbusd_epi32(*v, a, xf);
        *g = _mm512_add_epi64(*g, _mm512_sad_epu8(xh, x2));
        *g = _mm512_add_epi64(*g, _mm512_sad_epu8(x, a));
    }

    /// 4D − 2H − 2V over all the 32-bit lanes of both sets, in 64 bits; the sets' D, H and
    /// V lanes are then 0 (Σ|x − y| is kept).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn flush(sets: &mut [Lanes; 2]) -> i64 {
        let wide = |x: __m512i| {
            _mm512_add_epi64(
                _mm512_cvtepi32_epi64(_mm512_castsi512_si256(x)),
                _mm512_cvtepi32_epi64(_mm512_extracti64x4_epi64::<1>(x)),
            )
        };
        let mut t = _mm512_setzero_si512();
        for s in sets.iter_mut() {
            let [d, h, v, _] = &mut s.0;
            let hv = _mm512_add_epi64(wide(*h), wide(*v));
            t = _mm512_add_epi64(t, _mm512_slli_epi64::<2>(wide(*d)));
            t = _mm512_sub_epi64(t, _mm512_slli_epi64::<1>(hv));
            (*d, *h, *v) = (
                _mm512_setzero_si512(),
                _mm512_setzero_si512(),
                _mm512_setzero_si512(),
            );
        }
        _mm512_reduce_add_epi64(t)
    }
}

/// A whole frame's focus sums, as the sums of [`crate::focus::RowFocus::push`] over its
/// rows give them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct FrameSums {
    /// Σ|central difference|, horizontal plus vertical, over the interior.
    pub abs_sum: u64,
    /// Σ(central difference)², horizontal plus vertical, over the interior.
    pub sq_sum: u64,
}

/// The state of [`frame_row`] between a frame's rows: the lanes of both sets of [`Lanes`]
/// (as 64-byte blocks), the steps they hold since their last widening, and the scalar sums.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
pub(crate) struct FrameLanes {
    lanes: [[i64; 8]; 8],
    pending: usize,
    sq: i64,
    abs: i64,
}

impl FrameLanes {
    /// Both sets of lanes, loaded (aligned loads of the eight 64-byte blocks).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn sets(&self) -> [Lanes; 2] {
        let p = self.lanes.as_ptr().cast::<__m512i>();
        // SAFETY: `FrameLanes` is 64-byte aligned and holds eight 64-byte blocks.
        let load = |k: usize| unsafe { _mm512_load_si512(p.add(k).cast()) };
        [
            Lanes([load(0), load(1), load(2), load(3)]),
            Lanes([load(4), load(5), load(6), load(7)]),
        ]
    }

    /// Stores both sets of lanes back ([`FrameLanes::sets`]' blocks), eight aligned stores
    /// (an iterator over the sets compiled to unaligned copies through the stack).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn keep(&mut self, [a, b]: [Lanes; 2]) {
        let p = self.lanes.as_mut_ptr().cast::<__m512i>();
        for k in 0..4 {
            // SAFETY: as in `sets`.
            unsafe {
                _mm512_store_si512(p.add(k).cast(), a.0[k]);
                _mm512_store_si512(p.add(4 + k).cast(), b.0[k]);
            }
        }
    }
}

/// Row `y` of a frame `h` rows high into `st` (row 0 starts it afresh), with rows y − 2 and
/// y − 1 as `prev` from y = 2 on; its pixels at 255 returned. A row r in 2 … h − 3 takes all
/// three of its shares (`now` + `next` + `after` of [`RowSums`] is 4D − 2H − 2V: S cancels),
/// so it adds D, H, V and both Σ|x − y| into lanes kept across rows, widened and reduced once
/// a block of [`FRAME_FLUSH`] steps; the first two and last two rows take the shares they have
/// by [`kernel`]; the end columns the pairs leave out are subtracted in scalar code.
///
/// # Safety
/// The CPU must support AVX-512 F, BW, VNNI and POPCNT.
///
/// # Panics
/// If the rows' lengths differ or w < 2 while `prev` is given.
#[target_feature(enable = "avx512f,avx512bw,avx512vnni,popcnt")]
unsafe fn frame_row(
    st: &mut FrameLanes,
    (y, h): (usize, usize),
    x: &[u8],
    prev: Option<(&[u8], &[u8])>,
) -> u32 {
    if y == 0 {
        *st = FrameLanes::default();
    }
    let w = x.len();
    if let Some((a, b)) = prev {
        assert!(
            w >= 2 && a.len() == w && b.len() == w,
            "rows of one width ≥ 2"
        );
        // The end columns: b[0], b[1] of the horizontal x = b[..w − 2] and b[w − 2], b[w − 1]
        // of y = b[2..] (their Σy shifted by 128 in D − H), and columns 0 and w − 1 of the
        // vertical pair.
        let bv = |k: usize| i64::from(b[k]);
        let (d0, d1) = (
            i64::from(x[0]) - i64::from(a[0]),
            i64::from(x[w - 1]) - i64::from(a[w - 1]),
        );
        st.sq -= bv(0) * bv(0) + bv(1) * bv(1) + bv(w - 2) * bv(w - 2) + bv(w - 1) * bv(w - 1)
            - 256 * (bv(0) + bv(1))
            + d0 * d0
            + d1 * d1;
        st.abs -= d0.abs() + d1.abs();
    }
    let m = w.saturating_sub(2);
    let steps = w.div_ceil(64);
    match prev {
        // Rows too wide for a block of lanes go through the row kernel (it blocks its columns).
        Some((a, _)) if y + 3 <= h && steps <= FRAME_FLUSH => {
            let mut sets = st.sets();
            if st.pending + steps > FRAME_FLUSH {
                st.sq += Lanes::flush(&mut sets);
                st.pending = 0;
            }
            st.pending += steps;
            let (pr, pa) = (x.as_ptr(), a.as_ptr());
            let mut top = _mm512_setzero_si512();
            let mut i = 0;
            // SAFETY (both loops): as in `kernel`.
            while i + 128 <= m {
                let (l0, l1) = unsafe { (plain(pr, pa, i), plain(pr, pa, i + 64)) };
                sets[0].step(&mut top, l0);
                sets[1].step(&mut top, l1);
                i += 128;
            }
            while i < w {
                sets[0].step(&mut top, unsafe { step_loads(pr, pa, i, m, w) });
                i += 64;
            }
            st.keep(sets);
            if _mm512_cmpeq_epi8_mask(top, _mm512_set1_epi8(-1)) == 0 {
                0
            } else {
                saturated(x)
            }
        }
        _ => {
            // SAFETY: the caller has the CPU's features; `kernel` checks the lengths.
            let r = unsafe { kernel(x, prev.map(|(a, _)| a)) };
            if y >= 2 {
                st.sq += r.now;
                st.abs += r.v_abs as i64;
            }
            if y >= 1 && y + 2 <= h {
                st.sq += r.next;
                st.abs += r.h_abs as i64;
            }
            if y + 3 <= h {
                st.sq += r.after;
            }
            r.saturated
        }
    }
}

/// The frame's sums once its last row is in `st` (which then holds no lanes).
///
/// # Safety
/// The CPU must support AVX-512 F.
#[target_feature(enable = "avx512f")]
unsafe fn frame_end(st: &mut FrameLanes) -> FrameSums {
    let mut sets = st.sets();
    let sq = st.sq + Lanes::flush(&mut sets);
    let g = _mm512_add_epi64(sets[0].0[3], sets[1].0[3]);
    let abs = st.abs + _mm512_reduce_add_epi64(g);
    *st = FrameLanes::default();
    FrameSums {
        abs_sum: abs as u64,
        sq_sum: sq as u64,
    }
}

/// [`frame_row`] on a CPU that has the features (`_cpu` proves it): row `y` of a frame `h`
/// rows high into `st`, its pixels at 255 returned.
///
/// # Panics
/// If the rows' lengths differ or w < 2 while `prev` is given.
#[inline]
pub(crate) fn frame_row_sums(
    _cpu: Vnni,
    st: &mut FrameLanes,
    yh: (usize, usize),
    row: &[u8],
    prev: Option<(&[u8], &[u8])>,
) -> u32 {
    // SAFETY: `_cpu` proves the CPU's features (as in `row_sums`).
    unsafe { frame_row(st, yh, row, prev) }
}

/// The sums of the frame whose rows went into `st` by [`frame_row_sums`] (`_cpu` proves the
/// CPU's features).
#[inline]
pub(crate) fn frame_end_sums(_cpu: Vnni, st: &mut FrameLanes) -> FrameSums {
    // SAFETY: `_cpu` proves the CPU's features (as in `row_sums`).
    unsafe { frame_end(st) }
}
