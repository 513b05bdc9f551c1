//! Frames in: the [`FrameSource`] trait that image files, raw standard input, the renderer and a
//! camera's SDK implement, with each frame's size and stamp ([`FrameHeader`], [`FrameStamp`]:
//! index, exposure start and time in s, table angle in degrees). A source's errors are its own
//! type ([`FrameSource::Error`]).
//!
//! ```
//! use gonio_vision::{FrameSource, RawFrames};
//! let bytes = vec![128u8; 2 * 4 * 3]; // two 4 × 3 frames
//! let mut src = RawFrames::new(&bytes[..], 4, 3);
//! let mut pixels = Vec::new();
//! let hdr = src.next_frame(&mut pixels).unwrap().unwrap();
//! assert_eq!((hdr.width, hdr.height, hdr.stamp.index), (4, 3, 0));
//! ```

/// When and how a frame was taken, as far as its source knows.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameStamp {
    /// 0-based index of the frame in its source.
    pub index: u64,
    /// Start of the exposure, s (on the source's clock).
    pub start_s: Option<f64>,
    /// Exposure time, s.
    pub exposure_s: Option<f64>,
    /// Table angle at mid-exposure, degrees.
    pub theta_deg: Option<f64>,
}

/// A frame's size and stamp (its pixels are in the caller's buffer).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameHeader {
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// The stamp.
    pub stamp: FrameStamp,
}

/// Something that delivers 8-bit grey frames one after another: image files, raw frames on
/// standard input, the renderer, a camera. Frames may be of the optics' window or its sensor;
/// [`Optics::crop_window`](crate::Optics::crop_window) cuts the window out.
pub trait FrameSource {
    /// The source's error.
    type Error: std::error::Error + 'static;
    /// Reads the next frame into `pixels` (resized to width × height, row-major) and returns its
    /// size and stamp; `Ok(None)` after the last frame.
    ///
    /// # Errors
    /// Whatever keeps the source from delivering a whole frame (unreadable file, truncated
    /// stream, camera fault).
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Self::Error>;
}

impl<T: FrameSource + ?Sized> FrameSource for &mut T {
    type Error = T::Error;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Self::Error> {
        (**self).next_frame(pixels)
    }
}

impl<T: FrameSource + ?Sized> FrameSource for Box<T> {
    type Error = T::Error;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Self::Error> {
        (**self).next_frame(pixels)
    }
}
