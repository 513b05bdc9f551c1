//! Ring selection: which two edges are the alignment ring's, chosen by the ring's model rather
//! than by component size (spec `eccentricity-detector.md`, "Scenes the detector must survive").
//!
//! A grating shows many long, near-vertical edges besides the ring's: the residues that thin
//! concentric track-border lines leave after the d/2 opening (10–50 % of their depth once the
//! optics blur them), scratches, the ends of radial marks. The selection uses what only the ring
//! has:
//!
//! 1. **Fragments.** Every component spanning at least `min_fragment_rows` rows whose pixels
//!    share one gradient polarity (≥ 90 %): rising (Gx > 0: the left edge of the bright band the
//!    top-hat makes of a dark ring) or falling. Each gets its least-squares curve (column as a
//!    parabola, or a line when short, of the row), the scatter of its pixels about it, and its
//!    mean gradient magnitude.
//! 2. **Tracks.** Fragments of one edge cut apart by dust, a scratch, marks touching the ring or a
//!    gap in the ring are linked top to bottom when each continues the other's curve (within
//!    1.5 px plus 1 % of the rows between them); their sums are added.
//! 3. **Candidates.** A rising track L and a falling track R to its right form a ring candidate
//!    when, over the rows they share (at least `min_edge_fraction` of the window's): their
//!    separation stays within the band derived from the ring width in the optics, they are
//!    parallel (the separation changes by at most `parallel_px`), their gradients are alike (the
//!    weaker at least half the stronger: both edges of one band), and no track at least
//!    `interior_fraction` as strong as their weaker edge runs between them, parallel to them,
//!    over 30 % of those rows (a ring's inside is flat; two neighbouring lines have edges as
//!    strong as their outer ones between them; a scratch crossing the ring at an angle, or what
//!    the opening leaves of one inside it, does not count).
//! 4. **Score.** Strength × coverage × width fit × balance, each 0 … 1: strength is the weaker
//!    edge's mean gradient relative to the strongest candidate's (the frame-relative threshold:
//!    a faint ring in a faint frame scores as well as a strong one in a strong frame) with half
//!    weight on its strong-pixel share; coverage the shared rows over the window's; width fit
//!    1 − ½·((sep − d)/(tolerance·d))²; balance the weaker edge's gradient over the stronger's.
//! 5. **Margin.** (best − runner-up)/best, the runner-up being the best candidate whose c lies
//!    more than d/2 from the best's (a different ring hypothesis). Below `min_margin` the frame
//!    is [`InvalidReason::Ambiguous`]: never guess.
//!
//! Each candidate's edges are re-fitted from the frame's own edge pixels near their curves, the
//! two together as parallel curves with the pixels that stray from them dropped
//! ([`refit_pair`]): pixels that only crossed an edge, or a scratch or speck running along one,
//! drop out, and c is the fitted centre line's mean column over the window's rows.
//!
//! Thresholds are the optics' (the minimum ring contrast sets the segmentation's floor) and the
//! frame's own (relative to its best candidate); no fixed count of largest components.
//!
//! Cost (the `dense` frame: ≈ 155 candidate components of which ≈ 20 are split, ≈ 34 tracks,
//! 15 × 15 pairs of long tracks, ≈ 1 pair re-fitted): the selection is written by hand because
//! it is the product, and kept allocation-free per component and per pair: the pixel, RANSAC
//! and refit buffers live for one frame (`Scratch`, `RefitScratch`) and are reused from
//! component to component and pair to pair. A fragment is a plain record until it starts a
//! track (no row list per fragment; fragments sorted by index, not moved); a track's rows are
//! kept as disjoint intervals in row order, so every pair of tracks intersects them in one
//! sweep without sorting; a curve or a joint fit is computed once per set of pixels (a clean
//! fragment's, a long component's fitted for the frame's curvature, a piece's or an edge's
//! whose re-fit kept the same pixels); a split component's pixels are looked up within its own
//! columns; a pair whose tracks' row ranges cannot share enough rows is dropped before their
//! rows are intersected; the refit gathers both edges in one pass over the rows, each row
//! searched linearly from where the row above's search ended; RANSAC stops counting a line
//! once it can no longer win, and skips the tries that cannot (a pair of pixels already
//! tried, or any try once every pixel is an inlier); when a re-fit or a dropped row changes
//! an edge's pixels, its sums follow by the sums of the pixels that went and came (`resum`)
//! instead of being summed afresh; the buffers are kept per thread from frame to frame; the
//! linking scan reads one compact list of the open tracks per polarity (last row, mean row,
//! curve, its column at the last row) instead of the tracks; the moments' exact integer
//! expansion runs in i64 when a guard proves it cannot overflow (i128 otherwise); the refit's
//! row means are computed once, the rows it drops marked. None of this changes a value: the
//! same sums (integers) and the same floating-point expressions in the same order
//! (BENCHMARKS.md, "Labelling and selection (issue 10)", "Selection and features, third pass
//! (issue 10)" and its fourth and fifth passes).
//!
//! ```
//! use gonio_vision::{Detector, InvalidReason, Optics};
//! let optics = Optics { window_width_px: 200, window_height_px: 64, ..Optics::default() };
//! let mut det = Detector::new(&optics).unwrap();
//! // A dark 11 px ring at column 100 and, 40 px to its left, a thin 3 px line of the same depth.
//! let mut frame = vec![190u8; 200 * 64];
//! for row in frame.chunks_mut(200) {
//!     for x in 95..=105 { row[x] = 70; }
//!     for x in 59..=61 { row[x] = 70; }
//! }
//! let r = det.detect(&frame).unwrap();
//! assert!(r.valid, "{:?}", r.reason);
//! assert!((r.c_px.unwrap() - 100.0).abs() < 0.05);
//! assert_eq!(r.margin, Some(1.0)); // nothing else looks like a ring
//! ```

use crate::features::{InvalidReason, SaturatedRun};
use crate::label::{Component, EdgeList, EdgePixel, EdgeRows, component_of};
use crate::optics::Params;

/// A least-squares curve of a component's pixels: column = a + b·u + q·u² with
/// u = 2·row − (H − 1) (q = 0 for a short component), and the scatter about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Curve {
    /// Column at u = 0 (the window's middle row), px.
    pub a: f64,
    /// Linear coefficient, px per u.
    pub b: f64,
    /// Quadratic coefficient, px per u².
    pub q: f64,
    /// RMS distance of the positioned pixels from the curve, px.
    pub rms_px: f64,
    /// Positioned pixels.
    pub n: f64,
}

impl Curve {
    /// Column at `row`, px.
    pub fn at(&self, row: f64, height: usize) -> f64 {
        let u = 2.0 * row - (height as f64 - 1.0);
        self.a + self.b * u + self.q * u * u
    }
}

/// Centred moments of a component: Σuᵏ (k = 0…4), Σuᵏ·c (k = 0…2, px), Σc² (px²).
pub(crate) fn moments(c: &Component, height: usize) -> ([f64; 5], [f64; 3], f64) {
    // u = 2·row − (H − 1): centred, integer. Exact expansion: in i64 when every product and
    // partial sum provably fits ([`fits_i64`]: the usual case; the same integers), else in
    // i128.
    let h = height as i64 - 1;
    let s = [
        c.pos_n as i64,
        c.sum_row,
        c.sum_row2,
        c.sum_row3,
        c.sum_row4,
    ];
    let cs = [c.sum_col32, c.sum_row_col32, c.sum_row2_col32];
    let e: [i128; 8] = if fits_i64(h, &s, &cs) {
        expand(h, s, cs).map(i128::from)
    } else {
        expand(h as i128, s.map(i128::from), cs.map(i128::from))
    };
    let f = to_f64;
    (
        [f(e[0]), f(e[1]), f(e[2]), f(e[3]), f(e[4])],
        [f(e[5]) / 32.0, f(e[6]) / 32.0, f(e[7]) / 32.0],
        f(c.sum_col32_sq) / 1024.0,
    )
}

/// The centred sums of [`moments`] from the raw ones (`s` = n, Σr, Σr², Σr³, Σr⁴; `c` = Σc,
/// Σr·c, Σr²·c; `h` = H − 1): n, Σu…Σu⁴, Σc, Σu·c, Σu²·c, exact in `T` when nothing overflows.
fn expand<T>(h: T, s: [T; 5], c: [T; 3]) -> [T; 8]
where
    T: Copy + From<i8> + std::ops::Add<Output = T> + std::ops::Sub<Output = T>,
    T: std::ops::Mul<Output = T>,
{
    let k = |v: i8| T::from(v);
    let [n, s1, s2, s3, s4] = s;
    let u1 = k(2) * s1 - h * n;
    let u2 = k(4) * s2 - k(4) * h * s1 + h * h * n;
    let u3 = k(8) * s3 - k(12) * h * s2 + k(6) * h * h * s1 - h * h * h * n;
    let u4 = k(16) * s4 - k(32) * h * s3 + k(24) * h * h * s2 - k(8) * h * h * h * s1
        + h * h * h * h * n;
    let [c0, c1, c2] = c;
    let v1 = k(2) * c1 - h * c0;
    let v2 = k(4) * c2 - k(4) * h * c1 + h * h * c0;
    [n, u1, u2, u3, u4, c0, v1, v2]
}

/// True when [`expand`] cannot overflow an i64: 0 ≤ n < 2¹⁹, 0 ≤ h < 2¹⁰ and each raw sum
/// within a bound that keeps every product below 2⁵⁹ (e.g. 32·h·Σr³ < 2⁵·2¹⁰·2⁴⁴), so each
/// sum of at most five of them below 2⁶². A 540-row window with a few thousand pixels is far
/// inside.
fn fits_i64(h: i64, s: &[i64; 5], c: &[i64; 3]) -> bool {
    let below = |v: i64, bits: u32| v.unsigned_abs() < 1 << bits;
    (0..1 << 10).contains(&h)
        && (0..1 << 19).contains(&s[0])
        && below(s[1], 26)
        && below(s[2], 34)
        && below(s[3], 44)
        && below(s[4], 55)
        && below(c[0], 36)
        && below(c[1], 46)
        && below(c[2], 56)
}

/// `x as f64`, through the hardware's i64 conversion when x fits in an i64 (the usual case;
/// the i128 conversion is a library call). Both round to nearest: the same value.
/// The i128 path is a separate cold function: inlined, LLVM computed both conversions and
/// selected one, so the library call ran every time.
#[inline]
fn to_f64(x: i128) -> f64 {
    #[cold]
    #[inline(never)]
    fn wide(x: i128) -> f64 {
        x as f64
    }
    match i64::try_from(x) {
        Ok(v) => v as f64,
        Err(_) => wide(x),
    }
}

