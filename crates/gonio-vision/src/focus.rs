//! The focus and mean-gradient sums of the raw rows: Σ|a − b| and Σ(a − b)² over two rows of
//! bytes, in exact integer arithmetic.
//!
//! The detector takes them for every row (central differences of the raw image), so the pair of
//! sums runs once per row over twice the width. The portable path sums the differences in 32-bit
//! lanes, 64 columns at a time; with AVX2 (runtime-detected, also used on AVX-512 machines) the
//! absolute differences are summed by `vpsadbw` and the squares by `vpmaddwd`, 32 columns a step.
//! Both are exact integer sums, so they give the same bits (tested over random rows of every
//! length up to a few vectors, and the detector's level test).
//!
//! The detector itself goes through [`RowFocus`], which also counts a row's saturated pixels.
//! With AVX-512 VNNI (runtime-detected, [`crate::simd::vnni`]) it uses the identity
//!
//! $$\sum (x - y)^2 = \sum x^2 + \sum y^2 - 2 \sum x y,$$
//!
//! exact in integers: each row's Σx and Σx² are taken once when it arrives (`vpsadbw` against
//! zero and `vpdpbusd` of x with x − 128, together with the `vpcmpeqb` count of 255s) and kept for
//! the two rows that pair with it; a pair then costs `vpsadbw` for Σ|x − y| and one `vpdpbusd`
//! for Σx(y − 128) = Σxy − 128 Σx, four vector operations per 64 columns instead of ten per 32.
//! One pass over the rows takes each row's totals and, from row 2 on, both pairs' cross
//! terms, each pair's sums added together (only their total is used): one loop and one set of
//! reductions a row instead of three, and three independent `vpdpbusd` accumulators (the
//! instruction adds into its destination; one accumulator a loop made it a chain of its latency).
//! The end columns a pair leaves out are subtracted from the row totals in scalar code. This is
//! written by hand (no crate computes these sums); the plain definition is the reference the
//! tests hold it to.
//!
//! ```
//! use gonio_vision::focus::abs_diff_sums;
//! assert_eq!(abs_diff_sums(&[10, 0, 255], &[7, 5, 0]), (3 + 5 + 255, 9 + 25 + 255 * 255));
//! ```

#![allow(unsafe_code)]

use crate::simd::{Level, level};

/// Σ|a − b| and Σ(a − b)² over the common length of two rows, with the fastest path the CPU
/// has (the level [`crate::simd::level`] chooses).
#[inline]
pub fn abs_diff_sums(a: &[u8], b: &[u8]) -> (u64, u64) {
    #[cfg(target_arch = "x86_64")]
    if level() >= Level::Avx2 {
        // SAFETY: `level` returns AVX2 or above only when the CPU has AVX2
        // (`is_x86_feature_detected!` in `simd::detected`).
        return unsafe { abs_diff_sums_avx2(a, b) };
    }
    abs_diff_sums_scalar(a, b)
}

/// What one row adds to a frame's raw statistics ([`RowFocus::push`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RowStats {
    /// Pixels of the row at 255.
    pub saturated: u32,
    /// Σ|central difference| at row y − 1's interior, horizontal plus vertical (0 for the first
    /// two rows of a frame).
    pub abs_sum: u64,
    /// Σ(central difference)², horizontal plus vertical (0 for the first two rows).
    pub sq_sum: u64,
}

/// A row's Σx and Σx² (the VNNI path's per-row totals).
#[derive(Debug, Clone, Copy, Default)]
struct Totals {
    sum: i64,
    sq: i64,
}

/// The streaming raw-row statistics of a frame: the saturated pixels of each row and the central
/// differences at the row before it, as [`abs_diff_sums`] gives them.
///
/// Rows are pushed in order from y = 0; `prev` holds rows y − 2 and y − 1 (absent for the
/// first two rows). For row y ≥ 2 the sums cover row y − 1's interior columns 1 … w − 2: the
/// horizontal differences `b[x + 1] − b[x − 1]` and the vertical ones `row[x] − a[x]`.
///
/// ```
/// use gonio_vision::focus::{RowFocus, abs_diff_sums};
/// let rows = [[0u8, 9, 255, 4], [7, 7, 1, 200], [3, 255, 0, 6]];
/// let mut f = RowFocus::default();
/// f.push(0, &rows[0], None);
/// f.push(1, &rows[1], None);
/// let s = f.push(2, &rows[2], Some((&rows[0], &rows[1])));
/// let (hx, hq) = abs_diff_sums(&rows[1][..2], &rows[1][2..]);
/// let (vx, vq) = abs_diff_sums(&rows[2][1..3], &rows[0][1..3]);
/// assert_eq!((s.saturated, s.abs_sum, s.sq_sum), (1, hx + vx, hq + vq));
/// ```
#[derive(Debug, Clone, Default)]
pub struct RowFocus {
    /// Totals of the last two rows, at index y % 2 (VNNI path only).
    totals: [Totals; 2],
    /// Whether this frame takes the VNNI path: latched at row 0, since the ring
    /// above holds the VNNI path's state only (the SIMD level may change between
    /// frames, never within one).
    use_vnni: bool,
}

