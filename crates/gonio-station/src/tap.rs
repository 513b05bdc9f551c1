//! A frame as the station's camera saw it ([`SeenFrame`]: the pixels its detector ran on, their
//! size and stamp, and the detector's whole result), and the one way to be told each one
//! ([`FrameTap`]): the recorder of `gonio mount --record` and the live view's thumbnail take
//! the frames of the twin and of a real station alike.
//!
//! ```
//! use gonio_station::tap::{FrameTap, SeenFrame};
//! let mut widths = Vec::new();
//! let mut tap: FrameTap<'_> = Box::new(|f: &SeenFrame<'_>| widths.push(f.width));
//! # let r = gonio_vision::Detector::new(&gonio_vision::Optics {
//! #     window_width_px: 96, window_height_px: 48, ..gonio_vision::Optics::default() })
//! #     .unwrap().detect(&[128u8; 96 * 48]).unwrap();
//! tap(&SeenFrame { width: 96, height: 48, pixels: &[128; 96 * 48],
//!                  stamp: gonio_vision::FrameStamp::default(), result: &r });
//! drop(tap);
//! assert_eq!(widths, [96]);
//! ```

use gonio_vision::{FrameResult, FrameStamp};

/// A frame as the station's camera saw it.
#[derive(Debug, Clone, Copy)]
pub struct SeenFrame<'a> {
    /// Width, px (the optics' window).
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// 8-bit grey pixels, row-major, `width` × `height`, as the detector saw them (the raw
    /// stream format of `gonio detect --raw`).
    pub pixels: &'a [u8],
    /// The camera's stamp: its frame number (a triggered camera's = the PLC's trigger count)
    /// and its own time of the exposure's start, s.
    pub stamp: FrameStamp,
    /// What the detector found (edge columns and `c_px` in the window's pixels).
    pub result: &'a FrameResult,
}

/// Told every frame a station's camera delivers, as it delivers it (on the station's thread,
/// between frames: it should return at once for most frames and rate-limit any work).
pub type FrameTap<'a> = Box<dyn FnMut(&SeenFrame<'_>) + 'a>;
