//! Baseline features (seed §4, baseline-feature computation): the ring's two edges from the
//! largest components, their lines, the validity checks, c, and why a frame is invalid.
//!
//! Each edge's column is fitted as a function of row (least squares on the sub-pixel edge
//! positions: a line for the reported slope, a parabola for c). c is the mean of the two edges'
//! fitted columns averaged over all the window's rows: with every row detected this is exactly the
//! seed's centroid column (the fit's residuals sum to zero), and it stays unbiased when a few
//! rows are missing from a slanted or curved edge. The plain centroid is reported too.

use crate::label::Component;
use crate::optics::Params;
use serde::Serialize;

/// Why a frame gave no valid c.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum InvalidReason {
    /// No edge long enough in a sharp frame.
    NoRing,
    /// Only one long edge, away from the window's sides.
    OneEdge,
    /// The ring touches or leaves the window's left or right side.
    RingOutsideWindow,
    /// Too many pixels at 255.
    Saturated,
    /// No ring found and the focus measure is below `min_focus`.
    OutOfFocus,
    /// Two long edges, but not a ring's: wrong gradient signs, separation or tilt.
    InconsistentEdges,
}

/// One edge of the ring: its fitted line `column(row) = column_px + slope·(row − row_px)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EdgeLine {
    /// Mean sub-pixel column of the edge's pixels.
    pub column_px: f64,
    /// Mean row of the edge's pixels.
    pub row_px: f64,
    /// d column / d row of the fitted line.
    pub slope: f64,
    /// Pixels in the component (strong + weak).
    pub pixels: u64,
    /// Strong pixels.
    pub strong: u64,
    /// Weak pixels (including filled ones).
    pub weak: u64,
    /// Mean gradient direction, degrees (≈ 0: brighter to the right in the top-hat, ≈ 180: darker).
    pub direction_deg: f64,
    /// First and last row.
    pub rows: (u32, u32),
    /// Fitted column averaged over all the window's rows (parabola), px.
    pub window_mean_column_px: f64,
}

/// The detector's output for one frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrameResult {
    /// The ring's column c (px, 0 = the window's first column's centre), when valid.
    pub c_px: Option<f64>,
    /// The seed's plain centroid column (mean of the two edges' mean columns), when two edges.
    pub c_centroid_px: Option<f64>,
    /// True when c is valid.
    pub valid: bool,
    /// Why not, when invalid.
    pub reason: Option<InvalidReason>,
    /// Focus measure: the raw frame's mean gradient energy (∂I/∂x)² + (∂I/∂y)² (central
    /// differences), grey²/px². The autofocus maximises it. (The mean gradient magnitude is
    /// nearly blind to blur — ∫|∇I| across an edge is its contrast whatever the blur — while
    /// ∫|∇I|² ∝ contrast²/σ.)
    pub focus: f64,
    /// The raw frame's mean gradient magnitude |∂I/∂x| + |∂I/∂y| (central differences), grey
    /// levels per px.
    pub mean_gradient: f64,
    /// Pixels at 255.
    pub saturated_px: u64,
    /// The ring's edges (left first) when two were paired; else the longest candidates.
    pub edges: Vec<EdgeLine>,
    /// Connected edge components in the frame.
    pub components: usize,
}

fn moments_u(c: &Component, h: i128) -> ([f64; 5], [f64; 3]) {
    // u = 2·row − (H − 1): centred, integer. Exact expansion in i128.
    let n = c.pos_n as i128;
    let (s1, s2, s3, s4) = (
        c.sum_row as i128,
        c.sum_row2 as i128,
        c.sum_row3 as i128,
        c.sum_row4 as i128,
    );
    let u0 = n;
    let u1 = 2 * s1 - h * n;
    let u2 = 4 * s2 - 4 * h * s1 + h * h * n;
    let u3 = 8 * s3 - 12 * h * s2 + 6 * h * h * s1 - h * h * h * n;
    let u4 = 16 * s4 - 32 * h * s3 + 24 * h * h * s2 - 8 * h * h * h * s1 + h * h * h * h * n;
    let (c0, c1, c2) = (
        c.sum_col32 as i128,
        c.sum_row_col32 as i128,
        c.sum_row2_col32 as i128,
    );
    let v0 = c0;
    let v1 = 2 * c1 - h * c0;
    let v2 = 4 * c2 - 4 * h * c1 + h * h * c0;
    (
        [u0 as f64, u1 as f64, u2 as f64, u3 as f64, u4 as f64],
        [v0 as f64 / 32.0, v1 as f64 / 32.0, v2 as f64 / 32.0],
    )
}

fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
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
        *xi = det(m) / d;
    }
    Some(x)
}

