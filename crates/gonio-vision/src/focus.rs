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
//! With AVX-512 VNNI (runtime-detected, `crate::simd::vnni`) it uses the identity
//!
//! $$\sum (x - y)^2 = \sum x^2 + \sum y^2 - 2 \sum x y,$$
//!
//! exact in integers, every row read once, when it arrives. One pass over its columns (with the
//! row two above it, a) gives its share of the pairs it belongs to: its vertical pair with a,
//! its own horizontal pair (`x[c]`, `x[c + 2]`) for the next row, and what the row two below needs
//! of it. A step of 64 columns loads x, x two columns on and a, flips x once into x − 128 (a
//! signed byte) and takes Σx, Σx(x − 128), `Σx[c + 2](x[c] − 128)` and Σa(x − 128) by four
//! `vpdpbusd` (Σxy = Σy(x − 128) + 128 Σy), the pairs' Σ|x − y| by two `vpsadbw`, and the
//! row's maximum (a row that reaches 255 is then counted): ten vector operations, one
//! `vpdpbusd` accumulator each (the instruction adds into its destination). The dot products
//! are combined in their lanes into the three numbers the rows need (this row's, the next
//! row's, the row after next's), and these and both Σ|x − y| are reduced together, in 32-bit
//! lanes, by one transposing reduction (blocks of 8192 columns keep them exact). The end columns a
//! pair leaves out are subtracted in scalar code. This is written by hand (no crate computes
//! these sums); the plain definition is the reference the tests hold it to.
//!
//! Where only the frame's totals are wanted and its height is known, [`FrameFocus`] gives them
//! without a reduction per row: a row between the first two and the last two takes all three of
//! its shares, whose sum 4D − 2H − 2V has no Σx, so those rows add three `vpdpbusd` and two
//! `vpsadbw` a step into lanes that run on from row to row, widened to 64 bits every 2^13
//! steps and reduced once, at the frame's end (the same integers as [`RowFocus`]'s rows added
//! up).
//!
//! ```
//! use gonio_vision::focus::abs_diff_sums;
//! assert_eq!(abs_diff_sums(&[10, 0, 255], &[7, 5, 0]), (3 + 5 + 255, 9 + 25 + 255 * 255));
//! ```

use crate::simd::{Avx2, Vnni};

