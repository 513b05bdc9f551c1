//! Errors of the detector.

use thiserror::Error;

/// An error from the detector or its configuration.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum VisionError {
    /// An optics parameter is out of its valid range.
    #[error("optics: {name} = {found}: expected {expected}")]
    Optics {
        /// The parameter's name (as in the optics TOML file).
        name: &'static str,
        /// The value given.
        found: String,
        /// What is allowed.
        expected: String,
    },
    /// A pushed row has the wrong number of pixels.
    #[error("row {row}: expected {expected} pixels, found {found}")]
    RowLength {
        /// 0-based row index within the frame.
        row: usize,
        /// Window width in pixels.
        expected: usize,
        /// Pixels given.
        found: usize,
    },
    /// More rows were pushed than the window has, or a frame was finished early.
    #[error("frame has {found} rows: expected {expected}")]
    FrameHeight {
        /// Window height in rows.
        expected: usize,
        /// Rows pushed.
        found: usize,
    },
    /// A whole frame has the wrong number of bytes.
    #[error("frame has {found} bytes: expected {expected} ({width}×{height})")]
    FrameSize {
        /// Expected bytes.
        expected: usize,
        /// Bytes given.
        found: usize,
        /// Window width.
        width: usize,
        /// Window height.
        height: usize,
    },
    /// A frame is neither the optics' window nor its sensor in size.
    #[error(
        "frame is {width}×{height}: expected the window {window_width}×{window_height} or the \
         sensor {sensor_width}×{sensor_height} (see the optics)"
    )]
    FrameShape {
        /// Width of the frame given, px.
        width: usize,
        /// Height of the frame given, px.
        height: usize,
        /// The optics' window width, px.
        window_width: usize,
        /// The optics' window height, px.
        window_height: usize,
        /// The optics' sensor width, px.
        sensor_width: usize,
        /// The optics' sensor height, px.
        sensor_height: usize,
    },
}
