//! The streaming baseline detector of the mounting station: from camera rows to the alignment
//! ring's column c, row by row as the sensor reads out (the baseline detector of Yu et al., 2024;
//! docs/detector.md).
//!
//! One module per stage, each a [`rows::RowStage`] (`push_row` → an output row after a fixed lag,
//! `flush_row` after the frame's last row), sized at construction, integer arithmetic:
//!
//! 1. [`morphology`]: black top-hat (closing with a 2d + 1 disk, minus the input) and opening
//!    with a ≈ d/2 disk; [`gaussian`]: 5×5 blur;
//! 2. [`gradient`]: Sobel ([`blur_sobel`]: the blur and the Sobel as one stage); [`segment`]: NMS, dual threshold, baseline filter;
//! 3. [`fill`]: edge filling; [`label`]: single-pass 8-connected labelling with per-component
//!    sums;
//! 4. [`select`]: the ring's two edges chosen by the ring's model (polarity, separation from
//!    the optics, parallel, shared rows, a flat inside), with a score and a margin over the
//!    runner-up; [`features`]: validity checks and reasons, c, each edge's fitted line;
//! 5. the focus measure, in the same pass ([`pipeline`], its sums in [`focus`]).
//!
//! Below the stages, plain data: [`buffer`] (aligned and padded row buffers), [`row_types`]
//! (the rows the stages hand on: gradients, edges, edge pixels), [`result`] (the per-frame
//! result and why a frame is invalid). The crate's only unsafe code is in [`simd`]: the
//! kernels written with intrinsics, one module per instruction set, each called through a safe
//! wrapper that takes a proof of the CPU's features.
//!
//! [`Detector`] chains them into one cascade ([`rows::Then`]); [`Optics`] derives every parameter
//! and cuts the window out of a sensor frame; [`frame_source`] brings frames in ([`FrameSource`]:
//! files, [`raw_frames`] on standard input, the renderer, a camera) and [`source`]'s
//! [`SourceDetector`] runs them through the detector, the one path from a frame to its result
//! ([`in_order`]'s [`detect_in_order`]: the same path on several threads, results in the
//! stream's order); [`track`] measures frames that come in order in a band of columns around
//! the ring's predicted column, with the whole frame as the fallback
//! ([`SourceDetector::track_frames`]); [`reference`](mod@reference) holds the
//! whole-frame implementations the streaming ones equal bit for bit; [`simd`] chooses the hot
//! loops' code path (baseline, AVX2, AVX-512: the same bits).
//!
//! ```
//! use gonio_vision::{Detector, Optics};
//! let mut det = Detector::new(&Optics::default()).unwrap();
//! let frame = vec![128u8; 1440 * 540]; // a blank, featureless frame
//! let r = det.detect(&frame).unwrap();
//! assert!(!r.valid);
//! ```
#![deny(missing_docs)]

pub mod blur_sobel;
pub mod buffer;
pub mod error;
pub mod features;
pub mod fill;
pub mod focus;
pub mod frame_source;
pub mod gaussian;
pub mod gradient;
pub mod in_order;
pub mod label;
pub mod morphology;
pub mod optics;
pub mod pipeline;
pub mod raw_frames;
pub mod reference;
pub mod result;
pub mod row_types;
pub mod rows;
pub mod segment;
pub mod select;
pub mod simd;
pub mod source;
#[cfg(test)]
mod test_frames;
pub mod track;

pub use error::VisionError;
pub use frame_source::{FrameHeader, FrameSource, FrameStamp};
pub use in_order::{DetectInOrderError, detect_in_order};
pub use optics::{MAX_RING_WIDTH_PX, MAX_SENSOR_PX, MAX_WINDOW_PIXELS, Optics, Params, Polarity};
pub use pipeline::{Detector, LowerHalf, StageImages};
pub use raw_frames::{RawFrames, RawFramesError};
pub use result::{EdgeLine, FrameResult, InvalidReason};
pub use source::{Detection, SourceDetector, SourceError};
