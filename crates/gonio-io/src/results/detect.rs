//! One frame's detection as `gonio detect` writes it (one JSON line a frame) and
//! `gonio.detect` returns it: the frame's index, file, angle and time, c in µm, then the
//! detector's [`FrameResult`] (c_px, valid, reason, score, margin, edges …). A camera's frame
//! also carries the camera's frame id and timestamp ([`Line::with_camera`]); a frame missing
//! from the camera's id sequence is a [`MissingLine`].
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

use gonio_vision::{FrameResult, InvalidReason};
use serde::Serialize;

/// The camera's own numbering of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct CameraIds {
    /// The camera's frame id (`null` when not known: a missing frame after the last one).
    pub frame_id: Option<u64>,
    /// The camera's timestamp, ns (`null` for a missing frame).
    pub timestamp_ns: Option<u64>,
}

/// One output line.
#[derive(Debug, Serialize)]
pub struct Line<'a> {
    /// 0-based index of the frame.
    pub frame: usize,
    /// The frame's file, when it came from one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// The camera's frame id and timestamp, when the frame came from a camera.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraIds>,
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
            camera: None,
            theta_deg,
            time_s,
            c_um: result.c_px.map(|c| c * um_per_px),
            result,
        }
    }
}

impl Line<'_> {
    /// The line with the camera's frame id and timestamp, ns.
    pub fn with_camera(mut self, frame_id: u64, timestamp_ns: u64) -> Self {
        self.camera = Some(CameraIds {
            frame_id: Some(frame_id),
            timestamp_ns: Some(timestamp_ns),
        });
        self
    }
}

/// The line of a frame missing from a camera's id sequence: never valid, no column, reason
/// `missing_frame`, keys as a [`Line`]'s.
///
/// ```
/// use gonio_io::results::detect::MissingLine;
/// let json = serde_json::to_string(&MissingLine::new(7, Some(8), Some(12.6), Some(0.07))).unwrap();
/// assert!(json.contains("\"frame_id\":8,\"timestamp_ns\":null,"));
/// assert!(json.ends_with("\"valid\":false,\"reason\":\"missing_frame\",\"tracked\":false}"));
/// ```
#[derive(Debug, Serialize)]
pub struct MissingLine {
    /// 0-based slot of the frame in the camera's sequence.
    pub frame: u64,
    /// The camera's ids: the frame id when a later frame told it, no timestamp.
    #[serde(flatten)]
    pub camera: CameraIds,
    /// Table angle, degrees, when known.
    pub theta_deg: Option<f64>,
    /// Time of the frame, s, when known.
    pub time_s: Option<f64>,
    /// Always `null`.
    pub c_um: Option<f64>,
    /// Always `null`.
    pub c_px: Option<f64>,
    /// Always false.
    pub valid: bool,
    /// Always [`InvalidReason::MissingFrame`].
    pub reason: InvalidReason,
    /// Always false.
    pub tracked: bool,
}

impl MissingLine {
    /// The line of missing slot `frame` whose camera frame id is `frame_id` (`None` when no
    /// later frame came to tell it).
    pub fn new(
        frame: u64,
        frame_id: Option<u64>,
        theta_deg: Option<f64>,
        time_s: Option<f64>,
    ) -> MissingLine {
        MissingLine {
            frame,
            camera: CameraIds {
                frame_id,
                timestamp_ns: None,
            },
            theta_deg,
            time_s,
            c_um: None,
            c_px: None,
            valid: false,
            reason: InvalidReason::MissingFrame,
            tracked: false,
        }
    }
}