fn det3(m: [[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Solves a 3×3 system by Cramer's rule; `None` when (nearly) singular.
pub(crate) fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let d = det3(a);
    let scale = a[0][0] * a[1][1] * a[2][2];
    if d.is_nan() || d.abs() <= 1e-9 * scale.abs() {
        return None;
    }
    let mut x = [0.0; 3];
    for (i, xi) in x.iter_mut().enumerate() {
        let mut m = a;
        for r in 0..3 {
            m[r][i] = b[r];
        }
        *xi = det3(m) / d;
    }
    Some(x)
}

/// The component's curve: a parabola when it spans at least half the window's rows, a line
/// otherwise (a shorter piece cannot pin the curvature, and a line extrapolates better);
/// `None` without two positioned pixels on different rows.
pub fn curve(c: &Component, height: usize) -> Option<Curve> {
    curve_with(c, height, None)
}

/// As [`curve`], but a piece spanning less than half the window's rows bends with the given
/// curvature `q_prior` (px per u², e.g. the frame's: every edge in the window is a circle
/// concentric with the ring) instead of being straight.
pub fn curve_with(c: &Component, height: usize, q_prior: Option<f64>) -> Option<Curve> {
    if c.pos_n < 2 {
        return None;
    }
    let (u, v, cc) = moments(c, height);
    let n = u[0];
    // A line through the columns less q·u²: Σ(c − q u²) = v0 − q·u2, Σu(c − q u²) = v1 − q·u3,
    // Σ(c − q u²)² = cc − 2q·v2 + q²·u4.
    let line = |q: f64| {
        let (w0, w1) = (v[0] - q * u[2], v[1] - q * u[3]);
        let ww = cc - 2.0 * q * v[2] + q * q * u[4];
        let suu = u[2] - u[1] * u[1] / n;
        if suu <= 0.0 {
            return None;
        }
        let b = (w1 - u[1] * w0 / n) / suu;
        let a = (w0 - b * u[1]) / n;
        Some((a, b, q, ww, a * w0 + b * w1, 2.0))
    };
    let fit = if parabola(c, height) {
        match solve3(
            [[u[0], u[1], u[2]], [u[1], u[2], u[3]], [u[2], u[3], u[4]]],
            [v[0], v[1], v[2]],
        ) {
            Some([a, b, q]) => Some((a, b, q, cc, a * v[0] + b * v[1] + q * v[2], 3.0)),
            None => line(0.0),
        }
    } else {
        line(q_prior.unwrap_or(0.0))
    };
    let (a, b, q, total, explained, k) = fit?;
    let ssr = (total - explained).max(0.0);
    let dof = (n - k).max(1.0);
    Some(Curve {
        a,
        b,
        q,
        rms_px: (ssr / dof).sqrt(),
        n,
    })
}

/// True when [`curve_with`] fits `c` with a parabola (it spans at least half the window's rows,
/// with four positioned pixels or more): its curvature prior is then not used.
fn parabola(c: &Component, height: usize) -> bool {
    (c.max_row - c.min_row) as f64 >= height as f64 / 2.0 && c.pos_n >= 4
}

/// The disjoint row intervals covered by intervals `[first, last]` given in order of their first
/// rows (a track's fragments, top to bottom): overlapping and adjacent ones merged, in row order.
/// One sweep, no sort.
fn merged(iv: &[(u32, u32)]) -> impl Iterator<Item = (u32, u32)> + '_ {
    let mut it = iv.iter().copied().peekable();
    std::iter::from_fn(move || {
        let (a, mut b) = it.next()?;
        while let Some(&(a2, b2)) = it.peek() {
            debug_assert!(a2 >= a, "intervals in order of their first rows");
            if a2 > b + 1 {
                break;
            }
            b = b.max(b2);
            it.next();
        }
        Some((a, b))
    })
}

/// Rows covered by intervals given in order of their first rows (overlaps counted once).
fn union_len(iv: &[(u32, u32)]) -> u32 {
    merged(iv).map(|(a, b)| b - a + 1).sum()
}

/// Rows covered by both of two sets of disjoint intervals in row order ([`merged`]), and the
/// first and last of them (0, 0, 0 when none): one merge-like sweep. The same integers as the
/// union of the pairwise overlaps of the unmerged intervals (a row lies in both unions exactly
/// when it lies in an overlap of one interval of each).
fn shared(a: &[(u32, u32)], b: &[(u32, u32)]) -> (u32, u32, u32) {
    let (mut i, mut j) = (0, 0);
    let (mut n, mut first, mut last) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        let (lo, hi) = (a[i].0.max(b[j].0), a[i].1.min(b[j].1));
        if lo <= hi {
            if n == 0 {
                first = lo;
            }
            n += hi - lo + 1;
            last = hi;
        }
        if a[i].1 < b[j].1 {
            i += 1;
        } else {
            j += 1;
        }
    }
    (n, first, last)
}

/// One edge of the window seen as a ring edge: linked fragments with their summed statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// The fragments' sums, added.
    pub comp: Component,
    /// Row ranges of the fragments.
    pub rows: Vec<(u32, u32)>,
    /// Rows covered.
    pub coverage: u32,
    /// +1 rising (Gx > 0), −1 falling.
    pub polarity: i8,
    /// The curve of all the fragments' pixels.
    pub curve: Curve,
    /// Mean gradient magnitude of the positioned pixels (Sobel L1 units).
    pub gradient: f64,
    /// Strong pixels over all pixels.
    pub strong_share: f64,
}

/// A fragment of an edge: a clean candidate component, or a smooth piece of one, of one
/// polarity, with its curve (`curve_with` with the frame's curvature). Tracks start from
/// fragments and absorb them; only the tracks are [`Track`]s (no row list per fragment).
#[derive(Debug, Clone, Copy)]
struct Frag {
    comp: Component,
    polarity: i8,
    curve: Curve,
}

impl Track {
    /// A track of one fragment.
    fn start(f: &Frag) -> Track {
        let comp = f.comp;
        let mut t = Track {
            comp,
            rows: vec![(comp.min_row, comp.max_row)],
            coverage: comp.row_span(),
            polarity: f.polarity,
            curve: f.curve,
            gradient: 0.0,
            strong_share: 0.0,
        };
        t.update_stats();
        t
    }

    fn update_stats(&mut self) {
        self.gradient = self.comp.sum_mag as f64 / self.comp.pos_n.max(1) as f64;
        self.strong_share = self.comp.strong as f64 / self.comp.pixels.max(1) as f64;
    }

    /// Adds a fragment that starts no higher than the track's fragments (they come top to
    /// bottom: `rows` stays in order of first rows, see [`merged`]).
    fn absorb(&mut self, f: &Frag, height: usize, q: Option<f64>) {
        let mut c = self.comp;
        c.merge(&f.comp);
        if let Some(cv) = curve_with(&c, height, q) {
            self.comp = c;
            self.curve = cv;
            self.rows.push((f.comp.min_row, f.comp.max_row));
            self.coverage = union_len(&self.rows);
            self.update_stats();
        }
    }

    /// Last row covered.
    fn last_row(&self) -> u32 {
        self.rows.iter().map(|r| r.1).max().unwrap_or(0)
    }

    /// Mean row of the positioned pixels.
    fn mean_row(&self) -> f64 {
        self.comp.sum_row as f64 / self.comp.pos_n.max(1) as f64
    }
}

fn polarity(c: &Component) -> Option<i8> {
    if 10 * c.gx_pos >= 9 * c.pixels {
        Some(1)
    } else if 10 * c.gx_pos <= c.pixels {
        Some(-1)
    } else {
        None
    }
}

/// A deterministic RANSAC line through pixels whose columns are first reduced by the curvature
/// `q` (px per u²): pairs of pixels from the upper and lower halves (in raster order) at least
/// `min_fragment_rows` rows apart, slope within the baseline filter's tolerance, the line with
/// most pixels within `gate` px. Returns (row, reduced column, slope) of the line.
fn ransac(
    px: &[EdgePixel],
    q: f64,
    gate: f64,
    p: &Params,
    rows: &mut Vec<f64>,
    cols: &mut Vec<f64>,
) -> Option<(f64, f64, f64)> {
    let h = p.height;
    let tan = p.tan_tolerance_q10 as f64 / 1024.0;
    let col = |e: &EdgePixel| {
        let u = 2.0 * e.row as f64 - (h as f64 - 1.0);
        e.col32() as f64 / 32.0 - q * u * u
    };
    let n = px.len();
    let half = n / 2;
    if half == 0 {
        return None;
    }
    // Each pixel's row and reduced column once (the same values the tries would compute).
    rows.clear();
    rows.extend(px.iter().map(|e| e.row as f64));
    cols.clear();
    cols.extend(px.iter().map(col));
    let (rows, cols) = (&rows[..], &cols[..]);
    let min_rows = p.min_fragment_rows as f64;
    // The tries and their counts under one dispatch (not one per try).
    crate::simd::dispatch(
        #[inline(always)]
        || best_line(rows, cols, min_rows, tan, gate),
    )
}

/// RANSAC's tries ([`ransac`]) over the pixels' rows and reduced columns: (row, reduced column,
/// slope) of the first line with most pixels within `gate`; `None` without a pair of pixels
/// `min_rows` rows apart within the slope tolerance `tan`.
#[inline(always)]
fn best_line(
    rows: &[f64],
    cols: &[f64],
    min_rows: f64,
    tan: f64,
    gate: f64,
) -> Option<(f64, f64, f64)> {
    let n = rows.len();
    let half = n / 2;
    let mut best: Option<(usize, f64, f64, f64)> = None;
    const TRIES: usize = 48;
    let ib_of = |k: usize| half + ((k * 37) % TRIES) * (n - half) / TRIES;
    // The first try with this try's `ia` (`ia` never decreases with k).
    let mut group = 0;
    for k in 0..TRIES {
        // Skipped tries could not be chosen (the choice needs strictly more inliers than the
        // best so far): once every pixel is an inlier of the best line, any later one; and a
        // try of the same pair of pixels as an earlier one (fewer than 48 pixels a half), whose
        // line and count are that try's, no more than the best since.
        if best.is_some_and(|b| b.0 == n) {
            break;
        }
        let ia = k * half / TRIES;
        if k > 0 && (k - 1) * half / TRIES != ia {
            group = k;
        }
        let ib = ib_of(k);
        if (group..k).any(|k2| ib_of(k2) == ib) {
            continue;
        }
        let dr = rows[ib] - rows[ia];
        if dr < min_rows {
            continue;
        }
        let slope = (cols[ib] - cols[ia]) / dr;
        if slope.abs() > tan {
            continue;
        }
        let (r0, c0) = (rows[ia], cols[ia]);
        // A line must beat the best so far: counting stops once it no longer can.
        let need = best.map_or(0, |b| b.0 + 1);
        let inl = inliers(rows, cols, r0, c0, slope, gate, need);
        if best.is_none_or(|b| inl > b.0) {
            best = Some((inl, r0, c0, slope));
        }
    }
    best.map(|(_, r0, c0, slope)| (r0, c0, slope))
}

