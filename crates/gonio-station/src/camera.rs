//! The camera as the station sees it: a frame source with the streaming detector behind it
//! ([`DetectorCamera`]), implementing [`hal::Camera`](crate::hal::Camera). The one path from a
//! frame to a push: `FrameSource` → the optics' window → `Detector` → [`CameraFrame`] with a
//! typed reason.
//!
//! A real GenICam camera is `DetectorCamera<gonio_camera::AravisSource>` (crate `gonio-camera`,
//! feature `genicam`): its frames' `start_s` is the camera's timestamp mapped to the host's
//! monotonic clock, `exposure_s` the camera's `ExposureTime`, incomplete frames are left out,
//! and its errors map to [`DeviceErrorKind`] naming the camera (docs/camera.md).
//!
//! ```
//! use gonio_station::camera::DetectorCamera;
//! use gonio_station::hal::{Camera, DeviceError, DeviceErrorKind};
//! use gonio_vision::{FrameHeader, FrameSource, FrameStamp, InvalidReason, Optics};
//!
//! /// A camera that sees a blank grating at 100 fps.
//! struct Blank(u64);
//! #[derive(Debug)]
//! struct Never;
//! impl std::fmt::Display for Never {
//!     fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result { f.write_str("never") }
//! }
//! impl std::error::Error for Never {}
//! impl DeviceError for Never {
//!     fn kind(&self) -> DeviceErrorKind { DeviceErrorKind::Other }
//! }
//! impl FrameSource for Blank {
//!     type Error = Never;
//!     fn next_frame(&mut self, px: &mut Vec<u8>) -> Result<Option<FrameHeader>, Never> {
//!         px.clear();
//!         px.resize(128 * 64, 180);
//!         self.0 += 1;
//!         let stamp = FrameStamp { index: self.0 - 1, start_s: Some(self.0 as f64 / 100.0),
//!                                  exposure_s: Some(0.5e-3), theta_deg: None };
//!         Ok(Some(FrameHeader { width: 128, height: 64, stamp }))
//!     }
//! }
//! let optics = Optics { window_width_px: 128, window_height_px: 64, ..Optics::default() };
//! let mut cam = DetectorCamera::new(Blank(0), &optics).unwrap();
//! let f = cam.capture().unwrap();
//! assert_eq!(f.c_px, None);
//! assert_eq!(f.invalid_reason, Some(InvalidReason::OutOfFocus)); // featureless: no gradient
//! ```

use crate::hal::{Camera, CameraFrame, DeviceError, DeviceErrorKind};
use crate::tap::SeenFrame;
use gonio_vision::{
    FrameResult, FrameSource, FrameStamp, InvalidReason, Optics, SourceDetector, SourceError,
    VisionError,
};
use thiserror::Error;

/// What the detector found in one frame, as the station uses it: the ring's column (only when
/// the frame is valid: the fit never sees an ambiguous or invalid frame's column), why the
/// frame is invalid, and its focus measure. With the exposure's start and length it is a
/// [`CameraFrame`] ([`RingReading::at`]); every camera of the station (the detector camera, the
/// camera a PLC triggers, the twin's) reads a [`FrameResult`] through [`RingReading::of`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingReading {
    /// The ring's column, px (`None`: no valid ring).
    pub c_px: Option<f64>,
    /// Why the frame has no valid ring (`None` when valid).
    pub invalid_reason: Option<InvalidReason>,
    /// The frame's focus measure.
    pub focus_measure: f64,
}

impl RingReading {
    /// The reading of the detector's result `r`.
    pub fn of(r: &FrameResult) -> Self {
        RingReading {
            c_px: r.c_px.filter(|_| r.valid),
            invalid_reason: if r.valid { None } else { r.reason },
            focus_measure: r.focus,
        }
    }

    /// The reading of a frame whose exposure started at `start_s` (s, the station's clock) and
    /// lasted `exposure_s` (s).
    pub fn at(self, start_s: f64, exposure_s: f64) -> CameraFrame {
        CameraFrame {
            start_s,
            exposure_s,
            c_px: self.c_px,
            invalid_reason: self.invalid_reason,
            focus_measure: self.focus_measure,
        }
    }
}

impl From<&CameraFrame> for RingReading {
    fn from(f: &CameraFrame) -> Self {
        RingReading {
            c_px: f.c_px,
            invalid_reason: f.invalid_reason,
            focus_measure: f.focus_measure,
        }
    }
}