impl RowFocus {
    /// Row `y` (of width w ≥ 2) and, from y = 2 on, rows y − 2 and y − 1 as `prev`;
    /// every frame starts at y = 0 and goes on one row at a time.
    ///
    /// # Panics
    /// If the rows' lengths differ or w < 2 while `prev` is given.
    #[inline]
    pub fn push(&mut self, y: usize, row: &[u8], prev: Option<(&[u8], &[u8])>) -> RowStats {
        if y == 0 {
            self.use_vnni = crate::simd::vnni();
        }
        #[cfg(target_arch = "x86_64")]
        if self.use_vnni {
            // SAFETY: `vnni` is true only when the CPU has AVX-512 F/BW and VNNI
            // (`is_x86_feature_detected!` in `simd::detected` and `simd::vnni`).
            return unsafe { self.push_vnni(y, row, prev) };
        }
        Self::push_direct(row, prev)
    }

    /// [`RowFocus::push`] by [`abs_diff_sums`] over each pair of rows.
    #[inline(always)]
    fn push_direct(row: &[u8], prev: Option<(&[u8], &[u8])>) -> RowStats {
        let mut s = RowStats {
            saturated: row.iter().map(|&v| (v == 255) as u32).sum(),
            ..RowStats::default()
        };
        if let Some((a, b)) = prev {
            let w = row.len();
            let (s1x, s2x) = abs_diff_sums(&b[..w - 2], &b[2..w]);
            let (s1y, s2y) = abs_diff_sums(&row[1..w - 1], &a[1..w - 1]);
            s.abs_sum = s1x + s1y;
            s.sq_sum = s2x + s2y;
        }
        s
    }

    /// [`RowFocus::push`] by the sum-of-squares identity (see the module docs).
    ///
    /// # Safety
    /// The CPU must support AVX-512 F, BW, VNNI and POPCNT.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512bw,avx512vnni,popcnt")]
    unsafe fn push_vnni(&mut self, y: usize, row: &[u8], prev: Option<(&[u8], &[u8])>) -> RowStats {
        // One pass over the rows: row y's totals and, from row 2 on, both pairs' cross sums,
        // the two pairs' Σ|x − y| and Σx(y − 128) added together (only their sums are used).
        // SAFETY: the caller guarantees the features; `row_sums` checks the lengths.
        let (t, saturated, sad, dot) = unsafe { avx512::row_sums(row, prev) };
        // Row y − 2's totals sit where row y's go.
        let (ta, tb) = (self.totals[y % 2], self.totals[(y + 1) % 2]);
        self.totals[y % 2] = t;
        let Some((a, b)) = prev else {
            return RowStats {
                saturated,
                ..RowStats::default()
            };
        };
        let w = row.len();
        let sq = |v: u8| i64::from(v) * i64::from(v);
        let one = |v: u8| i64::from(v);
        // Horizontal: x = b[0 .. w − 2], y = b[2 .. w].
        let sum_xh = tb.sum - one(b[w - 2]) - one(b[w - 1]);
        let sq_xh = tb.sq - sq(b[w - 2]) - sq(b[w - 1]);
        let sq_yh = tb.sq - sq(b[0]) - sq(b[1]);
        // Vertical: x = row[1 .. w − 1], y = a[1 .. w − 1].
        let sum_xv = t.sum - one(row[0]) - one(row[w - 1]);
        let sq_xv = t.sq - sq(row[0]) - sq(row[w - 1]);
        let sq_yv = ta.sq - sq(a[0]) - sq(a[w - 1]);
        let sq_sum = sq_xh + sq_yh + sq_xv + sq_yv - 2 * (dot + 128 * (sum_xh + sum_xv));
        RowStats {
            saturated,
            abs_sum: sad,
            sq_sum: sq_sum as u64,
        }
    }
}