/// Σ|a − b| and Σ(a − b)² over the common length of two rows, with the fastest path the CPU
/// has (the level [`crate::simd::level`] chooses).
#[inline]
pub fn abs_diff_sums(a: &[u8], b: &[u8]) -> (u64, u64) {
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = Avx2::get() {
        return crate::simd::avx2::abs_diff_sums(cpu, a, b);
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

/// What the VNNI path keeps of a row for the two rows after it ([`crate::simd::vnni::RowSums`]).
#[derive(Debug, Clone, Copy, Default)]
struct Kept {
    /// Its share of its own horizontal pair's Σ(difference)², without the end columns.
    next: i64,
    /// Its share of the vertical pair it is the upper row of, without the end columns.
    after: i64,
    /// Its horizontal pair's Σ|difference|.
    h_abs: u64,
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
    /// What the last two rows leave to the rows after them, at index y % 2 (VNNI path
    /// only).
    kept: [Kept; 2],
    /// Whether this frame takes the VNNI path: latched at row 0, since the ring
    /// above holds the VNNI path's state only (the SIMD level may change between
    /// frames, never within one).
    use_vnni: Option<Vnni>,
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
            self.use_vnni = Vnni::get();
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = self.use_vnni {
            return self.push_vnni(cpu, y, row, prev);
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

    /// [`RowFocus::push`] by the sum-of-squares identity (see the module docs), on a CPU with
    /// AVX-512 VNNI (`cpu`).
    #[cfg(target_arch = "x86_64")]
    fn push_vnni(
        &mut self,
        cpu: Vnni,
        y: usize,
        row: &[u8],
        prev: Option<(&[u8], &[u8])>,
    ) -> RowStats {
        // One pass over the row: its share of its vertical pair (with row y − 2), of its own
        // horizontal pair (used by row y + 1) and of the vertical pair of row y + 2.
        let r = crate::simd::vnni::row_sums(cpu, row, prev.map(|(a, _)| a));
        // Row y − 2's share sits where row y's goes.
        let (ka, kb) = (self.kept[y % 2], self.kept[(y + 1) % 2]);
        self.kept[y % 2] = Kept {
            next: r.next,
            after: r.after,
            h_abs: r.h_abs,
        };
        let Some((a, b)) = prev else {
            return RowStats {
                saturated: r.saturated,
                ..RowStats::default()
            };
        };
        let w = row.len();
        assert!(w >= 2 && b.len() == w, "rows of one width ≥ 2");
        let v = |k: usize| i64::from(row[k]);
        let (av, bv) = (|k: usize| i64::from(a[k]), |k: usize| i64::from(b[k]));
        // The end columns the pairs leave out: b[0], b[1] of the horizontal x = b[0 .. w − 2]
        // and b[w − 2], b[w − 1] of y = b[2 .. w] (their Σy shifted by 128 in `next`), and
        // columns 0 and w − 1 of the vertical pair.
        let ends_h = bv(0) * bv(0) + bv(1) * bv(1) + bv(w - 2) * bv(w - 2) + bv(w - 1) * bv(w - 1)
            - 256 * (bv(0) + bv(1));
        let (d0, d1) = (v(0) - av(0), v(w - 1) - av(w - 1));
        let sq_sum = kb.next - ends_h + r.now + ka.after - d0 * d0 - d1 * d1;
        RowStats {
            saturated: r.saturated,
            abs_sum: kb.h_abs + r.v_abs - d0.unsigned_abs() - d1.unsigned_abs(),
            sq_sum: sq_sum as u64,
        }
    }
}

/// A whole frame's raw sums: what [`RowFocus::push`] gives, added up over the frame's rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FrameStats {
    /// Pixels at 255.
    pub saturated: u64,
    /// Σ|central difference|, horizontal plus vertical, over the interior.
    pub abs_sum: u64,
    /// Σ(central difference)², horizontal plus vertical, over the interior.
    pub sq_sum: u64,
}

/// The streaming raw statistics of a frame whose height is known: [`RowFocus`]'s sums added
/// up over the frame, bit for bit, without a total per row. With AVX-512 VNNI the lanes of the
/// rows between the first two and the last two run on from row to row
/// (`crate::simd::vnni`), reduced once at the frame's end; otherwise row by row.
///
/// ```
/// use gonio_vision::focus::{FrameFocus, RowFocus};
/// let rows = [[0u8, 9, 255, 4], [7, 7, 1, 200], [3, 255, 0, 6], [1, 2, 3, 4]];
/// let (mut f, mut r) = (FrameFocus::default(), RowFocus::default());
/// let (mut abs, mut sq) = (0, 0);
/// for y in 0..4 {
///     let prev = (y >= 2).then(|| (&rows[y - 2][..], &rows[y - 1][..]));
///     let s = r.push(y, &rows[y], prev);
///     (abs, sq) = (abs + s.abs_sum, sq + s.sq_sum);
///     assert_eq!(f.push((y, 4), &rows[y], prev), s.saturated);
/// }
/// let t = f.finish();
/// assert_eq!((t.saturated, t.abs_sum, t.sq_sum), (2, abs, sq));
/// ```
#[derive(Debug, Clone, Default)]
pub struct FrameFocus {
    /// The sums so far.
    total: FrameStats,
    /// The VNNI path's lanes and sums.
    #[cfg(target_arch = "x86_64")]
    lanes: crate::simd::vnni::FrameLanes,
    /// Whether this frame takes the VNNI path (latched at row 0, as in [`RowFocus`]).
    use_vnni: Option<Vnni>,
}

impl FrameFocus {
    /// Row `y` of a frame `h` rows high (`yh` = (y, h); of width w ≥ 2) and, from y = 2 on,
    /// rows y − 2 and y − 1 as `prev`; its pixels at 255 returned. Every frame starts at
    /// y = 0 and goes on one row at a time to y = h − 1, then [`FrameFocus::finish`].
    ///
    /// # Panics
    /// If the rows' lengths differ or w < 2 while `prev` is given.
    #[inline]
    pub fn push(&mut self, yh: (usize, usize), row: &[u8], prev: Option<(&[u8], &[u8])>) -> u32 {
        if yh.0 == 0 {
            self.use_vnni = Vnni::get();
        }
        self.push_on(yh, row, prev)
    }

    /// [`FrameFocus::push`] on the path latched in `use_vnni`.
    #[inline(always)]
    fn push_on(&mut self, yh: (usize, usize), row: &[u8], prev: Option<(&[u8], &[u8])>) -> u32 {
        if yh.0 == 0 {
            self.total = FrameStats::default();
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = self.use_vnni {
            let n = crate::simd::vnni::frame_row_sums(cpu, &mut self.lanes, yh, row, prev);
            self.total.saturated += u64::from(n);
            return n;
        }
        // Compiled for the level in use, as the detector's rows are (`Detector::feed`).
        let s = crate::simd::dispatch(
            #[inline(always)]
            || RowFocus::push_direct(row, prev),
        );
        self.total.saturated += u64::from(s.saturated);
        self.total.abs_sum += s.abs_sum;
        self.total.sq_sum += s.sq_sum;
        s.saturated
    }

    /// The frame's sums, once its last row is in.
    pub fn finish(&mut self) -> FrameStats {
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = self.use_vnni {
            let t = crate::simd::vnni::frame_end_sums(cpu, &mut self.lanes);
            self.total.abs_sum = t.abs_sum;
            self.total.sq_sum = t.sq_sum;
        }
        self.total
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
    /// steps every way and the VNNI kernel's blocks of 8192 columns, up to the widest window.
    #[test]
    fn row_focus_gives_the_defined_sums() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut byte = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 24) as u8
        };
        let widths = (2..200).chain([
            255, 256, 257, 1439, 1440, 1441, 4097, 8193, 8194, 20000, 32768,
        ]);
        for w in widths {
            let mut rows: Vec<Vec<u8>> = (0..5).map(|_| (0..w).map(|_| byte()).collect()).collect();
            rows.push(vec![0; w]);
            rows.push(vec![255; w]);
            rows.push((0..w).map(|x| if x % 2 == 0 { 255 } else { 0 }).collect());
            rows.push(vec![255; w]);
            rows.push(vec![0; w]);
            #[cfg(target_arch = "x86_64")]
            let vnni = crate::simd::Vnni::detected();
            let mut by_identity = RowFocus::default();
            for y in 0..rows.len() {
                let prev = (y >= 2).then(|| (&rows[y - 2][..], &rows[y - 1][..]));
                let want = row_stats_by_definition(&rows, y);
                let got = RowFocus::push_direct(&rows[y], prev);
                assert_eq!(got, want, "direct, width {w}, row {y}");
                #[cfg(target_arch = "x86_64")]
                if let Some(cpu) = vnni {
                    let got = by_identity.push_vnni(cpu, y, &rows[y], prev);
                    assert_eq!(got, want, "VNNI identity, width {w}, row {y}");
                }
            }
        }
    }

    /// The frame's sums by the definition, row by row, and its rows with pixels at 255.
    fn frame_by_definition(rows: &[Vec<u8>]) -> (FrameStats, Vec<(usize, u32)>) {
        let mut t = FrameStats::default();
        let mut sat = Vec::new();
        for y in 0..rows.len() {
            let s = row_stats_by_definition(rows, y);
            if s.saturated > 0 {
                sat.push((y, s.saturated));
            }
            t.saturated += u64::from(s.saturated);
            t.abs_sum += s.abs_sum;
            t.sq_sum += s.sq_sum;
        }
        (t, sat)
    }

    /// [`FrameFocus`] each way (row by row, the VNNI frame kernel where the CPU has it, and
    /// the path [`FrameFocus::push`] dispatches to) against the definition, on `rows`.
    fn check_frame(rows: &[Vec<u8>], what: &str) {
        let (w, h) = (rows.first().map_or(2, Vec::len), rows.len());
        let want = frame_by_definition(rows);
        /// `push_on` with the VNNI kernel latched or not, or `push` with its own choice.
        enum Drive {
            Latched(Option<Vnni>),
            Push,
        }
        let mut paths = vec![
            ("direct", Drive::Latched(None)),
            ("dispatched", Drive::Push),
        ];
        #[cfg(target_arch = "x86_64")]
        if let Some(cpu) = crate::simd::Vnni::detected() {
            paths.push(("VNNI frame kernel", Drive::Latched(Some(cpu))));
        }
        for (path, drive) in paths {
            let mut f = FrameFocus::default();
            let mut sat = Vec::new();
            for y in 0..h {
                let prev = (y >= 2).then(|| (&rows[y - 2][..], &rows[y - 1][..]));
                let n = match drive {
                    Drive::Latched(cpu) => {
                        f.use_vnni = cpu;
                        f.push_on((y, h), &rows[y], prev)
                    }
                    Drive::Push => f.push((y, h), &rows[y], prev),
                };
                if n > 0 {
                    sat.push((y, n));
                }
            }
            let got = f.finish();
            assert_eq!((got, sat), want, "{path}, {what}, {w} × {h}");
        }
    }

    /// Frames of random rows with rows of 0, of 255 and 0/255 stripes among them (the
    /// largest lanes), of every odd width and height around the kernel's steps and the
    /// frame's first and last two rows, and the station's window.
    #[test]
    fn frame_sums_are_the_rows_sums() {
        let mut s = 0x853c_49e6_748f_ea9bu64;
        let mut byte = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 24) as u8
        };
        let widths = [
            2, 3, 4, 5, 63, 64, 65, 66, 127, 128, 129, 130, 191, 1440, 1441,
        ];
        for w in widths {
            for h in [1, 2, 3, 4, 5, 6, 7, 540] {
                if h == 540 && w < 1440 && w != 65 {
                    continue;
                }
                let rows: Vec<Vec<u8>> = (0..h)
                    .map(|y| match (y * 7 + w) % 11 {
                        0 => vec![0; w],
                        1 => vec![255; w],
                        2 => (0..w)
                            .map(|x| if (x / 2) % 2 == 0 { 255 } else { 0 })
                            .collect(),
                        _ => (0..w).map(|_| byte()).collect(),
                    })
                    .collect();
                check_frame(&rows, "mixed rows");
                let flat: Vec<Vec<u8>> = (0..h).map(|y| vec![255 * (y % 2) as u8; w]).collect();
                check_frame(&flat, "rows of 0 and 255");
            }
        }
        // Every difference 255, vertically, over a frame long enough to widen the lanes
        // several times, and over rows wider than a block of lanes.
        let stripes: Vec<Vec<u8>> = (0..3000)
            .map(|y| vec![[0, 0, 255, 255][y % 4]; 1441])
            .collect();
        check_frame(&stripes, "rows of 0, 0, 255, 255");
        let wide: Vec<Vec<u8>> = (0..6)
            .map(|_| (0..600_000).map(|_| byte()).collect())
            .collect();
        check_frame(&wide, "rows wider than a block");
    }

    use proptest::prelude::*;

    proptest! {
        /// [`FrameFocus`] against the definition on arbitrary small frames.
        #[test]
        fn frame_sums_match_the_definition(
            (w, bytes) in (2usize..200, 1usize..12)
                .prop_flat_map(|(w, h)| (Just(w), proptest::collection::vec(any::<u8>(), w * h)))
        ) {
            let rows: Vec<Vec<u8>> = bytes.chunks(w).map(<[u8]>::to_vec).collect();
            check_frame(&rows, "proptest");
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_path_matches_the_scalar_one() {
        // A CPU without the AVX2 level has no AVX2 path to compare: the test fails naming it
        // rather than pass without comparing anything.
        let cpu = crate::simd::Avx2::detected().unwrap_or_else(|| {
            panic!(
                "this CPU lacks the AVX2 level ({:?}): the AVX2 path cannot be compared here",
                crate::simd::AVX2_FEATURES
            )
        });
        let a: Vec<u8> = (0..5000u32).map(|i| (i * 37 % 251) as u8).collect();
        let b: Vec<u8> = (0..5000u32).map(|i| (i * 91 % 253) as u8).collect();
        for n in [0, 1, 31, 32, 33, 1438, 5000] {
            let v = crate::simd::avx2::abs_diff_sums(cpu, &a[..n], &b[..n]);
            assert_eq!(v, abs_diff_sums_scalar(&a[..n], &b[..n]), "n = {n}");
        }
        let (a, b) = (vec![255u8; 200_000], vec![0u8; 200_000]);
        let v = crate::simd::avx2::abs_diff_sums(cpu, &a, &b);
        assert_eq!(v, abs_diff_sums_scalar(&a, &b));
    }
}