/// Pixels within `gate` of the line through (r0, c0) with `slope` (vectorised: exact f64
/// arithmetic, no contraction, so every code path counts the same), counted 64 at a time; the
/// count stops early, below `need`, once even every pixel left could not bring it to `need`
/// (the caller only wants lines with at least `need`).
#[inline(always)]
fn inliers(
    rows: &[f64],
    cols: &[f64],
    r0: f64,
    c0: f64,
    slope: f64,
    gate: f64,
    need: usize,
) -> usize {
    const CHUNK: usize = 64;
    let (mut n, mut left) = (0, rows.len());
    for (rs, cs) in rows.chunks(CHUNK).zip(cols.chunks(CHUNK)) {
        n += rs
            .iter()
            .zip(cs)
            .map(|(&r, &c)| ((c - c0 - slope * (r - r0)).abs() <= gate) as usize)
            .sum::<usize>();
        left -= rs.len();
        if n + left < need {
            break;
        }
    }
    n
}

/// The pixels of `old` not in `new` into `gone` and those of `new` not in `old` into `came`
/// (both cleared first), for two subsets of one pixel list in raster order (no two pixels at
/// one position): one merge-like sweep. True when the two are the same set.
fn diff(
    old: &[EdgePixel],
    new: &[EdgePixel],
    gone: &mut Vec<EdgePixel>,
    came: &mut Vec<EdgePixel>,
) -> bool {
    let key = |e: &EdgePixel| (e.row as u32) << 16 | e.col as u32;
    gone.clear();
    came.clear();
    let (mut i, mut j) = (0, 0);
    while i < old.len() && j < new.len() {
        let (a, b) = (key(&old[i]), key(&new[j]));
        debug_assert!(i == 0 || key(&old[i - 1]) < a, "raster order");
        debug_assert!(j == 0 || key(&new[j - 1]) < b, "raster order");
        if a == b {
            i += 1;
            j += 1;
        } else if a < b {
            gone.push(old[i]);
            i += 1;
        } else {
            came.push(new[j]);
            j += 1;
        }
    }
    gone.extend_from_slice(&old[i..]);
    came.extend_from_slice(&new[j..]);
    gone.is_empty() && came.is_empty()
}

/// `component_of(new, w)` from the sums `old` of a pixel set that became `new` (in raster
/// order) by losing the pixels `gone` and gaining `came`: the counts and sums are integers, so
/// adding what came and taking away what went gives the same values as summing `new` afresh
/// (in any order); the first and last row and pixel are `new`'s first and last (raster order),
/// the column range a pass over `new`'s columns. Summed afresh when the change is not smaller
/// than `new`.
fn resum(
    old: &Component,
    gone: &[EdgePixel],
    came: &[EdgePixel],
    new: &[EdgePixel],
    w: usize,
) -> Component {
    let (Some(first), Some(last)) = (new.first(), new.last()) else {
        return component_of(new, w);
    };
    if gone.len() + came.len() >= new.len() {
        return component_of(new, w);
    }
    let mut c = *old;
    if !came.is_empty() {
        c.merge(&component_of(came, w));
    }
    if !gone.is_empty() {
        c.remove(&component_of(gone, w));
    }
    c.min_row = first.row as u32;
    c.max_row = last.row as u32;
    c.first_index = first.row as u64 * w as u64 + first.col as u64;
    (c.min_col, c.max_col) = new.iter().fold((u32::MAX, 0), |(lo, hi), e| {
        (lo.min(e.col as u32), hi.max(e.col as u32))
    });
    c
}

/// The smooth pieces of a set of same-polarity pixels, strongest first: a deterministic RANSAC
/// line bent with the frame's curvature `q` (pairs of pixels from the upper and lower halves;
/// inliers within 1.5 px; slope within the baseline filter's tolerance), its pixels within
/// 1.5 px, then a curve re-fitted to those within 1 px of it, twice. Pieces spanning fewer than
/// `min_fragment_rows` rows end the search.
///
/// Each piece comes with its curve (`curve_with` with `q`) when the re-fits reached it (the last
/// re-fit kept the same pixels), else `None`. A re-fit that keeps the same pixels as the one
/// before ends the re-fits: the same pixels give the same sums and the same curve, so the
/// remaining one would change nothing (no component summed twice).
fn split(s: &mut Scratch, p: &Params, q: Option<f64>, out: &mut Vec<(Component, Option<Curve>)>) {
    let (h, w) = (p.height, p.width);
    let qq = q.unwrap_or(0.0);
    // Columns less the frame's curvature: a concentric edge is straight in these.
    let col = |e: &EdgePixel| {
        let u = 2.0 * e.row as f64 - (h as f64 - 1.0);
        e.col32() as f64 / 32.0 - qq * u * u
    };
    let col_px = |e: &EdgePixel| e.col32() as f64 / 32.0;
    for _ in 0..4 {
        if s.part.len() < p.min_fragment_rows as usize {
            break;
        }
        let Some((r0, c0, slope)) = ransac(&s.part, qq, 1.5, p, &mut s.rows, &mut s.cols) else {
            break;
        };
        let near = |q: &EdgePixel| (col(q) - c0 - slope * (q.row as f64 - r0)).abs() <= 1.5;
        s.taken.clear();
        s.rest.clear();
        for e in &s.part {
            if near(e) {
                s.taken.push(*e);
            } else {
                s.rest.push(*e);
            }
        }
        std::mem::swap(&mut s.part, &mut s.rest);
        s.piece.clear();
        s.piece.extend_from_slice(&s.taken);
        // `c` is always the sums of `s.piece`; `known` its curve once fitted.
        let mut c = component_of(&s.piece, w);
        let mut known = None;
        for _ in 0..2 {
            let Some(cv) = curve_with(&c, h, q) else {
                break;
            };
            s.next.clear();
            s.next.extend(
                s.taken
                    .iter()
                    .filter(|e| (col_px(e) - cv.at(e.row as f64, h)).abs() <= 1.0),
            );
            // Both are subsets of `taken` (raster order): the new sums from the change.
            if diff(&s.piece, &s.next, &mut s.gone, &mut s.came) {
                known = Some(cv);
                break;
            }
            c = resum(&c, &s.gone, &s.came, &s.next, w);
            std::mem::swap(&mut s.piece, &mut s.next);
        }
        if c.pixels == 0 || c.row_span() < p.min_fragment_rows {
            break;
        }
        out.push((c, known));
    }
}

/// Pixel and value buffers the selection reuses within a frame: no allocation per component
/// split or pair refitted.
#[derive(Debug, Default)]
struct Scratch {
    /// A component's pixels.
    comp: Vec<EdgePixel>,
    /// The pixels of one polarity still to split.
    part: Vec<EdgePixel>,
    rest: Vec<EdgePixel>,
    taken: Vec<EdgePixel>,
    piece: Vec<EdgePixel>,
    next: Vec<EdgePixel>,
    /// The pixels a re-fit dropped and took in ([`diff`]).
    gone: Vec<EdgePixel>,
    came: Vec<EdgePixel>,
    /// The long candidates' curves fitted for the frame's curvature, by sorted candidate.
    fitted: Vec<Option<Curve>>,
    /// RANSAC's rows and reduced columns.
    rows: Vec<f64>,
    cols: Vec<f64>,
}

/// The fragments of the frame and its curvature: clean candidate components as they are; a
/// component that mixes polarities or scatters about its curve (an edge that took in a
/// crossing scratch's or a speck's edge) split into its smooth pieces from its own pixels. The
/// frame's curvature (px per u²) is the median of the clean fragments spanning half the window
/// or more (`None` without one): every edge in the window is concentric with the ring, and a
/// shorter piece bends with it.
///
/// Each curve is fitted once: a component fitted with a parabola for the frame's curvature
/// ([`parabola`]: the curvature prior is not used) keeps that curve for its cleanliness test,
/// and a clean fragment or a converged piece keeps the curve it was tested with.
fn fragments(
    cands: &[Component],
    edges: &mut EdgeList,
    p: &Params,
    s: &mut Scratch,
) -> (Vec<Frag>, Option<f64>) {
    let h = p.height;
    let mut sorted: Vec<&Component> = cands
        .iter()
        .filter(|c| c.row_span() >= p.min_fragment_rows)
        .collect();
    sorted.sort_by_key(|c| c.first_index);
    s.fitted.clear();
    let mut qs: Vec<f64> = Vec::new();
    for c in &sorted {
        let mut fitted = None;
        if 2 * c.row_span() as usize > h && polarity(c).is_some() {
            let cv = curve(c, h);
            if let Some(cv) = cv.filter(|cv| cv.rms_px <= p.max_fragment_rms_px) {
                qs.push(cv.q);
            }
            if parabola(c, h) {
                fitted = cv;
            }
        }
        s.fitted.push(fitted);
    }
    let q = (!qs.is_empty()).then(|| median(&mut qs));
    let mut out = Vec::with_capacity(sorted.len());
    let mut pieces = Vec::new();
    for (k, c) in sorted.into_iter().enumerate() {
        // `curve_with(c, h, q)`: for a parabola the curve already fitted without the prior.
        let cv = match s.fitted[k] {
            Some(cv) => Some(cv),
            None => curve_with(c, h, q),
        };
        let clean = cv.filter(|cv| cv.rms_px <= p.max_fragment_rms_px);
        // A clean fragment keeps the curve just fitted (the same `curve_with`).
        if let (Some(pol), Some(cv)) = (polarity(c), clean) {
            out.push(Frag {
                comp: *c,
                polarity: pol,
                curve: cv,
            });
            continue;
        }
        edges.component_pixels_into(c, &mut s.comp);
        for rising in [true, false] {
            s.part.clear();
            s.part
                .extend(s.comp.iter().filter(|e| e.rising() == rising).copied());
            pieces.clear();
            split(s, p, q, &mut pieces);
            for &(comp, known) in &pieces {
                let polarity = if rising { 1 } else { -1 };
                out.extend(known.or_else(|| curve_with(&comp, h, q)).map(|curve| Frag {
                    comp,
                    polarity,
                    curve,
                }));
            }
        }
    }
    (out, q)
}

