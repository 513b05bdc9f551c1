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
use gonio_vision::{FrameResult, FrameSource, Optics, SourceDetector, SourceError, VisionError};
use thiserror::Error;

/// An error of a [`DetectorCamera`]: the source's, or why a frame could not be used.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DetectorCameraError<E: std::error::Error + 'static> {
    /// The frame source failed.
    #[error(transparent)]
    Source(E),
    /// A frame could not be run through the detector (wrong size).
    #[error("frame {index}: {error}")]
    Frame {
        /// 0-based index of the frame.
        index: u64,
        /// Why.
        error: VisionError,
    },
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
            DetectorCameraError::Source(e) => e.kind(),
            DetectorCameraError::Ended { .. } => DeviceErrorKind::Timeout,
            DetectorCameraError::Frame { .. } | DetectorCameraError::Unstamped { .. } => {
                DeviceErrorKind::Fault
            }
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
    last: Option<FrameResult>,
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
        self.last.as_ref()
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
        let d = match self.det.detect_next() {
            Ok(Some(d)) => d,
            Ok(None) => {
                return Err(DetectorCameraError::Ended {
                    frames: self.frames,
                });
            }
            Err(SourceError::Source(e)) => return Err(DetectorCameraError::Source(e)),
            Err(SourceError::Frame { index, error }) => {
                return Err(DetectorCameraError::Frame { index, error });
            }
        };
        self.frames += 1;
        let Some(start_s) = d.stamp.start_s else {
            return Err(DetectorCameraError::Unstamped {
                index: d.stamp.index,
            });
        };
        let r = d.result;
        let frame = CameraFrame {
            start_s,
            exposure_s: d.stamp.exposure_s.unwrap_or(0.0),
            c_px: r.c_px.filter(|_| r.valid),
            invalid_reason: if r.valid { None } else { r.reason },
            focus_measure: r.focus,
        };
        self.last = Some(r);
        Ok(frame)
    }
}