/// The detector's path as a device: the source's own error keeps its kind; a frame the
/// detector cannot take (wrong size) is a fault.
impl<E: std::error::Error + DeviceError + 'static> DeviceError for SourceError<E> {
    fn kind(&self) -> DeviceErrorKind {
        match self {
            SourceError::Source(e) => e.kind(),
            SourceError::Frame { .. } => DeviceErrorKind::Fault,
        }
    }
}

/// An error of a [`DetectorCamera`]: the detector's path (the source's, or a frame it could not
/// take), or why a frame could not be used.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DetectorCameraError<E: std::error::Error + 'static> {
    /// The frame source failed, or a frame could not be run through the detector (wrong size).
    #[error(transparent)]
    Detect(#[from] SourceError<E>),
    /// The source has no more frames.
    #[error("the frame source ended after {frames} frames")]
    Ended {
        /// Frames delivered before.
        frames: u64,
    },
    /// A frame came without the start of its exposure (the station stamps θ from it).
    #[error("frame {index} has no exposure start time: a station camera must stamp its frames")]
    Unstamped {
        /// 0-based index of the frame.
        index: u64,
    },
}

impl<E: std::error::Error + DeviceError + 'static> DeviceError for DetectorCameraError<E> {
    fn kind(&self) -> DeviceErrorKind {
        match self {
            DetectorCameraError::Detect(e) => e.kind(),
            DetectorCameraError::Ended { .. } => DeviceErrorKind::Timeout,
            DetectorCameraError::Unstamped { .. } => DeviceErrorKind::Fault,
        }
    }
}

/// A frame source with the detector behind it: every [`Camera::capture`] takes the source's next
/// frame, cuts the optics' window out of it and detects the ring (tracked: in a band of columns
/// around the ring's predicted column when the band can vouch for it, see
/// [`gonio_vision::track`]). A valid frame gives c; any
/// other gives `None` and the detector's reason — the fit never sees an ambiguous or invalid
/// frame's column.
#[derive(Debug)]
pub struct DetectorCamera<S> {
    det: SourceDetector<S>,
    frames: u64,
    last: Option<(FrameStamp, FrameResult)>,
}

impl<S: FrameSource> DetectorCamera<S> {
    /// A camera over `source` for the optics.
    ///
    /// # Errors
    /// [`VisionError::Optics`] when the optics are invalid.
    pub fn new(source: S, optics: &Optics) -> Result<Self, VisionError> {
        let mut det = SourceDetector::new(source, optics)?;
        // A camera's frames come in order: tracked (gonio_vision::track).
        det.track_frames(true);
        Ok(DetectorCamera {
            det,
            frames: 0,
            last: None,
        })
    }

    /// The detector's whole result for the last frame (edges, score, margin: the live view).
    pub fn last_result(&self) -> Option<&FrameResult> {
        self.last.as_ref().map(|(_, r)| r)
    }

    /// The last frame captured as the detector saw it: its window's pixels (borrowed from the
    /// detector's buffers, no copy), stamp and result (`None` before the first capture or after
    /// a failed one).
    pub fn seen(&self) -> Option<SeenFrame<'_>> {
        let (stamp, result) = self.last.as_ref()?;
        let o = self.det.optics();
        Some(SeenFrame {
            width: o.window_width_px as usize,
            height: o.window_height_px as usize,
            pixels: self.det.window()?,
            stamp: *stamp,
            result,
        })
    }

    /// The frame source.
    pub fn source(&self) -> &S {
        self.det.source()
    }

    /// The frame source, mutably.
    pub fn source_mut(&mut self) -> &mut S {
        self.det.source_mut()
    }
}

impl<S> Camera for DetectorCamera<S>
where
    S: FrameSource,
    S::Error: DeviceError,
{
    type Error = DetectorCameraError<S::Error>;

    fn capture(&mut self) -> Result<CameraFrame, Self::Error> {
        self.last = None;
        let Some(d) = self.det.detect_next()? else {
            return Err(DetectorCameraError::Ended {
                frames: self.frames,
            });
        };
        self.frames += 1;
        let Some(start_s) = d.stamp.start_s else {
            return Err(DetectorCameraError::Unstamped {
                index: d.stamp.index,
            });
        };
        let frame = RingReading::of(&d.result).at(start_s, d.stamp.exposure_s.unwrap_or(0.0));
        self.last = Some((d.stamp, d.result));
        Ok(frame)
    }
}