/// The VNNI path's kernel (64 columns a step, the tail by a masked load: zero lanes add
/// nothing to any sum).
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::Totals;
    use std::arch::x86_64::*;

    /// Steps between flushes of the 32-bit dot-product lanes: a step adds at most
    /// 4 · 255 · 128 < 2^17 to a lane, so 2^13 steps stay below 2^30.
    const FLUSH: usize = 1 << 13;

    /// The 64-byte mask of columns i … n − 1 (all 64 when that many remain).
    #[inline(always)]
    fn mask(i: usize, n: usize) -> __mmask64 {
        crate::simd::first_lanes(n - i)
    }

    /// The sixteen signed 32-bit lanes of `v`, summed as 64-bit.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn lanes_i64(v: __m512i) -> i64 {
        let lo = _mm512_cvtepi32_epi64(_mm512_castsi512_si256(v));
        let hi = _mm512_cvtepi32_epi64(_mm512_extracti64x4_epi64::<1>(v));
        _mm512_reduce_add_epi64(_mm512_add_epi64(lo, hi))
    }

    /// The row's Σx, Σx² and count of 255s and, with `prev` = (a, b), added together,
    /// Σ|x − y| and Σx(y − 128) of the two pairs (b[0 .. w − 2], b[2 .. w]) and
    /// (row[1 .. w − 1], a[1 .. w − 1]) (0 and 0 without `prev`), in one pass over the rows:
    /// one loop and one set of reductions a row instead of one per sum.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F, BW, VNNI and POPCNT.
    ///
    /// # Panics
    /// If `prev` is given and the rows' lengths differ or are below 2.
    #[target_feature(enable = "avx512f,avx512bw,avx512vnni,popcnt")]
    pub(super) unsafe fn row_sums(
        row: &[u8],
        prev: Option<(&[u8], &[u8])>,
    ) -> (Totals, u32, u64, i64) {
        let w = row.len();
        // The pairs cover w − 2 columns (b from 0 and 2, row and a from 1), none without
        // `prev` (their loads then read no byte).
        let (a, b, m) = match prev {
            Some((a, b)) => {
                assert!(
                    w >= 2 && a.len() == w && b.len() == w,
                    "rows of one width ≥ 2"
                );
                (a, b, w - 2)
            }
            None => (row, row, 0),
        };
        let (pr, pa, pb) = (row.as_ptr(), a.as_ptr(), b.as_ptr());
        let (zero, flip, full) = (
            _mm512_setzero_si512(),
            _mm512_set1_epi8(i8::MIN),
            _mm512_set1_epi8(-1),
        );
        let (mut sum, mut sad, mut sat) = (zero, zero, 0u32);
        let (mut sq, mut dot) = (0i64, 0i64);
        let mut i = 0;
        while i < w {
            let end = (i + 64 * FLUSH).min(w);
            let (mut acc, mut dh, mut dv) = (zero, zero, zero);
            while i < end {
                // SAFETY: plain loads when columns i … i + 63 of the row and i … i + 65 of
                // the pairs' reads are inside the rows; masked loads otherwise, each covering
                // only its own slice's columns (the row's i … w − 1; the pairs' i … m − 1).
                let (x, hx, hy, vx, vy) = unsafe {
                    if i + 64 <= m {
                        (
                            _mm512_loadu_si512(pr.add(i).cast()),
                            _mm512_loadu_si512(pb.add(i).cast()),
                            _mm512_loadu_si512(pb.add(i + 2).cast()),
                            _mm512_loadu_si512(pr.add(i + 1).cast()),
                            _mm512_loadu_si512(pa.add(i + 1).cast()),
                        )
                    } else {
                        let (kr, kp) = (mask(i, w), mask(i.min(m), m));
                        // (`wrapping_add`: with an empty mask the address may lie past
                        // the row; it is never dereferenced.)
                        (
                            _mm512_maskz_loadu_epi8(kr, pr.wrapping_add(i).cast()),
                            _mm512_maskz_loadu_epi8(kp, pb.wrapping_add(i).cast()),
                            _mm512_maskz_loadu_epi8(kp, pb.wrapping_add(i + 2).cast()),
                            _mm512_maskz_loadu_epi8(kp, pr.wrapping_add(i + 1).cast()),
                            _mm512_maskz_loadu_epi8(kp, pa.wrapping_add(i + 1).cast()),
                        )
                    }
                };
                sat += _mm512_cmpeq_epi8_mask(x, full).count_ones();
                sum = _mm512_add_epi64(sum, _mm512_sad_epu8(x, zero));
                acc = _mm512_dpbusd_epi32(acc, x, _mm512_xor_si512(x, flip));
                sad = _mm512_add_epi64(
                    sad,
                    _mm512_add_epi64(_mm512_sad_epu8(hx, hy), _mm512_sad_epu8(vx, vy)),
                );
                dh = _mm512_dpbusd_epi32(dh, hx, _mm512_xor_si512(hy, flip));
                dv = _mm512_dpbusd_epi32(dv, vx, _mm512_xor_si512(vy, flip));
                i += 64;
            }
            sq += lanes_i64(acc);
            dot += lanes_i64(dh) + lanes_i64(dv);
        }
        let sum = _mm512_reduce_add_epi64(sum);
        (
            Totals {
                sum,
                sq: sq + 128 * sum,
            },
            sat,
            _mm512_reduce_add_epi64(sad) as u64,
            dot,
        )
    }
}

