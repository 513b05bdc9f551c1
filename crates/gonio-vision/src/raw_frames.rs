//! [`RawFrames`]: raw 8-bit frames of a fixed size, back to back, from any reader (standard
//! input, a pipe); errors name the frame ([`RawFramesError`]).
//!
//! ```
//! use gonio_vision::{FrameSource, RawFrames};
//! let bytes = vec![128u8; 4 * 3 + 5]; // one 4 × 3 frame and 5 bytes of the next
//! let mut src = RawFrames::new(&bytes[..], 4, 3);
//! let mut pixels = Vec::new();
//! assert!(src.next_frame(&mut pixels).unwrap().is_some());
//! assert!(src.next_frame(&mut pixels).is_err()); // truncated
//! ```

use crate::{FrameHeader, FrameSource, FrameStamp};
use std::io::Read;
use thiserror::Error;

/// An error reading raw frames.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum RawFramesError {
    /// The reader failed.
    #[error("cannot read frame {frame}: {source}")]
    Io {
        /// 0-based index of the frame being read.
        frame: u64,
        /// The reader's error.
        source: std::io::Error,
    },
    /// The stream ended inside a frame.
    #[error(
        "truncated frame: {frames} whole {width}x{height} frames read, then {got} of {expected} bytes"
    )]
    Truncated {
        /// Whole frames read before.
        frames: u64,
        /// Frame width, px.
        width: usize,
        /// Frame height, px.
        height: usize,
        /// Bytes of the last, partial frame.
        got: usize,
        /// Bytes of a whole frame.
        expected: usize,
    },
}

/// Raw 8-bit frames of a fixed size, back to back, from any reader (standard input from
/// `ffmpeg … -f rawvideo -pix_fmt gray -` or a camera SDK's pipe). Stamps carry the index only.
#[derive(Debug)]
pub struct RawFrames<R> {
    reader: R,
    width: usize,
    height: usize,
    index: u64,
}

impl<R: Read> RawFrames<R> {
    /// Frames of `width` × `height` bytes from `reader`.
    pub fn new(reader: R, width: usize, height: usize) -> Self {
        RawFrames {
            reader,
            width,
            height,
            index: 0,
        }
    }
}

impl<R: Read> FrameSource for RawFrames<R> {
    type Error = RawFramesError;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, RawFramesError> {
        let n = self.width * self.height;
        pixels.resize(n, 0);
        let mut got = 0;
        while got < n {
            match self.reader.read(&mut pixels[got..]) {
                Ok(0) => break,
                Ok(m) => got += m,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(RawFramesError::Io {
                        frame: self.index,
                        source: e,
                    });
                }
            }
        }
        if got == 0 {
            return Ok(None);
        }
        if got < n {
            return Err(RawFramesError::Truncated {
                frames: self.index,
                width: self.width,
                height: self.height,
                got,
                expected: n,
            });
        }
        let stamp = FrameStamp {
            index: self.index,
            ..FrameStamp::default()
        };
        self.index += 1;
        Ok(Some(FrameHeader {
            width: self.width,
            height: self.height,
            stamp,
        }))
    }
}
