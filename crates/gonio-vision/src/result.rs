//! The detector's result for one frame ([`FrameResult`]): c, its validity and why not
//! ([`InvalidReason`]), the ring's edges ([`EdgeLine`]), the choice's score and margin; and the
//! raw frame's saturated runs ([`SaturatedRun`]) the selection leaves out. Plain data, below
//! every stage that produces or reads it ([`crate::select`], [`crate::features`]).

use serde::{Deserialize, Serialize};

/// Why a frame gave no valid c.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
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
    /// Two ring candidates score too close to call (see [`FrameResult::margin`]).
    Ambiguous,
    /// The camera delivered the frame's buffer incomplete (packets lost on the way): whatever
    /// the detector saw in it, c is not trusted.
    IncompleteFrame,
    /// The frame never arrived: a gap in the camera's frame ids.
    MissingFrame,
}

impl InvalidReason {
    /// The reason's name as in the detector's JSON lines (`no_ring`, `ambiguous`, …).
    pub fn name(self) -> &'static str {
        match self {
            InvalidReason::NoRing => "no_ring",
            InvalidReason::OneEdge => "one_edge",
            InvalidReason::RingOutsideWindow => "ring_outside_window",
            InvalidReason::Saturated => "saturated",
            InvalidReason::OutOfFocus => "out_of_focus",
            InvalidReason::InconsistentEdges => "inconsistent_edges",
            InvalidReason::Ambiguous => "ambiguous",
            InvalidReason::IncompleteFrame => "incomplete_frame",
            InvalidReason::MissingFrame => "missing_frame",
        }
    }
}

impl std::fmt::Display for InvalidReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
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
    /// RMS distance of the edge's pixels from its fitted curve, px.
    pub fit_rms_px: f64,
    /// Mean gradient magnitude along the edge (Sobel L1 units).
    pub mean_gradient: f64,
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
    /// The ring's edges (left first) when two were paired; else the longest edges.
    pub edges: Vec<EdgeLine>,
    /// Connected edge components in the frame.
    pub components: usize,
    /// Score of the best ring candidate, 0 … 1 (`None`: no candidate).
    pub score: Option<f64>,
    /// How far the best candidate's score is ahead of the runner-up's, as a fraction of the
    /// best's: 1 with no runner-up (`None`: no candidate).
    pub margin: Option<f64>,
    /// Standard uncertainty of c from the edges' fit, px (the pixels' scatter about the fitted
    /// curves propagated through the fit; `None` without a ring).
    pub c_sigma_px: Option<f64>,
    /// How much the ring's width changes over the window, px (see
    /// [`PairFit::width_change_px`](crate::select::PairFit::width_change_px)).
    pub width_change_px: Option<f64>,
    /// True when the frame was measured in a band of columns around the ring's predicted
    /// column ([`crate::track`]), false when over the whole frame.
    pub tracked: bool,
}

impl FrameResult {
    /// Marks the result invalid for `reason` (e.g. [`InvalidReason::IncompleteFrame`]): no c,
    /// `valid` false; what the detector measured otherwise (edges, score, focus …) stays.
    pub fn invalidate(&mut self, reason: InvalidReason) {
        self.c_px = None;
        self.valid = false;
        self.reason = Some(reason);
    }
}

/// A run of saturated pixels (value 255) in one row of the raw frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SaturatedRun {
    /// Row.
    pub row: u32,
    /// First column.
    pub first: u32,
    /// Last column.
    pub last: u32,
}