/// The fitted line and window-mean column of one component (`None` if it has no positioned
/// pixel).
pub fn edge_line(c: &Component, height: usize) -> Option<EdgeLine> {
    if c.pos_n == 0 {
        return None;
    }
    let h = height as i128 - 1;
    let (u, v) = moments_u(c, h);
    let n = u[0];
    let column_px = v[0] / n;
    let row_px = c.sum_row as f64 / n;
    // Line in u: slope per u; u = 2 row − h, so d col/d row = 2·slope_u.
    let suu = u[2] - u[1] * u[1] / n;
    let suv = v[1] - u[1] * v[0] / n;
    let slope = if suu > 0.0 { 2.0 * suv / suu } else { 0.0 };
    let mean_u2 = ((height * height) as f64 - 1.0) / 3.0;
    let span = (c.max_row - c.min_row) as f64;
    let window_mean = if span >= height as f64 / 4.0 {
        match solve3(
            [[u[0], u[1], u[2]], [u[1], u[2], u[3]], [u[2], u[3], u[4]]],
            [v[0], v[1], v[2]],
        ) {
            Some([a, _b, q]) => a + q * mean_u2,
            None => column_px + slope / 2.0 * (0.0 - u[1] / n),
        }
    } else {
        // Line evaluated at the window's middle row (u = 0).
        column_px - slope / 2.0 * (u[1] / n)
    };
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
        window_mean_column_px: window_mean,
    })
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

fn near_side(c: &Component, p: &Params) -> bool {
    let m = 2 * p.baseline_width_px as u32;
    c.min_col <= m || c.max_col as usize + m as usize >= p.width - 1
}

fn pair_problem(
    a: &Component,
    b: &Component,
    la: &EdgeLine,
    lb: &EdgeLine,
    p: &Params,
) -> Option<InvalidReason> {
    if touches_side(a, p) || touches_side(b, p) {
        return Some(InvalidReason::RingOutsideWindow);
    }
    let (lc, rc, ll, rl) = if la.column_px <= lb.column_px {
        (a, b, la, lb)
    } else {
        (b, a, lb, la)
    };
    // In the top-hat the ring is bright: its left edge has Gx > 0, its right edge Gx < 0.
    let left_pos = 2 * lc.gx_pos > lc.pixels;
    let right_neg = 2 * rc.gx_pos < rc.pixels;
    let sep = rl.column_px - ll.column_px;
    let tan_tol = p.tan_tolerance_q10 as f64 / 1024.0;
    if !left_pos
        || !right_neg
        || sep < p.separation_px.0
        || sep > p.separation_px.1
        || la.slope.abs() > tan_tol
        || lb.slope.abs() > tan_tol
    {
        return Some(InvalidReason::InconsistentEdges);
    }
    None
}

/// Computes the frame's result from the largest components (best first) and the raw statistics.
pub fn baseline_features(
    best: &[Component],
    components: usize,
    stats: RawStats,
    p: &Params,
) -> FrameResult {
    let long: Vec<(&Component, EdgeLine)> = best
        .iter()
        .filter(|c| c.pixels as usize >= p.min_edge_pixels)
        .filter_map(|c| edge_line(c, p.height).map(|l| (c, l)))
        .collect();
    let mut res = FrameResult {
        c_px: None,
        c_centroid_px: None,
        valid: false,
        reason: None,
        focus: stats.focus,
        mean_gradient: stats.mean_gradient,
        saturated_px: stats.saturated_px,
        edges: long.iter().take(2).map(|(_, l)| *l).collect(),
        components,
    };
    let mut reason = None;
    let mut pair = None;
    if long.is_empty() {
        reason = Some(if stats.focus < p.min_focus {
            InvalidReason::OutOfFocus
        } else {
            InvalidReason::NoRing
        });
    } else if long.len() == 1 {
        reason = Some(if near_side(long[0].0, p) {
            InvalidReason::RingOutsideWindow
        } else if stats.focus < p.min_focus {
            InvalidReason::OutOfFocus
        } else {
            InvalidReason::OneEdge
        });
    } else {
        'search: for i in 0..long.len() {
            for j in i + 1..long.len() {
                let (a, la) = &long[i];
                let (b, lb) = &long[j];
                match pair_problem(a, b, la, lb, p) {
                    None => {
                        pair = Some((*la, *lb));
                        break 'search;
                    }
                    Some(r) => {
                        if reason.is_none() {
                            reason = Some(r);
                        }
                    }
                }
            }
        }
    }
    if let Some((la, lb)) = pair {
        let (l, r) = if la.column_px <= lb.column_px {
            (la, lb)
        } else {
            (lb, la)
        };
        res.c_px = Some((l.window_mean_column_px + r.window_mean_column_px) / 2.0);
        res.c_centroid_px = Some((l.column_px + r.column_px) / 2.0);
        res.edges = vec![l, r];
        res.valid = true;
        reason = None;
    }
    if stats.saturated_px as usize > p.max_saturated_pixels {
        res.valid = false;
        res.c_px = None;
        reason = Some(InvalidReason::Saturated);
    }
    res.reason = reason;
    res
}
