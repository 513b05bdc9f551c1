//! The one error type of the crate: every variant names the camera.

use gonio_station::hal::{DeviceError, DeviceErrorKind};
use thiserror::Error;

/// An error of a camera (or of the fake camera).
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum CameraError {
    /// Built without the `genicam` feature: no camera support.
    #[error(
        "camera support is not built in: build with `--features genicam` (needs libaravis-0.8)"
    )]
    NotBuilt,
    /// No camera of that id.
    #[error("camera {camera}: not found (cameras found: {found})")]
    NotFound {
        /// The id asked for.
        camera: String,
        /// The ids found, comma-separated (`none` when none).
        found: String,
    },
    /// The camera could not be opened or set up over its link.
    #[error("camera {camera}: {action}: {message}")]
    Communication {
        /// The camera.
        camera: String,
        /// What was being done.
        action: String,
        /// Aravis's message.
        message: String,
    },
    /// The camera refused a setting (a window, a pixel format, a trigger).
    #[error("camera {camera}: refuses {feature} = {value}: {message}")]
    Refused {
        /// The camera.
        camera: String,
        /// The GenICam feature(s).
        feature: String,
        /// The value asked for.
        value: String,
        /// Why (Aravis's message or the camera's limits).
        message: String,
    },
    /// A value outside the camera's range.
    #[error("camera {camera}: {feature} {value} is out of the camera's range {min} … {max}")]
    OutOfRange {
        /// The camera.
        camera: String,
        /// The GenICam feature.
        feature: String,
        /// The value asked for.
        value: f64,
        /// The camera's minimum.
        min: f64,
        /// The camera's maximum.
        max: f64,
    },
    /// No frame came in time: the camera stopped sending or is gone.
    #[error(
        "camera {camera}: no frame for {waited_ms} ms after {frames} frames (camera gone or not triggered)"
    )]
    Timeout {
        /// The camera.
        camera: String,
        /// How long was waited, ms.
        waited_ms: u64,
        /// Frames received before.
        frames: u64,
    },
    /// The fake camera could not start (address in use, bad interface).
    #[error("fake camera {serial} on {address}: {message}")]
    FakeCamera {
        /// Its serial number.
        serial: String,
        /// The interface address.
        address: String,
        /// Why.
        message: String,
    },
}

impl DeviceError for CameraError {
    fn kind(&self) -> DeviceErrorKind {
        match self {
            CameraError::Timeout { .. } => DeviceErrorKind::Timeout,
            CameraError::Communication { .. } | CameraError::NotFound { .. } => {
                DeviceErrorKind::Communication
            }
            CameraError::Refused { .. } | CameraError::OutOfRange { .. } => DeviceErrorKind::Fault,
            CameraError::NotBuilt | CameraError::FakeCamera { .. } => DeviceErrorKind::Other,
        }
    }
}
