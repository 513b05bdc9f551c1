//! [`SourceDetector`]: the one path from a source to the detector's results (each frame's
//! window cut out by [`Optics::crop_window`], then [`Detector::detect`]), one frame at a time;
//! [`detect_in_order`](crate::detect_in_order) runs the same path on several threads for a
//! recorded stream and hands the results on in the stream's order.
//!
//! ```
//! use gonio_vision::{Optics, RawFrames, SourceDetector};
//! let optics = Optics { window_width_px: 96, window_height_px: 48, ..Optics::default() };
//! // Two frames of a dark 11 px ring at column 30, as a camera would stream them.
//! let mut frame = vec![200u8; 96 * 48];
//! for row in frame.chunks_mut(96) {
//!     for x in 25..=35 { row[x] = 60; }
//! }
//! let bytes = [frame.clone(), frame].concat();
//! let mut src = SourceDetector::new(RawFrames::new(&bytes[..], 96, 48), &optics).unwrap();
//! let first = src.detect_next().unwrap().unwrap();
//! assert_eq!(first.stamp.index, 0);
//! assert!((first.result.c_px.unwrap() - 30.0).abs() < 0.05);
//! assert!(src.detect_next().unwrap().is_some());
//! assert!(src.detect_next().unwrap().is_none()); // end of the stream
//! ```

use crate::pipeline::LowerHalf;
use crate::track::Tracker;
use crate::{Detector, FrameHeader, FrameResult, FrameSource, FrameStamp, Optics, VisionError};
use thiserror::Error;

/// An error on the path from a source to a result: the source's, or the frame's (exactly these
/// two, so callers can take each apart).
#[derive(Debug, Error)]
pub enum SourceError<E: std::error::Error + 'static> {
    /// The source could not deliver a frame.
    #[error(transparent)]
    Source(E),
    /// A frame could not be detected on (wrong size).
    #[error("frame {index}: {error}")]
    Frame {
        /// 0-based index of the frame.
        index: u64,
        /// Why.
        error: VisionError,
    },
}

/// One frame's stamp and the detector's result for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// The frame's stamp, from its source.
    pub stamp: FrameStamp,
    /// The detector's result.
    pub result: FrameResult,
}

/// A source, the optics' window cut and the detector: every frame of the source, detected.
/// Buffers are allocated once and reused.
#[derive(Debug)]
pub struct SourceDetector<S> {
    source: S,
    optics: Optics,
    detector: Detector,
    raw: Vec<u8>,
    scratch: Vec<u8>,
    /// The second thread's share of each frame, when frames are split ([`Detector::detect_split`]).
    lower: Option<LowerHalf>,
    /// The tracked detector's state, when frames are tracked ([`SourceDetector::track_frames`]).
    tracker: Option<Tracker>,
    /// Where the window of the frame last detected is: `Some(true)` cut into `scratch`,
    /// `Some(false)` the whole of `raw`, `None` no frame detected since the last read.
    window_in_scratch: Option<bool>,
}

impl<S: FrameSource> SourceDetector<S> {
    /// A detector for the optics over `source`.
    ///
    /// # Errors
    /// [`VisionError::Optics`] if the optics are invalid.
    pub fn new(source: S, optics: &Optics) -> Result<Self, VisionError> {
        let detector = Detector::new(optics)?;
        let n = detector.params().width * detector.params().height;
        Ok(SourceDetector {
            source,
            optics: optics.clone(),
            detector,
            raw: Vec::with_capacity(n),
            scratch: Vec::with_capacity(n),
            lower: None,
            tracker: None,
            window_in_scratch: None,
        })
    }

    /// Measures each frame in a band of columns around the ring's predicted column when the
    /// band can vouch for it, else whole ([`Tracker`]: for frames that come in order, as from a
    /// camera), or, `false` (the default), every frame whole.
    pub fn track_frames(&mut self, on: bool) {
        self.tracker = on.then(|| Tracker::from_params(self.detector.params().clone()));
    }

    /// Forgets the ring being tracked (when frames are tracked): the next frame is measured
    /// whole, as the first. For a new sequence of frames (a station's next turn), or after a
    /// frame the caller discards, so that what follows depends on the frames kept only (what
    /// a replay of them reproduces).
    pub fn restart_tracking(&mut self) {
        if let Some(t) = self.tracker.as_mut() {
            t.reset();
        }
    }

    /// The tracked detector's state and counts, when frames are tracked.
    pub fn tracker(&self) -> Option<&Tracker> {
        self.tracker.as_ref()
    }

    /// Detects each frame on two threads ([`Detector::detect_split`]: the same results, in
    /// about three quarters of the time when the second thread wakes at once) or, `false`
    /// (the default), on the calling thread alone.
    pub fn split_frames(&mut self, on: bool) {
        self.lower = on.then(|| self.detector.lower_half());
    }

    /// Whether frames are detected on two threads ([`SourceDetector::split_frames`] on and
    /// the window tall enough: [`Detector::seam_row`]).
    pub fn splits_frames(&self) -> bool {
        self.lower.is_some() && self.detector.seam_row().is_some()
    }

    /// Reads, crops and detects the next frame; `Ok(None)` after the last.
    ///
    /// # Errors
    /// [`SourceError::Source`] from the source, [`SourceError::Frame`] for a frame that is
    /// neither the window nor the sensor in size.
    pub fn detect_next(&mut self) -> Result<Option<Detection>, SourceError<S::Error>> {
        match self.read_next()? {
            Some(hdr) => self.detect_read(&hdr).map(Some),
            None => Ok(None),
        }
    }