/// The portable path: 64 columns at a time, the differences as bytes, their sums and squares in
/// sixteen 32-bit lanes (no overflow: a lane takes at most 4·255² per 64 columns, 512 steps for
/// the widest window of 32768 px).
pub fn abs_diff_sums_scalar(a: &[u8], b: &[u8]) -> (u64, u64) {
    const C: usize = 64;
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let (mut s1, mut s2) = (0u64, 0u64);
    let (ac, bc) = (a.chunks_exact(C), b.chunks_exact(C));
    let (ar, br) = (ac.remainder(), bc.remainder());
    let mut it = ac.zip(bc);
    loop {
        // Blocks of at most 1024 chunks: a 32-bit lane takes ≤ 4·255² < 2^18 a chunk.
        let (mut acc1, mut acc2) = ([0u32; 16], [0u32; 16]);
        let mut steps = 0;
        for (x, y) in it.by_ref().take(1024) {
            steps += 1;
            let mut d = [0u8; C];
            for k in 0..C {
                d[k] = x[k].abs_diff(y[k]);
            }
            for k in 0..16 {
                let q = [d[4 * k], d[4 * k + 1], d[4 * k + 2], d[4 * k + 3]].map(u32::from);
                acc1[k] += q[0] + q[1] + q[2] + q[3];
                acc2[k] += q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
            }
        }
        for k in 0..16 {
            s1 += acc1[k] as u64;
            s2 += acc2[k] as u64;
        }
        if steps < 1024 {
            break;
        }
    }
    for (&x, &y) in ar.iter().zip(br) {
        let d = x.abs_diff(y) as u64;
        s1 += d;
        s2 += d * d;
    }
    (s1, s2)
}