/// `v.partition_point(pred)` for a predicate true on a prefix of `v` (columns sorted), looked
/// for from `hint` (0, or the boundary on a neighbouring curve): a linear walk when it lies
/// near (a row holds ≈ 30 pixels on the `dense` frame: a walk streams through them, where a
/// binary search waits on one dependent load after another), a binary search of the rest when
/// not. The same index for any hint.
fn partition_near<T>(v: &[T], hint: usize, pred: impl Fn(&T) -> bool) -> usize {
    const WALK: usize = 32;
    let mut k = hint.min(v.len());
    if k > 0 && !pred(&v[k - 1]) {
        // The boundary is at or before k − 1.
        for _ in 0..WALK {
            k -= 1;
            if k == 0 || pred(&v[k - 1]) {
                return k;
            }
        }
        v[..k].partition_point(pred)
    } else {
        // Every element before k satisfies the predicate.
        for _ in 0..WALK {
            if k == v.len() || !pred(&v[k]) {
                return k;
            }
            k += 1;
        }
        k + v[k..].partition_point(pred)
    }
}

/// The pixels of one polarity within `gate` px of column `c` in one row (sorted by column),
/// appended to `px`; returns where the search started (the first pixel left of c − gate − 1
/// excluded), for the next search in this row.
fn gather_row(
    row: &[EdgePixel],
    hint: usize,
    c: f64,
    rising: bool,
    gate: f64,
    px: &mut Vec<EdgePixel>,
) -> usize {
    let lo = partition_near(row, hint, |q| (q.col as f64) < c - gate - 1.0);
    for q in &row[lo..] {
        let x = q.col32() as f64 / 32.0;
        if x > c + gate {
            break;
        }
        if q.rising() == rising && (x - c).abs() <= gate {
            px.push(*q);
        }
    }
    lo
}

/// The rising pixels within `gate` px of the left curve and the falling ones within `gate` px
/// of the right curve, row by row (rows marked in `skip` left out), appended to `lpx` and
/// `rpx`; `hints[y]` gets where row y's search for the left edge started. One pass over the
/// rows: the right edge's search in a row starts from the left edge's, and the left edge's
/// from where it started in the row above (the same other edges lie left of it from row to
/// row: the walk is a step or two; [`partition_near`] finds the same index from any hint).
#[allow(clippy::too_many_arguments)]
fn gather(
    left: &Curve,
    right: &Curve,
    gate: f64,
    edges: &EdgeRows,
    skip: &[bool],
    h: usize,
    lpx: &mut Vec<EdgePixel>,
    rpx: &mut Vec<EdgePixel>,
    hints: &mut [u32],
) {
    let mut above = 0;
    for y in 0..h {
        hints[y] = 0;
        if skip[y] {
            continue;
        }
        let row = edges.row(y);
        let lo = gather_row(row, above, left.at(y as f64, h), true, gate, lpx);
        gather_row(row, lo, right.at(y as f64, h), false, gate, rpx);
        hints[y] = lo as u32;
        above = lo;
    }
}

fn median(v: &mut [f64]) -> f64 {
    // The middle elements by selection, not a full sort: under `total_cmp` (a total order,
    // equal only for identical bits) the k-th smallest value is the sorted array's v[k].
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let (below, &mut m, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        m
    } else {
        let lo = below.iter().copied().max_by(f64::total_cmp).unwrap_or(m);
        0.5 * (lo + m)
    }
}

/// How far another edge can pull a ring edge's profile through the opening, the 5×5 blur and
/// Sobel, px.
const NEIGHBOUR_REACH_PX: f64 = 6.0;
/// Neighbouring edge pixels weaker than this fraction of the ring edge's mean gradient are
/// ignored (noise).
const NEIGHBOUR_FRACTION: f64 = 0.15;

/// A ring's two edges fitted together as parallel curves: column = a_L (or a_R) + b·u + q·u²,
/// u = 2·row − (H − 1) (concentric circles 10 px apart differ in slope and curvature by
/// ≈ 0.2 %), with the pixels each edge kept.
#[derive(Debug, Clone, PartialEq)]
pub struct PairFit {
    /// The left edge's kept pixels, summed.
    pub left: Component,
    /// The right edge's kept pixels, summed.
    pub right: Component,
    /// Rows where the left edge kept a pixel.
    pub left_rows: Vec<bool>,
    /// Rows where the right edge kept a pixel.
    pub right_rows: Vec<bool>,
    /// The left edge's column at u = 0, px.
    pub a_left: f64,
    /// The right edge's column at u = 0, px.
    pub a_right: f64,
    /// Common linear coefficient, px per u.
    pub b: f64,
    /// Common quadratic coefficient, px per u².
    pub q: f64,
    /// Standard uncertainty of c from the fit (the pixels' scatter about the curves propagated
    /// through the fit: grows when the edges cover little of the window), px.
    pub c_sigma_px: f64,
    /// How much the ring's width changes over the window: the range of a parabola fitted to the
    /// row-wise widths, px (a ring is equally wide everywhere; something running along an edge
    /// or into the ring makes it change).
    pub width_change_px: f64,
}

impl PairFit {
    /// The ring's c: its centre line's mean column over the window's rows, px.
    pub fn c_px(&self, height: usize) -> f64 {
        let mean_u2 = ((height * height) as f64 - 1.0) / 3.0;
        0.5 * (self.a_left + self.a_right) + self.q * mean_u2
    }

    /// Each edge's mean column over the window's rows, px (left, right).
    pub fn window_means(&self, height: usize) -> (f64, f64) {
        let mean_u2 = ((height * height) as f64 - 1.0) / 3.0;
        (
            self.a_left + self.q * mean_u2,
            self.a_right + self.q * mean_u2,
        )
    }

    fn at(&self, right: bool, row: f64, height: usize) -> f64 {
        let u = 2.0 * row - (height as f64 - 1.0);
        (if right { self.a_right } else { self.a_left }) + self.b * u + self.q * u * u
    }
}

