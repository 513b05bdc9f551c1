//! One frame's detection as `gonio detect` writes it (one JSON line a frame) and
//! `gonio.detect` returns it: the frame's index, file, angle and time, c in µm, then the
//! detector's [`FrameResult`] (c_px, valid, reason, score, margin, edges …).
//!
//! ```
//! use gonio_io::results::detect::Line;
//! use gonio_vision::{Detector, Optics};
//! let optics = Optics::default();
//! let r = Detector::new(&optics).unwrap().detect(&vec![128u8; 1440 * 540]).unwrap();
//! let line = Line::new(0, None, None, None, &r, optics.params().unwrap().um_per_px);
//! let json = serde_json::to_string(&line).unwrap();
//! assert!(json.starts_with("{\"frame\":0,\"theta_deg\":null,\"time_s\":null,\"c_um\":null,"));
//! ```

use gonio_vision::FrameResult;
use serde::Serialize;

/// One output line.
#[derive(Debug, Serialize)]
pub struct Line<'a> {
    /// 0-based index of the frame.
    pub frame: usize,
    /// The frame's file, when it came from one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Table angle, degrees, when known.
    pub theta_deg: Option<f64>,
    /// Time of the frame, s, when known.
    pub time_s: Option<f64>,
    /// The ring's column in µm (c_px × µm per px), when valid.
    pub c_um: Option<f64>,
    /// The detector's result.
    #[serde(flatten)]
    pub result: &'a FrameResult,
}

impl<'a> Line<'a> {
    /// The line of frame `frame` with `um_per_px` from the optics.
    pub fn new(
        frame: usize,
        file: Option<String>,
        theta_deg: Option<f64>,
        time_s: Option<f64>,
        result: &'a FrameResult,
        um_per_px: f64,
    ) -> Line<'a> {
        Line {
            frame,
            file,
            theta_deg,
            time_s,
            c_um: result.c_px.map(|c| c * um_per_px),
            result,
        }
    }
}