/// The AVX2 path: `vpsadbw` sums eight absolute differences into a 64-bit lane; the differences
/// widened to 16 bits and `vpmaddwd` with themselves give sums of two squares in 32-bit lanes
/// (each lane takes ≤ 4·255² a step: blocks of 4096 steps stay below 2^32).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn abs_diff_sums_avx2(a: &[u8], b: &[u8]) -> (u64, u64) {
    use std::arch::x86_64::*;
    const V: usize = 32;
    const BLOCK: usize = 4096 * V;
    let n = a.len().min(b.len());
    let (mut s1, mut s2) = (0u64, 0u64);
    let mut i = 0;
    let zero = _mm256_setzero_si256();
    let mut acc1 = zero;
    while i + V <= n {
        let end = (i + BLOCK).min(n);
        let mut acc2 = zero;
        while i + V <= end {
            // SAFETY: i + 32 ≤ n ≤ both lengths: the 32-byte unaligned loads are in bounds.
            let (x, y) = unsafe {
                (
                    _mm256_loadu_si256(a.as_ptr().add(i).cast()),
                    _mm256_loadu_si256(b.as_ptr().add(i).cast()),
                )
            };
            acc1 = _mm256_add_epi64(acc1, _mm256_sad_epu8(x, y));
            let d = _mm256_or_si256(_mm256_subs_epu8(x, y), _mm256_subs_epu8(y, x));
            let (lo, hi) = (_mm256_unpacklo_epi8(d, zero), _mm256_unpackhi_epi8(d, zero));
            let sq = _mm256_add_epi32(_mm256_madd_epi16(lo, lo), _mm256_madd_epi16(hi, hi));
            acc2 = _mm256_add_epi32(acc2, sq);
            i += V;
        }
        let mut t = [0u32; 8];
        // SAFETY: `t` holds 32 bytes.
        unsafe { _mm256_storeu_si256(t.as_mut_ptr().cast(), acc2) };
        s2 += t.iter().map(|&v| v as u64).sum::<u64>();
    }
    let mut t = [0u64; 4];
    // SAFETY: `t` holds 32 bytes.
    unsafe { _mm256_storeu_si256(t.as_mut_ptr().cast(), acc1) };
    s1 += t.iter().sum::<u64>();
    for k in i..n {
        let d = a[k].abs_diff(b[k]) as u64;
        s1 += d;
        s2 += d * d;
    }
    (s1, s2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every path against the plain definition, on random rows of every length from 0 to 300
    /// (tails of every size after the vectors), and on rows of extreme differences.
    #[test]
    fn every_path_gives_the_exact_sums() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut byte = || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 56) as u8
        };
        for n in 0..300 {
            let a: Vec<u8> = (0..n).map(|_| byte()).collect();
            let b: Vec<u8> = (0..n).map(|_| byte()).collect();
            let want = a.iter().zip(&b).fold((0u64, 0u64), |(s1, s2), (&x, &y)| {
                let d = x.abs_diff(y) as u64;
                (s1 + d, s2 + d * d)
            });
            assert_eq!(abs_diff_sums_scalar(&a, &b), want, "scalar, n = {n}");
            assert_eq!(abs_diff_sums(&a, &b), want, "dispatched, n = {n}");
        }
        // The widest window, every difference 255: the largest sums the lanes must hold.
        let (a, b) = (vec![0u8; 32768], vec![255u8; 32768]);
        let want = (32768 * 255, 32768 * 255 * 255);
        assert_eq!(abs_diff_sums_scalar(&a, &b), want);
        assert_eq!(abs_diff_sums(&b, &a), want);
    }

    /// The plain definition of what [`RowFocus::push`] returns for row y of `rows`.
    fn row_stats_by_definition(rows: &[Vec<u8>], y: usize) -> RowStats {
        let row = &rows[y];
        let mut s = RowStats {
            saturated: row.iter().filter(|&&v| v == 255).count() as u32,
            ..RowStats::default()
        };
        if y >= 2 {
            let (a, b, w) = (&rows[y - 2], &rows[y - 1], row.len());
            for x in 1..w - 1 {
                for d in [b[x + 1].abs_diff(b[x - 1]), row[x].abs_diff(a[x])] {
                    s.abs_sum += u64::from(d);
                    s.sq_sum += u64::from(d) * u64::from(d);
                }
            }
        }
        s
    }

    /// Both ways through [`RowFocus`] (the direct sums at the level in use, and the VNNI
    /// identity where the CPU has it) against the definition: frames of random, all-0,
    /// all-255 and 0/255 striped rows, widths 2 … 200 and wider ones that cross the 64-column
    /// steps every way.
    #[test]
    fn row_focus_gives_the_defined_sums() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut byte = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 24) as u8
        };
        let widths = (2..200).chain([255, 256, 257, 1439, 1440, 1441, 4097]);
        for w in widths {
            let mut rows: Vec<Vec<u8>> = (0..5).map(|_| (0..w).map(|_| byte()).collect()).collect();
            rows.push(vec![0; w]);
            rows.push(vec![255; w]);
            rows.push((0..w).map(|x| if x % 2 == 0 { 255 } else { 0 }).collect());
            rows.push(vec![255; w]);
            rows.push(vec![0; w]);
            #[cfg(target_arch = "x86_64")]
            let vnni = crate::simd::vnni_detected();
            let mut by_identity = RowFocus::default();
            for y in 0..rows.len() {
                let prev = (y >= 2).then(|| (&rows[y - 2][..], &rows[y - 1][..]));
                let want = row_stats_by_definition(&rows, y);
                let got = RowFocus::push_direct(&rows[y], prev);
                assert_eq!(got, want, "direct, width {w}, row {y}");
                #[cfg(target_arch = "x86_64")]
                if vnni {
                    // SAFETY: `vnni_detected` checked the features (AVX-512 F/BW and VNNI).
                    let got = unsafe { by_identity.push_vnni(y, &rows[y], prev) };
                    assert_eq!(got, want, "VNNI identity, width {w}, row {y}");
                }
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_path_matches_the_scalar_one() {
        if !std::is_x86_feature_detected!("avx2") {
            return;
        }
        let a: Vec<u8> = (0..5000u32).map(|i| (i * 37 % 251) as u8).collect();
        let b: Vec<u8> = (0..5000u32).map(|i| (i * 91 % 253) as u8).collect();
        for n in [0, 1, 31, 32, 33, 1438, 5000] {
            // SAFETY: AVX2 checked above.
            let v = unsafe { abs_diff_sums_avx2(&a[..n], &b[..n]) };
            assert_eq!(v, abs_diff_sums_scalar(&a[..n], &b[..n]), "n = {n}");
        }
        let (a, b) = (vec![255u8; 200_000], vec![0u8; 200_000]);
        // SAFETY: AVX2 checked above.
        let v = unsafe { abs_diff_sums_avx2(&a, &b) };
        assert_eq!(v, abs_diff_sums_scalar(&a, &b));
    }
}