/// Solves a small dense system by Gaussian elimination with partial pivoting.
#[allow(clippy::needless_range_loop)]
fn solve_n<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for k in 0..N {
        let piv = (k..N).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if a[piv][k].abs() < 1e-12 * a[k][k].abs().max(1.0) || a[piv][k] == 0.0 {
            return None;
        }
        a.swap(k, piv);
        b.swap(k, piv);
        for i in k + 1..N {
            let f = a[i][k] / a[k][k];
            for j in k..N {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = [0.0; N];
    for k in (0..N).rev() {
        let s: f64 = (k + 1..N).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    Some(x)
}

/// The joint least-squares fit of two edges as parallel curves (see [`PairFit`]), with the
/// common curvature free or fixed to `q_fixed`: (a_L, a_R, b, q, standard uncertainty of c).
fn joint_fit(
    l: &Component,
    r: &Component,
    height: usize,
    q_fixed: Option<f64>,
) -> Option<(f64, f64, f64, f64, f64)> {
    if l.pos_n < 3 || r.pos_n < 3 {
        return None;
    }
    let (ul, vl, cl) = moments(l, height);
    let (ur, vr, cr) = moments(r, height);
    let mean_u2 = ((height * height) as f64 - 1.0) / 3.0;
    let dof = (ul[0] + ur[0] - 4.0).max(1.0);
    match q_fixed {
        None => {
            let n = [
                [ul[0], 0.0, ul[1], ul[2]],
                [0.0, ur[0], ur[1], ur[2]],
                [ul[1], ur[1], ul[2] + ur[2], ul[3] + ur[3]],
                [ul[2], ur[2], ul[3] + ur[3], ul[4] + ur[4]],
            ];
            let rhs = [vl[0], vr[0], vl[1] + vr[1], vl[2] + vr[2]];
            let theta = solve_n(n, rhs)?;
            // c = (a_L + a_R)/2 + q·mean(u²): var(c) = σ²·gᵀN⁻¹g.
            let g = [0.5, 0.5, 0.0, mean_u2];
            let ng = solve_n(n, g)?;
            let explained: f64 = theta.iter().zip(&rhs).map(|(t, v)| t * v).sum();
            let s2 = ((cl + cr - explained) / dof).max(0.0);
            let var_c: f64 = g.iter().zip(&ng).map(|(a, b)| a * b).sum::<f64>() * s2;
            let [a_l, a_r, b, q] = theta;
            Some((a_l, a_r, b, q, var_c.max(0.0).sqrt()))
        }
        Some(q) => {
            // Columns less q·u²: Σ(c − q u²) = v0 − q·u2, Σu(c − q u²) = v1 − q·u3,
            // Σ(c − q u²)² = cc − 2q·v2 + q²·u4.
            let w = |u: &[f64; 5], v: &[f64; 3], cc: f64| {
                (
                    v[0] - q * u[2],
                    v[1] - q * u[3],
                    cc - 2.0 * q * v[2] + q * q * u[4],
                )
            };
            let (wl0, wl1, wll) = w(&ul, &vl, cl);
            let (wr0, wr1, wrr) = w(&ur, &vr, cr);
            let n = [
                [ul[0], 0.0, ul[1]],
                [0.0, ur[0], ur[1]],
                [ul[1], ur[1], ul[2] + ur[2]],
            ];
            let rhs = [wl0, wr0, wl1 + wr1];
            let theta = solve_n(n, rhs)?;
            let g = [0.5, 0.5, 0.0];
            let ng = solve_n(n, g)?;
            let explained: f64 = theta.iter().zip(&rhs).map(|(t, v)| t * v).sum();
            let s2 = ((wll + wrr - explained) / dof).max(0.0);
            let var_c: f64 = g.iter().zip(&ng).map(|(a, b)| a * b).sum::<f64>() * s2;
            let [a_l, a_r, b] = theta;
            Some((a_l, a_r, b, q, var_c.max(0.0).sqrt()))
        }
    }
}

/// Row-wise mean column of a pixel set (NaN where a row has none), into `mean` (`n`: the
/// counts).
fn row_means(px: &[EdgePixel], h: usize, mean: &mut Vec<f64>, n: &mut Vec<u32>) {
    mean.clear();
    mean.resize(h, 0.0);
    n.clear();
    n.resize(h, 0);
    for e in px {
        mean[e.row as usize] += e.col32() as f64 / 32.0;
        n[e.row as usize] += 1;
    }
    for (s, &k) in mean.iter_mut().zip(n.iter()) {
        *s = if k > 0 { *s / k as f64 } else { f64::NAN };
    }
}

/// The buffers of [`refit_pair`], reused from pair to pair.
#[derive(Debug, Default)]
struct RefitScratch {
    skip: Vec<bool>,
    hints: Vec<u32>,
    lpx: Vec<EdgePixel>,
    rpx: Vec<EdgePixel>,
    lk: Vec<EdgePixel>,
    rk: Vec<EdgePixel>,
    lnext: Vec<EdgePixel>,
    rnext: Vec<EdgePixel>,
    /// The pixels a step dropped and took in ([`diff`]).
    gone: Vec<EdgePixel>,
    came: Vec<EdgePixel>,
    rows: Vec<f64>,
    cols: Vec<f64>,
    ml: Vec<f64>,
    mr: Vec<f64>,
    count: Vec<u32>,
    widths: Vec<f64>,
    near_l: Vec<bool>,
    near_r: Vec<bool>,
}

/// An edge's clean majority (step 2 of [`refit_pair`]): the pixels within 0.75 px of a RANSAC
/// curve (the frame's curvature, else the track's), all of them without one; into `out`.
#[allow(clippy::too_many_arguments)]
fn clean_majority(
    px: &[EdgePixel],
    t: &Track,
    q_frame: Option<f64>,
    p: &Params,
    rows: &mut Vec<f64>,
    cols: &mut Vec<f64>,
    out: &mut Vec<EdgePixel>,
) {
    let h = p.height;
    let q = q_frame.unwrap_or(t.curve.q);
    let red = |e: &EdgePixel| {
        let u = 2.0 * e.row as f64 - (h as f64 - 1.0);
        e.col32() as f64 / 32.0 - q * u * u
    };
    out.clear();
    match ransac(px, q, 0.75, p, rows, cols) {
        Some((r0, c0, slope)) => out.extend(
            px.iter()
                .filter(|e| (red(e) - c0 - slope * (e.row as f64 - r0)).abs() <= 0.75),
        ),
        None => out.extend_from_slice(px),
    }
}

/// Re-fits a ring candidate's two edges from the frame's pixels (`None` when the frame's edge
/// pixels are not available or too little is left):
///
/// 1. the pixels of each edge's polarity within 1.5 px of its track's curve, rows marked in
///    `skip` (saturated) left out: the edge's pixels, whatever component they ended up in;
/// 2. each edge's clean majority: a RANSAC curve (the frame's curvature, else the track's) and
///    its pixels within 0.75 px; then, twice, the two edges fitted together as parallel curves
///    ([`PairFit`]) and the gathered pixels within 0.75 px of them kept (pixels that only
///    crossed an edge drop out);
/// 3. rows where the ring's width departs from its median by more than max(0.35 px, 4 robust
///    σ) left out, both edges: a ring is equally wide everywhere, a scratch or speck running
///    along an edge or into the ring is not;
/// 4. rows where another edge at least 15 % as strong lies within 6 px of a ring edge left out
///    for that edge: the opening, the 5×5 blur and Sobel pull an edge's profile toward a
///    neighbour that close;
/// 5. the joint fit of what is left.
pub fn refit_pair(
    l: &Track,
    r: &Track,
    edges: &mut EdgeList,
    skip: &[bool],
    q_frame: Option<f64>,
    p: &Params,
) -> Option<PairFit> {
    refit_pair_with(l, r, edges, skip, q_frame, p, &mut RefitScratch::default())
}

/// [`refit_pair`] with buffers reused from pair to pair.
fn refit_pair_with(
    l: &Track,
    r: &Track,
    edges: &mut EdgeList,
    skip_in: &[bool],
    q_frame: Option<f64>,
    p: &Params,
    s: &mut RefitScratch,
) -> Option<PairFit> {
    let h = p.height;
    let edges = edges.rows()?;
    let skip = &mut s.skip;
    skip.clear();
    skip.extend_from_slice(skip_in);
    skip.resize(h, false);
    // 1. Gather.
    s.hints.clear();
    s.hints.resize(h, 0);
    s.lpx.clear();
    s.rpx.clear();
    gather(
        &l.curve,
        &r.curve,
        1.5,
        &edges,
        skip,
        h,
        &mut s.lpx,
        &mut s.rpx,
        &mut s.hints,
    );
    let col = |e: &EdgePixel| e.col32() as f64 / 32.0;
    // 2. Clean majorities, then the joint parallel curves.
    let (lpx, rpx) = (&s.lpx, &s.rpx);
    let (lk, rk) = (&mut s.lk, &mut s.rk);
    clean_majority(lpx, l, q_frame, p, &mut s.rows, &mut s.cols, lk);
    clean_majority(rpx, r, q_frame, p, &mut s.rows, &mut s.cols, rk);
    // The sums of `lk` and `rk` as they stand and their free joint fit, when known: a step
    // that keeps every pixel of an edge keeps that edge's sums (the same pixels give the same
    // sums), and one that keeps both keeps the fit (the same sums give the same fit); a step
    // that changes an edge's pixels changes its sums by those of the pixels it dropped and
    // took in ([`resum`]: every kept set is a subset of the gathered pixels, in raster order).
    let (mut lsum, mut rsum): (Option<Component>, Option<Component>) = (None, None);
    let mut fit: Option<PairFit> = None;
    let (ln, rn) = (&mut s.lnext, &mut s.rnext);
    let (gone, came) = (&mut s.gone, &mut s.came);
    let w = p.width;
    for _ in 0..2 {
        let f = match fit.take() {
            Some(f) => f,
            None => fit_kept(lk, rk, &mut lsum, &mut rsum, h, w)?,
        };
        let near =
            |e: &EdgePixel, right: bool| (col(e) - f.at(right, e.row as f64, h)).abs() <= 0.75;
        ln.clear();
        ln.extend(lpx.iter().filter(|e| near(e, false)));
        rn.clear();
        rn.extend(rpx.iter().filter(|e| near(e, true)));
        let l_same = diff(lk, ln, gone, came);
        if !l_same {
            lsum = lsum.map(|c| resum(&c, gone, came, ln, w));
        }
        let r_same = diff(rk, rn, gone, came);
        if !r_same {
            rsum = rsum.map(|c| resum(&c, gone, came, rn, w));
        }
        if l_same && r_same {
            fit = Some(f);
        }
        std::mem::swap(lk, ln);
        std::mem::swap(rk, rn);
    }
    // 3. Rows where the ring is not its own width.
    let (ml, mr) = (&mut s.ml, &mut s.mr);
    row_means(lk, h, ml, &mut s.count);
    row_means(rk, h, mr, &mut s.count);
    let widths = &mut s.widths;
    widths.clear();
    widths.extend((0..h).map(|y| mr[y] - ml[y]).filter(|w| w.is_finite()));
    if widths.is_empty() {
        return None;
    }
    // The median of the widths, then of their deviations from it (in the same buffer: the
    // widths are not needed once their median is known).
    let w0 = median(widths);
    for w in widths.iter_mut() {
        *w = (*w - w0).abs();
    }
    let thr = (4.0 * 1.4826 * median(widths)).max(0.35);
    for y in 0..h {
        let w = mr[y] - ml[y];
        if w.is_finite() && (w - w0).abs() > thr {
            skip[y] = true;
        }
    }
    retain_summed(lk, |e| !skip[e.row as usize], &mut lsum, &mut fit, gone, w);
    retain_summed(rk, |e| !skip[e.row as usize], &mut rsum, &mut fit, gone, w);
    // 4. Rows where another edge is close enough to pull a ring edge.
    let f = match fit {
        Some(f) => f,
        None => fit_kept(lk, rk, &mut lsum, &mut rsum, h, w)?,
    };
    let g = |c: &Component| c.sum_mag as f64 / c.pos_n.max(1) as f64;
    let (gl, gr) = (g(&f.left), g(&f.right));
    let (near_l, near_r) = (&mut s.near_l, &mut s.near_r);
    near_l.clear();
    near_l.resize(h, false);
    near_r.clear();
    near_r.resize(h, false);
    let reach = NEIGHBOUR_REACH_PX;
    for y in 0..h {
        let (xl, xr) = (f.at(false, y as f64, h), f.at(true, y as f64, h));
        let half = 0.5 * (xr - xl);
        let row = edges.row(y);
        let lo = partition_near(row, s.hints[y] as usize, |e| {
            (e.col as f64) < xl - reach - 1.0
        });
        for e in &row[lo..] {
            let x = col(e);
            if x > xr + reach {
                break;
            }
            let (dl, dr) = (x - xl, x - xr);
            let m = e.mag as f64;
            if dl.abs() > 1.5 && dl.abs() <= reach && dl < half && m >= NEIGHBOUR_FRACTION * gl {
                near_l[y] = true;
            }
            if dr.abs() > 1.5 && dr.abs() <= reach && dr > -half && m >= NEIGHBOUR_FRACTION * gr {
                near_r[y] = true;
            }
        }
    }
    let mut fit = Some(f);
    retain_summed(
        lk,
        |e| !near_l[e.row as usize],
        &mut lsum,
        &mut fit,
        gone,
        w,
    );
    retain_summed(
        rk,
        |e| !near_r[e.row as usize],
        &mut rsum,
        &mut fit,
        gone,
        w,
    );
    // 5. The fit, with the ring's own curvature: a circle of the optics' radius whose tangent
    // has the fitted slope s bends by (1 + s²)^{3/2}/radius per row² (its sign from the free
    // fit, else from the frame's concentric edges). A free curvature would have to be pinned
    // by the data, and with rows missing at one end the extrapolated mean would follow its
    // error; with every row present c does not depend on it.
    let free = match fit {
        Some(f) => f,
        None => fit_kept(lk, rk, &mut lsum, &mut rsum, h, w)?,
    };
    let slope = 2.0 * free.b;
    let q_mag = (1.0 + slope * slope).powf(1.5) / (8.0 * p.ring_radius_px);
    let sign = if (free.q.abs() - q_mag).abs() <= 0.5 * q_mag {
        Some(free.q.signum())
    } else {
        q_frame.filter(|q| q.abs() > 0.5 * q_mag).map(f64::signum)
    };
    let mut f = match sign {
        // The same pixels as the free fit's: its sums.
        Some(sg) => fit_sums(free.left, free.right, h, Some(sg * q_mag))?,
        None => free,
    };
    if f.left.row_span() < p.min_fragment_rows || f.right.row_span() < p.min_fragment_rows {
        return None;
    }
    // The row means of step 3 hold for every row steps 3 and 4 kept (the same pixels, in the
    // same order); a dropped row has none (NaN, as `row_means` marks a row without pixels). A
    // row has pixels exactly when its mean is a number.
    for y in 0..h {
        if skip[y] || near_l[y] {
            ml[y] = f64::NAN;
        }
        if skip[y] || near_r[y] {
            mr[y] = f64::NAN;
        }
    }
    f.left_rows = ml.iter().map(|m| m.is_finite()).collect();
    f.right_rows = mr.iter().map(|m| m.is_finite()).collect();
    f.width_change_px = width_change(ml, mr, h);
    Some(f)
}

/// The joint fit of two edges' sums ([`joint_fit`]) as a [`PairFit`] (rows and width change
/// not yet filled in).
fn fit_sums(l: Component, r: Component, h: usize, q_fixed: Option<f64>) -> Option<PairFit> {
    let (a_left, a_right, b, q, c_sigma_px) = joint_fit(&l, &r, h, q_fixed)?;
    Some(PairFit {
        left: l,
        right: r,
        left_rows: Vec::new(),
        right_rows: Vec::new(),
        a_left,
        a_right,
        b,
        q,
        c_sigma_px,
        width_change_px: 0.0,
    })
}

/// The free joint fit of two edges' kept pixels, from their sums: known sums (`lsum`, `rsum`)
/// reused, the others summed and kept.
fn fit_kept(
    lk: &[EdgePixel],
    rk: &[EdgePixel],
    lsum: &mut Option<Component>,
    rsum: &mut Option<Component>,
    h: usize,
    w: usize,
) -> Option<PairFit> {
    let l = *lsum.get_or_insert_with(|| component_of(lk, w));
    let r = *rsum.get_or_insert_with(|| component_of(rk, w));
    fit_sums(l, r, h, None)
}

/// Keeps the pixels of an edge's kept set `k` that `keep` accepts. When some are dropped, its
/// sums `sum` (when known) follow by those of the dropped pixels ([`resum`]) and the joint
/// `fit` is no longer known.
fn retain_summed(
    k: &mut Vec<EdgePixel>,
    keep: impl Fn(&EdgePixel) -> bool,
    sum: &mut Option<Component>,
    fit: &mut Option<PairFit>,
    gone: &mut Vec<EdgePixel>,
    w: usize,
) {
    gone.clear();
    k.retain(|e| {
        let kept = keep(e);
        if !kept {
            gone.push(*e);
        }
        kept
    });
    if !gone.is_empty() {
        *sum = sum.map(|c| resum(&c, gone, &[], k, w));
        *fit = None;
    }
}

/// Range over the window of a parabola fitted to the row-wise widths `right − left`, px.
fn width_change(ml: &[f64], mr: &[f64], h: usize) -> f64 {
    let (mut m, mut v) = ([[0.0; 3]; 3], [0.0; 3]);
    for y in 0..h {
        let w = mr[y] - ml[y];
        if !w.is_finite() {
            continue;
        }
        let u = (2.0 * y as f64 - (h as f64 - 1.0)) / h as f64;
        let x = [1.0, u, u * u];
        for i in 0..3 {
            v[i] += x[i] * w;
            for j in 0..3 {
                m[i][j] += x[i] * x[j];
            }
        }
    }
    let Some([_, b, q]) = solve_n(m, v) else {
        return f64::INFINITY;
    };
    // Extremes of b·u + q·u² on [−1, 1]: the ends and the vertex.
    let f = |u: f64| b * u + q * u * u;
    let mut vals = [f(-1.0), f(1.0), 0.0];
    let mut n = 2;
    if q != 0.0 {
        let uv = -b / (2.0 * q);
        if uv.abs() <= 1.0 {
            vals[2] = f(uv);
            n = 3;
        }
    }
    let (lo, hi) = vals[..n]
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, z), &x| (a.min(x), z.max(x)));
    hi - lo
}

/// Tracks from the frame's candidate components: fragments of one polarity linked top to bottom.
pub fn tracks(cands: &[Component], edges: &mut EdgeList, p: &Params) -> (Vec<Track>, Option<f64>) {
    tracks_with(cands, edges, p, &mut Scratch::default())
}

/// [`tracks`] with the selection's buffers.
fn tracks_with(
    cands: &[Component],
    edges: &mut EdgeList,
    p: &Params,
    s: &mut Scratch,
) -> (Vec<Track>, Option<f64>) {
    let h = p.height;
    let (frags, q) = fragments(cands, edges, p, s);
    // Without the frame's curvature, pieces are straight: allow for the ring's own bending
    // (1/radius) over the distance a piece is extrapolated.
    let bend = if q.is_some() {
        0.0
    } else {
        0.5 / p.ring_radius_px
    };
    // Top to bottom, ties by the unique first pixel: the same order whatever the input order
    // (a stable sort of indices: the fragments themselves are not moved).
    let mut order: Vec<u32> = (0..frags.len() as u32).collect();
    order.sort_by_key(|&k| {
        let c = &frags[k as usize].comp;
        (c.min_row, c.first_index)
    });
    let mut out: Vec<Track> = Vec::with_capacity(frags.len());
    // What the scan below reads of each track, one list per polarity (rising, falling), each
    // in the order the tracks started: most tracks are rejected on their last row alone,
    // without touching the tracks themselves.
    let mut open: [Vec<Link>; 2] = Default::default();
    for &k in &order {
        let f = &frags[k as usize];
        let f_first = f.comp.min_row as f64;
        let f_mean = f.comp.sum_row as f64 / f.comp.pos_n.max(1) as f64;
        let f_at_first = f.curve.at(f_first, h);
        let links = &mut open[usize::from(f.polarity != 1)];
        // (position in `links`, distance)
        let mut best: Option<(usize, f64)> = None;
        for (j, l) in links.iter().enumerate() {
            if l.last > f.comp.min_row + 12 {
                continue;
            }
            // Where they meet: the track continued down to the fragment's first row, and the
            // fragment continued up to the track's last row.
            let t_last = l.last as f64;
            let gap = (f_first - t_last).max(0.0);
            let reach = (f_first - l.mean).max(f_mean - t_last);
            let tol = 1.5 + 0.01 * gap + bend * reach * reach;
            let d1 = (l.curve.at(f_first, h) - f_at_first).abs();
            let d2 = (l.at_last - f.curve.at(t_last, h)).abs();
            let d = d1.max(d2);
            if d <= tol && best.is_none_or(|(_, bd)| d < bd) {
                best = Some((j, d));
            }
        }
        match best {
            Some((j, _)) => {
                let i = links[j].track;
                out[i].absorb(f, h, q);
                links[j] = Link::of(&out[i], i, h);
            }
            None => {
                out.push(Track::start(f));
                links.push(Link::of(&out[out.len() - 1], out.len() - 1, h));
            }
        }
    }
    (out, q)
}

/// What the linking scan of [`tracks_with`] reads of a track, kept apart from it: its index,
/// last row, mean row, curve and the curve's column at the last row (the same values the
/// scan would compute from the track).
#[derive(Debug, Clone, Copy)]
struct Link {
    track: usize,
    last: u32,
    mean: f64,
    curve: Curve,
    at_last: f64,
}

impl Link {
    fn of(t: &Track, track: usize, h: usize) -> Link {
        let last = t.last_row();
        Link {
            track,
            last,
            mean: t.mean_row(),
            curve: t.curve,
            at_last: t.curve.at(last as f64, h),
        }
    }
}

/// A ring candidate: a rising track and a falling track to its right, with both edges
/// re-fitted from their own pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Index of the left (rising) track.
    pub left: usize,
    /// Index of the right (falling) track.
    pub right: usize,
    /// Both edges re-fitted together from their own pixels.
    pub fit: PairFit,
    /// Mean separation over the shared rows, px.
    pub separation_px: f64,
    /// Rows where both edges have pixels after the refit.
    pub shared_rows: u32,
    /// The weaker edge's mean gradient.
    pub gradient: f64,
    /// The weaker edge's strong-pixel share.
    pub strong_share: f64,
    /// The weaker edge's gradient over the stronger's.
    pub balance: f64,
    /// Score, 0 … 1.
    pub score: f64,
    /// The candidate's c (mean of the two curves over the window), px.
    pub c_px: f64,
}

