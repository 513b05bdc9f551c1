//! The pair fit: a ring candidate's two edges re-fitted from the frame's own edge pixels as
//! parallel curves, the pixels that stray from them dropped ([`refit_pair`]).

use super::line::{Curve, median, moments, ransac, solve_n};
use super::tracks::{Track, resum};
use crate::label::{Component, EdgeList, EdgePixel, EdgeRows, component_of};
use crate::optics::Params;

/// `v.partition_point(pred)` for a predicate true on a prefix of `v` (columns sorted), looked
/// for from `hint` (0, or the boundary on a neighbouring curve): a linear walk when it lies
/// near (a row holds ≈ 30 pixels on the `dense` frame: a walk streams through them, where a
/// binary search waits on one dependent load after another), a binary search of the rest when
/// not. The same index for any hint.
pub(super) fn partition_near<T>(v: &[T], hint: usize, pred: impl Fn(&T) -> bool) -> usize {
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
pub(super) fn gather_row(
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
pub(super) fn gather(
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

/// How far another edge can pull a ring edge's profile through the opening, the 5×5 blur and
/// Sobel, px.
pub(super) const NEIGHBOUR_REACH_PX: f64 = 6.0;
/// Neighbouring edge pixels weaker than this fraction of the ring edge's mean gradient are
/// ignored (noise).
pub(super) const NEIGHBOUR_FRACTION: f64 = 0.15;

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

/// The joint least-squares fit of two edges as parallel curves (see [`PairFit`]), with the
/// common curvature free or fixed to `q_fixed`: (a_L, a_R, b, q, standard uncertainty of c).
pub(super) fn joint_fit(
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

/// Row-wise column sums of a pixel set into `sum`, their counts into `n`.
fn row_sums(px: &[EdgePixel], h: usize, sum: &mut Vec<f64>, n: &mut Vec<u32>) {
    sum.clear();
    sum.resize(h, 0.0);
    n.clear();
    n.resize(h, 0);
    for e in px {
        sum[e.row as usize] += e.col32() as f64 / 32.0;
        n[e.row as usize] += 1;
    }
}

/// A row's mean from its sum and count (NaN where the row has none).
fn mean_of(s: f64, k: u32) -> f64 {
    if k > 0 { s / k as f64 } else { f64::NAN }
}

/// Row-wise mean column of a pixel set (NaN where a row has none), into `mean` (`n`: the
/// counts).
#[cfg(test)]
pub(super) fn row_means(px: &[EdgePixel], h: usize, mean: &mut Vec<f64>, n: &mut Vec<u32>) {
    row_sums(px, h, mean, n);
    for (s, &k) in mean.iter_mut().zip(n.iter()) {
        *s = mean_of(*s, k);
    }
}

/// Whether each pixel (column, u) lies within 0.75 px of the curve a + b·u + q·u², into `keep`
/// ([`PairFit::at`]'s expression, term by term).
pub(super) fn near_flags(pos: &[(f64, f64)], a: f64, b: f64, q: f64, keep: &mut Vec<bool>) {
    keep.clear();
    keep.extend(
        pos.iter()
            .map(|&(x, u)| (x - (a + b * u + q * u * u)).abs() <= 0.75),
    );
}

/// The pixels of `all` flagged in `is`, into `new`, and how they differ from those flagged in
/// `was`: the pixels flagged before and not now into `gone`, those flagged now and not before
/// into `came` (both in `all`'s order); true when nothing changed. The same lists as
/// filtering `all` both ways and comparing with [`diff`](super::tracks::diff), in one pass
/// over `all` whose steps do not wait on each other.
pub(super) fn filter_diff(
    all: &[EdgePixel],
    was: &[bool],
    is: &[bool],
    new: &mut Vec<EdgePixel>,
    gone: &mut Vec<EdgePixel>,
    came: &mut Vec<EdgePixel>,
) -> bool {
    new.clear();
    gone.clear();
    came.clear();
    for ((e, &was), &is) in all.iter().zip(was).zip(is) {
        if is {
            new.push(*e);
        }
        if was && !is {
            gone.push(*e);
        } else if is && !was {
            came.push(*e);
        }
    }
    gone.is_empty() && came.is_empty()
}

/// `row_means` of both edges (`ml`, `mr`), with the finite row-wise widths `mr − ml` in row
/// order into `widths`: the same values, one pass over the rows for both.
pub(super) fn row_widths(
    lk: &[EdgePixel],
    rk: &[EdgePixel],
    h: usize,
    (ml, mr): (&mut Vec<f64>, &mut Vec<f64>),
    (nl, nr): (&mut Vec<u32>, &mut Vec<u32>),
    widths: &mut Vec<f64>,
) {
    row_sums(lk, h, ml, nl);
    row_sums(rk, h, mr, nr);
    widths.clear();
    for y in 0..h {
        let (l, r) = (mean_of(ml[y], nl[y]), mean_of(mr[y], nr[y]));
        (ml[y], mr[y]) = (l, r);
        let w = r - l;
        if w.is_finite() {
            widths.push(w);
        }
    }
}

/// The buffers of [`refit_pair`], reused from pair to pair.
#[derive(Debug, Default)]
pub(super) struct RefitScratch {
    skip: Vec<bool>,
    hints: Vec<u32>,
    lpx: Vec<EdgePixel>,
    rpx: Vec<EdgePixel>,
    lk: Vec<EdgePixel>,
    rk: Vec<EdgePixel>,
    lnext: Vec<EdgePixel>,
    rnext: Vec<EdgePixel>,
    /// The pixels a step dropped and took in ([`diff`](super::tracks::diff)).
    gone: Vec<EdgePixel>,
    came: Vec<EdgePixel>,
    rows: Vec<f64>,
    cols: Vec<f64>,
    ml: Vec<f64>,
    mr: Vec<f64>,
    count: Vec<u32>,
    count_r: Vec<u32>,
    /// The gathered pixels' (column, u) and whether each is near its curve.
    lpos: Vec<(f64, f64)>,
    rpos: Vec<(f64, f64)>,
    keep: Vec<bool>,
    /// Whether each gathered pixel is in the kept set `lk` (`rk`).
    lin: Vec<bool>,
    rin: Vec<bool>,
    widths: Vec<f64>,
    near_l: Vec<bool>,
    near_r: Vec<bool>,
}

/// An edge's clean majority (step 2 of [`refit_pair`]): the pixels within 0.75 px of a RANSAC
/// curve (the frame's curvature, else the track's), all of them without one; into `out`, and
/// whether each pixel of `px` is one of them into `kept`.
#[allow(clippy::too_many_arguments)]
pub(super) fn clean_majority(
    px: &[EdgePixel],
    t: &Track,
    q_frame: Option<f64>,
    p: &Params,
    (rows, cols): (&mut Vec<f64>, &mut Vec<f64>),
    out: &mut Vec<EdgePixel>,
    kept: &mut Vec<bool>,
) {
    let q = q_frame.unwrap_or(t.curve.q);
    kept.clear();
    match ransac(px, q, 0.75, p, rows, cols) {
        // `rows` and `cols` hold each pixel's row and column reduced by q·u² (RANSAC's).
        Some((r0, c0, slope)) => kept.extend(
            rows.iter()
                .zip(cols.iter())
                .map(|(r, c)| (*c - c0 - slope * (*r - r0)).abs() <= 0.75),
        ),
        None => kept.resize(px.len(), true),
    }
    out.clear();
    out.extend(px.iter().zip(kept.iter()).filter(|x| *x.1).map(|x| *x.0));
}

/// Re-fits a ring candidate's two edges from the frame's pixels (`None` when the frame's edge
/// pixels are not available or too little is left):
///
/// 1. the pixels of each edge's polarity within 1.5 px of its track's curve, rows marked in
///    `skip` (saturated) left out: the edge's pixels, whatever component they ended up in;
/// 2. each edge's clean majority: a RANSAC curve (the frame's curvature, else the track's) and
///    its pixels within 0.75 px; then, twice (once when the first keeps the same pixels: the
///    second would too), the two edges fitted together as parallel curves
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
pub(super) fn refit_pair_with(
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
    let (lin, rin) = (&mut s.lin, &mut s.rin);
    clean_majority(lpx, l, q_frame, p, (&mut s.rows, &mut s.cols), lk, lin);
    clean_majority(rpx, r, q_frame, p, (&mut s.rows, &mut s.cols), rk, rin);
    // The sums of `lk` and `rk` as they stand and their free joint fit, when known: a step
    // that keeps every pixel of an edge keeps that edge's sums (the same pixels give the same
    // sums), and one that keeps both keeps the fit (the same sums give the same fit); a step
    // that changes an edge's pixels changes its sums by those of the pixels it dropped and
    // took in ([`resum`]: every kept set is a subset of the gathered pixels, in raster order).
    let (mut lsum, mut rsum): (Option<Component>, Option<Component>) = (None, None);
    let mut fit: Option<PairFit> = None;
    let (ln, rn) = (&mut s.lnext, &mut s.rnext);
    let (gone, came) = (&mut s.gone, &mut s.came);
    // Each gathered pixel's column and u, once: `PairFit::at`'s u, the same values.
    let (lpos, rpos, keep) = (&mut s.lpos, &mut s.rpos, &mut s.keep);
    for (px, pos) in [(lpx, &mut *lpos), (rpx, &mut *rpos)] {
        pos.clear();
        pos.extend(
            px.iter()
                .map(|e| (col(e), 2.0 * e.row as f64 - (h as f64 - 1.0))),
        );
    }
    let (lpos, rpos) = (&*lpos, &*rpos);
    let w = p.width;
    for _ in 0..2 {
        let f = match fit.take() {
            Some(f) => f,
            None => fit_kept(lk, rk, &mut lsum, &mut rsum, h, w)?,
        };
        near_flags(lpos, f.a_left, f.b, f.q, keep);
        let l_same = filter_diff(lpx, lin, keep, ln, gone, came);
        std::mem::swap(lin, keep);
        if !l_same {
            lsum = lsum.map(|c| resum(&c, gone, came, ln, w));
        }
        near_flags(rpos, f.a_right, f.b, f.q, keep);
        let r_same = filter_diff(rpx, rin, keep, rn, gone, came);
        std::mem::swap(rin, keep);
        if !r_same {
            rsum = rsum.map(|c| resum(&c, gone, came, rn, w));
        }
        std::mem::swap(lk, ln);
        std::mem::swap(rk, rn);
        if l_same && r_same {
            // Nothing changed: a second pass would find the same pixels near the same curves
            // (most frames: the clean majorities already are the pixels near the joint fit).
            fit = Some(f);
            break;
        }
    }
    // 3. Rows where the ring is not its own width.
    let (ml, mr) = (&mut s.ml, &mut s.mr);
    let widths = &mut s.widths;
    row_widths(lk, rk, h, (ml, mr), (&mut s.count, &mut s.count_r), widths);
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
    let (mut left_rows, mut right_rows) = (Vec::with_capacity(h), Vec::with_capacity(h));
    for y in 0..h {
        if skip[y] || near_l[y] {
            ml[y] = f64::NAN;
        }
        if skip[y] || near_r[y] {
            mr[y] = f64::NAN;
        }
        left_rows.push(ml[y].is_finite());
        right_rows.push(mr[y].is_finite());
    }
    (f.left_rows, f.right_rows) = (left_rows, right_rows);
    f.width_change_px = width_change(ml, mr, h);
    Some(f)
}

/// The joint fit of two edges' sums ([`joint_fit`]) as a [`PairFit`] (rows and width change
/// not yet filled in).
pub(super) fn fit_sums(
    l: Component,
    r: Component,
    h: usize,
    q_fixed: Option<f64>,
) -> Option<PairFit> {
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
pub(super) fn fit_kept(
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
pub(super) fn retain_summed(
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
pub(super) fn width_change(ml: &[f64], mr: &[f64], h: usize) -> f64 {
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
