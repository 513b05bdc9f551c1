//! Frame sources for the tests of the source-to-result path.

use crate::{FrameHeader, FrameSource, FrameStamp, Optics};
use thiserror::Error;

/// Frames of a dark ring whose column moves by one pixel a frame; fails reading frame
/// `fail_at` (if any) and counts the reads it was asked for.
pub(crate) struct Moving {
    next: u64,
    count: u64,
    fail_at: Option<u64>,
    pub(crate) asked: u64,
}

/// A camera fault at a frame.
#[derive(Debug, Error)]
#[error("camera fault at frame {0}")]
pub(crate) struct Fault(pub(crate) u64);

impl FrameSource for Moving {
    type Error = Fault;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Fault> {
        self.asked += 1;
        if Some(self.next) == self.fail_at {
            return Err(Fault(self.next));
        }
        if self.next == self.count {
            return Ok(None);
        }
        let c = 20 + (self.next % 50) as usize;
        pixels.clear();
        for _ in 0..48 {
            pixels.extend((0..96usize).map(|x| if x.abs_diff(c) <= 5 { 60 } else { 200 }));
        }
        let stamp = FrameStamp {
            index: self.next,
            ..FrameStamp::default()
        };
        self.next += 1;
        Ok(Some(FrameHeader {
            width: 96,
            height: 48,
            stamp,
        }))
    }
}

/// A 96 × 48 window.
pub(crate) fn optics() -> Optics {
    Optics {
        window_width_px: 96,
        window_height_px: 48,
        ..Optics::default()
    }
}

/// `count` frames, failing at `fail_at`.
pub(crate) fn source(count: u64, fail_at: Option<u64>) -> Moving {
    Moving {
        next: 0,
        count,
        fail_at,
        asked: 0,
    }
}