/// The selection's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// The tracks of the frame.
    pub tracks: Vec<Track>,
    /// The best candidate, if any.
    pub best: Option<Candidate>,
    /// Its margin over the runner-up, 0 … 1.
    pub margin: Option<f64>,
    /// Why there is no usable candidate (or why it is not trusted).
    pub reason: Option<InvalidReason>,
}

/// Window-mean column of a curve: its mean over the window's rows, px.
pub fn window_mean(c: &Curve, height: usize) -> f64 {
    let mean_u2 = ((height * height) as f64 - 1.0) / 3.0;
    c.a + c.q * mean_u2
}

/// First, last and count of the rows where both edges have pixels.
fn rows_in_both(a: &Component, b: &Component, pa: &[bool], pb: &[bool]) -> (u32, u32, u32) {
    let lo = a.min_row.max(b.min_row) as usize;
    let hi = a.max_row.min(b.max_row) as usize;
    let (mut n, mut first, mut last) = (0, u32::MAX, 0);
    for y in lo..=hi.min(pa.len().saturating_sub(1)) {
        if pa[y] && pb[y] {
            n += 1;
            first = first.min(y as u32);
            last = y as u32;
        }
    }
    (first, last, n)
}

thread_local! {
    /// The selection's buffers ([`Scratch`], [`RefitScratch`]), kept from frame to frame on
    /// each thread: every use clears them first, only their capacity carries over (no
    /// allocations to grow them again every frame).
    static BUFFERS: std::cell::Cell<(Scratch, RefitScratch)> = Default::default();
}