    /// The first half of [`SourceDetector::detect_next`]: reads the next frame into the
    /// detector's buffer and returns its header (`Ok(None)` after the last), so that a caller
    /// can time the detection alone.
    ///
    /// # Errors
    /// [`SourceError::Source`] from the source.
    pub fn read_next(&mut self) -> Result<Option<FrameHeader>, SourceError<S::Error>> {
        self.window_in_scratch = None;
        self.source
            .next_frame(&mut self.raw)
            .map_err(SourceError::Source)
    }

    /// The second half of [`SourceDetector::detect_next`]: crops and detects the frame last
    /// read by [`SourceDetector::read_next`] (`hdr` is what it returned).
    ///
    /// # Errors
    /// [`SourceError::Frame`] for a frame that is neither the window nor the sensor in size.
    pub fn detect_read(&mut self, hdr: &FrameHeader) -> Result<Detection, SourceError<S::Error>> {
        let result = detect_frame(
            &self.optics,
            &mut self.detector,
            self.lower.as_mut(),
            self.tracker.as_mut(),
            hdr,
            &self.raw,
            &mut self.scratch,
        )?;
        let window = (
            self.optics.window_width_px as usize,
            self.optics.window_height_px as usize,
        );
        self.window_in_scratch = Some((hdr.width, hdr.height) != window);
        Ok(Detection {
            stamp: hdr.stamp,
            result,
        })
    }

    /// The window of the frame last detected, as the detector saw it: 8-bit grey pixels,
    /// row-major, the optics' window in size (`window_width_px` × `window_height_px`), borrowed
    /// from the detector's buffers (no copy). `None` before the first detection, after a read
    /// that was not detected, or after a frame that could not be.
    pub fn window(&self) -> Option<&[u8]> {
        match self.window_in_scratch? {
            true => Some(&self.scratch),
            false => Some(&self.raw),
        }
    }

    /// The detector (parameters, stage dumps of the last frame).
    pub fn detector(&self) -> &Detector {
        &self.detector
    }

    /// The detector, to switch stage dumps on or off.
    pub fn detector_mut(&mut self) -> &mut Detector {
        &mut self.detector
    }

    /// The source.
    pub fn source(&self) -> &S {
        &self.source
    }

    /// The source, mutably.
    pub fn source_mut(&mut self) -> &mut S {
        &mut self.source
    }

    /// The optics.
    pub fn optics(&self) -> &Optics {
        &self.optics
    }
}

/// One frame through the path: its window cut out, then detected.
pub(crate) fn detect_frame<E: std::error::Error + 'static>(
    optics: &Optics,
    detector: &mut Detector,
    lower: Option<&mut LowerHalf>,
    tracker: Option<&mut Tracker>,
    hdr: &FrameHeader,
    raw: &[u8],
    scratch: &mut Vec<u8>,
) -> Result<FrameResult, SourceError<E>> {
    let index = hdr.stamp.index;
    let frame = optics
        .crop_window(hdr.width, hdr.height, raw, scratch)
        .map_err(|error| SourceError::Frame { index, error })?;
    match (tracker, lower) {
        (Some(tracker), lower) => tracker.detect(frame, index, detector, lower),
        (None, Some(lower)) => detector.detect_split(frame, lower),
        (None, None) => detector.detect(frame),
    }
    .map_err(|error| SourceError::Frame { index, error })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_frames::{Fault, optics, source};

    /// One frame of `w` × `h` pixels numbered by their position, then the end.
    struct Once(Option<(usize, usize)>);

    impl FrameSource for Once {
        type Error = Fault;
        fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Fault> {
            let Some((w, h)) = self.0.take() else {
                return Ok(None);
            };
            pixels.clear();
            pixels.extend((0..w * h).map(|i| (i % 251) as u8));
            Ok(Some(FrameHeader {
                width: w,
                height: h,
                stamp: FrameStamp::default(),
            }))
        }
    }

    #[test]
    fn the_window_is_the_last_detected_frame_as_the_detector_saw_it() {
        // A frame the window's size: the window is the frame.
        let mut det = SourceDetector::new(source(2, None), &optics()).unwrap();
        assert!(det.window().is_none());
        det.detect_next().unwrap().unwrap();
        let w = det.window().expect("a window").to_vec();
        assert_eq!(w.len(), 96 * 48);
        // Frame 0: the ring's 11 dark columns around column 20.
        assert_eq!(
            w[14..27],
            [200, 60, 60, 60, 60, 60, 60, 60, 60, 60, 60, 60, 200]
        );
        det.read_next().unwrap().unwrap();
        assert!(det.window().is_none(), "read, not detected");
        // A sensor-sized frame: the window cut out of its middle.
        let o = Optics {
            sensor_width_px: 100,
            sensor_height_px: 52,
            ..optics()
        };
        let mut det = SourceDetector::new(Once(Some((100, 52))), &o).unwrap();
        det.detect_next().unwrap().unwrap();
        let w = det.window().expect("a window");
        assert_eq!(w.len(), 96 * 48);
        assert_eq!(w[0], 202, "row 2, column 2 of the sensor");
        assert!(det.detect_next().unwrap().is_none());
        assert!(det.window().is_none());
    }
}
