//! Baseline features (Yu et al., 2024, §4, baseline-feature computation): the ring's two edges as
//! chosen by the ring's model ([`crate::select`]), their lines, the validity checks, c, the score
//! and margin of the choice, and why a frame is invalid.
//!
//! Each edge's column is fitted as a function of row (least squares on the sub-pixel edge
//! positions: a line for the reported slope, a parabola for c). c is the mean of the two edges'
//! fitted columns averaged over all the window's rows: with every row detected this is exactly the
//! seed's centroid column (the fit's residuals sum to zero), and it stays unbiased when a few
//! rows are missing from a slanted or curved edge. The plain centroid is reported too.

use crate::label::{Component, EdgeList};
use crate::optics::Params;
pub use crate::result::{EdgeLine, FrameResult, InvalidReason, SaturatedRun};
use crate::select::{Selection, curve, moments, select, window_mean};

/// The fitted line and window-mean column of one component (`None` if it has no positioned
/// pixel).
pub fn edge_line(c: &Component, height: usize) -> Option<EdgeLine> {
    let cv = curve(c, height)?;
    let n = c.pos_n as f64;
    let column_px = c.sum_col32 as f64 / 32.0 / n;
    let row_px = c.sum_row as f64 / n;
    // The least-squares line's slope per row (u = 2·row − (H − 1)).
    let (u, v, _) = moments(c, height);
    let suu = u[2] - u[1] * u[1] / n;
    let suv = v[1] - u[1] * v[0] / n;
    let slope = if suu > 0.0 { 2.0 * suv / suu } else { 0.0 };
    let dev = c.sum_dev as f64 / c.pixels as f64 * 360.0 / 256.0;
    let direction_deg = if 2 * c.gx_pos >= c.pixels {
        dev
    } else {
        180.0 + dev
    };
    Some(EdgeLine {
        column_px,
        row_px,
        slope,
        pixels: c.pixels,
        strong: c.strong,
        weak: c.weak,
        direction_deg,
        rows: (c.min_row, c.max_row),
        window_mean_column_px: window_mean(&cv, height),
        fit_rms_px: cv.rms_px,
        mean_gradient: c.sum_mag as f64 / c.pos_n.max(1) as f64,
    })
}

/// The saturated runs of one raw row, appended to `out`.
pub fn saturated_runs(row: &[u8], y: usize, out: &mut Vec<SaturatedRun>) {
    let mut x = 0;
    while x < row.len() {
        if row[x] == 255 {
            let a = x;
            while x < row.len() && row[x] == 255 {
                x += 1;
            }
            out.push(SaturatedRun {
                row: y as u32,
                first: a as u32,
                last: x as u32 - 1,
            });
        } else {
            x += 1;
        }
    }
}

/// Per-frame statistics gathered from the raw rows.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RawStats {
    /// Pixels at 255.
    pub saturated_px: u64,
    /// The focus measure (see [`FrameResult::focus`]).
    pub focus: f64,
    /// Mean gradient magnitude (see [`FrameResult::mean_gradient`]).
    pub mean_gradient: f64,
}

fn touches_side(c: &Component, p: &Params) -> bool {
    c.min_col <= 1 || c.max_col as usize >= p.width - 2
}

/// Computes the frame's result from its candidate components (any order), its edge pixels, its
/// saturated runs (in row order) and the raw statistics.
///
/// Rows where a saturated pixel lies on a ring candidate or within 3 px of its edges are left
/// out of the edges' fits (a clipped profile moves the edge); with fewer than
/// `min_edge_fraction` of the rows left, the candidate is dropped and, when no other remains,
/// the frame is [`InvalidReason::Saturated`].
pub fn baseline_features(
    cands: &[Component],
    components: usize,
    edges: &mut EdgeList,
    saturated: &[SaturatedRun],
    stats: RawStats,
    p: &Params,
) -> FrameResult {
    frame_result(select(cands, edges, saturated, p), components, stats, p)
}

/// The frame's result from the ring's selection ([`select`]), the frame's component count and
/// its raw statistics: the second half of [`baseline_features`] (the tracked detector,
/// [`crate::track`], selects on a band of columns and finishes here).
pub fn frame_result(sel: Selection, components: usize, stats: RawStats, p: &Params) -> FrameResult {
    let h = p.height;
    let mut res = FrameResult {
        c_px: None,
        c_centroid_px: None,
        valid: false,
        reason: sel.reason,
        focus: stats.focus,
        mean_gradient: stats.mean_gradient,
        saturated_px: stats.saturated_px,
        edges: Vec::new(),
        components,
        score: sel.best.as_ref().map(|b| b.score),
        margin: sel.margin,
        c_sigma_px: sel.best.as_ref().map(|b| b.fit.c_sigma_px),
        width_change_px: sel.best.as_ref().map(|b| b.fit.width_change_px),
        tracked: false,
    };
    let Some(best) = sel.best else {
        // The longest edges, for the user to see what the frame holds.
        let mut t: Vec<&crate::select::Track> = sel.tracks.iter().collect();
        t.sort_by_key(|t| (std::cmp::Reverse(t.coverage), t.comp.first_index));
        res.edges = t
            .iter()
            .take(2)
            .filter_map(|t| edge_line(&t.comp, h))
            .collect();
        if matches!(
            res.reason,
            Some(InvalidReason::NoRing | InvalidReason::OneEdge)
        ) && stats.focus < p.min_focus
        {
            res.reason = Some(InvalidReason::OutOfFocus);
        }
        if stats.saturated_px as usize > p.max_saturated_pixels {
            res.reason = Some(InvalidReason::Saturated);
        }
        return res;
    };
    let (lc, rc) = (&best.fit.left, &best.fit.right);
    let (Some(mut l), Some(mut r)) = (edge_line(lc, h), edge_line(rc, h)) else {
        res.reason = Some(InvalidReason::InconsistentEdges);
        return res;
    };
    // The edges' window means from the joint fit: c is their mean.
    (l.window_mean_column_px, r.window_mean_column_px) = best.fit.window_means(h);
    res.c_centroid_px = Some((l.column_px + r.column_px) / 2.0);
    res.edges = vec![l, r];
    let mut reason = sel.reason;
    if reason.is_none() && (touches_side(lc, p) || touches_side(rc, p)) {
        reason = Some(InvalidReason::RingOutsideWindow);
    }
    // An edge whose pixels scatter about their curve more than a clean edge's can has taken in
    // something else: its position is not the ring's.
    if reason.is_none() && l.fit_rms_px.max(r.fit_rms_px) > p.max_edge_rms_px {
        reason = Some(InvalidReason::InconsistentEdges);
    }
    // A ring is equally wide everywhere. When its width changes along the window, something
    // runs along an edge or into the ring (a scratch nearly parallel to it) and moves that edge
    // where the refit could not tell: c could be off by a fair part of the change.
    if reason.is_none() && best.fit.width_change_px > p.max_width_change_px {
        reason = Some(InvalidReason::InconsistentEdges);
    }
    if reason.is_none() {
        res.c_px = Some(best.fit.c_px(h));
        res.valid = true;
    }
    res.reason = reason;
    res
}