/// Chooses the ring among the frame's candidate components (see the module documentation);
/// `edges` holds the frame's edge pixels for the robust steps (an incomplete list disables them:
/// contaminated components are then dropped), `saturated` the frame's saturated runs.
pub fn select(
    cands: &[Component],
    edges: &mut EdgeList,
    saturated: &[SaturatedRun],
    p: &Params,
) -> Selection {
    let h = p.height;
    let (mut scratch, mut refit_scratch) = BUFFERS.take();
    let (tracks, q_frame) = tracks_with(cands, edges, p, &mut scratch);
    // Each track's rows as disjoint intervals in row order (`spans[span_of[k].0..span_of[k].1]`),
    // once: every pair and the interior check intersect them without sorting.
    let mut spans: Vec<(u32, u32)> = Vec::new();
    let mut span_of: Vec<(usize, usize)> = Vec::with_capacity(tracks.len());
    for t in &tracks {
        let a = spans.len();
        spans.extend(merged(&t.rows));
        span_of.push((a, spans.len()));
    }
    let rows_of = |k: usize| &spans[span_of[k].0..span_of[k].1];
    let mut skip: Vec<bool> = Vec::new();
    let long: Vec<usize> = (0..tracks.len())
        .filter(|&i| 2 * tracks[i].coverage as usize >= p.min_edge_pixels)
        .collect();
    let d = p.baseline_width_px as f64;
    let (sep_lo, sep_hi) = p.separation_px;
    let mut pairs: Vec<Candidate> = Vec::new();
    // Each candidate's edge curves (`curve` of its refitted edges), computed once.
    let mut pair_curves: Vec<(Curve, Curve)> = Vec::new();
    let mut clipped_out = false;
    let mut coarse_found = false;
    let mut at_side = false;
    for &i in &long {
        let l = &tracks[i];
        if l.polarity != 1 {
            continue;
        }
        for &j in &long {
            let r = &tracks[j];
            if r.polarity != -1 {
                continue;
            }
            // The rows both cover lie within the overlap of their row ranges: without enough
            // of that, no need to intersect their fragments' rows.
            let hull = (l.comp.max_row.min(r.comp.max_row) + 1)
                .saturating_sub(l.comp.min_row.max(r.comp.min_row));
            if 2 * (hull as usize) < p.min_edge_pixels {
                continue;
            }
            // Coarse: the tracks as linked (their curves may still carry a crossing's pull).
            let (n, first, last) = shared(rows_of(i), rows_of(j));
            if 2 * (n as usize) < p.min_edge_pixels {
                continue;
            }
            let (y0, y1) = (first as f64, last as f64);
            let sep0 = r.curve.at(y0, h) - l.curve.at(y0, h);
            let sep1 = r.curve.at(y1, h) - l.curve.at(y1, h);
            let sepm = r.curve.at(0.5 * (y0 + y1), h) - l.curve.at(0.5 * (y0 + y1), h);
            if sepm < sep_lo - 1.0
                || sepm > sep_hi + 1.0
                || (sep1 - sep0).abs() > 3.0 * p.parallel_px
                || l.gradient.min(r.gradient) < 0.4 * l.gradient.max(r.gradient)
            {
                continue;
            }
            // Rows where saturation reaches the ring or its edges' profiles are left out.
            skip.clear();
            skip.resize(h, false);
            for s in saturated {
                let y = s.row as f64;
                let (a, b) = (l.curve.at(y, h) - 3.0, r.curve.at(y, h) + 3.0);
                if (s.last as f64) >= a && (s.first as f64) <= b {
                    skip[s.row as usize] = true;
                }
            }
            if h - skip.iter().filter(|&&c| c).count() < p.min_edge_pixels {
                clipped_out = true;
                continue;
            }
            // Fine: both edges from their own pixels (without the frame's pixels: the tracks'
            // sums, which only clean fragments make).
            let fit = if edges.pixels().is_some() {
                refit_pair_with(l, r, edges, &skip, q_frame, p, &mut refit_scratch)
            } else {
                let rows = |t: &Track| {
                    let mut v = vec![false; h];
                    for &(a, b) in &t.rows {
                        for y in a..=b {
                            v[y as usize] = !skip[y as usize];
                        }
                    }
                    v
                };
                joint_fit(&l.comp, &r.comp, h, None).map(|(a_left, a_right, b, q, c_sigma_px)| {
                    PairFit {
                        left: l.comp,
                        right: r.comp,
                        left_rows: rows(l),
                        right_rows: rows(r),
                        a_left,
                        a_right,
                        b,
                        q,
                        c_sigma_px,
                        width_change_px: 0.0,
                    }
                })
            };
            let Some(fit) = fit else {
                continue;
            };
            let (lc, rc) = (fit.left, fit.right);
            let (Some(lcv), Some(rcv)) = (curve(&lc, h), curve(&rc, h)) else {
                continue;
            };
            // The refit leaves out rows where something else touches the ring; what is left
            // must still hold the ring on a good part of the window (with the ring's own
            // curvature, c needs no more).
            if (sep_lo..=sep_hi).contains(&sepm) {
                coarse_found = true;
                let side = |c: &Component| c.min_col <= 1 || c.max_col as usize + 2 >= p.width;
                at_side |= side(&l.comp) || side(&r.comp);
            }
            let (first, last, n) = rows_in_both(&lc, &rc, &fit.left_rows, &fit.right_rows);
            if 5 * (n as usize) < 3 * p.min_edge_pixels {
                continue;
            }
            let rows = [first as f64, 0.5 * (first + last) as f64, last as f64];
            let seps = rows.map(|y| rcv.at(y, h) - lcv.at(y, h));
            let (smin, smax) = seps
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &s| (a.min(s), b.max(s)));
            if smin < sep_lo || smax > sep_hi || smax - smin > p.parallel_px {
                continue;
            }
            let gl = lc.sum_mag as f64 / lc.pos_n.max(1) as f64;
            let gr = rc.sum_mag as f64 / rc.pos_n.max(1) as f64;
            let (g_lo, g_hi) = (gl.min(gr), gl.max(gr));
            if g_lo < 0.5 * g_hi {
                continue;
            }
            let share = |c: &Component| c.strong as f64 / c.pixels.max(1) as f64;
            pair_curves.push((lcv, rcv));
            pairs.push(Candidate {
                left: i,
                right: j,
                separation_px: fit.a_right - fit.a_left,
                shared_rows: n,
                gradient: g_lo,
                strong_share: share(&lc).min(share(&rc)),
                balance: g_lo / g_hi,
                score: 0.0,
                c_px: fit.c_px(h),
                fit,
            });
        }
    }
    BUFFERS.set((scratch, refit_scratch));
    // A ring's inside is flat: drop candidates with a track as strong as their edges running
    // between them, parallel to them, over 30 % of their shared rows (two neighbouring lines,
    // not a ring). A scratch crossing the ring at an angle does not count.
    let mut curves = pair_curves.iter();
    pairs.retain(|c| {
        let &(lcv, rcv) = curves.next().expect("one pair of curves per candidate");
        let lrows = [(c.fit.left.min_row, c.fit.left.max_row)];
        !tracks.iter().enumerate().any(|(k, t)| {
            if k == c.left || k == c.right || t.gradient < p.interior_fraction * c.gradient {
                return false;
            }
            let (n, first, last) = shared(rows_of(k), &lrows);
            if (n as f64) < 0.3 * c.shared_rows as f64 {
                return false;
            }
            let (y0, y1) = (first as f64, last as f64);
            let drift = (t.curve.at(y1, h) - lcv.at(y1, h)) - (t.curve.at(y0, h) - lcv.at(y0, h));
            if drift.abs() > 2.0 * p.parallel_px {
                return false;
            }
            let y = 0.5 * (y0 + y1);
            let x = t.curve.at(y, h);
            x > lcv.at(y, h) + 1.5 && x < rcv.at(y, h) - 1.5
        })
    });
    // Frame-relative strength: against the strongest candidate.
    let g_top = pairs.iter().map(|c| c.gradient).fold(0.0, f64::max);
    for c in pairs.iter_mut() {
        let strength = (c.gradient / g_top) * (0.5 + 0.5 * c.strong_share);
        let coverage = c.shared_rows as f64 / h as f64;
        let x = (c.separation_px - d) / (p.width_tolerance * d);
        let width = (1.0 - 0.5 * x * x).max(0.0);
        c.score = strength * coverage.min(1.0) * width * c.balance;
    }
    pairs.sort_by(|a, b| {
        b.score
            .total_cmp(&a.score)
            .then(a.fit.left.first_index.cmp(&b.fit.left.first_index))
            .then(a.fit.right.first_index.cmp(&b.fit.right.first_index))
    });
    let best = pairs.first().cloned();
    let mut reason = None;
    let margin = best.as_ref().map(|b| {
        let runner = pairs
            .iter()
            .skip(1)
            .filter(|c| (c.c_px - b.c_px).abs() > d / 2.0)
            .map(|c| c.score)
            .next()
            .unwrap_or(0.0);
        if b.score > 0.0 {
            (1.0 - runner / b.score).clamp(0.0, 1.0)
        } else {
            0.0
        }
    });
    if margin.is_some_and(|m| m < p.min_margin) {
        reason = Some(InvalidReason::Ambiguous);
    }
    if best.is_none() {
        reason = Some(if clipped_out {
            InvalidReason::Saturated
        } else if at_side {
            InvalidReason::RingOutsideWindow
        } else if coarse_found {
            // Edges that look like the ring's, but not once re-fitted from their own pixels.
            InvalidReason::InconsistentEdges
        } else {
            no_candidate_reason(&tracks, &long, p)
        });
    }
    Selection {
        tracks,
        best,
        margin,
        reason,
    }
}

/// Why no candidate: a lone edge whose partner would lie beyond the window's side, one long
/// edge, two that are not a ring's, or none that fits the model at all.
fn no_candidate_reason(tracks: &[Track], long: &[usize], p: &Params) -> InvalidReason {
    let h = p.height;
    let reach = p.separation_px.1 + 2.0;
    let w = p.width as f64;
    let beyond_side = long.iter().any(|&i| {
        let t = &tracks[i];
        let c = window_mean(&t.curve, h);
        (t.polarity == 1 && c + reach > w - 1.0) || (t.polarity == -1 && c - reach < 0.0)
    });
    if beyond_side {
        return InvalidReason::RingOutsideWindow;
    }
    match long.len() {
        0 => InvalidReason::NoRing,
        1 => InvalidReason::OneEdge,
        2 => InvalidReason::InconsistentEdges,
        _ => InvalidReason::NoRing,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift) for the interval and search cases.
    fn next(s: &mut u64) -> u64 {
        *s ^= *s << 13;
        *s ^= *s >> 7;
        *s ^= *s << 17;
        *s
    }

    /// Intervals in order of their first rows, as a track's fragments come (overlapping,
    /// adjacent, nested, equal starts).
    fn intervals(s: &mut u64) -> Vec<(u32, u32)> {
        let n = (next(s) % 8) as usize;
        let mut a = (next(s) % 20) as u32;
        let mut v = Vec::new();
        for _ in 0..n {
            a += (next(s) % 12) as u32;
            v.push((a, a + (next(s) % 15) as u32));
        }
        v
    }

    fn rows(iv: &[(u32, u32)]) -> std::collections::BTreeSet<u32> {
        iv.iter().flat_map(|&(a, b)| a..=b).collect()
    }

    #[test]
    fn shared_rows_match_the_row_sets() {
        // Against the rows as sets: the union's size, and the intersection's size, first and
        // last row. A wrong merge of adjacent or nested intervals changes one of them.
        let mut s = 0x9e37_79b9_7f4a_7c15;
        for _ in 0..5000 {
            let (a, b) = (intervals(&mut s), intervals(&mut s));
            let (ra, rb) = (rows(&a), rows(&b));
            assert_eq!(union_len(&a) as usize, ra.len(), "{a:?}");
            let (ma, mb): (Vec<_>, Vec<_>) = (merged(&a).collect(), merged(&b).collect());
            assert!(ma.windows(2).all(|w| w[0].1 + 1 < w[1].0), "{ma:?}");
            let both: Vec<u32> = ra.intersection(&rb).copied().collect();
            let want = match (both.first(), both.last()) {
                (Some(&f), Some(&l)) => (both.len() as u32, f, l),
                _ => (0, 0, 0),
            };
            assert_eq!(shared(&ma, &mb), want, "{a:?} {b:?}");
        }
    }

    #[test]
    fn sums_from_the_change_are_the_sums_of_the_new_set() {
        // Random pixel lists in raster order (strong and weak, filled ones without a position,
        // both polarities) and random subsets of them: the sums carried over from one subset to
        // another by what `diff` says went and came equal `component_of` of the new subset, in
        // every field (a sign slip or a forgotten field in `resum` fails this).
        use crate::segment::{FILLED, STRONG, WEAK};
        let mut s = 0x5851_f42d_4c95_7f2d;
        let w = 1440;
        for _ in 0..400 {
            let mut all = Vec::new();
            let (mut row, mut col) = (next(&mut s) % 500, 0u64);
            for _ in 0..(next(&mut s) % 120) {
                col += 1 + next(&mut s) % 40;
                if col >= w as u64 {
                    row += 1 + next(&mut s) % 3;
                    col %= 40;
                }
                let r = next(&mut s);
                all.push(EdgePixel {
                    row: row as u16,
                    col: col as u16,
                    class: if r.is_multiple_of(3) { STRONG } else { WEAK },
                    dir: (r >> 8) as u8,
                    sub: if r.is_multiple_of(11) {
                        FILLED
                    } else {
                        (r >> 16) as i8 % 16
                    },
                    mag: (r >> 24) as u16,
                    comp: 0,
                });
            }
            // The old subset, then the new one with each pixel's membership flipped with a
            // probability of 1/2 to 1/64: changes small (summed from the change) and large
            // (summed afresh).
            let keep = 1 + next(&mut s) % 8;
            let was: Vec<bool> = all.iter().map(|_| next(&mut s) % 8 < keep).collect();
            let flip = 2 << (next(&mut s) % 6);
            let is: Vec<bool> = was
                .iter()
                .map(|&k| k ^ next(&mut s).is_multiple_of(flip))
                .collect();
            let pick = |m: &[bool]| -> Vec<EdgePixel> {
                all.iter().zip(m).filter(|x| *x.1).map(|x| *x.0).collect()
            };
            let (old, new) = (pick(&was), pick(&is));
            let (mut gone, mut came) = (Vec::new(), Vec::new());
            let same = diff(&old, &new, &mut gone, &mut came);
            assert_eq!(same, old == new);
            let want = component_of(&new, w);
            let got = resum(&component_of(&old, w), &gone, &came, &new, w);
            assert_eq!(got, want, "{} -> {} pixels", old.len(), new.len());
            // A pure removal, as the refit's row drops make.
            let kept: Vec<EdgePixel> = old.iter().filter(|e| e.row % 2 == 0).copied().collect();
            diff(&old, &kept, &mut gone, &mut came);
            assert!(came.is_empty());
            let got = resum(&component_of(&old, w), &gone, &[], &kept, w);
            assert_eq!(got, component_of(&kept, w));
        }
    }

    #[test]
    fn skipped_ransac_tries_change_no_line() {
        // Every try counted in full (no early stop, no skipped try) against `best_line`, on
        // small sets (repeated pairs of pixels), collinear ones (every pixel an inlier) and
        // scattered ones: the same line, bit for bit.
        fn every_try(
            rows: &[f64],
            cols: &[f64],
            min_rows: f64,
            tan: f64,
            gate: f64,
        ) -> Option<(f64, f64, f64)> {
            let (n, half) = (rows.len(), rows.len() / 2);
            let mut best: Option<(usize, f64, f64, f64)> = None;
            for k in 0..48 {
                let ia = k * half / 48;
                let ib = half + ((k * 37) % 48) * (n - half) / 48;
                let dr = rows[ib] - rows[ia];
                if dr < min_rows {
                    continue;
                }
                let slope = (cols[ib] - cols[ia]) / dr;
                if slope.abs() > tan {
                    continue;
                }
                let (r0, c0) = (rows[ia], cols[ia]);
                let inl = rows
                    .iter()
                    .zip(cols)
                    .filter(|&(&r, &c)| (c - c0 - slope * (r - r0)).abs() <= gate)
                    .count();
                if best.is_none_or(|b| inl > b.0) {
                    best = Some((inl, r0, c0, slope));
                }
            }
            best.map(|(_, r0, c0, slope)| (r0, c0, slope))
        }
        let mut s = 0x1405_7b7e_f767_814f;
        for case in 0..3000 {
            let n = 2 + (next(&mut s) % 200) as usize;
            let scatter = [0.0, 0.3, 3.0][case % 3];
            let mut rows: Vec<f64> = (0..n).map(|_| (next(&mut s) % 540) as f64).collect();
            rows.sort_by(f64::total_cmp);
            let cols: Vec<f64> = rows
                .iter()
                .map(|&r| 700.0 + 0.05 * r + scatter * ((next(&mut s) % 1000) as f64 / 500.0 - 1.0))
                .collect();
            let want = every_try(&rows, &cols, 20.0, 0.2, 1.5);
            assert_eq!(best_line(&rows, &cols, 20.0, 0.2, 1.5), want, "case {case}");
        }
    }

    #[test]
    fn moments_in_i64_are_the_i128_ones() {
        // Wherever `fits_i64` lets the i64 path run, its integers equal the i128 expansion's:
        // random sums of either sign up to the bounds (each drawn near its top half the time,
        // with h up to 1023 and n up to 2¹⁹ − 1: the products the bounds were derived for; one
        // sum a case drawn up to four bits beyond its bound, for the guard to refuse), computed
        // with i64 overflow checks (a wrapped product panics). The bounds keep a bit or two of
        // slack; Σr, Σr³ or Σr⁴ loosened by four bits (e.g. Σr⁴ < 2⁵⁹) fails this.
        let mut s = 0x3c6e_f372_fe94_f82b;
        let mut draw = |bits: u32| -> i64 {
            let r = next(&mut s);
            let top = 1i64 << bits;
            let v = if r.is_multiple_of(2) {
                top - 1 - (r >> 40) as i64 % 1024
            } else {
                (r >> 1) as i64 % top
            };
            if r & 4 == 0 { v } else { -v }
        };
        let mut ran = 0;
        for case in 0..40_000u32 {
            let h = 1023 - draw(4).abs();
            let n = draw(19).abs();
            let loose = case % 16;
            let mut wide =
                |k: u32, bits: u32| draw(bits + u32::from(k == loose) * (1 + case / 16 % 4));
            let sums = [n, wide(1, 26), wide(2, 34), wide(3, 44), wide(4, 55)];
            let cs = [wide(5, 36), wide(6, 46), wide(7, 56)];
            if !fits_i64(h, &sums, &cs) {
                continue;
            }
            ran += 1;
            let want = expand(h as i128, sums.map(i128::from), cs.map(i128::from));
            let got = expand(Checked(h), sums.map(Checked), cs.map(Checked));
            assert_eq!(got.map(|v| v.0 as i128), want, "h {h} {sums:?} {cs:?}");
        }
        assert!(ran > 20_000, "{ran}");
        // And `moments` of a real component against the i128 expansion.
        let c = component_of(
            &[(3, 100, 5), (200, 101, -7), (539, 99, 0)].map(|(row, col, sub)| EdgePixel {
                row,
                col,
                class: crate::segment::STRONG,
                dir: 0,
                sub,
                mag: 9,
                comp: 0,
            }),
            1440,
        );
        let (u, v, _) = moments(&c, 540);
        let h = 539i128;
        let (s1, n) = (c.sum_row as i128, c.pos_n as i128);
        assert_eq!(u[1], (2 * s1 - h * n) as f64);
        let u4 = 16 * c.sum_row4 as i128 - 32 * h * c.sum_row3 as i128
            + 24 * h * h * c.sum_row2 as i128
            - 8 * h * h * h * s1
            + h * h * h * h * n;
        assert_eq!(u[4], u4 as f64);
        let v2 = 4 * c.sum_row2_col32 as i128 - 4 * h * c.sum_row_col32 as i128
            + h * h * c.sum_col32 as i128;
        assert_eq!(v[2], v2 as f64 / 32.0);
    }

    /// An i64 whose arithmetic panics on overflow (in every build profile).
    #[derive(Debug, Clone, Copy)]
    struct Checked(i64);

    impl From<i8> for Checked {
        fn from(v: i8) -> Self {
            Checked(v.into())
        }
    }
    impl std::ops::Add for Checked {
        type Output = Checked;
        fn add(self, o: Checked) -> Checked {
            Checked(self.0.checked_add(o.0).expect("i64 overflow"))
        }
    }
    impl std::ops::Sub for Checked {
        type Output = Checked;
        fn sub(self, o: Checked) -> Checked {
            Checked(self.0.checked_sub(o.0).expect("i64 overflow"))
        }
    }
    impl std::ops::Mul for Checked {
        type Output = Checked;
        fn mul(self, o: Checked) -> Checked {
            Checked(self.0.checked_mul(o.0).expect("i64 overflow"))
        }
    }

    #[test]
    fn partition_near_is_partition_point_for_every_hint() {
        let mut s = 0x2545_f491_4f6c_dd1d;
        for len in [0usize, 1, 2, 5, 31, 32, 33, 70, 200] {
            let mut v: Vec<u32> = (0..len).map(|_| (next(&mut s) % 300) as u32).collect();
            v.sort_unstable();
            for t in [0u32, 1, 17, 150, 299, 300, 400] {
                let pred = |x: &u32| *x < t;
                let want = v.partition_point(pred);
                for hint in 0..=len + 2 {
                    assert_eq!(
                        partition_near(&v, hint, pred),
                        want,
                        "len {len} t {t} hint {hint}"
                    );
                }
            }
        }
    }
}
